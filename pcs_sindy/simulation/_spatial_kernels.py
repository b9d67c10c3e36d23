"""Compiled (numba) kernels of the spatial (3-D) PCS simulator: the dynamics terms of one state.

The spatial counterpart of :mod:`pcs_sindy.simulation._kernels`, with the same entry points
(:func:`workspace`, :func:`rhs_ws`, :func:`accel_jacobian`, batches) so that the integrators of
:mod:`pcs_sindy.simulation._radau` and :mod:`pcs_sindy.simulation.integrate` run either robot
(:mod:`pcs_sindy.simulation._dispatch` picks by the geometry tuple, and holds the batched state
derivative and its Jacobian for scipy's integrators).

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

Dynamics (issue 26 conventions): ``M = Σ w (ρA J_pᵀJ_p + J_wᵀ I_b J_w)`` over Gauss–Legendre nodes
with ``I_b = diag(ρI, 2ρI, ρI)`` in the body frame (y the tangent) and ``J_w`` the body angular
Jacobian; ``C q̇ = Σ w (ρA J_pᵀ J̇_p q̇ + J_wᵀ (I_b J̇_w q̇ + ω_b × I_b ω_b))``;
``G = −Σ w ρA J_pᵀ g``.

Robot structure is the tuple ``geo`` built by ``SpatialPCSRobot._jit_geometry``, of
:data:`GEO_SIZE` entries (the planar tuple has 13):

``(L (m,), ell (m, K+1), w_lin (m K,), w_rot (m K, 3), stiffness (n,), damping (n,),
gravity (3,), base_position (3,), base_rotation (3, 3), act_kind (int), tendon_offset (p, 2),
tendon_span (p, m), act_matrix (n, p), n_segments (int))``

``ell`` holds the K nodes of each segment followed by its length, ``w_lin`` the weights times
``ρA`` and ``w_rot`` the weights times the body inertia diagonal.  Actuation: ``act_kind``
:data:`~pcs_sindy.simulation._kernels.ACT_IDENTITY` (``u`` is τ) or
:data:`~pcs_sindy.simulation._kernels.ACT_TENDON` (tendons at body offsets ``(d_x, d_z)`` covering
``tendon_span[k, i]`` of segment i: ``A = −∂ℓ/∂q``).
"""

from __future__ import annotations

from math import factorial

import numpy as np
from numba import njit

from ._kernels import ACT_IDENTITY, ACT_TENDON

GEO_SIZE = 14

_SWITCH = 3.0  # u below which the scalar functions use their Taylor series in u² (24 terms)
_SWITCH_AB = 0.5
_N_TERMS = 24


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

# q index of ω_x, ω_y, ω_z and of v_x, v_y, v_z; and the inverse maps
OMEGA_OF_Q = np.array([2, 0, 1])  # q0 -> ω_z, q1 -> ω_x, q2 -> ω_y
V_OF_Q = np.array([0, 2, 1])  # q3 -> v_x, q4 -> v_z, q5 -> v_y


# --------------------------------------------------------------------------
# scalars and 3-vectors (tuples: no allocation)
# --------------------------------------------------------------------------
@njit(cache=True)
def _horner(row, x):
    out = SERIES[row, _N_TERMS - 1]
    for k in range(_N_TERMS - 2, -1, -1):
        out = out * x + SERIES[row, k]
    return out


@njit(cache=True)
def coefficients(u):
    """``(a, b, c, b1, c1, b2, c2)`` of ``u >= 0`` (module docstring)."""
    x = u * u
    if u < _SWITCH_AB:
        a = _horner(0, x)
        b = _horner(1, x)
    else:
        a = np.sin(u) / u
        h = np.sin(0.5 * u) / u
        b = 2.0 * h * h
    if u < _SWITCH:
        return a, b, _horner(2, x), _horner(3, x), _horner(4, x), _horner(5, x), _horner(6, x)
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


@njit(cache=True)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _axpy(alpha, x, y):
    """``alpha x + y``."""
    return (alpha * x[0] + y[0], alpha * x[1] + y[1], alpha * x[2] + y[2])


@njit(cache=True)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True)
def _mv(R, x):
    """``R x`` for a (3, 3) array."""
    return (
        R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2],
        R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
        R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2],
    )


