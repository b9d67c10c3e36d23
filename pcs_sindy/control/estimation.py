"""What the controller sees: the plant's state or its marker poses, in the model's strains.

Two observers, both giving the modelled strains ``q`` (n,) and rates ``qd`` (n,)
of the *model's* segmentation at every control step:

* :class:`StateMap` — the exact state of a plant.  If the plant and the model
  share their segmentation, the modelled strains are selected; otherwise the
  model's strains are fitted to the plant's marker poses (the least-squares
  shape fit of :class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion`, warm-started
  at the previous step) and the rates follow from the same fit linearised:
  ``qd_m = (J_m^T W J_m)^-1 J_m^T W J_p qd_p`` with ``J`` the marker-pose
  Jacobians of model and plant.  No strain of the plant is ever read as a
  strain of the model.
* :class:`PoseEstimator` — marker poses at a camera rate, each frame converted
  to model strains by a fitted ``KinematicFusion`` (:func:`frame_strains`),
  rates by a low-pass filtered difference of consecutive frames
  ``v_k = a v_{k-1} + (1 - a) (q_k - q_{k-1}) / T_c`` with
  ``a = exp(-2 pi f_c T_c)``; between frames the estimate is extrapolated,
  ``q(t) = q_k + v_k (t - t_k)`` (docs/control.md, "Observation").
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import SEED_Q_MAX, PlanarPCS
from . import _kinematics

__all__ = ["frame_strains", "same_segmentation", "StateMap", "PoseEstimator"]


def frame_strains(
    fusion: Any, frame: NDArray[np.float64], q0: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Strains (3m,) of the fusion's segmentation from the marker poses (N + 1, 3) of one frame.

    The one place the closed loop turns a camera frame into strains:
    :meth:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion.transform_frame`, the
    compiled single-frame fit, warm-started from ``q0`` (the previous frame's
    strains) when given.
    """
    return fusion.transform_frame(frame, q0)


def same_segmentation(a: PlanarPCS, b: PlanarPCS, rtol: float = 1e-9) -> bool:
    """True if two segmentations have the same segment lengths and base pose (to ``rtol``)."""
    la, lb = np.asarray(a.segment_lengths), np.asarray(b.segment_lengths)
    return bool(
        la.shape == lb.shape
        and np.allclose(la, lb, rtol=rtol, atol=0.0)
        and np.allclose(a.base_pose, b.base_pose, rtol=0.0, atol=rtol)
    )


