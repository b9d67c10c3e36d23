"""Actuation terms of the identification: ``tau = A(q) u`` from actuator inputs ``u``.

Real robots are driven by tendons, chambers and motors, not by generalised
forces.  An :class:`Actuation` maps the inputs ``u`` (T, p) of a recording to
generalised forces on the modelled strains of a segmentation,

    A(q) u = known(q, u) + sum_j theta_j B_j(q, u),

with ``theta`` the gains the regression identifies (linear, solved with the
Lagrangian coefficients) and, for tendons, offsets that enter nonlinearly
(solved by variable projection around the linear fit).  Layouts are given by
arc length along the robot, so they hold for any fused segmentation.

* :class:`IdentityActuation` — the inputs are the generalised forces (3m columns).
* :class:`TendonActuation` — tendons from the base to termination arc lengths
  at offsets from the backbone along the cross-section axis; ``A = -dl/dq``.
* :class:`PressureActuation` — pressure chambers spanning arc-length intervals
  on either side of the backbone; constant columns with unknown gains.
* :class:`LinearActuation` — any constant ``A`` with a sparsity pattern over
  the strains of a known segmentation; one unknown gain per entry.
* :class:`LearnedActuation` — a mechanism of unknown layout: ``A(q)`` affine
  in the strains (terms ``u`` and ``u`` times strains), every term a gain.

Scale.  When every actuator gain is identified (chambers, linear layouts), the
equations are homogeneous: scaling every density, stiffness, damping and gain
by one factor leaves the motion unchanged, with or without known gravity
(gravity forces scale with the density).  The regression then needs one
absolute quantity — the robot's mass (``PhysicalPCSLibrary(mass=...)``) — and
raises otherwise.  Tendons carry their own scale: their tensions are in newtons
and ``A(q)`` is geometry.

A user-supplied actuation subclasses :class:`Actuation` and implements
:meth:`Actuation.parts` (and, to run on the compiled rollouts,
:meth:`Actuation.compiled`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from numbers import Integral, Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator

from ..core.kinematics import PlanarPCS
from ..core.validation import Check, Interval, InvalidParameterError, Options, validate_parameters

__all__ = [
    "Actuation",
    "IdentityActuation",
    "TendonActuation",
    "PressureActuation",
    "LinearActuation",
    "LearnedActuation",
    "actuation_from_layout",
    "ACT_IDENTITY",
    "ACT_TENDON",
    "ACT_CONSTANT",
    "ACT_SERVO",
    "ACT_AFFINE",
]

#: kinds of the compiled input map (see :meth:`Actuation.compiled`)
ACT_IDENTITY, ACT_TENDON, ACT_CONSTANT, ACT_SERVO, ACT_AFFINE = 0, 1, 2, 3, 4


def _per_actuator(obj: Actuation, name: str, size: int | None = None) -> NDArray[np.float64]:
    """The 1-D array of parameter ``name`` (its values checked by the table); with ``size``, one per actuator."""
    value = getattr(obj, name)
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if size is not None and arr.size != size:
        raise InvalidParameterError.of(obj, name, f"{size} values, one per actuator of end", value)
    return arr


def _finite_vector(value: Any) -> bool:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    return arr.ndim == 1 and arr.size > 0 and bool(np.all(np.isfinite(arr)))


def _positive_vector(value: Any) -> bool:
    return _finite_vector(value) and bool(np.all(np.asarray(value, dtype=float) > 0))


def _non_negative_vector(value: Any) -> bool:
    return _finite_vector(value) and bool(np.all(np.asarray(value, dtype=float) >= 0))


def _sides(value: Any) -> bool:
    return _finite_vector(value) and bool(np.all(np.abs(np.asarray(value, dtype=float)) == 1))


def _pattern(value: Any) -> bool:
    pat = np.asarray(value)
    return pat.ndim == 2 and pat.shape[1] >= 1 and (pat.dtype == bool or bool(np.all(np.isin(pat, (0, 1)))))


_ARC_LENGTHS = "a non-empty 1-D array of finite arc lengths"
#: the per-value checks of the layouts (the checks against a segmentation stay in fit)
_END = Check(_positive_vector, f"{_ARC_LENGTHS} > 0 [m]")
_SIDE = Check(_sides, "a non-empty 1-D array of -1 or 1 (one side per actuator)")


def _cover(start: NDArray, end: NDArray, lengths: NDArray) -> NDArray[np.float64]:
    """Rest length (p, m) of segment i inside the arc-length interval ``[start_k, end_k]``."""
    bounds = np.concatenate([[0.0], np.cumsum(lengths)])
    lo = np.maximum(start[:, None], bounds[None, :-1])
    hi = np.minimum(end[:, None], bounds[None, 1:])
    return np.maximum(hi - lo, 0.0)


def _inside(value: NDArray, name: str, total: float, *, allow_zero: bool, tol: float = 1e-6) -> None:
    # a termination measured on the robot may exceed a fused length by a little: clip within tol
    bad = (value < 0) | (value > total * (1 + tol)) | ((value == 0) & (not allow_zero))
    if np.any(bad):
        k = int(np.argmax(bad))
        hint = ""
        if value[k] > total:  # usually a rest length read from poses of a robot the actuators compress
            hint = (
                "; if that length was estimated from the poses, give the measured one "
                "(KinematicFusion(total_length=...) or MarkerPoseExtractor(robot_length=...))"
            )
        raise ValueError(
            f"{name}[{k}] = {float(value[k])!r} m lies beyond the robot (total rest length {total:g} m){hint}"
        )


class Actuation(BaseEstimator, ABC):
    """Base of the actuation terms: ``A(q; theta, d) u`` on the modelled strains of a segmentation.

    ``fit(kinematics)`` sets the segmentation; then ``n_inputs_`` (p),
    ``gain_names_`` (the linear parameters theta identified with the Lagrangian,
    possibly none) and ``offset_names_`` (nonlinear parameters, possibly none).
    """

    #: read by validate_parameters in fit (and by model files); a subclass lists its parameters
    _parameter_constraints: dict = {}
    #: lower bound of every identified gain (0: gains are positive by design)
    gain_lower_bound = 0.0
    #: the layout type written in layouts and model files ("identity", "tendon", "pressure", "linear")
    kind: str = ""

    @property
    def is_identity(self) -> bool:
        """True when the inputs are the generalised forces themselves (``A = I``)."""
        return self.kind == "identity"

    @property
    def linear_in_inputs(self) -> bool:
        """True when the forces are ``A(q) u`` (linear in the inputs); False for servo-wound tendons."""
        return True

    def fit(self, kinematics: PlanarPCS) -> Actuation:
        """Take the segmentation the inputs act on.

        Parameters
        ----------
        kinematics : PlanarPCS
            Segmentation and modelled strains (the data's).

        Returns
        -------
        self
        """
        validate_parameters(self)
        if not isinstance(kinematics, PlanarPCS):
            raise ValueError(f"kinematics must be a PlanarPCS; got {type(kinematics).__name__}")
        self.kinematics_ = kinematics
        self.__dict__.pop("_arrays_cache", None)
        arrays = self._arrays
        self.n_inputs_ = int(arrays["n_inputs"])
        self.gain_names_ = list(arrays["gain_names"])
        self.offset_names_ = list(arrays["offset_names"])
        self.gains_ = np.asarray(arrays["gains"], dtype=float)
        self.offsets_ = np.asarray(arrays["offsets"], dtype=float)
        return self

    @property
    def _arrays(self) -> dict[str, Any]:
        """Structure of the map on the fitted segmentation (rebuilt after loading a model file)."""
        cached = self.__dict__.get("_arrays_cache")
        if cached is None or cached[0] is not self.kinematics_:
            cached = (self.kinematics_, self._structure(self.kinematics_))
            self.__dict__["_arrays_cache"] = cached
        return cached[1]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_arrays_cache", None)
        return state

    @abstractmethod
    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        """Validate the parameters against the segmentation; return the arrays of the map and
        ``n_inputs``, ``gain_names``, ``offset_names`` and the starting ``gains``, ``offsets``."""

    # -- parameters -----------------------------------------------------------
    @property
    def n_gains(self) -> int:
        return len(self.gain_names_)

    @property
    def n_offsets(self) -> int:
        return len(self.offset_names_)

    def offset_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Bounds of the nonlinear parameters (none by default)."""
        return np.zeros(0), np.zeros(0)

    def initial_offsets(self) -> NDArray[np.float64]:
        """Starting point of the nonlinear parameters."""
        return np.zeros(0)

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """The map's signed offsets for the nonlinear parameters ``offsets`` (default: the fitted ``offsets_``)."""
        return self.offsets_

    # -- inputs -----------------------------------------------------------------
    def check_inputs(self, u: ArrayLike, name: str = "u", t: NDArray | None = None) -> NDArray[np.float64]:
        """Validated inputs (T, p): finite, the right width, one row per time of ``t`` when it is given
        (subclasses add sign rules)."""
        arr = np.asarray(u, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != self.n_inputs_:
            raise ValueError(
                f"{name} must have shape (T, {self.n_inputs_}) (one column per actuator input of "
                f"{type(self).__name__}); got {arr.shape}"
            )
        if t is not None and arr.shape[0] != np.size(t):
            # the compiled loops read row k on [t[k], t[k+1]): a short table would be read past its end
            raise ValueError(
                f"{name} must have shape ({np.size(t)}, {self.n_inputs_}) (one row per time in t, one column per "
                f"actuator input); got shape {arr.shape}: give one row of inputs for each of the {np.size(t)} times"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf (first at sample {np.argwhere(~np.isfinite(arr))[0][0]})")
        return arr

    # -- the map ------------------------------------------------------------------
    @abstractmethod
    def parts(
        self, q: NDArray[np.float64], u: NDArray[np.float64], offsets: NDArray[np.float64] | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``A(q) u = known + linear @ gains`` on the modelled strains.

        Parameters
        ----------
        q : ndarray, shape (B, n)
            Modelled strains.
        u : ndarray, shape (B, p)
            Inputs.
        offsets : ndarray, optional
            Nonlinear parameters (default: the given or identified ones).

        Returns
        -------
        known : ndarray, shape (B, n)
        linear : ndarray, shape (B, n, n_gains)
        """

    def forces(
        self, q: ArrayLike, u: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Generalised forces ``A(q) u`` (B, n) for gains (default: given or identified) and offsets."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        u = np.atleast_2d(np.asarray(u, dtype=float))
        known, linear = self.parts(q, u, None if offsets is None else np.asarray(offsets, float))
        g = self._gains(gains)
        return known + (linear @ g if g.size else 0.0)

    def matrix(self, q: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> NDArray:
        """``A(q)`` (B, n, p) on the modelled strains."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        eye = np.eye(self.n_inputs_)
        cols = [
            self.forces(q, np.broadcast_to(eye[j], (q.shape[0], self.n_inputs_)), gains, offsets)
            for j in range(self.n_inputs_)
        ]
        return np.stack(cols, axis=-1)

    def _gains(self, gains: ArrayLike | None) -> NDArray[np.float64]:
        if gains is None:
            gains = getattr(self, "gains_", np.zeros(0))
        g = np.asarray(gains, dtype=float).reshape(-1)
        if g.size != self.n_gains:
            raise ValueError(f"gains must hold {self.n_gains} values ({self.gain_names_}); got {g.size}")
        return g

    def compiled(self, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> tuple:
        """``(kind, offsets (p,), cover (p, m), matrix (n, p))`` for the compiled forward model."""
        raise NotImplementedError(f"{type(self).__name__} has no compiled form; roll out with a solve_ivp method")

    def set_identified(self, gains: ArrayLike, offsets: ArrayLike) -> Actuation:
        """Store identified gains and offsets (``gains_``, ``offsets_``)."""
        self.gains_ = np.asarray(gains, dtype=float).reshape(-1)
        self.offsets_ = np.asarray(offsets, dtype=float).reshape(-1)
        return self

    @abstractmethod
    def describe(self, precision: int = 3) -> list[str]:
        """The map and its identified parameters as text."""

    #: the constructor parameters that describe the design (what a user knows), in :meth:`design_layout`
    _design_keys: tuple[str, ...] = ()

    def design_layout(self) -> dict[str, Any]:
        """The layout as the robot's design gives it (terminations and sides, spans), JSON-able."""
        out: dict[str, Any] = {"type": self.kind}
        for key in self._design_keys:
            out[key] = np.asarray(getattr(self, key), dtype=float).tolist()
            if key == "side":
                out[key] = [int(v) for v in out[key]]
        return out

    def input_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Bounds (lower, upper) of the inputs, or None (unbounded)."""
        return None

    def layout(self) -> dict[str, Any]:
        """The JSON-able layout (constructor parameters)."""
        return {
            "type": self.kind,
            **{k: (np.asarray(v).tolist() if v is not None else None) for k, v in self.get_params().items()},
        }


class IdentityActuation(Actuation):
    """The inputs are the generalised forces themselves: ``u`` (T, 3m), ``A = I``."""

    kind = "identity"
    _parameter_constraints: dict = {}  # no parameters

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        return {
            "n_inputs": kinematics.n_q,
            "gain_names": [],
            "offset_names": [],
            "gains": np.zeros(0),
            "offsets": np.zeros(0),
        }

    def parts(self, q, u, offsets=None):
        mask = self.kinematics_.active_mask
        return np.asarray(u, dtype=float)[:, mask], np.zeros((u.shape[0], int(mask.sum()), 0))

    def compiled(self, gains=None, offsets=None) -> tuple:
        m = self.kinematics_.n_segments
        return ACT_IDENTITY, np.zeros(0), np.zeros((0, m)), np.zeros((self.kinematics_.n_active, 0))

    def describe(self, precision: int = 3) -> list[str]:
        return ["A = I (inputs are the generalised forces)"]


#: how the offsets' outer problem weights the strains' equations (pcs_sindy.identification.variable_projection)
_WEIGHTINGS = ("residual", "none")
#: what the inputs of tendons are: tensions [N] or servo angles [deg] (displacement drive)
_DRIVES = ("tension", "displacement")


class TendonActuation(Actuation):
    """Tendons from the base to termination arc lengths, at offsets along the cross-section axis.

    Tendon k runs at the signed offset ``d_k`` from the backbone along
    ``R(theta) e_x`` from the base to arc length ``end_k``.  Inside a
    constant-strain stretch the offset curve's tangent has the constant length
    ``nu = sqrt(sigma_sh^2 + (1 + sigma_ax + d kappa)^2)``, so
    ``l_k = sum_i c_ki nu_ki`` with ``c_ki`` the rest length of segment i the
    tendon covers, and its column of ``A`` is ``-dl_k/dq`` (a tension pulls).

    Parameters
    ----------
    end : array_like, shape (p,)
        Termination arc lengths [m], in ``(0, total rest length]``.
    side : array_like of {-1, 1}, shape (p,)
        Sign of each offset (the side of the backbone the tendon runs on).
    offset : array_like, shape (p,), optional
        Offset magnitudes [m] when known; default: identified (variable
        projection, within ``(0, max_offset]``).
    max_offset : float, default 0.05
        Upper bound [m] of identified offsets.
    shared : bool, default False
        Identify one offset magnitude for all tendons (tendons routed at one
        radius).  From the seed's pose noise both are determined to a few
        tenths of a percent (docs/results.md, "Identification from actuator
        inputs"); the regressor's ``identifiability_report()`` gives each
        offset's standard error and says when the recordings do not
        determine them, when one shared offset is the remedy.
    weighting : {"residual", "none"}, default "residual"
        How the equations of the strains are weighted when the offsets are
        identified.  ``"residual"``: each by the inverse RMS of its own
        residual, iterated (feasible generalised least squares; measured best
        when the model has the robot's segments, where the residual is
        noise).  ``"none"``: plain least squares over all equations.  When
        the model is coarser than the robot (a continuum, a stiffness that
        varies along a segment) the residual is the model's own error and
        neither rule is right in general: choose by rollout score, e.g.
        ``GridSearchCV(..., scoring=rollout_r2_scorer)`` over ``actuation__weighting``
        (docs/method.md, "Actuation").
    drive : {"tension", "displacement"}, default "tension"
        What the inputs are.  ``"tension"``: tendon tensions [N].
        ``"displacement"``: servo angles [deg] winding elastic tendons on
        pulleys: the tendon is stretched by
        ``e_k = r_k u_k pi/180 + l_k(q) - l_k(0) - s_k`` (the servo takes up
        ``r u``, the body's shortening gives back ``l(0) - l(q)``) and pulls
        with ``f_k = k_k max(0, e_k)`` (slack: no force).
    stiffness : array_like, shape (p,), optional
        Tendon stiffness ``k`` [N/m] when known (displacement drive only);
        default: identified with the Lagrangian (linear gains ``k_<k>``; the
        regression then needs the robot's mass for its scale).
    pulley_radius : array_like, shape (p,), optional
        Pulley radius ``r`` [m] when known (displacement drive only); default:
        identified (variable projection, within ``(0, max_radius]``).
    slack : array_like, shape (p,), optional
        Slack ``s`` [m] of the straight robot at ``u = 0`` when known (negative:
        pretension ``-k s``; displacement drive only); default: identified
        (variable projection, within ``[-max_slack, max_slack]``).
    max_radius : float, default 0.05
        Upper bound [m] of identified pulley radii.
    max_slack : float, default 0.05
        Bound [m] of identified slacks.

    Attributes
    ----------
    offsets_ : ndarray, shape (p,) or (3p,)
        Signed offsets used (given, or identified by the regressor); for a
        displacement drive followed by the pulley radii and the slacks.
    gains_ : ndarray
        Displacement drive: the identified tendon stiffnesses (or the given ones).

    Notes
    -----
    Tension inputs are tensions [N], ``>= 0``; a negative tension raises.
    Servo angles may take either sign.  :meth:`tensions` gives the tendon
    forces of either drive.
    """

    kind = "tendon"
    _design_keys = ("end", "side")
    _parameter_constraints: dict = {
        "end": [_END],
        "side": [_SIDE],
        "offset": [None, Check(_positive_vector, "a non-empty 1-D array of finite magnitudes > 0 [m]")],
        "max_offset": [Interval(Real, 0, None, closed="neither")],
        "shared": ["boolean"],
        "weighting": [Options(_WEIGHTINGS)],
        "drive": [Options(_DRIVES)],
        "stiffness": [None, Check(_positive_vector, "a non-empty 1-D array of tendon stiffnesses > 0 [N/m]")],
        "pulley_radius": [None, Check(_positive_vector, "a non-empty 1-D array of pulley radii > 0 [m]")],
        "slack": [None, Check(_finite_vector, "a non-empty 1-D array of finite slacks [m]")],
        "max_radius": [Interval(Real, 0, None, closed="neither")],
        "max_slack": [Interval(Real, 0, None, closed="neither")],
    }

    @property
    def depends_on_q(self) -> bool:  # type: ignore[override]
        return True

    @property
    def is_displacement(self) -> bool:
        """True for servo-wound elastic tendons (inputs are servo angles)."""
        return self.drive == "displacement"

    @property
    def linear_in_inputs(self) -> bool:
        """False for a displacement drive: the tensions are ``k max(0, stretch)``, not linear in the angles."""
        return not self.is_displacement

    def input_bounds(self):
        """Tensions pull: ``[0, inf)``; servo angles are unbounded (None)."""
        if self.is_displacement:
            return None
        return np.zeros(self.n_inputs_), np.full(self.n_inputs_, np.inf)

    def __init__(
        self,
        end: ArrayLike = (),
        side: ArrayLike = (),
        offset: ArrayLike | None = None,
        max_offset: float = 0.05,
        shared: bool = False,
        weighting: str = "residual",
        drive: str = "tension",
        stiffness: ArrayLike | None = None,
        pulley_radius: ArrayLike | None = None,
        slack: ArrayLike | None = None,
        max_radius: float = 0.05,
        max_slack: float = 0.05,
    ) -> None:
        self.end = end
        self.side = side
        self.offset = offset
        self.max_offset = max_offset
        self.shared = shared
        self.weighting = weighting
        self.drive = drive
        self.stiffness = stiffness
        self.pulley_radius = pulley_radius
        self.slack = slack
        self.max_radius = max_radius
        self.max_slack = max_slack

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        end = _per_actuator(self, "end")
        p = end.size
        side = _per_actuator(self, "side", p)
        lengths = np.asarray(kinematics.segment_lengths, dtype=float)
        total = float(lengths.sum())
        _inside(end, "end", total, allow_zero=False)
        if not self.is_displacement:
            for name in ("stiffness", "pulley_radius", "slack"):
                if getattr(self, name) is not None:
                    raise InvalidParameterError.of(
                        self, name, "None with drive='tension' (a displacement-drive parameter)", getattr(self, name)
                    )
        cover = _cover(np.zeros(p), np.minimum(end, total), lengths)
        out = {"cover": cover, "side": side, "n_inputs": p, "gain_names": [], "gains": np.zeros(0)}
        # nonlinear parameters: offset magnitudes, then (displacement drive) pulley radii and slacks
        free: list[NDArray[np.bool_]] = []
        names: list[str] = []
        if self.offset is None:
            names += ["d"] if self.shared else [f"d_{k + 1}" for k in range(p)]
            d = side * min(0.01, 0.5 * self.max_offset)
            free.append(np.ones(1 if self.shared else p, dtype=bool))
        else:
            d = side * _per_actuator(self, "offset", p)
        full = [d]
        if self.is_displacement:
            for name, start, label in (
                ("pulley_radius", min(0.01, 0.5 * self.max_radius), "r"),
                ("slack", 0.0, "s"),
            ):
                if getattr(self, name) is None:
                    names += [f"{label}_{k + 1}" for k in range(p)]
                    full.append(np.full(p, start))
                else:
                    full.append(_per_actuator(self, name, p))
            if self.stiffness is None:
                out.update(gain_names=[f"k_{k + 1}" for k in range(p)], gains=np.zeros(p))
            else:
                out.update(gains=_per_actuator(self, "stiffness", p))
            out["rest"] = cover.sum(axis=1)  # l_k(0): unit tangents when straight
        out.update(offset_names=names, offsets=np.concatenate(full))
        return out

    def _free(self) -> list[tuple[slice, slice]]:
        """Pairs (slice of the parameter vector, slice of ``offsets_``) of the free nonlinear parameters."""
        p = self.n_inputs_
        pairs, k = [], 0
        if self.offset is None:
            n_d = 1 if self.shared else p
            pairs.append((slice(k, k + n_d), slice(0, p)))
            k += n_d
        if self.is_displacement:
            for j, name in ((1, "pulley_radius"), (2, "slack")):
                if getattr(self, name) is None:
                    pairs.append((slice(k, k + p), slice(j * p, (j + 1) * p)))
                    k += p
        return pairs

    def offset_bounds(self):
        lo, hi = [], []
        p = self.n_inputs_
        for par, full in self._free():
            size = par.stop - par.start
            if full.start == 0:
                lo.append(np.full(size, 1e-4 * self.max_offset))
                hi.append(np.full(size, float(self.max_offset)))
            elif full.start == p:
                lo.append(np.full(size, 1e-4 * self.max_radius))
                hi.append(np.full(size, float(self.max_radius)))
            else:
                lo.append(np.full(size, -float(self.max_slack)))
                hi.append(np.full(size, float(self.max_slack)))
        return (np.concatenate(lo), np.concatenate(hi)) if lo else (np.zeros(0), np.zeros(0))

    def offset_floor(self) -> NDArray[np.float64]:
        """Magnitudes that the relative standard errors of the nonlinear parameters never divide below.

        A slack may be identified at 0: its error is reported relative to 1 mm.
        """
        out = []
        p = self.n_inputs_
        for par, full in self._free():
            out.append(np.full(par.stop - par.start, 1e-3 if full.start == 2 * p else 0.0))
        return np.concatenate(out) if out else np.zeros(0)

    def initial_offsets(self):
        out = []
        for par, full in self._free():
            vals = self.offsets_[full]
            if full.start == 0:
                vals = np.abs(vals[: par.stop - par.start])
            out.append(vals)
        return np.concatenate(out) if out else np.zeros(0)

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """The map's nonlinear parameters for the free ones ``offsets`` (default: the fitted ``offsets_``).

        The signed offsets (p,) (sides times the magnitudes); for a displacement drive
        followed by the pulley radii and slacks (3p,).
        """
        if offsets is None or self.n_offsets == 0:
            return self.offsets_
        x = np.asarray(offsets, dtype=float)
        out = self.offsets_.copy()
        side = self._arrays["side"]
        for par, full in self._free():
            if full.start == 0:
                out[full] = side * x[par]  # one shared magnitude broadcasts
            else:
                out[full] = x[par]
        return out

    def check_inputs(self, u, name="u", t=None):
        arr = super().check_inputs(u, name, t)
        if not self.is_displacement and np.any(arr < 0):
            idx = np.argwhere(arr < 0)[0]
            when = "" if t is None else f" at t = {float(np.asarray(t)[idx[0]]):g} s"
            raise ValueError(
                f"{name}[{idx[0]}, {idx[1]}] = {float(arr[tuple(idx)])!r}{when}: tendon {idx[1]} would push; "
                "tendon tensions must be >= 0"
            )
        return arr

    def lengths(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Tendon lengths (B, p) at modelled strains ``q`` (B, n)."""
        qf = self.kinematics_.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets)[: self.n_inputs_]
        kap, sh, ax = qf[:, 0::3], qf[:, 1::3], qf[:, 2::3]
        w = 1.0 + ax[:, None, :] + d[None, :, None] * kap[:, None, :]
        return np.sum(self._arrays["cover"][None] * np.sqrt(sh[:, None, :] ** 2 + w**2), axis=-1)

    def jacobian(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """``dl/dq`` (B, p, n) on the modelled strains."""
        kin = self.kinematics_
        qf = kin.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets)[: self.n_inputs_]
        B, m = qf.shape[0], kin.n_segments
        kap, sh, ax = qf[:, 0::3], qf[:, 1::3], qf[:, 2::3]
        w = 1.0 + ax[:, None, :] + d[None, :, None] * kap[:, None, :]  # (B, p, m)
        nu = np.sqrt(sh[:, None, :] ** 2 + w**2)
        c = self._arrays["cover"][None]
        jac = np.zeros((B, self.n_inputs_, m, 3))
        jac[..., 0] = c * d[None, :, None] * w / nu
        jac[..., 1] = c * sh[:, None, :] / nu
        jac[..., 2] = c * w / nu
        return jac.reshape(B, self.n_inputs_, 3 * m)[:, :, kin.active_mask]

    def stretch(self, q: ArrayLike, u: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Displacement drive: the tendons' stretch ``r u pi/180 + l(q) - l(0) - s`` [m] (B, p), negative when slack."""
        if not self.is_displacement:
            raise ValueError("stretch needs drive='displacement' (the inputs of this TendonActuation are tensions)")
        full = self.signed_offsets(None if offsets is None else np.asarray(offsets, dtype=float))
        p = self.n_inputs_
        r, s = full[p : 2 * p], full[2 * p : 3 * p]
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return r * np.deg2rad(u) + self.lengths(q, offsets) - self._arrays["rest"] - s

    def tensions(
        self, q: ArrayLike, u: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Tendon tensions [N] (B, p): the inputs, or ``k max(0, stretch)`` for a displacement drive."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if not self.is_displacement:
            return u.copy()
        k = self._stiffness(gains)
        return k * np.maximum(self.stretch(q, u, offsets), 0.0)

    def _stiffness(self, gains: ArrayLike | None = None) -> NDArray[np.float64]:
        if self.stiffness is not None:
            return _per_actuator(self, "stiffness", self.n_inputs_)
        return self._gains(gains)

    def parts(self, q, u, offsets=None):
        jac = self.jacobian(q, offsets)
        u = np.asarray(u, dtype=float)
        if not self.is_displacement:
            known = -np.einsum("bkn,bk->bn", jac, u)
            return known, np.zeros(known.shape + (0,))
        taut = np.maximum(self.stretch(q, u, offsets), 0.0)  # (B, p)
        per_unit = -jac * taut[:, :, None]  # (B, p, n): forces per unit stiffness
        if self.stiffness is None:
            return np.zeros((jac.shape[0], jac.shape[2])), np.transpose(per_unit, (0, 2, 1))
        k = _per_actuator(self, "stiffness", self.n_inputs_)
        known = np.einsum("bkn,k->bn", per_unit, k)
        return known, np.zeros(known.shape + (0,))

    def forces(self, q, u, gains=None, offsets=None):
        """Generalised forces ``-dl/dq^T f`` (B, n) of the tensions ``f`` (:meth:`tensions`)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if not self.is_displacement:
            return super().forces(q, u, gains, offsets)
        jac = self.jacobian(q, None if offsets is None else np.asarray(offsets, float))
        return -np.einsum("bkn,bk->bn", jac, self.tensions(q, u, gains, offsets))

    def matrix(self, q: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> NDArray:
        """``A(q)`` (B, n, p): ``-dl/dq``, the forces of unit *tensions* (also for a displacement drive)."""
        if not self.is_displacement:
            return super().matrix(q, gains, offsets)
        jac = self.jacobian(q, None if offsets is None else np.asarray(offsets, float))
        return -np.transpose(jac, (0, 2, 1))

    def compiled(self, gains=None, offsets=None) -> tuple:
        full = self.signed_offsets(offsets)
        p = self.n_inputs_
        if self.is_displacement:
            drive = np.stack([self._stiffness(gains), full[p : 2 * p], full[2 * p : 3 * p]])
            return ACT_SERVO, full[:p].copy(), self._arrays["cover"].copy(), drive
        return (
            ACT_TENDON,
            full[:p].copy(),
            self._arrays["cover"].copy(),
            np.zeros((self.kinematics_.n_active, 0)),
        )

    def design_layout(self) -> dict[str, Any]:
        out = super().design_layout()
        if self.is_displacement:
            out["drive"] = "displacement"
        return out

    def describe(self, precision: int = 3) -> list[str]:
        ends = ", ".join(f"{e:.{precision}g}" for e in np.atleast_1d(np.asarray(self.end, dtype=float)))
        p = self.n_inputs_
        offs = ", ".join(f"{1e3 * d:.{precision}g}" for d in self.offsets_[:p])
        how = "identified" if self.offset is None else "given"
        out = [
            "A(q) = -dl/dq, l_k = sum_i c_ki sqrt(sh_i^2 + (1 + ax_i + d_k be_i)^2) (tendons, tensions >= 0)",
            f"tendon ends [m]: {ends}; offsets d [mm] ({how}): {offs}",
        ]
        if self.is_displacement:

            def fmt(vals, scale=1.0):
                return ", ".join(f"{scale * v:.{precision}g}" for v in vals)

            k = self._stiffness()
            out += [
                "servo-wound elastic tendons: f_k = k_k max(0, r_k u_k pi/180 + l_k(q) - l_k(0) - s_k), u in deg",
                f"stiffness k [N/m] ({'given' if self.stiffness is not None else 'identified'}): {fmt(k)}; "
                f"pulley radius r [mm]: {fmt(self.offsets_[p : 2 * p], 1e3)}; "
                f"slack s [mm]: {fmt(self.offsets_[2 * p :], 1e3)}",
            ]
        return out


class _ConstantActuation(Actuation):
    """Constant ``A`` with unknown (or given) gains on fixed entries."""

    def _entries(self, kinematics: PlanarPCS) -> tuple[list[tuple[str, NDArray[np.float64]]], int]:
        """Per gain its name and unit matrix (3m, p) over the full strains; and p."""
        raise NotImplementedError

    def _given_gains(self, n_inputs: int) -> NDArray[np.float64] | None:
        return None

    def _structure(self, kinematics):
        entries, p = self._entries(kinematics)
        mask = kinematics.active_mask
        units = np.stack([e[1][mask] for e in entries]) if entries else np.zeros((0, int(mask.sum()), p))
        given = self._given_gains(p)
        out = {"units": units, "n_inputs": p, "offset_names": [], "offsets": np.zeros(0)}
        if given is None:
            out.update(gain_names=[e[0] for e in entries], gains=np.zeros(len(entries)))
        else:
            out.update(gain_names=[], gains=given)
        return out

    def _matrix_of(self, gains: NDArray) -> NDArray[np.float64]:
        return np.einsum("j,jnp->np", gains, self._arrays["units"])

    def forces(self, q, u, gains=None, offsets=None):
        """``A u`` (B, n) for every entry's gain (default: the given or identified ones)."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        g = self.gains_ if gains is None else np.asarray(gains, dtype=float).reshape(-1)
        units = self._arrays["units"]
        if g.size != units.shape[0]:
            raise ValueError(f"gains must hold {units.shape[0]} values (one per entry of the layout); got {g.size}")
        return u @ self._matrix_of(g).T

    def parts(self, q, u, offsets=None):
        u = np.asarray(u, dtype=float)
        units_u = np.einsum("jnp,bp->bnj", self._arrays["units"], u)  # (B, n, J)
        if self.n_gains:
            return np.zeros(units_u.shape[:2]), units_u
        return units_u @ self.gains_, np.zeros(units_u.shape[:2] + (0,))

    def compiled(self, gains=None, offsets=None) -> tuple:
        g = self.gains_ if gains is None else np.asarray(gains, dtype=float)
        m = self.kinematics_.n_segments
        return ACT_CONSTANT, np.zeros(0), np.zeros((0, m)), np.ascontiguousarray(self._matrix_of(g))


class PressureActuation(_ConstantActuation):
    """Pressure chambers spanning arc-length intervals on either side of the backbone.

    Chamber k over ``[start_k, end_k]`` on side ``side_k`` exerts a bending
    moment ``side_k g^b_k p_k`` and an axial force ``g^a_k p_k`` along its span;
    by virtual work its columns are ``A[kappa_i, k] = side_k g^b_k c_ki`` and
    ``A[sigma_ax,i, k] = g^a_k c_ki`` with ``c_ki`` the span's overlap with segment i.

    Parameters
    ----------
    start, end : array_like, shape (p,)
        Arc lengths [m] of each chamber's ends.
    side : array_like of {-1, 1}, shape (p,)
        Side of the backbone (a chamber on side +1 bends towards positive curvature).
    bending_gain, axial_gain : array_like, shape (p,), optional
        Gains [m^3], [m^2] when known; default: identified (then the regression
        needs the robot's mass for its scale, see the module docstring).

    Notes
    -----
    Inputs are gauge pressures [Pa] of either sign.
    """

    kind = "pressure"
    _design_keys = ("start", "end", "side")
    _parameter_constraints: dict = {
        "start": [Check(_non_negative_vector, f"{_ARC_LENGTHS} >= 0 [m]")],
        "end": [_END],
        "side": [_SIDE],
        "bending_gain": [None, Check(_finite_vector, "a non-empty 1-D array of finite gains [m^3]")],
        "axial_gain": [None, Check(_finite_vector, "a non-empty 1-D array of finite gains [m^2]")],
    }

    def __init__(
        self,
        start: ArrayLike = (),
        end: ArrayLike = (),
        side: ArrayLike = (),
        bending_gain: ArrayLike | None = None,
        axial_gain: ArrayLike | None = None,
    ) -> None:
        self.start = start
        self.end = end
        self.side = side
        self.bending_gain = bending_gain
        self.axial_gain = axial_gain

    def _entries(self, kinematics):
        end = _per_actuator(self, "end")
        p = end.size
        start = _per_actuator(self, "start", p)
        side = _per_actuator(self, "side", p)
        if np.any(start >= end):
            k = int(np.argmax(start >= end))
            want = f"below end, chamber by chamber (start[{k}] = {start[k]:g} >= end[{k}] = {end[k]:g})"
            raise InvalidParameterError.of(self, "start", want, self.start)
        lengths = np.asarray(kinematics.segment_lengths, dtype=float)
        total = float(lengths.sum())
        _inside(start, "start", total, allow_zero=True)
        _inside(end, "end", total, allow_zero=False)
        if (self.bending_gain is None) != (self.axial_gain is None):
            like = "None like bending_gain" if self.bending_gain is None else "given like bending_gain"
            want = f"{like} (give both gains, or neither: identified)"
            raise InvalidParameterError.of(self, "axial_gain", want, self.axial_gain)
        cover = _cover(start, np.minimum(end, total), lengths)  # (p, m)
        out = []
        for kind, row in (("b", 0), ("a", 2)):
            for k in range(p):
                unit = np.zeros((3 * lengths.size, p))
                unit[row::3, k] = cover[k] * (side[k] if kind == "b" else 1.0)
                out.append((f"g{kind}_{k + 1}", unit))
        return out, p

    def _given_gains(self, n_inputs):
        if self.bending_gain is None:
            return None
        gb = _per_actuator(self, "bending_gain", n_inputs)
        ga = _per_actuator(self, "axial_gain", n_inputs)
        return np.concatenate([gb, ga])

    def describe(self, precision: int = 3) -> list[str]:
        g = self.gains_
        p = self.n_inputs_
        how = "identified" if self.n_gains else "given"
        return [
            "A = const: A[be_i, k] = side_k gb_k c_ki, A[ax_i, k] = ga_k c_ki (pressure chambers)",
            f"gains ({how}): gb [m^3] = "
            + ", ".join(f"{v:.{precision}g}" for v in g[:p])
            + "; ga [m^2] = "
            + ", ".join(f"{v:.{precision}g}" for v in g[p:]),
        ]


class LinearActuation(_ConstantActuation):
    """A constant ``A`` with a sparsity pattern: one unknown gain per nonzero entry.

    Parameters
    ----------
    pattern : array_like of bool, shape (3m, p)
        Which strains (rows, in the order ``be_1, sh_1, ax_1, be_2, ...`` of the
        data's segmentation) each input (column) acts on.  Tied to a
        segmentation: use :class:`PressureActuation` or
        :class:`TendonActuation` for layouts by arc length.
    """

    kind = "linear"
    gain_lower_bound = -np.inf
    _parameter_constraints: dict = {
        "pattern": [Check(_pattern, "a boolean (or 0/1) array of shape (3m, p) with p >= 1 (strains x inputs)")],
    }

    def __init__(self, pattern: ArrayLike = ()) -> None:
        self.pattern = pattern

    def _entries(self, kinematics):
        pat = np.asarray(self.pattern)  # its values checked by the table
        if pat.shape[0] != kinematics.n_q:
            raise ValueError(f"pattern must have shape ({kinematics.n_q}, p) (strains x inputs); got {pat.shape}")
        pat = pat.astype(bool)
        names = kinematics.strain_names()
        out = []
        for r, c in zip(*np.nonzero(pat)):
            unit = np.zeros(pat.shape)
            unit[r, c] = 1.0
            out.append((f"a_{names[r]}_{c + 1}", unit))
        return out, pat.shape[1]

    def describe(self, precision: int = 3) -> list[str]:
        return [
            "A = const (linear layout): "
            + ", ".join(f"{nm} = {v:.{precision}g}" for nm, v in zip(self.gain_names_, self.gains_))
        ]


_LEARNED_TERMS = ("u", "u*q", "pull", "pull*q")
_LEARNED_STRAINS = ("bending", "all")


def _learned_terms(value: Any) -> bool:
    if isinstance(value, str):
        return False
    try:
        terms = list(value)
    except TypeError:
        return False
    return (
        bool(terms)
        and all(isinstance(t, str) and t in _LEARNED_TERMS for t in terms)
        and ("u" in terms or "pull" in terms)
        and ("u*q" not in terms or "u" in terms)
        and ("pull*q" not in terms or "pull" in terms)
    )


class LearnedActuation(Actuation):
    """An input map of unknown layout, linear in its parameters: ``A(q) = B0 + sum_b B1_b q_b``.

    For a mechanism whose layout is not known (an unknown tendon routing, a
    servo's linkage), every input ``u_k`` may act on every chosen strain's
    equation through a small basis:

        tau_a = sum_k (g_{a,k} + sum_b g_{a,k,b} q_b) u_k
              + sum_k (h_{a,k} + sum_b h_{a,k,b} q_b) max(0, u_k)

    (term ``"u"``: the constant part; term ``"u*q"``: the part proportional to
    the modelled bending strains ``q_b``, which set the moment arms and
    directions of tendons and linkages; ``"pull"`` and ``"pull*q"`` the same
    for the positive part of the input: a one-sided mechanism such as a
    servo winding a tendon, which pulls one way and goes slack the other).
    Every term vanishes with its input, so with the inputs off the map
    vanishes and the identified model stays passive (its own stiffness and
    damping, both non-negative, are all that acts).  The gains are identified
    with the Lagrangian, so the equations are homogeneous: give the robot's
    mass (``PhysicalPCSLibrary(mass=...)``).

    Parameters
    ----------
    terms : sequence of {"u", "u*q", "pull", "pull*q"}, default ("u", "u*q")
        The basis: ``"u"`` or ``"pull"`` is required, and a ``"*q"`` term needs its constant term.
    strains : {"bending", "all"}, default "bending"
        The equations the inputs act on: the modelled bending strains' (a
        tendon or a servo mostly bends a slender robot; fewer gains) or every
        modelled strain's (when the inputs also stretch or shear it).

    Attributes
    ----------
    gains_ : ndarray
        The identified gains, named by ``gain_names_`` (``a_<strain>_u<k>`` and
        ``a_<strain>_u<k>_<strain b>``).

    Notes
    -----
    Inputs are in the user's units (servo angles, pressures, ...), of either
    sign.  For a displacement drive with slack (a tendon that stops pulling)
    the affine map is the first-order picture; if the layout is known,
    :class:`TendonActuation` with ``drive="displacement"`` models the slack.
    """

    kind = "learned"
    gain_lower_bound = -np.inf
    _parameter_constraints: dict = {
        "terms": [
            Check(
                _learned_terms,
                f"a non-empty sequence of terms from {_LEARNED_TERMS} with 'u' or 'pull' (and each '*q' term's own)",
            )
        ],
        "strains": [Options(_LEARNED_STRAINS)],
        "n_inputs": [Interval(Integral, 1, None, closed="left")],
    }
    depends_on_q = True

    def __init__(self, n_inputs: int = 1, terms: Any = ("u", "u*q"), strains: str = "bending") -> None:
        self.n_inputs = n_inputs
        self.terms = terms
        self.strains = strains

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        p = int(self.n_inputs)
        names = kinematics.strain_names(active_only=True)
        n = len(names)
        mask = kinematics.active_mask
        kinds = np.tile([0, 1, 2], kinematics.n_segments)[mask]
        rows = np.flatnonzero(kinds == 0) if self.strains == "bending" else np.arange(n)
        if not np.any(kinds == 0):
            raise ValueError(
                "LearnedActuation needs a modelled bending strain (its rows with strains='bending', its "
                f"'u*q' terms); the segmentation models {names}"
            )
        bends = np.flatnonzero(kinds == 0)
        terms = list(self.terms)
        index, gain_names = [], []
        for a in rows:
            for k in range(p):
                for part, (const, slope, label) in enumerate((("u", "u*q", "u"), ("pull", "pull*q", "pull"))):
                    if const not in terms:
                        continue
                    index.append((a, k, -1, part))
                    gain_names.append(f"a_{names[a]}_{label}{k + 1}")
                    if slope in terms:
                        for b in bends:
                            index.append((a, k, b, part))
                            gain_names.append(f"a_{names[a]}_{label}{k + 1}_{names[b]}")
        return {
            "n_inputs": p,
            "gain_names": gain_names,
            "gains": np.zeros(len(gain_names)),
            "offset_names": [],
            "offsets": np.zeros(0),
            "index": np.asarray(index, dtype=int).reshape(-1, 4),
            "n": n,
        }

    def parts(self, q, u, offsets=None):
        q = np.atleast_2d(np.asarray(q, dtype=float))
        u = np.atleast_2d(np.asarray(u, dtype=float))
        idx = self._arrays["index"]
        B, n = q.shape[0], self._arrays["n"]
        inputs = np.stack([u, np.maximum(u, 0.0)])  # (2, B, p): the inputs and their positive parts
        vals = inputs[idx[:, 3], :, idx[:, 1]].T  # (B, J)
        mult = idx[:, 2] >= 0
        vals[:, mult] *= q[:, idx[mult, 2]]
        linear = np.zeros((B, n, idx.shape[0]))
        linear[:, idx[:, 0], np.arange(idx.shape[0])] = vals
        return np.zeros((B, n)), linear

    @property
    def linear_in_inputs(self) -> bool:
        """False with ``"pull"`` terms (the positive part of an input is not linear in it)."""
        return "pull" not in list(self.terms)

    def compiled(self, gains=None, offsets=None) -> tuple:
        g = self._gains(gains)
        idx = self._arrays["index"]
        n, p = self._arrays["n"], self.n_inputs_
        block = p * (1 + n)
        amat = np.zeros((n, 2 * block))  # [B0 | B1] of the inputs, then of their positive parts
        for (a, k, b, part), gj in zip(idx, g, strict=True):
            col = k if b < 0 else p + k * n + b
            amat[a, part * block + col] += gj
        return ACT_AFFINE, np.zeros(0), np.zeros((0, self.kinematics_.n_segments)), amat

    def describe(self, precision: int = 3) -> list[str]:
        body = ", ".join(f"{nm} = {v:.{precision}g}" for nm, v in zip(self.gain_names_, self.gains_, strict=True))
        return [
            "tau = sum_k (a_k + sum_b a_k,b q_b) u_k [+ the same in max(0, u_k)] (learned, zero with the inputs off)",
            f"gains: {body}",
        ]

    def layout(self) -> dict[str, Any]:
        return {"type": self.kind, "n_inputs": int(self.n_inputs), "terms": list(self.terms), "strains": self.strains}

    def design_layout(self) -> dict[str, Any]:
        return self.layout()


def actuation_from_layout(layout: dict[str, Any] | None) -> Actuation:
    """An actuation term from a JSON-able layout (``{"type": "tendon", "end": [...], "side": [...]}`` ...).

    ``None`` or ``{"type": "identity"}`` gives :class:`IdentityActuation`.
    """
    if layout is None:
        return IdentityActuation()
    if not isinstance(layout, dict) or "type" not in layout:
        raise ValueError(f"layout must be a dict with a 'type'; got {layout!r}")
    kind = layout["type"]
    kwargs = {k: v for k, v in layout.items() if k != "type"}
    classes = {
        "identity": IdentityActuation,
        "tendon": TendonActuation,
        "pressure": PressureActuation,
        "linear": LinearActuation,
        "learned": LearnedActuation,
    }
    if kind not in classes:
        raise ValueError(f"layout type must be one of {sorted(classes)}; got {kind!r}")
    try:
        return classes[kind](**kwargs)
    except TypeError as err:
        raise ValueError(f"layout of type {kind!r} has unknown keys: {err}") from None
