"""Integration schemes of the identification side: tableaus and solve_ivp over held inputs.

The compiled rollout loops (:mod:`pcs_sindy.models._jit_rollout`) take their
coefficients from here, the one place they are written down:

- :data:`DOPRI5`: Dormand & Prince (1980), explicit 5(4) pair, the 5th-order
  solution propagated, the embedded 4th-order one only estimating the error;
- :data:`ROS34PW2`: Rang & Angermann (2005), a linearly implicit Rosenbrock-W
  method with 4 stages, order 3, embedded order 2, L-stable and stiffly
  accurate.  A *W*-method keeps its order with any approximation of the
  Jacobian in ``W = I/(h gamma) - J``; stability only needs ``J`` to carry the
  stiff part, so the rollout uses the structural ``[[0, I], [-M^-1 K, -M^-1 D]]``.

Every other scheme, and any model or input the compiled loops do not take (a
callable actuation, a model without compiled kernels), goes through
:func:`solve_held`: :func:`scipy.integrate.solve_ivp` restarted at every sample
of an input held constant on ``[t_k, t_{k+1})`` (a step straddling a jump of
the input would lose its order), or run once over a callable input.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from tqdm.auto import tqdm

from ..core.simulate_contract import SCIPY_METHODS, DivergenceError, SimulationError

__all__ = ["DOPRI5", "ROS34PW2", "COMPILED_METHODS", "solve_held", "describe_state", "DivergenceError"]

#: schemes of the compiled rollout loops
COMPILED_METHODS = ("rosenbrock", "dopri5")


class _Tableau:
    """Butcher tableau of an explicit embedded pair (``b`` propagates, ``e = b - b_hat``)."""

    def __init__(
        self, c: Sequence[float], a: Sequence[Sequence[float]], b: Sequence[float], b_hat: Sequence[float], order: int
    ) -> None:
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


def describe_state(y: NDArray[np.float64], names: Sequence[str] | None) -> str:
    """``name=value`` pairs of a state for error messages."""
    if names is None or len(names) != y.size:
        return np.array2string(y, precision=4)
    return ", ".join(f"{n}={v:.4g}" for n, v in zip(names, y))


def solve_held(
    fun: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]],
    y0: ArrayLike,
    t: ArrayLike,
    u: ArrayLike | Callable[[float], ArrayLike],
    *,
    method: str = "radau",
    rtol: float = 3e-5,
    atol: float = 3e-8,
    max_step: float | None = None,
    max_abs_state: float = 1e6,
    state_names: Sequence[str] | None = None,
    progress: bool = False,
) -> NDArray[np.float64]:
    """Integrate ``dy/dt = fun(y, u)`` with :func:`scipy.integrate.solve_ivp` and sample it at ``t``.

    Parameters
    ----------
    fun : callable
        ``fun(y, u) -> dy/dt`` (y of shape (d,)); may raise ``np.linalg.LinAlgError``.
    y0 : array_like, shape (d,)
    t : array_like, shape (T,)
        Strictly increasing output times.
    u : array_like of shape (T, p), or callable
        Inputs held constant on ``[t[k], t[k+1])`` (one solve_ivp call per
        interval, so no step straddles a jump), or ``u(time)`` (one call).
    method : str
        A name of :data:`pcs_sindy.core.simulate_contract.SCIPY_METHODS` (``"radau"``,
        ``"dopri5"``, ``"dop853"``, ``"bdf"``, ``"lsoda"``, ``"rk23"``).
    rtol, atol, max_step : float
        Passed to solve_ivp (``max_step`` default: unbounded).
    max_abs_state : float
        A state component larger than this in magnitude means divergence.
    state_names : sequence of str, optional
        Used in error messages.
    progress : bool
        tqdm bar over the sample intervals.

    Returns
    -------
    ndarray, shape (T, d)

    Raises
    ------
    ValueError
        When ``y0``, ``t`` or a tabulated ``u`` is non-finite or ill-shaped
        (``u`` needs one row per time).
    SimulationError
        When solve_ivp fails, the state becomes non-finite or exceeds
        ``max_abs_state``, or ``fun`` raises ``LinAlgError``.
    """
    if method not in SCIPY_METHODS:
        raise ValueError(f"method must be one of {list(SCIPY_METHODS)} for solve_ivp; got {method!r}")
    scipy_method = SCIPY_METHODS[method]
    y = np.array(y0, dtype=float).reshape(-1)
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(y)):
        raise ValueError(f"y0 must be finite; got {y.tolist()}")
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError(
            f"t must be a 1-D array of at least 2 finite, strictly increasing times; got shape {t.shape}"
            + ("" if t.ndim != 1 or t.size < 2 else f" with values from {t.min()!r} to {t.max()!r}")
        )
    if not callable(u):
        u_check = np.asarray(u, dtype=float)
        if u_check.ndim != 2 or u_check.shape[0] != t.size:
            raise ValueError(
                f"u must have shape ({t.size}, p) (one row of inputs per time in t, held until the next); "
                f"got shape {u_check.shape}"
            )
        if not np.all(np.isfinite(u_check)):
            raise ValueError(f"u contains NaN or inf (first at sample {int(np.argwhere(~np.isfinite(u_check))[0][0])})")
    opts: dict[str, Any] = {"rtol": rtol, "atol": atol}
    if max_step is not None:
        opts["max_step"] = max_step

    def fail(msg: str, tk: float, yk: NDArray[np.float64]) -> SimulationError:
        return SimulationError(
            f"rollout diverged at t = {tk:.6g} s ({msg}); state: {describe_state(yk, state_names)}", tk, yk
        )

    def checked(sol: Any, t0: float, y_start: NDArray[np.float64]) -> NDArray[np.float64]:
        ts, ys = np.asarray(sol.t, dtype=float), np.asarray(sol.y, dtype=float).reshape(y_start.size, -1).T
        if not sol.success:
            # with t_eval the failed solution may hold no sample at all: report where the interval started
            tk, yk = (float(ts[-1]), ys[-1]) if ts.size else (t0, y_start)
            raise fail(f"solve_ivp {scipy_method}: {sol.message}", tk, yk)
        bad = ~np.all(np.isfinite(ys), axis=1) | (np.max(np.abs(ys), axis=1) > max_abs_state)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise fail(f"non-finite state or |state| > max_abs_state = {max_abs_state:g}", float(ts[k]), ys[k])
        return ys

    out = np.empty((t.size, y.size))
    out[0] = y
    try:
        if callable(u):
            sol = solve_ivp(
                lambda tk, yk: fun(yk, np.asarray(u(tk), dtype=float)),
                (t[0], t[-1]),
                y,
                method=scipy_method,
                t_eval=t,
                **opts,
            )
            ys = checked(sol, t[0], y)
            if ys.shape[0] != t.size:
                raise fail("solve_ivp stopped early", float(sol.t[-1]), ys[-1])
            return ys
        u_arr = np.asarray(u, dtype=float)
        for k in tqdm(range(t.size - 1), disable=not progress, desc="rollout", unit="sample", leave=False):
            sol = solve_ivp(
                lambda tk, yk, uk=u_arr[k]: fun(yk, uk),
                (t[k], t[k + 1]),
                y,
                method=scipy_method,
                **opts,
            )  # no t_eval: the steps' own times locate a failure inside the interval
            y = checked(sol, t[k], y)[-1]
            out[k + 1] = y
    except np.linalg.LinAlgError as err:
        raise fail(f"right-hand side failed: {err}", float("nan"), y) from None
    return out
