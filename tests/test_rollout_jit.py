"""Compiled (numba) rollout of physically parameterised PCS models.

Truth: the libraries' own ``mass_matrix``/``bias_forces`` (NumPy, and for the
Lagrangian library a symbolic derivation), numeric quadrature of the moment
integrals, the Python Dormand–Prince rollout (``integrate_zoh``) and the
ground-truth simulator ``PCSRobot.simulate`` (implicit Radau, independent code).
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy._jit_rollout import LumpedModel, _moments
from pcs_sindy.integrators import DivergenceError, integrate_zoh
from pcs_sindy.library import PCSLagrangianLibrary, PhysicalPCSLibrary
from pcs_sindy.regressor import EulerLagrangeRegressor, _make_rhs
from pcs_sindy.trajectory import StrainTrajectory

MAT = dict(density=1000.0, youngs_modulus=1e5, shear_modulus=3e4)


def _coef(lib, m):
    damp = np.tile([1e-4, 1e-2, 1e-2], m)
    if isinstance(lib, PCSLagrangianLibrary):
        return lib.coefficients_from_parameters(radius=0.01, damping=damp, **MAT)
    return lib.coefficients_from_parameters(radius=None, damping=damp, **MAT)


def _states(n_samples, mask, rng):
    # curvatures both inside (|kappa L| <= 1, series) and outside (closed form) the series range
    scale = np.tile([25.0, 0.1, 0.1], mask.size // 3)[mask]
    return rng.uniform(-1, 1, (n_samples, mask.sum())) * scale, rng.normal(size=(n_samples, mask.sum())) * 3 * scale


@pytest.mark.parametrize("u", [0.0, 1e-9, -0.3, 0.999, 1.0, 1.001, -2.7, 7.5, 40.0])
def test_moments_equal_numeric_integrals(u):
    got = _moments(u)
    # 200-node Gauss-Legendre on [0, 1]: exact to round-off for these smooth integrands
    x, w = np.polynomial.legendre.leggauss(200)
    t, w = 0.5 * (x + 1.0), 0.5 * w
    for n in range(3):
        ref = np.sum(w * t**n * np.exp(1j * u * t))
        assert abs(got[n] - ref) <= 1e-14


_LIBS = [
    ("physical", {}),
    ("physical", dict(identify_gravity=True, rotary_inertia="tied", gravity=(1.0, -9.0))),
    ("lagrangian", {}),
]


@pytest.mark.parametrize("kind,kw", _LIBS)
@pytest.mark.parametrize("lengths,active", [((0.1,), None), ((0.1, 0.08), None), ((0.1, 0.08), [[1, 1, 0], [1, 0, 1]])])
def test_kernels_equal_library_mass_and_bias(kind, kw, lengths, active):
    if kind == "lagrangian":
        lib = PCSLagrangianLibrary(lengths, active_strains=active, basis="physical")
    else:
        lib = PhysicalPCSLibrary(lengths, active_strains=active, radius=0.01, n_quadrature=8, **kw)
    m = len(lengths)
    coef = _coef(lib, m)
    model = LumpedModel.from_library(lib, coef)
    q, qd = _states(12, lib.kinematics.active_mask, np.random.default_rng(3))
    M, bias = model.mass_and_bias(q, qd)
    M_ref, b_ref = lib.mass_matrix(q, coef), lib.bias_forces(q, qd, coef)
    assert np.abs(M - M_ref).max() <= 1e-12 * np.abs(M_ref).max()
    assert np.abs(bias - b_ref).max() <= 1e-12 * np.abs(b_ref).max()


def test_fewer_quadrature_nodes_agree_for_moderate_curvature():
    # the integrands are smooth in s: 8 Gauss-Legendre nodes reproduce the 16-node library for |kappa L| <= 2.5
    lib = PhysicalPCSLibrary((0.1, 0.08), radius=0.01, n_quadrature=16)
    coef = _coef(lib, 2)
    model = LumpedModel.from_library(lib, coef, n_quadrature=8)
    assert model.wts.shape == (2, 8)
    q, qd = _states(12, lib.kinematics.active_mask, np.random.default_rng(4))
    M, bias = model.mass_and_bias(q, qd)
    M_ref, b_ref = lib.mass_matrix(q, coef), lib.bias_forces(q, qd, coef)
    assert np.abs(M - M_ref).max() <= 1e-12 * np.abs(M_ref).max()
    assert np.abs(bias - b_ref).max() <= 1e-12 * np.abs(b_ref).max()


def test_lagrangian_monomial_basis_has_no_lumped_parameters():
    lib = PCSLagrangianLibrary((0.1,))
    with pytest.raises(ValueError, match="basis='physical'"):
        lib.lumped_from_coef(np.zeros(lib.n_coefficients_))


def _square_wave(t, m, rng, amp):
    n_hold = 20
    levels = rng.uniform(-1, 1, (t.size // n_hold + 1, 3 * m)) * amp
    return np.repeat(levels, n_hold, axis=0)[: t.size]


@pytest.mark.parametrize("step", [None, 1e-4])
@pytest.mark.parametrize("active", [None, [[1, 0, 1], [1, 1, 0]]])
def test_compiled_rollout_equals_python_rollout(step, active):
    lib = PhysicalPCSLibrary((0.1, 0.08), active_strains=active, radius=0.01, n_quadrature=8)
    coef = _coef(lib, 2)
    mask = lib.kinematics.active_mask
    n = int(mask.sum())
    t = np.arange(61) * 1e-3
    rng = np.random.default_rng(5)
    tau = _square_wave(t, 2, rng, np.tile([2e-3, 0.5, 0.5], 2))[:, mask]
    y0 = np.concatenate([rng.normal(size=n) * np.tile([2.0, 0.01, 0.01], 2)[mask], np.zeros(n)])
    kw = dict(step=step, rtol=1e-8, atol=1e-10)
    s_jit, s_py = {}, {}
    y_jit = LumpedModel.from_library(lib, coef).rollout(y0, t, tau, stats=s_jit, **kw)
    y_py = integrate_zoh(_make_rhs(lib.compile_dynamics(coef), n), y0, t, tau, stats=s_py, **kw)
    assert s_jit == s_py  # same steps, rejections and evaluations
    scale = np.abs(y_py).max(axis=0)
    assert np.all(np.abs(y_jit - y_py).max(axis=0) <= 1e-8 * scale)
    assert np.ptp(y_py[:, :n], axis=0).min() > 1e-3 * scale[:n].min()  # the run actually moves


def _robot(name):
    from pcs_sindy.simulation import get_scenario

    return get_scenario(name).robot


@pytest.mark.parametrize("name", ["one_segment", "two_segment"])
def test_true_parameters_follow_simulator(name):
    robot = _robot(name)
    m = robot.n_segments
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    coef = lib.coefficients_from_parameters(robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus,
                                            robot.damping)
    t = np.arange(101) * 1e-3
    rng = np.random.default_rng(2)
    tau = robot.gravity_forces(np.zeros(3 * m)) + _square_wave(
        t, m, rng, np.abs(robot.elastic_forces(np.tile([10.0, 0.05, 0.05], m))))
    ref = robot.simulate(np.zeros(3 * m), np.zeros(3 * m), t, tau, rtol=1e-10, atol=1e-12)
    q_ref, qd_ref = ref.q, ref.qd
    y = LumpedModel.from_library(lib, coef).rollout(np.zeros(6 * m), t, tau, rtol=1e-10, atol=1e-12)
    assert np.all(np.abs(y[:, : 3 * m] - q_ref).max(axis=0) <= 1e-7 * np.abs(q_ref).max(axis=0))
    assert np.all(np.abs(y[:, 3 * m:] - qd_ref).max(axis=0) <= 1e-6 * np.abs(qd_ref).max(axis=0))


def test_regressor_backends_agree_and_divergence_is_reported():
    robot = _robot("one_segment")
    rng = np.random.default_rng(0)
    L = robot.kinematics.segment_lengths
    X, taus, qds, qdds = [], [], [], []
    for _ in range(2):
        q = rng.uniform(-1, 1, (200, 3)) * [15.0, 0.05, 0.05]
        qd = rng.normal(size=(200, 3)) * [30.0, 0.1, 0.1]
        qdd = rng.normal(size=(200, 3)) * [300.0, 1.0, 1.0]
        X.append(StrainTrajectory(q, np.arange(200) * 1e-3, segment_lengths=L))
        taus.append(robot.inverse_dynamics(q, qd, qdd))
        qds.append(qd)
        qdds.append(qdd)
    model = EulerLagrangeRegressor(basis="physical").fit(X, taus, qd=qds, qdd=qdds)
    t = np.arange(81) * 1e-3
    tau = robot.gravity_forces(np.zeros(3)) + _square_wave(t, 1, rng, np.abs(robot.elastic_forces([10.0, 0.05, 0.05])))
    q0 = np.array([3.0, 0.01, -0.01])
    a = model.simulate(q0, np.zeros(3), tau, t, backend="numba", rtol=1e-9, atol=1e-11)
    b = model.simulate(q0, np.zeros(3), tau, t, backend="python", rtol=1e-9, atol=1e-11)
    c = model.simulate(q0, np.zeros(3), tau, t, rtol=1e-9, atol=1e-11)  # auto
    for k in (a, c):
        assert np.all(np.abs(k.q - b.q).max(axis=0) <= 1e-8 * np.abs(b.q).max(axis=0))
        assert np.all(np.abs(k.qd - b.qd).max(axis=0) <= 1e-8 * np.abs(b.qd).max(axis=0))
    q_ref = robot.simulate(q0, np.zeros(3), t, tau, rtol=1e-10, atol=1e-12).q
    assert np.all(np.abs(a.q - q_ref).max(axis=0) <= 1e-5 * np.abs(q_ref).max(axis=0))
    with pytest.raises(DivergenceError, match=r"t = .*exceeded max_abs_state.*be_1="):
        model.simulate(np.zeros(3), np.zeros(3), np.full((t.size, 3), 1e6), t, max_abs_state=1e3, backend="numba")
    with pytest.raises(ValueError, match="callable"):
        model.simulate(q0, np.zeros(3), lambda s: tau[0], t, backend="numba")
    with pytest.raises(ValueError, match="backend"):
        model.simulate(q0, np.zeros(3), tau, t, backend="jax")


def test_singular_mass_matrix_and_bad_input():
    model = LumpedModel((0.1,), np.ones(3, bool), [0.0], [0.0], [[0.0, 0.0]], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
    t = np.arange(5) * 1e-3
    with pytest.raises(DivergenceError, match=r"t = 0 s .*singular") as err:
        model.rollout(np.ones(6), t, np.zeros((5, 3)))
    np.testing.assert_array_equal(err.value.y, np.ones(6))
    good = LumpedModel((0.1,), np.ones(3, bool), [0.3], [0.0], [[0.0, -3.0]], [1.0, 10.0, 10.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="does not divide"):
        good.rollout(np.zeros(6), t, np.zeros((5, 3)), step=3e-4)
    with pytest.raises(ValueError, match=r"u must be finite with shape \(5, 3\)"):
        good.rollout(np.zeros(6), t, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="rhoA"):
        LumpedModel((0.1,), np.ones(3, bool), [np.nan], [0.0], [[0.0, 0.0]], [1.0] * 3, [0.0] * 3)


# ---------------------------------------------------------------------------
# Rosenbrock-W rollout (method="rosenbrock")
# ---------------------------------------------------------------------------
def _structural_jacobian(model):
    """``[[0, I], [-M^-1 K, -M^-1 D]]`` with M from the kernels: the Jacobian the compiled loop uses."""
    n = model.n
    K, D = np.diag(model.stiffness), np.diag(model.damping)

    def jac(y, u):
        M = model.mass_and_bias(y[None, :n], y[None, n:])[0][0]
        return np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, D)]])

    return jac


@pytest.mark.parametrize("step", [None, 2.5e-4])
def test_compiled_rosenbrock_equals_python_rosenbrock(step):
    lib = PhysicalPCSLibrary((0.1, 0.08), active_strains=[[1, 0, 1], [1, 1, 1]], radius=0.01, n_quadrature=8)
    coef = _coef(lib, 2)
    mask = lib.kinematics.active_mask
    n = int(mask.sum())
    t = np.arange(41) * 1e-3
    rng = np.random.default_rng(7)
    tau = _square_wave(t, 2, rng, np.tile([2e-3, 0.5, 0.5], 2))[:, mask]
    y0 = np.concatenate([rng.normal(size=n) * np.tile([2.0, 0.01, 0.01], 2)[mask], np.zeros(n)])
    model = LumpedModel.from_library(lib, coef)
    kw = dict(step=step, rtol=1e-6, atol=1e-9, method="rosenbrock")
    s_jit, s_py = {}, {}
    y_jit = model.rollout(y0, t, tau, stats=s_jit, **kw)
    y_py = integrate_zoh(_make_rhs(lib.compile_dynamics(coef), n), y0, t, tau, stats=s_py,
                         jac=_structural_jacobian(model), **kw)
    assert s_jit == s_py
    scale = np.abs(y_py).max(axis=0)
    assert np.all(np.abs(y_jit - y_py).max(axis=0) <= 1e-9 * scale)
    assert np.ptp(y_py[:, :n], axis=0).min() > 1e-3 * scale[:n].min()


@pytest.mark.parametrize("name", ["one_segment", "two_segment"])
def test_rosenbrock_true_parameters_follow_simulator(name):
    robot = _robot(name)
    m = robot.n_segments
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity, n_quadrature=8)
    coef = lib.coefficients_from_parameters(robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus,
                                            robot.damping)
    t = np.arange(151) * 1e-3
    rng = np.random.default_rng(2)
    tau = robot.gravity_forces(np.zeros(3 * m)) + _square_wave(
        t, m, rng, np.abs(robot.elastic_forces(np.tile([10.0, 0.05, 0.05], m))))
    ref = robot.simulate(np.zeros(3 * m), np.zeros(3 * m), t, tau, rtol=1e-10, atol=1e-12)
    q_ref, qd_ref = ref.q, ref.qd
    model = LumpedModel.from_library(lib, coef)
    scale = np.abs(q_ref).max(axis=0)
    errs = []
    for step in (1e-3 / 2, 1e-3 / 4):  # fixed steps: third order against the simulator
        y = model.rollout(np.zeros(6 * m), t, tau, step=step, method="rosenbrock")
        errs.append((np.abs(y[:, : 3 * m] - q_ref).max(axis=0) / scale).max())
    assert errs[1] <= 2e-4 and 5.0 < errs[0] / errs[1] < 11.0, errs
    stats: dict = {}
    y = model.rollout(np.zeros(6 * m), t, tau, rtol=1e-6, atol=1e-9, method="rosenbrock", stats=stats)
    assert np.all(np.abs(y[:, : 3 * m] - q_ref).max(axis=0) <= 1e-5 * scale)
    assert np.all(np.abs(y[:, 3 * m:] - qd_ref).max(axis=0) <= 1e-4 * np.abs(qd_ref).max(axis=0))


def test_regressor_rosenbrock_backends_agree_and_errors():
    robot = _robot("one_segment")
    rng = np.random.default_rng(0)
    L = robot.kinematics.segment_lengths
    X, taus, qds, qdds = [], [], [], []
    for _ in range(2):
        q = rng.uniform(-1, 1, (200, 3)) * [15.0, 0.05, 0.05]
        qd = rng.normal(size=(200, 3)) * [30.0, 0.1, 0.1]
        qdd = rng.normal(size=(200, 3)) * [300.0, 1.0, 1.0]
        X.append(StrainTrajectory(q, np.arange(200) * 1e-3, segment_lengths=L))
        taus.append(robot.inverse_dynamics(q, qd, qdd))
        qds.append(qd)
        qdds.append(qdd)
    model = EulerLagrangeRegressor(basis="physical").fit(X, taus, qd=qds, qdd=qdds)
    t = np.arange(31) * 1e-3
    tau = robot.gravity_forces(np.zeros(3)) + _square_wave(t, 1, rng, np.abs(robot.elastic_forces([10.0, 0.05, 0.05])))
    q0 = np.array([3.0, 0.01, -0.01])
    kw = dict(method="rosenbrock", rtol=1e-7, atol=1e-10)
    a = model.simulate(q0, np.zeros(3), tau, t, backend="numba", **kw)
    b = model.simulate(q0, np.zeros(3), tau, t, backend="python", **kw)  # Jacobian by differences
    ref = model.simulate(q0, np.zeros(3), tau, t, backend="numba", rtol=1e-10, atol=1e-12)  # dopri5
    for k in (a, b):
        assert np.all(np.abs(k.q - ref.q).max(axis=0) <= 1e-6 * np.abs(ref.q).max(axis=0))
    with pytest.raises(DivergenceError, match=r"t = .*exceeded max_abs_state.*be_1="):
        model.simulate(np.zeros(3), np.zeros(3), np.full((t.size, 3), 1e6), t, max_abs_state=1e3, method="rosenbrock")
    with pytest.raises(ValueError, match="method must be.*'radau5'"):
        model.simulate(q0, np.zeros(3), tau, t, method="radau5")
    with pytest.raises(ValueError, match="method must be one of.*'bdf'"):
        LumpedModel.from_library(model.library_, model.model_coef_).rollout(np.zeros(6), t, tau, method="bdf")


def test_rosenbrock_singular_mass_matrix():
    model = LumpedModel((0.1,), np.ones(3, bool), [0.0], [0.0], [[0.0, 0.0]], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
    t = np.arange(5) * 1e-3
    with pytest.raises(DivergenceError, match=r"t = 0 s .*singular") as err:
        model.rollout(np.ones(6), t, np.zeros((5, 3)), method="rosenbrock")
    np.testing.assert_array_equal(err.value.y, np.ones(6))


def test_eight_nodes_agree_with_sixteen_up_to_kappa_l_six():
    # the bound behind simulate's reduced quadrature (regressor._FAST_QUAD_MAX_KL)
    lib = PhysicalPCSLibrary((0.07, 0.1), radius=0.02, n_quadrature=16)
    coef = _coef(lib, 2)
    full, fast = LumpedModel.from_library(lib, coef), LumpedModel.from_library(lib, coef, n_quadrature=8)
    rng = np.random.default_rng(8)
    for kl in (2.0, 4.0, 6.0):
        q = rng.uniform(-1, 1, (100, 6)) * np.array([kl / 0.07, 0.3, 0.3, kl / 0.1, 0.3, 0.3])
        q[:, [0, 3]] = np.sign(q[:, [0, 3]]) * np.array([kl / 0.07, kl / 0.1])  # at the bound
        qd = rng.normal(size=(100, 6)) * [600.0, 3.0, 8.0, 500.0, 10.0, 10.0]
        (M1, b1), (M2, b2) = full.mass_and_bias(q, qd), fast.mass_and_bias(q, qd)
        assert np.abs(M1 - M2).max() <= 1e-10 * np.abs(M1).max()
        assert np.all(np.abs(b1 - b2).max(axis=0) <= 1e-10 * np.abs(b1).max(axis=0))


def test_simulate_repeats_with_the_library_rule_beyond_the_bound(monkeypatch):
    import pcs_sindy.regressor as regmod

    robot = _robot("one_segment")
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    coef = lib.coefficients_from_parameters(robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus,
                                            robot.damping)
    rng = np.random.default_rng(1)
    q = rng.uniform(-1, 1, (100, 3)) * [15.0, 0.05, 0.05]
    qd = rng.normal(size=(100, 3)) * [30.0, 0.1, 0.1]
    qdd = rng.normal(size=(100, 3)) * [300.0, 1.0, 1.0]
    X = [StrainTrajectory(q, np.arange(100) * 1e-3, segment_lengths=robot.kinematics.segment_lengths)]
    tau_fit = lib.euler_lagrange_matrix(q, qd, qdd) @ coef
    model = EulerLagrangeRegressor(library=lib).fit(X, [tau_fit], qd=[qd], qdd=[qdd])
    t = np.arange(31) * 1e-3
    tau = robot.gravity_forces(np.zeros(3)) + _square_wave(t, 1, rng, np.abs(robot.elastic_forces([10.0, 0.05, 0.05])))
    y0 = np.array([3.0, 0.01, -0.01, 0.0, 0.0, 0.0])
    kw = dict(rtol=1e-8, atol=1e-11, method="rosenbrock")
    direct = {nq: LumpedModel.from_library(lib, model.model_coef_, n_quadrature=nq).rollout(y0, t, tau, **kw)
              for nq in (8, 16)}
    assert not np.array_equal(direct[8], direct[16])  # the two rules differ (at round-off)
    sim = model.simulate(y0[:3], y0[3:], tau, t, **kw)
    np.testing.assert_array_equal(np.hstack([sim.q, sim.qd]), direct[8])
    monkeypatch.setattr(regmod, "_FAST_QUAD_MAX_KL", 0.0)
    sim = model.simulate(y0[:3], y0[3:], tau, t, **kw)
    np.testing.assert_array_equal(np.hstack([sim.q, sim.qd]), direct[16])
