"""Figures of the seed: strain-distance profile, error trade-off, rollouts, stills, animation.

Plain functions on numpy arrays (the fitted estimators expose everything they
need: e.g. ``KinematicFusion.distance_profile_``, ``boundaries_``,
``marker_arc_lengths_``; ``StrainTrajectory.poses(s)`` gives backbones).
Every plotting function returns the :class:`matplotlib.figure.Figure` and
accepts an ``ax``/``axes`` argument to draw into existing axes; none calls
``plt.show()``.  :func:`animate_rollout` writes a video file with OpenCV and
uses its own Agg canvas, so it works without a display.

Conventions (docs/method.md, "Configuration"): positions in metres, angles in radians, strains
``[kappa_be 1/m, sigma_sh -, sigma_ax -]`` per segment.  Drawings of the robot
follow the renderer: the base at the top and image-down = +y, so the y axis of
robot drawings in metres is inverted.

This module sits on top of the package: nothing in the core imports it.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import cv2
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.transforms import blended_transform_factory
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from .metrics import end_effector_errors

__all__ = [
    "plot_strain_distance_profile",
    "plot_error_vs_segments",
    "plot_rollout",
    "plot_end_effector",
    "plot_stills",
    "animate_rollout",
]

_STRAIN_TYPES = ("be", "sh", "ax")
_STRAIN_LABELS = {
    "be": r"bending $\kappa_{be}$ [1/m]",
    "sh": r"shear $\sigma_{sh}$ [-]",
    "ax": r"axial $\sigma_{ax}$ [-]",
}
_STRAIN_UNITS = {"be": "[1/m]", "sh": "[-]", "ax": "[-]"}
_NAME_RE = re.compile(r"^(be|sh|ax)_(\d+)$")
_VIDEO_CODECS = {".mp4": "mp4v", ".avi": "MJPG"}
_TRUTH_STYLE = {"linestyle": ":", "linewidth": 2.0, "zorder": 3}  # on top: predictions may cover it


# --------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------
def _finite_array(value: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a numeric array; got {type(value).__name__} ({err})") from None
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = tuple(int(i) for i in bad[0]) if bad.size else ()
        raise ValueError(f"{name} contains NaN or inf (first at index {where})")
    return arr


def _check_time(t: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    t = _finite_array(t, name)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"{name} must be a non-empty 1-D array of time stamps; got shape {t.shape}")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0))
        raise ValueError(
            f"{name} must be strictly increasing; {name}[{k + 1}] = {t[k + 1]!r} <= {name}[{k}] = {t[k]!r}"
        )
    return t


def _check_scalar(value: Any, name: str, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not np.isscalar(value):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number; got {value!r}") from None
    if not np.isfinite(out) or (positive and out <= 0):
        raise ValueError(f"{name} must be a finite number{' > 0' if positive else ''}; got {value!r}")
    return out


def _predictions(
    pred: Any, labels: Sequence[str] | None, shape: tuple[int, ...], name: str
) -> tuple[list[NDArray[np.float64]], list[str]]:
    """Normalise one prediction, a sequence of them or a ``{label: array}`` mapping."""
    if isinstance(pred, Mapping):
        if labels is not None:
            raise ValueError(f"labels must be None when {name} is a mapping (its keys are the labels); got {labels!r}")
        labels = [str(k) for k in pred]
        arrays = list(pred.values())
    elif isinstance(pred, (list, tuple)) and len(pred) > 0 and np.ndim(pred[0]) == len(shape):
        arrays = list(pred)
    else:
        arrays = [pred]
    if len(arrays) == 0:
        raise ValueError(f"{name} must hold at least one prediction")
    if labels is None:
        labels = ["model"] if len(arrays) == 1 else [f"model {k + 1}" for k in range(len(arrays))]
    elif isinstance(labels, str):
        labels = [labels]
    labels = [str(v) for v in labels]
    if len(labels) != len(arrays):
        raise ValueError(
            f"labels must have one entry per prediction in {name} ({len(arrays)}); got {len(labels)}: {labels!r}"
        )
    out = []
    for k, arr in enumerate(arrays):
        key = name if len(arrays) == 1 else f"{name}[{labels[k]!r}]"
        arr = _finite_array(arr, key)
        if arr.shape != shape:
            raise ValueError(f"{key} must have shape {shape} (like the truth); got {arr.shape}")
        out.append(arr)
    return out, labels


def _new_axes(axes: Any, n: int, name: str, figsize: tuple[float, float], **kwargs: Any) -> tuple[Figure, list[Axes]]:
    """Create ``n`` stacked/row axes or validate the given ones."""
    if axes is None:
        fig, created = plt.subplots(figsize=figsize, squeeze=False, layout="constrained", **kwargs)
        return fig, list(created.ravel())
    if isinstance(axes, Axes):
        axes = [axes]
    axes = list(np.ravel(np.asarray(axes, dtype=object)))
    if len(axes) != n or not all(isinstance(a, Axes) for a in axes):
        raise ValueError(f"{name} must be {n} matplotlib Axes; got {len(axes)} object(s)")
    return axes[0].figure, axes


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
    d = _finite_array(distances, "distances")
    if d.ndim != 1 or d.size < 1:
        raise ValueError(f"distances must be a 1-D array of N - 1 >= 1 values; got shape {d.shape}")
    if np.any(d < 0):
        raise ValueError(f"distances must be >= 0; got minimum {d.min()!r}")
    h = _check_scalar(threshold, "threshold")
    n = d.size + 1  # initial segments = markers
    if boundaries is not None and segment_lengths is not None:
        raise ValueError("give either boundaries or segment_lengths, not both")
    if len(colors) < 1:
        raise ValueError(f"colors must hold at least one colour; got {colors!r}")

    if marker_arc_lengths is None:
        x_marker = np.arange(n + 1, dtype=float)
        xlabel = "joint of segment pair (i, i+1) = marker index i"
    else:
        x_marker = _finite_array(marker_arc_lengths, "marker_arc_lengths")
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
        lengths = _finite_array(segment_lengths, "segment_lengths")
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

    fig, (ax,) = _new_axes(ax, 1, "ax", (6.4, 3.2))
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

    fig, (ax,) = _new_axes(ax, 1, "ax", (6.0, 3.6))
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


# --------------------------------------------------------------------------
# Seed Fig. 9: rollouts
# --------------------------------------------------------------------------
def _default_strain_names(n: int) -> list[str]:
    if n % 3 == 0:
        return [f"{s}_{i + 1}" for i in range(n // 3) for s in _STRAIN_TYPES]
    return [f"q_{k + 1}" for k in range(n)]


def plot_rollout(
    t: ArrayLike,
    q_true: ArrayLike,
    q_pred: Any,
    names: Sequence[str] | None = None,
    labels: Sequence[str] | None = None,
    *,
    layout: str = "auto",
    axes: Sequence[Axes] | None = None,
    title: str | None = None,
) -> Figure:
    """Configurations against time: truth dotted, prediction(s) solid (seed Fig. 9a / 11a).

    Parameters
    ----------
    t : array_like, shape (T,)
        Time stamps [s].
    q_true : array_like, shape (T, n)
        True strains.
    q_pred : array_like (T, n), sequence of them, or mapping ``{label: array}``
        Predicted strains, same shape as ``q_true`` (full strains; strains a
        model does not keep are 0).  Several predictions (e.g. models trained
        with and without noise) are drawn in different colours.
    names : sequence of str, optional
        Strain names, default ``be_1, sh_1, ax_1, be_2, ...`` when n is a
        multiple of 3 (as ``PlanarPCS.strain_names()``), else ``q_1 ... q_n``.
    labels : sequence of str, optional
        Legend labels of the predictions (not with a mapping).
    layout : {"auto", "type", "strain"}
        ``"type"``: one subplot per strain type (bending, shear, axial), all
        segments in it (needs names ``be_i``/``sh_i``/``ax_i``); ``"strain"``:
        one subplot per strain.  ``"auto"``: ``"type"`` when names allow it and
        either there is one segment or one prediction, else ``"strain"``.
    axes : sequence of Axes, optional
        One per subplot.
    title : str, optional

    Returns
    -------
    Figure
        In every subplot, for each strain in it (in ``names`` order): the
        truth line, then one line per prediction.  With one prediction,
        colours follow the segment; with several, they follow the prediction
        and the truth is black.
    """
    t = _check_time(t)
    q_true = _finite_array(q_true, "q_true")
    if q_true.ndim != 2 or q_true.shape[0] != t.size or q_true.shape[1] < 1:
        raise ValueError(f"q_true must have shape ({t.size}, n) to match t; got {q_true.shape}")
    n = q_true.shape[1]
    preds, labels = _predictions(q_pred, labels, q_true.shape, "q_pred")
    names = _default_strain_names(n) if names is None else [str(v) for v in names]
    if len(names) != n:
        raise ValueError(f"names must have one entry per strain ({n}); got {len(names)}: {names!r}")
    parsed = [_NAME_RE.match(nm) for nm in names]
    typed = all(p is not None for p in parsed)
    segments = sorted({int(p.group(2)) for p in parsed}) if typed else []
    if layout not in ("auto", "type", "strain"):
        raise ValueError(f"layout must be 'auto', 'type' or 'strain'; got {layout!r}")
    if layout == "type" and not typed:
        raise ValueError(f"layout='type' needs names of the form be_i, sh_i, ax_i; got {names!r}")
    if layout == "auto":
        layout = "type" if typed and (len(segments) == 1 or len(preds) == 1) else "strain"

    if layout == "type":
        types = [s for s in _STRAIN_TYPES if any(p.group(1) == s for p in parsed)]
        panels = [[k for k in range(n) if parsed[k].group(1) == s] for s in types]
        ylabels = [_STRAIN_LABELS[s] for s in types]
    else:
        panels = [[k] for k in range(n)]
        ylabels = [f"{nm} {_STRAIN_UNITS[p.group(1)]}" if p else nm for nm, p in zip(names, parsed)]

    fig, axes = _new_axes(axes, len(panels), "axes", (7.0, 1.9 * len(panels) + 0.8), nrows=len(panels), sharex=True)
    single = len(preds) == 1
    for ax, panel, ylabel in zip(axes, panels, ylabels):
        many = len(panel) > 1
        for k in panel:
            seg = int(parsed[k].group(2)) - 1 if typed else 0
            colour = f"C{seg % 10}" if single else "k"
            prefix = f"{names[k]}: " if many else ""
            ax.plot(t, q_true[:, k], color=colour, label=f"{prefix}truth", **_TRUTH_STYLE)
            for j, (q, lab) in enumerate(zip(preds, labels)):
                ax.plot(t, q[:, k], color=colour if single else f"C{j % 10}", linewidth=1.2, label=f"{prefix}{lab}")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if many or ax is axes[0]:
            # outside the axes: rollouts fill the whole panel
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="x-small")
    axes[-1].set_xlabel("time t [s]")
    axes[0].set_title(title if title is not None else "configuration rollout (truth dotted)")
    return fig


def plot_end_effector(
    t: ArrayLike,
    tip_true: ArrayLike,
    tip_pred: Any,
    labels: Sequence[str] | None = None,
    *,
    axes: Sequence[Axes] | None = None,
    show_errors: bool = True,
    title: str | None = None,
) -> Figure:
    """End-effector x, y and theta against time: truth dotted, prediction(s) solid (seed Fig. 9b).

    Parameters
    ----------
    t : array_like, shape (T,)
        Time stamps [s].
    tip_true : array_like, shape (T, 3)
        True tip poses ``[x, y, theta]`` [m, m, rad] in the base frame.
    tip_pred : array_like (T, 3), sequence of them, or mapping ``{label: array}``
    labels : sequence of str, optional
        Legend labels of the predictions (not with a mapping).
    axes : sequence of 3 Axes, optional
    show_errors : bool
        Append the seed's end-effector errors ``e_p^EE`` and ``e_theta^EE``
        (eqs. 25-26, :func:`pcs_sindy.metrics.end_effector_errors`) to each
        prediction's legend label.
    title : str, optional

    Returns
    -------
    Figure
        Three subplots (x, y, theta); in each, the truth line then one line per prediction.
    """
    t = _check_time(t)
    tip_true = _finite_array(tip_true, "tip_true")
    if tip_true.shape != (t.size, 3):
        raise ValueError(f"tip_true must have shape ({t.size}, 3) ([x, y, theta] per time stamp); got {tip_true.shape}")
    preds, labels = _predictions(tip_pred, labels, tip_true.shape, "tip_pred")
    if show_errors:
        full = []
        for tip, lab in zip(preds, labels):
            e_p, e_th = end_effector_errors(tip[:, None, :], tip_true[:, None, :])
            full.append(f"{lab}\n$e_p^{{EE}}$ = {1e3 * e_p:.3g} mm\n$e_\\theta^{{EE}}$ = {e_th:.3g} rad")
        labels = full
    fig, axes = _new_axes(axes, 3, "axes", (7.0, 6.0), nrows=3, sharex=True)
    for c, (ax, ylabel) in enumerate(zip(axes, (r"tip $x$ [m]", r"tip $y$ [m]", r"tip $\theta$ [rad]"))):
        ax.plot(t, tip_true[:, c], color="k", label="truth", **_TRUTH_STYLE)
        for j, (tip, lab) in enumerate(zip(preds, labels)):
            ax.plot(t, tip[:, c], color=f"C{j % 10}", linewidth=1.2, label=lab)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="x-small")
    axes[-1].set_xlabel("time t [s]")
    axes[0].set_title(title if title is not None else "end-effector rollout (truth dotted)")
    return fig


# --------------------------------------------------------------------------
# Seed Fig. 3 / 10: stills
# --------------------------------------------------------------------------
def _per_still(value: Any, k: int, name: str, min_points: int = 1) -> list[NDArray[np.float64]]:
    """A (K, P, 2|3) array or K arrays (P_k, 2|3) -> K arrays (P_k, 2)."""
    if isinstance(value, np.ndarray) or not isinstance(value, (list, tuple)):
        arr = _finite_array(value, name)
        if arr.ndim != 3 or arr.shape[-1] not in (2, 3):
            raise ValueError(
                f"{name} must have shape ({k}, P, 2 or 3) or be a list of {k} (P, 2 or 3) arrays; got {arr.shape}"
            )
        value = list(arr)
    if len(value) != k:
        raise ValueError(f"{name} must hold one entry per still ({k}); got {len(value)}")
    out = []
    for i, item in enumerate(value):
        arr = _finite_array(item, f"{name}[{i}]")
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
    as :class:`pcs_sindy.camera.Camera`), every overlay is in metres in the
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
        times_arr = _finite_array(times, "times")
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
    fig, axes = _new_axes(axes, k, "axes", (2.4 * k + 0.6, 2.4 * min(max(aspect, 0.3), 3.0) + 1.3), ncols=k)
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


# --------------------------------------------------------------------------
# Animation
# --------------------------------------------------------------------------
def _check_track(value: ArrayLike, n_frames: int | None, name: str, min_points: int = 1) -> NDArray[np.float64]:
    arr = _finite_array(value, name)
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
    written with OpenCV's ``VideoWriter``.

    Parameters
    ----------
    path : str or path-like
        Output file; ``.mp4`` (codec ``mp4v``) or ``.avi`` (``MJPG``).  Its
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
    codec = _VIDEO_CODECS.get(path.suffix.lower())
    if codec is None:
        raise ValueError(f"path must end in one of {sorted(_VIDEO_CODECS)}; got {str(path)!r}")
    if not path.parent.is_dir():
        raise OSError(f"the folder of path={str(path)!r} does not exist")
    t = _check_time(t)
    n_frames = t.size
    true_xy = _check_track(backbone_true, n_frames, "backbone_true", 2)
    pred_xy = _check_track(backbone_pred, n_frames, "backbone_pred", 2)
    mark_xy = None if markers_true is None else _check_track(markers_true, n_frames, "markers_true")
    fps = _check_scalar(fps, "fps")
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
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*codec), fps, (width, height))
    if not writer.isOpened():
        raise OSError(f"OpenCV cannot open a {codec} video writer for path={str(path)!r}")
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
                raise RuntimeError(f"canvas size {rgba.shape[1]}x{rgba.shape[0]} differs from size {width}x{height}")
            writer.write(cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGR))
    finally:
        writer.release()
    return path
