"""Regulation to a fixed configuration: the seed's P-satI-D with feed-forward, and tip regulation through inputs.

:class:`SetpointRegulator` (docs/control.md, "Set-point regulation")::

    tau = G(q*) + K q* - f0 + Kp (q* - q) + Ki sat(int (q* - q) dt) - Kd qd
    u   = A^+ tau

with the model's static forces as feed-forward (``feedforward=False`` gives the
PID baseline) and two anti-windup measures: the integrator state is clamped
(it never winds beyond the saturation) and each strain integrates only near
its set-point (conditional integration).

:class:`TipRegulator` (docs/control.md, "Tip regulation") finds the inputs
``u*`` whose model equilibrium ``q*`` puts the tip at the target (bounded
optimisation, :func:`~.statics.equilibrium_inputs`), stabilises that
equilibrium with input-space gains of the same rule and removes the remaining
tip error with integral action through the static sensitivity
``S = d tip / d u`` of the model's equilibria::

    w   <- clip(w + dt ki S_W^+ e,  box)              (the integral, an input offset)
    u    = clip(u* + w - Fq (q - q* - Q w) - Fd qd + kp S_W^+ e,  bounds),     e = tip* - tip(q)

with ``S_W^+ = W S^T (S W S^T)^-1`` (``W`` the squared input scales),
``Q = dq*/du`` (the offset moves the equilibrium the strain feedback regulates
about, so at rest ``u = u* + w``) and the box keeping ``u* + w`` within the
input bounds: projected integral action, updated only while ``|e|`` is within
a band (conditional integration),
which cannot wind up against a bound and lets an antagonist take over where an
input rests on its bound (a slack tendon).

It needs nothing but the model's ``input_matrix`` and input bounds, so it
serves generalised-force models and tendon or chamber models alike.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _kinematics
from .base import Controller
from .gains import (
    as_gain_matrix,
    check_gain,
    check_positive,
    force_scales,
    integral_gain,
    loop_poles,
    lqr_gains,
    open_loop_decay,
    warn_if_cannot_regulate,
)
from .models import REACH_MARGIN, InputMap, check_strains, linearise, static_forces, strain_scales
from .statics import EquilibriumResult, equilibrium_inputs, input_scales, tip_jacobian
from .targets import ShapeTarget, shape_strains

__all__ = ["SetpointRegulator", "TipRegulator"]

#: how long [s] the tip must stay slower than ``integral_speed`` to count as at rest
_REST_TIME = 0.1
#: Tikhonov damping of the integral's gain over a subset of free inputs, relative to the full set's
_DAMPING = 1e-2


class SetpointRegulator(Controller):
    """P-satI-D with model feed-forward to a strain set-point (the published paper's regulator).

    Parameters
    ----------
    model : fitted model or ForwardModel
    kp, ki, kd : scalar, (n,) or (n, n), optional
        Gains on the n modelled strains.  Not given: ``kp``/``kd`` by the rule
        of :mod:`pcs_sindy.control.gains` (discrete LQR with prescribed degree
        of stability on the model's linearisation at the set-point) and
        ``ki = integral_rate (K + Kp)``.
    rate : float, default 10.0
        Rule: every mode of the linearised loop decays at least like ``exp(-rate t)``.
    effort : float, default 1.0
        Rule: weight of the scaled forces in the quadratic cost.
    integral_rate : float, optional
        Rule: decay rate of the integral action [1/s]; default ``rate / 3``.
    integral_limit : scalar or (n,), optional
        Largest generalised force the integral may supply per strain (the
        saturation).  Default: 10 % of the force that holds each strain at
        its typical magnitude (60 1/m bending, 0.3 shear/axial) with the
        static stiffness; ``np.inf`` for none.
    integral_band : float, default 0.05
        A strain integrates its error only while it is within this fraction of
        its typical magnitude from the set-point (3 1/m bending, 0.015 shear
        and axial): conditional integration, so the transient of a large move
        winds up nothing the integral then has to unwind.  ``np.inf``: always.
    feedforward : bool, default True
        Add ``G(q*) + K q* - f0`` of the model.  False: PID on the strains.
    input_bounds, strain_limits, on_nan
        See :class:`~pcs_sindy.control.base.Controller`.

    Attributes
    ----------
    setpoint_ : ndarray (n,)
    feedforward_ : ndarray (n,)
    kp_, ki_, kd_ : ndarray (n, n)
    integral_max_ : ndarray (n,)
        Saturation of each integrator state ``int (q* - q) dt``.
    linearisation_ : Linearisation
        Of the model at the set-point.
    poles_ : ndarray (3n,)
        Discrete poles of the model's linearised loop with these gains
        (:func:`~.gains.loop_poles`); a warning is issued if any lies outside the unit circle.
    shape_fit_ : dict or None
        For a :class:`~pcs_sindy.control.targets.ShapeTarget` reference, how
        well the model's shape at the set-point fits it (``tip_error``,
        ``max_position_error``, ``rms_position_error`` [m]); else None.
    """

    def __init__(
        self,
        model: Any,
        kp: ArrayLike | None = None,
        ki: ArrayLike | None = None,
        kd: ArrayLike | None = None,
        *,
        rate: float = 10.0,
        effort: float = 1.0,
        integral_rate: float | None = None,
        integral_limit: ArrayLike | None = None,
        integral_band: float = 0.05,
        feedforward: bool = True,
        input_bounds: Any = None,
        strain_limits: ArrayLike | None = None,
        on_nan: str = "raise",
    ) -> None:
        super().__init__(model, input_bounds=input_bounds, strain_limits=strain_limits, on_nan=on_nan)
        self.kp = kp
        self.ki = ki
        self.kd = kd
        self.rate = rate
        self.effort = effort
        self.integral_rate = integral_rate
        self.integral_limit = integral_limit
        self.integral_band = integral_band
        self.feedforward = feedforward

    def start(
        self, reference: ArrayLike, t: ArrayLike, q0: ArrayLike | None = None, qd0: ArrayLike | None = None
    ) -> SetpointRegulator:
        """Regulate to the set-point ``reference`` over the control times ``t``.

        Parameters
        ----------
        reference : array_like (n,) or (3m,), or ShapeTarget
            The model's modelled (or all) strains, or a shape
            (:class:`~pcs_sindy.control.targets.ShapeTarget`: marker poses, or
            :meth:`~pcs_sindy.control.targets.ShapeTarget.from_strains` for
            strains of another segmentation such as the plant's), mapped to
            the model's strains by :func:`~pcs_sindy.control.targets.shape_strains`
            (the fit is :attr:`shape_fit_`).  A set-point a little outside the
            model's strain range is accepted with a warning saying how far;
            a far one is refused (:func:`~pcs_sindy.control.models.check_strains`).
        t : array_like (T,)
        q0, qd0 : ignored
        """
        self._prepare(t)
        fm = self.forward_model_
        self.shape_fit_ = None
        if isinstance(reference, ShapeTarget):
            reference, self.shape_fit_ = shape_strains(fm, reference)
        n = fm.kinematics.n_active
        rate = check_positive(self.rate, "rate")
        effort = check_positive(self.effort, "effort")
        i_rate = (
            rate / 3.0
            if self.integral_rate is None
            else check_positive(self.integral_rate, "integral_rate", allow_zero=True)
        )
        q_ref = check_strains(reference, fm, self.strain_limits_, "reference")
        self._inputs = InputMap(fm, q_ref)
        lin = linearise(fm, q_ref)
        scales = strain_scales(fm.kinematics)
        if self.kp is None or self.kd is None:
            kp, kd = lqr_gains(lin, self.dt_, rate, effort, scales)
        self.kp_ = as_gain_matrix(kp, n, "kp") if self.kp is None else check_gain(self.kp, n, "kp")
        self.kd_ = as_gain_matrix(kd, n, "kd") if self.kd is None else check_gain(self.kd, n, "kd")
        self.ki_ = (
            as_gain_matrix(integral_gain(lin, self.kp_, i_rate), n, "ki")
            if self.ki is None
            else check_gain(self.ki, n, "ki")
        )
        warn_if_cannot_regulate(self.kp_, self.ki_, "SetpointRegulator")
        if self.integral_limit is None:
            limit = 0.1 * force_scales(lin, scales)
        else:
            limit = np.asarray(self.integral_limit, dtype=float)
            limit = np.full(n, float(limit)) if limit.ndim == 0 else limit
            if limit.shape != (n,) or np.any(np.isnan(limit)) or np.any(limit < 0):
                raise ValueError(
                    f"integral_limit must be a scalar or ({n},) of values >= 0 (np.inf: no "
                    f"saturation); got {np.asarray(self.integral_limit).tolist()}"
                )
        ki_diag = np.abs(np.diag(self.ki_))
        with np.errstate(divide="ignore", invalid="ignore"):
            self.integral_max_ = np.where(ki_diag > 0, limit / ki_diag, 0.0)
        self.linearisation_ = lin
        self.poles_ = loop_poles(lin, self.kp_, self.ki_, self.kd_, self.dt_)
        if np.max(np.abs(self.poles_)) > 1.0 + 1e-9:
            warnings.warn(
                f"the gains do not stabilise the model's linearisation at the set-point with a control "
                f"period of {self.dt_:g} s (largest |pole| {np.max(np.abs(self.poles_)):.6f} > 1)",
                UserWarning,
                stacklevel=2,
            )
        band = check_positive(self.integral_band, "integral_band", allow_inf=True)
        self._band = band * scales
        self.setpoint_ = q_ref
        self.feedforward_ = static_forces(fm, q_ref) if self.feedforward else np.zeros(n)
        self._z = np.zeros(n)
        self.reference_tip_ = np.broadcast_to(self._tips(q_ref), (self.t_.size, 2)).copy()
        self.reference_strains_ = np.broadcast_to(q_ref, (self.t_.size, n)).copy()
        return self

    def step(
        self, k: int, q: NDArray[np.float64], qd: NDArray[np.float64], tip: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        e = self.setpoint_ - q
        z = self._z
        # conditional integration: a strain integrates only near its set-point
        z += self.dt_ * np.where(np.abs(e) <= self._band, e, 0.0)
        np.minimum(np.maximum(z, -self.integral_max_, out=z), self.integral_max_, out=z)
        tau = self.feedforward_ + self.kp_ @ e + self.ki_ @ z - self.kd_ @ qd
        return self._clip(self._inputs(tau, q))


class TipRegulator(Controller):
    """Tip regulation through the model's inputs: equilibrium inputs for the target, then feedback.

    Parameters
    ----------
    model : fitted model or ForwardModel
    kp : float, default 0.0
        Proportional gain on the tip error through ``S_W^+`` (1: one full
        static correction per error); the strain feedback already acts proportionally.
    ki : float, default 3.0
        Integral gain [1/s] on the tip error.
    integral_limit : float, default 0.25
        Largest integral offset of each input, as a fraction of its scale (the
        span of its bounds, else the input exerting the strains' typical forces;
        :func:`~.statics.input_scales`); the offset also keeps every input within its bounds.
    integral_band : float, default 5e-3
        The integral acts while the tip error is within this distance [m]
        (conditional integration: the transient of a large move winds
        nothing up) ...
    integral_speed : float, default 0.02
        ... and always once the tip, having moved, has come to rest: its speed
        (``J q̇`` of the model) stayed below this [m/s] for 0.1 s.  A model
        whose equilibrium misses the target by more than the band (a
        low-dimensional model of a robot that is not piecewise constant
        strain) is then still corrected; the box keeps the integral from winding up.
    rate, effort : float
        The rule of :mod:`pcs_sindy.control.gains`, here for the inputs:
        ``(Fq, Fd)`` stabilise the model's equilibrium ``q*`` through ``A(q*)``.
        With fewer inputs than modelled strains (tendons, chambers) the
        prescribed decay rate is capped at the decay rate of the slowest mode
        of the model's open loop at ``q*`` (``rate_``): such inputs cannot
        speed up every strain, and demanding it of a weakly controllable one
        (the shear of a tendon robot) makes the gains huge and the loop
        fragile to camera-rate, noisy observation (docs/control.md).
    on_unreachable : {"raise", "nearest"}, default "raise"
        A target the model cannot reach within its input bounds and strain
        range raises ValueError (with the nearest reachable tip), or is
        replaced by the nearest reachable tip.  A target reachable with strains
        a little outside the strain range (up to 25 % of its span beyond,
        ``models.REACH_MARGIN``) is accepted with a warning saying how far.
    input_bounds, strain_limits, on_nan
        See :class:`~pcs_sindy.control.base.Controller` (e.g. ``(0, 16)``
        for tendon tensions).

    Attributes
    ----------
    equilibrium_ : EquilibriumResult
        ``u*``, ``q*``, the tip and whether the target was reachable.
    target_ : ndarray (2,)
        The regulated tip (the nearest reachable one if replaced).
    sensitivity_ : ndarray (2, p)
        ``d tip / d u`` of the model's equilibria at ``u*``.
    fq_, fd_ : ndarray (p, n)
        Strain and rate feedback on the inputs.
    rate_ : float
        The prescribed decay rate the gains were designed with.

    Notes
    -----
    The tip error is that of the measured tip when :meth:`step` is given one
    (closed loops pass the camera's last marker, or the plant's tip when the
    state is observed), else that of the model's tip at the measured strains.
    """

    def __init__(
        self,
        model: Any,
        kp: float = 0.0,
        ki: float = 3.0,
        *,
        integral_limit: float = 0.25,
        integral_band: float = 5e-3,
        integral_speed: float = 0.02,
        rate: float = 10.0,
        effort: float = 1.0,
        on_unreachable: str = "raise",
        input_bounds: Any = None,
        strain_limits: ArrayLike | None = None,
        on_nan: str = "raise",
    ) -> None:
        super().__init__(model, input_bounds=input_bounds, strain_limits=strain_limits, on_nan=on_nan)
        self.kp = kp
        self.ki = ki
        self.integral_limit = integral_limit
        self.integral_band = integral_band
        self.integral_speed = integral_speed
        self.rate = rate
        self.effort = effort
        self.on_unreachable = on_unreachable

    def start(
        self, reference: ArrayLike, t: ArrayLike, q0: ArrayLike | None = None, qd0: ArrayLike | None = None
    ) -> TipRegulator:
        """Regulate the tip to ``reference`` ([x, y] in the base frame) over the control times ``t``."""
        self._prepare(t)
        fm = self.forward_model_
        kp = check_positive(self.kp, "kp", allow_zero=True)
        ki = check_positive(self.ki, "ki", allow_zero=True)
        if kp == 0 and ki == 0:
            warnings.warn(
                "TipRegulator: kp = ki = 0: the tip error is not fed back (only the model's equilibrium inputs "
                "and the strain feedback act), so a model error leaves a tip error; give ki > 0",
                UserWarning,
                stacklevel=2,
            )
        i_lim = check_positive(self.integral_limit, "integral_limit", allow_zero=True, allow_inf=True)
        band = check_positive(self.integral_band, "integral_band", allow_inf=True)
        speed = check_positive(self.integral_speed, "integral_speed", allow_zero=True, allow_inf=True)
        rate = check_positive(self.rate, "rate")
        effort = check_positive(self.effort, "effort")
        if self.on_unreachable not in ("raise", "nearest"):
            raise ValueError(f"on_unreachable must be 'raise' or 'nearest'; got {self.on_unreachable!r}")
        eq = equilibrium_inputs(fm, reference, self.input_bounds_, self.strain_limits_)
        if not eq.reachable:
            eq = self._a_little_beyond(fm, reference, eq)
        if not eq.reachable and self.on_unreachable == "raise":
            raise ValueError(
                f"reference tip {eq.target.tolist()} is not reachable by the model within input_bounds and its strain "
                f"range; nearest reachable tip {eq.tip.round(6).tolist()} ({1e3 * eq.error:.3g} mm away); pass "
                "on_unreachable='nearest' to regulate there"
            )
        self.equilibrium_: EquilibriumResult = eq
        self.target_ = eq.target.copy() if eq.reachable else eq.tip.copy()
        lin = linearise(fm, eq.q, eq.u)
        dq_du = np.linalg.solve(lin.stiffness, lin.input_matrix)
        S = tip_jacobian(fm, eq.q) @ dq_du
        self.sensitivity_ = S
        u_scale = input_scales(lin, self.input_bounds_, strain_scales(fm.kinematics))
        self._u_weight = u_scale**2
        self._gains: dict[bytes, NDArray[np.float64]] = {}
        self._gain = self._free_gain(np.ones(self.n_inputs_, dtype=bool))
        n = eq.q.size
        self.rate_ = rate if self.n_inputs_ >= n else float(np.clip(open_loop_decay(lin), 0.0, rate))
        self.fq_, self.fd_ = lqr_gains(
            lin, self.dt_, rate, effort, strain_scales(fm.kinematics), u_scale, decay=self.rate_
        )
        # the strain feedback regulates about the equilibrium the integral offset moves to
        self._shift = np.eye(self.n_inputs_) + self.fq_ @ dq_du
        self._kp, self._ki = kp, ki
        self._band2 = band**2
        self._speed2 = speed**2
        self._settled = False
        self._moved = False
        self._slow = 0
        self._probe = np.zeros(3)
        self._w = np.zeros(self.n_inputs_)
        # the offset keeps u* + w inside the bounds and within integral_limit of its own scale
        self._w_lo = np.maximum(self.input_bounds_[0] - eq.u, -i_lim * u_scale)
        self._w_hi = np.minimum(self.input_bounds_[1] - eq.u, i_lim * u_scale)
        kin = fm.kinematics
        self._lengths = np.asarray(kin.segment_lengths, dtype=float)
        self._base = np.asarray(kin.base_pose, dtype=float)
        self._mask = kin.active_mask
        self._qfull = np.zeros(kin.n_q)
        self._pose = np.zeros(3)
        self.reference_tip_ = np.broadcast_to(self.target_, (self.t_.size, 2)).copy()
        self.reference_strains_ = np.broadcast_to(eq.q, (self.t_.size, eq.q.size)).copy()
        return self

    def _a_little_beyond(self, fm: Any, reference: ArrayLike, eq: EquilibriumResult) -> EquilibriumResult:
        """``eq``, or the equilibrium within strain limits widened by ``REACH_MARGIN`` of their span, with a warning."""
        lim = self.strain_limits_
        span = lim[1] - lim[0]
        wide = equilibrium_inputs(
            fm, reference, self.input_bounds_, lim + REACH_MARGIN * span * np.array([[-1.0], [1.0]])
        )
        if not wide.reachable:
            return eq
        beyond = np.maximum(lim[0] - wide.q, wide.q - lim[1]) / span
        names = fm.kinematics.strain_names(active_only=True)
        out = ", ".join(
            f"{names[i]} = {wide.q[i]:.4g} not in [{lim[0, i]:.4g}, {lim[1, i]:.4g}] ({100 * beyond[i]:.3g} % of its "
            "span beyond)"
            for i in np.flatnonzero(beyond > 0)
        )
        warnings.warn(
            f"reference tip {wide.target.tolist()} needs strains a little outside the model's strain range: {out}; "
            f"accepted (up to {100 * REACH_MARGIN:g} % beyond), the model extrapolates there",
            UserWarning,
            stacklevel=3,
        )
        return wide

    def _free_gain(self, free: NDArray[np.bool_]) -> NDArray[np.float64]:
        """``S_W^+`` over the inputs ``free`` (zero rows for the others); damped for a subset."""
        key = free.tobytes()
        gain = self._gains.get(key)
        if gain is None:
            S = self.sensitivity_[:, free]
            SW = S * self._u_weight[free]
            gain = np.zeros((free.size, 2))
            # a subset is damped (least squares): few or nearly parallel free inputs would explode the inverse
            full = (self.sensitivity_ * self._u_weight) @ self.sensitivity_.T
            damping = 0.0 if free.all() else _DAMPING * np.trace(full)
            gain[free] = SW.T @ np.linalg.inv(S @ SW.T + damping * np.eye(2))
            self._gains[key] = gain
        return gain

    def tip(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The model's tip position (2,) at modelled strains ``q`` (compiled)."""
        self._qfull[self._mask] = q
        _kinematics.tip_pose(self._qfull, self._lengths, self._base, self._pose)
        return self._pose[:2]

    def step(
        self, k: int, q: NDArray[np.float64], qd: NDArray[np.float64], tip: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        here = self.tip(q)
        e = self.target_ - (here if tip is None else tip)
        eq = self.equilibrium_
        # integral action as an input offset kept inside the input box (projected), so a bounded
        # input never winds up and an antagonist takes over where one input rests on its bound
        w = self._w
        inside = e[0] * e[0] + e[1] * e[1] <= self._band2
        if not (inside or self._settled):
            # tip speed J qd by a directional difference of the compiled tip; at rest = slow for _REST_TIME
            h = 1e-4
            self._qfull[self._mask] = q + h * qd
            _kinematics.tip_pose(self._qfull, self._lengths, self._base, self._probe)
            vx, vy = (self._probe[0] - here[0]) / h, (self._probe[1] - here[1]) / h
            if vx * vx + vy * vy > self._speed2:
                self._moved, self._slow = True, 0
            else:
                self._slow += 1
            self._settled = self._moved and self._slow * self.dt_ >= _REST_TIME
        if inside or self._settled:
            dw = self._gain @ e
            # inputs resting on their box and pushed further out leave the correction to the others
            blocked = ((w <= self._w_lo) & (dw < 0)) | ((w >= self._w_hi) & (dw > 0))
            if blocked.any():
                dw = self._free_gain(~blocked) @ e
            w += (self.dt_ * self._ki) * dw
            np.minimum(np.maximum(w, self._w_lo, out=w), self._w_hi, out=w)
        u = eq.u + self._shift @ w - self.fq_ @ (q - eq.q) - self.fd_ @ qd
        if self._kp:
            u += self._kp * (self._gain @ e)
        return self._clip(u)
