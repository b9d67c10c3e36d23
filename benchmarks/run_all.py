"""Run every benchmark in turn (``make bench``); each writes its own section of docs/results.md.

Paper-scale runs take a long time on 2 cores (scenario simulation is cached under
``~/.cache/pcs_sindy`` after the first run). Pass benchmark names to run a subset.

``lowest_versions`` (a fresh venv with every dependency at its lower bound, needs
PyPI) is not part of ``make bench``: run it with ``make lowest-versions``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ORDER = [
    "simulation_speed",
    "extraction_speed",
    "degraded_footage",
    "foreign_footage",
    "calibration_round_trip",
    "streaming_state_estimation",
    "library_build",
    "maintained_alternatives",
    "physical_library",
    "physical_weak_form",
    "kinematic_fusion",
    "dynamic_identification",
    "rollout_speed",
    "noise_robustness",
    "end_to_end",
    "monomial_divergence",
    "rest_length",
    "rest_length_estimate",
    "model_selection",
    "pysindy_optimizers",
    "actuation",
    "control",
    "control_actuated",
    "servo_tendon",
    "static_holds",
    "control_targets",
    "cli_startup",
    "atomic_writes",
    "position_fusion_speed",
    "real_robots",
    "spatial_rollout_speed",
    "spatial_accuracy",
    "spatial_fusion",
    "spatial_identification",
    "spatial_tendons_statics",
]
# arguments of the benchmarks that write docs/results.md only when asked to
ARGS = {
    "position_fusion_speed": ["--write"],
    "real_robots": ["--write", "--plots", "docs"],
    "spatial_rollout_speed": ["--write"],
    "spatial_accuracy": ["--write"],
    "spatial_identification": ["--write"],
    "spatial_tendons_statics": ["--write"],
}
# benchmarks outside make bench (run on their own)
SEPARATE = ["lowest_versions"]


def main(names: list[str]) -> int:
    chosen = names or [n for n in ORDER if (HERE / f"{n}.py").exists()]
    unknown = [n for n in chosen if not (HERE / f"{n}.py").exists() or n not in ORDER + SEPARATE]
    if unknown:
        print(f"unknown benchmark(s): {unknown}; available: {ORDER + SEPARATE}")
        return 2
    failed = []
    for name in chosen:
        print(f"== {name}", flush=True)
        if subprocess.call([sys.executable, str(HERE / f"{name}.py"), *ARGS.get(name, [])]) != 0:
            failed.append(name)
    if failed:
        print(f"failed: {failed}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
