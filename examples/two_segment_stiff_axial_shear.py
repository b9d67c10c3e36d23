"""Two segments, segment 1 axially and segment 2 in shear 1000 times stiffer.

The published paper's extra case.  The stiffened strains barely move under the
nominal robot's forces.  Only one of them exceeds the material maximum used
for sparsification (seed eq. 19, r = 0.02 m): the shear of segment 2
(1000 × 5.03 N = 5.03 kN > c_sh A G_max = 168 N) is removed as rigid, while
the axial stiffness of segment 1 (1000 × 12.6 N = 12.6 kN) stays below
A E_max = 126 kN and is identified like any other strain.

Data: the seed's 8 training recordings and 7 s validation, noise-free marker
poses (with the seed's noise the stiff strains' motion is below the noise and
their stiffness cannot be identified from these data); segmentation by
``KinematicFusion``; ``EulerLagrangeRegressor()`` (physical library, weak form).

Run: ``.venv/bin/python examples/two_segment_stiff_axial_shear.py``
"""

import time

import numpy as np

from pcs_sindy import EulerLagrangeRegressor, KinematicFusion
from pcs_sindy.metrics import end_effector_errors
from pcs_sindy.simulation import get_scenario

start = time.perf_counter()
scenario = get_scenario("two_segment_stiff_axial_shear")
data = scenario.generate(seed=0)
total_length = scenario.robot.kinematics.total_length

poses = [rec.poses for rec in data.train]
fusion = KinematicFusion(threshold=0.2, total_length=total_length).fit(poses)
strains = fusion.transform(poses)
print(
    f"segmentation: {fusion.n_segments_} segments, lengths {np.round(fusion.segment_lengths_, 4)} m "
    f"(true {list(scenario.robot.kinematics.segment_lengths)})"
)

# the defaults (physical library with rest strains, weak form) with a wider Savitzky-Golay window for the rates
model = EulerLagrangeRegressor(window_length=15)
model.fit(strains, [rec.tau for rec in data.train])
names = model.kinematics_.strain_names()
print("removed strains:", model.removed_strains_)
print("strain    true K        identified K   max K")
for name, k_true, k_hat, k_max in zip(
    names, scenario.robot.stiffness, model.stiffness_, model.optimizer_.max_stiffness_, strict=True
):
    print(f"{name:6s} {k_true:12.4g} {k_hat:14.4g} {k_max:10.4g}")
model.print(precision=3)

val = data.validation
n = model.kinematics_.n_q
sim = model.simulate(np.zeros(n), np.zeros(n), val.t, val.tau)
tip = sim.poses(np.array([fusion.segment_lengths_.sum()]))
e_p, e_theta = end_effector_errors(tip, val.poses_true[:, -1:, :])
print(f"7 s validation rollout: e_p^EE = {1e3 * e_p:.2f} mm, e_theta^EE = {e_theta:.4f} rad")
print(f"total {time.perf_counter() - start:.1f} s")
