"""Spatial (3-D) robots driven by tendons routed in 3-D: identification with known routing, and statics.

Ground truth: :class:`~pcs_sindy.simulation.spatial_dynamics.SpatialPCSRobot` with ``SpatialTendons``
(compiled kernels), two segments of 0.07 m and 0.1 m, seed-like material (ρ 1070 kg/m³, E 10 kPa,
G 1 kPa, r 2 cm), all six strains per segment, four tendons (ends 0.07, 0.17, 0.17, 0.12 m; offsets
(d_x, d_z) = (10, 0), (−8, 4), (0, −12), (5, 6) mm).

* ``dynamics``: two training recordings of 1.5 s of smooth random tensions (0–2 N, 200 Hz, the
  simulator's rates given), a held-out 0.5-s recording of other tensions.  ``EulerLagrangeRegressor``
  with the actuation ``spatial_tendon`` of the known offsets, and with the offsets' directions only
  (magnitudes identified); the identified model rolled out open loop from rest over the held-out
  recording, its tip against the truth's.  Black boxes on the same split: ARX(2, 2) and a quadratic
  map of first-order-lagged tensions (``pcs_sindy.identification.baselines``), tensions -> tip position.
* ``statics``: the equilibrium of the model of the simulator's parameters against the simulator left
  to settle (6 s) under held tensions; static fits (``formulation="static"``) on 12 simulated holds of
  3 s (generalised forces on every strain; tendons with known routing; tendon directions only),
  checked on 6 held-out holds: the identified model's equilibrium tip against the settled simulator's.
  Black boxes on the same holds: linear and quadratic maps of the loads to the tip (``PolynomialLoadMap``).

Usage::

    .venv/bin/python benchmarks/spatial_tendons_statics.py [--parts dynamics statics] [--write]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pcs_sindy.core.spatial import SpatialPCS  # noqa: E402
from pcs_sindy.identification import EulerLagrangeRegressor  # noqa: E402
from pcs_sindy.identification.baselines import ARX, LaggedPolynomialMap, PolynomialLoadMap  # noqa: E402
from pcs_sindy.identification.library.spatial_physical import SpatialPhysicalPCSLibrary  # noqa: E402
from pcs_sindy.models import SpatialTendonActuation  # noqa: E402
from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot, SpatialTendons  # noqa: E402

from _results import write_section  # noqa: E402

LENGTHS = [0.07, 0.1]
END = [0.07, 0.17, 0.17, 0.12]
OFFSET = [[0.01, 0.0], [-0.008, 0.004], [0.0, -0.012], [0.005, 0.006]]
ANGLE = np.arctan2(np.asarray(OFFSET)[:, 1], np.asarray(OFFSET)[:, 0]).tolist()
RHO, E, G = 1070.0, 1e4, 1e3
DAMP_DYN = np.tile([3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15], 2)
DAMP_STATIC = np.tile([1e-4, 1e-4, 6e-5, 0.15, 0.15, 0.15], 2)
BENDING = [0, 1, 6, 7]
TIP = [0.17]


def tensions(t, seed, p=4):
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.5, 4.0, (3, p))
    ph = rng.uniform(0, 2 * np.pi, (3, p))
    return 1.0 + np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).mean(axis=1)


def tip_of(kin, q):
    return kin.forward_kinematics(q, TIP)[0][:, 0]


def rms(err):
    return float(np.sqrt(np.mean(np.sum(err**2, axis=-1))))


def dynamics() -> list[str]:
    rob = SpatialPCSRobot(LENGTHS, RHO, E, G, DAMP_DYN, actuation=SpatialTendons(END, OFFSET))
    kin = rob.kinematics
    t = np.arange(0.0, 1.5, 0.005)
    X, U = [], []
    for seed in range(2):
        u = tensions(t, seed)
        X.append(rob.simulate(np.zeros(12), np.zeros(12), t, u))
        U.append(u)
    tv = np.arange(0.0, 0.5, 0.005)
    uv = tensions(tv, 7)
    val = rob.simulate(np.zeros(12), np.zeros(12), tv, uv)
    tip_true = tip_of(kin, val.q)
    motion = rms(tip_true - tip_true.mean(axis=0))
    rows = [
        "| model | fit [s] | bending stiffness, max rel. error | offsets, max error [mm] | held-out tip RMSE [mm] "
        "| max [mm] | rollout [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, layout in (
        ("PCS, known routing", {"type": "spatial_tendon", "end": END, "offset": OFFSET}),
        ("PCS, directions only", {"type": "spatial_tendon", "end": END, "angle": ANGLE}),
    ):
        start = time.perf_counter()
        reg = EulerLagrangeRegressor(actuation=layout).fit(X, U, qd=[x.qd for x in X])
        fit_s = time.perf_counter() - start
        k_err = np.max(np.abs(reg.stiffness_[BENDING] / rob.stiffness[BENDING] - 1))
        d_err = 1e3 * np.abs(reg.actuation_.offset_vectors_ - np.asarray(OFFSET)).max()
        start = time.perf_counter()
        sim = reg.simulate(np.zeros(12), np.zeros(12), tv, uv)
        roll_s = time.perf_counter() - start
        err = tip_of(kin, sim.q) - tip_true
        rows.append(
            f"| {label} | {fit_s:.1f} | {k_err:.2e} | {d_err:.2g} | {1e3 * rms(err):.4f} | "
            f"{1e3 * np.linalg.norm(err, axis=1).max():.4f} | {roll_s:.2f} |"
        )
        print(rows[-1], flush=True)
    y_train = [tip_of(kin, x.q) for x in X]
    arx = ARX(2, 2).fit(U[0], y_train[0])
    pred = arx.predict(uv, tip_true[:2])
    rows.append(
        f"| black box ARX(2, 2) (first recording) | | | | {1e3 * rms(pred - tip_true):.3f} | "
        f"{1e3 * np.linalg.norm(pred - tip_true, axis=1).max():.3f} | |"
    )
    lag = LaggedPolynomialMap(degree=2).fit(np.concatenate(U), np.concatenate(y_train), dt=0.005)
    pred = lag.predict(uv, dt=0.005)
    rows.append(
        f"| black box: quadratic map of lagged tensions | | | | {1e3 * rms(pred - tip_true):.3f} | "
        f"{1e3 * np.linalg.norm(pred - tip_true, axis=1).max():.3f} | |"
    )
    print("\n".join(rows[-2:]), flush=True)
    return [
        "### Dynamics from 3-D tendon inputs",
        "",
        f"Held-out recording: 0.5 s, tip motion {1e3 * motion:.2f} mm RMS about its mean.  Rollouts of the compiled "
        "spatial model (`SpatialPCSModel`, the tendon map's compiled form `spatial_tendon`), first call included.",
        "",
        *rows,
    ]


def settle(rob, inputs, hold_s=3.0, dt=0.01):
    n = int(round(hold_s / dt))
    u = np.repeat(np.atleast_2d(inputs), n, axis=0)
    return rob.simulate(np.zeros(12), np.zeros(12), np.arange(u.shape[0]) * dt, u), u


def statics() -> list[str]:
    out = ["### Statics", ""]
    rob = SpatialPCSRobot(LENGTHS, RHO, E, G, DAMP_STATIC, actuation=SpatialTendons(END, OFFSET))
    kin = SpatialPCS(tuple(LENGTHS))
    lib = SpatialPhysicalPCSLibrary(LENGTHS, rest_strain=False).fit(np.zeros((1, 24)))
    fm = lib.forward_model(
        lib.coefficients_from_parameters(RHO, 0.02, E, G, DAMP_STATIC),
        actuation=SpatialTendonActuation(end=END, offset=OFFSET).fit(kin),
    )
    rng = np.random.default_rng(0)
    diffs, resid, times = [], [], []
    for _ in range(5):
        u = rng.uniform(0.0, 2.0, 4)
        start = time.perf_counter()
        q = fm.equilibrium(u)
        times.append(time.perf_counter() - start)
        t = np.linspace(0.0, 6.0, 601)
        tr = rob.simulate(np.zeros(12), np.zeros(12), t, np.tile(u, (t.size, 1)))
        diffs.append(np.abs(q - tr.q[-1]).max() / np.abs(q).max())
        el = rob.elastic_forces(q)
        resid.append(np.abs(rob.gravity_forces(q) + el - rob.actuation_forces(q, u)).max() / np.abs(el).max())
    out += [
        f"Equilibrium of the model of the simulator's parameters under 5 random held tensions (0–2 N): max "
        f"|q − q_settled| / max |q| = {max(diffs):.1e} against the simulator after 6 s; the simulator's own "
        f"|G + K q − A u| / |K q| = {max(resid):.1e}; {1e3 * np.mean(times):.0f} ms per equilibrium.",
        "",
        "| static fit (12 holds of 3 s) | stiffness, max rel. error (bending / all kept) | offsets, max error [mm] "
        "| held-out tip error, mean [mm] | black boxes: linear / quadratic load map [mm] |",
        "|---|---|---|---|---|",
    ]
    cases = (
        (
            "generalised forces on every strain",
            None,
            lambda r: r.uniform(-1, 1, 12) * np.tile([1e-3, 1e-3, 2e-4, 0.05, 0.05, 0.2], 2),
        ),
        (
            "tendons, known routing",
            {"type": "spatial_tendon", "end": END, "offset": OFFSET},
            lambda r: r.uniform(0.0, 2.0, 4),
        ),
        (
            "tendons, directions only",
            {"type": "spatial_tendon", "end": END, "angle": ANGLE},
            lambda r: r.uniform(0.0, 2.0, 4),
        ),
    )
    for label, layout, draw in cases:
        sim_rob = rob if layout is not None else SpatialPCSRobot(LENGTHS, RHO, E, G, DAMP_STATIC)
        r = np.random.default_rng(1)
        train = np.stack([draw(r) for _ in range(12)])
        test = np.stack([draw(r) for _ in range(6)])
        tr, u = settle(sim_rob, train)
        reg = EulerLagrangeRegressor(formulation="static", actuation=layout).fit([tr], [u])
        kept = reg.active_strains_.reshape(-1)
        rel = np.abs(reg.stiffness_ / sim_rob.stiffness - 1)
        d_err = f"{1e3 * np.abs(reg.actuation_.offset_vectors_ - np.asarray(OFFSET)).max():.2g}" if layout else "–"
        truth_tips = np.array([tip_of(kin, settle(sim_rob, v)[0].q[-1:])[0] for v in test])
        model_tips = tip_of(kin, reg.equilibrium(test))
        held = np.array([tr.q[300 * (k + 1) - 1] for k in range(12)])
        held_tips = tip_of(kin, held)
        boxes = [PolynomialLoadMap(degree=d).fit(train, held_tips).predict(test) for d in (1, 2)]
        out.append(
            f"| {label} | {rel[BENDING].max():.1e} / {rel[kept].max():.1e} | {d_err} | "
            f"{1e3 * np.linalg.norm(model_tips - truth_tips, axis=1).mean():.2e} | "
            + " / ".join(f"{1e3 * np.linalg.norm(b - truth_tips, axis=1).mean():.3f}" for b in boxes)
            + " |"
        )
        print(out[-1], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", nargs="+", default=["dynamics", "statics"], choices=["dynamics", "statics"])
    ap.add_argument("--write", action="store_true", help="write the numbers to docs/results.md")
    args = ap.parse_args()
    body: list[str] = []
    for part in args.parts:
        body += (dynamics() if part == "dynamics" else statics()) + [""]
    print("\n".join(body))
    if args.write:
        cmd = "python benchmarks/spatial_tendons_statics.py --write" + (
            "" if len(args.parts) == 2 else " --parts " + " ".join(args.parts)
        )
        write_section("spatial_tendons_statics", "Spatial robots: 3-D tendons and statics", "\n".join(body), cmd)


if __name__ == "__main__":
    main()
