"""StiffnessThresholdOptimizer on synthetic linear problems with known truth.

The optimizer only needs from a library: ``kinematics``, ``n_coefficients_``,
``stiffness_index_``, ``euler_lagrange_matrix`` and ``restrict`` (limit rule,
``column_map_``).  ``ToyLibrary`` below is an independent, hand-derived
Lagrangian library for a toy 3-strain system (kinetic ``1/2 m_e qd_e^2``,
elastic ``q_e^2``, one potential coupling ``q_0 q_1``, damping), so truth is
known in closed form.
"""

from __future__ import annotations

import numpy as np
import pysindy as ps
import pytest
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from pcs_sindy.identification import StiffnessThresholdOptimizer, scaled_lstsq, stiffness_bounds

from toy_library import ToyLibrary

# truth: masses, stiffnesses k (coef -k/2), coupling, damping
MASS = np.array([2e-4, 5e-4, 3e-4])
K_TRUE = np.array([1.5e-3, 3.0e3, 12.0])
COUPLE = 0.02
DAMP = np.array([1e-5, 2.0, 0.1])
PI_TRUE = np.concatenate([MASS, -K_TRUE / 2, [COUPLE], DAMP])


def _data(n=400, seed=0):
    rng = np.random.default_rng(seed)
    scale = np.array([30.0, 0.2, 0.2])
    q = rng.normal(size=(n, 3)) * scale
    qd = rng.normal(size=(n, 3)) * scale * 20
    qdd = rng.normal(size=(n, 3)) * scale * 400
    lib = ToyLibrary()
    psi = lib.euler_lagrange_matrix(q, qd, qdd)
    tau = psi @ PI_TRUE
    return lib, q, qd, qdd, psi, tau


def test_stiffness_bounds_match_seed_numbers():
    area, inertia = np.pi * 0.02**2, np.pi * 0.02**4 / 4
    expected = [inertia * 100e6, 4 / 3 * area * 0.1e6, area * 100e6]
    b = stiffness_bounds([0.07, 0.1])
    np.testing.assert_allclose(b, expected * 2, rtol=1e-14)
    # the seed's rounded values
    np.testing.assert_allclose(b[:3], [12.6, 168.0, 126e3], rtol=5e-3)
    np.testing.assert_allclose(stiffness_bounds([0.07, 0.1], stiffness_scaling="length"), b * np.repeat([0.07, 0.1], 3))
    with pytest.raises(ValueError, match="stiffness_scaling"):
        stiffness_bounds([0.1], stiffness_scaling="meters")
    with pytest.raises(ValueError, match="segment_lengths"):
        stiffness_bounds([0.1, -0.2])


def test_recovers_coefficients_without_removal():
    lib, q, qd, qdd, psi, tau = _data()
    opt = StiffnessThresholdOptimizer(max_stiffness=[1e9] * 3).fit(psi, tau, library=lib, states=(q, qd, qdd))
    np.testing.assert_allclose(opt.coef_[0], PI_TRUE, rtol=1e-9)
    np.testing.assert_allclose(opt.stiffness_, K_TRUE, rtol=1e-9)
    assert opt.removed_strains_ == [] and opt.n_rounds_ == 1
    assert opt.active_strains_.all()


