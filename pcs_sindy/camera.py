"""The mapping between the robot's base frame (metres) and image pixels.

Conventions (DESIGN.md §3): the robot's base sits near the top of the image
and, with the default ``angle = 0``, image-down is +y of the base frame and
image-right is +x.  Pixel coordinates ``(u, v)`` are OpenCV's: ``u`` the
column, ``v`` the row, and integer values are pixel *centres*.

A pose ``[x, y, theta]`` maps to ``[u, v, phi]`` with

    [u, v] = origin + pixels_per_metre * R(angle) @ [x, y]
    phi    = theta + angle

where ``phi`` is measured in image coordinates with the same formula as
``theta`` in the base frame (the marker's long axis is ``[cos phi, sin phi]``
in ``(u, v)``).  Because ``(x, y) -> (u, v)`` is a rotation and a scaling, it
keeps the handedness of the base frame: a counter-clockwise ``theta`` in the
base frame appears clockwise on a screen (rows grow downwards).

Ground floor: imports nothing of the package besides numpy.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Camera", "camera_json_path", "read_camera_json"]

_JSON_KIND = "pcs_sindy.camera"


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


@dataclass(frozen=True)
class Camera:
    """Pinhole-free planar camera: base-frame metres <-> pixels.

    Parameters
    ----------
    pixels_per_metre : float
        Scale, strictly positive.
    origin : tuple of float
        Pixel position ``(u, v)`` of the base frame's origin (the base marker's centre).
    image_size : tuple of int
        ``(width, height)`` in pixels.
    angle : float
        Rotation (radians) of the base frame with respect to the image axes;
        0 means +y of the robot points down the image.
    """

    pixels_per_metre: float = 1350.0
    origin: tuple[float, float] = (320.0, 100.0)
    image_size: tuple[int, int] = (640, 480)
    angle: float = 0.0

    def __post_init__(self) -> None:
        ppm = float(self.pixels_per_metre) if np.isscalar(self.pixels_per_metre) else np.nan
        if not np.isfinite(ppm) or ppm <= 0:
            raise ValueError(f"pixels_per_metre must be a finite number > 0; got {self.pixels_per_metre!r}")
        object.__setattr__(self, "pixels_per_metre", ppm)
        object.__setattr__(self, "origin", _finite_pair(self.origin, "origin"))
        size = np.asarray(self.image_size)
        if size.shape != (2,) or not np.all(np.isfinite(size.astype(float))) or np.any(size < 1) or np.any(size != np.round(size)):
            raise ValueError(f"image_size must be two positive integers (width, height); got {self.image_size!r}")
        object.__setattr__(self, "image_size", (int(size[0]), int(size[1])))
        ang = float(self.angle) if np.isscalar(self.angle) else np.nan
        if not np.isfinite(ang):
            raise ValueError(f"angle must be a finite number (radians); got {self.angle!r}")
        object.__setattr__(self, "angle", ang)

    # -- construction ------------------------------------------------------
    @classmethod
    def fit_robot(cls, robot_length: float, image_size: tuple[int, int] = (640, 480), *, stretch: float = 1.3) -> "Camera":
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
    def fit_poses(cls, poses: ArrayLike, image_size: tuple[int, int] = (640, 480)) -> "Camera":
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

    # -- mapping ----------------------------------------------------------
    def _rotation(self) -> NDArray[np.float64]:
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([[c, -s], [s, c]])

    @staticmethod
    def _check_points(points: ArrayLike, name: str) -> NDArray[np.float64]:
        arr = np.asarray(points, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] not in (2, 3):
            raise ValueError(f"{name} must have a last axis of length 2 (positions) or 3 (poses); got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
        return arr

    def to_pixels(self, points: ArrayLike) -> NDArray[np.float64]:
        """Base-frame ``[..., x, y(, theta)]`` in metres -> ``[..., u, v(, phi)]`` in pixels."""
        arr = self._check_points(points, "points")
        out = np.empty_like(arr)
        out[..., :2] = self.pixels_per_metre * arr[..., :2] @ self._rotation().T + np.asarray(self.origin)
        if arr.shape[-1] == 3:
            out[..., 2] = arr[..., 2] + self.angle
        return out

    def to_metres(self, pixels: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`to_pixels`."""
        arr = self._check_points(pixels, "pixels")
        out = np.empty_like(arr)
        out[..., :2] = ((arr[..., :2] - np.asarray(self.origin)) / self.pixels_per_metre) @ self._rotation()
        if arr.shape[-1] == 3:
            out[..., 2] = arr[..., 2] - self.angle
        return out

    # -- JSON ---------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": _JSON_KIND,
            "pixels_per_metre": self.pixels_per_metre,
            "origin": list(self.origin),
            "image_size": list(self.image_size),
            "angle": self.angle,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Camera":
        missing = [k for k in ("pixels_per_metre", "origin", "image_size") if k not in data]
        if missing:
            raise ValueError(f"camera description lacks {missing}; got keys {sorted(data)}")
        return cls(data["pixels_per_metre"], tuple(data["origin"]), tuple(data["image_size"]), data.get("angle", 0.0))

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
            path.write_text(json.dumps(data, indent=2) + "\n")
        except OSError as err:
            raise OSError(f"cannot write camera JSON to path={str(path)!r}: {err}") from err
        return path

    @classmethod
    def from_json(cls, path: str | os.PathLike) -> "Camera":
        """Read a camera written by :meth:`to_json`."""
        return cls.from_dict(read_camera_json(path))


def read_camera_json(path: str | os.PathLike) -> dict[str, Any]:
    """The raw dictionary of a camera JSON file (camera keys plus extras such as ``fps``)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as err:
        raise OSError(f"cannot read camera JSON path={str(path)!r}: {err}") from err
    except json.JSONDecodeError as err:
        raise ValueError(f"camera JSON path={str(path)!r} is not valid JSON: {err}") from err
    if not isinstance(data, dict):
        raise ValueError(f"camera JSON path={str(path)!r} must hold an object; got {type(data).__name__}")
    return data
