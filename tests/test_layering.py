"""Import layering of the package, checked on the source.

Every ``import`` / ``from ... import`` statement of every module under
``pcs_sindy/`` (module level, inside functions, under ``if TYPE_CHECKING``, and
``importlib.import_module("literal")`` calls) is parsed with :mod:`ast`,
relative imports are resolved, and each imported package module is checked
against the layer table below.  A module that no layer claims is an error, so a
new module has to be placed in a layer before the suite passes.

Layers (what each may import besides itself):

- ground floor: ``kinematics`` and ``integration`` import nothing of the
  package, ``trajectory`` only ``kinematics``, ``metrics`` only the ground floor;
- infrastructure with no domain knowledge (``_numba_linalg``: a compiled dense
  LU; ``_saving``: the estimators' ``save``/``load`` mixin, which reaches the
  file-format module only inside its methods so that importing an estimator
  never loads the I/O layer);
- simulation (the ground truth) and the identification side never import each
  other; the simulator may use the camera model to render synthetic videos;
- vision (images → poses → strains) imports no dynamics;
- ``pipeline`` and ``rest_length`` compose vision and identification;
- ``control`` runs identified models on observations from vision; the plant
  (the simulator) is passed in, never imported;
- the top layer (CLI and its commands, data files, demo and report, plotting,
  model files, the package root's lazy re-exports) may import anything, and
  nothing below it imports it.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

PACKAGE = "pcs_sindy"
ROOT = Path(__file__).resolve().parents[1] / PACKAGE

GROUND = ("pcs_sindy.kinematics", "pcs_sindy.trajectory", "pcs_sindy.integration", "pcs_sindy.metrics")
INFRASTRUCTURE = ("pcs_sindy._numba_linalg", "pcs_sindy._saving")
SIMULATION = ("pcs_sindy.simulation",)
#: identification side; extend when a module is added (a prefix covers its submodules)
IDENTIFICATION = (
    "pcs_sindy.library",
    "pcs_sindy.optimizers",
    "pcs_sindy.least_squares",
    "pcs_sindy.regressor",
    "pcs_sindy.integrators",
    "pcs_sindy._jit_rollout",
    "pcs_sindy._jit_dynamics",
    "pcs_sindy.forward",
    "pcs_sindy.formulations",
    "pcs_sindy.recordings",
    "pcs_sindy.variable_projection",
    "pcs_sindy.identifiability",
    "pcs_sindy.rollout",
    "pcs_sindy.actuation",
)
VISION = (
    "pcs_sindy.vision",
    "pcs_sindy.camera",
    "pcs_sindy.calibration",
    "pcs_sindy.frame_source",
    "pcs_sindy.binarisation",
    "pcs_sindy.markers",
    "pcs_sindy.marker_chain",
    "pcs_sindy.frame_tracker",
    "pcs_sindy.extraction",
    "pcs_sindy.chain_geometry",
    "pcs_sindy.segment_merging",
    "pcs_sindy.shape_fit",
    "pcs_sindy.threshold_selection",
    "pcs_sindy.segmentation",
    "pcs_sindy._frame_fit",
)
#: vision and identification together: the pipeline, and the rest length corrected through the dynamics
COMPOSITION = ("pcs_sindy.pipeline", "pcs_sindy.rest_length")
#: controllers and closed loops: identified models observed through vision; the plant (the simulator) is passed in
CONTROL = ("pcs_sindy.control",)
TOP = (
    "pcs_sindy.cli",
    "pcs_sindy.commands",
    "pcs_sindy.datafiles",
    "pcs_sindy.demo",
    "pcs_sindy.report",
    "pcs_sindy.plotting",
    "pcs_sindy.persistence",
    "pcs_sindy",
)

LAYERS = {
    "ground": GROUND,
    "infrastructure": INFRASTRUCTURE,
    "simulation": SIMULATION,
    "identification": IDENTIFICATION,
    "vision": VISION,
    "composition": COMPOSITION,
    "control": CONTROL,
    "top": TOP,
}

#: ground-floor modules, one by one: what each may import of the package
GROUND_ALLOWED = {
    "pcs_sindy.kinematics": (),
    "pcs_sindy.integration": (),
    "pcs_sindy.trajectory": ("pcs_sindy.kinematics",),
    "pcs_sindy.metrics": GROUND,
}
#: other layers: the layers each may import (its own included)
LAYER_ALLOWED = {
    "infrastructure": ("ground", "infrastructure"),
    "simulation": ("ground", "infrastructure", "simulation"),
    "identification": ("ground", "infrastructure", "identification"),
    "vision": ("ground", "infrastructure", "vision"),
    "composition": ("ground", "infrastructure", "vision", "identification", "composition"),
    "control": ("ground", "infrastructure", "vision", "identification", "control"),
    "top": tuple(LAYERS),
}
#: single modules allowed across the table, each with the reason
EXCEPTIONS = {
    # synthetic videos are rendered through the same camera model the extractor inverts
    ("simulation", "pcs_sindy.camera"): "any",
    # the save/load mixin delegates to the file-format module at call time only
    ("pcs_sindy._saving", "pcs_sindy.persistence"): "local",
}


def _matches(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def _claims(prefix: str, module: str) -> bool:
    # the package root claims only itself, not its submodules
    return module == prefix if prefix == PACKAGE else _matches(module, prefix)


def layer_of(module: str) -> str | None:
    """Layer claiming ``module`` (longest prefix wins), None when unclassified."""
    best, best_len = None, -1
    for layer, prefixes in LAYERS.items():
        for prefix in prefixes:
            if _claims(prefix, module) and len(prefix) > best_len:
                best, best_len = layer, len(prefix)
    return best


@dataclass(frozen=True)
class Import:
    target: str  # absolute dotted name of the package module imported
    line: int
    local: bool  # inside a function (executed only when it runs)


def package_modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted name → file of every module of the package."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _resolve_from(module: str, is_package: bool, level: int, name: str | None) -> str:
    if level == 0:
        return name or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level - 1 > len(base) - 1:
        raise ValueError(f"relative import beyond the top-level package in {module}")
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def imports_of(module: str, source: str, known: set[str], *, is_package: bool = False) -> list[Import]:
    """Package modules imported by ``source`` (the text of ``module``).

    ``from X import name`` counts as importing ``X.name`` when that is a module of
    ``known`` and as importing ``X`` otherwise.
    """
    tree = ast.parse(source)
    found: list[Import] = []

    def add(target: str, node: ast.AST, local: bool) -> None:
        imp = Import(target, node.lineno, local)
        if _matches(target, PACKAGE) and imp not in found:
            found.append(imp)

    def visit(node: ast.AST, local: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = local or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, ast.Import):
                for alias in child.names:
                    add(alias.name, child, local)
            elif isinstance(child, ast.ImportFrom):
                base = _resolve_from(module, is_package, child.level, child.module)
                for alias in child.names:
                    sub = f"{base}.{alias.name}"
                    add(sub if sub in known else base, child, local)
            elif (
                isinstance(child, ast.Call)
                and isinstance(child.func, (ast.Attribute, ast.Name))
                and (child.func.attr if isinstance(child.func, ast.Attribute) else child.func.id)
                in ("import_module", "__import__")
                and child.args
                and isinstance(child.args[0], ast.Constant)
                and isinstance(child.args[0].value, str)
            ):
                add(child.args[0].value, child, local)
            visit(child, inner)

    visit(tree, False)
    return found


def violations(module: str, source: str, known: set[str], *, is_package: bool = False) -> list[str]:
    """Layering violations of one module's source, as readable messages."""
    layer = layer_of(module)
    if layer is None:
        return [f"{module} is in no layer: add it to one of the layer lists in tests/test_layering.py"]
    problems = []
    for imp in imports_of(module, source, known, is_package=is_package):
        target = imp.target
        if _matches(target, module) and target != PACKAGE:
            continue  # its own submodules
        target_layer = layer_of(target)
        where = f"{module}:{imp.line} imports {target}"
        if target_layer is None:
            problems.append(f"{where}, which is in no layer")
            continue
        rule = EXCEPTIONS.get((module, target), EXCEPTIONS.get((layer, target)))
        if rule == "any" or (rule == "local" and imp.local):
            continue
        if layer == "ground":
            allowed = next(v for k, v in GROUND_ALLOWED.items() if _matches(module, k))
            if not any(_matches(target, a) for a in allowed):
                problems.append(f"{where}: the ground-floor module may import only {list(allowed) or 'nothing'}")
        elif target_layer not in LAYER_ALLOWED[layer]:
            problems.append(f"{where} ({target_layer}); {layer} may import only {list(LAYER_ALLOWED[layer])}")
    return problems


