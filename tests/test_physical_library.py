"""Tests of the physically parameterised PCS library against the independent simulator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear
from sklearn.base import clone
from truth import simulate_truth

from pcs_sindy.identification import PhysicalPCSLibrary
from pcs_sindy.identification.formulations import integrate_forces, sliding_windows, weak_form_rows
from pcs_sindy.simulation.dynamics import PCSRobot

# (lengths, density, E, G, damping) — the seed's Table I robots
ROBOTS = {
    1: ([0.1], [1070.0], [1e4], [1e3], [1e-5, 1.5e-1, 1.5e-1]),
    2: ([0.07, 0.1], [1070.0, 1049.0], [1e4, 9e3], [1e3, 3e3], [3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2]),
    3: (
        [0.05, 0.1, 0.06],
        [1240.0, 1049.0, 1070.0],
        [1e4, 6e4, 8e4],
        [1e3, 3e3, 5e3],
        [5e-5, 4e-2, 5e-2, 5e-5, 5e-3, 5e-2, 5e-5, 5e-3, 5e-2],
    ),
}
SCALE = np.array([40.0, 0.25, 0.25])  # typical |q| per strain type


def make(m, **kw):
    L, rho, E, G, D = ROBOTS[m]
    robot = PCSRobot(L, rho, E, G, D, **kw)
    return robot, (L, rho, E, G, D)


def random_states(rng, m, n_samples):
    """Random states, including the straight robot and exactly zero curvature in one segment."""
    s = np.tile(SCALE, m)
    q = rng.uniform(-1, 1, (n_samples, 3 * m)) * s
    qd = rng.uniform(-1, 1, (n_samples, 3 * m)) * 20 * s
    qdd = rng.uniform(-1, 1, (n_samples, 3 * m)) * 2000 * s
    q[0] = 0.0
    q[1, 0::3] = 0.0  # every bending strain exactly 0, shear/axial not
    q[2, 0] = 0.0
    q[3, 0] = 1e-9
    return q, qd, qdd


def rel_err(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("m", [1, 2, 3])
@pytest.mark.parametrize("identify_gravity", [False, True])
def test_inverse_dynamics_and_mass_match_simulator(m, identify_gravity):
    rng = np.random.default_rng(m)
    robot, (L, rho, E, G, D) = make(m)
    lib = PhysicalPCSLibrary(L, identify_gravity=identify_gravity)
    coef = lib.coefficients_from_parameters(rho, 0.02, E, G, D)
    q, qd, qdd = random_states(rng, m, 40)
    psi = lib.euler_lagrange_matrix(q, qd, qdd)
    assert psi.shape == (40, 3 * m, lib.n_coefficients_)
    assert rel_err(psi @ coef, robot.inverse_dynamics(q, qd, qdd)) < 1e-8
    assert rel_err(lib.mass_matrix(q, coef), robot.mass_matrix(q)) < 1e-8
    assert rel_err(lib.bias_forces(q, qd, coef), robot.inverse_dynamics(q, qd, 0 * qdd)) < 1e-8
    pot = robot.gravity_forces(q) + robot.elastic_forces(q)
    assert rel_err(lib.potential_forces(q, coef), pot) < 1e-8
    np.testing.assert_allclose(lib.stiffness_from_coef(coef), robot.stiffness, rtol=1e-14)
    np.testing.assert_allclose(lib.damping_from_coef(coef), robot.damping, rtol=1e-14)


def test_length_scaled_stiffness_and_other_gravity():
    rng = np.random.default_rng(5)
    L, rho, E, G, D = ROBOTS[2]
    g = (3.0, -7.0)
    robot = PCSRobot(L, rho, E, G, D, radius=[0.02, 0.015], gravity=g, stiffness_scaling="length")
    lib = PhysicalPCSLibrary(L, gravity=g)
    coef = lib.coefficients_from_parameters(rho, [0.02, 0.015], E, G, D, stiffness_scaling="length")
    q, qd, qdd = random_states(rng, 2, 10)
    assert rel_err(lib.euler_lagrange_matrix(q, qd, qdd) @ coef, robot.inverse_dynamics(q, qd, qdd)) < 1e-8


@pytest.mark.parametrize("m", [1, 3])
def test_compiled_dynamics_match_simulator(m):
    rng = np.random.default_rng(10 + m)
    robot, (L, rho, E, G, D) = make(m)
    for identify_gravity in (False, True):
        lib = PhysicalPCSLibrary(L, identify_gravity=identify_gravity)
        fm = lib.forward_model(lib.coefficients_from_parameters(rho, None, E, G, D))
        q, qd, _ = random_states(rng, m, 6)
        for k in range(6):
            M, bias = (a[0] for a in fm.mass_and_bias(q[k], qd[k]))
            assert M.shape == (3 * m, 3 * m) and bias.shape == (3 * m,)
            assert rel_err(M, robot.mass_matrix(q[k])) < 1e-10
            tau = rng.normal(size=3 * m)
            qdd = np.linalg.solve(M, tau - bias)
            assert rel_err(qdd, robot.forward_dynamics(q[k], qd[k], tau)) < 1e-8
    # with strains removed: the compiled model equals the restricted library's batched terms
    keep = np.ones((m, 3), dtype=bool)
    keep[0, 1] = keep[-1, 2] = False
    sub = PhysicalPCSLibrary(L).restrict(keep)
    coef = sub.coefficients_from_parameters(rho, None, E, G, D)
    fm = sub.forward_model(coef)
    q, qd, _ = random_states(rng, m, 4)
    q, qd = q[:, keep.reshape(-1)], qd[:, keep.reshape(-1)]
    M_all, b_all = sub.mass_matrix(q, coef), sub.bias_forces(q, qd, coef)
    for k in range(4):
        M, bias = (a[0] for a in fm.mass_and_bias(q[k], qd[k]))
        assert rel_err(M, M_all[k]) < 1e-12 and rel_err(bias, b_all[k]) < 1e-12


@pytest.mark.parametrize("m", [1, 2])
def test_lagrangian_basis_gives_simulator_energies(m):
    rng = np.random.default_rng(20 + m)
    robot, (L, rho, E, G, D) = make(m)
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    coef = lib.coefficients_from_parameters(rho, None, E, G, D)
    q, qd, _ = random_states(rng, m, 25)
    x = np.hstack([q, qd])
    theta = np.asarray(lib.fit(x).transform(x))
    assert lib.n_features_in_ == 6 * m
    assert theta.shape == (25, lib.n_output_features_) == (25, lib.n_coefficients_ - 3 * m)
    assert len(lib.get_feature_names()) == lib.n_output_features_
    lagrangian = robot.kinetic_energy(q, qd) - robot.potential_energy(q)
    # damping is last and is not part of the Lagrangian
    assert rel_err(theta @ coef[: lib.n_output_features_], lagrangian) < 1e-10
    # list input (several trajectories) as pysindy passes it
    out = lib.transform([x[:10], x[10:]])
    assert len(out) == 2 and np.allclose(np.asarray(out[1]), theta[10:])


def test_pysindy_params_and_clone():
    lib = PhysicalPCSLibrary(
        [0.1, 0.05], active_strains=[[1, 0, 1], [1, 1, 1]], identify_gravity=True, rest_strain=False
    )
    c = clone(lib)
    assert c.get_params() == lib.get_params()
    assert c.n_coefficients_ == lib.n_coefficients_
    c.set_params(identify_gravity=False)
    assert c.n_coefficients_ == lib.n_coefficients_ - 4  # two rhoA g columns per segment fewer
    names = lib.euler_lagrange_names()
    assert names[-5:] == ["d_be_1", "d_ax_1", "d_be_2", "d_sh_2", "d_ax_2"]
    assert [names[j] for j in lib.stiffness_index_] == ["k_be_1", "k_ax_1", "k_be_2", "k_sh_2", "k_ax_2"]
    lb = lib.lower_bounds_
    assert np.all(lb[[j for j, nm in enumerate(names) if "rhoAg" in nm]] == -np.inf)
    assert np.all(lb[[j for j, nm in enumerate(names) if "rhoAg" not in nm]] == 0.0)


def _simulate(m, t, tau_fn):
    robot, (L, rho, E, G, D) = make(m)
    q, qd = simulate_truth(robot, np.zeros(3 * m), np.zeros(3 * m), t, tau_fn, rtol=1e-9)
    return robot, q, qd


@pytest.mark.parametrize("m,identify_gravity,rotary", [(1, True, "tied"), (2, False, "free")])
def test_weak_form_matches_integrated_forces(m, identify_gravity, rotary):
    rng = np.random.default_rng(30 + m)
    L, rho, E, G, D = ROBOTS[m]
    amp = rng.uniform(-1, 1, 3 * m) * np.tile([2e-3, 5e-2, 5e-2], m)
    freq = rng.uniform(5, 15, 3 * m)
    tau_fn = lambda tt: amp * np.sin(2 * np.pi * freq * tt)  # noqa: E731
    t = np.arange(0.0, 0.02, 2e-4)
    robot, q, qd = _simulate(m, t, tau_fn)
    tau = np.array([tau_fn(tt) for tt in t])
    lib = PhysicalPCSLibrary(L, identify_gravity=identify_gravity, rotary_inertia=rotary)
    coef = lib.coefficients_from_parameters(rho, None, E, G, D)
    windows = sliding_windows(t.size, 20, stride=10)
    lhs = lib.integrated_euler_lagrange_matrix(t, q, qd, windows) @ coef
    rhs = integrate_forces(t, tau, windows, hold="simpson")
    assert lhs.shape == rhs.shape == (windows.shape[0], 3 * m)
    assert rel_err(lhs, rhs) < 1e-6
    # the weak form uses no accelerations: the strong form integrated needs them
    qdd = np.array([robot.forward_dynamics(q[k], qd[k], tau[k]) for k in range(t.size)])
    psi = lib.euler_lagrange_matrix(q, qd, qdd) @ coef
    assert rel_err(psi, tau) < 1e-8


@pytest.fixture(scope="module")
def held_trajectory():
    """One-segment robot under actuation held for 50 samples (5 ms), sampled at 10 kHz."""
    rng = np.random.default_rng(40)
    t = np.arange(0.0, 0.02 + 1e-12, 1e-4)
    tau = np.repeat(rng.uniform(-1, 1, (t.size // 50 + 1, 3)) * [2e-3, 5e-2, 5e-2], 50, axis=0)[: t.size]
    robot, _ = make(1)
    q, qd = simulate_truth(robot, np.zeros(3), np.zeros(3), t, tau, rtol=1e-9)
    return t, q, qd, tau


def test_weak_form_with_zero_order_hold(held_trajectory):
    """Held actuation: tau integrated exactly, windows aligned with the holds."""
    t, q, qd, tau = held_trajectory
    L, rho, E, G, D = ROBOTS[1]
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    coef = lib.coefficients_from_parameters(rho, None, E, G, D)
    windows = np.array([[a, a + 50] for a in range(0, t.size - 50, 50)])
    lhs = lib.integrated_euler_lagrange_matrix(t, q, qd, windows, rule="simpson") @ coef
    rhs = integrate_forces(t, tau, windows, hold="zoh")
    np.testing.assert_allclose(rhs, tau[windows[:, 0]] * 50e-4, rtol=1e-9)
    assert rel_err(lhs, rhs) < 1e-5


def test_integrate_forces_rules_exact_cases():
    t = np.sort(np.random.default_rng(0).uniform(0, 1, 31))
    tau = np.stack([np.full_like(t, 2.0), 3.0 * t, t**2], axis=1)
    w = np.array([[0, 30], [3, 17], [5, 6]])
    exact_lin = np.stack([2.0 * (t[w[:, 1]] - t[w[:, 0]]), 1.5 * (t[w[:, 1]] ** 2 - t[w[:, 0]] ** 2)], axis=1)
    for hold in ("trapezoid", "simpson"):
        np.testing.assert_allclose(integrate_forces(t, tau, w, hold=hold)[:, :2], exact_lin, rtol=1e-12)
    # zero-order hold: sum of held values times intervals
    zoh = integrate_forces(t, tau, w)
    for k, (a, b) in enumerate(w):
        np.testing.assert_allclose(zoh[k], (tau[a:b] * np.diff(t[a : b + 1])[:, None]).sum(0), rtol=1e-12)


def test_bounded_fit_on_noisy_data_is_physical():
    rng = np.random.default_rng(50)
    robot, (L, rho, E, G, D) = make(2)
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    n = 6
    q, qd, _ = random_states(rng, 2, 300)
    tau = rng.normal(size=(300, n)) * np.tile([5e-3, 5e-2, 5e-1], 2)
    qdd = robot.forward_dynamics(q, qd, tau)
    # noise on q (1 % of its range / 20) and a heavy 5 % of its spread on the accelerations
    noisy = [
        q + 5e-4 * np.tile(SCALE, 2) * rng.normal(size=q.shape),
        qd,
        qdd + 0.05 * np.std(qdd, axis=0) * rng.normal(size=q.shape),
    ]
    psi = lib.euler_lagrange_matrix(*noisy).reshape(-1, lib.n_coefficients_)
    y = tau.reshape(-1)
    scale = np.linalg.norm(psi, axis=0)
    plain = np.linalg.lstsq(psi / scale, y, rcond=None)[0] / scale
    assert np.any(plain < 0), "the noise level must be high enough to push a free fit negative"
    res = lsq_linear(psi / scale, y, bounds=(lib.lower_bounds_ * scale, np.inf))
    coef = res.x / scale
    assert np.all(coef >= 0)
    assert np.all(lib.stiffness_from_coef(coef) >= 0)
    M = lib.mass_matrix(noisy[0], coef)
    np.linalg.cholesky(M)  # raises unless positive definite at every sample
    assert np.all(np.linalg.eigvalsh(M) > 0)


def test_five_segments_recover_parameters_from_exact_derivatives():
    rng = np.random.default_rng(60)
    m = 5
    L = [0.03, 0.04, 0.05, 0.035, 0.045]
    rho = rng.uniform(900, 1300, m)
    E = rng.uniform(1e4, 1e5, m)
    G = rng.uniform(1e3, 1e4, m)
    D = np.tile([5e-5, 5e-2, 5e-2], m) * rng.uniform(0.5, 2, 3 * m)
    robot = PCSRobot(L, rho, E, G, D)
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    true = lib.coefficients_from_parameters(rho, None, E, G, D)
    q, qd, _ = random_states(rng, m, 400)
    tau = rng.normal(size=(400, 3 * m)) * np.tile([5e-3, 5e-2, 5e-1], m)
    qdd = robot.forward_dynamics(q, qd, tau)
    psi = lib.euler_lagrange_matrix(q, qd, qdd).reshape(-1, lib.n_coefficients_)
    scale = np.linalg.norm(psi, axis=0)
    res = lsq_linear(psi / scale, tau.reshape(-1), bounds=(lib.lower_bounds_ * scale, np.inf), tol=1e-14)
    coef = res.x / scale
    np.testing.assert_allclose(coef, true, rtol=1e-2)


def test_restrict_is_the_library_with_strains_held_at_zero():
    rng = np.random.default_rng(70)
    L = ROBOTS[2][0]
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    keep = np.array([[False, True, True], [True, False, True]])
    sub = lib.restrict(keep)
    mask = keep.reshape(-1)
    q, qd, qdd = random_states(rng, 2, 12)
    full = [a * mask for a in (q, qd, qdd)]
    psi_full = lib.euler_lagrange_matrix(*full)[:, mask, :]
    psi_sub = sub.euler_lagrange_matrix(*(a[:, mask] for a in (q, qd, qdd)))
    np.testing.assert_allclose(psi_sub, psi_full[:, :, sub.column_map_], rtol=1e-13, atol=1e-300)
    dropped = np.setdiff1d(np.arange(lib.n_coefficients_), sub.column_map_)
    assert {lib.euler_lagrange_names()[j] for j in dropped} == {"rhoI_1", "k_be_1", "d_be_1", "k_sh_2", "d_sh_2"}
    assert np.all(psi_full[:, :, dropped] == 0)  # every dropped column vanishes
    # restricting twice composes the column maps
    sub2 = sub.restrict([[False, False, True], [True, False, True]])
    np.testing.assert_array_equal(
        np.asarray(lib.euler_lagrange_names())[sub.column_map_[sub2.column_map_]], sub2.euler_lagrange_names()
    )
    with pytest.raises(ValueError, match="active_strains"):
        sub.restrict(np.ones((2, 3), dtype=bool))
    # a fitted library gives a fitted child whose Lagrangian basis is the parent's at the held strains
    x = np.hstack([q * mask, qd * mask])
    lib.fit(x)
    child = lib.restrict(keep)
    theta_child = np.asarray(child.transform(np.hstack([q[:, mask], qd[:, mask]])))
    theta_parent = np.asarray(lib.transform(x))
    lag_cols = [j for j in child.column_map_ if j < lib.n_output_features_]
    np.testing.assert_allclose(theta_child, theta_parent[:, lag_cols], rtol=1e-13, atol=1e-300)


def test_bad_input_raises_naming_the_argument():
    lib = PhysicalPCSLibrary([0.1])
    ok = np.zeros((4, 3))
    coef = lib.coefficients_from_parameters(1000.0, None, 1e4, 1e3, np.ones(3))
    with pytest.raises(ValueError, match="segment_lengths"):
        PhysicalPCSLibrary([0.1, -0.1]).n_coefficients_
    with pytest.raises(ValueError, match="n_quadrature"):
        PhysicalPCSLibrary([0.1], n_quadrature=0).euler_lagrange_matrix(ok, ok, ok)
    with pytest.raises(ValueError, match="radius"):
        PhysicalPCSLibrary([0.1], radius=-1.0).n_coefficients_
    with pytest.raises(ValueError, match="gravity"):
        PhysicalPCSLibrary([0.1], gravity=(0.0, 1.0, 2.0)).n_coefficients_
    with pytest.raises(ValueError, match="qd"):
        lib.euler_lagrange_matrix(ok, np.zeros((4, 2)), ok)
    with pytest.raises(ValueError, match="qdd"):
        lib.euler_lagrange_matrix(ok, ok, np.full((4, 3), np.nan))
    with pytest.raises(ValueError, match="q "):
        lib.mass_matrix(np.zeros(3), coef)
    with pytest.raises(ValueError, match="coef"):
        lib.mass_matrix(ok, coef[:-1])
    with pytest.raises(ValueError, match="gravity"):
        lib.coefficients_from_parameters(1000.0, None, 1e4, 1e3, np.ones(3), gravity=(0.0, -9.81))
    with pytest.raises(ValueError, match="damping"):
        lib.coefficients_from_parameters(1000.0, None, 1e4, 1e3, np.ones(2))
    with pytest.raises(ValueError, match="density"):
        lib.coefficients_from_parameters([1000.0, 2.0], None, 1e4, 1e3, np.ones(3))
    t = np.arange(5) * 0.1
    with pytest.raises(ValueError, match="windows"):
        lib.integrated_euler_lagrange_matrix(t, np.zeros((5, 3)), np.zeros((5, 3)), [[2, 2]])
    with pytest.raises(ValueError, match="windows"):
        integrate_forces(t, np.zeros((5, 3)), [[0, 5]])
    with pytest.raises(ValueError, match="t must"):
        integrate_forces(t[::-1], np.zeros((5, 3)), [[0, 4]])
    with pytest.raises(ValueError, match="hold"):
        integrate_forces(t, np.zeros((5, 3)), [[0, 4]], hold="foh")
    with pytest.raises(ValueError, match="rule"):
        lib.integrated_euler_lagrange_matrix(t, np.zeros((5, 3)), np.zeros((5, 3)), [[0, 4]], rule="euler")
    with pytest.raises(ValueError, match="width"):
        sliding_windows(5, 5)
    with pytest.raises(ValueError, match="x must"):
        lib.fit(np.zeros((4, 5)))


def test_identifiability_standard_errors_and_unexcited_columns():
    from pcs_sindy.identification.identifiability import identifiability

    rng = np.random.default_rng(80)
    x = rng.normal(size=(200, 3)) * [1.0, 1e3, 1e-3]
    true = np.array([2.0, -1e-3, 5e3])
    y = x @ true + 0.1 * rng.normal(size=200)
    coef = np.linalg.lstsq(x, y, rcond=None)[0]
    rep = identifiability(x, y, coef, names=["a", "b", "c"])
    # textbook formula with the explicit inverse (fine for this tiny, well-scaled check)
    s2 = np.sum((y - x @ coef) ** 2) / (200 - 3)
    np.testing.assert_allclose(rep["standard_errors"], np.sqrt(s2 * np.diag(np.linalg.inv(x.T @ x))), rtol=1e-8)
    assert np.isfinite(rep["condition_number"]) and rep["rank"] == 3
    assert rep["poorly_determined"] == []
    # a column that is never excited and a duplicated one are flagged, not silently fitted
    x2 = np.hstack([x, np.zeros((200, 1)), x[:, :1]])
    coef2 = np.append(coef, [0.0, 0.0])
    rep2 = identifiability(x2, y, coef2, names=["a", "b", "c", "never", "dup"])
    assert rep2["condition_number"] == np.inf and rep2["rank"] == 3
    assert np.isinf(rep2["standard_errors"][[0, 3, 4]]).all() and np.isfinite(rep2["standard_errors"][1:3]).all()
    assert set(rep2["poorly_determined"]) == {"a", "never", "dup"}
    with pytest.raises(ValueError, match="coef"):
        identifiability(x, y, coef[:2])


def test_tied_rotary_inertia_is_exact_for_circular_sections():
    rng = np.random.default_rng(90)
    robot, (L, rho, E, G, D) = make(2, radius=[0.02, 0.015])
    free = PhysicalPCSLibrary(L, radius=[0.02, 0.015])
    tied = PhysicalPCSLibrary(L, radius=[0.02, 0.015], rotary_inertia="tied")
    assert tied.n_coefficients_ == free.n_coefficients_ - 2
    assert not any(nm.startswith("rhoI") for nm in tied.euler_lagrange_names())
    coef = tied.coefficients_from_parameters(rho, None, E, G, D)
    q, qd, qdd = random_states(rng, 2, 10)
    assert rel_err(tied.euler_lagrange_matrix(q, qd, qdd) @ coef, robot.inverse_dynamics(q, qd, qdd)) < 1e-8
    assert rel_err(tied.mass_matrix(q, coef), robot.mass_matrix(q)) < 1e-8
    M, bias = (a[0] for a in tied.forward_model(coef).mass_and_bias(q[3], qd[3]))
    assert rel_err(M, robot.mass_matrix(q[3])) < 1e-10
    x = np.hstack([q, qd])
    lag = np.asarray(tied.fit(x).transform(x)) @ coef[: tied.n_output_features_]
    assert rel_err(lag, robot.kinetic_energy(q, qd) - robot.potential_energy(q)) < 1e-10
    with pytest.raises(ValueError, match="radius"):
        tied.coefficients_from_parameters(rho, 0.03, E, G, D)
    with pytest.raises(ValueError, match="rotary_inertia"):
        PhysicalPCSLibrary(L, rotary_inertia="yes").n_coefficients_


def test_bump_weighted_weak_form(held_trajectory):
    """Test-function weak form: no boundary samples; exact ZOH weights; matches the forces."""
    t, q, qd, tau = held_trajectory
    L, rho, E, G, D = ROBOTS[1]
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    coef = lib.coefficients_from_parameters(rho, None, E, G, D)
    windows = sliding_windows(t.size, 50, stride=25)  # windows straddle actuation switches
    lhs = lib.integrated_euler_lagrange_matrix(t, q, qd, windows, test_function="bump") @ coef
    rhs = integrate_forces(t, tau, windows, hold="zoh", test_function="bump")
    assert rel_err(lhs, rhs) < 1e-4
    x, y = weak_form_rows(lib, t, q, qd, tau, 50, 25)
    np.testing.assert_allclose(x @ coef, lhs.reshape(-1), rtol=1e-12)
    np.testing.assert_allclose(y, rhs.reshape(-1), rtol=1e-12)
    # exact ZOH weights: a constant tau integrates to tau * int phi dt = tau * span * 16/35 (Beta(4, 4) * 64)
    const = integrate_forces(t, np.ones((t.size, 2)), windows, test_function="bump")
    span = t[windows[:, 1]] - t[windows[:, 0]]
    np.testing.assert_allclose(const, (span * 64.0 / 140.0)[:, None] * np.ones((1, 2)), rtol=1e-12)
    # the damping column needs no qd: it is -int phi' q dt = int phi qd dt
    psi = lib.integrated_euler_lagrange_matrix(t, q, np.zeros_like(qd), windows, test_function="bump")
    direct = integrate_forces(t, qd, windows, hold="trapezoid", test_function="bump")
    d_cols = lib.damping_index_
    assert rel_err(psi[:, np.arange(3), d_cols], direct) < 1e-2  # two quadratures of one integral


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")  # quad reaches round-off, as asked
def test_moments_against_adaptive_quadrature():
    from scipy.integrate import quad

    from pcs_sindy.models.pcs_numeric import moments

    us = np.array([0.0, 1e-12, -1e-6, 0.5, -2.9999, 3.0, 3.0001, -3.5, 6.283185307179586, 9.0, -14.0])
    big = np.repeat(us, 100)  # large arrays (> 512 values) take the Horner branch of the series
    for arr in (us, us[np.abs(us) <= 3], big, big[np.abs(big) <= 3]):  # mixed and all-series branches
        e = [x[::100] for x in moments(arr)] if arr.size > 100 else moments(arr)
        arr = arr[::100] if arr.size > 100 else arr
        for n in range(3):
            ref = [
                quad(lambda x: x**n * np.cos(u * x), 0, 1, epsabs=1e-15, epsrel=1e-14, limit=200)[0]
                + 1j * quad(lambda x: x**n * np.sin(u * x), 0, 1, epsabs=1e-15, epsrel=1e-14, limit=200)[0]
                for u in arr
            ]
            np.testing.assert_allclose(e[n], ref, rtol=0, atol=2e-15)
