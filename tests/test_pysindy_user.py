"""A pysindy or scikit-learn user's script runs unchanged on the regressor (issue 28, items 1-2).

Truth: the same fit through the package's own call style (``StrainTrajectory`` recordings), the
scenario's material parameters and stiffened strains, the library's Euler–Lagrange matrix (which
columns act on which equation), and scikit-learn's ``clone`` / ``GridSearchCV`` / pickle.
"""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pysindy as ps
import pytest
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV

from pcs_sindy.core import StrainTrajectory, rollout_r2_scorer
from pcs_sindy.identification import (
    EulerLagrangeRegressor,
    PhysicalPCSLibrary,
    StiffnessThresholdOptimizer,
    WeakEulerLagrangeSINDy,
)
from pcs_sindy.simulation import get_scenario


@pytest.fixture(scope="module")
def one_segment():
    sc = get_scenario("one_segment")
    data = sc.generate(seed=0, validation=False)
    lengths = list(sc.robot.segment_lengths)
    X = [StrainTrajectory(r.q, r.t, segment_lengths=lengths) for r in data.train]
    return sc.robot, data.train, X, [r.tau for r in data.train], lengths


@pytest.fixture(scope="module")
def fitted(one_segment):
    _, _, X, y, _ = one_segment
    return EulerLagrangeRegressor().fit(X, y)


# -- item 1: fit(q, t=..., u=..., segment_lengths=...) ------------------------------------------
def test_array_fit_is_the_trajectory_fit(one_segment, fitted):
    robot, recs, X, y, lengths = one_segment
    qs, dt = [r.q for r in recs], float(recs[0].t[1] - recs[0].t[0])
    by_dt = EulerLagrangeRegressor().fit(qs, t=dt, u=y, segment_lengths=lengths)
    by_times = EulerLagrangeRegressor().fit(qs, t=[r.t for r in recs], u=y, segment_lengths=lengths)
    np.testing.assert_array_equal(by_dt.coef_, fitted.coef_)
    np.testing.assert_array_equal(by_times.coef_, fitted.coef_)
    # one recording, pysindy's positional order fit(x, t, u=u), and scikit-learn's fit(X, y, t=...)
    one = EulerLagrangeRegressor().fit(X[:2], y[:2])
    np.testing.assert_array_equal(
        EulerLagrangeRegressor().fit(qs[:2], dt, u=y[:2], segment_lengths=lengths).coef_, one.coef_
    )
    np.testing.assert_array_equal(
        EulerLagrangeRegressor().fit(qs[:2], y[:2], t=dt, segment_lengths=lengths).coef_, one.coef_
    )
    single = EulerLagrangeRegressor().fit(qs[0], t=recs[0].t, u=y[0], segment_lengths=lengths)
    np.testing.assert_array_equal(single.coef_, EulerLagrangeRegressor().fit(X[:1], y[:1]).coef_)
    k_be = single.stiffness_[0]
    assert k_be == pytest.approx(robot.stiffness[0], rel=0.02)


def test_plain_arrays_without_a_segmentation_say_how_to_give_it(one_segment):
    _, recs, X, y, lengths = one_segment
    with pytest.raises(
        ValueError, match=r"segment_lengths=\[L_1, \.\.\., L_m\].*StrainTrajectory\(q, t, segment_lengths="
    ):
        EulerLagrangeRegressor().fit([r.q for r in recs], t=1e-3, u=y)
    with pytest.raises(ValueError, match="give t="):
        EulerLagrangeRegressor().fit([r.q for r in recs], u=y, segment_lengths=lengths)
    with pytest.raises(ValueError, match="inputs were given twice"):
        EulerLagrangeRegressor().fit(X, y, u=y)
    with pytest.raises(ValueError, match="carry their own time stamps"):
        EulerLagrangeRegressor().fit(X, y, segment_lengths=lengths)
    with pytest.raises(ValueError, match="inputs of each recording are required"):
        EulerLagrangeRegressor().fit([r.q for r in recs], t=1e-3, segment_lengths=lengths)
    with pytest.raises(ValueError, match=r"X\[1\]: q must have shape \(T, 3\)"):
        EulerLagrangeRegressor().fit([recs[0].q, recs[1].q[:, :2]], t=1e-3, u=y[:2], segment_lengths=lengths)
    with pytest.raises(ValueError, match="one time array but X holds 2 recordings"):
        EulerLagrangeRegressor().fit([r.q for r in recs[:2]], t=recs[0].t, u=y[:2], segment_lengths=lengths)


