"""Figures of kinematic fusion: the strain-distance profile (seed Fig. 6) and the error trade-off (seed Fig. 8).

Inputs are what the fitted :class:`pcs_sindy.fusion.kinematic_fusion.KinematicFusion`
exposes (``distance_profile_``, ``boundaries_``, ``marker_arc_lengths_``,
``segment_lengths_``) and the rows of
:func:`pcs_sindy.fusion.threshold_selection.threshold_sweep`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.transforms import blended_transform_factory
from numpy.typing import ArrayLike, NDArray

from ._checks import check_scalar, finite_array, new_axes

__all__ = ["plot_strain_distance_profile", "plot_error_vs_segments"]


# --------------------------------------------------------------------------
# Seed Fig. 6: strain-distance profile
# --------------------------------------------------------------------------
def _one_merge_step(distances: NDArray[np.float64], threshold: float) -> NDArray[np.intp]:
    # One step of the seed's Algorithm 1: a segment boundary survives at every
    # joint whose distance exceeds the threshold.
    n_segments = distances.size + 1
    return np.append(np.flatnonzero(distances > threshold) + 1, n_segments)


def plot_strain_distance_profile(
    distances: ArrayLike,
    threshold: float,
    boundaries: ArrayLike | None = None,
    marker_arc_lengths: ArrayLike | None = None,
    *,
    segment_lengths: ArrayLike | None = None,
    ax: Axes | None = None,
    colors: Sequence[Any] = ("tab:blue", "tab:orange"),
    title: str | None = None,
) -> Figure:
    """Average scaled strain distance of adjacent segments with the resulting segments (seed Fig. 6).

    The pair of initial segments ``(i, i + 1)`` (1-based) meets at marker
    ``i``, so its distance is drawn at marker ``i``: at x = ``i`` (marker
    index, base = 0, tip = N) or at its arc length when
    ``marker_arc_lengths`` is given.  Each resulting segment is a shaded
    vertical band from its first to its last marker, in alternating colours,
    numbered at the top.

    Parameters
    ----------
    distances : array_like, shape (N - 1,)
        Average scaled strain distance of each adjacent pair of the N initial
        segments (``KinematicFusion.distance_profile_``), >= 0.
    threshold : float
        Merge threshold ``h`` (dashed horizontal line).
    boundaries : array_like of int, shape (m,), optional
        Marker index of each resulting segment's *end* (strictly increasing,
        in 1..N, the last equal to N), as ``KinematicFusion.boundaries_``.
        Default: one merge step of Algorithm 1 on ``distances`` (a boundary at
        every pair whose distance exceeds ``threshold``), i.e. what the seed's
        Fig. 6 shows.
    marker_arc_lengths : array_like, shape (N + 1,), optional
        Rest arc lengths of the base and markers
        (``KinematicFusion.marker_arc_lengths_``); the x axis becomes arc length [m].
    segment_lengths : array_like, shape (m,), optional
        Segment rest lengths instead of ``boundaries`` (e.g. refined lengths
        off the marker grid, ``KinematicFusion.segment_lengths_``); needs
        ``marker_arc_lengths`` and must add up to the robot's length.
    ax : Axes, optional
    colors : two colours for alternating segment shading
    title : str, optional

    Returns
    -------
    Figure
        ``ax.get_lines()``: [distances, threshold line]; the shaded bands are
        the axes' patches, one per segment, base to tip.
    """
    d = finite_array(distances, "distances")
    if d.ndim != 1 or d.size < 1:
        raise ValueError(f"distances must be a 1-D array of N - 1 >= 1 values; got shape {d.shape}")
    if np.any(d < 0):
        raise ValueError(f"distances must be >= 0; got minimum {d.min()!r}")
    h = check_scalar(threshold, "threshold")
    n = d.size + 1  # initial segments = markers
    if boundaries is not None and segment_lengths is not None:
        raise ValueError("give either boundaries or segment_lengths, not both")
    if len(colors) < 1:
        raise ValueError(f"colors must hold at least one colour; got {colors!r}")

    if marker_arc_lengths is None:
        x_marker = np.arange(n + 1, dtype=float)
        xlabel = "joint of segment pair (i, i+1) = marker index i"
    else:
        x_marker = finite_array(marker_arc_lengths, "marker_arc_lengths")
        if x_marker.shape != (n + 1,):
            raise ValueError(
                f"marker_arc_lengths must have shape ({n + 1},) (base + N markers for {d.size} distances); "
                f"got {x_marker.shape}"
            )
        if np.any(np.diff(x_marker) <= 0):
            raise ValueError(f"marker_arc_lengths must be strictly increasing; got {x_marker.tolist()}")
        xlabel = "arc length of the joint s [m]"

    if segment_lengths is not None:
        if marker_arc_lengths is None:
            raise ValueError("segment_lengths needs marker_arc_lengths (to place the bands in arc length)")
        lengths = finite_array(segment_lengths, "segment_lengths")
        if lengths.ndim != 1 or lengths.size < 1 or np.any(lengths <= 0):
            raise ValueError(f"segment_lengths must be a 1-D array of positive lengths; got {lengths.tolist()}")
        ends = x_marker[0] + np.cumsum(lengths)
        span = x_marker[-1] - x_marker[0]
        if abs(ends[-1] - x_marker[-1]) > 1e-6 * span:
            raise ValueError(
                f"segment_lengths must add up to the robot's length {span!r} (marker_arc_lengths); "
                f"got sum {lengths.sum()!r}"
            )
        ends[-1] = x_marker[-1]
    else:
        if boundaries is None:
            b = _one_merge_step(d, h)
        else:
            raw = np.asarray(boundaries)
            if (
                raw.ndim != 1
                or raw.size < 1
                or not np.all(np.isfinite(raw.astype(float)))
                or np.any(raw != np.round(raw))
            ):
                raise ValueError(f"boundaries must be a 1-D array of marker indices; got {boundaries!r}")
            b = raw.astype(np.intp)
            if np.any(np.diff(b) <= 0) or b[0] < 1 or b[-1] != n:
                raise ValueError(
                    f"boundaries must be strictly increasing marker indices in 1..{n} ending at the tip {n}; "
                    f"got {b.tolist()}"
                )
        ends = x_marker[b]
    starts = np.concatenate([[x_marker[0]], ends[:-1]])

    fig, (ax,) = new_axes(ax, 1, "ax", (6.4, 3.2))
    for j, (a, e) in enumerate(zip(starts, ends)):
        ax.axvspan(a, e, color=colors[j % len(colors)], alpha=0.18, linewidth=0, zorder=0)
        ax.text(
            0.5 * (a + e),
            0.97,
            str(j + 1),
            ha="center",
            va="top",
            fontsize="small",
            transform=blended_transform_factory(ax.transData, ax.transAxes),
        )
    ax.plot(x_marker[1:-1], d, "o-", color="k", markersize=4, linewidth=1.2, label=r"$\bar d_{i,i+1}$ (scaled strains)")
    ax.axhline(h, linestyle="--", color="tab:red", linewidth=1.2, label=f"threshold h = {h:g}")
    ax.set_xlim(x_marker[0], x_marker[-1])
    ax.set_ylim(0.0, 1.15 * max(float(d.max()), h))
    if marker_arc_lengths is None:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(r"average strain distance $\bar d_{i,i+1}$ [-]")
    m = len(ends)
    ax.set_title(
        title if title is not None else f"strain-distance profile; shaded: {m} resulting segment{'s' * (m > 1)}"
    )
    ax.legend(loc="upper right", bbox_to_anchor=(1.0, 0.9), fontsize="small")
    return fig


# --------------------------------------------------------------------------
# Seed Fig. 8: errors against the number of segments
# --------------------------------------------------------------------------
def _check_rows(rows: Any) -> NDArray[np.float64]:
    try:
        arr = np.array([tuple(r) for r in rows], dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"rows must be a sequence of (h, n_segments, e_p_dist, e_theta_dist); got {rows!r} ({err})"
        ) from None
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] != 4:
        raise ValueError(
            f"rows must be a non-empty sequence of (h, n_segments, e_p_dist, e_theta_dist); got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        k = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise ValueError(f"rows[{k}] contains NaN or inf: {tuple(arr[k])}")
    n = arr[:, 1]
    if np.any(n < 1) or np.any(n != np.round(n)):
        raise ValueError(f"rows must have positive integer n_segments; got {n.tolist()}")
    if np.any(arr[:, 2:] < 0):
        raise ValueError("rows must have non-negative errors")
    return arr


def plot_error_vs_segments(
    rows: Sequence[Sequence[float]],
    selected: Sequence[float] | int | None = None,
    *,
    ax: Axes | None = None,
    logy: bool = False,
    title: str | None = None,
) -> Figure:
    """Distributed position (■) and orientation (●) errors against the number of segments (seed Fig. 8).

    Parameters
    ----------
    rows : sequence of (h, n_segments, e_p_dist, e_theta_dist)
        A threshold sweep (``segmentation.threshold_sweep``).  Several rows
        with the same number of segments are reduced to the one with the
        lowest position error (the same rule as ``select_threshold``).
    selected : row or int, optional
        The selected model (a row, e.g. ``select_threshold(rows)``, or its
        number of segments); marked by a vertical dotted line.
    ax : Axes, optional
        Axes for the position error; the orientation error goes on ``ax.twinx()``.
    logy : bool
        Logarithmic error axes.
    title : str, optional

    Returns
    -------
    Figure
        ``fig.axes[0].get_lines()``: [e_p_dist (m), selected line if any];
        ``fig.axes[-1]`` (the twin): [e_theta_dist (rad)].
    """
    arr = _check_rows(rows)
    n_all = arr[:, 1].astype(int)
    ns = np.unique(n_all)
    best = np.array([arr[n_all == n][np.argmin(arr[n_all == n, 2])] for n in ns])
    sel_n = sel_h = None
    if selected is not None:
        if isinstance(selected, (int, np.integer)) and not isinstance(selected, bool):
            sel_n = int(selected)
        else:
            sel = _check_rows([selected])[0]
            sel_n, sel_h = int(sel[1]), float(sel[0])
        if sel_n not in ns:
            raise ValueError(f"selected must name a number of segments present in rows {ns.tolist()}; got {selected!r}")

    fig, (ax,) = new_axes(ax, 1, "ax", (6.0, 3.6))
    twin = ax.twinx()
    lp = ax.plot(best[:, 1], best[:, 2], "s-", color="tab:blue", label=r"position $e_p^{dist}$ [m]")
    lt = twin.plot(best[:, 1], best[:, 3], "o--", color="tab:orange", label=r"orientation $e_\theta^{dist}$ [rad]")
    handles = lp + lt
    if sel_n is not None:
        label = f"selected: {sel_n} segment(s)" + ("" if sel_h is None else f" (h = {sel_h:g})")
        handles += [ax.axvline(sel_n, linestyle=":", color="0.3", linewidth=1.5, label=label)]
    if logy:
        ax.set_yscale("log")
        twin.set_yscale("log")
    else:
        ax.set_ylim(bottom=0.0)
        twin.set_ylim(bottom=0.0)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("number of segments m")
    ax.set_ylabel(r"position error $e_p^{dist}$ [m]", color="tab:blue")
    twin.set_ylabel(r"orientation error $e_\theta^{dist}$ [rad]", color="tab:orange")
    ax.tick_params(axis="y", colors="tab:blue")
    twin.tick_params(axis="y", colors="tab:orange")
    ax.legend(handles, [hd.get_label() for hd in handles], loc="upper right", fontsize="small")
    ax.set_title(title if title is not None else "kinematic error vs number of segments")
    return fig
