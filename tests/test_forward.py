"""Forward models of identified dynamics: compiled kernels, rollouts and the simulate contract.

Truth: numeric quadrature of the moment integrals, the libraries' own NumPy
``mass_matrix``/``bias_forces`` (and for the Lagrangian library a symbolic
derivation), and the ground-truth simulator ``PCSRobot.simulate`` (implicit
Radau, independent code).
"""

from __future__ import annotations

import numpy as np
import pytest
from truth import simulate_truth as _simulate_truth

from pcs_sindy.core import SimulationError, StrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor, PCSLagrangianLibrary, PhysicalPCSLibrary
from pcs_sindy.models import CallableModel, LumpedPCSModel
from pcs_sindy.models._jit_dynamics import moments
from pcs_sindy.models.pcs_numeric import moments as moments_array
from pcs_sindy.simulation import get_scenario

MAT = dict(density=1000.0, youngs_modulus=1e5, shear_modulus=3e4)


def _coef(lib, m):
    damp = np.tile([1e-4, 1e-2, 1e-2], m)
    if isinstance(lib, PCSLagrangianLibrary):
        return lib.coefficients_from_parameters(radius=0.01, damping=damp, **MAT)
    return lib.coefficients_from_parameters(radius=None, damping=damp, **MAT)


def _states(n_samples, mask, rng):
    # curvatures both inside (|kappa L| <= 1, series) and outside (closed form) the series range
    scale = np.tile([25.0, 0.1, 0.1], mask.size // 3)[mask]
    return rng.uniform(-1, 1, (n_samples, mask.sum())) * scale, rng.normal(size=(n_samples, mask.sum())) * 3 * scale


@pytest.mark.parametrize("u", [0.0, 1e-9, -0.3, 0.999, 1.0, 1.001, -2.7, 7.5, 40.0])
def test_moments_equal_numeric_integrals(u):
    x, w = np.polynomial.legendre.leggauss(200)  # exact to round-off for these smooth integrands
    t, w = 0.5 * (x + 1.0), 0.5 * w
    got_scalar = moments(u)
    got_array = [e[0] for e in moments_array(np.array([u]))]
    for n in range(3):
        ref = np.sum(w * t**n * np.exp(1j * u * t))
        assert abs(got_scalar[n] - ref) <= 1e-14
        assert got_array[n] == got_scalar[n]  # one implementation


_LIBS = [
    ("physical", {}),
    ("physical", dict(identify_gravity=True, rotary_inertia="tied", gravity=(1.0, -9.0))),
    ("lagrangian", {}),
]


@pytest.mark.parametrize("kind,kw", _LIBS)
@pytest.mark.parametrize("lengths,active", [((0.1,), None), ((0.1, 0.08), None), ((0.1, 0.08), [[1, 1, 0], [1, 0, 1]])])
def test_compiled_model_equals_library_mass_and_bias(kind, kw, lengths, active):
    if kind == "lagrangian":
        lib = PCSLagrangianLibrary(lengths, active_strains=active, basis="physical")
    else:
        lib = PhysicalPCSLibrary(lengths, active_strains=active, radius=0.01, n_quadrature=8, **kw)
    coef = _coef(lib, len(lengths))
    if kind == "physical":  # a constant force per strain too
        coef[lib.rest_force_index_] = np.linspace(-0.1, 0.2, lib.rest_force_index_.size)
    model = lib.forward_model(coef)
    assert isinstance(model, LumpedPCSModel)
    q, qd = _states(12, lib.kinematics.active_mask, np.random.default_rng(3))
    M, bias = model.mass_and_bias(q, qd)
    M_ref, b_ref = lib.mass_matrix(q, coef), lib.bias_forces(q, qd, coef)
    assert np.abs(M - M_ref).max() <= 1e-12 * np.abs(M_ref).max()
    assert np.abs(bias - b_ref).max() <= 1e-12 * np.abs(b_ref).max()


def test_monomial_model_is_a_callable_model_of_the_library():
    lib = PCSLagrangianLibrary((0.1,))
    coef = _coef(lib, 1)
    model = lib.forward_model(coef)
    assert isinstance(model, CallableModel) and model.default_method == "radau"
    q, qd = _states(6, lib.kinematics.active_mask, np.random.default_rng(4))
    M, bias = model.mass_and_bias(q, qd)
    np.testing.assert_allclose(M, lib.mass_matrix(q, coef), rtol=1e-11, atol=0)
    np.testing.assert_allclose(bias, lib.bias_forces(q, qd, coef), rtol=1e-10, atol=1e-14)
    single = model._state_derivative(np.r_[q[0], qd[0]], np.zeros(3))
    np.testing.assert_allclose(single[3:], np.linalg.solve(M[0], -bias[0]), rtol=1e-9)


def test_eight_nodes_agree_with_sixteen_up_to_kappa_l_six():
    # the bound behind the cheaper rule of rollouts (fast_max_bend)
    lib = PhysicalPCSLibrary((0.07, 0.1), radius=0.02, n_quadrature=16)
    coef = _coef(lib, 2)
    full = lib.forward_model(coef)
    lp = lib.lumped_from_coef(coef)
    fast = LumpedPCSModel(
        lib.kinematics,
        lp["rhoA"],
        lp["rhoI"],
        lp["rhoAg"],
        lp["stiffness"],
        lp["damping"],
        lp["rest_force"],
        n_quadrature=8,
    )
    rng = np.random.default_rng(8)
    for kl in (2.0, 4.0, 6.0):
        q = rng.uniform(-1, 1, (100, 6)) * np.array([kl / 0.07, 0.3, 0.3, kl / 0.1, 0.3, 0.3])
        q[:, [0, 3]] = np.sign(q[:, [0, 3]]) * np.array([kl / 0.07, kl / 0.1])  # at the bound
        qd = rng.normal(size=(100, 6)) * [600.0, 3.0, 8.0, 500.0, 10.0, 10.0]
        (M1, b1), (M2, b2) = full.mass_and_bias(q, qd), fast.mass_and_bias(q, qd)
        assert np.abs(M1 - M2).max() <= 1e-10 * np.abs(M1).max()
        assert np.all(np.abs(b1 - b2).max(axis=0) <= 1e-10 * np.abs(b1).max(axis=0))


def _square_wave(t, m, rng, amp):
    n_hold = 20
    levels = rng.uniform(-1, 1, (t.size // n_hold + 1, 3 * m)) * amp
    return np.repeat(levels, n_hold, axis=0)[: t.size]


def _true_model(name, library="physical"):
    robot = get_scenario(name).robot
    if library == "physical":
        lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    else:
        lib = PCSLagrangianLibrary(robot.segment_lengths)
    coef = lib.coefficients_from_parameters(
        robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
    )
    return robot, lib, coef


@pytest.mark.parametrize(
    "name,method,library",
    [
        ("one_segment", "rosenbrock", "physical"),
        ("one_segment", "dopri5", "physical"),
        ("two_segment", "rosenbrock", "physical"),
        ("two_segment", "dopri5", "physical"),
        ("one_segment", "radau", "monomial"),
        ("one_segment", "dopri5", "monomial"),  # a callable model takes solve_ivp's RK45 for dopri5
    ],
)
def test_true_parameters_follow_the_simulator(name, method, library):
    robot, lib, coef = _true_model(name, library)
    m = robot.n_segments
    t = np.arange(101) * 1e-3
    rng = np.random.default_rng(2)
    tau = robot.gravity_forces(np.zeros(3 * m)) + _square_wave(
        t, m, rng, np.abs(robot.elastic_forces(np.tile([10.0, 0.05, 0.05], m)))
    )
    q_ref, qd_ref = _simulate_truth(robot, np.zeros(3 * m), np.zeros(3 * m), t, tau)
    sim = lib.forward_model(coef).simulate(
        np.zeros(3 * m), np.zeros(3 * m), t, tau, method=method, rtol=1e-10, atol=1e-12
    )
    assert np.all(np.abs(sim.q - q_ref).max(axis=0) <= 1e-6 * np.abs(q_ref).max(axis=0))
    assert np.all(np.abs(sim.qd - qd_ref).max(axis=0) <= 1e-5 * np.abs(qd_ref).max(axis=0))
    assert sim.segment_lengths == robot.kinematics.segment_lengths


def test_rollout_repeats_with_the_reference_rule_beyond_the_bound():
    robot, lib, coef = _true_model("one_segment")
    lp = lib.lumped_from_coef(coef)
    args = (lib.kinematics, lp["rhoA"], lp["rhoI"], lp["rhoAg"], lp["stiffness"], lp["damping"], lp["rest_force"])
    t = np.arange(31) * 1e-3
    rng = np.random.default_rng(1)
    tau = robot.gravity_forces(np.zeros(3)) + _square_wave(t, 1, rng, np.abs(robot.elastic_forces([10.0, 0.05, 0.05])))
    q0, qd0 = np.array([3.0, 0.01, -0.01]), np.zeros(3)
    kw = dict(rtol=1e-8, atol=1e-11, method="rosenbrock")
    eight = LumpedPCSModel(*args, n_quadrature=8, fast_quadrature=None).simulate(q0, qd0, t, tau, **kw)
    sixteen = LumpedPCSModel(*args, n_quadrature=16, fast_quadrature=None).simulate(q0, qd0, t, tau, **kw)
    assert not np.array_equal(eight.q, sixteen.q)  # the two rules differ (at round-off)
    np.testing.assert_array_equal(LumpedPCSModel(*args).simulate(q0, qd0, t, tau, **kw).q, eight.q)
    np.testing.assert_array_equal(LumpedPCSModel(*args, fast_max_bend=0.0).simulate(q0, qd0, t, tau, **kw).q, sixteen.q)


def _fitted_one_segment():
    robot, lib, coef = _true_model("one_segment")
    rng = np.random.default_rng(0)
    X, taus, qds, qdds = [], [], [], []
    for _ in range(2):
        q = rng.uniform(-1, 1, (200, 3)) * [15.0, 0.05, 0.05]
        qd = rng.normal(size=(200, 3)) * [30.0, 0.1, 0.1]
        qdd = rng.normal(size=(200, 3)) * [300.0, 1.0, 1.0]
        X.append(StrainTrajectory(q, np.arange(200) * 1e-3, segment_lengths=robot.kinematics.segment_lengths))
        taus.append(robot.inverse_dynamics(q, qd, qdd))
        qds.append(qd)
        qdds.append(qdd)
    model = EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(rest_strain=False), formulation="strong")
    return robot, model.fit(X, taus, qd=qds, qdd=qdds)


@pytest.mark.filterwarnings("ignore::pcs_sindy.identification.regressor.PoorFitWarning")  # random states
def test_regressor_simulate_is_the_forward_models_and_keeps_the_old_order_for_a_release():
    robot, model = _fitted_one_segment()
    t = np.arange(81) * 1e-3
    rng = np.random.default_rng(0)
    tau = robot.gravity_forces(np.zeros(3)) + _square_wave(t, 1, rng, np.abs(robot.elastic_forces([10.0, 0.05, 0.05])))
    q0 = np.array([3.0, 0.01, -0.01])
    new = model.simulate(q0, np.zeros(3), t, tau)
    direct = model.forward_model().simulate(q0, np.zeros(3), t, tau, rtol=model.rtol, atol=model.atol)
    np.testing.assert_array_equal(new.q, direct.q)
    with pytest.warns(FutureWarning, match=r"simulate\(q0, qd0, t, u\)"):
        old = model.simulate(q0, np.zeros(3), tau, t)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.warns(FutureWarning, match="pass the input as u"):
        kw = model.simulate(q0, np.zeros(3), t=t, tau=tau)
    np.testing.assert_array_equal(kw.q, new.q)
    q_ref, _ = _simulate_truth(robot, q0, np.zeros(3), t, tau)
    assert np.all(np.abs(new.q - q_ref).max(axis=0) <= 1e-4 * np.abs(q_ref).max(axis=0))
    with pytest.raises(SimulationError, match=r"t = .*exceeded max_abs_state.*be_1="):
        model.simulate(np.zeros(3), np.zeros(3), t, np.full((t.size, 3), 1e6), max_abs_state=1e3)
    with pytest.raises(ValueError, match="needs the times t and the input u"):
        model.simulate(q0, np.zeros(3), t)


@pytest.mark.filterwarnings("ignore::pcs_sindy.identification.regressor.PoorFitWarning")  # random states
def test_forward_model_is_rebuilt_after_pickling():
    import pickle

    _, model = _fitted_one_segment()
    model.forward_model()
    clone = pickle.loads(pickle.dumps(model))
    assert "_forward" not in clone.__dict__
    q = np.array([[2.0, 0.01, 0.0]])
    np.testing.assert_array_equal(
        clone.forward_model().mass_and_bias(q, q)[0], model.forward_model().mass_and_bias(q, q)[0]
    )
