"""Trajectory containers, task-space metrics and the PAC kinematic simulator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pcs_sindy.core import (
    PoseTrajectory,
    StrainTrajectory,
    as_pose_trajectories,
    as_strain_trajectories,
    distributed_errors,
    end_effector_errors,
    forward_kinematics,
)
from pcs_sindy.simulation.pac import PACRobot, pac_forward_kinematics


def test_pose_trajectory_validates_and_builds_time():
    poses = np.zeros((5, 4, 3))
    traj = PoseTrajectory(poses, dt=0.01)
    np.testing.assert_allclose(traj.t, [0, 0.01, 0.02, 0.03, 0.04])
    assert traj.n_markers == 3 and len(traj) == 5
    with pytest.raises(ValueError, match="poses must have shape"):
        PoseTrajectory(np.zeros((5, 4)), dt=0.01)
    bad = poses.copy()
    bad[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match="frame 2, marker 1"):
        PoseTrajectory(bad, dt=0.01)
    with pytest.raises(ValueError, match="strictly increasing"):
        PoseTrajectory(poses, t=[0, 1, 1, 2, 3])
    with pytest.raises(ValueError, match=r"t must have shape \(5,\)"):
        PoseTrajectory(poses, t=[0, 1, 2])


def test_strain_trajectory_carries_segmentation():
    q = np.zeros((4, 6))
    traj = StrainTrajectory(q, dt=1e-3, segment_lengths=[0.07, 0.1])
    assert traj.segment_lengths == (0.07, 0.1)
    assert traj.poses([0.17]).shape == (4, 1, 3)
    with pytest.raises(ValueError, match=r"q must have shape \(T, 3\)"):
        StrainTrajectory(q, dt=1e-3, segment_lengths=[0.1])
    with pytest.raises(ValueError, match="qd must have the shape"):
        StrainTrajectory(q, dt=1e-3, segment_lengths=[0.07, 0.1], qd=np.zeros((4, 3)))


def test_coercion_of_recordings():
    arr = np.zeros((3, 5, 3))
    assert len(as_pose_trajectories(arr)) == 1
    assert len(as_pose_trajectories(np.zeros((2, 3, 5, 3)))) == 2
    with pytest.raises(ValueError, match=r"X\[1\]"):
        as_pose_trajectories([arr, np.zeros((3, 5))])
    with pytest.raises(ValueError, match="StrainTrajectory"):
        as_strain_trajectories([np.zeros((3, 3))])


def test_metrics_closed_form():
    truth = np.zeros((10, 4, 3))
    est = truth.copy()
    est[..., 0] += 3e-3  # constant 3 mm offset in x
    est[..., 1] += 4e-3  # and 4 mm in y -> 5 mm
    est[..., 2] += 0.1 + 2 * np.pi  # a full turn is not an error
    ep, eth = distributed_errors(est, truth)
    assert ep == pytest.approx(5e-3) and eth == pytest.approx(0.1)
    est[:, -1, 0] += 1.0
    ep_ee, _ = end_effector_errors(est, truth)
    assert ep_ee == pytest.approx(np.hypot(1.003, 4e-3))
    with pytest.raises(ValueError, match="same shape"):
        distributed_errors(est[:, :2], truth)


def test_pac_reduces_to_pcs_without_affine_term():
    s = np.linspace(0, 0.15, 21)
    cfg = np.array([[15.0, 0.0, 0.1, -0.05], [0.0, 0.0, -0.2, 0.2]])
    np.testing.assert_allclose(
        pac_forward_kinematics(cfg, 0.15, s), forward_kinematics(cfg[:, [0, 2, 3]], [0.15], s), atol=1e-14
    )


def test_pac_matches_integrated_backbone():
    c0, c1, sh, ax = 12.0, -300.0, 0.15, -0.1
    s = np.linspace(0, 0.15, 21)

    def rhs(v, y):
        th = c0 * v + 0.5 * c1 * v * v
        return [np.cos(th) * sh - np.sin(th) * (1 + ax), np.sin(th) * sh + np.cos(th) * (1 + ax)]

    ref = solve_ivp(rhs, (0, 0.15), [0, 0], t_eval=s, rtol=1e-12, atol=1e-14, method="DOP853").y.T
    out = PACRobot(0.15).forward_kinematics([c0, c1, sh, ax], s)
    np.testing.assert_allclose(out[:, :2], ref, atol=1e-11)
    np.testing.assert_allclose(out[:, 2], c0 * s + 0.5 * c1 * s * s)


def test_pac_bad_input():
    with pytest.raises(ValueError, match="config"):
        pac_forward_kinematics([1, 2, 3], 0.15, [0.1])
    with pytest.raises(ValueError, match="length"):
        PACRobot(-1.0)
