"""Dense LU with partial pivoting for compiled (numba) kernels.

Shared by the ground-truth simulator (:mod:`pcs_sindy.simulation._radau`, Newton
systems of its Radau IIA step) and the rollouts of identified models
(:mod:`pcs_sindy.models._jit_rollout`): generic linear algebra, no physics, so the
simulator stays an independent check of the identification side.  Ground
floor: imports nothing of the package.  The systems are small (a few dozen
unknowns at most), where a hand-written loop beats a LAPACK call's overhead.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def lu_factor(A, piv):
    """In-place LU with partial pivoting (``piv[k]`` = row swapped into k); False if singular.

    A zero, infinite or NaN pivot counts as singular.
    """
    n = A.shape[0]
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        if big == 0.0 or not np.isfinite(big):
            return False
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
    return True


@njit(cache=True)
def lu_solve(A, piv, x):
    """Solve in place with the factors of :func:`lu_factor`."""
    n = A.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
    for i in range(n):
        s = x[i]
        for k in range(i):
            s -= A[i, k] * x[k]
        x[i] = s
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= A[i, k] * x[k]
        x[i] = s / A[i, i]


@njit(cache=True)
def solve(M, r, out):
    """``out = M^{-1} r`` without touching ``M`` or ``r``; False if ``M`` is singular."""
    A = M.copy()
    piv = np.empty(M.shape[0], dtype=np.int64)
    if not lu_factor(A, piv):
        return False
    out[:] = r
    lu_solve(A, piv, out)
    return True
