"""The compiled spatial (3-D) forward model: its terms, rollouts and failures against independent routes.

Truths: the NumPy node integrals :func:`pcs_sindy.models.spatial_forward.node_terms` (Jacobians of
:class:`~pcs_sindy.core.spatial.SpatialPCS`, einsum quadrature: no code shared with the compiled
kernels), the spatial simulator :class:`~pcs_sindy.simulation.SpatialPCSRobot` (physical parameters,
its own integrator; itself held to an mpmath reference), and the planar model
:class:`~pcs_sindy.models.LumpedPCSModel` (complex-number kinematics) for planar motions.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core.kinematics import PlanarPCS
from pcs_sindy.core.simulate_contract import DivergenceError
from pcs_sindy.core.spatial import SpatialPCS
from pcs_sindy.models import LearnedActuation, LumpedPCSModel
from pcs_sindy.models.spatial_forward import SpatialPCSModel, node_terms, spatial_quadrature
from pcs_sindy.simulation import SpatialPCSRobot

L = (0.07, 0.1)
RHO, E, G = [1070.0, 1049.0], [1e4, 9e3], [1e3, 3e3]
DAMP = np.array([3e-5, 3e-5, 3e-5, 5e-1, 5e-1, 5e-2, 3e-5, 3e-5, 3e-5, 2.5e-2, 2.5e-2, 5e-2])
# rotated base frame, so that the gravity per length and the base pose both enter
ANGLE = 0.4
BASE_R = np.array([[np.cos(ANGLE), 0.0, np.sin(ANGLE)], [0.0, 1.0, 0.0], [-np.sin(ANGLE), 0.0, np.cos(ANGLE)]])


def reference_terms(model: SpatialPCSModel, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M (B, n, n) and bias (B, n) by the NumPy node integrals (the model's former evaluation)."""
    kin = model.kinematics
    mask = kin.active_mask
    qf = np.zeros((q.shape[0], kin.n_q))
    qdf = np.zeros_like(qf)
    qf[:, mask], qdf[:, mask] = q, qd
    f = node_terms(kin, spatial_quadrature(kin.segment_lengths, model.n_quadrature), qf, qdf, None, mass=True)
    M = np.einsum("j,bjac->bac", model.rhoA, f["M_trans"]) + np.einsum("j,bjac->bac", model.rhoI, f["M_rot"])
    bias = (
        np.einsum("j,bjn->bn", model.rhoA, f["trans"])
        - np.einsum("bjnx,jx->bn", f["grav"], model.rhoAg)
        + np.einsum("j,bjn->bn", model.rhoI, f["rot"])
    )
    M = M[:, mask][:, :, mask]
    bias = bias[:, mask] + q * model.stiffness + qd * model.damping - model.rest_force
    return M, bias


def physical_model(robot: SpatialPCSRobot, kin: SpatialPCS, **kwargs) -> SpatialPCSModel:
    """The identified-parameters model of a simulated robot: ρA = ρ π r², ρI = ρ π r⁴/4, ρA g, its K and D."""
    rhoA = robot.density * np.pi * robot.radius**2
    rhoI = robot.density * np.pi * robot.radius**4 / 4
    mask = kin.active_mask
    return SpatialPCSModel(
        kin, rhoA, rhoI, rhoA[:, None] * robot.gravity[None], robot.stiffness[mask], robot.damping[mask], **kwargs
    )


