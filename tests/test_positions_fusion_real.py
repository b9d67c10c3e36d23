"""Positions-only fusion on real recordings and on synthetic truth (issue 25): reading the Trunk and
tentacle files as they are, jump detection that keeps genuine fast motion, unlabelled markers,
a recorded base marker, markers off the backbone, shared planes and the base from positions."""

import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from real_data import real_data_dir

from pcs_sindy.core import MarkerPlane, PoseTrajectory, clean_marker_tracks, find_base_marker, order_markers
from pcs_sindy.core.kinematics import forward_kinematics
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.fusion.position_fit import bending_strains, fit_marker_geometry, marker_positions_jacobian
from pcs_sindy.io import DataFileError, read_marker_csv

REAL = real_data_dir()
needs_real = pytest.mark.skipif(REAL is None, reason="real recordings (../shared/real) not available")


def _slice_csv(src: Path, dst: Path, rows: int) -> Path:
    with open(src) as f:
        lines = [next(f) for _ in range(rows)]
    dst.write_text("".join(lines))
    return dst


# -- reading -------------------------------------------------------------------------------------


def test_read_axis_first_names_and_id_column(tmp_path):
    f = tmp_path / "trunk.csv"
    rows = ["ID,x1,y1,z1,x2,y2,z2,phi1"]
    for k in (0, 1, 3):  # sample 2 skipped: a NaN row in its place
        rows.append(f"{k},{k},{-1 - k},{2},{10 + k},{-20},{30},{0.5 * k}")
    f.write_text("\n".join(rows) + "\n")
    d = read_marker_csv(f, ["1", "2"], rate=100, units="m", inputs=["phi1"])
    assert d.positions.shape == (4, 2, 3)
    np.testing.assert_allclose(d.positions[3, 0], [3, -4, 2])
    np.testing.assert_allclose(d.positions[1, 1], [11, -20, 30])
    assert np.all(np.isnan(d.positions[2]))
    np.testing.assert_allclose(d.inputs[:, 0], [0, 0.5, 0.5, 1.5])  # a skipped sample holds the input
    assert d.dt == pytest.approx(0.01)


def test_read_headerless_unlabelled_markers(tmp_path):
    f = tmp_path / "hold.csv"
    data = np.column_stack([np.arange(5), np.arange(5) / 240, np.arange(5 * 6).reshape(5, 6) * 0.001])
    np.savetxt(f, data, delimiter=",", fmt="%.6f")
    d = read_marker_csv(f, 2, rate=240, units="m")
    assert d.markers == ["m0", "m1"]
    np.testing.assert_allclose(d.positions[:, 1, 0], data[:, 5], atol=1e-9)
    d2 = read_marker_csv(f, 1, rate=240, units="m", columns=[5])
    np.testing.assert_allclose(d2.positions[:, 0], data[:, 5:8], atol=1e-9)
    with pytest.raises(DataFileError, match="columns"):
        read_marker_csv(f, ["a"], rate=240, units="m", columns=[2])
    with pytest.raises(DataFileError, match="needs 30 columns"):
        read_marker_csv(f, 10, rate=240, units="m")
    with pytest.raises(DataFileError, match="units"):
        read_marker_csv(f, 2, rate=240)


@needs_real
def test_read_real_trunk_and_tentacle_slices(tmp_path):
    trunk = _slice_csv(REAL / "trunk" / "observations_motor2_test_allmotors.csv", tmp_path / "t.csv", 201)
    d = read_marker_csv(trunk, ["1", "2", "3"], rate=100, units="m", inputs=[f"phi{k}" for k in range(1, 7)])
    assert d.positions.shape == (200, 3, 3) and d.inputs.shape == (200, 6)
    assert np.all(np.diff(d.positions[:, :, 1].mean(axis=0)) < 0)  # disks hang along -y, base to tip
    tent = _slice_csv(REAL / "tentacle" / "m12_u001.csv", tmp_path / "h.csv", 100)
    h = read_marker_csv(tent, 5, rate=240, units="m")
    assert h.positions.shape == (100, 5, 3) and np.all(np.isfinite(h.positions))


# -- jumps and frozen samples ------------------------------------------------------------------------