@njit(cache=True)
def _mtv(R, x):
    """``Rᵀ x``."""
    return (
        R[0, 0] * x[0] + R[1, 0] * x[1] + R[2, 0] * x[2],
        R[0, 1] * x[0] + R[1, 1] * x[1] + R[2, 1] * x[2],
        R[0, 2] * x[0] + R[1, 2] * x[1] + R[2, 2] * x[2],
    )


@njit(cache=True)
def _jl(W, X, co):
    """``J(W) X``."""
    WX = _cross(W, X)
    return _axpy(co[2], _cross(W, WX), _axpy(co[1], WX, X))


@njit(cache=True)
def _djl(W, Wd, X, co):
    """``(∂J/∂W · Ẇ) X``."""
    wwd = _dot(W, Wd)
    WX = _cross(W, X)
    WdX = _cross(Wd, X)
    out = _axpy(co[3] * wwd, WX, _axpy(co[1], WdX, (0.0, 0.0, 0.0)))
    out = _axpy(co[4] * wwd, _cross(W, WX), out)
    return _axpy(co[2], _add(_cross(Wd, WX), _cross(W, WdX)), out)


@njit(cache=True)
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


@njit(cache=True)
def _twist(q, i):
    """``ω``, ``v`` of segment i (v with the rest axial strain 1)."""
    b = 6 * i
    return (q[b + 1], q[b + 2], q[b]), (q[b + 3], 1.0 + q[b + 5], q[b + 4])


# --------------------------------------------------------------------------
# one state: geometry, mass, static forces, Coriolis
# --------------------------------------------------------------------------
@njit(cache=True)
def workspace(geo):
    """Scratch arrays of one state (layout in :func:`geometry`)."""
    L, ell = geo[0], geo[1]
    m = L.shape[0]
    K = ell.shape[1] - 1
    n = 6 * m
    co = np.empty((m, K + 1, 7))
    wv = np.empty((m, K + 1, 9))  # W, V, r (local position) per node and segment end
    R0 = np.empty((m, 3, 3))  # start rotation of each segment
    Rn = np.empty((m * K, 3, 3))  # node rotations
    jp = np.zeros((m * K, 3, n))
    jw = np.zeros((m * K, 3, n))  # body frame
    M = np.empty((n, n))
    chol = np.empty((n, n))
    vec = np.empty((5, n))  # static forces (G + K q), Coriolis, right-hand side, solution, actuation A(q) u
    ends = np.empty((m, 3, 13))  # per segment end: [∂p/∂q_i (6) | ∂θ/∂q_i (6) | p_end] in the base frame
    return co, wv, R0, Rn, jp, jw, M, chol, vec, ends


