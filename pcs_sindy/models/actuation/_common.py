"""Checks and geometry shared by the built-in actuation kinds: per-actuator parameters, arc-length spans.

Holds the per-value checks of the layouts' ``_parameter_constraints`` tables and the overlap of
arc-length intervals with segments.  Knows no kind: each kind's module takes what it needs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...core.validation import Check, InvalidParameterError

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
