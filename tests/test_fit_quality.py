"""A fit reports its own quality and warns when it is worse than a model with no inputs (issue 27, item 5).

Truth: scikit-learn's ``r2_score`` on the regression rows (an independent R^2), the ground-truth
simulator's robots and tendon layouts (a layout with its sides swapped is wrong by construction),
and the tip path of the recordings themselves (the zero-input prediction holds it still).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from sklearn.metrics import r2_score

from pcs_sindy.cli.main import main
from pcs_sindy.core import PoseTrajectory, StrainTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor, PoorFitWarning, formulations, recordings
from pcs_sindy.io.data_files import write_strains, write_tau
from pcs_sindy.models import IdentityActuation, TendonActuation
from pcs_sindy.simulation import get_scenario
from pcs_sindy.simulation.mocap import MocapScenario, play_operator

TENDONS = dict(end=[0.07, 0.07, 0.17, 0.17], side=[1, -1, 1, -1])
SWAPPED = dict(end=[0.07, 0.07, 0.17, 0.17], side=[-1, 1, -1, 1])


@pytest.fixture(scope="module")
def tendon_data():
    sc = get_scenario("two_segment_tendon")
    data = sc.generate(seed=0, validation=False)
    X = [StrainTrajectory(r.q[:300], r.t[:300], segment_lengths=sc.robot.segment_lengths) for r in data.train[:2]]
    return X, [r.u[:300] for r in data.train[:2]]


def _fit(*args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = EulerLagrangeRegressor(**kwargs).fit(*args)
    return model, [w for w in caught if issubclass(w.category, PoorFitWarning)]


def test_training_r2_is_the_r2_of_each_equation_on_the_fitted_rows():
    sc = get_scenario("one_segment")
    data = sc.generate(seed=0, validation=False)
    rng = np.random.default_rng(0)
    lengths = sc.robot.segment_lengths
    clean = [StrainTrajectory(r.q, r.t, segment_lengths=lengths) for r in data.train]
    # noisy strains: the balance is imperfect, so R^2 is informative (not 1 to round-off)
    noisy = [
        StrainTrajectory(r.q + 0.02 * rng.standard_normal(r.q.shape), r.t, segment_lengths=lengths) for r in data.train
    ]
    y = [r.tau for r in data.train]
    model, poor = _fit(noisy, y)
    assert model.training_r2_.shape == (3,) and not poor
    # the same rows, rebuilt, and scikit-learn's R^2 of the model's forces against the applied ones
    act = IdentityActuation().fit(noisy[0].kinematics)
    _, _, recs = recordings.prepare(noisy, y, formulation="weak", actuation=act)
    x, forces, _ = formulations.regression(model.library_, recs, "weak", act)
    expected = r2_score(forces, x @ model.coef_, multioutput="raw_values")
    np.testing.assert_allclose(model.training_r2_, expected, rtol=1e-9)
    assert np.all(expected < 1 - 1e-6) and np.all(expected > 0.9)
    exact, _ = _fit(clean, y)
    assert np.all(exact.training_r2_ > 1 - 1e-6)  # noise-free: the identified model balances every window
    # the training rollouts are rollout_error's, and beat holding the tip still by far
    np.testing.assert_array_equal(exact.training_rollout_error_, exact.rollout_error(clean, y))
    assert np.all(exact.training_rollout_error_ < 1e-3 * exact.no_input_error_)


def test_no_input_error_holds_the_tip_where_the_rollout_starts(tendon_data):
    X, U = tendon_data
    model, poor = _fit(X, U, actuation=TendonActuation(**TENDONS))
    assert not poor
    for rec, err in zip(X, model.no_input_error_, strict=True):
        tip = rec.kinematics.forward_kinematics(rec.q[3:], np.array([0.17]))[:, 0, :2]  # rollouts start at sample 3
        assert err == pytest.approx(np.mean(np.linalg.norm(tip - tip[0], axis=1)), rel=1e-12)


def test_training_r2_shows_swapped_tendon_sides(tendon_data):
    X, U = tendon_data
    good, poor_good = _fit(X, U, actuation=TendonActuation(**TENDONS))
    bad, _ = _fit(X, U, actuation=TendonActuation(**SWAPPED))
    assert not poor_good and np.all(good.training_r2_ > 0.99)
    names = bad.kinematics_.strain_names(active_only=True)
    bending = [names.index("be_1"), names.index("be_2")]
    assert np.all(bad.training_r2_[bending] < 0)  # measured -3.2 and -0.43: the inputs bend the wrong way


@pytest.fixture(scope="module")
def servo_capture():
    """Issue 27's case: a servo capture fused from three markers, servo angles as inputs (20 s, 100 Hz)."""
    sc = MocapScenario.servo(duration=20.0)
    rec = sc.generate(seed=0)
    traj = PoseTrajectory.from_positions(rec.positions, dt=0.01, arc_lengths=sc.marker_arc_lengths)
    fusion = KinematicFusion(threshold=0.2).fit(traj)
    return sc, fusion.transform(traj), [play_operator(rec.u, sc.play)], fusion.total_length_


def _servos(sc, length, side):
    return TendonActuation(
        [length] * 2,
        side,
        offset=[sc.tendon_offset] * 2,
        drive="displacement",
        pulley_radius=list(sc.actuation.pulley_radius),
        stiffness=list(sc.actuation.stiffness),
    )


