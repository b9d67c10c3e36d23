"""Compiled (numba) dynamics terms of a spatial (3-D) PCS body at one state: the one implementation.

Used by the spatial simulator (:mod:`pcs_sindy.simulation.spatial_dynamics`, through its
``_spatial_kernels``: the ground truth, with physical parameters) and by the identified spatial
model (:mod:`pcs_sindy.models.spatial_forward`, through its ``_jit_spatial``: lumped per-segment
parameters).  This module knows the kinematics and the inertial and gravity terms of a body given by
per-node weights; it must not know where the weights come from (materials or identified
coefficients), nor stiffness, damping, actuation, which strains a caller models, or integrators.

Kinematics (conventions of :mod:`pcs_sindy.core.spatial`): inside segment i at local arc length
``s``, with ``W = s ω``, ``V = s v`` and ``u = |W|``, the pose relative to the segment's start is
``R = I + a Ŵ + b Ŵ²``, ``r = J(W) V``, ``J(W) = I + b Ŵ + c Ŵ²``.  Derivatives with respect to the
own strains are derivatives of ``J`` along ``Ẇ`` (coefficients ``b1 = b'/u``, ``c1 = c'/u`` and,
for the accelerations, ``b2``, ``c2``), every scalar by its Taylor series in ``u²`` below ``u = 3``
and its closed form above (no epsilon on any strain).  A node beyond segment j moves rigidly with
that segment's end: its Jacobian columns of segment j are the end's, plus the end's rotation
variation crossed with the lever to the node.  Accelerations at ``q̈ = 0`` (the Coriolis terms)
follow from the base-frame recursion ``p̈ = p̈0 + α0×R0r + Ω0×(Ω0×R0r) + 2Ω0×R0ṙ + R0r̈``,
``α = α0 + Ω0×R0Ω_loc + R0 Ω̇_loc``.

Dynamics (issue 26 conventions), all 6m strains: ``M = Σ_k (w_k J_pᵀJ_p + J_wᵀ diag(r_k) J_w)``
over Gauss–Legendre nodes k with the translational weight ``w_k`` (quadrature weight times ``ρA``)
and the body-frame rotational weights ``r_k`` (quadrature weight times ``(ρI, 2ρI, ρI)``, y the
tangent), ``J_w`` the body angular Jacobian;
``C q̇ = Σ_k (w_k J_pᵀ J̇_p q̇ + J_wᵀ (diag(r_k) J̇_w q̇ + ω_b × diag(r_k) ω_b))``;
``G = −Σ_k J_pᵀ f_k`` with the gravity force weight ``f_k`` of the node (quadrature weight times the
segment's gravity force per length, base frame: ``ρA g`` for a uniform field, an independent
``(ρA g)_i`` per segment for an identified model).  Only a node's own segment's columns are summed
node by node: a node of a later segment moves rigidly with an earlier segment's strains
(``J_p = v + θ × p``, ``J_w = Rᵀ θ`` for that segment end's twist ``(v, θ)`` at the origin), so those
entries of M, G and C q̇ are the same sums regrouped: projections of per-segment wrenches and
composite inertias on the end twists.

Quadrature tiers: each segment uses the fewest Gauss–Legendre nodes that are as accurate at its
``|ω_i| L_i`` (:data:`QUADRATURE_TIERS`, measured against a 48-node rule), the body's
``n_quadrature`` above the last bound; the node Jacobians (``jacobian_batch``) use all of them.

The body is the tuple ``body`` built by :func:`body_tuple`, of :data:`BODY_SIZE` entries:

``(L (m,), ell (T, m, K+1), w_lin (T, m, K), w_rot (T, m, K, 3), w_grav (T, m, K, 3),
base_position (3,), base_rotation (3, 3), tier_nodes (T,), tier_bounds (T,))``

with K = n_quadrature and T tiers: tier t has ``tier_nodes[t]`` nodes for a segment with
``|ω_i| L_i <= tier_bounds[t]`` (the last bound infinite, its nodes K).  ``ell[t, i]`` holds tier t's
nodes of segment i followed by its length; ``w_lin``, ``w_rot`` and ``w_grav`` the node weights above
(zero-padded to K).  Tendons (:func:`tendon_terms`): lengths and gradients only; how tensions act is
the caller's.
"""

from __future__ import annotations

from math import factorial

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

__all__ = [
    "BODY_SIZE",
    "QUADRATURE_TIERS",
    "body_tuple",
    "workspace",
    "geometry",
    "mass",
    "gravity_forces",
    "coriolis",
    "tendon_terms",
    "tendon_batch",
    "cholesky",
    "cholesky_solve",
    "terms_batch",
    "jacobian_batch",
]

#: entries of the body tuple (:func:`body_tuple`)
BODY_SIZE = 9

_SWITCH = 3.0  # u below which the scalar functions use their Taylor series in u² (24 terms)
_SWITCH_AB = 0.5
_N_TERMS = 24
# terms of the u² series that leave every omitted tail below 2e-18 of the value (measured over the seven
# rows at the bracket's upper end): (u bound, terms)
_TERMS_BY_U = np.array([[0.25, 7], [0.5, 8], [1.0, 10], [2.0, 13], [_SWITCH, 15]])

