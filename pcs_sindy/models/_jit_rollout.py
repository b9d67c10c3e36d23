"""Compiled (numba) rollout loops of identified models: Dormand–Prince 5(4) and Rosenbrock-W.

The one implementation of the two integrators on the identification side.  Both
step *within* each sample interval of an input held constant on
``[t_k, t_{k+1})`` (a step straddling a jump would lose its order), keep their
step-size estimate across the jump, and land on every sample time.

* :func:`dopri_loop`: explicit Dormand–Prince 5(4) (tableau
  :data:`pcs_sindy.models.integrators.DOPRI5`), PI step control; its step is bounded by
  stability on the stiff, strongly damped shear/axial modes.
* :func:`ros_loop`: the L-stable Rosenbrock-W method ROS34PW2
  (:data:`pcs_sindy.models.integrators.ROS34PW2`), linearly implicit in the structural
  Jacobian ``[[0, I], [-M0^-1 K, -M0^-1 D]]`` (``M0`` the mass matrix at the
  step's start): its step is set by accuracy alone.

The model enters through :func:`rhs` with its parameter tuple ``P`` and work arrays
``W``: numba resolves it at compile time, by the length of ``P``, to the planar
model's :func:`pcs_sindy.models._jit_dynamics.rhs` or the spatial model's
:func:`pcs_sindy.models._jit_spatial.rhs` (inlined: the loops stay cacheable and as fast
as with one model).  Every model's ``P`` holds the stiffness and damping of its
modelled strains at positions 7 and 8 and its rhs leaves ``M`` in ``W[0]`` (the
structural Jacobian of :func:`ros_loop`).  Both loops return
``(out, status, k_fail, t_fail, y_fail, n_steps, n_rejected, n_eval)``; rows of
``out`` after a failure are NaN; :func:`rollout` runs one and raises
:class:`~pcs_sindy.core.simulate_contract.SimulationError` on a failure.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.core.errors import TypingError
from numba.extending import overload

from ..core.linalg import lu_factor, lu_solve
from ..core.simulate_contract import SimulationError
from . import _jit_dynamics, _jit_spatial
from .integrators import DOPRI5, ROS34PW2, describe_state

__all__ = ["dopri_loop", "ros_loop", "rollout", "rhs", "OK", "STATUS_MESSAGES"]

#: status codes of the compiled loops
OK, NONFINITE, TOO_LARGE, SINGULAR, MIN_STEP = 0, 1, 2, 3, 4
STATUS_MESSAGES = {
    NONFINITE: "non-finite state",
    TOO_LARGE: "|state| exceeded max_abs_state = {max_abs:g}",
    SINGULAR: "right-hand side failed: singular mass matrix",
    MIN_STEP: "step size fell below min_step = {min_step:g} s",
}
#: PI controller weight of the previous error (Hairer's DOPRI5)
BETA = 0.04
#: length of the planar models' parameter tuple (:mod:`pcs_sindy.models._jit_dynamics`)
PLANAR_P_SIZE = 14
if _jit_spatial.P_SIZE == PLANAR_P_SIZE:  # pragma: no cover - a layout change must keep them apart
    raise ImportError("the planar and spatial parameter tuples must differ in length")


def rhs(y, u, P, W, out):
    """State derivative of the model of ``P`` (compiled code only; module docstring)."""
    raise NotImplementedError("compiled dispatch only")


# The planar rhs is inlined as Python source (``py_func``): calling its dispatcher through the overload measured
# ~8 % slower planar rollouts than the former direct call (one more call layer, whose tuple arguments are
# reference counted array by array; ~0.25 us of a 3 us evaluation); inlined, the two are equal.  The spatial
# rhs (itself inlining the shared kernels) is called: inlined twice into each loop it would only add compile time.
@overload(rhs, inline="always")
def _rhs(y, u, P, W, out):
    size = len(getattr(P, "types", ()))
    if size == PLANAR_P_SIZE:
        return _jit_dynamics.rhs.py_func
    if size == _jit_spatial.P_SIZE:
        impl = _jit_spatial.rhs
        return lambda y, u, P, W, out: impl(y, u, P, W, out)
    sizes = f"{PLANAR_P_SIZE} or {_jit_spatial.P_SIZE}"
    raise TypingError(f"P must be a model parameter tuple ({sizes} entries); got {P}")


@numba.njit(cache=True)
def _next_step(fixed_step, h_fixed, h, y, f, rtol, atol, remaining, max_step, dt_k):
    """The next step towards the sample ``remaining`` ahead: ``(hk, last, h)``.

    Fixed steps: ``h_fixed``, the last one of the interval absorbing round-off.
    Adaptive: the proposal ``h`` (a starting guess from ``y`` and its rate ``f``
    when ``h < 0``, returned as the new proposal), bounded by the sample and
    ``max_step``; a step that would leave a sliver before the sample is halved.
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
def _controller(err, hk, expo, beta, err_prev, rejected_last):
    """Accept or reject a step of scaled error ``err``: ``(accept, h_next, err_prev, rejected_last)``.

    PI control (``beta = 0`` gives plain I control); no growth right after a
    rejection; a non-finite error shrinks the step five-fold.
    """
    if not math.isfinite(err):
        return False, 0.2 * hk, err_prev, True
    accept = err <= 1.0
    if err == 0:
        fac = 10.0
    else:
        fac = min(10.0, max(0.2, 0.9 * err ** (expo + 0.75 * beta) * err_prev**beta))
    if (not accept) or rejected_last:
        fac = min(fac, 1.0)
    if accept:
        err_prev = max(err, 1e-4)
    return accept, hk * fac, err_prev, not accept


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
def _fixed_substep(fixed_step, dt_k):
    if fixed_step <= 0:
        return 0.0
    return dt_k / max(1, int(round(dt_k / fixed_step)))