@njit(cache=True)
def geometry(q, geo, ws):
    """Local terms, node rotations and the Jacobians ``J_p`` (base) and ``J_w`` (body) at the nodes."""
    L, ell, base_p, base_R = geo[0], geo[1], geo[7], geo[8]
    co_a, wv, R0a, Rn, jp, jw, ends = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[9]
    m = L.shape[0]
    K = ell.shape[1] - 1
    p0 = (base_p[0], base_p[1], base_p[2])
    R0 = base_R.copy()
    R = np.empty((3, 3))
    Rl = np.empty((3, 3))
    for i in range(m):
        R0a[i] = R0
        om, v = _twist(q, i)
        for k in range(K + 1):
            s = ell[i, k]
            W = (s * om[0], s * om[1], s * om[2])
            V = (s * v[0], s * v[1], s * v[2])
            co = coefficients(np.sqrt(_dot(W, W)))
            for j in range(7):
                co_a[i, k, j] = co[j]
            r = _jl(W, V, co)
            wv[i, k, 0], wv[i, k, 1], wv[i, k, 2] = W
            wv[i, k, 3], wv[i, k, 4], wv[i, k, 5] = V
            wv[i, k, 6], wv[i, k, 7], wv[i, k, 8] = r
            # R_loc = I + a Ŵ + b Ŵ² (Ŵ² = W Wᵀ − |W|² I)
            a, b = co[0], co[1]
            w2 = _dot(W, W)
            Rl[0, 0] = 1.0 + b * (W[0] * W[0] - w2)
            Rl[1, 1] = 1.0 + b * (W[1] * W[1] - w2)
            Rl[2, 2] = 1.0 + b * (W[2] * W[2] - w2)
            Rl[0, 1] = -a * W[2] + b * W[0] * W[1]
            Rl[1, 0] = a * W[2] + b * W[0] * W[1]
            Rl[0, 2] = a * W[1] + b * W[0] * W[2]
            Rl[2, 0] = -a * W[1] + b * W[0] * W[2]
            Rl[1, 2] = -a * W[0] + b * W[1] * W[2]
            Rl[2, 1] = a * W[0] + b * W[1] * W[2]
            for x in range(3):
                for y in range(3):
                    R[x, y] = R0[x, 0] * Rl[0, y] + R0[x, 1] * Rl[1, y] + R0[x, 2] * Rl[2, y]
            p = _add(p0, _mv(R0, r))
            node = k < K
            pn = i * K + k
            if node:
                Rn[pn] = R
            # own columns: derivatives of the local pose along each strain, rotated to the base frame
            for c in range(6):
                e = (0.0, 0.0, 0.0)
                if c < 3:
                    j = OMEGA_OF_Q[c]
                    Wd = (s if j == 0 else 0.0, s if j == 1 else 0.0, s if j == 2 else 0.0)
                    dr = _djl(W, Wd, V, co)
                    dth = _mv(R0, _jl(W, Wd, co))
                else:
                    j = V_OF_Q[c - 3]
                    Vd = (s if j == 0 else 0.0, s if j == 1 else 0.0, s if j == 2 else 0.0)
                    dr = _jl(W, Vd, co)
                    dth = e
                dp = _mv(R0, dr)
                if node:
                    wb = _mtv(R, dth)
                    for x in range(3):
                        jp[pn, x, 6 * i + c] = dp[x]
                        jw[pn, x, 6 * i + c] = wb[x]
                else:
                    for x in range(3):
                        ends[i, x, c] = dp[x]
                        ends[i, x, 6 + c] = dth[x]
            if node:
                # earlier segments: their end's variation, carried rigidly to the node
                for jseg in range(i):
                    lever = (p[0] - ends[jseg, 0, 12], p[1] - ends[jseg, 1, 12], p[2] - ends[jseg, 2, 12])
                    for c in range(6):
                        dth = (ends[jseg, 0, 6 + c], ends[jseg, 1, 6 + c], ends[jseg, 2, 6 + c])
                        sw = _cross(dth, lever)
                        wb = _mtv(R, dth)
                        for x in range(3):
                            jp[pn, x, 6 * jseg + c] = ends[jseg, x, c] + sw[x]
                            jw[pn, x, 6 * jseg + c] = wb[x]
            else:
                for x in range(3):
                    ends[i, x, 12] = p[x]
                p0 = p
                R0 = R.copy()


