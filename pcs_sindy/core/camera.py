"""The mapping between the robot's base frame (metres) and image pixels.

Conventions (docs/method.md): the robot's base sits near the top of the image
and, with the default ``angle = 0``, image-down is +y of the base frame and
image-right is +x.  Pixel coordinates ``(u, v)`` are OpenCV's: ``u`` the
column, ``v`` the row, and integer values are pixel *centres*.

Two stages map a base-frame pose ``[x, y, theta]`` to the recorded image:

1. a similarity to *rectified* pixels,

       [u_r, v_r] = origin + pixels_per_metre * R(angle) @ [x, y]
       phi_r      = theta + angle

   where ``phi`` is measured in image coordinates with the same formula as
   ``theta`` in the base frame (the marker's long axis is
   ``[cos phi, sin phi]`` in ``(u, v)``).  Because this is a rotation and a
   scaling, a counter-clockwise ``theta`` appears clockwise on a screen;
2. an optional lens: rectified pixels -> ideal pinhole pixels through the
   inverse of the ``rectification`` homography (the robot's plane seen in
   perspective), then OpenCV's lens distortion (``camera_matrix``,
   ``dist_coeffs``) to the recorded pixels.

Without a lens, rectified pixels are the recorded pixels.  With one, points
(marker centres, and marker axes carried as pairs of nearby points) are
undistorted and rectified; whole frames never are, which keeps extraction
fast.  A camera may leave its base frame open (``origin`` and/or ``angle``
None, as :func:`pcs_sindy.vision.calibration.calibrate_camera` writes it): the
extractor then finds the base marker and the rest direction in the footage.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import atomic
from .optional import require

cv2 = require("cv2", "pcs_sindy.core.camera (the camera model)")

__all__ = ["Camera", "FPS_RANGE", "camera_extras", "camera_json_path", "read_camera_json"]

_JSON_KIND = "pcs_sindy.core.camera"
# OpenCV's default of 5 iterations leaves a few hundredths of a pixel in the
# corners of a wide-angle lens; iterate to convergence instead
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
_AXIS_STEP = 0.5  # pixels: half-length of the segment that carries an angle through the lens


def undistort_points(
    points: NDArray[np.float64], K: NDArray[np.float64], dist: NDArray[np.float64] | None, R: Any, P: Any
) -> NDArray[np.float64]:
    """``cv2.undistortPoints`` iterated to convergence.

    OpenCV 4 takes the termination criteria through ``undistortPointsIter``;
    OpenCV 5 dropped that name and takes them as ``undistortPoints``'s last argument.

    Parameters
    ----------
    points : ndarray, shape (n, 1, 2)
        Distorted pixel coordinates.
    K, dist : ndarray
        Camera matrix (3, 3) and distortion coefficients (or None).
    R, P : ndarray (3, 3) or None
        Rectification and new camera matrix, as in OpenCV.

    Returns
    -------
    ndarray, shape (n, 1, 2)
    """
    iterate = getattr(cv2, "undistortPointsIter", None)
    if iterate is not None:
        return iterate(points, K, dist, R, P, _UNDISTORT_CRITERIA)
    return cv2.undistortPoints(points, K, dist, None, R, P, _UNDISTORT_CRITERIA)


def camera_json_path(recording: str | os.PathLike) -> Path:
    """Where the camera JSON of a recording lives.

    ``<video>.camera.json`` next to a video file (``clip.mp4`` ->
    ``clip.mp4.camera.json``) and ``camera.json`` inside a folder of frames.
    """
    path = Path(recording)
    if path.is_dir():
        return path / "camera.json"
    return path.with_name(path.name + ".camera.json")


def _finite_pair(value: Any, name: str, *, positive: bool = False) -> tuple[float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be two finite numbers; got {value!r}")
    if positive and np.any(arr <= 0):
        raise ValueError(f"{name} must be positive; got {value!r}")
    return float(arr[0]), float(arr[1])


def _matrix(value: Any, name: str, shape: tuple[int, int] | None = None) -> tuple | None:
    """A finite matrix (or vector when ``shape`` is None) as nested tuples; None stays None."""
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}; got {arr.shape}")
    if shape is None and (arr.ndim != 1 or arr.size not in (4, 5, 8, 12, 14)):
        raise ValueError(
            f"{name} must hold 4, 5, 8, 12 or 14 coefficients (OpenCV's lens model); got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return tuple(tuple(float(v) for v in row) for row in arr) if arr.ndim == 2 else tuple(float(v) for v in arr)


def _plane_similarity(
    H: NDArray[np.float64], point: NDArray[np.float64]
) -> tuple[float, float, float, NDArray[np.float64]]:
    """Scale, rotation, handedness (+1/-1) and image point of a homography's local similarity at ``point``."""
    w = H[2, :2] @ point + H[2, 2]
    img = (H[:2, :2] @ point + H[:2, 2]) / w
    J = (H[:2, :2] - np.outer(img, H[2, :2])) / w  # d(image)/d(plane) at the point
    det = float(np.linalg.det(J))
    if not np.isfinite(det) or abs(det) < 1e-12 * max(float(np.abs(J).max()), 1e-300) ** 2:
        raise ValueError(f"the homography is singular at plane point {point.tolist()}")
    return float(np.sqrt(abs(det))), float(np.arctan2(J[1, 0], J[0, 0])), float(np.sign(det)), img


