"""Compiled (numba) kernels of the ground-truth PCS simulator.

These are single-state versions of the closed forms in
:mod:`pcs_sindy.simulation.dynamics` (same complex backbone formulation, same
Gauss–Legendre nodes) and a fixed-step / error-controlled Radau IIA integrator
whose whole loop over the time grid runs compiled.  They exist because the
batched numpy evaluation costs 150–400 µs of interpreter overhead per call,
which dominates an integrator that evaluates one state at a time.

Robot structure is passed as a tuple ``geo`` built by
``PCSRobot._jit_geometry``:

``(L (m,), ell (m, K+1), w_lin (m K,), mass_rot (n, n), stiffness (n,),
damping (n,), g_conj (complex), z_base (complex), base_angle (float))``

where ``ell`` holds the K quadrature nodes of each segment followed by its
length and ``w_lin`` the quadrature weights times ``ρ A``.

Every kernel is compiled with ``cache=True``: the first call on a machine
compiles (tens of seconds) and later processes load the cached machine code.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_linalg import lu_factor, lu_solve  # dense LU for the Newton systems

_SERIES_LIMIT = 0.25

# The Radau IIA tableau (A, C, E, mu) is passed in by dynamics.py, which defines it once;
# the Newton iteration limit matches dynamics._NEWTON_MAXITER.
NEWTON_MAXITER = 7

# integrator status codes returned by radau_run and rk_run
OK, NONFINITE, COLLAPSE = 0, 1, 2


# --------------------------------------------------------------------------
# kinematics and dynamics terms of one state
# --------------------------------------------------------------------------
@njit(cache=True)
def step_to_sample(h, time, t_next, max_step):
    """The next step from ``time`` towards the sample at ``t_next``.

    Proposed step ``h`` bounded by ``max_step``; a step that would leave a
    round-off sliver before the sample is stretched onto it, so every sample
    is hit exactly.  Returns the negated step when it has collapsed (below
    1e-12 of the time scale while the sample is still ahead).
    """
    span = t_next - time
    step = min(h, span, max_step)
    if span - step < 1e-10 * span + 8.0 * np.spacing(abs(t_next)):
        step = span
    if step < 1e-12 * max(1.0, abs(time)) and step < span:
        return -step
    return step


@njit(cache=True)
def _moments(u):
    """``E_0, E_1, E_2`` of :func:`dynamics.backbone_moments` for one scalar ``u``."""
    v = 0.5 * u
    sn, cs = np.sin(v), np.cos(v)
    if abs(v) < _SERIES_LIMIT:
        v2 = v * v
        s0 = 1.0 + v2 * (-1 / 6 + v2 * (1 / 120 + v2 * (-1 / 5040 + v2 * (1 / 362880 + v2 * (
            -1 / 39916800 + v2 / 6227020800)))))
        s1 = v * (-1 / 3 + v2 * (1 / 30 + v2 * (-1 / 840 + v2 * (1 / 45360 + v2 * (
            -1 / 3991680 + v2 / 518918400)))))
        s2 = -1 / 3 + v2 * (1 / 10 + v2 * (-1 / 168 + v2 * (1 / 6480 + v2 * (-1 / 443520 + v2 / 47174400))))
    else:
        inv = 1.0 / v
        s0 = sn * inv
        s1 = (cs - s0) * inv
        s2 = -s0 - 2.0 * s1 * inv
    ph = complex(cs, sn)
    e0 = ph * s0
    a = ph * s1
    e1 = 0.5 * e0 - 0.5j * a
    e2 = 0.25 * (e0 - ph * s2) - 0.5j * a
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
    vec = np.empty((4, n))  # static forces (G + K q), Coriolis, right-hand side, solution
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
            e0, e1, e2 = _moments(kap * s)
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


@njit(cache=True)
def _accel_given_geometry(qd, tau, geo, ws, q, out):
    """``q̈`` at ``(q, qd)`` when ``ws`` already holds the geometry, Cholesky factor and static forces of q."""
    damping = geo[5]
    chol, vec = ws[6], ws[7]
    static, cq, r = vec[0], vec[1], vec[2]
    _coriolis(q, qd, geo, ws, cq)
    for a in range(tau.shape[0]):
        r[a] = tau[a] - static[a] - cq[a] - damping[a] * qd[a]
    _cholesky_solve(chol, r, out)


@njit(cache=True)
def _rhs_ws(y, tau, geo, ws, out):
    """:func:`rhs` with scratch arrays; returns False (and NaN accelerations) if M is not positive definite."""
    n = tau.shape[0]
    q = y[:n]
    qd = y[n:]
    _geometry(q, geo, ws)
    M, chol, vec = ws[5], ws[6], ws[7]
    _mass(geo, ws, M)
    _static_forces(q, geo, ws, vec[0])
    for a in range(n):
        out[a] = qd[a]
    if not _cholesky(M, chol):
        for a in range(n):
            out[n + a] = np.nan
        return False
    _accel_given_geometry(qd, tau, geo, ws, q, vec[3])
    for a in range(n):
        out[n + a] = vec[3][a]
    return True


@njit(cache=True)
def rhs(y, tau, geo, out):
    """State derivative ``[q̇, q̈]`` of one state ``y = [q, q̇]``; NaN where M is not positive definite."""
    _rhs_ws(y, tau, geo, workspace(geo), out)


@njit(cache=True)
def rhs_batch(Y, TAU, geo):
    """:func:`rhs` for states (B, 2n) and actuations (B, n)."""
    out = np.empty_like(Y)
    ws = workspace(geo)
    for b in range(Y.shape[0]):
        _rhs_ws(Y[b], TAU[b], geo, ws, out[b])
    return out


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
def accel_jacobian(y, f0, tau, geo, ws, jac):
    """Forward differences ``jac = [∂q̈/∂q, ∂q̈/∂q̇]`` (n, 2n) at ``y`` with ``f0 = rhs(y)``.

    Same increments as the numpy path.  The velocity columns reuse the
    geometry and Cholesky factor of ``q`` (M does not depend on ``q̇``), so
    they cost one Coriolis evaluation each.
    """
    n = tau.shape[0]
    N = 2 * n
    yp = y.copy()
    fp = np.empty(N)
    for c in range(n):
        delta = 1.5e-8 * max(abs(y[c]), 1e-3)
        yp[c] = y[c] + delta
        _rhs_ws(yp, tau, geo, ws, fp)
        yp[c] = y[c]
        for r in range(n):
            jac[r, c] = (fp[n + r] - f0[n + r]) / delta
    q = y[:n]
    _rhs_ws(y, tau, geo, ws, fp)  # geometry, factor and static forces of the unperturbed q
    qdd = np.empty(n)
    qdp = y[n:].copy()
    for c in range(n):
        delta = 1.5e-8 * max(abs(y[n + c]), 1e-3)
        qdp[c] = y[n + c] + delta
        _accel_given_geometry(qdp, tau, geo, ws, q, qdd)
        qdp[c] = y[n + c]
        for r in range(n):
            jac[r, n + c] = (qdd[r] - f0[n + r]) / delta


@njit(cache=True)
def _stage_rms(D, scale):
    """Largest over the stages of the RMS of ``D / scale`` (the numpy path's norm)."""
    worst = 0.0
    N = scale.shape[0]
    for i in range(D.shape[0]):
        acc = 0.0
        for c in range(N):
            v = D[i, c] / scale[c]
            acc += v * v
        v = np.sqrt(acc / N)
        if not v <= worst:  # NaN propagates
            worst = v
    return worst


@njit(cache=True)
def _all_finite(x):
    for v in x.ravel():
        if not np.isfinite(v):
            return False
    return True


# --------------------------------------------------------------------------
# Radau IIA over a time grid
# --------------------------------------------------------------------------
@njit(cache=True)
def _factor_newton(jac, step, A, A2, big, piv):
    """LU of the velocity-reduced Newton matrix ``I - h A⊗J_v - h² A²⊗J_q`` (3n, 3n).

    For ``y = [q, v]`` the state Jacobian is ``[[0, I], [J_q, J_v]]``; block
    elimination of the position increments (``dZ_q = r_q + h (A⊗I) dZ_v``)
    turns the 6n Newton system of Radau IIA into this 3n one, exactly.
    """
    n = jac.shape[0]
    for i in range(3):
        for j in range(3):
            a = step * A[i, j]
            a2 = step * step * A2[i, j]
            for r in range(n):
                for c in range(n):
                    big[i * n + r, j * n + c] = -a * jac[r, n + c] - a2 * jac[r, c]
    for r in range(3 * n):
        big[r, r] += 1.0
    return lu_factor(big, piv)


@njit(cache=True)
def _newton_solve(jac, step, A, big, piv, R, dZ, rhs_v):
    """Newton increments dZ (3, 2n) for residuals R (3, 2n) with the factors of :func:`_factor_newton`."""
    n = jac.shape[0]
    for i in range(3):
        for r in range(n):
            v = R[i, n + r]
            for j in range(3):
                a = step * A[i, j]
                if a != 0.0:
                    for c in range(n):
                        v += a * jac[r, c] * R[j, c]
            rhs_v[i * n + r] = v
    lu_solve(big, piv, rhs_v)
    for i in range(3):
        for r in range(n):
            dZ[i, n + r] = rhs_v[i * n + r]
            v = R[i, r]
            for j in range(3):
                v += step * A[i, j] * rhs_v[j * n + r]
            dZ[i, r] = v


@njit(cache=True)
def _factor_error(jac, c0, small, piv):
    """LU of the velocity-reduced error matrix ``c I - J_v - J_q / c`` for ``(c I - J)``, ``c = mu/h``."""
    n = jac.shape[0]
    for r in range(n):
        for c in range(n):
            small[r, c] = -jac[r, n + c] - jac[r, c] / c0
        small[r, r] += c0
    return lu_factor(small, piv)


@njit(cache=True)
def _error_solve(jac, c0, small, piv, rhs_in, out, tmp):
    """``out = (c I - J)^{-1} rhs_in`` (2n) with the factors of :func:`_factor_error`."""
    n = jac.shape[0]
    for r in range(n):
        v = rhs_in[n + r]
        for c in range(n):
            v += jac[r, c] * rhs_in[c] / c0
        tmp[r] = v
    lu_solve(small, piv, tmp)
    for r in range(n):
        out[n + r] = tmp[r]
        out[r] = (rhs_in[r] + tmp[r]) / c0


@njit(cache=True)
def _rms(x, scale):
    acc = 0.0
    for c in range(x.shape[0]):
        v = x[c] / scale[c]
        acc += v * v
    return np.sqrt(acc / x.shape[0])


@njit(cache=True)
def radau_run(k0, k1, t, tau_rows, out, h_arr, hprev_arr, havez_arr, zprev_arr, ratelast_arr, jac_arr, jacst_arr,
              hlu_arr, big_arr, pivbig_arr, small_arr, pivsmall_arr, geo, rtol, atol, max_step, fixed, A, C, E, mu,
              refresh_rate, stats):
    """Advance every robot from sample ``k0`` to ``k1`` with Radau IIA (order 5), in place.

    ``out`` (T, B, N) holds the sampled states (``out[k0]`` is the start);
    ``tau_rows`` (T, B, n) the zero-order-hold actuation.  The per-robot
    integrator state (next step ``h``, last step, last collocation increments,
    last Newton rate, acceleration Jacobian ``[J_q, J_v]`` (n, 2n) and its
    status 0 = none / 1 = stale / 2 = current, factored Newton and error
    matrices and the step they belong to) is carried in the ``*_arr`` arrays
    so that a run split in chunks gives exactly the same numbers.  ``fixed``: steps of
    ``max_step`` without error control.  ``stats`` (4,) counts accepted steps,
    Newton iterations, Jacobian evaluations and rejected or repeated steps.
    Returns ``(status, time, robot)``; status 0 = ok, 1 = non-finite
    derivative, 2 = step size collapsed.
    """
    B = out.shape[1]
    N = out.shape[2]
    n = N // 2
    newton_tol = max(10.0 * 2.220446049250313e-16 / rtol, min(0.03, np.sqrt(rtol)))
    nodes = np.array([0.0, C[0], C[1], C[2]])
    A2 = A @ A
    ws = workspace(geo)
    Z = np.empty((3, N))
    F = np.empty((3, N))
    R = np.empty((3, N))
    dZ = np.empty((3, N))
    rhs_v = np.empty(3 * n)
    state = np.empty(N)
    f0 = np.empty(N)
    scale = np.empty(N)
    y_new = np.empty(N)
    err = np.empty(N)
    err_in = np.empty(N)
    work = np.empty(N)
    tmp = np.empty(n)
    wts = np.empty((3, 4))
    for b in range(B):
        y = out[k0, b].copy()
        h = h_arr[b]
        h_prev = hprev_arr[b]
        have_z = havez_arr[b]
        z_prev = zprev_arr[b]
        rate_last = ratelast_arr[b]
        jac = jac_arr[b]
        jac_state = jacst_arr[b]
        h_lu = hlu_arr[b]  # step the factored Newton matrix belongs to (-1: none)
        big = big_arr[b]
        piv_big = pivbig_arr[b]
        small = small_arr[b]
        piv_small = pivsmall_arr[b]
        time = t[k0]
        for k in range(k0, k1):
            tau = tau_rows[k, b]
            t_next = t[k + 1]
            while time < t_next:
                span = t_next - time
                step = step_to_sample(h, time, t_next, max_step)
                if step < 0.0:
                    return COLLAPSE, time, b
                for c in range(N):
                    scale[c] = atol + abs(y[c]) * rtol
                if have_z:
                    # continue the last step's collocation polynomial (Newton starts closer)
                    ratio = step / h_prev
                    for i in range(3):
                        s = 1.0 + ratio * C[i]
                        for j in range(4):
                            v = 1.0
                            for kk in range(4):
                                if kk != j:
                                    v *= (s - nodes[kk]) / (nodes[j] - nodes[kk])
                            wts[i, j] = v
                    for i in range(3):
                        for c in range(N):
                            v = -z_prev[2, c]
                            for j in range(3):
                                v += wts[i, j + 1] * z_prev[j, c]
                            Z[i, c] = v
                else:
                    Z[:, :] = 0.0
                _rhs_ws(y, tau, geo, ws, f0)
                if not _all_finite(f0):
                    return NONFINITE, time, b
                if jac_state == 0:
                    accel_jacobian(y, f0, tau, geo, ws, jac)
                    stats[2] += 1
                    jac_state = 2
                    h_lu = -1.0
                if h_lu < 0.0 or abs(step - h_lu) > 1e-9 * step:
                    ok = _factor_newton(jac, step, A, A2, big, piv_big)
                    if not fixed:
                        ok = ok and _factor_error(jac, mu / step, small, piv_small)
                    if not ok:
                        return NONFINITE, time, b
                    h_lu = step
                converged = False
                rate = -1.0  # -1: not known
                dz_old = -1.0
                n_iter = 0
                for it in range(1, NEWTON_MAXITER + 1):
                    n_iter = it
                    stats[1] += 1
                    for i in range(3):
                        for c in range(N):
                            state[c] = y[c] + Z[i, c]
                        _rhs_ws(state, tau, geo, ws, F[i])
                    if not _all_finite(F):
                        break
                    for i in range(3):
                        for c in range(N):
                            v = -Z[i, c]
                            for j in range(3):
                                v += step * A[i, j] * F[j, c]
                            R[i, c] = v
                    _newton_solve(jac, step, A, big, piv_big, R, dZ, rhs_v)
                    dz = _stage_rms(dZ, scale)
                    stop = False
                    if dz_old >= 0.0:
                        rate = dz / dz_old
                        if rate >= 1.0 or rate ** (NEWTON_MAXITER - it) / (1.0 - rate) * dz > newton_tol:
                            stop = True
                    for i in range(3):
                        for c in range(N):
                            Z[i, c] += dZ[i, c]
                    if stop:
                        break
                    # first iteration: judge with the rate seen in the last step (Hairer's RADAU5)
                    known = rate if rate >= 0.0 else rate_last
                    if dz == 0.0 or (known >= 0.0 and known < 1.0 and known / (1.0 - known) * dz < newton_tol):
                        converged = True
                        break
                    dz_old = dz
                if not converged:
                    stats[3] += 1
                    have_z = False
                    if jac_state != 2:
                        accel_jacobian(y, f0, tau, geo, ws, jac)
                        stats[2] += 1
                        jac_state = 2
                        h_lu = -1.0
                    else:
                        h = 0.5 * step
                    continue
                if rate >= 0.0:
                    rate_last = rate
                for c in range(N):
                    y_new[c] = y[c] + Z[2, c]
                slow = n_iter > 2 and rate > refresh_rate
                if fixed:
                    stats[0] += 1
                    time = t_next if step == span else time + step
                    y[:] = y_new
                    z_prev[:, :] = Z
                    have_z = True
                    h_prev = step
                    h = max_step
                    jac_state = 0 if slow else 1  # slow Newton convergence: refresh the Jacobian next step
                    continue
                # error estimate (Hairer & Wanner): (mu/h I - J)^{-1} (f0 + Σ e_i Z_i / h)
                for c in range(N):
                    work[c] = (E[0] * Z[0, c] + E[1] * Z[1, c] + E[2] * Z[2, c]) / step
                    err_in[c] = f0[c] + work[c]
                    scale[c] = atol + max(abs(y[c]), abs(y_new[c])) * rtol
                _error_solve(jac, mu / step, small, piv_small, err_in, err, tmp)
                err_norm = _rms(err, scale)
                safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
                if not err_norm <= 1.0:
                    # refined estimate before rejecting: filters the stiff components
                    for c in range(N):
                        state[c] = y[c] + err[c]
                    _rhs_ws(state, tau, geo, ws, err_in)
                    for c in range(N):
                        err_in[c] += work[c]
                    _error_solve(jac, mu / step, small, piv_small, err_in, err, tmp)
                    err_norm = _rms(err, scale) if _all_finite(err) else np.inf
                if not err_norm <= 1.0:
                    factor = 0.2 if not np.isfinite(err_norm) else max(0.2, safety * err_norm ** -0.25)
                    h = step * factor
                    have_z = False
                    stats[3] += 1
                    continue
                stats[0] += 1
                z_prev[:, :] = Z
                have_z = True
                h_prev = step
                time = t_next if step == span else time + step
                y[:] = y_new
                factor = 10.0 if err_norm == 0.0 else min(10.0, safety * err_norm ** -0.25)
                h = max(h, step * factor) if step < h else step * factor
                jac_state = 0 if slow else 1
            out[k + 1, b] = y
        h_arr[b] = h
        hprev_arr[b] = h_prev
        havez_arr[b] = have_z
        ratelast_arr[b] = rate_last
        jacst_arr[b] = jac_state
        hlu_arr[b] = h_lu
    return OK, 0.0, -1


# --------------------------------------------------------------------------
# explicit embedded Runge-Kutta over a time grid
# --------------------------------------------------------------------------
@njit(cache=True)
def rk_run(t, tau_rows, out, geo, rtol, atol, max_step, fixed, A, Bw, C, E, E3, E5, is_dop853, err_exp, stats):
    """Explicit embedded Runge–Kutta (scipy's RK45 / DOP853 tableaux) for every robot, in place.

    ``out`` (T, B, N) receives the sampled states (``out[0]`` is the start),
    ``tau_rows`` (T, B, n) is the zero-order-hold actuation.  Error norms as
    in :mod:`scipy.integrate` (DOP853's combined 3rd/5th-order estimate when
    ``is_dop853``).  ``fixed``: steps of ``max_step`` without error control.
    ``stats`` (2,) counts accepted and rejected steps.  Returns ``(status,
    time, robot)`` like :func:`radau_run`.
    """
    T = out.shape[0]
    B = out.shape[1]
    N = out.shape[2]
    n = N // 2
    S = Bw.shape[0]
    ws = workspace(geo)
    K = np.empty((S, N))
    ys = np.empty(N)
    y_new = np.empty(N)
    f_new = np.empty(N)
    fsal = np.empty(N)
    for b in range(B):
        y = out[0, b].copy()
        h = min(t[1] - t[0], max_step) if T > 1 else 0.0
        have_fsal = False
        time = t[0]
        for k in range(T - 1):
            tau = tau_rows[k, b]
            if k > 0:
                for a in range(n):
                    if tau_rows[k, b, a] != tau_rows[k - 1, b, a]:
                        have_fsal = False  # the held actuation switched: the last derivative is stale
            t_next = t[k + 1]
            while time < t_next:
                span = t_next - time
                step = step_to_sample(h, time, t_next, max_step)
                if step < 0.0:
                    return COLLAPSE, time, b
                for s in range(S):
                    if s == 0 and have_fsal:
                        K[0, :] = fsal
                        continue
                    for c in range(N):
                        v = y[c]
                        for j in range(s):
                            v += step * A[s, j] * K[j, c]
                        ys[c] = v
                    _rhs_ws(ys, tau, geo, ws, K[s])
                for c in range(N):
                    v = 0.0
                    for s in range(S):
                        v += Bw[s] * K[s, c]
                    y_new[c] = y[c] + step * v
                finite = _all_finite(y_new)
                got_f_new = False
                if fixed and finite:
                    err_norm = 0.0
                elif not finite:
                    err_norm = np.inf
                else:
                    _rhs_ws(y_new, tau, geo, ws, f_new)
                    got_f_new = True
                    if not _all_finite(f_new):
                        err_norm = np.inf
                    elif is_dop853:
                        e5n = 0.0
                        e3n = 0.0
                        for c in range(N):
                            sc = atol + max(abs(y[c]), abs(y_new[c])) * rtol
                            e5 = E5[S] * f_new[c]
                            e3 = E3[S] * f_new[c]
                            for s in range(S):
                                e5 += E5[s] * K[s, c]
                                e3 += E3[s] * K[s, c]
                            e5n += (e5 / sc) ** 2
                            e3n += (e3 / sc) ** 2
                        denom = e5n + 0.01 * e3n
                        err_norm = step * e5n / np.sqrt(denom * N) if denom > 0 else 0.0
                    else:
                        acc = 0.0
                        for c in range(N):
                            sc = atol + max(abs(y[c]), abs(y_new[c])) * rtol
                            e = E[S] * f_new[c]
                            for s in range(S):
                                e += E[s] * K[s, c]
                            acc += (step * e / sc) ** 2
                        err_norm = np.sqrt(acc / N)
                if err_norm <= 1.0:
                    stats[0] += 1
                    time = t_next if step == span else time + step
                    y[:] = y_new
                    have_fsal = got_f_new
                    if got_f_new:
                        fsal[:] = f_new
                    factor = 10.0 if err_norm == 0.0 else min(10.0, 0.9 * err_norm ** err_exp)
                    # a step shortened to land on a sample must not shrink the proposal
                    h = max(h, step * factor) if step < h else step * factor
                else:
                    stats[1] += 1
                    h = step * (0.2 if not np.isfinite(err_norm) else max(0.2, 0.9 * err_norm ** err_exp))
            out[k + 1, b] = y
    return OK, 0.0, -1
