"""A piecewise-affine-curvature segment (seed Case 5): kinematic fusion only.

The robot's curvature varies linearly along its 0.15 m (``c0 + c1 s``), so no
number of constant-strain segments describes it exactly: the segmentation is a
trade-off between model size and shape error.  The example

1. draws the seed's 500 random configurations with the seed's pose noise
   (0.5 mm, 1°) on 20 tracked cross-sections;
2. sweeps the merge threshold ``h`` of ``KinematicFusion`` (seed Fig. 8) and
   picks the model with the largest decrease of shape error per added segment
   (``select_threshold``, the seed's rule);
3. fits that segmentation with least-squares shapes and prints its segment
   lengths and distributed pose errors against the noise-free poses
   (seed eq. 23-24).

There are no dynamics here (the PAC robot has no forces), hence no rollout.

Run: ``.venv/bin/python examples/pac_one_segment.py``
"""

import time

import numpy as np

from pcs_sindy.core import distributed_errors
from pcs_sindy.fusion import KinematicFusion, select_threshold, threshold_sweep
from pcs_sindy.simulation import get_scenario

start = time.perf_counter()
scenario = get_scenario("pac_one_segment")
data = scenario.generate(seed=0, noise="seed")
poses = [rec.poses for rec in data.train]
truth = [rec.poses_true for rec in data.train]

# "closest_pair" merges only the most similar adjacent pair per step (the seed merges whole runs at once)
template = KinematicFusion(total_length=0.15, shape_fit="end_pose", merge="closest_pair", pose_std=data.noise)
rows = threshold_sweep(poses, [0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0], fusion=template, truth=truth)
print("   h   segments   e_p^dist [m]   e_theta^dist [rad]")
for r in rows:
    print(f"{r.h:5g}   {r.n_segments:8d}   {r.e_p_dist:12.2e}   {r.e_theta_dist:18.2e}")
chosen = select_threshold(rows)
print(f"chosen: h = {chosen.h:g} ({chosen.n_segments} segments)")

fusion = KinematicFusion(threshold=chosen.h, total_length=0.15, merge="closest_pair", pose_std=data.noise).fit(poses)
recon = fusion.reconstruct(poses)
e_p, e_theta = distributed_errors(
    np.concatenate([r.poses[:, 1:] for r in recon]), np.concatenate([p[:, 1:] for p in truth])
)
print(
    f"least-squares shapes, refined boundaries: lengths {np.round(fusion.segment_lengths_, 4)} m, "
    f"e_p^dist = {e_p:.2e} m, e_theta^dist = {e_theta:.2e} rad "
    f"(seed, 3 segments [0.0075, 0.105, 0.0375]: 7.46e-04 m, 8.92e-02 rad)"
)
print(f"total {time.perf_counter() - start:.1f} s")