# Gauss-Legendre nodes a segment needs at |ω_i| L_i up to the bound: with them M, G and C q̇ agree with a
# 48-node quadrature to <= 2e-14 relative (measured at random strain directions, shears up to 0.3,
# velocities ~3); above the last bound the body's n_quadrature.  16 nodes reach ~3e-14 at 8 rad.
#: (bound on |ω_i| L_i [rad], Gauss–Legendre nodes) of the quadrature tiers
QUADRATURE_TIERS = ((0.15, 5), (0.5, 6), (1.0, 7), (2.0, 8), (3.0, 10), (6.0, 12), (8.0, 14))


def _series_tables() -> np.ndarray:
    """Rows: Taylor coefficients in u² of a, b, c, b1, c1, b2, c2 (``f_k = b'/u`` etc. termwise)."""

    def alternating(offset: int, n: int) -> list[float]:
        return [(-1) ** k / factorial(2 * k + offset) for k in range(n)]

    def over_u(coefs: list[float]) -> list[float]:
        return [2 * k * coefs[k] for k in range(1, len(coefs))]

    a = alternating(1, _N_TERMS + 2)
    b = alternating(2, _N_TERMS + 2)
    c = alternating(3, _N_TERMS + 2)
    rows = [a, b, c, over_u(b), over_u(c), over_u(over_u(b)), over_u(over_u(c))]
    return np.array([r[:_N_TERMS] for r in rows])


SERIES = _series_tables()


def body_tuple(
    segment_lengths: ArrayLike,
    n_quadrature: int,
    line_density: ArrayLike,
    rotary_inertia: ArrayLike,
    gravity_force: ArrayLike,
    base_position: ArrayLike,
    base_rotation: ArrayLike,
    tiers: tuple | None = None,
) -> tuple:
    """The body tuple of the kernels (layout in the module docstring) from per-segment quantities.

    Parameters
    ----------
    segment_lengths : array_like, shape (m,)
    n_quadrature : int
        Gauss–Legendre nodes of a segment above the last tier's bound (and of :func:`jacobian_batch`).
    line_density : array_like, shape (m,)
        ``ρA_i`` [kg/m].
    rotary_inertia : array_like, shape (m, 3)
        Body-frame rotary inertia per length ``(ρI, 2ρI, ρI)_i`` [kg m].
    gravity_force : array_like, shape (m, 3)
        Gravity force per length of every segment in the base frame [N/m].
    base_position : array_like, shape (3,)
    base_rotation : array_like, shape (3, 3)
    tiers : tuple of (bound, nodes), optional
        Default :data:`QUADRATURE_TIERS` (read at call time); ``()`` gives every segment ``n_quadrature`` nodes.
    """
    # fresh writable copies: a read-only array would be another numba type (another compiled signature)
    L = np.array(segment_lengths, dtype=float).reshape(-1)
    K, m = int(n_quadrature), L.size
    rhoA = np.asarray(line_density, dtype=float).reshape(m)
    inertia = np.asarray(rotary_inertia, dtype=float).reshape(m, 3)
    force = np.asarray(gravity_force, dtype=float).reshape(m, 3)
    table = QUADRATURE_TIERS if tiers is None else tiers
    levels = [(bound, k) for bound, k in table if k < K] + [(np.inf, K)]
    T = len(levels)
    ell = np.zeros((T, m, K + 1))
    w_lin = np.zeros((T, m, K))
    w_rot = np.zeros((T, m, K, 3))
    w_grav = np.zeros((T, m, K, 3))
    for t, (_, k) in enumerate(levels):
        xk, wk = np.polynomial.legendre.leggauss(k)
        wk = 0.5 * wk[None, :] * L[:, None]
        ell[t, :, :k] = 0.5 * (xk + 1.0)[None, :] * L[:, None]
        ell[t, :, k] = L
        w_lin[t, :, :k] = wk * rhoA[:, None]
        w_rot[t, :, :k] = wk[:, :, None] * inertia[:, None, :]
        w_grav[t, :, :k] = wk[:, :, None] * force[:, None, :]
    return (
        L,
        ell,
        w_lin,
        w_rot,
        w_grav,
        np.array(base_position, dtype=float).reshape(3),
        np.array(base_rotation, dtype=float).reshape(3, 3),
        np.array([k for _, k in levels], dtype=np.int64),
        np.array([bound for bound, _ in levels]),
    )


# No floating-point liberties (measured ~8 % faster with reassociation and fused multiply-adds): a planar
# motion must stay exactly in the plane, which needs the exact cancellations of unfused products.
_FAST = False

# q index of ω_x, ω_y, ω_z and of v_x, v_y, v_z; and the inverse maps
OMEGA_OF_Q = np.array([2, 0, 1])  # q0 -> ω_z, q1 -> ω_x, q2 -> ω_y
V_OF_Q = np.array([0, 2, 1])  # q3 -> v_x, q4 -> v_z, q5 -> v_y


# --------------------------------------------------------------------------
# scalars and 3-vectors (tuples: no allocation)
# --------------------------------------------------------------------------
@njit(cache=True)
def _horner7(x, terms):
    """The seven series at ``x = u²``, each by Horner's rule, interleaved (seven independent chains)."""
    k = terms - 1
    s0, s1, s2, s3 = SERIES[0, k], SERIES[1, k], SERIES[2, k], SERIES[3, k]
    s4, s5, s6 = SERIES[4, k], SERIES[5, k], SERIES[6, k]
    for k in range(terms - 2, -1, -1):
        s0 = s0 * x + SERIES[0, k]
        s1 = s1 * x + SERIES[1, k]
        s2 = s2 * x + SERIES[2, k]
        s3 = s3 * x + SERIES[3, k]
        s4 = s4 * x + SERIES[4, k]
        s5 = s5 * x + SERIES[5, k]
        s6 = s6 * x + SERIES[6, k]
    return s0, s1, s2, s3, s4, s5, s6


