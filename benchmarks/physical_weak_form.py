"""Strong vs weak (integral) form of the physical PCS library under strain noise.

two_segment training data (8 × 0.5 s, 1 kHz, zero-order-hold actuation), the true
strains plus Gaussian noise ``level × [0.35 1/m, 0.01, 0.01]`` per segment (the
order of magnitude closed-form IK gives for σ_p = 0.5 mm / σ_θ = 1° on markers
7–10 cm apart; a stand-in — the pose-level study is benchmarks/noise_robustness.py).
Bounded least squares (``lsq_linear`` with ``lower_bounds_``) on the rows of
all recordings; reported: relative error of the identified parameters
(``PhysicalPCSLibrary(rotary_inertia="tied", rest_strain=False)``: rhoA,
stiffness, damping per strain).

Run: ``.venv/bin/python benchmarks/physical_weak_form.py``
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import lsq_linear
from scipy.signal import savgol_filter

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pcs_sindy.identification import PhysicalPCSLibrary  # noqa: E402
from pcs_sindy.identification.formulations import integrate_forces, sliding_windows  # noqa: E402
from pcs_sindy.simulation import get_scenario  # noqa: E402

from _results import write_section  # noqa: E402

LEVELS = (0.0, 0.3, 1.0)
SEEDS = (0, 1, 2)
STRAIN_SIGMA = np.array([0.35, 0.01, 0.01])


def sg(q, window, dt, deriv=0):
    return savgol_filter(q, window, 3, deriv=deriv, delta=dt, axis=0)


METHODS = {
    # name: (description, builder(lib, rec, q) -> (X, y))
    "strong, SG 25": lambda lib, r, q, dt: (
        lib.euler_lagrange_matrix(sg(q, 25, dt), sg(q, 25, dt, 1), sg(q, 25, dt, 2)),
        r.tau,
    ),
    "weak, plain windows of 10, SG 9 for q̇": lambda lib, r, q, dt: (
        lib.integrated_euler_lagrange_matrix(r.t, q, sg(q, 9, dt, 1), sliding_windows(len(r.t), 10), rule="trapezoid"),
        integrate_forces(r.t, r.tau, sliding_windows(len(r.t), 10)),
    ),
    "weak, bump windows of 40 (stride 20), SG 15 for q̇": lambda lib, r, q, dt: (
        lib.integrated_euler_lagrange_matrix(
            r.t, q, sg(q, 15, dt, 1), sliding_windows(len(r.t), 40, 20), test_function="bump"
        ),
        integrate_forces(r.t, r.tau, sliding_windows(len(r.t), 40, 20), test_function="bump"),
    ),
    "weak, bump windows of 80 (stride 40), SG 25 for q, q̇": lambda lib, r, q, dt: (
        lib.integrated_euler_lagrange_matrix(
            r.t, sg(q, 25, dt), sg(q, 25, dt, 1), sliding_windows(len(r.t), 80, 40), test_function="bump"
        ),
        integrate_forces(r.t, r.tau, sliding_windows(len(r.t), 80, 40), test_function="bump"),
    ),
}


def main() -> None:
    scenario = get_scenario("two_segment")
    data = scenario.generate(seed=0, validation=False)
    robot = scenario.robot
    lib = PhysicalPCSLibrary(robot.segment_lengths, rotary_inertia="tied", rest_strain=False)
    true = lib.coefficients_from_parameters(
        robot.density, None, robot.youngs_modulus, robot.shear_modulus, robot.damping
    )
    sigma = np.tile(STRAIN_SIGMA, robot.n_segments)
    results = {}
    load_start = os.getloadavg()[0]
    for level in LEVELS:
        for name, build in METHODS.items():
            errs, secs = [], []
            for seed in SEEDS:
                rng = np.random.default_rng(seed)
                t0 = time.perf_counter()
                X, Y = [], []
                for rec in data.train:
                    q = rec.q + level * sigma * rng.standard_normal(rec.q.shape)
                    x, y = build(lib, rec, q, float(rec.t[1] - rec.t[0]))
                    X.append(x.reshape(-1, lib.n_coefficients_))
                    Y.append(np.asarray(y).reshape(-1))
                X, Y = np.vstack(X), np.concatenate(Y)
                scale = np.linalg.norm(X, axis=0)
                coef = lsq_linear(X / scale, Y, bounds=(lib.lower_bounds_ * scale, np.inf)).x / scale
                secs.append(time.perf_counter() - t0)
                errs.append(np.abs(coef - true) / true)
            errs = np.array(errs)
            results[(level, name)] = (
                np.median(errs),
                np.max(errs),
                np.max(errs[:, lib.stiffness_index_]),
                np.max(errs[:, [0, lib.euler_lagrange_names().index("rhoA_2")]]),
                np.mean(secs),
            )
            print(level, name, results[(level, name)], flush=True)
    body = [
        __doc__.split("Run:")[0].strip(),
        "",
        f"Noise seeds {list(SEEDS)}; errors pooled over seeds and parameters.  1-minute load average of the shared "
        f"2-core machine: {load_start:.1f} at the start, {os.getloadavg()[0]:.1f} at the end.",
        "",
        "| noise level | method | median rel. error | max rel. error | max stiffness error | max mass error "
        "| build+fit [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for (level, name), (med, mx, st, ms, sec) in results.items():
        body.append(f"| {level} | {name} | {med:.3f} | {mx:.3f} | {st:.3f} | {ms:.3f} | {sec:.1f} |")
    write_section(
        "physical_weak_form",
        "Physical library: strong vs weak form under strain noise (two_segment)",
        "\n".join(body),
        ".venv/bin/python benchmarks/physical_weak_form.py",
    )


if __name__ == "__main__":
    main()
