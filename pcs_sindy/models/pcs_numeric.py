"""Numeric core of the physically parameterised PCS library.

Backbone points are complex numbers ``z = x + i y``.  Segment ``j`` with strains
``(kappa_j, sigma_sh,j, sigma_ax,j)`` contributes the displacement

    T_j(l) = e^{i phi_j} w_j F(kappa_j, l),    w_j = sigma_sh,j + i (1 + sigma_ax,j),
    F(kappa, l) = int_0^l e^{i kappa t} dt = l E_0(kappa l),

where ``phi_j = sum_{k<j} kappa_k L_k`` is the orientation of the segment's
start and ``E_n(u) = int_0^1 t^n e^{iut} dt``.  Then
``dF/dkappa = i l^2 E_1`` and ``d^2F/dkappa^2 = -l^3 E_2`` give the Jacobian
and every time derivative in closed form; no finite differences anywhere.

For a point in segment ``i`` the Jacobian column of strain ``(k, c)`` is

* ``k == i``: the segment's *own* derivative ``e^{i phi_i} [w_i F_kappa, F, i F]`` at ``l = s``;
* ``k < i``: the own derivative of segment ``k`` at ``l = L_k``, plus, for the
  bending strain, the rigid swing ``i L_k (z - Z_k^end)`` about segment ``k``'s end;
* ``k > i``: zero.

Every regressor column is a weighted quadrature sum ``sum_p w_p conj(J(p)) v_p``
of such columns against a complex field ``v`` at the nodes.  Because the
``k < i`` columns are affine in ``z``, those sums reduce to two sums per segment
(``sum w v`` and ``sum w conj(z) v``): the cost is O(m K + m^2) per sample
instead of O(m^2 K).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import _jit_dynamics

__all__ = ["moments", "Quadrature", "make_quadrature", "kinematic_fields", "project", "jacobian", "rotary_mass"]


def moments(u: NDArray[np.float64]) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128]]:
    """``E_n(u) = int_0^1 t^n e^{iut} dt`` for n = 0, 1, 2 of every element, exact through ``u = 0``.

    The compiled :func:`pcs_sindy.models._jit_dynamics.moments` applied element-wise: the
    one implementation of these integrals on the identification side (Taylor
    series near 0, integration by parts elsewhere; about 1e-15 absolute).
    """
    u = np.asarray(u, dtype=float)
    e0, e1, e2 = _jit_dynamics.moments_array(np.ascontiguousarray(u.reshape(-1)))
    return e0.reshape(u.shape), e1.reshape(u.shape), e2.reshape(u.shape)


@dataclass(frozen=True)
class Quadrature:
    """Gauss–Legendre nodes of every segment.

    Attributes
    ----------
    lengths : ndarray, shape (m,)
    ell : ndarray, shape (m, K + 1)
        Local arc lengths: the K nodes of each segment, then its length.
    weights : ndarray, shape (m, K)
    """

    lengths: NDArray[np.float64]
    ell: NDArray[np.float64]
    weights: NDArray[np.float64]

    @property
    def n_nodes(self) -> int:
        return self.weights.shape[1]


def make_quadrature(lengths: NDArray[np.float64], n_quadrature: int) -> Quadrature:
    """Gauss–Legendre rule with ``n_quadrature`` nodes on each segment."""
    x, w = np.polynomial.legendre.leggauss(int(n_quadrature))
    L = np.asarray(lengths, dtype=float)
    nodes = 0.5 * (x + 1.0)[None, :] * L[:, None]
    weights = 0.5 * w[None, :] * L[:, None]
    return Quadrature(L, np.concatenate([nodes, L[:, None]], axis=1), weights)


def kinematic_fields(
    quad: Quadrature,
    q: NDArray[np.float64],
    qd: NDArray[np.float64] | None = None,
    qdd: NDArray[np.float64] | None = None,
    *,
    jacobian_rate: bool = False,
) -> dict[str, NDArray]:
    """Positions, velocities, accelerations and own-derivative terms at the nodes.

    Parameters
    ----------
    quad : Quadrature
    q, qd, qdd : ndarray, shape (B, 3m)
        Full strains (inactive ones at 0) and their rates.  Without ``qd`` only
        positions and own derivatives are computed; with ``qd`` velocities; with
        ``qdd`` accelerations (``qdd`` may be all zeros for ``J̇ q̇``).
    jacobian_rate : bool
        Also return the own terms of ``J̇`` (needed by the weak form).

    Returns
    -------
    dict with (complex arrays)
        ``z`` (B, m, K) node positions, ``zend`` (B, m) segment ends,
        ``own`` (B, m, K+1, 3) own derivatives (last node index = segment end),
        and with ``qd``: ``zd``, ``zdend``; with ``qdd``: ``zdd``;
        with ``jacobian_rate``: ``owndot`` (B, m, K+1, 3).
    """
    B = q.shape[0]
    L, ell = quad.lengths, quad.ell
    m, K = L.size, quad.n_nodes
    qs = q.reshape(B, m, 3)
    kappa = qs[..., 0]
    w = (qs[..., 1] + 1j * (1.0 + qs[..., 2]))[..., None]  # (B, m, 1)
    e0, e1, e2 = moments(kappa[..., None] * ell)
    F = ell * e0
    Fk = 1j * ell**2 * e1
    turn = kappa * L
    phi = np.cumsum(turn, axis=1) - turn  # exclusive: orientation of each segment start
    eph = np.exp(1j * phi)[..., None]  # (B, m, 1)
    T = eph * w * F  # (B, m, K+1)
    zstart = np.cumsum(T[..., K], axis=1) - T[..., K]
    out: dict[str, NDArray] = {
        "z": zstart[..., None] + T[..., :K],
        "zend": zstart + T[..., K],
    }
    ephF = eph * F
    out["own"] = np.stack([eph * w * Fk, ephF, 1j * ephF], axis=-1)
    if qd is None:
        return out
    qds = qd.reshape(B, m, 3)
    kd = qds[..., 0][..., None]
    wd = (qds[..., 1] + 1j * qds[..., 2])[..., None]
    turn_d = qds[..., 0] * L
    phid = (np.cumsum(turn_d, axis=1) - turn_d)[..., None]
    # X = e^{-i phi} dT/dt
    X = 1j * phid * w * F + wd * F + w * Fk * kd
    Td = eph * X
    zdstart = np.cumsum(Td[..., K], axis=1) - Td[..., K]
    out["zd"] = zdstart[..., None] + Td[..., :K]
    out["zdend"] = zdstart + Td[..., K]
    Fkk = None
    if qdd is not None:
        Fkk = -(ell**3) * e2
        qdds = qdd.reshape(B, m, 3)
        kdd = qdds[..., 0][..., None]
        wdd = (qdds[..., 1] + 1j * qdds[..., 2])[..., None]
        turn_dd = qdds[..., 0] * L
        phidd = (np.cumsum(turn_dd, axis=1) - turn_dd)[..., None]
        Tdd = eph * (
            (1j * phidd - phid**2) * w * F
            + 2j * phid * (wd * F + w * Fk * kd)
            + 2.0 * wd * Fk * kd
            + w * Fkk * kd**2
            + w * Fk * kdd
            + wdd * F
        )
        zddstart = np.cumsum(Tdd[..., K], axis=1) - Tdd[..., K]
        out["zdd"] = zddstart[..., None] + Tdd[..., :K]
    if jacobian_rate:
        if Fkk is None:
            Fkk = -(ell**3) * e2
        sh_dot = eph * (1j * phid * F + Fk * kd)
        be_dot = eph * (1j * phid * w * Fk + wd * Fk + w * Fkk * kd)
        out["owndot"] = np.stack([be_dot, sh_dot, 1j * sh_dot], axis=-1)
    return out


def project(
    quad: Quadrature,
    own: NDArray[np.complex128],
    z: NDArray[np.complex128],
    zend: NDArray[np.complex128],
    v: NDArray[np.complex128] | complex,
) -> NDArray[np.complex128]:
    """Per-segment quadrature sums ``P[b, i, k, c] = sum_{p in i} w_p conj(J_(k,c)(p)) v_p``.

    ``own``, ``z``, ``zend`` define the "Jacobian" (pass ``owndot``, ``zd``,
    ``zdend`` for ``J̇``).  ``Re P[b, i]`` flattened over ``(k, c)`` is the
    generalised force of the field ``v`` acting on segment ``i``.

    Returns
    -------
    ndarray, shape (B, m, m, 3), complex
    """
    B, m, K = z.shape
    L = quad.lengths
    wv = quad.weights * np.broadcast_to(v, z.shape)  # (B, m, K)
    V = wv.sum(axis=-1)  # (B, m)
    W = np.einsum("bik,bik->bi", np.conj(z), wv)
    own_end = np.conj(own[:, :, K, :])  # (B, m, 3)
    P = own_end[:, None, :, :] * V[:, :, None, None]  # [b, i, k, c]
    P[..., 0] += -1j * L[None, None, :] * (W[:, :, None] - np.conj(zend)[:, None, :] * V[:, :, None])
    lower = np.tril(np.ones((m, m), dtype=bool), -1)
    P *= lower[None, :, :, None]
    diag = np.arange(m)
    P[:, diag, diag, :] = np.einsum("bikc,bik->bic", np.conj(own[:, :, :K, :]), wv)
    return P


def jacobian(quad: Quadrature, fields: dict[str, NDArray]) -> NDArray[np.complex128]:
    """Full positional Jacobian at the nodes, shape (B, m, K, 3m) complex (``dz/dq``)."""
    own, z, zend = fields["own"], fields["z"], fields["zend"]
    B, m, K = z.shape
    L = quad.lengths
    J = np.zeros((B, m, K, m, 3), dtype=complex)
    lower = np.tril(np.ones((m, m), dtype=bool), -1)
    J[...] = own[:, None, None, :, K, :]  # [b, i, p, k, c] = own_k(L_k)
    J[..., 0] += 1j * L[None, None, None, :] * (z[..., None] - zend[:, None, None, :])
    J *= lower[None, :, None, :, None]
    diag = np.arange(m)
    J[:, diag, :, diag, :] = own[:, :, :K, :].transpose(1, 0, 2, 3)
    return J.reshape(B, m, K, 3 * m)


def rotary_mass(lengths: NDArray[np.float64]) -> NDArray[np.float64]:
    """``M_I,i = int_{seg i} J_o^T J_o ds`` per segment, exact, shape (m, 3m, 3m).

    ``theta(s) = sum_{k<i} kappa_k L_k + kappa_i s`` is linear in the strains.
    """
    L = np.asarray(lengths, dtype=float)
    m = L.size
    out = np.zeros((m, 3 * m, 3 * m))
    for i in range(m):
        a = np.zeros(3 * m)
        a[0 : 3 * i : 3] = L[:i]
        e = np.zeros(3 * m)
        e[3 * i] = 1.0
        Li = L[i]
        out[i] = Li * np.outer(a, a) + 0.5 * Li**2 * (np.outer(a, e) + np.outer(e, a)) + Li**3 / 3.0 * np.outer(e, e)
    return out