MODULES = package_modules()
KNOWN = set(MODULES)


def test_the_package_was_found():
    # guards against a path change turning every parametrized case below into nothing
    assert {"pcs_sindy.kinematics", "pcs_sindy.regressor", "pcs_sindy.simulation.dynamics"} <= KNOWN


@pytest.mark.parametrize("module", sorted(MODULES))
def test_module_respects_the_layering(module):
    path = MODULES[module]
    source = path.read_text(encoding="utf-8")
    assert violations(module, source, KNOWN, is_package=path.name == "__init__.py") == []


def test_every_ground_floor_module_has_its_own_rule():
    assert set(GROUND_ALLOWED) == set(GROUND)


# ----------------------------------------------------------------------
# the checker itself must be able to fail
# ----------------------------------------------------------------------
SYNTHETIC_KNOWN = KNOWN | {"pcs_sindy.simulation.fake", "pcs_sindy.library.fake"}


def _check(module, source, **kw):
    return violations(module, textwrap.dedent(source), SYNTHETIC_KNOWN, **kw)


def test_simulation_importing_the_regressor_inside_a_function_is_reported():
    source = """
        import numpy as np

        def f():
            from ..regressor import EulerLagrangeRegressor
            return EulerLagrangeRegressor
        """
    (problem,) = _check("pcs_sindy.simulation.fake", source)
    assert "pcs_sindy.regressor" in problem and ":5 " in problem


