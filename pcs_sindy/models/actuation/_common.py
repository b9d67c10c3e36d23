"""Checks and geometry shared by the built-in actuation kinds: per-actuator parameters, arc-length spans.

Holds the per-value checks of the layouts' ``_parameter_constraints`` tables and the overlap of
arc-length intervals with segments.  Knows no kind: each kind's module takes what it needs.
"""

from __future__ import annotations

from numbers import Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...core.validation import Check, Interval, InvalidParameterError, Options

__all__ = [
    "per_actuator",
    "finite_vector",
    "positive_vector",
    "non_negative_vector",
    "sides",
    "ARC_LENGTHS",
    "END",
    "SIDE",
    "segment_cover",
    "check_inside",
]


def per_actuator(obj: Any, name: str, size: int | None = None) -> NDArray[np.float64]:
    """The 1-D array of parameter ``name`` (its values checked by the table); with ``size``, one per actuator."""
    value = getattr(obj, name)
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if size is not None and arr.size != size:
        raise InvalidParameterError.of(obj, name, f"{size} values, one per actuator of end", value)
    return arr


def finite_vector(value: Any) -> bool:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    return arr.ndim == 1 and arr.size > 0 and bool(np.all(np.isfinite(arr)))


def positive_vector(value: Any) -> bool:
    return finite_vector(value) and bool(np.all(np.asarray(value, dtype=float) > 0))


def non_negative_vector(value: Any) -> bool:
    return finite_vector(value) and bool(np.all(np.asarray(value, dtype=float) >= 0))


def sides(value: Any) -> bool:
    return finite_vector(value) and bool(np.all(np.abs(np.asarray(value, dtype=float)) == 1))


ARC_LENGTHS = "a non-empty 1-D array of finite arc lengths"
#: the per-value checks of the layouts (the checks against a segmentation stay in fit)
END = Check(positive_vector, f"{ARC_LENGTHS} > 0 [m]")
SIDE = Check(sides, "a non-empty 1-D array of -1 or 1 (one side per actuator)")


def segment_cover(start: NDArray, end: NDArray, lengths: NDArray) -> NDArray[np.float64]:
    """Rest length (p, m) of segment i inside the arc-length interval ``[start_k, end_k]``."""
    bounds = np.concatenate([[0.0], np.cumsum(lengths)])
    lo = np.maximum(start[:, None], bounds[None, :-1])
    hi = np.minimum(end[:, None], bounds[None, 1:])
    return np.maximum(hi - lo, 0.0)


def check_inside(value: NDArray, name: str, total: float, *, allow_zero: bool, tol: float = 1e-6) -> None:
    """Raise unless every arc length of ``value`` lies on the robot (``[0, total]``; 0 only with ``allow_zero``)."""
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


#: how the offsets' outer problem weights the strains' equations (pcs_sindy.identification.variable_projection)
TENDON_WEIGHTINGS = ("residual", "none")
#: what the inputs of tendons are: tensions [N] or servo angles [deg] (displacement drive)
TENDON_DRIVES = ("tension", "displacement")
#: the constructor checks every tendon kind shares (offset search bound, weighting, drive and its parameters)
TENDON_DRIVE_CONSTRAINTS: dict = {
    "max_offset": [Interval(Real, 0, None, closed="neither")],
    "shared": ["boolean"],
    "weighting": [Options(TENDON_WEIGHTINGS)],
    "drive": [Options(TENDON_DRIVES)],
    "stiffness": [None, Check(positive_vector, "a non-empty 1-D array of tendon stiffnesses > 0 [N/m]")],
    "pulley_radius": [None, Check(positive_vector, "a non-empty 1-D array of pulley radii > 0 [m]")],
    "slack": [None, Check(finite_vector, "a non-empty 1-D array of finite slacks [m]")],
    "max_radius": [Interval(Real, 0, None, closed="neither")],
    "max_slack": [Interval(Real, 0, None, closed="neither")],
}


class TendonDrive:
    """What the planar and the spatial tendon kinds share: tensions or servo-wound elastic tendons.

    A mixin placed before :class:`~pcs_sindy.models.actuation.base.Actuation` in a tendon kind's
    bases.  The kind supplies ``drive``, ``stiffness``, ``stretch(q, u, offsets)`` and
    ``n_tendons_`` (the tendons: the inputs, unless servos wind several of them).
    """

    @property
    def n_tendons_(self) -> int:
        """Number of tendons (one per input unless the kind lets one servo wind several)."""
        return int(self.n_inputs_)  # type: ignore[attr-defined]

    @property
    def is_displacement(self) -> bool:
        """True for servo-wound elastic tendons (inputs are servo angles)."""
        return self.drive == "displacement"  # type: ignore[attr-defined]

    @property
    def linear_in_inputs(self) -> bool:
        """False for a displacement drive: the tensions are ``k max(0, stretch)``, not linear in the angles."""
        return not self.is_displacement

    def input_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Tensions pull: ``[0, inf)``; servo angles are unbounded (None)."""
        if self.is_displacement:
            return None
        p = self.n_inputs_  # type: ignore[attr-defined]
        return np.zeros(p), np.full(p, np.inf)

    def check_inputs(self, u: Any, name: str = "u", t: Any = None) -> NDArray[np.float64]:
        arr = super().check_inputs(u, name, t)  # type: ignore[misc]
        if not self.is_displacement and np.any(arr < 0):
            idx = np.argwhere(arr < 0)[0]
            when = "" if t is None else f" at t = {float(np.asarray(t)[idx[0]]):g} s"
            raise ValueError(
                f"{name}[{idx[0]}, {idx[1]}] = {float(arr[tuple(idx)])!r}{when}: tendon {idx[1]} would push; "
                "tendon tensions must be >= 0"
            )
        return arr

    def _stiffness(self, gains: ArrayLike | None = None) -> NDArray[np.float64]:
        """Tendon stiffnesses [N/m] (p,): given, or the identified gains."""
        if self.stiffness is not None:  # type: ignore[attr-defined]
            return per_actuator(self, "stiffness", self.n_tendons_)  # type: ignore[attr-defined]
        return self._gains(gains)  # type: ignore[attr-defined]

    def tensions(
        self, q: ArrayLike, u: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Tendon tensions [N] (B, p): the inputs, or ``k max(0, stretch)`` for a displacement drive."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if not self.is_displacement:
            return u.copy()
        return self._stiffness(gains) * np.maximum(self.stretch(q, u, offsets), 0.0)  # type: ignore[attr-defined]
