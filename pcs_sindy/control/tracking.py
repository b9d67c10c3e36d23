"""Trajectory tracking: computed torque on the identified model, for strain or tip references.

:class:`ComputedTorqueController` (docs/control.md, "Tracking") with
``law="computed_torque"`` linearises the model by feedback::

    tau = M(q) (qdd_r + Kd (qd_r - qd) + Kp (q_r - q)) + C(q, qd) qd + G(q) + K q + D qd - f0

so a perfect model leaves every strain error obeying ``e'' + Kd e' + Kp e = 0``.
With ``law="pd_plus"`` it feeds the model's inverse dynamics along the
reference forward and adds PD feedback with the gains of the rule of
:mod:`.gains`::

    tau = M(q) qdd_r + C(q, qd_r) qd_r + G(q) + K q + D qd_r - f0 + Kp (q_r - q) + Kd (qd_r - qd)

which never cancels the plant's own damping with a measured rate.  ``law="pid"``
is the model-free baseline ``tau = Kp e + Ki int e dt + Kd e'`` with the same
rule's gains (the model only chooses them).  A tip
reference (:class:`TipReference`) is turned into strains by the model's
least-effort inverse kinematics (:func:`~.statics.tip_inverse_kinematics`)
before the loop starts; the derivatives of a strain reference come from a
quintic spline through its samples.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import make_interp_spline

from .base import Controller
from .gains import as_gain_matrix, check_gain, check_positive, integral_gain, lqr_gains, warn_if_cannot_regulate
from .models import InputMap, check_strains, linearise, strain_scales
from .statics import tip_inverse_kinematics

__all__ = ["StrainReference", "TipReference", "tip_circle", "ComputedTorqueController"]

_LAWS = ("computed_torque", "pd_plus", "pid")


def _samples(t: ArrayLike, values: ArrayLike, width: int | None, name: str) -> tuple[NDArray, NDArray]:
    ts = np.asarray(t, dtype=float)
    v = np.asarray(values, dtype=float)
    if ts.ndim != 1 or ts.size < 6 or np.any(np.diff(ts) <= 0) or not np.all(np.isfinite(ts)):
        raise ValueError(f"{name}: t must be at least 6 strictly increasing finite times; got shape {ts.shape}")
    if (
        v.ndim != 2
        or v.shape[0] != ts.size
        or (width is not None and v.shape[1] != width)
        or not np.all(np.isfinite(v))
    ):
        want = f"({ts.size}, {width})" if width is not None else f"({ts.size}, n)"
        raise ValueError(f"{name}: values must be finite with shape {want}; got shape {v.shape}")
    return ts, v


class StrainReference:
    """A strain trajectory of the model's modelled strains, sampled; derivatives by a quintic spline.

    Parameters
    ----------
    t : array_like (S,)
        Sample times [s] (at least 6); the control times must lie within.
    q : array_like (S, n) or (S, 3m)
        Strains of the model's segmentation.
    """

    def __init__(self, t: ArrayLike, q: ArrayLike) -> None:
        self.t = t
        self.q = q

    def evaluate(
        self, fm: Any, limits: NDArray[np.float64], times: NDArray[np.float64]
    ) -> tuple[NDArray, NDArray, NDArray]:
        """``(q, qd, qdd)`` (T, n) at ``times``, checked against the model and its strain range."""
        ts, v = _samples(self.t, self.q, None, "StrainReference")
        rows = [check_strains(row, fm, limits, f"StrainReference.q[{k}]") for k, row in enumerate(v)]
        if times[0] < ts[0] - 1e-12 or times[-1] > ts[-1] + 1e-12:
            raise ValueError(
                f"the control times [{times[0]:g}, {times[-1]:g}] s leave the reference's [{ts[0]:g}, {ts[-1]:g}] s"
            )
        spline = make_interp_spline(ts, np.array(rows), k=5)
        return spline(times), spline(times, 1), spline(times, 2)


class TipReference:
    """A tip path ``p(t)`` [m] in the base frame, followed through the model's least-effort inverse kinematics.

    Parameters
    ----------
    path : callable
        ``path(times) -> (len(times), 2)`` tip positions.
    sample_period : float, default 0.01
        Spacing [s] of the inverse-kinematics samples (a quintic spline joins them).
    input_bounds : None or (lower, upper), optional
        Bounds on the equilibrium inputs of the inverse kinematics (default: the controller's).
    """

    def __init__(
        self, path: Callable[[NDArray], ArrayLike], sample_period: float = 0.01, input_bounds: Any = None
    ) -> None:
        self.path = path
        self.sample_period = sample_period
        self.input_bounds = input_bounds

    def strains(
        self,
        fm: Any,
        limits: NDArray[np.float64],
        times: NDArray[np.float64],
        input_bounds: Any,
        progress: bool = False,
    ) -> StrainReference:
        """The :class:`StrainReference` that puts the model's tip on the path over ``times``."""
        if not callable(self.path):
            raise ValueError(f"TipReference.path must be a callable t -> (T, 2); got {self.path!r}")
        h = check_positive(self.sample_period, "sample_period")
        n = max(int(np.ceil((times[-1] - times[0]) / h)) + 1, 6)
        ts = np.linspace(times[0], times[-1], n)
        pts = np.asarray(self.path(ts), dtype=float)
        if pts.shape != (n, 2) or not np.all(np.isfinite(pts)):
            raise ValueError(
                f"TipReference.path(t) must return finite tip positions of shape ({n}, 2); got {pts.shape}"
            )
        bounds = self.input_bounds if self.input_bounds is not None else input_bounds
        q, _ = tip_inverse_kinematics(fm, pts, bounds, limits, progress=progress)
        return StrainReference(ts, q)


def _smoothstep(x: NDArray[np.float64]) -> NDArray[np.float64]:
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10.0 + x * (-15.0 + 6.0 * x))


