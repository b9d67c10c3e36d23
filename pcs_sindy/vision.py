"""Marker poses from videos: :class:`MarkerPoseExtractor` (DESIGN.md §1, step 1).

Per frame: binarise (Otsu by default, a fixed threshold or a colour range),
``findContours`` + ``minAreaRect`` on every component, keep the
marker-shaped ones (area and aspect ratio relative to the typical marker),
refine each centre and axis from the intensity-weighted moments of the
component (sub-pixel), then per recording: find the base marker, order the
markers base -> tip by chaining, resolve the 90°/180° ambiguity of the
rectangle's angle from its long side (across the robot) and the direction to
the neighbours, make theta continuous along the robot and in time, and map
pixels to metres in the robot's base frame (:class:`pcs_sindy.camera.Camera`).

Knows nothing of dynamics; imports only the ground floor.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, Iterator

import cv2
import numpy as np
import scipy.sparse
from joblib import Parallel, delayed
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from tqdm.auto import tqdm

from ._saving import PersistenceMixin
from .camera import Camera, camera_json_path, read_camera_json
from .trajectory import PoseTrajectory

__all__ = ["MarkerPoseExtractor", "detect_markers", "read_frames"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")

# columns of the candidate table returned by detect_markers
U, V, AXIS, AREA, LONG, SHORT, RECT_AXIS = range(7)
N_FEATURES = 7


# --------------------------------------------------------------------------
# Frame sources
# --------------------------------------------------------------------------
def _natural_key(path: Path) -> list[Any]:
    return [int(tok) if tok.isdigit() else tok for tok in re.split(r"(\d+)", path.name)]


def _describe(recording: Any, index: int) -> str:
    if isinstance(recording, (str, os.PathLike)):
        return str(recording)
    return f"array recording {index}"


def _open_source(recording: Any, name: str) -> tuple[int, float | None, Iterator[NDArray[np.uint8]]]:
    """Number of frames, frame rate (None if unknown) and an iterator over frames."""
    if isinstance(recording, (str, os.PathLike)):
        path = Path(recording)
        if not path.exists():
            raise FileNotFoundError(f"recording {name!r}: no such file or folder")
        if path.is_dir():
            files = sorted((p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key)
            if not files:
                raise ValueError(f"recording {name!r}: the folder holds no image files ({', '.join(IMAGE_SUFFIXES)})")

            def images() -> Iterator[NDArray[np.uint8]]:
                for k, f in enumerate(files):
                    img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
                    if img is None:
                        raise OSError(f"recording {name!r}, frame {k}: cannot read image {str(f)!r}")
                    yield img

            return len(files), None, images()
        cap = cv2.VideoCapture(str(path))
        if not cap.isOpened():
            cap.release()
            raise OSError(f"recording {name!r}: OpenCV cannot open it as a video")
        count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        ok, first = cap.read()
        if not ok or first is None:
            cap.release()
            raise OSError(f"recording {name!r}: OpenCV opened it but could not decode frame 0")

        def video() -> Iterator[NDArray[np.uint8]]:
            try:
                yield first
                while True:
                    ok, frame = cap.read()
                    if not ok:
                        break
                    yield frame
            finally:
                cap.release()

        return max(count, 1), (fps if np.isfinite(fps) and fps > 0 else None), video()
    arr = np.asarray(recording)
    if arr.ndim not in (3, 4) or (arr.ndim == 4 and arr.shape[-1] not in (3, 4)) or arr.shape[0] < 1:
        raise ValueError(f"recording {name!r}: an array of frames must have shape (T, H, W) or (T, H, W, 3); got {arr.shape}")
    if arr.dtype != np.uint8:
        raise ValueError(f"recording {name!r}: frames must be uint8 images; got dtype {arr.dtype}")
    return arr.shape[0], None, iter(arr)


def _check_recordings(X: Any, name: str = "X") -> list[Any]:
    """The recordings of ``X`` as a list, checked without reading a frame."""
    if scipy.sparse.issparse(X):
        raise ValueError(f"{name}: sparse input is not supported; give videos (paths, image folders or uint8 frame arrays)")
    if isinstance(X, (str, os.PathLike, np.ndarray)):
        X = [X]
    if not isinstance(X, (list, tuple)) or len(X) == 0:
        raise ValueError(f"{name} must be a non-empty list of recordings; got {type(X).__name__}")
    for k, rec in enumerate(X):
        if isinstance(rec, (str, os.PathLike)):
            continue
        if not isinstance(rec, np.ndarray):
            raise ValueError(
                f"{name}[{k}] must be a video path, an image folder or a uint8 array of frames; got {type(rec).__name__}"
            )
        if rec.ndim not in (3, 4) or (rec.ndim == 4 and rec.shape[-1] not in (3, 4)) or 0 in rec.shape:
            raise ValueError(f"{name}[{k}]: an array of frames must have shape (T, H, W) or (T, H, W, 3); got {rec.shape}")
        if rec.dtype != np.uint8:
            raise ValueError(f"{name}[{k}]: frames must be uint8 images; got dtype {rec.dtype}")
    return list(X)


def read_frames(recording: Any) -> NDArray[np.uint8]:
    """All frames of a recording (video path, image folder or array) as one array."""
    _, _, it = _open_source(recording, _describe(recording, 0))
    return np.stack(list(it))


# --------------------------------------------------------------------------
# Per-frame detection
# --------------------------------------------------------------------------
def _to_grey(frame: NDArray[np.uint8], name: str, k: int) -> NDArray[np.uint8]:
    if frame.ndim == 2:
        return frame
    if frame.ndim == 3 and frame.shape[2] == 3:
        return cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    if frame.ndim == 3 and frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2GRAY)
    raise ValueError(f"recording {name!r}, frame {k}: unsupported image shape {frame.shape}")


def detect_markers(
    frame: NDArray[np.uint8],
    *,
    threshold: str | float | tuple = "otsu",
    polarity: str = "dark",
    blur: int = 0,
    roi: tuple[int, int, int, int] | None = None,
    min_area: float = 4.0,
    refine: bool = True,
    name: str = "frame",
    index: int = 0,
) -> NDArray[np.float64]:
    """Candidate marker components of one image.

    Parameters
    ----------
    frame : ndarray of uint8, (H, W) or (H, W, 3) BGR
    threshold : "otsu", float or (lower, upper)
        Otsu's threshold, a fixed grey level (markers are the pixels at or
        below it, or above it with ``polarity="bright"``), or a colour range
        for ``cv2.inRange`` (each bound a grey level or a BGR triple; edge
        pixels are then weighted by their mix of marker and background colour).
    polarity : {"dark", "bright"}
        Markers darker or brighter than the background (grey thresholds).
    blur : int
        Odd Gaussian kernel size applied before thresholding (0: none); the
        moments are taken on the unblurred image.
    roi : (x, y, width, height), optional
        Only components inside this rectangle are considered.
    min_area : float
        Components smaller than this (pixels) are noise.
    refine : bool
        Refine centre and axis from intensity-weighted moments (sub-pixel);
        otherwise use ``minAreaRect``'s centre and angle.

    Returns
    -------
    ndarray, shape (K, 7)
        Columns ``u, v`` (centre, pixels), ``axis`` (angle of the long side in
        image coordinates, modulo pi), ``area`` (pixels covered), ``long``,
        ``short`` (sides of the ``minAreaRect``, in covered pixels) and ``rect_axis`` (minAreaRect's long-side
        angle, modulo pi).
    """
    is_range = isinstance(threshold, tuple)
    grey = None
    x0 = y0 = 0
    if is_range:
        lo, hi = (np.atleast_1d(np.asarray(b, dtype=float)) for b in threshold)
        img = frame
        if frame.ndim == 3 and (lo.size == 1 or frame.shape[2] != 3):
            img = _to_grey(frame, name, index)
        if roi is not None:
            x0, y0, w, h = roi
            img = img[y0 : y0 + h, x0 : x0 + w]
        binary = cv2.inRange(img, lo if lo.size > 1 else float(lo[0]), hi if hi.size > 1 else float(hi[0]))
        if refine:
            grey = _coverage_image(img, binary)
            fg, bg = 0.0, 255.0
    else:
        grey = _to_grey(frame, name, index)
        if polarity == "bright":
            grey = 255 - grey  # work on dark markers throughout
        if roi is not None:
            x0, y0, w, h = roi
            grey = grey[y0 : y0 + h, x0 : x0 + w]
        src = cv2.GaussianBlur(grey, (blur, blur), 0) if blur else grey
        # one histogram of every other row and column gives Otsu's threshold
        # and the background and marker grey levels (a quarter of the memory
        # traffic of a full-frame pass, with the same threshold in practice)
        hist = _histogram(src)
        if threshold == "otsu":
            level = _otsu(hist)
        else:  # markers are the pixels darker (brighter) than the given level
            level = float(threshold) if polarity == "dark" else 255.0 - float(threshold) - 1e-9
        _, binary = cv2.threshold(src, level, 255, cv2.THRESH_BINARY_INV)
        if refine:
            if src is not grey:
                hist = _histogram(grey)
            g = np.arange(256.0)
            dark = g <= level
            n_dark, n_light = hist[dark].sum(), hist[~dark].sum()
            fg = float(hist[dark] @ g[dark] / n_dark) if n_dark else 0.0
            bg = float(hist[~dark] @ g[~dark] / n_light) if n_light else 255.0
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    out = []
    H, W = binary.shape
    kernel = np.ones((3, 3), np.uint8)
    for c in contours:
        # the contour runs through the centres of the boundary pixels: add
        # half a pixel all round so thin markers get their pixel area and sides
        area = cv2.contourArea(c) + 0.5 * cv2.arcLength(c, True) + 1.0
        if area < min_area:
            continue
        (cu, cv_), (rw, rh), ang = cv2.minAreaRect(c)
        long_, short = (rw + 1.0, rh + 1.0) if rw >= rh else (rh + 1.0, rw + 1.0)
        rect_axis = np.deg2rad(ang if rw >= rh else ang + 90.0) % np.pi
        u, v, axis = cu, cv_, rect_axis
        if refine:
            bx, by, bw, bh = cv2.boundingRect(c)
            xa, ya = max(bx - 2, 0), max(by - 2, 0)
            xb, yb = min(bx + bw + 2, W), min(by + bh + 2, H)
            mask = np.zeros((yb - ya, xb - xa), np.uint8)
            cv2.drawContours(mask, [c], -1, 1, thickness=cv2.FILLED, offset=(-xa, -ya))
            if grey is not None:
                # 1-px ring: anti-aliased edge pixels carry their area coverage,
                # measured against the local background (the brightest pixel
                # nearby) so that a lighter robot body next to a marker counts
                # as background, not as a faint part of the marker
                mask = cv2.dilate(mask, kernel)
                patch = grey[ya:yb, xa:xb].astype(np.float32)
                local = cv2.dilate(patch, kernel)
                local = np.where(local < 0.5 * (bg + fg), bg, local)
                wgt = (local - patch) / np.maximum(local - fg, 1.0)
                wgt = np.clip(wgt, 0.0, 1.0) * mask
            else:
                wgt = (mask * (binary[ya:yb, xa:xb] > 0)).astype(np.float32)
            m = cv2.moments(wgt.astype(np.float32))
            if m["m00"] > 0:
                u, v = xa + m["m10"] / m["m00"], ya + m["m01"] / m["m00"]
                aniso = np.hypot(2 * m["mu11"], m["mu20"] - m["mu02"]) / max(m["mu20"] + m["mu02"], 1e-12)
                if aniso > 0.1:  # moments define an axis only for elongated shapes
                    axis = (0.5 * np.arctan2(2 * m["mu11"], m["mu20"] - m["mu02"])) % np.pi
        out.append([u + x0, v + y0, axis, area, long_, short, rect_axis])
    return np.asarray(out, dtype=float).reshape(-1, N_FEATURES)


def _coverage_image(img: NDArray[np.uint8], binary: NDArray[np.uint8]) -> NDArray[np.uint8] | None:
    """A grey image 255 * (1 - c) where c is each pixel's share of the marker colour.

    Anti-aliased pixels mix the marker and background colours linearly:
    ``pixel = c * marker + (1 - c) * background``; projecting on the colour
    difference recovers ``c``.  The two colours are the mean colours inside
    and outside the colour-range mask.  None when they cannot be told apart.
    """
    step = 2 if min(img.shape[:2]) >= 64 else 1
    sub, bsub = img[::step, ::step], np.ascontiguousarray(binary[::step, ::step])
    n_in = int(np.count_nonzero(bsub))
    if n_in == 0 or n_in == bsub.size:
        return None
    nch = 1 if img.ndim == 2 else img.shape[2]
    fg = np.asarray(cv2.mean(np.ascontiguousarray(sub), mask=bsub)[:nch])
    bg = np.asarray(cv2.mean(np.ascontiguousarray(sub), mask=255 - bsub)[:nch])
    d = fg - bg
    norm = float(d @ d)
    if norm < 1.0:
        return None
    # affine map per pixel, saturated to [0, 255] by OpenCV
    m = np.concatenate([-255.0 * d / norm, [255.0 + 255.0 * float(bg @ d) / norm]])[None, :]
    return cv2.transform(img if img.ndim == 3 else img[..., None], m).reshape(img.shape[:2])


def _histogram(image: NDArray[np.uint8]) -> NDArray[np.float64]:
    sub = np.ascontiguousarray(image[::2, ::2]) if min(image.shape) >= 64 else image
    return cv2.calcHist([sub], [0], None, [256], [0, 256]).ravel().astype(float)


def _otsu(hist: NDArray[np.float64]) -> float:
    """Otsu's threshold of a 256-bin histogram (class 0: levels <= threshold)."""
    total = hist.sum()
    if total == 0:
        return 127.0
    p = hist / total
    omega = np.cumsum(p)
    mu = np.cumsum(p * np.arange(256))
    with np.errstate(divide="ignore", invalid="ignore"):
        between = (mu[-1] * omega - mu) ** 2 / (omega * (1.0 - omega))
    between[~np.isfinite(between)] = -1.0
    return float(np.argmax(between))


