"""The linear kind: any constant ``A`` with a sparsity pattern over the strains, one gain per entry.

Tied to a segmentation (the pattern's rows are its strains); layouts by arc length are
the tendon and pressure kinds.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ...core.validation import Check
from .base import gain_unit
from .constant import ConstantActuation

__all__ = ["LinearActuation"]


def _pattern(value: Any) -> bool:
    pat = np.asarray(value)
    return pat.ndim == 2 and pat.shape[1] >= 1 and (pat.dtype == bool or bool(np.all(np.isin(pat, (0, 1)))))


class LinearActuation(ConstantActuation):
    """A constant ``A`` with a sparsity pattern: one unknown gain per nonzero entry.

    Parameters
    ----------
    pattern : array_like of bool, shape (3m, p)
        Which strains (rows, in the order ``be_1, sh_1, ax_1, be_2, ...`` of the
        data's segmentation) each input (column) acts on.  Tied to a
        segmentation: use :class:`PressureActuation` or
        :class:`TendonActuation` for layouts by arc length.
    """

    kind = "linear"
    gain_lower_bound = -np.inf
    _parameter_constraints: dict = {
        "pattern": [Check(_pattern, "a boolean (or 0/1) array of shape (3m, p) with p >= 1 (strains x inputs)")],
    }

    def __init__(self, pattern: ArrayLike = ()) -> None:
        self.pattern = pattern

    def _entries(self, kinematics):
        pat = np.asarray(self.pattern)  # its values checked by the table
        if pat.shape[0] != kinematics.n_q:
            raise ValueError(f"pattern must have shape ({kinematics.n_q}, p) (strains x inputs); got {pat.shape}")
        pat = pat.astype(bool)
        names = kinematics.strain_names()
        out = []
        for r, c in zip(*np.nonzero(pat)):
            unit = np.zeros(pat.shape)
            unit[r, c] = 1.0
            out.append((f"a_{names[r]}_{c + 1}", unit))
        return out, pat.shape[1]

    def describe(self, precision: int = 3) -> list[str]:
        strains = self.kinematics_.strain_names()
        return [
            "A = const (linear layout; u: the input's own unit): "
            + ", ".join(
                f"{nm} = {v:.{precision}g} {gain_unit(nm, strains)}" for nm, v in zip(self.gain_names_, self.gains_)
            )
        ]
