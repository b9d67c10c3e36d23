"""pcs_sindy.control: controllers on identified models against independent truth.

Truths used: the closed-form zero-order-hold response of a linear one-strain
plant (matrix exponential), the ground-truth simulator's statics (its own
gravity/elastic forces, not the identification side's), numpy kinematics for
the compiled poses, and brute-force sampling for the nearest reachable tip.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from pcs_sindy.control import (
    ComputedTorqueController,
    SetpointRegulator,
    StrainReference,
    TipReference,
    TipRegulator,
    _kinematics,
    closed_loop,
    equilibrium_inputs,
    tip_circle,
)
from pcs_sindy.control.closed_loop import plant_equilibrium
from pcs_sindy.control.gains import loop_poles, lqr_gains
from pcs_sindy.control.models import ActuatedModel, linearise, strain_scales
from pcs_sindy.core import PlanarPCS
from pcs_sindy.identification import PhysicalPCSLibrary
from pcs_sindy.models import CallableModel
from pcs_sindy.simulation import get_scenario


def true_model(robot):
    """The forward model with the simulator's parameters on the simulator's segmentation."""
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    coef = lib.coefficients_from_parameters(
        robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
    )
    return lib.forward_model(coef)


def statics(robot, q):
    """The simulator's own static forces G(q) + K q."""
    return robot.gravity_forces(q) + robot.elastic_forces(q)


# --------------------------------------------------------------------------- compiled kinematics
def test_compiled_poses_match_the_numpy_kinematics():
    kin = PlanarPCS((0.07, 0.1, 0.05), base_pose=(0.01, -0.02, 0.3))
    rng = np.random.default_rng(0)
    s = np.linspace(0, kin.total_length, 13)
    for q in [
        np.zeros(9),
        rng.uniform(-1, 1, 9) * np.tile([40, 0.2, 0.2], 3),
        np.array([0, 0.1, 0.1, 1e-9, 0, 0, -30, 0, -0.2]),
    ]:
        lengths, base = np.array(kin.segment_lengths), np.array(kin.base_pose)
        out = np.empty((s.size, 3))
        _kinematics.marker_poses(q, lengths, base, s, out)
        np.testing.assert_allclose(out, kin.forward_kinematics(q, s), atol=1e-14)
        tip = np.empty(3)
        _kinematics.tip_pose(q, lengths, base, tip)
        np.testing.assert_allclose(tip, kin.forward_kinematics(q, [kin.total_length])[0], atol=1e-14)
        J = np.empty((3 * s.size, 9))
        _kinematics.pose_jacobian(q, lengths, base, s, 1e-6 * np.tile([60, 0.3, 0.3], 3), J)
        np.testing.assert_allclose(J, kin.jacobian(q, s)[1].reshape(-1, 9), atol=1e-7)


# --------------------------------------------------------------------------- a linear one-strain plant
class LinearPlant:
    """m q'' + d q' + k q = u[0] on the bending strain of one segment (others held at 0), exact ZOH steps."""

    def __init__(self, m, d, k):
        self.kinematics = PlanarPCS((0.1,))
        self.n_q, self.n_inputs, self.n_segments, self.actuation = 3, 3, 1, None
        A = np.array([[0.0, 1.0], [-k / m, -d / m]])
        self._A, self._B = A, np.array([0.0, 1.0 / m])

    def advance(self, q, qd, u, dt, **integrator):
        if getattr(self, "_dt", None) != dt:
            self._E, self._dt = sla.expm(np.block([[self._A, self._B[:, None]], [np.zeros((1, 3))]]) * dt), dt
        E = self._E
        y = E[:2, :2] @ [q[0], qd[0]] + E[:2, 2] * u[0]
        return np.array([y[0], 0, 0]), np.array([y[1], 0, 0])


def linear_model(m, d, k):
    kin = PlanarPCS((0.1,), active_strains=[True, False, False])
    return CallableModel(kin, lambda q, qd: (np.array([[m]]), np.array([d * qd[0] + k * q[0]])))


