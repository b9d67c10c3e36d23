"""A spatial (3-D) robot: two segments, three tendons, a prediction plotted against noisy markers.

The simulator's :class:`~pcs_sindy.simulation.SpatialPCSRobot` (six strains per segment,
docs/spatial.md) hangs under gravity and is pulled by three tendons, one after the other: to the tip
along body x, to the tip along body z, to the middle of the robot diagonally, so the tip leaves
every plane.  Four markers along the backbone are "measured" with 0.5 mm noise, and the tracker
loses the tip for 0.3 s.  A second robot 10 % stiffer stands in for a model's prediction (the
spatial identification is not part of this example).  The example prints how far the tip moved and
the prediction's error, and writes two figures into the given folder (default: the current one):
``spatial_prediction.png`` (:func:`~pcs_sindy.plotting.plot_positions_3d`) and
``spatial_shapes.png`` (:func:`~pcs_sindy.plotting.plot_shapes_3d`).

Run: ``.venv/bin/python examples/spatial_robot.py [folder]`` (a few seconds; the first run on a
machine compiles the spatial kernels, about a minute).
"""

import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

from pcs_sindy.plotting import plot_positions_3d, plot_shapes_3d  # noqa: E402
from pcs_sindy.simulation import SpatialPCSRobot, SpatialTendons  # noqa: E402

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(".")

# tendon k ends at arc length end[k] and runs at (d_x, d_z) from the backbone in the cross-section
tendons = SpatialTendons(end=[0.2, 0.2, 0.1], offset=[[0.01, 0.0], [0.0, 0.01], [-0.01, -0.01]])


def robot(youngs_modulus):
    return SpatialPCSRobot(
        [0.1, 0.1],  # segment lengths [m]
        density=1070.0,  # kg/m^3
        youngs_modulus=youngs_modulus,  # Pa
        shear_modulus=youngs_modulus / 3.0,  # Pa
        radius=0.01,  # m
        damping=np.tile([1e-4, 1e-4, 1e-4, 1e-2, 1e-2, 1e-2], 2),  # bend_z, bend_x, twist, shear_x, shear_z, axial
        actuation=tendons,
    )


def ramp(t, start, end):
    return np.clip((t - start) / (end - start), 0.0, 1.0)


t = np.arange(0.0, 3.0, 0.01)  # 100 Hz for 3 s
u = np.column_stack(  # tensions [N], >= 0, held between samples
    [
        1.0 * ramp(t, 0.2, 0.6) * (1.0 - ramp(t, 1.6, 2.0)),
        1.0 * ramp(t, 0.9, 1.3),
        1.0 * ramp(t, 2.0, 2.4),
    ]
)
start = time.perf_counter()
truth = robot(3e4).simulate(np.zeros(12), np.zeros(12), t, u)  # a SpatialStrainTrajectory
print(f"simulated {t[-1] + 0.01:.0f} s in {time.perf_counter() - start:.2f} s")
model = robot(3.3e4).simulate(np.zeros(12), np.zeros(12), t, u)

arcs = [0.05, 0.1, 0.15, 0.2]  # markers along the backbone, the last at the tip
true_markers, _ = truth.poses(arcs)  # (T, 4, 3) positions [m], (T, 4, 3, 3) rotations
predicted, _ = model.poses(arcs)
rng = np.random.default_rng(0)
measured = true_markers + rng.normal(scale=5e-4, size=true_markers.shape)
measured[(t >= 1.0) & (t < 1.3), -1] = np.nan  # the tracker loses the tip

tip = true_markers[:, -1]
print(
    f"tip moved up to {1e3 * np.linalg.norm(tip - tip[0], axis=1).max():.1f} mm; "
    f"range x {1e3 * np.ptp(tip[:, 0]):.1f} mm, z {1e3 * np.ptp(tip[:, 2]):.1f} mm"
)
print(
    f"largest strains: bend_z {np.abs(truth.q[:, [0, 6]]).max():.2f} 1/m, "
    f"bend_x {np.abs(truth.q[:, [1, 7]]).max():.2f} 1/m, twist {np.abs(truth.q[:, [2, 8]]).max():.3f} 1/m"
)
seen = np.all(np.isfinite(measured[:, -1]), axis=1)
err = 1e3 * np.linalg.norm(predicted[seen, -1] - measured[seen, -1], axis=1)
err_true = 1e3 * np.linalg.norm(predicted[:, -1] - tip, axis=1)
print(
    f"10 % stiffer model: tip RMSE {np.sqrt(np.mean(err**2)):.2f} mm against the measurement "
    f"({seen.sum()} of {t.size} samples), {np.sqrt(np.mean(err_true**2)):.2f} mm against the truth"
)

fig = plot_positions_3d(t, measured, {"10 % stiffer model": predicted})
fig.savefig(out / "spatial_prediction.png", dpi=70)
fig = plot_shapes_3d(truth.kinematics, truth.q, frames=[0, 60, 130, 200, 299], t=t, markers=measured)
fig.savefig(out / "spatial_shapes.png", dpi=60)
print(f"figures in {out.resolve()}")