@njit(cache=True)
def _series_terms(u):
    for row in range(_TERMS_BY_U.shape[0]):
        if u < _TERMS_BY_U[row, 0]:
            return int(_TERMS_BY_U[row, 1])
    return _N_TERMS


@njit(cache=True)
def coefficients(u):
    """``(a, b, c, b1, c1, b2, c2)`` of ``u >= 0`` (module docstring)."""
    x = u * u
    if u < _SWITCH:
        a, b, c, b1, c1, b2, c2 = _horner7(x, _series_terms(u))
        if u >= _SWITCH_AB:
            a = np.sin(u) / u
            h = np.sin(0.5 * u) / u
            b = 2.0 * h * h
        return a, b, c, b1, c1, b2, c2
    a = np.sin(u) / u
    h = np.sin(0.5 * u) / u
    b = 2.0 * h * h
    sn, cs = np.sin(u), np.cos(u)
    sh = np.sin(0.5 * u)
    u2 = x
    u4 = u2 * u2
    c = (u - sn) / (u2 * u)
    b1 = (u * sn - 4.0 * sh * sh) / u4
    c1 = (3.0 * sn - u * cs - 2.0 * u) / (u4 * u)
    b2 = (u2 * cs - 5.0 * u * sn + 16.0 * sh * sh) / (u4 * u2)
    c2 = (u2 * sn + 7.0 * u * cs + 8.0 * u - 15.0 * sn) / (u4 * u2 * u)
    return a, b, c, b1, c1, b2, c2


@njit(cache=True, fastmath=_FAST)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, fastmath=_FAST)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, fastmath=_FAST)
def _axpy(alpha, x, y):
    """``alpha x + y``."""
    return (alpha * x[0] + y[0], alpha * x[1] + y[1], alpha * x[2] + y[2])


@njit(cache=True, fastmath=_FAST)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True, fastmath=_FAST)
def _mv(R, x):
    """``R x`` for a (3, 3) array."""
    return (
        R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2],
        R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
        R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2],
    )


@njit(cache=True, fastmath=_FAST)
def _mtv(R, x):
    """``Rᵀ x``."""
    return (
        R[0, 0] * x[0] + R[1, 0] * x[1] + R[2, 0] * x[2],
        R[0, 1] * x[0] + R[1, 1] * x[1] + R[2, 1] * x[2],
        R[0, 2] * x[0] + R[1, 2] * x[1] + R[2, 2] * x[2],
    )


@njit(cache=True, fastmath=_FAST)
def _mv_at(Rs, k, x):
    """``Rs[k] x`` without taking a view (a view costs two atomic reference counts)."""
    return (
        Rs[k, 0, 0] * x[0] + Rs[k, 0, 1] * x[1] + Rs[k, 0, 2] * x[2],
        Rs[k, 1, 0] * x[0] + Rs[k, 1, 1] * x[1] + Rs[k, 1, 2] * x[2],
        Rs[k, 2, 0] * x[0] + Rs[k, 2, 1] * x[1] + Rs[k, 2, 2] * x[2],
    )


@njit(cache=True, fastmath=_FAST)
def _mtv_at(Rs, k, x):
    """``Rs[k]ᵀ x`` without taking a view."""
    return (
        Rs[k, 0, 0] * x[0] + Rs[k, 1, 0] * x[1] + Rs[k, 2, 0] * x[2],
        Rs[k, 0, 1] * x[0] + Rs[k, 1, 1] * x[1] + Rs[k, 2, 1] * x[2],
        Rs[k, 0, 2] * x[0] + Rs[k, 1, 2] * x[1] + Rs[k, 2, 2] * x[2],
    )


@njit(cache=True, fastmath=_FAST)
def _row6(A, i, j):
    """``A[i, j, :6]`` as a tuple (no view)."""
    return (A[i, j, 0], A[i, j, 1], A[i, j, 2], A[i, j, 3], A[i, j, 4], A[i, j, 5])


@njit(cache=True, fastmath=_FAST)
def _net(A, m):
    """``A[m, :6]`` of a 2-D array as a tuple (no view)."""
    return (A[m, 0], A[m, 1], A[m, 2], A[m, 3], A[m, 4], A[m, 5])


@njit(cache=True, fastmath=_FAST)
def _jl(W, X, co):
    """``J(W) X``."""
    WX = _cross(W, X)
    return _axpy(co[2], _cross(W, WX), _axpy(co[1], WX, X))


@njit(cache=True, fastmath=_FAST)
def _djl(W, Wd, X, co):
    """``(∂J/∂W · Ẇ) X``."""
    wwd = _dot(W, Wd)
    WX = _cross(W, X)
    WdX = _cross(Wd, X)
    out = _axpy(co[3] * wwd, WX, _axpy(co[1], WdX, (0.0, 0.0, 0.0)))
    out = _axpy(co[4] * wwd, _cross(W, WX), out)
    return _axpy(co[2], _add(_cross(Wd, WX), _cross(W, WdX)), out)