def test_print_with_lhs_and_feature_names(fitted, capsys):
    fitted.print()
    assert capsys.readouterr().out.splitlines() == fitted.equations()  # the library's format, as before
    fitted.print(lhs=["M_z", "F_x", "F_y"], precision=4)
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split(" = ")[0] for ln in lines] == ["M_z", "F_x", "F_y"]
    assert [ln.split(" = ", 1)[1] for ln in lines] == fitted.strain_equations(precision=4)
    with pytest.raises(ValueError, match=r"lhs must be a list of 3 names"):
        fitted.print(lhs=["only_one"])
    with pytest.raises(ValueError, match=r"lhs must be a list of 3 names"):
        fitted.print(4)
    names = fitted.get_feature_names_out()
    assert names.dtype == object and list(names) == fitted.get_feature_names()
    assert names.shape == (fitted.coefficients().shape[1],)
    with pytest.raises(ValueError, match="input_features must be None"):
        fitted.get_feature_names_out(["a", "b", "c"])


def test_coefficients_hold_one_row_per_strain_equation(one_segment, fitted):
    _, recs, _, _, _ = one_segment
    coefs = fitted.coefficients()
    lib = fitted.library_
    assert coefs.shape == (3, fitted.coef_.size)
    # every entry is the coefficient of its column or 0
    assert np.all((coefs == 0) | (coefs == fitted.coef_[None, :]))
    # a stiffness and a damping act on their own strain's equation alone
    for e, (k, d) in enumerate(zip(lib.stiffness_index_, lib.damping_index_, strict=True)):
        assert coefs[e, k] == fitted.coef_[k] != 0 and np.count_nonzero(coefs[:, k]) == 1
        assert coefs[e, d] == fitted.coef_[d] != 0 and np.count_nonzero(coefs[:, d]) == 1
    # equation i of the model is Psi_i @ coefficients()[i] on any state: no acting term is missing
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.normal(scale=s, size=(20, 3)) for s in (5.0, 50.0, 500.0))
    psi = np.asarray(lib.euler_lagrange_matrix(q, qd, qdd))
    np.testing.assert_allclose(np.einsum("tij,ij->ti", psi, coefs), psi @ fitted.coef_, rtol=1e-12, atol=1e-12)


def test_coefficients_after_strain_removal():
    sc = get_scenario("one_segment_stiff_shear")
    data = sc.generate(seed=0, validation=False)
    X = [StrainTrajectory(r.q, r.t, segment_lengths=sc.robot.segment_lengths) for r in data.train[:4]]
    model = EulerLagrangeRegressor().fit(X, [r.tau for r in data.train[:4]])
    assert model.removed_strains_ == ["sh_1"]
    coefs = model.coefficients()
    assert coefs.shape == (2, model.coef_.size)  # one row per modelled strain (be_1, ax_1)
    dropped = np.setdiff1d(np.arange(model.coef_.size), model.column_map_)
    assert dropped.size and np.all(coefs[:, dropped] == 0)


def test_every_simulate_returns_a_strain_trajectory_that_is_the_pysindy_state(one_segment, fitted):
    robot, recs, _, _, lengths = one_segment
    r = recs[1]
    a = fitted.simulate(np.r_[r.q[0], r.qd[0]], r.t, r.tau)
    assert isinstance(a, StrainTrajectory)
    x = np.asarray(a)
    assert x.shape == (r.t.size, 6)
    np.testing.assert_array_equal(x, np.hstack([a.q, a.qd]))
    lib = PhysicalPCSLibrary(lengths)
    sindy = WeakEulerLagrangeSINDy(feature_library=lib).fit(
        [s.q for s in recs], t=[s.t for s in recs], u=[s.tau for s in recs]
    )
    b = sindy.simulate(np.r_[r.q[0], r.qd[0]], r.t, r.tau)
    assert type(b) is type(a) and np.asarray(b).shape == x.shape
    # both follow the ground truth
    q_true = robot.simulate(r.q[0], r.qd[0], r.t, r.tau, rtol=1e-10, atol=1e-12).q
    for sim in (a, b):
        assert np.abs(np.asarray(sim)[:, :3] - q_true).max() < 0.01 * np.abs(q_true).max()
    with pytest.raises(ValueError, match="no rates qd"):
        np.asarray(StrainTrajectory(r.q, r.t, segment_lengths=lengths))