def _wrap_half_pi(a: NDArray[np.float64] | float) -> Any:
    """Wrap to [-pi/2, pi/2)."""
    return (np.asarray(a) + 0.5 * np.pi) % np.pi - 0.5 * np.pi


# --------------------------------------------------------------------------
# Per-recording geometry
# --------------------------------------------------------------------------
def _typical_marker(cands: NDArray[np.float64], expected: int | None = None) -> tuple[float, float]:
    """Area and aspect ratio of the markers among the components of one frame.

    The markers are the largest group of components of similar area (within
    a factor 1.4), or, when their number is known, the group whose size is
    nearest to it (so many small specks of noise cannot pose as markers).
    """
    log_a = np.log(cands[:, AREA])
    counts = (np.abs(log_a[:, None] - log_a[None, :]) <= np.log(1.4)).sum(axis=1)
    if expected is None:
        best = log_a[counts == counts.max()]
    else:
        miss = np.abs(counts - expected)
        best = log_a[miss == miss.min()]
        best = best[best >= np.median(best)]  # ties: the larger components
    centre = np.median(best)
    group = np.abs(log_a - centre) <= np.log(1.4)
    aspect = cands[group, LONG] / np.maximum(cands[group, SHORT], 1e-9)
    return float(np.exp(np.median(log_a[group]))), float(np.median(aspect))


