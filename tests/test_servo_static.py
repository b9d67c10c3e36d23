"""Inputs that are not forces and rigs that only hold shapes: servo-wound tendons, learned input maps, statics.

Independent truths: the ground-truth simulator's own servo-tendon forces and static forces
(:mod:`pcs_sindy.simulation`, no code shared with the identification side), equilibria found by
:func:`scipy.optimize.root` on the simulator's forces, closed-form hold means, and rollouts of the
identified model that settle where its statics say.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import root

from pcs_sindy.core import PlanarPCS, StrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.identification.formulations import static_recording
from pcs_sindy.io import load, save
from pcs_sindy.models import LearnedActuation, TendonActuation
from pcs_sindy.simulation import Tendons, get_scenario
from pcs_sindy.simulation.dynamics import PCSRobot

LENGTHS = [0.07, 0.1]
BODY = dict(
    density=[1070.0, 1049.0],
    youngs_modulus=[1e4, 9e3],
    shear_modulus=[1e3, 3e3],
    damping=[3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2],
)
SERVO = dict(
    end=[0.07, 0.07, 0.17, 0.17],
    offset=[0.015, -0.015, 0.015, -0.015],
    stiffness=[500.0, 500.0, 400.0, 400.0],
    pulley_radius=[0.01, 0.01, 0.012, 0.012],
    slack=[0.001, 0.002, -0.001, 0.0],
)
SIDES = [1, -1, 1, -1]
MASS = float(np.sum(np.asarray(BODY["density"]) * np.pi * 0.02**2 * np.asarray(LENGTHS)))


def servo_robot(**kw) -> PCSRobot:
    return PCSRobot(LENGTHS, **BODY, actuation=Tendons(**{**SERVO, **kw}, drive="displacement"))


@pytest.fixture(scope="module")
def servo_data():
    """Three 1.5 s recordings at 1 kHz of random servo steps (tendons go slack and taut)."""
    robot = servo_robot()
    rng = np.random.default_rng(0)
    t = np.arange(1500) * 1e-3
    X, U = [], []
    for _ in range(3):
        level = rng.uniform(-10, 90, (75, 4)) * (rng.uniform(size=(75, 4)) < 0.5)
        u = np.repeat(level, 20, axis=0)
        traj = robot.simulate(np.zeros(6), np.zeros(6), t, u)
        X.append(StrainTrajectory(traj.q, t, segment_lengths=LENGTHS))
        U.append(u)
    return robot, X, U


def test_displacement_map_equals_the_simulators_servo_tendons():
    robot = servo_robot()
    act = TendonActuation(
        SERVO["end"],
        SIDES,
        offset=np.abs(SERVO["offset"]),
        drive="displacement",
        stiffness=SERVO["stiffness"],
        pulley_radius=SERVO["pulley_radius"],
        slack=SERVO["slack"],
    ).fit(PlanarPCS(LENGTHS))
    rng = np.random.default_rng(1)
    q = rng.normal(size=(30, 6)) * [15, 0.05, 0.05, 15, 0.05, 0.05]
    u = rng.uniform(-30, 90, (30, 4))
    np.testing.assert_allclose(act.forces(q, u), robot.actuation_forces(q, u), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(act.tensions(q, u), robot.tendon_tensions(q, u), rtol=1e-12, atol=1e-15)
    assert np.any(act.tensions(q, u) == 0) and np.any(act.tensions(q, u) > 0)  # both regimes covered
    # the compiled kernel of the identified model's rollouts agrees too
    lib = PhysicalPCSLibrary().fit([StrainTrajectory(q[:3], np.arange(3.0), segment_lengths=LENGTHS)])
    coef = lib.coefficients_from_parameters(
        BODY["density"], 0.02, BODY["youngs_modulus"], BODY["shear_modulus"], BODY["damping"]
    )
    fwd = lib.forward_model(coef, actuation=act)
    for k in range(5):
        np.testing.assert_allclose(fwd.input_forces(q[k], u[k]), robot.actuation_forces(q[k], u[k]), atol=1e-13)
    # servo angles may be negative; the map is -dl/dq for unit tensions
    np.testing.assert_allclose(act.matrix(q[:2]), robot.actuation_matrix(q[:2]), atol=1e-15)
    assert act.input_bounds() is None
    # controllers read A(q) u: a displacement drive has none, and says so instead of treating angles as tensions
    with pytest.raises(ValueError, match="nonlinearly in its inputs"):
        fwd.input_matrix(q[0])
    with pytest.raises(ValueError, match="drive='tension'"):
        TendonActuation(SERVO["end"], SIDES, stiffness=SERVO["stiffness"]).fit(PlanarPCS(LENGTHS))


def test_servo_tendon_stiffness_radius_and_slack_are_identified(servo_data):
    robot, X, U = servo_data
    # stiffness known: offsets, pulley radii and slacks by variable projection
    known = TendonActuation(SERVO["end"], SIDES, drive="displacement", stiffness=SERVO["stiffness"])
    model = EulerLagrangeRegressor(actuation=known).fit(X, U)
    p = 4
    off = model.actuation_.offsets_
    np.testing.assert_allclose(off[:p], SERVO["offset"], rtol=0.01)
    np.testing.assert_allclose(off[p : 2 * p], SERVO["pulley_radius"], rtol=0.01)
    np.testing.assert_allclose(off[2 * p :], SERVO["slack"], atol=5e-5)
    np.testing.assert_allclose(model.stiffness_, robot.stiffness, rtol=0.01)
    names = model.identifiability_["offset_names"]
    assert names[:4] == ["d_1", "d_2", "d_3", "d_4"] and names[4] == "r_1" and names[-1] == "s_4"
    # stiffness unknown too: linear gains k_k, the scale from the robot's mass
    free = TendonActuation(SERVO["end"], SIDES, drive="displacement")
    # no mass: the stated 1 kg convention scales the gains by 1 / MASS and leaves the geometry as it is
    conv = EulerLagrangeRegressor(actuation=free).fit(X, U)
    assert "1 kg" in conv.scale_convention_
    np.testing.assert_allclose(conv.actuation_.gains_ * MASS, SERVO["stiffness"], rtol=0.01)
    np.testing.assert_allclose(conv.actuation_.offsets_[p : 2 * p], SERVO["pulley_radius"], rtol=0.01)
    model = EulerLagrangeRegressor(actuation=free, feature_library=PhysicalPCSLibrary(mass=MASS)).fit(X, U)
    np.testing.assert_allclose(model.actuation_.gains_, SERVO["stiffness"], rtol=0.01)
    np.testing.assert_allclose(model.actuation_.offsets_[p : 2 * p], SERVO["pulley_radius"], rtol=0.01)
    np.testing.assert_allclose(model.stiffness_, robot.stiffness, rtol=0.01)
    # the identified model, driven by the servo angles, follows the simulator
    sim = model.simulate(X[2].q[0], np.zeros(6), X[2].t, U[2])
    err = np.abs(sim.q - X[2].q).max(axis=0) / np.abs(X[2].q).max(axis=0)
    assert np.all(err < 0.01), err
    assert any("slack s [mm]" in line for line in model.equations())


def test_servo_tendon_model_file_round_trip(servo_data, tmp_path):
    _, X, U = servo_data
    act = TendonActuation(
        SERVO["end"], SIDES, offset=np.abs(SERVO["offset"]), drive="displacement", stiffness=SERVO["stiffness"]
    )
    model = EulerLagrangeRegressor(actuation=act).fit(X[:1], U[:1])
    loaded = load(save(model, tmp_path / "servo"))
    assert loaded.actuation_.drive == "displacement"
    np.testing.assert_array_equal(loaded.actuation_.offsets_, model.actuation_.offsets_)
    a = model.simulate(X[0].q[0], np.zeros(6), X[0].t[:200], U[0][:200])
    b = loaded.simulate(X[0].q[0], np.zeros(6), X[0].t[:200], U[0][:200])
    np.testing.assert_array_equal(a.q, b.q)


def test_learned_actuation_recovers_a_constant_map_and_is_passive_with_inputs_off(tmp_path):
    scenario = get_scenario("one_segment_pneumatic")
    data = scenario.generate(seed=0, n_train=3, validation=False)
    lengths = scenario.robot.kinematics.segment_lengths
    X = [StrainTrajectory(r.q, r.t, segment_lengths=lengths) for r in data.train]
    U = [r.u for r in data.train]
    mass = float(np.sum(np.asarray(scenario.parameters["density"]) * np.pi * 0.02**2 * np.asarray(lengths)))
    act = LearnedActuation(2, strains="all")
    model = EulerLagrangeRegressor(actuation=act, feature_library=PhysicalPCSLibrary(mass=mass), refine="none").fit(
        X, U
    )
    # no mass: the stated convention (1 kg) scales every parameter alike, and the motion is the same
    conv = EulerLagrangeRegressor(actuation=act, refine="none").fit(X, U)
    assert "1 kg" in conv.scale_convention_ and "scale convention" in conv.identifiability_report()
    assert model.scale_convention_ is None
    np.testing.assert_allclose(conv.stiffness_ * mass, model.stiffness_, rtol=1e-6)
    np.testing.assert_allclose(conv.actuation_.gains_ * mass, model.actuation_.gains_, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(model.stiffness_, scenario.robot.stiffness, rtol=1e-3)
    q = np.random.default_rng(2).normal(size=(4, 3)) * [10, 0.05, 0.05]
    # the chambers' constant map (the simulator's), whatever the strains
    np.testing.assert_allclose(
        model.actuation_.matrix(q), scenario.robot.actuation_matrix(q), rtol=1e-3, atol=1e-3 * 2e-5
    )
    # inputs off: no force at any configuration, for any gains
    gains = np.random.default_rng(3).normal(size=model.actuation_.n_gains)
    np.testing.assert_array_equal(model.actuation_.forces(q, np.zeros((4, 2)), gains), 0.0)
    assert model.actuation_.gain_names_[:2] == ["a_be_1_u1", "a_be_1_u1_be_1"]
    loaded = load(save(model, tmp_path / "learned"))
    np.testing.assert_array_equal(loaded.actuation_.gains_, model.actuation_.gains_)
    r = data.train[0]
    np.testing.assert_array_equal(
        loaded.simulate(r.q[0], r.qd[0], r.t[:100], r.u[:100]).q,
        model.simulate(r.q[0], r.qd[0], r.t[:100], r.u[:100]).q,
    )
    with pytest.raises(ValueError, match="terms"):
        LearnedActuation(2, terms=("u*q",)).fit(PlanarPCS(lengths))


def test_learned_pull_terms_numpy_and_compiled_maps_agree_and_vanish_with_the_inputs_off():
    # independent pieces: the numpy basis (parts) and the compiled kernel of the rollouts, for random gains;
    # a pull term acts only for a positive input
    kin = PlanarPCS(LENGTHS)
    act = LearnedActuation(2, terms=("u", "u*q", "pull", "pull*q"), strains="all").fit(kin)
    rng = np.random.default_rng(5)
    act.set_identified(rng.normal(size=act.n_gains), np.zeros(0))
    assert act.n_gains == 6 * 2 * (1 + 2) * 2 and not act.linear_in_inputs
    lib = PhysicalPCSLibrary().fit([StrainTrajectory(np.zeros((3, 6)), np.arange(3.0), segment_lengths=LENGTHS)])
    coef = lib.coefficients_from_parameters(
        BODY["density"], 0.02, BODY["youngs_modulus"], BODY["shear_modulus"], BODY["damping"]
    )
    fwd = lib.forward_model(coef, actuation=act)
    q = rng.normal(size=(6, 6)) * [10, 0.05, 0.05, 10, 0.05, 0.05]
    u = rng.normal(size=(6, 2)) * 5
    for k in range(6):
        np.testing.assert_allclose(fwd.input_forces(q[k], u[k]), act.forces(q[k], u[k])[0], rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(act.forces(q, np.zeros((6, 2))), 0.0)
    # pull terms alone: a negative input does nothing, a positive one acts linearly
    pull = LearnedActuation(2, terms=("pull",)).fit(kin)
    g = rng.normal(size=pull.n_gains)
    np.testing.assert_array_equal(pull.forces(q, -np.abs(u), g), 0.0)
    np.testing.assert_allclose(pull.forces(q, 2 * np.abs(u), g), 2 * pull.forces(q, np.abs(u), g), rtol=1e-14)


def test_static_recording_averages_each_hold_after_settling():
    t = np.arange(10.0)
    u = np.array([[0.0]] * 4 + [[2.0]] * 6)
    q = np.arange(20.0).reshape(10, 2)
    rec = static_recording(t, q, u, settle=0.5)
    np.testing.assert_array_equal(rec.u, [[0.0], [2.0]])
    np.testing.assert_array_equal(rec.q, [q[2:4].mean(axis=0), q[7:10].mean(axis=0)])
    np.testing.assert_array_equal(rec.qd, 0.0)
    np.testing.assert_array_equal(rec.t, [3.0, 9.0])
    with pytest.raises(ValueError, match="NaN"):
        static_recording(t, np.where(t[:, None] == 5, np.nan, q), u)


def _true_equilibrium(robot, u, q0):
    def residual(q):
        return robot.gravity_forces(q) + robot.elastic_forces(q) - robot.actuation_forces(q, u)

    sol = root(residual, q0, tol=1e-12)
    assert sol.success
    return sol.x


def test_static_fit_from_equilibria_and_forward_statics():
    # tension-driven tendons: the tensions' units fix the scale; equilibria of the simulator by root finding
    robot = PCSRobot(LENGTHS, **BODY, actuation=Tendons(SERVO["end"], SERVO["offset"]))
    rng = np.random.default_rng(4)
    holds = rng.uniform(0, 6, (25, 4)) * (rng.uniform(size=(25, 4)) < 0.5)
    q_eq = np.array([_true_equilibrium(robot, u, np.zeros(6)) for u in holds])
    per = 40  # samples per hold, with small strain noise
    q = np.repeat(q_eq, per, axis=0) + rng.normal(size=(25 * per, 6)) * [0.02, 1e-5, 1e-5, 0.02, 1e-5, 1e-5]
    X = [StrainTrajectory(q, np.arange(q.shape[0]) * 5e-3, segment_lengths=LENGTHS)]
    U = [np.repeat(holds, per, axis=0)]
    act = TendonActuation(SERVO["end"], SIDES)
    model = EulerLagrangeRegressor(formulation="static", actuation=act).fit(X, U)
    np.testing.assert_allclose(model.stiffness_, robot.stiffness, rtol=0.01)
    np.testing.assert_allclose(np.abs(model.actuation_.offsets_), np.abs(SERVO["offset"]), rtol=0.01)
    assert model.n_regression_samples_ >= 25
    # forward statics at new inputs against the simulator's equilibria (a sweep, ordered by load)
    new = np.array([[0.0, 0.0, 2.0, 0.0], [0.0, 0.0, 4.0, 0.0], [0.0, 0.0, 6.0, 0.5], [1.0, 3.0, 0.0, 4.0]])
    q_model = model.equilibrium(new)
    q_true = np.array([_true_equilibrium(robot, u, np.zeros(6)) for u in new])
    assert q_model.shape == (4, 6)
    np.testing.assert_allclose(q_model[:, 0::3], q_true[:, 0::3], atol=0.01 * np.abs(q_true[:, 0::3]).max())
    # a single input gives one configuration
    assert model.equilibrium(new[0]).shape == (6,)


def test_equilibrium_is_where_a_rollout_comes_to_rest(servo_data):
    _, X, U = servo_data
    model = EulerLagrangeRegressor(
        actuation=TendonActuation(SERVO["end"], SIDES, drive="displacement", stiffness=SERVO["stiffness"])
    ).fit(X[:2], U[:2])
    u = np.array([60.0, 0.0, 10.0, 45.0])
    q_eq = model.equilibrium(u)
    t = np.arange(0.0, 6.0, 1e-3)
    rest = model.simulate(np.zeros(6), np.zeros(6), t, np.tile(u, (t.size, 1))).q[-1]
    np.testing.assert_allclose(q_eq, rest, atol=1e-3 * np.abs(q_eq).max())
    with pytest.raises(ValueError, match="u must"):
        model.equilibrium(np.array([np.nan, 0, 0, 0]))
