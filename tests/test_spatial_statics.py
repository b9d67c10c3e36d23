"""Statics of spatial (3-D) models: equilibria under held inputs, and identification from equilibria.

Independent truth: the spatial simulator (:class:`~pcs_sindy.simulation.spatial_dynamics.SpatialPCSRobot`,
compiled kernels written separately from the models' NumPy quadrature) — its state after a long damped
rollout under a held input, and its own static forces ``G(q) + K q`` and tendon forces ``A(q) u`` —
and the simulator's material parameters (the stiffness a static fit must find).
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.control.statics import equilibrium as newton_equilibrium
from pcs_sindy.control.statics import equilibrium_inputs, model_tip
from pcs_sindy.core.spatial import SpatialPCS
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.identification.library.spatial_physical import SpatialPhysicalPCSLibrary
from pcs_sindy.models import SpatialTendonActuation
from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot, SpatialTendons

LENGTHS = [0.07, 0.1]
END = [0.07, 0.17, 0.17, 0.12]
OFFSET = [[0.01, 0.0], [-0.008, 0.004], [0.0, -0.012], [0.005, 0.006]]
RHO, E, G = 1070.0, 1e4, 1e3
DAMP = np.tile([1e-4, 1e-4, 6e-5, 0.15, 0.15, 0.15], 2)  # damped enough to settle within a hold


def _robot(tendons: bool = True) -> SpatialPCSRobot:
    return SpatialPCSRobot(LENGTHS, RHO, E, G, DAMP, actuation=SpatialTendons(END, OFFSET) if tendons else None)


def _model_of(rob: SpatialPCSRobot):
    """The SpatialPCSModel of the simulator's parameters, driven by the same tendons (known routing)."""
    lib = SpatialPhysicalPCSLibrary(LENGTHS, rest_strain=False).fit(np.zeros((1, 24)))
    coef = lib.coefficients_from_parameters(RHO, 0.02, E, G, DAMP)
    act = SpatialTendonActuation(end=END, offset=OFFSET).fit(SpatialPCS(tuple(LENGTHS)))
    return lib.forward_model(coef, actuation=act)


def test_equilibrium_is_the_simulators_settled_state_and_balances_its_forces():
    rob = _robot()
    fm = _model_of(rob)
    u = np.array([1.5, 0.5, 2.0, 0.8])  # tensions [N]: bends both segments out of any plane by ~1 rad
    q = fm.equilibrium(u)
    assert np.abs(q[[0, 1, 6, 7]]).max() > 0.5
    # the simulator's own static balance G(q) + K q = A(q) u, to round-off
    elastic = rob.elastic_forces(q)
    residual = rob.gravity_forces(q) + elastic - rob.actuation_forces(q, u)
    assert np.abs(residual).max() < 1e-12 * np.abs(elastic).max()
    # the simulator, left to settle under the held tensions
    t = np.linspace(0.0, 6.0, 601)
    tr = rob.simulate(np.zeros(12), np.zeros(12), t, np.tile(u, (t.size, 1)))
    assert np.abs(tr.qd[-1]).max() < 1e-9
    np.testing.assert_allclose(q, tr.q[-1], rtol=0, atol=1e-10 * np.abs(q).max())
    # the control module's Newton solve finds the same equilibrium
    np.testing.assert_allclose(newton_equilibrium(fm, u), q, rtol=0, atol=1e-10 * np.abs(q).max())
    # several rows: one equilibrium each (a load sweep)
    sweep = fm.equilibrium(np.outer([0.25, 0.5, 1.0], u))
    np.testing.assert_allclose(sweep[-1], q, rtol=0, atol=1e-10 * np.abs(q).max())


