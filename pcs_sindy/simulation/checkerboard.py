"""Calibration boards rendered through a pinhole camera with lens distortion."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.optional import require
from ._drawing import SHIFT, fixed_point, subdivide

cv2 = require("cv2", "drawing checkerboards (pcs_sindy.simulation.checkerboard)")

__all__ = ["render_checkerboard"]


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
        pts = subdivide(poly, 16)
        obj = np.column_stack([pts, np.zeros(len(pts))])
        img, _ = cv2.projectPoints(obj, np.asarray(rvec, float), np.asarray(tvec, float), K, dist)
        return img.reshape(-1, 2)

    big = np.full((height * S, width * S), 128, np.uint8)

    def fill(poly: NDArray[np.float64], value: int) -> None:
        pts = fixed_point((project(poly) + 0.5) * S - 0.5).reshape(-1, 1, 2)
        cv2.fillPoly(big, [pts], value, cv2.LINE_8, SHIFT)

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
