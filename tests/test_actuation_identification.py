"""Identification from actuator inputs: tendons (offsets identified) and pressure chambers (gains identified).

Truth: the ground-truth simulator's own actuation (an independent
implementation of the tendon lengths and chamber columns), its actuated
recordings, and finite differences.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core import PlanarPCS, PoseTrajectory, StrainTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.identification.identifiability import report
from pcs_sindy.identification.variable_projection import equation_weights
from pcs_sindy.io import load, save
from pcs_sindy.models import (
    IdentityActuation,
    LinearActuation,
    PressureActuation,
    TendonActuation,
    actuation_from_layout,
)
from pcs_sindy.simulation import PressureChambers as TruePressure
from pcs_sindy.simulation import Tendons as TrueTendon
from pcs_sindy.simulation import get_scenario
from pcs_sindy.simulation.dynamics import PCSRobot


def _robot(lengths, actuation):
    m = len(lengths)
    return PCSRobot(
        lengths,
        density=[1000.0] * m,
        radius=0.02,
        youngs_modulus=[1e4] * m,
        shear_modulus=[1e3] * m,
        damping=[1e-4, 1e-2, 1e-2] * m,
        actuation=actuation,
    )


def _states(n, rng, size=20):
    return rng.uniform(-1, 1, (size, n)) * np.tile([30.0, 0.2, 0.2], n // 3)


@pytest.mark.parametrize("lengths", [(0.07, 0.1), (0.05, 0.06, 0.06)])
def test_tendon_map_equals_the_simulators(lengths):
    # terminations at a boundary, inside a segment and at the tip; offsets of both signs
    end, offset = [0.07, 0.09, 0.17], [0.015, -0.01, 0.02]
    end = [min(e, sum(lengths)) for e in end]
    robot = _robot(lengths, TrueTendon(end, offset))
    kin = PlanarPCS(lengths)
    act = TendonActuation(end, np.sign(offset), offset=np.abs(offset)).fit(kin)
    q = _states(kin.n_q, np.random.default_rng(0))
    np.testing.assert_allclose(act.lengths(q), robot.tendon_lengths(q), rtol=1e-13)
    np.testing.assert_allclose(act.matrix(q), robot.actuation_matrix(q), rtol=1e-12, atol=1e-15)
    # A = -dl/dq by central differences of the lengths
    h = 1e-6
    fd = np.stack([(act.lengths(q + h * e) - act.lengths(q - h * e)) / (2 * h) for e in np.eye(kin.n_q)], axis=-1)
    np.testing.assert_allclose(act.matrix(q), -np.swapaxes(fd, 1, 2), rtol=1e-6, atol=1e-9)
    # kappa = 0 is an ordinary point: the straight robot's map equals the limit
    np.testing.assert_allclose(act.matrix(np.zeros((1, kin.n_q))), act.matrix(1e-9 * np.ones((1, kin.n_q))), atol=1e-9)


def test_pressure_map_equals_the_simulators_for_another_segmentation():
    start, end, side, gb, ga = [0.0, 0.03], [0.1, 0.12], [1, -1], [3e-6, 2e-6], [2e-4, 1e-4]
    lengths = (0.05, 0.04, 0.06)  # spans end inside segments
    robot = _robot(lengths, TruePressure(start, end, side, gb, ga))
    act = PressureActuation(start, end, side, gb, ga).fit(PlanarPCS(lengths))
    q = _states(9, np.random.default_rng(1), 3)
    np.testing.assert_allclose(act.matrix(q), robot.actuation_matrix(q), rtol=1e-13, atol=1e-18)
    unknown = PressureActuation(start, end, side).fit(PlanarPCS(lengths))
    assert unknown.gain_names_ == ["gb_1", "gb_2", "ga_1", "ga_2"]
    np.testing.assert_allclose(unknown.matrix(q, gains=np.r_[gb, ga]), robot.actuation_matrix(q), rtol=1e-13)


def _strains(recs, lengths):
    return [StrainTrajectory(r.q, r.t, segment_lengths=lengths) for r in recs]


@pytest.fixture(scope="module")
def tendon_data():
    scenario = get_scenario("two_segment_tendon")
    return scenario, scenario.generate(seed=0, n_train=4, validation=False)


def test_tendon_offsets_and_dynamics_are_identified(tendon_data):
    scenario, data = tendon_data
    lengths = scenario.robot.kinematics.segment_lengths
    model = EulerLagrangeRegressor(actuation=scenario.actuation).fit(
        _strains(data.train, lengths), [r.u for r in data.train]
    )
    true_offsets = np.asarray(scenario.robot.actuation.offset)
    # measured: offsets within 0.1 %, stiffness within 0.05 %
    np.testing.assert_allclose(model.actuation_.offsets_, true_offsets, rtol=1e-2)
    np.testing.assert_allclose(model.stiffness_, scenario.robot.stiffness, rtol=1e-2)
    info = model.identifiability_
    assert info["offset_names"] == ["d_1", "d_2", "d_3", "d_4"]
    assert np.all(info["offset_relative_standard_errors"] < 0.05)
    text = model.equations()
    assert any("offsets d [mm] (identified)" in line for line in text) and text[-1].startswith("D = diag(")
    # the identified model, driven by the tensions, follows the simulator
    rec = data.train[3]
    sim = model.simulate(rec.q[0], rec.qd[0], rec.t, rec.u)
    err = np.abs(sim.q - rec.q).max(axis=0) / np.abs(rec.q).max(axis=0)
    assert np.all(err < 0.02), err
    assert model.forward_model().n_inputs == 4
    with pytest.raises(ValueError, match="tendon tensions must be >= 0"):
        model.simulate(rec.q[0], rec.qd[0], rec.t, -rec.u)


def test_per_tendon_offsets_from_noisy_poses(tendon_data):
    # the seed's pose noise (0.1 mm, 0.5 deg) through kinematic fusion: the shear and axial equations' residuals
    # are orders of magnitude above the bending ones', which carry the offsets; unweighted, the outer problem put
    # the four offsets 11-12 % off (standard errors 16-20 %); with each equation weighted by its residual 0.3 %
    scenario, _ = tendon_data
    data = scenario.generate(seed=0, n_train=4, validation=False, noise=(1e-4, float(np.deg2rad(0.5))))
    poses = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    X = KinematicFusion(total_length=0.17, threshold=0.1).fit_transform(poses)
    assert X[0].segment_lengths == pytest.approx([0.07, 0.1], abs=5e-4)
    model = EulerLagrangeRegressor(actuation=scenario.actuation).fit(X, [r.u for r in data.train])
    true = np.asarray(scenario.robot.actuation.offset)
    err = model.actuation_.offsets_ / true - 1
    info = model.identifiability_
    rel_se = info["offset_relative_standard_errors"]
    assert np.all(np.abs(err) < 0.015), err
    # the reported errors are small and describe the actual error (not 20 % for a 0.3 % error)
    assert np.all(rel_se < 0.02) and np.all(np.abs(err) < 4 * rel_se), (err, rel_se)
    # the bending equations (every third) weigh more than the shear ones
    w = info["equation_weights"]
    assert np.all(w[0::3] > 10 * w[1::3])
    text = model.identifiability_report()
    assert "actuation offsets" in text and "d_4" in text and "do not determine" not in text
    # every offset line carries its unit (a length from the backbone)
    after = text.split("actuation offsets")[1].splitlines()[1:]
    offset_lines = [ln for ln in after if ln.startswith("d_")]
    assert offset_lines and all(ln.split()[4] == "m" for ln in offset_lines), offset_lines
    # weighting="none": one plain least-squares solve over all equations, the shear and axial noise then sets
    # the offsets (measured 11-12 % off on these recordings)
    act = {**scenario.actuation, "weighting": "none"}  # the layout as a JSON file gives it
    plain = EulerLagrangeRegressor(actuation=act).fit(X, [r.u for r in data.train])
    err_plain = plain.actuation_.offsets_ / true - 1
    assert np.max(np.abs(err_plain)) > 5 * np.max(np.abs(err)), (err_plain, err)
    assert plain.identifiability_["offset_weighting"] == "none"
    np.testing.assert_array_equal(plain.identifiability_["equation_weights"], 1.0)
    assert "unweighted" in plain.identifiability_report()


def test_offset_weighting_is_validated(tendon_data):
    scenario, data = tendon_data
    act = {**scenario.actuation, "weighting": "ols"}
    with pytest.raises(ValueError, match=r"TendonActuation: weighting must be one of 'residual', 'none'; got 'ols'"):
        EulerLagrangeRegressor(actuation=act).fit(
            _strains(data.train[:1], scenario.robot.kinematics.segment_lengths), [data.train[0].u]
        )


def test_equation_weights_are_inverse_residual_rms():
    rng = np.random.default_rng(3)
    scale = np.array([1e-6, 2e-3, 5e-2])
    r = rng.standard_normal((4000, 3)) * scale
    rms = np.sqrt(np.mean(r**2, axis=0))
    np.testing.assert_allclose(equation_weights(r), rms[0] / rms, rtol=1e-12)
    np.testing.assert_allclose(equation_weights(r), scale[0] / scale, rtol=0.05)
    # an exact equation gets a large finite weight, never inf
    w = equation_weights(np.c_[np.zeros(10), np.ones(10)])
    assert np.all(np.isfinite(w)) and w[0] > 1e5 * w[1]
    with pytest.raises(ValueError, match="residual must be a finite"):
        equation_weights(np.array([1.0, np.nan]))


def test_report_says_when_offsets_are_not_determined():
    info = {
        "condition_number": 10.0,
        "rank": 1,
        "names": ["k_be_1"],
        "coef": np.array([1.0]),
        "standard_errors": np.array([0.01]),
        "relative_standard_errors": np.array([0.01]),
        "residual_std": 0.1,
        "poorly_determined": ["d_2"],
        "offset_names": ["d_1", "d_2"],
        "offsets": np.array([0.015, 0.015]),
        "offset_standard_errors": np.array([0.0003, 0.003]),
        "offset_relative_standard_errors": np.array([0.02, 0.2]),
        "offset_correlation": np.array([[1.0, -0.9], [-0.9, 1.0]]),
    }
    text = report(info, tol=0.1)
    assert "do not determine the offsets d_2 " in text and "shared=True" in text
    assert "-0.900 (d_1, d_2)" in text
    line = next(ln for ln in text.splitlines() if ln.startswith("d_2"))
    assert "0.003" in line and "20.00%" in line and "poorly determined" in line


def test_actuated_model_file_round_trip(tendon_data, tmp_path):
    scenario, data = tendon_data
    lengths = scenario.robot.kinematics.segment_lengths
    X = _strains(data.train[:2], lengths)
    act = TendonActuation(scenario.actuation["end"], scenario.actuation["side"], offset=[0.015] * 4)
    model = EulerLagrangeRegressor(actuation=act).fit(X, [r.u for r in data.train[:2]])
    loaded = load(save(model, tmp_path / "tendon"))
    assert isinstance(loaded.actuation_, TendonActuation)
    np.testing.assert_array_equal(loaded.actuation_.offsets_, model.actuation_.offsets_)
    rec = data.train[0]
    a = model.simulate(rec.q[0], rec.qd[0], rec.t[:100], rec.u[:100])
    b = loaded.simulate(rec.q[0], rec.qd[0], rec.t[:100], rec.u[:100])
    np.testing.assert_array_equal(a.q, b.q)
    assert loaded.equations() == model.equations()


def test_pressure_gains_take_the_mass_or_the_stated_convention():
    scenario = get_scenario("one_segment_pneumatic")
    data = scenario.generate(seed=0, n_train=3, validation=False)
    lengths = scenario.robot.kinematics.segment_lengths
    X, u = _strains(data.train, lengths), [r.u for r in data.train]
    p = scenario.parameters
    mass = float(np.sum(np.asarray(p["density"]) * np.pi * 0.02**2 * np.asarray(lengths)))
    # no mass: fitted under the stated 1 kg convention, every gain scaled by 1 / mass
    conv = EulerLagrangeRegressor(actuation=scenario.actuation).fit(X, u)
    assert "1 kg" in conv.scale_convention_
    model = EulerLagrangeRegressor(actuation=scenario.actuation, feature_library=PhysicalPCSLibrary(mass=mass)).fit(
        X, u
    )
    true = scenario.robot.actuation
    np.testing.assert_allclose(model.actuation_.gains_, np.r_[true.bending_gain, true.axial_gain], rtol=1e-2)
    np.testing.assert_allclose(model.stiffness_, scenario.robot.stiffness, rtol=1e-2)
    assert any(line.startswith("gains (identified)") for line in model.equations())
    np.testing.assert_allclose(conv.actuation_.gains_ * mass, model.actuation_.gains_, rtol=1e-6)


def test_bad_inputs_are_named(tendon_data):
    scenario, data = tendon_data
    lengths = scenario.robot.kinematics.segment_lengths
    X, u = _strains(data.train[:2], lengths), [r.u for r in data.train[:2]]
    layout = scenario.actuation
    with pytest.raises(ValueError, match=r"y\[0\] must have shape \(T, 4\)"):
        EulerLagrangeRegressor(actuation=layout).fit(X, [v[:, :3] for v in u])
    bad = [v.copy() for v in u]
    bad[1][17, 2] = -0.5
    with pytest.raises(ValueError, match=r"y\[1\]\[17, 2\] = -0.5 at t = 0.017 s: tendon 2 would push"):
        EulerLagrangeRegressor(actuation=layout).fit(X, bad)
    with pytest.raises(ValueError, match=r"end\[0\] = 0.3 m lies beyond the robot.*give the measured one"):
        EulerLagrangeRegressor(actuation={**layout, "end": [0.3, 0.07, 0.17, 0.17]}).fit(X, u)
    with pytest.raises(ValueError, match="zero in every recording"):
        EulerLagrangeRegressor(actuation=layout).fit(X, [np.zeros_like(v) for v in u])
    with pytest.raises(ValueError, match="layout type must be one of"):
        actuation_from_layout({"type": "magnet"})
    with pytest.raises(ValueError, match="actuation must be None, an Actuation or a layout dict"):
        EulerLagrangeRegressor(actuation="tendon").fit(X, u)


def test_identity_and_linear_layouts():
    kin = PlanarPCS((0.1,))
    ident = IdentityActuation().fit(kin)
    u = np.random.default_rng(0).normal(size=(5, 3))
    np.testing.assert_array_equal(ident.forces(np.zeros((5, 3)), u), u)
    lin = LinearActuation(pattern=[[1, 0], [0, 0], [0, 1]]).fit(kin)
    assert lin.gain_names_ == ["a_be_1_1", "a_ax_1_2"]
    A = lin.matrix(np.zeros((1, 3)), gains=[2.0, 3.0])[0]
    np.testing.assert_array_equal(A, [[2.0, 0.0], [0.0, 0.0], [0.0, 3.0]])
    with pytest.raises(ValueError, match=r"pattern must have shape \(3, p\)"):
        LinearActuation(pattern=[[1, 0]]).fit(kin)
