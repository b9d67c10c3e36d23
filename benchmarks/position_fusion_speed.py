"""Positions-only fusion on the real Trunk: time of fit + transform, the arc lengths it finds, the jumps it flags.

Issue 25's target: ``KinematicFusion().fit`` + ``transform`` of 10 000 frames x 3 markers in <= 5 s here.
Reads the two step-test files of the real-data folder (``_real_data.py``); the full recordings
(10 001 frames, 100 s at 100 Hz), positions read by ``pcs_sindy.io.read_marker_csv``.  Timed: reading
excluded, ``PoseTrajectory.from_positions`` (plane, frozen samples, jumps) + fit + transform at
defaults (arc lengths estimated), the median of ``--repeats`` runs.  Also: the estimated disk arc
lengths with their standard errors (truth: equally spaced disks, the base about one spacing above
disk 1), and the samples set missing as frozen and as jumps.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/position_fusion_speed.py [--repeats 3] [--write]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _real_data import TRUNK_STEP_FILES, read_trunk, real_data_dir  # noqa: E402

from pcs_sindy.core import PoseTrajectory  # noqa: E402
from pcs_sindy.fusion import KinematicFusion  # noqa: E402

from _results import write_section  # noqa: E402

TARGET_SECONDS = 5.0


def one_file(path: Path, repeats: int) -> dict:
    rec = read_trunk(path)
    P, dt = rec.positions, rec.dt
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        traj = PoseTrajectory.from_positions(P, dt=dt)
        fusion = KinematicFusion().fit(traj)
        fusion.transform(traj)
        times.append(time.perf_counter() - start)
    return {
        "name": path.name,
        "frames": P.shape[0],
        "markers": P.shape[1],
        "seconds": float(np.median(times)),
        "arcs": 1e3 * np.asarray(fusion.marker_arc_lengths_[1:]),
        "arcs_std": 1e3 * np.asarray(fusion.marker_arc_lengths_std_[1:]),  # the base (0) is exact
        "segments": fusion.n_segments_,
        "frozen": traj.metadata["frozen_samples"],
        "jumps": traj.metadata["jump_samples"],
    }


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--write", action="store_true", help="write the section of docs/results.md")
    args = ap.parse_args(argv)
    root = real_data_dir()
    if root is None:
        print("no real-data folder (set PCS_SINDY_REAL_DATA); nothing to do")
        return []
    rows = [one_file(root / "trunk" / name, args.repeats) for name in TRUNK_STEP_FILES]
    load = os.getloadavg()[0]
    lines = [
        f"Positions-only fusion at defaults (`from_positions` + `KinematicFusion().fit` + `transform`, arc lengths "
        f"estimated) of the full Trunk step files; median of {args.repeats} runs; load average {load:.1f} on "
        f"the 2 cores while measuring.  Target: 10 000 frames x 3 markers in <= {TARGET_SECONDS:g} s.",
        "",
        "| file | frames x markers | time [s] | disk arc lengths [mm] (± std) | segments | samples set missing: "
        "frozen / jumps |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        arcs = ", ".join(f"{a:.0f} ± {s:.0f}" for a, s in zip(r["arcs"], r["arcs_std"], strict=True))
        lines.append(
            f"| {r['name']} | {r['frames']} x {r['markers']} | {r['seconds']:.2f} | {arcs} | {r['segments']} | "
            f"{r['frozen']} / {r['jumps']} |"
        )
    body = "\n".join(lines) + "\n"
    print(body)
    if args.write:
        write_section(
            "position_fusion_speed",
            "Positions-only fusion on the real Trunk (issue 25)",
            body,
            "OMP_NUM_THREADS=1 .venv/bin/python benchmarks/position_fusion_speed.py --write",
        )
    return rows


if __name__ == "__main__":
    main()
