"""Array files that claim more than they hold are refused before anything is allocated (issue 27, item 6).

Truth: archives built by hand from the .npy format (a header stating a shape, then the bytes).
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile

import numpy as np
import pytest

from pcs_sindy.io import DataFileError, load, read_arrays, read_poses, save
from pcs_sindy.io.npz_headers import check_npz_headers


def _npy(shape, dtype="<f8", data=b"") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buf.getvalue() + data


def _npz(path, members: dict[str, bytes]) -> None:
    with zipfile.ZipFile(path, "w") as zf:
        for name, payload in members.items():
            zf.writestr(name + ".npy", payload)


def test_a_header_claiming_1e13_elements_is_refused_without_allocating(tmp_path):
    path = tmp_path / "bomb.npz"
    _npz(path, {"poses": _npy((10**13, 2, 3)), "t": _npy((3,), data=np.zeros(3).tobytes())})
    assert path.stat().st_size < 1000
    with pytest.raises(DataFileError, match=r"'poses' claims shape \(10000000000000, 2, 3\)"):
        read_poses(path)


def test_a_header_claiming_more_than_its_bytes_is_refused(tmp_path):
    path = tmp_path / "short.npz"
    _npz(path, {"q": _npy((100, 3), data=np.zeros(10).tobytes())})
    with pytest.raises(DataFileError, match="holds 80 bytes"):
        read_arrays(path, ["q"], "strain file")


def test_honest_archives_pass_and_round_trip(tmp_path):
    path = tmp_path / "ok.npz"
    arrays = {"a": np.arange(12.0).reshape(4, 3), "b": np.array([1, 2], dtype=np.int32), "e": np.zeros((0, 3))}
    np.savez_compressed(path, **arrays)
    with np.load(path) as npz:
        check_npz_headers(npz, "x")
    got = read_arrays(path, list(arrays), "test file")
    for k, v in arrays.items():
        np.testing.assert_array_equal(got[k], v)


def test_a_model_files_array_with_a_lying_header_is_refused(tmp_path, monkeypatch):
    from pcs_sindy.fusion import KinematicFusion
    from pcs_sindy.simulation import get_scenario

    monkeypatch.setattr("pcs_sindy.io.model_files.INLINE_ARRAY_SIZE", 0)  # every array in the npz

    rec = get_scenario("one_segment").generate(seed=0, n_train=1, train_duration=0.02, validation=False).train[0]
    fusion = KinematicFusion(threshold=0.2, total_length=0.1).fit([rec.poses])
    json_path = tmp_path / "seg.json"
    save(fusion, json_path)
    npz_path = json_path.with_suffix(".npz")
    with zipfile.ZipFile(npz_path) as zf:
        members = {info.filename: zf.read(info) for info in zf.infolist()}
    name = next(iter(members))
    members[name] = _npy((10**12,))  # same name, a header claiming 8 TB
    with zipfile.ZipFile(npz_path, "w") as zf:
        for k, v in members.items():
            zf.writestr(k, v)
    doc = json.loads(json_path.read_text())
    doc["arrays"]["sha256"] = hashlib.sha256(npz_path.read_bytes()).hexdigest()  # a consistent, lying pair
    json_path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="claims shape"):
        load(json_path)
