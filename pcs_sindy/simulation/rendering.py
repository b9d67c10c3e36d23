"""Render pose trajectories as marker images, videos and folders of PNG frames.

Each tracked cross-section (and the base) is drawn as a filled rectangle
centred on its pose, wider across the robot than along it, so that its long
axis is ``[cos theta, sin theta]`` in the base frame (the backbone tangent is
``[-sin theta, cos theta]``).  Optionally the robot's body is drawn first in a
lighter shade, as a thick polyline through the marker centres or through a
backbone the caller provides.  Drawing uses OpenCV with sub-pixel vertices
(``shift``) on a supersampled canvas that is box-averaged down (exact area
anti-aliasing), so that intensity centroids of the markers are unbiased to a
few hundredths of a pixel.  A camera with a lens (:class:`pcs_sindy.camera.Camera`
with distortion and perspective) bends the marker outlines as a real lens does.

:class:`Nuisances` degrades the footage the way real recordings are degraded
(uneven light, vignetting, sensor noise, motion blur, JPEG compression, a
floor, clutter and printed text, a marker partly covered for a few frames),
so that extraction is tested on footage it was not tuned to.
:func:`render_checkerboard` draws calibration boards through the same lens.

The camera (metres <-> pixels) is written next to every video as JSON so
that extraction can invert the mapping.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from ..camera import Camera, camera_json_path

__all__ = ["render_frames", "render_video", "render_checkerboard", "marker_corners", "Nuisances", "RenderedVideo"]

_SHIFT = 8  # fractional bits of the vertex coordinates passed to OpenCV
_VIDEO_CODECS = {".mp4": "mp4v", ".avi": "MJPG"}
_EDGE_POINTS = 6  # vertices per polygon edge when a lens bends straight edges
_BLUR_SAMPLES = 5  # sub-frame renders averaged for motion blur


class RenderedVideo(NamedTuple):
    """Paths written by :func:`render_video`."""

    video: Path
    """The video file, or the folder of PNG frames."""
    camera: Path
    """The camera JSON next to it."""


@dataclass(frozen=True)
class Nuisances:
    """What makes real footage harder than a clean rendering (all off by default).

    Parameters
    ----------
    lighting_gradient : float
        Illumination falls linearly across the image from ``1 + g/2`` to
        ``1 - g/2`` (it multiplies every pixel, markers included).
    gradient_angle : float
        Image direction (radians) in which the illumination falls.
    vignetting : float
        Relative darkening in the image corners (radial, quadratic).
    noise : float
        Standard deviation (grey levels) of Gaussian sensor noise.
    motion_blur : float
        Exposure as a fraction of the frame interval: every frame averages
        renders of the robot moving over that interval (centred on the frame's pose).
    jpeg_quality : int, optional
        JPEG-compress every frame at this quality (1-100).
    clutter : bool
        A support bar above the base, a printed label, a tray and two cables,
        all drawn into the background (the robot passes in front of them).
    floor : float, optional
        Grey level (0-255) of a floor filling the image below ``floor_level``.
    floor_level : float
        Top of the floor as a fraction of the image height.
    occlusion : (marker, first frame, n frames, fraction), optional
        A finger-like occluder covering ``fraction`` of the width of marker
        ``marker`` (0 = base) in frames ``first .. first + n - 1``.
    seed : int
        Seed of the noise and of the clutter layout.
    """

    lighting_gradient: float = 0.0
    gradient_angle: float = 0.0
    vignetting: float = 0.0
    noise: float = 0.0
    motion_blur: float = 0.0
    jpeg_quality: int | None = None
    clutter: bool = False
    floor: float | None = None
    floor_level: float = 0.85
    occlusion: tuple[int, int, int, float] | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("lighting_gradient", "vignetting", "noise", "motion_blur"):
            value = getattr(self, name)
            if not np.isscalar(value) or not np.isfinite(value) or value < 0:
                raise ValueError(f"Nuisances.{name} must be a finite number >= 0; got {value!r}")
        if self.lighting_gradient >= 2 or self.vignetting >= 1:
            raise ValueError(
                f"Nuisances: lighting_gradient must be < 2 and vignetting < 1 (light stays positive); got "
                f"{self.lighting_gradient!r}, {self.vignetting!r}"
            )
        if self.jpeg_quality is not None and not (
            isinstance(self.jpeg_quality, (int, np.integer)) and 1 <= self.jpeg_quality <= 100
        ):
            raise ValueError(
                f"Nuisances.jpeg_quality must be None or an integer in [1, 100]; got {self.jpeg_quality!r}"
            )
        if self.floor is not None and not 0 <= self.floor <= 255:
            raise ValueError(f"Nuisances.floor must be None or a grey level in [0, 255]; got {self.floor!r}")
        if not 0 < self.floor_level < 1:
            raise ValueError(f"Nuisances.floor_level must lie in (0, 1); got {self.floor_level!r}")
        occ = self.occlusion
        if occ is not None and (len(occ) != 4 or min(occ[:3]) < 0 or not 0 < occ[3] < 1 or occ[2] < 1):
            raise ValueError(
                f"Nuisances.occlusion must be (marker >= 0, first >= 0, n >= 1, 0 < fraction < 1); got {occ!r}"
            )

    @classmethod
    def random(cls, seed: int, n_frames: int, n_markers: int, strength: float = 1.0) -> Nuisances:
        """Every nuisance at once, with magnitudes drawn at random (reproducibly from ``seed``).

        ``strength`` scales the photometric ones.  Ranges: light falling by
        30-60 % across the image, 20-40 % vignetting, noise of 2-6 grey
        levels, an exposure of 30-100 % of the frame interval, JPEG quality
        60-90, clutter, a floor of grey 140-190 over the bottom 8-15 %, and
        30-60 % of one marker (not the base or the first) hidden for 3
        frames (fewer in recordings under 12 frames).
        """
        rng = np.random.default_rng(seed)
        n_occ = int(min(3, max(1, n_frames // 4)))  # a few frames
        return cls(
            lighting_gradient=strength * rng.uniform(0.3, 0.6),
            gradient_angle=rng.uniform(-np.pi, np.pi),
            vignetting=strength * rng.uniform(0.2, 0.4),
            noise=strength * rng.uniform(2.0, 6.0),
            motion_blur=rng.uniform(0.3, 1.0),
            jpeg_quality=int(rng.integers(60, 90)),
            clutter=True,
            floor=float(rng.uniform(140.0, 190.0)),
            floor_level=float(rng.uniform(0.85, 0.92)),
            occlusion=(
                int(rng.integers(2, n_markers + 1)),
                int(rng.integers(1, max(2, n_frames - n_occ))),
                n_occ,
                float(rng.uniform(0.3, 0.6)),
            ),
            seed=seed,
        )


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


def _subdivide(polygons: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Polygons (..., V, 2) with ``n`` vertices per edge, so a lens can bend the edges."""
    nxt = np.roll(polygons, -1, axis=-2)
    w = (np.arange(n) / n)[:, None]
    pts = polygons[..., :, None, :] * (1 - w) + nxt[..., :, None, :] * w
    return pts.reshape(*polygons.shape[:-2], -1, 2)


def _fixed(points: NDArray[np.float64]) -> NDArray[np.int32]:
    return np.ascontiguousarray(np.round(points * (1 << _SHIFT)), dtype=np.int32)


def _draw_polygon(
    img: NDArray[np.uint8], poly: NDArray[np.float64], colour: tuple, S: int, outline: float | None
) -> None:
    """Draw one polygon (pixel vertices) with exact area anti-aliasing on a patch supersampled S times.

    Patches start from the current image, so overlaps compose in order
    (OpenCV's LINE_AA fill is not sub-pixel in v, which would bias centroids).
    """
    height, width = img.shape[:2]
    margin = 2.0 + (outline or 0.0)
    lo = np.floor(poly.min(axis=0) - margin).astype(int)
    hi = np.ceil(poly.max(axis=0) + margin).astype(int) + 1
    x0, y0 = max(lo[0], 0), max(lo[1], 0)
    x1, y1 = min(hi[0], width), min(hi[1], height)
    if x1 <= x0 or y1 <= y0:
        return  # outside the image
    patch = img[y0:y1, x0:x1]
    big = cv2.resize(patch, ((x1 - x0) * S, (y1 - y0) * S), interpolation=cv2.INTER_NEAREST)
    # low-res pixel centre p -> high-res coordinate (p + 0.5) S - 0.5
    pts = _fixed((poly - np.array([x0, y0], dtype=float) + 0.5) * S - 0.5).reshape(-1, 1, 2)
    if outline is None:
        cv2.fillPoly(big, [pts], colour, cv2.LINE_8, _SHIFT)
    else:
        cv2.polylines(big, [pts], True, colour, max(1, int(round(outline * S))), cv2.LINE_8, _SHIFT)
    patch[...] = cv2.resize(big, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA).reshape(patch.shape)


def _scene(
    camera: Camera, shape: tuple[int, ...], bg: tuple, nz: Nuisances | None, base_px: NDArray, marker_px: float
) -> NDArray[np.uint8]:
    """The static background: plain, or with a floor and clutter."""
    img = np.empty(shape, dtype=np.uint8)
    img[...] = np.round(bg if len(shape) == 3 else bg[0]).astype(np.uint8)
    if nz is None:
        return img
    height, width = shape[:2]
    rng = np.random.default_rng([nz.seed, 1])
    dark = (40,) * (3 if len(shape) == 3 else 1)
    if nz.floor is not None:
        top = int(round(nz.floor_level * height))
        img[top:] = np.uint8(round(nz.floor))
    if nz.clutter:
        u, v = base_px
        # a clamp bar above the base with a gap of two marker widths, a tray in a bottom corner,
        # a printed label on the other side, two cables hanging from the top corners
        bar_h = max(4, int(0.6 * marker_px))
        bar_bottom = int(v - 2.0 * marker_px)
        cv2.rectangle(img, (int(u - 3 * marker_px), bar_bottom - bar_h), (int(u + 3 * marker_px), bar_bottom), dark, -1)
        side = rng.choice([-1, 1])
        tx = int(width * (0.04 if side < 0 else 0.70))
        cv2.rectangle(
            img, (tx, int(0.78 * height)), (tx + int(0.26 * width), height - 3), dark, max(2, int(marker_px / 6))
        )
        text_x = int(width * (0.72 if side < 0 else 0.03))
        scale = 0.35 * marker_px / 8.0 + 0.2
        thick = max(1, int(round(marker_px / 12)))
        label = f"RUN {int(rng.integers(1, 99)):02d} - soft arm"
        cv2.putText(img, label, (text_x, int(0.12 * height)), cv2.FONT_HERSHEY_SIMPLEX, scale, dark, thick, cv2.LINE_AA)
        cv2.putText(
            img,
            "t = 0.5 s  E = 10 kPa",
            (text_x, int(0.12 * height + 3.5 * marker_px)),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.8 * scale,
            dark,
            thick,
            cv2.LINE_AA,
        )
        for x_start in (rng.uniform(0.0, 0.12), rng.uniform(0.88, 1.0)):
            xs = x_start * width + np.cumsum(rng.normal(0.0, 0.01 * width, 8))
            ys = np.linspace(0.0, 0.3 * height, 8)
            cv2.polylines(
                img, [_fixed(np.column_stack([xs, ys])).reshape(-1, 1, 2)], False, dark, 2, cv2.LINE_AA, _SHIFT
            )
    return img


def _illumination(shape: tuple[int, int], nz: Nuisances) -> NDArray[np.float32]:
    height, width = shape
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    cu, cv_ = 0.5 * (width - 1), 0.5 * (height - 1)
    along = ((u - cu) * np.cos(nz.gradient_angle) + (v - cv_) * np.sin(nz.gradient_angle)) / np.hypot(cu, cv_)
    light = 1.0 - 0.5 * nz.lighting_gradient * along
    r2 = ((u - cu) ** 2 + (v - cv_) ** 2) / (cu**2 + cv_**2)
    return (light * (1.0 - nz.vignetting * r2)).astype(np.float32)


def _degrade(
    img: NDArray[np.uint8], light: NDArray[np.float32] | None, nz: Nuisances, rng: np.random.Generator
) -> NDArray[np.uint8]:
    out = img.astype(np.float32)
    if light is not None:
        out *= light if img.ndim == 2 else light[..., None]
    if nz.noise > 0:
        out += rng.normal(0.0, nz.noise, out.shape).astype(np.float32)
    out = np.clip(np.round(out), 0, 255).astype(np.uint8)
    if nz.jpeg_quality is not None:
        ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(nz.jpeg_quality)])
        out = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
    return out