@njit(cache=True, fastmath=_FAST)
def _ddjl(W, Wd, X, co):
    """Second derivative of ``J(W) X`` along ``Ẇ`` twice (``Ẅ = 0``)."""
    wwd = _dot(W, Wd)
    wdwd = _dot(Wd, Wd)
    WX = _cross(W, X)
    WdX = _cross(Wd, X)
    out = _axpy(co[5] * wwd * wwd + co[3] * wdwd, WX, _axpy(2.0 * co[3] * wwd, WdX, (0.0, 0.0, 0.0)))
    out = _axpy(co[6] * wwd * wwd + co[4] * wdwd, _cross(W, WX), out)
    out = _axpy(2.0 * co[4] * wwd, _add(_cross(Wd, WX), _cross(W, WdX)), out)
    return _axpy(2.0 * co[2], _cross(Wd, WdX), out)


@njit(cache=True, fastmath=_FAST)
def _twist(q, i):
    """``ω``, ``v`` of segment i (v with the rest axial strain 1)."""
    b = 6 * i
    return (q[b + 1], q[b + 2], q[b]), (q[b + 3], 1.0 + q[b + 5], q[b + 4])


# --------------------------------------------------------------------------
# one state: geometry, mass, static forces, Coriolis
# --------------------------------------------------------------------------
@njit(cache=True, fastmath=_FAST)
def workspace(body):
    """Scratch arrays of one state (layout in :func:`geometry`)."""
    L, ell = body[0], body[1]
    m = L.shape[0]
    K = ell.shape[2] - 1  # n_quadrature, the most nodes a segment uses
    n = 6 * m
    co = np.empty((m, K + 1, 7))
    wv = np.empty((m, K + 1, 9))  # W, V, r (local position) per node and segment end
    R0 = np.empty((m, 3, 3))  # start rotation of each segment
    Rn = np.empty((m * K, 3, 3))  # node rotations
    jp = np.zeros((m * K, 3, n))
    jw = np.zeros((m * K, 3, n))  # body frame
    M = np.empty((n, n))
    chol = np.empty((n, n))  # Cholesky factor of M: lower triangle, reciprocal diagonal
    vec = np.empty((5, n))  # static forces (G + K q), Coriolis, right-hand side, solution, actuation A(q) u
    ends = np.empty((m, 3, 13))  # per segment end: [∂p/∂q_i (6) | ∂θ/∂q_i (6) | p_end] in the base frame
    tier = np.zeros(m, dtype=np.int64)  # quadrature tier of each segment (node i K + k is node k of segment i)
    pos = np.empty((m * K, 3))  # node positions (base frame)
    twist = np.empty((m, 6, 6))  # per segment end and own strain: its variation as a twist (v, θ) at the origin
    # per segment's nodes, about the origin: Σ w ρA, Σ w ρA p, Σ w ρA (|p|² I − p pᵀ) + R I_b Rᵀ
    comp = np.empty((m, 13))
    wrench = np.empty((m, 6, 6))  # per segment and own strain b: Σ w ρA J_p,b and its moment about the origin
    inertial = np.empty((m + 1, 6))  # per segment: net inertial force and moment (origin) of its nodes; a sum
    mats = np.empty((7, 3, 3))  # geometry's 3x3 scratch (allocation costs as much as the work it holds)
    later = np.empty(13)  # mass: composite inertia of the later segments
    return co, wv, R0, Rn, jp, jw, M, chol, vec, ends, tier, pos, twist, comp, wrench, inertial, mats, later


@njit(cache=True, fastmath=_FAST, inline="always")
def _select_tiers(q, body, tier, full):
    """Quadrature tier of each segment: the first whose bound covers ``|ω_i| L_i`` (the last if ``full``)."""
    L, bounds = body[0], body[8]
    last = bounds.shape[0] - 1
    for i in range(L.shape[0]):
        t = last
        if not full:
            b = 6 * i
            u = np.sqrt(q[b] * q[b] + q[b + 1] * q[b + 1] + q[b + 2] * q[b + 2]) * L[i]
            for tt in range(last):
                if u <= bounds[tt]:
                    t = tt
                    break
        tier[i] = t