def _chain(
    points: NDArray[np.float64],
    axes: NDArray[np.float64],
    base: int,
    spacing: float,
    first_dir: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.intp], str | None]:
    """Order markers base -> tip by chaining; returns (order, error message or None).

    The first step takes the marker nearest to the base ahead of it (within
    60° of ``first_dir``, the rest direction in the image, when given: a robot
    curled into a full loop has its tip right next to the base).  Every
    further step predicts the next centre by rotating the last chord by the
    rotation between the last two markers (exact for a constant-strain
    stretch) and takes the nearest remaining candidate; where strains jump
    (segment boundaries) and the prediction misses, it takes the nearest
    marker ahead if that one is unambiguous.  Steps that fit neither way, or
    where a second candidate fits almost as well, are refused, so a missing, merged or crossing marker is reported rather than
    silently skipped or swapped.
    """
    n = len(points)
    order = [base]
    left = np.ones(n, bool)
    left[base] = False
    for _ in range(n - 1):
        cur = order[-1]
        idx = np.flatnonzero(left)
        rel = points[idx] - points[cur]
        if len(order) == 1:
            dist = np.linalg.norm(rel, axis=1)
            if first_dir is not None:
                ahead = np.flatnonzero(rel @ first_dir > 0.5 * dist)
                if ahead.size == 0:
                    return np.asarray(order), "chaining broke at the base (no marker ahead of it)"
                idx, dist = idx[ahead], dist[ahead]
            srt = np.argsort(dist)
            if dist[srt[0]] > 2.5 * spacing:
                return np.asarray(order), (
                    f"chaining broke at the base (nearest marker {dist[srt[0]]:.1f} px away, spacing {spacing:.1f} px)"
                )
            if srt.size > 1 and dist[srt[1]] < 1.4 * dist[srt[0]]:
                return np.asarray(order), "chaining is ambiguous at the base (two markers equally near)"
            nxt = idx[srt[0]]
        else:
            prev = order[-2]
            chord = points[cur] - points[prev]
            step = float(np.linalg.norm(chord))
            turn = float(_wrap_half_pi(axes[cur] - axes[prev]))
            c, s_ = np.cos(turn), np.sin(turn)
            pred = np.array([c * chord[0] - s_ * chord[1], s_ * chord[0] + c * chord[1]])
            dist = np.linalg.norm(rel - pred, axis=1)
            srt = np.argsort(dist)
            best = dist[srt[0]]
            near = np.linalg.norm(rel, axis=1)
            fits = best <= 0.6 * step
            if fits and srt.size > 1 and dist[srt[1]] < best + 0.3 * step:
                # two candidates fit the prediction: the next marker must also
                # be clearly the nearer one to the current marker
                fits = near[srt[0]] < 0.8 * near[srt[1]]
            if fits:
                j = srt[0]
                # the spacing can shrink abruptly at a segment boundary (axial
                # strain), so a prediction one old chord long may land on the
                # marker after next: never step over a marker lying between
                gap = np.linalg.norm(rel - rel[j], axis=1)
                between = np.flatnonzero((near < near[j]) & (gap < near[j]))
                if between.size:
                    return np.asarray(order), (
                        f"chaining is ambiguous after {len(order)} markers (a marker lies between the current one "
                        "and the predicted next one)"
                    )
                nxt = idx[j]
            else:
                # Strains jump at a segment boundary (shear can turn the chord by
                # tens of degrees): fall back on the nearest marker ahead of the
                # current one, if it is clearly the nearest and not far off.
                ahead = np.flatnonzero(rel @ chord > 0.0)
                if ahead.size == 0:
                    return np.asarray(order), f"chaining broke after {len(order)} markers (no marker ahead)"
                by_near = ahead[np.argsort(near[ahead])]
                j = by_near[0]
                clear = by_near.size == 1 or near[by_near[1]] >= 1.4 * near[j]
                if not (clear and near[j] <= 3.0 * step and dist[j] <= 1.5 * step):
                    return np.asarray(order), (
                        f"chaining broke after {len(order)} markers (nearest candidate {best:.1f} px from the "
                        f"predicted position, spacing {step:.1f} px, no unambiguous marker ahead)"
                    )
                nxt = idx[j]
        order.append(nxt)
        left[nxt] = False
    return np.asarray(order), None


