"""Compiled (numba) strain fit of one frame, for state estimation at camera rate.

The same weighted least-squares problem as
:func:`pcs_sindy.fusion.shape_fit.fit_strains_least_squares` (marker poses of a
PCS robot against measured ones, Levenberg-Marquardt with Marquardt scaling),
for a single frame without numpy's per-call overhead: tens of microseconds
instead of milliseconds.  The closed forms are those of docs/method.md,
written out again here so that the two implementations check each other
(``tests/test_streaming.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..core.linalg import solve

__all__ = ["fit_frame", "fk_jacobian"]

_SMALL = 1e-3  # |kappa s| below which the series of sin(u)/u, (1 - cos u)/u and their derivatives are used


@njit(cache=True)
def _sc(u):
    """sin(u)/u, (1 - cos u)/u and their derivatives, exact through u = 0."""
    if abs(u) < _SMALL:
        u2 = u * u
        return 1.0 - u2 / 6.0, u / 2.0 - u * u2 / 24.0, -u / 3.0 + u * u2 / 30.0, 0.5 - u2 / 8.0
    s, c = np.sin(u), np.cos(u)
    return s / u, (1.0 - c) / u, (u * c - s) / (u * u), (u * s - (1.0 - c)) / (u * u)


@njit(cache=True)
def fk_jacobian(q, lengths, s, pose, jac):
    """Marker poses (P, 3) and their Jacobian (P, 3, 3m) at global arc lengths ``s``, base at the origin."""
    m = lengths.shape[0]
    P = s.shape[0]
    start = np.zeros((m + 1, 3))  # start pose of every segment (and the tip)
    for i in range(m):
        k, sh, ax = q[3 * i], q[3 * i + 1], q[3 * i + 2]
        L = lengths[i]
        S, C, _, _ = _sc(k * L)
        x, y = L * (sh * S - (1.0 + ax) * C), L * (sh * C + (1.0 + ax) * S)
        c0, s0 = np.cos(start[i, 2]), np.sin(start[i, 2])
        start[i + 1, 0] = start[i, 0] + c0 * x - s0 * y
        start[i + 1, 1] = start[i, 1] + s0 * x + c0 * y
        start[i + 1, 2] = start[i, 2] + k * L
    jac[:] = 0.0
    for j in range(P):
        # the segment holding this marker and the local arc length
        i = 0
        acc = 0.0
        while i < m - 1 and s[j] > acc + lengths[i]:
            acc += lengths[i]
            i += 1
        u_loc = s[j] - acc
        k, sh, ax = q[3 * i], q[3 * i + 1], q[3 * i + 2]
        S, C, _, _ = _sc(k * u_loc)
        x, y = u_loc * (sh * S - (1.0 + ax) * C), u_loc * (sh * C + (1.0 + ax) * S)
        c0, s0 = np.cos(start[i, 2]), np.sin(start[i, 2])
        pose[j, 0] = start[i, 0] + c0 * x - s0 * y
        pose[j, 1] = start[i, 1] + s0 * x + c0 * y
        pose[j, 2] = start[i, 2] + k * u_loc
        for g in range(i + 1):
            sg = u_loc if g == i else lengths[g]
            kg, shg, axg = q[3 * g], q[3 * g + 1], q[3 * g + 2]
            S, C, dS, dC = _sc(kg * sg)
            d = np.empty((2, 3))
            d[0, 0] = sg * sg * (shg * dS - (1.0 + axg) * dC)
            d[1, 0] = sg * sg * (shg * dC + (1.0 + axg) * dS)
            d[0, 1], d[1, 1] = sg * S, sg * C
            d[0, 2], d[1, 2] = -sg * C, sg * S
            cg, sn = np.cos(start[g, 2]), np.sin(start[g, 2])
            for c in range(3):
                jac[j, 0, 3 * g + c] = cg * d[0, c] - sn * d[1, c]
                jac[j, 1, 3 * g + c] = sn * d[0, c] + cg * d[1, c]
            if g < i:  # the marker swings rigidly about segment g's end when g bends
                jac[j, 0, 3 * g] += -sg * (pose[j, 1] - start[g + 1, 1])
                jac[j, 1, 3 * g] += sg * (pose[j, 0] - start[g + 1, 0])
            jac[j, 2, 3 * g] = sg


@njit(cache=True)
def _cost(q, lengths, s, target, w, pose, jac, r, J):
    fk_jacobian(q, lengths, s, pose, jac)
    P = s.shape[0]
    n = q.shape[0]
    total = 0.0
    for j in range(P):
        for c in range(3):
            e = pose[j, c] - target[j, c]
            if c == 2:
                e = (e + np.pi) % (2.0 * np.pi) - np.pi
            r[3 * j + c] = e * w[c]
            total += r[3 * j + c] * r[3 * j + c]
            for a in range(n):
                J[3 * j + c, a] = jac[j, c, a] * w[c]
    return total


@njit(cache=True)
def fit_frame(target, lengths, s, q0, w, max_iter, xtol):
    """Levenberg-Marquardt strains of one frame; returns (q, cost)."""
    n = q0.shape[0]
    P = s.shape[0]
    pose = np.empty((P, 3))
    jac = np.empty((P, 3, n))
    r = np.empty(3 * P)
    J = np.empty((3 * P, n))
    q = q0.copy()
    cost = _cost(q, lengths, s, target, w, pose, jac, r, J)
    lam = 1e-4
    q_new = np.empty(n)
    r_new = np.empty(3 * P)
    J_new = np.empty((3 * P, n))
    dq = np.empty(n)
    for _ in range(max_iter):
        JtJ = J.T @ J
        g = J.T @ r
        A = JtJ.copy()
        for a in range(n):
            A[a, a] += lam * (JtJ[a, a] + 1e-12)
        if not solve(A, -g, dq):
            break
        q_new[:] = q + dq
        c_new = _cost(q_new, lengths, s, target, w, pose, jac, r_new, J_new)
        if c_new <= cost:
            q[:] = q_new
            r[:] = r_new
            J[:] = J_new
            small = np.max(np.abs(dq)) <= xtol * (1.0 + np.max(np.abs(q)))
            flat = cost - c_new <= 1e-12 * cost
            cost = c_new
            lam *= 0.1
            if small or flat:
                break
        else:
            lam *= 10.0
            if lam > 1e12:
                break
    return q, cost
