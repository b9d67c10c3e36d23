"""Figures of closed-loop runs: tip path against the reference, strains, commands (matplotlib).

Functions draw into given axes (or new ones) and return them; nothing is shown
or saved here.  Use a non-interactive backend (``matplotlib.use("Agg")``) in
scripts and tests.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["plot_tip_path", "plot_tip_error", "plot_strains", "plot_commands", "plot_closed_loop"]


def _axes(ax: Any) -> Any:
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.figure().add_subplot()


def _as_list(results: Any, labels: Sequence[str] | None) -> tuple[list, list[str]]:
    runs = list(results) if isinstance(results, (list, tuple)) else [results]
    if labels is None:
        labels = [f"run {k}" for k in range(len(runs))] if len(runs) > 1 else ["tip"]
    if len(labels) != len(runs):
        raise ValueError(f"labels must name each of the {len(runs)} results; got {len(labels)} labels")
    return runs, list(labels)


def _names(names: Sequence[str] | None, count: int, prefix: str, what: str) -> list[str]:
    out = [f"{prefix}{i + 1}" for i in range(count)] if names is None else list(names)
    if len(out) != count:
        raise ValueError(f"names must name the {count} {what}; got {len(out)}")
    return out


def plot_tip_path(results: Any, labels: Sequence[str] | None = None, ax: Any = None) -> Any:
    """Tip paths (x, y in mm, image-down +y as the robot hangs) of one or more results against the reference."""
    ax = _axes(ax)
    runs, labels = _as_list(results, labels)
    ref = runs[0].tip_reference * 1e3
    ax.plot(ref[:, 0], ref[:, 1], "k--", lw=1.0, label="reference")
    for res, lab in zip(runs, labels):
        ax.plot(res.tip[:, 0] * 1e3, res.tip[:, 1] * 1e3, lw=1.2, label=lab)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.invert_yaxis()
    ax.legend(fontsize="small")
    return ax


def plot_tip_error(results: Any, labels: Sequence[str] | None = None, ax: Any = None) -> Any:
    """Tip error [mm] over time (log scale)."""
    ax = _axes(ax)
    runs, labels = _as_list(results, labels)
    for res, lab in zip(runs, labels):
        ax.semilogy(res.t, np.maximum(res.tip_error * 1e3, 1e-6), lw=1.0, label=lab)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("tip error [mm]")
    ax.legend(fontsize="small")
    return ax


def plot_strains(result: Any, names: Sequence[str] | None = None, ax: Any = None) -> Any:
    """The modelled strains the controller saw (solid) and its reference (dashed)."""
    ax = _axes(ax)
    names = _names(names, result.q_model.shape[1], "q", "modelled strains")
    for i in range(len(names)):
        (line,) = ax.plot(result.t, result.q_model[:, i], lw=1.0, label=names[i])
        ax.plot(result.t, result.q_reference[:, i], "--", lw=0.8, color=line.get_color())
    ax.set_xlabel("t [s]")
    ax.set_ylabel("strain (model)")
    ax.legend(fontsize="small", ncol=2)
    return ax


def plot_commands(result: Any, names: Sequence[str] | None = None, ax: Any = None) -> Any:
    """The held commands ``u`` over time."""
    ax = _axes(ax)
    names = _names(names, result.u.shape[1], "u", "inputs")
    for i in range(len(names)):
        ax.step(result.t, result.u[:, i], where="post", lw=1.0, label=names[i])
    ax.set_xlabel("t [s]")
    ax.set_ylabel("command")
    ax.legend(fontsize="small", ncol=2)
    return ax


def plot_closed_loop(
    result: Any, strain_names: Sequence[str] | None = None, input_names: Sequence[str] | None = None
) -> Any:
    """One figure: tip path, tip error, strains and commands of a run; returns the figure."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    plot_tip_path(result, ax=axes[0, 0])
    plot_tip_error(result, ax=axes[0, 1])
    plot_strains(result, strain_names, ax=axes[1, 0])
    plot_commands(result, input_names, ax=axes[1, 1])
    fig.tight_layout()
    return fig