@njit(cache=True, fastmath=_FAST, inline="always")
def geometry(q, body, ws, full):
    """Local terms, node rotations and the Jacobians ``J_p`` (base) and ``J_w`` (body) at the nodes.

    Each segment uses the nodes of its quadrature tier (``full``: every segment the n_quadrature nodes).
    """
    L, ell, base_p, base_R, tier_K = body[0], body[1], body[5], body[6], body[7]
    co_a, wv, R0a, Rn, jp, jw = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5]
    ends, tier, pos, twist = ws[9], ws[10], ws[11], ws[12]
    m = L.shape[0]
    Kmax = ell.shape[2] - 1
    _select_tiers(q, body, tier, full)
    p0 = (base_p[0], base_p[1], base_p[2])
    mats = ws[16]
    R0, R, Rl, Jl, D, RJ, RD = mats[0], mats[1], mats[2], mats[3], mats[4], mats[5], mats[6]
    R0[:, :] = base_R
    for i in range(m):
        for x in range(3):
            for y in range(3):
                R0a[i, x, y] = R0[x, y]
        om, v = _twist(q, i)
        t = tier[i]
        K = tier_K[t]
        for k in range(K + 1):
            s = ell[t, i, k]
            W = (s * om[0], s * om[1], s * om[2])
            V = (s * v[0], s * v[1], s * v[2])
            w2 = _dot(W, W)
            co = coefficients(np.sqrt(w2))
            for j in range(7):
                co_a[i, k, j] = co[j]
            a, b, c = co[0], co[1], co[2]
            WV = _cross(W, V)
            WWV = _cross(W, WV)
            r = _axpy(c, WWV, _axpy(b, WV, V))  # J(W) V
            wv[i, k, 0], wv[i, k, 1], wv[i, k, 2] = W
            wv[i, k, 3], wv[i, k, 4], wv[i, k, 5] = V
            wv[i, k, 6], wv[i, k, 7], wv[i, k, 8] = r
            # R_loc = I + a Ŵ + b Ŵ², J = I + b Ŵ + c Ŵ² (Ŵ² = W Wᵀ − |W|² I)
            for x in range(3):
                for y in range(3):
                    ww = W[x] * W[y]
                    Rl[x, y] = b * ww
                    Jl[x, y] = c * ww
                Rl[x, x] += 1.0 - b * w2
                Jl[x, x] += 1.0 - c * w2
            Rl[0, 1] -= a * W[2]
            Rl[1, 0] += a * W[2]
            Rl[0, 2] += a * W[1]
            Rl[2, 0] -= a * W[1]
            Rl[1, 2] -= a * W[0]
            Rl[2, 1] += a * W[0]
            Jl[0, 1] -= b * W[2]
            Jl[1, 0] += b * W[2]
            Jl[0, 2] += b * W[1]
            Jl[2, 0] -= b * W[1]
            Jl[1, 2] -= b * W[0]
            Jl[2, 1] += b * W[0]
            # D = ∂(J(W) V)/∂W = (b1 W×V + c1 W×(W×V) − c V) Wᵀ − [b V + c W×V]ₓ + c (W·V) I
            P = _axpy(-c, V, _axpy(co[4], WWV, _axpy(co[3], WV, (0.0, 0.0, 0.0))))
            Y = _axpy(c, WV, (b * V[0], b * V[1], b * V[2]))
            cwv = c * _dot(W, V)
            for x in range(3):
                for y in range(3):
                    D[x, y] = P[x] * W[y]
                D[x, x] += cwv
            D[0, 1] += Y[2]
            D[1, 0] -= Y[2]
            D[0, 2] -= Y[1]
            D[2, 0] += Y[1]
            D[1, 2] += Y[0]
            D[2, 1] -= Y[0]
            for x in range(3):
                for y in range(3):
                    R[x, y] = R0[x, 0] * Rl[0, y] + R0[x, 1] * Rl[1, y] + R0[x, 2] * Rl[2, y]
                    RJ[x, y] = s * (R0[x, 0] * Jl[0, y] + R0[x, 1] * Jl[1, y] + R0[x, 2] * Jl[2, y])
                    RD[x, y] = s * (R0[x, 0] * D[0, y] + R0[x, 1] * D[1, y] + R0[x, 2] * D[2, y])
            p = _add(p0, _mv(R0, r))
            if k < K:
                pn = i * Kmax + k
                for x in range(3):
                    for y in range(3):
                        Rn[pn, x, y] = R[x, y]
                pos[pn, 0], pos[pn, 1], pos[pn, 2] = p
                # own columns: ∂p/∂ω_j = s R0 D e_j, ∂p/∂v_j = s R0 J e_j; body ∂θ/∂ω_j = s Jᵀ e_j (= Rlᵀ J),
                # ∂θ/∂v_j = 0 (left at zero by the workspace)
                for cq in range(3):
                    jo = OMEGA_OF_Q[cq]
                    jv = V_OF_Q[cq]
                    for x in range(3):
                        jp[pn, x, 6 * i + cq] = RD[x, jo]
                        jw[pn, x, 6 * i + cq] = s * Jl[jo, x]
                        jp[pn, x, 6 * i + 3 + cq] = RJ[x, jv]
                # earlier segments: their end's variation, carried rigidly to the node (the dynamics terms use
                # the segment ends' twists instead; only node_jacobians asks for these columns)
                for jseg in range(i if full else 0):
                    lever = (p[0] - ends[jseg, 0, 12], p[1] - ends[jseg, 1, 12], p[2] - ends[jseg, 2, 12])
                    for cq in range(6):
                        dth = (ends[jseg, 0, 6 + cq], ends[jseg, 1, 6 + cq], ends[jseg, 2, 6 + cq])
                        sw = _cross(dth, lever)
                        wb = _mtv(R, dth)
                        for x in range(3):
                            jp[pn, x, 6 * jseg + cq] = ends[jseg, x, cq] + sw[x]
                            jw[pn, x, 6 * jseg + cq] = wb[x]
            else:
                for cq in range(3):
                    jo = OMEGA_OF_Q[cq]
                    jv = V_OF_Q[cq]
                    for x in range(3):
                        ends[i, x, cq] = RD[x, jo]
                        ends[i, x, 6 + cq] = RJ[x, jo]
                        ends[i, x, 3 + cq] = RJ[x, jv]
                        ends[i, x, 9 + cq] = 0.0
                for x in range(3):
                    ends[i, x, 12] = p[x]
                for cq in range(6):
                    th = (ends[i, 0, 6 + cq], ends[i, 1, 6 + cq], ends[i, 2, 6 + cq])
                    lin = _cross(p, th)  # e − θ × p_end
                    for x in range(3):
                        twist[i, cq, x] = ends[i, x, cq] + lin[x]
                        twist[i, cq, 3 + x] = th[x]
                p0 = p
                R0[:, :] = R


