"""3-D static holds of a tendon rod: kinematics, identification and prediction against independent truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from real_data import real_data_dir
from scipy.spatial.transform import Rotation

from benchmarks._real_data import TENTACLE_LOADS
from pcs_sindy.core import order_markers
from pcs_sindy.identification.static_shape import StaticShapeRegressor, cc_points

LENGTH = 0.3
S_MARKERS = np.array([0.1, 0.2, 0.3])
OFFSET = 0.02
BASE = np.array([0.1, 0.05, 0.2])
ROLL = 0.4
#: the truth: per segment, curvature = compliance @ loads + rest curvature (a linear rod, tendons ending at the tip)
COMPLIANCE = np.array([[[20.0, -12.0], [10.0, 14.0]], [[25.0, -15.0], [12.0, 18.0]]])  # (segment, axis, tendon)
REST = np.array([[0.5, -0.3], [0.8, 0.2]])


def integrate_rod(w: np.ndarray, s_query: np.ndarray, n: int = 6000) -> tuple[np.ndarray, np.ndarray]:
    """Frames along a rod of piecewise-constant curvature by small rotation steps (scipy's Rotation)."""
    R = Rotation.align_vectors([[0, 1, 0]], [[0, 0, 1]])[0] * Rotation.from_rotvec([0, 0, ROLL])
    p = BASE.copy()
    ds = LENGTH / n
    seg_len = LENGTH / w.shape[0]
    out_R, out_p, k = [], [], 0
    for j in range(n + 1):
        s = j * ds
        while k < s_query.size and s_query[k] <= s + 1e-12:
            out_R.append(R.as_matrix())
            out_p.append(p.copy())
            k += 1
        if j == n:
            break
        i = min(int((s + 0.5 * ds) / seg_len), w.shape[0] - 1)
        p = p + R.apply([0, 0, ds / 2])
        R = R * Rotation.from_rotvec([w[i, 0] * ds, w[i, 1] * ds, 0.0])
        p = p + R.apply([0, 0, ds / 2])
    return np.asarray(out_R), np.asarray(out_p)


def true_markers(u: np.ndarray) -> np.ndarray:
    w = np.einsum("iat,t->ia", COMPLIANCE, u) + REST
    R, p = integrate_rod(w, S_MARKERS)
    body = p + OFFSET * R[:, :, 0]
    base_marker = BASE
    return np.vstack([base_marker, body])


def test_cc_points_matches_small_step_integration():
    w = np.array([[3.0, -2.0], [-4.0, 6.0]])
    Rt, pt = integrate_rod(w, S_MARKERS)
    # cc_points from the identity base; the integrator's base is rotated and shifted
    base_R = (Rotation.align_vectors([[0, 1, 0]], [[0, 0, 1]])[0] * Rotation.from_rotvec([0, 0, ROLL])).as_matrix()
    R2, p2 = cc_points(w, [0.15, 0.15], S_MARKERS, base_R, BASE)
    assert np.allclose(p2, pt, atol=1e-6)
    assert np.allclose(R2, Rt, atol=1e-5)


def test_order_markers_recovers_the_body_order():
    rng = np.random.default_rng(1)
    holds = np.array([true_markers(u) for u in [np.array([0.1, 0.05]), np.array([0.2, 0.1])]])
    perm = np.array([rng.permutation(4) for _ in holds])
    shuffled = np.take_along_axis(holds, perm[..., None], axis=1)
    ordered = order_markers([h[None] for h in shuffled], base=None)  # one frame per hold, base found across them
    assert np.allclose(np.concatenate(ordered), holds)


@pytest.fixture(scope="module")
def grid():
    loads = np.array([[a, b] for a in (0.05, 0.12, 0.2) for b in (0.05, 0.12, 0.2)])
    return loads, np.array([true_markers(u) for u in loads])


def test_static_fit_predicts_a_held_out_hold(grid):
    loads, markers = grid
    h = 4  # the centre of the grid
    train = np.arange(len(loads)) != h
    model = StaticShapeRegressor(2, length=LENGTH).fit(markers[train], loads[train])
    assert model.terms_ == ("tendon", "rest")
    pred = model.predict(loads[h])[0]
    assert np.linalg.norm(pred[-1] - markers[h, -1]) < 1e-3
    assert model.shape_rms_ < 1e-3
    assert np.allclose(model.marker_arc_lengths_, S_MARKERS, atol=2e-3)
    # the tendon's share of the curvature per unit load, L w = A u: independent of the scale convention
    assert np.allclose(model.compliance_ / (LENGTH / 2), COMPLIANCE, rtol=0.05, atol=0.5)
    assert np.all(model.stiffness_ > 0)


def test_rank_deficiency_is_reported(grid):
    loads, markers = grid
    # tendon 2 held at one load: its column is the constant one of the rest curvature
    one = np.isclose(loads[:, 1], 0.12)
    model = StaticShapeRegressor(1, length=LENGTH)
    # three holds along one tendon: the rest curvature and tendon 2 cannot be told apart
    model.fit(markers[one], loads[one])
    assert any("rank-deficient" in d for d in model.dropped_)
    assert "rest" not in model.terms_ or "tendon" in model.terms_


def _real_folder() -> Path | None:
    root = real_data_dir()
    return root / "tentacle" if root is not None and (root / "tentacle").is_dir() else None


@pytest.mark.skipif(_real_folder() is None, reason="the real recordings (../shared/real) are absent")
def test_real_tentacle_hold_predicted_within_a_centimetre():
    folder = _real_folder()
    files = sorted(folder.glob("m12_*.csv"))
    holds = [np.loadtxt(f, delimiter=",")[:, 2:].reshape(-1, 5, 3) for f in files]
    loads = np.array([TENTACLE_LOADS[f.stem] for f in files])
    positions = np.array([hold.mean(axis=0) for hold in order_markers(holds)])
    h = int(np.flatnonzero(np.all(np.isclose(loads, [0.2, 0.2]), axis=1))[0])
    train = np.arange(len(loads)) != h
    model = StaticShapeRegressor(2).fit(positions[train], loads[train])
    tip = model.predict(loads[h])[0, -1]
    assert np.linalg.norm(tip - positions[h, -1]) < 0.010
