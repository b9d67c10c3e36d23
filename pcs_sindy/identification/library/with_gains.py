"""The columns of a regression with identified actuator gains: a library's, then one per gain.

The optimizer removes strains through the library's ``restrict`` and reads its
column layout; when actuator gains are identified with the Lagrangian, the
regression has extra columns after the library's.  :class:`WithGains` presents
that layout to the optimizer (duck-typed, structure only) and keeps the gain
columns last through every restriction.  Internal to the regressor's fit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["WithGains"]


class WithGains:
    """Column layout ``[library columns, gains]`` of an actuated regression.

    Parameters
    ----------
    library : LagrangianLibrary
    gain_names : sequence of str
    gain_lower : float
        Lower bound of every gain (``-inf``: free).
    parent_columns : int, optional
        Columns of the unrestricted library (set by :meth:`restrict`).
    """

    def __init__(self, library: Any, gain_names: Sequence[str], gain_lower: float, parent_columns: int | None = None):
        self.library = library
        self.gain_names = list(gain_names)
        self.gain_lower = float(gain_lower)
        self._parent = int(library.n_coefficients_) if parent_columns is None else int(parent_columns)
        self.parent_columns = self._parent  # read back by model files (a fitted regressor's optimizer holds one)

    @property
    def kinematics(self) -> Any:
        return self.library.kinematics

    @property
    def n_coefficients_(self) -> int:
        return int(self.library.n_coefficients_) + len(self.gain_names)

    @property
    def stiffness_index_(self) -> NDArray[np.intp]:
        return np.asarray(self.library.stiffness_index_)

    @property
    def damping_index_(self) -> NDArray[np.intp]:
        return np.asarray(self.library.damping_index_)

    @property
    def stiffness_factor_(self) -> float:
        return float(self.library.stiffness_factor_)

    @property
    def lower_bounds_(self) -> NDArray[np.float64]:
        lb = self.library.lower_bounds_
        lb = np.full(self.library.n_coefficients_, -np.inf) if lb is None else np.asarray(lb, dtype=float)
        return np.concatenate([lb, np.full(len(self.gain_names), self.gain_lower)])

    @property
    def column_map_(self) -> NDArray[np.intp]:
        own = np.asarray(getattr(self.library, "column_map_", np.arange(self.library.n_coefficients_)), dtype=int)
        return np.concatenate([own, self._parent + np.arange(len(self.gain_names))])

    def coefficient_names(self) -> list[str]:
        return list(self.library.coefficient_names()) + self.gain_names

    euler_lagrange_names = coefficient_names

    def coefficient_units(self) -> list[Any]:
        """The library's units, then None per gain (a gain's unit depends on the inputs' units)."""
        return list(self.library.coefficient_units()) + [None] * len(self.gain_names)

    def restrict(self, active_strains: ArrayLike) -> WithGains:
        return WithGains(self.library.restrict(active_strains), self.gain_names, self.gain_lower, self._parent)

    def scale_constraint(self) -> tuple[NDArray[np.float64], float] | None:
        sc = self.library.scale_constraint()
        if sc is None:
            return None
        return np.concatenate([sc[0], np.zeros(len(self.gain_names))]), sc[1]
