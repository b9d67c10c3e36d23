"""Tests of the ground-truth PCS dynamics against independent truths.

Independent references used here: the kinematic Jacobian of
``pcs_sindy.core.kinematics`` integrated with a dense quadrature (mass matrix),
adaptive quadrature (moments), finite differences of energies (gravity,
Coriolis), energy conservation / dissipation and static equilibria found by
``scipy.optimize``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import fsolve

from pcs_sindy.core import SimulationError, forward_kinematics_jacobian
from pcs_sindy.simulation import _dispatch, _kernels
from pcs_sindy.simulation._backbone import backbone_moments
from pcs_sindy.simulation.dynamics import PCSRobot

SCALES = np.array([30.0, 0.2, 0.2])


def one_segment(**kw) -> PCSRobot:
    params = dict(
        segment_lengths=[0.1], density=1070, youngs_modulus=1e4, shear_modulus=1e3, damping=[1e-5, 0.15, 0.15]
    )
    params.update(kw)
    return PCSRobot(**params)


def two_segment(**kw) -> PCSRobot:
    params = dict(
        segment_lengths=[0.07, 0.1],
        density=[1070, 1049],
        youngs_modulus=[1e4, 9e3],
        shear_modulus=[1e3, 3e3],
        damping=[3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2],
    )
    params.update(kw)
    return PCSRobot(**params)


def random_q(rng, m, size=()):
    q = rng.normal(size=size + (3 * m,)) * np.tile(SCALES, m)
    return q


def states(runs):
    """(q, qd) of a simulate result: (T, n) for one robot, (T, B, n) for a batch."""
    if isinstance(runs, list):
        return np.stack([r.q for r in runs], axis=1), np.stack([r.qd for r in runs], axis=1)
    return runs.q, runs.qd


def fd_gradient(fun, q, eps=1e-6):
    return np.array([(fun(q + eps * e) - fun(q - eps * e)) / (2 * eps) for e in np.eye(q.size)])


# --------------------------------------------------------------------------
def test_backbone_moments_match_adaptive_quadrature():
    for u in [0.0, 1e-9, -0.3, 0.4999, 0.5001, 1.0, 3.7, -6.0, 12.0]:
        E = backbone_moments(u)
        for n in range(3):
            re = quad(lambda t: t**n * np.cos(u * t), 0, 1, epsabs=1e-15)[0]
            im = quad(lambda t: t**n * np.sin(u * t), 0, 1, epsabs=1e-15)[0]
            assert abs(E[n] - (re + 1j * im)) < 1e-13, (u, n)
    # exact values at u = 0 (no epsilon anywhere)
    assert np.allclose(backbone_moments(0.0), [1.0, 0.5, 1.0 / 3.0], rtol=0, atol=0)


@pytest.mark.parametrize("kappa_zero", [False, True])
def test_mass_matrix_matches_kinematic_jacobian(kappa_zero):
    rng = np.random.default_rng(1)
    robot = two_segment(base_pose=(0.01, -0.02, 0.4))
    L = robot.segment_lengths
    A, I = np.pi * 0.02**2, np.pi * 0.02**4 / 4
    for _ in range(3):
        q = random_q(rng, 2)
        if kappa_zero:
            q[[0, 3]] = 0.0
        x, w = np.polynomial.legendre.leggauss(40)
        M_ref = np.zeros((6, 6))
        start = 0.0
        for i in range(2):
            # interior nodes only, so each point lies unambiguously in segment i
            s = start + 0.5 * (x + 1) * L[i]
            _, J = forward_kinematics_jacobian(q, L, s, robot.base_pose)
            ws = 0.5 * w * L[i] * robot.density[i]
            M_ref += np.einsum("p,pai,paj->ij", ws * A, J[:, :2], J[:, :2])
            M_ref += np.einsum("p,pi,pj->ij", ws * I, J[:, 2], J[:, 2])
            start += L[i]
        M = robot.mass_matrix(q)
        np.testing.assert_allclose(M, M_ref, rtol=1e-11, atol=1e-13 * np.abs(M_ref).max())


def test_mass_matrix_symmetric_positive_definite_batched():
    rng = np.random.default_rng(2)
    robot = PCSRobot([0.05, 0.1, 0.06], [1240, 1049, 1070], [1e4, 6e4, 8e4], [1e3, 3e3, 5e3], np.full(9, 1e-2))
    q = random_q(rng, 3, (4, 5))
    q[0, :, ::3] = 0.0  # straight segments exactly
    q[1, 0] = 0.0
    M = robot.mass_matrix(q)
    assert M.shape == (4, 5, 9, 9)
    np.testing.assert_allclose(M, np.swapaxes(M, -1, -2), rtol=0, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    # batching does not change values
    np.testing.assert_allclose(M[2, 3], robot.mass_matrix(q[2, 3]), rtol=1e-14, atol=0)


def test_continuous_through_zero_curvature():
    robot = two_segment()
    q = np.array([0.0, 0.1, -0.05, 0.0, -0.2, 0.1])
    qd = np.array([3.0, 0.5, -0.2, -4.0, 0.1, 0.3])
    for d in (1e-7, -1e-7):
        qe = q + d * np.array([1, 0, 0, 1, 0, 0])
        for a, b in [
            (robot.mass_matrix(qe), robot.mass_matrix(q)),
            (robot.gravity_forces(qe), robot.gravity_forces(q)),
            (robot.coriolis_forces(qe, qd), robot.coriolis_forces(q, qd)),
        ]:
            assert np.abs(a - b).max() <= 1e-5 * np.abs(b).max()


@pytest.mark.parametrize("make", [one_segment, two_segment])
def test_gravity_is_gradient_of_potential(make):
    rng = np.random.default_rng(3)
    robot = make(gravity=(3.0, 9.81), base_pose=(0.0, 0.0, 0.3))
    for _ in range(3):
        q = random_q(rng, robot.n_segments)
        G_fd = fd_gradient(robot.gravitational_energy, q)
        np.testing.assert_allclose(robot.gravity_forces(q), G_fd, rtol=1e-7, atol=1e-9 * np.abs(G_fd).max())
        # potential energy adds the elastic part 1/2 q^T K q, whose gradient is K q
        P_fd = fd_gradient(robot.potential_energy, q)
        np.testing.assert_allclose(
            robot.gravity_forces(q) + robot.elastic_forces(q), P_fd, rtol=1e-7, atol=1e-9 * np.abs(P_fd).max()
        )


def test_coriolis_consistent_with_mass_matrix():
    rng = np.random.default_rng(4)
    robot = two_segment()
    eps = 1e-6
    for _ in range(3):
        q = random_q(rng, 2)
        qd = random_q(rng, 2) * 10
        M_dot = (robot.mass_matrix(q + eps * qd) - robot.mass_matrix(q - eps * qd)) / (2 * eps)
        # Euler-Lagrange: C qd = Mdot qd - 1/2 d/dq (qd^T M qd)
        dT = fd_gradient(lambda x: qd @ robot.mass_matrix(x) @ qd, q, eps)
        cq_ref = M_dot @ qd - 0.5 * dT
        cq = robot.coriolis_forces(q, qd)
        np.testing.assert_allclose(cq, cq_ref, rtol=1e-6, atol=1e-7 * np.abs(cq_ref).max())
        C = robot.coriolis_matrix(q, qd)
        np.testing.assert_allclose(C @ qd, cq, rtol=1e-12, atol=1e-14 * np.abs(cq).max())
        S = M_dot - 2 * C
        assert np.abs(S + S.T).max() < 1e-6 * np.abs(M_dot).max()


def test_inverse_and_forward_dynamics_round_trip():
    rng = np.random.default_rng(5)
    robot = two_segment()
    q = random_q(rng, 2, (7,))
    qd = random_q(rng, 2, (7,)) * 5
    qdd = random_q(rng, 2, (7,)) * 100
    tau = robot.inverse_dynamics(q, qd, qdd)
    # assembled from the documented pieces
    M = robot.mass_matrix(q)
    tau_ref = (
        np.einsum("bij,bj->bi", M, qdd)
        + robot.coriolis_forces(q, qd)
        + robot.gravity_forces(q)
        + robot.elastic_forces(q)
        + robot.damping * qd
    )
    np.testing.assert_allclose(tau, tau_ref, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(robot.forward_dynamics(q, qd, tau), qdd, rtol=1e-7, atol=1e-7 * np.abs(qdd).max())


def test_stiffness_conventions():
    L = np.array([0.07, 0.1])
    E, G, r = np.array([1e4, 9e3]), np.array([1e3, 3e3]), 0.02
    A, I = np.pi * r**2, np.pi * r**4 / 4
    per_seg = np.stack([E * I, 4 / 3 * G * A, E * A], axis=1)
    seed = two_segment()
    length = two_segment(stiffness_scaling="length")
    np.testing.assert_allclose(seed.stiffness, per_seg.reshape(-1), rtol=1e-14)
    np.testing.assert_allclose(length.stiffness, (L[:, None] * per_seg).reshape(-1), rtol=1e-14)
    assert np.isclose(seed.stiffness[1], 4 / 3 * 1e3 * A)
    q = np.arange(1.0, 7.0)
    np.testing.assert_allclose(length.elastic_forces(q), length.stiffness * q)


# --------------------------------------------------------------------------
# simulation
# --------------------------------------------------------------------------
@pytest.mark.parametrize("make", [one_segment, two_segment])
def test_undamped_energy_conserved(make):
    robot = make(damping=np.zeros(3 * len(make().segment_lengths)))
    m = robot.n_segments
    q0 = np.tile([8.0, 0.05, -0.03], m)
    qd0 = np.tile([-40.0, 0.5, 0.3], m)
    t = np.linspace(0.0, 1.0, 101)
    tau = np.zeros((t.size, 3 * m))
    q, qd = states(robot.simulate(q0, qd0, t, tau, method="dop853", rtol=1e-8, atol=1e-10))
    energy = robot.total_energy(q, qd)
    kinetic = robot.kinetic_energy(q, qd)
    assert np.ptp(kinetic) > 1e-3 * np.abs(energy[0])  # energy really is exchanged
    # relative to the energy that moves between kinetic and potential form
    assert np.abs(energy - energy[0]).max() <= 1e-6 * kinetic.max()


def test_damped_energy_never_increases():
    robot = two_segment()
    t = np.linspace(0.0, 0.3, 301)
    q, qd = states(
        robot.simulate(
            [20.0, 0.05, 0.1, -30.0, -0.1, 0.05], np.zeros(6), t, np.zeros((t.size, 6)), rtol=1e-9, atol=1e-12
        )
    )
    energy = robot.total_energy(q, qd)
    assert energy[0] - energy[-1] > 0.1 * (energy[0] - energy.min() + 1e-300)  # damping removes energy
    assert np.all(np.diff(energy) <= 1e-9 * np.abs(energy).max())


@pytest.mark.parametrize("scaling", ["seed", "length"])
def test_settles_at_static_equilibrium(scaling):
    # bending damping raised so the robot settles quickly
    # damping chosen so that the slowest mode decays at >= 3 1/s (with f_L = L the stiffness is ~10x lower)
    damping = [2e-4, 0.5, 0.05, 1e-4, 0.025, 0.05] if scaling == "seed" else [5e-5, 0.02, 0.01, 2.5e-5, 0.005, 0.01]
    robot = two_segment(damping=damping, stiffness_scaling=scaling)
    tau = np.array([2e-3, 0.01, 0.05, -1e-3, -0.005, 0.02]) * (1.0 if scaling == "seed" else 0.1)
    q_eq = fsolve(lambda q: robot.elastic_forces(q) + robot.gravity_forces(q) - tau, np.zeros(6), xtol=1e-13)
    assert np.allclose(robot.elastic_forces(q_eq) + robot.gravity_forces(q_eq), tau, atol=1e-12)
    t = np.linspace(0.0, 5.0, 51)
    q, qd = states(robot.simulate(np.zeros(6), np.zeros(6), t, np.tile(tau, (t.size, 1)), rtol=1e-8, atol=1e-11))
    np.testing.assert_allclose(q[-1], q_eq, rtol=0, atol=1e-6 * np.abs(q_eq).max())
    assert np.abs(qd[-1]).max() < 1e-5


def test_batched_simulation_matches_single_and_callable():
    robot = one_segment()
    t = np.linspace(0.0, 0.05, 51)
    rng = np.random.default_rng(6)
    q0 = random_q(rng, 1, (2,)) * 0.5
    tau_rows = np.repeat(rng.normal(size=(6, 2, 3)) * [5e-3, 0.05, 0.05], 10, axis=0)[: t.size]
    qb, qdb = states(robot.simulate(q0, np.zeros((2, 3)), t, tau_rows, rtol=1e-8, atol=1e-11))
    assert qb.shape == (t.size, 2, 3)
    for b in range(2):
        qs, qds = states(robot.simulate(q0[b], np.zeros(3), t, tau_rows[:, b], rtol=1e-8, atol=1e-11))
        np.testing.assert_allclose(qs, qb[:, b], rtol=0, atol=1e-6 * np.abs(qs).max())

        # zero-order hold expressed as a callable (scipy's Radau over the whole span) gives the same trajectory
        def hold(time, b=b):
            k = min(int(np.floor(time / 1e-3 + 1e-9)), t.size - 1)
            return tau_rows[k, b]

        qc, _ = states(robot.simulate(q0[b], np.zeros(3), t[:11], hold, rtol=1e-8, atol=1e-11))
        np.testing.assert_allclose(qc, qs[:11], rtol=0, atol=1e-6 * np.abs(qs).max())


def test_fixed_step_and_explicit_agree_with_adaptive():
    robot = two_segment()
    t = np.linspace(0.0, 0.04, 41)
    tau = np.repeat(np.random.default_rng(7).normal(size=(5, 6)) * [5e-3, 0.05, 0.1, 3e-3, 0.05, 0.1], 10, axis=0)[
        : t.size
    ]
    q_ref = robot.simulate(np.zeros(6), np.zeros(6), t, tau, method="radau", rtol=1e-9, atol=1e-12).q
    q_rk = robot.simulate(np.zeros(6), np.zeros(6), t, tau, method="dop853", rtol=1e-9, atol=1e-12).q
    q_fx = robot.simulate(np.zeros(6), np.zeros(6), t, tau, step=2.5e-4).q
    q_auto = robot.simulate(np.zeros(6), np.zeros(6), t, tau).q  # default: 0.5 ms fixed Radau steps
    span = np.ptp(q_ref, axis=0)
    assert np.all(np.abs(q_rk - q_ref).max(axis=0) <= 1e-6 * span)
    assert np.all(np.abs(q_fx - q_ref).max(axis=0) <= 1e-4 * span)
    assert np.all(np.abs(q_auto - q_ref).max(axis=0) <= 1e-4 * span)


@pytest.mark.parametrize("method", ["radau", "dopri5", "bdf"])
def test_integration_failure_raises_with_time(method):
    robot = one_segment()
    t = np.arange(11) * 1e-3
    tau = np.zeros((11, 3))
    tau[5:, 0] = 1e300  # finite, but the accelerations overflow from t = 5 ms on
    kws = ({}, dict(rtol=1e-6)) if method == "radau" else ({},)
    for kw in kws:
        with pytest.raises(SimulationError, match=r"t = 0\.005 s") as err:
            robot.simulate(np.zeros(3), np.zeros(3), t, tau, method=method, **kw)
        assert err.value.t == pytest.approx(0.005, abs=1e-9)


# --------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(segment_lengths=[0.1, -0.1]), "segment_lengths"),
        (dict(segment_lengths=[0.1, 0.0]), "segment_lengths"),
        (dict(density=[1070, 0.0]), "density"),
        (dict(density=[1070, 1000, 900]), "density"),
        (dict(youngs_modulus=np.nan), "youngs_modulus"),
        (dict(radius=-0.02), "radius"),
        (dict(damping=[1e-5, 0.1, 0.1]), "damping"),
        (dict(damping=[-1e-5, 0.1, 0.1, 1e-5, 0.1, 0.1]), "damping"),
        (dict(gravity=[0.0, 9.81, 0.0]), "gravity"),
        (dict(stiffness_scaling="area"), "stiffness_scaling"),
        (dict(base_pose=[0.0, 0.0]), "base_pose"),
        (dict(n_quadrature=0), "n_quadrature"),
    ],
)
def test_bad_constructor_arguments(kwargs, name):
    params = dict(
        segment_lengths=[0.07, 0.1], density=1070, youngs_modulus=1e4, shear_modulus=1e3, damping=np.full(6, 0.1)
    )
    params.update(kwargs)
    with pytest.raises(ValueError, match=name):
        PCSRobot(**params)


def test_bad_call_arguments():
    robot = two_segment()
    q = np.zeros(6)
    with pytest.raises(ValueError, match="q"):
        robot.mass_matrix(np.zeros(5))
    with pytest.raises(ValueError, match="q contains NaN"):
        robot.gravity_forces(np.array([np.nan, 0, 0, 0, 0, 0]))
    with pytest.raises(ValueError, match="qd"):
        robot.coriolis_forces(np.zeros((2, 6)), np.zeros(6))  # no silent broadcasting
    with pytest.raises(ValueError, match="tau"):
        robot.forward_dynamics(q, q, np.array([0, 0, np.inf, 0, 0, 0]))
    t = np.linspace(0, 0.01, 11)
    with pytest.raises(ValueError, match="u must have shape"):
        robot.simulate(q, q, t, np.zeros((10, 6)))
    with pytest.raises(ValueError, match="u contains NaN"):
        robot.simulate(q, q, t, np.full((11, 6), np.nan))
    with pytest.raises(ValueError, match="t must"):
        robot.simulate(q, q, t[::-1], np.zeros((11, 6)))
    with pytest.raises(ValueError, match="method"):
        robot.simulate(q, q, t, np.zeros((11, 6)), method="Euler")
    with pytest.raises(ValueError, match="q0"):
        robot.simulate(np.zeros(3), q, t, np.zeros((11, 6)))
    with pytest.raises(ValueError, match=r"u\(t\) must return shape \(6,\)"):
        robot.simulate(q, q, t, lambda time: np.zeros(5))
    with pytest.raises(ValueError, match="step"):
        robot.simulate(q, q, t, lambda time: np.zeros(6), step=1e-4)  # fixed steps need tabulated inputs
    with pytest.raises(ValueError, match="step"):
        robot.simulate(q, q, t, np.zeros((11, 6)), method="dopri5", step=1e-4)


def test_sample_grids_with_round_off_are_stepped_cleanly():
    # t = k * 1 ms far from 0 leaves round-off slivers between half-steps and samples
    robot = two_segment()
    t = np.arange(3995, 4016) * 1e-3
    tau = np.tile([1e-3, 0.01, 0.02, 0.0, 0.0, 0.0], (t.size, 1))
    for kw in ({}, dict(step=3e-4)):
        q, qd = states(robot.simulate(np.zeros(6), np.zeros(6), t, tau, **kw))
        assert q.shape == (t.size, 6) and np.all(np.isfinite(q)) and np.all(np.isfinite(qd))


# --------------------------------------------------------------------------
# compiled (numba) path
# --------------------------------------------------------------------------
def three_segment(**kw) -> PCSRobot:
    params = dict(
        segment_lengths=[0.05, 0.1, 0.06],
        density=[1240, 1049, 1070],
        youngs_modulus=[1e4, 6e4, 8e4],
        shear_modulus=[1e3, 3e3, 5e3],
        damping=[5e-5, 4e-2, 5e-2, 5e-5, 5e-3, 5e-2, 5e-5, 5e-3, 5e-2],
    )
    params.update(kw)
    return PCSRobot(**params)


def numpy_rhs(robot, y, tau):
    """State derivative from the batched numpy evaluations (the reference for the compiled kernels)."""
    n = robot.n_q
    return np.concatenate([y[..., n:], robot.forward_dynamics(y[..., :n], y[..., n:], tau)], axis=-1)


@pytest.mark.parametrize("make", [one_segment, two_segment, three_segment])
def test_compiled_terms_equal_numpy_terms(make):
    rng = np.random.default_rng(8)
    robot = make(base_pose=(0.01, -0.02, 0.4), gravity=(2.0, 9.81))
    robot.stiffness = robot.stiffness * rng.uniform(0.5, 3.0, robot.n_q)  # rescaled after construction
    m = robot.n_segments
    q = random_q(rng, m, (6,))
    q[0, ::3] = 0.0  # straight segments exactly
    q[1, 0] = 1e-9
    qd = random_q(rng, m, (6,)) * 5
    tau = random_q(rng, m, (6,)) * 0.01
    M, bias = _kernels.mass_and_bias_batch(q, qd, robot._jit_geometry())
    M_ref = robot.mass_matrix(q)
    bias_ref = (
        robot.coriolis_forces(q, qd) + robot.gravity_forces(q) + robot.elastic_forces(q) + robot.damping_forces(qd)
    )
    np.testing.assert_allclose(M, M_ref, rtol=0, atol=1e-12 * np.abs(M_ref).max())
    np.testing.assert_allclose(bias, bias_ref, rtol=0, atol=1e-12 * np.abs(bias_ref).max())
    y = np.concatenate([q, qd], axis=1)
    f = _dispatch.rhs_batch(y, tau, robot._jit_geometry())
    f_ref = numpy_rhs(robot, y, tau)
    # accelerations go through two different solvers of M x = b: compare relative to their size per state
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-10 * np.abs(f_ref).max())


def test_compiled_acceleration_jacobian_matches_central_differences():
    rng = np.random.default_rng(9)
    robot = two_segment()
    n = robot.n_q
    y = np.concatenate([random_q(rng, 2), random_q(rng, 2) * 5])
    tau = random_q(rng, 2) * 0.01
    geo = robot._jit_geometry()
    f0 = numpy_rhs(robot, y, tau)
    jac = np.empty((n, 2 * n))
    _kernels.accel_jacobian(y, f0, tau, geo, _kernels.workspace(geo), jac)
    ref = np.empty((n, 2 * n))

    def central(c: int, h: float) -> np.ndarray:
        e = np.zeros(2 * n)
        e[c] = h
        return (numpy_rhs(robot, y + e, tau)[n:] - numpy_rhs(robot, y - e, tau)[n:]) / (2 * h)

    for c in range(2 * n):
        h = 1e-5 * max(abs(y[c]), 1e-2)
        ref[:, c] = (4.0 * central(c, h) - central(c, 2.0 * h)) / 3.0  # Richardson: O(h^4), a sharp reference
    # the kernel's own forward differences (step 1.5e-8 |y|) are good to ~3e-6 of the largest entry here, and
    # their round-off moves with the numpy build (1.2e-5 at the lowest supported versions): a Newton matrix
    # needs no more; a wrong column or sign is off by O(1)
    tol = 5e-5 * np.abs(ref).max()
    np.testing.assert_allclose(jac, ref, rtol=0, atol=tol)
    # the full state Jacobian handed to scipy's implicit methods
    full = _dispatch.state_jacobian_batch(y[None], tau[None], geo)[0]
    np.testing.assert_array_equal(full[:n], np.hstack([np.zeros((n, n)), np.eye(n)]))
    np.testing.assert_allclose(full[n:], ref, rtol=0, atol=tol)


@pytest.mark.parametrize("kw", [{}, dict(rtol=1e-7, atol=1e-10)])
def test_compiled_radau_agrees_with_scipy_radau(kw):
    # scipy's Radau (an independent implementation of the same method) on the callable path, tightly
    robot = two_segment()
    t = np.linspace(0.0, 0.06, 61)
    tau = np.repeat(np.random.default_rng(10).normal(size=(7, 6)) * [5e-3, 0.05, 0.1, 3e-3, 0.05, 0.1], 10, axis=0)[
        : t.size
    ]
    q0 = np.array([5.0, 0.02, -0.01, -8.0, 0.03, 0.02])
    sim = robot.simulate(q0, np.zeros(6), t, tau, **kw)
    hold = lambda time: tau[min(int(np.floor(time / 1e-3 + 1e-9)), t.size - 1)]  # noqa: E731
    # the hold switches inside scipy's steps unless it restarts there: simulate each 10 ms hold on its own
    ref_q, ref_qd = [q0], [np.zeros(6)]
    for k in range(0, 60, 10):
        part = robot.simulate(ref_q[-1], ref_qd[-1], t[k : k + 11], hold, rtol=1e-10, atol=1e-13)
        ref_q.extend(part.q[1:])
        ref_qd.extend(part.qd[1:])
    ref_q, ref_qd = np.array(ref_q), np.array(ref_qd)
    assert sim.metadata["method"] == "radau" and part.metadata["step"] is None
    span, span_d = np.ptp(ref_q, axis=0), np.ptp(ref_qd, axis=0)
    # fixed 0.5 ms steps / error control at rtol 1e-7 (velocities carry the larger relative error)
    bound, bound_d = (1e-5, 1e-3) if not kw else (1e-6, 1e-5)
    assert np.all(np.abs(sim.q - ref_q).max(axis=0) <= bound * span)
    assert np.all(np.abs(sim.qd - ref_qd).max(axis=0) <= bound_d * span_d)


def test_compiled_radau_accuracy_against_tight_dop853():
    rng = np.random.default_rng(11)
    robot = three_segment()
    t = np.linspace(0.0, 0.05, 51)
    amp = np.tile([2e-3, 0.02, 0.05], 3)
    tau = np.repeat(rng.uniform(-1, 1, (6, 2, 9)) * amp, 10, axis=0)[: t.size]
    q0 = random_q(rng, 3, (2,)) * 0.3
    q_ref, _ = states(robot.simulate(q0, np.zeros((2, 9)), t, tau, method="dop853", rtol=1e-11, atol=1e-14))
    span = np.ptp(q_ref, axis=0)
    q_fix, _ = states(robot.simulate(q0, np.zeros((2, 9)), t, tau))  # default: fixed 0.5 ms Radau steps
    q_adp, _ = states(robot.simulate(q0, np.zeros((2, 9)), t, tau, rtol=1e-7, atol=1e-10))
    assert np.all(np.abs(q_fix - q_ref).max(axis=0) <= 1e-4 * span)
    assert np.all(np.abs(q_adp - q_ref).max(axis=0) <= 1e-6 * span)


def test_compiled_batch_progress_chunks_and_single_runs_agree():
    rng = np.random.default_rng(12)
    robot = two_segment()
    t = np.linspace(0.0, 0.1, 101)
    tau = np.repeat(rng.normal(size=(11, 3, 6)) * [5e-3, 0.05, 0.1, 3e-3, 0.05, 0.1], 10, axis=0)[: t.size]
    q0 = random_q(rng, 2, (3,)) * 0.3
    for kw in ({}, dict(rtol=1e-6, atol=1e-9)):
        qb, qdb = states(robot.simulate(q0, np.zeros((3, 6)), t, tau, **kw))
        # the progress bar splits the compiled run in chunks; the integrator state carries over exactly
        qp, qdp = states(robot.simulate(q0, np.zeros((3, 6)), t, tau, progress=True, **kw))
        np.testing.assert_array_equal(qp, qb)
        np.testing.assert_array_equal(qdp, qdb)
        # every robot of a batch has its own step sizes and Newton iterations
        for b in range(3):
            qs, qds = states(robot.simulate(q0[b], np.zeros(6), t, tau[:, b], **kw))
            np.testing.assert_array_equal(qs, qb[:, b])
            np.testing.assert_array_equal(qds, qdb[:, b])
