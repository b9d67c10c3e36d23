"""The package's architecture, checked on the source: a rule per folder, no import cycle, no private crossings.

Every import of every module under ``pcs_sindy/`` is parsed with :mod:`ast`: ``import`` and
``from ... import`` statements at module level, inside functions and under ``if TYPE_CHECKING``,
``importlib.import_module("literal")`` calls, and the lazy export tables of the packages'
``__init__`` files (``lazy_loader.attach(__name__, submodules=..., submod_attrs=...)``: a package
exporting a name depends on the module that defines it).  Relative imports are resolved, and an
import of a name through a package's lazy table counts as an import of the module behind it.

From that graph the tests check:

* **one rule per folder** (:data:`RULES`): the stages a folder's modules may import besides
  their own.  The house reads like the pipeline, core -> vision -> fusion -> identification ->
  models -> control, with simulation, io, cli and plotting beside it;
* **no cycle between files** and **no cycle between stages**, function-local imports included;
* **no private name across modules**: ``from x import _name`` only inside one module, and a
  private module (``_x.py``) only from its own package;
* **one lazy loader**: every package ``__init__`` that exports names uses ``lazy_loader.attach``
  and defines no ``__getattr__`` of its own.
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

#: Each folder (stage) and the other stages its modules may import.  ``root`` is the package's
#: ``__init__``; ``version`` is ``pcs_sindy/_version.py``.
RULES: dict[str, tuple[str, ...]] = {
    # kinematics, trajectories, metrics, the camera model, the simulate contract: the ground floor
    "core": (),
    # frames -> marker poses: no dynamics, no segments
    "vision": ("core",),
    # marker poses -> segments and strains: no images, no dynamics
    "fusion": ("core",),
    # forward models, actuation maps, rollouts: built by identification, never importing it
    "models": ("core",),
    # strains + inputs -> coefficients; never the simulator (it is what checks identification)
    "identification": ("core", "models"),
    # controllers on identified models; the plant (the simulator) is passed in, never imported
    "control": ("core", "models"),
    # the stages composed into one Pipeline, and the rest length through the identified dynamics
    "pipeline": ("core", "vision", "fusion", "identification", "models"),
    # the ground truth: independent of identification, vision and fusion
    "simulation": ("core",),
    # figures from arrays
    "plotting": ("core",),
    # model and data files (classes are found through the REGISTRY's names, at load time)
    "io": ("core", "version"),
    # the command line: may use everything
    "cli": ("core", "vision", "fusion", "identification", "models", "control", "pipeline", "simulation", "plotting",
            "io", "version"),
    # the package root: lazy re-exports of every stage, and the file format behind the estimators' save/load
    "root": ("version", "core", "vision", "fusion", "identification", "models", "control", "pipeline", "simulation",
             "plotting", "io"),
    "version": (),
}  # fmt: skip

#: at most this many modules at the top level besides the subpackages (issue "One house")
MAX_TOP_LEVEL_MODULES = 6


def stage_of(module: str) -> str:
    """The folder (stage) of a dotted module name."""
    parts = module.split(".")
    if len(parts) == 1:
        return "root"
    return "version" if parts[1] == "_version" else parts[1]


@dataclass(frozen=True)
class Import:
    target: str  # absolute dotted name of the package module imported
    line: int
    local: bool  # inside a function (executed only when it runs)
    names: tuple[str, ...] = ()  # names imported from the target (from-imports)


def package_modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted name -> file of every module of the package."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _matches(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def _resolve_from(module: str, is_package: bool, level: int, name: str | None) -> str:
    if level == 0:
        return name or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level - 1 > len(base) - 1:
        raise ValueError(f"relative import beyond the top-level package in {module}")
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def lazy_table(source: str) -> tuple[list[str], dict[str, str]] | None:
    """``(submodules, {name: submodule})`` of a ``lazy_loader.attach`` call, None without one."""
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "attach"):
            continue
        kwargs = {kw.arg: kw.value for kw in node.keywords}
        args = list(node.args[1:]) + [None, None]
        subs = kwargs.get("submodules", args[0])
        attrs = kwargs.get("submod_attrs", args[1])
        submodules = list(ast.literal_eval(subs)) if subs is not None else []
        table = ast.literal_eval(attrs) if attrs is not None else {}
        return submodules, {name: sub for sub, names in table.items() for name in names}
    return None


class Graph:
    """Modules of the package and the imports between them."""

    def __init__(self, sources: dict[str, tuple[str, bool]]) -> None:
        #: module -> (source, is_package)
        self.sources = sources
        self.known = set(sources)
        self.tables = {m: lazy_table(src) for m, (src, is_pkg) in sources.items() if is_pkg}

    def exporter(self, package: str, name: str) -> str | None:
        """The module behind ``name`` in ``package``'s lazy table (followed through nested tables)."""
        table = self.tables.get(package)
        if not table:
            return None
        submodules, attrs = table
        if name in submodules:
            return f"{package}.{name}"
        sub = attrs.get(name)
        if sub is None:
            return None
        target = f"{package}.{sub}"
        return self.exporter(target, name) or target if target in self.tables else target

    def imports_of(self, module: str) -> list[Import]:
        source, is_package = self.sources[module]
        found: list[Import] = []

        def add(target: str, node: ast.AST, local: bool, names: tuple[str, ...] = ()) -> None:
            imp = Import(target, getattr(node, "lineno", 0), local, names)
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
                        if sub in self.known:
                            add(sub, child, local)
                        else:
                            add(self.exporter(base, alias.name) or base, child, local, (alias.name,))
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

        visit(ast.parse(source), False)
        table = self.tables.get(module)
        if table:  # a package depends on the modules behind its exports, when they are used
            submodules, attrs = table
            for sub in [*submodules, *attrs.values()]:
                add(f"{module}.{sub}", ast.Module(body=[], type_ignores=[]), True)
        return found

    def edges(self) -> dict[str, set[str]]:
        out: dict[str, set[str]] = {}
        for module in self.sources:
            out[module] = {i.target for i in self.imports_of(module) if i.target != module and i.target in self.known}
        return out


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one node (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = [0]

    def connect(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            connect(v)
    return found


def stage_edges(edges: dict[str, set[str]]) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for a, targets in edges.items():
        for b in targets:
            if stage_of(a) != stage_of(b):
                out.setdefault(stage_of(a), set()).add(stage_of(b))
    return out


def rule_violations(graph: Graph, module: str) -> list[str]:
    stage = stage_of(module)
    if stage not in RULES:
        return [f"{module} is in folder {stage!r}, which has no rule: add one to RULES in tests/test_layering.py"]
    problems = []
    for imp in graph.imports_of(module):
        target = stage_of(imp.target)
        if target == stage:
            continue
        if target not in RULES[stage]:
            problems.append(
                f"{module}:{imp.line} imports {imp.target} ({target}); {stage} may import only {list(RULES[stage])}"
            )
    return problems


def _is_private(part: str) -> bool:
    return part.startswith("_") and not part.startswith("__")


def private_violations(graph: Graph, module: str) -> list[str]:
    """Private names imported from another module, private modules imported from outside their package."""
    problems = []
    own_package = module if graph.sources[module][1] else module.rsplit(".", 1)[0]
    for imp in graph.imports_of(module):
        where = f"{module}:{imp.line}"
        for name in imp.names:
            if _is_private(name) and imp.target != module:
                problems.append(f"{where} imports the private name {name} from {imp.target}")
        parts = imp.target.split(".")
        for k, part in enumerate(parts):
            if _is_private(part):
                home = ".".join(parts[:k])  # the package the private module belongs to
                if not _matches(own_package, home):
                    problems.append(f"{where} imports {imp.target}, private to {home}")
                break
    return problems


def _graph_of_package() -> Graph:
    modules = package_modules()
    return Graph({m: (p.read_text(encoding="utf-8"), p.name == "__init__.py") for m, p in modules.items()})


GRAPH = _graph_of_package()
MODULES = sorted(GRAPH.sources)


def test_the_package_was_found():
    # guards against a path change turning every parametrized case below into nothing
    assert {"pcs_sindy.core.kinematics", "pcs_sindy.identification.regressor", "pcs_sindy.simulation.dynamics"} <= set(
        MODULES
    )


def test_the_top_level_shows_the_stages():
    modules = sorted(p.name for p in ROOT.glob("*.py"))
    assert len(modules) <= MAX_TOP_LEVEL_MODULES, modules
    packages = {p.name for p in ROOT.iterdir() if (p / "__init__.py").exists()}
    assert packages == set(RULES) - {"root", "version"}, "every subpackage needs exactly one rule in RULES"


@pytest.mark.parametrize("module", MODULES)
def test_module_follows_its_folders_rule(module):
    assert rule_violations(GRAPH, module) == []


@pytest.mark.parametrize("module", MODULES)
def test_module_imports_no_private_name_of_another_module(module):
    assert private_violations(GRAPH, module) == []


def test_no_cycle_between_files():
    assert cycles(GRAPH.edges()) == []


def test_no_cycle_between_stages():
    assert cycles(stage_edges(GRAPH.edges())) == []


def test_every_package_exports_through_the_one_lazy_loader():
    for module, (source, is_package) in GRAPH.sources.items():
        if not is_package:
            continue
        tree = ast.parse(source)
        own = [n.name for n in tree.body if isinstance(n, ast.FunctionDef) and n.name in ("__getattr__", "__dir__")]
        assert own == [], f"{module} defines {own}; use lazy_loader.attach"
        if any(isinstance(n, ast.ImportFrom) and n.level == 1 and n.module for n in tree.body):
            # an eager re-export loads the submodule with the package: only the root's two wiring imports may
            assert module == PACKAGE, f"{module} imports submodules eagerly; export them with lazy_loader.attach"
        table = GRAPH.tables[module]
        for name, target in ([] if table is None else [(n, f"{module}.{s}") for n, s in table[1].items()]):
            assert target in GRAPH.known, f"{module} exports {name} from {target}, which does not exist"


# ----------------------------------------------------------------------
# the checkers themselves must be able to fail
# ----------------------------------------------------------------------
def _synthetic(extra: dict[str, str]) -> Graph:
    sources = dict(GRAPH.sources)
    for module, source in extra.items():
        sources[module] = (textwrap.dedent(source), module.endswith("__init__") or module in GRAPH.tables)
    return Graph(sources)


def test_identification_importing_the_simulator_inside_a_function_is_reported():
    source = """
        import numpy as np

        def f():
            from ...simulation import get_scenario
            return get_scenario
        """
    graph = _synthetic({"pcs_sindy.identification.library.fake": source})
    (problem,) = rule_violations(graph, "pcs_sindy.identification.library.fake")
    assert "pcs_sindy.simulation.catalog" in problem and ":5 " in problem  # resolved through the lazy table


@pytest.mark.parametrize(
    ("module", "source"),
    [
        ("pcs_sindy.core.fake", "from ..vision import MarkerPoseExtractor"),
        ("pcs_sindy.vision.fake", "from ..fusion.kinematic_fusion import KinematicFusion"),
        ("pcs_sindy.fusion.fake", "import pcs_sindy.identification.regressor"),
        ("pcs_sindy.models.fake", "def f():\n    from ..identification import EulerLagrangeRegressor"),
        ("pcs_sindy.simulation.fake", "import importlib\nimportlib.import_module('pcs_sindy.models.forward')"),
        ("pcs_sindy.control.fake", "from pcs_sindy.simulation import PCSRobot"),
        ("pcs_sindy.identification.fake", "from ..io import save"),
        ("pcs_sindy.pipeline.fake", "from ..cli import commands"),
        ("pcs_sindy.plotting.fake", "from pcs_sindy import EulerLagrangeRegressor"),
    ],
)
def test_an_import_against_the_rules_is_reported(module, source):
    problems = rule_violations(_synthetic({module: source}), module)
    assert len(problems) == 1, problems


def test_allowed_imports_are_not_reported():
    graph = _synthetic(
        {
            "pcs_sindy.identification.fake": "from ..models.forward import ForwardModel\nfrom . import regressor",
            "pcs_sindy.pipeline.fake": "from ..vision import MarkerPoseExtractor\nfrom ..fusion import KinematicFusion",
        }
    )
    assert rule_violations(graph, "pcs_sindy.identification.fake") == []
    assert rule_violations(graph, "pcs_sindy.pipeline.fake") == []


def test_unclassified_folders_are_reported():
    graph = _synthetic({"pcs_sindy.brand_new.thing": "import numpy"})
    assert "has no rule" in rule_violations(graph, "pcs_sindy.brand_new.thing")[0]


def test_a_cycle_through_a_function_local_import_is_found():
    graph = _synthetic(
        {
            "pcs_sindy.fusion.fake_a": "from .fake_b import g",
            "pcs_sindy.fusion.fake_b": "def g():\n    from .fake_a import f",
        }
    )
    assert ["pcs_sindy.fusion.fake_a", "pcs_sindy.fusion.fake_b"] in cycles(graph.edges())


def test_a_cycle_between_stages_is_found():
    edges = {"pcs_sindy.models.a": {"pcs_sindy.core.b"}, "pcs_sindy.core.b": {"pcs_sindy.models.c"}}
    assert cycles(stage_edges(edges)) == [["core", "models"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_private_names_across_modules_are_reported():
    graph = _synthetic(
        {
            "pcs_sindy.fusion.fake": "from .merging import _helper\nfrom . import _frame_fit\n",
            "pcs_sindy.identification.fake": (
                "from ..models import _jit_rollout\nfrom ..fusion._frame_fit import fit_frame"
            ),
        }
    )
    problems = private_violations(graph, "pcs_sindy.fusion.fake")
    assert len(problems) == 1 and "_helper" in problems[0]  # its own package's private module is fine
    assert len(private_violations(graph, "pcs_sindy.identification.fake")) == 2


def test_relative_imports_resolve_like_python():
    with pytest.raises(ValueError, match="beyond the top-level package"):
        _resolve_from("pcs_sindy.core.fake", False, 4, "x")
    graph = _synthetic(
        {
            "pcs_sindy.identification.library.fake": (
                "from . import special\nfrom ...core import kinematics\n"
                "from ...core.trajectory import StrainTrajectory\n"
            )
        }
    )
    targets = [i.target for i in graph.imports_of("pcs_sindy.identification.library.fake")]
    assert targets == [
        "pcs_sindy.identification.library.special",
        "pcs_sindy.core.kinematics",
        "pcs_sindy.core.trajectory",
    ]


def test_names_imported_through_a_package_resolve_to_their_module():
    graph = _synthetic({"pcs_sindy.cli.fake": "from pcs_sindy import EulerLagrangeRegressor, save"})
    targets = {i.target for i in graph.imports_of("pcs_sindy.cli.fake")}
    assert targets == {"pcs_sindy.identification.regressor", "pcs_sindy.io.model_files"}


# ----------------------------------------------------------------------
# at run time: importing one side does not load the other
# ----------------------------------------------------------------------
_LOADED = "import sys, {0}; print(repr(sorted(m for m in sys.modules if m.startswith('pcs_sindy.'))))"


def _loaded_by(*modules):
    script = _LOADED.format(", ".join(modules))
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=300)
    return ast.literal_eval(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # fresh interpreters; the source checks above are the fast ones
def test_importing_one_stage_loads_no_other_side():
    sim = _loaded_by("pcs_sindy.simulation.dynamics", "pcs_sindy.simulation.catalog")
    assert "pcs_sindy.simulation.dynamics" in sim
    assert {stage_of(m) for m in sim} <= {"simulation", "core", "version"}, sim
    core = _loaded_by("pcs_sindy.identification.regressor", "pcs_sindy.fusion.kinematic_fusion", "pcs_sindy.vision")
    assert "pcs_sindy.identification.regressor" in core
    assert {stage_of(m) for m in core} <= {"identification", "models", "fusion", "vision", "core", "version"}, core
    root = _loaded_by("pcs_sindy")
    assert {stage_of(m) for m in root} <= {"core", "version"}, root