def test_pid_with_feedforward_follows_the_closed_form_discrete_response():
    m, d, k, dt = 2e-6, 1e-5, 1.3e-3, 1e-3
    q_star = 12.0
    kp, ki, kd = 4e-3, 2e-2, 1e-4
    ctrl = SetpointRegulator(linear_model(m, d, k), kp=kp, ki=ki, kd=kd, integral_limit=np.inf, integral_band=np.inf)
    t = np.arange(2000) * dt
    res = closed_loop(LinearPlant(m, d, k), ctrl, [q_star], t, q0=np.zeros(3), qd0=np.zeros(3))
    # independent: x = [q, qd, z] with u = k q* + kp (q* - q) + ki z - kd qd, z+ = z + dt (q* - q)
    E = sla.expm(np.array([[0, 1, 0], [-k / m, -d / m, 1 / m], [0, 0, 0]]) * dt)
    x, z = np.zeros(2), 0.0
    expected = []
    for _ in t:
        expected.append(x[0])
        z_next = z + dt * (q_star - x[0])
        u = k * q_star + kp * (q_star - x[0]) + ki * z_next - kd * x[1]
        x, z = E[:2, :2] @ x + E[:2, 2] * u, z_next
    np.testing.assert_allclose(res.q[:, 0], expected, rtol=0, atol=1e-9 * q_star)
    assert abs(res.q[-1, 0] - q_star) < 1e-3 * q_star  # and it got there


def test_rule_gains_place_every_pole_of_the_linearisation_inside_the_prescribed_circle():
    robot = get_scenario("two_segment").robot
    fm = true_model(robot)
    q = np.array([15.0, 0.05, 0.03, -10.0, 0.02, 0.04])
    lin = linearise(fm, q)
    for rate in (4.0, 10.0):
        kp, kd = lqr_gains(lin, 1e-3, rate, 1.0, strain_scales(fm.kinematics))
        poles = loop_poles(lin, kp, np.zeros((6, 6)), kd, 1e-3)
        moving = np.sort(np.abs(poles))[:12]  # the 6 integrator poles sit at 1 without integral gain
        assert np.all(moving <= np.exp(-rate * 1e-3) + 1e-12)
    # the model's linearisation: its static stiffness is the simulator's, by central differences there
    K_true = np.stack([(statics(robot, q + 1e-6 * e) - statics(robot, q - 1e-6 * e)) / 2e-6 for e in np.eye(6)], 1)
    np.testing.assert_allclose(lin.stiffness, K_true, rtol=1e-5, atol=1e-6 * np.abs(K_true).max())
    np.testing.assert_allclose(lin.mass, robot.mass_matrix(q), rtol=1e-9, atol=1e-12 * np.abs(lin.mass).max())
    np.testing.assert_allclose(lin.damping, np.diag(robot.damping), atol=1e-9)


# --------------------------------------------------------------------------- the two-segment robot
@pytest.fixture(scope="module")
def two_segment():
    robot = get_scenario("two_segment").robot
    return robot, true_model(robot), plant_equilibrium(robot, np.zeros(6))


def test_regulation_reaches_the_equilibrium_of_the_true_statics(two_segment):
    robot, fm, q_rest = two_segment
    tau = robot.stiffness * np.array([20.0, 0.05, 0.05, -15.0, 0.05, -0.05])
    q_star = plant_equilibrium(robot, tau, q_rest)
    t = np.arange(1201) * 1e-3
    res = closed_loop(robot, SetpointRegulator(fm), q_star, t)
    assert np.all(np.abs(res.q[-1] - q_star) <= 5e-4 * np.tile([60, 0.3, 0.3], 2))
    # at rest the command is the force that holds the true robot there
    assert np.all(np.abs(res.u[-1] - statics(robot, q_star)) <= 3e-3 * np.abs(tau))
    assert res.final_tip_error() < 2e-4
    assert res.settling_time() < 1.0
    # without the model's feed-forward the integral has to find that force: far off half-way
    pid = SetpointRegulator(fm, feedforward=False, integral_limit=np.inf, integral_band=np.inf)
    pid = closed_loop(robot, pid, q_star, t)
    assert pid.tip_error[300] > 3 * res.tip_error[300]
    assert pid.settling_time() > res.settling_time()