def test_feature_library_and_the_deprecated_library(one_segment):
    _, _, X, y, _ = one_segment
    lib = PhysicalPCSLibrary(rest_strain=False)
    new = EulerLagrangeRegressor(feature_library=lib)
    assert new.get_params()["feature_library"] is lib and new.get_params()["library"] is None
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        new.fit(X[:3], y[:3])
    old = EulerLagrangeRegressor(library=lib)
    assert old.library is lib and old.feature_library is None  # stored unchanged
    with pytest.warns(FutureWarning, match="feature_library"):
        old.fit(X[:3], y[:3])
    np.testing.assert_array_equal(old.coef_, new.coef_)
    assert clone(old).library is not lib and isinstance(clone(old).library, PhysicalPCSLibrary)
    with pytest.raises(ValueError, match="library must be None when feature_library is given"):
        EulerLagrangeRegressor(feature_library=lib, library="monomial").fit(X[:3], y[:3])
    assert EulerLagrangeRegressor.seed_method().feature_library == "monomial"


# -- item 2: the default optimizer's parameters --------------------------------------------------
def test_default_optimizer_parameters_are_settable_and_never_shared():
    reg = EulerLagrangeRegressor()
    assert reg.optimizer is None  # stored unchanged (scikit-learn's rule)
    assert reg.get_params(deep=True)["optimizer__threshold"] == StiffnessThresholdOptimizer().threshold
    assert "optimizer__threshold" not in reg.get_params(deep=False)
    assert reg.set_params(optimizer__threshold=0.3) is reg
    assert isinstance(reg.optimizer, StiffnessThresholdOptimizer) and reg.optimizer.threshold == 0.3
    assert EulerLagrangeRegressor().optimizer is None  # no default instance was changed
    assert EulerLagrangeRegressor().get_params(deep=True)["optimizer__threshold"] == 1.0
    twin = clone(reg)
    assert twin.optimizer is not reg.optimizer and twin.optimizer.threshold == 0.3
    both = EulerLagrangeRegressor().set_params(optimizer=None, optimizer__max_iter=5)
    assert both.optimizer.max_iter == 5
    given = StiffnessThresholdOptimizer(threshold=0.5)
    assert EulerLagrangeRegressor(optimizer=given).set_params(optimizer__threshold=0.2).optimizer is given


def test_weak_sindy_default_optimizer_is_searchable_too():
    """``WeakEulerLagrangeSINDy(optimizer=None)`` stands for ``STLSQ()``: its parameters are nested ones."""
    est = WeakEulerLagrangeSINDy()
    assert est.optimizer is None
    assert est.get_params(deep=True)["optimizer__threshold"] == ps.STLSQ().threshold
    assert est.set_params(optimizer__threshold=0.05) is est
    assert isinstance(est.optimizer, ps.STLSQ) and est.optimizer.threshold == 0.05
    assert WeakEulerLagrangeSINDy().optimizer is None and clone(est).optimizer is not est.optimizer


def test_default_optimizer_gives_todays_numbers_and_fit_mutates_nothing(one_segment):
    _, _, X, y, _ = one_segment
    opt = StiffnessThresholdOptimizer()
    before = opt.get_params()
    explicit = EulerLagrangeRegressor(optimizer=opt).fit(X[:4], y[:4])
    default = EulerLagrangeRegressor().fit(X[:4], y[:4])
    np.testing.assert_array_equal(default.coef_, explicit.coef_)
    assert opt.get_params() == before and not hasattr(opt, "coef_")  # fit fitted a clone
    assert default.optimizer is None and explicit.optimizer_ is not opt
    restored = pickle.loads(pickle.dumps(default))
    np.testing.assert_array_equal(restored.coef_, default.coef_)
    assert restored.get_params(deep=True)["optimizer__threshold"] == 1.0


def test_grid_search_over_the_threshold_with_the_rollout_scorer():
    """README: on two_segment_stiff_axial_shear the rollouts choose 0.03 and remove the two stiffened strains."""
    sc = get_scenario("two_segment_stiff_axial_shear")
    data = sc.generate(seed=0, validation=False)
    X = [StrainTrajectory(r.q, r.t, segment_lengths=sc.robot.segment_lengths) for r in data.train[:6]]
    y = [r.tau for r in data.train[:6]]
    cv = [(np.arange(3, 6), np.arange(3)), (np.arange(3), np.arange(3, 6))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # identifiability notes of the candidates
        search = GridSearchCV(
            EulerLagrangeRegressor(), {"optimizer__threshold": [1.0, 0.03]}, scoring=rollout_r2_scorer, cv=cv
        ).fit(X, y)
    assert search.best_params_ == {"optimizer__threshold": 0.03}
    assert sorted(search.best_estimator_.removed_strains_) == ["ax_1", "sh_2"]
