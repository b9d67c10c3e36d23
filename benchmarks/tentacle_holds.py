"""The real tentacle's static holds: leave one hold out, predict its markers, against two black boxes.

Eight static holds of a tendon-driven soft tentacle (``../shared/real/tentacle``, README there):
two tendon loads per hold, five unlabelled markers (the base one included) in a different column
order per file.  The tendons are not on opposite sides of the body: their sum bends it one way, their
difference another, so the holds do not share a plane; the model is 3-D
(:class:`pcs_sindy.identification.StaticShapeRegressor`).

Per held-out hold: the model fitted on the other seven predicts the hold's markers at its loads;
beside it, from the same seven holds' measured tips: (i) linear interpolation in the 2-D load space
(:class:`scipy.interpolate.LinearNDInterpolator`; outside the hull a plane through the three
nearest holds' loads), (ii) a full quadratic in the two loads (least squares per coordinate).
Tip error [mm] in the capture frame.

Run: ``python benchmarks/tentacle_holds.py`` (about 2 min on one core).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.interpolate import LinearNDInterpolator

from pcs_sindy.core import order_markers
from pcs_sindy.identification import StaticShapeRegressor

#: the two tendon loads of each hold, from the file names (README of the recordings)
LOADS = {
    "m12_u00050010": (0.05, 0.10),
    "m12_u00100005": (0.10, 0.05),
    "m12_u001": (0.10, 0.10),
    "m12_u001002": (0.10, 0.20),
    "m12_u002001": (0.20, 0.10),
    "m12_u0015002": (0.15, 0.20),
    "m12_u0020015": (0.20, 0.15),
    "m12_u002": (0.20, 0.20),
}


def real_folder() -> Path | None:
    """``$PCS_SINDY_REAL_DATA``, else ``<repo>/../shared/real``, else ``/work/shared/real``."""
    env = os.environ.get("PCS_SINDY_REAL_DATA")
    repo = Path(__file__).resolve().parents[1]
    for cand in ([Path(env)] if env else []) + [repo / ".." / "shared" / "real", Path("/work/shared/real")]:
        if (cand / "tentacle").is_dir():
            return cand / "tentacle"
    return None


def read_holds(folder: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Each hold's mean marker positions ordered from the base (H, 5, 3) and its loads (H, 2)."""
    names = [n for n in LOADS if (folder / f"{n}.csv").exists()]
    holds = [np.loadtxt(folder / f"{n}.csv", delimiter=",")[:, 2:].reshape(-1, 5, 3) for n in names]
    positions = np.array([h.mean(axis=0) for h in order_markers(holds)])
    return names, positions, np.array([LOADS[n] for n in names])


def interpolate(loads: np.ndarray, tips: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Linear interpolation in the load plane; outside the hull a plane through the 3 nearest holds."""
    tip = LinearNDInterpolator(loads, tips)(u[None])[0]
    if np.all(np.isfinite(tip)):
        return tip
    near = np.argsort(np.linalg.norm(loads - u, axis=1))[:3]
    coef = np.linalg.lstsq(np.c_[np.ones(3), loads[near]], tips[near], rcond=None)[0]
    return np.r_[1.0, u] @ coef


def quadratic(loads: np.ndarray, tips: np.ndarray, u: np.ndarray) -> np.ndarray:
    """A full quadratic in the two loads, least squares per coordinate."""

    def basis(x):
        return np.c_[np.ones(len(x)), x, x[:, 0] ** 2, x[:, 1] ** 2, x[:, 0] * x[:, 1]]

    return basis(u[None])[0] @ np.linalg.lstsq(basis(loads), tips, rcond=None)[0]


def main() -> dict[str, list[float]]:
    folder = real_folder()
    if folder is None:
        print("the real recordings (../shared/real/tentacle) are absent: nothing to measure")
        return {}
    start = time.perf_counter()
    names, positions, loads = read_holds(folder)
    errors: dict[str, list[float]] = {"PCS static (3-D)": [], "interpolation": [], "quadratic": []}
    rows = []
    for h, name in enumerate(names):
        train = np.arange(len(names)) != h
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # held-out loads outside the training range: said in the table
            model = StaticShapeRegressor().fit(positions[train], loads[train])
            tip = model.predict(loads[h])[0, -1]
        measured = positions[h, -1]
        errors["PCS static (3-D)"].append(float(np.linalg.norm(tip - measured)))
        errors["interpolation"].append(
            float(np.linalg.norm(interpolate(loads[train], positions[train, -1], loads[h]) - measured))
        )
        errors["quadratic"].append(
            float(np.linalg.norm(quadratic(loads[train], positions[train, -1], loads[h]) - measured))
        )
        inside = bool(np.all(loads[h] >= model.input_range_[0]) and np.all(loads[h] <= model.input_range_[1]))
        rows.append(
            f"| {name} | {loads[h][0]:.2f}, {loads[h][1]:.2f} | {'yes' if inside else 'no'} | "
            + " | ".join(f"{1e3 * v[-1]:.1f}" for v in errors.values())
            + f" | {'+'.join(model.terms_)} | {1e3 * model.shape_rms_:.1f} |"
        )
        print(rows[-1], flush=True)
    table = "\n".join(rows)
    means = " | ".join(f"**{1e3 * np.mean(v):.1f}**" for v in errors.values())
    body = f"""| hold | loads | inside the training range | {" | ".join(errors)} | terms | shape-fit RMS [mm] |
|---|---|---|---|---|---|---|---|
{table}
| mean | | | {means} | | |

Tip error [mm], leave one hold out ({len(names)} holds); wall time {time.perf_counter() - start:.0f} s."""
    print(body)
    return errors


if __name__ == "__main__":
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    sys.exit(0 if main() is not None else 1)
