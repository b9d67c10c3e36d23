"""From videos to a validated model in one scikit-learn Pipeline (one_segment robot).

The only example that starts from images, as a user with a camera would:

1. simulate 4 training recordings (0.3 s at 1 kHz, forces held 10 ms) and the
   7 s validation recording of the one_segment robot;
2. render the training recordings as MJPG ``.avi`` videos (640×480, black
   marker rectangles on the robot's body, 20 tracked cross-sections + base)
   with the camera calibration written next to each video as JSON;
3. ``make_pcs_pipeline`` chains ``MarkerPoseExtractor`` (OpenCV: threshold,
   contours, sub-pixel marker poses, read in metres through the camera JSON),
   ``KinematicFusion`` and ``EulerLagrangeRegressor()``;
   ``pipe.fit(videos, taus)`` runs all three;
4. ``pipe.simulate_poses`` rolls the model out under the validation forces
   and returns marker poses, compared with the simulator's truth.

Videos are written to a temporary folder and deleted at the end.

Run: ``.venv/bin/python examples/from_videos.py``
"""

import tempfile
import time
from pathlib import Path

import numpy as np

from pcs_sindy.core import Camera, distributed_errors, end_effector_errors
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.pipeline import make_pcs_pipeline
from pcs_sindy.simulation import get_scenario, render_video
from pcs_sindy.vision import MarkerPoseExtractor

start = time.perf_counter()
scenario = get_scenario("one_segment")
data = scenario.generate(seed=0, n_train=4, train_duration=0.3)
total_length = scenario.robot.kinematics.total_length

with tempfile.TemporaryDirectory() as folder:
    camera = Camera.fit_robot(total_length)  # the image holds the robot bent either way
    videos = []
    for k, rec in enumerate(data.train):
        out = render_video(rec.poses_true, Path(folder) / f"train{k}.avi", camera, fps=1000.0)
        videos.append(str(out.video))
    print(
        f"rendered {len(videos)} videos ({sum(r.t.size for r in data.train)} frames, "
        f"{camera.pixels_per_metre:.0f} px/m) in {time.perf_counter() - start:.1f} s"
    )

    pipe = make_pcs_pipeline(
        extractor=MarkerPoseExtractor(progress=False),
        # sub-pixel extraction: a few hundredths of a millimetre, a few tenths of a degree
        fusion=KinematicFusion(threshold=0.2, total_length=total_length, pose_std=(2.5e-5, 6e-3)),
        # the defaults: physical library with a constant force per strain, weak form
        regressor=EulerLagrangeRegressor(),
    )
    pipe.fit(videos, [rec.tau for rec in data.train])

print(f"segmentation: {pipe.n_segments_} segment(s), lengths {np.round(pipe.segment_lengths_, 4)} m")
pipe.model_.print(precision=3)
print("stiffness, identified / true:", np.round(pipe.model_.stiffness_ / scenario.robot.stiffness, 3))

val = data.validation
n = pipe.model_.kinematics_.n_q
poses = pipe.simulate_poses(np.zeros(n), np.zeros(n), val.t, val.tau).poses
e_p, e_theta = end_effector_errors(poses[:, -1:], val.poses_true[:, -1:])
d_p, d_theta = distributed_errors(poses[:, 1:], val.poses_true[:, 1:])
print(
    f"7 s validation rollout: e_p^EE = {1e3 * e_p:.2f} mm, e_theta^EE = {e_theta:.4f} rad; "
    f"all markers: e_p^dist = {1e3 * d_p:.2f} mm, e_theta^dist = {d_theta:.4f} rad"
)
print(f"total {time.perf_counter() - start:.1f} s")
