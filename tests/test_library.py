"""Tests of the symbolic PCS Lagrangian library against independent truth.

Truth: the numerical simulator :class:`pcs_sindy.simulation.dynamics.PCSRobot`
(Gauss–Legendre quadrature of closed-form Jacobians; shares no derivation
code with the library) and direct quadrature of the defining integrals.
"""

from __future__ import annotations

import hashlib
import json
import pickle

import numpy as np
import pysindy as ps
import pytest
from scipy.integrate import quad
from sklearn.base import clone

from pcs_sindy.core.kinematics import cosc, cosc_prime, sinc, sinc_prime
from pcs_sindy.identification import PCSLagrangianLibrary
from pcs_sindy.identification.library import codegen
from pcs_sindy.identification.library.special import SERIES_RADIUS, SpecialBank, register_backbone_functions, special
from pcs_sindy.simulation.dynamics import PCSRobot

RADIUS = 0.02
ONE = dict(lengths=[0.1], rho=[1070.0], E=[1e4], G=[1e3], D=[1e-5, 1.5e-1, 1.5e-1])
TWO = dict(
    lengths=[0.07, 0.1], rho=[1070.0, 1049.0], E=[1e4, 9e3], G=[1e3, 3e3], D=[3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2]
)


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    return str(tmp_path_factory.mktemp("pcs_cache"))


def robot(case, scaling="seed"):
    return PCSRobot(
        case["lengths"], case["rho"], case["E"], case["G"], case["D"], radius=RADIUS, stiffness_scaling=scaling
    )


def true_coef(lib, case, scaling="seed"):
    return lib.coefficients_from_parameters(
        case["rho"], RADIUS, case["E"], case["G"], case["D"], stiffness_scaling=scaling
    )