def test_identification_importing_the_simulator_is_reported():
    for source in (
        "from pcs_sindy.simulation import get_scenario",
        "import pcs_sindy.simulation.dynamics",
        "from ..simulation import dynamics",  # resolves to pcs_sindy.simulation.dynamics from library.fake
        "import importlib\nimportlib.import_module('pcs_sindy.simulation.scenarios')",
    ):
        problems = _check("pcs_sindy.library.fake", source)
        assert len(problems) == 1 and "pcs_sindy.simulation" in problems[0], source
    # and the same module importing its own side is fine
    assert _check("pcs_sindy.library.fake", "from ..optimizers import StiffnessThresholdOptimizer") == []


def test_ground_floor_vision_and_core_violations_are_reported():
    assert _check("pcs_sindy.kinematics", "from .trajectory import StrainTrajectory")
    assert _check("pcs_sindy.trajectory", "from .kinematics import PlanarPCS") == []
    assert _check("pcs_sindy.metrics", "from .segmentation import KinematicFusion")
    assert _check("pcs_sindy.vision", "from .library import PhysicalPCSLibrary")
    assert _check("pcs_sindy.segmentation", "from .simulation.dynamics import PCSRobot")
    assert _check("pcs_sindy.regressor", "from .plotting import plot_rollout")
    assert _check("pcs_sindy.regressor", "def f():\n    from . import cli")
    assert _check("pcs_sindy.pipeline", "from .persistence import save")
    assert _check("pcs_sindy.regressor", "from pcs_sindy import EulerLagrangeRegressor")  # the root re-exports all


def test_saving_reaches_persistence_only_at_call_time():
    assert _check("pcs_sindy._saving", "def save():\n    from .persistence import save") == []
    assert _check("pcs_sindy._saving", "from .persistence import save")


def test_unclassified_modules_are_reported():
    assert "in no layer" in _check("pcs_sindy.brand_new", "import numpy")[0]
    assert "in no layer" in _check("pcs_sindy.regressor", "from .brand_new import thing")[0]


def test_relative_imports_resolve_like_python():
    with pytest.raises(ValueError, match="beyond the top-level package"):
        imports_of("pcs_sindy.library.fake", "from ...x import y", SYNTHETIC_KNOWN)
    imps = imports_of(
        "pcs_sindy.library.fake",
        "from . import special\nfrom .. import kinematics\nfrom ..trajectory import StrainTrajectory\n",
        SYNTHETIC_KNOWN,
    )
    assert [i.target for i in imps] == ["pcs_sindy.library.special", "pcs_sindy.kinematics", "pcs_sindy.trajectory"]
    pkg = imports_of("pcs_sindy.library", "from .physical import PhysicalPCSLibrary", KNOWN, is_package=True)
    assert [i.target for i in pkg] == ["pcs_sindy.library.physical"]


# ----------------------------------------------------------------------
# at run time: importing one side does not load the other
# ----------------------------------------------------------------------
_LOADED = "import sys, {0}; print(repr(sorted(m for m in sys.modules if m.startswith('pcs_sindy.'))))"


def _loaded_by(*modules):
    script = _LOADED.format(", ".join(modules))
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=300)
    return ast.literal_eval(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # two fresh interpreters; the source check above is the fast one
def test_importing_the_simulator_or_the_core_loads_no_other_side():
    sim = _loaded_by("pcs_sindy.simulation.dynamics", "pcs_sindy.simulation.scenarios")
    assert "pcs_sindy.simulation.dynamics" in sim
    assert [m for m in sim if layer_of(m) in ("identification", "vision", "composition", "top")] == []
    core = _loaded_by("pcs_sindy.regressor", "pcs_sindy.segmentation", "pcs_sindy.vision", "pcs_sindy.pipeline")
    assert "pcs_sindy.regressor" in core
    assert [m for m in core if layer_of(m) in ("simulation", "top")] == []
