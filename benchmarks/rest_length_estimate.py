"""Rest length without being told: poses alone against poses corrected by the identified dynamics.

Cases:
- two_segment (seed 0, the 8 noise-free training recordings; and with the seed's pose noise);
- a soft one-segment robot (0.1 m, E = 1.73 kPa) that gravity stretches by 3 % when it
  hangs, bent by held random torques only (no shear or axial actuation), 4 x 0.3 s at 1 kHz.

"kinematic": the median deformed length of the marker chain (what ``KinematicFusion`` uses
when given no length) with its jackknife standard error over recordings; "corrected":
``pcs_sindy.pipeline.rest_length.estimate_rest_length`` (fusion, weak-form physical fit with
``rest_strain=True``, lengths rescaled by the identified axial rest strain, refit), with
its jackknife standard error.

Run: ``.venv/bin/python benchmarks/rest_length_estimate.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_rest_length import soft_hanging_robot  # noqa: E402  (the same robot as the test)

from pcs_sindy.core import PoseTrajectory  # noqa: E402
from pcs_sindy.fusion import KinematicFusion  # noqa: E402
from pcs_sindy.pipeline import estimate_rest_length  # noqa: E402
from pcs_sindy.simulation import get_scenario  # noqa: E402

from _results import write_section  # noqa: E402


def row(label: str, truth: float, target: float, poses, taus) -> str:
    kin = KinematicFusion().fit(poses)
    start = time.perf_counter()
    est = estimate_rest_length(poses, taus)
    elapsed = time.perf_counter() - start
    err = 100 * (est.total_length / truth - 1)
    line = (
        f"| {label} | {1e3 * truth:.1f} | {1e3 * kin.total_length_:.2f} ± {1e3 * kin.total_length_std_:.2f} "
        f"({100 * (kin.total_length_ / truth - 1):+.2f} %) | {1e3 * est.total_length:.3f} ± {1e3 * est.std:.3f} "
        f"({err:+.3f} %) | {', '.join(f'{1e3 * v:.2f}' for v in est.segment_lengths)} | "
        f"{'met' if abs(err) <= target else 'MISSED'} (±{target:g} %) | {elapsed:.1f} |"
    )
    print(line, flush=True)
    return line


def main() -> None:
    rows = []
    for noise, label in ((None, "two_segment, noise-free"), ("seed", "two_segment, seed noise (0.1 mm, 0.5°)")):
        data = get_scenario("two_segment").generate(seed=0, noise=noise)
        poses = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
        rows.append(row(label, 0.17, 0.5, poses, [r.tau for r in data.train]))
    poses, taus, hanging = soft_hanging_robot()
    rows.append(row(f"soft one-segment robot, {100 * hanging:.1f} % stretched hanging", 0.1, 1.0, poses, taus))
    body = "\n".join(
        [
            __doc__.split("Run:")[0].split("\n\n", 1)[1].strip(),
            "",
            "| case | true rest length [mm] | kinematic [mm] | "
            "corrected [mm] | segment lengths [mm] | target | time [s] |",
            "|---|---|---|---|---|---|---|",
            *rows,
            "",
            "The kinematic standard error covers the scatter between recordings, not the bias of a mean stretch: "
            "poses alone cannot tell a constant stretch from length.",
        ]
    )
    write_section(
        "rest_length_estimate",
        "Rest length without being told",
        body,
        ".venv/bin/python benchmarks/rest_length_estimate.py",
    )


if __name__ == "__main__":
    main()
