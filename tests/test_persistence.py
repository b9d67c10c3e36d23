"""Model files (pcs_sindy.io.model_files): JSON + npz round trips and crafted (hostile) files.

Round trips: a loaded model must reproduce the original's outputs bit for bit
(``np.array_equal``) and its parameters.  Crafted files: each must raise a
clear error, and none may run code (a sentinel file that hostile content would
create must not appear).
"""

from __future__ import annotations

import copy
import hashlib
import io
import json
import math
import pathlib
import pickle

import numpy as np
import pytest
from sklearn.pipeline import Pipeline

from pcs_sindy.core import PoseTrajectory, StrainTrajectory
from pcs_sindy.core.saving import PersistenceMixin
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import FORMAT_NAME, FORMAT_VERSION, INLINE_ARRAY_SIZE, load, save
from pcs_sindy.simulation import get_scenario
from pcs_sindy.vision import MarkerPoseExtractor

N_SAMPLES = 200


# ----------------------------------------------------------------------
# data and fitted models (module scope: fitted once)
# ----------------------------------------------------------------------
def _strain_data(name: str, n_rec: int = 3):
    sc = get_scenario(name)
    recs = sc.generate(seed=0).train[:n_rec]
    lengths = sc.robot.kinematics.segment_lengths
    X = [StrainTrajectory(r.q[:N_SAMPLES], r.t[:N_SAMPLES], segment_lengths=lengths) for r in recs]
    qd = [r.qd[:N_SAMPLES] for r in recs]
    qdd = [sc.robot.forward_dynamics(r.q[:N_SAMPLES], r.qd[:N_SAMPLES], r.tau[:N_SAMPLES]) for r in recs]
    tau = [r.tau[:N_SAMPLES] for r in recs]
    return X, tau, qd, qdd, recs


@pytest.fixture(scope="module")
def one_segment():
    return _strain_data("one_segment")


@pytest.fixture(scope="module")
def poses_two():
    d = get_scenario("two_segment").generate(seed=0)
    return [PoseTrajectory(r.poses[:150], r.t[:150]) for r in d.train[:2]]


@pytest.fixture(scope="module")
def fusion(poses_two):
    return KinematicFusion().fit(poses_two)


@pytest.fixture(scope="module")
def regressors(one_segment):
    X, tau, qd, qdd, _ = one_segment
    return {
        basis: EulerLagrangeRegressor(feature_library=basis, formulation="strong").fit(X, tau, qd=qd, qdd=qdd)
        for basis in ("physical", "monomial")
    }


@pytest.fixture()
def sentinel(tmp_path):
    path = tmp_path / "PWNED"
    yield path
    assert not path.exists(), "loading a crafted model file ran code"


