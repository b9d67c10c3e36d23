"""Stills of the robot: images with true markers, detections and the model's backbone overlaid (seed Fig. 3 / 10).

:func:`plot_contact_sheet` draws what an extraction found on a few frames (the chain of markers in
order, the base, the components rejected) for ``pcs-sindy inspect``.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ._checks import finite_array, new_axes

__all__ = ["plot_contact_sheet", "plot_stills"]


def _per_still(value: Any, k: int, name: str, min_points: int = 1) -> list[NDArray[np.float64]]:
    """A (K, P, 2|3) array or K arrays (P_k, 2|3) -> K arrays (P_k, 2)."""
    if isinstance(value, np.ndarray) or not isinstance(value, (list, tuple)):
        arr = finite_array(value, name)
        if arr.ndim != 3 or arr.shape[-1] not in (2, 3):
            raise ValueError(
                f"{name} must have shape ({k}, P, 2 or 3) or be a list of {k} (P, 2 or 3) arrays; got {arr.shape}"
            )
        value = list(arr)
    if len(value) != k:
        raise ValueError(f"{name} must hold one entry per still ({k}); got {len(value)}")
    out = []
    for i, item in enumerate(value):
        arr = finite_array(item, f"{name}[{i}]")
        if arr.ndim != 2 or arr.shape[-1] not in (2, 3) or arr.shape[0] < min_points:
            raise ValueError(f"{name}[{i}] must have shape (P >= {min_points}, 2 or 3); got {arr.shape}")
        out.append(arr[:, :2])
    return out


def _to_pixels(camera: Any, xy: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    out = np.asarray(camera.to_pixels(xy), dtype=float)
    if out.shape != xy.shape:
        raise ValueError(f"camera.to_pixels must map {name} of shape {xy.shape} to the same shape; got {out.shape}")
    return out


def plot_stills(
    frames: Any = None,
    *,
    poses: Any = None,
    detected: Any = None,
    backbone: Any = None,
    times: Sequence[float] | None = None,
    camera: Any = None,
    bgr: bool = True,
    crop: bool = True,
    axes: Sequence[Axes] | None = None,
    labels: Mapping[str, str] | None = None,
    title: str | None = None,
) -> Figure:
    """A row of stills with markers and the model's backbone overlaid (seed Fig. 3 and 10).

    Give image ``frames``, or ``poses`` (drawn as the true markers), or both.

    Coordinates: with a ``camera`` (any object with ``to_pixels(xy)``, such
    as :class:`pcs_sindy.core.camera.Camera`), every overlay is in metres in the
    base frame and is mapped to pixels.  Without a camera, overlays are in
    pixels ``(u, v)`` when ``frames`` are given and in metres otherwise
    (axes then read x [m], y [m], with y pointing down as in the videos).

    Parameters
    ----------
    frames : array_like (K, H, W) or (K, H, W, 3), or list of K images, optional
        Grey or colour (``bgr``: OpenCV channel order) images.
    poses : array_like (K, P, 2|3) or list of K (P_k, 2|3) arrays, optional
        True marker poses or positions (blue dots).
    detected : same form as ``poses``, optional
        Detected marker centres (green dots); the count may vary per still
        (an empty array: nothing detected on that still).
    backbone : same form as ``poses`` with P >= 2, optional
        The model's backbone (red line).
    times : sequence of K floats, optional
        Time of each still [s] (panel titles).
    camera : object with ``to_pixels``, optional
    bgr : bool
        Colour frames are in BGR order (OpenCV); set False for RGB.
    crop : bool
        Zoom every panel to the box around all overlays (same view in all
        panels).  With ``False``, images are shown whole, and drawings in
        pixels without images span ``camera.image_size`` when it exists.
    axes : sequence of K Axes, optional
    labels : mapping, optional
        Legend labels overriding ``{"poses": "true markers", "detected":
        "detected markers", "backbone": "model backbone"}``.
    title : str, optional
        Figure title.

    Returns
    -------
    Figure
        Per panel, lines in the order: poses, backbone, detected (those given).
    """
    if frames is None and poses is None:
        raise ValueError("give frames or poses (or both); got neither")
    images: list[NDArray] | None = None
    if frames is not None:
        images = list(frames) if isinstance(frames, (list, tuple)) else list(np.asarray(frames))
        if len(images) == 0:
            raise ValueError("frames must hold at least one image")
        for i, img in enumerate(images):
            img = np.asarray(img)
            if not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)) or min(img.shape[:2]) < 1:
                raise ValueError(f"frames[{i}] must be a grey (H, W) or colour (H, W, 3) image; got shape {img.shape}")
            if not np.issubdtype(img.dtype, np.number) or not np.all(np.isfinite(img)):
                raise ValueError(f"frames[{i}] must be a finite numeric image")
            images[i] = img
    if images is not None:
        k = len(images)
    elif isinstance(poses, (list, tuple)):
        k = len(poses)
    else:
        k = np.shape(poses)[0] if np.ndim(poses) >= 1 else 0
    if k < 1:
        raise ValueError(f"poses must hold at least one still; got {poses!r}")
    overlays: dict[str, list[NDArray[np.float64]] | None] = {
        "poses": None if poses is None else _per_still(poses, k, "poses"),
        "backbone": None if backbone is None else _per_still(backbone, k, "backbone", min_points=2),
        "detected": None if detected is None else _per_still(detected, k, "detected", min_points=0),
    }
    if camera is not None:
        if not callable(getattr(camera, "to_pixels", None)):
            raise ValueError(f"camera must have a to_pixels(xy) method; got {type(camera).__name__}")
        overlays = {
            key: None if val is None else [_to_pixels(camera, xy, f"{key}[{i}]") for i, xy in enumerate(val)]
            for key, val in overlays.items()
        }
    if times is not None:
        times_arr = finite_array(times, "times")
        if times_arr.shape != (k,):
            raise ValueError(f"times must have one entry per still ({k}); got shape {times_arr.shape}")
    names = {"poses": "true markers", "detected": "detected markers", "backbone": "model backbone"}
    if labels is not None:
        unknown = set(labels) - set(names)
        if unknown:
            raise ValueError(f"labels keys must be among {sorted(names)}; got {sorted(unknown)}")
        names.update(labels)
    styles = {
        "poses": dict(linestyle="none", marker="o", markersize=4, color="tab:blue"),
        "backbone": dict(linestyle="-", linewidth=1.6, color="tab:red", alpha=0.9),
        "detected": dict(linestyle="none", marker="o", markersize=3, color="tab:green"),
    }
    pixels = images is not None or camera is not None

    # One view for every still (so the panels compare), computed here rather
    # than with shared axes, which fight the equal aspect ratio.
    points = [xy for val in overlays.values() if val is not None for xy in val]
    view = None
    if points and (images is None or crop):
        allp = np.concatenate(points)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        pad = 0.12 * max(float(np.max(hi - lo)), 1e-9) + (8.0 if pixels else 0.0)
        view = (lo - pad, hi + pad)
    if images is None and camera is not None and hasattr(camera, "image_size") and not crop:
        width, height = camera.image_size
        view = (np.array([-0.5, -0.5]), np.array([width - 0.5, height - 0.5]))

    created = axes is None
    if view is not None:
        aspect = float((view[1][1] - view[0][1]) / (view[1][0] - view[0][0]))
    elif images is not None:
        aspect = images[0].shape[0] / images[0].shape[1]
    else:
        aspect = 1.0
    # panel height follows the view so the figure has no empty band
    fig, axes = new_axes(axes, k, "axes", (2.4 * k + 0.6, 2.4 * min(max(aspect, 0.3), 3.0) + 1.3), ncols=k)
    for i, ax in enumerate(axes):
        if images is not None:
            img = images[i]
            if img.ndim == 3:
                rgb = img[..., ::-1] if bgr else img
                ax.imshow(rgb if rgb.dtype == np.uint8 else np.clip(rgb, 0, 1))
            else:
                vmax = 255 if img.dtype == np.uint8 else None
                ax.imshow(img, cmap="gray", vmin=0 if vmax else None, vmax=vmax)
        for key in ("poses", "backbone", "detected"):
            data = overlays[key]
            if data is not None:
                ax.plot(data[i][:, 0], data[i][:, 1], label=names[key], **styles[key])
        if times is not None:
            ax.set_title(f"t = {times_arr[i]:.3g} s", fontsize="medium")
        if view is not None:
            ax.set_xlim(view[0][0], view[1][0])
            ax.set_ylim(view[1][1], view[0][1])  # image-down = +y: base at the top as in the videos
        elif not ax.yaxis_inverted():
            ax.invert_yaxis()
        ax.set_aspect("equal", adjustable="box")
        if images is None:
            if i == 0:
                ax.set_ylabel("v [px]" if pixels else "y [m]")
            elif view is not None:
                ax.tick_params(labelleft=False)  # same view in every panel
            ax.set_xlabel("u [px]" if pixels else "x [m]")
            ax.grid(alpha=0.3)
        else:
            ax.set_xticks([])
            ax.set_yticks([])
    if axes[0].get_lines():
        if created:
            # below the panels, where it cannot hide the robot
            fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize="small")
        else:
            axes[0].legend(loc="lower left", fontsize="x-small")
    if title is not None:
        fig.suptitle(title)
    return fig


def plot_contact_sheet(
    frames: Sequence[Any],
    *,
    chains: Sequence[Any | None],
    rejected: Sequence[Any] | None = None,
    titles: Sequence[str] | None = None,
    notes: Sequence[str] | None = None,
    bgr: bool = True,
    ncols: int = 3,
    title: str | None = None,
    rejected_label: str = "rejected component",
) -> Figure:
    """A grid of frames with the marker chain an extraction found drawn on each, in pixels.

    Per frame: the chain as a line through the markers in order (green dots, numbered from the base,
    0), the base (a cyan square), and the marker-shaped components that were not taken as markers
    (red crosses: clutter, merged or partly hidden markers).

    Parameters
    ----------
    frames : sequence of K images
        Grey (H, W) or colour (H, W, 3) uint8 images.
    chains : sequence of K arrays (N + 1, 2|3) or None
        Marker positions ``(u, v)`` in pixels, base first; None where no chain was found.
    rejected : sequence of K arrays (P, 2+), optional
        Positions ``(u, v)`` of rejected components in pixels (P may be 0).
    titles : sequence of K str, optional
        Panel titles (e.g. the frame index and time).
    notes : sequence of K str, optional
        A line under each panel (e.g. why the frame could not be extracted).
    bgr : bool
        Colour frames are in OpenCV's BGR order.
    ncols : int
        Panels per row.
    title : str, optional
        Figure title (wrapped to the figure's width).
    rejected_label : str
        Legend label of ``rejected``.

    Returns
    -------
    Figure
    """
    k = len(frames)
    if k < 1:
        raise ValueError("frames must hold at least one image")
    for name, value in (("chains", chains), ("rejected", rejected), ("titles", titles), ("notes", notes)):
        if value is not None and len(value) != k:
            raise ValueError(f"{name} must hold one entry per frame ({k}); got {len(value)}")
    if isinstance(ncols, bool) or not isinstance(ncols, (int, np.integer)) or ncols < 1:
        raise ValueError(f"ncols must be a positive integer; got {ncols!r}")
    images = []
    for i, img in enumerate(frames):
        img = np.asarray(img)
        if img.dtype != np.uint8 or not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)):
            raise ValueError(f"frames[{i}] must be a uint8 image (H, W) or (H, W, 3); got {img.dtype} {img.shape}")
        images.append(img)
    cols = min(int(ncols), k)
    rows = -(-k // cols)
    aspect = images[0].shape[0] / images[0].shape[1]
    width = max(3.6 * cols, 6.0)  # room for the title and the legend under a single panel
    fig, axes = new_axes(None, rows * cols, "axes", (width, 3.6 * aspect * rows + 1.0), nrows=rows, ncols=cols)
    for i, ax in enumerate(axes):
        ax.set_xticks([])
        ax.set_yticks([])
        if i >= k:
            ax.set_axis_off()
            continue
        img = images[i]
        if img.ndim == 3:
            ax.imshow(img[..., ::-1] if bgr else img)
        else:
            ax.imshow(img, cmap="gray", vmin=0, vmax=255)
        if rejected is not None and rejected[i] is not None and len(rejected[i]):
            rej = finite_array(rejected[i], f"rejected[{i}]")
            if rej.ndim != 2 or rej.shape[1] < 2:
                raise ValueError(f"rejected[{i}] must have shape (P, 2 or more); got {rej.shape}")
            ax.plot(rej[:, 0], rej[:, 1], "x", color="tab:red", markersize=6, mew=1.5, label=rejected_label)
        chain = chains[i]
        if chain is not None:
            xy = finite_array(chain, f"chains[{i}]")
            if xy.ndim != 2 or xy.shape[1] < 2 or xy.shape[0] < 1:
                raise ValueError(f"chains[{i}] must have shape (N + 1, 2 or 3); got {xy.shape}")
            ax.plot(xy[:, 0], xy[:, 1], "-", color="yellow", linewidth=1.0, alpha=0.8)
            ax.plot(xy[1:, 0], xy[1:, 1], "o", color="lime", markersize=3.5, label="marker (chain order)")
            ax.plot(xy[0, 0], xy[0, 1], "s", color="cyan", markersize=8, mfc="none", mew=2, label="base")
            step = max(1, (len(xy) - 1) // 4)
            for j in sorted({*range(0, len(xy), step), len(xy) - 1}):
                ax.annotate(
                    str(j), xy[j, :2], xytext=(4, 4), textcoords="offset points", color="yellow", fontsize="x-small"
                )
        ax.set_xlim(-0.5, img.shape[1] - 0.5)
        ax.set_ylim(img.shape[0] - 0.5, -0.5)
        if titles is not None:
            ax.set_title(titles[i], fontsize="small")
        if notes is not None and notes[i]:
            ax.set_xlabel(notes[i], fontsize="x-small", color="tab:red", wrap=True)
    handles: dict[str, Any] = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncol=3, fontsize="small")
    if title is not None:
        fig.suptitle(textwrap.fill(title, int(width * 12)), fontsize="medium")
    return fig
