"""The rest length: carried from the extractor to the fusion, or estimated without the stretch bias."""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core import Camera, PlanarPCS, PoseTrajectory, forward_kinematics
from pcs_sindy.fusion import KinematicFusion, estimate_total_length
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.pipeline import estimate_rest_length
from pcs_sindy.simulation import get_scenario
from pcs_sindy.simulation.dynamics import PCSRobot
from pcs_sindy.simulation.rendering import render_frames
from pcs_sindy.vision import MarkerPoseExtractor


def test_two_segment_rest_length_within_half_a_percent() -> None:
    data = get_scenario("two_segment").generate(seed=0)
    poses = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    est = estimate_rest_length(poses, [r.tau for r in data.train], jackknife=False)
    assert abs(est.kinematic_length / 0.17 - 1) > 0.005  # the median deformed length is biased: the test has teeth
    assert abs(est.total_length / 0.17 - 1) < 0.005
    np.testing.assert_allclose(est.segment_lengths, [0.07, 0.1], rtol=0.01)
    assert est.fusion.total_length_ == est.total_length and "corrected" in est.fusion.total_length_source_
    assert np.all(np.abs(est.regressor.rest_strain_[2::3]) < 1e-3)  # refitted: nothing left to absorb


def test_rest_length_needs_a_model_with_axial_rest_strains() -> None:
    data = get_scenario("one_segment").generate(seed=0, n_train=2, validation=False)
    poses = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    taus = [r.tau for r in data.train]
    for rest in (False, ("be", "sh")):
        with pytest.raises(ValueError, match="axial rest strains"):
            estimate_rest_length(
                poses, taus, regressor=EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(rest_strain=rest))
            )
    with pytest.raises(ValueError, match="one array per recording"):
        estimate_rest_length(poses, taus[:1])


def soft_hanging_robot(n_rec: int = 4, n_frames: int = 300) -> tuple[list[PoseTrajectory], list[np.ndarray], float]:
    """A one-segment robot that gravity stretches by 3 % when it hangs, bent (only) by held random torques."""
    robot = PCSRobot((0.1,), density=1070.0, youngs_modulus=1734.0, shear_modulus=1e3, damping=[1e-5, 0.15, 0.15])
    hanging = float(-(robot.gravity_forces(np.zeros(3)) / robot.stiffness)[2])
    rng = np.random.default_rng(0)
    targets = rng.uniform(-1, 1, (n_frames // 10, n_rec, 3)) * np.array([60.0, 0.3, 0.3])
    tau = robot.elastic_forces(targets) + robot.gravity_forces(targets)
    tau[..., 1:] = 0.0  # no shear or axial actuation: gravity stretches it
    tau = np.repeat(tau, 10, axis=0)
    t = np.arange(n_frames) * 1e-3
    runs = robot.simulate(np.zeros((n_rec, 3)), np.zeros((n_rec, 3)), t, tau)
    s = PlanarPCS((0.1,)).marker_arc_lengths(20)
    return (
        [PoseTrajectory(forward_kinematics(r.q, (0.1,), s), t=t) for r in runs],
        list(tau.transpose(1, 0, 2)),
        hanging,
    )


def test_robot_stretched_by_gravity_within_one_percent() -> None:
    poses, taus, hanging = soft_hanging_robot()
    assert 0.025 < hanging < 0.035
    est = estimate_rest_length(poses, taus)
    assert est.kinematic_length / 0.1 - 1 > 0.02  # poses alone read the stretch as length
    assert abs(est.total_length / 0.1 - 1) < 0.01
    assert np.isfinite(est.std) and est.std < 0.005 * 0.1


def test_rest_length_travels_from_the_extractor_to_the_fusion() -> None:
    lengths = (0.05, 0.05)
    s = PlanarPCS(lengths).marker_arc_lengths(10)
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, (12, 6)) * np.array([20.0, 0.05, 0.2] * 2)
    q[0] = 0.0
    q[1:, 2::3] = np.abs(q[1:, 2::3])  # stretched in every frame but the straight reference frame
    poses = forward_kinematics(q, lengths, s)
    hidden = Camera(3000.0, (320.0, 90.0), (640, 480), angle=0.2)
    frames = render_frames(poses, hidden, marker_size=(0.008, 0.002))
    traj = MarkerPoseExtractor(camera=None, robot_length=0.1, fps=100.0, progress=False).transform([frames])[0]
    assert traj.metadata["rest_length"] == 0.1
    carried = KinematicFusion(threshold=0.5).fit([traj])
    assert carried.total_length_ == 0.1 and "metadata" in carried.total_length_source_
    assert estimate_total_length([carried._chains([traj])[1][0]]) > 0.105  # without it: long by the stretch
    assert KinematicFusion(total_length=0.12).fit([traj]).total_length_ == 0.12  # an explicit length wins
    other = PoseTrajectory(traj.poses, traj.t, metadata={"rest_length": 0.11})
    with pytest.raises(ValueError, match="different rest lengths"):
        KinematicFusion().fit([traj, other])


def test_correct_rest_length_closed_form() -> None:
    lengths = (0.07, 0.1)
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, (50, 6)) * np.array([30.0, 0.05, 0.05] * 2)
    q[:, 2::3] += 0.02  # a mean stretch of 2 %: the median deformed length reads ~2 % long
    poses = forward_kinematics(q, lengths, PlanarPCS(lengths).marker_arc_lengths(20))
    fusion = KinematicFusion().fit([poses])
    e = fusion.total_length_ / 0.17 - 1
    assert 0.01 < e < 0.03 and fusion.total_length_std_ > 0
    rest = np.zeros(3 * fusion.n_segments_)
    rest[2::3] = -e / (1 + e)  # what an identified model reports for that length error
    fusion.correct_rest_length(rest, rest_strain_std=1e-4)
    assert fusion.total_length_ == pytest.approx(0.17, rel=1e-12)
    assert fusion.marker_arc_lengths_[-1] == pytest.approx(0.17, rel=1e-12)
    assert np.sum(fusion.segment_lengths_) == pytest.approx(0.17, rel=1e-12)
    with pytest.raises(ValueError, match="rest_strain"):
        fusion.correct_rest_length(np.zeros(2))
    with pytest.raises(ValueError, match="no length error"):
        fusion.correct_rest_length(np.full(3 * fusion.n_segments_, 0.9))
