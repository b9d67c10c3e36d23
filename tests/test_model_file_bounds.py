"""Model files are bounded: regular files only, no paths, integer ranges, consistency, in seconds.

Every hostile file below must be refused with a ``ValueError`` (or ``OSError`` for an
unreadable file) within a time budget, never hang, never allocate without bound.  A fuzz
test mutates one value at a time in saved files of every registered class (both
libraries) and requires the same of each mutant: it loads, or it is refused cleanly.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import pathlib
import random
import signal
import time

import numpy as np
import pytest

from pcs_sindy.core import Camera, PlanarPCS, PoseTrajectory, StrainTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import load, save
from pcs_sindy.io.model_files import MAX_MONOMIAL_SEGMENTS, PARAMETER_RANGES, REGISTRY
from pcs_sindy.simulation import get_scenario

BUDGET = 5.0  # seconds per load


@contextlib.contextmanager
def within(seconds: float = BUDGET):
    """Fail (TimeoutError) instead of hanging when the block takes longer than ``seconds``."""

    def expire(signum, frame):
        raise TimeoutError(f"took more than {seconds} s")

    old = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


# ----------------------------------------------------------------------
# fitted objects (module scope) and file surgery
# ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def cache_env(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PCS_SINDY_CACHE", str(tmp_path_factory.mktemp("cache")))
        yield


@pytest.fixture(scope="module")
def data():
    sc = get_scenario("one_segment")
    recs = sc.generate(seed=0).train[:2]
    lengths = sc.robot.kinematics.segment_lengths
    X = [StrainTrajectory(r.q[:200], r.t[:200], segment_lengths=lengths) for r in recs]
    return X, [r.tau[:200] for r in recs], recs


@pytest.fixture(scope="module")
def regressors(cache_env, data):
    X, tau, _ = data
    return {b: EulerLagrangeRegressor(feature_library=b).fit(X, tau) for b in ("physical", "monomial")}


def _arrays(json_path: pathlib.Path) -> dict[str, np.ndarray]:
    with np.load(json_path.with_suffix(".npz"), allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def _write(json_path: pathlib.Path, doc: dict, arrays: dict[str, np.ndarray] | None = None) -> None:
    """Write ``doc`` (and ``arrays``) as a consistent pair: hash and listing match, as a forger would make them."""
    if arrays is not None:
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        payload = buf.getvalue()
        json_path.with_suffix(".npz").write_bytes(payload)
        doc["arrays"]["sha256"] = hashlib.sha256(payload).hexdigest()
        doc["arrays"]["entries"] = {k: {"dtype": a.dtype.str, "shape": list(a.shape)} for k, a in arrays.items()}
    json_path.write_text(json.dumps(doc))


def _objects(node, name):
    """Every stored object of class ``name`` in a JSON tree."""
    if isinstance(node, dict):
        if node.get("$object") == name:
            yield node
        for v in node.values():
            yield from _objects(v, name)
    elif isinstance(node, list):
        for v in node:
            yield from _objects(v, name)


def _read_array(node: dict, arrays: dict[str, np.ndarray]) -> np.ndarray:
    """The array a JSON node stores: in place (``$ndarray``, small) or in the npz (``$array``)."""
    if "$array" in node:
        return arrays[node["$array"]]
    return np.array(node["values"], dtype=node["$ndarray"]).reshape(node["shape"])


def _inline(arr: np.ndarray) -> dict:
    """The JSON node of a small array written in place, as a forger would write it."""
    return {"$ndarray": arr.dtype.name, "shape": list(arr.shape), "values": arr.tolist()}


# ----------------------------------------------------------------------
# regular files only
# ----------------------------------------------------------------------
def test_json_symlinked_to_a_device_is_refused(tmp_path):
    good = save(KinematicFusion(), tmp_path / "good")
    (tmp_path / "evil.npz").write_bytes(good.with_suffix(".npz").read_bytes())
    os.symlink("/dev/zero", tmp_path / "evil.json")  # st_size 0 passed the size check before, then read forever
    with within(), pytest.raises(ValueError, match="symbolic link out of its folder|not a regular file"):
        load(tmp_path / "evil.json")


def test_npz_that_is_a_fifo_is_refused_without_blocking(tmp_path):
    path = save(KinematicFusion(), tmp_path / "m")
    path.with_suffix(".npz").unlink()
    os.mkfifo(path.with_suffix(".npz"))  # opening a FIFO for reading blocks until a writer comes
    with within(), pytest.raises(ValueError, match="not a regular file"):
        load(path)


def test_symlinks_inside_the_folder_are_followed_but_not_out_of_it(tmp_path):
    fusion = KinematicFusion(threshold=0.02)
    inner = tmp_path / "models"
    inner.mkdir()
    real = save(fusion, inner / "real")
    os.symlink("real.json", inner / "alias.json")
    os.symlink("real.npz", inner / "alias.npz")
    assert load(inner / "alias.json").threshold == 0.02
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    os.symlink(real, outside / "link.json")
    os.symlink(real.with_suffix(".npz"), outside / "link.npz")
    with pytest.raises(ValueError, match="symbolic link out of its folder"):
        load(outside / "link.json")


# ----------------------------------------------------------------------
# no paths: a camera is stored by value
# ----------------------------------------------------------------------
def test_extractor_camera_path_is_stored_by_value(tmp_path):
    from pcs_sindy.vision import MarkerPoseExtractor

    cam = Camera(pixels_per_metre=1500.0, origin=(320.0, 40.0), image_size=(640, 480))
    cam_file = cam.to_json(tmp_path / "cam.json")
    path = save(MarkerPoseExtractor(camera=str(cam_file)), tmp_path / "ext")
    assert str(cam_file) not in path.read_text()  # no path in the model file
    cam_file.unlink()  # the model does not depend on the camera file any more
    assert load(path).camera == cam


@pytest.mark.parametrize("value", ["/dev/zero", "fifo"])
def test_extractor_file_naming_a_camera_path_is_refused(value, tmp_path):
    from pcs_sindy.vision import MarkerPoseExtractor

    if value == "fifo":
        value = str(tmp_path / "cam.fifo")
        os.mkfifo(value)
    path = save(MarkerPoseExtractor(), tmp_path / "ext")
    doc = json.loads(path.read_text())
    doc["object"]["params"]["camera"] = value
    _write(path, doc)
    with within(), pytest.raises(ValueError, match="camera .* is a path"):
        load(path)


# ----------------------------------------------------------------------
# integer ranges and segment counts
# ----------------------------------------------------------------------
@pytest.mark.parametrize("value", [20_000, 10**9])
def test_n_quadrature_out_of_range_is_refused(value, regressors, tmp_path):
    path = save(regressors["physical"], tmp_path / "m")
    doc = json.loads(path.read_text())
    for lib in _objects(doc["object"], "PhysicalPCSLibrary"):
        lib["params"]["n_quadrature"] = value
    _write(path, doc)
    with within(), pytest.raises(ValueError, match=r"n_quadrature = .* outside its range \[1, 256\]"):
        load(path)


def test_every_stated_range_names_a_real_integer_parameter():
    import inspect

    from pcs_sindy.io.model_files import _resolve

    for name, ranges in PARAMETER_RANGES.items():
        params = inspect.signature(_resolve(name)).parameters
        for key, (lo, hi) in ranges.items():
            assert key in params and lo <= hi, (name, key)
            default = params[key].default
            # a word default (reference_frame="auto") is checked by the estimator's table, the range by integers
            assert default is None or isinstance(default, str) or lo <= default <= hi, (name, key, default)


def test_monomial_library_of_too_many_segments_is_refused(tmp_path):
    from pcs_sindy.identification.library import PCSLagrangianLibrary

    path = save(PCSLagrangianLibrary(segment_lengths=[0.05] * (MAX_MONOMIAL_SEGMENTS + 1)), tmp_path / "lib")
    with within(), pytest.raises(ValueError, match="monomial library of 3 segments"):
        load(path)


@pytest.mark.parametrize("basis", ["physical", "monomial"])
def test_segment_count_that_disagrees_with_the_coefficients_is_refused(basis, regressors, tmp_path):
    """The regressor's kinematics say two segments; its library and coefficients say one."""
    path = save(regressors[basis], tmp_path / "m")
    doc = json.loads(path.read_text())
    arrays = _arrays(path)
    kin = doc["object"]["state"]["kinematics_"]
    kin["params"]["segment_lengths"] = {"$tuple": [0.05, 0.05]}
    kin["params"]["active_strains"] = _inline(np.ones((2, 3), dtype=bool))
    _write(path, doc, arrays)
    with within(), pytest.raises(ValueError, match="inconsistent file"):
        load(path)


