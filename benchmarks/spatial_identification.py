"""Identification of a 2-segment spatial (3-D) PCS robot from simulated data (issue 26, item 4).

Ground truth: :class:`~pcs_sindy.simulation.spatial_dynamics.SpatialPCSRobot` (compiled kernels, Radau),
two segments of 0.1 m, seed-like material (ρ 1070 kg/m³, E 10 kPa, G 1 kPa, r 2 cm), all six strains
per segment, driven by random smooth generalised forces on every strain (a sum of three sinusoids
of random frequency in 0.3–3 Hz and phase per strain, held per sample at 100 Hz).  Training:
three 3-s recordings; validation: a held-out 5-s recording with other inputs.  Identification:
``EulerLagrangeRegressor()`` defaults (weak form, spatial physical library chosen from the data,
stiffness-threshold sparsification, bounded least squares), rates from the estimator's own
Savitzky–Golay differentiation.  The identified model is rolled out open loop over the 5 s
from the validation's initial state and its tip compared with the truth's.

Cases: ``clean`` (the simulator's strains) and ``noisy`` (0.5 mm Gaussian noise on 3-D marker
positions — two markers per disc at ±r on the body x and z axes, four discs per segment — and the
strains fitted back per frame by batched Gauss–Newton least squares on the known segmentation;
a stand-in for the spatial kinematic fusion, which landed too late to be used here).

Usage::

    .venv/bin/python benchmarks/spatial_identification.py [--cases clean noisy] [--write]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pcs_sindy.core.spatial import SpatialStrainTrajectory  # noqa: E402
from pcs_sindy.identification import EulerLagrangeRegressor  # noqa: E402
from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot  # noqa: E402

from _results import write_section  # noqa: E402

LENGTHS = [0.1, 0.1]
RHO, E, G, R = 1070.0, 1e4, 1e3, 0.02
DAMP = np.tile([3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15], 2)
FORCE_SCALE = np.tile([1e-3, 1e-3, 3e-4, 0.05, 0.05, 0.1], 2)
DT = 0.01
NOISE = 0.5e-3
#: rows are cached here so the cases can be run separately (the written section holds every cached row)
CACHE = Path(os.environ.get("PCS_SINDY_CACHE", Path.home() / ".cache" / "pcs_sindy")) / "spatial_identification.json"
#: rollout tolerances of the identified model (the truth uses its own defaults)
RTOL, ATOL = 1e-4, 1e-7


def inputs(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    f = rng.uniform(0.3, 3.0, (3, FORCE_SCALE.size))
    ph = rng.uniform(0.0, 2 * np.pi, (3, FORCE_SCALE.size))
    return FORCE_SCALE * np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).sum(axis=1) / 2


def marker_geometry(kin):
    s = np.concatenate([np.linspace(0, L, 5)[1:] + start for start, L in zip([0.0, LENGTHS[0]], LENGTHS, strict=True)])
    offsets = np.array([[R, 0.0, 0.0], [0.0, 0.0, R]])
    return s, offsets


def markers(kin, q, s, offsets):
    p, Rm = kin.forward_kinematics(q, s)  # (T, K, 3), (T, K, 3, 3)
    return p[:, :, None, :] + np.einsum("tkab,jb->tkja", Rm, offsets)


def fit_strains(kin, measured, s, offsets, iterations=8):
    """Batched Gauss–Newton: strains (T, 12) whose markers best fit ``measured`` (T, K, 2, 3)."""
    T = measured.shape[0]
    q = np.zeros((T, kin.n_q))
    for _ in range(iterations):
        p, Rm, Jp, Jw = kin.jacobian(q, s)
        pred = p[:, :, None, :] + np.einsum("tkab,jb->tkja", Rm, offsets)
        # d(R d)/dq = -R [d]x J_w
        d1, d2, d3 = offsets.T
        z = np.zeros_like(d1)
        hat = np.stack([np.stack([z, -d3, d2], -1), np.stack([d3, z, -d1], -1), np.stack([-d2, d1, z], -1)], 1)
        J = Jp[:, :, None] - np.einsum("tkab,jbc,tkcn->tkjan", Rm, hat, Jw)
        J = J.reshape(T, -1, kin.n_q)
        res = (measured - pred).reshape(T, -1)
        q = q + _solve(J, res)
    return q


def _solve(J, res):
    JT = J.transpose(0, 2, 1)
    return np.linalg.solve(JT @ J, (JT @ res[..., None]))[..., 0]


def run_case(case: str) -> dict:
    rng = np.random.default_rng(2026)
    robot = SpatialPCSRobot(LENGTHS, RHO, E, G, DAMP, radius=R)
    kin = robot.kinematics
    t_train = np.arange(0.0, 3.0, DT)
    t_val = np.arange(0.0, 5.0, DT)
    u_train = [inputs(rng, t_train) for _ in range(3)]
    train = [(robot.simulate(np.zeros(12), np.zeros(12), t_train, u), u) for u in u_train]
    u_val = inputs(rng, t_val)
    val = robot.simulate(np.zeros(12), np.zeros(12), t_val, u_val)
    X = [tr for tr, _ in train]
    if case == "noisy":
        s, offsets = marker_geometry(kin)
        X = []
        for tr, _ in train:
            meas = markers(kin, tr.q, s, offsets) + rng.normal(0.0, NOISE, (tr.q.shape[0], s.size, 2, 3))
            q = fit_strains(kin, meas, s, offsets)
            X.append(SpatialStrainTrajectory(q, tr.t, segment_lengths=LENGTHS))
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reg = EulerLagrangeRegressor().fit(X, [u for _, u in train])
    fit_time = time.perf_counter() - t0
    truth = reg.full_library_.coefficients_from_parameters(RHO, R, E, G, DAMP)
    t0 = time.perf_counter()
    stats: dict = {}
    sim = reg.simulate(np.zeros(12), np.zeros(12), t_val, u_val, rtol=RTOL, atol=ATOL, stats=stats)
    roll_time = time.perf_counter() - t0
    tip = [kin.total_length]
    p_true = kin.forward_kinematics(val.q, tip)[0][:, 0]
    p_sim = kin.forward_kinematics(sim.q, tip)[0][:, 0]
    err = np.linalg.norm(p_sim - p_true, axis=1)
    names = reg.full_library_.coefficient_names()
    k_idx = reg.full_library_.stiffness_index_
    stiff_rel = np.abs(reg.coef_[k_idx] / truth[k_idx] - 1)
    mass_cols = [j for j, nm in enumerate(names) if nm.startswith(("rhoA", "rhoI"))]
    return {
        "case": case,
        "tip_rmse_mm": 1e3 * float(np.sqrt(np.mean(err**2))),
        "tip_max_mm": 1e3 * float(err.max()),
        "tip_motion_rms_mm": 1e3 * float(np.sqrt(np.mean(np.sum((p_true - p_true.mean(0)) ** 2, axis=1)))),
        "stiffness_rel_err_max": float(stiff_rel.max()),
        "stiffness_rel_err_median": float(np.median(stiff_rel)),
        "mass": {names[j]: (float(reg.coef_[j]), float(truth[j])) for j in mass_cols},
        "removed": list(reg.removed_strains_),
        "fit_s": fit_time,
        "rollout_s": roll_time,
        "steps": stats.get("n_steps"),
        "warnings": sorted({str(w.message)[:80] for w in caught}),
    }


def render(rows: list[dict]) -> str:
    lines = [
        "2-segment spatial PCS robot (0.1 m + 0.1 m, ρ 1070 kg/m³, E 10 kPa, G 1 kPa, r 2 cm, all 6 strains per "
        "segment), random smooth generalised forces on every strain; training 3 × 3 s at 100 Hz, validation a "
        "held-out 5-s recording rolled out open loop from its initial state (identified model: ROS34PW2 NumPy "
        f"loop, rtol {RTOL:g}, atol {ATOL:g}). `EulerLagrangeRegressor()` defaults (weak form, spatial physical "
        "library chosen from the data). `noisy`: 0.5 mm Gaussian noise on 3-D marker positions (2 markers per disc "
        "at ±r on body x and z, 4 discs per segment), strains fitted back per frame by batched Gauss–Newton on the "
        "known segmentation (a stand-in for the spatial kinematic fusion, which landed too late to be used here). "
        "Targets (issue 26): ≤ 0.1 mm noise-free, ≤ 1 mm with 0.5 mm marker noise.",
        "",
        "| case | tip RMSE [mm] | tip max [mm] | tip motion RMS [mm] | stiffness rel. err. (median / max) "
        "| rhoA_1, rhoA_2 (identified / true) [kg/m] | removed strains | fit [s] | 5-s rollout [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ra = ", ".join(f"{v[0]:.4g}/{v[1]:.4g}" for k, v in r["mass"].items() if k.startswith("rhoA"))
        lines.append(
            f"| {r['case']} | {r['tip_rmse_mm']:.4f} | {r['tip_max_mm']:.4f} | {r['tip_motion_rms_mm']:.1f} "
            f"| {r['stiffness_rel_err_median']:.2e} / {r['stiffness_rel_err_max']:.2e} | {ra} "
            f"| {', '.join(r['removed']) or '-'} | {r['fit_s']:.1f} | {r['rollout_s']:.0f} |"
        )
    lines += [
        "",
        "The noise-free target is met. The noisy one is not: 0.5 mm marker noise gives strain noise of about "
        "0.2 1/m (bending, twist) and 0.005–0.026 (shear, axial) from this 8-disc per-frame fit, comparable to the "
        "excited shear motion; the equation-error fit then loses the inertia (rhoA_1, rhoI_i at their bound 0) and "
        "the rollout drifts. Probes on the same data (fit only, not in the table): Savitzky–Golay window 41 with "
        "weak window 100 brings the stiffness errors to 2–65 % and the densities to 20–60 %, 3 × 10 s of training "
        "no better; a temporally smoothing spatial fusion or the output-error refinement is needed (not done).",
    ]
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=["clean", "noisy"], choices=["clean", "noisy"])
    parser.add_argument("--write", action="store_true", help="write the table (every cached row) into docs/results.md")
    parser.add_argument("--from-cache", action="store_true", help="run nothing: render the cached rows")
    args = parser.parse_args(argv)
    cached = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    for case in [] if args.from_cache else args.cases:
        row = run_case(case)
        print(row, flush=True)
        cached[case] = row
        CACHE.parent.mkdir(parents=True, exist_ok=True)
        CACHE.write_text(json.dumps(cached, indent=1))
    rows = [cached[c] for c in ("clean", "noisy") if c in cached]
    text = render(rows)
    print(text)
    if args.write:
        write_section(
            "spatial_identification",
            "Spatial (3-D) PCS identification on simulated data",
            text,
            ".venv/bin/python benchmarks/spatial_identification.py --write",
        )


if __name__ == "__main__":
    main()
