"""A hand-derived toy library implementing the library contract, shared by the optimizer and regressor tests.

L = sum 1/2 m_e qd_e^2 + sum pi_e q_e^2 + pi_c q_0 q_1, D diagonal, one 0.1 m segment.
A column survives the limit q_e -> 0 only if it involves no removed strain.
"""

from __future__ import annotations

import numpy as np

from pcs_sindy.kinematics import PlanarPCS

_COLUMNS = [
    ("kin", (0,)), ("kin", (1,)), ("kin", (2,)),
    ("el", (0,)), ("el", (1,)), ("el", (2,)),
    ("cpl", (0, 1)),
    ("damp", (0,)), ("damp", (1,)), ("damp", (2,)),
]


class ToyLibrary:
    """Hand-derived library of the toy model, implementing the library contract."""

    def __init__(self, mask=None, parent_columns=None):
        self.kinematics = PlanarPCS((0.1,), mask)
        self._mask = self.kinematics.active_mask
        self.column_map_ = np.arange(len(_COLUMNS)) if parent_columns is None else np.asarray(parent_columns)
        self.n_coefficients_ = len(self.column_map_)
        self._cols = [_COLUMNS[j] for j in self.column_map_]
        active = list(np.flatnonzero(self._mask))
        self.stiffness_index_ = np.array([self._cols.index(("el", (e,))) for e in active])
        self.damping_index_ = np.array([self._cols.index(("damp", (e,))) for e in active])

    def fit(self, x):
        return self

    def _full(self, a):
        out = np.zeros(a.shape[:-1] + (3,))
        out[..., self._mask] = a
        return out

    def euler_lagrange_matrix(self, q, qd, qdd):
        Q, QD, QDD = self._full(q), self._full(qd), self._full(qdd)
        psi = np.zeros((q.shape[0], 3, len(self._cols)))
        for c, (kind, st) in enumerate(self._cols):
            if kind == "kin":
                psi[:, st[0], c] = QDD[:, st[0]]
            elif kind == "el":
                psi[:, st[0], c] = -2 * Q[:, st[0]]
            elif kind == "cpl":
                psi[:, st[0], c] = -Q[:, st[1]]
                psi[:, st[1], c] = -Q[:, st[0]]
            else:
                psi[:, st[0], c] = QD[:, st[0]]
        return psi[:, self._mask, :]

    def mass_matrix(self, q, coef):
        # column j of M is Psi(q, 0, e_j) coef minus the potential part Psi(q, 0, 0) coef
        n = int(self._mask.sum())
        zero = np.zeros_like(q)
        base = self.euler_lagrange_matrix(q, zero, zero) @ coef
        cols = [
            self.euler_lagrange_matrix(q, zero, np.tile(np.eye(n)[j], (q.shape[0], 1))) @ coef - base for j in range(n)
        ]
        return np.stack(cols, axis=-1)

    def bias_forces(self, q, qd, coef):
        return self.euler_lagrange_matrix(q, qd, np.zeros_like(q)) @ coef

    def potential_forces(self, q, coef):
        return self.euler_lagrange_matrix(q, np.zeros_like(q), np.zeros_like(q)) @ coef

    def compile_dynamics(self, coef):
        def f(q, qd):
            return self.mass_matrix(q[None], coef)[0], self.bias_forces(q[None], qd[None], coef)[0]

        return f

    def restrict(self, mask):
        mask = np.asarray(mask, dtype=bool).reshape(-1)
        keep = [j for j, (_, st) in enumerate(_COLUMNS) if all(mask[e] for e in st)]
        return ToyLibrary(mask.reshape(1, 3), keep)

    def euler_lagrange_names(self):
        return [f"{k}{''.join(map(str, st))}" for k, st in self._cols]
