"""Model files people can read: names, values and units in the JSON; small arrays in place; format 1 still loads.

Truth: the fitted model in memory (a loaded model must predict and print exactly as it does), the
scenario's true parameters (the values a reader finds by name in the JSON), and format 1's
documented layout (every array in the npz as ``{"$array": key}``, no summary), written here by hand
from a new file.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from pcs_sindy.core import StrainTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import INLINE_ARRAY_SIZE, load, save
from pcs_sindy.simulation import get_scenario

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "release_0_1_0"


@pytest.fixture(scope="module")
def fitted():
    sc = get_scenario("one_segment")
    recs = sc.generate(seed=0).train[:3]
    lengths = sc.robot.kinematics.segment_lengths
    X = [StrainTrajectory(r.q[:400], r.t[:400], segment_lengths=lengths) for r in recs]
    model = EulerLagrangeRegressor().fit(X, [r.tau[:400] for r in recs])
    return model, X, recs, sc


def _arrays(json_path):
    with np.load(json_path.with_suffix(".npz"), allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def _write_pair(json_path, doc, arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    payload = buf.getvalue()
    json_path.with_suffix(".npz").write_bytes(payload)
    doc["arrays"] = {
        "sha256": hashlib.sha256(payload).hexdigest(),
        "entries": {k: {"dtype": a.dtype.str, "shape": list(a.shape)} for k, a in arrays.items()},
    }
    json_path.write_text(json.dumps(doc))


def _as_format_1(doc: dict, arrays: dict) -> tuple[dict, dict]:
    """Format 1, by hand: every in-place array moved to the npz as ``{"$array": "a<k>"}``; no summary."""
    arrays = dict(arrays)

    def value(v):
        return float(v["$float"]) if isinstance(v, dict) else [value(x) for x in v] if isinstance(v, list) else v

    keys = {}  # id of a shared array -> its npz key (format 1 shares arrays through their key)

    def walk(node):
        if isinstance(node, dict):
            if "$ndarray" in node:
                key = f"a{len(arrays)}"
                arrays[key] = np.array(value(node["values"]), dtype=node["$ndarray"]).reshape(node["shape"])
                if "id" in node:
                    keys[node["id"]] = key
                return {"$array": key}
            if "$ref" in node and node["$ref"] in keys:
                return {"$array": keys[node["$ref"]]}
            return {k: walk(v) for k, v in node.items()}
        if isinstance(node, list):
            return [walk(v) for v in node]
        return node

    old = {k: v for k, v in doc.items() if k != "summary"}
    old["format_version"] = 1
    old["object"] = walk(doc["object"])
    return old, arrays


def test_json_shows_coefficients_by_name_with_units(fitted, tmp_path):
    model, _, _, sc = fitted
    path = save(model, tmp_path / "model")
    with open(path, encoding="utf-8") as fh:
        doc = json.load(fh)
    summary = doc["summary"]
    assert summary["segment_lengths"] == {"value": [0.1], "unit": "m"}
    assert summary["strains"] == ["be_1", "sh_1", "ax_1"]
    coef = summary["coefficients"]
    # the scenario's robot: rho A = 1070 pi 0.02^2 kg/m, k_be = E I = 1e4 pi 0.02^4 / 4 (f_L = 1 m)
    area, inertia = np.pi * 0.02**2, np.pi * 0.02**4 / 4
    assert coef["rhoA_1"]["unit"] == "kg/m" and coef["rhoA_1"]["value"] == pytest.approx(1070 * area, rel=1e-3)
    assert coef["k_be_1"]["unit"] == "N·m³" and coef["k_be_1"]["value"] == pytest.approx(1e4 * inertia, rel=1e-3)
    assert coef["k_ax_1"]["unit"] == "N·m" and coef["d_sh_1"]["unit"] == "N·m·s"
    assert summary["stiffness"]["be_1"] == coef["k_be_1"]
    assert summary["damping"]["be_1"]["value"] == pytest.approx(sc.robot.damping[0], rel=1e-2)
    assert summary["equations"] == model.equations()
    # the values are read as written: the numbers of coef_, bit for bit
    assert [c["value"] for c in coef.values()] == model.model_coef_.tolist()
    # small arrays in place, no npz entry: coef_ is readable where it is stored
    assert doc["arrays"]["entries"] == {}
    assert doc["object"]["state"]["coef_"]["values"] == model.coef_.tolist()
    text = path.read_text(encoding="utf-8")
    assert '"rhoA_1": {"value": ' in text and "N·m³" in text  # one line per value, units not escaped


def test_round_trip_predicts_and_prints_the_same(fitted, tmp_path):
    model, X, recs, _ = fitted
    loaded = load(save(model, tmp_path / "model"))
    assert loaded.equations() == model.equations()
    for name in ("coef_", "model_coef_", "stiffness_", "damping_", "column_map_"):
        a, b = getattr(model, name), getattr(loaded, name)
        assert a.dtype == b.dtype and np.array_equal(a, b)
    np.testing.assert_array_equal(loaded.predict(X[:1])[0], model.predict(X[:1])[0])
    r = recs[0]
    np.testing.assert_array_equal(
        loaded.simulate(r.q[0], r.qd[0], r.t[:200], r.tau[:200]).q,
        model.simulate(r.q[0], r.qd[0], r.t[:200], r.tau[:200]).q,
    )


def test_format_1_files_still_load(fitted, tmp_path):
    model, X, _, _ = fitted
    path = save(model, tmp_path / "model")
    old, arrays = _as_format_1(json.loads(path.read_text(encoding="utf-8")), _arrays(path))
    assert len(arrays) > 5 and '"$ndarray"' not in json.dumps(old)
    target = tmp_path / "old.json"
    _write_pair(target, old, arrays)
    loaded = load(target)
    assert loaded.equations() == model.equations()
    np.testing.assert_array_equal(loaded.coef_, model.coef_)
    np.testing.assert_array_equal(loaded.predict(X[:1])[0], model.predict(X[:1])[0])


def test_large_arrays_go_to_the_npz_and_shared_ones_stay_shared(tmp_path):
    obj = KinematicFusion()
    small, large = np.arange(INLINE_ARRAY_SIZE, dtype=float), np.arange(INLINE_ARRAY_SIZE + 1, dtype=np.int32)
    shared = np.array([1.5, -np.inf, np.nan, -0.0])
    obj.small_, obj.large_, obj.a_, obj.b_ = small, large, shared, shared
    obj.odd_ = np.array([[np.inf, 2.0]], dtype=np.float32)
    obj.names_ = np.array(["be_1", "ax_1"])
    path = save(obj, tmp_path / "f")
    doc = json.loads(path.read_text(encoding="utf-8"))
    state = doc["object"]["state"]
    assert state["small_"]["values"] == small.tolist() and "$array" in state["large_"]
    # met twice: written once (with an id), then referred to
    assert state["a_"]["values"][0] == 1.5 and state["b_"] == {"$ref": state["a_"]["id"]}
    assert state["odd_"] == {"$ndarray": "float32", "shape": [1, 2], "values": [[{"$float": "inf"}, 2.0]]}
    assert state["names_"] == {"$ndarray": "U4", "shape": [2], "values": ["be_1", "ax_1"]}
    loaded = load(path)
    for name in ("small_", "large_", "odd_", "names_", "a_"):
        a, b = getattr(obj, name), getattr(loaded, name)
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    assert loaded.a_ is loaded.b_ and np.signbit(loaded.a_[3])


@pytest.mark.parametrize(
    "node, match",
    [
        ({"$ndarray": "float64", "shape": [2], "values": [1.0, "2"]}, "holds the element '2'"),
        ({"$ndarray": "float64", "shape": [3], "values": [1.0, 2.0]}, "do not have the shape"),
        ({"$ndarray": "object", "shape": [1], "values": [1]}, "dtype must be one of"),
        ({"$ndarray": "bool", "shape": [2], "values": [1, 0]}, "holds the element 1"),
        ({"$ndarray": "uint8", "shape": [1], "values": [-1]}, "do not fit dtype uint8"),
        ({"$ndarray": "float64", "shape": [1], "values": [{"$float": "1e9"}]}, "not a number or a \\$float"),
        ({"$ndarray": "int64", "shape": [-1], "values": []}, "shape must be"),
        ({"$ndarray": "int64", "shape": [1], "values": [1], "extra": 0}, "expected the keys"),
    ],
)
def test_crafted_inline_arrays_are_refused(node, match, tmp_path):
    obj = KinematicFusion()
    obj.x_ = np.zeros(2)
    path = save(obj, tmp_path / "f")
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["object"]["state"]["x_"] = node
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=match):
        load(path)


def test_summary_is_not_read_back(fitted, tmp_path):
    model, X, _, _ = fitted
    path = save(model, tmp_path / "model")
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["summary"]["coefficients"]["rhoA_1"]["value"] = 1e9
    path.write_text(json.dumps(doc), encoding="utf-8")
    np.testing.assert_array_equal(load(path).coef_, model.coef_)


@pytest.mark.parametrize("name", ["regressor_physical", "regressor_monomial", "regressor_tendon", "fusion", "pipeline"])
def test_files_of_release_0_1_0_save_in_the_new_format(name, tmp_path):
    """Loaded from format 1 (every array in the npz), saved again: readable, and it loads to the same."""
    old = load(FIXTURES / name)
    path = save(old, tmp_path / name)
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["format_version"] == 2 and "summary" in doc
    again = load(path)
    assert json.loads(save(again, tmp_path / "again").read_text(encoding="utf-8"))["object"] == doc["object"]
    if name.startswith("regressor"):
        coef = doc["summary"]["coefficients"]
        assert list(coef) == old.library_.coefficient_names()
        assert all(c["unit"] for c in coef.values())
        assert doc["summary"]["equations"] == old.equations()


def test_a_library_with_parameters_its_fit_refuses_still_saves(tmp_path):
    from pcs_sindy.identification import PhysicalPCSLibrary

    path = save(PhysicalPCSLibrary([0.1], n_quadrature=0), tmp_path / "lib")
    assert "summary" not in json.loads(path.read_text(encoding="utf-8"))
    with pytest.raises(ValueError, match="n_quadrature"):
        load(path)
