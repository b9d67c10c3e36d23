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
from numbers import Real
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
    "actuation_from_layout",
    "ACT_IDENTITY",
    "ACT_TENDON",
    "ACT_CONSTANT",
]

#: kinds of the compiled input map (see :meth:`Actuation.compiled`)
ACT_IDENTITY, ACT_TENDON, ACT_CONSTANT = 0, 1, 2


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
        """Validated inputs (T, p): finite, the right width (subclasses add sign rules)."""
        arr = np.asarray(u, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != self.n_inputs_:
            raise ValueError(
                f"{name} must have shape (T, {self.n_inputs_}) (one column per actuator input of "
                f"{type(self).__name__}); got {arr.shape}"
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

    Attributes
    ----------
    offsets_ : ndarray, shape (p,)
        Signed offsets used (given, or identified by the regressor).

    Notes
    -----
    Inputs are tensions [N], ``>= 0``; a negative tension raises.
    """

    kind = "tendon"
    _design_keys = ("end", "side")
    depends_on_q = True
    _parameter_constraints: dict = {
        "end": [_END],
        "side": [_SIDE],
        "offset": [None, Check(_positive_vector, "a non-empty 1-D array of finite magnitudes > 0 [m]")],
        "max_offset": [Interval(Real, 0, None, closed="neither")],
        "shared": ["boolean"],
        "weighting": [Options(_WEIGHTINGS)],
    }

    def input_bounds(self):
        """Tensions pull: ``[0, inf)``."""
        return np.zeros(self.n_inputs_), np.full(self.n_inputs_, np.inf)

    def __init__(
        self,
        end: ArrayLike = (),
        side: ArrayLike = (),
        offset: ArrayLike | None = None,
        max_offset: float = 0.05,
        shared: bool = False,
        weighting: str = "residual",
    ) -> None:
        self.end = end
        self.side = side
        self.offset = offset
        self.max_offset = max_offset
        self.shared = shared
        self.weighting = weighting

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        end = _per_actuator(self, "end")
        p = end.size
        side = _per_actuator(self, "side", p)
        lengths = np.asarray(kinematics.segment_lengths, dtype=float)
        total = float(lengths.sum())
        _inside(end, "end", total, allow_zero=False)
        out = {
            "cover": _cover(np.zeros(p), np.minimum(end, total), lengths),
            "side": side,
            "n_inputs": p,
            "gain_names": [],
            "gains": np.zeros(0),
        }
        if self.offset is None:
            names = ["d"] if self.shared else [f"d_{k + 1}" for k in range(p)]
            out.update(offset_names=names, offsets=side * min(0.01, 0.5 * self.max_offset))
        else:
            mag = _per_actuator(self, "offset", p)
            out.update(offset_names=[], offsets=side * mag)
        return out

    def offset_bounds(self):
        p = self.n_offsets
        return np.full(p, 1e-4 * self.max_offset), np.full(p, float(self.max_offset))

    def initial_offsets(self):
        return np.abs(self.offsets_[: self.n_offsets]).copy()

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Signed offsets: the sides times the magnitudes ``offsets`` (default: the fitted ``offsets_``)."""
        if offsets is None or self.n_offsets == 0:
            return self.offsets_
        return self._arrays["side"] * np.asarray(offsets, dtype=float)  # one shared magnitude broadcasts

    def check_inputs(self, u, name="u", t=None):
        arr = super().check_inputs(u, name, t)
        if np.any(arr < 0):
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
        d = self.signed_offsets(offsets)
        kap, sh, ax = qf[:, 0::3], qf[:, 1::3], qf[:, 2::3]
        w = 1.0 + ax[:, None, :] + d[None, :, None] * kap[:, None, :]
        return np.sum(self._arrays["cover"][None] * np.sqrt(sh[:, None, :] ** 2 + w**2), axis=-1)

    def jacobian(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """``dl/dq`` (B, p, n) on the modelled strains."""
        kin = self.kinematics_
        qf = kin.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets)
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

    def parts(self, q, u, offsets=None):
        jac = self.jacobian(q, offsets)
        known = -np.einsum("bkn,bk->bn", jac, np.asarray(u, dtype=float))
        return known, np.zeros(known.shape + (0,))

    def compiled(self, gains=None, offsets=None) -> tuple:
        return (
            ACT_TENDON,
            self.signed_offsets(offsets).copy(),
            self._arrays["cover"].copy(),
            np.zeros((self.kinematics_.n_active, 0)),
        )

    def describe(self, precision: int = 3) -> list[str]:
        ends = ", ".join(f"{e:.{precision}g}" for e in np.atleast_1d(np.asarray(self.end, dtype=float)))
        offs = ", ".join(f"{1e3 * d:.{precision}g}" for d in self.offsets_)
        how = "identified" if self.n_offsets else "given"
        return [
            "A(q) = -dl/dq, l_k = sum_i c_ki sqrt(sh_i^2 + (1 + ax_i + d_k be_i)^2) (tendons, tensions >= 0)",
            f"tendon ends [m]: {ends}; offsets d [mm] ({how}): {offs}",
        ]


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
    }
    if kind not in classes:
        raise ValueError(f"layout type must be one of {sorted(classes)}; got {kind!r}")
    try:
        return classes[kind](**kwargs)
    except TypeError as err:
        raise ValueError(f"layout of type {kind!r} has unknown keys: {err}") from None
