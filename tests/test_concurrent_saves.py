"""Saves from two processes to the same file set: one complete set or the other, never a mix (issue 27, item 4).

Truth: each process writes a pair of files carrying its own tag; after every round both files must
carry the same tag.
"""

from __future__ import annotations

import multiprocessing as mp
from pathlib import Path

from pcs_sindy.core.atomic import FileSet

ROUNDS = 60


def _writer(folder: str, tag: str, barrier, rounds: int) -> None:
    for k in range(rounds):
        barrier.wait()
        with FileSet(folder) as files:
            # the content is large enough that the two writes overlap in time
            files.write_text(Path(folder) / "model.json", f"{tag} {k}\n" + "x" * 200_000)
            files.write_bytes(Path(folder) / "model.npz", f"{tag} {k}\n".encode() + b"y" * 200_000)
        barrier.wait()  # the parent checks the pair between rounds
        barrier.wait()


def _tag(path: Path) -> str:
    return path.read_bytes().split(b"\n", 1)[0].decode()


def test_two_processes_saving_one_set_leave_one_complete_set(tmp_path):
    ctx = mp.get_context("fork")
    barrier = ctx.Barrier(3)
    procs = [ctx.Process(target=_writer, args=(str(tmp_path), tag, barrier, ROUNDS)) for tag in ("A", "B")]
    for p in procs:
        p.start()
    mixed = 0
    try:
        for _ in range(ROUNDS):
            barrier.wait()  # both start writing
            barrier.wait()  # both done
            mixed += _tag(tmp_path / "model.json") != _tag(tmp_path / "model.npz")
            barrier.wait()
    finally:
        for p in procs:
            p.join(timeout=60)
    assert all(p.exitcode == 0 for p in procs)
    assert mixed == 0, f"{mixed} of {ROUNDS} rounds left one process's JSON beside the other's npz"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json", "model.npz"]  # no journal or lock left
