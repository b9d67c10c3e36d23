"""Rollout of ODEs under inputs sampled at discrete times (zero-order hold).

The identified models are rolled out under a recorded actuation that is held
constant between samples (zero-order hold).  A step that straddled a sample
boundary would see a discontinuous right-hand side and lose its order, so the
integrator steps *within* each sample interval and restarts (without losing its
step-size estimate) at every boundary.

Two schemes, either adaptive (``step=None``) or with a fixed step that divides
every sample interval:

- ``method="dopri5"`` (default): explicit Dormand–Prince 5(4) (the 5th-order
  solution is propagated, the embedded 4th-order one only estimates the error),
  with first-same-as-last reuse of the last stage inside an interval.  Its step
  is bounded by stability on stiff problems (strongly damped shear/axial modes).
- ``method="rosenbrock"``: the linearly implicit Rosenbrock-W method ROS34PW2
  (Rang & Angermann 2005: 4 stages, order 3, embedded order 2, L-stable,
  stiffly accurate).  A *W*-method keeps its order with any approximation of
  the Jacobian in ``W = I/(h gamma) - J``; stability only needs ``J`` to carry
  the stiff part, so ``J`` may be lagged or structural (the compiled rollout uses
  ``[[0, I], [-M^-1 K, -M^-1 D]]``).  One LU of ``W`` per step, one right-hand
  side call per stage.

Identification side: imports nothing of the package beyond numpy/tqdm.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import lu_factor, lu_solve
from tqdm.auto import tqdm

__all__ = ["DivergenceError", "DOPRI5", "ROS34PW2", "METHODS", "integrate_zoh"]

#: integration schemes of :func:`integrate_zoh` (and the compiled rollout)
METHODS = ("dopri5", "rosenbrock")

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


class _RosenbrockTableau:
    """Rosenbrock(-W) method ``(I - h gamma J) k_i = h f(y + sum_j alpha_ij k_j) + h J sum_{j<i} gamma_ij k_j``.

    ``y_new = y + sum_i b_i k_i``; ``b_hat`` is the embedded solution.  Stored
    also in the transformed variables ``u_i = sum_j Gamma_ij k_j`` (Hairer &
    Wanner II, §IV.7), which need no Jacobian-vector products:

        (I / (h gamma) - J) u_i = f(y + sum_{j<i} at_ij u_j) + sum_{j<i} ct_ij u_j / h
        y_new = y + sum_i mt_i u_i,   error = sum_i et_i u_i

    with ``at = alpha Gamma^-1``, ``ct = -(Gamma^-1)`` off the diagonal,
    ``mt = b Gamma^-1``, ``et = (b - b_hat) Gamma^-1``.
    """

    def __init__(self, alpha, gamma_mat, b, b_hat, order: int) -> None:
        self.alpha = np.asarray(alpha, dtype=float)
        self.Gamma = np.asarray(gamma_mat, dtype=float)
        self.b = np.asarray(b, dtype=float)
        self.b_hat = np.asarray(b_hat, dtype=float)
        self.order = order
        self.stages = self.b.size
        self.gamma = float(self.Gamma[0, 0])
        if not np.allclose(np.diag(self.Gamma), self.gamma, rtol=0, atol=1e-15):
            raise ValueError("Gamma must have a constant diagonal")
        ginv = np.linalg.inv(self.Gamma)
        self.at = np.ascontiguousarray(np.tril(self.alpha @ ginv, -1))
        self.ct = np.ascontiguousarray(np.tril(-ginv, -1))
        self.mt = np.ascontiguousarray(self.b @ ginv)
        self.et = np.ascontiguousarray((self.b - self.b_hat) @ ginv)
        self.c = self.alpha.sum(axis=1)


# Rang & Angermann (2005), "New Rosenbrock W-methods of order 3 for partial
# differential algebraic equations of index 1", BIT 45: the method ROS34PW2.
ROS34PW2 = _RosenbrockTableau(
    alpha=[
        [0.0, 0.0, 0.0, 0.0],
        [8.7173304301691801e-01, 0.0, 0.0, 0.0],
        [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ],
    gamma_mat=[
        [4.3586652150845900e-01, 0.0, 0.0, 0.0],
        [-8.7173304301691801e-01, 4.3586652150845900e-01, 0.0, 0.0],
        [-9.0338057013044082e-01, 5.4180672388095326e-02, 4.3586652150845900e-01, 0.0],
        [2.4212380706095346e-01, -1.2232505839045147e00, 5.4526025533510214e-01, 4.3586652150845900e-01],
    ],
    b=[2.4212380706095346e-01, -1.2232505839045147e00, 1.5452602553351020e00, 4.3586652150845900e-01],
    b_hat=[3.7810903145819369e-01, -9.6042292212423178e-02, 5.0000000000000000e-01, 2.1793326075422950e-01],
    order=3,
)


def _fd_jacobian(fun: Callable, y: NDArray[np.float64], u: Any, f0: NDArray[np.float64]) -> NDArray[np.float64]:
    """Forward-difference Jacobian of ``fun(., u)`` at ``y`` (``f0 = fun(y, u)``)."""
    d = y.size
    jac = np.empty((d, d))
    for j in range(d):
        dy = np.sqrt(np.finfo(float).eps) * max(1.0, abs(y[j]))
        yp = y.copy()
        yp[j] += dy
        jac[:, j] = (fun(yp, u) - f0) / dy
    return jac


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
    method: str = "dopri5",
    jac: Callable[[NDArray[np.float64], Any], ArrayLike] | None = None,
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
        Filled with ``n_steps``, ``n_rejected`` and ``n_evaluations`` (calls of
        ``fun``, including those of a finite-difference Jacobian).
    method : {"dopri5", "rosenbrock"}
        Explicit Dormand–Prince 5(4), or the linearly implicit Rosenbrock-W
        method ROS34PW2 (order 3) for stiff problems (see the module docstring).
        The adaptive Rosenbrock step filters its error estimate through
        ``(I - h gamma J)^-1`` (the embedded solution is not L-stable), scales
        it by the largest ``|y_j|`` reached so far rather than the current one
        (strain rates cross zero), and restarts each sample interval with the
        step predicted after the previous interval's first step (the held
        input jumps at the boundary).
    jac : callable, optional
        ``jac(y, u) -> (d, d)``, the Jacobian (or any approximation that carries
        the stiff part) used by ``method="rosenbrock"``, evaluated once per step
        at its start.  Default: forward differences of ``fun`` (``d`` calls).
        Not allowed with ``"dopri5"``.

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
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")
    if jac is not None and method != "rosenbrock":
        raise ValueError(f"jac is only used by method='rosenbrock'; got method={method!r}")
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

    rosen = method == "rosenbrock"
    if rosen:
        rtab = ROS34PW2
        n_st = rtab.stages
        expo, beta = -1.0 / rtab.order, 0.0  # the embedded pair's error is O(h^3)
    else:
        tab = DOPRI5
        A, C, E = tab.a, tab.c, tab.e
        n_st = tab.stages
        expo, beta = -1.0 / tab.order, _BETA
    d = y.size
    out = np.empty((t.size, d))
    out[0] = y
    K = np.empty((n_st, d))
    intervals = np.diff(t)
    h_max = max_step
    h = None if step is None else step
    err_prev = 1e-4
    rejected_last = False
    # rosenbrock: error scale = largest |y_j| reached so far (strain rates cross zero, and a
    # relative error measured there would force tiny steps), and the step predicted after
    # the first step of an interval restarts the next one (the held input jumps there)
    ymax = np.abs(y)
    h_first = None

    def fail(msg: str, tk: float, yk: NDArray[np.float64]) -> DivergenceError:
        return DivergenceError(f"rollout diverged at t = {tk:.6g} s ({msg}); state: {_describe(yk, state_names)}", tk, yk)

    counts = {"n_steps": 0, "n_rejected": 0, "n_evaluations": 0}

    def rhs(tk: float, yk: NDArray[np.float64], uk: NDArray[np.float64] | None) -> NDArray[np.float64]:
        counts["n_evaluations"] += 1
        try:
            return fun(yk, uk if u_fun is None else np.asarray(u_fun(tk), dtype=float))
        except np.linalg.LinAlgError as err:
            raise fail(f"right-hand side failed: {err}", tk, yk) from None

    def jacobian(tk: float, yk: NDArray[np.float64], uk: Any, f0: NDArray[np.float64]) -> NDArray[np.float64]:
        u_now = uk if u_fun is None else np.asarray(u_fun(tk), dtype=float)
        if jac is None:
            return _fd_jacobian(lambda yy, uu: rhs(tk, yy, uk), yk, u_now, f0)
        try:
            jm = np.asarray(jac(yk, u_now), dtype=float)
        except np.linalg.LinAlgError as err:
            raise fail(f"Jacobian failed: {err}", tk, yk) from None
        if jm.shape != (d, d):
            raise ValueError(f"jac must return shape ({d}, {d}); got {jm.shape}")
        return jm

    def rosenbrock_step(tc: float, hk: float, uk: Any, f0: NDArray[np.float64], jm: NDArray[np.float64]):
        at, ct = rtab.at, rtab.ct
        W = np.eye(d) / (hk * rtab.gamma) - jm
        if not np.all(np.isfinite(W)):
            raise fail("non-finite Jacobian", tc, y)
        lu = lu_factor(W, check_finite=False)
        for i in range(n_st):
            # stage time t + c_i h: a W-method keeps its order on the autonomised system
            # whatever J misses, here the time derivative of a callable input
            fi = f0 if i == 0 else rhs(tc + hk * rtab.c[i], y + at[i, :i] @ K[:i], uk)
            K[i] = lu_solve(lu, fi + (ct[i, :i] @ K[:i]) / hk, check_finite=False)
        # error estimate filtered by (I - h gamma J)^-1 = W^-1 / (h gamma) (Shampine; Hairer &
        # Wanner IV.8): the embedded solution is not L-stable, and unfiltered its estimate makes
        # the step resolve the stiff transient after every jump of a held input
        return y + rtab.mt @ K, lu_solve(lu, rtab.et @ K, check_finite=False) / (hk * rtab.gamma)

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
            f0 = None
            if k == 0 or u_arr is not None or rosen:
                # a held input jumps at the boundary, so the last stage is stale
                f0 = rhs(tc, y, uk)
                K[0] = f0
            jm = jacobian(tc, y, uk, f0) if rosen else None
            first = True
            if rosen and h_first is not None and k > 0:
                h = min(h, h_first)
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
                if rosen:
                    y_new, err_vec = rosenbrock_step(tc, hk, uk, f0, jm)
                else:
                    for i in range(1, n_st):
                        yi = y + hk * (A[i, :i] @ K[:i])
                        K[i] = rhs(tc + C[i] * hk, yi, uk)
                    y_new = yi  # the last stage of DOPRI5 is evaluated at the 5th-order solution
                    err_vec = hk * (E @ K)
                if step is not None:
                    accept = True
                else:
                    sc = atol + rtol * np.maximum(ymax if rosen else np.abs(y), np.abs(y_new))
                    err = math.sqrt(np.mean((err_vec / sc) ** 2))
                    if not math.isfinite(err):
                        accept = False
                        h = 0.2 * hk
                    else:
                        accept = err <= 1.0
                        # PI step control (Hairer's DOPRI5, beta = 0.04): steadier steps where
                        # stability, not accuracy, limits the step, hence fewer rejections
                        fac = 10.0 if err == 0 else min(
                            10.0, max(0.2, 0.9 * err ** (expo + 0.75 * beta) * err_prev**beta))
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
                    if rosen:
                        np.maximum(ymax, np.abs(y), out=ymax)
                        if first and step is None:
                            h_first = h
                        first = False
                        if tc < t_end:
                            f0 = rhs(tc, y, uk)
                            jm = jacobian(tc, y, uk, f0)
                            K[0] = f0
                    else:
                        K[0] = K[n_st - 1]
                # on rejection K[0] (dopri5) or f0 and the Jacobian (rosenbrock) still hold f(tc, y)
            out[k + 1] = y
            bar.update(1)
    finally:
        bar.close()
        if stats is not None:
            stats.update(counts)
    return out
