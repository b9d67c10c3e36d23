"""Atomic outputs (pcs_sindy.core.atomic): old or new, never a mix, never a user's file deleted.

The crash test kills a forked child (``os._exit``, no clean-up runs) after every possible
number of renames of a three-file set, then reads the folder as the package's readers do
(after :func:`recover`): it must hold exactly the old set or exactly the new set.
"""

from __future__ import annotations

import json
import os
import resource
from pathlib import Path

import numpy as np
import pytest

from pcs_sindy.core import atomic
from pcs_sindy.io import data_files, load, save

OLD = {"a.npz": b"old a", "b.json": b"old b", "c.png": b"old c"}
NEW = {"a.npz": b"new a " * 10, "b.json": b"new b " * 10, "c.png": b"new c " * 10}


def _state(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and not p.name.startswith(".")}


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def _crash_after(folder: Path, n_renames: int) -> None:
    """Commit NEW over OLD in a child that dies right after its ``n_renames``-th ``os.replace``."""
    pid = os.fork()
    if pid == 0:
        try:
            real = os.replace
            count = {"n": 0}

            def replace(src, dst):
                real(src, dst)
                count["n"] += 1
                if count["n"] == n_renames:
                    os._exit(0)

            os.replace = replace
            with atomic.FileSet(folder) as fs:
                for name, data in NEW.items():
                    fs.write_bytes(folder / name, data)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)


@pytest.mark.parametrize("n_renames", range(0, 6))
def test_a_crash_at_any_rename_leaves_the_old_set_or_the_new_one(n_renames, tmp_path):
    for name, data in OLD.items():
        (tmp_path / name).write_bytes(data)
    _crash_after(tmp_path, n_renames)  # renames: journal, a, b, c (then the journal is removed)
    atomic.recover(tmp_path)
    got = _state(tmp_path)
    assert got in (OLD, NEW), got
    if n_renames >= 1:  # the journal was committed: the new set is rolled forward
        assert got == NEW
    assert not [h for h in _hidden(tmp_path) if h.startswith(".pcs_sindy-commit.")]


def test_a_failure_while_writing_leaves_the_old_files_and_no_temporaries(tmp_path):
    for name, data in OLD.items():
        (tmp_path / name).write_bytes(data)

    def boom(fh):
        fh.write(b"partial")
        raise RuntimeError("the producer failed")

    with pytest.raises(RuntimeError, match="producer failed"), atomic.FileSet(tmp_path) as fs:
        fs.write_bytes(tmp_path / "a.npz", NEW["a.npz"])
        fs.add(tmp_path / "b.json", boom)
    assert _state(tmp_path) == OLD and _hidden(tmp_path) == []


def test_a_full_disk_names_the_file_and_keeps_the_old_one(tmp_path):
    target = tmp_path / "poses.npz"
    data_files.write_poses(target, np.arange(3.0), np.zeros((3, 2, 3)))
    before = target.read_bytes()
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            resource.setrlimit(resource.RLIMIT_FSIZE, (1024, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
            try:
                data_files.write_poses(target, np.arange(1000.0), np.zeros((1000, 2, 3)))
            except OSError as err:
                code = 0 if (err.errno == 27 and str(target) in str(err)) else 3
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, "no OSError naming the file"
    assert target.read_bytes() == before and _hidden(tmp_path) == []


def test_output_dir_never_deletes_a_users_file(tmp_path):
    mine = tmp_path / ".write_test"
    mine.write_text("my notes")
    assert data_files.output_dir(tmp_path) == tmp_path
    assert mine.read_text() == "my notes"
    assert _hidden(tmp_path) == [".write_test"]


def test_temporaries_never_follow_a_planted_link(tmp_path):
    """Temporaries are created with O_EXCL under fresh random names: a link at a guessable name is never used."""
    victim = tmp_path / "victim"
    victim.write_text("keep")
    for k in range(5):
        os.symlink(victim, tmp_path / f".out.json.{os.getpid()}.{k}.tmp.json")
    atomic.write_text(tmp_path / "out.json", "{}")
    assert victim.read_text() == "keep" and (tmp_path / "out.json").read_text() == "{}"


def test_a_model_save_interrupted_after_its_commit_loads_as_the_new_model(tmp_path):
    from pcs_sindy.fusion import KinematicFusion

    path = save(KinematicFusion(threshold=0.01), tmp_path / "m")
    pid = os.fork()
    if pid == 0:
        try:
            real = os.replace
            seen = {"n": 0}

            def replace(src, dst):
                real(src, dst)
                seen["n"] += 1
                if seen["n"] == 2:  # the journal and the npz are in place, the JSON is not
                    os._exit(0)

            os.replace = replace
            save(KinematicFusion(threshold=0.02), tmp_path / "m")
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    assert json.loads(path.read_text())["object"]["params"]["threshold"] == 0.01  # a mix on disk ...
    assert load(path).threshold == 0.02  # ... that the reader completes to the new pair


def test_files_of_a_set_must_share_a_folder(tmp_path):
    (tmp_path / "sub").mkdir()
    with pytest.raises(ValueError, match="share one folder"), atomic.FileSet() as fs:
        fs.write_text(tmp_path / "a.txt", "a")
        fs.write_text(tmp_path / "sub" / "b.txt", "b")
    assert not (tmp_path / "a.txt").exists() and _hidden(tmp_path) == []