@pytest.mark.parametrize("basis", ["physical", "monomial"])
def test_tampered_coef_is_refused(basis, regressors, tmp_path):
    """coef_ altered, model_coef_ left: the old loader silently used model_coef_."""
    path = save(regressors[basis], tmp_path / "m")
    doc = json.loads(path.read_text())
    arrays = _arrays(path)
    state = doc["object"]["state"]
    coef = _read_array(state["coef_"], arrays).copy()
    coef[0] += 1.0
    state["coef_"] = _inline(coef)
    _write(path, doc, arrays)
    with within(), pytest.raises(ValueError, match=r"model_coef_ differs from coef_\[column_map_\]"):
        load(path)


@pytest.mark.parametrize("basis", ["physical", "monomial"])
def test_coefficients_of_the_wrong_length_are_refused(basis, regressors, tmp_path):
    path = save(regressors[basis], tmp_path / "m")
    doc = json.loads(path.read_text())
    arrays = _arrays(path)
    state = doc["object"]["state"]
    for attr in ("coef_", "model_coef_", "column_map_"):
        state[attr] = _inline(_read_array(state[attr], arrays)[:-1])
    _write(path, doc, arrays)
    with within(), pytest.raises(ValueError, match="inconsistent file: coef_ has"):
        load(path)