def random_states(n, n_samples, seed=0):
    """Random strains in the seed's range; rows 0-2 hit kappa = 0 exactly."""
    rng = np.random.default_rng(seed)
    scale = np.tile([40.0, 0.3, 0.3], n // 3 + 1)[:n]
    q = rng.uniform(-1, 1, (n_samples, n)) * scale
    qd = rng.normal(size=(n_samples, n)) * scale * 5
    qdd = rng.normal(size=(n_samples, n)) * scale * 100
    q[0] = 0.0  # straight, unstretched
    q[1, 0::3] = 0.0  # straight but sheared/stretched
    q[2, 0] = 0.0
    return q, qd, qdd


def rel_err(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


# ---------------------------------------------------------------- special functions
def test_special_functions_match_quadrature_and_switch_smoothly():
    fns = register_backbone_functions()

    # independent closed forms from the kinematics module: a = s sinc(us), b = s cosc(us)
    def a(u, s):
        return s * sinc(u * s)

    def b(u, s):
        return s * cosc(u * s)

    def au(u, s):
        return s * s * sinc_prime(u * s)

    def bu(u, s):
        return s * s * cosc_prime(u * s)

    truth = {
        "Ea": lambda u: a(u, 1.0),
        "Eb": lambda u: b(u, 1.0),
        "Eua": lambda u: au(u, 1.0),
        "IEa": lambda u: quad(lambda s: a(u, s), 0, 1, epsabs=1e-14)[0],
        "IEE": lambda u: quad(lambda s: a(u, s) ** 2 + b(u, s) ** 2, 0, 1, epsabs=1e-14)[0],
        "IEEu_re": lambda u: quad(lambda s: a(u, s) * au(u, s) + b(u, s) * bu(u, s), 0, 1, epsabs=1e-14)[0],
        "IEuEu": lambda u: quad(lambda s: au(u, s) ** 2 + bu(u, s) ** 2, 0, 1, epsabs=1e-14)[0],
    }
    us = np.array([0.0, 1e-7, 0.4, 2.5, SERIES_RADIUS - 1e-9, SERIES_RADIUS + 1e-9, 5.0, -7.5])
    for name, ref in truth.items():
        got = fns[name](us)
        want = np.array([ref(u) for u in us])
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-13, err_msg=name)
    # the vectorised bank used by the forward model agrees with the per-function evaluation
    names = sorted(fns) + ["IEuEu_u", "IEEu_im_u"]
    bank = SpecialBank(names)
    got = bank(us)
    for k, name in enumerate(names):
        np.testing.assert_allclose(got[:, k], special(name)(us), rtol=1e-11, atol=1e-13, err_msg=name)


# ---------------------------------------------------------------- dynamics vs simulator
@pytest.mark.parametrize("case", [ONE, TWO], ids=["one_segment", "two_segment"])
@pytest.mark.parametrize("basis", ["monomial", "physical"])
def test_inverse_dynamics_and_mass_matrix_match_simulator(case, basis, cache_dir):
    lib = PCSLagrangianLibrary(case["lengths"], basis=basis, cache_dir=cache_dir)
    coef = true_coef(lib, case)
    assert coef.shape == (lib.n_coefficients_,)
    sim = robot(case)
    q, qd, qdd = random_states(sim.n_q, 30)
    psi = lib.euler_lagrange_matrix(q, qd, qdd)
    assert psi.shape == (30, sim.n_q, lib.n_coefficients_)
    assert np.all(np.any(psi.reshape(-1, lib.n_coefficients_) != 0, axis=0))  # no empty column
    tau_ref = sim.inverse_dynamics(q, qd, qdd)
    for k in range(30):  # per sample, relative to that sample's magnitude
        assert rel_err(psi[k] @ coef, tau_ref[k]) < 1e-8
    np.testing.assert_allclose(
        lib.mass_matrix(q, coef), sim.mass_matrix(q), rtol=1e-8, atol=1e-10 * np.max(np.abs(sim.mass_matrix(q)))
    )
    # bias and potential forces split Psi coef consistently with the simulator's terms
    pot = sim.gravity_forces(q) + sim.elastic_forces(q)
    assert rel_err(lib.potential_forces(q, coef), pot) < 1e-8
    bias_ref = tau_ref - np.einsum("kij,kj->ki", sim.mass_matrix(q), qdd)
    assert rel_err(lib.bias_forces(q, qd, coef), bias_ref) < 1e-8
    # stiffness and damping read back from pi+ as the contract says
    np.testing.assert_allclose(-2.0 * coef[lib.stiffness_index_], sim.stiffness, rtol=1e-12)
    np.testing.assert_allclose(coef[lib.damping_index_], sim.damping, rtol=0)


def test_length_scaled_stiffness_matches_simulator(cache_dir):
    lib = PCSLagrangianLibrary(TWO["lengths"], cache_dir=cache_dir)
    coef = true_coef(lib, TWO, scaling="length")
    sim = robot(TWO, scaling="length")
    q, qd, qdd = random_states(6, 10, seed=3)
    assert rel_err(lib.euler_lagrange_matrix(q, qd, qdd) @ coef, sim.inverse_dynamics(q, qd, qdd)) < 1e-8


@pytest.mark.parametrize("case", [ONE, TWO], ids=["one_segment", "two_segment"])
def test_features_sum_to_the_lagrangian(case, cache_dir):
    """sum_j pi_j f_j = T - U (simulator energies) for the pysindy transform."""
    lib = PCSLagrangianLibrary(case["lengths"], cache_dir=cache_dir)
    sim = robot(case)
    q, qd, _ = random_states(sim.n_q, 20, seed=1)
    x = np.hstack([q, qd])
    f = np.asarray(lib.fit(x).transform(x))
    coef = true_coef(lib, case)[: lib.n_output_features_]
    lagrangian = sim.kinetic_energy(q, qd) - sim.potential_energy(q)
    # the Lagrangian is defined up to a constant: compare differences to the straight robot
    ref = lagrangian - (sim.kinetic_energy(q[:1] * 0, qd[:1] * 0) - sim.potential_energy(q[:1] * 0))
    got = f @ coef - (np.asarray(lib.transform(np.zeros((1, x.shape[1])))) @ coef)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref)))