def test_removes_exactly_the_strain_above_its_bound():
    lib, q, qd, qdd, psi, tau = _data()
    bounds = np.array([1.0, 100.0, 100.0])  # only K_TRUE[1] = 3000 exceeds
    opt = StiffnessThresholdOptimizer(max_stiffness=bounds).fit(psi, tau, library=lib, states=(q, qd, qdd))
    assert opt.removed_strains_ == ["sh_1"]
    np.testing.assert_array_equal(opt.active_strains_, [[True, False, True]])
    assert len(opt.history_) == 2
    np.testing.assert_allclose(opt.history_[0]["stiffness"], K_TRUE, rtol=1e-9)
    assert opt.history_[0]["removed"] == ["sh_1"] and opt.history_[1]["removed"] == []
    assert opt.stiffness_[1] == np.inf
    # independent check of the second round: plain lstsq on the hand-built
    # limit-rule design (strain 1 zeroed, its row and the columns that
    # involve it dropped)
    keep_cols = [0, 2, 3, 5, 7, 9]  # kin0, kin2, el0, el2, damp0, damp2
    q0, qd0, qdd0 = (a.copy() for a in (q, qd, qdd))
    for a in (q0, qd0, qdd0):
        a[:, 1] = 0
    psi_full = ToyLibrary().euler_lagrange_matrix(q0, qd0, qdd0)
    X = psi_full[:, [0, 2], :][:, :, keep_cols].reshape(-1, len(keep_cols))
    y = tau[:, [0, 2]].reshape(-1)
    ref = np.linalg.lstsq(X, y, rcond=None)[0]
    np.testing.assert_allclose(opt.coef_[0, keep_cols], ref, rtol=1e-8)
    dropped = np.setdiff1d(np.arange(10), keep_cols)
    assert np.all(opt.coef_[0, dropped] == 0)
    np.testing.assert_array_equal(opt.column_map_, keep_cols)
    assert opt.stiffness_[0] == pytest.approx(-2 * ref[2]) and opt.stiffness_[2] == pytest.approx(-2 * ref[3])


def test_physical_bound_is_applied_in_physical_units():
    # the seed's bounds (12.6 N m^2, 168 N, 126 kN): shear 3000 N > 168 N only
    lib, q, qd, qdd, psi, tau = _data()
    opt = StiffnessThresholdOptimizer().fit(psi, tau, library=lib, states=(q, qd, qdd))
    assert opt.removed_strains_ == ["sh_1"]
    # with G_max raised above the shear stiffness nothing is removed
    opt2 = StiffnessThresholdOptimizer(shear_modulus_max=1e8).fit(psi, tau, library=lib, states=(q, qd, qdd))
    assert opt2.removed_strains_ == []
    # threshold=inf never removes
    opt3 = StiffnessThresholdOptimizer(threshold=np.inf).fit(psi, tau, library=lib, states=(q, qd, qdd))
    assert opt3.removed_strains_ == [] and opt3.active_strains_.all()


def test_threshold_is_a_factor_on_the_bound():
    lib, q, qd, qdd, psi, tau = _data()
    k = StiffnessThresholdOptimizer(threshold=np.inf).fit(psi, tau, library=lib, states=(q, qd, qdd)).stiffness_
    bounds = StiffnessThresholdOptimizer().fit(psi, tau, library=lib, states=(q, qd, qdd)).max_stiffness_
    # a factor just below k/bound of the softest strain removes every strain above it, and only those
    ratio = np.sort(k / bounds)
    factor = 0.5 * (ratio[0] + ratio[1])
    opt = StiffnessThresholdOptimizer(threshold=factor).fit(psi, tau, library=lib, states=(q, qd, qdd))
    softest = lib.kinematics.strain_names()[int(np.argmin(k / bounds))]
    assert len(opt.removed_strains_) >= 1 and softest not in opt.removed_strains_
    # the former switch keeps working for a release
    with pytest.warns(FutureWarning, match="threshold=np.inf"):
        old = StiffnessThresholdOptimizer(threshold=False).fit(psi, tau, library=lib, states=(q, qd, qdd))
    assert old.removed_strains_ == []
    for bad in (0.0, -1.0, "yes", np.nan, None):
        with pytest.raises(ValueError, match="threshold must be a number > 0"):
            StiffnessThresholdOptimizer(threshold=bad).fit(psi, tau, library=lib, states=(q, qd, qdd))


def test_max_iter_exhausted_warns_and_keeps_a_consistent_model():
    lib, q, qd, qdd, psi, tau = _data()
    with pytest.warns(ConvergenceWarning, match="max_iter"):
        opt = StiffnessThresholdOptimizer(max_stiffness=[1, 100, 100], max_iter=1).fit(
            psi, tau, library=lib, states=(q, qd, qdd)
        )
    assert opt.removed_strains_ == [] and opt.active_strains_.all()
    np.testing.assert_allclose(opt.coef_[0], PI_TRUE, rtol=1e-9)