@pytest.mark.parametrize("active", [None, [[1, 1, 0, 1, 0, 1], [1, 0, 1, 0, 1, 1]]])
def test_compiled_terms_equal_the_numpy_node_integrals(active):
    """M and the bias (inertial, gravity, elastic, damping, constant parts) at strains from 1e-9 to 60 (|ω|L ~ 6)."""
    rng = np.random.default_rng(3)
    kin = SpatialPCS(L, base_position=(0.1, -0.2, 0.3), base_rotation=BASE_R, active_strains=active)
    n = kin.n_active
    model = SpatialPCSModel(
        kin,
        [1.3, 0.9],
        [2e-4, 7e-5],
        rng.normal(size=(2, 3)) * 10,
        rng.uniform(0.1, 1, n),
        rng.uniform(0.01, 0.1, n),
        rng.normal(size=n) * 0.1,
    )
    worst = {"M": 0.0, "bias": 0.0}
    for magnitude in (1e-9, 1e-4, 0.1, 1.0, 10.0, 60.0):
        scale = np.tile(
            [magnitude, magnitude, magnitude, min(magnitude, 0.3), min(magnitude, 0.3), min(magnitude, 0.3)], 2
        )
        q = (rng.normal(size=(6, 12)) * scale)[:, kin.active_mask]
        qd = rng.normal(size=(6, n)) * 3
        M, bias = model.mass_and_bias(q, qd)
        Mr, br = reference_terms(model, q, qd)
        for name, a, b in (("M", M, Mr), ("bias", bias, br)):
            err = np.abs(a - b).reshape(6, -1).max(axis=1) / np.abs(b).reshape(6, -1).max(axis=1)
            worst[name] = max(worst[name], err.max())
        # the small parts of the bias separately (the elastic terms would hide them): gravity, and the rate terms
        for qd_, f0 in ((0 * qd, model.rest_force), (qd, model.rest_force)):
            a = model.mass_and_bias(q, qd_)[1] - q * model.stiffness - qd_ * model.damping + f0
            b = reference_terms(model, q, qd_)[1] - q * model.stiffness - qd_ * model.damping + f0
            err = np.abs(a - b).max(axis=1) / np.abs(b).max(axis=1)
            worst["bias"] = max(worst["bias"], err.max())
        M1, b1 = model.terms(q[0], qd[0])
        np.testing.assert_array_equal(M1, M[0])
        np.testing.assert_array_equal(b1, bias[0])
    # measured: M 7e-16, bias 6e-16 (the quadrature tiers against the 16-node rule: round-off)
    assert worst["M"] <= 1e-12 and worst["bias"] <= 1e-12, worst