def test_tracking_with_the_true_model_is_exact_up_to_the_hold_of_the_command(two_segment):
    robot, fm, q_rest = two_segment
    ts = np.linspace(0, 0.2, 41)
    amp = np.array([8.0, 0.02, 0.01, -6.0, 0.01, 0.02])
    q_ref = q_rest + amp * np.sin(2 * np.pi * 3 * ts)[:, None] * np.sin(np.pi * ts / 0.2)[:, None] ** 2
    errors = {}
    for law in ("pd_plus", "computed_torque"):
        for dt in (1e-3, 5e-4):
            t = np.arange(int(round(0.2 / dt)) + 1) * dt
            res = closed_loop(
                robot,
                ComputedTorqueController(fm, law=law),
                StrainReference(ts, q_ref),
                t,
                q0=q_ref[0],
                plant_step=None,
            )
            errors[law, dt] = np.abs(res.q - res.q_reference).max(axis=0) / np.tile([60, 0.3, 0.3], 2)
    # the plant integrated to 1e-9: what is left is the zero-order hold, first order in the control period
    ratio = errors["pd_plus", 5e-4] / errors["pd_plus", 1e-3]
    assert np.all((ratio > 0.45) & (ratio < 0.55))
    assert errors["pd_plus", 1e-3].max() < 5e-3
    # exact linearisation with a held command converges too, more slowly
    assert np.all(errors["computed_torque", 5e-4] < errors["computed_torque", 1e-3])


def test_tip_tracking_through_the_models_inverse_kinematics(two_segment):
    robot, fm, q_rest = two_segment
    tip0 = robot.kinematics.forward_kinematics(q_rest, [0.17])[0, :2]
    path = tip_circle(tip0 + [0, -0.02], 0.015, 1.0, start=tip0, ramp=0.3)
    t = np.arange(601) * 1e-3
    res = closed_loop(robot, ComputedTorqueController(fm), TipReference(path, sample_period=0.02), t)
    np.testing.assert_allclose(res.tip_reference, path(t))
    assert res.tip_rmse() < 4e-4
    # the reference strains hold the model's tip on the path (the inverse kinematics)
    tips = fm.kinematics.forward_kinematics(res.q_reference, [0.17])[:, 0, :2]
    assert np.abs(tips - path(t)).max() < 2e-5


# --------------------------------------------------------------------------- equilibrium inputs and tip regulation
def test_equilibrium_inputs_hold_the_true_robot_with_its_tip_at_the_target(two_segment):
    robot, fm, q_rest = two_segment
    target = robot.kinematics.forward_kinematics(q_rest, [0.17])[0, :2] + [0.03, -0.02]
    eq = equilibrium_inputs(fm, target)
    assert eq.reachable and eq.stable
    np.testing.assert_allclose(robot.kinematics.forward_kinematics(eq.q, [0.17])[0, :2], target, atol=1e-9)
    np.testing.assert_allclose(eq.u, statics(robot, eq.q), atol=1e-8)


def test_an_unreachable_tip_is_reported_with_the_nearest_reachable_one(two_segment):
    robot, fm, q_rest = two_segment
    bounds = (-0.01, 0.01)
    target = robot.kinematics.forward_kinematics(q_rest, [0.17])[0, :2] + [0.08, 0.0]
    eq = equilibrium_inputs(fm, target, bounds)
    assert not eq.reachable
    assert np.all(eq.u >= bounds[0] - 1e-12) and np.all(eq.u <= bounds[1] + 1e-12)
    # brute force: equilibria of random inputs within the bounds get no nearer (corners included)
    rng = np.random.default_rng(0)
    U = np.concatenate([rng.uniform(*bounds, (150, 6)), rng.choice(bounds, (50, 6))])
    best = min(
        np.linalg.norm(robot.kinematics.forward_kinematics(plant_equilibrium(robot, u, q_rest), [0.17])[0, :2] - target)
        for u in U
    )
    assert eq.error <= best + 1e-6
    with pytest.raises(ValueError, match="nearest reachable tip"):
        TipRegulator(fm, input_bounds=bounds).start(target, np.arange(10) * 1e-3)


def test_tip_regulation_through_tendons_never_commands_a_negative_tension():
    scenario = get_scenario("two_segment_tendon")
    robot = scenario.robot
    model = ActuatedModel(true_model(robot), robot.actuation_matrix, robot.n_inputs, (0.0, 16.0), scenario.actuation)
    q_target = plant_equilibrium(robot, np.array([0.0, 7.5, 0.0, 0.02]))
    target = robot.kinematics.forward_kinematics(q_target, [0.17])[0, :2]
    t = np.arange(2001) * 1e-3
    res = closed_loop(robot, TipRegulator(model), target, t)
    assert res.u.min() >= 0.0 and res.u.max() <= 16.0
    # two tendons slack at the target: the integral corrects through the others (active set), to the micrometre
    assert res.final_tip_error() < 2e-5
    np.testing.assert_allclose(res.tip_reference[-1], target)


