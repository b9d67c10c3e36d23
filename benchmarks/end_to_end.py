"""Three- and five-segment robots identified end to end, videos -> model (issue 6 item 4).

For each scenario (``three_segment``, ``five_segment``; ``generate(seed=0)``:
8 training recordings of 0.5 s at 1 kHz and the 7 s sinusoidal validation):

1. render the 8 training recordings (noise-free marker poses) as MJPG ``.avi``
   videos with their camera JSON (``render_video``, 640x480,
   ``Camera.fit_robot`` of the rest length);
2. ``MarkerPoseExtractor`` reads the files back (decoding included) -> poses;
3. ``KinematicFusion(threshold=0.2)`` with the robot's rest length given finds
   the segmentation and the strains (found lengths reported against the truth);
4. ``EulerLagrangeRegressor`` fits the model on the fused segmentation: with
   ``feature_library=PhysicalPCSLibrary(rest_strain=False)`` in the weak form
   (``formulation="weak"``, SG 15 for q̇) and in the strong form (SG 7/3,
   ``exclude_force_jumps=True``), and with the defaults ``EulerLagrangeRegressor()``
   (windows of 160 samples);
5. the model is rolled out from rest under the validation actuation and its
   tip pose compared with the simulator's noise-free truth (e_p^EE, e_θ^EE).

The same chain also runs from the simulated marker poses (no video), noise-free
and with the scenario's seed noise, and the regression alone from the
simulator's strains on the true segmentation (``exact``), for comparison.  If the fused segmentation
has the true number of segments but other lengths, the model is still fitted
and validated on it (that is what a user gets); with another number of segments
the actuation (one force per true strain) cannot be mapped and the row says so.

Videos, extracted poses and result rows are cached under
``$PCS_SINDY_CACHE/end_to_end`` (default ``~/.cache/pcs_sindy/end_to_end``),
so reruns skip rendering and extraction (their times are those of the first run).

Usage::

    nice -n 10 .venv/bin/python benchmarks/end_to_end.py [--cases three_segment five_segment]
        [--sources video poses noisy exact] [--configs weak strong] [--no-write]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _rollout import validate  # noqa: E402

from pcs_sindy.core import (  # noqa: E402
    Camera,  # noqa: E402
    PoseTrajectory,
    StrainTrajectory,
    distributed_errors,  # noqa: E402
)
from pcs_sindy.fusion import KinematicFusion  # noqa: E402
from pcs_sindy.identification import (
    EulerLagrangeRegressor,  # noqa: E402
    PhysicalPCSLibrary,  # noqa: E402
)
from pcs_sindy.simulation import get_scenario, render_video  # noqa: E402
from pcs_sindy.vision import MarkerPoseExtractor  # noqa: E402

from _results import write_section  # noqa: E402

CACHE = Path(os.environ.get("PCS_SINDY_CACHE") or Path.home() / ".cache" / "pcs_sindy") / "end_to_end"
ROWS = CACHE / "rows.json"
CASES = ["three_segment", "five_segment"]
SOURCES = {
    "video": "rendered videos → MarkerPoseExtractor",
    "poses": "simulated poses, noise-free",
    "noisy": "simulated poses, seed noise",
    "exact": "the simulator's strains on the true segmentation "
    "(no poses, no fusion; a reference for the regression alone)",
}
# "weak" and "strong": the physical library as before the refactor (no rest strains, rotary inertia identified);
# "default": EulerLagrangeRegressor() with no arguments
CONFIGS = {
    "weak": lambda: EulerLagrangeRegressor(
        feature_library=PhysicalPCSLibrary(rest_strain=False),
        formulation="weak",
        window_length=15,
        weak_window=40,
        weak_stride=20,
    ),
    "strong": lambda: EulerLagrangeRegressor(
        feature_library=PhysicalPCSLibrary(rest_strain=False),
        formulation="strong",
        window_length=7,
        exclude_force_jumps=True,
    ),
    "default": lambda: EulerLagrangeRegressor(),
}
SEED = 0
# extraction accuracy on rendered 640x480 frames (benchmarks/kinematic_fusion.py: about 2e-5 m and
# 6e-3 rad); only the ratio weights the least-squares shape fit
VIDEO_POSE_STD = (2.5e-5, 6e-3)


def _video_poses(scenario, data) -> tuple[list[np.ndarray], dict]:
    """Render (once) and extract (once) the training videos; cached poses and timings."""
    folder = CACHE / f"{scenario.name}-seed{SEED}"
    poses_file = folder / "extracted.npz"
    info_file = folder / "extraction.json"
    if poses_file.exists() and info_file.exists():
        with np.load(poses_file) as z:
            poses = [z[f"p{k}"] for k in range(len(data.train))]
        return poses, json.loads(info_file.read_text())
    folder.mkdir(parents=True, exist_ok=True)
    camera = Camera.fit_robot(float(scenario.robot.kinematics.total_length))
    paths = []
    t0 = time.perf_counter()
    for k, rec in enumerate(data.train):
        path = folder / f"train{k}.avi"
        render_video(rec.poses_true, path, camera, fps=1.0 / rec.dt)
        paths.append(str(path))
    render_time = time.perf_counter() - t0
    extractor = MarkerPoseExtractor(n_markers=scenario.n_markers, on_missing="interpolate", progress=False)
    t0, c0 = time.perf_counter(), time.process_time()
    trajs = extractor.transform(paths)
    extraction_time = time.perf_counter() - t0
    extraction_cpu = time.process_time() - c0
    poses = [tr.poses for tr in trajs]
    err = np.concatenate([p[:, 1:] - r.poses_true[:, 1:] for p, r in zip(poses, data.train, strict=True)])
    info = dict(
        render_time=render_time,
        extraction_time=extraction_time,
        extraction_cpu=extraction_cpu,
        loadavg=os.getloadavg()[0],
        n_frames=int(sum(p.shape[0] for p in poses)),
        pixels_per_metre=camera.pixels_per_metre,
        frames_repaired=int(sum(len(d["frames_repaired"]) for d in extractor.diagnostics_)),
        marker_e_p=float(np.linalg.norm(err[..., :2], axis=-1).mean()),
        marker_e_theta=float(np.abs(err[..., 2]).mean()),
        dt_ok=bool(all(np.allclose(tr.t, r.t, rtol=0, atol=1e-9) for tr, r in zip(trajs, data.train, strict=True))),
    )
    np.savez(poses_file, **{f"p{k}": p for k, p in enumerate(poses)})
    info_file.write_text(json.dumps(info))
    return poses, info


def run_source(name: str, source: str, configs: list[str]) -> list[dict]:
    scenario = get_scenario(name)
    noise = "seed" if source == "noisy" else None
    data = scenario.generate(seed=SEED, noise=noise, progress=True)
    kin = scenario.robot.kinematics
    total = float(kin.total_length)
    base = dict(case=name, source=source, true_lengths=list(map(float, kin.segment_lengths)))
    if source == "exact":
        return _fit_rows(
            scenario,
            data,
            configs,
            dict(
                base,
                found_lengths=base["true_lengths"],
                fusion_time=0.0,
                fusion_cpu=0.0,
                fusion_e_p_dist=None,
                fusion_e_theta_dist=None,
            ),
            [StrainTrajectory(r.q, r.t, segment_lengths=kin.segment_lengths) for r in data.train],
        )
    if source == "video":
        poses, info = _video_poses(scenario, data)
        pose_std = VIDEO_POSE_STD
        base.update(extraction=info)
    else:
        poses = [r.poses for r in data.train]
        pose_std = data.noise if max(data.noise) > 0 else (5e-4, float(np.deg2rad(1.0)))
    times = [r.t for r in data.train]

    t0, c0 = time.perf_counter(), time.process_time()
    fusion = KinematicFusion(threshold=0.2, total_length=total, pose_std=pose_std)
    trajs = [PoseTrajectory(p, t) for p, t in zip(poses, times, strict=True)]
    strains = fusion.fit(trajs).transform(trajs)
    base["fusion_time"] = time.perf_counter() - t0
    base["fusion_cpu"] = time.process_time() - c0
    base["found_lengths"] = [float(v) for v in fusion.segment_lengths_]
    recon = fusion.inverse_transform(strains)
    e_dist = distributed_errors(
        np.concatenate([r.poses[:, 1:] for r in recon]), np.concatenate([r.poses_true[:, 1:] for r in data.train])
    )
    base["fusion_e_p_dist"], base["fusion_e_theta_dist"] = e_dist
    return _fit_rows(scenario, data, configs, base, strains)


def _fit_rows(scenario, data, configs: list[str], base: dict, strains: list) -> list[dict]:
    """Fit every configuration on ``strains`` and validate it; one row each."""
    kin = scenario.robot.kinematics
    n_found = len(base["found_lengths"])
    rows = []
    for config in configs:
        row = dict(base, config=config)
        rows.append(row)
        if n_found != kin.n_segments:
            row["skipped"] = (
                f"fusion found {n_found} segments, the actuation acts on {kin.n_segments}: the forces cannot be mapped"
            )
            continue
        model = CONFIGS[config]()
        c0 = time.process_time()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model.fit(strains, [r.tau for r in data.train])
        row["fit_cpu"] = time.process_time() - c0
        n_psi = model.library_.n_coefficients_
        row.update(
            fit_time=model.fit_time_,
            removed=list(model.removed_strains_),
            n_coef=int(n_psi),
            k_true=scenario.robot.stiffness.tolist(),
            k_hat=[float(v) for v in model.stiffness_],
            not_pd=float(model.mass_matrix_not_pd_fraction_),
            warnings=[str(w.message)[:160] for w in caught],
        )
        row.update(validate(model, data.validation, float(np.sum(base["found_lengths"]))))
        row["loadavg"] = os.getloadavg()[0]
        print(json.dumps({k: v for k, v in row.items() if k not in ("k_true", "k_hat")}), flush=True)
    return rows


def _fmt(v, spec):
    return "–" if v is None else format(v, spec)


def _wc(row: dict, stage: str) -> str:
    """Wall time and, when recorded, CPU time of this process (all its threads) of one stage."""
    cpu = row.get(f"{stage}_cpu")
    return f"{row[f'{stage}_time']:.1f}" + ("" if cpu is None else f" ({cpu:.1f})")


def render(rows: list[dict]) -> str:
    lines = [
        "Training data: `generate(seed=0)` (8 × 0.5 s at 1 kHz, forces held 10 ms, 20 markers + base); validation: "
        'the 7 s sinusoidal recording, rolled out from rest (`simulate(..., method="dopri5", rtol=1e-6, atol=1e-9)`: '
        "the compiled adaptive Dormand–Prince 5(4)), tip pose vs. the noise-free truth. "
        "Sources: " + "; ".join(f"`{k}` = {v}" for k, v in SOURCES.items()) + ". "
        "Videos: 640×480 MJPG `.avi` + camera JSON (`render_video`, `Camera.fit_robot(L)`), read back by "
        "`MarkerPoseExtractor(camera='auto')`. Fusion: `KinematicFusion(threshold=0.2, total_length=L)` (rest length "
        "given; least-squares shapes with refined boundaries). Regression: "
        "`EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(rest_strain=False), ...)` (8 unknowns per segment, "
        "bounded least squares, seed stiffness bounds) with `weak` = `formulation='weak'` (bump windows of 40 "
        "samples, stride 20, SG 15 for q̇) or `strong` = `formulation='strong'`, SG 7/3 with "
        "`exclude_force_jumps=True`; `default` = `EulerLagrangeRegressor()` with no arguments (weak form over windows "
        "of 160 samples, stride 40, SG 7 for q̇, `PhysicalPCSLibrary()` with a constant force per strain).",
        "",
        "| case | source | config | found lengths [m] (true) | fusion e_p^dist [m] | e_p^EE [mm] | e_θ^EE [rad] | "
        "removed | fusion [s] wall (CPU) | fit [s] wall (CPU) | rollout [s] wall (CPU) | M not PD | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        found = "[" + ", ".join(f"{v:.4f}" for v in r["found_lengths"]) + "]"
        true = "(" + ", ".join(f"{v:g}" for v in r["true_lengths"]) + ")"
        if r.get("skipped"):
            lines.append(
                f"| {r['case']} | {r['source']} | {r['config']} | {found} {true} | "
                f"{_fmt(r['fusion_e_p_dist'], '.2e')} | not fitted | – | – | {_wc(r, 'fusion')} | – | – | – | – |"
            )
            continue
        e_p = "diverged" if r["diverged"] else _fmt(1e3 * r["e_p"], ".3g")
        rollout = "–" if r["diverged"] else _wc(r, "rollout")
        load = _fmt(r.get("loadavg"), ".1f")
        lines.append(
            f"| {r['case']} | {r['source']} | {r['config']} | {found} {true} | {_fmt(r['fusion_e_p_dist'], '.2e')} | "
            f"{e_p} | {_fmt(r['e_theta'], '.3g')} | {', '.join(r['removed']) or '–'} | {_wc(r, 'fusion')} | "
            f"{_wc(r, 'fit')} | {rollout} | {r['not_pd']:.1%} | {load} |"
        )
    videos = {r["case"]: r["extraction"] for r in rows if r.get("extraction")}
    if videos:
        lines += ["", "Videos (first run; later runs read the cached poses):", ""]
        lines += [
            "| case | frames | px/m | render [s] | extraction [s] wall (CPU) | marker e_p [m] | marker e_θ [rad] | "
            "frames repaired | load |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for case, v in videos.items():
            lines.append(
                f"| {case} | {v['n_frames']} | {v['pixels_per_metre']:.0f} | {v['render_time']:.1f} | "
                f"{v['extraction_time']:.1f} ({_fmt(v.get('extraction_cpu'), '.1f')}) | {v['marker_e_p']:.2e} | "
                f"{v['marker_e_theta']:.2e} | {v['frames_repaired']} | {_fmt(v.get('loadavg'), '.1f')} |"
            )
    fitted = [r for r in rows if not r.get("skipped")]
    if fitted:
        lines += [
            "",
            "Identified vs. true stiffness, relative error per strain (be, sh, ax of each segment; ∞ = removed):",
            "",
        ]
        lines += ["| case | source | config | relative error of K |", "|---|---|---|---|"]
        for r in fitted:
            kt, kh = np.array(r["k_true"]), np.array(r["k_hat"])
            rel = np.where(np.isfinite(kh), kh / kt - 1, np.inf)
            lines.append(
                f"| {r['case']} | {r['source']} | {r['config']} | "
                + ", ".join(f"{v:+.1%}" if np.isfinite(v) else "∞" for v in rel)
                + " |"
            )
    notes = [r for r in rows if r.get("diverged") or r.get("warnings") or r.get("skipped")]
    if notes:
        lines += ["", "Warnings, divergences, skipped fits:", ""]
        for r in notes:
            for msg in [r.get("skipped"), r.get("diverged")] + r.get("warnings", []):
                if msg:
                    lines.append(f"- {r['case']} / {r['source']} / {r['config']}: {msg}")
    lines += [
        "",
        "Targets (issue 6): three_segment e_p^EE ≤ 5 mm; five segments fitted in under a minute on 2 cores (`fit` = "
        "`EulerLagrangeRegressor.fit` wall time; fusion is timed separately). Wall times on a 2-core machine shared "
        "with other jobs, run under `nice -n 10`: `load` is the 1-minute load average when the row was measured, and "
        "the CPU time of the benchmark's process (where recorded) is the better measure of the work.",
        "Rows are cached per (case, source, config) and may come from separate runs of subsets "
        "(`--cases`, `--sources`, `--configs`); `--cases` with no names re-renders the cached rows.",
    ]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=CASES, choices=CASES)
    parser.add_argument("--sources", nargs="*", default=list(SOURCES), choices=list(SOURCES))
    parser.add_argument("--configs", nargs="*", default=list(CONFIGS), choices=list(CONFIGS))
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    rows = json.loads(ROWS.read_text()) if ROWS.exists() else []
    for name in args.cases:
        for source in args.sources:
            print(f"== {name} / {source}", flush=True)
            try:
                new = run_source(name, source, args.configs)
            except Exception:  # a failing case is reported, not fatal for the others
                traceback.print_exc()
                continue
            keys = {(r["case"], r["source"], r["config"]) for r in new}
            rows = json.loads(ROWS.read_text()) if ROWS.exists() else rows
            rows = [r for r in rows if (r["case"], r["source"], r["config"]) not in keys] + new
            ROWS.parent.mkdir(parents=True, exist_ok=True)
            ROWS.write_text(json.dumps(rows))
    order_case = {c: k for k, c in enumerate(CASES)}
    order_src = {c: k for k, c in enumerate(SOURCES)}
    order_cfg = {c: k for k, c in enumerate(CONFIGS)}
    rows.sort(key=lambda r: (order_case[r["case"]], order_src[r["source"]], order_cfg[r["config"]]))
    body = render(rows)
    print(body)
    if not args.no_write and rows:
        write_section(
            "end_to_end",
            "End to end, videos → model: three and five segments",
            body,
            "nice -n 10 .venv/bin/python benchmarks/end_to_end.py "
            + " ".join(argv if argv is not None else sys.argv[1:]),
        )


if __name__ == "__main__":
    main()
