"""Strains not excited above their measurement noise are not identified (``EulerLagrangeRegressor.min_excitation``).

Truth: the spatial simulator (:class:`~pcs_sindy.simulation.spatial_dynamics.SpatialPCSRobot`), one segment
driven by generalised forces on every strain but (almost) none on twist and the second bending, so these
barely move; white noise is then added to the strains.  The noisy twist must be removed (held at 0, with
its reason), the noise-free one kept; a bending is never removed, however little it moves.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pcs_sindy.core.spatial import SpatialStrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot

RHO, E, G = 1070.0, 1e4, 1e3
DAMP = np.array([3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15])
#: force amplitudes per strain (bend_z, bend_x, twist, shear_x, shear_z, axial): bend_x and twist barely driven
SCALE = np.array([2e-3, 2e-5, 1e-6, 0.1, 0.1, 0.2])
#: strain noise: far above the motion of bend_x (std 0.055 1/m) and twist (0.01 1/m), small elsewhere
NOISE = np.array([1e-3, 0.2, 0.05, 1e-5, 1e-5, 1e-5])


@pytest.fixture(scope="module")
def data():
    rob = SpatialPCSRobot([0.1], RHO, E, G, DAMP)
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 2.0, 0.005)
    U, Q = [], []
    for _ in range(2):
        f = rng.uniform(0.3, 3.0, (3, 6))
        ph = rng.uniform(0, 2 * np.pi, (3, 6))
        u = SCALE * np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).sum(axis=1) / 2
        U.append(u)
        Q.append(rob.simulate(np.zeros(6), np.zeros(6), t, u).q)
    noisy = [q + NOISE * rng.standard_normal(q.shape) for q in Q]
    return rob, t, U, Q, noisy


def _fit(t, Q, U, **kwargs):
    X = [SpatialStrainTrajectory(q, t, segment_lengths=[0.1]) for q in Q]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the noisy bending's poor-fit warnings: not what is tested here
        return EulerLagrangeRegressor(**kwargs).fit(X, U)


def test_an_unexcited_noisy_strain_is_removed_and_a_noise_free_one_kept(data):
    rob, t, U, Q, noisy = data
    clean = _fit(t, Q, U)
    assert clean.removed_strains_ == [] and clean.active_strains_.all()
    assert np.all(clean.excitation_ > 100)  # noise-free: the second differences are the signal's own, tiny
    reg = _fit(t, noisy, U)
    # twist moves 0.01 1/m under 0.05 of noise: removed, with its reason; bend_x (0.055 under 0.2) is a bending: kept
    assert reg.excitation_[2] < 0.5 and reg.excitation_[1] < 0.5
    assert reg.removed_strains_ == ["twist_1"]
    assert reg.active_strains_.tolist() == [[True, True, False, True, True, True]]
    assert reg.removal_reasons_["twist_1"].startswith("not excited")
    assert "twist_1: not excited" in reg.identifiability_report()
    # the removed strain's columns are exactly 0 and the kept library's layout is the full one's restriction
    np.testing.assert_array_equal(reg.column_map_, reg.library_.column_map_)
    dropped = np.setdiff1d(np.arange(reg.coef_.size), reg.column_map_)
    assert dropped.size and np.all(reg.coef_[dropped] == 0.0)
    assert np.isinf(reg.stiffness_[2])
    # the well-excited strains are still identified (the noise there is small)
    keep = [0, 3, 4, 5]
    np.testing.assert_allclose(reg.stiffness_[keep], rob.stiffness[keep], rtol=2e-3)
    sim = reg.simulate(np.zeros(6), np.zeros(6), t[:20], U[0][:20])
    assert np.all(sim.q[:, 2] == 0.0) and np.all(np.isfinite(sim.q))


def test_min_excitation_none_or_zero_or_no_kinds_keep_every_strain(data):
    _, t, U, _, noisy = data
    for off in ({"min_excitation": None}, {"min_excitation": 0.0}, {"excitation_kinds": ()}):
        reg = _fit(t, noisy, U, **off)
        assert reg.removed_strains_ == [] and reg.removal_reasons_ == {}
        assert reg.excitation_[2] < 0.5  # still measured and reported


def test_excitation_kinds_choose_what_may_be_removed(data):
    _, t, U, _, noisy = data
    # shear may go too, but moves well above its noise here: the same removal
    assert _fit(t, noisy, U, excitation_kinds=("twist", "shear", "axial")).removed_strains_ == ["twist_1"]
    # a threshold above every non-bending strain's ratio: all of them go, the bendings stay
    reg = _fit(t, noisy, U, excitation_kinds=("twist", "shear", "axial"), min_excitation=1e6)
    assert reg.active_strains_.tolist() == [[True, True, False, False, False, False]]
    assert _fit(t, noisy, U, excitation_kinds=("shear",)).removed_strains_ == []


def test_min_excitation_and_kinds_are_validated(data):
    _, t, U, Q, _ = data
    with pytest.raises(ValueError, match="min_excitation"):
        _fit(t, Q, U, min_excitation=-1.0)
    with pytest.raises(ValueError, match="excitation_kinds"):
        _fit(t, Q, U, excitation_kinds=("bend_z",))
