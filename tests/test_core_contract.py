"""The library contract and the regressor that only composes.

Truth: hand-written printouts of hand-chosen coefficients, the scenarios'
simulated ground truth (poses and tip path of the 7 s validation) and the
seed's published settings.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core import PoseTrajectory, end_effector_errors, rollout_scorer
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor, PCSLagrangianLibrary, PhysicalPCSLibrary
from pcs_sindy.identification.library.base import LagrangianLibrary
from pcs_sindy.models import ForwardModel
from pcs_sindy.simulation import get_scenario


def test_every_library_implements_the_contract():
    for lib in (PhysicalPCSLibrary([0.1]), PCSLagrangianLibrary([0.1])):
        assert isinstance(lib, LagrangianLibrary)
        coef = np.ones(lib.n_coefficients_)
        assert isinstance(lib.forward_model(coef), ForwardModel)
        assert lib.equations(coef)[-1].startswith("D = diag(")
    with pytest.raises(TypeError, match="abstract"):
        LagrangianLibrary()


def test_physical_equations_exactly():
    lib = PhysicalPCSLibrary([0.1], rest_strain=False)
    assert lib.equations(np.arange(1.0, 9.0)) == [
        "L = 1/2 qd^T M(q) qd + sum_i int_0^L_i rhoA_i g . p ds - 1/2 (k_be_1 be_1^2 + k_sh_1 sh_1^2 + k_ax_1 ax_1^2)",
        "M(q) = sum_i int_0^L_i (rhoA_i Jp^T Jp + rhoI_i Jo^T Jo) ds",
        "units: be [1/m], sh, ax [-]; tau_be [N·m²], tau_sh, tau_ax [N·m]; k = f_L (E I, c_sh G A, E A), "
        "f_L = 1 m (seed) or L_i",
        "rhoA_1 = 1 kg/m, rhoI_1 = 2 kg·m, k_be_1 = 3 N·m³, k_sh_1 = 4 N·m, k_ax_1 = 5 N·m",
        "D = diag(be_1: 6 N·m³·s, sh_1: 7 N·m·s, ax_1: 8 N·m·s)",
    ]


def test_monomial_equations_exactly():
    lib = PCSLagrangianLibrary([0.1])
    names = lib.get_feature_names()
    coef = np.zeros(lib.n_coefficients_)
    coef[names.index("IEE(u1) dax_1^2")] = 0.00125
    coef[names.index("be_1^2")] = -0.5
    coef[names.index("sh_1^2")] = -2.0
    coef[names.index("ax_1^2")] = -3.25
    coef[lib.damping_index_] = [1e-5, 0.15, 0.15]
    # terms in column order, zero coefficients hidden; no physical template for a monomial model
    # each coefficient in J over its function's unit: dax^2 in 1/s^2, be^2 in 1/m^2, sh^2 and ax^2 pure
    units = "units: be [1/m], sh, ax [-]; tau_be [N·m²], tau_sh, tau_ax [N·m]; L [J]"
    damping = "D = diag(be_1: 1e-05 N·m³·s, sh_1: 0.15 N·m·s, ax_1: 0.15 N·m·s)"
    assert lib.equations(coef) == [
        "L = 0.00125 [kg·m²] IEE(u1) dax_1^2 - 3.25 [N·m] ax_1^2 - 0.5 [N·m³] be_1^2 - 2 [N·m] sh_1^2",
        units,
        damping,
    ]
    assert lib.equations(coef, threshold=1.0) == ["L = -3.25 [N·m] ax_1^2 - 2 [N·m] sh_1^2", units, damping]


def test_regressor_prints_what_its_library_prints():
    data = get_scenario("one_segment").generate(seed=0, validation=False)
    X = [PoseTrajectory(r.poses, t=r.t) for r in data.train[:3]]
    strains = KinematicFusion(total_length=0.1).fit(X).transform(X)
    taus = [r.tau for r in data.train[:3]]
    for model in (EulerLagrangeRegressor(), EulerLagrangeRegressor.seed_method()):
        model.fit(strains, taus)
        assert model.equations(precision=4) == model.library_.equations(model.model_coef_, precision=4)
    assert any(line.startswith("M(q) =") for line in EulerLagrangeRegressor().fit(strains, taus).equations())
    assert not any(line.startswith("M(q) =") for line in model.equations())  # the seed preset: monomial


def test_seed_preset_is_the_seeds_method():
    seed = EulerLagrangeRegressor.seed_method()
    p = seed.get_params()
    assert (p["feature_library"], p["formulation"], p["window_length"], p["polyorder"]) == ("monomial", "strong", 25, 3)
    assert EulerLagrangeRegressor.seed_method(window_length=15).window_length == 15
    default = EulerLagrangeRegressor().get_params()
    assert (default["feature_library"], default["formulation"], default["window_length"]) == (None, "weak", 7)


@pytest.mark.parametrize("name", ["one_segment", "two_segment"])
def test_defaults_identify_the_scenarios_from_their_training_poses(name):
    """Done-when of the core: EulerLagrangeRegressor() rolls the 7 s validation out within 0.1 mm."""
    scenario = get_scenario(name)
    data = scenario.generate(seed=0)
    poses = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    fusion = KinematicFusion().fit(poses)  # rest length estimated from the poses, not given
    model = EulerLagrangeRegressor().fit(fusion.transform(poses), [r.tau for r in data.train])
    val = data.validation
    (start,) = fusion.transform([PoseTrajectory(val.poses, t=val.t)])
    sim = model.simulate(start.q[0], np.zeros(start.q.shape[1]), val.t, val.tau)
    tip = sim.poses(np.array([fusion.total_length_]))
    e_p, _ = end_effector_errors(tip, val.poses_true[:, -1:, :])
    assert e_p <= 1e-4, e_p  # measured 0.0078 / 0.024 mm
    # the rollout scorer sees the same quality on held-out training recordings
    held = fusion.transform(poses[:2])
    assert -rollout_scorer(model, held, [r.tau for r in data.train[:2]]) < 1e-3