def _fast_step(T=600, seed=0):
    """Three markers of one body stepping fast (a lightly damped 3 Hz response), 0.01 mm noise."""
    t = np.arange(T) * 0.01
    w = 2 * np.pi * 3
    x = np.zeros(T)
    for t0, amp in ((1.0, 0.03), (3.0, -0.05), (4.5, 0.04)):
        tau = np.clip(t - t0, 0, None)
        x += amp * (1 - np.exp(-0.15 * w * tau) * np.cos(w * tau))
    gains = np.array([0.2, 0.5, 1.0])  # distal markers move more
    P = np.zeros((T, 3, 3))
    P[..., 0] = x[:, None] * gains
    P[..., 1] = -np.array([0.1, 0.2, 0.3])
    P += 1e-5 * np.random.default_rng(seed).standard_normal(P.shape)
    return P


def test_jumps_keep_fast_motion_and_catch_glitches():
    P = _fast_step()
    clean, counts = clean_marker_tracks(P)
    assert counts["jumps"] == 0  # the steps move every marker at once
    _, alone = clean_marker_tracks(P, consistency=None)
    assert alone["jumps"] > 0  # judged track by track, the same steps are flagged
    glitchy = P.copy()
    glitchy[250, 2, 1] += 0.004  # a tracker glitch of one marker, during motion
    glitchy[420:422, 0, 2] -= 0.003  # a two-sample burst at rest
    cleaned, counts = clean_marker_tracks(glitchy)
    assert np.isnan(cleaned[250, 2]).all() and np.isnan(cleaned[420:422, 0]).all()
    assert counts["jumps"] == 3
    frozen = P.copy()
    frozen[300:305, 1] = frozen[299, 1]
    _, counts = clean_marker_tracks(frozen)
    assert counts["frozen"] == 5


@needs_real
def test_real_trunk_step_motion_is_not_jumps():
    d = read_marker_csv(REAL / "trunk" / "observations_motor4_test_allmotors.csv", ["1", "2", "3"], rate=100, units="m")
    P = d.positions[:4000]
    _, counts = clean_marker_tracks(P)
    _, alone = clean_marker_tracks(P, consistency=None)
    assert counts["jumps"] < 0.5 * alone["jumps"]
    assert counts["jumps"] < 0.005 * P.shape[0] * P.shape[1]


# -- unlabelled markers ----------------------------------------------------------------------------------


def _hold_shapes(n_holds=4, T=30, seed=0, offsets=None):
    """Static holds of a 4-marker robot (plus a base marker) in a 3-D capture frame."""
    rng = np.random.default_rng(seed)
    s = np.array([0.1, 0.18, 0.25, 0.3])
    lengths = np.diff(np.concatenate([[0.0], s]))
    holds = []
    for _ in range(n_holds):
        k = rng.uniform(-5, 5, 2)
        kappa = np.tile(np.array([k[0], k[0], k[1], k[1]]), (T, 1))
        pos, _ = marker_positions_jacobian(kappa, lengths, s, (0.0, 0.0, 0.0), offsets)
        pos = np.concatenate([np.zeros((T, 1, 2)), pos], axis=1)  # the base marker first
        P3 = np.concatenate([pos, np.zeros(pos.shape[:2] + (1,))], axis=2)
        holds.append(P3 + 1e-4 * rng.standard_normal(P3.shape))
    return holds, s


def test_order_markers_undoes_shuffled_labels_per_file_and_per_frame():
    holds, _ = _hold_shapes()
    rng = np.random.default_rng(1)
    shuffled = []
    for h in holds:
        perm = rng.permutation(5)
        x = h[:, perm].copy()
        swap = rng.choice(h.shape[0], 5, replace=False)  # the tracker swaps two labels in a few frames
        x[swap[:, None], [1, 3]] = x[swap[:, None], [3, 1]]
        shuffled.append(x)
    assert len(set(find_base_marker(shuffled))) >= 1
    ordered = order_markers(shuffled)
    for o, h in zip(ordered, holds, strict=True):
        np.testing.assert_allclose(o, h)
    one = order_markers(shuffled[0], base=int(np.flatnonzero(np.all(shuffled[0][0] == holds[0][0, 0], axis=1))[0]))
    np.testing.assert_allclose(one, holds[0])


