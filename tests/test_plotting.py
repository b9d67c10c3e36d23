"""Plots check their content (line data, spans, labels, legends), not pixels.

Truth comes from the inputs themselves, hand-worked segmentations, the
independent ``segmentation.merge_runs`` and plain numpy formulas; the
animation is read back with OpenCV.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import cv2  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pcs_sindy.core import Camera  # noqa: E402
from pcs_sindy.plotting import (
    animate_rollout,
    plot_end_effector,
    plot_error_vs_segments,
    plot_rollout,
    plot_stills,
    plot_strain_distance_profile,
    plot_tip_positions,
)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _spans(ax):
    """(start, end) in data x of the shaded bands, left to right."""
    out = []
    for p in ax.patches:
        # axvspan draws a Polygon before matplotlib 3.9 and a Rectangle since: read either through its path
        xs = p.get_patch_transform().transform(p.get_path().vertices)[:, 0]
        out.append((float(xs.min()), float(xs.max())))
    return sorted(out)


def _legend_texts(ax):
    leg = ax.get_legend()
    assert leg is not None, "axes has no legend"
    return [t.get_text() for t in leg.get_texts()]


# --------------------------------------------------------------------------
# strain-distance profile (seed Fig. 6)
# --------------------------------------------------------------------------
def _profile(split_at=(7, 13), equal_at=4, n_markers=20):
    d = np.full(n_markers - 1, 0.05)
    for m in split_at:
        d[m - 1] = 0.9  # pair (m, m + 1) meets at marker m
    d[equal_at - 1] = 0.2  # exactly the threshold: merged (seed: "below or equal")
    return d


def test_profile_default_segments_follow_one_merge_step():
    d = _profile()
    fig = plot_strain_distance_profile(d, 0.2)
    ax = fig.axes[0]
    dist_line, thr_line = ax.get_lines()[:2]
    np.testing.assert_array_equal(dist_line.get_xydata(), np.column_stack([np.arange(1, 20), d]))
    assert np.all(np.asarray(thr_line.get_ydata()) == 0.2) and thr_line.get_linestyle() == "--"
    # hand-worked: splits at markers 7 and 13 of 20 -> three bands
    assert _spans(ax) == [(0.0, 7.0), (7.0, 13.0), (13.0, 20.0)]
    assert ax.get_xlabel() and "[-]" in ax.get_ylabel()
    assert any("h = 0.2" in s for s in _legend_texts(ax))


def test_profile_default_matches_merge_runs_of_segmentation():
    from pcs_sindy.fusion import merge_runs

    rng = np.random.default_rng(3)
    for _ in range(5):
        d = rng.uniform(0, 0.4, size=14)
        groups = merge_runs(d, 0.2)
        ends = [g[-1] + 1 for g in groups]  # marker index of each group's end
        starts = [0] + ends[:-1]
        fig = plot_strain_distance_profile(d, 0.2)
        assert _spans(fig.axes[0]) == [(float(a), float(b)) for a, b in zip(starts, ends, strict=True)]
        plt.close(fig)


def test_profile_boundaries_and_arc_lengths():
    d = _profile(split_at=(7,))
    s = np.linspace(0.0, 0.17, 21)
    fig = plot_strain_distance_profile(d, 0.2, boundaries=[7, 20], marker_arc_lengths=s)
    ax = fig.axes[0]
    np.testing.assert_array_equal(ax.get_lines()[0].get_xydata(), np.column_stack([s[1:20], d]))
    spans = _spans(ax)
    assert len(spans) == 2
    np.testing.assert_allclose(spans, [(0.0, s[7]), (s[7], 0.17)], rtol=0, atol=1e-15)
    assert "[m]" in ax.get_xlabel()


def test_profile_refined_segment_lengths():
    d = _profile(split_at=(8,))
    s = np.linspace(0.0, 0.17, 21)
    fig = plot_strain_distance_profile(d, 0.2, marker_arc_lengths=s, segment_lengths=[0.068, 0.102])
    np.testing.assert_allclose(_spans(fig.axes[0]), [(0.0, 0.068), (0.068, 0.17)], atol=1e-15)


def test_profile_from_a_fitted_kinematic_fusion():
    # the attributes of the real estimator plug in directly (two true segments 0.07 + 0.1 m)
    from pcs_sindy.core import forward_kinematics
    from pcs_sindy.fusion import KinematicFusion

    tt = np.linspace(0.0, 1.0, 30)
    q = np.zeros((30, 6))
    q[:, 0], q[:, 3] = 40 * np.sin(6 * tt), -30 * np.cos(5 * tt)
    q[:, 1], q[:, 5] = 0.05 * np.sin(4 * tt), 0.1 * np.cos(3 * tt)
    poses = forward_kinematics(q, (0.07, 0.1), np.linspace(0.0, 0.17, 21))
    fusion = KinematicFusion(threshold=0.2, shape_fit="end_pose").fit([poses])
    fig = plot_strain_distance_profile(
        fusion.distance_profile_, fusion.threshold, fusion.boundaries_, fusion.marker_arc_lengths_
    )
    ax = fig.axes[0]
    s = fusion.marker_arc_lengths_
    np.testing.assert_array_equal(ax.get_lines()[0].get_xydata(), np.column_stack([s[1:-1], fusion.distance_profile_]))
    spans = _spans(ax)
    assert len(spans) == fusion.n_segments_
    np.testing.assert_allclose(np.diff(spans, axis=1).ravel(), np.diff(s[np.r_[0, fusion.boundaries_]]))


def test_profile_draws_into_given_axes():
    fig, ax = plt.subplots()
    out = plot_strain_distance_profile(_profile(), 0.3, ax=ax)
    assert out is fig and len(ax.get_lines()) == 2


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(distances=np.ones((2, 3)), threshold=0.2), "distances"),
        (dict(distances=[0.1, np.nan], threshold=0.2), "distances"),
        (dict(distances=[0.1, -0.1], threshold=0.2), "distances"),
        (dict(distances=[0.1, 0.3], threshold=-1.0), "threshold"),
        (dict(distances=[0.1, 0.3], threshold=0.2, boundaries=[1, 2]), "boundaries"),
        (dict(distances=[0.1, 0.3], threshold=0.2, boundaries=[2, 1, 3]), "boundaries"),
        (dict(distances=[0.1, 0.3], threshold=0.2, marker_arc_lengths=[0, 0.1, 0.2]), "marker_arc_lengths"),
        (dict(distances=[0.1, 0.3], threshold=0.2, marker_arc_lengths=[0, 0.2, 0.1, 0.3]), "marker_arc_lengths"),
        (dict(distances=[0.1, 0.3], threshold=0.2, segment_lengths=[0.1, 0.2]), "segment_lengths"),
        (
            dict(
                distances=[0.1, 0.3], threshold=0.2, marker_arc_lengths=[0, 0.1, 0.2, 0.3], segment_lengths=[0.1, 0.1]
            ),
            "segment_lengths",
        ),
    ],
)
def test_profile_bad_input(kwargs, word):
    with pytest.raises(ValueError, match=word):
        plot_strain_distance_profile(**kwargs)


# --------------------------------------------------------------------------
# error vs number of segments (seed Fig. 8)
# --------------------------------------------------------------------------
ROWS = [
    (0.05, 5, 2.0e-4, 0.010),
    (0.1, 3, 4.0e-4, 0.020),
    (0.2, 3, 3.0e-4, 0.025),  # same count, lower position error: this one is kept
    (0.5, 2, 9.0e-4, 0.040),
    (1.0, 1, 2.0e-3, 0.100),
]


def test_error_vs_segments_content():
    fig = plot_error_vs_segments(ROWS, selected=ROWS[2])
    ax, twin = fig.axes[0], fig.axes[-1]
    assert twin is not ax
    pos, sel = ax.get_lines()
    (ori,) = twin.get_lines()
    n = [1, 2, 3, 5]
    np.testing.assert_array_equal(pos.get_xydata(), np.column_stack([n, [2.0e-3, 9.0e-4, 3.0e-4, 2.0e-4]]))
    np.testing.assert_array_equal(ori.get_xydata(), np.column_stack([n, [0.100, 0.040, 0.025, 0.010]]))
    assert pos.get_marker() == "s" and ori.get_marker() == "o"
    assert np.all(np.asarray(sel.get_xdata()) == 3)
    assert "[m]" in ax.get_ylabel() and "[rad]" in twin.get_ylabel() and "segments" in ax.get_xlabel()
    texts = _legend_texts(ax)
    assert len(texts) == 3 and any("h = 0.2" in s for s in texts)


def test_error_vs_segments_accepts_sweep_rows_and_int_selection():
    from pcs_sindy.fusion import SweepRow

    rows = [SweepRow(*r) for r in ROWS]
    fig = plot_error_vs_segments(rows, selected=2, logy=True)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log" and len(ax.get_lines()) == 2
    assert np.all(np.asarray(ax.get_lines()[1].get_xdata()) == 2)


@pytest.mark.parametrize(
    "rows, selected, word",
    [
        ([(0.1, 2, np.nan, 0.1)], None, "rows"),
        ([(0.1, 2, 1e-3)], None, "rows"),
        ([(0.1, 2.5, 1e-3, 0.1)], None, "rows"),
        ([], None, "rows"),
        (ROWS, 4, "selected"),
    ],
)
def test_error_vs_segments_bad_input(rows, selected, word):
    with pytest.raises(ValueError, match=word):
        plot_error_vs_segments(rows, selected=selected)


# --------------------------------------------------------------------------
# rollouts (seed Fig. 9)
# --------------------------------------------------------------------------
T = 40
t_grid = np.linspace(0.0, 0.39, T)


def _strains(n, phase=0.0):
    k = np.arange(1, n + 1)
    return np.sin(np.outer(t_grid, k) * 7 + phase) * np.where(np.arange(n) % 3 == 0, 20.0, 0.1)


def test_rollout_type_layout_two_segments():
    q, qp = _strains(6), _strains(6, 0.1)
    fig = plot_rollout(t_grid, q, qp, residuals=False)
    assert len(fig.axes) == 3
    for panel, ax in enumerate(fig.axes):
        lines = ax.get_lines()
        assert len(lines) == 4  # per segment: truth, prediction
        cols = [panel, panel + 3]  # be_1, be_2 / sh_1, sh_2 / ax_1, ax_2
        for j, k in enumerate(cols):
            truth, pred = lines[2 * j], lines[2 * j + 1]
            np.testing.assert_array_equal(truth.get_xydata(), np.column_stack([t_grid, q[:, k]]))
            np.testing.assert_array_equal(pred.get_xydata(), np.column_stack([t_grid, qp[:, k]]))
            assert truth.get_linestyle() == ":" and pred.get_linestyle() == "-"
        assert ax.get_legend() is not None
    assert "[1/m]" in fig.axes[0].get_ylabel() and "[-]" in fig.axes[1].get_ylabel()
    assert "[s]" in fig.axes[-1].get_xlabel()
    # one model: the colour tells the segment, truth and model alike
    colours = [matplotlib.colors.to_hex(line.get_color()) for line in fig.axes[0].get_lines()]
    assert colours[0] == colours[1] and colours[2] == colours[3] and colours[0] != colours[2]


def test_rollout_several_predictions_one_segment():
    q = _strains(3)
    preds = {"no noise": _strains(3, 0.05), "noise": _strains(3, 0.2)}
    fig = plot_rollout(t_grid, q, preds, residuals=False)
    assert len(fig.axes) == 3
    for k, ax in enumerate(fig.axes):
        lines = ax.get_lines()
        assert len(lines) == 3
        np.testing.assert_array_equal(lines[0].get_ydata(), q[:, k])
        np.testing.assert_array_equal(lines[1].get_ydata(), preds["no noise"][:, k])
        np.testing.assert_array_equal(lines[2].get_ydata(), preds["noise"][:, k])
    assert _legend_texts(fig.axes[0]) == ["truth", "no noise", "noise"]


def test_rollout_strain_layout_for_several_models_and_segments():
    q = _strains(6)
    fig = plot_rollout(t_grid, q, [q * 0.9, q * 1.1], labels=["a", "b"], residuals=False)
    assert len(fig.axes) == 6  # one subplot per strain
    for k, ax in enumerate(fig.axes):
        np.testing.assert_array_equal(ax.get_lines()[2].get_ydata(), 1.1 * q[:, k])
    assert fig.axes[3].get_ylabel() == "be_2 [1/m]"


def test_rollout_custom_names_and_axes():
    q = _strains(2)
    fig, axes = plt.subplots(2)
    out = plot_rollout(t_grid, q, q, names=["alpha", "beta"], axes=axes, residuals=False)
    assert out is fig and axes[1].get_ylabel() == "beta"
    with pytest.raises(ValueError, match="4 matplotlib Axes"):  # with residuals: a panel below each
        plot_rollout(t_grid, q, q, names=["alpha", "beta"], axes=axes)


@pytest.mark.parametrize(
    "args, kwargs, word",
    [
        ((t_grid, _strains(3), _strains(3)[:-1]), {}, "q_pred"),
        ((t_grid[:-1], _strains(3), _strains(3)), {}, "q_true"),
        ((t_grid[::-1], _strains(3), _strains(3)), {}, "t"),
        ((t_grid, _strains(3), _strains(3)), dict(names=["a", "b"]), "names"),
        ((t_grid, _strains(3), [_strains(3), _strains(3)]), dict(labels=["one"]), "labels"),
        ((t_grid, _strains(3), _strains(3)), dict(layout="grid"), "layout"),
        ((t_grid, _strains(2), _strains(2)), dict(layout="type"), "layout"),
        ((t_grid, _strains(3), _strains(3)), dict(axes=[None]), "axes"),
    ],
)
def test_rollout_bad_input(args, kwargs, word):
    with pytest.raises(ValueError, match=word):
        plot_rollout(*args, **kwargs)


def test_end_effector_content_and_errors():
    rng = np.random.default_rng(0)
    tip = rng.normal(size=(T, 3))
    pred = tip + rng.normal(scale=1e-3, size=(T, 3))
    fig = plot_end_effector(t_grid, tip, [pred], labels=["model"], residuals=False)
    assert len(fig.axes) == 3
    for c, ax in enumerate(fig.axes):
        truth, p = ax.get_lines()
        np.testing.assert_array_equal(truth.get_xydata(), np.column_stack([t_grid, tip[:, c]]))
        np.testing.assert_array_equal(p.get_xydata(), np.column_stack([t_grid, pred[:, c]]))
    units = [ax.get_ylabel() for ax in fig.axes]
    assert "[m]" in units[0] and "[m]" in units[1] and "[rad]" in units[2]
    # seed eqs. 25-26 computed here directly
    e_p = np.mean(np.hypot(*(pred[:, :2] - tip[:, :2]).T))
    e_th = np.mean(np.abs(pred[:, 2] - tip[:, 2]))
    label = _legend_texts(fig.axes[0])[1]
    assert label.startswith("model") and f"{1e3 * e_p:.3g} mm" in label and f"{e_th:.3g} rad" in label


def test_rollout_residual_panels_show_model_minus_truth():
    """Issue 28: a model's line covers the truth's; the residual panel below shows the difference."""
    q = _strains(6)
    qp = q + 1e-3 * np.cos(7 * t_grid)[:, None] * np.arange(1, 7)
    fig = plot_rollout(t_grid, q, qp)
    assert len(fig.axes) == 6  # bending, its residuals, shear, its residuals, axial, its residuals
    for panel in range(3):
        res = fig.axes[2 * panel + 1]
        zero, *lines = res.get_lines()
        np.testing.assert_array_equal(zero.get_ydata(), [0.0, 0.0])
        assert len(lines) == 2  # segments 1 and 2
        for line, k in zip(lines, (panel, panel + 3), strict=True):
            np.testing.assert_allclose(line.get_ydata(), qp[:, k] - q[:, k], rtol=0, atol=1e-15)
    assert "model - truth" in fig.axes[1].get_ylabel() and "[1/m]" in fig.axes[1].get_ylabel()
    assert "[-]" in fig.axes[3].get_ylabel()
    # the data panels are unchanged by the residuals
    np.testing.assert_array_equal(fig.axes[0].get_lines()[1].get_ydata(), qp[:, 0])


def test_end_effector_residual_panels_are_the_seed_errors_over_time():
    rng = np.random.default_rng(1)
    tip = rng.normal(size=(T, 3))
    pred = tip + rng.normal(scale=1e-3, size=(T, 3))
    pred[3, 2] = tip[3, 2] + 2 * np.pi - 0.01  # an angle error across the wrap: 0.01 rad, not 6.27
    fig = plot_end_effector(t_grid, tip, pred)
    assert len(fig.axes) == 5
    e_p = 1e3 * np.sqrt((pred[:, 0] - tip[:, 0]) ** 2 + (pred[:, 1] - tip[:, 1]) ** 2)
    e_th = np.abs(pred[:, 2] - tip[:, 2])
    e_th[3] = 0.01
    (err_p, mean_p), (err_th, mean_th) = fig.axes[3].get_lines(), fig.axes[4].get_lines()
    np.testing.assert_allclose(err_p.get_ydata(), e_p, rtol=1e-12)
    np.testing.assert_allclose(err_th.get_ydata(), e_th, rtol=1e-9)
    assert mean_p.get_ydata()[0] == pytest.approx(e_p.mean()) and mean_th.get_ydata()[0] == pytest.approx(e_th.mean())
    assert "[mm]" in fig.axes[3].get_ylabel() and "[rad]" in fig.axes[4].get_ylabel()


def test_tip_positions_keep_measurement_gaps_and_give_the_error():
    rng = np.random.default_rng(2)
    tip = rng.normal(size=(T, 3))
    tip[5:8] = np.nan  # samples the tracker lost
    pred = np.nan_to_num(tip) + 1e-3 * rng.normal(size=(T, 3))
    fig = plot_tip_positions(t_grid, tip, pred, labels=["PCS"])
    assert len(fig.axes) == 4
    ok = np.all(np.isfinite(tip), axis=1)
    e = 1e3 * np.sqrt(np.sum((pred - tip) ** 2, axis=1))
    (line,) = fig.axes[3].get_lines()
    np.testing.assert_allclose(line.get_ydata()[ok], e[ok], rtol=1e-12)
    assert np.all(np.isnan(line.get_ydata()[~ok]))
    label = _legend_texts(fig.axes[0])[1]
    assert f"RMSE {np.sqrt(np.mean(e[ok] ** 2)):.3g} mm" in label and f"mean {np.mean(e[ok]):.3g} mm" in label
    np.testing.assert_array_equal(fig.axes[2].get_lines()[0].get_ydata(), tip[:, 2])
    assert fig.axes[2].get_ylabel() == "tip Z [m]"
    with pytest.raises(ValueError, match="tip_pred"):
        plot_tip_positions(t_grid, tip, pred[:, :2])
    with pytest.raises(ValueError, match="no measured"):
        plot_tip_positions(t_grid, np.full((T, 3), np.nan), pred)
    with pytest.raises(ValueError, match="tip_true"):
        plot_tip_positions(t_grid, tip[:, :1], pred[:, :1])


def test_end_effector_bad_input():
    tip = np.zeros((T, 3))
    with pytest.raises(ValueError, match="tip_pred"):
        plot_end_effector(t_grid, tip, np.zeros((T, 2)))
    with pytest.raises(ValueError, match="tip_true"):
        plot_end_effector(t_grid, np.zeros((T, 4)), tip)
    with pytest.raises(ValueError, match="labels"):
        plot_end_effector(t_grid, tip, {"a": tip}, labels=["b"])


# --------------------------------------------------------------------------
# stills (seed Fig. 3 / 10)
# --------------------------------------------------------------------------
def _arc_poses(K=3, P=6):
    s = np.linspace(0, 0.1, P)
    out = np.zeros((K, P, 3))
    for k in range(K):
        out[k, :, 0] = 0.02 * k * s / 0.1
        out[k, :, 1] = s
        out[k, :, 2] = 0.1 * k
    return out


def test_stills_from_poses_in_metres():
    poses = _arc_poses()
    backbone = poses[:, :, :2] + 0.001
    fig = plot_stills(poses=poses, backbone=backbone, times=[0.0, 0.5, 1.0])
    assert len(fig.axes) == 3
    for k, ax in enumerate(fig.axes):
        mark, line = ax.get_lines()
        np.testing.assert_array_equal(mark.get_xydata(), poses[k, :, :2])
        np.testing.assert_array_equal(line.get_xydata(), backbone[k])
        assert ax.yaxis_inverted()  # base at the top, as in the videos
        assert ax.get_title() == f"t = {[0.0, 0.5, 1.0][k]:.3g} s"
        assert "[m]" in ax.get_xlabel()
    assert "[m]" in fig.axes[0].get_ylabel()
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert texts == ["true markers", "model backbone"]


def test_stills_on_frames_with_camera():
    cam = Camera(pixels_per_metre=1000.0, origin=(10.0, 20.0), image_size=(160, 140))
    frames = np.zeros((2, 140, 160, 3), dtype=np.uint8)
    frames[..., 0] = 200  # blue in BGR
    poses = _arc_poses(K=2)
    detected = [poses[0, :4], poses[1, :5, :2]]  # detections vary per still
    backbone = poses[:, :, :2]
    fig = plot_stills(frames, detected=detected, backbone=backbone, camera=cam, crop=False)
    for k, ax in enumerate(fig.axes):
        (img,) = ax.images
        np.testing.assert_array_equal(img.get_array(), frames[k][..., ::-1])  # shown as RGB
        bb, det = ax.get_lines()
        # u = u0 + ppm x, v = v0 + ppm y for angle 0
        np.testing.assert_allclose(
            bb.get_xydata(), np.column_stack([10 + 1000 * backbone[k, :, 0], 20 + 1000 * backbone[k, :, 1]])
        )
        np.testing.assert_allclose(
            det.get_xydata(), np.column_stack([10 + 1000 * detected[k][:, 0], 20 + 1000 * detected[k][:, 1]])
        )


def test_stills_with_a_still_where_nothing_was_detected():
    poses = _arc_poses(K=2)
    fig = plot_stills(poses=poses, detected=[poses[0], np.empty((0, 3))])
    first, second = (ax.get_lines()[-1] for ax in fig.axes)
    np.testing.assert_array_equal(first.get_xydata(), poses[0, :, :2])
    assert second.get_xydata().shape == (0, 2)


def test_stills_grey_frames_pixels_and_duck_typed_camera():
    class Doubler:
        def to_pixels(self, xy):
            return 2.0 * np.asarray(xy)

    frames = [np.full((30, 40), 255, dtype=np.uint8)] * 2
    det = np.array([[[1.0, 2.0]], [[3.0, 4.0]]])
    fig = plot_stills(frames, detected=det, camera=Doubler())
    np.testing.assert_array_equal(fig.axes[1].get_lines()[0].get_xydata(), [[6.0, 8.0]])
    fig2 = plot_stills(frames, detected=det)  # no camera: overlays already in pixels
    np.testing.assert_array_equal(fig2.axes[1].get_lines()[0].get_xydata(), [[3.0, 4.0]])
    np.testing.assert_array_equal(fig2.axes[0].images[0].get_array(), frames[0])


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(), "frames or poses"),
        (dict(poses=_arc_poses(), times=[0.0, 1.0]), "times"),
        (dict(poses=_arc_poses(), detected=_arc_poses(K=2)), "detected"),
        (dict(poses=_arc_poses(), backbone=_arc_poses()[:, :1]), "backbone"),
        (dict(poses=_arc_poses()[..., :1]), "poses"),
        (dict(poses=_arc_poses(), camera=object()), "camera"),
        (dict(frames=np.zeros((2, 5, 5, 4))), "frames"),
        (dict(poses=_arc_poses(), labels={"truth": "x"}), "labels"),
    ],
)
def test_stills_bad_input(kwargs, word):
    with pytest.raises(ValueError, match=word):
        plot_stills(**kwargs)


# --------------------------------------------------------------------------
# animation
# --------------------------------------------------------------------------
def _rollout(n_frames, n_points=15):
    t = np.arange(n_frames) * 1e-3
    s = np.linspace(0, 0.1, n_points)
    ang = 0.5 * np.sin(40 * t)[:, None] * s[None] / 0.1
    xy = np.stack([0.1 * np.sin(ang) * s / 0.1, s * np.cos(ang)], axis=-1)
    return t, xy


def _read_video(path):
    cap = cv2.VideoCapture(str(path))
    assert cap.isOpened()
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames


def _read_gif(path):
    from PIL import Image, ImageSequence

    with Image.open(path) as img:
        assert img.format == "GIF"
        return [np.asarray(f.convert("RGB"))[..., ::-1] for f in ImageSequence.Iterator(img)]


@pytest.mark.parametrize("suffix", [".avi", ".mp4", ".webm", ".gif"])
def test_animation_file(tmp_path, suffix):
    t, xy = _rollout(49)
    before = plt.get_fignums()
    out = animate_rollout(
        tmp_path / f"roll{suffix}",
        t,
        xy,
        xy + 0.002,
        markers_true=xy[:, ::3],
        stride=4,
        size=(160, 128),
        dpi=40,
        progress=False,
    )
    assert out == tmp_path / f"roll{suffix}" and out.is_file()
    frames = _read_gif(out) if suffix == ".gif" else _read_video(out)
    assert len(frames) == math.ceil(49 / 4)  # samples 0, 4, ..., 48
    assert all(f.shape == (128, 160, 3) for f in frames)
    assert not np.array_equal(frames[0], frames[len(frames) // 2])  # the robot moves
    assert plt.get_fignums() == before  # no pyplot figure left behind


def test_animation_default_stride_is_real_time(tmp_path):
    t, xy = _rollout(100)  # 0.1 s at 1 kHz; 50 fps -> every 20th sample
    out = animate_rollout(tmp_path / "r.avi", t, xy, xy, fps=50, size=(64, 64), dpi=20, progress=False)
    assert len(_read_video(out)) == 5


def test_animation_bad_input(tmp_path):
    t, xy = _rollout(10)
    with pytest.raises(ValueError, match="path"):
        animate_rollout(tmp_path / "r.mkv", t, xy, xy)
    with pytest.raises(OSError, match="path"):
        animate_rollout(tmp_path / "missing" / "r.avi", t, xy, xy)
    with pytest.raises(ValueError, match="backbone_pred"):
        animate_rollout(tmp_path / "r.avi", t, xy, xy[:-1])
    with pytest.raises(ValueError, match="markers_true"):
        animate_rollout(tmp_path / "r.avi", t, xy, xy, markers_true=xy[:, :, :1])
    with pytest.raises(ValueError, match="size"):
        animate_rollout(tmp_path / "r.avi", t, xy, xy, size=(65, 64))
    with pytest.raises(ValueError, match="stride"):
        animate_rollout(tmp_path / "r.avi", t, xy, xy, stride=0)
    with pytest.raises(ValueError, match="fps"):
        animate_rollout(tmp_path / "r.avi", t, xy, xy, fps=-1.0)
