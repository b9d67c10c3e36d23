"""Tests of KinematicFusion (seed Algorithm 1) and the least-squares shape fit.

Truth comes from outside the code under test: marker poses generated with
the closed-form forward kinematics from known strain trajectories, PAC poses
from the PAC simulator's quadrature, hand-worked merge and selection examples,
and invariances (rigid motion of the data, angle wrapping).
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from pcs_sindy.core import PoseTrajectory, StrainTrajectory, forward_kinematics, se2_compose, wrap_angle
from pcs_sindy.fusion import (
    KinematicFusion,
    SweepRow,
    chain_poses,
    estimate_total_length,
    fit_strains_least_squares,
    fuse_segments,
    merge_runs,
    segment_strains,
    segmentation_sweep,
    select_threshold,
    strain_distances,
    threshold_sweep,
)

N_MARKERS = 20


def smooth_signal(rng, n_frames, amplitude, dt=1e-3):
    """A smooth random signal (a few sinusoids) whose peak magnitude is 60-100 % of ``amplitude``."""
    t = np.arange(n_frames) * dt
    out = np.zeros(n_frames)
    for _ in range(4):
        out += rng.normal() * np.sin(2 * np.pi * rng.uniform(0.5, 8.0) * t + rng.uniform(0, 2 * np.pi))
    return out / np.max(np.abs(out)) * amplitude * rng.uniform(0.6, 1.0)


def random_strains(lengths, n_frames, seed, kappa_max=40.0, sigma_max=0.2, axial=True):
    """Independent smooth strain trajectories for every segment, shape (T, 3m)."""
    rng = np.random.default_rng(seed)
    cols = []
    for _ in lengths:
        cols += [smooth_signal(rng, n_frames, kappa_max), smooth_signal(rng, n_frames, sigma_max)]
        cols.append(smooth_signal(rng, n_frames, sigma_max) if axial else np.zeros(n_frames))
    return np.stack(cols, axis=1)


def pcs_poses(lengths, n_frames=150, seed=0, **kwargs):
    q = random_strains(lengths, n_frames, seed, **kwargs)
    s = np.linspace(0.0, sum(lengths), N_MARKERS + 1)
    return q, forward_kinematics(q, lengths, s)


def add_noise(poses, sigma_p, sigma_theta, seed):
    """Gaussian noise on the markers; the base defines the frame and stays exact."""
    rng = np.random.default_rng(seed)
    out = poses.copy()
    out[:, 1:, :2] += rng.normal(0.0, sigma_p, out[:, 1:, :2].shape)
    out[:, 1:, 2] += rng.normal(0.0, sigma_theta, out[:, 1:, 2].shape)
    return out


# --------------------------------------------------------------------------
# Building blocks against hand-worked truth
# --------------------------------------------------------------------------
def test_merge_runs_groups_runs_of_small_distances():
    assert merge_runs([0.1, 0.5, 0.1, 0.1], 0.2) == [[0, 1], [2, 3, 4]]
    assert merge_runs([0.3, 0.3], 0.2) == [[0], [1], [2]]
    assert merge_runs([0.2, 0.2], 0.2) == [[0, 1, 2]]  # "<= h" merges (seed Algorithm 1 line 7)
    assert merge_runs([], 0.2) == [[0]]


def test_strain_distances_is_mean_euclidean_distance():
    q = np.zeros((4, 3, 3))
    q[:, 1, :] = [3.0, 4.0, 0.0]  # segment 1 differs from segment 0 by a 3-4-5 vector in every frame
    q[:2, 2, :] = [3.0, 4.0, 0.0]  # segment 2 equals segment 1 in half the frames, is 0 in the others
    np.testing.assert_allclose(strain_distances(q), [5.0, 2.5])


def test_segment_strains_recover_true_strains_on_marker_boundaries():
    lengths = [0.04, 0.1, 0.06]  # 20 markers on 0.2 m: boundaries at markers 4 and 14
    q, poses = pcs_poses(lengths, n_frames=50, seed=3)
    chain, _ = chain_poses(poses)
    s = np.linspace(0.0, 0.2, N_MARKERS + 1)
    est = segment_strains(chain, s, np.array([4, 14, 20]))
    np.testing.assert_allclose(est.reshape(50, -1), q, atol=1e-9)
    # every inter-marker piece of a constant-strain segment has that segment's strains
    fine = segment_strains(chain, s, np.arange(1, 21))
    np.testing.assert_allclose(fine[:, 5:14, :], np.repeat(q[:, None, 3:6], 9, axis=1), atol=1e-9)


def test_segment_strains_exact_at_zero_curvature():
    lengths = [0.1]
    q = np.zeros((3, 3))
    q[1] = [0.0, 0.1, -0.05]  # straight but sheared and compressed
    q[2] = [1e-14, 0.0, 0.0]
    poses = forward_kinematics(q, lengths, np.linspace(0, 0.1, N_MARKERS + 1))
    chain, _ = chain_poses(poses)
    est = segment_strains(chain, np.linspace(0, 0.1, N_MARKERS + 1), np.arange(1, 21))
    assert np.all(np.isfinite(est))
    np.testing.assert_allclose(est, np.repeat(q[:, None, :], 20, axis=1), atol=1e-12)


def test_estimate_total_length_exact_without_axial_strain():
    lengths = [0.08, 0.12]  # boundary on a marker: every inter-marker piece has constant strain
    q, poses = pcs_poses(lengths, n_frames=40, seed=1, axial=False)
    chain, _ = chain_poses(poses)
    assert estimate_total_length([chain]) == pytest.approx(0.2, rel=1e-10)
    # fitted without total_length, the fusion uses that estimate
    fusion = KinematicFusion(shape_fit="end_pose").fit(poses)
    assert fusion.total_length_ == pytest.approx(0.2, rel=1e-10)
    np.testing.assert_allclose(fusion.segment_lengths_, lengths, rtol=1e-10)


def test_least_squares_fit_recovers_strains_from_a_perturbed_start():
    lengths = [0.07, 0.1]
    q, poses = pcs_poses(lengths, n_frames=30, seed=4)
    s = np.linspace(0.0, 0.17, N_MARKERS + 1)
    rng = np.random.default_rng(0)
    q0 = q + rng.normal(0.0, 1.0, q.shape) * np.tile([3.0, 0.03, 0.03], 2)
    est, cost = fit_strains_least_squares(poses[:, 1:, :], lengths, s[1:], q0)
    np.testing.assert_allclose(est, q, atol=1e-8)
    assert np.all(cost < 1e-12)


# --------------------------------------------------------------------------
# Algorithm 1 on synthetic PCS robots (the scenario lengths)
# --------------------------------------------------------------------------
@pytest.mark.parametrize("lengths", [[0.1], [0.07, 0.1], [0.05, 0.1, 0.06]])
def test_fusion_recovers_segments(lengths):
    _, poses = pcs_poses(lengths, n_frames=120, seed=len(lengths))
    total = sum(lengths)
    spacing = total / N_MARKERS
    fusion = KinematicFusion(threshold=0.2, total_length=total, shape_fit="end_pose").fit(poses)
    assert fusion.n_segments_ == len(lengths)
    np.testing.assert_allclose(np.cumsum(fusion.segment_lengths_), np.cumsum(lengths), atol=spacing + 1e-12)
    np.testing.assert_allclose(fusion.segment_lengths_.sum(), total)
    assert fusion.boundaries_[-1] == N_MARKERS
    np.testing.assert_allclose(fusion.marker_arc_lengths_[fusion.boundaries_], np.cumsum(fusion.segment_lengths_))
    assert fusion.distance_profile_.shape == (N_MARKERS - 1,)
    assert fusion.history_[0]["boundaries"].size == N_MARKERS
    # inside a constant-strain segment the initial segments have identical strains
    true_ends = np.cumsum(lengths) / spacing
    inside = [i for i in range(N_MARKERS - 1) if not np.any((true_ends > i) & (true_ends < i + 2))]
    np.testing.assert_allclose(fusion.distance_profile_[inside], 0.0, atol=1e-8)


def test_seed_algorithm_keeps_a_straddling_segment_that_absorption_removes():
    # the 150 mm boundary falls inside the marker interval 14-15: a blend of two segments
    _, poses = pcs_poses([0.05, 0.1, 0.06], n_frames=120, seed=3)
    seed_like = KinematicFusion(total_length=0.21, shape_fit="end_pose", min_segment_markers=1).fit(poses)
    ours = KinematicFusion(total_length=0.21, shape_fit="end_pose").fit(poses)
    assert seed_like.n_segments_ > 3
    assert np.min(np.diff(np.concatenate([[0], seed_like.boundaries_]))) == 1  # a one-spacing sliver
    assert ours.n_segments_ == 3
    assert any("absorbed" in step for step in ours.history_)


def test_least_squares_boundary_within_1mm_two_segments():
    lengths = [0.07, 0.1]
    _, poses = pcs_poses(lengths, n_frames=120, seed=2)
    fusion = KinematicFusion(total_length=0.17).fit(poses)  # least squares is the default
    assert fusion.n_segments_ == 2
    assert abs(fusion.segment_lengths_[0] - 0.07) < 1e-3
    # noise-free PCS data: the refined segmentation reproduces every marker
    rec = fusion.reconstruct(poses)[0].poses
    assert np.max(np.abs(rec - poses)) < 1e-5


@pytest.mark.parametrize("shape_fit", ["end_pose", "least_squares"])
def test_round_trip_exact_when_segmentation_is_right(shape_fit):
    lengths = [0.08, 0.12]  # boundary on marker 8
    q, poses = pcs_poses(lengths, n_frames=80, seed=5)
    traj = PoseTrajectory(poses, dt=1e-3)
    fusion = KinematicFusion(total_length=0.2, shape_fit=shape_fit, refine_boundaries=False).fit([traj])
    np.testing.assert_array_equal(fusion.boundaries_, [8, 20])
    strains = fusion.transform([traj])
    assert isinstance(strains[0], StrainTrajectory)
    assert strains[0].q.shape == (80, 6)
    np.testing.assert_allclose(strains[0].segment_lengths, lengths)
    np.testing.assert_allclose(strains[0].t, traj.t)
    np.testing.assert_allclose(strains[0].q, q, atol=1e-8)
    rec = fusion.inverse_transform(strains)
    assert isinstance(rec[0], PoseTrajectory) and rec[0].poses.shape == poses.shape
    np.testing.assert_allclose(rec[0].poses, poses, atol=1e-10)
    assert -1e-10 < fusion.score([traj]) <= 0.0


def test_rigid_motion_and_wrapped_angles_do_not_change_the_result():
    lengths = [0.07, 0.1]
    q, poses = pcs_poses(lengths, n_frames=60, seed=6, kappa_max=45.0)
    assert np.max(np.abs(poses[..., 2])) > np.pi  # the tip curls past ±180°
    moved = se2_compose(np.array([0.3, -0.2, 2.5]), poses)  # the same robot seen in another frame
    moved[..., 2] = wrap_angle(moved[..., 2])  # as a vision step without unwrapping would report it
    ref = KinematicFusion(total_length=0.17, shape_fit="end_pose").fit(poses)
    other = KinematicFusion(total_length=0.17, shape_fit="end_pose").fit(moved)
    np.testing.assert_array_equal(ref.boundaries_, other.boundaries_)
    np.testing.assert_allclose(ref.distance_profile_, other.distance_profile_, atol=1e-9)
    np.testing.assert_allclose(ref.transform(poses)[0].q, other.transform(moved)[0].q, atol=1e-9)
    # the reconstruction moves with the data
    rec = other.reconstruct(moved)[0].poses
    expected = se2_compose(np.array([0.3, -0.2, 2.5]), ref.reconstruct(poses)[0].poses)
    np.testing.assert_allclose(rec[..., :2], expected[..., :2], atol=1e-10)
    np.testing.assert_allclose(wrap_angle(rec[..., 2] - expected[..., 2]), 0.0, atol=1e-10)


def test_least_squares_halves_strain_error_under_seed_noise():
    lengths = [0.1]
    q, poses = pcs_poses(lengths, n_frames=150, seed=7)
    noisy = add_noise(poses, 5e-4, np.deg2rad(1.0), seed=8)
    errors = {}
    for shape_fit in ("end_pose", "least_squares"):
        fusion = KinematicFusion(total_length=0.1, shape_fit=shape_fit).fit(noisy)
        assert fusion.n_segments_ == 1
        est = fusion.transform(noisy)[0].q
        errors[shape_fit] = np.mean(np.abs(est - q), axis=0) / np.array([60.0, 0.3, 0.3])
    assert np.all(errors["least_squares"] <= 0.5 * errors["end_pose"])


def test_noisy_two_segment_fusion_and_boundary():
    lengths = [0.07, 0.1]
    _, poses = pcs_poses(lengths, n_frames=150, seed=9)
    noisy = add_noise(poses, 1e-4, np.deg2rad(0.5), seed=10)
    fusion = KinematicFusion(total_length=0.17, pose_std=(1e-4, np.deg2rad(0.5))).fit(noisy)
    assert fusion.n_segments_ == 2
    assert abs(fusion.segment_lengths_[0] - 0.07) < 1e-3


# --------------------------------------------------------------------------
# PAC robot: threshold sweep and selection
# --------------------------------------------------------------------------
def pac_poses(n_frames=80, seed=0, length=0.15):
    from pcs_sindy.simulation.pac import pac_forward_kinematics

    rng = np.random.default_rng(seed)
    config = np.column_stack(
        [
            rng.uniform(-20.0, 20.0, n_frames),
            rng.uniform(-250.0, 250.0, n_frames),
            rng.uniform(-0.2, 0.2, (n_frames, 2)),
        ]
    )
    s = np.linspace(0.0, length, N_MARKERS + 1)
    return pac_forward_kinematics(config, length, s[1:]), s


def test_pac_sweep_is_sensible():
    markers, s = pac_poses()
    poses = np.concatenate([np.zeros((markers.shape[0], 1, 3)), markers], axis=1)
    hs = [0.01, 0.02, 0.05, 0.1, 0.2, 1.0]
    # affine curvature: adjacent pieces differ by c1 Δs everywhere, so the seed's rule merges
    # all pairs or none ...
    seed_rows = threshold_sweep(poses, hs, fusion=KinematicFusion(total_length=0.15, shape_fit="end_pose"))
    assert {r.n_segments for r in seed_rows} <= {1, 10, 20}
    # ... while merging the closest pair at a time yields models of every complexity
    template = KinematicFusion(total_length=0.15, shape_fit="end_pose", merge="closest_pair")
    rows = threshold_sweep(poses, hs, fusion=template)
    assert [r.h for r in rows] == hs
    n = [r.n_segments for r in rows]
    assert all(a >= b for a, b in zip(n, n[1:], strict=False))  # larger h never adds segments
    assert n[-1] == 1 and len(set(n)) >= 5
    e_p = [r.e_p_dist for r in rows]
    e_th = [r.e_theta_dist for r in rows]
    assert all(a <= b for a, b in zip(e_p, e_p[1:], strict=False))  # fewer segments, larger error
    assert all(a <= b for a, b in zip(e_th, e_th[1:], strict=False))
    assert e_p[0] < 1e-3 * e_p[-1]  # pairs of marker intervals nearly reproduce every marker
    # the errors are those of the fitted model at that threshold
    fusion = clone(template).set_params(threshold=0.1).fit(poses)
    assert rows[3].e_p_dist == pytest.approx(-fusion.score(poses), rel=1e-12)
    chosen = select_threshold(rows)
    assert chosen in rows and 1 < chosen.n_segments < N_MARKERS
    assert chosen.e_p_dist < 0.01 * 0.15  # within 1 % of the robot's length


def test_select_threshold_largest_decrease_per_added_segment():
    rows = [
        SweepRow(0.05, 6, 0.6e-3, 0.01),
        SweepRow(0.1, 3, 1.0e-3, 0.02),
        SweepRow(0.15, 3, 1.1e-3, 0.02),
        SweepRow(0.3, 2, 4.0e-3, 0.05),
        SweepRow(1.0, 1, 5.0e-3, 0.09),
    ]
    # gains per added segment: 1->2: 1.0e-3, 2->3: 3.0e-3, 3->6: 0.13e-3
    assert select_threshold(rows) == rows[1]
    # in angle: 1->2: 0.04, 2->3: 0.03
    assert select_threshold(rows, error="e_theta_dist") == rows[3]
    assert select_threshold([rows[-1]]) == rows[-1]
    with pytest.raises(ValueError, match="error"):
        select_threshold(rows, error="e_x")
    with pytest.raises(ValueError, match="non-finite"):
        select_threshold([SweepRow(0.1, 2, float("nan"), 0.1)])


def test_select_threshold_relative_drop_per_added_segment():
    # the errors of three_segment's candidates (docs/results.md): 1: 17.4 mm, 2: 6.8 mm, 3: 0.26 mm
    rows = [SweepRow(0.05, 3, 0.26e-3, 0.01), SweepRow(1.0, 2, 6.8e-3, 0.2), SweepRow(2.0, 1, 17.4e-3, 0.4)]
    # absolute drops: 10.6 mm for the first split, 6.54 mm for the second -> the seed's rule stops at 2
    assert select_threshold(rows, rule="largest_drop") == rows[1]
    # factors: 17.4 / 6.8 = 2.6 and 6.8 / 0.26 = 26 -> 3
    assert select_threshold(rows, rule="relative_drop") == rows[0]
    # per added segment: 1 -> 3 cuts by 17.4 / 3.2 = 5.4 (2.3 per segment), 3 -> 5 by 3.2 / 0.24 = 13 (3.7 per segment)
    five = [SweepRow(0.05, 5, 0.24e-3, 0.01), SweepRow(0.5, 3, 3.2e-3, 0.2), SweepRow(1.0, 1, 18e-3, 0.4)]
    assert select_threshold(five, rule="relative_drop") == five[0]
    assert select_threshold(five, rule="largest_drop") == five[1]
    # an exact model (zero error) stays finite and wins
    exact = [SweepRow(0.05, 2, 0.0, 0.0), SweepRow(1.0, 1, 1e-3, 0.1)]
    assert select_threshold(exact, rule="relative_drop") == exact[0]
    with pytest.raises(ValueError, match="rule must be one of"):
        select_threshold(rows, rule="elbow")


@pytest.mark.parametrize(
    "lengths", [[0.07, 0.1], [0.05, 0.09, 0.06], [0.04, 0.06, 0.05, 0.07, 0.05]], ids=["two", "three", "five"]
)
def test_auto_threshold_recovers_the_true_segment_count(lengths):
    # marker spacing 8.5 / 10 / 13.5 mm: boundaries on or between markers
    _, poses = pcs_poses(lengths, n_frames=120, seed=len(lengths))
    total = sum(lengths)
    fusion = KinematicFusion(total_length=total, shape_fit="end_pose").fit(poses)  # threshold="auto"
    assert fusion.n_segments_ == len(lengths)
    np.testing.assert_allclose(np.cumsum(fusion.segment_lengths_), np.cumsum(lengths), atol=total / N_MARKERS)
    choice = fusion.threshold_choice_
    assert choice["rule"] == "relative_drop" and choice["n_segments"] == len(lengths)
    assert choice["h"] == fusion.threshold_ and str(len(lengths)) in choice["reason"]
    counts = [c[0] for c in choice["candidates"]]
    assert counts == sorted(counts) and counts[0] == 1 and len(lengths) in counts
    # the simplest candidate (one segment) is far off; the chosen one is close (a boundary between
    # markers leaves a straddling piece the end-pose model cannot bend exactly)
    errors = {c[0]: c[1] for c in choice["candidates"]}
    assert errors[len(lengths)] < 0.1 * errors[1]
    # the chosen h, given as a number, gives the same segmentation
    fixed = KinematicFusion(threshold=fusion.threshold_, total_length=total, shape_fit="end_pose").fit(poses)
    np.testing.assert_array_equal(fixed.boundaries_, fusion.boundaries_)
    assert fixed.threshold_choice_ == {"rule": "given", "h": fusion.threshold_}


def test_segmentation_sweep_errors_match_the_estimator():
    _, poses = pcs_poses([0.07, 0.1], n_frames=60, seed=2)
    chain, _ = chain_poses(poses)
    s = np.linspace(0.0, 0.17, N_MARKERS + 1)
    hs = [0.01, 0.1, 5.0]
    rows, bounds = segmentation_sweep([chain], s, hs, (60.0, 0.3, 0.3), min_segment_markers=2)
    template = KinematicFusion(total_length=0.17, shape_fit="end_pose")
    for row, b, ref in zip(rows, bounds, threshold_sweep(poses, hs, fusion=template), strict=True):
        assert row.n_segments == ref.n_segments == b.size
        assert row.e_p_dist == pytest.approx(ref.e_p_dist, rel=1e-9, abs=1e-15)
        assert row.e_theta_dist == pytest.approx(ref.e_theta_dist, rel=1e-9, abs=1e-15)
    assert rows[-1].n_segments == 1 and rows[-1].e_p_dist > 1e-3  # one segment cannot bend twice
    with pytest.raises(ValueError, match="thresholds"):
        segmentation_sweep([chain], s, [0.1, -1.0], (60.0, 0.3, 0.3))


# --------------------------------------------------------------------------
# Validation and scikit-learn conventions
# --------------------------------------------------------------------------
def test_bad_input_raises_value_errors_naming_the_argument():
    _, poses = pcs_poses([0.1], n_frames=10, seed=0)
    with pytest.raises(ValueError, match="shape"):
        KinematicFusion().fit(poses[:, :, :2])
    bad = poses.copy()
    bad[3, 5, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        KinematicFusion().fit(bad)
    with pytest.raises(ValueError, match="at least 2 markers"):
        KinematicFusion().fit(poses[:, :2, :])
    for h in (0.0, -0.1, np.nan):
        with pytest.raises(ValueError, match="threshold"):
            KinematicFusion(threshold=h).fit(poses)
    with pytest.raises(ValueError, match="shape_fit"):
        KinematicFusion(shape_fit="magic").fit(poses)
    with pytest.raises(ValueError, match="scaling"):
        KinematicFusion(scaling="max").fit(poses)
    with pytest.raises(ValueError, match="q_max"):
        KinematicFusion(q_max=(60.0, 0.0, 0.3)).fit(poses)
    with pytest.raises(ValueError, match="total_length"):
        KinematicFusion(total_length=-1.0).fit(poses)
    with pytest.raises(ValueError, match="pose_std"):
        KinematicFusion(pose_std=(1e-3,)).fit(poses)
    with pytest.raises(ValueError, match="merge"):
        KinematicFusion(merge="all").fit(poses)
    with pytest.raises(ValueError, match="min_segment_markers"):
        KinematicFusion(min_segment_markers=0).fit(poses)
    with pytest.raises(ValueError, match="same number of markers"):
        KinematicFusion().fit([poses, poses[:, :-1, :]])
    fusion = KinematicFusion(shape_fit="end_pose").fit(poses)
    with pytest.raises(ValueError, match="markers"):
        fusion.transform(poses[:, :-1, :])
    with pytest.raises(ValueError, match="thresholds"):
        threshold_sweep(poses, [0.1, 0.0])
    with pytest.raises(ValueError, match="threshold"):
        fuse_segments([poses], np.linspace(0, 0.1, 21), 0.0, (60.0, 0.3, 0.3))


def test_transform_before_fit_raises():
    from sklearn.exceptions import NotFittedError

    _, poses = pcs_poses([0.1], n_frames=5, seed=0)
    with pytest.raises(NotFittedError):
        KinematicFusion().transform(poses)


def test_clone_and_params():
    fusion = KinematicFusion(threshold=0.3, q_max=(50.0, 0.2, 0.2), shape_fit="end_pose", total_length=0.1)
    params = fusion.get_params()
    assert params["threshold"] == 0.3 and params["q_max"] == (50.0, 0.2, 0.2)
    assert params["shape_fit"] == "end_pose" and params["total_length"] == 0.1
    _, poses = pcs_poses([0.1], n_frames=20, seed=0)
    fusion.fit(poses)
    copy = clone(fusion)
    assert copy.get_params() == params
    assert not hasattr(copy, "segment_lengths_")
    assert fusion.set_params(threshold=0.5) is fusion and fusion.threshold == 0.5


def test_data_scaling_and_per_frame_base():
    lengths = [0.07, 0.1]
    _, poses = pcs_poses(lengths, n_frames=80, seed=11)
    fusion = KinematicFusion(total_length=0.17, scaling="data", shape_fit="end_pose", fixed_base=False).fit(poses)
    assert fusion.n_segments_ == 2 and abs(fusion.segment_lengths_[0] - 0.07) <= 0.17 / 20
    # the 99th percentile of |strain| over the initial segments
    chain, _ = chain_poses(poses)
    q = segment_strains(chain, fusion.marker_arc_lengths_, np.arange(1, 21)).reshape(-1, 3)
    np.testing.assert_allclose(fusion.q_max_, np.percentile(np.abs(q), 99, axis=0))


def test_fit_transform_and_strains_without_metadata():
    lengths = [0.08, 0.12]
    q, poses = pcs_poses(lengths, n_frames=30, seed=12)
    fusion = KinematicFusion(total_length=0.2, shape_fit="end_pose")
    strains = fusion.fit_transform([poses])  # as inside a scikit-learn Pipeline
    np.testing.assert_allclose(strains[0].q, fusion.transform([poses])[0].q)
    # a bare StrainTrajectory (no metadata) maps to the fitted marker arc lengths and its base pose
    bare = StrainTrajectory(q, dt=1e-3, segment_lengths=lengths)
    rec = fusion.inverse_transform(bare)[0].poses
    np.testing.assert_allclose(rec, poses, atol=1e-12)
    with pytest.raises(ValueError, match="segment lengths sum"):
        fusion.inverse_transform(StrainTrajectory(q, dt=1e-3, segment_lengths=[0.1, 0.12]))
    with pytest.raises(ValueError, match="truth"):
        threshold_sweep([poses], [0.2], fusion=fusion, truth=[poses[:-1]])


def test_extraction_and_fusion_on_a_rendered_two_segment_video():
    from pcs_sindy.core import Camera
    from pcs_sindy.simulation.rendering import render_frames
    from pcs_sindy.vision import extractor as vision

    lengths = [0.07, 0.1]
    q, poses = pcs_poses(lengths, n_frames=60, seed=13, kappa_max=30.0, sigma_max=0.1)
    camera = Camera()
    frames = render_frames(poses, camera)
    extracted = vision.MarkerPoseExtractor(n_markers=N_MARKERS, camera=camera, dt=1e-3, progress=False).transform(
        [frames]
    )
    fusion = KinematicFusion(total_length=0.17, pose_std=(3e-5, np.deg2rad(0.5))).fit(extracted)
    assert fusion.n_segments_ == 2
    assert abs(fusion.segment_lengths_[0] - 0.07) < 1e-3
    rec = fusion.reconstruct(extracted)[0].poses
    assert np.mean(np.linalg.norm(rec[:, 1:, :2] - poses[:, 1:, :2], axis=-1)) < 1e-4
