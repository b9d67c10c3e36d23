"""Speed of the compiled rollout of identified models (issue 4: >= 10x real time).

For the one- and two-segment scenarios, the true parameters in a
``PhysicalPCSLibrary`` and in a ``PCSLagrangianLibrary(basis="physical")`` are
rolled out over the 7 s validation actuation (1 kHz, held per sample) with the
estimator's default tolerances (rtol 1e-6, atol 1e-9) and looser ones (1e-4, 1e-7), through
``EulerLagrangeRegressor.simulate``'s compiled path (``LumpedModel.rollout``).
Reported: the first call in the process (loads numba's on-disk cache, or
compiles when it is cold), the second call, real-time multiples, integrator
statistics, the error against the simulator's validation trajectory, and the
Python path on the first 0.5 s of the same run for comparison.

Run: ``.venv/bin/python benchmarks/rollout_speed.py``
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
from _results import write_section  # noqa: E402

from pcs_sindy._jit_rollout import LumpedModel  # noqa: E402
from pcs_sindy.integrators import integrate_zoh  # noqa: E402
from pcs_sindy.library import PCSLagrangianLibrary, PhysicalPCSLibrary  # noqa: E402
from pcs_sindy.regressor import _make_rhs  # noqa: E402
from pcs_sindy.simulation import get_scenario  # noqa: E402

RTOL, ATOL = 1e-6, 1e-9  # the estimator's defaults
TOLERANCES = [(RTOL, ATOL), (1e-4, 1e-7)]
PY_SECONDS = 0.5


def _libraries(robot):
    phys = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    c_phys = phys.coefficients_from_parameters(robot.density, robot.radius, robot.youngs_modulus,
                                               robot.shear_modulus, robot.damping)
    lag = PCSLagrangianLibrary(robot.segment_lengths, basis="physical")
    c_lag = lag.coefficients_from_parameters(robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus,
                                             robot.damping, gravity=robot.gravity)
    return [("PhysicalPCSLibrary", phys, c_phys, None), ('PCSLagrangianLibrary(basis="physical")', lag, c_lag, None),
            ("PhysicalPCSLibrary, 8 nodes", phys, c_phys, 8)]


_COLD = """
import time, numpy as np
t0 = time.perf_counter()
from pcs_sindy._jit_rollout import LumpedModel
m = LumpedModel((0.1,), np.ones(3, bool), [0.3], [1e-5], [[0.0, -3.0]], [1e-2, 10.0, 10.0], [1e-4, 1e-2, 1e-2])
m.rollout(np.zeros(6), np.arange(3) * 1e-3, np.zeros((3, 3)))
print(time.perf_counter() - t0)
"""


def cold_compile_seconds() -> float:
    """Import + first tiny rollout in a fresh process with an empty numba cache (full compilation)."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        out = subprocess.run([sys.executable, "-c", _COLD], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    cold = cold_compile_seconds()
    print(f"cold compile: {cold:.1f} s", flush=True)
    rows = []
    for name in ("one_segment", "two_segment"):
        scenario = get_scenario(name)
        robot = scenario.robot
        val = scenario.generate(seed=0, progress=True).validation
        t, tau = val.t, val.tau
        duration = t[-1] - t[0]
        n = robot.n_q
        y0 = np.zeros(2 * n)
        for lib_name, lib, coef, nq in _libraries(robot):
            model = LumpedModel.from_library(lib, coef, n_quadrature=nq)
            k_py = int(round(PY_SECONDS / scenario.dt)) + 1
            rhs = _make_rhs(lib.compile_dynamics(coef), n)
            py = None
            if nq is None:  # the Python path always uses the library's own rule
                t0 = time.perf_counter()
                integrate_zoh(rhs, y0, t[:k_py], tau[:k_py], rtol=RTOL, atol=ATOL)
                py = time.perf_counter() - t0
            for i_tol, (rtol, atol) in enumerate(TOLERANCES):
                t0 = time.perf_counter()
                model.rollout(y0, t, tau, rtol=rtol, atol=atol)
                first = time.perf_counter() - t0
                stats: dict = {}
                t0 = time.perf_counter()
                y = model.rollout(y0, t, tau, rtol=rtol, atol=atol, stats=stats)
                second = time.perf_counter() - t0
                err = np.abs(y[:, :n] - val.q).max(axis=0) / np.abs(val.q).max(axis=0)
                row = dict(case=name, lib=lib_name, tol=f"{rtol:g} / {atol:g}", first=first, second=second,
                           rt=duration / second, steps=stats["n_steps"], rej=stats["n_rejected"],
                           evals=stats["n_evaluations"], us=1e6 * second / stats["n_evaluations"], err=float(err.max()),
                           py_rt=(t[k_py - 1] - t[0]) / py if (i_tol == 0 and py) else None)
                rows.append(row)
                print(row, flush=True)
    body = [
        f"7 s validation actuation of each scenario (seed 0, {t.size} samples at 1 kHz, held per sample), true "
        f"parameters, from rest, adaptive Dormand–Prince 5(4) at the estimator's default "
        f"tolerances (rtol {RTOL:g}, atol {ATOL:g}) and at looser ones.  "
        "'first' = first call in the process (numba kernels loaded from the on-disk cache when warm).  "
        f"Compilation with a cold cache (fresh process, empty NUMBA_CACHE_DIR, import + tiny rollout): {cold:.1f} s, "
        "once per installation.  'x real time' = 7 s / second call.  The machine (2 cores) was shared with "
        "other jobs, so times are noisy by ~1.5x.  "
        "Error: max over strains of max |q - q_sim| / max |q_sim| against the simulator's validation trajectory.  "
        f"Python path (`integrate_zoh` + `compile_dynamics`) timed on the first {PY_SECONDS} s only.",
        "",
        "| scenario | library (Gauss–Legendre nodes per segment: 16 unless said) | rtol / atol | first call (s) | second call (s) | x real time | steps (rejected) "
        "| rhs calls | µs / rhs call | rel. error vs simulator | Python path x real time (rtol 1e-6) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        body.append(
            f"| {r['case']} | {r['lib']} | {r['tol']} | {r['first']:.2f} | {r['second']:.3f} | {r['rt']:.1f} "
            f"| {r['steps']} ({r['rej']}) | {r['evals']} | {r['us']:.2f} | {r['err']:.1e} "
            f"| {'' if r['py_rt'] is None else format(r['py_rt'], '.2f')} |"
        )
    write_section("rollout_speed", "Compiled rollout speed (issue 4)", "\n".join(body),
                  ".venv/bin/python benchmarks/rollout_speed.py")


if __name__ == "__main__":
    main()