def _sub_frame_poses(poses: NDArray[np.float64], exposure: float) -> NDArray[np.float64]:
    """Poses (T, B, N + 1, 3) at B instants spread over the exposure centred on each frame."""
    T = poses.shape[0]
    times = np.arange(T)[:, None] + exposure * (np.linspace(0.0, 1.0, _BLUR_SAMPLES) - 0.5)[None, :]
    times = np.clip(times, 0, T - 1)
    lo = np.floor(times).astype(int)
    hi = np.minimum(lo + 1, T - 1)
    w = (times - lo)[..., None, None]
    return poses[lo] * (1 - w) + poses[hi] * w


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
        raise ValueError(f"camera must be a pcs_sindy.camera.Camera; got {type(camera).__name__}")
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
    sub = _sub_frame_poses(poses, nz.motion_blur) if blur else poses[:, None]  # (T, B, N + 1, 3)
    # OpenCV fills a polygon's boundary pixels too, which widens a filled
    # rectangle by one canvas pixel: shrink it by that much so areas are exact
    grow = -1.0 / supersample if marker_style == "filled" else 0.0
    rect = camera.to_rectified(sub)
    corners = marker_corners(rect, w_px + grow, t_px + grow)  # (T, B, N + 1, 4, 2), rectified pixels
    if camera.has_lens:
        corners = camera.unrectify(_subdivide(corners, _EDGE_POINTS))
    body_pts = backbone[:, None] if backbone is not None else camera.unrectify(rect[..., :2])
    body_thick = max(1, int(round(body_width * ppm)))
    shape = (height, width, 3) if colour else (height, width)
    scene = _scene(camera, shape, bg, nz, camera.to_pixels(np.zeros(2)), t_px)
    light = _illumination((height, width), nz) if nz is not None and (nz.lighting_gradient or nz.vignetting) else None
    occ = nz.occlusion if nz is not None else None
    out = np.empty((T, *shape), dtype=np.uint8)
    for k in tqdm(range(T), desc="render", unit="frame", disable=not progress):
        acc = None
        for b in range(sub.shape[1]):
            img = scene.copy()
            if draw_body:
                pts = body_pts[k, 0 if backbone is not None else b]
                cv2.polylines(img, [_fixed(pts).reshape(-1, 1, 2)], False, bc, body_thick, cv2.LINE_AA, _SHIFT)
            for c in corners[k, b]:
                _draw_polygon(img, c, fg, supersample, None if marker_style == "filled" else line)
            acc = img.astype(np.float32) if acc is None else acc + img
        img = np.round(acc / sub.shape[1]).astype(np.uint8) if sub.shape[1] > 1 else acc.astype(np.uint8)
        if occ is not None and occ[1] <= first_frame + k < occ[1] + occ[2] and occ[0] < poses.shape[1]:
            # a finger reaching over one end of the marker, covering a fraction of its width
            u, v, phi = camera.to_rectified(poses[k, occ[0]])
            axis = np.array([np.cos(phi), np.sin(phi)])
            thick = max(2, int(round(2.5 * t_px)))
            tip = np.array([u, v]) + axis * (w_px * (0.5 - occ[3]) + 0.5 * thick)  # the line's round cap
            pts = camera.unrectify(np.stack([tip, tip + axis * 4 * w_px]))
            skin = (150, 170, 200) if colour else (175,)
            cv2.line(img, tuple(_fixed(pts[0])), tuple(_fixed(pts[1])), skin, thick, cv2.LINE_AA, _SHIFT)
        if nz is not None:
            img = _degrade(img, light, nz, np.random.default_rng([nz.seed, first_frame + k]))
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
        ``*.mp4`` (codec ``mp4v``) or ``*.avi`` (``MJPG``) for a video; a path
        without suffix is a folder that receives ``frame_000000.png``, ...
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
    if suffix and suffix not in _VIDEO_CODECS:
        raise ValueError(f"path must end in .mp4 or .avi, or have no suffix (PNG folder); got {str(path)!r}")
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
        fourcc = cv2.VideoWriter_fourcc(*(codec or _VIDEO_CODECS[suffix]))
        writer = cv2.VideoWriter(str(path), fourcc, float(fps), (width, height), True)
        if not writer.isOpened():
            raise OSError(
                f"OpenCV cannot open a video writer for path={str(path)!r} (codec {codec or _VIDEO_CODECS[suffix]})"
            )
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


