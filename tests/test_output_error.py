"""Output-error refinement, the scale convention, the input range: stable models from inputs of unknown units."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from real_data import real_data_dir

from pcs_sindy.core import StrainTrajectory
from pcs_sindy.core.kinematics import PlanarPCS
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.identification.output_error import STIFFNESS_MARGIN, input_stiffness
from pcs_sindy.models import LearnedActuation

L = 0.3
DT = 0.01
# the hand-built truth: a hanging one-segment robot, 0.6 kg, a servo-like input bending it
MASS = 0.6
ACTIVE = [[True, False, False]]
TRUE = {"k": 0.08, "d": 0.004, "f0": 0.01, "a": 0.002, "b": -0.0004}


def _truth_model():
    kin = PlanarPCS([L], ACTIVE)
    lib = PhysicalPCSLibrary().fit(
        [StrainTrajectory(np.zeros((3, 3)), np.arange(3.0), segment_lengths=[L], active_strains=ACTIVE)]
    )
    names = lib.coefficient_names()
    coef = np.zeros(len(names))
    coef[names.index("rhoA_1")] = MASS / L
    coef[names.index("k_be_1")] = TRUE["k"]
    coef[names.index("d_be_1")] = TRUE["d"]
    coef[names.index("f0_be_1")] = TRUE["f0"]
    act = LearnedActuation(1).fit(kin)
    act.set_identified([TRUE["a"], TRUE["b"]], np.zeros(0))
    return kin, lib.forward_model(coef, actuation=act)


@pytest.fixture(scope="module")
def steps():
    """30 s of 2.5 s input steps between 0 and 10..60 (a servo angle) rolled out by the hand-built model."""
    kin, fm = _truth_model()
    rng = np.random.default_rng(0)
    t = np.arange(3000) * DT
    levels = np.where(np.arange(12) % 2 == 1, rng.uniform(10, 60, 12), 0.0)
    u = np.repeat(levels, 250)[:, None]
    sim = fm.simulate(np.zeros(1), np.zeros(1), t, u, step=DT)
    q = np.zeros((t.size, 3))
    q[:, 0] = sim.q[:, 0] + 1e-3 * rng.standard_normal(t.size)  # curvature noise ~0.3 mm at the tip
    return StrainTrajectory(q, t, segment_lengths=[L], active_strains=ACTIVE), u


@pytest.fixture(scope="module")
def fitted(steps):
    rec, u = steps
    half = rec.n_frames // 2
    train = StrainTrajectory(rec.q[:half], rec.t[:half], segment_lengths=[L], active_strains=ACTIVE)
    return EulerLagrangeRegressor(actuation=LearnedActuation(1)).fit([train], [u[:half]])


def test_no_mass_fits_under_the_stated_convention_and_recovers_the_hand_built_model(fitted):
    # the convention fixes the total mass at 1 kg: every other parameter comes out scaled by 1 / MASS
    assert "1 kg" in fitted.scale_convention_
    assert "scale convention" in fitted.identifiability_report()
    assert fitted.refinement_ is not None and fitted.refinement_["rmse"] < fitted.refinement_["rmse_start"]
    np.testing.assert_allclose(fitted.stiffness_[0] * MASS, TRUE["k"], rtol=0.05)
    np.testing.assert_allclose(fitted.damping_[0] * MASS, TRUE["d"], rtol=0.15)
    np.testing.assert_allclose(fitted.actuation_.gains_ * MASS, [TRUE["a"], TRUE["b"]], rtol=0.1, atol=2e-5)


def test_refined_model_predicts_held_out_half_and_holds_the_stiffness_margin(fitted, steps):
    rec, u = steps
    half = rec.n_frames // 2
    sim = fitted.simulate(rec.q[half], np.zeros(3), rec.t[half:], u[half:])
    kin = rec.kinematics
    tip = kin.forward_kinematics(sim.q, [L])[:, 0, :2]
    true = kin.forward_kinematics(rec.q[half:], [L])[:, 0, :2]
    assert np.sqrt(np.mean(np.sum((tip - true) ** 2, axis=1))) < 2e-3
    lo, hi = fitted.input_range_
    assert lo[0] == 0.0 and hi[0] == u[:half].max()
    lam = input_stiffness(
        fitted.stiffness_[:1], fitted.actuation_, fitted.actuation_.gains_, np.array([[lo[0]], [hi[0]]])
    )
    assert np.all(lam >= STIFFNESS_MARGIN * fitted.stiffness_[0] * (1 - 1e-9))


def test_released_at_rest_inputs_comes_to_rest_with_energy_non_increasing(fitted):
    # passivity, checked on the rollout itself: kinetic + elastic + gravitational energy of the identified
    # parameters (computed here from the mass matrix and the potential forces' integral) never grows
    t = np.arange(4000) * DT
    sim = fitted.simulate(np.array([4.0, 0, 0]), np.array([5.0, 0, 0]), t, np.zeros((t.size, 1)))
    q, qd = sim.q[:, 0], sim.qd[:, 0]
    assert abs(qd[-1]) < 1e-3 and abs(q[-1] - q[-200]) < 1e-4
    m = fitted.mass_matrix(sim.q[:, :1])[:, 0, 0]
    grid = np.linspace(q.min() - 0.1, q.max() + 0.1, 2001)
    f = fitted.potential_forces(grid[:, None])[:, 0]
    pot = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(grid))])
    energy = 0.5 * m * qd**2 + np.interp(q, grid, pot)
    assert np.all(np.diff(energy) <= 1e-6 * energy[0] + 1e-9)


def test_inputs_outside_the_training_range_warn_with_their_values(fitted):
    t = np.arange(50) * DT
    with pytest.warns(UserWarning, match=r"input 0 .* reaches 200"):
        fitted.simulate(np.zeros(3), np.zeros(3), t, np.full((50, 1), 200.0))
    with pytest.warns(UserWarning, match="outside the range"):
        fitted.equilibrium([-50.0])


def _real_trunk() -> Path | None:
    root = real_data_dir()
    f = None if root is None else root / "trunk" / "observations_motor2_test_allmotors.csv"
    return f if f is not None and f.is_file() else None


@pytest.mark.skipif(_real_trunk() is None, reason="the real Trunk recordings are not available")
def test_real_trunk_slice_is_predicted_open_loop_without_divergence():
    from pcs_sindy.core import PoseTrajectory
    from pcs_sindy.fusion import KinematicFusion

    a = np.genfromtxt(_real_trunk(), delimiter=",", names=True, max_rows=3000)
    P = np.stack([np.stack([a[f"{c}{i}"] for c in "xyz"], -1) for i in (1, 2, 3)], 1)
    U = np.stack([a[f"phi{k}"] for k in range(1, 7)], -1)
    n = 2000  # 20 s train (two step cycles), 10 s predicted
    train = PoseTrajectory.from_positions(P[:n], dt=DT, arc_lengths=[0.105, 0.21, 0.315])
    test = PoseTrajectory.from_positions(P[n:], dt=DT, arc_lengths=[0.105, 0.21, 0.315], plane=train.plane)
    fusion = KinematicFusion(threshold=1e6).fit(train)
    (st,), (ste,) = fusion.transform(train), fusion.transform(test)
    model = EulerLagrangeRegressor(actuation=LearnedActuation(6)).fit([st], [U[:n]])
    sim = model.simulate(ste.q[0], np.zeros(3), ste.t, U[n:])
    sim.metadata.update({k: ste.metadata[k] for k in ("plane", "marker_arc_lengths", "base_poses")})
    (pred,) = fusion.inverse_transform([sim])
    err = np.sqrt(np.nanmean(np.sum((pred.positions[:, -1] - P[n:, -1]) ** 2, axis=-1)))
    motion = np.sqrt(np.nanmean(np.sum((P[n:, -1] - np.nanmean(P[n:, -1], axis=0)) ** 2, axis=-1)))
    assert err < 0.35 * motion, (err, motion)
    rest = model.simulate(ste.q[0], np.zeros(3), np.arange(3000) * DT, np.zeros((3000, 6)))
    assert np.all(np.abs(rest.qd[-100:]) < 1e-3)


def test_select_segmentation_checks_its_arguments():
    from pcs_sindy.pipeline import select_segmentation

    with pytest.raises(ValueError, match="positions must have shape"):
        select_segmentation(np.zeros((10, 3)), np.zeros((10, 1)), dt=0.01)
    with pytest.raises(ValueError, match="validation_fraction"):
        select_segmentation(np.zeros((10, 3, 3)), np.zeros((10, 1)), dt=0.01, validation_fraction=0.9)


def test_a_constant_input_gets_zero_gain_instead_of_a_rank_deficient_fit(steps):
    # a servo that never moves acts like the constant force f0: its gains are not determined by the data
    rec, u = steps
    half = rec.n_frames // 2
    train = StrainTrajectory(rec.q[:half], rec.t[:half], segment_lengths=[L], active_strains=ACTIVE)
    both = np.c_[u[:half], np.full(half, 3.0)]
    model = EulerLagrangeRegressor(actuation=LearnedActuation(2), refine="none").fit([train], [both])
    one = EulerLagrangeRegressor(actuation=LearnedActuation(1), refine="none").fit([train], [u[:half]])
    np.testing.assert_array_equal(model.input_directions_, [[1.0], [0.0]])
    gains = dict(zip(model.actuation_.gain_names_, model.actuation_.gains_, strict=True))
    assert gains["a_be_1_u2"] == 0.0 and gains["a_be_1_u2_be_1"] == 0.0
    np.testing.assert_allclose([gains["a_be_1_u1"], gains["a_be_1_u1_be_1"]], one.actuation_.gains_, rtol=1e-9)