def test_swapped_servo_sides_warn(servo_capture):
    """Issue 27's case: training R^2 of the forces -23.5, open-loop 146 mm, the tip held still 16 mm, exit 0."""
    sc, strains, U, length = servo_capture
    good, poor_good = _fit(strains, U, actuation=_servos(sc, length, [-1, 1]))
    bad, poor_bad = _fit(strains, U, actuation=_servos(sc, length, [1, -1]))
    assert not poor_good and np.all(good.training_rollout_error_ < 0.5 * good.no_input_error_)  # 1.3 / 11.3 mm
    assert len(poor_bad) == 1
    message = str(poor_bad[0].message)
    assert "worse than a model with no inputs" in message and "tendon sides" in message
    assert np.all(bad.training_rollout_error_ > bad.no_input_error_)  # measured 119 mm against 11.3 mm
    assert bad.score(strains, U) < 0 < good.score(strains, U)  # the forces' R^2 (measured -34.5 and 0.95)
    unchecked, poor = _fit(strains, U, actuation=_servos(sc, length, [1, -1]), check_fit=False)
    assert not poor and unchecked.training_rollout_error_ is None and unchecked.no_input_error_ is None
    np.testing.assert_array_equal(unchecked.coef_, bad.coef_)  # the check changes nothing of the fit


def test_cli_fit_refuses_a_model_worse_than_no_inputs(servo_capture, tmp_path, capsys):
    sc, strains, U, length = servo_capture
    (tmp_path / "strains").mkdir()
    (tmp_path / "inputs").mkdir()
    write_strains(tmp_path / "strains" / "capture.npz", strains[0])
    write_tau(tmp_path / "inputs" / "capture.npz", strains[0].t, U[0], key="u")
    files = [str(tmp_path / "strains" / "capture.npz"), "--inputs", str(tmp_path / "inputs" / "capture.npz")]
    for name, side in (("swapped", [1, -1]), ("right", [-1, 1])):
        layout = _servos(sc, length, side).layout()
        (tmp_path / f"{name}.json").write_text(json.dumps(layout))
    out = tmp_path / "model" / "model.json"
    capsys.readouterr()
    assert main(["fit", *files, "--actuation", str(tmp_path / "swapped.json"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "worse than a model with no inputs" in err[0] and "no model written" in err[0], err
    assert not out.exists()
    assert main(["fit", *files, "--actuation", str(tmp_path / "right.json"), "--out", str(out), "-q"]) == 0
    assert out.exists()


def test_rollout_error_is_measured_in_the_recordings_frame():
    """Fused strains carry the base pose they were measured from; the model's kinematics do not."""
    sc = get_scenario("one_segment")
    data = sc.generate(seed=0, validation=False)
    lengths = sc.robot.segment_lengths
    X = [StrainTrajectory(r.q, r.t, segment_lengths=lengths) for r in data.train[:3]]
    y = [r.tau for r in data.train[:3]]
    model = EulerLagrangeRegressor().fit(X, y)
    moved = [StrainTrajectory(x.q, x.t, segment_lengths=lengths, base_pose=(0.05, -0.02, 0.3)) for x in X]
    # a rigid motion of the base moves the recorded and the predicted tips alike: the error does not change
    np.testing.assert_allclose(model.rollout_error(moved, y), model.rollout_error(X, y), rtol=1e-9)
    assert np.all(model.rollout_error(X, y) < 1e-4)


def test_identified_gains_with_a_strain_removed_in_the_weak_form():
    """Tendon stiffness identified (gain columns) and stiff strains removed: the weak rows were rebuilt for
    the gains' column layout and failed (AttributeError: 'WithGains' object has no attribute 'weak_terms')."""
    sc = MocapScenario.servo(duration=8.0)
    rec = sc.generate(seed=0)
    strains = StrainTrajectory(rec.q, rec.t, segment_lengths=list(sc.segment_lengths))
    act = TendonActuation(
        [0.3, 0.3], [1, -1], offset=[0.012] * 2, drive="displacement", pulley_radius=[0.012] * 2, slack=[0.002] * 2
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # identifiability notes
        model = EulerLagrangeRegressor(actuation=act).fit([strains], [play_operator(rec.u, sc.play)])
    assert model.removed_strains_  # the threshold removed stiff strains with the gains identified
    assert model.actuation_.gains_.shape == (2,) and np.all(np.isfinite(model.actuation_.gains_))


def test_a_singular_mass_matrix_of_the_default_fit_does_not_advise_the_default():
    """Issue 27: the CLI advised "the default regressor", which was in use."""
    sc = MocapScenario.servo(duration=8.0)
    rec = sc.generate(seed=0)
    strains = StrainTrajectory(rec.q, rec.t, segment_lengths=list(sc.segment_lengths))
    act = TendonActuation([0.3, 0.3], [-1, 1], offset=[0.012] * 2, drive="displacement")  # sides swapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = EulerLagrangeRegressor(actuation=act).fit([strains], [play_operator(rec.u, sc.play)])
    assert model.mass_matrix_not_pd_fraction_ > 0
    (note,) = [str(w.message) for w in caught if "mass matrix is not positive definite" in str(w.message)]
    assert "tendon sides" in note and "default EulerLagrangeRegressor()" not in note
    assert any(issubclass(w.category, PoorFitWarning) for w in caught)  # its rollouts diverge
