"""Explicit 5th-order Runge–Kutta rollout for inputs sampled at discrete times.

The identified models are rolled out under a recorded actuation that is held
constant between samples (zero-order hold).  A step that straddled a sample
boundary would see a discontinuous right-hand side and lose its order, so the
integrator steps *within* each sample interval and restarts (without losing its
step-size estimate) at every boundary.

The scheme is Dormand–Prince 5(4) (the 5th-order solution is propagated, the
embedded 4th-order one only estimates the error), with first-same-as-last reuse
of the last stage inside an interval.  Either adaptive (``step=None``) or with a
fixed step that divides every sample interval.

Identification side: imports nothing of the package beyond numpy/tqdm.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

__all__ = ["DivergenceError", "DOPRI5", "integrate_zoh"]

_BETA = 0.04  # PI controller weight of the previous error


class DivergenceError(RuntimeError):
    """The state of a rollout became non-finite, unbounded or unsolvable.

    Attributes
    ----------
    t : float
        Time (s) of the last state reached.
    y : ndarray
        That state.
    """

    def __init__(self, message: str, t: float, y: NDArray[np.float64]) -> None:
        super().__init__(message)
        self.t = float(t)
        self.y = np.array(y, dtype=float)


class _Tableau:
    """Butcher tableau of an explicit embedded pair (``b`` propagates, ``e = b - b_hat``)."""

    def __init__(self, c: Sequence[float], a: Sequence[Sequence[float]], b: Sequence[float], b_hat: Sequence[float], order: int) -> None:
        s = len(c)
        self.c = np.asarray(c, dtype=float)
        self.a = np.zeros((s, s))
        for i, row in enumerate(a):
            self.a[i, : len(row)] = row
        self.b = np.asarray(b, dtype=float)
        self.e = self.b - np.asarray(b_hat, dtype=float)
        self.order = order
        self.stages = s


# Dormand & Prince (1980), "A family of embedded Runge-Kutta formulae".
DOPRI5 = _Tableau(
    c=[0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0],
    a=[
        [],
        [1 / 5],
        [3 / 40, 9 / 40],
        [44 / 45, -56 / 15, 32 / 9],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
        [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
    ],
    b=[35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0],
    b_hat=[5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40],
    order=5,
)


def _describe(y: NDArray[np.float64], names: Sequence[str] | None) -> str:
    if names is None or len(names) != y.size:
        return np.array2string(y, precision=4)
    return ", ".join(f"{n}={v:.4g}" for n, v in zip(names, y))


def integrate_zoh(
    fun: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]],
    y0: ArrayLike,
    t: ArrayLike,
    u: ArrayLike | Callable[[float], ArrayLike],
    *,
    step: float | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_step: float | None = None,
    min_step: float = 1e-12,
    max_abs_state: float = 1e6,
    state_names: Sequence[str] | None = None,
    progress: bool = False,
    stats: dict | None = None,
) -> NDArray[np.float64]:
    """Integrate ``dy/dt = fun(y, u)`` and return the state at the times ``t``.

    Parameters
    ----------
    fun : callable
        ``fun(y, u) -> dy/dt`` with ``y`` of shape (d,) and the input ``u``.
        Autonomous apart from ``u``.
    y0 : array_like, shape (d,)
        State at ``t[0]``.
    t : array_like, shape (T,)
        Strictly increasing output times.
    u : array_like of shape (T, p), or callable
        Input samples, held constant on ``[t[k], t[k+1])`` (zero-order hold),
        or ``u(time)`` evaluated at every stage.
    step : float, optional
        Fixed step.  ``None`` (default) selects the adaptive step.  A fixed step
        must divide every sample interval (to 1e-6 relative).
    rtol, atol : float
        Error tolerances of the adaptive step (scaled RMS norm).
    max_step : float, optional
        Upper bound on the adaptive step (default: the sample interval).
    min_step : float
        Smallest adaptive step before the rollout is declared diverged.
    max_abs_state : float
        A state component larger than this in magnitude means divergence.
    state_names : sequence of str, optional
        Names of the state components, used in error messages.
    progress : bool
        Show a tqdm progress bar over the sample intervals.
    stats : dict, optional
        Filled with ``n_steps``, ``n_rejected`` and ``n_evaluations``.

    Returns
    -------
    ndarray, shape (T, d)

    Raises
    ------
    DivergenceError
        When the state becomes non-finite or exceeds ``max_abs_state``, the
        right-hand side fails (e.g. a singular mass matrix), or the adaptive
        step falls below ``min_step``; the message names the time and state.
    """
    y = np.array(y0, dtype=float).reshape(-1)
    if not np.all(np.isfinite(y)):
        raise ValueError(f"y0 contains NaN or inf: {y}")
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
        raise ValueError(f"t must be a finite 1-D array of times; got shape {t.shape}")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        raise ValueError("t must be strictly increasing")
    if callable(u):
        u_fun = u
        u_arr = None
    else:
        u_fun = None
        u_arr = np.asarray(u, dtype=float)
        if u_arr.ndim == 1:
            u_arr = u_arr[:, None]
        if u_arr.ndim != 2 or u_arr.shape[0] != t.size:
            raise ValueError(f"u must have shape ({t.size}, p) (one sample per time); got {np.shape(u)}")
        if not np.all(np.isfinite(u_arr)):
            raise ValueError("u contains NaN or inf")
    if step is not None and (not np.isfinite(step) or step <= 0):
        raise ValueError(f"step must be finite and > 0; got {step!r}")
    for name, val in (("rtol", rtol), ("atol", atol), ("min_step", min_step), ("max_abs_state", max_abs_state)):
        if not np.isfinite(val) or val <= 0:
            raise ValueError(f"{name} must be finite and > 0; got {val!r}")

    tab = DOPRI5
    A, C, B, E = tab.a, tab.c, tab.b, tab.e
    n_st = tab.stages
    d = y.size
    out = np.empty((t.size, d))
    out[0] = y
    K = np.empty((n_st, d))
    intervals = np.diff(t)
    h_max = max_step
    h = None if step is None else step
    expo = -1.0 / tab.order
    err_prev = 1e-4
    rejected_last = False

    def fail(msg: str, tk: float, yk: NDArray[np.float64]) -> DivergenceError:
        return DivergenceError(f"rollout diverged at t = {tk:.6g} s ({msg}); state: {_describe(yk, state_names)}", tk, yk)

    counts = {"n_steps": 0, "n_rejected": 0, "n_evaluations": 0}

    def rhs(tk: float, yk: NDArray[np.float64], uk: NDArray[np.float64] | None) -> NDArray[np.float64]:
        counts["n_evaluations"] += 1
        try:
            return fun(yk, uk if u_fun is None else np.asarray(u_fun(tk), dtype=float))
        except np.linalg.LinAlgError as err:
            raise fail(f"right-hand side failed: {err}", tk, yk) from None

    bar = tqdm(total=t.size - 1, disable=not progress, desc="rollout", unit="sample", leave=False)
    try:
        for k in range(t.size - 1):
            t0, dt_k = t[k], intervals[k]
            uk = None if u_arr is None else u_arr[k]
            t_end = t0 + dt_k
            tc = t0
            if step is not None:
                n_sub = dt_k / step
                n_int = max(1, int(round(n_sub)))
                if abs(n_sub - n_int) > 1e-6 * n_sub:
                    raise ValueError(f"step = {step!r} does not divide the sample interval t[{k + 1}] - t[{k}] = {dt_k!r}")
                h_fixed = dt_k / n_int
            if k == 0 or u_arr is not None:
                # a held input jumps at the boundary, so the last stage is stale
                K[0] = rhs(tc, y, uk)
            while tc < t_end:
                remaining = t_end - tc
                if step is not None:
                    hk = h_fixed
                    last = remaining <= 1.5 * h_fixed
                else:
                    if h is None:
                        # Hairer's initial step heuristic, coarse version.
                        sc = atol + rtol * np.abs(y)
                        d0 = math.sqrt(np.mean((y / sc) ** 2))
                        d1 = math.sqrt(np.mean((K[0] / sc) ** 2))
                        h = 0.01 * d0 / d1 if d0 > 1e-5 and d1 > 1e-5 else 1e-6
                        h = min(h, dt_k)
                    hk = min(h, remaining, h_max if h_max is not None else dt_k)
                    # avoid a sliver step at the end of the interval
                    last = hk >= remaining * (1 - 1e-12)
                    if not last and remaining - hk < 0.1 * hk:
                        hk = 0.5 * remaining
                for i in range(1, n_st):
                    yi = y + hk * (A[i, :i] @ K[:i])
                    K[i] = rhs(tc + C[i] * hk, yi, uk)
                y_new = yi  # the last stage of DOPRI5 is evaluated at the 5th-order solution
                if step is not None:
                    accept = True
                else:
                    sc = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
                    err = math.sqrt(np.mean((hk * (E @ K) / sc) ** 2))
                    if not math.isfinite(err):
                        accept = False
                        h = 0.2 * hk
                    else:
                        accept = err <= 1.0
                        # PI step control (Hairer's DOPRI5, beta = 0.04): steadier steps where
                        # stability, not accuracy, limits the step, hence fewer rejections
                        fac = 10.0 if err == 0 else min(10.0, max(0.2, 0.9 * err ** (expo + 0.75 * _BETA) * err_prev**_BETA))
                        if not accept or rejected_last:
                            # no growth right after a rejection (Hairer)
                            fac = min(fac, 1.0)
                        if accept:
                            err_prev = max(err, 1e-4)
                        rejected_last = not accept
                        h = hk * fac
                    if not accept and h < min_step:
                        raise fail(f"step size fell below min_step = {min_step:g} s", tc, y)
                if not accept:
                    counts["n_rejected"] += 1
                if accept:
                    counts["n_steps"] += 1
                    if not np.all(np.isfinite(y_new)):
                        raise fail("non-finite state", tc + hk, y_new)
                    if np.max(np.abs(y_new)) > max_abs_state:
                        raise fail(f"|state| exceeded max_abs_state = {max_abs_state:g}", tc + hk, y_new)
                    y = y_new
                    tc = t_end if last else tc + hk
                    K[0] = K[n_st - 1]
                # on rejection K[0] still holds f(tc, y)
            out[k + 1] = y
            bar.update(1)
    finally:
        bar.close()
        if stats is not None:
            stats.update(counts)
    return out
