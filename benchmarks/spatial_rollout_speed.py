"""Speed of the spatial (3-D) ground-truth simulator and of the identified spatial model's rollouts.

The two_segment robot's parameters (benchmarks/simulation_speed.py) with six strains per
segment (the out-of-plane bending and the twist damped like the bending, the second shear like
the first), hanging under gravity and driven by random generalised forces held for 10 ms (1 kHz
samples), from rest.  Integrated with the default settings of ``simulate`` (compiled Radau IIA,
fixed 0.5 ms steps), with error control (rtol 1e-6, atol 1e-8) and as a tight reference (rtol
1e-10, atol 1e-12); the planar robot on the same planar parameters, integrated the default way, is
timed for comparison.  Reported: wall and CPU time of the second call (the first may compile), the
real-time factor (simulated seconds per wall second, and per CPU second: the machine may be shared),
the integrator's counts and the largest distance of the tip from the reference's over the samples.
The one-time compilation of the spatial kernels (cold numba cache) is not measured here.

The identified spatial model (``SpatialPCSModel``, compiled kernels and the compiled ROS34PW2 loop,
its default tolerances rtol 3e-5, atol 3e-8) with the robot's parameters (ρA = ρ π r², ρI = ρ π r⁴/4,
ρA g, its stiffness and damping) on the same inputs: all six strains (tip error against the
simulator's reference) and bending only (bend_z, bend_x of each segment; its tip error against its own
rollout at rtol 1e-10, the unmodelled strains being a different model).  And the size of the real
Trunk problem: three 105-mm segments, bending only, a ``LearnedActuation(6)`` (gains fixed at random
values of a plausible size) driven by six smooth random inputs sampled at 100 Hz for 75 s: seconds
per rollout (what one output-error Jacobian column costs).

Run: ``.venv/bin/python benchmarks/spatial_rollout_speed.py [--write]`` (``--write`` records the
numbers in docs/results.md).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pcs_sindy.core.spatial import SpatialPCS  # noqa: E402
from pcs_sindy.models import LearnedActuation, SpatialPCSModel  # noqa: E402
from pcs_sindy.simulation import PCSRobot, SpatialPCSRobot  # noqa: E402

from _results import write_section  # noqa: E402

L = [0.07, 0.1]
RHO, E, G = [1070, 1049], [1e4, 9e3], [1e3, 3e3]
D_PLANAR = [3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2]
# (bend_z, bend_x, twist, shear_x, shear_z, axial) per segment
D_SPATIAL = [3e-5, 3e-5, 3e-5, 5e-1, 5e-1, 5e-2, 3e-5, 3e-5, 3e-5, 2.5e-2, 2.5e-2, 5e-2]
DURATION = 5.0
DT = 1e-3


def held_forces(rng: np.random.Generator, amplitude: np.ndarray, n: int, hold: int = 10) -> np.ndarray:
    blocks = rng.uniform(-1, 1, (n // hold + 1, amplitude.size)) * amplitude
    return np.repeat(blocks, hold, axis=0)[:n]


def timed(fn):
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w0, time.process_time() - c0


def physical_model(robot: SpatialPCSRobot, kin: SpatialPCS, actuation=None) -> SpatialPCSModel:
    """The identified-parameters model of the robot on the active strains of ``kin``."""
    rhoA = robot.density * robot.area
    mask = kin.active_mask
    return SpatialPCSModel(
        kin,
        rhoA,
        robot.density * robot.second_moment,
        rhoA[:, None] * robot.gravity[None],
        robot.stiffness[mask],
        robot.damping[mask],
        actuation=actuation,
    )


def model_rows(robot: SpatialPCSRobot, t: np.ndarray, u: np.ndarray, reference: np.ndarray, tip_arc) -> list[str]:
    """Rows of the identified model (default tolerances): two segments, all strains and bending only."""
    rows = []
    m = robot.n_segments
    for name, active in (("all 6 strains", None), ("bending only", [[1, 1, 0, 0, 0, 0]] * m)):
        kin = SpatialPCS(tuple(robot.segment_lengths), active_strains=active)
        model = physical_model(robot, kin)
        n = 12
        model.simulate(np.zeros(n), np.zeros(n), t[:3], u[:3])  # load (or compile) the kernels
        stats: dict = {}
        traj, wall, cpu = timed(
            lambda model=model, stats=stats: model.simulate(np.zeros(n), np.zeros(n), t, u, stats=stats)
        )
        tip = kin.forward_kinematics(traj.q, tip_arc)[0][:, 0]
        if active is None:
            ref, against = reference, "simulator reference"
        else:
            tight = model.simulate(np.zeros(n), np.zeros(n), t, u, rtol=1e-10, atol=1e-12)
            ref, against = kin.forward_kinematics(tight.q, tip_arc)[0][:, 0], "own rtol 1e-10 rollout"
        err = np.linalg.norm(tip - ref, axis=1).max()
        rows.append(
            f"| SpatialPCSModel, {name} | compiled ROS34PW2, rtol 3e-5, atol 3e-8 | {wall:.2f} | {cpu:.2f} | "
            f"{DURATION / wall:.1f} | {DURATION / cpu:.1f} | {stats['n_steps']} | {stats['n_rejected']} | "
            f"{np.abs(traj.q).max():.3g} | {err:.2g} ({against}) |"
        )
        print(rows[-1], flush=True)
    return rows


def trunk_sized() -> str:
    """Seconds per rollout of a 3-segment bending-only model with LearnedActuation(6), 75 s at 100 Hz."""
    rng = np.random.default_rng(1)
    lengths = [0.105] * 3
    robot = SpatialPCSRobot(lengths, 1070.0, 1e4, 1e3, np.tile([3e-5, 3e-5, 3e-5, 0.5, 0.5, 0.05], 3))
    kin = SpatialPCS(tuple(lengths), active_strains=[[1, 1, 0, 0, 0, 0]] * 3)
    act = LearnedActuation(6).fit(kin)
    # gains: ~1e-3 N m per unit input on the bending equations, its strain-dependent part a tenth of that
    act.gains_ = rng.normal(size=act.gains_.size) * np.where(
        [g.count("_") > 4 for g in act.gain_names_], 1e-4, 1e-3
    )
    model = physical_model(robot, kin, act)
    t = np.arange(0.0, 75.0, 0.01)
    f = rng.uniform(0.05, 0.5, (3, 6))
    ph = rng.uniform(0, 2 * np.pi, (3, 6))
    u = np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).sum(axis=1) / 2
    model.simulate(np.zeros(18), np.zeros(18), t[:3], u[:3])
    times, stats = [], {}
    for _ in range(3):
        traj, wall, cpu = timed(lambda: model.simulate(np.zeros(18), np.zeros(18), t, u, stats=stats))
        times.append((wall, cpu))
    wall, cpu = min(times, key=lambda x: x[1])
    line = (
        f"Trunk-sized model (3 × 105 mm, bending only: 6 strains, LearnedActuation(6), 75 s at 100 Hz, "
        f"default tolerances): {wall:.2f} s wall, {cpu:.2f} s CPU per rollout (best of 3; {75 / cpu:.0f}x real "
        f"time), {stats['n_steps']} steps, {stats['n_rejected']} rejected, max |q| {np.abs(traj.q).max():.3g}."
    )
    print(line, flush=True)
    return line


def main(write: bool) -> None:
    t = np.arange(0.0, DURATION, DT)
    rng = np.random.default_rng(0)
    spatial = SpatialPCSRobot(L, RHO, E, G, D_SPATIAL)
    planar = PCSRobot(L, RHO, E, G, D_PLANAR)
    u6 = held_forces(rng, np.tile([2e-3, 2e-3, 1e-3, 0.02, 0.02, 0.05], 2), t.size)
    u3 = u6[:, [0, 3, 5, 6, 9, 11]]
    runs = [
        ("SpatialPCSRobot", "default (fixed 0.5 ms Radau steps)", spatial, u6, {}),
        ("SpatialPCSRobot", "rtol 1e-6, atol 1e-8", spatial, u6, dict(rtol=1e-6, atol=1e-8)),
        ("SpatialPCSRobot", "reference: rtol 1e-10, atol 1e-12", spatial, u6, dict(rtol=1e-10, atol=1e-12)),
        ("PCSRobot (planar)", "default (fixed 0.5 ms Radau steps)", planar, u3, {}),
    ]
    rows, tips = [], {}
    tip_arc = np.array([sum(L)])
    for name, setting, robot, u, opts in runs:
        n = robot.n_q
        robot.simulate(np.zeros(n), np.zeros(n), t[:3], u[:3], **opts)  # load (or compile) the kernels
        traj, wall, cpu = timed(lambda r=robot, u=u, o=opts: r.simulate(np.zeros(n), np.zeros(n), t, u, **o))
        counts = traj.metadata["counts"]
        if robot is spatial:
            tips[setting] = spatial.kinematics.forward_kinematics(traj.q, tip_arc)[0][:, 0]
        rows.append(
            [
                f"| {name} | {setting} | {wall:.2f} | {cpu:.2f} | {DURATION / wall:.1f} | {DURATION / cpu:.1f} | "
                f"{counts['steps']} | {counts['rejected']} | {np.abs(traj.q).max():.3g} |",
                setting if robot is spatial and opts.get("rtol") != 1e-10 else None,
            ]
        )
        print(rows[-1][0], flush=True)
    reference = tips[runs[2][1]]
    rows = [
        row + (f" {np.linalg.norm(tips[key] - reference, axis=1).max():.2g} |" if key else " — |") for row, key in rows
    ]
    rows += model_rows(spatial, t, u6, reference, tip_arc)
    body = "\n".join(
        [
            f"Two segments (L = {L} m, the two_segment parameters), {DURATION:g} s from rest under random",
            "generalised forces held for 10 ms, 1 kHz samples.  Real-time factor: simulated seconds per wall (CPU)",
            "second; tip error: the largest distance of the tip from the reference rollout's over the samples.",
            "Before the speed-up of the spatial kernels (quadrature tiers, segment-end twists; main at 44b1598, this",
            "machine, 2026-11-29, load ~6 on 2 cores): default 2.28 s wall, 1.14 s CPU (2.2x / 4.4x real time), tip",
            "error 9.2e-10 m; rtol 1e-6: 7.21 s wall, 3.57 s CPU; the reference 35.4 s CPU.",
            "",
            "| robot | integration | wall [s] | CPU [s] | real-time factor (wall) | real-time factor (CPU) | steps "
            "| rejected | max abs q | tip error vs reference [m] |",
            "|---|---|---|---|---|---|---|---|---|---|",
            *rows,
            "",
            "Before the compiled spatial model (main at bc46459, the NumPy Rosenbrock loop of SpatialPCSModel): a 5-s",
            "six-strain rollout ~10 min (the spatial identification benchmark's 5-s rollouts 557-624 s).",
            "",
            trunk_sized(),
        ]
    )
    print(body)
    if write:
        write_section(
            "spatial_rollout_speed",
            "Spatial simulator and identified spatial model speed (issue 26)",
            body,
            ".venv/bin/python benchmarks/spatial_rollout_speed.py --write",
        )


if __name__ == "__main__":
    main("--write" in sys.argv[1:])
