"""Batched numpy closed forms of the PCS backbone: positions, Jacobians and their time derivatives.

Backbone positions are complex numbers ``z = x + i y``.  With the shear/axial
strain packed into ``w = σ_sh + i (1 + σ_ax)`` the position inside a segment
that starts at ``z0`` with orientation ``φ`` is

    z(s) = z0 + e^{iφ} s w E_0(κ s),     E_n(u) = ∫_0^1 t^n e^{iut} dt,

and ``dE_n/du = i E_{n+1}``, so every derivative with respect to ``q`` (and
with respect to time, for the Coriolis terms) is again a closed form in
``E_0, E_1, E_2`` (:func:`backbone_moments`, exact at ``κ = 0``; no epsilon
is added to the curvature).  These functions evaluate whole batches of
states at the Gauss–Legendre nodes of a :class:`~pcs_sindy.simulation.dynamics.PCSRobot`
(the public evaluations, fast for large batches); the integrator uses the
single-state compiled kernels of :mod:`pcs_sindy.simulation._kernels`, which
also provide the moments here.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._kernels import moments_array

__all__ = ["backbone_moments", "segment_terms"]


def backbone_moments(u: ArrayLike) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128]]:
    """The moments ``E_n(u) = ∫_0^1 t^n e^{iut} dt`` for ``n = 0, 1, 2``.

    With ``t = 1/2 + τ`` and ``v = u/2`` they are
    ``E_0 = e^{iv} sinc v``, ``E_1 = e^{iv} (sinc v − i sinc' v)/2`` and
    ``E_2 = e^{iv} (sinc v − 2i sinc' v − sinc'' v)/4``, which are exact at
    ``u = 0`` (values 1, 1/2, 1/3).

    Parameters
    ----------
    u : array_like of float

    Returns
    -------
    E0, E1, E2 : ndarray of complex, shape of ``u``
    """
    u = np.asarray(u, dtype=float)
    e0, e1, e2 = moments_array(np.ascontiguousarray(u.reshape(-1)))
    return e0.reshape(u.shape), e1.reshape(u.shape), e2.reshape(u.shape)


def segment_terms(robot: Any, q: NDArray, qd: NDArray | None, need: str) -> dict[str, NDArray]:
    """Closed-form terms at every node and segment end of ``robot`` for flattened batches (B, n).

    ``need`` is one of ``"pos"`` (positions ``z``), ``"jac"`` (+ Jacobian
    ``J`` (B, m K, n)), ``"acc"`` (+ convective accelerations ``acc`` = J̇ q̇)
    or ``"jdot"`` (+ ``Jdot``).  ``robot`` provides the node structure built
    by ``PCSRobot._precompute``.
    """
    B, m, K = q.shape[0], robot.n_segments, robot.n_quadrature
    L = robot.segment_lengths
    qs = q.reshape(B, m, 3)
    kappa, w = qs[..., 0], qs[..., 1] + 1j * (1.0 + qs[..., 2])  # (B, m)
    ell, ell2 = robot._ell, robot._ell2
    e0, e1, e2 = backbone_moments(kappa[..., None] * ell)  # (B, m, K+1)
    phi = robot.base_pose[2] + np.cumsum(kappa * L, axis=1) - kappa * L  # start angle of each segment
    eph = np.exp(1j * phi)[..., None]  # (B, m, 1)
    wk = w[..., None]
    local = ell * wk * e0
    tseg = eph * local  # (B, m, K+1): displacement from the segment start
    z_start = robot._z_base + np.cumsum(tseg[..., K], axis=1) - tseg[..., K]  # (B, m)
    z_end = z_start + tseg[..., K]
    z_nodes = z_start[..., None] + tseg[..., :K]  # (B, m, K)
    out = {"z": z_nodes}
    if need == "pos":
        return out
    # derivative of each segment's displacement w.r.t. its own strains (κ, σ_sh, σ_ax)
    own = np.empty((B, m, K + 1, 3), dtype=complex)
    own[..., 0] = robot._i_ell2 * wk * e1
    own[..., 1] = ell * e0
    own[..., 2] = robot._i_ell * e0
    own *= eph[..., None]
    out["J"] = _assemble(robot, own, z_nodes, z_end)
    if need == "jac":
        return out
    qds = qd.reshape(B, m, 3)
    kd, wd = qds[..., 0], qds[..., 1] + 1j * qds[..., 2]
    phid = (np.cumsum(kd * L, axis=1) - kd * L)[..., None]  # angular velocity of each segment start
    kdk, wdk = kd[..., None], wd[..., None]
    local_d = robot._i_ell2 * wk * e1 * kdk + ell * e0 * wdk
    if need == "acc":
        local_dd = (-robot._ell3 * wk * e2 * kdk + 2.0 * robot._i_ell2 * e1 * wdk) * kdk
        tdd = eph * (-(phid**2) * local + 2j * phid * local_d + local_dd)
        acc = np.cumsum(tdd[..., K], axis=1) - tdd[..., K]
        out["acc"] = acc[..., None] + tdd[..., :K]
        return out
    td = eph * (1j * phid * local + local_d)
    zd_start = np.cumsum(td[..., K], axis=1) - td[..., K]
    zd_end = zd_start + td[..., K]
    zd_nodes = zd_start[..., None] + td[..., :K]
    own_local = own / eph[..., None]
    own_d = np.stack(
        [1j * ell2 * (wdk * e1 + 1j * ell * wk * e2 * kdk), 1j * ell2 * e1 * kdk, -ell2 * e1 * kdk], axis=-1
    )
    owndot = eph[..., None] * (1j * phid[..., None] * own_local + own_d)
    out["Jdot"] = _assemble(robot, owndot, zd_nodes, zd_end)
    return out


def _assemble(robot: Any, own: NDArray, z_nodes: NDArray, z_end: NDArray) -> NDArray[np.complex128]:
    """Jacobian (B, m·K, n) at the nodes from per-segment own derivatives and positions.

    Works for the Jacobian and, fed with time derivatives, for its time derivative.
    """
    B, m, K = z_nodes.shape
    jac = np.empty((B, m, K, m, 3), dtype=complex)
    jac[...] = np.where(robot._strict_b, own[:, None, None, :, K, :], 0.0)
    jac[:, robot._diag, :, robot._diag, :] = own[:, :, :K, :].transpose(1, 0, 2, 3)
    # bending of an earlier segment j swings the node rigidly about that segment's end
    lever = 1j * robot.segment_lengths[None, None, None, :] * (z_nodes[..., None] - z_end[:, None, None, :])
    jac[..., 0] += robot._strict[None, :, None, :] * lever
    return jac.reshape(B, m * K, robot.n_q)