# ----------------------------------------------------------------------
# fuzz: single-value mutations of a saved file of every registered class
# ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def specimens(regressors, data):
    """A saved-able instance of every class in the REGISTRY (fitted where fitting means anything)."""
    from pysindy.differentiation import FiniteDifference
    from sklearn.pipeline import Pipeline

    from pcs_sindy.identification.library.with_gains import WithGains
    from pcs_sindy.models.actuation import (
        IdentityActuation,
        LearnedActuation,
        LinearActuation,
        PressureActuation,
        TendonActuation,
    )
    from pcs_sindy.pipeline import make_pcs_pipeline
    from pcs_sindy.vision import MarkerPoseExtractor

    X, _, recs = data
    poses = [PoseTrajectory(r.poses[:60], r.t[:60]) for r in recs]
    fusion = KinematicFusion().fit(poses)
    phys, mono = regressors["physical"], regressors["monomial"]
    out = {
        "KinematicFusion": fusion,
        "EulerLagrangeRegressor[physical]": phys,
        "EulerLagrangeRegressor[monomial]": mono,
        "StiffnessThresholdOptimizer": phys.optimizer_,
        "PCSLagrangianLibrary": mono.library_,
        "PhysicalPCSLibrary": phys.library_,
        "IdentityActuation": IdentityActuation(),
        "TendonActuation": TendonActuation(end=[0.1], side=[1]),
        "PressureActuation": PressureActuation(start=[0.0], end=[0.1], side=[1]),
        "LinearActuation": LinearActuation(pattern=np.eye(3)),
        "TendonActuation[servo]": TendonActuation(end=[0.1], side=[1], drive="displacement"),
        "LearnedActuation": LearnedActuation(n_inputs=2, terms=("u", "u*q"), strains="all"),
        "WithGains": WithGains(phys.library_, ["g_1", "g_2"], 0.0),
        "MarkerPoseExtractor": MarkerPoseExtractor(camera=Camera(pixels_per_metre=1000.0, origin=(10.0, 5.0))),
        "Camera": Camera(pixels_per_metre=1000.0, origin=(10.0, 5.0), image_size=(640, 480)),
        "PlanarPCS": PlanarPCS((0.05, 0.05)),
        "PoseTrajectory": poses[0],
        "StrainTrajectory": X[0],
        "Pipeline": Pipeline([("segments", KinematicFusion())]),
        "PCSPipeline": make_pcs_pipeline(),
        "FiniteDifference": FiniteDifference(order=2),
    }
    out.update(_spatial_specimens())
    return out


def _spatial_specimens() -> dict:
    """The spatial classes: a regressor fitted on exact inverse dynamics (bending of one segment), its parts."""
    from pcs_sindy.core.spatial import SpatialPCS, SpatialStrainTrajectory
    from pcs_sindy.identification.library.spatial_physical import SpatialPhysicalPCSLibrary
    from pcs_sindy.models import SpatialTendonActuation
    from pcs_sindy.models.spatial_forward import SpatialPCSModel

    active = [True, True, False, False, False, False]
    lib = SpatialPhysicalPCSLibrary([0.1], active_strains=active, rest_strain=False, n_quadrature=4)
    lib.fit(np.zeros((1, 4)))
    coef = lib.coefficients_from_parameters(1070.0, 0.02, 1e4, 1e3, [3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15])
    t = np.arange(0.0, 0.5, 0.01)
    w = 2 * np.pi * np.array([1.0, 1.7])
    q, qd, qdd = np.sin(w * t[:, None]), w * np.cos(w * t[:, None]), -(w**2) * np.sin(w * t[:, None])
    kin = SpatialPCS((0.1,), active, (0.0, 0.1, 0.0), np.eye(3)[[1, 0, 2]] * [[1], [-1], [1]])
    tr = SpatialStrainTrajectory(
        kin.to_full(q), t, segment_lengths=[0.1], active_strains=active, base_position=(0.0, 0.1, 0.0)
    )
    tau = kin.to_full(lib.euler_lagrange_matrix(q, qd, qdd) @ coef)
    reg = EulerLagrangeRegressor(formulation="strong", feature_library=SpatialPhysicalPCSLibrary(n_quadrature=4))
    reg.fit([tr], [tau], qd=[kin.to_full(qd)], qdd=[kin.to_full(qdd)])
    return {
        "EulerLagrangeRegressor[spatial]": reg,
        "SpatialPhysicalPCSLibrary": reg.library_,
        "SpatialPCS": kin,
        "SpatialStrainTrajectory": tr,
        "SpatialPCSModel": SpatialPCSModel(kin, **lib.lumped_from_coef(coef)),
        "SpatialTendonActuation": SpatialTendonActuation(end=[0.1, 0.05], angle=[0.0, 2.0]).fit(kin),
        "SpatialTendonActuation[servo]": SpatialTendonActuation(
            end=[0.1, 0.1, 0.05], angle=[0.0, 3.0, 1.5], drive="displacement", motor=[0, 0, 1], winding=[1, -1, 1]
        ).fit(kin),
    }


