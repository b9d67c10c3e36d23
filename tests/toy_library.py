"""A hand-derived toy library implementing the library contract, shared by the optimizer and regressor tests.

L = sum 1/2 m_e qd_e^2 + sum pi_e q_e^2 + pi_c q_0 q_1, D diagonal, one segment.
A column survives the limit q_e -> 0 only if it involves no removed strain.
"""

from __future__ import annotations

import numpy as np

from pcs_sindy.identification.library.base import LagrangianLibrary
from pcs_sindy.models import CallableModel

_COLUMNS = [
    ("kin", (0,)),
    ("kin", (1,)),
    ("kin", (2,)),
    ("el", (0,)),
    ("el", (1,)),
    ("el", (2,)),
    ("cpl", (0, 1)),
    ("damp", (0,)),
    ("damp", (1,)),
    ("damp", (2,)),
]


class ToyLibrary(LagrangianLibrary):
    """Hand-derived library of the toy model (``columns``: the parent columns kept after a restriction)."""

    stiffness_factor_ = -2.0  # the Lagrangian holds pi_e q_e^2 = -k_e/2 q_e^2

    def __init__(self, segment_lengths=(0.1,), active_strains=None, columns=None):
        self.segment_lengths = segment_lengths
        self.active_strains = active_strains
        self.columns = columns

    @property
    def _mask(self):
        return self.kinematics.active_mask

    @property
    def column_map_(self):
        return np.arange(len(_COLUMNS)) if self.columns is None else np.asarray(self.columns)

    @property
    def _cols(self):
        return [_COLUMNS[j] for j in self.column_map_]

    @property
    def n_coefficients_(self):
        return len(self.column_map_)

    @property
    def stiffness_index_(self):
        return np.array([self._cols.index(("el", (e,))) for e in np.flatnonzero(self._mask)])

    @property
    def damping_index_(self):
        return np.array([self._cols.index(("damp", (e,))) for e in np.flatnonzero(self._mask)])

    def coefficient_names(self):
        return [f"{k}{''.join(map(str, st))}" for k, st in self._cols]

    def _full(self, a):
        out = np.zeros(a.shape[:-1] + (3,))
        out[..., self._mask] = a
        return out

    def _terms(self, q, qd, qdd):
        """(Psi, P, R) with Psi = dP/dt + R, by hand."""
        Q, QD, QDD = (
            self._full(np.asarray(q, float)),
            self._full(np.asarray(qd, float)),
            self._full(np.asarray(qdd, float)),
        )
        shape = (Q.shape[0], 3, len(self._cols))
        psi, mom, rest = np.zeros(shape), np.zeros(shape), np.zeros(shape)
        for c, (kind, st) in enumerate(self._cols):
            if kind == "kin":
                psi[:, st[0], c] = QDD[:, st[0]]
                mom[:, st[0], c] = QD[:, st[0]]
            elif kind == "el":
                psi[:, st[0], c] = rest[:, st[0], c] = -2 * Q[:, st[0]]
            elif kind == "cpl":
                psi[:, st[0], c] = rest[:, st[0], c] = -Q[:, st[1]]
                psi[:, st[1], c] = rest[:, st[1], c] = -Q[:, st[0]]
            else:
                psi[:, st[0], c] = QD[:, st[0]]
                mom[:, st[0], c] = Q[:, st[0]]
        m = self._mask
        return psi[:, m, :], mom[:, m, :], rest[:, m, :]

    def euler_lagrange_matrix(self, q, qd, qdd):
        return self._terms(q, qd, qdd)[0]

    def weak_terms(self, q, qd):
        _, mom, rest = self._terms(q, qd, np.zeros_like(np.asarray(q, float)))
        return mom, rest

    def mass_matrix(self, q, coef):
        # column j of M is Psi(q, 0, e_j) coef minus the potential part Psi(q, 0, 0) coef
        q = np.asarray(q, float)
        n = int(self._mask.sum())
        zero = np.zeros_like(q)
        base = self.euler_lagrange_matrix(q, zero, zero) @ coef
        cols = [
            self.euler_lagrange_matrix(q, zero, np.tile(np.eye(n)[j], (q.shape[0], 1))) @ coef - base for j in range(n)
        ]
        return np.stack(cols, axis=-1)

    def bias_forces(self, q, qd, coef):
        q = np.asarray(q, float)
        return self.euler_lagrange_matrix(q, qd, np.zeros_like(q)) @ coef

    def forward_model(self, coef, actuation=None):
        coef = self._check_coef(coef)

        def single(q, qd):
            return self.mass_matrix(q[None], coef)[0], self.bias_forces(q[None], qd[None], coef)[0]

        return CallableModel(
            self.kinematics,
            single,
            lambda q, qd: (self.mass_matrix(q, coef), self.bias_forces(q, qd, coef)),
            actuation=actuation,
        )

    def restrict(self, active_strains):
        mask = np.asarray(active_strains, dtype=bool).reshape(-1)
        keep = [j for j, (_, st) in enumerate(_COLUMNS) if all(mask[e] for e in st)]
        return ToyLibrary(self.kinematics.segment_lengths, mask.reshape(1, 3), keep)

    def equations(self, coef, precision=3, threshold=0.0):
        coef = self._check_coef(coef)
        terms = [
            f"{c:.{precision}g} {nm}"
            for c, nm in zip(coef, self.coefficient_names(), strict=True)
            if abs(c) > threshold
        ]
        return ["L = " + " + ".join(terms), self._damping_line(coef, precision)]

    def transform(self, x):
        raise NotImplementedError("the toy library is only used through its Euler-Lagrange rows")

    def get_feature_names(self, input_features=None):
        return self.coefficient_names()