@numba.njit(cache=True)
def dopri_loop(y0, t, u, fixed_step, rtol, atol, max_step, min_step, max_abs, A, C, E, P, W):
    """DOPRI5 over all sample intervals; ``fixed_step <= 0`` means adaptive."""
    T = t.size
    d = y0.size
    n_st = C.size
    out = np.full((T, d), np.nan)
    out[0] = y0
    y = y0.copy()
    Ks = np.zeros((n_st, d))
    yi = np.empty(d)
    y_new = np.empty(d)
    kbuf = np.empty(d)
    h = -1.0  # not yet chosen
    expo = -1.0 / 5.0
    err_prev = 1e-4
    rejected_last = False
    n_steps = 0
    n_rej = 0
    n_eval = 0
    for k in range(T - 1):
        tc = t[k]
        dt_k = t[k + 1] - t[k]
        t_end = tc + dt_k
        uk = u[k]
        h_fixed = _fixed_substep(fixed_step, dt_k)
        # a held input jumps at the boundary, so the last stage of the previous interval is stale
        n_eval += 1
        if not rhs(y, uk, P, W, kbuf):
            return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
        Ks[0] = kbuf
        while tc < t_end:
            hk, last, h = _next_step(fixed_step, h_fixed, h, y, Ks[0], rtol, atol, t_end - tc, max_step, dt_k)
            for i in range(1, n_st):
                for j in range(d):
                    s = 0.0
                    for l in range(i):
                        s += A[i, l] * Ks[l, j]
                    yi[j] = y[j] + hk * s
                n_eval += 1
                if not rhs(yi, uk, P, W, kbuf):
                    return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
                Ks[i] = kbuf
            y_new[:] = yi  # the last stage is evaluated at the 5th-order solution
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
                accept, h, err_prev, rejected_last = _controller(
                    math.sqrt(err / d), hk, expo, BETA, err_prev, rejected_last
                )
                if (not accept) and h < min_step:
                    return out, MIN_STEP, k, tc, y, n_steps, n_rej, n_eval
            if not accept:
                n_rej += 1
                continue
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
def _structured_solve(M0, stiff, damp, c, S, piv, r, x1):
    """Solve ``(c I - J) [x1, x2] = [r1, r2]`` for the structural Jacobian; return ``x1`` (``x2 = c x1 - r1``).

    With ``J = [[0, I], [-M0^-1 K, -M0^-1 D]]`` this is exactly
    ``(c^2 M0 + c D + K) x1 = M0 (r2 + c r1) + D r1``: one n x n LU per step
    (``S``, ``piv``), no inverse of ``M0``.
    """
    n = x1.size
    for a in range(n):
        s = 0.0
        for b in range(n):
            s += M0[a, b] * (r[n + b] + c * r[b])
        x1[a] = s + damp[a] * r[a]
    lu_solve(S, piv, x1)


