"""Ways of telling marker pixels from everything else in a frame.

Each :class:`Thresholder` is prepared once per recording on its reference
frame, then turns every frame into a binary mask of candidate marker pixels
and, for sub-pixel refinement, a per-pixel *coverage* (the share of each
pixel covered by marker, 0 to 1) around any component.

* :class:`OtsuThresholder` - one grey level per frame (Otsu's method), or a
  fixed level given by the user: right for evenly lit footage.
* :class:`LocalThresholder` - the reflectance ratio ``grey / background``,
  where the background is the reference frame with every thin dark structure
  closed away (grey-level morphological closing).  Lighting gradients and
  vignetting divide out; a floor, a tray or a bar wider than the closing
  kernel becomes background, so markers touching it stay separate.
* :class:`ColourThresholder` - the projection of each pixel on the chroma of
  the dominant saturated colour of the reference frame: coloured markers on
  grey floors, white backgrounds and grey clutter.
* :class:`RangeThresholder` - a user-given ``cv2.inRange`` colour range.

:func:`candidate_thresholders` lists the automatic candidates for a frame;
the extractor keeps the one whose components form the marker chain.
Knows nothing of markers' geometry or of dynamics.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Thresholder",
    "OtsuThresholder",
    "LocalThresholder",
    "ColourThresholder",
    "RangeThresholder",
    "candidate_thresholders",
    "is_colour",
]

_KERNEL = np.ones((3, 3), np.uint8)


def _histogram(image: NDArray[np.uint8]) -> NDArray[np.float64]:
    """256-bin histogram of a regular subsample of about 80 000 pixels (the same levels, far less memory traffic)."""
    step = max(1, int(np.sqrt(image.shape[0] * image.shape[1] / 80_000)))
    sub = np.ascontiguousarray(image[::step, ::step]) if step > 1 else image
    return cv2.calcHist([sub], [0], None, [256], [0, 256]).ravel().astype(float)


def otsu_level(hist: NDArray[np.float64]) -> float:
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


def _class_means(hist: NDArray[np.float64], level: float) -> tuple[float, float]:
    g = np.arange(256.0)
    dark = g <= level
    n_dark, n_light = hist[dark].sum(), hist[~dark].sum()
    fg = float(hist[dark] @ g[dark] / n_dark) if n_dark else 0.0
    bg = float(hist[~dark] @ g[~dark] / n_light) if n_light else 255.0
    return fg, bg


def is_colour(frame: NDArray[np.uint8]) -> bool:
    """True for a BGR frame with saturated pixels (a grey video stored as BGR is not colour)."""
    if frame.ndim != 3:
        return False
    sub = frame[::2, ::2].astype(np.int16)
    chroma = sub.max(axis=2) - sub.min(axis=2)
    return bool(np.count_nonzero(chroma > 40) > 20)


def _dark_coverage(
    grey: NDArray[np.uint8], bg: NDArray | float, fg: NDArray | float, y0: int, y1: int, x0: int, x1: int
) -> NDArray[np.float32]:
    """Marker share of dark-marker pixels measured against the local background.

    Anti-aliased edge pixels mix marker and background linearly.  The local
    background is the brightest pixel nearby (so that a lighter robot body
    next to a marker counts as background, not as a faint part of the marker)
    unless that is itself dark, then the expected background.
    """
    patch = grey[y0:y1, x0:x1].astype(np.float32)
    local = cv2.dilate(patch, _KERNEL)
    if np.ndim(bg):
        b = bg[y0:y1, x0:x1]
        f = fg[y0:y1, x0:x1]
    else:
        b, f = np.float32(bg), np.float32(fg)
    local = np.where(local < 0.5 * (b + f), b, local)
    return np.clip((local - patch) / np.maximum(local - f, 1.0), 0.0, 1.0)


class Thresholder:
    """Base class: ``prepare`` on the reference frame, then ``binary`` and ``coverage`` per frame."""

    name = "threshold"
    needs_colour = False

    def prepare(self, frame: NDArray[np.uint8]) -> Thresholder:
        return self

    def work(self, frame: NDArray[np.uint8]) -> Any:
        """Per-frame state (the working image and levels) shared by ``binary`` and ``coverage``."""
        raise NotImplementedError

    def binary(self, work: Any) -> NDArray[np.uint8]:
        raise NotImplementedError

    def coverage(self, work: Any, y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        raise NotImplementedError

    def describe(self) -> str:
        return self.name


def _grey_of(frame: NDArray[np.uint8], invert: bool) -> NDArray[np.uint8]:
    grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    return cv2.bitwise_not(grey) if invert else grey


class OtsuThresholder(Thresholder):
    """Dark (or, with ``polarity="bright"``, light) markers below one grey level.

    Parameters
    ----------
    level : float, optional
        Fixed grey level (markers at or below it; at or above it for bright
        markers); default Otsu's level of every frame.
    polarity : {"dark", "bright"}
    blur : int
        Odd Gaussian kernel applied before thresholding (0: none); coverage
        is measured on the unblurred image.
    """

    def __init__(self, level: float | None = None, polarity: str = "dark", blur: int = 0) -> None:
        self.level = level
        self.polarity = polarity
        self.blur = blur
        self.name = "otsu" if level is None else f"fixed grey level {level:g}"

    def work(self, frame: NDArray[np.uint8]) -> tuple:
        grey = _grey_of(frame, self.polarity == "bright")
        src = cv2.GaussianBlur(grey, (self.blur, self.blur), 0) if self.blur else grey
        hist = _histogram(src)
        if self.level is None:
            level = otsu_level(hist)
        else:  # markers are the pixels darker (brighter) than the given level
            level = float(self.level) if self.polarity == "dark" else 255.0 - float(self.level) - 1e-9
        if src is not grey:
            hist = _histogram(grey)
        fg, bg = _class_means(hist, level)
        return grey, src, level, fg, bg

    def binary(self, work: tuple) -> NDArray[np.uint8]:
        _, src, level, _, _ = work
        return cv2.threshold(src, level, 255, cv2.THRESH_BINARY_INV)[1]

    def coverage(self, work: tuple, y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        grey, _, _, fg, bg = work
        return _dark_coverage(grey, bg, fg, y0, y1, x0, x1)


class LocalThresholder(Thresholder):
    """Markers darker than a fraction of the local background (lighting divided out).

    Parameters
    ----------
    polarity : {"dark", "bright"}
        Bright markers are handled on the inverted image.
    kernel : int, optional
        Side of the closing kernel in pixels; default 1/16 of the smaller
        image side (wider than any marker, narrower than a floor or a tray).
    """

    name = "local"

    def __init__(self, polarity: str = "dark", kernel: int | None = None) -> None:
        self.polarity = polarity
        self.kernel = kernel

    def prepare(self, frame: NDArray[np.uint8]) -> LocalThresholder:
        grey = _grey_of(frame, self.polarity == "bright")
        h, w = grey.shape
        k = self.kernel or max(7, min(h, w) // 16)
        k += 1 - k % 2
        # closing removes every dark structure narrower than the kernel: markers, text, cables, the
        # robot's body; what stays is the lit background, a floor, a tray
        background = cv2.morphologyEx(grey, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))
        bg = np.maximum(background.astype(np.float32), 8.0)
        ratio = np.clip(255.0 * grey / bg, 0, 255).astype(np.uint8)
        hist = _histogram(ratio)
        # the bright background dominates the histogram: split what is clearly darker than it, and put
        # the threshold halfway between the markers' ratio and the background's (1); a lighter robot body
        # or a shadow stays above it
        dark = hist.copy()
        dark[int(0.9 * 255) :] = 0.0
        fg, _ = _class_means(dark, otsu_level(dark))
        level = min(0.5 * (fg + 255.0), 0.8 * 255.0)
        self.kernel_used_ = k
        self.ratio_ = level / 255.0
        self.background_ = bg
        self.foreground_ = bg * np.float32(fg / 255.0)
        self.threshold_map_ = np.clip(np.floor(bg * self.ratio_), 0, 255).astype(np.uint8)
        return self

    def work(self, frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
        return _grey_of(frame, self.polarity == "bright")

    def binary(self, grey: NDArray[np.uint8]) -> NDArray[np.uint8]:
        return cv2.compare(grey, self.threshold_map_, cv2.CMP_LE)

    def coverage(self, grey: NDArray[np.uint8], y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        return _dark_coverage(grey, self.background_, self.foreground_, y0, y1, x0, x1)

    def describe(self) -> str:
        return f"local (closing {self.kernel_used_} px, markers below {self.ratio_:.2f} of the local background)"


class ColourThresholder(Thresholder):
    """Pixels whose chroma points the way of the dominant saturated colour.

    ``prepare`` finds the marker colour: the hue that carries most chroma in
    the reference frame.  Every pixel's score is its BGR vector projected on
    that colour's chroma direction (zero for any grey, negative for other hues).
    """

    name = "colour"
    needs_colour = True

    def prepare(self, frame: NDArray[np.uint8]) -> ColourThresholder:
        if frame.ndim != 3:
            raise ValueError("colour thresholding needs BGR frames")
        sub = np.ascontiguousarray(frame[::2, ::2])
        hsv = cv2.cvtColor(sub, cv2.COLOR_BGR2HSV)
        px = sub.reshape(-1, 3).astype(np.float32)
        chroma = px.max(axis=1) - px.min(axis=1)
        strong = chroma > max(40.0, 0.5 * float(np.percentile(chroma, 99.9)))
        hue = hsv.reshape(-1, 3)[:, 0].astype(int)
        weights = np.bincount(hue[strong], weights=chroma[strong] ** 2, minlength=180)
        weights = np.convolve(np.concatenate([weights[-3:], weights, weights[:3]]), np.ones(7), "valid")
        top = int(np.argmax(weights))
        near = strong & (np.abs((hue - top + 90) % 180 - 90) <= 6)
        colour = np.median(px[near], axis=0) if np.any(near) else px[strong].mean(axis=0)
        direction = colour - colour.mean()
        norm = float(np.linalg.norm(direction))
        if norm < 20.0:
            raise ValueError("no saturated marker colour in the reference frame")
        self.marker_colour_ = tuple(float(v) for v in colour)
        self.direction_ = (direction / norm).reshape(1, 3).astype(np.float32)
        score = cv2.transform(frame, self.direction_)
        full = (
            float(np.percentile(score[::2, ::2][score[::2, ::2] > 0.5 * norm], 90))
            if np.any(score > 0.5 * norm)
            else norm
        )
        self.full_score_ = max(full, 1.0)
        self.level_ = 0.5 * self.full_score_
        return self

    def work(self, frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
        if frame.ndim != 3:
            raise ValueError("colour thresholding needs BGR frames")
        return cv2.transform(frame, self.direction_)  # saturates: other hues score 0

    def binary(self, score: NDArray[np.uint8]) -> NDArray[np.uint8]:
        return cv2.threshold(score, self.level_, 255, cv2.THRESH_BINARY)[1]

    def coverage(self, score: NDArray[np.uint8], y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        return np.clip(score[y0:y1, x0:x1].astype(np.float32) / np.float32(self.full_score_), 0.0, 1.0)

    def describe(self) -> str:
        b, g, r = (int(round(v)) for v in self.marker_colour_)
        return f"colour (markers near BGR ({b}, {g}, {r}))"


class RangeThresholder(Thresholder):
    """A user-given colour or grey range for ``cv2.inRange``.

    Edge pixels are weighted by their mix of the mean marker and background
    colours (projection on the colour difference).
    """

    def __init__(self, lower: Any, upper: Any) -> None:
        self.lower = np.atleast_1d(np.asarray(lower, dtype=float))
        self.upper = np.atleast_1d(np.asarray(upper, dtype=float))
        self.name = f"colour range {self.lower.tolist()}..{self.upper.tolist()}"
        self.needs_colour = self.lower.size == 3

    def work(self, frame: NDArray[np.uint8]) -> tuple:
        img = frame
        if frame.ndim == 3 and (self.lower.size == 1 or frame.shape[2] != 3):
            img = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        lo = self.lower if self.lower.size > 1 else float(self.lower[0])
        hi = self.upper if self.upper.size > 1 else float(self.upper[0])
        binary = cv2.inRange(img, lo, hi)
        return img, binary, _coverage_image(img, binary)

    def binary(self, work: tuple) -> NDArray[np.uint8]:
        return work[1]

    def coverage(self, work: tuple, y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        _, binary, cov = work
        if cov is None:
            return (binary[y0:y1, x0:x1] > 0).astype(np.float32)
        return _dark_coverage(cov, 255.0, 0.0, y0, y1, x0, x1)


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
    return cv2.transform(img if img.ndim == 3 else img[..., None], m)


def candidate_thresholders(frame: NDArray[np.uint8], polarity: str = "dark", blur: int = 0) -> list[Thresholder]:
    """The automatic candidates for a recording whose reference frame is ``frame``, prepared."""
    out: list[Thresholder] = [OtsuThresholder(None, polarity, blur), LocalThresholder(polarity)]
    if is_colour(frame):
        out.append(ColourThresholder())
    prepared = []
    for seg in out:
        try:
            prepared.append(seg.prepare(frame))
        except ValueError:
            continue  # e.g. no saturated colour after all
    return prepared