@needs_real
def test_real_tentacle_base_marker_is_found_in_every_file():
    files = sorted((REAL / "tentacle").glob("m12_*.csv"))[:4]
    recs = [read_marker_csv(f, 5, rate=240, units="m").positions[:50] for f in files]
    ordered = order_markers(recs)
    bases = np.array([np.median(o[:, 0], axis=0) for o in ordered])
    assert np.max(np.linalg.norm(bases - bases[0], axis=1)) < 2e-3  # one clamp
    for o in ordered:  # the other markers recede from the base
        m = np.median(o, axis=0)
        assert np.all(np.diff(np.linalg.norm(m - m[0], axis=1)) > 0)


# -- geometry: base marker, offsets, shared planes, base from positions -------------------------------------


def test_markers_off_the_backbone_and_a_known_base_position():
    s = np.array([0.1, 0.2, 0.3])
    lengths = np.diff(np.concatenate([[0.0], s]))
    d = np.array([0.015, 0.02, 0.012])
    base = np.array([0.03, -0.01, 0.2])
    t = np.arange(300) * 0.01
    kappa = np.stack([6 * np.sin(2.5 * t), 4 * np.sin(2.5 * t + 1), 5 * np.cos(1.9 * t)], axis=1)
    pos, _ = marker_positions_jacobian(kappa, lengths, s, base, d)
    # independent check of the offset model: the backbone plus d along (cos theta, sin theta)
    pose = forward_kinematics(bending_strains(kappa), lengths, s, base_pose=base)
    np.testing.assert_allclose(
        pos, pose[..., :2] + d[:, None] * np.stack([np.cos(pose[..., 2]), np.sin(pose[..., 2])], -1)
    )
    noisy = pos + 5e-5 * np.random.default_rng(0).standard_normal(pos.shape)
    fit = fit_marker_geometry([noisy], s, curvatures="per_segment", base_position=base[:2], offsets="fit")
    np.testing.assert_allclose(fit["offsets"], d, atol=1e-3)
    assert fit["base_pose"][2] == pytest.approx(base[2], abs=0.02)
    np.testing.assert_allclose(fit["base_pose"][:2], base[:2])
    ignored = fit_marker_geometry([noisy], s, curvatures="per_segment", base_position=base[:2])
    assert ignored["rms"] > 10 * fit["rms"]


def test_static_holds_share_one_plane_and_a_recorded_base_marker_fixes_the_base():
    holds, s = _hold_shapes(n_holds=5, seed=3)
    R, _ = np.linalg.qr(np.random.default_rng(4).standard_normal((3, 3)))
    origin = np.array([0.2, 0.05, 0.18])
    trajs = [PoseTrajectory.from_positions(h @ R.T + origin, dt=0.01, base_marker=True) for h in holds]
    assert trajs[0].n_markers == 4
    np.testing.assert_allclose(trajs[0].metadata["base_marker"], origin, atol=1e-4)
    fusion = KinematicFusion(threshold=1e-9).fit(trajs)
    normal = R[:, 2]
    assert abs(fusion.plane_.normal @ normal) == pytest.approx(1.0, abs=1e-3)
    np.testing.assert_allclose(fusion.plane_.to_plane(origin), fusion.base_pose_[:2], atol=3e-4)
    err = -fusion.score(trajs)
    assert err < 1e-3
    np.testing.assert_allclose(fusion.marker_arc_lengths_[1:], s, atol=0.01)


def test_planes_through_a_common_base_axis():
    holds, _ = _hold_shapes(n_holds=4, seed=5)
    rng = np.random.default_rng(6)
    turned = []
    for k, h in enumerate(holds):  # each hold bends in its own plane about the clamp's axis (+y)
        a = 0.4 * (k - 1.5)
        Ry = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
        turned.append(h @ Ry.T + 1e-5 * rng.standard_normal(h.shape))
    trajs = [PoseTrajectory.from_positions(h, dt=0.01, base_marker=True) for h in turned]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = KinematicFusion(threshold=1e-9).fit(trajs)
    axis = KinematicFusion(threshold=1e-9, shared_plane="base_axis").fit(trajs)
    assert abs(axis.plane_base_axis_[0] @ [0, 1, 0]) == pytest.approx(1.0, abs=1e-3)
    assert -axis.score(trajs) < 1e-3 < -one.score(trajs)


