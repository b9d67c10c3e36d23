"""Physical identification of a five-segment robot (issue 6 item 4).

Ground truth is the simulator (:mod:`pcs_sindy.simulation`), an independent
implementation of the dynamics; the true lumped parameters are the robot's
material table turned into ``rho A``, ``rho I``, ``k``, ``d`` by
:meth:`PhysicalPCSLibrary.coefficients_from_parameters` (closed-form
expressions, independent of the regression).  Short recordings keep the file
fast: 0.1 s slices instead of the scenario's 0.5 s.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pcs_sindy.core import StrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary, StiffnessThresholdOptimizer
from pcs_sindy.simulation import get_scenario

# 27 markers 10 mm apart put every boundary of five_segment (0.04, 0.10, 0.15,
# 0.22, 0.27 m) on a marker, so the strains follow from the closed-form IK of
# the segment-end markers and the noise reaches them undamped by any smoothing
N_MARKERS = 27
NOISE = (5e-4, np.deg2rad(1.0))  # the seed's one_segment level: sigma_p = 0.5 mm, sigma_theta = 1 deg
SEEDS = (0, 1, 2)
SHORT = dict(n_train=8, train_duration=0.1, validation=False, cache=False)


def _true_coefficients(scenario, lib: PhysicalPCSLibrary) -> np.ndarray:
    p = scenario.parameters
    return lib.coefficients_from_parameters(
        p["density"], p["radius"], p["youngs_modulus"], p["shear_modulus"], p["damping"]
    )


@pytest.fixture(scope="module")
def scenario():
    return get_scenario("five_segment", n_markers=N_MARKERS)


@pytest.fixture(scope="module")
def noisy(scenario):
    """Per seed: strains from the noisy segment-end poses and the forces."""
    kin = scenario.robot.kinematics
    s = scenario.marker_arc_lengths
    ends = np.array([int(np.argmin(np.abs(s - b))) for b in kin.boundaries])
    assert np.allclose(s[ends], kin.boundaries, atol=1e-12), "the segment ends must be tracked markers"
    out = {}
    for seed in SEEDS:
        data = scenario.generate(seed=seed, noise=NOISE, **SHORT)
        X, taus = [], []
        for rec in data.train:
            poses = rec.poses[:, np.r_[0, ends], :].copy()
            poses[..., 2] = np.unwrap(poses[..., 2], axis=1)
            q = kin.inverse_kinematics(poses)
            X.append(StrainTrajectory(q, rec.t, segment_lengths=kin.segment_lengths))
            taus.append(rec.tau)
        out[seed] = (X, taus)
    return out


def _fit_noisy(scenario, X, taus, bounded: bool) -> EulerLagrangeRegressor:
    lib = PhysicalPCSLibrary(scenario.robot.kinematics.segment_lengths, rest_strain=False)
    model = EulerLagrangeRegressor(
        feature_library=lib,
        formulation="strong",
        window_length=7,
        exclude_force_jumps=True,
        optimizer=StiffnessThresholdOptimizer(bounded=bounded),
    )
    with warnings.catch_warnings():
        # an unbounded fit on noisy data may warn about its mass matrix; that is what it is compared for
        warnings.simplefilter("ignore", UserWarning)
        return model.fit(X, taus)


def test_exact_derivatives_recover_every_parameter(scenario):
    data = scenario.generate(seed=0, n_train=2, train_duration=0.1, validation=False, cache=False)
    robot = scenario.robot
    L = robot.kinematics.segment_lengths
    X = [StrainTrajectory(r.q, r.t, segment_lengths=L) for r in data.train]
    # exact accelerations from the simulator's forward dynamics at the recorded states
    qdd = [robot.forward_dynamics(r.q, r.qd, r.tau) for r in data.train]
    lib = PhysicalPCSLibrary(L, rest_strain=False)
    model = EulerLagrangeRegressor(feature_library=lib, formulation="strong").fit(
        X, [r.tau for r in data.train], qd=[r.qd for r in data.train], qdd=qdd
    )

    truth = _true_coefficients(scenario, lib)
    assert lib.n_coefficients_ == 5 * 8  # rhoA, rhoI, 3 stiffnesses, 3 dampings per segment
    assert model.removed_strains_ == []  # every true stiffness is far below the material maximum
    np.testing.assert_allclose(model.model_coef_, truth, rtol=1e-2, atol=0)
    # the same in the regressor's physical read-outs
    np.testing.assert_allclose(model.stiffness_, robot.stiffness, rtol=1e-2, atol=0)
    np.testing.assert_allclose(model.damping_, robot.damping, rtol=1e-2, atol=0)
    q_all = np.concatenate([r.q for r in data.train])
    np.testing.assert_allclose(model.mass_matrix(q_all[::50]), robot.mass_matrix(q_all[::50]), rtol=1e-2, atol=1e-12)


@pytest.fixture(scope="module")
def noisy_fits(scenario, noisy):
    """Per seed: (bounded fit, unbounded fit) on the noisy strains."""
    return {seed: tuple(_fit_noisy(scenario, *noisy[seed], bounded=b) for b in (True, False)) for seed in SEEDS}


def test_bounded_fits_are_never_negative_on_noisy_data(noisy_fits):
    n_negative_unbounded = 0
    for seed, (model, unbounded) in noisy_fits.items():
        lower = model.library_.lower_bounds_
        assert np.all(lower == 0.0)  # known gravity: densities, stiffnesses and damping are all >= 0
        assert np.all(model.model_coef_ >= lower), f"seed {seed}: smallest coefficient {model.model_coef_.min()}"
        finite = np.isfinite(model.stiffness_)
        assert np.all(model.stiffness_[finite] >= 0) and np.all(model.damping_ >= 0)
        n_negative_unbounded += int(np.sum(unbounded.model_coef_ < 0))
    # the data do push plain least squares below zero, so the bound is what keeps the fits physical
    assert n_negative_unbounded > 0


def test_mass_matrix_positive_definite_at_every_noisy_sample(noisy, noisy_fits):
    for seed, (model, _) in noisy_fits.items():
        X, _ = noisy[seed]
        q = np.concatenate([x.q for x in X])
        M = model.mass_matrix(q)
        assert M.shape == (q.shape[0], 15, 15)
        np.testing.assert_allclose(M, np.swapaxes(M, 1, 2), rtol=0, atol=1e-15)
        # Cholesky succeeds exactly for symmetric positive definite matrices (raises LinAlgError otherwise)
        np.linalg.cholesky(M)
        assert np.linalg.eigvalsh(M)[:, 0].min() > 0
        assert model.mass_matrix_not_pd_fraction_ == 0.0