# ---------------------------------------------------------------- limit rule
@pytest.mark.parametrize(
    "case,mask",
    [(ONE, [[1, 0, 1]]), (ONE, [[0, 1, 1]]), (TWO, [[1, 1, 1], [1, 0, 1]]), (TWO, [[1, 1, 0], [1, 0, 1]])],
    ids=["1seg-noshear", "1seg-nobend", "2seg-noshear2", "2seg-mixed"],
)
def test_restrict_is_the_limit_of_the_full_library(case, mask, cache_dir):
    full = PCSLagrangianLibrary(case["lengths"], cache_dir=cache_dir)
    red = full.restrict(mask)
    keep = np.asarray(mask, dtype=bool).reshape(-1)
    q, qd, qdd = random_states(keep.sum(), 15, seed=2)
    psi_red = red.euler_lagrange_matrix(q, qd, qdd)
    embed = red.kinematics.to_full
    psi_full = full.euler_lagrange_matrix(embed(q), embed(qd), embed(qdd))[:, keep, :]
    # kept columns are the full library's columns evaluated in the limit, row dropped
    np.testing.assert_array_equal(psi_red, psi_full[:, :, red.column_map_])
    # every dropped column is identically zero or an exact multiple of a kept one
    dropped = np.setdiff1d(np.arange(full.n_coefficients_), red.column_map_)
    kept = psi_full[:, :, red.column_map_].reshape(-1, red.n_coefficients_)
    for j in dropped:
        col = psi_full[:, :, j].reshape(-1)
        if np.all(col == 0):
            continue
        cosine = np.abs(kept.T @ col) / (np.linalg.norm(kept, axis=0) * np.linalg.norm(col))
        k = int(np.argmax(cosine))
        ratio = (col @ kept[:, k]) / (kept[:, k] @ kept[:, k])
        np.testing.assert_allclose(col, ratio * kept[:, k], rtol=1e-9, atol=1e-12 * np.max(np.abs(col)))
    # and the restricted model is the simulator's with those strains frozen at zero
    coef = true_coef(red, case)
    sim = robot(case)
    tau = sim.inverse_dynamics(embed(q), embed(qd), embed(qdd))[:, keep]
    assert rel_err(psi_red @ coef, tau) < 1e-8
    # no column of the restricted library is identically zero on these states
    assert np.all(np.any(psi_red.reshape(-1, red.n_coefficients_) != 0, axis=0))


def test_restrict_physical_basis_matches_simulator(cache_dir):
    full = PCSLagrangianLibrary(TWO["lengths"], cache_dir=cache_dir, basis="physical")
    red = full.restrict([[1, 0, 1], [0, 1, 1]])
    keep = red.kinematics.active_mask
    q, qd, qdd = random_states(int(keep.sum()), 10, seed=5)
    embed = red.kinematics.to_full
    psi_full = full.euler_lagrange_matrix(embed(q), embed(qd), embed(qdd))[:, keep, :]
    # same columns up to summation order of the (physical) weight matrix product
    np.testing.assert_allclose(
        red.euler_lagrange_matrix(q, qd, qdd),
        psi_full[:, :, red.column_map_],
        rtol=1e-12,
        atol=1e-14 * np.max(np.abs(psi_full)),
    )
    tau = robot(TWO).inverse_dynamics(embed(q), embed(qd), embed(qdd))[:, keep]
    assert rel_err(red.euler_lagrange_matrix(q, qd, qdd) @ true_coef(red, TWO), tau) < 1e-8
    np.testing.assert_allclose(-2.0 * true_coef(red, TWO)[red.stiffness_index_], robot(TWO).stiffness[keep], rtol=1e-12)


def test_basis_sizes_one_segment(cache_dir):
    """Sizes counted by hand from the closed form (see docs/results.md, library_build)."""
    lib = PCSLagrangianLibrary([0.1], cache_dir=cache_dir)
    assert lib.n_lagrangian_ == 22 and lib.n_coefficients_ == 25
    no_shear = lib.restrict([[1, 0, 1]])
    # 1 (dax^2) + 2 (dax dbe, ax dax dbe) + 4 gravity + 3 (dbe^2 times 1, ax, ax^2) + dbe^2 (rotary) + 2 stiffness
    assert no_shear.n_lagrangian_ == 13 and no_shear.n_coefficients_ == 15
    assert PCSLagrangianLibrary([0.1], basis="physical", cache_dir=cache_dir).n_lagrangian_ == 7


