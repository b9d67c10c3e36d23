"""What each dependency costs on disk, and what a motion-capture-only user needs.

Reads ``[project] dependencies`` and the extras ``video``, ``plots`` and ``symbolic`` of
``pyproject.toml``, resolves each requirement's installed dependencies (``importlib.metadata``,
markers evaluated for this interpreter) and sums the files each distribution installed (its
``RECORD``: code, compiled libraries, the ``*.libs`` folders of the wheels).  For each direct
dependency it reports its own size and what leaving it out saves (the distributions nothing else
of the package needs), then the totals of the full install and of the core that positions-only
motion capture needs (``fuse --markers-csv``, ``fit``, ``rollout --no-plot``; ``KinematicFusion``,
``EulerLagrangeRegressor`` with the physical library): everything but the three extras.

Finally it runs that motion-capture path in a fresh interpreter with ``cv2``, ``matplotlib`` and
``sympy`` blocked (``sys.modules[name] = None``), to check that the core list is enough.

Run: ``.venv/bin/python benchmarks/install_size.py`` (needs the full install in the venv; a few seconds)
"""

from __future__ import annotations

import re
import subprocess
import sys
import sysconfig
import time
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_section  # noqa: E402

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

ROOT = Path(__file__).resolve().parents[1]
OPTIONAL = ("video", "plots", "symbolic")

#: the motion-capture path, run with the optional modules blocked
MOCAP_PATH = """
import sys, tempfile
for name in ("cv2", "matplotlib", "sympy"):
    sys.modules[name] = None
import numpy as np
from pcs_sindy.core import PoseTrajectory
from pcs_sindy.fusion import KinematicFusion, tendon_sides
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import read_marker_csv
from pcs_sindy.models import TendonActuation
from pcs_sindy.simulation import MocapScenario

with tempfile.TemporaryDirectory() as tmp:
    path = MocapScenario(duration=10.0).generate(seed=0).to_csv(tmp + "/capture.csv")
    data = read_marker_csv(path, ["M1", "M2", "M3"], rate=100.0, units="mm", inputs=["u1", "u2"])
tr = PoseTrajectory.from_positions(data.positions, dt=data.dt)
fusion = KinematicFusion(threshold=0.2, progress=False).fit(tr)
strains = fusion.transform(tr)
end = fusion.total_length_ * (1 - 1e-6)
act = TendonActuation([end, end], tendon_sides(strains, [data.inputs]), offset=[0.012, 0.012])
model = EulerLagrangeRegressor(actuation=act).fit(strains, [data.inputs])
sim = model.simulate(strains[0].q[0], np.zeros(3), strains[0].t, data.inputs, progress=False)
print("ok", sim.q.shape, sorted(m for m in ("cv2", "matplotlib", "sympy") if sys.modules.get(m) is not None))
"""


def _name(text: str) -> str:
    return re.sub(r"[-_.]+", "-", text).lower()


def _size(dist: metadata.Distribution) -> int:
    total = 0
    for f in dist.files or []:
        p = Path(dist.locate_file(f))
        if p.is_file():
            total += p.stat().st_size
    return total


def _requires(dist: metadata.Distribution) -> list[str]:
    out = []
    for text in dist.requires or []:
        req = Requirement(text)
        if req.marker is None or req.marker.evaluate({"extra": ""}):
            out.append(_name(req.name))
    return out


def closure(names: list[str]) -> set[str]:
    """The installed distributions ``names`` need, themselves included."""
    seen: set[str] = set()
    todo = list(names)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        seen.add(name)
        todo += _requires(dist)
    return seen


def main() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    direct = [_name(Requirement(r).name) for r in project["dependencies"]]
    extras = {e: [_name(Requirement(r).name) for r in project["optional-dependencies"][e]] for e in OPTIONAL}
    optional = {n: e for e, names in extras.items() for n in names}
    sizes = {n: _size(metadata.distribution(n)) for n in closure(direct)}
    mb = 1e-6
    full = closure(direct)
    core_direct = [n for n in direct if n not in optional]
    core = closure(core_direct)
    rows = []
    for n in direct:
        others = closure([m for m in direct if m != n])
        saves = sum(sizes[m] for m in full - others)
        only = sorted(full - others - {n})
        rows.append(
            f"| {n} | {metadata.version(n)} | {sizes[n] * mb:.0f} | {saves * mb:.0f} | "
            f"{', '.join(only) if only else '-'} | {optional.get(n, 'core')} |"
        )
    site = Path(sysconfig.get_paths()["purelib"])
    du = sum(p.stat().st_size for p in site.rglob("*") if p.is_file() and not p.is_symlink())
    lines = [
        "| dependency | version | own [MB] | leaving it out saves [MB] | pulled in only by it | extra |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        "| install | distributions | size [MB] |",
        "|---|---|---|",
        f"| full (`pip install pcs_sindy`) | {len(full)} | {sum(sizes[n] for n in full) * mb:.0f} |",
        f"| motion capture only (core list, `--no-deps`) | {len(core)} | {sum(sizes[n] for n in core) * mb:.0f} |",
        f"| saved | {len(full - core)} | {sum(sizes[n] for n in full - core) * mb:.0f} |",
        "",
        f"The venv's whole site-packages (with pip, setuptools and the test tools): {du * mb:.0f} MB.",
        "",
        "Core list (`pip install --no-deps pcs_sindy` then these): "
        + " ".join(f'"{r}"' for r in project["dependencies"] if _name(Requirement(r).name) not in optional),
    ]
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", MOCAP_PATH], capture_output=True, text=True, timeout=600)
    seconds = time.perf_counter() - start
    verdict = proc.stdout.strip() if proc.returncode == 0 else f"FAILED: {proc.stderr.strip().splitlines()[-1:]}"
    lines += [
        "",
        f"Motion-capture path with cv2, matplotlib and sympy blocked (fusion, fit, rollout): {verdict} "
        f"({seconds:.1f} s).",
    ]
    body = "\n".join(lines)
    print(body)
    write_section("install_size", "Install size per dependency", body, ".venv/bin/python benchmarks/install_size.py")


if __name__ == "__main__":
    main()
