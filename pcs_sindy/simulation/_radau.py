"""Compiled (numba) Radau IIA integrator of the ground-truth simulator, over a time grid.

Radau IIA with 3 stages (order 5, L-stable: the shear and axial modes of
these robots are stiff), simplified Newton iterations on the
velocity-reduced 3n system, Hairer & Wanner's error estimate and step
control, and a Jacobian of the accelerations by forward differences that is
reused while Newton converges fast.  It steps across sample boundaries
without restarting and lands exactly on every sample, where a zero-order-hold
input may switch; each robot of a batch has its own steps.  Either with error
control or with fixed steps.  This is the simulator's one own integrator;
every other method goes through :func:`scipy.integrate.solve_ivp`
(:mod:`pcs_sindy.simulation.integrate`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..core.linalg import lu_factor, lu_solve  # dense LU for the Newton systems
from ._dispatch import accel_jacobian, rhs_ws, workspace  # the planar or spatial robot, by its geometry

# Radau IIA, 3 stages, order 5 (Hairer & Wanner, Solving ODEs II, §IV.8)
_S6 = np.sqrt(6.0)
RADAU_C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
RADAU_A = np.array(
    [
        [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
        [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
        [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0],
    ]
)
RADAU_E = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0  # embedded error estimate weights
RADAU_MU = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)  # real eigenvalue of A^{-1}
NEWTON_MAXITER = 7
# refresh the Jacobian after a step whose Newton contraction rate exceeded this.  Measured: 0.03 is ~25 %
# faster on five_segment but ~25 % slower on the two_segment validation run.
JAC_REFRESH_RATE = 1e-3

# integrator status codes returned by radau_run
OK, NONFINITE, COLLAPSE, BUDGET = 0, 1, 2, 3


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
def radau_run(
    k0,
    k1,
    t,
    u_rows,
    out,
    h_arr,
    hprev_arr,
    havez_arr,
    zprev_arr,
    ratelast_arr,
    jac_arr,
    jacst_arr,
    hlu_arr,
    big_arr,
    pivbig_arr,
    small_arr,
    pivsmall_arr,
    geo,
    rtol,
    atol,
    max_step,
    fixed,
    A,
    C,
    E,
    mu,
    refresh_rate,
    stats,
    max_steps,
):
    """Advance every robot from sample ``k0`` to ``k1`` with Radau IIA (order 5), in place.

    ``out`` (T, B, N) holds the sampled states (``out[k0]`` is the start);
    ``u_rows`` (T, B, p) the zero-order-hold inputs.  The per-robot
    integrator state (next step ``h``, last step, last collocation increments,
    last Newton rate, acceleration Jacobian ``[J_q, J_v]`` (n, 2n) and its
    status 0 = none / 1 = stale / 2 = current, factored Newton and error
    matrices and the step they belong to) is carried in the ``*_arr`` arrays
    so that a run split in chunks gives exactly the same numbers.  ``fixed``: steps of
    ``max_step`` without error control.  ``stats`` (4,) counts accepted steps,
    Newton iterations, Jacobian evaluations and rejected or repeated steps.
    ``max_steps`` > 0 bounds the steps attempted (accepted or not) in this call.
    Returns ``(status, time, robot)``; status 0 = ok, 1 = non-finite
    derivative, 2 = step size collapsed, 3 = ``max_steps`` exhausted.
    """
    attempts = 0
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
            u = u_rows[k, b]
            t_next = t[k + 1]
            while time < t_next:
                if max_steps > 0 and attempts >= max_steps:
                    return BUDGET, time, b
                attempts += 1
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
                rhs_ws(y, u, geo, ws, f0)
                if not _all_finite(f0):
                    return NONFINITE, time, b
                if jac_state == 0:
                    accel_jacobian(y, f0, u, geo, ws, jac)
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
                        rhs_ws(state, u, geo, ws, F[i])
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
                        accel_jacobian(y, f0, u, geo, ws, jac)
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
                    rhs_ws(state, u, geo, ws, err_in)
                    for c in range(N):
                        err_in[c] += work[c]
                    _error_solve(jac, mu / step, small, piv_small, err_in, err, tmp)
                    err_norm = _rms(err, scale) if _all_finite(err) else np.inf
                if not err_norm <= 1.0:
                    factor = 0.2 if not np.isfinite(err_norm) else max(0.2, safety * err_norm**-0.25)
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
                factor = 10.0 if err_norm == 0.0 else min(10.0, safety * err_norm**-0.25)
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
