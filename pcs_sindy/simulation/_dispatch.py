"""The integrators' view of a robot: its compiled state derivative, picked by the geometry tuple.

:mod:`pcs_sindy.simulation._radau` and :mod:`pcs_sindy.simulation.integrate` integrate the planar
robot (:mod:`._kernels`, a 13-entry geometry tuple) and the spatial one (:mod:`._spatial_kernels`,
``GEO_SIZE`` entries, on the shared terms of :mod:`pcs_sindy.core.spatial_kernels`) with the same
code.  The functions here are resolved at compile time by numba from the type of ``geo``
(:func:`numba.extending.overload`), so the compiled integrator calls the robot's kernels directly
and stays cacheable.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.core.errors import TypingError
from numba.extending import overload

from . import _kernels, _spatial_kernels

PLANAR_GEO_SIZE = 13
if _spatial_kernels.GEO_SIZE == PLANAR_GEO_SIZE:  # pragma: no cover - a layout change must keep them apart
    raise ImportError("the planar and spatial geometry tuples must differ in length")


def _kernels_of(geo):
    """The kernel module of a geometry tuple's numba type."""
    size = len(getattr(geo, "types", ()))
    if size == PLANAR_GEO_SIZE:
        return _kernels
    if size == _spatial_kernels.GEO_SIZE:
        return _spatial_kernels
    sizes = f"{PLANAR_GEO_SIZE} or {_spatial_kernels.GEO_SIZE}"
    raise TypingError(f"geo must be a robot geometry tuple ({sizes} entries); got {geo}")


def workspace(geo):
    """Scratch arrays of the robot of ``geo`` (compiled code only)."""
    raise NotImplementedError("compiled dispatch only")


def rhs_ws(y, u, geo, ws, out):
    """State derivative of the robot of ``geo`` (compiled code only)."""
    raise NotImplementedError("compiled dispatch only")


def accel_jacobian(y, f0, u, geo, ws, jac):
    """Acceleration Jacobian of the robot of ``geo`` (compiled code only)."""
    raise NotImplementedError("compiled dispatch only")


@overload(workspace)
def _workspace(geo):
    impl = _kernels_of(geo).workspace
    return lambda geo: impl(geo)


@overload(rhs_ws)
def _rhs_ws(y, u, geo, ws, out):
    impl = _kernels_of(geo).rhs_ws
    return lambda y, u, geo, ws, out: impl(y, u, geo, ws, out)


@overload(accel_jacobian)
def _accel_jacobian(y, f0, u, geo, ws, jac):
    impl = _kernels_of(geo).accel_jacobian
    return lambda y, f0, u, geo, ws, jac: impl(y, f0, u, geo, ws, jac)


@njit(cache=True)
def rhs_batch(Y, U, geo):
    """State derivatives (B, 2n) of states (B, 2n) under inputs (B, p)."""
    out = np.empty_like(Y)
    ws = workspace(geo)
    for b in range(Y.shape[0]):
        rhs_ws(Y[b], U[b], geo, ws, out[b])
    return out


@njit(cache=True)
def state_jacobian_batch(Y, U, geo):
    """Jacobians (B, 2n, 2n) ``[[0, I], [∂q̈/∂q, ∂q̈/∂q̇]]`` of the state derivative (scipy's implicit methods)."""
    B, N = Y.shape
    n = N // 2
    out = np.zeros((B, N, N))
    ws = workspace(geo)
    f0 = np.empty(N)
    jac = np.empty((n, N))
    for b in range(B):
        rhs_ws(Y[b], U[b], geo, ws, f0)
        accel_jacobian(Y[b], f0, U[b], geo, ws, jac)
        for r in range(n):
            out[b, r, n + r] = 1.0
            for c in range(N):
                out[b, n + r, c] = jac[r, c]
    return out
