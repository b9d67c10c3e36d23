"""Frames per second of MarkerPoseExtractor on one core: 640x480 video, and large JPEG frames against decoding alone.

1. 640x480: 4 recordings of the two_segment robot (its first training
   recordings at 1 kHz, base + 20 markers) rendered by ``render_video`` to
   MJPG .avi with camera JSON; extraction from the files (decoding included)
   with ``n_jobs=1`` and OpenCV limited to one thread, from frame arrays in
   memory, with ``n_jobs=2`` (joblib processes), and from footage with every
   nuisance of ``Nuisances.random`` (uneven light, noise, motion blur, JPEG,
   clutter, a floor, a hidden marker).
2. 3000x2360 grey JPEG frames in a folder (the size of the issue's footage):
   extraction against the time to decode the same files to grey alone
   (``cv2.imread(..., IMREAD_GRAYSCALE)``), the limit for large frames.

Run: ``.venv/bin/python benchmarks/extraction_speed.py [--frames 300]``
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
from pcs_sindy.core import Camera  # noqa: E402
from pcs_sindy.core.camera import camera_json_path
from pcs_sindy.simulation import get_scenario  # noqa: E402
from pcs_sindy.simulation.nuisances import Nuisances  # noqa: E402
from pcs_sindy.simulation.rendering import render_frames, render_video
from pcs_sindy.vision import MarkerPoseExtractor  # noqa: E402

from _results import write_section  # noqa: E402

N_RECORDINGS = 4


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - start


def errors(trajs, truths, ppm: float) -> str:
    pos = np.concatenate(
        [np.linalg.norm(tr.poses[..., :2] - tt[..., :2], axis=-1).ravel() for tr, tt in zip(trajs, truths, strict=True)]
    )
    ang = np.concatenate([np.abs(tr.poses[..., 2] - tt[..., 2]).ravel() for tr, tt in zip(trajs, truths, strict=True)])
    return (
        f"{ppm * pos.max():.3f} / {ppm * np.sqrt(np.mean(pos**2)):.3f} | "
        f"{np.degrees(ang.max()):.3f} / {np.degrees(np.sqrt(np.mean(ang**2))):.3f}"
    )


def small(tmp: Path, n_frames: int) -> list[str]:
    data = get_scenario("two_segment").generate(seed=0, validation=False)
    truths = [r.poses_true[:n_frames] for r in data.train[:N_RECORDINGS]]
    cam = Camera.fit_robot(0.17, (640, 480))
    total = N_RECORDINGS * n_frames
    paths = [str(render_video(t, tmp / f"clean_{k}.avi", cam, fps=1000.0).video) for k, t in enumerate(truths)]
    degraded = [
        str(
            render_video(
                t, tmp / f"degraded_{k}.avi", cam, fps=1000.0, nuisances=Nuisances.random(k, n_frames, 20)
            ).video
        )
        for k, t in enumerate(truths)
    ]
    rows = []
    cv2.setNumThreads(1)
    one = MarkerPoseExtractor(progress=False)
    one.transform(paths[:1])  # imports and caches outside the timing
    trajs, t_one = timed(lambda: one.transform(paths))
    rows.append(
        f"| 640x480 MJPG file, 1 core | {total} | {total / t_one:.0f} | {errors(trajs, truths, cam.pixels_per_metre)} |"
    )
    arrays = [render_frames(t, cam) for t in truths]
    arr = MarkerPoseExtractor(camera=cam, fps=1000.0, progress=False)
    trajs, t_arr = timed(lambda: arr.transform(arrays))
    rows.append(
        f"| 640x480 frame arrays, 1 core | {total} | {total / t_arr:.0f} "
        f"| {errors(trajs, truths, cam.pixels_per_metre)} |"
    )
    deg = MarkerPoseExtractor(progress=False, on_missing="interpolate")
    trajs, t_deg = timed(lambda: deg.transform(degraded))
    rows.append(
        f"| 640x480 MJPG file, all nuisances, 1 core | {total} | {total / t_deg:.0f} | "
        f"{errors(trajs, truths, cam.pixels_per_metre)} |"
    )
    cv2.setNumThreads(0)
    two = MarkerPoseExtractor(progress=False, n_jobs=2)
    two.transform(paths[:2])  # start the worker processes outside the timing
    _, t_two = timed(lambda: two.transform(paths))
    rows.append(f"| 640x480 MJPG file, n_jobs=2 | {total} | {total / t_two:.0f} | |")
    return rows


def large(tmp: Path, n_frames: int) -> list[str]:
    data = get_scenario("two_segment").generate(seed=0, validation=False)
    truth = data.train[0].poses_true[:n_frames]
    cam = Camera.fit_robot(0.17, (3000, 2360))
    folder = tmp / "large"
    folder.mkdir()
    for start in range(0, n_frames, 20):
        for j, f in enumerate(
            render_frames(truth[start : start + 20], cam, nuisances=Nuisances(noise=2.0, seed=1), first_frame=start)
        ):
            cv2.imwrite(str(folder / f"frame_{start + j:05d}.jpg"), f, [cv2.IMWRITE_JPEG_QUALITY, 92])
    cam.to_json(camera_json_path(folder), extra={"fps": 1000.0})
    files = sorted(folder.glob("*.jpg"))
    cv2.setNumThreads(1)
    ex = MarkerPoseExtractor(progress=False)
    t_dec, t_ex = np.inf, np.inf
    for _ in range(2):  # alternate, best of two: the machine is shared
        t_dec = min(t_dec, timed(lambda: [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files])[1])
        trajs, t = timed(lambda: ex.transform([str(folder)]))
        t_ex = min(t_ex, t)
    return [
        f"| 3000x2360 JPEG files, decoding to grey only, 1 core | {n_frames} | {n_frames / t_dec:.1f} | |",
        f"| 3000x2360 JPEG files, extraction, 1 core | {n_frames} | {n_frames / t_ex:.1f} | "
        f"{errors(trajs, [truth], cam.pixels_per_metre)} |",
    ], t_ex / t_dec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=300, help="frames per 640x480 recording")
    parser.add_argument("--large-frames", type=int, default=100, help="3000x2360 frames")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rows = small(Path(tmp), args.frames)
        for r in rows:
            print(r, flush=True)
        big, ratio = large(Path(tmp), args.large_frames)
        for r in big:
            print(r, flush=True)
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    body = (
        __doc__.split("Run:")[0].split("\n\n", 1)[1].strip() + "\n\n"
        "| footage | frames | frames/s | position error max / rms [px] | angle error max / rms [deg] |\n"
        "|---|---|---|---|---|\n" + "\n".join(rows + big) + "\n\n"
        f"Large frames: extraction takes {ratio:.2f}x the time of decoding the JPEG files alone.  Target (issue 13): "
        ">= 300 frames/s at 640x480 on 1 core, and the JPEG-decode limit for large frames.  "
        f"Load average at the end: {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} (1/5/15 min; the 2 cores are shared "
        "with other jobs, so timings are upper bounds)."
    )
    path = write_section(
        "extraction_speed",
        "Marker extraction speed",
        body,
        f".venv/bin/python benchmarks/extraction_speed.py --frames {args.frames} --large-frames {args.large_frames}",
    )
    print(f"written to {path}")


if __name__ == "__main__":
    main()