@pytest.fixture(scope="module")
def robot_and_inputs():
    robot = SpatialPCSRobot(L, RHO, E, G, DAMP, base_rotation=BASE_R)
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 0.25, 1e-3)
    blocks = rng.uniform(-1, 1, (t.size // 10 + 1, 12)) * np.tile([2e-3, 2e-3, 1e-3, 0.02, 0.02, 0.05], 2)
    return robot, t, np.repeat(blocks, 10, axis=0)[: t.size]


def test_rollout_equals_the_simulator_with_matching_physical_parameters(robot_and_inputs):
    """All six strains of two segments under random forces: the model's Rosenbrock rollout against the simulator."""
    robot, t, u = robot_and_inputs
    kin = SpatialPCS(L, base_rotation=BASE_R)
    model = physical_model(robot, kin)
    assert model.compiled_rollouts and model.default_method == "rosenbrock"
    q0 = np.tile([2.0, -1.0, 0.5, 0.01, -0.01, 0.02], 2)
    ref = robot.simulate(q0, np.zeros(12), t, u, rtol=1e-10, atol=1e-12)
    stats: dict = {}
    sim = model.simulate(q0, np.zeros(12), t, u, rtol=1e-9, atol=1e-12, stats=stats)
    assert stats["n_steps"] > 0
    tip = np.array([sum(L)])
    p_ref = kin.forward_kinematics(ref.q, tip)[0][:, 0]
    p_sim = kin.forward_kinematics(sim.q, tip)[0][:, 0]
    # measured: 8e-12 m tip distance, 4e-10 relative strains
    assert np.linalg.norm(p_sim - p_ref, axis=1).max() < 1e-9
    assert np.abs(sim.q - ref.q).max() <= 1e-7 * np.abs(ref.q).max()
    # the default tolerances: within the planar model's usual accuracy
    sim = model.simulate(q0, np.zeros(12), t, u)
    assert np.linalg.norm(kin.forward_kinematics(sim.q, tip)[0][:, 0] - p_ref, axis=1).max() < 1e-6  # measured 5e-8 m
    # a scipy method runs the same compiled state derivative
    sim = model.simulate(q0, np.zeros(12), t[:40], u[:40], method="radau", rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(sim.q, ref.q[:40], rtol=0, atol=1e-7 * np.abs(ref.q).max())


def test_planar_restriction_equals_the_planar_model():
    """bend_z, shear_x and axial only, gravity in the plane: terms and rollout of the planar LumpedPCSModel."""
    rng = np.random.default_rng(5)
    planar_kin = PlanarPCS(L)
    kin = SpatialPCS(L, active_strains=[[1, 0, 0, 1, 0, 1]] * 2)
    rhoA, rhoI, g = np.array([1.3, 0.9]), np.array([2e-4, 7e-5]), np.array([[1.0, 9.0], [-2.0, 8.0]])
    k, d, f0 = np.array([3e-3, 2.0, 5.0, 2e-3, 1.0, 4.0]), np.array([3e-5, 0.5, 0.05] * 2), rng.normal(size=6) * 1e-3
    planar = LumpedPCSModel(planar_kin, rhoA, rhoI, g, k, d, f0, fast_quadrature=None)
    spatial = SpatialPCSModel(kin, rhoA, rhoI, np.c_[g, np.zeros(2)], k, d, f0)
    q = rng.normal(size=(8, 6)) * np.tile([10.0, 0.1, 0.1], 2)
    qd = rng.normal(size=(8, 6))
    for a, b in zip(spatial.mass_and_bias(q, qd), planar.mass_and_bias(q, qd), strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
    t = np.arange(0.0, 0.2, 1e-3)
    u = rng.normal(size=(t.size, 6)) * np.tile([1e-3, 1e-2, 1e-2], 2)
    q0 = np.array([3.0, 0.01, 0.0, -2.0, 0.0, 0.01])
    a = spatial.simulate(q0, np.zeros(6), t, u, rtol=1e-9, atol=1e-12)
    b = planar.simulate(q0, np.zeros(6), t, u, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(a.q[:, kin.active_mask], b.q[:, planar_kin.active_mask], rtol=0, atol=1e-8)
    assert np.all(a.q[:, ~kin.active_mask] == 0.0)


def test_divergence_raises_the_planar_models_error():
    """A negative stiffness: both models raise DivergenceError (SimulationError) naming the time and state."""
    t = np.arange(0.0, 5.0, 1e-2)
    planar = LumpedPCSModel(PlanarPCS((0.1,)), [1.0], [1e-4], [[0.0, 0.0]], [-1.0, 10.0, 10.0], [0.0, 1.0, 1.0])
    kin = SpatialPCS((0.1,))
    spatial = SpatialPCSModel(
        kin, [1.0], [1e-4], [[0.0, 0.0, 0.0]], [-1.0, -1.0, 1.0, 10.0, 10.0, 10.0], [0, 0, 1.0, 1, 1, 1]
    )
    for model, n in ((planar, 3), (spatial, 6)):
        q0 = np.zeros(n)
        q0[0] = 1e-3
        with pytest.raises(DivergenceError, match="diverged at t"):
            model.simulate(q0, np.zeros(n), t, np.zeros((t.size, n)), max_abs_state=100.0)


def test_learned_actuation_runs_compiled_and_equals_its_python_map():
    rng = np.random.default_rng(7)
    kin = SpatialPCS(L)
    act = LearnedActuation(2, terms=("u", "u*q", "pull")).fit(kin)
    act.gains_ = rng.normal(size=act.gains_.size) * 1e-3
    model = SpatialPCSModel(kin, [1.3, 0.9], [2e-4, 7e-5], np.zeros((2, 3)), np.ones(12), np.ones(12), actuation=act)
    assert model.default_method in model.compiled_methods and not model.python_inputs
    q, u = rng.normal(size=(5, 12)), rng.normal(size=(5, 2))
    for qi, ui in zip(q, u, strict=True):
        np.testing.assert_allclose(model.input_forces(qi, ui), act.forces(qi[None], ui[None])[0], rtol=1e-14, atol=0)
    t = np.arange(0.0, 0.05, 1e-3)
    u = rng.normal(size=(t.size, 2))
    a = model.simulate(np.zeros(12), np.zeros(12), t, u, rtol=1e-9, atol=1e-12)
    b = model.simulate(np.zeros(12), np.zeros(12), t, u, method="radau", rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-7 * np.abs(b.q).max())
    assert np.abs(a.q).max() > 0