def _same(a, b) -> bool:
    """Structural equality with bit-exact arrays (NaN equal to NaN), types included."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            isinstance(a, np.ndarray)
            and isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and np.array_equal(a, b, equal_nan=a.dtype.kind in "fc")
        )
    if type(a) is not type(b):
        return False
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (float, np.floating)) and math.isnan(a):
        return math.isnan(b)
    if hasattr(a, "get_params"):
        return _same(a.get_params(deep=False), b.get_params(deep=False))
    return a == b


def _doc(path: pathlib.Path) -> dict:
    return json.loads(path.read_text())


def _write_doc(path: pathlib.Path, doc: dict) -> None:
    path.write_text(json.dumps(doc))


def _replace_npz(json_path: pathlib.Path, payload: bytes, entries: dict | None = None) -> None:
    """Put ``payload`` in the npz and make the JSON agree with it (hash, listing)."""
    json_path.with_suffix(".npz").write_bytes(payload)
    doc = _doc(json_path)
    doc["arrays"]["sha256"] = hashlib.sha256(payload).hexdigest()
    if entries is not None:
        doc["arrays"]["entries"] = entries
    _write_doc(json_path, doc)


class _Touch:
    """Unpickling this creates the sentinel file: the payload of a hostile pickle."""

    def __init__(self, path: pathlib.Path) -> None:
        self.path = path

    def __reduce__(self):
        return (pathlib.Path.touch, (self.path,))


# ----------------------------------------------------------------------
# round trips
# ----------------------------------------------------------------------
def test_fusion_round_trip_bit_exact(fusion, poses_two, tmp_path):
    out = save(fusion, tmp_path / "fusion")
    assert out == tmp_path / "fusion.json" and (tmp_path / "fusion.npz").is_file()
    loaded = load(out)
    assert type(loaded) is KinematicFusion
    assert loaded.get_params() == fusion.get_params()
    for key in (
        "segment_lengths_",
        "boundaries_",
        "marker_arc_lengths_",
        "q_max_",
        "distance_profile_",
        "total_length_",
        "n_segments_",
        "n_markers_",
        "history_",
    ):
        assert _same(getattr(loaded, key), getattr(fusion, key)), key
    a, b = fusion.transform(poses_two), loaded.transform(poses_two)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x.q, y.q) and x.segment_lengths == y.segment_lengths
    ra, rb = fusion.inverse_transform(a), loaded.inverse_transform(b)
    assert all(np.array_equal(x.poses, y.poses) for x, y in zip(ra, rb, strict=True))


@pytest.mark.parametrize("basis", ["physical", "monomial"])
def test_regressor_round_trip_bit_exact(basis, regressors, one_segment, tmp_path):
    X, tau, qd, qdd, recs = one_segment
    model = regressors[basis]
    loaded = load(save(model, tmp_path / f"model_{basis}.json"))
    assert loaded.get_params() == model.get_params()
    assert set(vars(loaded)) - {k for k in vars(loaded) if k.startswith("_")} == {
        k for k in vars(model) if not k.startswith("_")
    }
    for key in ("coef_", "model_coef_", "stiffness_", "damping_", "active_strains_", "column_map_"):
        assert _same(getattr(loaded, key), getattr(model, key)), key
    # shared objects stay shared (one library, referenced from the optimizer and the regressor)
    assert loaded.library_ is loaded.optimizer_.library_
    assert (loaded.full_library_ is loaded.library_) == (model.full_library_ is model.library_)
    pa, pb = model.predict(X, qd=qd, qdd=qdd), loaded.predict(X, qd=qd, qdd=qdd)
    assert all(np.array_equal(a, b) for a, b in zip(pa, pb, strict=True))
    q = recs[0].q[:50]
    assert np.array_equal(model.mass_matrix(q), loaded.mass_matrix(q))
    r = recs[1]
    sa = model.simulate(r.q[0], r.qd[0], r.t[:30], r.tau[:30])
    sb = loaded.simulate(r.q[0], r.qd[0], r.t[:30], r.tau[:30])
    assert np.array_equal(sa.q, sb.q) and np.array_equal(sa.qd, sb.qd)
    assert loaded.equations() == model.equations()


def test_regressor_with_strain_removal_round_trip(tmp_path):
    X, tau, qd, qdd, recs = _strain_data("one_segment_stiff_shear", n_rec=2)
    model = EulerLagrangeRegressor(formulation="strong").fit(X, tau, qd=qd, qdd=qdd)
    # the scenario's shear stiffness (1e6 Pa) is far above the bound (1e5 Pa): shear is removed
    assert model.removed_strains_ == ["sh_1"]
    loaded = load(save(model, tmp_path / "stiff"))
    assert loaded.removed_strains_ == ["sh_1"]
    assert np.array_equal(loaded.active_strains_, [[True, False, True]])
    assert np.array_equal(loaded.column_map_, model.column_map_)
    assert loaded.full_library_ is not loaded.library_
    assert _same(loaded.optimizer_.history_, model.optimizer_.history_)
    pa, pb = model.predict(X, qd=qd, qdd=qdd), loaded.predict(X, qd=qd, qdd=qdd)
    assert all(np.array_equal(a, b) for a, b in zip(pa, pb, strict=True))
    r = recs[0]
    sa = model.simulate(r.q[0], r.qd[0], r.t[:30], r.tau[:30])
    sb = loaded.simulate(r.q[0], r.qd[0], r.t[:30], r.tau[:30])
    assert np.array_equal(sa.q, sb.q)


def test_pipeline_round_trip(poses_two, tmp_path):
    d = get_scenario("two_segment").generate(seed=0)
    taus = [r.tau[:150] for r in d.train[:2]]
    pipe = Pipeline(
        [
            ("segments", KinematicFusion(shape_fit="end_pose")),
            ("dynamics", EulerLagrangeRegressor(weak_window=20, weak_stride=10, check_mass_matrix=False)),
        ]
    )
    pipe.fit(poses_two, taus)
    loaded = load(save(pipe, tmp_path / "pipe"))
    assert type(loaded) is Pipeline and [n for n, _ in loaded.steps] == ["segments", "dynamics"]
    assert _same(loaded.get_params(deep=False)["steps"], pipe.get_params(deep=False)["steps"])
    pa, pb = pipe.predict(poses_two), loaded.predict(poses_two)
    assert all(np.array_equal(a, b) for a, b in zip(pa, pb, strict=True))
    ta, tb = pipe[:-1].transform(poses_two), loaded[:-1].transform(poses_two)
    assert all(np.array_equal(a.q, b.q) for a, b in zip(ta, tb, strict=True))


def test_pcs_pipeline_round_trip(poses_two, tmp_path):
    from pcs_sindy.pipeline import pcs_pipeline as pipeline

    d = get_scenario("two_segment").generate(seed=0)
    taus = [r.tau[:150] for r in d.train[:2]]
    pipe = pipeline.make_pcs_pipeline(
        start="poses",
        fusion=KinematicFusion(shape_fit="end_pose"),
        regressor=EulerLagrangeRegressor(weak_window=20, weak_stride=10, check_mass_matrix=False),
    )
    pipe.fit(poses_two, taus)
    loaded = pipeline.PCSPipeline.load(pipe.save(tmp_path / "pcs_pipe"))
    assert type(loaded) is pipeline.PCSPipeline
    pa, pb = pipe.predict(poses_two), loaded.predict(poses_two)
    assert all(np.array_equal(a, b) for a, b in zip(pa, pb, strict=True))
    assert np.array_equal(loaded.segment_lengths_, pipe.segment_lengths_)
    r = d.train[0]
    q0, qd0 = pipe.initial_state(poses_two)
    sa = pipe.simulate(q0, qd0, r.t[:20], r.tau[:20])
    sb = loaded.simulate(q0, qd0, r.t[:20], r.tau[:20])
    assert np.array_equal(sa.q, sb.q)
    # unfitted, from videos: the extractor step round-trips its parameters
    video_pipe = pipeline.make_pcs_pipeline()
    again = load(save(video_pipe, tmp_path / "video_pipe"))
    assert [n for n, _ in again.steps] == ["poses", "segments", "dynamics"]
    assert _same(again.get_params(deep=False)["steps"], video_pipe.get_params(deep=False)["steps"])


def test_extractor_and_camera_params(tmp_path):
    from pcs_sindy.core import Camera
    from pcs_sindy.vision import MarkerPoseExtractor

    cam = Camera(pixels_per_metre=1200.0, origin=(300.5, 90.0), image_size=(640, 480), angle=0.1)
    ext = MarkerPoseExtractor(n_markers=20, threshold=(10, 60), roi=(1, 2, 300, 400), camera=cam, fps=1000.0)
    ext.diagnostics_ = [{"frame": 0}]  # learned diagnostics are not part of the model
    loaded = load(save(ext, tmp_path / "ext"))
    assert _same(loaded.get_params(deep=False), ext.get_params(deep=False))
    assert loaded.camera == cam and isinstance(loaded.threshold, tuple)
    assert not hasattr(loaded, "diagnostics_")
    assert load(save(cam, tmp_path / "cam")) == cam


def test_value_types_round_trip(fusion, tmp_path):
    obj = KinematicFusion(q_max=(60.0, 0.3, 0.3), pose_std=[1e-3, 0.02])
    obj.extra_ = {
        "inf": float("inf"),
        "-inf": float("-inf"),
        "nan": float("nan"),
        "tiny": 5e-324,
        "big": 2**70,
        "f32": np.float32(0.1),
        "i64": np.int64(-3),
        "b": np.bool_(True),
        "z": 1 + 2j,
        "tuple": (1, (2.5, "x")),
        "list": [None, True, "s"],
        3: "int key",
        (1, 2): "tuple key",
        "arrays": [
            np.arange(5, dtype=np.int32),
            np.array([[np.nan, -0.0]]),
            np.array(["a", "bc"]),
            np.zeros((0, 3)),
            np.array(2.5),
        ],
    }
    shared = np.linspace(0, 1, 7)
    obj.a_, obj.b_ = shared, shared
    loaded = load(save(obj, tmp_path / "types"))
    assert _same(loaded.extra_, obj.extra_)
    assert _same(loaded.get_params(), obj.get_params())  # tuple stays tuple, list stays list
    assert np.signbit(loaded.extra_["arrays"][1][0, 1])
    assert loaded.a_ is loaded.b_  # one array, stored once


def test_paths_with_and_without_suffix(fusion, tmp_path):
    assert save(fusion, tmp_path / "m.npz") == tmp_path / "m.json"
    for p in ("m", "m.json", "m.npz"):
        assert load(tmp_path / p).get_params() == fusion.get_params()
    assert save(fusion, str(tmp_path / "run.v2")) == tmp_path / "run.v2.json"
    assert (tmp_path / "run.v2.npz").is_file()
    with pytest.raises(OSError, match="does not exist"):
        save(fusion, tmp_path / "no_such_dir" / "m")


def test_mixin_checks_the_class(fusion, tmp_path):
    path = PersistenceMixin.save(fusion, tmp_path / "mix")
    load_as = PersistenceMixin.load.__func__
    assert load_as(KinematicFusion, path).get_params() == fusion.get_params()
    with pytest.raises(TypeError, match="KinematicFusion, not a EulerLagrangeRegressor"):
        load_as(EulerLagrangeRegressor, path)


def test_estimators_have_save_and_load_methods(fusion, tmp_path):
    path = fusion.save(tmp_path / "seg")
    again = KinematicFusion.load(path)
    assert np.array_equal(again.segment_lengths_, fusion.segment_lengths_)
    with pytest.raises(TypeError, match="not a EulerLagrangeRegressor"):
        EulerLagrangeRegressor.load(path)
    assert MarkerPoseExtractor.load(MarkerPoseExtractor(n_markers=3).save(tmp_path / "ex")).n_markers == 3


def test_unsupported_values_are_refused_at_save(fusion, tmp_path):
    with pytest.raises(ValueError, match=r"KinematicFusion\.gadget_ of type builtins\.object"):
        obj = KinematicFusion()
        obj.gadget_ = object()
        save(obj, tmp_path / "bad")
    with pytest.raises(ValueError, match=r"differentiation_method of type builtins\.function"):
        save(EulerLagrangeRegressor(differentiation_method=lambda x, t: x), tmp_path / "bad")
    with pytest.raises(ValueError, match="dtype object"):
        obj = KinematicFusion()
        obj.objs_ = np.array([object()], dtype=object)
        save(obj, tmp_path / "bad")
    with pytest.raises(ValueError, match="REGISTRY"):
        save({"a": 1}, tmp_path / "bad")
    assert not (tmp_path / "bad.json").exists()


# ----------------------------------------------------------------------
# crafted files
# ----------------------------------------------------------------------
@pytest.fixture()
def saved(fusion, tmp_path):
    """A fitted fusion with one array large enough for the npz (small arrays are written into the JSON)."""
    obj = copy.deepcopy(fusion)
    obj.big_ = np.arange(INLINE_ARRAY_SIZE + 1.0)
    return save(obj, tmp_path / "model")


@pytest.mark.parametrize("name", ["os.system", "builtins.eval", "posix.system", "subprocess.Popen", "__import__"])
def test_crafted_class_name_is_refused(name, saved, sentinel):
    doc = _doc(saved)
    doc["class"] = name
    doc["object"]["$object"] = name
    doc["object"]["params"] = {"command": f"touch {sentinel}"}
    _write_doc(saved, doc)
    with pytest.raises(ValueError, match="is not allowed in model files"):
        load(saved)
    # the same class nested in a parameter
    doc = _doc(saved.with_name("model.json"))
    doc["class"] = doc["object"]["$object"] = "KinematicFusion"
    doc["object"]["params"] = {
        "threshold": {"$object": name, "id": 5, "params": {"command": f"touch {sentinel}"}, "state": {}}
    }
    _write_doc(saved, doc)
    with pytest.raises(ValueError, match=r"threshold: class .* is not allowed"):
        load(saved)


def test_pickled_object_array_is_refused(saved, sentinel):
    entries = _doc(saved)["arrays"]["entries"]
    key = next(iter(entries))
    arrays = {k: np.zeros(v["shape"], dtype=np.dtype(v["dtype"])) for k, v in entries.items()}
    arrays[key] = np.array([_Touch(sentinel)], dtype=object)
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # object arrays are pickled inside the npz
    entries[key] = {"dtype": "|O", "shape": [1]}
    _replace_npz(saved, buf.getvalue(), entries)
    with pytest.raises(ValueError, match="cannot be read safely"):
        load(saved)


def test_pickle_posing_as_npz_is_refused(saved, sentinel):
    _replace_npz(saved, pickle.dumps(_Touch(sentinel)))
    with pytest.raises(ValueError, match="not a valid npz"):
        load(saved)


def test_npz_from_another_model_is_refused(saved, fusion, tmp_path):
    other = KinematicFusion(threshold=0.3)
    other.fit_marker_ = np.ones(INLINE_ARRAY_SIZE + 1)
    save(other, tmp_path / "other")
    (tmp_path / "model.npz").write_bytes((tmp_path / "other.npz").read_bytes())
    with pytest.raises(ValueError, match="sha256 mismatch"):
        load(saved)


@pytest.mark.parametrize(
    "version, match",
    [
        (FORMAT_VERSION + 1, "newer pcs_sindy"),
        (0, "invalid format_version"),
        ("1", "invalid format_version"),
        (None, "invalid format_version"),
        (True, "invalid format_version"),
    ],
)
def test_wrong_version_is_refused(version, match, saved):
    doc = _doc(saved)
    doc["format_version"] = version
    _write_doc(saved, doc)
    with pytest.raises(ValueError, match=match):
        load(saved)


def test_wrong_format_missing_and_truncated_files(saved, tmp_path):
    doc = _doc(saved)
    doc["format"] = "something.else"
    _write_doc(saved, doc)
    with pytest.raises(ValueError, match=f"not a {FORMAT_NAME} file"):
        load(saved)
    good = save(KinematicFusion(), tmp_path / "good")
    text = good.read_text()
    good.write_text(text[: len(text) // 2])
    with pytest.raises(ValueError, match="not valid JSON"):
        load(good)
    good.write_text(text.replace(f'"format_version": {FORMAT_VERSION}', '"format_version": NaN'))
    with pytest.raises(ValueError, match="not valid JSON"):
        load(good)
    good.write_text(text)
    (tmp_path / "good.npz").unlink()
    with pytest.raises(OSError, match="is missing"):
        load(good)
    with pytest.raises(OSError, match="does not exist"):
        load(tmp_path / "nothing")


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("threshold", "abc", "threshold must be a finite number > 0 or one of .auto."),
        ("fixed_base", 1, "parameter fixed_base must be a boolean"),
        ("threshold", -1.0, "invalid parameters.*threshold"),
        ("q_max", {"$tuple": ["a", 1, 2]}, "invalid parameters"),
        ("scaling", 3, "invalid parameters.*scaling"),
        ("evil", 1, r"unknown constructor parameter\(s\) \['evil'\]"),
        ("merge", {"$array": "a999"}, "does not hold"),
        ("merge", {"$ref": 0}, "not defined before"),
        ("merge", {"$float": "1e3"}, r"\$float must be"),
        ("merge", {"$scalar": "object", "value": 1}, "numpy scalar dtype"),
        ("merge", {"unknown": 1}, "exactly one of the tags"),
    ],
)
def test_wrong_params_are_refused(field, value, match, saved):
    doc = _doc(saved)
    doc["object"]["params"][field] = value
    _write_doc(saved, doc)
    with pytest.raises(ValueError, match=match):
        load(saved)


@pytest.mark.parametrize(
    "key", ["__class__", "__dict__", "fit", "transform", "_private_", "threshold", "segment lengths_"]
)
def test_state_cannot_reach_methods_or_dunders(key, saved):
    doc = _doc(saved)
    doc["object"]["state"][key] = 1
    _write_doc(saved, doc)
    with pytest.raises(ValueError, match="(not a learned attribute|cannot be set)"):
        load(saved)


def test_regressor_params_are_validated(regressors, tmp_path):
    path = save(regressors["physical"], tmp_path / "reg")
    for field, value in (("window_length", "x"), ("window_length", 4), ("formulation", "evil")):
        doc = _doc(path)
        original = doc["object"]["params"][field]
        doc["object"]["params"][field] = value
        _write_doc(path, doc)
        with pytest.raises(
            ValueError, match=rf"(invalid parameters|parameter {field} must).*{field}|parameter {field} must"
        ):
            load(path)
        doc["object"]["params"][field] = original
        _write_doc(path, doc)
    assert load(path).get_params() == regressors["physical"].get_params()


def test_model_file_cannot_choose_the_code_cache(regressors, tmp_path):
    """The library cache holds generated code that is executed: a stored cache_dir must not be used."""
    path = save(regressors["monomial"], tmp_path / "reg")
    doc = _doc(path)
    libraries = _objects_of_class(doc, "PCSLagrangianLibrary")
    assert libraries
    for lib in libraries:
        lib["params"]["cache_dir"] = str(tmp_path / "attacker_cache")
    _write_doc(path, doc)
    with pytest.raises(ValueError, match="may not choose it"):
        load(path)
    loaded = load(path, cache_dir=None)  # the user's own (default) cache
    assert loaded.full_library_.cache_dir is None and loaded.library_.cache_dir is None
    assert not (tmp_path / "attacker_cache").exists()


def _objects_of_class(node, name):
    """Every stored object of the registered class ``name`` in a model document."""
    found = []
    if isinstance(node, dict):
        if node.get("$object") == name and "params" in node:
            found.append(node)
        for value in node.values():
            found += _objects_of_class(value, name)
    elif isinstance(node, list):
        for value in node:
            found += _objects_of_class(value, name)
    return found


def test_pipeline_built_with_memory_saves_without_its_cache(tmp_path):
    """Issue 21: save refused a pipeline built with memory=; the cache is no part of the model."""
    from pcs_sindy.pipeline import PCSPipeline

    cache = tmp_path / "joblib"
    for pipe in (
        Pipeline([("segments", KinematicFusion(threshold=0.3))], memory=str(cache)),
        PCSPipeline([("segments", KinematicFusion()), ("dynamics", EulerLagrangeRegressor())], memory=str(cache)),
    ):
        loaded = load(save(pipe, tmp_path / type(pipe).__name__))
        assert type(loaded) is type(pipe) and loaded.memory is None
        assert loaded.steps[0][1].get_params() == pipe.steps[0][1].get_params()
        assert pipe.memory == str(cache)  # the saved object is not changed


def test_pipeline_memory_in_file_is_refused(tmp_path):
    path = save(Pipeline([("segments", KinematicFusion())]), tmp_path / "pipe")
    doc = _doc(path)
    doc["object"]["params"]["memory"] = str(tmp_path / "joblib")
    _write_doc(path, doc)
    with pytest.raises(ValueError, match="memory must be None"):
        load(path)


def test_deeply_nested_or_oversized_json_is_refused(saved):
    doc = _doc(saved)
    saved.write_text(json.dumps(doc)[:-1] + ', "extra": ' + "[" * 100000 + "]" * 100000 + "}")
    with pytest.raises(ValueError, match="(not valid JSON|nested too deeply)"):
        load(saved)
    text = json.dumps(doc)
    assert '"merge": "runs"' in text
    for depth in (400, 5000):  # below and above the JSON parser's own nesting limit
        nested = '{"$tuple": [' * depth + "1" + "]}" * depth
        saved.write_text(text.replace('"merge": "runs"', f'"merge": {nested}'))
        with pytest.raises(ValueError, match="(not valid JSON|nested too deeply|invalid parameters)"):
            load(saved)


def test_differentiation_object_round_trip(one_segment, tmp_path):
    import pysindy as ps

    X, tau, _, _, _ = one_segment
    model = EulerLagrangeRegressor(differentiation_method=ps.FiniteDifference(order=2), weak_window=20, weak_stride=10)
    model.fit(X, tau)
    loaded = load(save(model, tmp_path / "fd"))
    assert type(loaded.differentiation_method) is ps.FiniteDifference
    assert loaded.differentiation_method.get_params() == model.differentiation_method.get_params()
    pa, pb = model.predict(X), loaded.predict(X)  # derivatives from the restored differentiation object
    assert all(np.array_equal(a, b) for a, b in zip(pa, pb, strict=True))


def test_round_trip_in_a_fresh_process(regressors, one_segment, tmp_path):
    """No in-process cache (compiled basis, kernels) may carry state the file lacks."""
    import subprocess
    import sys

    X, _, qd, qdd, recs = one_segment
    r = recs[0]
    model = regressors["monomial"]
    path = save(model, tmp_path / "fresh")
    np.savez(tmp_path / "inputs.npz", q=X[0].q, t=X[0].t, qd=qd[0], qdd=qdd[0], tau=r.tau[:30])
    script = f"""
import numpy as np
from pcs_sindy.io.model_files import load
from pcs_sindy.core.trajectory import StrainTrajectory
d = np.load({str(tmp_path / "inputs.npz")!r})
m = load({str(path)!r})
X = [StrainTrajectory(d["q"], d["t"], segment_lengths=m.kinematics_.segment_lengths)]
p = m.predict(X, qd=[d["qd"]], qdd=[d["qdd"]])[0]
s = m.simulate(d["q"][0], d["qd"][0], d["t"][:30], d["tau"])
np.savez({str(tmp_path / "out.npz")!r}, p=p, s=s.q)
"""
    subprocess.run([sys.executable, "-c", script], check=True, timeout=300)
    out = np.load(tmp_path / "out.npz")
    assert np.array_equal(out["p"], model.predict(X[:1], qd=qd[:1], qdd=qdd[:1])[0])
    assert np.array_equal(out["s"], model.simulate(r.q[0], r.qd[0], r.t[:30], r.tau[:30]).q)
