"""Atomic outputs: the crash guarantee of a file set, measured, and what atomic writing costs.

1. Crash guarantee: a three-file set (npz, json, png stand-ins) replaces an old set in a
   forked child killed (``os._exit``) right after its k-th rename, k = 1..4 (the journal,
   then the three files), ``--repeats`` times each; the folder is classified as the old set,
   the new set or a mix, before and after :func:`pcs_sindy.core.atomic.recover` (which every
   reader of the package runs first).
2. Cost: writing a pose file (5000 frames, 21 markers) and a fitted model with plain
   ``np.savez`` / ``Path.write_bytes`` against :mod:`pcs_sindy.core.atomic` (temporary,
   fsync, rename, directory fsync); median of ``--repeats`` writes.

Run: ``python benchmarks/atomic_writes.py [--repeats 20] [--no-write]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pcs_sindy.core import atomic

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_section  # noqa: E402

OLD = {"a.npz": b"old a", "b.json": b"old b", "c.png": b"old c"}
NEW = {"a.npz": b"new a" * 100, "b.json": b"new b" * 100, "c.png": b"new c" * 100}


def _crash_after(folder: Path, k: int) -> None:
    pid = os.fork()
    if pid == 0:
        try:
            real, seen = os.replace, [0]

            def replace(src, dst):
                real(src, dst)
                seen[0] += 1
                if seen[0] == k:
                    os._exit(0)

            os.replace = replace
            with atomic.FileSet(folder) as fs:
                for name, data in NEW.items():
                    fs.write_bytes(folder / name, data)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)


def _classify(folder: Path) -> str:
    got = {name: (folder / name).read_bytes() for name in OLD}
    return "old" if got == OLD else "new" if got == NEW else "mix"


def crash_table(repeats: int) -> str:
    rows = []
    for k in range(1, 5):
        before = {"old": 0, "new": 0, "mix": 0}
        after = dict(before)
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as d:
                folder = Path(d)
                for name, data in OLD.items():
                    (folder / name).write_bytes(data)
                _crash_after(folder, k)
                before[_classify(folder)] += 1
                atomic.recover(folder)
                after[_classify(folder)] += 1
        rows.append(
            f"| {k} | {before['old']} / {before['new']} / {before['mix']} | {after['old']} / {after['new']} / "
            f"{after['mix']} |"
        )
    head = "| killed after rename k | on disk: old / new / mix | after recover(): old / new / mix |\n|---|---|---|"
    return head + "\n" + "\n".join(rows)


def _median_ms(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def cost_table(repeats: int) -> str:
    from pcs_sindy.core import StrainTrajectory
    from pcs_sindy.identification import EulerLagrangeRegressor
    from pcs_sindy.io import model_files
    from pcs_sindy.simulation import get_scenario

    sc = get_scenario("one_segment")
    recs = sc.generate(seed=0).train[:2]
    X = [StrainTrajectory(r.q[:400], r.t[:400], segment_lengths=sc.robot.kinematics.segment_lengths) for r in recs]
    model = EulerLagrangeRegressor().fit(X, [r.tau[:400] for r in recs])
    t, poses = np.arange(5000) * 1e-3, np.random.default_rng(0).normal(size=(5000, 21, 3))
    rows = []
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        plain = _median_ms(lambda: np.savez(folder / "p.npz", t=t, poses=poses), repeats)
        safe = _median_ms(lambda: atomic.savez(folder / "q.npz", t=t, poses=poses), repeats)
        size = (folder / "q.npz").stat().st_size
        rows.append(f"| pose file, 5000 x 21 markers ({size / 1e6:.1f} MB) | {plain:.2f} | {safe:.2f} |")

        def save_model():
            model_files.save(model, folder / "m")

        json_bytes = (model_files.save(model, folder / "m")).read_bytes()
        npz_bytes = (folder / "m.npz").read_bytes()

        def plain_pair():
            (folder / "x.npz").write_bytes(npz_bytes)
            (folder / "x.json").write_bytes(json_bytes)

        def safe_pair():
            with atomic.FileSet(folder) as fs:
                fs.write_bytes(folder / "y.npz", npz_bytes)
                fs.write_bytes(folder / "y.json", json_bytes)

        kb = (len(json_bytes) + len(npz_bytes)) / 1e3
        rows.append(
            f"| model JSON + npz pair ({kb:.0f} kB) | {_median_ms(plain_pair, repeats):.2f} | "
            f"{_median_ms(safe_pair, repeats):.2f} |"
        )
        rows.append(f"| `io.save(model)` incl. encoding (atomic pair) | - | {_median_ms(save_model, repeats):.2f} |")
    head = "| write | plain (ms) | atomic (ms) |\n|---|---|---|"
    return head + "\n" + "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/results.md alone")
    args = parser.parse_args()
    crash, cost = crash_table(args.repeats), cost_table(args.repeats)
    body = (
        "A three-file set replacing an old one, its writer killed after its k-th rename (1: the journal, "
        f"2-4: the files), {args.repeats} times each:\n\n{crash}\n\n"
        "Killed before the journal's rename (a failure or crash while the temporaries are written), the old set "
        "stays (tests/test_atomic.py, tests/test_disk_full.py).  After the journal's rename, the disk may hold a "
        "mix until the next reader or writer of the folder runs `recover()`, which completes the new set; "
        "the package's readers of model and data files (`io.load`, `io.read_*`) run it first, so they never read a "
        "mix.\n\n"
        f"What atomic writing costs (median of {args.repeats}; fsync of the file and the folder dominates):\n\n"
        f"{cost}\n"
    )
    print(body)
    if not args.no_write:
        write_section(
            "atomic_writes",
            "Atomic outputs: crash guarantee and cost",
            body,
            f"python benchmarks/atomic_writes.py --repeats {args.repeats}",
        )


if __name__ == "__main__":
    main()