@numba.njit(cache=True)
def ros_loop(y0, t, u, fixed_step, rtol, atol, max_step, min_step, max_abs, RA, RC, RM, RE, gam, P, W):
    """Rosenbrock-W (transformed coefficients ``RA, RC, RM, RE``, diagonal ``gam``) over all sample intervals.

    The error estimate is filtered through ``(I - h gam J)^-1`` (Shampine; Hairer &
    Wanner IV.8: the embedded solution is not L-stable, and unfiltered its estimate
    makes the step resolve the stiff transient after every jump of the held input),
    scaled by the largest ``|y_j|`` reached so far (strain rates cross zero), and
    each interval restarts with the step predicted after the previous interval's
    first step.
    """
    stiff, damp = P[7], P[8]
    T = t.size
    d = y0.size
    n = d // 2
    n_st = RM.size
    out = np.full((T, d), np.nan)
    out[0] = y0
    y = y0.copy()
    U = np.zeros((n_st, d))
    yi = np.empty(d)
    y_new = np.empty(d)
    f0 = np.empty(d)
    M0 = np.empty((n, n))
    S = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    kbuf = np.empty(d)
    x1 = np.empty(n)
    h = -1.0
    expo = -1.0 / 3.0
    err_prev = 1e-4
    rejected_last = False
    ymax = np.abs(y0)
    h_first = -1.0
    n_steps = 0
    n_rej = 0
    n_eval = 0
    for k in range(T - 1):
        tc = t[k]
        dt_k = t[k + 1] - t[k]
        t_end = tc + dt_k
        uk = u[k]
        h_fixed = _fixed_substep(fixed_step, dt_k)
        need_f0 = True
        first = True
        if h_first > 0 and k > 0:
            h = min(h, h_first)
        while tc < t_end:
            if need_f0:
                n_eval += 1
                if not rhs(y, uk, P, W, f0):
                    return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
                M0[:, :] = W[0]
                need_f0 = False
            hk, last, h = _next_step(fixed_step, h_fixed, h, y, f0, rtol, atol, t_end - tc, max_step, dt_k)
            c = 1.0 / (hk * gam)
            for a in range(n):
                for b in range(n):
                    S[a, b] = c * c * M0[a, b]
                S[a, a] += c * damp[a] + stiff[a]
            if not lu_factor(S, piv):
                return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
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
                    if not rhs(yi, uk, P, W, kbuf):
                        return out, SINGULAR, k, tc, y, n_steps, n_rej, n_eval
                # r = f + sum_l RC[i, l] U_l / h, then the structured solve
                for j in range(d):
                    s = kbuf[j]
                    for l in range(i):
                        s += RC[i, l] * U[l, j] / hk
                    kbuf[j] = s
                _structured_solve(M0, stiff, damp, c, S, piv, kbuf, x1)
                for a in range(n):
                    U[i, a] = x1[a]
                    U[i, n + a] = c * x1[a] - kbuf[a]
            for j in range(d):
                s = y[j]
                for l in range(n_st):
                    s += RM[l] * U[l, j]
                y_new[j] = s
            if fixed_step > 0:
                accept = True
            else:
                for j in range(d):
                    s = 0.0
                    for l in range(n_st):
                        s += RE[l] * U[l, j]
                    kbuf[j] = s
                _structured_solve(M0, stiff, damp, c, S, piv, kbuf, x1)
                err = 0.0
                for a in range(n):
                    sc = atol + rtol * max(ymax[a], abs(y_new[a]))
                    err += (c * x1[a] / sc) ** 2
                    sc = atol + rtol * max(ymax[n + a], abs(y_new[n + a]))
                    err += (c * (c * x1[a] - kbuf[a]) / sc) ** 2
                accept, h, err_prev, rejected_last = _controller(
                    math.sqrt(err / d), hk, expo, 0.0, err_prev, rejected_last
                )
                if (not accept) and h < min_step:
                    return out, MIN_STEP, k, tc, y, n_steps, n_rej, n_eval
            if not accept:
                n_rej += 1  # f0 and M0 still hold the step's start
                continue
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


def rollout(
    P: tuple,
    W: tuple,
    y0: np.ndarray,
    t: np.ndarray,
    u: np.ndarray,
    method: str,
    *,
    step: float | None,
    rtol: float,
    atol: float,
    max_step: float | None,
    max_abs_state: float,
    state_names: list[str],
    stats: dict | None,
) -> np.ndarray:
    """States (T, 2n) of the compiled ``method`` ("rosenbrock" or "dopri5"); SimulationError on a failure."""
    common = (
        np.ascontiguousarray(y0, dtype=float),
        np.ascontiguousarray(t, dtype=float),
        np.ascontiguousarray(u, dtype=float),
        -1.0 if step is None else float(step),
        float(rtol),
        float(atol),
        -1.0 if max_step is None else float(max_step),
        1e-12,
        float(max_abs_state),
    )
    if method == "rosenbrock":
        res = ros_loop(*common, ROS34PW2.at, ROS34PW2.ct, ROS34PW2.mt, ROS34PW2.et, ROS34PW2.gamma, P, W)
    else:
        a, c, e = (np.ascontiguousarray(x) for x in (DOPRI5.a, DOPRI5.c, DOPRI5.e))
        res = dopri_loop(*common, a, c, e, P, W)
    out, status, _k, t_fail, y_fail, n_steps, n_rej, n_eval = res
    if stats is not None:
        stats.update({"n_steps": int(n_steps), "n_rejected": int(n_rej), "n_evaluations": int(n_eval)})
    if status != OK:
        msg = STATUS_MESSAGES[int(status)].format(max_abs=max_abs_state, min_step=1e-12)
        y_fail = np.array(y_fail)
        raise SimulationError(
            f"rollout diverged at t = {t_fail:.6g} s ({msg}); state: {describe_state(y_fail, state_names)}",
            t_fail,
            y_fail,
        )
    return out
