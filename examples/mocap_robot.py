"""Your motion-capture robot: from a marker CSV to a PCS model and an open-loop prediction plot.

A simulated capture stands in for yours (``MocapScenario``: a 0.3 m hanging
robot, two tendons to the tip, three disks tracked by 3-D position only at
100 Hz, with noise, out-of-plane wobble, frozen samples and jumps).  The
example

1. writes it as a CSV (sample index, the two tensions, marker X/Y/Z in mm)
   and reads it back with ``read_marker_csv``;
2. builds ``PoseTrajectory.from_positions`` on the first half (plane fit,
   frozen samples and jumps set missing) and fuses it with ``KinematicFusion``
   (base pose and the disks' arc lengths fitted to the positions);
3. identifies ``EulerLagrangeRegressor(actuation=TendonActuation(...))`` with
   the design offset and the tendon sides read from the data;
4. predicts the second half open loop from the inputs, maps it back to the
   capture frame and plots the tip against the measurement, with the error
   over time (``mocap_prediction.png``).

Run: ``.venv/bin/python examples/mocap_robot.py`` (about 20 s; the first run
compiles the simulator's kernels).
"""

import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

from pcs_sindy.core import PoseTrajectory  # noqa: E402
from pcs_sindy.fusion import KinematicFusion, tendon_sides  # noqa: E402
from pcs_sindy.identification import EulerLagrangeRegressor  # noqa: E402
from pcs_sindy.io import read_marker_csv  # noqa: E402
from pcs_sindy.models import TendonActuation  # noqa: E402
from pcs_sindy.plotting import plot_tip_positions  # noqa: E402
from pcs_sindy.simulation import MocapScenario  # noqa: E402

start = time.perf_counter()
capture = MocapScenario(duration=40.0).generate(seed=0)
with tempfile.TemporaryDirectory() as tmp:
    csv_path = capture.to_csv(Path(tmp) / "capture.csv")
    data = read_marker_csv(csv_path, ["M1", "M2", "M3"], rate=100.0, units="mm", inputs=["u1", "u2"])

half = data.positions.shape[0] // 2
train = PoseTrajectory.from_positions(data.positions[:half], dt=data.dt)
test = PoseTrajectory.from_positions(data.positions[half:], dt=data.dt, plane=train.plane)
print(
    f"out-of-plane RMS {1e3 * train.metadata['out_of_plane_rms']:.2f} mm; "
    f"{train.metadata['frozen_samples']} frozen and {train.metadata['jump_samples']} jump samples set missing"
)

# threshold=0.2 (one segment here): threshold='auto' fuses these captures into 2-3 segments (the
# kinematic error drops from 0.36 to 0.19 mm), but a 3-segment model is poorly determined from 3 markers
# and predicts worse open loop (10.96 vs 5.35 mm tip RMSE on this capture); choose by prediction.
fusion = KinematicFusion(threshold=0.2).fit(train)
print(
    f"{fusion.n_segments_} segment(s); disks at {np.round(1e3 * fusion.marker_arc_lengths_[1:], 1)} mm "
    f"(+- {np.round(1e3 * fusion.marker_arc_lengths_std_[1:], 1)} mm) from the fitted base"
)
strains = fusion.transform(train)
u_train, u_test = data.inputs[:half], data.inputs[half:]
sides = tendon_sides(strains, [u_train])
actuation = TendonActuation([fusion.total_length_] * 2, sides, offset=[0.012, 0.012])  # the design offset
model = EulerLagrangeRegressor(actuation=actuation).fit(strains, [u_train])
print(model.identifiability_report())

(st_test,) = fusion.transform(test)
sim = model.simulate(st_test.q[0], np.zeros(st_test.q.shape[1]), st_test.t, u_test)
sim.metadata.update({k: st_test.metadata[k] for k in ("plane", "marker_arc_lengths", "base_poses")})
(prediction,) = fusion.inverse_transform([sim])  # markers back in the capture frame, 3-D
tip, measured = prediction.positions[:, -1, :], test.positions[:, -1, :]
ok = np.all(np.isfinite(measured), axis=1)
rmse = np.sqrt(np.mean(np.sum((tip[ok] - measured[ok]) ** 2, axis=1)))
print(f"open-loop tip RMSE over the second half: {1e3 * rmse:.2f} mm")

# the tip in the capture frame against the measurement, and the error over time (the lines overlap)
fig = plot_tip_positions(st_test.t, measured, tip, labels=["PCS model, open loop"], title="second half, open loop")
fig.savefig("mocap_prediction.png", dpi=120)
print(f"plot -> mocap_prediction.png; total {time.perf_counter() - start:.1f} s")
