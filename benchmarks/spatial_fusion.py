"""Spatial (3-D) fusion on the real recordings: marker RMS per file and per hold, and the time it takes.

Issue 26, item 3.  Reads the real-data folder (``_real_data.py``; skipped when absent):

* Trunk, every observation file, positions read by ``pcs_sindy.io.read_marker_csv`` (the zeros file
  also with the disks' orientations): ``KinematicFusion(space=...)`` fit + transform of the whole
  file, timed (reading excluded), then the RMS distance [mm] between the fused model's markers
  (``inverse_transform``, capture frame) and the measured ones, for the planar path (``"plane"``),
  the 3-D one (``"3d"``) and what ``"auto"`` picks; with the disks' arc lengths fitted, and given
  (0.105, 0.21, 0.315 m: equally spaced disks);
* tentacle, the 8 static holds together (markers ordered by ``read_tentacle``, the base marker
  recorded): ``KinematicFusion(space="3d")`` with the marker arc lengths fitted, per hold the
  per-marker RMS [mm], for markers on the backbone and 2 cm off it along the body's x axis, at the
  ``threshold="auto"`` segmentation and with one segment per marker spacing.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/spatial_fusion.py [--only trunk|tentacle]``
(about 3 minutes on one loaded core).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _real_data import (  # noqa: E402
    TRUNK_3D_FILE,
    TRUNK_REST_FILE,
    TRUNK_STEP_FILES,
    read_tentacle,
    real_data_dir,
)

from pcs_sindy.core import PoseTrajectory  # noqa: E402
from pcs_sindy.fusion import KinematicFusion, needs_3d  # noqa: E402
from pcs_sindy.io import read_marker_csv  # noqa: E402

ARCS = (0.105, 0.21, 0.315)


def _rms_mm(rec, tr) -> tuple[float, np.ndarray]:
    e = np.sum((rec.positions - tr.positions) ** 2, axis=2)
    return 1e3 * float(np.sqrt(np.nanmean(e))), 1e3 * np.sqrt(np.nanmean(e, axis=0))


def trunk_row(path: Path, space: str, arcs, orientations: bool = False) -> dict:
    d = read_marker_csv(path, ["1", "2", "3"], rate=100, units="m", orientations=orientations)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = PoseTrajectory.from_positions(d.positions, dt=d.dt, arc_lengths=arcs, rotations=d.rotations)
        fusion = KinematicFusion(space=space).fit(tr)
        (st,) = fusion.transform(tr)
    seconds = time.perf_counter() - start
    (rec,) = fusion.inverse_transform([st])
    rms, per = _rms_mm(rec, tr)
    return {
        "file": path.name + (" (+orientations)" if orientations else ""),
        "space": f"{fusion.space_} (auto: {'3d' if needs_3d([tr]) else 'plane'})",
        "arcs": "given" if arcs is not None else "fitted",
        "frames": tr.n_frames,
        "seconds": seconds,
        "rms": rms,
        "per_disk": per,
        "segments": fusion.n_segments_,
        "fitted_arcs": fusion.marker_arc_lengths_[1:],
        "rot": None if getattr(fusion, "rotation_rms_", None) is None else np.rad2deg(fusion.rotation_rms_),
    }


def run_trunk(root: Path) -> list[dict]:
    rows = []
    folder = root / "trunk"
    for name in (*TRUNK_STEP_FILES, TRUNK_3D_FILE, TRUNK_REST_FILE):
        path = folder / name
        if not path.is_file():
            continue
        for arcs in (None, ARCS):
            for space in ("plane", "3d"):
                rows.append(trunk_row(path, space, arcs))
                print(_trunk_line(rows[-1]), flush=True)
        if name == TRUNK_REST_FILE:
            rows.append(trunk_row(path, "3d", None, orientations=True))
            print(_trunk_line(rows[-1]), flush=True)
    return rows


def _trunk_line(r: dict) -> str:
    arcs = ", ".join(f"{v:.3f}" for v in r["fitted_arcs"])
    rot = "" if r["rot"] is None else f", orientation RMS {r['rot']:.2f} deg"
    per = ", ".join(f"{v:.2f}" for v in r["per_disk"])
    return (
        f"| {r['file']} | {r['space']} | {r['arcs']} [{arcs}] | {r['segments']} | {r['rms']:.2f} ({per}){rot} "
        f"| {r['seconds']:.1f} s / {r['frames']} frames |"
    )


def run_tentacle(root: Path) -> list[dict]:
    holds, _ = read_tentacle(root / "tentacle")
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trajs = [PoseTrajectory.from_positions(h.positions[::10], dt=h.dt * 10, base_marker=True) for h in holds]
    for label, kw in (
        ("on the backbone, auto", {}),
        ("on the backbone, 4 segments", {"n_segments": 4}),
        ("2 cm off (body x), auto", {"marker_offsets": [0.02] * 4}),
        ("2 cm off (body x), 4 segments", {"marker_offsets": [0.02] * 4, "n_segments": 4}),
    ):
        start = time.perf_counter()
        fusion = KinematicFusion(space="3d", **kw).fit(trajs)
        recs = fusion.inverse_transform(fusion.transform(trajs))
        seconds = time.perf_counter() - start
        per_hold = [_rms_mm(r, tr)[0] for r, tr in zip(recs, trajs, strict=True)]
        rows.append({"label": label, "per_hold": per_hold, "segments": fusion.n_segments_, "seconds": seconds})
        print(
            f"| {label} | {fusion.n_segments_} | "
            + " | ".join(f"{v:.1f}" for v in per_hold)
            + f" | **{np.mean(per_hold):.2f}** | {max(per_hold):.1f} | {seconds:.0f} s |",
            flush=True,
        )
    print("holds: " + ", ".join(h.name for h in holds))
    return rows


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=("trunk", "tentacle"))
    args = ap.parse_args(argv)
    root = real_data_dir()
    if root is None:
        print("no real-data folder: skipped")
        return {}
    out = {}
    if args.only != "tentacle":
        print("| file | space | arc lengths [m] | segments | marker RMS [mm] (per disk) | fit + transform |")
        print("|---|---|---|---|---|---|")
        out["trunk"] = run_trunk(root)
    if args.only != "trunk" and (root / "tentacle").is_dir():
        print("| markers | segments | per-hold per-marker RMS [mm] ... | mean | max | time |")
        out["tentacle"] = run_tentacle(root)
    return out


if __name__ == "__main__":
    main()
