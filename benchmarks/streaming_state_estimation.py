"""State estimation at camera rate: streaming extraction + single-frame fusion per 640x480 frame, on one core.

The fusion is fitted on the two_segment training recordings (seed 0, the
seed's pose noise, rest length 0.17 m given); the first seconds of the 7 s
validation recording (1 kHz) are rendered at 640x480 (markers 8 x 2 mm)
as frames in memory, clean and with every nuisance of
``Nuisances.random``.  Per frame, ``MarkerStream.update(frame)`` (tracking
from the previous frame, chaining from the base when needed) and
``KinematicFusion.transform_frame(poses, q_previous)`` (compiled
Levenberg-Marquardt strain fit, warm-started) are timed together with
``time.perf_counter`` (wall) and ``time.process_time`` (CPU of this
process: the work itself, without the waits of a shared, loaded machine),
OpenCV on one thread.  Each footage runs twice: with Python's garbage
collector as it is, and after ``gc.collect(); gc.freeze()`` at the end of the
set-up (what a control loop does: the objects of the set-up, numba's
compiled code and the package's imports, are never traversed again, so a
full collection, which then costs tens of milliseconds, cannot land in a
frame).  The camera frames the whole motion (the validation's tip curls
above the base).  Strain errors against the simulated truth; for reference
the batch path (``transform`` of the whole recording) on the same frames.
With ``on_missing="raise"`` (the stream's default) a frame that cannot be
extracted raises and the loop holds its last estimate; with
``on_missing="predict"`` the stream predicts up to ``max_predicted`` lost
markers per frame from the last two frames (constant velocity in the image),
at most 3 frames in a row, and the fusion runs on those poses.

Run: ``.venv/bin/python benchmarks/streaming_state_estimation.py [--seconds 2]``
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pcs_sindy.core import (
    Camera,  # noqa: E402
    PoseTrajectory,  # noqa: E402
)
from pcs_sindy.fusion import KinematicFusion  # noqa: E402
from pcs_sindy.simulation import get_scenario  # noqa: E402
from pcs_sindy.simulation.nuisances import Nuisances  # noqa: E402
from pcs_sindy.simulation.rendering import render_frames
from pcs_sindy.vision import MarkerPoseExtractor  # noqa: E402

from _results import write_section  # noqa: E402


def run(
    frames: np.ndarray,
    cam: Camera,
    fusion: KinematicFusion,
    q_true: np.ndarray,
    freeze: bool,
    on_missing: str,
    max_predicted: int = 2,
) -> tuple[str, np.ndarray]:
    stream = MarkerPoseExtractor(camera=cam, progress=False, on_missing=on_missing).stream(
        frames[0], max_predicted=max_predicted
    )
    q = fusion.transform_frame(stream.last)
    fusion.transform_frame(stream.last, q)  # compiled on first use: not timed
    full = []  # durations of full (generation 2) collections during the loop

    def watch(phase: str, info: dict) -> None:
        if info["generation"] == 2:
            full.append(time.perf_counter() if phase == "start" else time.perf_counter() - full.pop())

    if freeze:
        gc.collect()
        gc.freeze()
    gc.callbacks.append(watch)
    wall, cpu, qs, failed = [], [], [q], 0
    try:
        for frame in frames[1:]:
            start, start_cpu = time.perf_counter(), time.process_time()
            try:
                poses = stream.update(frame)
                q = fusion.transform_frame(poses, q)
            except ValueError:
                failed += 1  # a control loop would hold its last estimate
            wall.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
            qs.append(q)
    finally:
        gc.callbacks.remove(watch)
        gc.unfreeze()
    t, c = 1e3 * np.asarray(wall), 1e3 * np.asarray(cpu)
    err = np.abs(np.asarray(qs) - q_true)
    gcs = f"{len(full)}" + (f" ({1e3 * max(full):.0f} ms)" if full else "")
    pred = stream.diagnostics
    mode = f"predict (max_predicted={max_predicted})" if on_missing == "predict" else on_missing
    text = (
        f"{mode} | {'after gc.freeze()' if freeze else 'as it is'} | {len(frames)} | {np.median(t):.2f} | "
        f"{np.percentile(t, 99):.2f} | {t.max():.2f} | {np.percentile(c, 99):.2f} | {c.max():.2f} | {gcs} | "
        f"{failed} | {pred['frames_predicted']} ({pred['markers_predicted']}) | "
        f"{err[:, 0::3].max():.3f} / {err[:, 1::3].max():.4f} / {err[:, 2::3].max():.4f}"
    )
    return text, np.asarray(qs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=2.0, help="seconds of the validation recording (1 kHz)")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    data = get_scenario("two_segment").generate(seed=0, noise="seed")
    fusion = KinematicFusion(total_length=0.17).fit([PoseTrajectory(r.poses, t=r.t) for r in data.train])
    n = int(round(args.seconds * 1000))
    val = data.validation
    truth, q_true = val.poses_true[:n], val.q[:n]
    # a camera framing the whole motion (the validation curls the tip above the base, out of fit_robot's view)
    lo, hi = truth[..., :2].reshape(-1, 2).min(axis=0) - 0.01, truth[..., :2].reshape(-1, 2).max(axis=0) + 0.01
    ppm = float(min(640 / (hi[0] - lo[0]), 480 / (hi[1] - lo[1])))
    centre = 0.5 * (lo + hi)
    cam = Camera(ppm, (319.5 - ppm * centre[0], 239.5 - ppm * centre[1]), (640, 480))
    rows = []
    for label, nz in (("clean", None), ("every nuisance", Nuisances.random(5, n, 20))):
        frames = render_frames(truth, cam, nuisances=nz)
        batch = fusion.transform(
            MarkerPoseExtractor(camera=cam, fps=1000.0, progress=False, on_missing="interpolate").transform([frames])
        )[0].q
        berr = np.abs(batch - q_true)
        for on_missing, freeze, max_predicted in (
            ("raise", False, 2),
            ("raise", True, 2),
            ("predict", True, 2),
            ("predict", True, 3),
        ):
            text, _ = run(frames, cam, fusion, q_true, freeze, on_missing, max_predicted)
            rows.append(
                f"| {label} | {text} | {berr[:, 0::3].max():.3f} / {berr[:, 1::3].max():.4f} / "
                f"{berr[:, 2::3].max():.4f} |"
            )
            print(rows[-1], flush=True)
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    body = "\n".join(
        [
            __doc__.split("Run:")[0].split("\n\n", 1)[1].strip(),
            "",
            f"{fusion.n_segments_} segments, lengths "
            f"{', '.join(f'{1e3 * v:.1f}' for v in fusion.segment_lengths_)} mm; "
            f"camera {cam.pixels_per_metre:.0f} px/m.",
            "",
            "| footage | on_missing | garbage collector | frames | extraction + fusion per frame, wall, "
            "median [ms] | 99th percentile [ms] | max [ms] | CPU, 99th percentile [ms] | CPU, max [ms] | "
            "full collections in the loop (longest) | frames failed | frames predicted (markers) | "
            "strain error max, streaming (bending 1/m / shear / axial) | batch path, same frames |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
            "",
            "Target (issue 12, part 3): extraction + fusion <= 5 ms per 640x480 frame on 1 core.  "
            f"Load average at the end: {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} (shared 2-core machine: "
            "a wall time far above the CPU time of the same frame is time the process waited for a core).  "
            "Failed frames (the two tip markers blurred together or lost at 2.8 px thickness) try every "
            "candidate segmentation and so cost about twice a tracked frame; a predicted frame adds one more "
            "segmentation (the components matched to the prediction).  The frames that still fail with "
            "predict lose more markers than max_predicted (both tip markers and a third near them, blurred "
            "beyond matching) or follow such a frame (no two frames to predict from); the stream's default "
            "stays on_missing='raise', so a controller opts in to poses that are partly predicted.",
        ]
    )
    write_section(
        "streaming_state_estimation",
        "State estimation at camera rate (streaming)",
        body,
        f".venv/bin/python benchmarks/streaming_state_estimation.py --seconds {args.seconds:g}",
    )


if __name__ == "__main__":
    main()