def tip_circle(
    center: ArrayLike,
    radius: float,
    frequency: float,
    *,
    start: ArrayLike | None = None,
    ramp: float = 1.0,
    phase: float = 0.0,
) -> Callable[[NDArray], NDArray]:
    """A tip path around a circle, entered smoothly from a start point.

    ``p(t) = start + s(t / ramp) (c(t) - start)`` with ``c(t)`` the point at
    angle ``phase + 2 pi frequency t`` on the circle and ``s`` the quintic
    smooth step (zero velocity and acceleration at both ends); without
    ``start`` the path is the circle itself.
    """
    c = np.asarray(center, dtype=float)
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise ValueError(f"center must be a finite [x, y]; got {center!r}")
    r = check_positive(radius, "radius")
    f = check_positive(frequency, "frequency")
    p0 = None if start is None else np.asarray(start, dtype=float)
    if p0 is not None and (p0.shape != (2,) or not np.all(np.isfinite(p0))):
        raise ValueError(f"start must be a finite [x, y]; got {start!r}")
    ramp = check_positive(ramp, "ramp") if p0 is not None else 1.0

    def path(times: NDArray) -> NDArray:
        times = np.asarray(times, dtype=float)
        ang = phase + 2.0 * np.pi * f * times
        circ = c + r * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
        if p0 is None:
            return circ
        return p0 + _smoothstep(times / ramp)[:, None] * (circ - p0)

    return path


