"""Input checks shared by the figures: numeric arrays, time stamps, scalars, predictions and the axes to draw into.

Each check raises ``ValueError`` naming the argument and the offending value.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray


def finite_array(value: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a numeric array; got {type(value).__name__} ({err})") from None
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = tuple(int(i) for i in bad[0]) if bad.size else ()
        raise ValueError(f"{name} contains NaN or inf (first at index {where})")
    return arr


def check_time(t: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    t = finite_array(t, name)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"{name} must be a non-empty 1-D array of time stamps; got shape {t.shape}")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0))
        raise ValueError(
            f"{name} must be strictly increasing; {name}[{k + 1}] = {t[k + 1]!r} <= {name}[{k}] = {t[k]!r}"
        )
    return t


def check_scalar(value: Any, name: str, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not np.isscalar(value):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number; got {value!r}") from None
    if not np.isfinite(out) or (positive and out <= 0):
        raise ValueError(f"{name} must be a finite number{' > 0' if positive else ''}; got {value!r}")
    return out


def new_axes(axes: Any, n: int, name: str, figsize: tuple[float, float], **kwargs: Any) -> tuple[Figure, list[Axes]]:
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


def predictions(
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
