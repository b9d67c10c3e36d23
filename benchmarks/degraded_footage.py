"""Marker extraction on degraded footage it was not tuned to, with default settings.

1. **Degraded footage**: the two_segment robot's first training recordings
   (seed 0, noise-free poses at 1 kHz) rendered at ~2400 px/m (960x720,
   markers 8 x 2 mm = 19 x 4.8 px, the robot's body drawn) to MJPG .avi with
   their camera JSON, under each nuisance of ``Nuisances.random(seed)`` alone
   and all combined; one nuisance draw per recording (seeds 0..R-1), so
   magnitudes, clutter layout, gradient direction and the hidden marker
   differ between recordings.
2. **Outlined markers on a floor**: a one-segment robot (one_segment, 0.1 m)
   with blue outlined markers on a grey floor the robot curls into (the
   floor's top is where the robot's lowest marker is in 60 % of the frames),
   uneven light and sensor noise, 1500x1180 colour JPEG frames in a folder
   (every third frame of three recordings at 1 kHz).

Extraction: ``MarkerPoseExtractor(on_missing="interpolate")`` (defaults
otherwise; "interpolate" so that failing frames are counted rather than
stopping the run), camera from the JSON, 1 core for OpenCV.  A frame is
*complete* when every marker was detected, *extracted* when the extractor
returned it without interpolating it in time (markers filled from their
neighbours count here).  A marker the chain lacks but a partly hidden or
motion-blurred component shows at its predicted pose counts as detected; the
table lists how many (``diagnostics_["markers_partial"]``).  Errors against the rendered truth over extracted
frames and all markers.

Run: ``.venv/bin/python benchmarks/degraded_footage.py [--frames 300] [--recordings 4]``
"""

from __future__ import annotations

import argparse
import dataclasses
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

NUISANCE_SETS = {
    "none": (),
    "lighting gradient + vignetting": ("lighting_gradient", "gradient_angle", "vignetting"),
    "sensor noise": ("noise",),
    "motion blur": ("motion_blur",),
    "JPEG compression": ("jpeg_quality",),
    "clutter and printed text": ("clutter",),
    "floor": ("floor", "floor_level"),
    "one marker partly hidden": ("occlusion",),
    "all combined": "all",
}


def nuisances(seed: int, n_frames: int, n_markers: int, fields) -> Nuisances | None:
    full = Nuisances.random(seed, n_frames, n_markers)
    if fields == "all":
        return full
    if not fields:
        return None
    return dataclasses.replace(Nuisances(seed=seed), **{f: getattr(full, f) for f in fields})


def measure(paths: list[str], truths: list[np.ndarray], ppm: float, hidden: list[set] | None = None) -> dict:
    ex = MarkerPoseExtractor(on_missing="interpolate", progress=False)
    start = time.perf_counter()
    trajs = ex.transform(paths)
    elapsed = time.perf_counter() - start
    total = complete = extracted = filled = occluded = partial = 0
    pos, ang, chosen = [], [], []
    for r, (tr, truth, diag) in enumerate(zip(trajs, truths, ex.diagnostics_, strict=True)):
        T = truth.shape[0]
        ok = np.setdiff1d(np.arange(T), diag["frames_repaired"])
        total += T
        extracted += ok.size
        complete += diag["frames_complete"]
        filled += sum(len(v) for v in diag["markers_filled"].values())
        partial += sum(len(v) for v in diag["markers_partial"].values())
        if hidden is not None:  # incomplete frames where the occluder hid a marker on purpose
            occluded += len(hidden[r] & set(diag["markers_filled"]))
        pos.append(np.linalg.norm(tr.poses[ok, :, :2] - truth[ok, :, :2], axis=-1).ravel())
        ang.append(np.abs(tr.poses[ok, :, 2] - truth[ok, :, 2]).ravel())
        chosen.append(diag["binarisation"]["chosen"].split(" ")[0])
    pos, ang = np.concatenate(pos), np.degrees(np.concatenate(ang))
    return dict(
        total=total,
        complete=complete,
        extracted=extracted,
        filled=filled,
        occluded=occluded,
        partial=partial,
        pos_rms=1e3 * float(np.sqrt(np.mean(pos**2))),
        pos_max=1e3 * float(pos.max()),
        ang_rms=float(np.sqrt(np.mean(ang**2))),
        ang_max=float(ang.max()),
        px_rms=ppm * float(np.sqrt(np.mean(pos**2))),
        fps=total / elapsed,
        chosen=", ".join(f"{c} x{chosen.count(c)}" for c in sorted(set(chosen))),
    )


def row(label: str, m: dict) -> str:
    return (
        f"| {label} | {m['total']} | {100 * m['complete'] / m['total']:.1f} "
        f"| {100 * m['extracted'] / m['total']:.1f} | "
        f"{m['filled']} ({m['occluded']}) | {m['partial']} | {m['pos_rms']:.4f} / "
        f"{m['pos_max']:.3f} | {m['px_rms']:.3f} | {m['ang_rms']:.3f} / "
        f"{m['ang_max']:.2f} | {m['chosen']} | {m['fps']:.0f} |"
    )