def _leaves(node, path=()):
    """(path, value) of every JSON scalar under ``node``."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(node, list):
        for k, v in enumerate(node):
            yield from _leaves(v, (*path, k))
    else:
        yield path, node


def _set(doc, path, value):
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


def _variants(value):
    if isinstance(value, bool):
        return [not value, 0]
    if isinstance(value, int):
        return [0, -1, value + 1, 10**9, -(10**12)]
    if isinstance(value, float):
        return [0.0, -value, value * 1e6 + 1.0, 1e300]
    if isinstance(value, str):
        return ["", "/dev/zero", value + "x"]
    return [0, "/dev/zero"]


def _array_variants(arr: np.ndarray):
    if arr.size == 0:
        return [np.zeros((1,), dtype=arr.dtype)]
    flat = arr.reshape(-1)
    changed = flat.copy()
    if arr.dtype.kind == "b":
        changed[0] = ~changed[0]
    elif arr.dtype.kind in "iuf":
        changed[0] = changed[0] + 1
    else:
        return [flat[:-1]]
    return [changed.reshape(arr.shape), flat[:-1]]


def _mutants(path: pathlib.Path):
    doc = json.loads(path.read_text())
    arrays = _arrays(path)
    for leaf, value in _leaves(doc["object"]):
        for new in _variants(value):
            yield f"object{list(leaf)} = {new!r}", leaf, new, None
    for key, arr in arrays.items():
        for k, new in enumerate(_array_variants(arr)):
            yield f"array {key} variant {k}", None, None, (key, new)


def _fuzz(specimens, tmp_path, per_file: int | None, seed: int = 0) -> dict[str, int]:
    rng = random.Random(seed)
    counts = {}
    for label, obj in specimens.items():
        path = save(obj, tmp_path / "orig")
        original_doc, original_arrays = json.loads(path.read_text()), _arrays(path)
        mutants = list(_mutants(path))
        if per_file is not None and len(mutants) > per_file:
            mutants = rng.sample(mutants, per_file)
        counts[label] = len(mutants)
        for what, leaf, new, arr in mutants:
            doc = json.loads(json.dumps(original_doc))
            arrays = dict(original_arrays)
            if leaf is not None:
                _set(doc["object"], leaf, new)
            else:
                arrays[arr[0]] = arr[1]
            target = tmp_path / "mutant.json"
            _write(target, doc, arrays)
            start = time.perf_counter()
            try:
                with within():
                    loaded = load(target)
                    if isinstance(loaded, EulerLagrangeRegressor):  # a loaded model is used within bounds too
                        loaded.mass_matrix(np.full(loaded.n_features_in_, 0.1))
            except (ValueError, OSError):
                pass
            except Exception as err:  # noqa: BLE001 - anything else is the finding
                pytest.fail(f"{label}: mutation {what}: {type(err).__name__}: {err}")
            took = time.perf_counter() - start
            assert took < BUDGET, f"{label}: mutation {what} took {took:.1f} s"
    return counts


def test_specimens_cover_the_registry(specimens):
    assert {label.split("[")[0] for label in specimens} == set(REGISTRY)


def test_fuzz_single_value_mutations(specimens, tmp_path):
    """A sample of the single-value mutations of every class (the full sweep is the slow test)."""
    counts = _fuzz(specimens, tmp_path, per_file=30)
    assert len(counts) == len(specimens) and all(counts.values())


@pytest.mark.slow
def test_fuzz_every_single_value_mutation(specimens, tmp_path):
    _fuzz(specimens, tmp_path, per_file=None)
