"""Compiled (numba) dynamics of spatial (3-D) PCS models with lumped per-segment parameters.

The spatial counterpart of :mod:`pcs_sindy.models._jit_dynamics`, with the same entry points
(:func:`dynamics`, :func:`input_forces`, :func:`rhs`, :func:`mass_bias_batch`, :func:`workspace`) so
the rollout loops of :mod:`pcs_sindy.models._jit_rollout` run either model.  The mass, Coriolis and
gravity terms of all 6m strains are the shared kernels of :mod:`pcs_sindy.core.spatial_kernels` (also
the spatial simulator's), on a body whose node weights come from the lumped parameters
(``w ρA_i``, ``w ρI_i (1, 2, 1)``, ``w (ρA g)_i``); this module holds the model's side: the modelled
(active) strains, the unmodelled ones held at 0 (their rows and columns dropped after the full
evaluation), stiffness, damping, the constant force and the input map.  It must not know the
simulator's materials or how the parameters were identified.

``P = (act (n,), body, f0 (n,), akind (1,), aoff, acover, amat, stiff (n,), damp (n,))`` (:data:`P_SIZE`
entries; ``stiff``, ``damp`` at the planar tuple's positions 7 and 8, where the Rosenbrock loop reads
its structural Jacobian) and ``W = (M (n, n), bias (n,), ws, q (6m,), qd (6m,), r (n,), tau (n,),
G (6m,), C (6m,), factor (n, n), pivots (n,))`` (:func:`workspace`; ``ws`` the shared kernels'
scratch).  The input map ``akind`` is a code of :data:`pcs_sindy.models._jit_dynamics.INPUT_MAPS` among
:data:`INPUT_FORMS`: the maps that do not depend on the segmentation's strain layout.
"""

from __future__ import annotations

import numba
import numpy as np

from ..core.linalg import lu_factor, lu_solve
from ..core.spatial_kernels import cholesky, cholesky_solve, coriolis, geometry, gravity_forces, mass
from ..core.spatial_kernels import workspace as body_workspace
from ._jit_dynamics import strain_layout_free_forces

__all__ = ["dynamics", "input_forces", "rhs", "mass_bias_batch", "workspace", "P_SIZE", "INPUT_FORMS"]

#: entries of the parameter tuple ``P``
P_SIZE = 9
#: the compiled input maps of a spatial model (names of :data:`pcs_sindy.models.actuation.COMPILED_FORMS`)
INPUT_FORMS = ("forces", "matrix", "affine")


def workspace(P: tuple) -> tuple:
    """Work arrays ``W`` (module docstring) for the parameters ``P``."""
    act, body = P[0], P[1]
    n, N = act.size, 6 * body[0].size
    return (
        np.empty((n, n)),
        np.empty(n),
        body_workspace(body),
        np.zeros(N),
        np.zeros(N),
        np.empty(n),
        np.empty(n),
        np.empty(N),
        np.empty(N),
        np.empty((n, n)),
        np.zeros(n, dtype=np.int64),
    )


# inlined into rhs: one call less per evaluation (each passes the ~40 arrays of P and W, reference counted)
@numba.njit(cache=True, inline="always")
def dynamics(q, qd, P, W):
    """Fill ``W[0] = M`` (n, n) and ``W[1] = bias`` (n,) at the modelled strains ``q``, ``qd`` (n,)."""
    act, body, f0, stiff, damp = P[0], P[1], P[2], P[7], P[8]
    M, bias, ws, qf, qdf, G, C = W[0], W[1], W[2], W[3], W[4], W[7], W[8]
    n = act.size
    for a in range(qf.size):
        qf[a] = 0.0
        qdf[a] = 0.0
    for a in range(n):
        qf[act[a]] = q[a]
        qdf[act[a]] = qd[a]
    geometry(qf, body, ws, False)
    Mf = ws[6]
    mass(body, ws, Mf)
    gravity_forces(body, ws, G)
    coriolis(qdf, body, ws, C)
    for a in range(n):
        ca = act[a]
        bias[a] = G[ca] + C[ca] + stiff[a] * q[a] + damp[a] * qd[a] - f0[a]
        for b in range(n):
            M[a, b] = Mf[ca, act[b]]


@numba.njit(cache=True, inline="always")
def input_forces(q, u, P, tau):
    """``tau = A(q) u`` on the modelled strains ``q`` (n,) for the input map of ``P``."""
    if not strain_layout_free_forces(P[3][0], P[6], q, u, tau):
        for a in range(tau.size):
            tau[a] = np.nan  # a map this module does not evaluate (the model refuses it when built)


@numba.njit(cache=True)
def rhs(y, u, P, W, out):
    """``out = [qd, M^-1 (A(q) u - bias)]`` at the state ``y = [q, qd]``; False if ``M`` is singular."""
    n = P[0].size
    tau = W[6]
    input_forces(y[:n], u, P, tau)
    dynamics(y[:n], y[n:], P, W)
    M, bias, r, LU, piv = W[0], W[1], W[5], W[9], W[10]
    for a in range(n):
        out[a] = y[n + a]
        r[a] = tau[a] - bias[a]
    acc = out[n:]
    # Cholesky (half the work of LU), and LU where it fails: an identified M need not be positive definite
    if cholesky(M, LU):
        cholesky_solve(LU, r, acc)
        return True
    for a in range(n):
        acc[a] = r[a]
        for b in range(n):
            LU[a, b] = M[a, b]
    if not lu_factor(LU, piv):
        return False
    lu_solve(LU, piv, acc)
    return True


@numba.njit(cache=True)
def mass_bias_batch(q, qd, P, W):
    """``M`` (B, n, n) and bias (B, n) at the states ``q``, ``qd`` (B, n)."""
    B, n = q.shape
    Ms = np.empty((B, n, n))
    bs = np.empty((B, n))
    for b in range(B):
        dynamics(q[b], qd[b], P, W)
        Ms[b] = W[0]
        bs[b] = W[1]
    return Ms, bs
