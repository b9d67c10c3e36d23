"""Model files of spatial (3-D) models: a fitted regressor, a forward model of given parameters, trajectories.

Truth: the objects in memory (a loaded model must give the same forces, mass matrices, rollouts and
equilibria, bit for bit: the same code on the same numbers) and the parameters the data were made
from (the values a reader finds by name in the JSON).  Training data are exact inverse dynamics of
the spatial library along a smooth path (no simulation: the file format is under test, not the
identification).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pcs_sindy.core.spatial import SpatialPCS, SpatialStrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.identification.library.spatial_physical import SpatialPhysicalPCSLibrary
from pcs_sindy.io import load, save
from pcs_sindy.models import SpatialTendonActuation
from pcs_sindy.models.spatial_forward import SpatialPCSModel

RHO, E, G, R = 1070.0, 1e4, 1e3, 0.02
DAMP = np.array([3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15])
LENGTHS = [0.08, 0.1]
# bending and torsion in both segments, axial in the first: 7 strains (a spatial model need not keep all six)
ACTIVE = np.array([[1, 1, 1, 0, 0, 1], [1, 1, 1, 0, 0, 0]], dtype=bool)
BASE_P = (0.01, -0.02, 0.3)
BASE_R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # a quarter turn about z


def _path(t, n, seed=0):
    """A smooth path of n strains with its exact rates and accelerations."""
    rng = np.random.default_rng(seed)
    amp = rng.uniform(0.5, 1.0, (3, n)) * np.where(np.arange(n) == 6, 0.01, 5.0)  # 1/m; axial: -
    f = rng.uniform(0.5, 3.0, (3, n)) * 2 * np.pi
    ph = rng.uniform(0, 2 * np.pi, (3, n))
    arg = f[None] * t[:, None, None] + ph[None]
    q = (amp * np.sin(arg)).sum(axis=1)
    qd = (amp * f * np.cos(arg)).sum(axis=1)
    qdd = -(amp * f**2 * np.sin(arg)).sum(axis=1)
    return q, qd, qdd


@pytest.fixture(scope="module")
def fitted():
    lib = SpatialPhysicalPCSLibrary(LENGTHS, active_strains=ACTIVE, rest_strain=False).fit(np.zeros((1, 14)))
    coef = lib.coefficients_from_parameters(RHO, R, E, G, np.tile(DAMP, 2))
    t = np.arange(0.0, 1.0, 0.01)
    X, U, QD, QDD = [], [], [], []
    kin = SpatialPCS(tuple(LENGTHS), ACTIVE, BASE_P, BASE_R)
    for seed in range(2):
        q, qd, qdd = _path(t, 7, seed)
        tau = lib.euler_lagrange_matrix(q, qd, qdd) @ coef
        X.append(
            SpatialStrainTrajectory(
                kin.to_full(q),
                t,
                segment_lengths=LENGTHS,
                active_strains=ACTIVE,
                base_position=BASE_P,
                base_rotation=BASE_R,
            )
        )
        U.append(kin.to_full(tau))
        QD.append(kin.to_full(qd))
        QDD.append(kin.to_full(qdd))
    reg = EulerLagrangeRegressor(formulation="strong", feature_library=SpatialPhysicalPCSLibrary(rest_strain=False))
    reg.fit(X, U, qd=QD, qdd=QDD)
    return reg, X, U, QD, QDD, lib, coef


def test_a_fitted_spatial_regressor_round_trips(fitted, tmp_path):
    reg, X, U, QD, QDD, _, _ = fitted
    loaded = load(save(reg, tmp_path / "model"))
    # the identified model lives in the base frame (gravity is the library's, in that frame): its
    # segmentation is the data's lengths and strains; the forward model below keeps a base pose
    assert type(loaded.kinematics_) is SpatialPCS and loaded.kinematics_ == reg.kinematics_
    assert loaded.kinematics_.segment_lengths == tuple(LENGTHS)
    np.testing.assert_array_equal(loaded.active_strains_, reg.active_strains_)
    assert type(loaded.library_) is SpatialPhysicalPCSLibrary
    np.testing.assert_array_equal(loaded.library_.gravity, reg.library_.gravity)
    for name in ("coef_", "model_coef_", "stiffness_", "damping_", "column_map_"):
        a, b = getattr(reg, name), getattr(loaded, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert loaded.equations() == reg.equations()
    np.testing.assert_array_equal(
        loaded.predict(X[:1], qd=QD[:1], qdd=QDD[:1])[0], reg.predict(X[:1], qd=QD[:1], qdd=QDD[:1])[0]
    )
    q, qd = X[0].q[::9], QD[0][::9]
    for a, b in zip(loaded.forward_model().mass_and_bias(q, qd), reg.forward_model().mass_and_bias(q, qd), strict=True):
        np.testing.assert_array_equal(a, b)
    # a short rollout: the same numbers through the same code
    t = X[0].t[:4]
    sim_a = loaded.simulate(X[0].q[0], QD[0][0], t, U[0][:4])
    sim_b = reg.simulate(X[0].q[0], QD[0][0], t, U[0][:4])
    assert isinstance(sim_a, SpatialStrainTrajectory)
    np.testing.assert_array_equal(sim_a.q, sim_b.q)


def test_the_spatial_summary_names_every_coefficient_with_its_unit(fitted, tmp_path):
    reg, *_, lib, coef = fitted
    doc = json.loads(save(reg, tmp_path / "model").read_text(encoding="utf-8"))
    summary = doc["summary"]
    assert summary["segment_lengths"] == {"value": LENGTHS, "unit": "m"}
    assert summary["strains"] == reg.kinematics_.strain_names(active_only=True)
    assert "base_position" not in summary  # an identified model lives in its base frame
    assert summary["gravity"] == {"value": [0.0, 9.81, 0.0], "unit": "m/s^2"}  # in that frame
    got = summary["coefficients"]
    # the data were made from these parameters: the identified values are theirs (exact data)
    truth = dict(zip(lib.coefficient_names(), coef, strict=True))
    assert got["rhoA_1"]["unit"] == "kg/m" and got["rhoA_1"]["value"] == pytest.approx(RHO * np.pi * R**2, rel=1e-8)
    assert got["rhoI_2"]["unit"] == "kg·m" and got["rhoI_2"]["value"] == pytest.approx(truth["rhoI_2"], rel=1e-8)
    assert got["k_twist_2"]["unit"] == "N·m³" and got["k_twist_2"]["value"] == pytest.approx(
        2 * G * np.pi * R**4 / 4, rel=1e-8
    )
    assert got["k_axial_1"]["unit"] == "N·m" and got["d_bend_x_1"]["unit"] == "N·m³·s"
    assert summary["stiffness"]["twist_2"] == got["k_twist_2"]
    assert "shear_x_1" not in summary["stiffness"]  # not modelled
    assert [c["value"] for c in got.values()] == reg.model_coef_.tolist()


def test_a_spatial_forward_model_of_given_parameters_round_trips(fitted, tmp_path):
    *_, lib, coef = fitted
    kin = SpatialPCS(tuple(LENGTHS), ACTIVE, BASE_P, BASE_R)
    params = lib.lumped_from_coef(coef)
    params["rest_force"] = np.linspace(-1e-4, 1e-4, 7)
    params["n_quadrature"] = 9
    # tendons routed in 3-D, their magnitudes identified along given directions
    act = SpatialTendonActuation(end=[0.08, 0.18], angle=[0.3, 2.0]).fit(kin)
    act.set_identified([], act.signed_offsets([0.011, 0.007]))
    model = SpatialPCSModel(kin, **params, actuation=act)
    path = save(model, tmp_path / "fm")
    loaded = load(path)
    assert type(loaded) is SpatialPCSModel and loaded.kinematics == kin
    for name in ("rhoA", "rhoI", "rhoAg", "stiffness", "damping", "rest_force"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(model, name))
    np.testing.assert_array_equal(loaded.quadrature[0], model.quadrature[0])
    q = np.random.default_rng(2).uniform(-3, 3, (5, 7))
    for a, b in zip(loaded.mass_and_bias(q, q[::-1]), model.mass_and_bias(q, q[::-1]), strict=True):
        np.testing.assert_array_equal(a, b)
    assert type(loaded.actuation) is SpatialTendonActuation
    np.testing.assert_array_equal(loaded.actuation.offset_vectors_, act.offset_vectors_)
    u = np.array([0.5, 1.5])
    np.testing.assert_array_equal(loaded.input_forces(q[1], u), model.input_forces(q[1], u))
    np.testing.assert_array_equal(loaded.equilibrium(u), model.equilibrium(u))
    # the summary: every parameter by name with its unit
    summary = json.loads(path.read_text(encoding="utf-8"))["summary"]
    assert summary["rhoA"] == {"value": params["rhoA"].tolist(), "unit": "kg/m"}
    assert summary["base_position"]["value"] == list(BASE_P)
    assert summary["stiffness"]["twist_2"]["unit"] == "N·m³" and summary["rest_force"]["axial_1"]["unit"] == "N·m"
    assert summary["rhoAg"]["segment_2"]["unit"] == "N/m"
    assert summary["actuation"]["type"] == "spatial_tendon"


def test_a_spatial_trajectory_round_trips_with_its_base(fitted, tmp_path):
    X = fitted[1]
    tr = X[0]
    tr.metadata["note"] = "kept"
    loaded = load(save(tr, tmp_path / "traj"))
    assert type(loaded) is SpatialStrainTrajectory and loaded.kinematics == tr.kinematics
    np.testing.assert_array_equal(loaded.q, tr.q)
    np.testing.assert_array_equal(loaded.t, tr.t)
    assert loaded.metadata["note"] == "kept"
    doc = json.loads((tmp_path / "traj.json").read_text(encoding="utf-8"))
    assert doc["summary"]["n_frames"] == tr.n_frames and doc["summary"]["base_position"]["value"] == list(BASE_P)


def test_an_altered_spatial_file_is_refused_with_a_message_that_names_the_attribute(fitted, tmp_path):
    reg = fitted[0]
    path = save(reg, tmp_path / "model")
    doc = json.loads(path.read_text(encoding="utf-8"))
    state = doc["object"]["state"]
    # a planar-shaped active_strains_ in a spatial model
    state["active_strains_"] = {"$ndarray": "bool", "shape": [2, 3], "values": [[True] * 3] * 2}
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=r"active_strains_ must be the \(2, 6\) active strains"):
        load(path)
    # a library of other segments
    doc = json.loads(save(reg, tmp_path / "model2").read_text(encoding="utf-8"))
    kin = doc["object"]["state"]["kinematics_"]
    assert kin["$object"] == "SpatialPCS"
    kin["params"]["segment_lengths"] = {"$tuple": [0.08, 0.2]}
    (tmp_path / "model2.json").write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=r"library_ has segments \(0.08, 0.1\), kinematics_ \(0.08, 0.2\)"):
        load(tmp_path / "model2")


def test_a_crafted_spatial_library_with_a_huge_quadrature_is_refused(tmp_path):
    lib = SpatialPhysicalPCSLibrary([0.1])
    path = save(lib, tmp_path / "lib")
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["object"]["params"]["n_quadrature"] = 10**6
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=r"n_quadrature = 1000000 is outside its range"):
        load(path)
