"""Camera calibration from checkerboard views: lens distortion and the robot's plane.

:func:`calibrate_camera` finds the inner corners of a checkerboard in several
views (``cv2.findChessboardCornersSB``, sub-pixel), fits the pinhole
intrinsics and OpenCV's distortion coefficients (``cv2.calibrateCamera``),
and takes the view of the board lying in the robot's plane (``plane``) for
the plane-to-image homography.  The result is a
:class:`~pcs_sindy.core.camera.Camera` with a lens model whose base frame is left
open: the extractor finds the base marker and the rest direction in the
footage, so the board may lie anywhere in the robot's plane.  With fewer
than three views no distortion is fitted: the homography of the single plane
view (``cv2.findHomography``) still removes the perspective.

``pcs-sindy calibrate`` runs it on image files, folders and videos (:func:`read_views`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from ..core.camera import Camera, undistort_points
from .frame_source import IMAGE_SUFFIXES, FrameSource, check_frame_size, image_size

__all__ = ["calibrate_camera", "find_board", "read_views"]

_SUBPIX = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
_MIN_LENS_VIEWS = 3
#: the fewest pixels a checkerboard square may span in a view (a bound on the pattern's size)
_MIN_SQUARE_PX = 4


def _grey(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def find_board(image: NDArray[np.uint8], pattern: tuple[int, int]) -> NDArray[np.float64] | None:
    """Sub-pixel inner corners (cols * rows, 2) of a checkerboard, or None when it is not found.

    Corners are ordered row by row from the board's first inner corner, as
    ``cv2.findChessboardCorners`` returns them.
    """
    grey = _grey(np.asarray(image))
    # the classic detector refined by cornerSubPix is the less biased on sharp boards; the sector-based
    # detector finds boards the classic one misses (blur, uneven light)
    ok, corners = cv2.findChessboardCorners(
        grey, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    )
    if ok:
        corners = cv2.cornerSubPix(
            cv2.GaussianBlur(grey, (0, 0), 1.0), corners.astype(np.float32), (5, 5), (-1, -1), _SUBPIX
        )
    else:
        flags = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
        ok, corners = cv2.findChessboardCornersSB(grey, pattern, flags=flags)
        if not ok:
            return None
    return corners.reshape(-1, 2).astype(np.float64)


def _board_points(pattern: tuple[int, int], square: float) -> NDArray[np.float32]:
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * float(square)
    return np.column_stack([grid, np.zeros(len(grid))]).astype(np.float32)


def calibrate_camera(
    images: Sequence[NDArray[np.uint8]],
    pattern: tuple[int, int],
    square: float,
    *,
    plane: int = -1,
    names: Sequence[str] | None = None,
) -> tuple[Camera, dict[str, Any]]:
    """Lens and plane calibration from checkerboard views.

    Parameters
    ----------
    images : sequence of uint8 images
        Views of the same checkerboard, grey or BGR, all of one size; vary
        its position and tilt across the image for a good lens fit.
    pattern : (columns, rows)
        Inner corners of the board (a board of 10 x 7 squares has 9 x 6).
    square : float
        Side of one square in metres.
    plane : int
        Index of the view in which the board lies in the robot's plane (the
        plane the robot moves in); default the last one.
    names : sequence of str, optional
        Names of the views for messages (file names).

    Returns
    -------
    camera : Camera
        Intrinsics, distortion and the rectification of the robot's plane;
        origin and angle are None (found in the footage by the extractor).
    report : dict
        ``rms_reprojection_px`` (of the lens fit; None without one),
        ``plane_reprojection_px`` (the plane view through the final camera),
        ``views_used``, ``views_without_board``, ``lens`` (whether
        distortion was fitted), ``pixels_per_metre``.

    Raises
    ------
    ValueError
        No images, images of different sizes, a bad pattern or square, or no
        board found in the plane view.
    """
    if len(images) == 0:
        raise ValueError("images: give at least one view of the checkerboard")
    names = [f"image {k}" for k in range(len(images))] if names is None else list(names)
    cols, rows = (int(v) for v in pattern)
    if cols < 2 or rows < 2 or (cols, rows) != tuple(pattern):
        raise ValueError(f"pattern must be (columns, rows) inner corners, both >= 2; got {pattern!r}")
    if not np.isscalar(square) or not np.isfinite(square) or square <= 0:
        raise ValueError(f"square must be the side of a square in metres (> 0); got {square!r}")
    size = (int(images[0].shape[1]), int(images[0].shape[0]))
    # a square spans at least _MIN_SQUARE_PX pixels: a pattern that cannot fit the image is refused before
    # OpenCV allocates for it (100000x100000 corners would take about 149 GiB)
    most = max(size) // _MIN_SQUARE_PX - 1
    if max(cols, rows) > most or (cols + 1) * (rows + 1) * _MIN_SQUARE_PX**2 > size[0] * size[1]:
        raise ValueError(
            f"pattern {cols}x{rows} inner corners cannot fit in {size[0]}x{size[1]} views (a square needs at least "
            f"{_MIN_SQUARE_PX} px, so at most {most} corners along a side); pattern counts inner corners, "
            "e.g. 9x6 for a board of 10x7 squares"
        )
    for img, nm in zip(images, names):
        if (img.shape[1], img.shape[0]) != size:
            raise ValueError(
                f"{nm}: size {img.shape[1]}x{img.shape[0]} differs from the first view's {size[0]}x{size[1]}"
            )
    plane_k = plane % len(images) if -len(images) <= plane < len(images) else None
    if plane_k is None:
        raise ValueError(f"plane={plane} but there are {len(images)} views")
    obj = _board_points((cols, rows), square)
    found = [find_board(img, (cols, rows)) for img in images]
    if found[plane_k] is None:
        raise ValueError(
            f"{names[plane_k]} (the plane view): no {cols}x{rows} checkerboard found; check pattern (inner corners) "
            "and that "
            "the whole board is in view"
        )
    used = [k for k, f in enumerate(found) if f is not None]
    missing = [names[k] for k, f in enumerate(found) if f is None]
    plane_pts = found[plane_k]
    if len(used) >= _MIN_LENS_VIEWS:
        rms, K, dist, _, _ = cv2.calibrateCamera(
            [obj] * len(used), [found[k].astype(np.float32) for k in used], size, None, None
        )
        # the plane's homography from its own view's corners, undistorted: the metric scale then
        # rests on that view alone rather than on the focal length shared by all views
        ideal = undistort_points(plane_pts.reshape(-1, 1, 2), K, dist, K, None).reshape(-1, 2)
        H, _ = cv2.findHomography(obj[:, :2].astype(np.float64), ideal, 0)
        camera = Camera.from_plane(H, size, K, dist.ravel(), base_frame=False)
        lens_rms: float | None = float(rms)
    else:
        H, _ = cv2.findHomography(obj[:, :2].astype(np.float64), plane_pts, 0)
        camera = Camera.from_plane(H, size, base_frame=False)
        lens_rms = None
    # the plane view through the final camera: rectified corners against the board's metric grid
    rect = camera.rectify(plane_pts)
    grid = obj[:, :2].astype(np.float64) * camera.pixels_per_metre
    A = np.column_stack([grid, np.ones(len(grid))])
    fit, *_ = np.linalg.lstsq(A, rect, rcond=None)  # the similarity (rotation, offset) the base frame will remove
    residual = np.linalg.norm(A @ fit - rect, axis=1)
    report = {
        "rms_reprojection_px": lens_rms,
        "plane_reprojection_px": float(np.sqrt(np.mean(residual**2))),
        "views_used": len(used),
        "views_without_board": missing,
        "lens": lens_rms is not None,
        "pixels_per_metre": camera.pixels_per_metre,
    }
    return camera, report


def read_views(paths: Sequence[str | Path], every: int = 1) -> tuple[list[NDArray[np.uint8]], list[str]]:
    """Grey checkerboard views from image files, folders of images or videos.

    Parameters
    ----------
    paths : sequence of path
        Image files, folders of images or videos.
    every : int
        Keep every ``every``-th frame of a video or folder (default all).

    Returns
    -------
    images : list of uint8 images
    names : list of str
        Where each image came from (file, or file and frame), for messages.
    """
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer; got {every!r}")
    images, names = [], []
    for raw in paths:
        path = Path(raw)
        if path.is_file() and path.suffix.lower() in IMAGE_SUFFIXES:
            size = image_size(path)
            if size is not None:
                check_frame_size(*size, f"image {str(path)!r}")
            img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise OSError(f"cannot read image {str(path)!r}")
            images.append(img)
            names.append(str(path))
            continue
        src = FrameSource(str(path), str(path))  # a video or a folder of images
        for k, frame in enumerate(src.frames(grey=True)):
            if k % every == 0:
                images.append(frame)
                names.append(f"{path}, frame {k}")
    return images, names