class ComputedTorqueController(Controller):
    """Tracking of a strain or tip trajectory with the model's ``M, C, G, K, D`` (one compiled evaluation per step).

    Parameters
    ----------
    model : fitted model or ForwardModel
    law : {"pd_plus", "computed_torque", "pid"}, default "pd_plus"
        See the module docstring.  ``pd_plus`` is the default because it
        tracked best in every measurement (docs/results.md, section control):
        exact feedback linearisation cancels the plant's damping with a rate
        measured up to a control period earlier, which the shear and axial
        strains (relaxing in well under a period) punish.
    bandwidth : float, default 40.0
        ``computed_torque``: error dynamics ``e'' + 2 z w e' + w^2 e = 0`` with ``w`` this [rad/s].
    damping_ratio : float, default 1.0
        ``z`` of the error dynamics.
    kp, kd : scalar, (n,) or (n, n), optional
        Gains instead of the defaults: accelerations per strain error for
        ``computed_torque``, forces for ``pd_plus`` (default: the LQR rule of
        :mod:`.gains` at the reference's first configuration with ``rate`` and ``effort``).
    rate, effort : float
        Rule parameters for ``pd_plus`` and ``pid``.
    integral_rate : float, optional
        ``pid``: ``Ki = integral_rate (K + Kp)``; default ``rate / 3``.
    input_bounds, strain_limits, on_nan
        See :class:`~pcs_sindy.control.base.Controller`.
    progress : bool
        Progress bar over the inverse kinematics of a tip reference.

    Attributes
    ----------
    q_ref_, qd_ref_, qdd_ref_ : ndarray (T, n)
        The strain reference at the control times.
    kp_, ki_, kd_ : ndarray (n, n)
    """

    def __init__(
        self,
        model: Any,
        law: str = "pd_plus",
        *,
        bandwidth: float = 40.0,
        damping_ratio: float = 1.0,
        kp: ArrayLike | None = None,
        kd: ArrayLike | None = None,
        rate: float = 10.0,
        effort: float = 1.0,
        integral_rate: float | None = None,
        input_bounds: Any = None,
        strain_limits: ArrayLike | None = None,
        progress: bool = False,
        on_nan: str = "raise",
    ) -> None:
        super().__init__(model, input_bounds=input_bounds, strain_limits=strain_limits, on_nan=on_nan)
        self.law = law
        self.bandwidth = bandwidth
        self.damping_ratio = damping_ratio
        self.kp = kp
        self.kd = kd
        self.rate = rate
        self.effort = effort
        self.integral_rate = integral_rate
        self.progress = progress

    def start(
        self, reference: Any, t: ArrayLike, q0: ArrayLike | None = None, qd0: ArrayLike | None = None
    ) -> ComputedTorqueController:
        """Track ``reference`` (a :class:`StrainReference` or :class:`TipReference`) over the control times ``t``."""
        self._prepare(t)
        fm = self.forward_model_
        n = fm.kinematics.n_active
        if self.law not in _LAWS:
            raise ValueError(f"law must be one of {_LAWS}; got {self.law!r}")
        if isinstance(reference, TipReference):
            tip_path = np.asarray(reference.path(self.t_), dtype=float)
            reference = reference.strains(fm, self.strain_limits_, self.t_, self.input_bounds_, self.progress)
        elif isinstance(reference, StrainReference):
            tip_path = None
        else:
            raise ValueError(f"reference must be a StrainReference or a TipReference; got {type(reference).__name__}")
        self.q_ref_, self.qd_ref_, self.qdd_ref_ = reference.evaluate(fm, self.strain_limits_, self.t_)
        self.reference_tip_ = self._tips(self.q_ref_) if tip_path is None else tip_path
        self.reference_strains_ = self.q_ref_
        self._inputs = InputMap(fm, self.q_ref_[0])
        if self.law == "computed_torque":
            w = check_positive(self.bandwidth, "bandwidth")
            z = check_positive(self.damping_ratio, "damping_ratio")
            kp, kd = w * w, 2.0 * z * w
        else:
            rate = check_positive(self.rate, "rate")
            lin = linearise(fm, self.q_ref_[0])
            if self.kp is None or self.kd is None:
                kp, kd = lqr_gains(
                    lin, self.dt_, rate, check_positive(self.effort, "effort"), strain_scales(fm.kinematics)
                )
        self.kp_ = as_gain_matrix(kp, n, "kp") if self.kp is None else check_gain(self.kp, n, "kp")
        self.kd_ = as_gain_matrix(kd, n, "kd") if self.kd is None else check_gain(self.kd, n, "kd")
        self.ki_ = np.zeros((n, n))
        if self.law == "pid":
            i_rate = (
                rate / 3.0
                if self.integral_rate is None
                else check_positive(self.integral_rate, "integral_rate", allow_zero=True)
            )
            self.ki_ = integral_gain(lin, self.kp_, i_rate)
        warn_if_cannot_regulate(self.kp_, self.ki_ if self.law == "pid" else None, "ComputedTorqueController")
        self._law = _LAWS.index(self.law)
        self._z = np.zeros(n)
        return self

    def step(
        self, k: int, q: NDArray[np.float64], qd: NDArray[np.float64], tip: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        e = self.q_ref_[k] - q
        ed = self.qd_ref_[k] - qd
        if self._law == 0:
            M, bias = self.forward_model_.terms(q, qd)
            tau = M @ (self.qdd_ref_[k] + self.kd_ @ ed + self.kp_ @ e) + bias
        elif self._law == 1:
            M, bias = self.forward_model_.terms(q, self.qd_ref_[k])
            tau = M @ self.qdd_ref_[k] + bias + self.kp_ @ e + self.kd_ @ ed
        else:
            self._z += self.dt_ * e
            tau = self.kp_ @ e + self.ki_ @ self._z + self.kd_ @ ed
        return self._clip(self._inputs(tau, q))