# ---------------------------------------------------------------- fast dynamics
@pytest.mark.parametrize(
    "case,mask", [(ONE, None), (ONE, [[1, 0, 1]]), (TWO, None)], ids=["1seg", "1seg-noshear", "2seg"]
)
def test_forward_model_matches_batched_and_simulator(case, mask, cache_dir):
    lib = PCSLagrangianLibrary(case["lengths"], active_strains=mask, cache_dir=cache_dir)
    coef = true_coef(lib, case)
    fm = lib.forward_model(coef)
    n = lib.n_strains
    q, qd, _ = random_states(n, 8, seed=4)
    M_b = lib.mass_matrix(q, coef)
    bias_b = lib.bias_forces(q, qd, coef)
    sim = robot(case)
    keep = lib.kinematics.active_mask
    M_sim = sim.mass_matrix(lib.kinematics.to_full(q))[:, keep][:, :, keep]
    M_f, bias_f = fm.mass_and_bias(q, qd)
    assert M_f.shape == (q.shape[0], n, n) and bias_f.shape == q.shape
    tau = np.ones(n)
    for k in range(q.shape[0]):
        assert rel_err(M_f[k], M_b[k]) < 1e-10 and rel_err(M_f[k], M_sim[k]) < 1e-8
        assert rel_err(bias_f[k], bias_b[k]) < 1e-10
        # the single-sample path of rollouts: qdd = M^-1 (tau - bias)
        qdd = fm._state_derivative(np.r_[q[k], qd[k]], tau)[n:]
        assert rel_err(qdd, np.linalg.solve(M_b[k], tau - bias_b[k])) < 1e-8


# ---------------------------------------------------------------- pysindy / sklearn
def test_works_inside_pysindy_and_clones(cache_dir):
    lib = PCSLagrangianLibrary([0.1], cache_dir=cache_dir)
    params = lib.get_params()
    assert params["segment_lengths"] == [0.1] and params["basis"] == "monomial"
    twin = clone(lib)
    assert twin.get_params()["cache_dir"] == cache_dir
    twin.set_params(basis="physical")
    t = np.linspace(0.0, 1.0, 120)
    x = np.stack(
        [
            10 * np.sin(3 * t),
            0.1 * np.cos(2 * t),
            0.05 * np.sin(t),
            30 * np.cos(3 * t),
            -0.2 * np.sin(2 * t),
            0.05 * np.cos(t),
        ],
        axis=1,
    )
    # a plain SINDy (x_dot = Theta(x) Xi) cannot fit a Lagrangian library: refused, naming the routes that work
    with pytest.raises(TypeError, match="EulerLagrangeRegressor.*WeakEulerLagrangeSINDy"):
        ps.SINDy(feature_library=twin, optimizer=ps.STLSQ(threshold=0.0)).fit(x, t=t)
    feats = np.asarray(twin.fit(x).transform(x))
    assert feats.shape == (120, 7) and len(twin.get_feature_names()) == 7
    # pickling (joblib workers) drops the generated code and rebuilds it on use
    thawed = pickle.loads(pickle.dumps(lib.fit(x)))
    np.testing.assert_array_equal(np.asarray(thawed.transform(x)), np.asarray(lib.transform(x)))
    names = lib.fit(x).get_feature_names()
    assert len(names) == lib.n_output_features_ == 22 and len(set(names)) == 22
    assert len(lib.euler_lagrange_names()) == lib.n_coefficients_


