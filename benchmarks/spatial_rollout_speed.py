"""Speed of the spatial (3-D) ground-truth simulator: a 2-segment SpatialPCSRobot, 5 s rollout.

The two_segment robot's parameters (benchmarks/simulation_speed.py) with six strains per
segment (the out-of-plane bending and the twist damped like the bending, the second shear like
the first), hanging under gravity and driven by random generalised forces held for 10 ms (1 kHz
samples), from rest.  Integrated with the default settings of ``simulate`` (compiled Radau IIA,
fixed 0.5 ms steps) and with error control (rtol 1e-6, atol 1e-8); the planar robot on the same
planar parameters, integrated the default way, is timed for comparison.  Reported: wall and CPU
time of the second call (the first may compile), the real-time factor (simulated seconds per wall
second) and the integrator's counts.  The one-time compilation of the spatial kernels (cold
numba cache) is not measured here.

Run: ``.venv/bin/python benchmarks/spatial_rollout_speed.py [--write]`` (``--write`` records the
numbers in docs/results.md).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
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
        ("PCSRobot (planar)", "default (fixed 0.5 ms Radau steps)", planar, u3, {}),
    ]
    rows = []
    for name, setting, robot, u, opts in runs:
        n = robot.n_q
        robot.simulate(np.zeros(n), np.zeros(n), t[:3], u[:3], **opts)  # load (or compile) the kernels
        traj, wall, cpu = timed(lambda r=robot, u=u, o=opts: r.simulate(np.zeros(n), np.zeros(n), t, u, **o))
        counts = traj.metadata["counts"]
        rows.append(
            f"| {name} | {setting} | {wall:.2f} | {cpu:.2f} | {DURATION / wall:.2f} | "
            f"{counts['steps']} | {counts['rejected']} | {np.abs(traj.q).max():.3g} |"
        )
        print(rows[-1], flush=True)
    body = "\n".join(
        [
            f"Two segments (L = {L} m, the two_segment parameters), {DURATION:g} s from rest under random",
            "generalised forces held for 10 ms, 1 kHz samples.  Real-time factor: simulated seconds per wall second.",
            "",
            "| robot | integration | wall [s] | CPU [s] | real-time factor | steps | rejected | max abs q |",
            "|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )
    print(body)
    if write:
        write_section(
            "spatial_rollout_speed",
            "Spatial simulator speed (issue 26)",
            body,
            ".venv/bin/python benchmarks/spatial_rollout_speed.py --write",
        )


if __name__ == "__main__":
    main("--write" in sys.argv[1:])
