"""Compiled (numba) state derivative of the spatial (3-D) PCS simulator: the robot's side of the kernels.

The spatial counterpart of :mod:`pcs_sindy.simulation._kernels`, with the same entry points
(:func:`workspace`, :func:`rhs_ws`, :func:`accel_jacobian`) so that the integrators of
:mod:`pcs_sindy.simulation._radau` and :mod:`pcs_sindy.simulation.integrate` run either robot
(:mod:`pcs_sindy.simulation._dispatch` picks by the geometry tuple, and holds the batched state
derivative and its Jacobian for scipy's integrators).  The mass, Coriolis and gravity terms are the
shared kernels of :mod:`pcs_sindy.core.spatial_kernels` (also those of the identified spatial model);
this module adds what only the simulator knows: the stiffness and damping of all 6m strains and the
actuation ``τ = A(q) u``.  It must not know the identified models' parameterisation.

Robot structure is the tuple ``geo`` built by ``SpatialPCSRobot._jit_geometry``, of
:data:`GEO_SIZE` entries (the planar tuple has 13):

``(body, stiffness (n,), damping (n,), act_kind (int), tendon_offset (p, 2), tendon_span (p, m),
act_matrix (n, p))``

with ``body`` the tuple of :func:`pcs_sindy.core.spatial_kernels.body_tuple` (node weights
``w ρA``, ``w (ρI, 2ρI, ρI)`` and ``w ρA g``).  Actuation: ``act_kind``
:data:`~pcs_sindy.simulation._kernels.ACT_IDENTITY` (``u`` is τ) or
:data:`~pcs_sindy.simulation._kernels.ACT_TENDON` (tendons at body offsets ``(d_x, d_z)`` covering
``tendon_span[k, i]`` of segment i: ``A = −∂ℓ/∂q``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..core.spatial_kernels import (
    cholesky,
    cholesky_solve,
    coriolis,
    geometry,
    gravity_forces,
    mass,
    tendon_terms,
)
from ..core.spatial_kernels import workspace as body_workspace
from ._kernels import ACT_IDENTITY, ACT_TENDON

GEO_SIZE = 7

# as the shared kernels: no reassociation (a planar motion must stay exactly in the plane)
_FAST = False


@njit(cache=True)
def workspace(geo):
    """Scratch arrays of one state (:func:`pcs_sindy.core.spatial_kernels.workspace` of the body)."""
    return body_workspace(geo[0])


# --------------------------------------------------------------------------
# actuation τ = A(q) u, state derivative, its Jacobian
# --------------------------------------------------------------------------
@njit(cache=True, fastmath=_FAST, inline="always")
def actuation_forces(q, u, geo, tau):
    """Generalised forces ``τ = A(q) u`` (n,) of the inputs ``u`` (p,), into ``tau``."""
    kind, offset, span, matrix = geo[3], geo[4], geo[5], geo[6]
    n = tau.shape[0]
    if kind == ACT_IDENTITY:
        for a in range(n):
            tau[a] = u[a]
    elif kind == ACT_TENDON:
        p = offset.shape[0]
        length = np.empty(p)
        dlength = np.empty((p, n))
        tendon_terms(q, offset, span, length, dlength)
        for a in range(n):
            v = 0.0
            for k in range(p):
                v -= dlength[k, a] * u[k]  # a tension does the virtual work −f δℓ
            tau[a] = v
    else:
        for a in range(n):
            v = 0.0
            for k in range(u.shape[0]):
                v += matrix[a, k] * u[k]
            tau[a] = v


@njit(cache=True, fastmath=_FAST, inline="always")
def _accel_given_geometry(qd, geo, ws, out):
    """``q̈`` at ``(q, qd)`` when ``ws`` holds the geometry, Cholesky factor, static and actuation forces of q."""
    damping = geo[2]
    chol, vec = ws[7], ws[8]
    static, cq, r, tau = vec[0], vec[1], vec[2], vec[4]
    coriolis(qd, geo[0], ws, cq)
    for a in range(tau.shape[0]):
        r[a] = tau[a] - static[a] - cq[a] - damping[a] * qd[a]
    cholesky_solve(chol, r, out)


@njit(cache=True, fastmath=_FAST, inline="always")
def rhs_ws(y, u, geo, ws, out):
    """State derivative ``[q̇, q̈]`` with scratch arrays; False (and NaN accelerations) if M is not definite."""
    stiffness = geo[1]
    n = y.shape[0] // 2
    q = y[:n]
    qd = y[n:]
    geometry(q, geo[0], ws, False)
    M, chol, vec = ws[6], ws[7], ws[8]
    mass(geo[0], ws, M)
    gravity_forces(geo[0], ws, vec[0])
    static, qdd = vec[0], vec[3]
    for a in range(n):
        static[a] += stiffness[a] * q[a]
    actuation_forces(q, u, geo, vec[4])
    for a in range(n):
        out[a] = qd[a]
    if not cholesky(M, chol):
        for a in range(n):
            out[n + a] = np.nan
        return False
    _accel_given_geometry(qd, geo, ws, qdd)
    for a in range(n):
        out[n + a] = qdd[a]
    return True


@njit(cache=True, fastmath=_FAST)
def accel_jacobian(y, f0, u, geo, ws, jac):
    """Forward differences ``jac = [∂q̈/∂q, ∂q̈/∂q̇]`` (n, 2n) at ``y`` with ``f0 = rhs(y)``.

    As the planar kernel: the velocity columns reuse the geometry and factor of ``q``.
    """
    n = y.shape[0] // 2
    N = 2 * n
    yp = y.copy()
    fp = np.empty(N)
    for c in range(n):
        delta = 1.5e-8 * max(abs(y[c]), 1e-3)
        yp[c] = y[c] + delta
        rhs_ws(yp, u, geo, ws, fp)
        yp[c] = y[c]
        for r in range(n):
            jac[r, c] = (fp[n + r] - f0[n + r]) / delta
    rhs_ws(y, u, geo, ws, fp)  # geometry, factor and forces of the unperturbed q
    qdd = np.empty(n)
    qdp = y[n:].copy()
    for c in range(n):
        delta = 1.5e-8 * max(abs(y[n + c]), 1e-3)
        qdp[c] = y[n + c] + delta
        _accel_given_geometry(qdp, geo, ws, qdd)
        qdp[c] = y[n + c]
        for r in range(n):
            jac[r, n + c] = (qdd[r] - f0[n + r]) / delta


@njit(cache=True, fastmath=_FAST)
def actuation_batch(Q, U, geo):
    """:func:`actuation_forces` for configurations (B, n) and inputs (B, p); τ (B, n)."""
    out = np.empty(Q.shape)
    for b in range(Q.shape[0]):
        actuation_forces(Q[b], U[b], geo, out[b])
    return out
