"""Frames per second of MarkerPoseExtractor at 640x480 and 1920x1080.

Renders 4 recordings of a two-segment robot (20 markers) as MJPG .avi files
with their camera JSON, then times the extraction from the files (decoding
included) on one core (``n_jobs=1``, OpenCV limited to one thread) and with
``n_jobs=2`` (joblib processes, one recording each), plus the extraction from
in-memory frame arrays.  Also reports the accuracy against the rendered poses.

Run: ``.venv/bin/python benchmarks/extraction_speed.py [--frames 100]``
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pcs_sindy.camera import Camera  # noqa: E402
from pcs_sindy.kinematics import PlanarPCS, forward_kinematics  # noqa: E402
from pcs_sindy.simulation.rendering import render_frames, render_video  # noqa: E402
from pcs_sindy.vision import MarkerPoseExtractor  # noqa: E402

from _results import write_section  # noqa: E402

LENGTHS = (0.07, 0.1)
N_RECORDINGS = 4


def motion(n_frames: int, seed: int) -> np.ndarray:
    """Smooth random two-segment motion within ±40 1/m and ±0.1 strain."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n_frames)[:, None]
    amp = rng.uniform(-1, 1, (1, 6)) * np.array([40.0, 0.1, 0.1] * 2)
    freq = rng.uniform(0.5, 2.0, (1, 6))
    q = amp * np.sin(2 * np.pi * freq * t)
    return forward_kinematics(q, LENGTHS, PlanarPCS(LENGTHS).marker_arc_lengths(20))


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=100, help="frames per recording")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size in ((640, 480), (1920, 1080)):
            cam = Camera.fit_robot(sum(LENGTHS), size)
            truths = [motion(args.frames, seed) for seed in range(N_RECORDINGS)]
            paths = []
            for k, truth in enumerate(truths):
                out = render_video(truth, Path(tmp) / f"rec{size[0]}_{k}.avi", cam, fps=1000.0)
                paths.append(str(out.video))
            total = N_RECORDINGS * args.frames

            cv2.setNumThreads(1)
            one = MarkerPoseExtractor(progress=False)
            trajs, t_one = timed(lambda: one.transform(paths))
            arrays = [render_frames(truth, cam) for truth in truths]
            _, t_arr = timed(lambda: MarkerPoseExtractor(camera=cam, fps=1000.0, progress=False).transform(arrays))
            cv2.setNumThreads(0)
            two = MarkerPoseExtractor(progress=False, n_jobs=2)
            two.transform(paths[:2])  # start the worker processes outside the timing
            _, t_two = timed(lambda: two.transform(paths))

            pos = np.concatenate(
                [
                    np.linalg.norm(tr.poses[..., :2] - tt[..., :2], axis=-1).ravel()
                    for tr, tt in zip(trajs, truths, strict=True)
                ]
            )
            ang = np.concatenate(
                [np.abs(tr.poses[..., 2] - tt[..., 2]).ravel() for tr, tt in zip(trajs, truths, strict=True)]
            )
            repaired = sum(len(d["frames_repaired"]) for d in one.diagnostics_)
            rows.append(
                f"| {size[0]}x{size[1]} | {cam.pixels_per_metre:.0f} | {total / t_one:.1f} | {total / t_two:.1f} | "
                f"{total / t_arr:.1f} | {pos.max() * cam.pixels_per_metre:.3f} / "
                f"{np.sqrt(np.mean(pos**2)) * cam.pixels_per_metre:.3f} | "
                f"{np.degrees(ang.max()):.3f} / {np.degrees(np.sqrt(np.mean(ang**2))):.3f} | {repaired} |"
            )
            print(rows[-1], flush=True)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    body = (
        f"{N_RECORDINGS} recordings x {args.frames} frames of a two-segment robot (0.07 + 0.1 m, base + 20 markers, "
        "|kappa| <= 40 1/m), rendered by `render_video` to MJPG .avi with camera JSON "
        "(`Camera.fit_robot(0.17, size)`).\n"
        "fps = frames extracted per second of wall time; 'file' includes video decoding, "
        "'array' starts from frames in memory.\n\n"
        "| resolution | px/m | fps, file, 1 core | fps, file, n_jobs=2 | fps, array, 1 core | position error max / "
        "rms [px] | angle error max / rms [deg] | frames repaired |\n"
        "|---|---|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n\n"
        f"1-minute load average at the end: {load:.2f} (the 2 cores are shared with other jobs, "
        "so parallel speed-up varies)."
    )
    path = write_section(
        "extraction_speed",
        "Marker extraction speed",
        body,
        f".venv/bin/python benchmarks/extraction_speed.py --frames {args.frames}",
    )
    print(f"written to {path}")


if __name__ == "__main__":
    main()
