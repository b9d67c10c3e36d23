"""Evaluation speed of the physically parameterised PCS library.

Times, for 1, 2, 3 and 5 segments: the Euler–Lagrange matrix ``Psi`` on 4000
samples, its weak (integral) form on the same samples, and one call of the
single-sample dynamics of the compiled forward model (``lib.forward_model(coef).terms(q, qd)``: M and
bias at one state, the inner loop of a rollout or a controller).  The library is
``PhysicalPCSLibrary(lengths, rest_strain=False)``: 8 unknowns per segment (line
density, rotary inertia, 3 stiffnesses, 3 dampings), as before the refactor.

Run: ``.venv/bin/python benchmarks/physical_library.py``
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pcs_sindy.identification import PhysicalPCSLibrary  # noqa: E402
from pcs_sindy.identification.formulations import sliding_windows  # noqa: E402

from _results import write_section  # noqa: E402

LENGTHS = {
    1: [0.1],
    2: [0.07, 0.1],
    3: [0.05, 0.1, 0.06],
    5: [0.03, 0.04, 0.05, 0.035, 0.045],
}
N_SAMPLES = 4000


def best_of(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def reference_op_time() -> float:
    """Time of one tiny numpy operation (3x17 complex product), to put call times in load-free units."""
    a = np.ones((3, 17), dtype=complex)
    n = 20000
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(n):
            a * a
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def main() -> None:
    rng = np.random.default_rng(0)
    rows = []
    load_before = os.getloadavg()[0]
    for m, lengths in LENGTHS.items():
        lib = PhysicalPCSLibrary(lengths, rest_strain=False)
        n = 3 * m
        scale = np.tile([40.0, 0.25, 0.25], m)
        q = rng.uniform(-1, 1, (N_SAMPLES, n)) * scale
        qd = rng.uniform(-1, 1, (N_SAMPLES, n)) * 20 * scale
        qdd = rng.uniform(-1, 1, (N_SAMPLES, n)) * 2000 * scale
        t = np.arange(N_SAMPLES) * 1e-3
        windows = sliding_windows(N_SAMPLES, 20)
        coef = lib.coefficients_from_parameters(1000.0, None, 1e4, 1e3, np.full(n, 1e-2))
        lib.euler_lagrange_matrix(q[:10], qd[:10], qdd[:10])  # warm-up
        t_psi = best_of(lambda: lib.euler_lagrange_matrix(q, qd, qdd), 3)
        t_weak = best_of(lambda: lib.integrated_euler_lagrange_matrix(t, q, qd, windows), 3)
        t_bump = best_of(lambda: lib.integrated_euler_lagrange_matrix(t, q, qd, windows, test_function="bump"), 3)
        f = lib.forward_model(coef).terms
        q = np.ascontiguousarray(q)
        qd = np.ascontiguousarray(qd)
        for k in range(50):
            f(q[k], qd[k])
        n_calls = 2000
        per_call = []
        for _ in range(3):
            t0 = time.perf_counter()
            for k in range(n_calls):
                f(q[k], qd[k])
            per_call.append((time.perf_counter() - t0) / n_calls)
        t_call = min(per_call)
        t_op = reference_op_time()
        rows.append((m, lib.n_coefficients_, t_psi, t_weak, t_bump, t_call, t_call / t_op))
        print(
            f"m={m}: n_coef={lib.n_coefficients_}, Psi {t_psi:.3f} s, weak {t_weak:.3f} s, bump {t_bump:.3f} s, "
            f"forward_model().terms call {t_call * 1e6:.1f} us = {t_call / t_op:.0f} tiny ops"
        )
    load_after = os.getloadavg()[0]
    body = [
        "Euler–Lagrange matrix of `PhysicalPCSLibrary` (numeric, Gauss–Legendre 16 nodes per segment) on "
        f"{N_SAMPLES} random samples; weak form on the same samples with windows of 20 intervals (plain and "
        "bump-weighted); one call of the single-sample dynamics `PhysicalPCSLibrary.forward_model(coef).terms(q, qd)` "
        "(M and bias at one state, the compiled `LumpedPCSModel` a rollout or a controller calls; before the "
        "refactor: the numpy closure of `compile_dynamics`). Library `PhysicalPCSLibrary(lengths, rest_strain=False)`. "
        "Best of 3.",
        "",
        "| segments | coefficients | Psi, 4000 samples [s] | weak form [s] | weak form, bump [s] "
        "| terms call [µs] | call / tiny numpy op |",
        "|---|---|---|---|---|---|---|",
    ]
    for m, nc, tp, tw, tb, tc, ratio in rows:
        body.append(f"| {m} | {nc} | {tp:.3f} | {tw:.3f} | {tb:.3f} | {tc * 1e6:.2f} | {ratio:.2f} |")
    body += [
        "",
        f"1-minute load average of the machine during the run: {load_before:.1f} → {load_after:.1f} "
        "(other jobs share the 2 cores; timings scale with it). The last column divides the call time by "
        "the time of one tiny numpy operation (3×17 complex product) measured in the same run: a call costs "
        "about that many small numpy operations, whatever the load.",
    ]
    write_section(
        "physical_library",
        "Physical PCS library: evaluation speed",
        "\n".join(body),
        ".venv/bin/python benchmarks/physical_library.py",
    )


if __name__ == "__main__":
    main()
