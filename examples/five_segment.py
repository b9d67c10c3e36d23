"""Five constant-strain segments (beyond the seed): 0.27 m, 15 strains.

The numeric physical library (no symbolic derivation) makes five segments as
cheap to identify as one: 55 unknowns (line density, rotary inertia, three
stiffnesses, three constant forces, three dampings per segment).  Materials alternate between soft
and stiffer segments (docs/method.md):

1. simulate the seed's training data (8 recordings of 0.5 s at 1 kHz with
   forces held 10 ms) and a sinusoidal validation recording, shortened from
   the seed's 7 s to 2 s to keep the example under a minute
   (``benchmarks/end_to_end.py`` rolls out the full 7 s), with the scenario's
   measurement noise on the 20 tracked cross-sections (0.1 mm, 0.5°);
2. ``KinematicFusion`` finds the segmentation (0.04, 0.06, 0.05, 0.07, 0.05 m;
   the boundaries lie between markers, where the least-squares
   shape fit places them, here from 100 of the 4000 frames) and the strains
   from the noisy poses;
3. ``EulerLagrangeRegressor()`` (physical library, weak form) identifies
   density, rotary inertia, stiffness, damping and a constant force per
   strain (weak form: no second derivative of noisy strains is needed);
4. the model is rolled out from rest under the validation forces and its tip
   compared with the simulator's noise-free truth (seed eq. 25-26).

Run: ``.venv/bin/python examples/five_segment.py``
"""

import time

import numpy as np

from pcs_sindy.core import end_effector_errors
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.simulation import get_scenario

start = time.perf_counter()
scenario = get_scenario("five_segment")
# cached under ~/.cache/pcs_sindy after the first run
data = scenario.generate(seed=0, noise="seed", validation_duration=2.0)
total_length = scenario.robot.kinematics.total_length  # the robot's rest length is known to the user

poses = [rec.poses for rec in data.train]
fusion = KinematicFusion(threshold=0.2, total_length=total_length, pose_std=data.noise, max_refine_frames=100)
fusion.fit(poses)
strains = fusion.transform(poses)
print(
    f"segmentation: {fusion.n_segments_} segment(s), lengths {np.round(fusion.segment_lengths_, 4)} m "
    f"(true {list(scenario.robot.kinematics.segment_lengths)})"
)

# the defaults: physical library with a constant force per strain, weak form over windows of 160 samples
model = EulerLagrangeRegressor()
model.fit(strains, [rec.tau for rec in data.train])
model.print(precision=3)
print("stiffness, identified / true:", np.round(model.stiffness_ / scenario.robot.stiffness, 3))

val = data.validation
n = model.kinematics_.n_q
sim = model.simulate(np.zeros(n), np.zeros(n), val.t, val.tau)
tip = sim.poses(np.array([fusion.segment_lengths_.sum()]))
e_p, e_theta = end_effector_errors(tip, val.poses_true[:, -1:, :])
print(f"{val.t[-1] + val.dt:g} s validation rollout: e_p^EE = {1e3 * e_p:.2f} mm, e_theta^EE = {e_theta:.4f} rad")
print(f"total {time.perf_counter() - start:.1f} s")
