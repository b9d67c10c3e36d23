"""Speed of the ground-truth PCS simulator (pcs_sindy.simulation: PCSRobot.simulate).

Times, for robots of 1-5 segments (docs/method.md parameters; 4 and 5 segments
repeat the three_segment ones): inverse dynamics of a batch of 1000 samples
and a 1 s simulation under random actuation held for 10 ms (1 kHz samples);
then the 7 s sinusoidal validation-style run of two_segment (actuation sampled
every 1 ms and held), and the accuracy of the fast settings (and of scipy's
dopri5 and bdf) on a short window against a tight dop853 reference; the cost
of one 1 ms closed-loop period (``simulate`` on a 2-sample grid against
``advance``); the one-time numba compilation (cold cache) and the generation
of the two_segment, five_segment and actuated data sets.  Wall-clock and CPU
(process) times are both reported because the machine may be shared.

Run: .venv/bin/python benchmarks/simulation_speed.py
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pcs_sindy.simulation.dynamics import PCSRobot  # noqa: E402

from _results import write_section  # noqa: E402

ONE = dict(L=[0.1], rho=[1070], E=[1e4], G=[1e3], D=[1e-5, 1.5e-1, 1.5e-1])
TWO = dict(L=[0.07, 0.1], rho=[1070, 1049], E=[1e4, 9e3], G=[1e3, 3e3], D=[3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2])
THREE = dict(
    L=[0.05, 0.1, 0.06],
    rho=[1240, 1049, 1070],
    E=[1e4, 6e4, 8e4],
    G=[1e3, 3e3, 5e3],
    D=[5e-5, 4e-2, 5e-2, 5e-5, 5e-3, 5e-2, 5e-5, 5e-3, 5e-2],
)


def robot_with(m: int) -> PCSRobot:
    if m in (1, 2):
        p = ONE if m == 1 else TWO
    else:
        idx = [i % 3 for i in range(m)]
        p = {k: [THREE[k][i] for i in idx] for k in ("L", "rho", "E", "G")}
        p["D"] = [THREE["D"][3 * i + j] for i in idx for j in range(3)]
    return PCSRobot(p["L"], p["rho"], p["E"], p["G"], p["D"])


def timed(fn):
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w0, time.process_time() - c0


def random_hold(rng, m: int, t: np.ndarray, hold: int = 10) -> np.ndarray:
    amp = np.tile([2e-3, 0.02, 0.05], m)
    n_blocks = t.size // hold + 1
    return np.repeat(rng.uniform(-1, 1, (n_blocks, 3 * m)) * amp, hold, axis=0)[: t.size]


def sinusoid(rng, m: int, t: np.ndarray) -> np.ndarray:
    amp = np.tile([5e-3, 0.05, 0.1], m)
    w1, w2 = rng.uniform(1, 10, (2, 3 * m)) * 2 * np.pi
    a1, a2 = rng.uniform(0.5, 1.0, (2, 3 * m))
    return amp * (a1 * np.sin(w1 * t[:, None]) + a2 * np.cos(w2 * t[:, None]))


COMPILE_SNIPPET = """
import time, numpy as np
w0, c0 = time.perf_counter(), time.process_time()
from pcs_sindy.simulation.dynamics import PCSRobot
r = PCSRobot([0.1], 1070, 1e4, 1e3, [1e-5, 0.15, 0.15])
t = np.arange(3) * 1e-3
r.simulate(np.zeros(3), np.zeros(3), t, np.zeros((3, 3)))
r.simulate(np.zeros(3), np.zeros(3), t, np.zeros((3, 3)), rtol=1e-6)
r.simulate(np.zeros(3), np.zeros(3), t, np.zeros((3, 3)), method="dop853")
print(time.perf_counter() - w0, time.process_time() - c0)
"""


def compile_times() -> tuple[str, str]:
    """Import + first simulations in a fresh process: with an empty numba cache, then with the cache filled."""
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for _ in range(2):
            res = subprocess.run(
                [sys.executable, "-c", COMPILE_SNIPPET], env=env, capture_output=True, text=True, check=True
            )
            w, c = (float(v) for v in res.stdout.split())
            rows.append(f"{w:.1f} ({c:.1f})")
    return rows[0], rows[1]


def closed_loop_costs(name: str, repeats: int = 5, calls: int = 500) -> tuple[str, str]:
    """Median per-call wall (CPU) time [µs] of one 1 ms control period: simulate on a 2-sample grid, advance."""
    from pcs_sindy.simulation import get_scenario

    robot = get_scenario(name).robot
    n, p = robot.n_q, robot.n_inputs
    bent = np.tile([20.0, 0.1, 0.1], n // 3)
    held = np.full(p, 4.0) if robot.actuation is not None else robot.elastic_forces(bent) + robot.gravity_forces(bent)
    t2, rows = np.array([0.0, 1e-3]), np.stack([held, held])

    def by_simulate():
        q, qd = np.zeros(n), np.zeros(n)
        for _ in range(calls):
            sim = robot.simulate(q, qd, t2, rows)
            q, qd = sim.q[-1], sim.qd[-1]

    def by_advance():
        q, qd = np.zeros(n), np.zeros(n)
        for _ in range(calls):
            q, qd = robot.advance(q, qd, held, 1e-3)

    out = []
    for fn in (by_simulate, by_advance):
        fn()  # warm
        runs = [timed(fn)[1:] for _ in range(repeats)]
        w, c = np.median([r[0] for r in runs]), np.median([r[1] for r in runs])
        out.append(f"{w / calls * 1e6:.0f} ({c / calls * 1e6:.0f})")
    return out[0], out[1]


def main() -> None:
    rng = np.random.default_rng(0)
    load_start = os.getloadavg()[0]
    cold, warm = compile_times()
    print("compile", cold, warm, flush=True)
    # load the compiled kernels (numba cache) before timing
    robot_with(1).simulate(np.zeros(3), np.zeros(3), np.arange(3) * 1e-3, np.zeros((3, 3)))
    robot_with(1).inverse_dynamics(np.zeros(3), np.zeros(3), np.zeros(3))  # the moments kernel of numpy evaluations
    rows = []
    for m in range(1, 6):
        robot = robot_with(m)
        q = rng.normal(size=(1000, 3 * m)) * np.tile([20, 0.1, 0.1], m)
        _, w_id, c_id = timed(lambda: robot.inverse_dynamics(q, 10 * q, 100 * q))
        t = np.arange(1001) * 1e-3
        tau = random_hold(rng, m, t)
        sim, w_fx, c_fx = timed(lambda: robot.simulate(np.zeros(3 * m), np.zeros(3 * m), t, tau))
        st = [sim.metadata["counts"][k] for k in ("steps", "newton_iterations", "jacobians")]
        _, w_ad, c_ad = timed(lambda: robot.simulate(np.zeros(3 * m), np.zeros(3 * m), t, tau, rtol=1e-6, atol=1e-8))
        rows.append(
            f"| {m} | {w_id * 1e3:.1f} ({c_id * 1e3:.1f}) | {w_fx:.2f} ({c_fx:.2f}) | "
            f"{st[0]} / {st[1]} / {st[2]} | {w_ad:.2f} ({c_ad:.2f}) |"
        )
        print(rows[-1], flush=True)

    two = robot_with(2)
    t7 = np.arange(7001) * 1e-3
    tau7 = sinusoid(rng, 2, t7)
    long_rows = []
    for label, kw in [("radau, step=1e-3", dict(step=1e-3)), ("radau, step=5e-4 (default)", {})]:
        _, w, c = timed(lambda: two.simulate(np.zeros(6), np.zeros(6), t7, tau7, **kw))
        long_rows.append(f"| {label} | {w:.1f} | {c:.1f} |")
        print(long_rows[-1], flush=True)

    # accuracy of the fast settings on the first 0.2 s of the same run
    ts, taus = t7[:201], tau7[:201]
    ref, w_ref, c_ref = timed(
        lambda: two.simulate(np.zeros(6), np.zeros(6), ts, taus, method="dop853", rtol=1e-11, atol=1e-14)
    )
    q_ref = ref.q
    span = np.ptp(q_ref, axis=0)
    acc_rows = []
    for label, kw in [
        ("radau, error control rtol 1e-10, atol 1e-13", dict(rtol=1e-10, atol=1e-13)),
        ("radau, error control rtol 1e-6, atol 1e-8", dict(rtol=1e-6, atol=1e-8)),
        ("radau, step=1e-3", dict(step=1e-3)),
        ("radau, step=5e-4 (default)", {}),
        ("dopri5 (scipy), rtol 1e-6, atol 1e-8", dict(method="dopri5", rtol=1e-6, atol=1e-8)),
        ("bdf (scipy), rtol 1e-6, atol 1e-8", dict(method="bdf", rtol=1e-6, atol=1e-8)),
    ]:
        sim, w, c = timed(lambda: two.simulate(np.zeros(6), np.zeros(6), ts, taus, **kw))
        q = sim.q
        err = float(np.max(np.abs(q - q_ref).max(axis=0) / span))
        acc_rows.append(f"| {label} | {err:.1e} | {w:.2f} ({c:.2f}) |")
        print(acc_rows[-1], flush=True)

    loop_rows = []
    for name in ("two_segment", "two_segment_tendon"):
        sim_cost, adv_cost = closed_loop_costs(name)
        loop_rows.append(f"| {name} | {sim_cost} | {adv_cost} |")
        print(loop_rows[-1], flush=True)

    gen_rows = []
    from pcs_sindy.simulation import get_scenario

    for name in ("two_segment", "five_segment", "two_segment_tendon", "one_segment_pneumatic"):
        _, w, c = timed(lambda: get_scenario(name).generate(seed=0, cache=False))
        gen_rows.append(f"| {name} | {w:.1f} | {c:.1f} |")
        print(gen_rows[-1], flush=True)

    body = "\n".join(
        [
            f"Times in seconds (CPU time of the process in parentheses; the 2-core machine was shared: 1-minute load "
            f"average {load_start:.1f} at the start, {os.getloadavg()[0]:.1f} at the end).  The same",
            "benchmark before the simulator's split (own DOP853/RK45 loops then): section",
            "simulation_speed_before_split above.",
            "Robots: docs/method.md one_segment, two_segment, three_segment; 4 and 5 segments repeat",
            "three_segment's parameters.  1 s simulations: random actuation held 10 ms, 1 kHz samples,",
            "from rest.  Default settings: Radau IIA compiled with numba (pcs_sindy/simulation/_radau.py), fixed",
            "0.5 ms steps landing on every sample; steps / Newton iterations / Jacobians of that run;",
            "then the same run with error control (rtol 1e-6, atol 1e-8).  Inverse dynamics: batched numpy.",
            "",
            "| segments | inverse dynamics, 1000 samples [ms] | 1 s simulation [s] | steps / Newton / Jacobians "
            "| 1 s, error control [s] |",
            "|---|---|---|---|---|",
            *rows,
            "",
            "two_segment, 7 s sinusoidal actuation sampled every 1 ms and held (validation-style run):",
            "",
            "| settings | wall [s] | CPU [s] |",
            "|---|---|---|",
            *long_rows,
            "",
            f"Accuracy on the first 0.2 s of that run against dop853 (scipy's DOP853) at rtol 1e-11, atol 1e-14 "
            f"(itself "
            f"{w_ref:.1f} s wall, {c_ref:.1f} s CPU)",
            "(max over strains of max |error| / range of the strain):",
            "",
            "| settings | relative error | time [s] |",
            "|---|---|---|",
            *acc_rows,
            "",
            "One 1 ms control period of a closed loop (held command, default fixed 0.5 ms Radau steps), per call,",
            "median of 5 x 500 consecutive periods, wall (CPU) [µs]: `simulate` on a 2-sample grid (validation,",
            "trajectory object, fresh Jacobian every call) and `advance` (integrator state kept between calls):",
            "",
            "| robot | simulate, 2 samples [µs] | advance [µs] |",
            "|---|---|---|",
            *loop_rows,
            "",
            "Scenario data sets, `get_scenario(name).generate(seed=0, cache=False)` (8 x 0.5 s batched training",
            "recordings + 7 s validation, marker poses included):",
            "",
            "| scenario | wall [s] | CPU [s] |",
            "|---|---|---|",
            *gen_rows,
            "",
            "numba compilation, import + first Radau (fixed and error-controlled) and DOP853 calls in a fresh",
            f"process, wall (CPU) [s]: empty cache {cold}; cache filled {warm}.  Kernels use `cache=True`, so",
            "the compilation is paid once per machine (cache in pcs_sindy/simulation/__pycache__ or $NUMBA_CACHE_DIR).",
        ]
    )
    path = write_section(
        "simulation_speed", "Ground-truth simulator speed", body, ".venv/bin/python benchmarks/simulation_speed.py"
    )
    print(f"written to {path}")


if __name__ == "__main__":
    main()
