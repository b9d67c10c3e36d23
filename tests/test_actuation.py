"""Actuated ground truth: tendon lengths and their map A(q), pressure chambers, energy balance, scenarios.

Independent truths: the tendon's path integrated numerically as a polyline of the offset curve
``p(s) + d R(θ(s)) e_x`` built from :func:`pcs_sindy.core.kinematics.forward_kinematics` (no closed form of
the simulator), virtual work of the chambers from the backbone's orientation and a quadrature of the
axial strain field, hand-derived columns at the straight configuration, and the energy balance
``dE/dt = q̇ᵀ A(q) u − q̇ᵀ D q̇`` along simulated trajectories.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import quad

from pcs_sindy.core import forward_kinematics
from pcs_sindy.simulation import PressureChambers, Tendons, get_scenario
from pcs_sindy.simulation.dynamics import PCSRobot

TWO = dict(
    segment_lengths=[0.07, 0.1],
    density=[1070, 1049],
    youngs_modulus=[1e4, 9e3],
    shear_modulus=[1e3, 3e3],
    damping=[3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2],
)
TENDONS = Tendons(end=[0.05, 0.07, 0.12, 0.17], offset=[0.015, -0.015, 0.01, -0.02])


def tendon_robot(**kw) -> PCSRobot:
    return PCSRobot(**{**TWO, **kw}, actuation=TENDONS)


def polyline_length(q, lengths, end, d, base_pose=(0.0, 0.0, 0.0), per_segment=2000):
    """Length of the offset curve from the base to ``end``: Richardson-extrapolated polylines.

    Segment boundaries are nodes, so the polyline error is O(h²) on each smooth piece.
    """
    bounds = np.concatenate([[0.0], np.cumsum(lengths)])

    def length(k):
        pieces = [np.linspace(a, min(b, end), k + 1) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if a < end]
        s = np.unique(np.concatenate(pieces))
        pose = forward_kinematics(q, lengths, s, base_pose)
        pts = pose[:, :2] + d * np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])], axis=1)
        return np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()

    return (4 * length(2 * per_segment) - length(per_segment)) / 3


def random_q(rng, m):
    return rng.uniform(-1, 1, 3 * m) * np.tile([40.0, 0.2, 0.2], m)


# --------------------------------------------------------------------------
# tendons
# --------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["random", "straight_segment", "straight_robot"])
def test_tendon_lengths_match_numerical_integration_of_the_offset_curve(case):
    rng = np.random.default_rng({"random": 0, "straight_segment": 1, "straight_robot": 2}[case])
    robot = tendon_robot(base_pose=(0.01, -0.02, 0.3))
    for _ in range(2):
        q = random_q(rng, 2)
        if case == "straight_segment":
            q[3] = 0.0  # κ = 0 exactly in the segment where two tendons terminate
        if case == "straight_robot":
            q[[0, 3]] = 0.0
        lengths = robot.tendon_lengths(q)
        for k, (end, d) in enumerate(zip(TENDONS.end, TENDONS.offset, strict=True)):
            ref = polyline_length(q, robot.segment_lengths, end, d, robot.base_pose)
            assert lengths[k] == pytest.approx(ref, rel=1e-9), (case, k)


def test_tendon_columns_are_minus_the_length_gradient():
    rng = np.random.default_rng(3)
    robot = tendon_robot()
    for zero_kappa in (False, True):
        q = random_q(rng, 2)
        if zero_kappa:
            q[[0, 3]] = 0.0
        A = robot.actuation_matrix(q)
        eps = 1e-6
        grad = np.array(
            [(robot.tendon_lengths(q + eps * e) - robot.tendon_lengths(q - eps * e)) / (2 * eps) for e in np.eye(6)]
        )  # (n, p)
        np.testing.assert_allclose(A, -grad, rtol=0, atol=1e-8 * np.abs(grad).max())


def test_tendon_virtual_work_against_numerically_integrated_lengths():
    # τ · δq = −Σ f_k δℓ_k with the lengths integrated numerically (independent of the closed form)
    rng = np.random.default_rng(4)
    robot = tendon_robot()
    q = random_q(rng, 2)
    f = np.array([3.0, 0.0, 7.0, 1.5])
    tau = robot.actuation_forces(q, f)
    np.testing.assert_allclose(tau, robot.actuation_matrix(q) @ f, rtol=1e-13, atol=1e-15)
    for _ in range(3):
        dq = random_q(rng, 2) / 40.0
        eps = 1e-4
        work = 0.0
        for k, (end, d) in enumerate(zip(TENDONS.end, TENDONS.offset, strict=True)):
            dl = (
                polyline_length(q + eps * dq, robot.segment_lengths, end, d)
                - polyline_length(q - eps * dq, robot.segment_lengths, end, d)
            ) / (2 * eps)
            work -= f[k] * dl
        assert tau @ dq == pytest.approx(work, rel=1e-6)


def test_tendon_columns_at_the_straight_configuration_and_terminations_inside_segments():
    # straight, unstretched: ν = 1, so −∂ℓ/∂κ_i = −d c_i, −∂ℓ/∂σ_ax,i = −c_i, no shear term,
    # with c_i the covered part of segment i (tendons ending at 50 and 120 mm end inside segments)
    robot = tendon_robot()
    A = robot.actuation_matrix(np.zeros(6))
    covered = np.array([[0.05, 0.0], [0.07, 0.0], [0.07, 0.05], [0.07, 0.1]])
    for k, d in enumerate(TENDONS.offset):
        expected = -np.array([d * covered[k, 0], 0.0, covered[k, 0], d * covered[k, 1], 0.0, covered[k, 1]])
        np.testing.assert_allclose(A[:, k], expected, rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(robot.tendon_lengths(np.zeros(6)), TENDONS.end, rtol=1e-14)
    # continuous through κ = 0
    q = np.array([0.0, 0.1, -0.05, 0.0, -0.2, 0.1])
    for h in (1e-9, -1e-9):
        bumped = q + h * np.array([1, 0, 0, 1, 0, 0])
        np.testing.assert_allclose(robot.actuation_matrix(bumped), robot.actuation_matrix(q), rtol=0, atol=1e-10)


def test_negative_tension_is_rejected_with_the_input_and_time():
    robot = tendon_robot()
    t = np.arange(6) * 1e-3
    u = np.full((6, 4), 2.0)
    u[3, 2] = -0.5
    with pytest.raises(ValueError, match=r"u\[3, 2\] = -0\.5 at t = 0\.003 s: tendon 2 .*>= 0"):
        robot.simulate(np.zeros(6), np.zeros(6), t, u)
    ub = np.full((6, 2, 4), 2.0)
    ub[4, 1, 0] = -1.0
    with pytest.raises(ValueError, match=r"u\[4, 1, 0\] = -1\.0 at t = 0\.004 s: tendon 0"):
        robot.simulate(np.zeros((2, 6)), np.zeros((2, 6)), t, ub)
    with pytest.raises(ValueError, match=r"u\(t\)\[1\] = -1\.0 at t = 0 s: tendon 1"):
        robot.simulate(np.zeros(6), np.zeros(6), t, lambda time: np.array([1.0, -1.0, 1.0, 1.0]))


def test_actuation_shapes_and_bad_layouts():
    robot = tendon_robot()
    assert robot.n_inputs == 4 and robot.n_q == 6
    q = np.random.default_rng(5).normal(size=(2, 3, 6)) * 0.1
    assert robot.actuation_matrix(q).shape == (2, 3, 6, 4)
    assert robot.actuation_forces(q, np.ones((2, 3, 4))).shape == (2, 3, 6)
    assert robot.tendon_lengths(q).shape == (2, 3, 4)
    t = np.arange(4) * 1e-3
    with pytest.raises(ValueError, match=r"u must have shape .*\(4, 4\)"):
        robot.simulate(np.zeros(6), np.zeros(6), t, np.ones((4, 6)))  # generalised forces given to a tendon robot
    with pytest.raises(ValueError, match="u"):
        robot.actuation_forces(q, np.ones((2, 3, 6)))
    direct = PCSRobot(**TWO)
    assert direct.n_inputs == 6
    np.testing.assert_array_equal(direct.actuation_matrix(np.zeros(6)), np.eye(6))
    with pytest.raises(ValueError, match="Tendons"):
        direct.tendon_lengths(np.zeros(6))
    with pytest.raises(ValueError, match=r"end\[1\] = 0\.2 lies outside the robot"):
        PCSRobot(**TWO, actuation=Tendons(end=[0.1, 0.2], offset=[0.01, -0.01]))
    with pytest.raises(ValueError, match="offset must have shape"):
        PCSRobot(**TWO, actuation=Tendons(end=[0.1, 0.17], offset=[0.01]))
    with pytest.raises(ValueError, match="side"):
        PCSRobot(**TWO, actuation=PressureChambers([0.0], [0.1], [2], [1e-6], [1e-4]))
    with pytest.raises(ValueError, match=r"start\[0\]"):
        PCSRobot(**TWO, actuation=PressureChambers([0.1], [0.05], [1], [1e-6], [1e-4]))
    with pytest.raises(ValueError, match="actuation must be"):
        PCSRobot(**TWO, actuation="tendons")


# --------------------------------------------------------------------------
# pressure chambers
# --------------------------------------------------------------------------
CHAMBERS = PressureChambers(
    start=[0.0, 0.02, 0.09],
    end=[0.21, 0.13, 0.2],
    side=[1, -1, 1],
    bending_gain=[2e-6, 3e-6, 1.5e-6],
    axial_gain=[2e-4, 1e-4, 3e-4],
)
THREE = dict(
    segment_lengths=[0.05, 0.1, 0.06], density=1070, youngs_modulus=1e4, shear_modulus=1e3, damping=np.full(9, 0.05)
)


def chamber_work(q, lengths, p):
    """Virtual-work potential of the chambers: Σ p_j (σ_j g^b_j (θ(b) − θ(a)) + g^a_j ∫_a^b σ_ax ds)."""
    bounds = np.concatenate([[0.0], np.cumsum(lengths)])
    axial = lambda s: q[3 * min(np.searchsorted(bounds, s, side="right") - 1, len(lengths) - 1) + 2]  # noqa: E731
    total = 0.0
    for j in range(len(p)):
        a, b = CHAMBERS.start[j], CHAMBERS.end[j]
        theta = forward_kinematics(q, lengths, [a, b])[:, 2]
        integral = quad(axial, a, b, points=bounds[1:-1], limit=200, epsabs=1e-14)[0]
        total += p[j] * (
            CHAMBERS.side[j] * CHAMBERS.bending_gain[j] * (theta[1] - theta[0]) + CHAMBERS.axial_gain[j] * integral
        )
    return total


def test_chamber_columns_by_virtual_work_for_any_segmentation():
    robot = PCSRobot(**THREE, actuation=CHAMBERS)
    rng = np.random.default_rng(6)
    p = np.array([4e4, 2e4, 6e4])
    for _ in range(2):
        q = random_q(rng, 3)
        grad = np.array(
            [
                (
                    chamber_work(q + 1e-4 * e, robot.segment_lengths, p)
                    - chamber_work(q - 1e-4 * e, robot.segment_lengths, p)
                )
                / 2e-4
                for e in np.eye(9)
            ]
        )
        tau = robot.actuation_forces(q, p)
        np.testing.assert_allclose(tau, grad, rtol=0, atol=1e-9 * np.abs(grad).max())
        np.testing.assert_allclose(tau, robot.actuation_matrix(q) @ p, rtol=1e-14, atol=1e-18)
    # the map is constant and moves no shear strain
    A = robot.actuation_matrix(random_q(rng, 3))
    np.testing.assert_array_equal(A, robot.actuation_matrix(np.zeros(9)))
    assert np.all(A[1::3] == 0)


def test_a_constant_map_is_applied_like_the_equivalent_generalised_forces():
    robot = PCSRobot(**THREE, actuation=CHAMBERS)
    direct = PCSRobot(**THREE)
    t = np.arange(41) * 1e-3
    p = np.repeat(np.random.default_rng(7).uniform(0, 5e4, (5, 3)), 10, axis=0)[: t.size]
    a = robot.simulate(np.zeros(9), np.zeros(9), t, p)
    b = direct.simulate(np.zeros(9), np.zeros(9), t, p @ robot.actuation_matrix(np.zeros(9)).T)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12 * np.abs(b.q).max())


# --------------------------------------------------------------------------
# energy balance: dE/dt = q̇ᵀ A(q) u − q̇ᵀ D q̇
# --------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["tendon", "pressure"])
def test_energy_balance_under_actuation(kind):
    rng = np.random.default_rng(8)
    if kind == "tendon":
        robot = tendon_robot()
        u_levels = rng.uniform(0, 12, (4, 4))
    else:
        robot = PCSRobot(**THREE, actuation=CHAMBERS)
        u_levels = rng.uniform(0, 5e4, (4, 3))
    dt = 2e-5
    t = np.arange(2001) * dt  # 40 ms, inputs switching every 10 ms
    u = u_levels[np.minimum((t / 0.01).astype(int), 3)]
    sim = robot.simulate(np.zeros(robot.n_q), np.zeros(robot.n_q), t, u, rtol=1e-10, atol=1e-13)
    q, qd = sim.q, sim.qd
    energy = robot.total_energy(q, qd)
    # trapezoid on [t_k, t_k+1] with the input held there, u_k, at both ends
    power_start = np.einsum("ki,kij,kj->k", qd[:-1], robot.actuation_matrix(q[:-1]), u[:-1])
    power_end = np.einsum("ki,kij,kj->k", qd[1:], robot.actuation_matrix(q[1:]), u[:-1])
    dissipation = robot.damping * qd**2
    net = 0.5 * dt * (power_start + power_end - dissipation[:-1].sum(1) - dissipation[1:].sum(1))
    balance = energy[1:] - energy[0] - np.cumsum(net)
    work = np.cumsum(0.5 * dt * np.abs(power_start + power_end))
    assert work[-1] > 0 and np.ptp(energy) > 0.1 * work[-1]  # the actuators really do work
    assert np.abs(balance).max() <= 1e-5 * work[-1]


# --------------------------------------------------------------------------
# scenarios
# --------------------------------------------------------------------------
@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PCS_SINDY_CACHE", str(tmp_path / "cache"))


def test_two_segment_tendon_scenario():
    sc = get_scenario("two_segment_tendon")
    layout = sc.actuation
    assert layout == {"type": "tendon", "end": [0.07, 0.07, 0.17, 0.17], "side": [1, -1, 1, -1]}
    assert json.loads(json.dumps(layout)) == layout  # plain JSON, no offsets
    np.testing.assert_allclose(sc.robot.actuation.offset, [0.015, -0.015, 0.015, -0.015])
    np.testing.assert_allclose(sc.robot.segment_lengths, [0.07, 0.1])
    np.testing.assert_allclose(sc.robot.stiffness, get_scenario("two_segment").robot.stiffness)
    data = sc.generate(seed=0, n_train=2, train_duration=0.05, validation_duration=0.3)
    for rec in data.train + [data.validation]:
        T = rec.t.size
        assert rec.u.shape == (T, 4) and rec.tau.shape == (T, 6) and rec.poses.shape == (T, 21, 3)
        assert np.all(rec.u >= 0)
        np.testing.assert_allclose(rec.tau, sc.robot.actuation_forces(rec.q, rec.u), rtol=1e-14)
        assert np.all(np.abs(rec.q) <= np.tile([60.0, 0.3, 0.3], 2))
        # the recording is what simulate gives with its inputs
        np.testing.assert_array_equal(sc.robot.simulate(rec.q[0], rec.qd[0], rec.t, rec.u).q, rec.q)
    for k in range(0, 50, 10):  # training inputs held for 10 ms
        assert np.all(data.train[0].u[k : k + 10] == data.train[0].u[k])
    # validation: slow sinusoids, one frequency per tendon (different zero-crossing patterns)
    val = data.validation.u
    assert not np.any(np.all(np.diff(val, axis=0) == 0, axis=0))
    assert np.linalg.matrix_rank(val - val.mean(0), tol=1e-6 * np.abs(val).max()) == 4
    # the disk cache gives back the same inputs
    again = sc.generate(seed=0, n_train=2, train_duration=0.05, validation_duration=0.3)
    np.testing.assert_array_equal(again.train[1].u, data.train[1].u)
    np.testing.assert_array_equal(again.validation.tau, data.validation.tau)


def test_one_segment_pneumatic_scenario():
    sc = get_scenario("one_segment_pneumatic")
    assert sc.actuation == {"type": "pressure", "start": [0.0, 0.0], "end": [0.1, 0.1], "side": [1, -1]}
    data = sc.generate(seed=1, n_train=2, train_duration=0.05, validation_duration=0.3, cache=False)
    for rec in data.train + [data.validation]:
        assert rec.u.shape == (rec.t.size, 2) and rec.tau.shape == (rec.t.size, 3)
        assert np.all(rec.u >= 0)
        np.testing.assert_allclose(
            rec.tau, rec.u @ sc.robot.actuation_matrix(np.zeros(3)).T, rtol=0, atol=1e-14 * np.abs(rec.tau).max()
        )
        assert np.all(np.abs(rec.q) <= [60.0, 0.3, 0.3])
    # directly driven scenarios: no layout, and u is τ
    plain = get_scenario("one_segment")
    assert plain.actuation is None
    rec = plain.generate(seed=0, n_train=1, train_duration=0.02, validation=False, cache=False).train[0]
    assert rec.u is rec.tau


# --------------------------------------------------------------------------
# servo-wound elastic tendons (drive="displacement")
# --------------------------------------------------------------------------
SERVO = dict(end=[0.07, 0.17], offset=[0.015, -0.015], stiffness=[400.0, 250.0], pulley_radius=[0.01, 0.012])


def servo_energy(q, lengths, phi, slack):
    """Elastic energy ½ Σ k max(0, r φ π/180 + ℓ(q) − ℓ(0) − s)² with ℓ integrated numerically."""
    total = 0.0
    for k, (end, d) in enumerate(zip(SERVO["end"], SERVO["offset"], strict=True)):
        ell = polyline_length(q, lengths, end, d, per_segment=400)
        ell0 = polyline_length(np.zeros_like(q), lengths, end, d, per_segment=400)
        e = SERVO["pulley_radius"][k] * np.deg2rad(phi[k]) + ell - ell0 - slack[k]
        total += 0.5 * SERVO["stiffness"][k] * max(e, 0.0) ** 2
    return total


@pytest.mark.parametrize("slack", [(0.0, 0.0), (0.004, -0.002)])
def test_servo_tendon_forces_are_minus_the_gradient_of_the_tendon_energy(slack):
    # independent truth: the elastic energy of the tendons from numerically integrated offset curves
    robot = PCSRobot(**TWO, actuation=Tendons(**SERVO, drive="displacement", slack=list(slack)))
    rng = np.random.default_rng(7)
    for phi in (np.array([30.0, 5.0]), np.array([-10.0, 60.0])):
        q = random_q(rng, 2) / 4
        tau = robot.actuation_forces(q, phi)
        eps = 1e-5
        grad = np.array(
            [
                (
                    servo_energy(q + eps * e, robot.segment_lengths, phi, slack)
                    - servo_energy(q - eps * e, robot.segment_lengths, phi, slack)
                )
                / (2 * eps)
                for e in np.eye(6)
            ]
        )
        np.testing.assert_allclose(tau, -grad, rtol=1e-5, atol=1e-7 * np.abs(grad).max() + 1e-12)


def test_servo_tendon_is_slack_below_its_take_up_and_accepts_any_angle():
    robot = PCSRobot(**TWO, actuation=Tendons(**SERVO, drive="displacement", slack=[0.003, 0.003]))
    q = np.zeros(6)
    # straight robot: taut once r φ π/180 > s, i.e. φ > 0.003 / 0.01 rad = 17.19 deg for tendon 1
    f = robot.tendon_tensions(np.zeros((3, 6)), np.array([[17.0, 0.0], [18.0, 0.0], [-40.0, 0.0]]))
    assert f[0, 0] == 0.0 and f[2, 0] == 0.0
    assert f[1, 0] == pytest.approx(400.0 * (0.01 * np.deg2rad(18.0) - 0.003), rel=1e-12)
    np.testing.assert_array_equal(robot.actuation_forces(q, [-40.0, -40.0]), 0.0)
    with pytest.raises(ValueError, match="stiffness is required"):
        PCSRobot(**TWO, actuation=Tendons(end=[0.1], offset=[0.01], drive="displacement", pulley_radius=0.01))
    with pytest.raises(ValueError, match="drive must be"):
        PCSRobot(**TWO, actuation=Tendons(end=[0.1], offset=[0.01], drive="servo"))
    assert Tendons(**SERVO, drive="displacement").layout()["drive"] == "displacement"


def test_servo_tendon_robot_rests_where_elastic_gravity_and_tendon_forces_balance():
    # a hold: simulate to rest, then check G + K q = A(q) f(q, φ) with the tensions of the rest shape
    robot = PCSRobot(**TWO, actuation=Tendons(**SERVO, drive="displacement", slack=[0.001, -0.0005]))
    t = np.linspace(0.0, 5.0, 501)
    phi = np.tile([40.0, 10.0], (t.size, 1))
    traj = robot.simulate(np.zeros(6), np.zeros(6), t, phi)
    q = traj.q[-1]
    assert np.abs(traj.qd[-1]).max() < 1e-4
    f = robot.tendon_tensions(q, phi[-1])
    assert f[0] > 0.5  # tendon 1 is taut and bends the robot
    static = robot.gravity_forces(q) + robot.elastic_forces(q)
    np.testing.assert_allclose(static, robot.actuation_matrix(q) @ f, atol=1e-3 * np.abs(static).max())
