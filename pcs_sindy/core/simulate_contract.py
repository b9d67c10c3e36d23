"""The simulate contract shared by the ground-truth robot and identified models.

``PCSRobot.simulate``, ``EulerLagrangeRegressor.simulate``, ``PCSPipeline.simulate`` and
any forward model's ``simulate`` take the same arguments in the same order,

    simulate(q0, qd0, t, u, *, method=..., rtol=..., atol=..., step=..., max_step=..., progress=...)

with ``u`` the inputs held constant on ``[t[k], t[k+1])`` (generalised forces, or actuator
inputs of an actuated robot or model), return a :class:`~pcs_sindy.core.StrainTrajectory`,
raise :class:`SimulationError` when the integration fails, and name their integration
schemes from one vocabulary (:data:`METHODS`).  This module holds that vocabulary, the error
class and :func:`simulate_inputs`, which reads the arguments the same way for everyone
(including the former ``tau=`` spelling); it is part of the ground floor and imports nothing
else of the package.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["SimulationError", "DivergenceError", "METHODS", "SCIPY_METHODS", "canonical_method", "simulate_inputs"]


class SimulationError(RuntimeError):
    """An integration failed: non-finite or unbounded state, singular mass matrix or collapsed step.

    Attributes
    ----------
    t : float
        Time (s) of the last state reached (NaN when unknown).
    y : ndarray
        That state ``[q, qd]`` (empty when unknown).
    """

    def __init__(self, message: str, t: float = float("nan"), y: NDArray[np.float64] | None = None) -> None:
        super().__init__(message)
        self.t = float(t)
        self.y = np.zeros(0) if y is None else np.array(y, dtype=float)


#: former name of :class:`SimulationError` on the identification side; the same class
DivergenceError = SimulationError

#: integration schemes by name; each simulator implements a subset and says which
METHODS: dict[str, str] = {
    "radau": "implicit Radau IIA, order 5, L-stable",
    "rosenbrock": "linearly implicit Rosenbrock-W ROS34PW2, order 3, L-stable",
    "dopri5": "explicit Dormand-Prince 5(4)",
    "dop853": "explicit Dormand-Prince 8(5,3)",
    "bdf": "scipy.integrate.solve_ivp BDF",
    "lsoda": "scipy.integrate.solve_ivp LSODA",
    "rk23": "scipy.integrate.solve_ivp RK23",
}

#: the scipy.integrate.solve_ivp name of each method scipy implements
SCIPY_METHODS: dict[str, str] = {
    "radau": "Radau",
    "dopri5": "RK45",
    "dop853": "DOP853",
    "bdf": "BDF",
    "lsoda": "LSODA",
    "rk23": "RK23",
}

# names used before the contract was unified (scipy's spelling); accepted with a FutureWarning
_FORMER_NAMES = {scipy_name: name for name, scipy_name in SCIPY_METHODS.items()}


def canonical_method(method: str, supported: Iterable[str], *, owner: str = "simulate") -> str:
    """The canonical name of ``method``, checked against what the caller ``supported``.

    Parameters
    ----------
    method : str
        A name of :data:`METHODS`, or a former scipy-style spelling
        (``"Radau"``, ``"RK45"``, ...) which is translated with a FutureWarning.
    supported : iterable of str
        Canonical names the calling simulator implements.
    owner : str
        Named in the error message.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If the name is unknown or not supported by the caller.
    """
    supported = tuple(supported)
    if isinstance(method, str) and method in _FORMER_NAMES and method not in METHODS:
        new = _FORMER_NAMES[method]
        warnings.warn(
            f"method={method!r} is deprecated; use method={new!r} (the names of pcs_sindy.core.METHODS)",
            FutureWarning,
            stacklevel=3,
        )
        method = new
    if not isinstance(method, str) or method not in supported:
        raise ValueError(f"{owner}: method must be one of {list(supported)}; got {method!r}")
    return method


def simulate_inputs(t: Any, u: Any, tau: Any) -> tuple[Any, Any]:
    """``(t, u)`` of the simulate contract, accepting the former ``tau=`` name and argument order.

    Parameters
    ----------
    t, u : array_like, callable or None
        The times and inputs as passed to ``simulate(q0, qd0, t, u)``.
    tau : array_like, callable or None
        The former keyword name of ``u`` (a FutureWarning); not with ``u``.

    Returns
    -------
    t, u
        In the contract's order; the former order ``simulate(q0, qd0, tau, t)`` (times given
        second, as a callable or after a 2-D input) is swapped back with a FutureWarning.

    Raises
    ------
    ValueError
        When both ``u`` and ``tau`` are given, or the times or the inputs are missing.
    """
    if tau is not None:
        if u is not None:
            raise ValueError("give the input as u (tau is its former name), not both")
        warnings.warn(
            "simulate(..., tau=...) is deprecated; pass the input as u (simulate(q0, qd0, t, u))",
            FutureWarning,
            stacklevel=3,
        )
        u = tau
    if t is None or u is None:
        raise ValueError("simulate needs the times t and the input u: simulate(q0, qd0, t, u)")
    t_arr = None if callable(t) else np.asarray(t)
    u_arr = None if callable(u) else np.asarray(u)
    if callable(t) or (t_arr is not None and t_arr.ndim == 2 and u_arr is not None and u_arr.ndim == 1):
        warnings.warn(
            "simulate(q0, qd0, tau, t) is deprecated; the order is simulate(q0, qd0, t, u)", FutureWarning, stacklevel=3
        )
        t, u = u, t
    return t, u
