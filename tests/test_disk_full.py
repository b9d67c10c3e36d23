"""A full disk (``RLIMIT_FSIZE``, what ``ulimit -f`` sets) never costs the user the previous outputs.

Each command first runs normally; then it runs again, with new inputs, in a forked child whose
file-size limit is too small for its outputs.  It must fail with the CLI's one-line error that
names the file it could not write, and leave the folder exactly as it was: the old files bit
for bit, no temporaries.
"""

from __future__ import annotations

import os
import resource
import sys
import time
from pathlib import Path

import pytest

from pcs_sindy.cli.main import main

LIMIT = 2048  # bytes: smaller than every output below, larger than nothing that must succeed


def _run_limited(argv: list[str], limit: int = LIMIT, timeout: float = 120.0) -> tuple[int, str]:
    """``main(argv)`` in a forked child with the file-size limit ``limit``; (exit code, stderr)."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # child
        code = 99
        try:
            os.close(read_end)
            os.dup2(write_end, 2)
            sys.stderr = os.fdopen(2, "w", buffering=1)
            _, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
            code = main(argv)
            sys.stderr.flush()
        finally:
            os._exit(code)
    os.close(write_end)
    deadline = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
            pytest.fail(f"{argv[0]} under a file-size limit did not finish in {timeout} s")
        time.sleep(0.05)
    with os.fdopen(read_end) as fh:
        err = fh.read()
    return os.waitstatus_to_exitcode(status), err


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _assert_refused_and_intact(argv: list[str], folder: Path, names_one_of: list[str]) -> None:
    before = _snapshot(folder)
    assert before, "the first run wrote nothing"
    code, err = _run_limited(argv)
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith(f"pcs-sindy {argv[0]}: error: "), err
    assert "File too large" in err and any(name in err for name in names_one_of), err
    after = _snapshot(folder)
    assert sorted(after) == sorted(before), f"left behind: {sorted(set(after) - set(before))}"
    for name, data in before.items():
        assert after[name] == data, f"{name} changed"


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """Two short recordings, their first outputs (poses, strains, model, rollout)."""
    root = tmp_path_factory.mktemp("diskfull")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PCS_SINDY_CACHE", str(root / "cache"))
        data = root / "data"
        sim = ["simulate", "one_segment", "--out", str(data), "--n-train", "2", "--train-duration", "0.1"]
        assert main([*sim, "--no-validation", "--quiet"]) == 0
        recs = [str(data / f"train_0{k}.npz") for k in range(2)]
        assert main(["fuse", recs[0], "--out", str(root / "strains"), "--total-length", "0.1", "--quiet"]) == 0
        strains = str(root / "strains" / "train_00.npz")
        assert main(["fit", strains, "--tau", recs[0], "--out", str(root / "model" / "model.json"), "--quiet"]) == 0
        model = str(root / "model" / "model.json")
        argv = ["rollout", model, "--tau", recs[0], "--truth", recs[0], "--out", str(root / "rollout"), "--quiet"]
        assert main(argv) == 0
        yield root, recs


def test_fuse_on_a_full_disk_keeps_the_old_segmentation_and_strains(work):
    root, recs = work
    # new inputs: the other recording under the same stem would replace train_00.npz and segmentation.json
    argv = ["fuse", recs[0], "--out", str(root / "strains"), "--total-length", "0.1", "--threshold", "0.5"]
    _assert_refused_and_intact([*argv, "--quiet"], root / "strains", ["train_00.npz", "segmentation"])


def test_fit_on_a_full_disk_keeps_the_old_model_loadable(work):
    from pcs_sindy.io import load

    root, recs = work
    strains = str(root / "strains" / "train_00.npz")
    argv = ["fit", strains, "--tau", recs[0], "--out", str(root / "model" / "model.json"), "--no-rest-strain"]
    _assert_refused_and_intact([*argv, "--quiet"], root / "model", ["model.npz", "model.json"])
    assert load(root / "model" / "model.json").library_.rest_strain is True  # the old model, still whole


def test_rollout_on_a_full_disk_keeps_the_old_rollout_and_metrics(work):
    root, recs = work
    model = str(root / "model" / "model.json")
    argv = ["rollout", model, "--tau", recs[1], "--truth", recs[1], "--out", str(root / "rollout"), "--quiet"]
    _assert_refused_and_intact(argv, root / "rollout", ["rollout.npz", "metrics.json", "rollout.png"])


def test_extract_on_a_full_disk_keeps_the_old_pose_file(work):
    root, recs = work
    videos = root / "videos"
    render = ["render", recs[0], "--out", str(videos), "--size", "320x240", "--marker-size", "0.010,0.0025"]
    assert main([*render, "--quiet"]) == 0
    poses = root / "poses"
    assert main(["extract", str(videos / "train_00.avi"), "--out", str(poses), "--quiet"]) == 0
    argv = ["extract", str(videos / "train_00.avi"), "--out", str(poses), "--robot-length", "0.1", "--quiet"]
    _assert_refused_and_intact(argv, poses, ["train_00.npz"])


def test_simulate_on_a_full_disk_keeps_the_old_recordings(work):
    root, _ = work
    argv = ["simulate", "one_segment", "--out", str(root / "data"), "--n-train", "2", "--train-duration", "0.05"]
    _assert_refused_and_intact([*argv, "--no-validation", "--quiet"], root / "data", ["train_00.npz"])
