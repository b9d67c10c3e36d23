"""The controller interface shared by the regulators and the tracking controllers.

A controller is built from an identified model and hyper-parameters (stored
unchanged, sklearn-style), prepared for one task by :meth:`Controller.start`
(a reference and the uniform control time grid; learned attributes end in
``_``) and then called once per control period by :meth:`Controller.step`
with the measured modelled strains and rates.  :func:`~.closed_loop.closed_loop`
drives a controller against a plant; on hardware the same two calls run the loop.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .models import as_forward_model, strain_limits
from .statics import check_input_bounds, model_tip

__all__ = ["Controller", "check_time_grid", "ON_NAN"]

#: what :meth:`Controller.command` does with a non-finite measurement
ON_NAN = ("raise", "hold")


def check_time_grid(t: ArrayLike, name: str = "t") -> tuple[NDArray[np.float64], float]:
    """Uniform, strictly increasing control times (T,) with T >= 2, and their period."""
    arr = np.asarray(t, dtype=float)
    if arr.ndim != 1 or arr.size < 2 or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a finite 1-D array of at least 2 control times; got shape {arr.shape}")
    dt = np.diff(arr)
    if np.any(dt <= 0) or np.max(np.abs(dt - dt[0])) > 1e-9 * dt[0]:
        raise ValueError(
            f"{name} must be uniformly spaced and increasing (one control period); got steps from "
            f"{dt.min():.6g} to {dt.max():.6g} s"
        )
    return arr, float(dt[0])


class Controller(ABC):
    """A feedback law on the modelled strains of an identified model.

    Parameters
    ----------
    model : fitted model or ForwardModel
        Anything with ``forward_model()`` (e.g. a fitted
        :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`) or a forward model.
    input_bounds : None or (lower, upper)
        Bounds on the commanded inputs (scalars or (p,)); commands are clipped
        to them.  Default: the forward model's ``input_bounds`` if it has
        them, else unbounded.
    strain_limits : array_like, optional
        The model's trusted strain range, (n,) symmetric or (2, n); references
        outside it are rejected.  Default: :func:`~.models.strain_limits`.
    on_nan : {"raise", "hold"}, default "raise"
        What :meth:`command` does with a measurement holding NaN or inf (a
        lost camera frame, a failed estimate): raise ValueError naming the
        control step, or hold the last command (the first measurement must be
        finite).  :meth:`step`, the unchecked hot path, never looks.

    Attributes
    ----------
    forward_model_ : ForwardModel
    n_inputs_ : int
    input_bounds_ : ndarray (2, p)
    strain_limits_ : ndarray (2, n)
    t_ : ndarray (T,)
        Control times of the task.
    dt_ : float
        Control period.
    reference_tip_ : ndarray (T, 2)
        Tip position the task asks for at every control time.
    reference_strains_ : ndarray (T, n)
        The modelled strains the controller steers to at every control time.
    """

    def __init__(
        self, model: Any, *, input_bounds: Any = None, strain_limits: ArrayLike | None = None, on_nan: str = "raise"
    ) -> None:
        self.model = model
        self.input_bounds = input_bounds
        self.strain_limits = strain_limits
        self.on_nan = on_nan

    def _prepare(self, t: ArrayLike) -> None:
        if self.on_nan not in ON_NAN:
            raise ValueError(f"on_nan must be one of {ON_NAN}; got {self.on_nan!r}")
        self._last_command: NDArray[np.float64] | None = None
        fm = as_forward_model(self.model)
        self._n_strains = int(fm.kinematics.n_active)
        self.forward_model_ = fm
        self.n_inputs_ = int(fm.n_inputs)
        bounds = self.input_bounds if self.input_bounds is not None else getattr(fm, "input_bounds", None)
        self.input_bounds_ = check_input_bounds(bounds, self.n_inputs_)
        self._bounded = bool(np.any(np.isfinite(self.input_bounds_)))
        self.strain_limits_ = strain_limits(self.model, fm, self.strain_limits)
        self.t_, self.dt_ = check_time_grid(t)

    def _clip(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        if self._bounded:
            np.minimum(np.maximum(u, self.input_bounds_[0], out=u), self.input_bounds_[1], out=u)
        return u

    def _tips(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        return model_tip(self.forward_model_, q)

    @abstractmethod
    def start(
        self, reference: Any, t: ArrayLike, q0: ArrayLike | None = None, qd0: ArrayLike | None = None
    ) -> Controller:
        """Prepare the task ``reference`` over the control times ``t`` from the model state ``(q0, qd0)``."""

    def command(self, k: int, q: ArrayLike, qd: ArrayLike, tip: ArrayLike | None = None) -> NDArray[np.float64]:
        """:meth:`step` with its inputs checked: the call for a hardware loop (and :func:`~.closed_loop.closed_loop`).

        Parameters
        ----------
        k : int
            Index of the control time ``t_[k]`` (0 <= k < len(t_)).
        q, qd : array_like (n,)
            Measured modelled strains and rates.
        tip : array_like (2,), optional
            Measured tip position.

        Returns
        -------
        ndarray (p,)
            The command; with ``on_nan="hold"`` and a non-finite measurement, the last one.

        Raises
        ------
        ValueError
            Before :meth:`start`, for ``k`` out of range, wrong shapes, or a
            non-finite measurement with ``on_nan="raise"`` (or before any command to hold).
        """
        if not hasattr(self, "t_"):
            raise ValueError(f"{type(self).__name__}.command: call start(reference, t) first")
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < self.t_.size:
            raise ValueError(f"k must be a control step index in [0, {self.t_.size - 1}]; got {k!r}")
        n = self._n_strains
        if type(q) is not np.ndarray or q.dtype != np.float64:
            q = np.asarray(q, dtype=float)
        if type(qd) is not np.ndarray or qd.dtype != np.float64:
            qd = np.asarray(qd, dtype=float)
        if q.shape != (n,) or qd.shape != (n,):
            raise ValueError(
                f"q and qd must be the {n} modelled strains and rates, shape ({n},); got {q.shape} and {qd.shape}"
            )
        total = q.sum() + qd.sum()
        if tip is not None:
            if type(tip) is not np.ndarray or tip.dtype != np.float64:
                tip = np.asarray(tip, dtype=float)
            if tip.shape != (2,):
                raise ValueError(f"tip must be a position (2,); got shape {tip.shape}")
            total += tip.sum()
        # one sum for the hot path; the element-wise look only when it is not finite (or overflowed)
        if not math.isfinite(total):
            bad = [nm for nm, v in (("q", q), ("qd", qd), ("tip", tip)) if v is not None and not np.isfinite(v).all()]
            if bad:
                if self.on_nan == "hold" and self._last_command is not None:
                    return self._last_command.copy()
                raise ValueError(
                    f"the measurement at control step {k} (t = {self.t_[k]:.6g} s) holds NaN or inf in "
                    f"{', '.join(bad)}"
                    + (
                        "; with on_nan='hold' there is no earlier command to hold yet"
                        if self.on_nan == "hold"
                        else "; pass on_nan='hold' to hold the last command over lost measurements"
                    )
                )
        u = self.step(k, q, qd, tip)
        self._last_command = u
        return u

    @abstractmethod
    def step(
        self, k: int, q: NDArray[np.float64], qd: NDArray[np.float64], tip: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        """Command (p,) for control time ``t_[k]`` from the measured modelled strains and rates (n,).

        The hot path: no checks; ``q`` and ``qd`` are float arrays of the n
        modelled strains.  ``tip``: the measured tip position (2,) when the
        observer has one (the camera's last marker; :func:`~.closed_loop.closed_loop`
        passes it), else None; controllers that regulate the tip use it
        instead of the model's tip at ``q``, which differs from the robot's
        where the robot is not piecewise constant strain.
        """