@dataclass(frozen=True)
class Camera:
    """Planar camera: base-frame metres <-> pixels, optionally through a lens.

    Parameters
    ----------
    pixels_per_metre : float
        Scale of the rectified image, strictly positive.
    origin : tuple of float or None
        Rectified pixel position ``(u, v)`` of the base frame's origin (the
        base marker's centre); None: to be found in the footage.
    image_size : tuple of int
        ``(width, height)`` of the recorded frames in pixels.
    angle : float or None
        Rotation (radians) of the base frame with respect to the rectified
        image axes; 0 means +y of the robot points down the image.  None: to
        be found in the footage (the rest direction of the reference frame).
    camera_matrix : 3x3, optional
        Pinhole intrinsics (OpenCV's ``K``); with ``dist_coeffs`` the lens.
    dist_coeffs : sequence of 4, 5, 8, 12 or 14 floats, optional
        OpenCV's distortion coefficients ``(k1, k2, p1, p2[, k3, ...])``.
    rectification : 3x3, optional
        Homography from ideal (undistorted) pixels to rectified pixels, in
        which the robot's plane is seen head-on at ``pixels_per_metre``.
    """

    pixels_per_metre: float = 1350.0
    origin: tuple[float, float] | None = (320.0, 100.0)
    image_size: tuple[int, int] = (640, 480)
    angle: float | None = 0.0
    camera_matrix: tuple | None = None
    dist_coeffs: tuple | None = None
    rectification: tuple | None = None

    def __post_init__(self) -> None:
        ppm = float(self.pixels_per_metre) if np.isscalar(self.pixels_per_metre) else np.nan
        if not np.isfinite(ppm) or ppm <= 0:
            raise ValueError(f"pixels_per_metre must be a finite number > 0; got {self.pixels_per_metre!r}")
        object.__setattr__(self, "pixels_per_metre", ppm)
        if self.origin is not None:
            object.__setattr__(self, "origin", _finite_pair(self.origin, "origin"))
        size = np.asarray(self.image_size)
        if (
            size.shape != (2,)
            or not np.all(np.isfinite(size.astype(float)))
            or np.any(size < 1)
            or np.any(size != np.round(size))
        ):
            raise ValueError(f"image_size must be two positive integers (width, height); got {self.image_size!r}")
        object.__setattr__(self, "image_size", (int(size[0]), int(size[1])))
        if self.angle is not None:
            ang = float(self.angle) if np.isscalar(self.angle) else np.nan
            if not np.isfinite(ang):
                raise ValueError(f"angle must be a finite number (radians) or None; got {self.angle!r}")
            object.__setattr__(self, "angle", ang)
        K = _matrix(self.camera_matrix, "camera_matrix", (3, 3))
        if K is not None and (K[0][0] <= 0 or K[1][1] <= 0 or K[2] != (0.0, 0.0, 1.0)):
            raise ValueError(f"camera_matrix must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0; got {K!r}")
        dist = _matrix(self.dist_coeffs, "dist_coeffs")
        if dist is not None and K is None:
            raise ValueError("dist_coeffs needs a camera_matrix")
        rect = _matrix(self.rectification, "rectification", (3, 3))
        if rect is not None and abs(np.linalg.det(np.asarray(rect))) < 1e-300:
            raise ValueError("rectification must be an invertible 3x3 homography")
        object.__setattr__(self, "camera_matrix", K)
        object.__setattr__(self, "dist_coeffs", dist)
        object.__setattr__(self, "rectification", rect)

    # -- construction ------------------------------------------------------
    @classmethod
    def fit_robot(
        cls, robot_length: float, image_size: tuple[int, int] = (640, 480), *, stretch: float = 1.3
    ) -> Camera:
        """A camera whose image holds a robot of ``robot_length`` bending ±180° and beyond.

        The visible box is ``x in [-0.85 L', 0.85 L']``, ``y in [-0.3 L', 1.05 L']``
        with ``L' = stretch * robot_length`` (room for axial stretch and a tip
        curling above the base).
        """
        if not np.isscalar(robot_length) or not np.isfinite(robot_length) or robot_length <= 0:
            raise ValueError(f"robot_length must be a finite number > 0; got {robot_length!r}")
        if not np.isfinite(stretch) or stretch < 1:
            raise ValueError(f"stretch must be >= 1; got {stretch!r}")
        w, h = _finite_pair(image_size, "image_size", positive=True)
        L = stretch * float(robot_length)
        ppm = min(w / (1.7 * L), h / (1.35 * L))
        return cls(ppm, (0.5 * (w - 1), 0.3 * L * ppm), (int(w), int(h)))

    @classmethod
    def fit_poses(cls, poses: ArrayLike, image_size: tuple[int, int] = (640, 480)) -> Camera:
        """:meth:`fit_robot` for the robot whose marker poses (T, N + 1, 3) are given.

        The robot's length is the median over frames of the length of the
        polyline through the marker centres.
        """
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 2:
            arr = arr[None]
        if arr.ndim != 3 or arr.shape[-1] != 3 or arr.shape[1] < 2 or not np.all(np.isfinite(arr)):
            raise ValueError(f"poses must be finite with shape (T, N + 1, 3), N >= 1; got shape {np.shape(poses)}")
        length = float(np.median(np.linalg.norm(np.diff(arr[..., :2], axis=1), axis=-1).sum(axis=1)))
        if length <= 0:
            raise ValueError("poses: all markers coincide, the robot has no length")
        return cls.fit_robot(length, image_size)

    @classmethod
    def from_plane(
        cls,
        homography: ArrayLike,
        image_size: tuple[int, int],
        camera_matrix: ArrayLike | None = None,
        dist_coeffs: ArrayLike | None = None,
        *,
        base_frame: bool = True,
    ) -> Camera:
        """A camera from the homography of the robot's plane (metres) to ideal pixels.

        Parameters
        ----------
        homography : 3x3
            Plane coordinates ``[x, y, 1]`` (metres) -> undistorted pixels.
        image_size : (width, height)
        camera_matrix, dist_coeffs : optional
            The lens (``cv2.calibrateCamera``); without them the homography
            maps straight to the recorded pixels.
        base_frame : bool
            True: the plane's coordinates are the robot's base frame (origin
            and angle are set).  False: they are another frame in the same
            plane (a checkerboard's); origin and angle are left to the footage.

        Notes
        -----
        The rectified image is the plane seen head-on at the homography's
        local scale at the plane's origin, placed and turned so that it
        matches the ideal image there; rectified and recorded pixels then
        agree closely near the robot.
        """
        H = np.asarray(homography, dtype=float)
        if H.shape != (3, 3) or not np.all(np.isfinite(H)):
            raise ValueError(f"homography must be a finite 3x3 matrix; got shape {H.shape}")
        scale, rot, hand, img = _plane_similarity(H, np.zeros(2))
        if base_frame and hand < 0:
            raise ValueError(
                "homography: the base frame appears mirrored in the image (x cross y points at the camera)"
            )
        c, s = np.cos(rot), np.sin(rot)
        S = np.array([[scale * c, -scale * s * hand, img[0]], [scale * s, scale * c * hand, img[1]], [0.0, 0.0, 1.0]])
        rect = S @ np.linalg.inv(H)
        rect /= rect[2, 2]
        if base_frame:
            return cls(scale, (float(img[0]), float(img[1])), image_size, rot, camera_matrix, dist_coeffs, rect)
        return cls(scale, None, image_size, None, camera_matrix, dist_coeffs, rect)

    @classmethod
    def from_pinhole(
        cls,
        camera_matrix: ArrayLike,
        dist_coeffs: ArrayLike | None,
        rvec: ArrayLike,
        tvec: ArrayLike,
        image_size: tuple[int, int],
    ) -> Camera:
        """A camera seeing the robot's base frame (plane ``z = 0``) at pose ``rvec, tvec``.

        ``rvec`` (Rodrigues) and ``tvec`` (metres) place the base frame in the
        camera's coordinates, as ``cv2.solvePnP`` returns them; a camera
        looking straight at the robot has ``rvec = 0`` and ``tvec = [tx, ty, distance]``.
        """
        K = np.asarray(camera_matrix, dtype=float)
        R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=float).reshape(3, 1))
        t = np.asarray(tvec, dtype=float).reshape(3)
        if t[2] <= 0:
            raise ValueError(f"tvec must put the robot in front of the camera (z > 0); got {t.tolist()}")
        H = K @ np.column_stack([R[:, 0], R[:, 1], t])
        return cls.from_plane(H, image_size, K, dist_coeffs, base_frame=True)

    def with_base(self, origin: tuple[float, float], angle: float) -> Camera:
        """This camera with its base frame set: ``origin`` in rectified pixels, ``angle`` in radians."""
        return replace(self, origin=tuple(origin), angle=float(angle))

    # -- properties --------------------------------------------------------
    @property
    def has_lens(self) -> bool:
        """True when points go through a lens model or a plane homography."""
        return self.camera_matrix is not None or self.rectification is not None

    @property
    def has_base_frame(self) -> bool:
        """True when ``origin`` and ``angle`` are both known."""
        return self.origin is not None and self.angle is not None

    def _need_base_frame(self) -> None:
        if not self.has_base_frame:
            raise ValueError(
                "this camera leaves the base frame open (origin or angle is None); use it through "
                "MarkerPoseExtractor, which finds the base in the footage, or set it with "
                "camera.with_base(origin, angle)"
            )

    # -- the lens ------------------------------------------------------------
    def _raw_to_rect_points(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        flat = np.ascontiguousarray(pts.reshape(-1, 1, 2))
        H = np.eye(3) if self.rectification is None else np.asarray(self.rectification)
        if self.camera_matrix is None:
            out = cv2.perspectiveTransform(flat, H)
        else:
            K = np.asarray(self.camera_matrix)
            dist = None if self.dist_coeffs is None else np.asarray(self.dist_coeffs)
            # R = H K maps normalised camera coordinates straight to rectified pixels
            out = undistort_points(flat, K, dist, H @ K, None)
        return out.reshape(pts.shape)

    def _rect_to_raw_points(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        flat = np.ascontiguousarray(pts.reshape(-1, 1, 2))
        Hinv = np.eye(3) if self.rectification is None else np.linalg.inv(np.asarray(self.rectification))
        if self.camera_matrix is None:
            return cv2.perspectiveTransform(flat, Hinv).reshape(pts.shape)
        K = np.asarray(self.camera_matrix)
        rays = cv2.convertPointsToHomogeneous(flat).reshape(-1, 3) @ (np.linalg.inv(K) @ Hinv).T
        if np.any(rays[:, 2] <= 0):
            raise ValueError("points lie behind the camera (beyond the horizon of the robot's plane)")
        dist = np.zeros(5) if self.dist_coeffs is None else np.asarray(self.dist_coeffs)
        out, _ = cv2.projectPoints(rays / rays[:, 2:], np.zeros(3), np.zeros(3), K, dist)
        return out.reshape(pts.shape)

    def _map(self, arr: NDArray[np.float64], forward: bool) -> NDArray[np.float64]:
        """Points ``(..., 2)`` or poses ``(..., 3)`` through the lens (raw -> rectified if ``forward``)."""
        if not self.has_lens:
            return arr.copy()
        fn = self._raw_to_rect_points if forward else self._rect_to_raw_points
        if arr.shape[-1] == 2:
            return fn(arr)
        # an angle travels as a short segment along the axis, centred on the point
        d = _AXIS_STEP * np.stack([np.cos(arr[..., 2]), np.sin(arr[..., 2])], axis=-1)
        c = arr[..., :2]
        mapped = fn(np.stack([c, c - d, c + d], axis=-2))
        out = np.empty_like(arr)
        out[..., :2] = mapped[..., 0, :]
        axis = mapped[..., 2, :] - mapped[..., 1, :]
        ang = np.arctan2(axis[..., 1], axis[..., 0])
        # keep the input's branch of the angle (the lens turns axes by far less than pi)
        out[..., 2] = arr[..., 2] + (ang - arr[..., 2] + np.pi) % (2 * np.pi) - np.pi
        return out

    def rectify(self, pixels: ArrayLike) -> NDArray[np.float64]:
        """Recorded ``[..., u, v(, phi)]`` -> rectified pixels (undistorted, plane seen head-on)."""
        return self._map(self._check_points(pixels, "pixels"), True)

    def unrectify(self, pixels: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`rectify`: rectified ``[..., u, v(, phi)]`` -> recorded pixels."""
        return self._map(self._check_points(pixels, "pixels"), False)

    # -- mapping ----------------------------------------------------------
    def _rotation(self) -> NDArray[np.float64]:
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([[c, -s], [s, c]])

    @staticmethod
    def _check_points(points: ArrayLike, name: str) -> NDArray[np.float64]:
        arr = np.asarray(points, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] not in (2, 3):
            raise ValueError(
                f"{name} must have a last axis of length 2 (positions) or 3 (poses); got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
        return arr

    def to_rectified(self, points: ArrayLike) -> NDArray[np.float64]:
        """Base-frame ``[..., x, y(, theta)]`` in metres -> rectified ``[..., u, v(, phi)]``."""
        arr = self._check_points(points, "points")
        self._need_base_frame()
        out = np.empty_like(arr)
        out[..., :2] = self.pixels_per_metre * arr[..., :2] @ self._rotation().T + np.asarray(self.origin)
        if arr.shape[-1] == 3:
            out[..., 2] = arr[..., 2] + self.angle
        return out

    def from_rectified(self, pixels: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`to_rectified`."""
        arr = self._check_points(pixels, "pixels")
        self._need_base_frame()
        out = np.empty_like(arr)
        out[..., :2] = ((arr[..., :2] - np.asarray(self.origin)) / self.pixels_per_metre) @ self._rotation()
        if arr.shape[-1] == 3:
            out[..., 2] = arr[..., 2] - self.angle
        return out

    def to_pixels(self, points: ArrayLike) -> NDArray[np.float64]:
        """Base-frame ``[..., x, y(, theta)]`` in metres -> recorded ``[..., u, v(, phi)]`` in pixels."""
        return self._map(self.to_rectified(points), False)

    def to_metres(self, pixels: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`to_pixels`."""
        return self.from_rectified(self.rectify(pixels))

    # -- JSON ---------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {
            "kind": _JSON_KIND,
            "pixels_per_metre": self.pixels_per_metre,
            "origin": None if self.origin is None else list(self.origin),
            "image_size": list(self.image_size),
            "angle": self.angle,
        }
        for key in ("camera_matrix", "dist_coeffs", "rectification"):
            value = getattr(self, key)
            if value is not None:
                data[key] = np.asarray(value).tolist()
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], image_size: tuple[int, int] | None = None) -> Camera:
        """The camera a dict describes (:meth:`to_dict`; extras such as ``fps`` are ignored).

        A hand-written camera JSON may leave out what the footage tells: ``image_size`` (width,
        height) is then the ``image_size`` given here (a description that has one keeps its own), and
        without ``origin`` the base frame (origin and, unless given, ``angle``) is found in the footage
        by the extractor, as for a camera from ``pcs-sindy calibrate``.  With an ``origin``, a missing
        ``angle`` is 0.
        """
        missing = [k for k in ("pixels_per_metre", "image_size") if k not in data]
        if image_size is not None and "image_size" in missing:
            missing.remove("image_size")
        if missing:
            raise ValueError(f"camera description lacks {missing}; got keys {sorted(data)}")
        origin = data.get("origin")
        return cls(
            data["pixels_per_metre"],
            None if origin is None else tuple(origin),
            tuple(data["image_size"] if "image_size" in data else image_size),  # type: ignore[arg-type]
            data.get("angle", 0.0 if "origin" in data else None),
            data.get("camera_matrix"),
            data.get("dist_coeffs"),
            data.get("rectification"),
        )

    def to_json(self, path: str | os.PathLike, extra: Mapping[str, Any] | None = None) -> Path:
        """Write the camera (plus ``extra`` keys such as ``fps``) as a small JSON file."""
        data = self.to_dict()
        if extra:
            clash = set(extra) & set(data)
            if clash:
                raise ValueError(f"extra must not override camera keys; got {sorted(clash)}")
            data.update(extra)
        path = Path(path)
        try:
            atomic.write_text(path, json.dumps(data, indent=2) + "\n")
        except OSError as err:
            raise OSError(f"cannot write camera JSON to path={str(path)!r}: {err}") from err
        return path

    @classmethod
    def from_json(cls, path: str | os.PathLike, image_size: tuple[int, int] | None = None) -> Camera:
        """Read a camera written by :meth:`to_json` (``image_size`` as in :meth:`from_dict`)."""
        data = read_camera_json(path)
        try:
            return cls.from_dict(data, image_size)
        except ValueError as err:
            raise ValueError(f"camera JSON path={str(path)!r}: {err}") from None


#: frame rates a camera JSON may state (frames per second): an hour per frame to a nanosecond per frame
FPS_RANGE = (1.0 / 3600.0, 1e9)


def camera_extras(data: Mapping[str, Any], source: str = "camera description") -> dict[str, Any]:
    """The recording facts a camera description holds besides the camera, checked: ``fps``, ``n_frames``.

    Parameters
    ----------
    data : mapping
        A camera dict or the content of a camera JSON.
    source : str
        What ``data`` is, for messages (e.g. ``"camera JSON 'clip.avi.camera.json'"``).

    Returns
    -------
    dict
        ``fps`` (float) and ``n_frames`` (int) when present.

    Raises
    ------
    ValueError
        A field that is not a number in its range: the message names ``source``, the field and the value.
    """
    out: dict[str, Any] = {}
    fps = data.get("fps")
    if fps is not None:
        lo, hi = FPS_RANGE
        ok = isinstance(fps, (int, float, np.integer, np.floating)) and not isinstance(fps, bool)
        if not ok or not (math.isfinite(float(fps)) and lo <= float(fps) <= hi):
            raise ValueError(
                f"{source}: field 'fps' must be the frame rate in frames per second, a number from {lo:.3g} to "
                f"{hi:.3g}; got {fps!r}"
            )
        out["fps"] = float(fps)
    n_frames = data.get("n_frames")
    if n_frames is not None:
        if isinstance(n_frames, bool) or not isinstance(n_frames, (int, np.integer)) or n_frames < 1:
            raise ValueError(f"{source}: field 'n_frames' must be a positive integer (frames); got {n_frames!r}")
        out["n_frames"] = int(n_frames)
    return out


def read_camera_json(path: str | os.PathLike) -> dict[str, Any]:
    """The raw dictionary of a camera JSON file (camera keys plus extras such as ``fps``).

    The extras are checked (:func:`camera_extras`): a frame rate of 0, a negative or a non-finite one
    is an error naming the file, the field and the value.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as err:
        raise OSError(f"cannot read camera JSON path={str(path)!r}: {err}") from err
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"camera JSON path={str(path)!r} is not valid JSON: {err}") from err
    if not isinstance(data, dict):
        raise ValueError(f"camera JSON path={str(path)!r} must hold an object; got {type(data).__name__}")
    camera_extras(data, f"camera JSON path={str(path)!r}")
    return data
