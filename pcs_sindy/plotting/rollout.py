"""Rollout figures: strains and end-effector pose against time, truth dotted (seed Fig. 9 / 11a).

One prediction, a sequence of them or a ``{label: array}`` mapping can be
drawn against the same truth (e.g. models trained with and without noise).
A good model's line covers the truth's, so each figure adds residual panels
(prediction minus truth, or the error's size) by default: the error is read
there, not guessed from two overlapping lines.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from ..core.kinematics import wrap_angle
from ..core.metrics import end_effector_errors
from ._checks import check_time, finite_array, new_axes, predictions

__all__ = ["plot_rollout", "plot_end_effector", "plot_tip_positions"]

_STRAIN_TYPES = ("be", "sh", "ax")
_STRAIN_LABELS = {
    "be": r"bending $\kappa_{be}$ [1/m]",
    "sh": r"shear $\sigma_{sh}$ [-]",
    "ax": r"axial $\sigma_{ax}$ [-]",
}
_STRAIN_UNITS = {"be": "[1/m]", "sh": "[-]", "ax": "[-]"}
_NAME_RE = re.compile(r"^(be|sh|ax)_(\d+)$")
_TRUTH_STYLE = {"linestyle": ":", "linewidth": 2.0, "zorder": 3}  # on top: predictions may cover it
_RESIDUAL_RATIO = 0.6  # height of a residual panel relative to its data panel


def _residual_axes(axes: Any, n: int, residuals: bool, figsize: tuple[float, float]) -> tuple[Figure, list[Axes]]:
    """``n`` data panels, each followed by its residual panel when ``residuals`` (given ones checked)."""
    if not residuals:
        return new_axes(axes, n, "axes", figsize, nrows=n, sharex=True)
    ratios = [1.0, _RESIDUAL_RATIO] * n
    return new_axes(axes, 2 * n, "axes", figsize, nrows=2 * n, sharex=True, gridspec_kw={"height_ratios": ratios})


def _zero_line(ax: Axes) -> None:
    ax.axhline(0.0, color="0.6", linewidth=0.8, zorder=1)


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
    residuals: bool = True,
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
        One per subplot (two per subplot with ``residuals``: the subplot, then its residual panel).
    title : str, optional
    residuals : bool
        Below each subplot, a panel of the residuals ``q_pred - q_true`` of its strains (same
        colours, same units), where an error hidden under overlapping lines shows.

    Returns
    -------
    Figure
        In every subplot, for each strain in it (in ``names`` order): the
        truth line, then one line per prediction; in its residual panel one
        line per strain and prediction, in that order, after a zero line.
        With one prediction, colours follow the segment; with several, they
        follow the prediction and the truth is black.
    """
    t = check_time(t)
    q_true = finite_array(q_true, "q_true")
    if q_true.ndim != 2 or q_true.shape[0] != t.size or q_true.shape[1] < 1:
        raise ValueError(f"q_true must have shape ({t.size}, n) to match t; got {q_true.shape}")
    n = q_true.shape[1]
    preds, labels = predictions(q_pred, labels, q_true.shape, "q_pred")
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

    height = (1.9 + (1.2 if residuals else 0.0)) * len(panels) + 0.8
    fig, axes = _residual_axes(axes, len(panels), residuals, (7.0, height))
    data_axes = axes[::2] if residuals else axes
    single = len(preds) == 1
    for p, (ax, panel, ylabel) in enumerate(zip(data_axes, panels, ylabels)):
        many = len(panel) > 1
        res = axes[2 * p + 1] if residuals else None
        if res is not None:
            _zero_line(res)
        for k in panel:
            seg = int(parsed[k].group(2)) - 1 if typed else 0
            colour = f"C{seg % 10}" if single else "k"
            prefix = f"{names[k]}: " if many else ""
            ax.plot(t, q_true[:, k], color=colour, label=f"{prefix}truth", **_TRUTH_STYLE)
            for j, (q, lab) in enumerate(zip(preds, labels)):
                ax.plot(t, q[:, k], color=colour if single else f"C{j % 10}", linewidth=1.2, label=f"{prefix}{lab}")
                if res is not None:
                    res.plot(t, q[:, k] - q_true[:, k], color=colour if single else f"C{j % 10}", linewidth=1.0)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if res is not None:
            unit = ylabel[ylabel.rfind("[") :] if "[" in ylabel else ""
            res.set_ylabel(f"model - truth\n{unit}".strip(), fontsize="small")
            res.grid(alpha=0.3)
        if many or ax is data_axes[0]:
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
    residuals: bool = True,
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
    axes : sequence of 3 Axes (5 with ``residuals``), optional
    show_errors : bool
        Append the seed's end-effector errors ``e_p^EE`` and ``e_theta^EE``
        (eqs. 25-26, :func:`pcs_sindy.core.metrics.end_effector_errors`) to each
        prediction's legend label.
    title : str, optional
    residuals : bool
        Add two panels: the tip position error ``|p_pred - p_true|`` [mm] and the
        angle error ``|theta_pred - theta_true|`` [rad] (wrapped) over time, whose
        means are ``e_p^EE`` and ``e_theta^EE`` (a dashed line each).

    Returns
    -------
    Figure
        Three subplots (x, y, theta); in each, the truth line then one line per prediction;
        with ``residuals`` two more, one error line (then its mean) per prediction.
    """
    t = check_time(t)
    tip_true = finite_array(tip_true, "tip_true")
    if tip_true.shape != (t.size, 3):
        raise ValueError(f"tip_true must have shape ({t.size}, 3) ([x, y, theta] per time stamp); got {tip_true.shape}")
    preds, labels = predictions(tip_pred, labels, tip_true.shape, "tip_pred")
    if show_errors:
        full = []
        for tip, lab in zip(preds, labels):
            e_p, e_th = end_effector_errors(tip[:, None, :], tip_true[:, None, :])
            full.append(f"{lab}\n$e_p^{{EE}}$ = {1e3 * e_p:.3g} mm\n$e_\\theta^{{EE}}$ = {e_th:.3g} rad")
        labels = full
    if residuals:
        fig, axes = new_axes(
            axes, 5, "axes", (7.0, 8.0), nrows=5, sharex=True, gridspec_kw={"height_ratios": [1, 1, 1, 0.7, 0.7]}
        )
    else:
        fig, axes = new_axes(axes, 3, "axes", (7.0, 6.0), nrows=3, sharex=True)
    for c, (ax, ylabel) in enumerate(zip(axes, (r"tip $x$ [m]", r"tip $y$ [m]", r"tip $\theta$ [rad]"))):
        ax.plot(t, tip_true[:, c], color="k", label="truth", **_TRUTH_STYLE)
        for j, (tip, lab) in enumerate(zip(preds, labels)):
            ax.plot(t, tip[:, c], color=f"C{j % 10}", linewidth=1.2, label=lab)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    if residuals:
        for j, tip in enumerate(preds):
            e_p = 1e3 * np.hypot(*(tip[:, :2] - tip_true[:, :2]).T)
            e_th = np.abs(wrap_angle(tip[:, 2] - tip_true[:, 2]))
            for ax, err in zip(axes[3:], (e_p, e_th)):
                ax.plot(t, err, color=f"C{j % 10}", linewidth=1.0)
                ax.axhline(float(np.mean(err)), color=f"C{j % 10}", linestyle="--", linewidth=0.8)
        for ax, ylabel in zip(axes[3:], (r"$|\Delta p|$ [mm]", r"$|\Delta\theta|$ [rad]")):
            ax.set_ylabel(ylabel)
            ax.set_ylim(bottom=0.0)
            ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="x-small")
    axes[-1].set_xlabel("time t [s]")
    axes[0].set_title(title if title is not None else "end-effector rollout (truth dotted)")
    return fig


def plot_tip_positions(
    t: ArrayLike,
    tip_true: ArrayLike,
    tip_pred: Any,
    labels: Sequence[str] | None = None,
    *,
    axis_names: Sequence[str] = ("X", "Y", "Z"),
    axes: Sequence[Axes] | None = None,
    title: str | None = None,
    residuals: bool = True,
) -> Figure:
    """A measured tip position against predicted ones over time, with the error panel (motion capture).

    The measurement may have gaps (NaN: samples a tracker lost); they stay gaps, and the errors are
    over the measured samples.

    Parameters
    ----------
    t : array_like, shape (T,)
        Time stamps [s].
    tip_true : array_like, shape (T, D)
        Measured tip positions [m] (D = 2 or 3, e.g. in the capture frame); NaN where missing.
    tip_pred : array_like (T, D), sequence of them, or mapping ``{label: array}``
        Predicted tip positions [m], finite.
    labels : sequence of str, optional
        Legend labels of the predictions (not with a mapping).
    axis_names : sequence of str
        Names of the D coordinates.
    axes : sequence of D Axes (D + 1 with ``residuals``), optional
    title : str, optional
    residuals : bool
        Add a panel of the position error ``|p_pred - p_true|`` [mm] over time; each
        prediction's legend label gives its RMS and mean over the measured samples.

    Returns
    -------
    Figure
        One subplot per coordinate (the measurement, then one line per prediction), then the
        error panel (one line per prediction).
    """
    t = check_time(t)
    try:
        tip_true = np.asarray(tip_true, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"tip_true must be a numeric array; got {type(tip_true).__name__} ({err})") from None
    if tip_true.ndim != 2 or tip_true.shape[0] != t.size or tip_true.shape[1] not in (2, 3):
        raise ValueError(
            f"tip_true must have shape ({t.size}, 2 or 3) (a position per time stamp); got {tip_true.shape}"
        )
    if np.any(np.isinf(tip_true)):
        raise ValueError("tip_true contains inf (missing samples are NaN)")
    measured = np.all(np.isfinite(tip_true), axis=1)
    if not np.any(measured):
        raise ValueError("tip_true has no measured (finite) sample")
    d = tip_true.shape[1]
    names = [str(v) for v in axis_names]
    if len(names) < d:
        raise ValueError(f"axis_names must name the {d} coordinates; got {axis_names!r}")
    preds, labels = predictions(tip_pred, labels, tip_true.shape, "tip_pred")
    errors = [1e3 * np.linalg.norm(p[measured] - tip_true[measured], axis=1) for p in preds]
    if residuals:
        full = [
            f"{lab}\nRMSE {np.sqrt(np.mean(e**2)):.3g} mm, mean {np.mean(e):.3g} mm" for lab, e in zip(labels, errors)
        ]
        ratios = [1.0] * d + [0.8]
        fig, axes = new_axes(
            axes, d + 1, "axes", (7.0, 1.8 * d + 2.0), nrows=d + 1, sharex=True, gridspec_kw={"height_ratios": ratios}
        )
    else:
        full = labels
        fig, axes = new_axes(axes, d, "axes", (7.0, 1.8 * d + 0.8), nrows=d, sharex=True)
    for c, ax in enumerate(axes[:d]):
        ax.plot(t, tip_true[:, c], color="k", label="measured", **_TRUTH_STYLE)
        for j, (tip, lab) in enumerate(zip(preds, full)):
            ax.plot(t, tip[:, c], color=f"C{j % 10}", linewidth=1.2, label=lab)
        ax.set_ylabel(f"tip {names[c]} [m]")
        ax.grid(alpha=0.3)
    if residuals:
        ax = axes[d]
        for j, e in enumerate(errors):
            err = np.full(t.size, np.nan)
            err[measured] = e
            ax.plot(t, err, color=f"C{j % 10}", linewidth=1.0)
        ax.set_ylabel(r"$|\Delta p|$ [mm]")
        ax.set_ylim(bottom=0.0)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="x-small")
    axes[-1].set_xlabel("time t [s]")
    axes[0].set_title(title if title is not None else "tip: model vs measurement (measurement dotted)")
    return fig