class StateMap:
    """Exact plant state -> modelled strains and rates of a model's segmentation.

    When the segmentations differ, the model's strains minimise the weighted
    pose residual ``sum_i |W (pose_m,i(q_m) - pose_p,i(q_p))|^2`` over the
    markers (Gauss–Newton from the previous step's solution, compiled poses of
    :mod:`._kinematics`), the problem :class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion`
    solves for each camera frame.

    Parameters
    ----------
    model_kinematics, plant_kinematics : PlanarPCS
    model_marker_arc_lengths, plant_marker_arc_lengths : array_like (N + 1,)
        Rest arc lengths of the base and markers on each (used when the
        segmentations differ; the fit uses the markers, not the base).
    pose_std : (float, float)
        Weights of the pose fit (position [m], angle [rad]), as the fusion's.
    iterations : int
        Gauss–Newton iterations per step (from the previous solution moved by its rate).
    """

    def __init__(
        self,
        model_kinematics: PlanarPCS,
        plant_kinematics: PlanarPCS,
        model_marker_arc_lengths: ArrayLike,
        plant_marker_arc_lengths: ArrayLike,
        pose_std: ArrayLike = (5e-4, 0.017453292519943295),  # 0.5 mm, 1 deg
        iterations: int = 2,
    ) -> None:
        self.model = model_kinematics
        self.plant = plant_kinematics
        self.identity = same_segmentation(model_kinematics, plant_kinematics)
        self.s_model = np.ascontiguousarray(np.asarray(model_marker_arc_lengths, dtype=float)[1:])
        self.s_plant = np.ascontiguousarray(np.asarray(plant_marker_arc_lengths, dtype=float)[1:])
        if self.s_model.shape != self.s_plant.shape:
            raise ValueError(
                f"model and plant marker arc lengths must have the same length; got "
                f"{self.s_model.size + 1} and {self.s_plant.size + 1}"
            )
        std = np.asarray(pose_std, dtype=float)
        self.w = np.tile([1.0 / std[0], 1.0 / std[0], 1.0 / std[1]], self.s_model.size)
        self.iterations = int(iterations)
        P = self.s_model.size
        self._geo_m = (
            np.asarray(self.model.segment_lengths, dtype=float),
            np.asarray(self.model.base_pose, dtype=float),
        )
        self._geo_p = (
            np.asarray(self.plant.segment_lengths, dtype=float),
            np.asarray(self.plant.base_pose, dtype=float),
        )
        self._h = 1e-7 * np.tile(np.asarray(SEED_Q_MAX, dtype=float), self.model.n_segments)
        self._pose_m, self._pose_p, self._tmp = np.empty((P, 3)), np.empty((P, 3)), np.empty((P, 3))
        self._J = np.empty((3 * P, self.model.n_q))
        self._q = None
        self._qd = None

    def _plant_poses(self, q: NDArray, out: NDArray) -> NDArray:
        _kinematics.marker_poses(q, *self._geo_p, self.s_plant, out)
        return out

    def __call__(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        mask = self.model.active_mask
        if self.identity:
            return q[mask], qd[mask]
        target = self._plant_poses(q, self._pose_p).reshape(-1).copy()
        if self._q is None:
            # closed-form start: the plant's poses where the model's segments end (rest lengths scaled)
            ends = self.model.boundaries * (self.plant.total_length / self.model.total_length)
            qm = self.model.inverse_kinematics(self.plant.forward_kinematics(q, ends))
            iters = 20
        else:
            qm = self._q.copy()
            iters = self.iterations
        J = self._J
        for _ in range(iters):
            _kinematics.marker_poses(qm, *self._geo_m, self.s_model, self._pose_m)
            _kinematics.pose_jacobian(qm, *self._geo_m, self.s_model, self._h, J)
            r = (self._pose_m.reshape(-1) - target) * self.w
            qm = qm - np.linalg.lstsq(J * self.w[:, None], r, rcond=None)[0]
        _kinematics.pose_jacobian(qm, *self._geo_m, self.s_model, self._h, J)
        # rate of the plant's marker poses along qd (a directional difference), mapped by the same fit
        h = 1e-7
        vp = (
            self._plant_poses(q + h * qd, self._pose_m).reshape(-1)
            - self._plant_poses(q - h * qd, self._tmp).reshape(-1)
        ) / (2 * h)
        qdm = np.linalg.lstsq(J * self.w[:, None], vp * self.w, rcond=None)[0]
        self._q = qm
        return qm[mask].copy(), qdm[mask]


class PoseEstimator:
    """Model strains and rates from camera frames of marker poses (filtered difference, extrapolated between frames).

    Parameters
    ----------
    fusion : KinematicFusion
        Fitted; its segmentation must be the model's.
    mask : ndarray of bool (3m,)
        The model's modelled strains.
    frame_period : float
        Camera period [s].
    velocity_cutoff : float
        Cut-off frequency [Hz] of the rate filter.
    """

    def __init__(self, fusion: Any, mask: NDArray[np.bool_], frame_period: float, velocity_cutoff: float) -> None:
        self.fusion = fusion
        self.mask = mask
        self.period = float(frame_period)
        self.alpha = float(np.exp(-2.0 * np.pi * velocity_cutoff * self.period))
        self.q = None
        self.v = None
        self.t = None
        self._strains = None  # all strains of the last frame: the next fit starts there

    def update(self, t: float, frame: NDArray[np.float64]) -> None:
        """Take the frame (N + 1, 3) captured at time ``t``."""
        self._strains = frame_strains(self.fusion, frame, self._strains)
        q = self._strains[self.mask]
        if self.q is None:
            self.v = np.zeros_like(q)
        else:
            self.v = self.alpha * self.v + (1.0 - self.alpha) * (q - self.q) / (t - self.t)
        self.q, self.t = q, t

    def __call__(self, t: float) -> tuple[NDArray, NDArray]:
        """Estimate at time ``t`` (at or after the last frame)."""
        return self.q + self.v * (t - self.t), self.v.copy()
