"""Spatial PCS dynamics (SpatialPCSRobot) against independent truth.

* the planar robot (:class:`PCSRobot`) on planar motions: every term and a rollout;
* the Lagrangian identities: ``G = ∂U_g/∂q`` (positions from :mod:`pcs_sindy.core.spatial`, a
  separate numpy code path), ``C q̇ = Ṁ q̇ − ∂T/∂q`` and ``q̇ᵀ(Ṁ − 2C) q̇ = 0`` with ``Ṁ`` and
  ``∂T/∂q`` by finite differences, energy conservation of a free undamped rollout, rest at an
  equilibrium found by a root finder;
* tendons: lengths against the polyline of the offset curve, ``A = −∂ℓ/∂q`` by finite differences;
* the independent mpmath reference ``tests/spatial_reference.py`` (energy-based, written apart
  from the package; the tests skip only if that file is missing).
"""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import root

from pcs_sindy.core import (
    SpatialPCS,
    SpatialStrainTrajectory,
    planar_to_spatial_strains,
    spatial_to_planar_strains,
)
from pcs_sindy.simulation import PCSRobot, SpatialPCSRobot, SpatialTendons, Tendons

SOFT = dict(density=1000.0, youngs_modulus=2e5, shear_modulus=7e4, radius=0.02)
PLANAR_COLS = lambda m: np.array([[6 * i, 6 * i + 3, 6 * i + 5] for i in range(m)]).reshape(-1)  # noqa: E731
OUT_OF_PLANE = lambda m: np.array([[6 * i + 1, 6 * i + 2, 6 * i + 4] for i in range(m)]).reshape(-1)  # noqa: E731


def rel(a, b):
    return np.abs(np.asarray(a) - b).max() / max(np.abs(b).max(), 1e-300)


