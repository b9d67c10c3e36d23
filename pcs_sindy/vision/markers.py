"""Candidate markers of one frame: components of a binary mask, refined to sub-pixel.

A frame goes through a :class:`~pcs_sindy.vision.thresholding.Thresholder`
(binary mask + per-pixel coverage), ``cv2.findContours`` finds its
components, their areas and bounding boxes are computed for all of them at
once (one numpy pass over the concatenated contours, so clutter and specks
of noise cost almost nothing), and only the plausible ones are refined: the
centre, the long axis and the size come from the coverage-weighted moments of
the component and a one-pixel ring around it (anti-aliased edges carry their
area coverage, so centres are sub-pixel and motion blur, which conserves the
total darkness, does not change the measured area).

Knows nothing of the robot's geometry or of dynamics.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from .thresholding import OtsuThresholder, RangeThresholder, Thresholder

__all__ = [
    "Components",
    "find_components",
    "measure_components",
    "detect_markers",
    "U",
    "V",
    "AXIS",
    "AREA",
    "LONG",
    "SHORT",
    "PIXELS",
]

# columns of a candidate table
U, V, AXIS, AREA, LONG, SHORT, PIXELS = range(7)
N_FEATURES = 7
_KERNEL = np.ones((3, 3), np.uint8)


class Components(NamedTuple):
    """Every component of a binary mask (external contours)."""

    contours: tuple
    area: NDArray[np.float64]
    """Pixels covered (polygon area plus half a pixel all round)."""
    box: NDArray[np.int64]
    """``(x, y, width, height)`` of each bounding box."""
    centre: NDArray[np.float64]
    """Centre of each bounding box (cheap; for matching, not for measuring)."""


def find_components(binary: NDArray[np.uint8]) -> Components:
    """Contours of a binary mask with their areas and bounding boxes, computed for all at once."""
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        return Components((), np.zeros(0), np.zeros((0, 4), np.int64), np.zeros((0, 2)))
    lens = np.fromiter((len(c) for c in contours), dtype=np.int64, count=len(contours))
    pts = np.concatenate(contours).reshape(-1, 2).astype(np.float64)
    start = np.concatenate([[0], np.cumsum(lens)[:-1]])
    nxt = np.arange(1, len(pts) + 1)
    nxt[start + lens - 1] = start
    x, y = pts[:, 0], pts[:, 1]
    cross = np.add.reduceat(x * y[nxt] - x[nxt] * y, start)
    perimeter = np.add.reduceat(np.hypot(x[nxt] - x, y[nxt] - y), start)
    # the contour runs through the centres of the boundary pixels: add half a
    # pixel all round so thin markers get their pixel area
    area = 0.5 * np.abs(cross) + 0.5 * perimeter + 1.0
    lo = np.stack([np.minimum.reduceat(x, start), np.minimum.reduceat(y, start)], axis=1)
    hi = np.stack([np.maximum.reduceat(x, start), np.maximum.reduceat(y, start)], axis=1)
    box = np.concatenate([lo, hi - lo + 1], axis=1).astype(np.int64)
    return Components(tuple(contours), area, box, 0.5 * (lo + hi))


def measure_components(
    seg: Thresholder,
    work: Any,
    comps: Components,
    which: NDArray[np.intp],
    shape: tuple[int, int],
    offset: tuple[int, int] = (0, 0),
) -> NDArray[np.float64]:
    """Sub-pixel measurements of the components ``which``: a candidate table (K, 7).

    Columns ``u, v`` (coverage-weighted centre), ``axis`` (long axis modulo
    pi from the weighted second moments; the bounding box's when the shape
    is too round to have one), ``area`` (summed coverage), ``long``,
    ``short`` (sides of the rectangle with the same second moments) and
    ``pixels`` (binary area).
    """
    H, W = shape
    out = np.empty((len(which), N_FEATURES))
    for row, i in enumerate(which):
        bx, by, bw, bh = comps.box[i]
        x0, y0 = max(bx - 2, 0), max(by - 2, 0)
        x1, y1 = min(bx + bw + 2, W), min(by + bh + 2, H)
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        # one contour passed alone: OpenCV converts every contour of the list it is given on each call
        cv2.drawContours(mask, (comps.contours[i],), 0, 1, thickness=cv2.FILLED, offset=(-x0, -y0))
        wgt = seg.coverage(work, y0, y1, x0, x1) * cv2.dilate(mask, _KERNEL)
        m = cv2.moments(wgt)
        m00 = m["m00"]
        if m00 <= 1e-9:
            u, v, axis, long_, short = (
                bx + 0.5 * (bw - 1),
                by + 0.5 * (bh - 1),
                0.0,
                float(max(bw, bh)),
                float(min(bw, bh)),
            )
        else:
            u, v = x0 + m["m10"] / m00, y0 + m["m01"] / m00
            a, b, c = m["mu20"] / m00, m["mu11"] / m00, m["mu02"] / m00
            spread = np.hypot(2 * b, a - c)
            lam1, lam2 = 0.5 * (a + c + spread), max(0.5 * (a + c - spread), 0.0)
            axis = (0.5 * np.arctan2(2 * b, a - c)) % np.pi
            # a uniform rectangle of sides L, S has second moments L^2/12 and S^2/12
            long_, short = np.sqrt(12.0 * lam1), np.sqrt(12.0 * lam2)
        out[row] = (u + offset[0], v + offset[1], axis, m00, long_, short, comps.area[i])
    return out


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
    """Candidate marker components of one image with one thresholder.

    Parameters
    ----------
    frame : ndarray of uint8, (H, W) or (H, W, 3) BGR
    threshold : "otsu", float or (lower, upper)
        Otsu's grey level, a fixed grey level (markers at or below it, at or
        above it with ``polarity="bright"``), or a ``cv2.inRange`` range
        (grey levels or BGR triples).
    polarity : {"dark", "bright"}
    blur : int
        Odd Gaussian kernel applied before thresholding (0: none).
    roi : (x, y, width, height), optional
        Only this rectangle is searched; coordinates stay those of the frame.
    min_area : float
        Components smaller than this (pixels) are noise.
    refine : bool
        Coverage-weighted moments (sub-pixel); otherwise the moments of the binary component.
    name, index : str, int
        Accepted for compatibility (recording and frame of the image); unused.

    Returns
    -------
    ndarray, shape (K, 7)
        Columns ``u, v, axis, area, long, short, pixels`` (see :func:`measure_components`).
    """
    if isinstance(threshold, tuple):
        seg: Thresholder = RangeThresholder(*threshold)
    else:
        seg = OtsuThresholder(None if threshold == "otsu" else float(threshold), polarity, blur)
    x0 = y0 = 0
    if roi is not None:
        x0, y0, w, h = roi
        frame = frame[y0 : y0 + h, x0 : x0 + w]
    seg = seg.prepare(frame)
    work = seg.work(frame)
    binary = seg.binary(work)
    comps = find_components(binary)
    keep = np.flatnonzero(comps.area >= min_area)
    if not refine:
        seg = BinaryCoverage(binary)
        work = None
    return measure_components(seg, work, comps, keep, binary.shape, (x0, y0))


class BinaryCoverage(Thresholder):
    """Coverage = the binary mask itself (no sub-pixel weighting)."""

    name = "binary"

    def __init__(self, binary: NDArray[np.uint8]) -> None:
        self._binary = binary

    def coverage(self, work: Any, y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        # the dilated ring of the mask must not pick up a neighbour's pixels
        return (self._binary[y0:y1, x0:x1] > 0).astype(np.float32)