@njit(cache=True, fastmath=_FAST)
def _dot6(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]


@njit(cache=True, fastmath=_FAST)
def _twist_dot(S, tw_c, tw_b):
    """``tw_cᵀ S tw_b`` for the composite inertia ``S`` (a row of ``comp``) of rigidly carried nodes."""
    mass_, h = S[0], (S[1], S[2], S[3])
    v_b, th_b = (tw_b[0], tw_b[1], tw_b[2]), (tw_b[3], tw_b[4], tw_b[5])
    P = _axpy(mass_, v_b, _cross(th_b, h))
    hv = _cross(h, v_b)
    Lm = (
        hv[0] + S[4] * th_b[0] + S[5] * th_b[1] + S[6] * th_b[2],
        hv[1] + S[7] * th_b[0] + S[8] * th_b[1] + S[9] * th_b[2],
        hv[2] + S[10] * th_b[0] + S[11] * th_b[1] + S[12] * th_b[2],
    )
    return tw_c[0] * P[0] + tw_c[1] * P[1] + tw_c[2] * P[2] + tw_c[3] * Lm[0] + tw_c[4] * Lm[1] + tw_c[5] * Lm[2]


@njit(cache=True, fastmath=_FAST, inline="always")
def mass(body, ws, M):
    """``M = Σ w (ρA J_pᵀ J_p + J_wᵀ I_b J_w)`` from the own Jacobian columns and segment-end twists in ``ws``.

    A node of segment i moves with an earlier segment j's strains rigidly (``J_p = v + θ × p``,
    ``J_w = Rᵀ θ`` for the end's twist ``(v, θ)`` at the origin), so those entries are projections of
    segment i's own-column wrenches, and entries between two rigid columns use the composite inertia of
    the later segments' nodes: the same sums as node by node, regrouped.
    """
    ell, w_lin, w_rot, tier_K = body[1], body[2], body[3], body[7]
    jp, jw, tier, pos, Rn = ws[4], ws[5], ws[10], ws[11], ws[3]
    twist, comp, wrench = ws[12], ws[13], ws[14]
    Kmax = ell.shape[2] - 1
    m = tier.shape[0]
    n = M.shape[0]
    for a in range(n):
        for b in range(a, n):
            M[a, b] = 0.0
    for i in range(m):
        t = tier[i]
        o = 6 * i
        for j in range(13):
            comp[i, j] = 0.0
        for b in range(6):
            for x in range(6):
                wrench[i, b, x] = 0.0
        for k in range(tier_K[t]):
            pn = i * Kmax + k
            wl = w_lin[t, i, k]
            w0, w1, w2 = w_rot[t, i, k, 0], w_rot[t, i, k, 1], w_rot[t, i, k, 2]
            p = (pos[pn, 0], pos[pn, 1], pos[pn, 2])
            for a in range(6):
                pa = (wl * jp[pn, 0, o + a], wl * jp[pn, 1, o + a], wl * jp[pn, 2, o + a])
                ra = (w0 * jw[pn, 0, o + a], w1 * jw[pn, 1, o + a], w2 * jw[pn, 2, o + a])
                for b in range(a, 6):
                    v = pa[0] * jp[pn, 0, o + b] + pa[1] * jp[pn, 1, o + b] + pa[2] * jp[pn, 2, o + b]
                    if b < 3:  # the own elongation and shear columns do not rotate the cross-section
                        v += ra[0] * jw[pn, 0, o + b] + ra[1] * jw[pn, 1, o + b] + ra[2] * jw[pn, 2, o + b]
                    M[o + a, o + b] += v
                if i > 0:
                    moment = _add(_cross(p, pa), _mv_at(Rn, pn, ra))
                    for x in range(3):
                        wrench[i, a, x] += pa[x]
                        wrench[i, a, 3 + x] += moment[x]
            if i > 0:  # the composite of the first segment's nodes is never used
                p2 = _dot(p, p)
                comp[i, 0] += wl
                for x in range(3):
                    comp[i, 1 + x] += wl * p[x]
                    for y in range(3):
                        v = (
                            Rn[pn, x, 0] * w0 * Rn[pn, y, 0]
                            + Rn[pn, x, 1] * w1 * Rn[pn, y, 1]
                            + Rn[pn, x, 2] * w2 * Rn[pn, y, 2]
                            - wl * p[x] * p[y]
                        )
                        if x == y:
                            v += wl * p2
                        comp[i, 4 + 3 * x + y] += v
        # earlier segments' columns against this segment's own: the wrench projected on their end twists
        for j in range(i):
            for c in range(6):
                for b in range(6):
                    M[6 * j + c, o + b] += _dot6(_row6(twist, j, c), _row6(wrench, i, b))
    # two rigid columns: the composite inertia of the segments after the later one
    S = ws[17]
    S[:] = 0.0
    for i in range(m - 2, -1, -1):
        for x in range(13):
            S[x] += comp[i + 1, x]
        for j in range(i + 1):
            for c in range(6):
                for b in range(c if j == i else 0, 6):
                    M[6 * j + c, 6 * i + b] += _twist_dot(S, _row6(twist, j, c), _row6(twist, i, b))
    for a in range(n):
        for b in range(a + 1, n):
            M[b, a] = M[a, b]