def test_column_scaling_survives_badly_scaled_columns():
    # columns spanning 16 orders of magnitude: normal equations would lose
    # every digit (cond^2 ~ 1e32); the scaled SVD solve keeps them
    rng = np.random.default_rng(1)
    x = rng.normal(size=(300, 4)) * np.array([1e-8, 1.0, 1e4, 1e8])
    truth = np.array([3e7, -2.0, 5e-4, 1e-8])
    coef, info = scaled_lstsq(x, x @ truth)
    np.testing.assert_allclose(coef, truth, rtol=1e-10)
    assert info["rank"] == 4 and info["relative_residual"] < 1e-12


def test_plain_mode_matches_numpy_lstsq():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(200, 5))
    y = rng.normal(size=(200, 2))
    opt = StiffnessThresholdOptimizer().fit(x, y)
    np.testing.assert_allclose(opt.coef_, np.linalg.lstsq(x, y, rcond=None)[0].T, rtol=1e-10)
    w = rng.uniform(0.5, 2.0, size=200)
    opt_w = StiffnessThresholdOptimizer().fit(x, y[:, 0], sample_weight=w)
    sw = np.sqrt(w)
    np.testing.assert_allclose(
        opt_w.coef_[0], np.linalg.lstsq(x * sw[:, None], y[:, 0] * sw, rcond=None)[0], rtol=1e-10
    )


def test_rank_deficient_and_bad_input_raise():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(100, 3))
    x_dup = np.column_stack([x, x[:, 0] * 2.0])
    with pytest.raises(ValueError, match="rank-deficient"):
        StiffnessThresholdOptimizer().fit(x_dup, x_dup.sum(axis=1))
    x_zero = x.copy()
    x_zero[:, 1] = 0
    with pytest.raises(ValueError, match="all zero"):
        StiffnessThresholdOptimizer().fit(x_zero, x[:, 0], feature_names=["a", "b", "c"])
    x_nan = x.copy()
    x_nan[5, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        StiffnessThresholdOptimizer().fit(x_nan, x[:, 0])
    with pytest.raises(ValueError, match="rows"):
        StiffnessThresholdOptimizer().fit(x, x[:50, 0])
    lib, q, qd, qdd, psi, tau = _data(50)
    with pytest.raises(ValueError, match="states"):
        StiffnessThresholdOptimizer().fit(psi, tau, library=lib)
    with pytest.raises(ValueError, match="max_stiffness"):
        StiffnessThresholdOptimizer(max_stiffness=[1.0, 2.0]).fit(psi, tau, library=lib, states=(q, qd, qdd))
    with pytest.raises(ValueError, match="max_iter"):
        StiffnessThresholdOptimizer(max_iter=0).fit(x, x[:, 0])
    # every strain above its bound
    with pytest.raises(ValueError, match="every strain"):
        StiffnessThresholdOptimizer(max_stiffness=[1e-9] * 3).fit(psi, tau, library=lib, states=(q, qd, qdd))


def test_set_params_returns_self_and_clone_round_trip():
    opt = StiffnessThresholdOptimizer(shear_modulus_max=2e5, stiffness_scaling="length")
    assert opt.set_params(rcond=1e-8, max_iter=5) is opt
    params = opt.get_params()
    assert params["rcond"] == 1e-8 and params["max_iter"] == 5 and params["shear_modulus_max"] == 2e5
    twin = clone(opt)
    assert twin is not opt and twin.get_params() == params
    assert StiffnessThresholdOptimizer(**params).get_params() == params


def test_plain_mode_inside_pysindy():
    t = np.linspace(0, 10, 2001)
    x = np.c_[np.cos(t), -np.sin(t)]  # x0' = x1, x1' = -x0
    model = ps.SINDy(optimizer=StiffnessThresholdOptimizer(), feature_library=ps.PolynomialLibrary(degree=1))
    model.fit(x, t=t)
    np.testing.assert_allclose(model.coefficients(), [[0, 0, 1], [0, -1, 0]], atol=1e-4)
