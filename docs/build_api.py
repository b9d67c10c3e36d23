"""Generate ``docs/api.md``, the API reference, from the package's docstrings.

Run ``.venv/bin/python docs/build_api.py`` (or ``make docs``) after changing a
public docstring; ``tests/test_docs.py`` checks that the committed file is up
to date.  Plain ``inspect`` instead of Sphinx: the reference is a single
Markdown page readable on GitHub, and no extra dependency is needed.
"""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path

# (module, names) in pipeline order; names must be public attributes of the module.
SECTIONS: list[tuple[str, str, list[str]]] = [
    ("Pipeline", "pcs_sindy.pipeline", ["make_pcs_pipeline", "PCSPipeline", "recording_groups"]),
    ("Vision: videos → poses", "pcs_sindy.vision", ["MarkerPoseExtractor"]),
    ("Camera", "pcs_sindy.camera", ["Camera"]),
    ("Segmentation: poses → strains", "pcs_sindy.segmentation", ["KinematicFusion"]),
    ("Choosing the threshold", "pcs_sindy.threshold_selection", ["threshold_sweep", "select_threshold"]),
    (
        "Marker chain geometry",
        "pcs_sindy.chain_geometry",
        ["chain_poses", "segment_strains", "estimate_total_length", "deformed_lengths"],
    ),
    ("Segment merging (Algorithm 1)", "pcs_sindy.segment_merging", ["fuse_segments", "strain_distances", "merge_runs"]),
    ("Least-squares shape fit", "pcs_sindy.shape_fit", ["fit_strains_least_squares", "refine_boundaries"]),
    ("Library", "pcs_sindy.library", ["PCSLagrangianLibrary", "PhysicalPCSLibrary", "StackedEulerLagrangeLibrary"]),
    ("Optimizer", "pcs_sindy.optimizers", ["StiffnessThresholdOptimizer"]),
    ("Regressor: strains + τ → model", "pcs_sindy.regressor", ["EulerLagrangeRegressor"]),
    (
        "Actuation: inputs → generalised forces",
        "pcs_sindy.actuation",
        ["TendonActuation", "PressureActuation", "LinearActuation", "IdentityActuation", "actuation_from_layout"],
    ),
    ("Library contract", "pcs_sindy.library.base", ["LagrangianLibrary"]),
    ("Formulations", "pcs_sindy.formulations", ["regression", "weak_rows", "integrate_forces", "sliding_windows"]),
    ("Identifiability", "pcs_sindy.identifiability", ["identifiability", "report"]),
    ("Forward models and rollouts", "pcs_sindy.forward", ["ForwardModel", "LumpedPCSModel", "CallableModel"]),
    ("The simulate contract", "pcs_sindy.integration", ["SimulationError", "canonical_method"]),
    (
        "Control",
        "pcs_sindy.control",
        ["SetpointRegulator", "ComputedTorqueController", "TipRegulator", "closed_loop", "ClosedLoopResult"],
    ),
    ("Model files", "pcs_sindy.persistence", ["save", "load"]),
    ("Kinematics", "pcs_sindy.kinematics", ["PlanarPCS", "forward_kinematics", "forward_kinematics_jacobian"]),
    ("Trajectories", "pcs_sindy.trajectory", ["PoseTrajectory", "StrainTrajectory"]),
    ("Metrics", "pcs_sindy.metrics", ["end_effector_errors", "distributed_errors", "rollout_scorer"]),
    (
        "Simulation (ground truth)",
        "pcs_sindy.simulation",
        ["get_scenario", "list_scenarios", "PCSRobot", "TendonActuation", "PressureActuation", "render_video"],
    ),
    ("Degraded footage", "pcs_sindy.simulation.nuisances", ["Nuisances"]),
    ("Calibration boards", "pcs_sindy.simulation.checkerboard", ["render_checkerboard"]),
    (
        "Plotting",
        "pcs_sindy.plotting",
        [
            "plot_strain_distance_profile",
            "plot_error_vs_segments",
            "plot_rollout",
            "plot_end_effector",
            "plot_stills",
            "animate_rollout",
        ],
    ),
]


def _signature(obj: object, name: str) -> str:
    try:
        sig = str(inspect.signature(obj))
    except (TypeError, ValueError):
        sig = "(...)"
    return f"{name}{sig}"


_ENTRY_SECTIONS = {"Parameters", "Returns", "Yields", "Raises", "Attributes", "Other Parameters", "Warns"}


def _doc(obj: object) -> str:
    """The docstring with numpydoc section underlines turned into bold headings.

    Markdown would read ``Parameters`` over a line of dashes as a heading of the
    page outline; bold text keeps the outline to the API names.
    """
    lines = (inspect.getdoc(obj) or "(no docstring)").strip().splitlines()
    out: list[str] = []
    in_list = False  # inside a numpydoc section of "name : type" entries
    k = 0
    while k < len(lines):
        line = lines[k]
        underline = lines[k + 1].strip() if k + 1 < len(lines) else ""
        if line.strip() and underline and set(underline) == {"-"} and len(underline) >= len(line.strip()) - 1:
            out += [f"**{line.strip()}**", ""]
            in_list = line.strip() in _ENTRY_SECTIONS
            k += 2
            continue
        if in_list and line and not line[0].isspace():
            name, _, kind = line.partition(" : ")
            line = f"- **{name.strip()}**" + (f" : {kind.strip()}" if kind else "")
        out.append(line)
        k += 1
    return "\n".join(out)


def _public_methods(cls: type) -> list[tuple[str, object]]:
    out = []
    for name, member in vars(cls).items():
        if name.startswith("_") or not (inspect.isfunction(member) or isinstance(member, (classmethod, staticmethod))):
            continue
        func = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
        if func.__doc__:
            out.append((name, func))
    return out


def render() -> str:
    """The Markdown text of the API reference."""
    lines = [
        "# API reference",
        "",
        "Generated from the docstrings by `docs/build_api.py`; do not edit by hand.",
        "",
    ]
    for title, module_name, names in SECTIONS:
        try:
            module = importlib.import_module(module_name)
        except ImportError:
            continue
        present = [n for n in names if hasattr(module, n)]
        if not present:
            continue
        lines += [f"## {title} (`{module_name}`)", ""]
        for name in present:
            obj = getattr(module, name)
            kind = "class" if inspect.isclass(obj) else "function"
            lines += [f"### `{name}`", "", "```python", f"{kind} {_signature(obj, name)}", "```", "", _doc(obj), ""]
            if inspect.isclass(obj):
                for meth_name, meth in _public_methods(obj):
                    lines += [
                        f"#### `{name}.{meth_name}`",
                        "",
                        "```python",
                        _signature(meth, meth_name),
                        "```",
                        "",
                        _doc(meth),
                        "",
                    ]
    return "\n".join(lines).rstrip() + "\n"


def main() -> int:
    target = Path(__file__).with_name("api.md")
    target.write_text(render(), encoding="utf-8")
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
