"""Check the lower bounds in pyproject.toml: install every dependency at its lower bound and run the fast tests.

Every requirement of ``[project] dependencies`` and of the ``test`` extra must
have a ``>=`` lower bound; the script turns each into ``name==bound.*`` in a pip
constraints file, creates a temporary virtual environment, installs the package
with its ``test`` extra under those constraints (dependencies of dependencies
are left to pip's resolver) and runs ``pytest -m "not slow"`` on the working
tree.  A dependency that needs a newer version than its bound says, or an
install that cannot be resolved, therefore fails the run.

The result (date, machine, installed versions, test summary) is written to the
``lowest_versions_py3.X`` section of docs/results.md (one per Python minor
version) unless ``--no-write``.

Needs network access to the package index.  ``make lowest-versions`` runs it.

Usage::

    python benchmarks/lowest_versions.py [--python python3.11] [--keep] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_section  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
_REQ = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(\[[^\]]*\])?\s*(.*?)\s*(;.*)?$")
_LOWER = re.compile(r">=\s*([0-9][^,\s]*)")


def lower_bounds(pyproject: Path, extras: tuple[str, ...] = ("test",)) -> dict[str, str]:
    """Package name → lower bound of every runtime requirement and of the given extras.

    Raises
    ------
    ValueError
        If a requirement has no ``>=`` lower bound.
    """
    project = tomllib.loads(pyproject.read_text())["project"]
    reqs = list(project["dependencies"])
    for extra in extras:
        reqs += project.get("optional-dependencies", {})[extra]
    bounds = {}
    for req in reqs:
        m = _REQ.match(req)
        low = _LOWER.search(m.group(3)) if m else None
        if low is None:
            raise ValueError(f"requirement {req!r} in {pyproject} has no '>=' lower bound")
        bounds[m.group(1).lower()] = low.group(1)
    return bounds


def _run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    print("+", " ".join(cmd), flush=True)
    return subprocess.run(cmd, text=True, capture_output=True, **kw)


def _tail(text: str, n: int = 25) -> str:
    return "\n".join(text.strip().splitlines()[-n:])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--python", default=sys.executable, help="interpreter of the temporary venv")
    parser.add_argument("--keep", action="store_true", help="keep the temporary directory (its path is printed)")
    parser.add_argument("--no-write", action="store_true", help="do not write docs/results.md")
    parser.add_argument("--pytest-args", default='-m "not slow" -n 2 -q -p no:cacheprovider')
    args = parser.parse_args(argv)

    try:
        version = _run([args.python, "-c", "import platform; print(platform.python_version())"])
    except OSError as err:
        raise SystemExit(f"--python {args.python!r} does not run: {err}") from err
    if version.returncode != 0:
        raise SystemExit(f"--python {args.python!r} does not run: {version.stderr.strip()}")
    python_version = "Python " + version.stdout.strip()

    bounds = lower_bounds(ROOT / "pyproject.toml")
    tmp = Path(tempfile.mkdtemp(prefix="pcs_sindy_lowest_"))
    venv, src = tmp / "venv", tmp / "src"
    # the package is built from a copy so that the build leaves nothing in the working tree
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "pcs_sindy", src / "pcs_sindy", ignore=shutil.ignore_patterns("__pycache__"))
    constraints = tmp / "constraints.txt"
    # ``==bound.*``: the release series the bound names (``numpy>=1.24`` → the newest 1.24.x, ``opencv>=4.8`` →
    # 4.8.0.x): a bound means that series, and its bug-fix releases are what a user of it installs
    constraints.write_text("".join(f"{name}=={version}.*\n" for name, version in bounds.items()))
    py = venv / "bin" / "python"
    t0 = time.perf_counter()
    outcome, detail, versions, summary = "failed", "", {}, ""
    try:
        steps = [
            [args.python, "-m", "venv", str(venv)],
            [str(py), "-m", "pip", "install", "--quiet", "--upgrade", "pip"],
            [str(py), "-m", "pip", "install", "--quiet", "-c", str(constraints), f"{src}[test]"],
        ]
        for cmd in steps:
            res = _run(cmd)
            if res.returncode != 0:
                detail = f"`{' '.join(cmd[-4:])}` failed:\n\n```\n{_tail(res.stdout + res.stderr)}\n```"
                outcome = "install failed"
                break
        else:
            freeze = _run([str(py), "-m", "pip", "list", "--format=freeze"]).stdout
            versions = dict(line.split("==", 1) for line in freeze.splitlines() if "==" in line)
            versions = {k.lower(): v for k, v in versions.items()}
            env = dict(os.environ)
            # compiled kernels and generated libraries of these versions stay out of the working tree's caches
            env["NUMBA_CACHE_DIR"] = str(tmp / "numba_cache")
            env["PCS_SINDY_CACHE"] = str(tmp / "pcs_sindy_cache")
            env.pop("PYTHONPATH", None)
            res = _run([str(py), "-m", "pytest", *shlex.split(args.pytest_args)], cwd=ROOT, env=env)
            summary = _tail(res.stdout, 1)
            outcome = "passed" if res.returncode == 0 else "tests failed"
            if res.returncode != 0:
                detail = f"```\n{_tail(res.stdout + res.stderr, 40)}\n```"
    finally:
        elapsed = time.perf_counter() - t0
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)

    rows = [f"| {name} | {bound} | {versions.get(name, '–')} |" for name, bound in sorted(bounds.items())]
    extra = sorted(set(versions) & {"llvmlite", "derivative", "threadpoolctl", "contourpy"})
    rows += [f"| {name} (dependency of a dependency) | – | {versions[name]} |" for name in extra]
    body = "\n".join(
        [
            "Every requirement of `pyproject.toml` (runtime and `test` extra) installed at its lower bound "
            "(`name==bound.*` constraints: the newest bug-fix release of the bound's series; everything else "
            f"left to pip) in a fresh venv ({python_version}); then `pytest {args.pytest_args}` on the working "
            "tree. Why each bound is what it is: the comments in `pyproject.toml`.",
            "",
            f"Outcome: **{outcome}**{f' — {summary}' if summary else ''} ({elapsed:.0f} s including the install).",
            "",
            "| package | lower bound | installed |",
            "|---|---|---|",
            *rows,
            *(["", detail] if detail else []),
        ]
    )
    print(body)
    if not args.no_write:
        short = python_version.split()[-1].rsplit(".", 1)[0]  # one section per Python minor version
        write_section(
            f"lowest_versions_py{short}",
            f"Lowest supported dependency versions, Python {short}",
            body,
            " ".join(["python benchmarks/lowest_versions.py", *(argv if argv is not None else sys.argv[1:])]),
        )
    return 0 if outcome == "passed" else 1


if __name__ == "__main__":
    sys.exit(main())