# ---------------------------------------------------------------- cache
def test_cache_roundtrip_and_tamper_detection(tmp_path):
    first = codegen.build_basis(1, cache_dir=tmp_path)
    assert not first.from_cache
    second = codegen.build_basis(1, cache_dir=tmp_path)
    assert second.from_cache and second.source == first.source
    q = np.array([[3.0, 0.1, -0.2], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(second.psi(q, q, q, np.array([0.1])), first.psi(q, q, q, np.array([0.1])))
    path = next(tmp_path.glob("*.json"))
    data = json.loads(path.read_text())
    data["source"] = data["source"].replace("np.zeros", "np.ones")  # tampered text, stale hash
    path.write_text(json.dumps(data))
    third = codegen.build_basis(1, cache_dir=tmp_path)
    assert not third.from_cache and third.source == first.source
    # text with a consistent hash but not of the generated shape is refused too (never executed)
    data = json.loads(path.read_text())
    data["source"] = data["source"].replace(
        "def psi(q, qd, qdd, L):", f"def psi(q, qd, qdd, L):\n    open({str(tmp_path / 'x')!r}, 'w')"
    )
    data["sha256"] = hashlib.sha256(data["source"].encode()).hexdigest()
    path.write_text(json.dumps(data))
    fourth = codegen.build_basis(1, cache_dir=tmp_path)
    assert not fourth.from_cache and fourth.source == first.source
    assert not (tmp_path / "x").exists()


# ---------------------------------------------------------------- bad input
def test_bad_input_raises_value_error_naming_the_argument(cache_dir):
    with pytest.raises(ValueError, match="segment_lengths"):
        PCSLagrangianLibrary([0.1, -0.2], cache_dir=cache_dir).euler_lagrange_matrix(
            np.zeros((1, 6)), np.zeros((1, 6)), np.zeros((1, 6))
        )
    with pytest.raises(ValueError, match="basis"):
        PCSLagrangianLibrary([0.1], basis="fourier", cache_dir=cache_dir).n_coefficients_
    with pytest.raises(ValueError, match="active_strains"):
        PCSLagrangianLibrary([0.1], active_strains=[1, 0], cache_dir=cache_dir).n_coefficients_
    lib = PCSLagrangianLibrary([0.1], cache_dir=cache_dir)
    good = np.zeros((4, 3))
    with pytest.raises(ValueError, match="q must have shape"):
        lib.euler_lagrange_matrix(np.zeros((4, 2)), good, good)
    with pytest.raises(ValueError, match="qdd must have 4 samples"):
        lib.euler_lagrange_matrix(good, good, np.zeros((5, 3)))
    bad = good.copy()
    bad[1, 1] = np.nan
    with pytest.raises(ValueError, match="qd contains NaN"):
        lib.euler_lagrange_matrix(good, bad, good)
    with pytest.raises(ValueError, match="coef must have length"):
        lib.mass_matrix(good, np.ones(3))
    with pytest.raises(ValueError, match="density"):
        lib.coefficients_from_parameters([1.0, 2.0], 0.02, 1e4, 1e3, np.ones(3))
    with pytest.raises(ValueError, match="stiffness_scaling"):
        lib.coefficients_from_parameters(1.0, 0.02, 1e4, 1e3, np.ones(3), stiffness_scaling="weird")
    with pytest.raises(ValueError, match="active_strains must be a subset"):
        lib.restrict([[1, 0, 1]]).restrict([[1, 1, 0]])
    with pytest.raises(ValueError, match="x must have 2n = 6 columns"):
        lib.fit(np.zeros((5, 4)))


def test_crafted_cache_cannot_execute_code(tmp_path):
    """A cache file with consistent hashes but hostile source is re-derived, never run."""
    import hashlib
    import json

    from pcs_sindy.identification.library import codegen

    good = codegen.build_basis(1, cache_dir=tmp_path)
    path = codegen._cache_file(tmp_path, 1)
    data = json.loads(path.read_text())
    sentinel = tmp_path / "pwned"
    attacks = [
        # rebinding an allowed call name to a builtin, then calling it
        f"def features(q, qd, L):\n    float = eval\n    return float(\"open({str(sentinel)!r}, 'w')\")\n"
        "def psi(q, qd, qdd, L):\n    return 0\n",
        # reading a builtin that is not in the allowed set
        f"def features(q, qd, L):\n    f = open\n    return f({str(sentinel)!r}, 'w')\n"
        "def psi(q, qd, qdd, L):\n    return 0\n",
    ]
    for source in attacks:
        hostile = dict(data, source=source, sha256=hashlib.sha256(source.encode()).hexdigest())
        path.write_text(json.dumps(hostile))
        basis = codegen.build_basis(1, cache_dir=tmp_path)
        basis.features(np.zeros((2, 3)), np.zeros((2, 3)), np.array([0.1]))
        assert not sentinel.exists()
        assert basis.source == good.source  # re-derived from scratch
