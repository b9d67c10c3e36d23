"""Optional dependencies (issue 28): the extras of pyproject.toml, the motion-capture path without
OpenCV, matplotlib and sympy, and the error that names the extra when one is missing.

Absence is simulated in a fresh interpreter with ``sys.modules[name] = None`` (what an uninstalled
module looks like to ``import``); the truth is pyproject.toml itself and the exit codes and messages.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from pcs_sindy.core.optional import EXTRAS, MissingDependencyError, require, require_installed

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

ROOT = Path(__file__).resolve().parents[1]
BLOCK = "import sys\nfor _m in ('cv2', 'matplotlib', 'sympy'):\n    sys.modules[_m] = None\n"


def _run(code: str, tmp_path: Path, timeout: float = 300) -> dict:
    proc = subprocess.run(
        [sys.executable, "-c", BLOCK + code], capture_output=True, text=True, timeout=timeout, cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_extras_match_the_table_and_the_plain_install_stays_complete():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    for module, (extra, dist) in EXTRAS.items():
        (req,) = extras[extra]
        assert req.startswith(dist), (module, req)
        assert req in project["dependencies"], f"{req} must stay a dependency: pip has no default extras"


def test_missing_modules_name_their_extra(tmp_path):
    code = """
import json
out = {}
for label, stmt in [
    ("vision", "from pcs_sindy.vision import MarkerPoseExtractor"),
    ("camera", "from pcs_sindy.core import Camera"),
    ("rendering", "from pcs_sindy.simulation.rendering import render_video"),
    ("plotting", "from pcs_sindy.plotting import plot_rollout"),
]:
    try:
        exec(stmt)
        out[label] = "imported"
    except ImportError as err:
        out[label] = [type(err).__name__, str(err)]
print(json.dumps(out))
"""
    out = _run(code, tmp_path)
    for label, extra in [("vision", "video"), ("camera", "video"), ("rendering", "video"), ("plotting", "plots")]:
        kind, message = out[label]
        assert kind == "MissingDependencyError", out[label]
        assert f'pip install "pcs_sindy[{extra}]"' in message, message


def test_motion_capture_from_the_command_line_needs_none_of_them(tmp_path):
    """fuse --markers-csv, fit --inputs and rollout --truth CSV --no-plot with cv2, matplotlib and sympy absent;
    the commands that need one stop with one line naming the extra."""
    code = """
import contextlib, io, json
from pcs_sindy.cli.main import main
from pcs_sindy.simulation import MocapScenario

rec = MocapScenario(duration=6.0).generate(seed=0)
rec.to_csv("take.csv")
codes, errors = {}, {}

def run(label, argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        codes[label] = main(argv)
    errors[label] = err.getvalue()

run("fuse", ["fuse", "--markers-csv", "take.csv", "--markers", "M1", "M2", "M3", "--rate", "100", "--units", "mm",
             "--input-columns", "u1", "u2", "--threshold", "0.2", "-o", "strains", "-q"])
from pcs_sindy.io import load
end = load("strains/segmentation.json").total_length_ * (1 - 1e-6)
open("tendons.json", "w").write(json.dumps({"type": "tendon", "end": [end, end], "side": [-1, 1],
                                             "offset": [0.012, 0.012]}))
fit = ["fit", "strains/take.npz", "--inputs", "strains/inputs/take.npz", "--actuation", "tendons.json"]
run("fit", [*fit, "-o", "model/", "-q"])
roll = ["rollout", "model/model.json", "--tau", "strains/inputs/take.npz", "--segmentation",
        "strains/segmentation.json", "--truth", "take.csv", "-q"]
run("rollout", [*roll, "--no-plot", "-o", "r1"])
run("rollout_plot", [*roll, "-o", "r2"])
run("extract", ["extract", "take.csv", "-o", "poses"])
run("monomial", [*fit, "--library", "monomial", "-o", "m2/"])
loaded = sorted(m for m in ("cv2", "matplotlib", "sympy") if sys.modules.get(m) is not None)
print(json.dumps({"codes": codes, "errors": errors, "loaded": loaded}))
"""
    out = _run(code, tmp_path)
    codes, errors = out["codes"], out["errors"]
    assert codes["fuse"] == codes["fit"] == codes["rollout"] == 0, errors
    assert (tmp_path / "r1" / "metrics.json").is_file() and not (tmp_path / "r1" / "rollout.png").exists()
    for label, extra in [("rollout_plot", "plots"), ("extract", "video"), ("monomial", "symbolic")]:
        assert codes[label] == 2, (label, errors[label])
        line = errors[label].strip()
        assert "\n" not in line and f'"pcs_sindy[{extra}]"' in line, line
    assert "--no-plot" in errors["rollout_plot"]
    assert out["loaded"] == []


def test_require_names_the_extra_but_not_a_missing_module_of_the_dependency(tmp_path, monkeypatch):
    with pytest.raises(MissingDependencyError, match=r"pip install no_such_module_here"):
        require("no_such_module_here", "a test")
    with pytest.raises(MissingDependencyError, match=r"a test needs .*no_such_module_here"):
        require_installed("no_such_module_here", "a test")
    # a module that is installed but whose own import fails is not reported as missing
    (tmp_path / "broken_dep_for_test.py").write_text("import no_such_inner_module_xyz\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ModuleNotFoundError) as err:
        require("broken_dep_for_test", "a test")
    assert not isinstance(err.value, MissingDependencyError) and err.value.name == "no_such_inner_module_xyz"
    assert require("json", "a test") is json
