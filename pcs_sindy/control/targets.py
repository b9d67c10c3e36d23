"""Targets as a user states them: a shape (marker poses) or the strains of another segmentation.

A set-point regulator steers the *model's* strains, whose segmentation is the
model's own (fused from the robot's markers: e.g. 70.7 / 101.0 mm where the
robot is 70 / 100 mm).  Strains of another segmentation (the plant's, a
simulator's, an earlier fusion's) are not strains of the model: given as they
are they land off target (1.7-2.1 mm at the tip for those lengths).  A target
stated as a *shape* does not depend on a segmentation:

* :class:`ShapeTarget` - poses along the robot (e.g. the base and markers of
  one camera frame, or :meth:`ShapeTarget.from_strains` for strains of any
  segmentation);
* :func:`shape_strains` - the model's strains whose shape fits it best
  (weighted least squares over positions and angles, scipy's
  ``least_squares`` with the closed-form Jacobian of
  :func:`~pcs_sindy.core.kinematics.forward_kinematics_jacobian`).

:class:`~pcs_sindy.control.regulators.SetpointRegulator` accepts a
:class:`ShapeTarget` as its reference.  Points are matched by their *relative*
arc length (fraction of the robot's length), so a model whose rest length
reads 1 % long still puts its tip on the target's tip.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from ..core.kinematics import (
    forward_kinematics,
    forward_kinematics_jacobian,
    se2_compose,
    se2_relative,
    wrap_angle,
)

__all__ = ["ShapeTarget", "shape_strains"]

#: default noise levels weighting position [m] and angle [rad] residuals (the fusion's): only their ratio matters
SHAPE_POSE_STD = (5e-4, float(np.deg2rad(1.0)))


@dataclass(frozen=True)
class ShapeTarget:
    """A target shape: poses ``[x, y, θ]`` of points along the robot.

    Parameters
    ----------
    poses : array_like, shape (P, 3)
        From the base to the tip, in the frame of the model (the base frame
        of its training poses, as the camera or the plant gives them).  When
        the first point is the base (arc length 0), the shape is first moved
        rigidly so that its base lies on the model's base.
    arc_lengths : array_like, shape (P,), optional
        Rest arc length of each point [m], increasing; default: equally spaced
        from the base (0) to the tip (``total_length``), the layout of the
        base and markers of :class:`~pcs_sindy.vision.extractor.MarkerPoseExtractor`.
    total_length : float, optional
        Rest length of the robot the shape belongs to [m]; default
        ``arc_lengths[-1]`` (1.0 when ``arc_lengths`` is not given: then only
        fractions of the length matter).

    Notes
    -----
    A point at arc length ``s`` is matched with the model's point at
    ``s / total_length`` of the model's length.
    """

    poses: Any
    arc_lengths: Any = None
    total_length: float | None = None

    def __post_init__(self) -> None:
        poses = np.array(self.poses, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != 3 or poses.shape[0] < 1 or not np.all(np.isfinite(poses)):
            raise ValueError(
                "ShapeTarget: poses must be finite [x, y, theta] rows of shape (P, 3); "
                f"got shape {np.shape(self.poses)}"
            )
        if self.arc_lengths is None:
            total = 1.0 if self.total_length is None else float(self.total_length)
            s = np.linspace(0.0, total, poses.shape[0]) if poses.shape[0] > 1 else np.array([total])
        else:
            s = np.array(self.arc_lengths, dtype=float)
            if s.shape != (poses.shape[0],) or not np.all(np.isfinite(s)) or np.any(s < 0) or np.any(np.diff(s) <= 0):
                raise ValueError(
                    f"ShapeTarget: arc_lengths must be {poses.shape[0]} finite, increasing values >= 0 (one per pose); "
                    f"got {np.asarray(self.arc_lengths).tolist()}"
                )
            total = float(s[-1]) if self.total_length is None else float(self.total_length)
        if not np.isfinite(total) or total <= 0 or s[-1] > total * (1 + 1e-12):
            raise ValueError(
                f"ShapeTarget: total_length must be a length > 0 [m] at least the last arc length ({s[-1]:g}); "
                f"got {self.total_length!r}"
            )
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "arc_lengths", s)
        object.__setattr__(self, "total_length", total)

    @classmethod
    def from_strains(
        cls,
        q: ArrayLike,
        segment_lengths: ArrayLike,
        base_pose: ArrayLike = (0.0, 0.0, 0.0),
        n_points: int = 41,
    ) -> ShapeTarget:
        """The shape of strains ``q`` (3m,) of a segmentation ``segment_lengths`` (m,), e.g. the plant's.

        Parameters
        ----------
        q : array_like, shape (3m,)
            ``[κ, σ_sh, σ_ax]`` of each segment.
        segment_lengths : array_like, shape (m,)
        base_pose : array_like, shape (3,)
            The base of that segmentation (default the origin).
        n_points : int, default 41
            Points sampled evenly along the robot, base and tip included.
        """
        lengths = np.asarray(segment_lengths, dtype=float)
        q = np.asarray(q, dtype=float)
        if lengths.ndim != 1 or lengths.size == 0 or not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
            raise ValueError(f"segment_lengths must be lengths > 0 [m]; got {np.asarray(segment_lengths).tolist()}")
        if q.shape != (3 * lengths.size,) or not np.all(np.isfinite(q)):
            raise ValueError(
                f"q must hold 3 finite strains per segment ({3 * lengths.size} for {lengths.size} segments); "
                f"got shape {q.shape}"
            )
        if isinstance(n_points, bool) or int(n_points) != n_points or n_points < 2:
            raise ValueError(f"n_points must be an integer >= 2; got {n_points!r}")
        s = np.linspace(0.0, float(lengths.sum()), int(n_points))
        return cls(forward_kinematics(q, lengths, s, base_pose), s, float(lengths.sum()))


def _modelled_kinematics(fm: Any) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    kin = fm.kinematics
    return np.asarray(kin.segment_lengths, dtype=float), np.asarray(kin.active_mask), np.asarray(kin.base_pose, float)


def shape_strains(
    model: Any,
    target: ShapeTarget,
    *,
    pose_std: tuple[float, float] = SHAPE_POSE_STD,
    q0: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], dict[str, float]]:
    """The model's modelled strains (n,) whose shape fits ``target`` best.

    Minimises ``Σ ‖p(s_k) − p*_k‖² / σ_p² + (θ(s_k) − θ*_k)² / σ_θ²`` over the
    model's modelled strains (the others held at zero) with the model's
    points at the target's relative arc lengths.

    Parameters
    ----------
    model : fitted model or ForwardModel
        Anything with ``forward_model()``, or a forward model (its ``kinematics``).
    target : ShapeTarget
    pose_std : (float, float), default (5e-4, 1°)
        Position [m] and angle [rad] scales of the residuals.
    q0 : array_like, shape (n,), optional
        Start of the fit (default straight, all zeros).

    Returns
    -------
    q : ndarray, shape (n,)
    fit : dict
        ``tip_error`` [m] (distance of the model's tip from the target's last
        point), ``max_position_error`` [m] and ``rms_position_error`` [m] over the points.
    """
    if not isinstance(target, ShapeTarget):
        raise TypeError(f"target must be a ShapeTarget; got {type(target).__name__}")
    fm = model.forward_model() if hasattr(model, "forward_model") and callable(model.forward_model) else model
    if not hasattr(fm, "kinematics"):
        raise ValueError(f"model must have a forward_model() or kinematics; {type(model).__name__} has neither")
    lengths, mask, base = _modelled_kinematics(fm)
    std = np.asarray(pose_std, dtype=float)
    if std.shape != (2,) or not np.all(np.isfinite(std)) or np.any(std <= 0):
        raise ValueError(f"pose_std must be two finite numbers > 0 (position [m], angle [rad]); got {pose_std!r}")
    n = int(mask.sum())
    start = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    if start.shape != (n,) or not np.all(np.isfinite(start)):
        raise ValueError(f"q0 must be {n} finite modelled strains; got shape {start.shape}")
    total = float(lengths.sum())
    s = np.clip(target.arc_lengths / target.total_length * total, 0.0, total)
    goal = target.poses
    if target.arc_lengths[0] == 0.0:  # the first point is the base: carry the shape onto the model's base
        goal = se2_compose(base, se2_relative(goal[0], goal))
    weights = np.array([1.0 / std[0], 1.0 / std[0], 1.0 / std[1]])
    q_full = np.zeros(mask.size)

    def residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
        q_full[mask] = x
        diff = forward_kinematics(q_full, lengths, s, base) - goal
        diff[:, 2] = wrap_angle(diff[:, 2])  # a target's angles may be wrapped differently
        return (diff * weights).ravel()

    def jacobian(x: NDArray[np.float64]) -> NDArray[np.float64]:
        q_full[mask] = x
        _, jac = forward_kinematics_jacobian(q_full, lengths, s, base)
        return (jac[:, :, mask] * weights[None, :, None]).reshape(-1, n)

    sol = least_squares(residual, start, jac=jacobian, method="lm" if 3 * s.size >= n else "trf")
    q_full[mask] = sol.x
    pose = forward_kinematics(q_full, lengths, s, base)
    dist = np.linalg.norm(pose[:, :2] - goal[:, :2], axis=1)
    fit = {
        "tip_error": float(dist[-1]),
        "max_position_error": float(dist.max()),
        "rms_position_error": float(np.sqrt(np.mean(dist**2))),
    }
    return sol.x.copy(), fit
