"""A video of a rollout: true and predicted backbones over time, drawn with matplotlib and written with OpenCV.

The drawing uses its own Agg canvas, so it works without a display.  A ``.gif`` is written with
Pillow (matplotlib's image library; no OpenCV); which format a browser plays on this OpenCV build is
:func:`pcs_sindy.core.video.browser_video_format`'s answer.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from ..core.video import VIDEO_CODECS, open_video_writer, video_codec
from ._checks import check_scalar, check_time, finite_array

__all__ = ["animate_rollout"]

_SUFFIXES = (*VIDEO_CODECS, ".gif")


def _check_track(value: ArrayLike, n_frames: int | None, name: str, min_points: int = 1) -> NDArray[np.float64]:
    arr = finite_array(value, name)
    if arr.ndim != 3 or arr.shape[-1] not in (2, 3) or arr.shape[1] < min_points:
        raise ValueError(f"{name} must have shape (T, P >= {min_points}, 2 or 3); got {arr.shape}")
    if n_frames is not None and arr.shape[0] != n_frames:
        raise ValueError(f"{name} must have one entry per time stamp ({n_frames}); got {arr.shape[0]}")
    return arr[..., :2]


def animate_rollout(
    path: str | os.PathLike,
    t: ArrayLike,
    backbone_true: ArrayLike,
    backbone_pred: ArrayLike,
    markers_true: ArrayLike | None = None,
    *,
    fps: float = 30.0,
    stride: int | None = None,
    labels: tuple[str, str] = ("truth", "model"),
    size: tuple[int, int] = (480, 480),
    dpi: int = 100,
    progress: bool = True,
) -> Path:
    """Write a video of a rollout: true and predicted backbones over time.

    Each video frame is a matplotlib drawing (base at the top, image-down =
    +y, fixed limits enclosing all the data) copied from the Agg canvas and
    written with OpenCV's ``VideoWriter`` (a GIF with Pillow).

    Parameters
    ----------
    path : str or path-like
        Output file; its suffix chooses the format: ``.mp4`` (H.264 ``avc1`` when this OpenCV build
        has the encoder, else ``mp4v``, which browsers often refuse), ``.webm`` (VP8, browser-playable),
        ``.avi`` (``MJPG``) or ``.gif`` (Pillow; every frame is held in memory until written).
        ``"rollout" + pcs_sindy.core.video.browser_video_format()`` is one a browser plays.  Its
        folder must exist.
    t : array_like, shape (T,)
        Time stamps [s].
    backbone_true, backbone_pred : array_like, shape (T, P, 2 or 3)
        Backbone points (or poses) in metres in the base frame, base to tip;
        the two may have different numbers of points.
    markers_true : array_like, shape (T, N, 2 or 3), optional
        True marker positions, drawn as dots.
    fps : float
        Frame rate of the video.
    stride : int, optional
        Use every ``stride``-th sample.  Default: the stride that plays the
        rollout in real time at ``fps`` (``round(1 / (fps * dt))``, at least 1).
    labels : (str, str)
        Legend labels of the true and predicted backbones.
    size : (int, int)
        Video (width, height) in pixels, each even and >= 32.
    dpi : int
        Resolution of the drawing (fonts scale with it).
    progress : bool
        Show a tqdm bar over frames.

    Returns
    -------
    Path
        ``path``; the video holds ``ceil(T / stride)`` frames of ``size``.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _SUFFIXES:
        raise ValueError(f"path must end in one of {sorted(_SUFFIXES)}; got {str(path)!r}")
    if not path.parent.is_dir():
        raise OSError(f"the folder of path={str(path)!r} does not exist")
    t = check_time(t)
    n_frames = t.size
    true_xy = _check_track(backbone_true, n_frames, "backbone_true", 2)
    pred_xy = _check_track(backbone_pred, n_frames, "backbone_pred", 2)
    mark_xy = None if markers_true is None else _check_track(markers_true, n_frames, "markers_true")
    fps = check_scalar(fps, "fps")
    if stride is None:
        dt = float(np.median(np.diff(t))) if n_frames > 1 else 1.0 / fps
        stride = max(1, int(round(1.0 / (fps * dt))))
    elif isinstance(stride, bool) or not isinstance(stride, (int, np.integer)) or stride < 1:
        raise ValueError(f"stride must be a positive integer; got {stride!r}")
    sz = np.asarray(size)
    if sz.shape != (2,) or np.any(sz != np.round(sz)) or np.any(sz < 32) or np.any(sz % 2):
        raise ValueError(f"size must be two even integers >= 32 (width, height); got {size!r}")
    width, height = int(sz[0]), int(sz[1])
    if isinstance(dpi, bool) or not isinstance(dpi, (int, np.integer)) or dpi < 10:
        raise ValueError(f"dpi must be an integer >= 10; got {dpi!r}")
    if len(labels) != 2:
        raise ValueError(f"labels must be two strings (truth, model); got {labels!r}")

    # Fixed limits over the whole rollout keep the picture from jumping.
    pts = [true_xy.reshape(-1, 2), pred_xy.reshape(-1, 2)] + ([] if mark_xy is None else [mark_xy.reshape(-1, 2)])
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.08 * max(float(np.max(hi - lo)), 1e-6)
    lo, hi = lo - pad, hi + pad

    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(hi[1], lo[1])  # image-down = +y, base at the top
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.xaxis.set_major_locator(MaxNLocator(5))
    ax.grid(alpha=0.3)
    # the truth wide and pale underneath, so the model line stays readable on top of it
    (l_true,) = ax.plot([], [], "-", color="0.55", linewidth=5.0, alpha=0.6, solid_capstyle="round", label=labels[0])
    (l_pred,) = ax.plot([], [], "-", color="tab:red", linewidth=1.8, label=labels[1])
    l_mark = None
    if mark_xy is not None:
        (l_mark,) = ax.plot([], [], "o", color="tab:blue", markersize=3, label="true markers")
    ax.legend(loc="lower left", fontsize="x-small")
    stamp = ax.set_title(f"t = {t[0]:.3f} s")  # a stand-in so the layout leaves room for it
    fig.tight_layout()

    indices = range(0, n_frames, stride)
    from ..core.atomic import FileSet

    # written under a temporary name in the same folder and renamed when complete: a failure leaves the old video
    with FileSet() as outputs, outputs.path_for(path) as tmp:
        if suffix == ".gif":
            from PIL import Image  # matplotlib's own image library (a dependency of matplotlib)

            frames: list = []

            def write(rgba: NDArray) -> None:  # a palette image per frame: a third of the memory of RGB
                frames.append(Image.fromarray(np.ascontiguousarray(rgba[..., :3])).convert("P", palette=1))

            def close() -> None:
                pass
        else:
            import cv2

            writer = open_video_writer(tmp, video_codec(suffix), fps, (width, height))
            write, close = (lambda rgba: writer.write(cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGR))), writer.release
        try:
            for k in tqdm(indices, desc="animate", unit="frame", disable=not progress):
                l_true.set_data(true_xy[k, :, 0], true_xy[k, :, 1])
                l_pred.set_data(pred_xy[k, :, 0], pred_xy[k, :, 1])
                if l_mark is not None:
                    l_mark.set_data(mark_xy[k, :, 0], mark_xy[k, :, 1])
                stamp.set_text(f"t = {t[k]:.3f} s")
                canvas.draw()
                rgba = np.asarray(canvas.buffer_rgba())
                if rgba.shape[:2] != (height, width):
                    raise RuntimeError(
                        f"canvas size {rgba.shape[1]}x{rgba.shape[0]} differs from size {width}x{height}"
                    )
                write(rgba)
        finally:
            close()
        if suffix == ".gif":  # frame durations in whole hundredths of a second, as GIF stores them
            ms = 10 * max(2, int(round(100.0 / fps)))
            frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], duration=ms, loop=0)
    return path
