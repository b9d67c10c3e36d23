"""Sub-pixel drawing primitives shared by the renderers (OpenCV with fractional vertex coordinates)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..core.optional import require

cv2 = require("cv2", "drawing marker images (pcs_sindy.simulation)")

SHIFT = 8  # fractional bits of the vertex coordinates passed to OpenCV


def subdivide(polygons: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Polygons (..., V, 2) with ``n`` vertices per edge, so a lens can bend the edges."""
    nxt = np.roll(polygons, -1, axis=-2)
    w = (np.arange(n) / n)[:, None]
    pts = polygons[..., :, None, :] * (1 - w) + nxt[..., :, None, :] * w
    return pts.reshape(*polygons.shape[:-2], -1, 2)


def fixed_point(points: NDArray[np.float64]) -> NDArray[np.int32]:
    return np.ascontiguousarray(np.round(points * (1 << SHIFT)), dtype=np.int32)


def draw_polygon(
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
    pts = fixed_point((poly - np.array([x0, y0], dtype=float) + 0.5) * S - 0.5).reshape(-1, 1, 2)
    if outline is None:
        cv2.fillPoly(big, [pts], colour, cv2.LINE_8, SHIFT)
    else:
        cv2.polylines(big, [pts], True, colour, max(1, int(round(outline * S))), cv2.LINE_8, SHIFT)
    patch[...] = cv2.resize(big, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA).reshape(patch.shape)