def Rz(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def random_spatial(rng, m, size=(), bend=8.0, strain=0.05):
    scale = np.array([bend, bend, bend, strain, strain, strain] * m)
    return rng.normal(size=size + (6 * m,)) * scale


def pair(m, scaling="seed", theta=0.4):
    """A planar robot and its spatial twin (per-segment parameters, a rotated base, oblique gravity)."""
    L = [0.1, 0.13, 0.08][:m]
    kw = dict(
        density=[1070.0, 900.0, 1200.0][:m],
        youngs_modulus=[1e6, 5e5, 8e5][:m],
        shear_modulus=[3e5, 2e5, 2.5e5][:m],
        radius=[0.02, 0.015, 0.018][:m],
        stiffness_scaling=scaling,
    )
    d3 = np.array([1e-4, 2e-3, 3e-3] * m)
    d6 = np.zeros(6 * m)
    d6[PLANAR_COLS(m)] = d3
    d6[OUT_OF_PLANE(m)] = 5e-4
    planar = PCSRobot(L, damping=d3, gravity=(2.0, 9.81), base_pose=(0.01, -0.02, theta), **kw)
    spatial = SpatialPCSRobot(
        L, damping=d6, gravity=(2.0, 9.81, 0.0), base_position=(0.01, -0.02, 0.0), base_rotation=Rz(theta), **kw
    )
    return planar, spatial


# --------------------------------------------------------------------------
# the planar restriction
# --------------------------------------------------------------------------
@pytest.mark.parametrize(("m", "scaling"), [(1, "seed"), (2, "seed"), (3, "length")])
def test_planar_motions_reproduce_the_planar_robot(m, scaling):
    planar, spatial = pair(m, scaling)
    rng = np.random.default_rng(m)
    q3 = rng.normal(size=(4, 3 * m)) * np.array([10.0, 0.05, 0.05] * m)
    q3[0, 0] = 0.0  # a straight first segment: exact, no epsilon
    qd3 = rng.normal(size=(4, 3 * m)) * np.array([5.0, 0.1, 0.1] * m)
    tau3 = rng.normal(size=(4, 3 * m))
    q6, qd6, tau6 = (planar_to_spatial_strains(x) for x in (q3, qd3, tau3))
    c = PLANAR_COLS(m)
    M6 = spatial.mass_matrix(q6)
    assert rel(M6[:, c][:, :, c], planar.mass_matrix(q3)) <= 1e-10
    # planar and out-of-plane strains do not couple in the plane (reflection symmetry z -> -z)
    assert np.abs(M6[:, c][:, :, OUT_OF_PLANE(m)]).max() <= 1e-15 * np.abs(M6).max()
    for name, args3, args6 in [
        ("coriolis_forces", (q3, qd3), (q6, qd6)),
        ("gravity_forces", (q3,), (q6,)),
        ("elastic_forces", (q3,), (q6,)),
        ("damping_forces", (qd3,), (qd6,)),
        ("forward_dynamics", (q3, qd3, tau3), (q6, qd6, tau6)),
        ("inverse_dynamics", (q3, qd3, tau3), (q6, qd6, tau6)),
    ]:
        ref = getattr(planar, name)(*args3)
        got = getattr(spatial, name)(*args6)
        assert rel(got[:, c], ref) <= 1e-10, name
        assert np.abs(got[:, OUT_OF_PLANE(m)]).max() <= 1e-14 * np.abs(got).max(), name
    np.testing.assert_allclose(spatial.potential_energy(q6), planar.potential_energy(q3), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(spatial.kinetic_energy(q6, qd6), planar.kinetic_energy(q3, qd3), rtol=1e-12)


def test_planar_rollout_reproduces_the_planar_robot():
    planar, spatial = pair(2)
    q3 = np.array([8.0, 0.01, 0.02, -5.0, 0.0, 0.01])
    t = np.arange(0.0, 0.02, 1e-3)
    u3 = np.zeros((t.size, 6))
    u3[:, 0] = 2e-3  # a bending moment from t = 0
    opts = dict(method="dop853", rtol=1e-12, atol=1e-14)
    a = planar.simulate(q3, np.zeros(6), t, u3, **opts)
    b = spatial.simulate(planar_to_spatial_strains(q3), np.zeros(12), t, planar_to_spatial_strains(u3), **opts)
    assert isinstance(b, SpatialStrainTrajectory) and b.q.shape == (t.size, 12)
    assert rel(spatial_to_planar_strains(b.q), a.q) <= 1e-10
    assert rel(spatial_to_planar_strains(b.qd), a.qd) <= 1e-10
    # the default integrator (fixed-step Radau IIA) keeps a planar motion exactly in the plane
    c = spatial.simulate(planar_to_spatial_strains(q3), np.zeros(12), t, planar_to_spatial_strains(u3))
    assert np.abs(c.q[:, OUT_OF_PLANE(2)]).max() == 0.0


def test_planar_tendons_reproduce_planar_tendons():
    L = [0.1, 0.1]
    planar = PCSRobot(L, 1070.0, 1e6, 3e5, np.full(6, 1e-3), actuation=Tendons([0.2, 0.1], [0.01, -0.012]))
    spatial = SpatialPCSRobot(
        L, 1070.0, 1e6, 3e5, np.full(12, 1e-3), actuation=SpatialTendons([0.2, 0.1], [[0.01, 0.0], [-0.012, 0.0]])
    )
    rng = np.random.default_rng(2)
    q3 = rng.normal(size=(3, 6)) * np.array([10.0, 0.05, 0.05] * 2)
    q6 = planar_to_spatial_strains(q3)
    A3, A6 = planar.actuation_matrix(q3), spatial.actuation_matrix(q6)
    assert rel(A6[:, PLANAR_COLS(2)], A3) <= 1e-12
    np.testing.assert_allclose(spatial.tendon_lengths(q6), planar.tendon_lengths(q3), rtol=1e-14)
    u = np.abs(rng.normal(size=(3, 2)))
    assert rel(spatial.actuation_forces(q6, u)[:, PLANAR_COLS(2)], planar.actuation_forces(q3, u)) <= 1e-12


# --------------------------------------------------------------------------
# 3-D: the Lagrangian identities
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def robot3d():
    return SpatialPCSRobot(
        [0.1, 0.12], damping=np.full(12, 1e-3), gravity=(1.0, 9.81, -2.0), base_rotation=Rz(0.3), **SOFT
    )


def test_gravity_is_the_gradient_of_the_gravitational_energy(robot3d):
    rng = np.random.default_rng(3)
    q = random_spatial(rng, 2)
    h = 1e-6
    eye = np.eye(12)
    ref = (robot3d.gravitational_energy(q + h * eye) - robot3d.gravitational_energy(q - h * eye)) / (2 * h)
    assert rel(robot3d.gravity_forces(q), ref) <= 1e-8


def test_coriolis_from_the_kinetic_energy_and_passivity(robot3d):
    rng = np.random.default_rng(4)
    q, qd = random_spatial(rng, 2), random_spatial(rng, 2, bend=3.0, strain=0.1)
    h = 1e-6
    eye = np.eye(12)
    Mdot = (robot3d.mass_matrix(q + h * qd) - robot3d.mass_matrix(q - h * qd)) / (2 * h)
    T = lambda x: 0.5 * np.einsum("a,...ab,b->...", qd, robot3d.mass_matrix(x), qd)  # noqa: E731
    dT = (T(q + h * eye) - T(q - h * eye)) / (2 * h)
    Cqd = robot3d.coriolis_forces(q, qd)
    # Lagrange: d/dt ∂T/∂q̇ − ∂T/∂q = M q̈ + Ṁ q̇ − ∂T/∂q, so C q̇ = Ṁ q̇ − ∂T/∂q
    assert rel(Cqd, Mdot @ qd - dT) <= 1e-8
    # passivity: q̇ᵀ (Ṁ − 2C) q̇ = 0
    assert abs(qd @ (Mdot @ qd - 2 * Cqd)) <= 1e-8 * np.abs(qd).max() * np.abs(Mdot @ qd).max() * 12
    # C q̇ is quadratic in q̇ (no term linear in it)
    np.testing.assert_allclose(robot3d.coriolis_forces(q, 2 * qd), 4 * Cqd, rtol=1e-12, atol=1e-15)


def test_mass_matrix_from_the_kinematics_module(robot3d):
    # the compiled Jacobians against the numpy ones of core.spatial (a separate implementation)
    rng = np.random.default_rng(5)
    q = random_spatial(rng, 2, (3,))
    _, _, Jp, Jw = robot3d.kinematics.jacobian(q, robot3d._node_arcs)
    jp, jw = robot3d.node_jacobians(q)
    np.testing.assert_allclose(jp, Jp, rtol=0, atol=1e-14)
    np.testing.assert_allclose(jw, Jw, rtol=0, atol=1e-14)
    M = np.einsum("k,tkai,tkaj->tij", robot3d._w_lin, Jp, Jp) + np.einsum("ka,tkai,tkaj->tij", robot3d._w_rot, Jw, Jw)
    assert rel(robot3d.mass_matrix(q), M) <= 1e-13
    assert np.all(np.linalg.eigvalsh(robot3d.mass_matrix(q)) > 0)
    # torsion stiffness: G J with J = 2I; bending E I about both axes
    E, G, r = SOFT["youngs_modulus"], SOFT["shear_modulus"], SOFT["radius"]
    I_ = np.pi * r**4 / 4
    A = np.pi * r**2
    np.testing.assert_allclose(robot3d.stiffness[:6], [E * I_, E * I_, 2 * G * I_, 4 / 3 * G * A, 4 / 3 * G * A, E * A])


def test_free_undamped_rollout_conserves_energy():
    robot = SpatialPCSRobot([0.1, 0.1], damping=np.zeros(12), gravity=(1.0, 9.81, -2.0), **SOFT)
    rng = np.random.default_rng(0)
    q0 = random_spatial(rng, 2, bend=5.0, strain=0.01)
    qd0 = random_spatial(rng, 2, bend=2.0, strain=0.01)
    t = np.arange(0.0, 0.02, 1e-3)
    run = robot.simulate(q0, qd0, t, np.zeros((t.size, 12)), rtol=1e-9, atol=1e-11)
    E = robot.total_energy(run.q, run.qd)
    KE = robot.kinetic_energy(run.q, run.qd)
    assert np.ptp(KE) > 1e-3 * np.abs(E).max()  # energy is exchanged
    assert np.abs(E - E[0]).max() <= 1e-7 * KE.max()


def test_rollout_from_rest_stays_at_the_gravity_equilibrium():
    robot = SpatialPCSRobot([0.1, 0.1], damping=np.full(12, 2e-3), gravity=(3.0, 9.81, -2.0), **SOFT)
    sol = root(lambda q: robot.gravity_forces(q) + robot.elastic_forces(q), np.zeros(12), tol=1e-15)
    q_eq = sol.x
    assert np.abs(robot.gravity_forces(q_eq) + robot.elastic_forces(q_eq)).max() <= 1e-12
    assert np.abs(q_eq[[0, 1]]).min() > 0.1  # bent about both axes: a 3-D equilibrium
    t = np.arange(0.0, 0.1, 1e-3)
    run = robot.simulate(q_eq, np.zeros(12), t, np.zeros((t.size, 12)))
    assert np.abs(run.q - q_eq).max() <= 1e-9 * np.abs(q_eq).max()
    assert np.abs(run.qd).max() <= 1e-8


# --------------------------------------------------------------------------
# tendons in 3-D
# --------------------------------------------------------------------------
def test_tendon_lengths_and_actuation_map():
    L = [0.1, 0.12]
    tendons = SpatialTendons([0.22, 0.15, 0.07], [[0.01, 0.005], [-0.008, 0.0], [0.0, -0.012]])
    robot = SpatialPCSRobot(L, damping=np.full(12, 1e-3), actuation=tendons, **SOFT)
    assert robot.n_inputs == 3
    rng = np.random.default_rng(6)
    q = random_spatial(rng, 2, bend=10.0)
    # the offset curve p(s) + R(s) d as fine polylines of core.spatial poses (nodes on the segment boundary,
    # where the curve has a kink), their O(h²) chord error removed by Richardson extrapolation
    lengths = robot.tendon_lengths(q)

    def polyline(end, d, n):
        pieces = [(0.0, min(end, 0.1))] + ([(0.1, end)] if end > 0.1 else [])
        s = np.unique(np.concatenate([np.linspace(a, b, n + 1) for a, b in pieces]))
        p, R = SpatialPCS(L).forward_kinematics(q, s)
        curve = p + R @ np.array([d[0], 0.0, d[1]])
        return np.linalg.norm(np.diff(curve, axis=0), axis=1).sum()

    for k, (end, d) in enumerate(zip(tendons.end, tendons.offset, strict=True)):
        coarse, fine = polyline(end, d, 2000), polyline(end, d, 4000)
        assert lengths[k] == pytest.approx(fine + (fine - coarse) / 3, rel=1e-12)
    # straight robot: every tendon as long as its span
    np.testing.assert_allclose(robot.tendon_lengths(np.zeros(12)), tendons.end, rtol=1e-15)
    h = 1e-7
    eye = np.eye(12)
    dl = (robot.tendon_lengths(q + h * eye) - robot.tendon_lengths(q - h * eye)) / (2 * h)  # (12, p)
    assert rel(robot.actuation_matrix(q), -dl) <= 1e-7
    u = np.array([1.0, 0.5, 2.0])
    np.testing.assert_allclose(robot.actuation_forces(q, u), robot.actuation_matrix(q) @ u, rtol=1e-13)
    # a tendon at +z bends towards +bend_x at rest, one at +x towards -bend_z (as the planar tendons)
    A0 = robot.actuation_matrix(np.zeros(12))
    assert A0[1, 0] > 0 and A0[0, 0] < 0 and A0[0, 1] > 0
    with pytest.raises(ValueError, match=r"u\[5, 1\] = -1.0 at t = 0.005 s: tendon 1"):
        t = np.arange(0.0, 0.01, 1e-3)
        u_bad = np.ones((t.size, 3))
        u_bad[5, 1] = -1.0
        robot.simulate(np.zeros(12), np.zeros(12), t, u_bad)


# --------------------------------------------------------------------------
# the simulate contract and argument checks
# --------------------------------------------------------------------------
def test_simulate_contract_batch_and_advance(robot3d):
    rng = np.random.default_rng(7)
    q0 = random_spatial(rng, 2, (2,), bend=2.0, strain=0.01)
    t = np.arange(0.0, 0.01, 1e-3)
    runs = robot3d.simulate(q0, np.zeros((2, 12)), t, np.zeros((t.size, 2, 12)))
    assert isinstance(runs, list) and len(runs) == 2
    one = robot3d.simulate(q0[1], np.zeros(12), t, np.zeros((t.size, 12)))
    np.testing.assert_allclose(runs[1].q, one.q, rtol=0, atol=1e-14)
    assert one.metadata["method"] == "radau" and one.metadata["step"] == 5e-4
    positions, rotations = one.poses([0.0, 0.22])
    assert positions.shape == (t.size, 2, 3) and rotations.shape == (t.size, 2, 3, 3)
    # advance over the same held inputs reproduces simulate
    q, qd = q0[1], np.zeros(12)
    for _ in range(t.size - 1):
        q, qd = robot3d.advance(q, qd, np.zeros(12), 1e-3)
    np.testing.assert_allclose(q, one.q[-1], rtol=0, atol=1e-12)


def test_errors_name_the_argument():
    with pytest.raises(ValueError, match=r"damping must have shape \(12,\)"):
        SpatialPCSRobot([0.1, 0.1], damping=np.zeros(6), **SOFT)
    with pytest.raises(ValueError, match=r"gravity must have shape \(3,\)"):
        SpatialPCSRobot([0.1], damping=np.zeros(6), gravity=(0, 9.81), **SOFT)
    with pytest.raises(ValueError, match="density must be finite and > 0"):
        SpatialPCSRobot([0.1], damping=np.zeros(6), density=-1.0, youngs_modulus=1e5, shear_modulus=1e4)
    with pytest.raises(ValueError, match="actuation must be None or a SpatialTendons"):
        SpatialPCSRobot([0.1], damping=np.zeros(6), actuation=Tendons([0.1], [0.01]), **SOFT)
    with pytest.raises(ValueError, match=r"offset must have shape \(2, 2\)"):
        SpatialPCSRobot([0.1], damping=np.zeros(6), actuation=SpatialTendons([0.1, 0.05], [0.01, 0.0]), **SOFT)
    with pytest.raises(ValueError, match=r"end\[0\] = 0.3 lies outside the robot"):
        SpatialPCSRobot([0.1], damping=np.zeros(6), actuation=SpatialTendons([0.3], [0.01, 0.0]), **SOFT)
    robot = SpatialPCSRobot([0.1], damping=np.zeros(6), **SOFT)
    with pytest.raises(ValueError, match="q must have a last axis of length n_q = 6"):
        robot.mass_matrix(np.zeros(3))
    with pytest.raises(ValueError, match="qd contains NaN"):
        robot.coriolis_forces(np.zeros(6), np.full(6, np.nan))
    with pytest.raises(ValueError, match="q0 must have a last axis"):
        robot.simulate(np.zeros(3), np.zeros(3), [0.0, 1e-3], np.zeros((2, 6)))
    with pytest.raises(ValueError, match=r"u must have shape \(len\(t\),\)"):
        robot.simulate(np.zeros(6), np.zeros(6), [0.0, 1e-3], np.zeros((3, 6)))
    with pytest.raises(ValueError, match="tendon_lengths needs a robot with SpatialTendons"):
        robot.tendon_lengths(np.zeros(6))


# --------------------------------------------------------------------------
# the independent mpmath reference (tests/spatial_reference.py, written apart from the package)
# --------------------------------------------------------------------------
REFERENCE = Path(__file__).with_name("spatial_reference.py")
needs_reference = pytest.mark.skipif(
    not REFERENCE.exists(), reason="tests/spatial_reference.py (the independent mpmath reference) is not there yet"
)
REF_PARAMS = dict(rho=1070.0, radius=0.02, youngs=1e6, shear=3e5, gravity=(1.0, 9.81, -2.0), n_quadrature=4)


def reference_robot(lengths, damping, length_scaled=False):
    return SpatialPCSRobot(
        lengths,
        density=REF_PARAMS["rho"],
        youngs_modulus=REF_PARAMS["youngs"],
        shear_modulus=REF_PARAMS["shear"],
        radius=REF_PARAMS["radius"],
        damping=damping,
        gravity=REF_PARAMS["gravity"],
        stiffness_scaling="length" if length_scaled else "seed",
        n_quadrature=REF_PARAMS["n_quadrature"],
    )


@needs_reference
@pytest.mark.parametrize(("lengths", "length_scaled"), [([0.1], False), ([0.1, 0.13], True)])
def test_terms_against_the_mpmath_reference(lengths, length_scaled):
    ref_module = importlib.import_module("spatial_reference")
    m = len(lengths)
    damping = np.linspace(1e-3, 2e-3, 6 * m)
    robot = reference_robot(lengths, damping, length_scaled)
    rng = np.random.default_rng(10 + m)
    q = random_spatial(rng, m, bend=10.0, strain=0.05)
    qd = random_spatial(rng, m, bend=4.0, strain=0.1)
    ref = ref_module.reference_terms(q, qd, lengths, damping=damping, length_scaled=length_scaled, dps=30, **REF_PARAMS)
    # measured: ~2e-16 on every term
    assert rel(robot.mass_matrix(q), ref["M"]) <= 1e-8
    assert rel(robot.coriolis_forces(q, qd), ref["coriolis"]) <= 1e-8
    assert rel(robot.gravity_forces(q), ref["gravity"]) <= 1e-8
    assert rel(robot.elastic_forces(q), ref["elastic"]) <= 1e-8
    assert rel(robot.damping_forces(qd), ref["damping"]) <= 1e-8


@needs_reference
@pytest.mark.parametrize("magnitude", [1e-9, 1e-5, 1e-2, 1.0, 10.0])
def test_accelerations_against_the_mpmath_reference_at_every_magnitude(magnitude):
    ref_module = importlib.import_module("spatial_reference")
    lengths = [0.1, 0.12]
    damping = np.full(12, 1e-3)
    robot = reference_robot(lengths, damping)
    rng = np.random.default_rng(int(np.log10(magnitude)) + 20)
    q = random_spatial(rng, 2, bend=magnitude, strain=min(magnitude, 0.05))
    qd = random_spatial(rng, 2, bend=3.0, strain=0.1)
    tau = rng.normal(size=12) * 1e-2
    qdd = ref_module.reference_accelerations(q, qd, tau, lengths, damping=damping, dps=30, **REF_PARAMS)
    # measured: ~1e-14 (the conditioning of M) at every magnitude
    assert rel(robot.forward_dynamics(q, qd, tau), qdd) <= 1e-9


@pytest.mark.parametrize("bend", [0.1, 0.4, 0.9, 1.8, 2.9, 5.5, 7.5, 10.0])
def test_nodes_chosen_by_bend_agree_with_a_48_node_rule(bend, monkeypatch):
    """The default robot picks fewer nodes for slightly bent segments: M, G and C qd stay at round-off.

    Truth: the same robot with 48 Gauss-Legendre nodes on every segment (the node table switched off).
    """
    from pcs_sindy.core import spatial_kernels

    lengths, params = (0.07, 0.1), dict(density=1070.0, youngs_modulus=1e4, shear_modulus=1e3, damping=np.ones(12))
    fast = SpatialPCSRobot(lengths, **params)
    monkeypatch.setattr(spatial_kernels, "QUADRATURE_TIERS", ())
    dense = SpatialPCSRobot(lengths, n_quadrature=48, **params)
    rng = np.random.default_rng(int(10 * bend))
    q, qd = np.zeros((20, 12)), rng.normal(0.0, 3.0, (20, 12))
    for i, length in enumerate(lengths):
        axis = rng.normal(size=(20, 3))
        omega = axis / np.linalg.norm(axis, axis=1, keepdims=True) * bend / length
        q[:, 6 * i + 1], q[:, 6 * i + 2], q[:, 6 * i + 0] = omega.T
        q[:, 6 * i + 3 : 6 * i + 6] = rng.uniform(-0.3, 0.3, (20, 3))
    for name, a, b in (
        ("M", fast.mass_matrix(q), dense.mass_matrix(q)),
        ("G", fast.gravity_forces(q), dense.gravity_forces(q)),
        ("C qd", fast.coriolis_forces(q, qd), dense.coriolis_forces(q, qd)),
    ):
        scale = np.abs(b).reshape(20, -1).max(axis=1)
        err = np.abs(a - b).reshape(20, -1).max(axis=1) / scale
        assert err.max() < 1e-12, (name, err.max())
