"""The real recordings: where they are, and reading them (never copied into the repository).

Folder: ``$PCS_SINDY_REAL_DATA``, else ``<repo>/../shared/real``, else ``/work/shared/real``
(:func:`real_data_dir`).  Readers:

* :func:`read_trunk` - a Trunk observation file (``ID, x1..z3, phi1..phi6`` at 100 Hz): disk positions
  (T, 3, 3) [m], disk 1 nearest the base, and the measured motor angles (T, 6) [deg], through
  :func:`pcs_sindy.io.read_marker_csv` (a reader that fails is an error of the benchmark, never a
  silent fallback);
* :func:`read_commanded` - ``control_inputs_*.csv`` (``ID, u1..u6``, commanded angles [deg]);
* :func:`read_tentacle` - the static holds: header-less ``frame, time, 5 x (x, y, z)`` with the markers
  unlabelled in a per-file order; returned ordered from the base along the body, with the two tendon
  loads of each file.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
ENV = "PCS_SINDY_REAL_DATA"
TRUNK_RATE = 100.0  # [Hz] the lab's control loop; the files have a sample index only
TRUNK_STEP_FILES = ("observations_motor2_test_allmotors.csv", "observations_motor4_test_allmotors.csv")
TRUNK_3D_FILE, TRUNK_3D_INPUTS = "observations_controlled_1.csv", "control_inputs_controlled_1.csv"
TRUNK_REST_FILE = "observations_zeros_0g.csv"
#: the tentacle's load levels per file, from the folder's README table (tendon 1, tendon 2)
TENTACLE_LOADS = {
    "m12_u00050010": (0.05, 0.10),
    "m12_u00100005": (0.10, 0.05),
    "m12_u001": (0.10, 0.10),
    "m12_u001002": (0.10, 0.20),
    "m12_u002001": (0.20, 0.10),
    "m12_u0015002": (0.15, 0.20),
    "m12_u0020015": (0.20, 0.15),
    "m12_u002": (0.20, 0.20),
}
TENTACLE_INPUT_RADIUS = 0.0325  # [m] the source turns a load level into a tendon input by dividing by it
TENTACLE_ARC_LENGTHS = (0.129, 0.220, 0.280, 0.305)  # [m] the marker sites beyond the base (the source's code)


def real_data_dir() -> Path | None:
    """The real-data folder (holding ``trunk/`` and ``tentacle/``), or None when there is none.

    ``$PCS_SINDY_REAL_DATA`` wins when set (a set but missing folder gives None, not a silent fallback).
    """
    env = os.environ.get(ENV)
    if env:
        path = Path(env).expanduser()
        return path if path.is_dir() else None
    for path in (REPO / ".." / "shared" / "real", Path("/work/shared/real")):
        if path.is_dir():
            return path.resolve()
    return None


@dataclass
class TrunkRecording:
    """One Trunk file: ``positions`` (T, 3, 3) [m] capture frame, ``inputs`` (T, 6) [deg], ``dt`` [s]."""

    name: str
    positions: np.ndarray
    inputs: np.ndarray
    dt: float
    reader: str


def _columns(path: Path) -> dict[str, np.ndarray]:
    table = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    return {name: np.asarray(table[name], dtype=float) for name in table.dtype.names}


def read_trunk(path: str | Path, n_rows: int | None = None) -> TrunkRecording:
    """Read a Trunk observation file (disk positions and measured motor angles), the first ``n_rows`` rows."""
    from pcs_sindy.io import read_marker_csv

    path = Path(path)
    phis = [f"phi{i}" for i in range(1, 7)]
    data = read_marker_csv(path, ["1", "2", "3"], rate=TRUNK_RATE, units="m", inputs=phis)
    positions, inputs, reader = data.positions, data.inputs, "pcs_sindy.io.read_marker_csv"
    if n_rows is not None:
        positions, inputs = positions[:n_rows], inputs[:n_rows]
    return TrunkRecording(path.name, positions, inputs, 1.0 / TRUNK_RATE, reader)


def read_commanded(path: str | Path) -> np.ndarray:
    """Commanded motor angles ``u1..u6`` [deg] (T, 6)."""
    cols = _columns(Path(path))
    return np.stack([cols[f"u{i}"] for i in range(1, 7)], axis=1)


def tentacle_loads(stem: str) -> tuple[float, float] | None:
    """The two tendon load levels of a hold file: the README table, else read from a ``u<4 digits><4 digits>``
    name (``0005`` = 0.05); None when the name says neither."""
    if stem in TENTACLE_LOADS:
        return TENTACLE_LOADS[stem]
    m = re.search(r"u(\d{4})(\d{4})$", stem)
    if m:
        return tuple(float("0." + g[2:]) for g in m.groups())  # type: ignore[return-value]
    return None


@dataclass
class TentacleHold:
    """One static hold: ``positions`` (T, 5, 3) [m] ordered base marker first, then along the body."""

    name: str
    loads: np.ndarray
    positions: np.ndarray
    order: np.ndarray  # the file's marker columns, base first
    dt: float

    @property
    def mean(self) -> np.ndarray:
        """The hold's mean marker positions (5, 3), NaN samples ignored."""
        return np.nanmean(self.positions, axis=0)


def read_tentacle(folder: str | Path) -> tuple[list[TentacleHold], list[str]]:
    """Every hold of a tentacle folder, markers ordered base first; and notes on skipped files.

    The order is the package's (:func:`pcs_sindy.core.order_markers` over all holds): the base is the
    marker found at the same place in every hold (the clamp), the others follow along the body,
    per file and per frame.
    """
    from pcs_sindy.core import order_markers

    holds, notes, raw = [], [], []
    for path in sorted(Path(folder).glob("*.csv")):
        loads = tentacle_loads(path.stem)
        if loads is None:
            notes.append(f"{path.name}: no load levels known for this name; skipped")
            continue
        table = np.loadtxt(path, delimiter=",")
        if table.ndim != 2 or table.shape[1] != 17:
            notes.append(f"{path.name}: expected 17 columns (frame, time, 5 x xyz); got {table.shape}; skipped")
            continue
        pos = table[:, 2:].reshape(-1, 5, 3)
        dt = float(np.median(np.diff(table[:, 1])))
        raw.append((path.stem, np.asarray(loads, dtype=float), pos, dt))
    if not raw:
        return [], notes
    ordered, orders = order_markers([p for _, _, p, _ in raw], return_order=True)
    for (stem, loads, _, dt), pos, order in zip(raw, ordered, orders, strict=True):
        holds.append(TentacleHold(stem, loads, pos, order[0], dt))
    return holds, notes