# --------------------------------------------------------------------------- observation
def test_state_map_between_segmentations_is_the_pose_fit_and_its_derivative():
    from pcs_sindy.control.estimation import StateMap
    from pcs_sindy.fusion import fit_strains_least_squares

    plant, model = PlanarPCS((0.07, 0.1)), PlanarPCS((0.0712, 0.1003))
    s_p, s_m = plant.marker_arc_lengths(20), model.marker_arc_lengths(20)
    q = np.array([12.0, 0.05, 0.03, -8.0, 0.02, 0.01])
    qd = np.array([50.0, 0.1, 0.2, 30.0, 0.1, 0.3])
    qm, qdm = StateMap(model, plant, s_m, s_p)(q, qd)
    ref, _ = fit_strains_least_squares(
        plant.forward_kinematics(q, s_p)[None, 1:], model.segment_lengths, s_m[1:], qm[None] + 0.01
    )
    np.testing.assert_allclose(qm, ref[0], rtol=1e-9, atol=1e-12)
    h = 1e-6
    fd = StateMap(model, plant, s_m, s_p)(q + h * qd, qd)[0] - StateMap(model, plant, s_m, s_p)(q - h * qd, qd)[0]
    # Gauss–Newton linearisation of the fit: exact up to the (small) residual curvature term
    np.testing.assert_allclose(qdm, fd / (2 * h), rtol=1e-3)
    same, _ = StateMap(plant, plant, s_p, s_p)(q, qd)
    np.testing.assert_array_equal(same, q)


class _FakeFusion:
    """Returns the strains it was given by poses of a known segmentation (exact inverse)."""

    def __init__(self, kin, s):
        self.kin, self.s = kin, s

    def transform_frame(self, poses, q0=None):
        from pcs_sindy.fusion import fit_strains_least_squares

        start = np.zeros((1, 6)) if q0 is None else np.asarray(q0)[None]
        q, _ = fit_strains_least_squares(poses[None, 1:], self.kin.segment_lengths, self.s[1:], start)
        return q[0]


def test_pose_estimator_rates_follow_the_filtered_difference_closed_form():
    from pcs_sindy.control.estimation import PoseEstimator

    kin = PlanarPCS((0.07, 0.1))
    s = kin.marker_arc_lengths(20)
    v = np.array([20.0, 0.05, 0.1, -10.0, 0.02, 0.05])
    period, cutoff = 0.01, 10.0
    est = PoseEstimator(_FakeFusion(kin, s), np.ones(6, bool), period, cutoff)
    a = np.exp(-2 * np.pi * cutoff * period)
    for k in range(6):
        tk = k * period
        est.update(tk, kin.forward_kinematics(0.1 * v + v * tk, s))
        q, qd = est(tk + 0.004)
        np.testing.assert_allclose(qd, (1 - a**k) * v, rtol=1e-6)  # v_k = a v_k-1 + (1 - a) v from v_0 = 0
        np.testing.assert_allclose(q, 0.1 * v + v * tk + qd * 0.004, rtol=1e-6)