@needs_real
def test_real_trunk_base_is_one_spacing_above_disk_one():
    for name in ("observations_motor2_test_allmotors.csv", "observations_motor4_test_allmotors.csv"):
        d = read_marker_csv(REAL / "trunk" / name, ["1", "2", "3"], rate=100, units="m")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tr = d.trajectory()
        fit = fit_marker_geometry([tr.plane_positions], None, max_frames=300)
        s = fit["arc_lengths"]
        spacing = np.diff(s).mean()
        assert 0.8 * spacing < s[0] < 1.25 * spacing, (name, s)
        assert np.all(fit["std"][3:] > 0) and np.all(fit["std"][3:] < 0.01)


def test_position_fusion_of_10000_frames_is_fast():
    rng = np.random.default_rng(0)
    t = np.arange(10_000) * 0.01
    # a robot bending nearly uniformly: the arc lengths from positions assume it (docs/mocap.md)
    kappa = np.stack([6 * np.sin(2.1 * t)] * 3, axis=1) + 0.2 * rng.standard_normal((t.size, 3))
    s = np.array([0.1, 0.2, 0.3])
    pose = forward_kinematics(bending_strains(kappa), np.diff(np.concatenate([[0.0], s])), s, (0.0, 0.0, 0.3))
    P = np.concatenate([pose[..., :2], np.zeros(pose.shape[:2] + (1,))], axis=2)
    tr = PoseTrajectory.from_positions(P + 5e-5 * rng.standard_normal(P.shape), dt=0.01)
    start = time.perf_counter()
    fusion = KinematicFusion().fit(tr)
    fusion.transform(tr)
    elapsed = time.perf_counter() - start
    assert elapsed < 20.0  # 1-3 s on one core; a loose guard against the 50-180 s of before
    np.testing.assert_allclose(fusion.marker_arc_lengths_[1:], s, atol=0.01)


def test_base_pose_with_the_arc_lengths_given():
    planar = forward_kinematics(
        bending_strains(np.stack([5 * np.sin(np.arange(400) * 0.03)] * 3, axis=1)),
        [0.1, 0.1, 0.1],
        [0.1, 0.2, 0.3],
        (0.05, 0.02, -0.3),
    )[..., :2]
    P = np.concatenate([planar, np.zeros(planar.shape[:2] + (1,))], axis=2)
    tr = PoseTrajectory.from_positions(
        P, dt=0.01, arc_lengths=[0.1, 0.2, 0.3], plane=MarkerPlane(np.zeros(3), np.eye(3)[:, :2])
    )
    fusion = KinematicFusion().fit(tr)
    np.testing.assert_allclose(fusion.base_pose_, [0.05, 0.02, -0.3], atol=1e-3)


def test_a_fixed_segment_count_for_position_data():
    planar, _ = _three_curvatures()
    P = np.concatenate([planar, np.zeros(planar.shape[:2] + (1,))], axis=2)
    tr = PoseTrajectory.from_positions(P, dt=0.01, arc_lengths=[0.1, 0.2, 0.3])
    for n in (1, 2, 3):
        fusion = KinematicFusion(n_segments=n).fit(tr)
        assert fusion.n_segments_ == n and fusion.threshold_ is None
        assert fusion.threshold_choice_["rule"] == "n_segments"
        assert np.sum(fusion.segment_lengths_) == pytest.approx(0.3)
    # the first two spacings bend alike: two segments merge them, not the last two
    assert KinematicFusion(n_segments=2).fit(tr).boundaries_.tolist() == [2, 3]
    with pytest.raises(ValueError, match="n_segments"):
        KinematicFusion(n_segments=4).fit(tr)


def _three_curvatures(T=500):
    t = np.arange(T) * 0.01
    k1 = 6 * np.sin(2.3 * t)
    kappa = np.stack([k1, k1, -4 * np.cos(1.7 * t)], axis=1)
    s = np.array([0.1, 0.2, 0.3])
    pose = forward_kinematics(bending_strains(kappa), [0.1, 0.1, 0.1], s, (0.0, 0.0, 0.2))
    return pose[..., :2], kappa