def _crossings(points: NDArray[np.float64]) -> int:
    """Number of proper crossings between non-adjacent links of a polyline.

    A real robot cannot pass through itself, so the polyline through its
    ordered markers never crosses itself; a chain that does was ordered wrongly
    (typically a curled tip interleaved with the markers near the base).
    """
    a, b = points[:-1], points[1:]
    d = b - a

    def orient(p, q, r):  # sign of the turn p -> q -> r, broadcast over link pairs
        return np.sign((q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))

    A, B = a[:, None], b[:, None]
    C, D = a[None, :], b[None, :]
    o1, o2 = orient(A, B, C), orient(A, B, D)
    o3, o4 = orient(C, D, A), orient(C, D, B)
    cross = (o1 * o2 < 0) & (o3 * o4 < 0)
    n = len(d)
    i, j = np.triu_indices(n, k=2)  # skip a link and its neighbours
    return int(np.count_nonzero(cross[i, j]))


def _zigzags(phi: NDArray[np.float64], tol: float = np.deg2rad(8.0)) -> int:
    """Number of large alternating second differences of the angles along a chain."""
    d2 = np.diff(phi, n=2)
    big = np.abs(d2) > tol
    return int(np.count_nonzero(big[1:] & big[:-1] & (np.sign(d2[1:]) != np.sign(d2[:-1]))))


def _frame_angles(points: NDArray[np.float64], axes: NDArray[np.float64], phi0_hint: float | None) -> tuple[NDArray[np.float64], int]:
    """Continuous image-frame angles phi of ordered markers, and the number of conflicts.

    phi is the angle of the long axis with the tangent ``[-sin phi, cos phi]``
    pointing towards the tip.  The base's pi-ambiguity is resolved by the
    direction to the next marker (and its 2pi one by ``phi0_hint``, the
    previous frame's value); every further marker takes the representative of
    its axis closest to its predecessor (neighbours differ by far less than pi/2).
    """
    n = len(points)
    phi = np.empty(n)
    chord = points[1] - points[0]
    a = axes[0]
    if np.array([-np.sin(a), np.cos(a)]) @ chord < 0:
        a += np.pi
    if phi0_hint is not None:
        a += 2 * np.pi * np.round((phi0_hint - a) / (2 * np.pi))
    phi[0] = a
    for i in range(1, n):
        phi[i] = phi[i - 1] + _wrap_half_pi(axes[i] - phi[i - 1])
    # the tangent of every marker must point along the chain (1 + sigma_ax > 0)
    nxt = np.vstack([points[1:], points[-1:]])
    prv = np.vstack([points[:1], points[:-1]])
    chords = nxt - prv
    tang = np.stack([-np.sin(phi), np.cos(phi)], axis=1)
    conflicts = int(np.count_nonzero(np.sum(tang * chords, axis=1) <= 0))
    return phi, conflicts