@njit(cache=True, fastmath=_FAST, inline="always")
def gravity_forces(body, ws, out):
    """``G = −Σ_k J_pᵀ f_k`` (``f_k`` the nodes' gravity force weights) into ``out``.

    Earlier segments' columns through their end twists ``(v, θ)``: ``−(v·F + θ·Σ p × f)`` with ``F`` the
    net gravity force of the later segments' nodes and ``Σ p × f`` its moment about the origin.
    """
    ell, w_grav, tier_K = body[1], body[4], body[7]
    jp, tier, pos, twist = ws[4], ws[10], ws[11], ws[12]
    Kmax = ell.shape[2] - 1
    m = tier.shape[0]
    later_f = (0.0, 0.0, 0.0)  # net gravity force of the nodes of the later segments
    later_mom = (0.0, 0.0, 0.0)  # its moment about the origin
    for i in range(m - 1, -1, -1):
        for c in range(6):
            tw = _row6(twist, i, c)
            lin = tw[0] * later_f[0] + tw[1] * later_f[1] + tw[2] * later_f[2]
            out[6 * i + c] = -(lin + tw[3] * later_mom[0] + tw[4] * later_mom[1] + tw[5] * later_mom[2])
        t = tier[i]
        for k in range(tier_K[t]):
            pn = i * Kmax + k
            f = (w_grav[t, i, k, 0], w_grav[t, i, k, 1], w_grav[t, i, k, 2])
            for c in range(6):
                a = 6 * i + c
                out[a] -= jp[pn, 0, a] * f[0] + jp[pn, 1, a] * f[1] + jp[pn, 2, a] * f[2]
            later_f = _add(later_f, f)
            later_mom = _add(later_mom, _cross((pos[pn, 0], pos[pn, 1], pos[pn, 2]), f))


@njit(cache=True, fastmath=_FAST, inline="always")
def coriolis(qd, body, ws, out):
    """``C(q, q̇) q̇`` into ``out`` from the geometry of q in ``ws``."""
    L, ell, w_lin, w_rot, tier_K = body[0], body[1], body[2], body[3], body[7]
    co_a, wv, R0a, Rn, jp, jw, tier, pos, twist, inertial = (
        ws[0],
        ws[1],
        ws[2],
        ws[3],
        ws[4],
        ws[5],
        ws[10],
        ws[11],
        ws[12],
        ws[15],
    )
    m = L.shape[0]
    Kmax = ell.shape[2] - 1
    for a in range(out.shape[0]):
        out[a] = 0.0
    for x in range(6):
        inertial[m, x] = 0.0  # net force and moment (origin) of the nodes of the later segments
    zero = (0.0, 0.0, 0.0)
    Om0, al0, pdd0 = zero, zero, zero
    for i in range(m):
        omd, vd = _twist(qd, i)
        vd = (vd[0], vd[1] - 1.0, vd[2])
        Om_e, al_e, pdd_e = zero, zero, zero
        t = tier[i]
        K = tier_K[t]
        if i > 0:
            for x in range(6):
                inertial[i, x] = 0.0
        for k in range(K + 1):
            s = ell[t, i, k]
            co = (
                co_a[i, k, 0],
                co_a[i, k, 1],
                co_a[i, k, 2],
                co_a[i, k, 3],
                co_a[i, k, 4],
                co_a[i, k, 5],
                co_a[i, k, 6],
            )
            W = (wv[i, k, 0], wv[i, k, 1], wv[i, k, 2])
            V = (wv[i, k, 3], wv[i, k, 4], wv[i, k, 5])
            r = (wv[i, k, 6], wv[i, k, 7], wv[i, k, 8])
            Wd = (s * omd[0], s * omd[1], s * omd[2])
            Vd = (s * vd[0], s * vd[1], s * vd[2])
            rb = _mv_at(R0a, i, r)
            rdb = _mv_at(R0a, i, _add(_djl(W, Wd, V, co), _jl(W, Vd, co)))
            Om_loc = _mv_at(R0a, i, _jl(W, Wd, co))
            rddb = _mv_at(R0a, i, _axpy(2.0, _djl(W, Wd, Vd, co), _ddjl(W, Wd, V, co)))
            Om = _add(Om0, Om_loc)
            Om0_rb = _cross(Om0, rb)
            pdd = _add(_add(pdd0, _cross(al0, rb)), _add(_cross(Om0, Om0_rb), _axpy(2.0, _cross(Om0, rdb), rddb)))
            al = _add(_add(al0, _cross(Om0, Om_loc)), _mv_at(R0a, i, _djl(W, Wd, Wd, co)))
            if k < K:
                pn = i * Kmax + k
                wb = _mtv_at(Rn, pn, Om)
                ab = _mtv_at(Rn, pn, al)
                wr = (w_rot[t, i, k, 0], w_rot[t, i, k, 1], w_rot[t, i, k, 2])
                Iw = (wr[0] * wb[0], wr[1] * wb[1], wr[2] * wb[2])
                gyro = _cross(wb, Iw)
                rot = (wr[0] * ab[0] + gyro[0], wr[1] * ab[1] + gyro[1], wr[2] * ab[2] + gyro[2])
                wl = w_lin[t, i, k]
                lin = (wl * pdd[0], wl * pdd[1], wl * pdd[2])
                if i > 0:
                    p = (pos[pn, 0], pos[pn, 1], pos[pn, 2])
                    moment = _add(_cross(p, lin), _mv_at(Rn, pn, rot))
                    for x in range(3):
                        inertial[i, x] += lin[x]
                        inertial[i, 3 + x] += moment[x]
                for a in range(6 * i, 6 * (i + 1)):
                    out[a] += (
                        jp[pn, 0, a] * lin[0]
                        + jp[pn, 1, a] * lin[1]
                        + jp[pn, 2, a] * lin[2]
                        + jw[pn, 0, a] * rot[0]
                        + jw[pn, 1, a] * rot[1]
                        + jw[pn, 2, a] * rot[2]
                    )
            else:
                Om_e, al_e, pdd_e = Om, al, pdd
        Om0, al0, pdd0 = Om_e, al_e, pdd_e
    # earlier segments' columns: the net wrench of the later segments' nodes on their end twists
    for i in range(m - 1, 0, -1):
        for x in range(6):
            inertial[m, x] += inertial[i, x]
        for c in range(6):
            out[6 * (i - 1) + c] += _dot6(_row6(twist, i - 1, c), _net(inertial, m))


