"""Render pose trajectories as marker images, videos and folders of PNG frames.

Each tracked cross-section (and the base) is drawn as a filled rectangle
centred on its pose, wider across the robot than along it, so that its long
axis is ``[cos theta, sin theta]`` in the base frame (the backbone tangent is
``[-sin theta, cos theta]``).  Optionally the robot's body is drawn first in a
lighter shade, as a thick polyline through the marker centres or through a
backbone the caller provides.  Drawing uses OpenCV with sub-pixel vertices
(``shift``) on a supersampled canvas that is box-averaged down (exact area
anti-aliasing), so that intensity centroids of the markers are unbiased to a
few hundredths of a pixel.  A camera with a lens (:class:`pcs_sindy.core.camera.Camera`
with distortion and perspective) bends the marker outlines as a real lens does.

:class:`~pcs_sindy.simulation.nuisances.Nuisances` degrades the footage the
way real recordings are degraded (:mod:`pcs_sindy.simulation.nuisances`), and
:func:`~pcs_sindy.simulation.checkerboard.render_checkerboard` draws
calibration boards through the same lens; both are importable from here too.

The camera (metres <-> pixels) is written next to every video as JSON so
that extraction can invert the mapping.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from ..core.atomic import FileSet
from ..core.camera import Camera, camera_json_path
from ..core.optional import require
from ..core.video import VIDEO_CODECS, open_video_writer, video_codec
from ._drawing import SHIFT, draw_polygon, fixed_point, subdivide
from .checkerboard import render_checkerboard
from .nuisances import Nuisances, degrade, draw_scene, illumination, occlude, sub_frame_poses

cv2 = require("cv2", "rendering marker videos (pcs_sindy.simulation.rendering)")

__all__ = ["render_frames", "render_video", "render_checkerboard", "marker_corners", "Nuisances", "RenderedVideo"]

_EDGE_POINTS = 6  # vertices per polygon edge when a lens bends straight edges


class RenderedVideo(NamedTuple):
    """Paths written by :func:`render_video`."""

    video: Path
    """The video file, or the folder of PNG frames."""
    camera: Path
    """The camera JSON next to it."""


def _check_poses(poses: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(poses, dtype=float)
    if arr.ndim == 2 and arr.shape[-1] == 3:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[-1] != 3 or arr.shape[1] < 1 or arr.shape[0] < 1:
        raise ValueError(f"poses must have shape (T, N + 1, 3); got {np.shape(poses)}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"poses contains NaN or inf (first at frame {bad[0]}, marker {bad[1]})")
    return arr


def _check_colour(value: float | Sequence[float], name: str, colour: bool) -> tuple[float, ...]:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1 or arr.size not in ((1, 3) if colour else (1,)) or np.any(arr < 0) or np.any(arr > 255):
        want = "a grey level or a (B, G, R) triple" if colour else "a grey level"
        raise ValueError(f"{name} must be {want} in [0, 255]; got {value!r}")
    if colour and arr.size == 1:
        arr = np.repeat(arr, 3)
    return tuple(float(v) for v in arr)


def marker_corners(pixel_poses: ArrayLike, width_px: float, thickness_px: float) -> NDArray[np.float64]:
    """Corners (..., 4, 2) of rectangles centred on pixel poses ``[u, v, phi]``.

    ``width_px`` is the side along the long axis ``[cos phi, sin phi]`` (across
    the robot) and ``thickness_px`` the side along the backbone.
    """
    p = np.asarray(pixel_poses, dtype=float)
    a = np.stack([np.cos(p[..., 2]), np.sin(p[..., 2])], axis=-1) * (0.5 * width_px)
    t = np.stack([-np.sin(p[..., 2]), np.cos(p[..., 2])], axis=-1) * (0.5 * thickness_px)
    c = p[..., None, :2]
    return np.stack([c[..., 0, :] + a + t, c[..., 0, :] - a + t, c[..., 0, :] - a - t, c[..., 0, :] + a - t], axis=-2)


def render_frames(
    poses: ArrayLike,
    camera: Camera | None = None,
    *,
    marker_size: tuple[float, float] = (0.008, 0.002),
    marker_style: str = "filled",
    outline_width: float | None = None,
    body: bool | ArrayLike = True,
    body_width: float = 0.005,
    background: float | Sequence[float] = 255,
    marker_colour: float | Sequence[float] = 0,
    body_colour: float | Sequence[float] = 210,
    colour: bool = False,
    supersample: int | None = None,
    nuisances: Nuisances | None = None,
    first_frame: int = 0,
    progress: bool = False,
) -> NDArray[np.uint8]:
    """Draw the base and tracked cross-sections of every frame.

    Parameters
    ----------
    poses : array_like, shape (T, N + 1, 3)
        Base (index 0) and marker poses in metres/radians in the base frame.
    camera : Camera, optional
        Metres -> pixels (with its lens, if any); default
        ``Camera.fit_poses(poses)``: 640×480 with the largest scale that
        holds this robot bending past ±180°.
    marker_size : (float, float)
        ``(width across the robot, thickness along it)`` in metres; the width
        must exceed the thickness so the orientation can be read back.
    marker_style : {"filled", "outline"}
        Filled rectangles or outlines only (as some real markers look).
    outline_width : float, optional
        Line width in pixels of outlined markers (default: a third of the
        thickness, at least 1.5 px).
    body : bool or array_like, shape (T, P, 2 or 3)
        Draw the robot's body as a polyline through the marker centres
        (``True``), through the given backbone points (metres), or not at all.
    body_width : float
        Width of the body in metres.
    background, marker_colour, body_colour : grey level or (B, G, R)
    colour : bool
        Return BGR frames (T, H, W, 3) instead of grey frames (T, H, W).
    supersample : int, optional
        Anti-aliasing of the markers: each is drawn at this many times the
        resolution and box-averaged down, so edge pixels carry their exact
        area coverage (to 1/supersample^2) and centroids are unbiased.
        Default: 16 for markers thinner than 8 px, else 8.  The body is drawn
        with OpenCV's own anti-aliasing.
    nuisances : Nuisances, optional
        Degradations of real footage (see :class:`Nuisances`).
    first_frame : int
        Index of ``poses[0]`` in its recording (occlusion timing and noise seeds
        when a long recording is rendered in pieces).
    progress : bool
        Show a tqdm bar over frames.

    Returns
    -------
    ndarray of uint8, shape (T, H, W) or (T, H, W, 3)
    """
    poses = _check_poses(poses)
    camera = Camera.fit_poses(poses) if camera is None else camera
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a pcs_sindy.core.camera.Camera; got {type(camera).__name__}")
    if not camera.has_base_frame:
        raise ValueError("camera must have a base frame (origin and angle) to render poses")
    size = np.asarray(marker_size, dtype=float)
    if size.shape != (2,) or not np.all(np.isfinite(size)) or np.any(size <= 0) or size[0] <= size[1]:
        raise ValueError(f"marker_size must be (width, thickness) > 0 with width > thickness; got {marker_size!r}")
    if marker_style not in ("filled", "outline"):
        raise ValueError(f"marker_style must be 'filled' or 'outline'; got {marker_style!r}")
    if not np.isfinite(body_width) or body_width <= 0:
        raise ValueError(f"body_width must be > 0; got {body_width!r}")
    if supersample is not None and (
        isinstance(supersample, bool) or not isinstance(supersample, (int, np.integer)) or not 1 <= supersample <= 32
    ):
        raise ValueError(f"supersample must be None or an integer in [1, 32]; got {supersample!r}")
    if nuisances is not None and not isinstance(nuisances, Nuisances):
        raise ValueError(f"nuisances must be None or a Nuisances; got {type(nuisances).__name__}")
    if isinstance(first_frame, bool) or not isinstance(first_frame, (int, np.integer)) or first_frame < 0:
        raise ValueError(f"first_frame must be a non-negative integer; got {first_frame!r}")
    bg = _check_colour(background, "background", colour)
    fg = _check_colour(marker_colour, "marker_colour", colour)
    bc = _check_colour(body_colour, "body_colour", colour)

    T = poses.shape[0]
    width, height = camera.image_size
    ppm = camera.pixels_per_metre
    w_px, t_px = size * ppm
    if supersample is None:
        supersample = 16 if t_px < 8.0 else 8
    line = max(1.5, t_px / 3.0) if outline_width is None else float(outline_width)
    if not np.isfinite(line) or line <= 0:
        raise ValueError(f"outline_width must be > 0; got {outline_width!r}")

    backbone = None
    if body is not True and body is not False and body is not None:
        backbone = np.asarray(body, dtype=float)
        if backbone.ndim != 3 or backbone.shape[0] != T or backbone.shape[-1] not in (2, 3) or backbone.shape[1] < 2:
            raise ValueError(f"body as an array must have shape ({T}, P >= 2, 2 or 3); got {backbone.shape}")
        if not np.all(np.isfinite(backbone)):
            raise ValueError("body (backbone points) contains NaN or inf")
        backbone = camera.to_pixels(backbone[..., :2])
    draw_body = backbone is not None or body is True

    nz = nuisances
    blur = nz is not None and nz.motion_blur > 0
    sub = sub_frame_poses(poses, nz.motion_blur) if blur else poses[:, None]  # (T, B, N + 1, 3)
    # OpenCV fills a polygon's boundary pixels too, which widens a filled
    # rectangle by one canvas pixel: shrink it by that much so areas are exact
    grow = -1.0 / supersample if marker_style == "filled" else 0.0
    rect = camera.to_rectified(sub)
    corners = marker_corners(rect, w_px + grow, t_px + grow)  # (T, B, N + 1, 4, 2), rectified pixels
    if camera.has_lens:
        corners = camera.unrectify(subdivide(corners, _EDGE_POINTS))
    body_pts = backbone[:, None] if backbone is not None else camera.unrectify(rect[..., :2])
    body_thick = max(1, int(round(body_width * ppm)))
    shape = (height, width, 3) if colour else (height, width)
    scene = draw_scene(camera, shape, bg, nz, camera.to_pixels(np.zeros(2)), t_px)
    light = illumination((height, width), nz) if nz is not None and (nz.lighting_gradient or nz.vignetting) else None
    occ = nz.occlusion if nz is not None else None
    out = np.empty((T, *shape), dtype=np.uint8)
    for k in tqdm(range(T), desc="render", unit="frame", disable=not progress):
        acc = None
        for b in range(sub.shape[1]):
            img = scene.copy()
            if draw_body:
                pts = body_pts[k, 0 if backbone is not None else b]
                cv2.polylines(img, [fixed_point(pts).reshape(-1, 1, 2)], False, bc, body_thick, cv2.LINE_AA, SHIFT)
            for c in corners[k, b]:
                draw_polygon(img, c, fg, supersample, None if marker_style == "filled" else line)
            acc = img.astype(np.float32) if acc is None else acc + img
        img = np.round(acc / sub.shape[1]).astype(np.uint8) if sub.shape[1] > 1 else acc.astype(np.uint8)
        if occ is not None and occ[1] <= first_frame + k < occ[1] + occ[2] and occ[0] < poses.shape[1]:
            occlude(img, camera, poses[k, occ[0]], occ[3], w_px, t_px, colour)
        if nz is not None:
            img = degrade(img, light, nz, np.random.default_rng([nz.seed, first_frame + k]))
        out[k] = img
    return out


def render_video(
    poses: ArrayLike,
    path: str | os.PathLike,
    camera: Camera | None = None,
    *,
    fps: float = 30.0,
    codec: str | None = None,
    progress: bool = False,
    **render_kwargs,
) -> RenderedVideo:
    """Render poses to a video file or a folder of PNG frames, plus the camera JSON.

    Parameters
    ----------
    poses : array_like, shape (T, N + 1, 3)
    path : path
        ``*.avi`` (``MJPG``, sharp marker edges), ``*.mp4`` (H.264 ``avc1`` when this OpenCV build
        has the encoder, else ``mp4v``) or ``*.webm`` (VP8; with H.264 MP4 what browsers play) for a
        video (:data:`pcs_sindy.core.video.VIDEO_CODECS`); a path without suffix is a folder that
        receives ``frame_000000.png``, ...
    camera : Camera, optional
        Default ``Camera.fit_poses(poses)`` (640×480, the robot fills it).
    fps : float
        Frame rate stored in the video and in the camera JSON (``"fps"``).
    codec : str, optional
        FourCC overriding the default of the suffix.
    progress : bool
        tqdm bar over frames.
    **render_kwargs
        Passed to :func:`render_frames` (marker size and style, body, colours,
        ``nuisances``).

    Returns
    -------
    RenderedVideo
        ``(video, camera)``: the video file (or PNG folder) and the camera JSON.
    """
    if camera is None:
        camera = Camera.fit_poses(_check_poses(poses))
    if not np.isscalar(fps) or not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a finite number > 0; got {fps!r}")
    if "first_frame" in render_kwargs:
        raise ValueError("first_frame is set by render_video itself")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix and suffix not in VIDEO_CODECS:
        raise ValueError(
            f"path must end in one of {', '.join(VIDEO_CODECS)}, or have no suffix (PNG folder); got {str(path)!r}"
        )
    if codec is not None and (not isinstance(codec, str) or len(codec) != 4):
        raise ValueError(f"codec must be a four-character code such as 'mp4v'; got {codec!r}")
    parent = path.parent if suffix else path
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OSError(f"cannot create the output folder for path={str(path)!r}: {err}") from err
    if not os.access(parent, os.W_OK):
        raise OSError(f"output folder for path={str(path)!r} is not writable")

    poses = _check_poses(poses)
    colour = bool(render_kwargs.get("colour", False))
    # render in chunks: a long 1 kHz recording does not fit in memory at once
    chunks = (
        (start, render_frames(poses[start : start + 256], camera, first_frame=start, **render_kwargs))
        for start in range(0, poses.shape[0], 256)
    )
    if suffix:
        width, height = camera.image_size
        codec = codec or video_codec(suffix)
        # written under a hidden temporary name and renamed when complete: an interrupted render
        # (Ctrl-C, a full disk) never leaves a truncated video under the name extraction reads
        with FileSet() as video, video.path_for(path) as tmp:
            try:
                writer = open_video_writer(tmp, codec, fps, (width, height))
            except OSError:
                raise OSError(f"OpenCV cannot open a video writer for path={str(path)!r} (codec {codec})") from None
            try:
                for _, frames in tqdm(chunks, desc="video", unit="chunk", disable=not progress):
                    for frame in frames:
                        writer.write(frame if colour else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
            finally:
                writer.release()
    else:
        for start, frames in tqdm(chunks, desc="frames", unit="chunk", disable=not progress):
            for j, frame in enumerate(frames):
                name = path / f"frame_{start + j:06d}.png"
                if not cv2.imwrite(str(name), frame):
                    raise OSError(f"cannot write frame {start + j} to {str(name)!r}")
    json_path = camera.to_json(camera_json_path(path), extra={"fps": float(fps), "n_frames": int(poses.shape[0])})
    return RenderedVideo(path, json_path)
