"""Constant input maps: ``A`` built from fixed unit entries, each with a gain (identified or given).

:class:`ConstantActuation` is the abstract base of the constant kinds (pressure chambers,
linear layouts): a kind lists its entries (a name and a unit matrix each); the gains
make ``A = sum_j g_j U_j``, evaluated by the compiled kernels as a constant matrix.
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np
from numpy.typing import NDArray

from ...core.kinematics import PlanarPCS
from .base import Actuation

__all__ = ["ConstantActuation"]


class ConstantActuation(Actuation):
    """Constant ``A`` with unknown (or given) gains on fixed entries: ``A = sum_j g_j U_j``.

    A kind implements ``_entries`` (and ``_given_gains`` when gains may be given) and :meth:`describe`.
    """

    compiled_forms = ("matrix",)

    @abstractmethod
    def _entries(self, kinematics: PlanarPCS) -> tuple[list[tuple[str, NDArray[np.float64]]], int]:
        """Per gain its name and unit matrix (3m, p) over the full strains; and p."""

    def _given_gains(self, n_inputs: int) -> NDArray[np.float64] | None:
        return None

    def _structure(self, kinematics):
        entries, p = self._entries(kinematics)
        mask = kinematics.active_mask
        units = np.stack([e[1][mask] for e in entries]) if entries else np.zeros((0, int(mask.sum()), p))
        given = self._given_gains(p)
        out = {"units": units, "n_inputs": p, "offset_names": [], "offsets": np.zeros(0)}
        if given is None:
            out.update(gain_names=[e[0] for e in entries], gains=np.zeros(len(entries)))
        else:
            out.update(gain_names=[], gains=given)
        return out

    def _matrix_of(self, gains: NDArray) -> NDArray[np.float64]:
        return np.einsum("j,jnp->np", gains, self._arrays["units"])

    def forces(self, q, u, gains=None, offsets=None):
        """``A u`` (B, n) for every entry's gain (default: the given or identified ones)."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        g = self.gains_ if gains is None else np.asarray(gains, dtype=float).reshape(-1)
        units = self._arrays["units"]
        if g.size != units.shape[0]:
            raise ValueError(f"gains must hold {units.shape[0]} values (one per entry of the layout); got {g.size}")
        return u @ self._matrix_of(g).T

    def parts(self, q, u, offsets=None):
        u = np.asarray(u, dtype=float)
        units_u = np.einsum("jnp,bp->bnj", self._arrays["units"], u)  # (B, n, J)
        if self.n_gains:
            return np.zeros(units_u.shape[:2]), units_u
        return units_u @ self.gains_, np.zeros(units_u.shape[:2] + (0,))

    def compiled(self, gains=None, offsets=None) -> tuple:
        g = self.gains_ if gains is None else np.asarray(gains, dtype=float)
        m = self.kinematics_.n_segments
        return "matrix", np.zeros(0), np.zeros((0, m)), np.ascontiguousarray(self._matrix_of(g))