def render_checkerboard(
    camera_matrix: ArrayLike,
    dist_coeffs: ArrayLike | None,
    rvec: ArrayLike,
    tvec: ArrayLike,
    image_size: tuple[int, int],
    *,
    pattern: tuple[int, int] = (9, 6),
    square: float = 0.01,
    supersample: int = 8,
) -> NDArray[np.uint8]:
    """A grey image of a checkerboard seen through a pinhole camera with lens distortion.

    Parameters
    ----------
    camera_matrix, dist_coeffs
        OpenCV's intrinsics and distortion coefficients.
    rvec, tvec
        Pose of the board in the camera's coordinates (Rodrigues vector,
        metres); the board's corner ``(0, 0)`` is its first inner corner and
        its squares run along +x and +y (``cv2.findChessboardCorners``'s object points).
    image_size : (width, height)
    pattern : (columns, rows)
        Inner corners, as ``cv2.findChessboardCorners`` takes them.
    square : float
        Side of a square in metres.
    supersample : int
        Anti-aliasing factor.

    Returns
    -------
    ndarray of uint8, shape (height, width)
        White paper (one square of margin) with black squares on a mid-grey background.
    """
    K = np.asarray(camera_matrix, dtype=float)
    dist = np.zeros(5) if dist_coeffs is None else np.asarray(dist_coeffs, dtype=float)
    cols, rows = (int(v) for v in pattern)
    if cols < 2 or rows < 2:
        raise ValueError(f"pattern must have at least 2 x 2 inner corners; got {pattern!r}")
    if not np.isfinite(square) or square <= 0:
        raise ValueError(f"square must be > 0; got {square!r}")
    width, height = (int(v) for v in image_size)
    S = int(supersample)

    def project(poly: NDArray[np.float64]) -> NDArray[np.float64]:
        pts = _subdivide(poly, 16)
        obj = np.column_stack([pts, np.zeros(len(pts))])
        img, _ = cv2.projectPoints(obj, np.asarray(rvec, float), np.asarray(tvec, float), K, dist)
        return img.reshape(-1, 2)

    big = np.full((height * S, width * S), 128, np.uint8)

    def fill(poly: NDArray[np.float64], value: int) -> None:
        pts = _fixed((project(poly) + 0.5) * S - 0.5).reshape(-1, 1, 2)
        cv2.fillPoly(big, [pts], value, cv2.LINE_8, _SHIFT)

    # OpenCV fills a polygon's boundary pixels too: shrink each square by one canvas pixel's worth
    # (in board units at this view's scale) so that the black and white areas are exact
    paper = project(square * np.array([[0.0, 0.0], [cols - 1.0, 0.0]]))
    shrink = 0.5 / S * square * (cols - 1) / max(float(np.linalg.norm(paper[-1] - paper[0])), 1e-9)
    fill(square * np.array([[-2, -2], [cols + 1, -2], [cols + 1, rows + 1], [-2, rows + 1]], float), 235)
    # squares (i, j) span [i - 1, i] x [j - 1, j] squares from the first inner corner
    for i in range(cols + 1):
        for j in range(rows + 1):
            if (i + j) % 2 == 0:
                sq = square * np.array([[i - 1, j - 1], [i, j - 1], [i, j], [i - 1, j]], float)
                fill(sq + shrink * np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]), 20)
    return cv2.resize(big, (width, height), interpolation=cv2.INTER_AREA)