# --------------------------------------------------------------------------
# tendons (geometry only: the callers map tensions to forces)
# --------------------------------------------------------------------------
@njit(cache=True, fastmath=_FAST)
def tendon_terms(q, offset, span, length, dlength):
    """Lengths ``ℓ_k(q)`` (p,) and gradients ``∂ℓ_k/∂q`` (p, n) of tendons, into the given arrays.

    Tendon k runs at the body offset ``d = (d_x, 0, d_z)`` = ``(offset[k, 0], 0, offset[k, 1])``;
    its tangent ``R (v + ω × d)`` is constant inside a constant-strain stretch, so
    ``ℓ_k = Σ_i span[k, i] |v_i + ω_i × d|`` exactly (NaN gradient where that length is 0).
    """
    p = offset.shape[0]
    m = span.shape[1]
    for k in range(p):
        dx, dz = offset[k, 0], offset[k, 1]
        total = 0.0
        for i in range(m):
            b = 6 * i
            kz, kx, ky = q[b], q[b + 1], q[b + 2]
            t0 = q[b + 3] + ky * dz
            t1 = 1.0 + q[b + 5] + kz * dx - kx * dz
            t2 = q[b + 4] - ky * dx
            nu = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            ell = span[k, i]
            total += ell * nu
            if ell == 0.0:
                for c in range(6):
                    dlength[k, b + c] = 0.0
            else:
                f = ell / nu if nu > 0.0 else np.nan
                dlength[k, b] = f * t1 * dx
                dlength[k, b + 1] = -f * t1 * dz
                dlength[k, b + 2] = f * (t0 * dz - t2 * dx)
                dlength[k, b + 3] = f * t0
                dlength[k, b + 4] = f * t2
                dlength[k, b + 5] = f * t1
        length[k] = total


@njit(cache=True, fastmath=_FAST)
def tendon_batch(Q, offset, span):
    """:func:`tendon_terms` for configurations (B, n): lengths (B, p) and gradients (B, p, n)."""
    B, n = Q.shape
    p = offset.shape[0]
    length = np.empty((B, p))
    dlength = np.empty((B, p, n))
    for b in range(B):
        tendon_terms(Q[b], offset, span, length[b], dlength[b])
    return length, dlength


# --------------------------------------------------------------------------
# Cholesky factor and solve, batches
# --------------------------------------------------------------------------
@njit(cache=True, fastmath=_FAST, inline="always")
def cholesky(M, Lc):
    """Cholesky factor of M into the lower triangle of Lc, its diagonal as reciprocals; False if M is not definite."""
    n = M.shape[0]
    for j in range(n):
        d = M[j, j]
        for k in range(j):
            d -= Lc[j, k] * Lc[j, k]
        if not d > 0.0:
            return False
        inv = 1.0 / np.sqrt(d)
        Lc[j, j] = inv
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= Lc[i, k] * Lc[j, k]
            Lc[i, j] = s * inv
    return True


@njit(cache=True, fastmath=_FAST, inline="always")
def cholesky_solve(Lc, r, out):
    n = Lc.shape[0]
    for i in range(n):
        s = r[i]
        for k in range(i):
            s -= Lc[i, k] * out[k]
        out[i] = s * Lc[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= Lc[k, i] * out[k]
        out[i] = s * Lc[i, i]


@njit(cache=True, fastmath=_FAST)
def terms_batch(Q, QD, body, need_coriolis):
    """Mass matrices (B, n, n), gravity forces (B, n) and (if asked) Coriolis forces (B, n) of states (B, n)."""
    B, n = Q.shape
    M = np.empty((B, n, n))
    G = np.empty((B, n))
    C = np.zeros((B, n))
    ws = workspace(body)
    for b in range(B):
        geometry(Q[b], body, ws, False)
        mass(body, ws, M[b])
        gravity_forces(body, ws, G[b])
        if need_coriolis:
            coriolis(QD[b], body, ws, C[b])
    return M, G, C


@njit(cache=True, fastmath=_FAST)
def jacobian_batch(Q, body):
    """Node Jacobians ``J_p`` (B, m K, 3, n) (base frame) and ``J_w`` (B, m K, 3, n) (body frame)."""
    B, n = Q.shape
    ws = workspace(body)
    P = ws[4].shape[0]
    jp = np.empty((B, P, 3, n))
    jw = np.empty((B, P, 3, n))
    for b in range(B):
        geometry(Q[b], body, ws, True)
        jp[b] = ws[4]
        jw[b] = ws[5]
    return jp, jw