# --------------------------------------------------------------------------
# The estimator
# --------------------------------------------------------------------------
class MarkerPoseExtractor(PersistenceMixin, TransformerMixin, BaseEstimator, auto_wrap_output_keys=None):
    """Videos of a marker-carrying planar robot -> pose trajectories (base + N markers).

    Parameters
    ----------
    n_markers : int, optional
        Number N of tracked cross-sections (the base marker not counted).
        Default: inferred from the reference frame of each recording.
    threshold : "otsu", float or (lower, upper)
        Binarisation: Otsu's method, a fixed grey level, or a colour range
        for ``cv2.inRange`` (bounds as grey levels or BGR triples).
    polarity : {"dark", "bright"}
        Markers darker (default) or brighter than the background.
    blur : int
        Odd Gaussian kernel applied before thresholding, 0 for none.
    roi : (x, y, width, height), optional
        Region of interest in pixels; components outside are ignored.
    marker_area : float, optional
        Typical marker area in pixels; default: the most common component
        area in the reference frame.
    area_tolerance : (float, float)
        Components whose area lies outside ``marker_area * [low, high]`` are
        not markers (clutter, noise, or two markers merged).
    aspect_tolerance : float
        Components whose long/short ratio differs from the typical marker's by
        more than this factor are not markers.
    camera : "auto", None, Camera, dict or path
        Calibration.  ``"auto"``: read ``<video>.camera.json`` (written by
        :func:`pcs_sindy.simulation.render_video`) when it exists, otherwise
        calibrate from the reference frame.  ``None``: always calibrate from
        the reference frame.  A :class:`~pcs_sindy.camera.Camera`, its dict or
        the path of its JSON: use it for every recording.
    pixels_per_metre : float, optional
        Scale when no camera is used.
    robot_length : float, optional
        Total rest length (m); with no camera and no ``pixels_per_metre`` the
        scale is the length of the marker chain in the reference frame (the
        robot straight and unstretched there) divided by this.
    base_position : (u, v), optional
        Pixel position of the base marker; default: the camera's origin, or
        the marker that stays put over the recording.
    rest_direction : float, optional
        Image angle (radians, ``atan2(dv, du)``) of the robot's rest direction
        (+y of the base frame) when no camera is used; default: from the base
        marker to the next one in the reference frame.
    reference_frame : int
        Frame used for the typical marker, N, and the calibration.
    fps, dt : float, optional
        Frame rate or period overriding the video's (required for arrays and
        image folders without a camera JSON holding ``fps``).
    refine : bool
        Sub-pixel centres and axes from intensity-weighted moments (default);
        ``False`` uses ``minAreaRect`` directly.
    on_missing : {"raise", "interpolate"}
        A frame where markers are missing, merged, extra or cannot be chained
        either raises (naming recording and frame) or is interpolated in time
        from its valid neighbours (listed in :attr:`diagnostics_`).
    min_area : float
        Components smaller than this many pixels are noise.
    n_jobs : int, optional
        Recordings processed in parallel (joblib).
    progress : bool
        tqdm progress bar over frames.

    Attributes
    ----------
    diagnostics_ : list of dict
        After :meth:`transform`, one per recording: ``recording``,
        ``n_frames``, ``n_markers``, ``markers_found`` (marker-shaped
        components per frame), ``frames_repaired`` and ``repair_reasons``,
        ``orientation_conflicts``, ``max_theta_step``, ``calibration`` and
        the camera used.

    Notes
    -----
    Accuracy on rendered frames (``tests/test_vision.py``, markers 24×6 px):
    about 0.05 px rms in position and 0.2° rms in angle; it degrades for
    markers thinner than about 4 px.  Frames are not silently misordered:
    the chain from the base refuses steps that do not fit or are ambiguous
    (a missing, merged or crossing marker), and a finished chain is rejected
    when it crosses itself, when a marker faces against it, or when the
    marker angles zigzag along it (two interleaved stretches of a robot
    curled over itself).  Rejected frames raise or are interpolated per
    ``on_missing``; ``tests/test_vision.py`` checks this on robots curled
    beyond a full turn.

    Examples
    --------
    >>> from pcs_sindy.simulation import render_video
    >>> paths = render_video(poses, "clip.avi", fps=1000.0)       # doctest: +SKIP
    >>> trajs = MarkerPoseExtractor().fit_transform([str(paths.video)])  # doctest: +SKIP
    >>> trajs[0].poses.shape                                       # doctest: +SKIP
    (500, 21, 3)
    """

    def __init__(
        self,
        n_markers: int | None = None,
        *,
        threshold: str | float | tuple = "otsu",
        polarity: str = "dark",
        blur: int = 0,
        roi: tuple[int, int, int, int] | None = None,
        marker_area: float | None = None,
        area_tolerance: tuple[float, float] = (0.5, 1.6),
        aspect_tolerance: float = 1.8,
        camera: Any = "auto",
        pixels_per_metre: float | None = None,
        robot_length: float | None = None,
        base_position: tuple[float, float] | None = None,
        rest_direction: float | None = None,
        reference_frame: int = 0,
        fps: float | None = None,
        dt: float | None = None,
        refine: bool = True,
        on_missing: str = "raise",
        min_area: float = 4.0,
        n_jobs: int | None = None,
        progress: bool = True,
    ) -> None:
        self.n_markers = n_markers
        self.threshold = threshold
        self.polarity = polarity
        self.blur = blur
        self.roi = roi
        self.marker_area = marker_area
        self.area_tolerance = area_tolerance
        self.aspect_tolerance = aspect_tolerance
        self.camera = camera
        self.pixels_per_metre = pixels_per_metre
        self.robot_length = robot_length
        self.base_position = base_position
        self.rest_direction = rest_direction
        self.reference_frame = reference_frame
        self.fps = fps
        self.dt = dt
        self.refine = refine
        self.on_missing = on_missing
        self.min_area = min_area
        self.n_jobs = n_jobs
        self.progress = progress

    # -- validation ---------------------------------------------------------
    def _validate(self) -> dict[str, Any]:
        def positive(name: str, value: Any, allow_none: bool = True) -> None:
            if value is None and allow_none:
                return
            if isinstance(value, bool) or not np.isscalar(value) or not np.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a finite number > 0; got {value!r}")

        if self.n_markers is not None and (
            isinstance(self.n_markers, bool) or not isinstance(self.n_markers, (int, np.integer)) or self.n_markers < 1
        ):
            raise ValueError(f"n_markers must be a positive integer or None; got {self.n_markers!r}")
        thr = self.threshold
        if isinstance(thr, str):
            if thr != "otsu":
                raise ValueError(f"threshold must be 'otsu', a grey level or a (lower, upper) colour range; got {thr!r}")
        elif isinstance(thr, tuple):
            if len(thr) != 2:
                raise ValueError(f"threshold as a colour range must be (lower, upper); got {thr!r}")
            lo, hi = (np.atleast_1d(np.asarray(b, dtype=float)) for b in thr)
            if lo.shape != hi.shape or lo.size not in (1, 3) or np.any(lo > hi) or np.any(lo < 0) or np.any(hi > 255):
                raise ValueError(f"threshold colour range must be two grey levels or BGR triples with lower <= upper in [0, 255]; got {thr!r}")
        elif not np.isscalar(thr) or isinstance(thr, bool) or not 0 <= float(thr) <= 255:
            raise ValueError(f"threshold must be 'otsu', a grey level in [0, 255] or a (lower, upper) colour range; got {thr!r}")
        if self.polarity not in ("dark", "bright"):
            raise ValueError(f"polarity must be 'dark' or 'bright'; got {self.polarity!r}")
        if not isinstance(self.blur, (int, np.integer)) or self.blur < 0 or (self.blur and self.blur % 2 == 0):
            raise ValueError(f"blur must be 0 or an odd positive integer; got {self.blur!r}")
        roi = self.roi
        if roi is not None:
            r = np.asarray(roi)
            if r.shape != (4,) or np.any(r != np.round(r)) or np.any(r[:2] < 0) or np.any(r[2:] < 1):
                raise ValueError(f"roi must be (x, y, width, height) integers with width, height >= 1; got {roi!r}")
            roi = tuple(int(v) for v in r)
        positive("marker_area", self.marker_area)
        tol = np.asarray(self.area_tolerance, dtype=float)
        if tol.shape != (2,) or not (0 < tol[0] < 1 < tol[1]) or not np.all(np.isfinite(tol)):
            raise ValueError(f"area_tolerance must be (low < 1, high > 1), both > 0; got {self.area_tolerance!r}")
        positive("aspect_tolerance", self.aspect_tolerance, allow_none=False)
        if self.aspect_tolerance < 1:
            raise ValueError(f"aspect_tolerance must be >= 1; got {self.aspect_tolerance!r}")
        cam = self.camera
        if isinstance(cam, str) and cam == "auto":
            pass
        elif cam is None or isinstance(cam, Camera):
            pass
        elif isinstance(cam, dict):
            cam = Camera.from_dict(cam)
        elif isinstance(cam, (str, os.PathLike)):
            cam = Camera.from_json(cam)
        else:
            raise ValueError(f"camera must be 'auto', None, a Camera, a dict or a JSON path; got {type(cam).__name__}")
        positive("pixels_per_metre", self.pixels_per_metre)
        positive("robot_length", self.robot_length)
        if self.base_position is not None:
            bp = np.asarray(self.base_position, dtype=float)
            if bp.shape != (2,) or not np.all(np.isfinite(bp)):
                raise ValueError(f"base_position must be (u, v) pixels; got {self.base_position!r}")
        if self.rest_direction is not None and (not np.isscalar(self.rest_direction) or not np.isfinite(self.rest_direction)):
            raise ValueError(f"rest_direction must be a finite angle in radians; got {self.rest_direction!r}")
        if isinstance(self.reference_frame, bool) or not isinstance(self.reference_frame, (int, np.integer)) or self.reference_frame < 0:
            raise ValueError(f"reference_frame must be a non-negative integer; got {self.reference_frame!r}")
        positive("fps", self.fps)
        positive("dt", self.dt)
        if self.fps is not None and self.dt is not None:
            raise ValueError(f"give fps or dt, not both; got fps={self.fps!r}, dt={self.dt!r}")
        if self.on_missing not in ("raise", "interpolate"):
            raise ValueError(f"on_missing must be 'raise' or 'interpolate'; got {self.on_missing!r}")
        positive("min_area", self.min_area, allow_none=False)
        params = self.get_params()
        params.update(camera=cam, roi=roi)
        return params

    # -- sklearn API -----------------------------------------------------------
    def fit(self, X: Any = None, y: Any = None) -> "MarkerPoseExtractor":
        """Validate the parameters and, if given, the form of ``X`` (extraction is stateless); returns self."""
        self._validate()
        if X is not None:
            _check_recordings(X)
        return self

    def transform(self, X: Any) -> list[PoseTrajectory]:
        """Extract the pose trajectory of every recording.

        Parameters
        ----------
        X : list of recordings
            Each a video path, a folder of image files, or a uint8 array of
            frames (T, H, W) / (T, H, W, 3).  A single path or array is one
            recording.

        Returns
        -------
        list of PoseTrajectory
            Poses (T, N + 1, 3) in metres/radians in the robot's base frame;
            ``metadata`` holds the source, the camera and the diagnostics.
        """
        params = self._validate()
        X = _check_recordings(X)
        names = [_describe(rec, k) for k, rec in enumerate(X)]
        jobs = (delayed(_extract_recording)(rec, name, params) for rec, name in zip(X, names))
        if self.n_jobs in (None, 1) or len(X) == 1:
            results = [_extract_recording(rec, name, params) for rec, name in zip(X, names)]
        else:
            results = Parallel(n_jobs=self.n_jobs)(jobs)
        self.diagnostics_ = [diag for _, diag in results]
        return [traj for traj, _ in results]

    def __sklearn_tags__(self):  # stateless: transform needs no fit
        tags = super().__sklearn_tags__()
        tags.requires_fit = False
        tags.input_tags.two_d_array = False  # X is a list of videos
        return tags


