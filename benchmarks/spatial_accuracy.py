"""Accuracy of the spatial (3-D) PCS code at every strain magnitude, against extended precision.

Three measurements, each against mpmath (no number here comes from the code under test alone):

1. The tangent coefficient ``c1 = c'(u)/u = (3 sin u − u cos u − 2u)/u⁵`` of the SE(3) exponential's
   derivatives, evaluated in double precision by its closed form (what a simulator without series
   switching computes) and by ``pcs_sindy.core.tangent_coefficients``, against mpmath (120 digits).
2. Tip positions of :class:`pcs_sindy.core.SpatialPCS` against ``tests/spatial_reference.py``'s
   ``reference_pose`` (mpmath matrix exponentials, 40 digits).
3. ``M``, ``C q̇``, ``G`` and the accelerations ``q̈`` of :class:`pcs_sindy.simulation.SpatialPCSRobot`
   against the reference's ``reference_terms`` and ``reference_accelerations`` (30 digits; the
   Lagrangian differentiated from the energies), on a 2-segment robot whose bending and twist
   strains have the given magnitude (shear and axial ``min(magnitude, 0.05)``), random rates and
   forces.

Errors are relative to the largest entry of the reference.  Run:
``.venv/bin/python benchmarks/spatial_accuracy.py [--write]`` (about 30 s; prints a Markdown table,
``--write`` records it in docs/results.md).
"""

from __future__ import annotations

import sys
from pathlib import Path

import mpmath
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from spatial_reference import reference_accelerations, reference_pose, reference_terms  # noqa: E402

from pcs_sindy.core import SpatialPCS, tangent_coefficients  # noqa: E402
from pcs_sindy.simulation import SpatialPCSRobot  # noqa: E402

from _results import write_section  # noqa: E402

MAGNITUDES = [1e-9, 1e-7, 1e-5, 1e-3, 1e-1, 1.0, 10.0]
LENGTHS = [0.1, 0.12]
PARAMS = dict(rho=1070.0, radius=0.02, youngs=1e6, shear=3e5, gravity=(1.0, 9.81, -2.0), n_quadrature=4)


def rel(a, b) -> float:
    b = np.asarray(b, dtype=float)
    return float(np.abs(np.asarray(a) - b).max() / np.abs(b).max())


def c1_errors(u: float) -> tuple[float, float]:
    with mpmath.workdps(120):  # the closed form cancels ~5 |log10 u| digits
        x = mpmath.mpf(u)
        exact = (3 * mpmath.sin(x) - x * mpmath.cos(x) - 2 * x) / x**5
        exact = float(exact)
    closed = (3.0 * np.sin(u) - u * np.cos(u) - 2.0 * u) / u**5
    switched = tangent_coefficients(np.array(u), order=1)[4]
    return abs(closed - exact) / abs(exact), abs(float(switched) - exact) / abs(exact)


def main(write: bool) -> None:
    damping = np.full(12, 1e-3)
    robot = SpatialPCSRobot(
        LENGTHS,
        density=PARAMS["rho"],
        youngs_modulus=PARAMS["youngs"],
        shear_modulus=PARAMS["shear"],
        radius=PARAMS["radius"],
        damping=damping,
        gravity=PARAMS["gravity"],
        n_quadrature=PARAMS["n_quadrature"],
    )
    kinematics = SpatialPCS(tuple(LENGTHS))
    header = [
        "| strain magnitude (and u of c1) | c1, closed form in double | c1, package | tip position | M | C q̇ | G | q̈ |",
        "|---|---|---|---|---|---|---|---|",
    ]
    print("\n".join(header))
    rows = []
    for k, mag in enumerate(MAGNITUDES):
        rng = np.random.default_rng(100 + k)
        scale = np.array([mag, mag, mag, min(mag, 0.05), min(mag, 0.05), min(mag, 0.05)] * 2)
        q = rng.normal(size=12) * scale
        qd = rng.normal(size=12) * np.array([3.0, 3.0, 3.0, 0.1, 0.1, 0.1] * 2)
        tau = rng.normal(size=12) * 1e-2
        c1_closed, c1_pkg = c1_errors(mag)
        tip_ref = reference_pose(q, LENGTHS, sum(LENGTHS), dps=40)[0]
        tip = kinematics.forward_kinematics(q, [sum(LENGTHS)])[0][0]
        ref = reference_terms(q, qd, LENGTHS, damping=damping, dps=30, **PARAMS)
        qdd = reference_accelerations(q, qd, tau, LENGTHS, damping=damping, dps=30, **PARAMS)
        row = [
            f"{mag:g}",
            f"{c1_closed:.1e}",
            f"{c1_pkg:.1e}",
            f"{rel(tip, tip_ref):.1e}",
            f"{rel(robot.mass_matrix(q), ref['M']):.1e}",
            f"{rel(robot.coriolis_forces(q, qd), ref['coriolis']):.1e}",
            f"{rel(robot.gravity_forces(q), ref['gravity']):.1e}",
            f"{rel(robot.forward_dynamics(q, qd, tau), qdd):.1e}",
        ]
        rows.append("| " + " | ".join(row) + " |")
        print(rows[-1], flush=True)
    body = "\n".join(
        [
            f"Two segments (L = {LENGTHS} m), bending and twist strains of the given magnitude, shear and axial",
            "min(magnitude, 0.05), random rates and forces; relative errors against mpmath (c1: 120 digits at",
            "u = magnitude; tip: tests/spatial_reference.py's reference_pose, 40 digits; M, C q̇, G, q̈: its",
            "reference_terms and reference_accelerations, 30 digits).",
            "",
            *header,
            *rows,
        ]
    )
    if write:
        write_section(
            "spatial_accuracy",
            "Spatial PCS accuracy at every strain magnitude (issue 26)",
            body,
            ".venv/bin/python benchmarks/spatial_accuracy.py --write",
        )


if __name__ == "__main__":
    main("--write" in sys.argv[1:])
