"""The 3-D figures check their content (line data, panels, legends), not pixels.

Truth: the inputs themselves, errors recomputed here with numpy, and backbones in closed form (a
straight robot, a circular arc) rather than the package's forward kinematics.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pcs_sindy.core import SpatialPCS  # noqa: E402
from pcs_sindy.plotting import plot_positions_3d, plot_shapes_3d  # noqa: E402


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _data3d(line):
    return np.column_stack(line.get_data_3d())


def _positions(n_t=40, n_points=3, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2.0, n_t)
    meas = rng.normal(scale=0.05, size=(n_t, n_points, 3))
    pred = meas + rng.normal(scale=2e-3, size=meas.shape)
    meas[5:9, -1] = np.nan  # the tip lost for 4 samples
    meas[12, 0, 1] = np.nan  # one coordinate missing: the whole sample is missing
    return t, meas, pred


# --------------------------------------------------------------------------
# positions predicted against measured
# --------------------------------------------------------------------------
def test_positions_figure_has_the_3d_time_and_error_panels():
    t, meas, pred = _positions()
    fig = plot_positions_3d(t, meas, {"model A": pred, "model B": pred + 1e-3})
    ax3, ax_x, ax_y, ax_z, ax_err = fig.axes
    assert ax3.name == "3d" and all(a.name != "3d" for a in (ax_x, ax_y, ax_z, ax_err))
    # 3-D panel: per point the measurement, then one line per prediction
    lines = ax3.get_lines()
    assert len(lines) == 3 * 3
    for k in range(3):
        want = meas[:, k].copy()
        want[~np.all(np.isfinite(want), axis=1)] = np.nan
        np.testing.assert_array_equal(_data3d(lines[3 * k]), want)
        np.testing.assert_array_equal(_data3d(lines[3 * k + 1]), pred[:, k])
        np.testing.assert_array_equal(_data3d(lines[3 * k + 2]), pred[:, k] + 1e-3)
    # coordinates against time: the tip (last point) by default, measurement first
    for c, ax in enumerate((ax_x, ax_y, ax_z)):
        m_line, a_line, b_line = ax.get_lines()
        np.testing.assert_array_equal(m_line.get_xdata(), t)
        np.testing.assert_array_equal(m_line.get_ydata(), meas[:, -1, c])
        np.testing.assert_array_equal(a_line.get_ydata(), pred[:, -1, c])
        assert m_line.get_linestyle() == ":"
        assert "[m]" in ax.get_ylabel()
    assert "time" in ax_err.get_xlabel() and "[mm]" in ax_err.get_ylabel()
    assert fig.get_suptitle()


def test_error_panel_is_the_norm_of_the_difference_in_mm_with_gaps():
    t, meas, pred = _positions()
    fig = plot_positions_3d(t, meas, pred, labels=["model"])
    ax_err = fig.axes[4]
    tip_line, mean_line = ax_err.get_lines()
    tip_err = 1e3 * np.sqrt(np.sum((pred[:, -1] - meas[:, -1]) ** 2, axis=1))  # NaN where the tip is lost
    np.testing.assert_allclose(tip_line.get_ydata(), tip_err, rtol=1e-12, equal_nan=True)
    assert np.all(np.isnan(tip_line.get_ydata()[5:9]))
    # the mean over the points measured at each sample (dashed)
    per_point = 1e3 * np.sqrt(np.sum((pred - meas) ** 2, axis=2))
    want = np.array([np.mean(row[np.isfinite(row)]) for row in per_point])
    np.testing.assert_allclose(mean_line.get_ydata(), want, rtol=1e-12)
    assert mean_line.get_linestyle() == "--"
    # legend: the tip's RMS error over its measured samples
    rmse = np.sqrt(np.mean(tip_err[np.isfinite(tip_err)] ** 2))
    texts = [tx.get_text() for tx in fig.axes[1].get_legend().get_texts()]
    assert texts[0] == "measured" and texts[1] == f"model: RMSE {rmse:.3g} mm"


def test_one_point_and_a_chosen_point():
    t, meas, pred = _positions(n_points=3)
    fig = plot_positions_3d(t, meas[:, 1], pred[:, 1])
    assert len(fig.axes[0].get_lines()) == 2 and len(fig.axes[4].get_lines()) == 1  # no mean over points
    np.testing.assert_allclose(
        fig.axes[4].get_lines()[0].get_ydata(), 1e3 * np.linalg.norm(pred[:, 1] - meas[:, 1], axis=1), equal_nan=True
    )
    fig = plot_positions_3d(t, meas, pred, point=0)
    np.testing.assert_array_equal(fig.axes[2].get_lines()[0].get_ydata()[:12], meas[:12, 0, 1])
    assert "point 0" in fig.axes[4].get_title()


def test_positions_into_given_axes_and_true_proportions():
    t, meas, pred = _positions()
    fig = plt.figure()
    axes = [fig.add_subplot(2, 3, 1, projection="3d")] + [fig.add_subplot(2, 3, k) for k in range(2, 6)]
    assert plot_positions_3d(t, meas, pred, axes=axes) is fig
    ax3 = axes[0]
    spans = [abs(np.diff(lim)[0]) for lim in (ax3.get_xlim(), ax3.get_ylim(), ax3.get_zlim())]
    np.testing.assert_allclose(spans, spans[0], rtol=1e-12)  # equal scale on x, y, z
    assert ax3.get_ylim()[0] > ax3.get_ylim()[1]  # +y (gravity) drawn downwards by default
    fig = plot_positions_3d(t, meas, pred, vertical="z")
    assert fig.axes[0].get_ylim()[0] < fig.axes[0].get_ylim()[1]


def test_positions_argument_errors_name_the_argument():
    t, meas, pred = _positions()
    with pytest.raises(ValueError, match="measured must have shape"):
        plot_positions_3d(t, meas[:-1], pred)
    with pytest.raises(ValueError, match="measured must have shape"):
        plot_positions_3d(t, meas[..., :2], pred[..., :2])
    bad = meas.copy()
    bad[0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="measured contains inf"):
        plot_positions_3d(t, bad, pred)
    bad = pred.copy()
    bad[3, 1, 2] = np.nan
    with pytest.raises(ValueError, match=r"predicted contains NaN or inf \(first at index \(3, 1, 2\)\)"):
        plot_positions_3d(t, meas, bad)
    with pytest.raises(ValueError, match="predicted must have shape"):
        plot_positions_3d(t, meas, pred[:, :2])
    with pytest.raises(ValueError, match="point must be an integer index into the 3"):
        plot_positions_3d(t, meas, pred, point=3)
    with pytest.raises(ValueError, match="point must be"):
        plot_positions_3d(t, meas, pred, point=1.0)
    with pytest.raises(ValueError, match="vertical must be one of"):
        plot_positions_3d(t, meas, pred, vertical="x")
    with pytest.raises(ValueError, match="axis_names must name the 3"):
        plot_positions_3d(t, meas, pred, axis_names=("X", "Y"))
    with pytest.raises(ValueError, match="labels must be None when predicted is a mapping"):
        plot_positions_3d(t, meas, {"a": pred}, labels=["b"])
    with pytest.raises(ValueError, match="t must be strictly increasing"):
        plot_positions_3d(t[::-1], meas, pred)
    lost = meas.copy()
    lost[:, -1] = np.nan
    with pytest.raises(ValueError, match="no measured .* sample of point -1"):
        plot_positions_3d(t, lost, pred)
    fig = plt.figure()
    flat = [fig.add_subplot(1, 5, k) for k in range(1, 6)]
    with pytest.raises(ValueError, match=r"axes\[0\] must be a 3-D Axes"):
        plot_positions_3d(t, meas, pred, axes=flat)
    with pytest.raises(ValueError, match="axes must be 5 matplotlib Axes"):
        plot_positions_3d(t, meas, pred, axes=flat[:4])


# --------------------------------------------------------------------------
# backbone shapes
# --------------------------------------------------------------------------
def test_straight_robot_is_a_line_along_y_from_the_base():
    robot = SpatialPCS((0.1, 0.15), base_position=(0.01, -0.02, 0.03))
    fig = plot_shapes_3d(robot, np.zeros(12), n_points=11)
    ax = fig.axes[0]
    assert ax.name == "3d"
    (backbone,) = [ln for ln in ax.get_lines()]
    xyz = _data3d(backbone)
    s = np.union1d(np.linspace(0.0, 0.25, 11), [0.1, 0.25])
    want = np.column_stack([np.full(s.size, 0.01), s - 0.02, np.full(s.size, 0.03)])
    np.testing.assert_allclose(xyz, want, atol=1e-15)
    # the segment ends are the line's markers
    ends = xyz[list(backbone.get_markevery())]
    np.testing.assert_allclose(ends, [[0.01, 0.08, 0.03], [0.01, 0.23, 0.03]], atol=1e-15)
    base = ax.collections[-1]
    np.testing.assert_allclose(np.ravel(base._offsets3d), [0.01, -0.02, 0.03])


def test_bent_frames_are_circular_arcs_and_markers_are_dots():
    robot = SpatialPCS((0.2,))
    kappas = np.array([0.0, 2.0, 5.0, 8.0])
    q = np.zeros((4, 6))
    q[:, 0] = kappas  # bend_z: an arc in the x-y plane
    t = np.array([0.0, 0.5, 1.0, 1.5])
    markers = np.random.default_rng(1).normal(scale=0.05, size=(4, 3, 3))
    markers[2, 1] = np.nan
    fig = plot_shapes_3d(robot, q, frames=[1, -1], t=t, markers=markers, n_points=30)
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert len(lines) == 2
    for line, k in zip(lines, (2.0, 8.0), strict=True):
        xyz = _data3d(line)
        s = np.linspace(0.0, 0.2, 30)
        arc = np.column_stack([(np.cos(k * s) - 1) / k, np.sin(k * s) / k, 0 * s])  # about body z, from +y
        np.testing.assert_allclose(xyz, arc, atol=1e-14)
    assert [tx.get_text() for tx in ax.get_legend().get_texts()][:2] == ["t = 0.5 s", "t = 1.5 s"]
    dots = ax.collections[:2]
    for coll, frame in zip(dots, (1, 3), strict=True):
        np.testing.assert_array_equal(np.column_stack(coll._offsets3d), markers[frame])
    assert ax.get_ylim()[0] > ax.get_ylim()[1]


def test_default_frames_are_evenly_spaced_with_first_and_last():
    robot = SpatialPCS((0.1,))
    q = np.zeros((21, 6))
    q[:, 0] = np.linspace(0.0, 10.0, 21)
    fig = plot_shapes_3d(robot, q)
    texts = [tx.get_text() for tx in fig.axes[0].get_legend().get_texts()]
    assert texts == ["frame 0", "frame 5", "frame 10", "frame 15", "frame 20", "base"]


def test_shapes_argument_errors_name_the_argument():
    robot = SpatialPCS((0.1,))
    q = np.zeros((3, 6))
    with pytest.raises(ValueError, match="kinematics must be a pcs_sindy.core.SpatialPCS"):
        plot_shapes_3d("robot", q)
    with pytest.raises(ValueError, match=r"q must have shape \(T, 6\)"):
        plot_shapes_3d(robot, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="q contains NaN"):
        plot_shapes_3d(robot, np.full((3, 6), np.nan))
    with pytest.raises(ValueError, match="frames must index the 3"):
        plot_shapes_3d(robot, q, frames=[0, 3])
    with pytest.raises(ValueError, match="frames must be a non-empty 1-D sequence of integer"):
        plot_shapes_3d(robot, q, frames=[0.5])
    with pytest.raises(ValueError, match="t must have one time stamp per configuration"):
        plot_shapes_3d(robot, q, t=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"markers must have shape \(3, K, 3\)"):
        plot_shapes_3d(robot, q, markers=np.zeros((3, 2)))
    with pytest.raises(ValueError, match="n_points must be an integer >= 2"):
        plot_shapes_3d(robot, q, n_points=1)
    with pytest.raises(ValueError, match="ax must be a 3-D matplotlib Axes"):
        plot_shapes_3d(robot, q, ax=plt.figure().add_subplot())
