"""Identified rest strains: constant generalised forces ``f0`` in the physical library.

Model: ``M q̈ + C q̇ + G + K q + D q̇ - f0 = tau`` with ``f0 = K q*``.  Truth: a
simulated robot with a rest strain ``q*`` is exactly the simulator driven by
``tau + K q*`` (its elastic force is ``K (q - q*)``), so the regressor sees the
user's ``tau`` and must find ``q*``; closed forms of the window integrals of a
constant; and the rest-length analysis (a rest length ``(1 + e)`` too long is
an axial rest strain ``-e / (1 + e)`` in the fused strains).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from truth import simulate_truth

from pcs_sindy.core import StrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.identification.formulations import integrate_forces, sliding_windows
from pcs_sindy.simulation import get_scenario

WEAK = dict(formulation="weak", weak_window=40, weak_stride=20, window_length=7)


def _states(n, seed, n_samples=12):
    rng = np.random.default_rng(seed)
    scale = np.tile([8.0, 0.05, 0.05], n // 3)
    return [rng.uniform(-1, 1, (n_samples, n)) * scale for _ in range(3)]


def test_columns_layout_and_strong_form():
    L = [0.07, 0.1]
    plain = PhysicalPCSLibrary(L, rest_strain=False)
    lib = PhysicalPCSLibrary(L, rest_strain=True)
    n = 6
    assert lib.n_coefficients_ == plain.n_coefficients_ + n
    names = lib.euler_lagrange_names()
    assert [names[j] for j in lib.rest_force_index_] == [
        "f0_be_1",
        "f0_sh_1",
        "f0_ax_1",
        "f0_be_2",
        "f0_sh_2",
        "f0_ax_2",
    ]
    # damping stays last, the stiffness columns do not move
    np.testing.assert_array_equal(lib.damping_index_, np.arange(lib.n_coefficients_ - n, lib.n_coefficients_))
    np.testing.assert_array_equal(lib.stiffness_index_, plain.stiffness_index_)
    lb = lib.lower_bounds_
    assert np.all(lb[lib.rest_force_index_] == -np.inf)
    assert np.all(np.delete(lb, lib.rest_force_index_) == plain.lower_bounds_)
    q, qd, qdd = _states(n, 0)
    psi = lib.euler_lagrange_matrix(q, qd, qdd)
    # f0 enters with -1 in the row of its own strain only
    np.testing.assert_array_equal(psi[:, :, lib.rest_force_index_], np.broadcast_to(-np.eye(n), (q.shape[0], n, n)))
    others = np.delete(np.arange(lib.n_coefficients_), lib.rest_force_index_)
    np.testing.assert_allclose(psi[:, :, others], plain.euler_lagrange_matrix(q, qd, qdd), rtol=0, atol=0)


@pytest.mark.parametrize("test_function", [None, "bump"])
def test_weak_form_integrates_the_constant(test_function):
    lib = PhysicalPCSLibrary([0.1], rest_strain=True)
    T = 201
    t = np.linspace(0.0, 0.4, T) + 0.01 * np.sin(np.linspace(0, 3, T))  # non-uniform sampling
    rng = np.random.default_rng(1)
    q = rng.normal(size=(T, 3)) * [1.0, 0.01, 0.01]
    qd = rng.normal(size=(T, 3))
    w = sliding_windows(T, 40, 25)
    x = lib.integrated_euler_lagrange_matrix(t, q, qd, w, test_function=test_function)
    span = t[w[:, 1]] - t[w[:, 0]]
    # closed form: int_0^1 (4x(1-x))^3 dx = 64 B(4, 4) = 16/35; plain window: its length
    factor = 16.0 / 35.0 if test_function == "bump" else 1.0
    expect = -factor * span[:, None, None] * np.eye(3)[None]
    tol = 2e-4 if test_function == "bump" else 1e-12  # the bump's trapezoid rule on 40 intervals
    np.testing.assert_allclose(x[:, :, lib.rest_force_index_], expect, rtol=tol, atol=1e-15)
    # consistent with integrate_forces of a constant force of -1 (same weights, zoh exact)
    y = integrate_forces(t, -np.ones((T, 3)), w, hold="zoh", test_function=test_function)
    np.testing.assert_allclose(x[:, np.arange(3), lib.rest_force_index_], y, rtol=tol)


def test_restrict_forces_compiled_dynamics_and_lagrangian():
    L = [0.07, 0.1]
    lib = PhysicalPCSLibrary(L, rest_strain=True)
    rng = np.random.default_rng(2)
    coef = np.abs(rng.normal(size=lib.n_coefficients_))
    f0 = rng.normal(size=6)
    coef[lib.rest_force_index_] = f0
    q, qd, _ = _states(6, 3)
    plain = PhysicalPCSLibrary(L, rest_strain=False)
    c_plain = np.delete(coef, lib.rest_force_index_)
    np.testing.assert_allclose(
        lib.potential_forces(q, coef), plain.potential_forces(q, c_plain) - f0, rtol=1e-12, atol=1e-12
    )
    bias = lib.bias_forces(q, qd, coef)
    np.testing.assert_allclose(bias, plain.bias_forces(q, qd, c_plain) - f0, rtol=1e-12, atol=1e-12)
    _, b = lib.forward_model(coef).mass_and_bias(q, qd)
    np.testing.assert_allclose(b, bias, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(lib.rest_force_from_coef(coef), f0)
    np.testing.assert_array_equal(lib.lumped_from_coef(coef)["rest_force"], f0)
    np.testing.assert_array_equal(plain.rest_force_from_coef(c_plain), np.zeros(6))
    # strain removal drops the f0 column of the removed strain
    keep = np.array([[1, 0, 1], [1, 1, 1]], dtype=bool)
    red = lib.restrict(keep)
    red_names = red.euler_lagrange_names()
    assert "f0_sh_1" not in red_names and "f0_ax_1" in red_names
    assert [lib.euler_lagrange_names()[j] for j in red.column_map_] == red_names
    qf = q.copy()
    qf[:, 1] = 0.0
    qdf = qd.copy()
    qdf[:, 1] = 0.0
    k = keep.reshape(-1)
    psi_full = lib.euler_lagrange_matrix(qf, qdf, np.zeros_like(qf))
    psi_red = red.euler_lagrange_matrix(qf[:, k], qdf[:, k], np.zeros((q.shape[0], 5)))
    np.testing.assert_allclose(psi_red, psi_full[:, k][:, :, red.column_map_], rtol=1e-12, atol=1e-14)
    # Lagrangian basis of f0_e is q_e (potential -f0 q)
    lib.fit(np.zeros((1, 12)))
    feats = np.asarray(lib.transform(np.hstack([q, qd])))
    lag_cols = [j for j in range(lib.n_coefficients_) if j not in set(lib.damping_index_)]
    for r, j in enumerate(lib.rest_force_index_):
        np.testing.assert_array_equal(feats[:, lag_cols.index(j)], q[:, r])


def _held(robot, f0, n_rec=3, n_samples=400, hold=25, seed=0):
    """Simulator rollouts under held forces; the robot feels ``tau + f0`` (a rest strain ``f0 / K``)."""
    rng = np.random.default_rng(seed)
    n = robot.n_q
    t = np.arange(n_samples) * 1e-3
    X, taus = [], []
    for _ in range(n_rec):
        targets = rng.uniform(-1, 1, (n_samples // hold + 1, n)) * np.tile([20.0, 0.05, 0.02], robot.n_segments)
        tau = np.repeat(robot.gravity_forces(targets) + robot.elastic_forces(targets), hold, axis=0)[:n_samples]
        q, _ = simulate_truth(robot, np.zeros(n), np.zeros(n), t, tau + f0)
        X.append(StrainTrajectory(q, t, segment_lengths=robot.kinematics.segment_lengths))
        taus.append(tau)
    return X, taus, t


def test_regressor_recovers_a_known_rest_strain_and_rolls_it_out():
    robot = get_scenario("one_segment").robot
    q_star = np.array([3.0, 0.01, 0.02])
    X, taus, t = _held(robot, robot.stiffness * q_star)
    model = EulerLagrangeRegressor(**WEAK).fit(X, taus)  # rest strains are the default
    # measured: rest strain within 1e-5, stiffness 4e-5, damping 2e-5 (relative)
    np.testing.assert_allclose(model.rest_strain_, q_star, rtol=1e-3)
    np.testing.assert_allclose(model.stiffness_, robot.stiffness, rtol=1e-3)
    np.testing.assert_allclose(model.damping_, robot.damping, rtol=1e-3)
    # without the offsets the same data bias the stiffness (measured 13-69 %)
    plain = EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(rest_strain=False), **WEAK).fit(X, taus)
    assert np.max(np.abs(plain.stiffness_ / robot.stiffness - 1)) > 0.1
    np.testing.assert_array_equal(plain.rest_strain_, np.zeros(3))
    # the compiled and the solve_ivp rollouts both carry f0 and reproduce the simulator (measured 3.7e-4 rad/m)
    scale = np.abs(X[0].q).max(axis=0)
    runs = [
        model.simulate(X[0].q[0], np.zeros(3), t, taus[0], method=m, rtol=1e-9, atol=1e-11).q
        for m in ("rosenbrock", "radau")
    ]
    np.testing.assert_allclose(runs[0], runs[1], rtol=0, atol=1e-6 * scale.max())
    assert np.all(np.abs(runs[0] - X[0].q).max(axis=0) <= 5e-3 * scale)


def test_no_rest_strain_in_the_data_gives_zero_offsets():
    robot = get_scenario("one_segment").robot
    X, taus, _ = _held(robot, np.zeros(3), n_rec=2, seed=4)
    model = EulerLagrangeRegressor(**WEAK).fit(X, taus)
    scale = np.abs(np.concatenate([x.q for x in X])).max(axis=0)
    # measured: |q*| / range below 1e-5
    assert np.all(np.abs(model.rest_strain_) <= 1e-3 * scale)
    np.testing.assert_allclose(model.stiffness_, robot.stiffness, rtol=1e-3)


def test_parameter_validation():
    X = [StrainTrajectory(np.zeros((50, 3)), np.arange(50) * 1e-3, segment_lengths=[0.1])]
    tau = [np.zeros((50, 3))]
    refused = "PhysicalPCSLibrary: rest_strain must be a boolean or a tuple of strain kinds"
    with pytest.raises(ValueError, match=refused):
        EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(rest_strain="yes")).fit(X, tau)
    with pytest.raises(ValueError, match=refused):
        PhysicalPCSLibrary([0.1], rest_strain=1).n_coefficients_


def test_wrong_rest_length_is_absorbed_by_the_axial_offset():
    from pcs_sindy.core import PoseTrajectory, end_effector_errors
    from pcs_sindy.fusion import KinematicFusion

    scenario = get_scenario("two_segment")
    data = scenario.generate(seed=0)
    L_true = float(np.sum(scenario.robot.kinematics.segment_lengths))
    e = 0.01
    fusion = KinematicFusion(threshold=0.2, total_length=L_true * (1 + e), pose_std=(5e-4, float(np.deg2rad(1.0))))
    trajs = [PoseTrajectory(r.poses, r.t) for r in data.train]
    strains = fusion.fit(trajs).transform(trajs)
    assert len(fusion.segment_lengths_) == 2
    val = data.validation
    k = int(round(1.0 / (val.t[1] - val.t[0]))) + 1  # 1 s of the validation
    errors, models = [], []
    for rest in (False, True):
        model = EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(rest_strain=rest), window_length=15)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.fit(strains, [r.tau for r in data.train])
        sim = model.simulate(np.zeros(6), np.zeros(6), val.t[:k], val.tau[:k])
        tip = sim.poses(np.array([L_true * (1 + e)]))
        errors.append(end_effector_errors(tip, val.poses_true[:k, -1:, :])[0])
        models.append(model)
    # measured: 4.83 mm without, 0.34 mm with the offsets
    assert errors[1] * 8 < errors[0], errors
    # the analysis: lengths (1 + e) too long read strains sigma_f = (1 + sigma) / (1 + e) - 1, so the
    # robot at rest sits at the axial rest strain -e / (1 + e), with f0 = K_f q* = -k_ax e
    fitted = models[1]
    # measured: within 0.2 % (q*) and 0.14 % (f0)
    np.testing.assert_allclose(fitted.rest_strain_[[2, 5]], -e / (1 + e), rtol=0.02)
    f0 = fitted.library_.rest_force_from_coef(fitted.model_coef_)
    k_ax = scenario.robot.stiffness[[2, 5]]
    np.testing.assert_allclose(f0[[2, 5]], -k_ax * e, rtol=0.02)