def degraded(tmp: Path, n_frames: int, n_rec: int) -> tuple[list[str], dict]:
    data = get_scenario("two_segment").generate(seed=0, validation=False)
    truths = [r.poses_true[:n_frames] for r in data.train[:n_rec]]
    cam = Camera.fit_robot(0.17, (960, 720))
    rows, results = [], {}
    for label, fields in NUISANCE_SETS.items():
        paths, hidden = [], []
        for k, truth in enumerate(truths):
            nz = nuisances(k, truth.shape[0], truth.shape[1] - 1, fields)
            out = render_video(truth, tmp / f"{label[:8].replace(' ', '_')}_{k}.avi", cam, fps=1000.0, nuisances=nz)
            paths.append(str(out.video))
            occ = None if nz is None else nz.occlusion
            hidden.append(set() if occ is None else set(range(occ[1], occ[1] + occ[2])))
        m = measure(paths, truths, cam.pixels_per_metre, hidden)
        results[label] = m
        rows.append(row(label, m))
        print(rows[-1], flush=True)
    return rows, dict(results=results, ppm=cam.pixels_per_metre)


def outlined_on_floor(tmp: Path, n_frames: int) -> tuple[str, dict]:
    data = get_scenario("one_segment").generate(seed=0, validation=False)
    # every third frame of three recordings: more of the robot's bending range in fewer frames
    truth = np.concatenate([r.poses_true[::3][: n_frames // 3] for r in data.train[:3]])
    cam = Camera.fit_robot(0.1, (1500, 1180))
    lowest = cam.to_pixels(truth[..., :2])[..., 1].max(axis=1)
    level = float(np.percentile(lowest, 40)) / cam.image_size[1]  # the robot reaches the floor in 60 % of the frames
    nz = Nuisances(
        lighting_gradient=0.4, gradient_angle=0.3, vignetting=0.25, noise=3.0, floor=150.0, floor_level=level, seed=3
    )
    folder = tmp / "outlined_floor"
    folder.mkdir()
    for start in range(0, truth.shape[0], 100):
        frames = render_frames(
            truth[start : start + 100],
            cam,
            marker_style="outline",
            colour=True,
            marker_colour=(190, 90, 30),
            body_colour=(215, 215, 225),
            nuisances=nz,
            first_frame=start,
        )
        for j, f in enumerate(frames):
            cv2.imwrite(str(folder / f"frame_{start + j:05d}.jpg"), f, [cv2.IMWRITE_JPEG_QUALITY, 90])
    cam.to_json(camera_json_path(folder), extra={"fps": 1000.0})
    m = measure([str(folder)], [truth], cam.pixels_per_metre)
    touching = float(np.mean(lowest >= level * cam.image_size[1]))
    return row(f"outlined blue markers, floor touched in {100 * touching:.0f} % of frames", m), m


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=500, help="frames per recording (500: the whole 0.5 s)")
    parser.add_argument("--recordings", type=int, default=4, help="recordings (and nuisance draws) per set")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    header = (
        "| footage | frames | complete [%] | extracted [%] | markers filled (of them hidden by the occluder) | "
        "markers measured from a partial or faint component | "
        "position error rms / max [mm] | "
        "rms [px] | angle error rms / max [deg] | binarisation "
        "chosen | fps |\n|---|---|---|---|---|---|---|---|---|---|---|"
    )
    with tempfile.TemporaryDirectory() as tmp:
        rows, info = degraded(Path(tmp), args.frames, args.recordings)
        floor_row, _ = outlined_on_floor(Path(tmp), 2 * args.frames)
        print(floor_row, flush=True)
    allc = info["results"]["all combined"]
    verdict = (
        f"Targets (issue 13), all nuisances combined: complete frames {100 * allc['complete'] / allc['total']:.1f} % "
        f"(target >= 99 %; {allc['occluded']} of the {allc['total'] - allc['complete']} incomplete frames have the "
        f"occluder's hidden marker; extracted {100 * allc['extracted'] / allc['total']:.1f} %), position error "
        f"{allc['pos_rms']:.4f} mm rms at {info['ppm']:.0f} px/m "
        f"(target <= 0.1 mm), angle {allc['ang_rms']:.3f} deg rms "
        "(target <= 1 deg)."
    )
    body = "\n".join(
        [
            __doc__.split("Run:")[0].split("\n\n", 1)[1].strip(),
            "",
            f"### Degraded two_segment footage ({args.recordings} recordings x {args.frames} frames per row, "
            f"{info['ppm']:.0f} px/m)",
            "",
            header,
            *rows,
            "",
            "### Outlined markers on a floor (one_segment, 1500x1180 JPEG frames)",
            "",
            header,
            floor_row,
            "",
            verdict,
            "",
            "fps: frames per second of wall time for the whole set (decoding included, one process); the renderer's "
            "MJPG compresses every video, so 'none' is not lossless.",
        ]
    )
    path = write_section(
        "degraded_footage",
        "Extraction on degraded footage (default settings)",
        body,
        f".venv/bin/python benchmarks/degraded_footage.py --frames {args.frames} --recordings {args.recordings}",
    )
    print(verdict)
    print(f"written to {path}")


if __name__ == "__main__":
    main()