@njit(cache=True)
def mass(geo, ws, M):
    """``M = Σ w (ρA J_pᵀ J_p + J_wᵀ I_b J_w)`` from the Jacobians in ``ws``."""
    ell, w_lin, w_rot = geo[1], geo[2], geo[3]
    jp, jw = ws[4], ws[5]
    K = ell.shape[1] - 1
    n = M.shape[0]
    for a in range(n):
        for b in range(a, n):
            M[a, b] = 0.0
    for pn in range(w_lin.shape[0]):
        wl = w_lin[pn]
        ncol = 6 * (pn // K + 1)  # later segments do not move this node
        for a in range(ncol):
            pa = (wl * jp[pn, 0, a], wl * jp[pn, 1, a], wl * jp[pn, 2, a])
            ra = (w_rot[pn, 0] * jw[pn, 0, a], w_rot[pn, 1] * jw[pn, 1, a], w_rot[pn, 2] * jw[pn, 2, a])
            for b in range(a, ncol):
                M[a, b] += (
                    pa[0] * jp[pn, 0, b]
                    + pa[1] * jp[pn, 1, b]
                    + pa[2] * jp[pn, 2, b]
                    + ra[0] * jw[pn, 0, b]
                    + ra[1] * jw[pn, 1, b]
                    + ra[2] * jw[pn, 2, b]
                )
    for a in range(n):
        for b in range(a + 1, n):
            M[b, a] = M[a, b]


@njit(cache=True)
def gravity_forces(geo, ws, out):
    """``G = −Σ w ρA J_pᵀ g`` into ``out``."""
    ell, w_lin, g = geo[1], geo[2], geo[6]
    jp = ws[4]
    K = ell.shape[1] - 1
    for a in range(out.shape[0]):
        out[a] = 0.0
    for pn in range(w_lin.shape[0]):
        wl = w_lin[pn]
        for a in range(6 * (pn // K + 1)):
            out[a] -= wl * (jp[pn, 0, a] * g[0] + jp[pn, 1, a] * g[1] + jp[pn, 2, a] * g[2])


@njit(cache=True)
def coriolis(qd, geo, ws, out):
    """``C(q, q̇) q̇`` into ``out`` from the geometry of q in ``ws``."""
    L, ell, w_lin, w_rot = geo[0], geo[1], geo[2], geo[3]
    co_a, wv, R0a, Rn, jp, jw = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5]
    m = L.shape[0]
    K = ell.shape[1] - 1
    for a in range(out.shape[0]):
        out[a] = 0.0
    zero = (0.0, 0.0, 0.0)
    Om0, al0, pdd0 = zero, zero, zero
    for i in range(m):
        R0 = R0a[i]
        omd, vd = _twist(qd, i)
        vd = (vd[0], vd[1] - 1.0, vd[2])
        Om_e, al_e, pdd_e = zero, zero, zero
        for k in range(K + 1):
            s = ell[i, k]
            c_ik = co_a[i, k]
            co = (c_ik[0], c_ik[1], c_ik[2], c_ik[3], c_ik[4], c_ik[5], c_ik[6])
            W = (wv[i, k, 0], wv[i, k, 1], wv[i, k, 2])
            V = (wv[i, k, 3], wv[i, k, 4], wv[i, k, 5])
            r = (wv[i, k, 6], wv[i, k, 7], wv[i, k, 8])
            Wd = (s * omd[0], s * omd[1], s * omd[2])
            Vd = (s * vd[0], s * vd[1], s * vd[2])
            rb = _mv(R0, r)
            rdb = _mv(R0, _add(_djl(W, Wd, V, co), _jl(W, Vd, co)))
            Om_loc = _mv(R0, _jl(W, Wd, co))
            rddb = _mv(R0, _axpy(2.0, _djl(W, Wd, Vd, co), _ddjl(W, Wd, V, co)))
            Om = _add(Om0, Om_loc)
            Om0_rb = _cross(Om0, rb)
            pdd = _add(_add(pdd0, _cross(al0, rb)), _add(_cross(Om0, Om0_rb), _axpy(2.0, _cross(Om0, rdb), rddb)))
            al = _add(_add(al0, _cross(Om0, Om_loc)), _mv(R0, _djl(W, Wd, Wd, co)))
            if k < K:
                pn = i * K + k
                R = Rn[pn]
                wb = _mtv(R, Om)
                ab = _mtv(R, al)
                Iw = (w_rot[pn, 0] * wb[0], w_rot[pn, 1] * wb[1], w_rot[pn, 2] * wb[2])
                gyro = _cross(wb, Iw)
                rot = (w_rot[pn, 0] * ab[0] + gyro[0], w_rot[pn, 1] * ab[1] + gyro[1], w_rot[pn, 2] * ab[2] + gyro[2])
                lin = (w_lin[pn] * pdd[0], w_lin[pn] * pdd[1], w_lin[pn] * pdd[2])
                for a in range(6 * (i + 1)):
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


# --------------------------------------------------------------------------
# actuation τ = A(q) u
# --------------------------------------------------------------------------
@njit(cache=True)
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


@njit(cache=True)
def tendon_batch(Q, offset, span):
    """:func:`tendon_terms` for configurations (B, n): lengths (B, p) and gradients (B, p, n)."""
    B, n = Q.shape
    p = offset.shape[0]
    length = np.empty((B, p))
    dlength = np.empty((B, p, n))
    for b in range(B):
        tendon_terms(Q[b], offset, span, length[b], dlength[b])
    return length, dlength


@njit(cache=True)
def actuation_forces(q, u, geo, tau):
    """Generalised forces ``τ = A(q) u`` (n,) of the inputs ``u`` (p,), into ``tau``."""
    kind, offset, span, matrix = geo[9], geo[10], geo[11], geo[12]
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


# --------------------------------------------------------------------------
# state derivative, its Jacobian, batches
# --------------------------------------------------------------------------
@njit(cache=True)
def _cholesky(M, Lc):
    n = M.shape[0]
    for j in range(n):
        d = M[j, j]
        for k in range(j):
            d -= Lc[j, k] * Lc[j, k]
        if not d > 0.0:
            return False
        d = np.sqrt(d)
        Lc[j, j] = d
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= Lc[i, k] * Lc[j, k]
            Lc[i, j] = s / d
    return True


@njit(cache=True)
def _cholesky_solve(Lc, r, out):
    n = Lc.shape[0]
    for i in range(n):
        s = r[i]
        for k in range(i):
            s -= Lc[i, k] * out[k]
        out[i] = s / Lc[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= Lc[k, i] * out[k]
        out[i] = s / Lc[i, i]


@njit(cache=True)
def _accel_given_geometry(qd, geo, ws, out):
    """``q̈`` at ``(q, qd)`` when ``ws`` holds the geometry, Cholesky factor, static and actuation forces of q."""
    damping = geo[5]
    chol, vec = ws[7], ws[8]
    static, cq, r, tau = vec[0], vec[1], vec[2], vec[4]
    coriolis(qd, geo, ws, cq)
    for a in range(tau.shape[0]):
        r[a] = tau[a] - static[a] - cq[a] - damping[a] * qd[a]
    _cholesky_solve(chol, r, out)


@njit(cache=True)
def rhs_ws(y, u, geo, ws, out):
    """State derivative ``[q̇, q̈]`` with scratch arrays; False (and NaN accelerations) if M is not definite."""
    stiffness = geo[4]
    n = y.shape[0] // 2
    q = y[:n]
    qd = y[n:]
    geometry(q, geo, ws)
    M, chol, vec = ws[6], ws[7], ws[8]
    mass(geo, ws, M)
    gravity_forces(geo, ws, vec[0])
    for a in range(n):
        vec[0][a] += stiffness[a] * q[a]
    actuation_forces(q, u, geo, vec[4])
    for a in range(n):
        out[a] = qd[a]
    if not _cholesky(M, chol):
        for a in range(n):
            out[n + a] = np.nan
        return False
    _accel_given_geometry(qd, geo, ws, vec[3])
    for a in range(n):
        out[n + a] = vec[3][a]
    return True


@njit(cache=True)
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


@njit(cache=True)
def terms_batch(Q, QD, geo, need_coriolis):
    """Mass matrices (B, n, n), gravity forces (B, n) and (if asked) Coriolis forces (B, n) of states (B, n)."""
    B, n = Q.shape
    M = np.empty((B, n, n))
    G = np.empty((B, n))
    C = np.zeros((B, n))
    ws = workspace(geo)
    for b in range(B):
        geometry(Q[b], geo, ws)
        mass(geo, ws, M[b])
        gravity_forces(geo, ws, G[b])
        if need_coriolis:
            coriolis(QD[b], geo, ws, C[b])
    return M, G, C


@njit(cache=True)
def jacobian_batch(Q, geo):
    """Node Jacobians ``J_p`` (B, m K, 3, n) (base frame) and ``J_w`` (B, m K, 3, n) (body frame)."""
    B, n = Q.shape
    ws = workspace(geo)
    P = ws[4].shape[0]
    jp = np.empty((B, P, 3, n))
    jw = np.empty((B, P, 3, n))
    for b in range(B):
        geometry(Q[b], geo, ws)
        jp[b] = ws[4]
        jw[b] = ws[5]
    return jp, jw


@njit(cache=True)
def actuation_batch(Q, U, geo):
    """:func:`actuation_forces` for configurations (B, n) and inputs (B, p); τ (B, n)."""
    out = np.empty(Q.shape)
    for b in range(Q.shape[0]):
        actuation_forces(Q[b], U[b], geo, out[b])
    return out
