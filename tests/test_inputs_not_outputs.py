"""Inputs are never outputs: a command refuses to write over a file it reads (issue 27, item 1).

Truth: the bytes of the input files before and after the command, compared directly.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pytest

from pcs_sindy.cli.main import main
from pcs_sindy.core import atomic


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Two 0.05 s one_segment recordings, fused strains, and a fitted model, made by the CLI."""
    root = tmp_path_factory.mktemp("inout")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PCS_SINDY_CACHE", str(root / "cache"))
        argv = ["simulate", "one_segment", "--out", str(root / "data"), "--n-train", "2"]
        assert main([*argv, "--train-duration", "0.1", "--no-validation", "--quiet"]) == 0
    recs = [root / "data" / f"train_0{k}.npz" for k in range(2)]
    assert main(["fuse", *map(str, recs), "--out", str(root / "strains"), "--total-length", "0.1", "--quiet"]) == 0
    strains = [root / "strains" / f"train_0{k}.npz" for k in range(2)]
    model = root / "model" / "model.json"
    argv = ["fit", *map(str, strains), "--tau", *map(str, recs), "--out", str(model), "--quiet"]
    assert main(argv) == 0
    return root, recs, strains, model


def _refused(capsys, argv, files):
    before = {f: _digest(f) for f in files}
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "refusing to write" in err and "reads" in err
    assert {f: _digest(f) for f in files} == before  # every input bit for bit


def test_fuse_into_the_folder_of_its_inputs_is_refused(data, capsys, tmp_path):
    root, recs, _, _ = data
    copies = [Path(shutil.copy(r, tmp_path / r.name)) for r in recs]
    _refused(capsys, ["fuse", *map(str, copies), "--out", str(tmp_path), "--total-length", "0.1", "--quiet"], copies)
    assert not (tmp_path / "segmentation.json").exists()  # nothing of the set was written


def test_fit_onto_a_strain_file_is_refused(data, capsys):
    root, recs, strains, _ = data
    argv = ["fit", *map(str, strains), "--tau", *map(str, recs), "--out", str(strains[0]), "--quiet"]
    _refused(capsys, argv, [*strains, *recs])


def test_rollout_onto_its_tau_file_is_refused(data, capsys, tmp_path):
    root, recs, strains, model = data
    ro = tmp_path / "ro"
    ro.mkdir()
    tau = Path(shutil.copy(recs[0], ro / "rollout.npz"))  # the file rollout would write
    argv = ["rollout", str(model), "--tau", str(tau), "--initial", str(strains[0]), "--out", str(ro), "--quiet"]
    _refused(capsys, argv, [tau])


def test_a_link_to_an_input_is_the_input(tmp_path):
    src = tmp_path / "in.npz"
    np.savez(src, a=np.arange(3))
    link = tmp_path / "sub" / "link.npz"
    link.parent.mkdir()
    link.symlink_to(src)
    before = _digest(src)
    with atomic.protecting([src]), pytest.raises(atomic.InputOverwriteError, match="link.npz"):
        atomic.savez(link, a=np.zeros(3))
    assert _digest(src) == before
    atomic.savez(link, a=np.zeros(3))  # outside the block the same write is allowed (replaces the link)
    assert not link.is_symlink()


def test_protection_ends_with_its_block_and_nests(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("a")
    b.write_text("b")
    with atomic.protecting([a]):
        with atomic.protecting([b, None, tmp_path / "missing.txt"]) as protected:
            assert len(protected) == 2
            for f in (a, b):
                with pytest.raises(atomic.InputOverwriteError):
                    atomic.write_text(f, "x")
        atomic.write_text(b, "new b")
        with pytest.raises(atomic.InputOverwriteError):
            atomic.write_text(a, "x")
    atomic.write_text(a, "new a")
    assert a.read_text() == "new a" and b.read_text() == "new b"