# --------------------------------------------------------------------------
# One recording (module level so joblib can pickle it)
# --------------------------------------------------------------------------
def _extract_recording(recording: Any, name: str, p: dict[str, Any]) -> tuple[PoseTrajectory, dict[str, Any]]:
    n_frames, video_fps, frames = _open_source(recording, name)
    camera = p["camera"]
    calibration = None
    json_fps = None
    if isinstance(camera, str):  # "auto"
        camera = None
        if isinstance(recording, (str, os.PathLike)):
            jpath = camera_json_path(recording)
            if jpath.exists():
                data = read_camera_json(jpath)
                camera = Camera.from_dict(data)
                json_fps = data.get("fps")
                calibration = f"camera JSON {str(jpath)!r}"
    elif camera is not None:
        calibration = "given camera"

    if p["dt"] is not None:
        dt = float(p["dt"])
    elif p["fps"] is not None:
        dt = 1.0 / float(p["fps"])
    elif video_fps is not None:
        dt = 1.0 / video_fps
    elif json_fps is not None:
        dt = 1.0 / float(json_fps)
    else:
        raise ValueError(f"recording {name!r}: the frame rate is unknown; give fps or dt")

    # pass 1: candidate components of every frame (images are not kept)
    cands: list[NDArray[np.float64]] = []
    image_size = (0, 0)
    for k, frame in enumerate(tqdm(frames, total=n_frames, desc=f"extract {Path(name).name}", unit="frame", disable=not p["progress"])):
        frame = np.asarray(frame)
        if frame.dtype != np.uint8:
            raise ValueError(f"recording {name!r}, frame {k}: images must be 8-bit; got dtype {frame.dtype}")
        if k == 0:
            image_size = (int(frame.shape[1]), int(frame.shape[0]))
        elif (frame.shape[1], frame.shape[0]) != image_size:
            raise ValueError(
                f"recording {name!r}, frame {k}: size {frame.shape[1]}x{frame.shape[0]} differs from frame 0 "
                f"({image_size[0]}x{image_size[1]})"
            )
        cands.append(
            detect_markers(
                frame,
                threshold=p["threshold"],
                polarity=p["polarity"],
                blur=p["blur"],
                roi=p["roi"],
                min_area=p["min_area"],
                refine=p["refine"],
                name=name,
                index=k,
            )
        )
    T = len(cands)
    if T == 0:
        raise ValueError(f"recording {name!r}: no frames")
    if camera is not None and tuple(camera.image_size) != image_size:
        raise ValueError(
            f"recording {name!r}: frames are {image_size[0]}x{image_size[1]} pixels but the camera ({calibration}) "
            f"expects {camera.image_size[0]}x{camera.image_size[1]}"
        )
    ref = p["reference_frame"]
    if ref >= T:
        raise ValueError(f"reference_frame={ref} but recording {name!r} has only {T} frames")

    # typical marker from the reference frame
    if len(cands[ref]) == 0:
        raise ValueError(f"recording {name!r}, frame {ref}: no markers found (reference frame)")
    typ_area, typ_aspect = _typical_marker(cands[ref], None if p["n_markers"] is None else p["n_markers"] + 1)
    if p["marker_area"] is not None:
        typ_area = float(p["marker_area"])
    lo, hi = p["area_tolerance"]
    tol = p["aspect_tolerance"]

    def accept(c: NDArray[np.float64]) -> NDArray[np.float64]:
        aspect = c[:, LONG] / np.maximum(c[:, SHORT], 1e-9)
        ok = (c[:, AREA] >= lo * typ_area) & (c[:, AREA] <= hi * typ_area)
        ok &= (aspect >= typ_aspect / tol) & (aspect <= typ_aspect * tol)
        return c[ok]

    markers = [accept(c) for c in cands]
    found = np.array([len(m) for m in markers])
    n_expected = p["n_markers"] + 1 if p["n_markers"] is not None else int(found[ref])
    if n_expected < 2:
        raise ValueError(f"recording {name!r}, frame {ref}: found {found[ref]} marker(s); need the base and at least one marker")
    if found[ref] != n_expected:
        raise ValueError(
            f"recording {name!r}, frame {ref} (reference frame): found {found[ref]} marker-shaped components, "
            f"expected {n_expected} (base + {n_expected - 1} markers)"
        )
    ref_pts = markers[ref][:, :2]
    nn = np.linalg.norm(ref_pts[:, None] - ref_pts[None], axis=-1)
    np.fill_diagonal(nn, np.inf)
    spacing = float(np.median(nn.min(axis=1)))

    problems: dict[int, str] = {}

    def problem(k: int, msg: str) -> None:
        if p["on_missing"] == "raise":
            raise ValueError(f"recording {name!r}, frame {k}: {msg}")
        problems[k] = msg

    for k in range(T):
        if found[k] != n_expected:
            what = "no markers found" if found[k] == 0 else f"found {found[k]} marker-shaped components"
            problem(k, f"{what}, expected {n_expected} (base + {n_expected - 1} markers; missing, merged or extra markers)")

    # the base marker
    if p["base_position"] is not None:
        base_px = np.asarray(p["base_position"], dtype=float)
        base_source = "given"
    elif camera is not None:
        base_px = np.asarray(camera.origin, dtype=float)
        base_source = "camera origin"
    else:
        base_px = _find_static_marker(markers, [k for k in range(T) if k not in problems], ref, spacing, name)
        base_source = "stays put"

    def base_index(k: int) -> int | None:
        d = np.linalg.norm(markers[k][:, :2] - base_px, axis=1)
        b = int(np.argmin(d))
        if d[b] > 0.5 * spacing:
            problem(k, f"no marker within {0.5 * spacing:.1f} px of the base position {base_px.round(1).tolist()}")
            return None
        return b

    # the rest direction (+y of the base frame) in the image orients the chain at the base
    if camera is not None:
        rest = camera.angle + 0.5 * np.pi
    elif p["rest_direction"] is not None:
        rest = float(p["rest_direction"])
    else:
        b = base_index(ref)
        order, err = _chain(markers[ref][:, :2], markers[ref][:, AXIS], b, spacing) if b is not None else (None, None)
        if b is None or err is not None:
            raise ValueError(f"recording {name!r}, frame {ref} (reference frame): {err or problems.get(ref)}")
        # direction from the base along the first markers (a least-squares line:
        # one pair of centres would carry their detection noise into every angle)
        near = markers[ref][order[: min(5, len(order))], :2]
        centred = near - near.mean(axis=0)
        dvec = np.linalg.svd(centred, full_matrices=False)[2][0]
        if dvec @ (near[-1] - near[0]) < 0:
            dvec = -dvec
        rest = float(np.arctan2(dvec[1], dvec[0]))
    rest_dir = np.array([np.cos(rest), np.sin(rest)])

    # pass 2: order and orient every valid frame
    phi = np.zeros((T, n_expected))
    pix = np.zeros((T, n_expected, 2))
    conflicts = np.zeros(T, dtype=int)
    phi0_prev = None
    order_ref = None
    for k in range(T):
        if k in problems:
            continue
        m = markers[k]
        b = base_index(k)
        if b is None:
            continue
        order, err = _chain(m[:, :2], m[:, AXIS], b, spacing, rest_dir)
        if err is not None:
            if k == ref and p["n_markers"] is None:
                err = f"{len(m)} marker-shaped components but only {len(order)} chain from the base ({err})"
            problem(k, err)
            continue
        pts = m[order, :2]
        n_cross = _crossings(pts)
        if n_cross:
            problem(k, f"the ordered marker chain crosses itself {n_cross} time(s) (ordering not trustworthy)")
            continue
        ang, conflicts[k] = _frame_angles(pts, m[order, AXIS], phi0_prev)
        if _zigzags(ang) >= 3:
            # bending is piecewise constant along a PCS robot; increments that
            # alternate big/small mark two interleaved stretches of the robot
            # (a tip curled more than a full turn back over the base)
            problem(k, "marker angles zigzag along the chain (interleaved markers; ordering not trustworthy)")
            continue
        if conflicts[k]:
            # a marker faces against the chain: the chain ran backwards somewhere
            # (e.g. round a loop whose tip touches the middle of the robot)
            problem(k, f"{conflicts[k]} marker(s) face against the chain direction (ordering not trustworthy)")
            continue
        phi0_prev = ang[0]
        pix[k], phi[k] = pts, ang
        if k == ref:
            order_ref = pts

    if ref in problems or order_ref is None:
        raise ValueError(f"recording {name!r}, frame {ref} (reference frame): {problems.get(ref, 'could not be ordered')}")
    valid = np.array([k not in problems for k in range(T)])
    if p["on_missing"] == "interpolate" and not np.any(valid):
        raise ValueError(f"recording {name!r}: no frame could be extracted")

    # calibration: metres in the robot's base frame
    if camera is None:
        if p["pixels_per_metre"] is not None:
            ppm = float(p["pixels_per_metre"])
            calibration = "given pixels_per_metre"
        elif p["robot_length"] is not None:
            chain_len = float(np.sum(np.linalg.norm(np.diff(order_ref, axis=0), axis=1)))
            ppm = chain_len / float(p["robot_length"])
            calibration = f"straight reference frame {ref} with robot_length={p['robot_length']!r}"
        else:
            raise ValueError(
                f"recording {name!r}: no calibration; give camera, pixels_per_metre, or robot_length "
                "(with a straight reference frame)"
            )
        # +y of the base frame maps to [-sin a, cos a] in the image: a = rest - pi/2
        camera = Camera(ppm, tuple(order_ref[0]), image_size, rest - 0.5 * np.pi)

    theta = phi - camera.angle
    # the base is clamped: pick the 2pi branch that puts its first valid angle nearest 0
    first = int(np.argmax(valid))
    shift = 2 * np.pi * np.round(theta[first, 0] / (2 * np.pi))
    theta -= shift
    metres = camera.to_metres(pix)
    poses = np.concatenate([metres, theta[..., None]], axis=-1)

    repaired = sorted(problems)
    if repaired:
        good = np.flatnonzero(valid)
        for i in range(n_expected):
            for c in range(3):
                poses[~valid, i, c] = np.interp(np.flatnonzero(~valid), good, poses[good, i, c])

    jumps = np.abs(np.diff(poses[valid][..., 2], axis=0)) if valid.sum() > 1 else np.zeros((0, n_expected))
    diag = {
        "recording": name,
        "n_frames": T,
        "n_markers": n_expected - 1,
        "markers_found": found,
        "frames_repaired": repaired,
        "repair_reasons": {k: problems[k] for k in repaired},
        "orientation_conflicts": int(conflicts.sum()),
        "max_theta_step": float(jumps.max()) if jumps.size else 0.0,
        "marker_area_px": typ_area,
        "marker_aspect": typ_aspect,
        "marker_spacing_px": spacing,
        "base_marker": base_source,
        "calibration": calibration,
        "camera": camera.to_dict(),
    }
    traj = PoseTrajectory(poses, dt=dt, metadata={"source": name, "camera": camera.to_dict(), "diagnostics": diag})
    return traj, diag


def _find_static_marker(markers: list[NDArray[np.float64]], valid: list[int], ref: int, spacing: float, name: str) -> NDArray[np.float64]:
    """Pixel position of the marker of the reference frame that stays put over the recording."""
    pts = markers[ref][:, :2]
    others = [k for k in valid if k != ref]
    if not others:
        raise ValueError(
            f"recording {name!r}: cannot tell the base marker from a single usable frame; give base_position or a camera"
        )
    sample = np.asarray(others)[np.linspace(0, len(others) - 1, min(len(others), 64)).astype(int)]
    worst = np.zeros(len(pts))
    for k in sample:
        d = np.linalg.norm(pts[:, None] - markers[k][None, :, :2], axis=-1).min(axis=1)
        worst = np.maximum(worst, d)
    order = np.argsort(worst)
    # the base moves by detection noise only; every other marker, even the
    # nearest one, must move clearly more somewhere in the recording
    if len(order) > 1 and worst[order[1]] < max(4.0 * worst[order[0]], 1.0):
        raise ValueError(
            f"recording {name!r}: several markers stay put (the robot hardly moves), so the base marker is ambiguous; "
            "give base_position or a camera"
        )
    return pts[order[0]]
