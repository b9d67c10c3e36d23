"""Model selection by cross-validation: which strains does GridSearchCV declare rigid? (issue 10)

For two_segment_stiff_axial_shear (segment 1 axial and segment 2 shear stiffness
x1000: ``ax_1`` and ``sh_2`` are the truly stiff strains) and
one_segment_stiff_shear (``sh_1`` x1000), seed 0, noise-free and with the
scenario's seed noise on the tracked poses:

1. strains from the poses, on the known segmentation (``estimate_strains`` of
   ``benchmarks/dynamic_identification.py``) and, for the two-segment robot,
   from the fused poses (``KinematicFusion(threshold=0.2)``, rest length given);
2. ``GridSearchCV(EulerLagrangeRegressor(),
   {"optimizer__threshold": THRESHOLDS}, cv=GroupKFold(4))`` over the 8 training
   recordings (groups = recordings, so every fold holds out 2 whole recordings),
   scored both by ``pcs_sindy.core.metrics.rollout_r2_scorer`` (the regressor's
   ``rollout_score``: R^2 of the tip path of rollouts of the held-out recordings)
   and by ``pcs_sindy.core.metrics.rollout_scorer`` (minus their mean tip error) —
   one search with both scorers, each choosing its best candidate as ``GridSearchCV(refit=...)`` would;
3. the chosen threshold refitted on all 8 recordings: the strains it removes
   and the tip error e_p^EE of its 7 s validation rollout from rest
   (``simulate(..., method="dopri5", rtol=1e-6, atol=1e-9)`` as in the other
   identification benchmarks) against the noise-free truth; the same for the default threshold 1.0.

``threshold`` is the factor on the material bound of each strain's stiffness
(seed bounds, r = 0.02 m: 12.6 N m², 168 N, 126 kN); a strain stiffer than
``threshold`` times its bound is removed as rigid.

Usage::

    .venv/bin/python benchmarks/model_selection.py [--cases ...] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, GroupKFold

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _rollout import validate  # noqa: E402
from dynamic_identification import estimate_strains  # noqa: E402

from pcs_sindy.core import (  # noqa: E402
    PoseTrajectory,
    StrainTrajectory,
    rollout_r2_scorer,  # noqa: E402
    rollout_scorer,  # noqa: E402
)
from pcs_sindy.fusion import KinematicFusion  # noqa: E402
from pcs_sindy.identification import EulerLagrangeRegressor  # noqa: E402
from pcs_sindy.simulation import get_scenario  # noqa: E402

from _results import write_section  # noqa: E402

THRESHOLDS = [1.0, 0.3, 0.1, 0.03, 0.01, 0.003]
N_FOLDS = 4
# the strains the scenarios stiffen x1000 (pcs_sindy/simulation/catalog.py)
TRUTH = {"two_segment_stiff_axial_shear": ["ax_1", "sh_2"], "one_segment_stiff_shear": ["sh_1"]}
# (scenario, strain source)
SEARCHES = [
    ("two_segment_stiff_axial_shear", "known"),
    ("two_segment_stiff_axial_shear", "fused"),
    ("one_segment_stiff_shear", "known"),
]
SOURCES = {"known": "poses → strains on the known segmentation", "fused": "poses → KinematicFusion"}


# "rollout_score": the R^2 of the tip path of the held-out rollouts (the regressor's score before issue 21)
SCORERS = {"rollout_score": rollout_r2_scorer, "rollout_scorer": rollout_scorer}


def strains(scenario, data, source: str, noise) -> tuple[list[StrainTrajectory], np.ndarray]:
    """Strain trajectories of the training recordings and the segment lengths they use."""
    kin = scenario.robot.kinematics
    if source == "known":
        L = np.asarray(kin.segment_lengths)
        X = [StrainTrajectory(estimate_strains(scenario, r, noise), r.t, segment_lengths=tuple(L)) for r in data.train]
        return X, L
    pose_std = noise if max(noise) > 0 else (5e-4, float(np.deg2rad(1.0)))
    fusion = KinematicFusion(threshold=0.2, total_length=float(kin.total_length), pose_std=pose_std)
    trajs = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    X = fusion.fit(trajs).transform(trajs)
    return X, np.asarray(fusion.segment_lengths_)


def run_search(name: str, source: str, noise_kind: str) -> dict:
    scenario = get_scenario(name)
    noise = tuple(scenario.seed_noise) if noise_kind == "seed" else (0.0, 0.0)
    data = scenario.generate(seed=0, noise=noise, progress=True)
    row = dict(case=name, source=source, noise=noise_kind, pose_noise=list(noise))
    X, lengths = strains(scenario, data, source, noise)
    row["lengths"] = [float(v) for v in lengths]
    if len(lengths) != scenario.robot.kinematics.n_segments:
        row["skipped"] = f"fusion found {len(lengths)} segments (true {scenario.robot.kinematics.n_segments})"
        return row
    y = [r.tau for r in data.train]
    base = EulerLagrangeRegressor()  # optimizer__threshold: the default StiffnessThresholdOptimizer's
    search = GridSearchCV(
        base,
        {"optimizer__threshold": THRESHOLDS},
        cv=GroupKFold(n_splits=N_FOLDS),
        scoring=SCORERS,
        refit=False,
        error_score="raise",
    )
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # identifiability notes of the small folds
        search.fit(X, y, groups=np.arange(len(X)))
    row["search_time"], row["search_cpu"] = time.perf_counter() - t0, time.process_time() - c0
    res = search.cv_results_
    row["mean_test"] = {m: [float(v) for v in res[f"mean_test_{m}"]] for m in SCORERS}
    # GridSearchCV's refit choice: the first candidate of rank 1
    row["chosen"] = {m: float(THRESHOLDS[int(np.argmin(res[f"rank_test_{m}"]))]) for m in SCORERS}
    refits = {}
    for thr in sorted(set(row["chosen"].values()) | {1.0}, reverse=True):
        model = clone(base).set_params(optimizer__threshold=thr)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            model.fit(X, y)
        check = validate(model, data.validation, float(np.sum(lengths)))
        refits[str(thr)] = dict(
            removed=list(model.removed_strains_),
            e_p=check["e_p"],
            diverged=check["diverged"],
            stiffness=[float(v) for v in model.stiffness_],
        )
    row["refits"] = refits
    row["loadavg"] = os.getloadavg()[0]
    print({k: v for k, v in row.items() if k != "refits"}, refits, flush=True)
    return row


def _mm(v) -> str:
    return "diverged" if v is None else f"{1e3 * v:.3g}"


def render(rows: list[dict]) -> str:
    head = __doc__.split("Usage::")[0].strip().split("\n\n", 1)[1]
    lines = [head, ""]
    lines += [
        "Chosen candidate, refitted on all 8 recordings (removed strains; e_p^EE of the 7 s validation rollout), and "
        "the default threshold 1.0 for comparison:",
        "",
        "| case | strains | noise | truly stiff | scorer | chosen threshold | removed | e_p^EE [mm] | right strains | "
        "threshold 1.0 removes | e_p^EE at 1.0 [mm] | search [s] wall (CPU) | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        truth = TRUTH[r["case"]]
        if r.get("skipped"):
            lines.append(
                f"| {r['case']} | {r['source']} | {r['noise']} | {', '.join(truth)} | – | – | – | – | – | – | "
                f"– | {r['skipped']} | – |"
            )
            continue
        at1 = r["refits"]["1.0"]
        for m in SCORERS:
            thr = r["chosen"][m]
            fit = r["refits"][str(thr)]
            right = "yes" if sorted(fit["removed"]) == sorted(truth) else "no"
            lines.append(
                f"| {r['case']} | {r['source']} | {r['noise']} | {', '.join(truth)} | `{m}` | {thr:g} | "
                f"{', '.join(fit['removed']) or '–'} | {_mm(fit['e_p'])} | {right} | "
                f"{', '.join(at1['removed']) or '–'} | {_mm(at1['e_p'])} | "
                f"{r['search_time']:.0f} ({r['search_cpu']:.0f}) | {r['loadavg']:.1f} |"
            )
    lines += [
        "",
        f"Mean cross-validated scores per threshold ({N_FOLDS} folds of 2 held-out recordings): "
        "`rollout_score` as 1 − R² of "
        "the tip path (lower is better), `rollout_scorer` as the mean tip error in mm (minus the score; lower is "
        "better); `inf` = a held-out rollout diverged.",
        "",
        "| case | strains | noise | scorer | " + " | ".join(f"{t:g}" for t in THRESHOLDS) + " |",
        "|---|---|---|---|" + "---|" * len(THRESHOLDS),
    ]
    for r in rows:
        if r.get("skipped"):
            continue
        for m in SCORERS:
            vals = np.asarray(r["mean_test"][m], dtype=float)
            shown = 1.0 - vals if m == "rollout_score" else -1e3 * vals
            cells = [f"{v:.3g}" for v in shown]
            best = THRESHOLDS.index(r["chosen"][m])
            cells[best] = f"**{cells[best]}**"
            lines.append(f"| {r['case']} | {r['source']} | {r['noise']} | `{m}` | " + " | ".join(cells) + " |")
    seed_noise = sorted(
        {
            f"{r['case']}: σ_p = {1e3 * r['pose_noise'][0]:g} mm, σ_θ = {np.rad2deg(r['pose_noise'][1]):g}°"
            for r in rows
            if r["noise"] == "seed"
        }
    )
    lines += [
        "",
        "Strains: "
        + "; ".join(f"`{k}` = {v}" for k, v in SOURCES.items())
        + "."
        + (f"  Noise: `seed` = the scenario's seed pose noise ({'; '.join(seed_noise)})." if seed_noise else "")
        + "  Wall times on a shared 2-core machine (`load`: 1-minute load average at the end of the search).",
    ]
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--cases", nargs="*", default=sorted({c for c, _ in SEARCHES}), choices=sorted({c for c, _ in SEARCHES})
    )
    parser.add_argument("--noise", nargs="*", default=["none", "seed"], choices=["none", "seed"])
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    rows = []
    for name, source in SEARCHES:
        if name not in args.cases:
            continue
        for noise_kind in args.noise:
            print(f"== {name} / {source} / noise {noise_kind}", flush=True)
            rows.append(run_search(name, source, noise_kind))
    body = render(rows)
    print(body)
    if not args.no_write and rows:
        write_section(
            "model_selection",
            "Model selection: GridSearchCV over the stiffness threshold",
            body,
            ".venv/bin/python benchmarks/model_selection.py " + " ".join(argv if argv is not None else sys.argv[1:]),
        )


if __name__ == "__main__":
    main()
