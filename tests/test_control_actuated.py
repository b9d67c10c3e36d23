"""Tip regulation through actuators: identified tendon and chamber models against the ground truth.

Truths used: the ground-truth simulator's statics (its own tendon and chamber
forces, equilibria under held inputs), eigenvalues of the linearised model's
matrix pencil computed independently (scipy's generalised eigenproblem), and
closed forms of the scaling rules.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg as sla

from pcs_sindy.control import TipRegulator, closed_loop
from pcs_sindy.control.closed_loop import plant_equilibrium
from pcs_sindy.control.gains import discretise, force_scales
from pcs_sindy.control.models import STRAIN_RANGE_MARGIN, Linearisation, linearise, strain_limits
from pcs_sindy.core import PoseTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.models import TendonActuation
from pcs_sindy.simulation import get_scenario


def true_tendon_model(robot, offset=0.015):
    """The simulator's parameters on its segmentation, tendons (the package's map) at ``offset``."""
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    coef = lib.coefficients_from_parameters(
        robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
    )
    layout = robot.actuation.layout()
    act = TendonActuation(layout["end"], layout["side"], offset=[offset] * 4).fit(lib.forward_model(coef).kinematics)
    return lib.forward_model(coef, actuation=act)


def tip_of(robot, q):
    return robot.kinematics.forward_kinematics(q, [robot.kinematics.total_length])[0, :2]


@pytest.fixture(scope="module")
def tendon():
    robot = get_scenario("two_segment_tendon").robot
    return robot, plant_equilibrium(robot, np.zeros(4))


# --------------------------------------------------------------------------- scaling rules
def test_force_scales_floor_a_strain_without_stiffness():
    lin = Linearisation(np.zeros(3), np.eye(3), np.diag([2.0, 0.0, 50.0]), np.eye(3), np.eye(3))
    f = force_scales(lin, np.array([60.0, 0.3, 0.3]))
    np.testing.assert_allclose(f, [120.0, 1e-3 * 120.0, 15.0])


def test_default_strain_limits_are_the_training_range_widened_by_the_margin(tendon):
    robot, _ = tendon
    fm = true_tendon_model(robot)

    class Fitted:
        strain_range_ = np.array([[-10.0, -0.1, -0.2, -5.0, -0.05, -0.1], [20.0, 0.1, 0.0, 5.0, 0.05, 0.1]])

    lim = strain_limits(Fitted(), fm)
    span = Fitted.strain_range_[1] - Fitted.strain_range_[0]
    np.testing.assert_allclose(lim[0], Fitted.strain_range_[0] - STRAIN_RANGE_MARGIN * span)
    np.testing.assert_allclose(lim[1], Fitted.strain_range_[1] + STRAIN_RANGE_MARGIN * span)


# --------------------------------------------------------------------------- gains of an under-actuated model
def test_tendon_gains_decay_at_the_open_loops_slowest_rate(tendon):
    robot, q_rest = tendon
    fm = true_tendon_model(robot)
    target = tip_of(robot, plant_equilibrium(robot, np.array([6.0, 0.0, 3.0, 0.0]), q_rest))
    dt = 1e-3
    ctrl = TipRegulator(fm, input_bounds=(0.0, 16.0), rate=10.0).start(target, np.arange(10) * dt)
    # independent: the slowest decay of M s^2 + D s + K from scipy's generalised eigenproblem
    lin = linearise(fm, ctrl.equilibrium_.q, ctrl.equilibrium_.u)
    n = lin.q.size
    Z, eye = np.zeros((n, n)), np.eye(n)
    s = sla.eigvals(np.block([[Z, eye], [-lin.stiffness, -lin.damping]]), np.block([[eye, Z], [Z, lin.mass]]))
    slowest = -np.max(s.real)
    assert 0 < slowest < 10.0  # 4 tendons, 6 strains: the cap applies
    assert ctrl.rate_ == pytest.approx(slowest, rel=1e-6)
    # the design: every pole of the linearised loop through A(q*) inside |z| = exp(-rate_ dt)
    Ad, Bd = discretise(lin, dt, lin.input_matrix)
    poles = np.linalg.eigvals(Ad - Bd @ np.hstack([ctrl.fq_, ctrl.fd_]))
    assert np.max(np.abs(poles)) <= np.exp(-ctrl.rate_ * dt) + 1e-9


# --------------------------------------------------------------------------- the measured tip
def test_the_measured_tip_error_corrects_the_true_robots_equilibrium(tendon):
    robot, q_rest = tendon
    fm = true_tendon_model(robot)
    target = tip_of(robot, plant_equilibrium(robot, np.array([6.0, 0.0, 3.0, 0.0]), q_rest))
    # bounds wide enough that the correction is not clipped: the linear map itself is checked
    ctrl = TipRegulator(fm, kp=1.0, ki=0.0, input_bounds=(-16.0, 16.0)).start(target, np.arange(10) * 1e-3)
    eq = ctrl.equilibrium_
    zero = np.zeros(eq.q.size)
    u0 = ctrl.step(0, eq.q, zero)
    np.testing.assert_allclose(u0, eq.u, atol=1e-9)  # at the planned equilibrium nothing is corrected
    delta = np.array([0.4e-3, -0.3e-3])
    u1 = ctrl.step(1, eq.q, zero, tip=target + delta)  # the camera sees the tip off by delta
    # independent: the true robot's equilibrium under the corrected inputs moves its tip back by -delta
    moved = tip_of(robot, plant_equilibrium(robot, u1, eq.q)) - tip_of(robot, plant_equilibrium(robot, u0, eq.q))
    np.testing.assert_allclose(moved, -delta, atol=0.05 * np.linalg.norm(delta))


def test_a_model_missing_by_more_than_the_band_is_corrected_once_the_tip_rests(tendon):
    robot, q_rest = tendon
    wrong = true_tendon_model(robot, offset=0.012)  # 20 % short moment arms: its equilibria miss
    target = tip_of(robot, plant_equilibrium(robot, np.array([9.0, 0.0, 4.0, 0.0]), q_rest))
    miss = np.linalg.norm(
        tip_of(
            robot,
            plant_equilibrium(robot, TipRegulator(wrong).start(target, np.arange(3) * 1e-3).equilibrium_.u, q_rest),
        )
        - target
    )
    assert miss > 5e-3  # beyond the default integral band
    t = np.arange(3001) * 1e-3
    band_only = closed_loop(robot, TipRegulator(wrong, input_bounds=(0, 16), integral_speed=0.0), target, t[:1501])
    rested = closed_loop(robot, TipRegulator(wrong, input_bounds=(0, 16)), target, t)
    assert band_only.final_tip_error() > 3e-3  # never within the band: the integral never starts
    assert rested.final_tip_error() < 5e-5
    assert rested.u.min() >= 0.0


# --------------------------------------------------------------------------- identified models, closed loop
@pytest.mark.slow
def test_identified_tendon_model_regulates_the_true_robot_from_state_and_noisy_poses(tendon):
    robot, q_rest = tendon
    scenario = get_scenario("two_segment_tendon")
    noise = (1e-4, np.deg2rad(0.5))
    data = scenario.generate(seed=0, noise=noise, validation=False)
    trajs = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    fusion = KinematicFusion(total_length=0.17, threshold=0.1, pose_std=noise).fit(trajs)
    lay = scenario.actuation
    model = EulerLagrangeRegressor(actuation=TendonActuation(lay["end"], lay["side"], shared=True))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # fit diagnostics are not the subject here
        model.fit(fusion.transform(trajs), [r.u for r in data.train])
    fm = model.forward_model()
    assert fm.actuation_layout == robot.actuation.layout() and fm.n_inputs == 4
    np.testing.assert_allclose(np.abs(model.actuation_.offsets_), 0.015, rtol=0.03)
    target = tip_of(robot, plant_equilibrium(robot, np.array([0.0, 8.0, 5.0, 0.0]), q_rest))
    t = np.arange(2001) * 1e-3
    for observe, tol in (("state", 5e-5), ("poses", 5e-4)):
        res = closed_loop(
            robot,
            TipRegulator(model, input_bounds=(0, 16)),
            target,
            t,
            observe=observe,
            fusion=fusion,
            pose_noise=noise,
        )
        assert res.u.min() >= 0.0, observe  # no tendon ever pushes
        err = np.linalg.norm(res.tip - target, axis=1)
        assert err[t >= 1.5].mean() < tol, observe


@pytest.mark.slow
def test_identified_chamber_model_regulates_the_true_robot():
    scenario = get_scenario("one_segment_pneumatic")
    robot = scenario.robot
    data = scenario.generate(seed=0, validation=False)
    trajs = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    fusion = KinematicFusion(total_length=0.1).fit(trajs)
    mass = float(np.sum(robot.density * robot.area * robot.segment_lengths))
    model = EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(mass=mass), actuation=scenario.actuation)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(fusion.transform(trajs), [r.u for r in data.train])
    q_rest = plant_equilibrium(robot, np.zeros(2))
    target = tip_of(robot, plant_equilibrium(robot, np.array([5e4, 1e4]), q_rest))
    res = closed_loop(robot, TipRegulator(model), target, np.arange(1501) * 1e-3, fusion=fusion)
    assert res.final_tip_error() < 2e-5
