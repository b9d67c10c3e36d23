"""Rollout figures: strains and end-effector pose against time, truth dotted (seed Fig. 9 / 11a).

One prediction, a sequence of them or a ``{label: array}`` mapping can be
drawn against the same truth (e.g. models trained with and without noise).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from ..core.metrics import end_effector_errors
from ._checks import check_time, finite_array, new_axes

__all__ = ["plot_rollout", "plot_end_effector"]

_STRAIN_TYPES = ("be", "sh", "ax")
_STRAIN_LABELS = {
    "be": r"bending $\kappa_{be}$ [1/m]",
    "sh": r"shear $\sigma_{sh}$ [-]",
    "ax": r"axial $\sigma_{ax}$ [-]",
}
_STRAIN_UNITS = {"be": "[1/m]", "sh": "[-]", "ax": "[-]"}
_NAME_RE = re.compile(r"^(be|sh|ax)_(\d+)$")
_TRUTH_STYLE = {"linestyle": ":", "linewidth": 2.0, "zorder": 3}  # on top: predictions may cover it


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
        arr = finite_array(arr, key)
        if arr.shape != shape:
            raise ValueError(f"{key} must have shape {shape} (like the truth); got {arr.shape}")
        out.append(arr)
    return out, labels


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
    t = check_time(t)
    q_true = finite_array(q_true, "q_true")
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

    fig, axes = new_axes(axes, len(panels), "axes", (7.0, 1.9 * len(panels) + 0.8), nrows=len(panels), sharex=True)
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
        (eqs. 25-26, :func:`pcs_sindy.core.metrics.end_effector_errors`) to each
        prediction's legend label.
    title : str, optional

    Returns
    -------
    Figure
        Three subplots (x, y, theta); in each, the truth line then one line per prediction.
    """
    t = check_time(t)
    tip_true = finite_array(tip_true, "tip_true")
    if tip_true.shape != (t.size, 3):
        raise ValueError(f"tip_true must have shape ({t.size}, 3) ([x, y, theta] per time stamp); got {tip_true.shape}")
    preds, labels = _predictions(tip_pred, labels, tip_true.shape, "tip_pred")
    if show_errors:
        full = []
        for tip, lab in zip(preds, labels):
            e_p, e_th = end_effector_errors(tip[:, None, :], tip_true[:, None, :])
            full.append(f"{lab}\n$e_p^{{EE}}$ = {1e3 * e_p:.3g} mm\n$e_\\theta^{{EE}}$ = {e_th:.3g} rad")
        labels = full
    fig, axes = new_axes(axes, 3, "axes", (7.0, 6.0), nrows=3, sharex=True)
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
