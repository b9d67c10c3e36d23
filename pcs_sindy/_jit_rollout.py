"""Compiled (numba) rollout of planar PCS models with lumped physical parameters.

A model identified with a physical parameterisation (``PhysicalPCSLibrary`` or
``PCSLagrangianLibrary(basis="physical")``) is fully described by per-segment
lumped parameters: ``rho A_i``, ``rho I_i`` (rotary), ``rho A_i g`` and, per
active strain, stiffness ``k_e`` and damping ``d_e``.  The kernels here evaluate

    M(q) = sum_p w_p rhoA Re(J_p^H J_p) + M_rot,
    bias = Re sum_p w_p J_p^H (rhoA Jdot_p qd - rhoA g) + K q + D qd

with complex backbone positions, closed-form Jacobians and Gauss–Legendre
quadrature (the same formulas as ``pcs_sindy.library._pcs_numeric``: segment j
contributes ``e^{i phi_j} w_j l E_0(kappa_j l)``, ``E_n`` by Taylor series near
``kappa l = 0``, no epsilon), and integrate over the whole time grid inside one
compiled call, with Dormand–Prince 5(4) or with the Rosenbrock-W method
ROS34PW2 (``method="rosenbrock"``), whose W matrix uses the structural Jacobian
``[[0, I], [-M^-1 K, -M^-1 D]]`` (stiffness and damping through the inertia at
the step's start: the stiff part of these models).  Both integrators mirror
:func:`pcs_sindy.integrators.integrate_zoh` step for step (same controllers; for
Rosenbrock with ``jac=`` that Jacobian), so both paths agree to round-off
accumulated over the run.

Identification side: does not import :mod:`pcs_sindy.simulation`.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._numba_linalg import lu_factor, lu_solve, solve
from .integrators import DOPRI5, METHODS, ROS34PW2, DivergenceError, _describe
from .library._pcs_numeric import make_quadrature, rotary_mass

__all__ = ["LumpedModel", "rollout", "STATUS_MESSAGES"]

_SERIES_RADIUS = 1.0
_N_SERIES = 20  # 1 / 20! < 1e-18
# Horner tables, highest power first: row j holds the coefficient of u^(2(J-1-j)) for n = 0, 1, 2
_SER_RE = np.array([[(-1) ** j / (math.factorial(2 * j) * (n + 2 * j + 1)) for n in range(3)]
                    for j in range(_N_SERIES // 2)])[::-1].copy()
_SER_IM = np.array([[(-1) ** j / (math.factorial(2 * j + 1) * (n + 2 * j + 2)) for n in range(3)]
                    for j in range(_N_SERIES // 2)])[::-1].copy()

#: status codes of the compiled loop
OK, NONFINITE, TOO_LARGE, SINGULAR, MIN_STEP = 0, 1, 2, 3, 4
STATUS_MESSAGES = {
    NONFINITE: "non-finite state",
    TOO_LARGE: "|state| exceeded max_abs_state = {max_abs:g}",
    SINGULAR: "right-hand side failed: singular mass matrix",
    MIN_STEP: "step size fell below min_step = {min_step:g} s",
}

_A = np.ascontiguousarray(DOPRI5.a)
_C = np.ascontiguousarray(DOPRI5.c)
_E = np.ascontiguousarray(DOPRI5.e)
_BETA = 0.04
_RA = ROS34PW2.at
_RC = ROS34PW2.ct
_RM = ROS34PW2.mt
_RE = ROS34PW2.et


# --------------------------------------------------------------------------
# kernels
# --------------------------------------------------------------------------
@numba.njit(cache=True)
def _moments(u: float):
    """``E_n(u) = int_0^1 t^n e^{iut} dt``, n = 0, 1, 2.

    |u| <= 1: Taylor series, real arithmetic on the even/odd powers (complex
    division is the slow path in compiled code); 20 terms, error < 1/20! < 1e-18.
    |u| > 1: integration by parts, ``E_{n+1} = (e^{iu} - (n+1) E_n) / (iu)``;
    each division by ``|u| > 1`` at most doubles the absolute error.
    """
    if abs(u) <= _SERIES_RADIUS:
        # E_n = sum_k (iu)^k / (k! (n + k + 1)): even k give the real part, odd k the
        # imaginary part, each a polynomial in u^2 (Horner with constant tables)
        u2 = u * u
        r0 = _SER_RE[0, 0]
        r1 = _SER_RE[0, 1]
        r2 = _SER_RE[0, 2]
        i0 = _SER_IM[0, 0]
        i1 = _SER_IM[0, 1]
        i2 = _SER_IM[0, 2]
        for j in range(1, _SER_RE.shape[0]):
            r0 = r0 * u2 + _SER_RE[j, 0]
            r1 = r1 * u2 + _SER_RE[j, 1]
            r2 = r2 * u2 + _SER_RE[j, 2]
            i0 = i0 * u2 + _SER_IM[j, 0]
            i1 = i1 * u2 + _SER_IM[j, 1]
            i2 = i2 * u2 + _SER_IM[j, 2]
        return complex(r0, u * i0), complex(r1, u * i1), complex(r2, u * i2)
    c = math.cos(u)
    sn = math.sin(u)
    # 1/(iu) = -i/u: multiply instead of dividing complex numbers
    inv = 1.0 / u
    e0 = complex(sn * inv, (1.0 - c) * inv)  # (e^{iu} - 1) / (iu)
    a = complex(c, sn) - e0
    e1 = complex(a.imag * inv, -a.real * inv)
    b = complex(c, sn) - 2.0 * e1
    e2 = complex(b.imag * inv, -b.real * inv)
    return e0, e1, e2


@numba.njit(cache=True)
def _dynamics(q, qd, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v):
    """Fill ``M`` (n, n) and ``bias`` (n,) at the active strains ``q``, ``qd``.

    ``J`` (2, 3m, m K) (real, imaginary parts of the Jacobian columns) and
    ``v`` (2, m K) (the node forces) are work arrays.
    """
    m = L.size
    K = wts.shape[1]
    n = act.size
    qf = np.zeros(3 * m)
    qdf = np.zeros(3 * m)
    for a in range(n):
        qf[act[a]] = q[a]
        qdf[act[a]] = qd[a]
    J[:, :, :] = 0.0
    phi = 0.0
    phid = 0.0
    zstart = 0.0j
    acc_start = 0.0j
    acc_end = 0.0j
    own_end_be = np.zeros(m, dtype=np.complex128)
    own_end_sh = np.zeros(m, dtype=np.complex128)
    zend = np.zeros(m, dtype=np.complex128)
    for i in range(m):
        kap = qf[3 * i]
        kd = qdf[3 * i]
        w = qf[3 * i + 1] + 1j * (1.0 + qf[3 * i + 2])
        wd = qdf[3 * i + 1] + 1j * qdf[3 * i + 2]
        eph = np.exp(1j * phi)
        ew = eph * w
        # convective acceleration coefficients (qdd = 0): e^{i phi} (c0 F + c1 F_k + c2 F_kk)
        ipd = 2j * phid
        c0 = ew * (-(phid * phid)) + ipd * eph * wd
        c1 = (ipd * ew + 2.0 * eph * wd) * kd
        c2 = ew * (kd * kd)
        for p in range(K + 1):
            s = ell[i, p]
            e0, e1, e2 = _moments(kap * s)
            F = s * e0
            Fk = 1j * s * s * e1
            Fkk = -(s * s * s) * e2
            sh = eph * F
            be = ew * Fk
            T = w * sh
            Tdd = c0 * F + c1 * Fk + c2 * Fkk
            if p == K:
                own_end_be[i] = be
                own_end_sh[i] = sh
                zend[i] = zstart + T
                acc_end = acc_start + Tdd
            else:
                row = i * K + p
                z = zstart + T
                J[0, 3 * i, row] = be.real
                J[1, 3 * i, row] = be.imag
                J[0, 3 * i + 1, row] = sh.real
                J[1, 3 * i + 1, row] = sh.imag
                J[0, 3 * i + 2, row] = -sh.imag
                J[1, 3 * i + 2, row] = sh.real
                for k in range(i):
                    jk = own_end_be[k] + 1j * L[k] * (z - zend[k])
                    J[0, 3 * k, row] = jk.real
                    J[1, 3 * k, row] = jk.imag
                    J[0, 3 * k + 1, row] = own_end_sh[k].real
                    J[1, 3 * k + 1, row] = own_end_sh[k].imag
                    J[0, 3 * k + 2, row] = -own_end_sh[k].imag
                    J[1, 3 * k + 2, row] = own_end_sh[k].real
                wa = wts[i, p] * rhoA[i]
                vr = wa * (acc_start + Tdd) - wts[i, p] * rhoAg[i]
                v[0, row] = vr.real
                v[1, row] = vr.imag
        zstart = zend[i]
        acc_start = acc_end
        phi += kap * L[i]
        phid += kd * L[i]
    _assemble(J, v, act, wts, rhoA, M_rot, stiff, damp, q, qd, M, bias)


# reassociation lets LLVM vectorise the quadrature sums (no NaN/inf assumptions)
@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _assemble(J, v, act, wts, rhoA, M_rot, stiff, damp, q, qd, M, bias):
    """``M = sum_p w rhoA Re(J^H J) + M_rot`` and ``bias = Re(J^H v) + K q + D qd`` (J as (2, 3m, mK))."""
    n = act.size
    m, K = wts.shape
    for a in range(n):
        ca = act[a]
        sa = ca // 3
        acc = 0.0
        for row in range(sa * K, m * K):
            acc += J[0, ca, row] * v[0, row] + J[1, ca, row] * v[1, row]
        bias[a] = acc + stiff[a] * q[a] + damp[a] * qd[a]
        for b in range(a, n):
            cb = act[b]
            acc = 0.0
            # only nodes beyond both strains' segments see both columns
            for i in range(max(sa, cb // 3), m):
                wa = rhoA[i]
                part = 0.0
                for p in range(K):
                    row = i * K + p
                    part += wts[i, p] * (J[0, ca, row] * J[0, cb, row] + J[1, ca, row] * J[1, cb, row])
                acc += wa * part
            M[a, b] = acc + M_rot[a, b]
            M[b, a] = M[a, b]


@numba.njit(cache=True)
def _rhs(y, u, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v, acc, out):
    n = act.size
    _dynamics(y[:n], y[n:], act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v)
    for a in range(n):
        bias[a] = u[a] - bias[a]
        out[a] = y[n + a]
    # LU, not Cholesky: an identified M need not be positive definite, and the Python path
    # only fails on an exactly singular (or non-finite) matrix
    ok = solve(M, bias, acc)
    for a in range(n):
        out[n + a] = acc[a]
    return ok


@numba.njit(cache=True)
def _mass_bias_batch(q, qd, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp):
    B, n = q.shape
    m = L.size
    K = wts.shape[1]
    Ms = np.empty((B, n, n))
    bs = np.empty((B, n))
    J = np.zeros((2, 3 * m, m * K))
    v = np.zeros((2, m * K))
    M = np.empty((n, n))
    bias = np.empty(n)
    for b in range(B):
        _dynamics(q[b], qd[b], act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v)
        Ms[b] = M
        bs[b] = bias
    return Ms, bs


@numba.njit(cache=True)
def _next_step(fixed_step, h_fixed, h, y, f, rtol, atol, remaining, max_step, dt_k):
    """The next step towards the sample ``remaining`` ahead: ``(hk, last, h)``.

    Fixed steps: ``h_fixed``, the last one of the interval absorbing round-off.
    Adaptive: the proposal ``h`` (a starting guess from ``y`` and its rate ``f``
    when ``h < 0``, which is returned as the new proposal), bounded by the sample
    and ``max_step``; a step that would leave a sliver before the sample is halved.
    The rule of :func:`pcs_sindy.integrators.integrate_zoh`, so both paths take the
    same steps.
    """
    if fixed_step > 0:
        return h_fixed, remaining <= 1.5 * h_fixed, h
    d = y.size
    if h < 0:
        d0 = 0.0
        d1 = 0.0
        for j in range(d):
            sc = atol + rtol * abs(y[j])
            d0 += (y[j] / sc) ** 2
            d1 += (f[j] / sc) ** 2
        d0 = math.sqrt(d0 / d)
        d1 = math.sqrt(d1 / d)
        h = 0.01 * d0 / d1 if (d0 > 1e-5 and d1 > 1e-5) else 1e-6
        h = min(h, dt_k)
    hmax = max_step if max_step > 0 else dt_k
    hk = min(h, remaining, hmax)
    last = hk >= remaining * (1 - 1e-12)
    if not last and remaining - hk < 0.1 * hk:
        hk = 0.5 * remaining
    return hk, last, h


@numba.njit(cache=True)
def _state_status(y, max_abs):
    """``OK``, or why an accepted state ends the rollout (``NONFINITE``, ``TOO_LARGE``)."""
    big = 0.0
    for j in range(y.size):
        if not math.isfinite(y[j]):
            return NONFINITE
        big = max(big, abs(y[j]))
    return TOO_LARGE if big > max_abs else OK


@numba.njit(cache=True)
def _dopri_loop(y0, t, u, fixed_step, rtol, atol, max_step, min_step, max_abs,
                A, C, E, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp):
    """DOPRI5 over all sample intervals; ``fixed_step <= 0`` means adaptive.

    Returns ``(out, status, k_fail, t_fail, y_fail, n_steps, n_rejected, n_eval)``.
    ``out`` rows after a failure are NaN.
    """
    T = t.size
    d = y0.size
    n = act.size
    m = L.size
    K = wts.shape[1]
    n_st = C.size
    out = np.full((T, d), np.nan)
    out[0] = y0
    y = y0.copy()
    Ks = np.zeros((n_st, d))
    yi = np.empty(d)
    y_new = np.empty(d)
    M = np.empty((n, n))
    bias = np.empty(n)
    J = np.zeros((2, 3 * m, m * K))
    v = np.zeros((2, m * K))
    acc = np.empty(n)
    kbuf = np.empty(d)
    h = -1.0  # not yet chosen
    expo = -1.0 / 5.0
    err_prev = 1e-4
    rejected_last = False
    n_steps = 0
    n_rej = 0
    n_eval = 0
    for k in range(T - 1):
        t0 = t[k]
        dt_k = t[k + 1] - t[k]
        t_end = t0 + dt_k
        tc = t0
        uk = u[k]
        h_fixed = 0.0
        if fixed_step > 0:
            n_int = max(1, int(round(dt_k / fixed_step)))
            h_fixed = dt_k / n_int
        # a held input jumps at the boundary, so the last stage is stale
        n_eval += 1
        if not _rhs(y, uk, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v, acc, kbuf):
            return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
        Ks[0] = kbuf
        while tc < t_end:
            hk, last, h = _next_step(fixed_step, h_fixed, h, y, Ks[0], rtol, atol, t_end - tc, max_step, dt_k)
            ok = True
            for i in range(1, n_st):
                for j in range(d):
                    s = 0.0
                    for l in range(i):
                        s += A[i, l] * Ks[l, j]
                    yi[j] = y[j] + hk * s
                n_eval += 1
                ok = _rhs(yi, uk, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v, acc, kbuf)
                if not ok:
                    break
                Ks[i] = kbuf
            if not ok:
                if fixed_step > 0:
                    return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
                # the Python path raises on a failed right-hand side as well
                return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
            y_new[:] = yi
            if fixed_step > 0:
                accept = True
            else:
                err = 0.0
                for j in range(d):
                    s = 0.0
                    for l in range(n_st):
                        s += E[l] * Ks[l, j]
                    sc = atol + rtol * max(abs(y[j]), abs(y_new[j]))
                    err += (hk * s / sc) ** 2
                err = math.sqrt(err / d)
                if not math.isfinite(err):
                    accept = False
                    h = 0.2 * hk
                else:
                    accept = err <= 1.0
                    if err == 0:
                        fac = 10.0
                    else:
                        fac = min(10.0, max(0.2, 0.9 * err ** (expo + 0.75 * _BETA) * err_prev ** _BETA))
                    if (not accept) or rejected_last:
                        fac = min(fac, 1.0)
                    if accept:
                        err_prev = max(err, 1e-4)
                    rejected_last = not accept
                    h = hk * fac
                if (not accept) and h < min_step:
                    return out, MIN_STEP, k, tc, y, n_steps, n_rej, n_eval
            if not accept:
                n_rej += 1
            else:
                n_steps += 1
                status = _state_status(y_new, max_abs)
                if status != OK:
                    return out, status, k, tc + hk, y_new, n_steps, n_rej, n_eval
                y[:] = y_new
                tc = t_end if last else tc + hk
                Ks[0] = Ks[n_st - 1]
        out[k + 1] = y
    return out, OK, T - 1, t[T - 1], y, n_steps, n_rej, n_eval


@numba.njit(cache=True)
def _ros_loop(y0, t, u, fixed_step, rtol, atol, max_step, min_step, max_abs,
              RA, RC, RM, RE, gam, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp):
    """Rosenbrock-W (transformed coefficients ``RA, RC, RM, RE``, diagonal ``gam``) over all sample intervals.

    The W matrix uses the structural Jacobian ``[[0, I], [-M0^-1 K, -M0^-1 D]]``
    with ``M0`` the mass matrix at the step's start: the stiff part of the
    dynamics (stiffness and damping acting through the inertia).  Solving
    ``(c I - J) [x1, x2] = [r1, r2]`` (``c = 1 / (h gam)``) reduces exactly to
    ``(c^2 M0 + c D + K) x1 = M0 (r2 + c r1) + D r1``, ``x2 = c x1 - r1``: one
    n x n LU per step, no inverse of ``M0``.  Same outputs as :func:`_dopri_loop`.
    """
    T = t.size
    d = y0.size
    n = act.size
    m = L.size
    K = wts.shape[1]
    n_st = RM.size
    out = np.full((T, d), np.nan)
    out[0] = y0
    y = y0.copy()
    U = np.zeros((n_st, d))
    yi = np.empty(d)
    y_new = np.empty(d)
    f0 = np.empty(d)
    M = np.empty((n, n))
    M0 = np.empty((n, n))
    S = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    bias = np.empty(n)
    J = np.zeros((2, 3 * m, m * K))
    v = np.zeros((2, m * K))
    acc = np.empty(n)
    kbuf = np.empty(d)
    x1 = np.empty(n)
    h = -1.0
    expo = -1.0 / 3.0
    rejected_last = False
    ymax = np.abs(y0)  # running max |y_j|: the error scale
    h_first = -1.0  # step predicted for the first step of an interval (after a jump of the input)
    n_steps = 0
    n_rej = 0
    n_eval = 0
    for k in range(T - 1):
        t0 = t[k]
        dt_k = t[k + 1] - t[k]
        t_end = t0 + dt_k
        tc = t0
        uk = u[k]
        h_fixed = 0.0
        if fixed_step > 0:
            n_int = max(1, int(round(dt_k / fixed_step)))
            h_fixed = dt_k / n_int
        need_f0 = True
        first = True
        if h_first > 0 and k > 0:
            h = min(h, h_first)
        while tc < t_end:
            if need_f0:
                n_eval += 1
                if not _rhs(y, uk, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v, acc, f0):
                    return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
                M0[:, :] = M
                need_f0 = False
            hk, last, h = _next_step(fixed_step, h_fixed, h, y, f0, rtol, atol, t_end - tc, max_step, dt_k)
            c = 1.0 / (hk * gam)
            for a in range(n):
                for b in range(n):
                    S[a, b] = c * c * M0[a, b]
                S[a, a] += c * damp[a] + stiff[a]
            if not lu_factor(S, piv):
                return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
            ok = True
            for i in range(n_st):
                if i == 0:
                    kbuf[:] = f0
                else:
                    for j in range(d):
                        s = y[j]
                        for l in range(i):
                            s += RA[i, l] * U[l, j]
                        yi[j] = s
                    n_eval += 1
                    ok = _rhs(yi, uk, act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, M, bias, J, v, acc, kbuf)
                    if not ok:
                        break
                # r = f + sum_l RC[i, l] U_l / h, then the structured solve
                for j in range(d):
                    s = kbuf[j]
                    for l in range(i):
                        s += RC[i, l] * U[l, j] / hk
                    kbuf[j] = s
                for a in range(n):
                    s = 0.0
                    for b in range(n):
                        s += M0[a, b] * (kbuf[n + b] + c * kbuf[b])
                    x1[a] = s + damp[a] * kbuf[a]
                lu_solve(S, piv, x1)
                for a in range(n):
                    U[i, a] = x1[a]
                    U[i, n + a] = c * x1[a] - kbuf[a]
            if not ok:
                return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
            for j in range(d):
                s = y[j]
                for l in range(n_st):
                    s += RM[l] * U[l, j]
                y_new[j] = s
            if fixed_step > 0:
                accept = True
            else:
                # error estimate filtered by (I - h gam J)^-1 = c W^-1 (Shampine; Hairer & Wanner
                # IV.8): the embedded solution is not L-stable, and without the filter the stiff
                # transient after every jump of the held input is resolved needlessly
                for j in range(d):
                    s = 0.0
                    for l in range(n_st):
                        s += RE[l] * U[l, j]
                    kbuf[j] = s
                for a in range(n):
                    s = 0.0
                    for b in range(n):
                        s += M0[a, b] * (kbuf[n + b] + c * kbuf[b])
                    x1[a] = s + damp[a] * kbuf[a]
                lu_solve(S, piv, x1)
                err = 0.0
                for a in range(n):
                    e1 = c * x1[a]
                    e2 = c * (c * x1[a] - kbuf[a])
                    sc = atol + rtol * max(ymax[a], abs(y_new[a]))
                    err += (e1 / sc) ** 2
                    sc = atol + rtol * max(ymax[n + a], abs(y_new[n + a]))
                    err += (e2 / sc) ** 2
                err = math.sqrt(err / d)
                if not math.isfinite(err):
                    accept = False
                    h = 0.2 * hk
                else:
                    accept = err <= 1.0
                    fac = 10.0 if err == 0 else min(10.0, max(0.2, 0.9 * err ** expo))
                    if (not accept) or rejected_last:
                        fac = min(fac, 1.0)
                    rejected_last = not accept
                    h = hk * fac
                if (not accept) and h < min_step:
                    return out, MIN_STEP, k, tc, y, n_steps, n_rej, n_eval
            if not accept:
                n_rej += 1  # f0 and M0 still hold the step's start
            else:
                n_steps += 1
                status = _state_status(y_new, max_abs)
                if status != OK:
                    return out, status, k, tc + hk, y_new, n_steps, n_rej, n_eval
                y[:] = y_new
                for j in range(d):
                    ymax[j] = max(ymax[j], abs(y_new[j]))
                if first and fixed_step <= 0:
                    h_first = h
                first = False
                tc = t_end if last else tc + hk
                need_f0 = True
        out[k + 1] = y
    return out, OK, T - 1, t[T - 1], y, n_steps, n_rej, n_eval


# --------------------------------------------------------------------------
# Python front end
# --------------------------------------------------------------------------
class LumpedModel:
    """Planar PCS dynamics from lumped parameters, evaluated by compiled kernels.

    Parameters
    ----------
    segment_lengths : array_like, shape (m,)
    active_mask : array_like of bool, shape (3m,)
        Modelled strains; the others are held at 0.
    rhoA, rhoI : array_like, shape (m,)
        Line density and rotary inertia per length of each segment (``rhoI``
        already includes any tie to ``rhoA``).
    rhoAg : array_like, shape (m, 2)
        ``rho A_i g`` per segment (the gravity force per length).
    stiffness, damping : array_like, shape (n,)
        Of the active strains.
    n_quadrature : int
        Gauss–Legendre nodes per segment.
    """

    def __init__(self, segment_lengths: ArrayLike, active_mask: ArrayLike, rhoA: ArrayLike, rhoI: ArrayLike,
                 rhoAg: ArrayLike, stiffness: ArrayLike, damping: ArrayLike, n_quadrature: int = 12) -> None:
        L = np.asarray(segment_lengths, dtype=float).reshape(-1)
        m = L.size
        if m == 0 or not np.all(np.isfinite(L)) or np.any(L <= 0):
            raise ValueError(f"segment_lengths must be finite and > 0; got {L.tolist()}")
        mask = np.asarray(active_mask, dtype=bool).reshape(-1)
        if mask.shape != (3 * m,) or not mask.any():
            raise ValueError(f"active_mask must have shape ({3 * m},) with at least one True; got {mask.tolist()}")
        act = np.flatnonzero(mask).astype(np.int64)
        n = act.size

        def arr(name, val, shape):
            a = np.asarray(val, dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite with shape {shape}; got {np.asarray(val).tolist()}")
            return np.ascontiguousarray(a)

        self.rhoA = arr("rhoA", rhoA, (m,))
        self.rhoI = arr("rhoI", rhoI, (m,))
        g = arr("rhoAg", rhoAg, (m, 2))
        self.rhoAg = np.ascontiguousarray(g[:, 0] + 1j * g[:, 1])
        self.stiffness = arr("stiffness", stiffness, (n,))
        self.damping = arr("damping", damping, (n,))
        if isinstance(n_quadrature, bool) or not isinstance(n_quadrature, (int, np.integer)) or n_quadrature < 1:
            raise ValueError(f"n_quadrature must be a positive integer; got {n_quadrature!r}")
        quad = make_quadrature(L, int(n_quadrature))
        self.L = L
        self.ell = np.ascontiguousarray(quad.ell)
        self.wts = np.ascontiguousarray(quad.weights)
        self.act = act
        self.n = n
        rot = rotary_mass(L)
        self.M_rot = np.ascontiguousarray(np.einsum("i,ipr->pr", self.rhoI, rot)[np.ix_(act, act)])

    @classmethod
    def from_library(cls, library, coef: ArrayLike, n_quadrature: int | None = None) -> "LumpedModel":
        """Model of ``coef`` in a library with ``lumped_from_coef`` (physical parameterisations).

        ``n_quadrature`` overrides the library's rule (default: the library's,
        which reproduces its ``mass_matrix`` to round-off).  Measured: 8 nodes
        agree with 16 to ~5e-16 relative for ``|kappa L| <= 3`` (6 nodes: ~2e-11)
        and cost ~2/3 of the time per call.
        """
        if not hasattr(library, "lumped_from_coef"):
            raise ValueError(f"library must provide lumped_from_coef; got {type(library).__name__}")
        lp = library.lumped_from_coef(coef)
        kin = library.kinematics
        nq = lp["n_quadrature"] if n_quadrature is None else n_quadrature
        return cls(kin.segment_lengths, kin.active_mask, lp["rhoA"], lp["rhoI"], lp["rhoAg"], lp["stiffness"],
                   lp["damping"], nq)

    def _args(self):
        return (self.act, self.L, self.ell, self.wts, self.rhoA, self.rhoAg, self.M_rot, self.stiffness, self.damping)

    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``M(q)`` (B, n, n) and ``C qd + G + K q + D qd`` (B, n) of active strains (B, n)."""
        q = np.ascontiguousarray(np.atleast_2d(np.asarray(q, dtype=float)))
        qd = np.ascontiguousarray(np.atleast_2d(np.asarray(qd, dtype=float)))
        if q.ndim != 2 or q.shape[1] != self.n or q.shape != qd.shape:
            raise ValueError(f"q and qd must have the same shape (n_samples, {self.n}); got {q.shape} and {qd.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise ValueError("q or qd contains NaN or inf")
        return _mass_bias_batch(q, qd, *self._args())

    def rollout(self, y0: ArrayLike, t: ArrayLike, u: ArrayLike, *, step: float | None = None, rtol: float = 1e-6,
                atol: float = 1e-9, max_step: float | None = None, min_step: float = 1e-12,
                max_abs_state: float = 1e6, state_names=None, stats: dict | None = None,
                method: str = "dopri5") -> NDArray[np.float64]:
        """Roll out ``[q, qd]`` under inputs held per sample; same contract as ``integrate_zoh``.

        Parameters
        ----------
        y0 : array_like, shape (2n,)
        t : array_like, shape (T,)
            Strictly increasing.
        u : array_like, shape (T, n)
            Forces on the active strains, held on ``[t[k], t[k+1])``.
        step, rtol, atol, max_step, min_step, max_abs_state, state_names, stats
            As in :func:`pcs_sindy.integrators.integrate_zoh`.
        method : {"dopri5", "rosenbrock"}
            ``"dopri5"``: explicit Dormand–Prince 5(4), step for step the
            scheme of ``integrate_zoh``.  ``"rosenbrock"``: the Rosenbrock-W
            method ROS34PW2 (order 3, L-stable) with the structural Jacobian
            ``[[0, I], [-M^-1 K, -M^-1 D]]`` (``M`` at the step's start): its
            step is not limited by the stiff, strongly damped shear/axial modes;
            the same as ``integrate_zoh(method="rosenbrock", jac=...)`` with that
            Jacobian.

        Returns
        -------
        ndarray, shape (T, 2n)

        Raises
        ------
        DivergenceError
            Non-finite or too large state, singular ``M``, or step below ``min_step``.
        """
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}; got {method!r}")
        n = self.n
        y = np.array(y0, dtype=float).reshape(-1)
        if y.shape != (2 * n,) or not np.all(np.isfinite(y)):
            raise ValueError(f"y0 must be finite with shape ({2 * n},); got {np.asarray(y0).tolist()}")
        t = np.ascontiguousarray(np.asarray(t, dtype=float))
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
            raise ValueError(f"t must be a finite 1-D array of times; got shape {t.shape}")
        if t.size > 1 and np.any(np.diff(t) <= 0):
            raise ValueError("t must be strictly increasing")
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            u = u[:, None]
        if u.shape != (t.size, n) or not np.all(np.isfinite(u)):
            raise ValueError(f"u must be finite with shape ({t.size}, {n}); got {u.shape}")
        u = np.ascontiguousarray(u)
        if step is not None:
            if not np.isfinite(step) or step <= 0:
                raise ValueError(f"step must be finite and > 0; got {step!r}")
            dt = np.diff(t)
            n_sub = dt / step
            n_int = np.maximum(1, np.round(n_sub))
            bad = np.flatnonzero(np.abs(n_sub - n_int) > 1e-6 * n_sub)
            if bad.size:
                k = int(bad[0])
                raise ValueError(f"step = {step!r} does not divide the sample interval t[{k + 1}] - t[{k}] = {dt[k]!r}")
        for name, val in (("rtol", rtol), ("atol", atol), ("min_step", min_step), ("max_abs_state", max_abs_state)):
            if not np.isfinite(val) or val <= 0:
                raise ValueError(f"{name} must be finite and > 0; got {val!r}")
        if max_step is not None and (not np.isfinite(max_step) or max_step <= 0):
            raise ValueError(f"max_step must be finite and > 0; got {max_step!r}")
        common = (y, t, u, -1.0 if step is None else float(step), float(rtol), float(atol),
                  -1.0 if max_step is None else float(max_step), float(min_step), float(max_abs_state))
        if method == "rosenbrock":
            res = _ros_loop(*common, _RA, _RC, _RM, _RE, ROS34PW2.gamma, *self._args())
        else:
            res = _dopri_loop(*common, _A, _C, _E, *self._args())
        out, status, _k, t_fail, y_fail, n_steps, n_rej, n_eval = res
        if stats is not None:
            stats.update({"n_steps": int(n_steps), "n_rejected": int(n_rej), "n_evaluations": int(n_eval)})
        if status != OK:
            msg = STATUS_MESSAGES[int(status)].format(max_abs=max_abs_state, min_step=min_step)
            y_fail = np.array(y_fail)
            raise DivergenceError(
                f"rollout diverged at t = {t_fail:.6g} s ({msg}); state: {_describe(y_fail, state_names)}", t_fail, y_fail
            )
        return out


def rollout(model: LumpedModel, y0: ArrayLike, t: ArrayLike, u: ArrayLike, **kwargs) -> NDArray[np.float64]:
    """Shortcut for :meth:`LumpedModel.rollout`."""
    return model.rollout(y0, t, u, **kwargs)