def test_equilibrium_inputs_reach_a_3d_tip_target():
    rob = _robot()
    fm = _model_of(rob)
    q_ref = fm.equilibrium(np.array([0.4, 1.2, 0.3, 0.9]))
    target = model_tip(fm, q_ref)
    assert target.shape == (3,) and abs(target[2]) > 2e-3  # out of the x-y plane
    res = equilibrium_inputs(fm, target, input_bounds=(0.0, 3.0))
    assert res.reachable and res.error < 1e-6 and np.all(res.u >= 0)
    # the simulator's kinematics put its tip there under the found inputs' equilibrium
    p_tip = rob.kinematics.forward_kinematics(res.q, [0.17])[0][0]
    np.testing.assert_allclose(p_tip, target, rtol=0, atol=1e-6)
    residual = rob.gravity_forces(res.q) + rob.elastic_forces(res.q) - rob.actuation_forces(res.q, res.u)
    assert np.abs(residual).max() < 1e-7 * np.abs(rob.elastic_forces(res.q)).max()
    with pytest.raises(ValueError, match=r"\[x, y, z\]"):
        equilibrium_inputs(fm, target[:2])


def _held(rob, inputs, hold_s=3.0, dt=0.01):
    """The simulator under inputs held hold_s each: a static rig's recording."""
    n = int(round(hold_s / dt))
    u = np.repeat(inputs, n, axis=0)
    t = np.arange(u.shape[0]) * dt
    return rob.simulate(np.zeros(12), np.zeros(12), t, u), u


def test_static_fit_on_simulated_equilibria_recovers_the_stiffness():
    rng = np.random.default_rng(0)
    rob = _robot(tendons=False)
    scale = np.tile([1e-3, 1e-3, 2e-4, 0.05, 0.05, 0.2], 2)  # generalised forces on every strain
    tr, u = _held(rob, rng.uniform(-1, 1, (12, 12)) * scale)
    reg = EulerLagrangeRegressor(formulation="static").fit([tr], [u])
    assert reg.active_strains_.all()
    np.testing.assert_allclose(reg.stiffness_, rob.stiffness, rtol=2e-3)
    ratios = reg.stiffness_ / reg.stiffness_[0]
    np.testing.assert_allclose(ratios, rob.stiffness / rob.stiffness[0], rtol=2e-3)
    coef = dict(zip(reg.library_.coefficient_names(), reg.model_coef_, strict=True))
    assert coef["rhoA_1"] == pytest.approx(RHO * rob.area[0], rel=0.05)  # through gravity alone
    # the identified model rests where the simulator settles under a new held input
    u_new = rng.uniform(-1, 1, 12) * scale
    tr_new, _ = _held(rob, u_new[None])
    np.testing.assert_allclose(reg.equilibrium(u_new), tr_new.q[-1], rtol=0, atol=2e-3 * np.abs(tr_new.q[-1]).max())


def test_static_fit_with_known_tendon_routing_recovers_the_stiffness_and_offsets():
    rng = np.random.default_rng(1)
    rob = _robot()
    tr, u = _held(rob, rng.uniform(0.0, 2.0, (12, 4)))
    reg = EulerLagrangeRegressor(
        formulation="static", actuation={"type": "spatial_tendon", "end": END, "offset": OFFSET}
    ).fit([tr], [u])
    bending = [0, 1, 6, 7]
    np.testing.assert_allclose(reg.stiffness_[bending], rob.stiffness[bending], rtol=1e-4)
    np.testing.assert_allclose(
        reg.stiffness_[bending] / reg.stiffness_[0], rob.stiffness[bending] / rob.stiffness[0], rtol=1e-4
    )
    angle = np.arctan2(np.asarray(OFFSET)[:, 1], np.asarray(OFFSET)[:, 0])
    free = EulerLagrangeRegressor(
        formulation="static", actuation={"type": "spatial_tendon", "end": END, "angle": angle.tolist()}
    ).fit([tr], [u])
    np.testing.assert_allclose(free.actuation_.offset_vectors_, OFFSET, rtol=0, atol=1e-6)
    np.testing.assert_allclose(free.stiffness_[bending], rob.stiffness[bending], rtol=1e-4)
