"""Monomial structure of ``M(q)`` and the bias forces of a :class:`PCSLagrangianLibrary` model.

From the cached polynomial data of the Euler–Lagrange images, ``M`` and the
bias forces of given coefficients are ``A @ monomials(q, qd)`` with one sparse
matrix ``A``: evaluated batched (:meth:`_DynamicsTables.evaluate`) or per
sample for rollouts (:meth:`_DynamicsTables.make`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from . import special as _special

__all__ = ["DynamicsTables"]


#: single-sample path: shorter series (error < (2 * 1.5)**31 / 31! ~ 1e-19 for frequencies <= 2u)
#: and the closed form beyond |u| = 1.5 (measured agreement with the series there: ~3e-14 relative)
_FAST_SERIES_RADIUS = 1.5
_FAST_SERIES_ORDER = 30


class DynamicsTables:
    """Monomial structure of M and the bias forces, from the cached Psi polynomial data."""

    def __init__(self, lib) -> None:
        cb = lib._cb
        m = lib._lengths.size
        mask = lib._mask
        L = lib._lengths
        q_names = [f"{n}_{i + 1}" for i in range(m) for n in ("kap", "sh", "ax")]
        active = [q_names[k] for k in np.flatnonzero(mask)]
        removed = {q_names[k] for k in range(3 * m) if not mask[k]}
        n = len(active)
        row_of = {name: r for r, name in enumerate(active)}
        col_of = {"dd" + name: r for r, name in enumerate(active)}
        # which products can contribute
        if lib._select is None:
            used = np.flatnonzero(np.any(lib._W != 0, axis=1))
        else:
            used = lib._select
        atoms: dict[str, int] = {"1": 0}
        monos: dict[tuple, int] = {}
        entries = []  # (out index, mono index, product index, value)
        n_m = n * n
        for j in used:
            for r_full, rows in enumerate(cb.psi_data[j]):
                name_r = q_names[r_full]
                if name_r not in row_of:
                    continue
                r = row_of[name_r]
                for term_atoms, num, den, lexp in rows:
                    value = num / den * float(np.prod(L ** np.array(lexp, dtype=float)))
                    col = None
                    mono = []
                    zero = False
                    for a, p in term_atoms:
                        if a in col_of:
                            col = col_of[a]
                            continue
                        if a.startswith("dd"):
                            zero = True  # acceleration of a removed strain
                            break
                        base = a[1:] if a.startswith("d") else a
                        if base in removed:
                            zero = True
                            break
                        idx = atoms.setdefault(a, len(atoms))
                        mono += [idx] * p
                    if zero:
                        continue
                    key = tuple(sorted(mono))
                    mi = monos.setdefault(key, len(monos))
                    out = r * n + col if col is not None else n_m + r
                    entries.append((out, mi, int(j), value))
        depth = max((len(k) for k in monos), default=1) or 1
        E = np.zeros((len(monos), depth), dtype=np.intp)
        for key, mi in monos.items():
            E[mi, : len(key)] = key
        self.E = E
        self.n = n
        self.n_out = n_m + n
        ent = np.array([(o, mi, j) for o, mi, j, _v in entries], dtype=np.intp).reshape(-1, 3)
        self.ent_out, self.ent_mono, self.ent_prod = ent[:, 0], ent[:, 1], ent[:, 2]
        self.ent_val = np.array([v for *_x, v in entries])
        self.n_mono = len(monos)
        # atom evaluation plan
        names = list(atoms)
        self.n_atoms = len(names)
        self.iq = np.array([atoms.get(a, -1) for a in active])
        self.iqd = np.array([atoms.get("d" + a, -1) for a in active])
        self.kap_full = np.array([3 * i for i in range(m)])
        self.active_pos = {k: r for r, k in enumerate(np.flatnonzero(mask))}
        self.kap_from_active = np.array([self.active_pos.get(3 * i, -1) for i in range(m)])
        self.L = L.copy()
        sf_atoms = [a for a in names if a.startswith("F")]
        sf_names = sorted({a[1:].rsplit("_", 1)[0] for a in sf_atoms})
        self.bank = _special.SpecialBank(sf_names) if sf_names else None
        self.isf = np.array([atoms[a] for a in sf_atoms], dtype=np.intp)
        self.sf_pick = np.array(
            [
                (int(a.rsplit("_", 1)[1]) - 1) * len(sf_names) + sf_names.index(a[1:].rsplit("_", 1)[0])
                for a in sf_atoms
            ],
            dtype=np.intp,
        )
        trig_atoms = [a for a in names if a[0] in "cs" and not a.startswith("sh_")]
        phases = np.array(
            [[-int(p[1:]) if p.startswith("m") else int(p) for p in a[1:].split("_")] for a in trig_atoms], dtype=float
        ).reshape(-1, m)
        self.phases = phases
        self.itrig = np.array([atoms[a] for a in trig_atoms], dtype=np.intp)
        self.is_cos = np.array([a[0] == "c" for a in trig_atoms], dtype=bool)
        self.msym = np.arange(n * n)

    def matrix(self, pi_g: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Outputs = A @ monomials for these coefficients (unused monomials dropped)."""
        A = np.zeros((self.n_out, self.n_mono))
        np.add.at(A, (self.ent_out, self.ent_mono), self.ent_val * pi_g[self.ent_prod])
        keep = np.flatnonzero(np.any(A != 0, axis=0))
        A = np.ascontiguousarray(A[:, keep])
        if A.shape[1] > 256:  # two or more segments: A is sparse, CSR products are far cheaper
            A = sparse.csr_matrix(A)
        return A, np.ascontiguousarray(self.E[keep].T)

    def evaluate(self, pi_g, damping, q, qd, chunk: int = 256):
        """Batched M (N, n, n) and bias (N, n) for active-strain states q, qd (N, n)."""
        A, E = self.matrix(pi_g)
        N, n = q.shape[0], self.n
        m = self.L.size
        kap_pos = self.kap_from_active
        kap_ok = kap_pos >= 0
        is_cos = self.is_cos
        out = np.empty((N, self.n_out))
        for start in range(0, N, chunk):
            sl = slice(start, min(start + chunk, N))
            k = sl.stop - sl.start
            a = np.zeros((k, self.n_atoms))
            a[:, 0] = 1.0
            has_q, has_qd = self.iq >= 0, self.iqd >= 0
            a[:, self.iq[has_q]] = q[sl][:, has_q]
            a[:, self.iqd[has_qd]] = qd[sl][:, has_qd]
            u = np.zeros((k, m))
            u[:, kap_ok] = q[sl][:, kap_pos[kap_ok]] * self.L[kap_ok]
            if self.bank is not None:
                a[:, self.isf] = self.bank(u.reshape(-1)).reshape(k, -1)[:, self.sf_pick]
            if self.itrig.size:
                ang = u @ self.phases.T
                a[:, self.itrig[is_cos]] = np.cos(ang[:, is_cos])
                a[:, self.itrig[~is_cos]] = np.sin(ang[:, ~is_cos])
            out[sl] = (A @ a[:, E].prod(axis=1).T).T
        n_m = n * n
        return out[:, :n_m].reshape(N, n, n), out[:, n_m:] + np.asarray(damping) * qd

    def _block_tables(self):
        """Per-atom special-function tables: one matmul evaluates every (function, segment) atom."""
        if hasattr(self, "_blocks"):
            return self._blocks
        bank = self.bank
        m = self.L.size
        K = _FAST_SERIES_ORDER + 1
        nb = bank.closed.shape[0]
        n_sf = len(bank.names)
        seg = self.sf_pick // n_sf
        fn = self.sf_pick % n_sf
        T = np.zeros((m * K, fn.size))
        C = np.zeros((m * nb, fn.size))
        for k, (sg, f) in enumerate(zip(seg, fn)):
            T[sg * K : (sg + 1) * K, k] = bank.taylor[:K, f]
            C[sg * nb : (sg + 1) * nb, k] = bank.closed[:, f]
        self._blocks = (T, C, seg)
        return self._blocks

    def make(self, pi_g: NDArray[np.float64], damping: NDArray[np.float64]):
        A, E = self.matrix(pi_g)
        n, n_m = self.n, self.n * self.n
        m = self.L.size
        # atoms re-ordered as [1, q (n), qd (n), special functions, cos, sin] so that the
        # atom vector is one concatenate per call
        pos = np.zeros(self.n_atoms, dtype=np.intp)
        for r in range(n):
            if self.iq[r] >= 0:
                pos[self.iq[r]] = 1 + r
            if self.iqd[r] >= 0:
                pos[self.iqd[r]] = 1 + n + r
        n_sfa = self.isf.size
        pos[self.isf] = 1 + 2 * n + np.arange(n_sfa)
        icos, isin = self.itrig[self.is_cos], self.itrig[~self.is_cos]
        pos[icos] = 1 + 2 * n + n_sfa + np.arange(icos.size)
        pos[isin] = 1 + 2 * n + n_sfa + icos.size + np.arange(isin.size)
        E = np.ascontiguousarray(pos[E])
        pcos, psin = self.phases[self.is_cos], self.phases[~self.is_cos]
        kap_rows = [(int(self.kap_from_active[i]), float(self.L[i])) for i in range(m)]
        d = np.array(damping, dtype=float)
        one = np.ones(1)
        radius = _FAST_SERIES_RADIUS
        cos, sin, concatenate, asarray = np.cos, np.sin, np.concatenate, np.asarray
        if self.bank is not None:
            T, C, seg = self._block_tables()
            powers = np.arange(_FAST_SERIES_ORDER + 1)
            ms, mcos, msin, mone = self.bank._ms, self.bank._mcos, self.bank._msin, self.bank._mone
            jpow = self.bank._jpowers
            seg_of_atom = seg

            def special_values(u_list):
                u = asarray(u_list)
                if all(-radius < x < radius for x in u_list):
                    return (u[:, None] ** powers).ravel() @ T
                small = [-radius < x < radius for x in u_list]
                ul = np.where(small, 1.0, u)  # the closed form is only used away from 0
                w = ul[:, None] * ms
                trig = cos(w) * mcos + sin(w) * msin + mone
                closed = (trig[:, :, None] * ((1.0 / ul)[:, None] ** jpow)[:, None, :]).ravel() @ C
                if not any(small):
                    return closed
                series = (u[:, None] ** powers).ravel() @ T
                return np.where(asarray(small)[seg_of_atom], series, closed)
        else:

            def special_values(u_list):
                return np.zeros(0)

        def dynamics(q, qd):
            u_list = [q[k] * Lk if k >= 0 else 0.0 for k, Lk in kap_rows]
            u = asarray(u_list)
            a = concatenate((one, q, qd, special_values(u_list), cos(pcos @ u), sin(psin @ u)))
            v = A @ a[E].prod(axis=0)
            return v[:n_m].reshape(n, n), v[n_m:] + d * qd

        return dynamics
