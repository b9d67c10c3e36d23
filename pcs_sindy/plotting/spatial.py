"""Figures of spatial (3-D) robots: positions predicted against measured, and backbone shapes.

:func:`plot_positions_3d` draws measured marker (or tip) positions against predicted ones: the
trajectories in a 3-D panel, each coordinate against time, and the position error over time,
where an error hidden by overlapping curves shows.  :func:`plot_shapes_3d` draws the backbone of a
:class:`~pcs_sindy.core.SpatialPCS` robot at a few frames, with measured markers as dots.

Positions are in metres in the robot's base frame (or any common frame: the capture's); errors in
millimetres.  The 3-D panels keep true proportions (equal scale on the three axes) and, by default,
draw +y downwards as the renderer and the planar figures do: a robot hanging under gravity (+y, the
package's default) hangs down.  Measurements may have gaps (NaN: samples a tracker lost); they stay
gaps in the curves and the errors are taken over the measured samples.

Takes arrays and a :class:`~pcs_sindy.core.SpatialPCS`, gives :class:`matplotlib.figure.Figure`
objects; knows nothing of how the predictions were made.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from ..core.spatial import SpatialPCS
from ._checks import check_time, finite_array, predictions

__all__ = ["plot_positions_3d", "plot_shapes_3d"]

_MEASURED_STYLE = {"color": "k", "linestyle": ":", "linewidth": 2.0, "zorder": 3}  # on top of the predictions
_VERTICALS = ("-y", "y", "z")


def _measured(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A numeric array of positions (..., 3) in which NaN marks a missing sample (inf is refused)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a numeric array; got {type(value).__name__} ({err})") from None
    if np.any(np.isinf(arr)):
        where = tuple(int(i) for i in np.argwhere(np.isinf(arr))[0])
        raise ValueError(f"{name} contains inf at index {where} (missing samples are NaN)")
    return arr


def _check_vertical(vertical: str) -> None:
    if vertical not in _VERTICALS:
        raise ValueError(f"vertical must be one of {_VERTICALS!r}; got {vertical!r}")


def _axis_names(axis_names: Sequence[str]) -> list[str]:
    names = [str(v) for v in axis_names]
    if len(names) != 3:
        raise ValueError(f"axis_names must name the 3 coordinates; got {axis_names!r}")
    return names


def _set_view(ax: Any, points: NDArray[np.float64], vertical: str) -> None:
    """Equal scale on the three axes around the finite ``points`` (N, 3), the chosen axis up."""
    pts = points[np.all(np.isfinite(points), axis=1)]
    if pts.size == 0:
        return
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = 0.5 * (lo + hi)
    half = 0.55 * max(float(np.max(hi - lo)), 1e-3)  # a robot that does not move still gets a 2 mm box
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    if vertical == "-y":
        ax.set_ylim(centre[1] + half, centre[1] - half)  # +y (gravity) down
    else:
        ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    if vertical in ("-y", "y"):
        ax.view_init(elev=20.0, azim=-60.0, vertical_axis="y")


def _label_3d(ax: Any, names: list[str]) -> None:
    ax.set_xlabel(f"{names[0]} [m]", fontsize="small")
    ax.set_ylabel(f"{names[1]} [m]", fontsize="small")
    ax.set_zlabel(f"{names[2]} [m]", fontsize="small")
    ax.locator_params(nbins=4)
    ax.tick_params(labelsize="x-small")


def _is_3d(ax: Any) -> bool:
    return isinstance(ax, Axes) and getattr(ax, "name", "") == "3d"


def _position_axes(axes: Any) -> tuple[Figure, Any, list[Axes]]:
    """A 3-D panel on the left, the x, y, z and error panels stacked on the right (or the given five)."""
    if axes is None:
        fig = plt.figure(figsize=(11.0, 6.5), layout="constrained")
        grid = fig.add_gridspec(4, 2, width_ratios=[1.1, 1.0], height_ratios=[1.0, 1.0, 1.0, 0.9])
        ax3 = fig.add_subplot(grid[:, 0], projection="3d")
        first = fig.add_subplot(grid[0, 1])
        rest = [fig.add_subplot(grid[k, 1], sharex=first) for k in range(1, 4)]
        for ax in (first, *rest[:-1]):
            ax.tick_params(labelbottom=False)
        return fig, ax3, [first, *rest]
    axes = list(np.ravel(np.asarray(axes, dtype=object)))
    if len(axes) != 5 or not all(isinstance(a, Axes) for a in axes):
        raise ValueError(f"axes must be 5 matplotlib Axes (one 3-D, then x, y, z, error); got {len(axes)} object(s)")
    if not _is_3d(axes[0]) or any(_is_3d(a) for a in axes[1:]):
        raise ValueError("axes[0] must be a 3-D Axes (projection='3d') and axes[1:] 2-D Axes")
    return axes[0].figure, axes[0], axes[1:]


def plot_positions_3d(
    t: ArrayLike,
    measured: ArrayLike,
    predicted: Any,
    labels: Sequence[str] | None = None,
    *,
    point: int = -1,
    axis_names: Sequence[str] = ("x", "y", "z"),
    vertical: str = "-y",
    axes: Sequence[Axes] | None = None,
    title: str | None = None,
) -> Figure:
    """Measured positions against predicted ones in 3-D, per coordinate over time, and the error.

    Parameters
    ----------
    t : array_like, shape (T,)
        Time stamps [s].
    measured : array_like, shape (T, 3) or (T, K, 3)
        Measured positions [m] of one point (e.g. the tip) or of K markers; NaN where missing (a
        sample with any coordinate NaN counts as missing).
    predicted : array_like (like ``measured``), sequence of them, or mapping ``{label: array}``
        Predicted positions [m] of the same points in the same frame, finite.
    labels : sequence of str, optional
        Legend labels of the predictions (not with a mapping).
    point : int, default -1
        Which of the K points the time series and the error panel show (default the last: the tip).
    axis_names : sequence of 3 str
        Names of the coordinates.
    vertical : {"-y", "y", "z"}
        Axis drawn upwards in the 3-D panel: ``"-y"`` (default) draws +y, gravity, downwards.
    axes : sequence of 5 Axes, optional
        A 3-D Axes (``projection="3d"``), then the x, y, z and error panels.
    title : str, optional

    Returns
    -------
    Figure
        Axes in order: the 3-D panel (for each point: the measurement, then one line per
        prediction), the three coordinates against time (the measurement, then one line per
        prediction), the error panel: per prediction ``|p_pred - p_meas|`` [mm] of ``point``
        over time (NaN where not measured) and, with K > 1 points, the mean over the measured
        points (dashed).  The legend gives each prediction's RMS error of ``point`` over its
        measured samples.
    """
    t = check_time(t)
    meas = _measured(measured, "measured")
    if meas.ndim not in (2, 3) or meas.shape[0] != t.size or meas.shape[-1] != 3:
        raise ValueError(
            f"measured must have shape ({t.size}, 3) or ({t.size}, K, 3) (positions per time stamp); got {meas.shape}"
        )
    single = meas.ndim == 2
    preds, labels = predictions(predicted, labels, meas.shape, "predicted")
    if single:
        meas = meas[:, None, :]
        preds = [p[:, None, :] for p in preds]
    n_points = meas.shape[1]
    if isinstance(point, bool) or not isinstance(point, (int, np.integer)) or not -n_points <= point < n_points:
        raise ValueError(f"point must be an integer index into the {n_points} measured point(s); got {point!r}")
    names = _axis_names(axis_names)
    _check_vertical(vertical)
    seen = np.all(np.isfinite(meas), axis=-1)  # (T, K)
    if not np.any(seen[:, point]):
        raise ValueError(f"measured has no measured (finite) sample of point {point}")
    meas = np.where(seen[..., None], meas, np.nan)

    fig, ax3, panels = _position_axes(axes)
    for k in range(n_points):
        lab = "measured" if k == 0 else None
        ax3.plot(*meas[:, k].T, label=lab, **{**_MEASURED_STYLE, "linewidth": 1.5})
        for j, p in enumerate(preds):
            ax3.plot(*p[:, k].T, color=f"C{j % 10}", linewidth=1.0, label=labels[j] if k == 0 else None)
    _set_view(ax3, np.concatenate([meas.reshape(-1, 3)] + [p.reshape(-1, 3) for p in preds]), vertical)
    _label_3d(ax3, names)
    ax3.legend(loc="upper left", fontsize="x-small")

    errors = [np.where(seen, 1e3 * np.linalg.norm(p - meas, axis=-1), np.nan) for p in preds]  # (T, K) [mm]
    full = []
    for lab, e in zip(labels, errors):
        rmse = float(np.sqrt(np.nanmean(e[:, point] ** 2)))
        full.append(f"{lab}: RMSE {rmse:.3g} mm")
    for c, ax in enumerate(panels[:3]):
        ax.plot(t, meas[:, point, c], label="measured", **_MEASURED_STYLE)
        for j, (p, lab) in enumerate(zip(preds, full)):
            ax.plot(t, p[:, point, c], color=f"C{j % 10}", linewidth=1.2, label=lab)
        ax.set_ylabel(f"{names[c]} [m]")
        ax.grid(alpha=0.3)
    err_ax = panels[3]
    for j, e in enumerate(errors):
        err_ax.plot(t, e[:, point], color=f"C{j % 10}", linewidth=1.0)
        if n_points > 1:
            counts = np.sum(seen, axis=1)
            mean = np.where(counts > 0, np.nansum(e, axis=1) / np.maximum(counts, 1), np.nan)
            err_ax.plot(t, mean, color=f"C{j % 10}", linewidth=0.8, linestyle="--")
    which = "tip" if point in (-1, n_points - 1) else f"point {point % n_points}"
    extra = "; dashed: mean over points" if n_points > 1 else ""
    err_ax.set_ylabel(r"$|\Delta p|$ [mm]")
    err_ax.set_title(f"error of the {which}{extra}", fontsize="small")
    err_ax.set_ylim(bottom=0.0)
    err_ax.grid(alpha=0.3)
    err_ax.set_xlabel("time t [s]")
    panels[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="x-small")
    panels[0].set_title(f"{which} against time (measurement dotted)", fontsize="small")
    fig.suptitle(title if title is not None else "positions: model vs measurement (measurement dotted)")
    return fig


def _frames(frames: Any, n_frames: int) -> NDArray[np.intp]:
    if frames is None:
        return np.unique(np.round(np.linspace(0, n_frames - 1, min(5, n_frames))).astype(int))
    arr = np.atleast_1d(np.asarray(frames))
    if arr.ndim != 1 or arr.size == 0 or arr.dtype.kind not in "iu":
        raise ValueError(f"frames must be a non-empty 1-D sequence of integer frame indices; got {frames!r}")
    bad = (arr < -n_frames) | (arr >= n_frames)
    if np.any(bad):
        raise ValueError(f"frames must index the {n_frames} configurations; got {arr[bad][0]!r}")
    return arr % n_frames


def plot_shapes_3d(
    kinematics: SpatialPCS,
    q: ArrayLike,
    frames: Sequence[int] | None = None,
    *,
    t: ArrayLike | None = None,
    markers: ArrayLike | None = None,
    n_points: int = 60,
    axis_names: Sequence[str] = ("x", "y", "z"),
    vertical: str = "-y",
    ax: Axes | None = None,
    title: str | None = None,
) -> Figure:
    """Still of a spatial robot's backbone at a few frames, measured markers as dots.

    Parameters
    ----------
    kinematics : SpatialPCS
        The robot's segmentation and base pose (e.g. ``SpatialStrainTrajectory.kinematics``).
    q : array_like, shape (T, 6m) or (6m,)
        Full spatial strains over time (or one configuration).
    frames : sequence of int, optional
        Frame indices to draw (default up to 5, evenly spaced, first and last included).
    t : array_like, shape (T,), optional
        Time stamps [s], for the legend.
    markers : array_like, shape (T, K, 3), optional
        Measured marker positions [m] in the base frame, NaN where missing; drawn as dots at the
        chosen frames, in their frame's colour.
    n_points : int, default 60
        Backbone samples (the segment ends are added).
    axis_names : sequence of 3 str
    vertical : {"-y", "y", "z"}
        Axis drawn upwards: ``"-y"`` (default) lets a robot hanging along +y hang down.
    ax : Axes, optional
        A 3-D Axes (``projection="3d"``).
    title : str, optional

    Returns
    -------
    Figure
        Its 3-D axes hold, per frame in ``frames`` order, the backbone line (the segment ends as
        its markers), then the measured markers of that frame (a scatter) when given; then the base
        (a black square).
    """
    if not isinstance(kinematics, SpatialPCS):
        raise ValueError(f"kinematics must be a pcs_sindy.core.SpatialPCS; got {type(kinematics).__name__}")
    q = finite_array(q, "q")
    if q.ndim == 1:
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != kinematics.n_q or q.shape[0] < 1:
        raise ValueError(
            f"q must have shape (T, {kinematics.n_q}) or ({kinematics.n_q},) for "
            f"{kinematics.n_segments} segment(s); got {np.shape(q)}"
        )
    n_frames = q.shape[0]
    idx = _frames(frames, n_frames)
    if t is not None:
        t = check_time(t)
        if t.size != n_frames:
            raise ValueError(f"t must have one time stamp per configuration ({n_frames}); got {t.size}")
    if markers is not None:
        markers = _measured(markers, "markers")
        if markers.ndim != 3 or markers.shape[0] != n_frames or markers.shape[2] != 3:
            raise ValueError(f"markers must have shape ({n_frames}, K, 3); got {markers.shape}")
    if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 2:
        raise ValueError(f"n_points must be an integer >= 2; got {n_points!r}")
    names = _axis_names(axis_names)
    _check_vertical(vertical)
    if ax is None:
        fig = plt.figure(figsize=(6.5, 6.0), layout="constrained")
        ax = fig.add_subplot(projection="3d")
    elif not _is_3d(ax):
        raise ValueError(f"ax must be a 3-D matplotlib Axes (projection='3d'); got {type(ax).__name__}")
    fig = ax.figure

    ends = kinematics.boundaries
    s = np.union1d(np.linspace(0.0, kinematics.total_length, int(n_points)), ends)
    at_end = np.searchsorted(s, ends)
    positions, _ = kinematics.forward_kinematics(q[idx], s)  # (F, S, 3)
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, idx.size))
    drawn = [positions.reshape(-1, 3)]
    for f, (k, colour) in enumerate(zip(idx, colours)):
        label = f"t = {t[k]:.3g} s" if t is not None else f"frame {k}"
        ax.plot(*positions[f].T, color=colour, linewidth=2.0, marker="o", markevery=list(at_end), ms=4, label=label)
        if markers is not None:
            pts = markers[k][np.all(np.isfinite(markers[k]), axis=1)]
            ax.scatter(*pts.T, color=colour, s=14, edgecolors="k", linewidths=0.5, depthshade=False)
            drawn.append(pts)
    base = np.asarray(kinematics.base_position)
    ax.scatter(*base[:, None], color="k", marker="s", s=30, depthshade=False, label="base")
    _set_view(ax, np.concatenate(drawn + [base[None, :]]), vertical)
    _label_3d(ax, names)
    ax.legend(loc="upper left", fontsize="x-small")
    default = "backbone (segment ends marked)" + ("; measured markers as dots" if markers is not None else "")
    ax.set_title(title if title is not None else default)
    return fig