# --------------------------------------------------------------------------- bad input
def test_bad_input_names_the_argument(two_segment):
    robot, fm, q_rest = two_segment
    t = np.arange(20) * 1e-3
    with pytest.raises(ValueError, match=r"reference lies outside the model's strain range: be_1 = 100"):
        SetpointRegulator(fm).start([100.0, 0, 0, 0, 0, 0], t)
    with pytest.raises(ValueError, match="reference must hold the 6 modelled strains"):
        SetpointRegulator(fm).start([1.0, 0, 0], t)
    with pytest.raises(ValueError, match=r"kp must be a scalar, an \(6,\) diagonal"):
        SetpointRegulator(fm, kp=np.ones(5)).start(q_rest, t)
    with pytest.raises(ValueError, match="kd contains NaN"):
        ComputedTorqueController(fm, kd=np.nan).start(StrainReference(np.linspace(0, 1, 6), np.zeros((6, 6))), t)
    with pytest.raises(ValueError, match="t must be uniformly spaced"):
        SetpointRegulator(fm).start(q_rest, [0.0, 0.001, 0.003])
    with pytest.raises(ValueError, match="input_bounds"):
        SetpointRegulator(fm, input_bounds=(np.zeros(5), 1.0)).start(q_rest, t)
    with pytest.raises(ValueError, match="model must be a fitted identified model"):
        SetpointRegulator(object()).start(q_rest, t)
    with pytest.raises(ValueError, match="law must be one of"):
        ComputedTorqueController(fm, law="sliding").start(StrainReference(np.linspace(0, 1, 6), np.zeros((6, 6))), t)
    with pytest.raises(ValueError, match="observe must be"):
        closed_loop(robot, SetpointRegulator(fm), q_rest, t, observe="video")
    with pytest.raises(ValueError, match="observe='poses' needs fusion"):
        closed_loop(robot, SetpointRegulator(fm), q_rest, t, observe="poses")


def test_a_plant_driven_differently_from_the_model_is_rejected(two_segment):
    _, fm, q_rest = two_segment
    tendon = get_scenario("two_segment_tendon").robot
    with pytest.raises(ValueError, match=r"plant: driven by Tendons.*actuation does not match"):
        closed_loop(tendon, SetpointRegulator(fm), q_rest, np.arange(5) * 1e-3)
    one = get_scenario("one_segment").robot
    with pytest.raises(ValueError, match="plant: driven by generalised forces .* 1 segments"):
        closed_loop(one, SetpointRegulator(fm), q_rest, np.arange(5) * 1e-3)


def test_plots_draw_the_run(two_segment):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pcs_sindy.control.plots import plot_closed_loop

    robot, fm, q_rest = two_segment
    q_star = plant_equilibrium(robot, robot.stiffness * np.array([10.0, 0, 0, -5.0, 0, 0]), q_rest)
    res = closed_loop(robot, SetpointRegulator(fm), q_star, np.arange(50) * 1e-3)
    fig = plot_closed_loop(res)
    path_ax, _, strain_ax, command_ax = fig.axes[:4]
    np.testing.assert_allclose(path_ax.lines[1].get_xydata(), res.tip * 1e3)
    assert len(strain_ax.lines) == 12 and len(command_ax.lines) == 6
    plt.close(fig)


@pytest.mark.slow
def test_an_identified_model_regulates_the_true_robot_from_its_state_and_from_noisy_poses():
    from pcs_sindy.control.estimation import frame_strains
    from pcs_sindy.core import PoseTrajectory
    from pcs_sindy.fusion import KinematicFusion
    from pcs_sindy.identification import EulerLagrangeRegressor

    scenario = get_scenario("two_segment")
    robot = scenario.robot
    data = scenario.generate(seed=0, validation=False)
    trajs = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    fusion = KinematicFusion().fit(trajs)
    model = EulerLagrangeRegressor().fit(fusion.transform(trajs), [r.tau for r in data.train])
    assert not np.allclose(fusion.segment_lengths_, robot.segment_lengths)  # the state reaches it through poses
    q_rest = plant_equilibrium(robot, np.zeros(6))
    q_target = plant_equilibrium(robot, robot.stiffness * np.array([-15.0, 0.05, 0.0, 20.0, 0.0, 0.05]), q_rest)
    poses = robot.kinematics.forward_kinematics(q_target, robot.kinematics.marker_arc_lengths(20))
    t = np.arange(1501) * 1e-3
    for observe, tol in (("state", 5e-5), ("poses", 5e-4)):
        res = closed_loop(
            robot,
            SetpointRegulator(model),
            frame_strains(fusion, poses),
            t,
            observe=observe,
            fusion=fusion,
            pose_noise=(1e-4, np.deg2rad(0.5)),
        )
        err = np.linalg.norm(res.tip - poses[-1, :2], axis=1)
        assert err[t >= 1.4].mean() < tol, observe
    assert res.frames.shape == (151, 21, 3) and np.allclose(res.frame_times, t[::10])
    with pytest.raises(ValueError, match="camera_rate = 300"):
        closed_loop(
            robot,
            SetpointRegulator(model),
            frame_strains(fusion, poses),
            t,
            observe="poses",
            fusion=fusion,
            camera_rate=300.0,
        )
