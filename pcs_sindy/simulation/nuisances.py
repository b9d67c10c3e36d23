"""What makes real footage harder than a clean rendering, and how it is drawn into the frames.

:class:`Nuisances` describes the degradations (uneven light, vignetting,
sensor noise, motion blur, JPEG compression, a floor, clutter and printed
text, a lit backdrop's edge, a marker partly covered for a few frames), so that extraction is tested
on footage it was not tuned to; the private helpers below draw them for
:func:`pcs_sindy.simulation.rendering.render_frames`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.camera import Camera
from ..core.optional import require
from ._drawing import SHIFT, fixed_point

cv2 = require("cv2", "degrading footage (pcs_sindy.simulation.nuisances)")

__all__ = ["Nuisances"]

_BLUR_SAMPLES = 5  # sub-frame renders averaged for motion blur


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
    backdrop : float, optional
        Grey level (0-255) of a brightly lit backdrop filling the image right
        of ``backdrop_edge`` (a wall or screen edge the robot swings across).
    backdrop_edge : float
        Left edge of the backdrop as a fraction of the image width.
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
    backdrop: float | None = None
    backdrop_edge: float = 0.5
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
        if self.backdrop is not None and not 0 <= self.backdrop <= 255:
            raise ValueError(f"Nuisances.backdrop must be None or a grey level in [0, 255]; got {self.backdrop!r}")
        if not 0 < self.backdrop_edge < 1:
            raise ValueError(f"Nuisances.backdrop_edge must lie in (0, 1); got {self.backdrop_edge!r}")
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


def draw_scene(
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
    if nz.backdrop is not None:
        img[:, int(round(nz.backdrop_edge * width)) :] = np.uint8(round(nz.backdrop))
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
                img, [fixed_point(np.column_stack([xs, ys])).reshape(-1, 1, 2)], False, dark, 2, cv2.LINE_AA, SHIFT
            )
    return img


def illumination(shape: tuple[int, int], nz: Nuisances) -> NDArray[np.float32]:
    height, width = shape
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    cu, cv_ = 0.5 * (width - 1), 0.5 * (height - 1)
    along = ((u - cu) * np.cos(nz.gradient_angle) + (v - cv_) * np.sin(nz.gradient_angle)) / np.hypot(cu, cv_)
    light = 1.0 - 0.5 * nz.lighting_gradient * along
    r2 = ((u - cu) ** 2 + (v - cv_) ** 2) / (cu**2 + cv_**2)
    return (light * (1.0 - nz.vignetting * r2)).astype(np.float32)


def degrade(
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


def sub_frame_poses(poses: NDArray[np.float64], exposure: float) -> NDArray[np.float64]:
    """Poses (T, B, N + 1, 3) at B instants spread over the exposure centred on each frame."""
    T = poses.shape[0]
    times = np.arange(T)[:, None] + exposure * (np.linspace(0.0, 1.0, _BLUR_SAMPLES) - 0.5)[None, :]
    times = np.clip(times, 0, T - 1)
    lo = np.floor(times).astype(int)
    hi = np.minimum(lo + 1, T - 1)
    w = (times - lo)[..., None, None]
    return poses[lo] * (1 - w) + poses[hi] * w


def occlude(
    img: NDArray[np.uint8],
    camera: Camera,
    pose: NDArray[np.float64],
    fraction: float,
    w_px: float,
    t_px: float,
    colour: bool,
) -> None:
    """A finger reaching over one end of the marker at ``pose``, covering ``fraction`` of its width (in place)."""
    u, v, phi = camera.to_rectified(pose)
    axis = np.array([np.cos(phi), np.sin(phi)])
    thick = max(2, int(round(2.5 * t_px)))
    tip = np.array([u, v]) + axis * (w_px * (0.5 - fraction) + 0.5 * thick)  # the line's round cap
    pts = camera.unrectify(np.stack([tip, tip + axis * 4 * w_px]))
    skin = (150, 170, 200) if colour else (175,)
    cv2.line(img, tuple(fixed_point(pts[0])), tuple(fixed_point(pts[1])), skin, thick, cv2.LINE_AA, SHIFT)
