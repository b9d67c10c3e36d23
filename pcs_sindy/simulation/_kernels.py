"""Compiled (numba) kernels of the ground-truth PCS simulator: the dynamics terms of one state.

Closed forms of the planar PCS robot in the complex backbone formulation of
:mod:`pcs_sindy.simulation.dynamics` (Gauss–Legendre nodes per segment),
evaluated one state at a time: the batched numpy evaluation costs
150–400 µs of interpreter overhead per call, which would dominate an
integrator that evaluates one state at a time.  The moments ``E_n`` and the
actuation map live here only: the numpy evaluations of
:class:`~pcs_sindy.simulation.dynamics.PCSRobot` call :func:`moments_array`
and :func:`tendon_batch` instead of keeping a second implementation.

Robot structure is passed as a tuple ``geo`` built by
``PCSRobot._jit_geometry``:

``(L (m,), ell (m, K+1), w_lin (m K,), mass_rot (n, n), stiffness (n,),
damping (n,), g_conj (complex), z_base (complex), base_angle (float),
act_kind (int), tendon_offset (p,), tendon_span (p, m), act_matrix (n, p))``

where ``ell`` holds the K quadrature nodes of each segment followed by its
length and ``w_lin`` the quadrature weights times ``ρ A``.  The actuation
``τ = A(q) u`` is selected by ``act_kind``: :data:`ACT_IDENTITY` (``u`` is τ),
:data:`ACT_TENDON` (``A = −∂ℓ/∂q`` of tendons at ``tendon_offset`` covering
``tendon_span[k, i]`` of segment i), :data:`ACT_CONSTANT` (``A =
act_matrix``) or :data:`ACT_SERVO` (servo-wound elastic tendons: the inputs are
servo angles [deg], the tensions ``f_k = k_k max(0, r_k θ_k π/180 + ℓ_k(q) −
ℓ_k(0) − s_k)`` with ``act_matrix`` rows ``[k, r, s]``).

Every kernel is compiled with ``cache=True``: the first call on a machine
compiles (tens of seconds) and later processes load the cached machine code.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_SERIES_LIMIT = 0.25  # |v| below which sinc and its derivatives use their Taylor series

# actuation kinds of geo[9]
ACT_IDENTITY, ACT_TENDON, ACT_CONSTANT, ACT_SERVO = 0, 1, 2, 3


# --------------------------------------------------------------------------
# moments E_n(u) = ∫_0^1 t^n e^{iut} dt
# --------------------------------------------------------------------------
@njit(cache=True)
def moments(u):
    """``E_0, E_1, E_2`` for one scalar ``u``, without cancellation at ``u = 0``.

    With ``t = 1/2 + τ`` and ``v = u/2``: ``E_0 = e^{iv} sinc v``,
    ``E_1 = e^{iv} (sinc v − i sinc' v)/2``, ``E_2 = e^{iv} (sinc v − 2i sinc' v − sinc'' v)/4``.
    """
    v = 0.5 * u
    sn, cs = np.sin(v), np.cos(v)
    if abs(v) < _SERIES_LIMIT:
        # Taylor series of sin(v)/v = Σ (-1)^k v^{2k} / (2k+1)!, differentiated termwise;
        # at |v| < 0.25 the first omitted terms are below 1e-19.
        v2 = v * v
        s0 = 1.0 + v2 * (
            -1 / 6 + v2 * (1 / 120 + v2 * (-1 / 5040 + v2 * (1 / 362880 + v2 * (-1 / 39916800 + v2 / 6227020800))))
        )
        s1 = v * (-1 / 3 + v2 * (1 / 30 + v2 * (-1 / 840 + v2 * (1 / 45360 + v2 * (-1 / 3991680 + v2 / 518918400)))))
        s2 = -1 / 3 + v2 * (1 / 10 + v2 * (-1 / 168 + v2 * (1 / 6480 + v2 * (-1 / 443520 + v2 / 47174400))))
    else:
        inv = 1.0 / v
        s0 = sn * inv
        s1 = (cs - s0) * inv
        s2 = -s0 - 2.0 * s1 * inv  # differentiating v·sinc' = cos v − sinc
    ph = complex(cs, sn)
    e0 = ph * s0
    a = ph * s1
    e1 = 0.5 * e0 - 0.5j * a
    e2 = 0.25 * (e0 - ph * s2) - 0.5j * a
    return e0, e1, e2


@njit(cache=True)
def moments_array(u):
    """:func:`moments` of every entry of a 1-D float array; three complex arrays."""
    e0 = np.empty(u.shape[0], dtype=np.complex128)
    e1 = np.empty(u.shape[0], dtype=np.complex128)
    e2 = np.empty(u.shape[0], dtype=np.complex128)
    for k in range(u.shape[0]):
        e0[k], e1[k], e2[k] = moments(u[k])
    return e0, e1, e2


@njit(cache=True)
def workspace(geo):
    """Scratch arrays for one state: moments (m, K+1) x3, Jacobian x/y parts (m K, n), M, Cholesky, vectors."""
    L, ell = geo[0], geo[1]
    m = L.shape[0]
    K = ell.shape[1] - 1
    n = 3 * m
    e0 = np.empty((m, K + 1), dtype=np.complex128)
    e1 = np.empty((m, K + 1), dtype=np.complex128)
    e2 = np.empty((m, K + 1), dtype=np.complex128)
    jx = np.zeros((m * K, n))
    jy = np.zeros((m * K, n))
    M = np.empty((n, n))
    chol = np.empty((n, n))
    vec = np.empty((5, n))  # static forces (G + K q), Coriolis, right-hand side, solution, actuation A(q) u
    return e0, e1, e2, jx, jy, M, chol, vec


@njit(cache=True)
def _geometry(q, geo, ws):
    """Moments at every node and segment end, and the position Jacobian at the nodes (into ``ws``)."""
    L, ell, base_angle, z_base = geo[0], geo[1], geo[8], geo[7]
    e0a, e1a, e2a, jx, jy = ws[0], ws[1], ws[2], ws[3], ws[4]
    m = L.shape[0]
    K = ell.shape[1] - 1
    phi = base_angle
    z_start = z_base
    # derivatives of earlier segments' end displacements and their end positions
    own_end = np.empty((m, 3), dtype=np.complex128)
    z_end = np.empty(m, dtype=np.complex128)
    for i in range(m):
        kap = q[3 * i]
        w = complex(q[3 * i + 1], 1.0 + q[3 * i + 2])
        eph = complex(np.cos(phi), np.sin(phi))
        for k in range(K + 1):
            s = ell[i, k]
            e0, e1, e2 = moments(kap * s)
            e0a[i, k] = e0
            e1a[i, k] = e1
            e2a[i, k] = e2
            o0 = eph * (1j * s * s * w * e1)
            o1 = eph * (s * e0)
            o2 = eph * (1j * s * e0)
            z = z_start + eph * (s * w * e0)
            if k < K:
                p = i * K + k
                jx[p, 3 * i], jy[p, 3 * i] = o0.real, o0.imag
                jx[p, 3 * i + 1], jy[p, 3 * i + 1] = o1.real, o1.imag
                jx[p, 3 * i + 2], jy[p, 3 * i + 2] = o2.real, o2.imag
                for j in range(i):
                    # bending of an earlier segment swings the node rigidly about that segment's end
                    a = own_end[j, 0] + 1j * L[j] * (z - z_end[j])
                    jx[p, 3 * j], jy[p, 3 * j] = a.real, a.imag
                    jx[p, 3 * j + 1], jy[p, 3 * j + 1] = own_end[j, 1].real, own_end[j, 1].imag
                    jx[p, 3 * j + 2], jy[p, 3 * j + 2] = own_end[j, 2].real, own_end[j, 2].imag
            else:
                own_end[i, 0] = o0
                own_end[i, 1] = o1
                own_end[i, 2] = o2
                z_end[i] = z
        z_start = z_end[i]
        phi += kap * L[i]


@njit(cache=True)
def _mass(geo, ws, M):
    """``M = mass_rot + Σ w ρA J_pᵀ J_p`` from the Jacobian in ``ws``."""
    ell, w_lin, mass_rot = geo[1], geo[2], geo[3]
    jx, jy = ws[3], ws[4]
    K = ell.shape[1] - 1
    n = M.shape[0]
    for a in range(n):
        for b in range(a, n):
            M[a, b] = mass_rot[a, b]
    for p in range(w_lin.shape[0]):
        wp = w_lin[p]
        ncol = 3 * (p // K + 1)  # later segments do not move this node
        for a in range(ncol):
            xa, ya = wp * jx[p, a], wp * jy[p, a]
            for b in range(a, ncol):
                M[a, b] += xa * jx[p, b] + ya * jy[p, b]
    for a in range(n):
        for b in range(a + 1, n):
            M[b, a] = M[a, b]


@njit(cache=True)
def _static_forces(q, geo, ws, out):
    """``G(q) + K q`` from the Jacobian in ``ws``."""
    ell, w_lin, stiffness, g_conj = geo[1], geo[2], geo[4], geo[6]
    jx, jy = ws[3], ws[4]
    K = ell.shape[1] - 1
    n = out.shape[0]
    gx, gy = g_conj.real, -g_conj.imag
    for a in range(n):
        out[a] = stiffness[a] * q[a]
    for p in range(w_lin.shape[0]):
        wx, wy = w_lin[p] * gx, w_lin[p] * gy
        for a in range(3 * (p // K + 1)):
            out[a] -= wx * jx[p, a] + wy * jy[p, a]


@njit(cache=True)
def _coriolis(q, qd, geo, ws, out):
    """``C(q, q̇) q̇ = Σ w ρA J_pᵀ (J̇_p q̇)`` from the moments and Jacobian in ``ws``."""
    L, ell, w_lin, base_angle = geo[0], geo[1], geo[2], geo[8]
    e0a, e1a, e2a, jx, jy = ws[0], ws[1], ws[2], ws[3], ws[4]
    m = L.shape[0]
    K = ell.shape[1] - 1
    n = out.shape[0]
    for a in range(n):
        out[a] = 0.0
    phi = base_angle
    phid = 0.0
    acc_start = 0j
    for i in range(m):
        kap = q[3 * i]
        w = complex(q[3 * i + 1], 1.0 + q[3 * i + 2])
        kd = qd[3 * i]
        wd = complex(qd[3 * i + 1], qd[3 * i + 2])
        eph = complex(np.cos(phi), np.sin(phi))
        acc_end = 0j
        for k in range(K + 1):
            s = ell[i, k]
            e0, e1, e2 = e0a[i, k], e1a[i, k], e2a[i, k]
            local = s * w * e0
            local_d = 1j * s * s * w * e1 * kd + s * e0 * wd
            local_dd = (-s * s * s * w * e2 * kd + 2j * s * s * e1 * wd) * kd
            acc = acc_start + eph * (-(phid * phid) * local + 2j * phid * local_d + local_dd)
            if k < K:
                p = i * K + k
                ax, ay = w_lin[p] * acc.real, w_lin[p] * acc.imag
                for a in range(3 * (i + 1)):
                    out[a] += ax * jx[p, a] + ay * jy[p, a]
            else:
                acc_end = acc
        acc_start = acc_end
        phi += kap * L[i]
        phid += kd * L[i]


@njit(cache=True)
def mass_and_bias(q, qd, geo, M, bias):
    """Fill ``M(q)`` (n, n) and ``bias = C q̇ + G + K q + D q̇`` (n,) for one state."""
    damping = geo[5]
    ws = workspace(geo)
    _geometry(q, geo, ws)
    _mass(geo, ws, M)
    _static_forces(q, geo, ws, bias)
    cq = ws[7][1]
    _coriolis(q, qd, geo, ws, cq)
    for a in range(bias.shape[0]):
        bias[a] += cq[a] + damping[a] * qd[a]


@njit(cache=True)
def _cholesky(M, Lc):
    """Lower Cholesky factor of M into Lc; False if M is not positive definite."""
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


# --------------------------------------------------------------------------
# actuation τ = A(q) u
# --------------------------------------------------------------------------
@njit(cache=True)
def tendon_terms(q, offset, span, length, dlength):
    """Lengths ``ℓ_k(q)`` (p,) and their gradients ``∂ℓ_k/∂q`` (p, n) of tendons, into the given arrays.

    Tendon k runs at the signed offset ``offset[k]`` from the backbone along
    the cross-section axis and covers ``span[k, i]`` of segment i's rest
    length (0 beyond its termination).  The offset curve ``p + d R(θ) e_x``
    has the tangent ``R(θ) [σ_sh, 1 + σ_ax + d κ]`` inside a constant-strain
    stretch, a constant of length ``ν = √(σ_sh² + (1 + σ_ax + d κ)²)``, so
    ``ℓ_k = Σ_i span[k, i] ν_ki`` exactly, at ``κ = 0`` as anywhere else.
    A gradient is NaN where ``ν = 0`` (the offset curve degenerates to a point).
    """
    p = offset.shape[0]
    m = span.shape[1]
    for k in range(p):
        d = offset[k]
        total = 0.0
        for i in range(m):
            sh = q[3 * i + 1]
            ax = 1.0 + q[3 * i + 2] + d * q[3 * i]
            nu = np.sqrt(sh * sh + ax * ax)
            ell = span[k, i]
            total += ell * nu
            if ell == 0.0:
                dlength[k, 3 * i] = 0.0
                dlength[k, 3 * i + 1] = 0.0
                dlength[k, 3 * i + 2] = 0.0
            else:
                c = ell / nu if nu > 0.0 else np.nan
                dlength[k, 3 * i] = c * ax * d
                dlength[k, 3 * i + 1] = c * sh
                dlength[k, 3 * i + 2] = c * ax
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
    elif kind == ACT_SERVO:
        p = offset.shape[0]
        length = np.empty(p)
        dlength = np.empty((p, n))
        tendon_terms(q, offset, span, length, dlength)
        tension = np.empty(p)
        for k in range(p):
            rest = 0.0
            for i in range(span.shape[1]):
                rest += span[k, i]  # l_k(0): the offset curve of the straight robot has unit tangent
            stretch = matrix[1, k] * u[k] * (np.pi / 180.0) + length[k] - rest - matrix[2, k]
            tension[k] = matrix[0, k] * stretch if stretch > 0.0 else 0.0
        for a in range(n):
            v = 0.0
            for k in range(p):
                v -= dlength[k, a] * tension[k]
            tau[a] = v
    else:
        for a in range(n):
            v = 0.0
            for k in range(u.shape[0]):
                v += matrix[a, k] * u[k]
            tau[a] = v


@njit(cache=True)
def actuation_batch(Q, U, geo):
    """:func:`actuation_forces` for configurations (B, n) and inputs (B, p); τ (B, n)."""
    out = np.empty(Q.shape)
    for b in range(Q.shape[0]):
        actuation_forces(Q[b], U[b], geo, out[b])
    return out


# --------------------------------------------------------------------------
# state derivative and its Jacobian
# --------------------------------------------------------------------------
@njit(cache=True)
def _accel_given_geometry(qd, geo, ws, q, out):
    """``q̈`` at ``(q, qd)`` when ``ws`` holds the geometry, Cholesky factor, static and actuation forces of q."""
    damping = geo[5]
    chol, vec = ws[6], ws[7]
    static, cq, r, tau = vec[0], vec[1], vec[2], vec[4]
    _coriolis(q, qd, geo, ws, cq)
    for a in range(tau.shape[0]):
        r[a] = tau[a] - static[a] - cq[a] - damping[a] * qd[a]
    _cholesky_solve(chol, r, out)


@njit(cache=True)
def rhs_ws(y, u, geo, ws, out):
    """:func:`rhs` with scratch arrays; returns False (and NaN accelerations) if M is not positive definite."""
    n = y.shape[0] // 2
    q = y[:n]
    qd = y[n:]
    _geometry(q, geo, ws)
    M, chol, vec = ws[5], ws[6], ws[7]
    _mass(geo, ws, M)
    _static_forces(q, geo, ws, vec[0])
    actuation_forces(q, u, geo, vec[4])
    for a in range(n):
        out[a] = qd[a]
    if not _cholesky(M, chol):
        for a in range(n):
            out[n + a] = np.nan
        return False
    _accel_given_geometry(qd, geo, ws, q, vec[3])
    for a in range(n):
        out[n + a] = vec[3][a]
    return True


@njit(cache=True)
def rhs(y, u, geo, out):
    """State derivative ``[q̇, q̈]`` of one state ``y = [q, q̇]`` under inputs ``u``; NaN where M is not definite."""
    rhs_ws(y, u, geo, workspace(geo), out)


@njit(cache=True)
def mass_and_bias_batch(Q, QD, geo):
    """:func:`mass_and_bias` for batches (B, n); returns M (B, n, n) and bias (B, n)."""
    B, n = Q.shape
    M = np.empty((B, n, n))
    bias = np.empty((B, n))
    for b in range(B):
        mass_and_bias(Q[b], QD[b], geo, M[b], bias[b])
    return M, bias


@njit(cache=True)
def accel_jacobian(y, f0, u, geo, ws, jac):
    """Forward differences ``jac = [∂q̈/∂q, ∂q̈/∂q̇]`` (n, 2n) at ``y`` with ``f0 = rhs(y)``.

    The position columns include the change of the actuation map ``A(q) u``.
    The velocity columns reuse the geometry, Cholesky factor and forces of
    ``q`` (none of them depends on ``q̇``), so they cost one Coriolis
    evaluation each.
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
    q = y[:n]
    rhs_ws(y, u, geo, ws, fp)  # geometry, factor and forces of the unperturbed q
    qdd = np.empty(n)
    qdp = y[n:].copy()
    for c in range(n):
        delta = 1.5e-8 * max(abs(y[n + c]), 1e-3)
        qdp[c] = y[n + c] + delta
        _accel_given_geometry(qdp, geo, ws, q, qdd)
        qdp[c] = y[n + c]
        for r in range(n):
            jac[r, n + c] = (qdd[r] - f0[n + r]) / delta
