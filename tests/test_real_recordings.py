"""Short slices of the real recordings (read at test time from the real-data folder; skipped without it).

The folder: ``$PCS_SINDY_REAL_DATA``, else ``<repo>/../shared/real``, else ``/work/shared/real``
(``tests/real_data.py``).  What is checked: the files read through the package (against a plain
``csv`` parse), the black-box baselines on real data, and the PCS recipe of
``benchmarks/real_robots.py`` on a few seconds of the Trunk.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from real_data import real_file

from pcs_sindy.identification import ARX, LaggedPolynomialMap, LinearLoadInterpolator, PolynomialLoadMap

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
PHIS = [f"phi{i}" for i in range(1, 7)]
STEP_FILE = "observations_motor2_test_allmotors.csv"


def csv_slice(path: Path, n_rows: int, tmp_path: Path) -> tuple[Path, dict[str, np.ndarray]]:
    """The header and first ``n_rows`` rows of a CSV written to ``tmp_path``, and its columns by name."""
    with open(path, newline="") as fh:
        rows = [row for _, row in zip(range(n_rows + 1), csv.reader(fh), strict=False)]
    out = tmp_path / path.name
    with open(out, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    cols = {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}
    return out, cols


def disks(cols: dict[str, np.ndarray]) -> np.ndarray:
    return np.stack([np.stack([cols[f"{c}{i}"] for c in "xyz"], axis=1) for i in (1, 2, 3)], axis=1)


def test_trunk_file_reads_through_the_package(tmp_path):
    from pcs_sindy.io import read_marker_csv

    path, cols = csv_slice(real_file("trunk", STEP_FILE), 500, tmp_path)
    data = read_marker_csv(path, ["1", "2", "3"], rate=100.0, units="m", inputs=PHIS)
    np.testing.assert_array_equal(data.positions, disks(cols))
    np.testing.assert_array_equal(data.inputs, np.stack([cols[p] for p in PHIS], axis=1))
    assert data.dt == pytest.approx(0.01)


def test_baselines_fit_and_predict_real_trunk_data(tmp_path):
    _, cols = csv_slice(real_file("trunk", STEP_FILE), 3000, tmp_path)
    tip, u = disks(cols)[:, -1], np.stack([cols[p] for p in PHIS], axis=1)
    half = tip.shape[0] // 2
    arx = ARX(2, 2).fit(u[:half], tip[:half])
    pred = arx.predict(u[half:], tip[half : half + 2])
    assert np.all(np.isfinite(pred)) and arx.spectral_radius_ < 1
    # open loop on unseen steps, better than predicting the training mean
    err = np.sqrt(np.mean(np.sum((pred - tip[half:]) ** 2, axis=1)))
    assert err < np.sqrt(np.mean(np.sum((tip[half:] - tip[:half].mean(axis=0)) ** 2, axis=1)))
    lagged = LaggedPolynomialMap(degree=1).fit(u[:half], tip[:half], 0.01)
    assert np.all(np.isfinite(lagged.predict(u)))
    assert 0.0 <= lagged.lag_ <= 2.0


def test_tentacle_holds_give_load_baselines_a_consistent_shape():
    # the markers are unlabelled; a hold's shape as the sorted distances of its markers from the clamp
    # (the marker that stays put across holds) is label-free, so the baselines can be fitted on it
    names = {"m12_u00050010": (0.05, 0.10), "m12_u00100005": (0.10, 0.05), "m12_u001": (0.10, 0.10),
             "m12_u002": (0.20, 0.20)}  # fmt: skip
    means = {}
    for stem in names:
        table = np.loadtxt(real_file("tentacle", f"{stem}.csv"), delimiter=",", max_rows=60)
        assert table.shape[1] == 17
        pos = table[:, 2:].reshape(-1, 5, 3)
        assert np.max(np.linalg.norm(pos - pos.mean(axis=0), axis=-1)) < 2e-3  # a static hold
        means[stem] = pos.mean(axis=0)
    first = next(iter(means.values()))
    worst = [max(np.min(np.linalg.norm(m - first[i], axis=1)) for m in means.values()) for i in range(5)]
    clamp = first[int(np.argmin(worst))]
    assert min(worst) < 2e-3  # one marker stays put in every hold: the base
    shapes = np.array([np.sort(np.linalg.norm(m - clamp, axis=1)) for m in means.values()])
    assert shapes[:, 0] == pytest.approx(0.0, abs=2e-3)
    assert np.all(shapes[:, -1] < 0.4)  # a 0.305 m tentacle, markers 2 cm off its backbone
    loads = np.array(list(names.values()))
    for model in (LinearLoadInterpolator(), PolynomialLoadMap(1)):
        pred = model.fit(loads[1:], shapes[1:]).predict(loads[0])
        assert pred.shape == (1, 5) and np.all(np.isfinite(pred))


@pytest.mark.slow
def test_spatial_pcs_path_predicts_the_3d_trunk_better_than_the_training_mean():
    # 60 s of the all-motor 3-D recording: the documented spatial path (benchmarks/real_robots.py, the regressor's
    # defaults with the output-error refinement) trains on the first 30 s (10 s leave the equation error fewer rows
    # than its 277 unknowns) and predicts the next 30 s open loop; it must stay bounded and beat the training-mean tip
    from benchmarks._real_data import TRUNK_3D_FILE, read_trunk
    from benchmarks.real_robots import pcs_trunk_3d

    rec = read_trunk(real_file("trunk", TRUNK_3D_FILE), 6000)
    P, u, dt = rec.positions, rec.inputs, rec.dt
    half = P.shape[0] // 2
    details: dict = {}
    tip = pcs_trunk_3d(P[:half], u[:half], P[half:], u[half:], dt, details)
    assert details["model"].refinement_ is not None  # compiled spatial rollouts: refine="auto" refines
    ref = P[half:, -1]
    ok = np.all(np.isfinite(ref), axis=1)
    assert np.all(np.isfinite(tip))
    err = np.sqrt(np.mean(np.sum((tip[ok] - ref[ok]) ** 2, axis=1)))
    assert err < np.sqrt(np.mean(np.sum((ref[ok] - P[:half, -1].mean(axis=0)) ** 2, axis=1)))
