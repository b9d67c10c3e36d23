"""A pneumatic robot identified from its chamber pressures and its weighed mass.

The ``one_segment_pneumatic`` robot (the one_segment robot, 0.1 m) has two
pressure chambers along its whole length, one on each side.  A chamber's
pressure bends the robot (gain g^b = chamber area × centroid offset) and
stretches it (gain g^a = chamber area).  The user knows the chambers' spans
and sides (``scenario.actuation``), measures the pressures ``u`` and weighs the
robot; the gains are identified with the Lagrangian.  Every identified
quantity (densities, stiffnesses, dampings, gains) could be scaled by one
factor without changing the motion, so the fit needs one absolute number:
the mass, given as ``PhysicalPCSLibrary(mass=...)`` (docs/method.md,
"Actuation").  The example

1. simulates 8 training recordings of 0.5 s (pressures held 10 ms) and a 7 s
   validation recording under slow sinusoidal pressures, with the seed's
   one-segment pose noise (0.5 mm, 1°) on the 20 tracked cross-sections;
2. fuses the poses with ``KinematicFusion`` (one segment);
3. fits ``EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(mass=m),
   actuation=PressureActuation(start, end, side))`` and, for comparison, the
   chambers as pure bending moments (``LinearActuation``, a gain per chamber
   on the curvature, no axial force);
4. rolls both out from the first (noisy, fused) validation frame under the
   validation pressures and compares the tip with the simulator's noise-free
   truth (seed eq. 25-26).

Run: ``.venv/bin/python examples/pneumatic_robot.py``
"""

import time

import numpy as np

from pcs_sindy.core import end_effector_errors
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor, PhysicalPCSLibrary
from pcs_sindy.models import LinearActuation, PressureActuation
from pcs_sindy.simulation import get_scenario

start = time.perf_counter()
scenario = get_scenario("one_segment_pneumatic")
data = scenario.generate(seed=0, noise="seed")  # cached under ~/.cache/pcs_sindy after the first run
total_length = scenario.robot.kinematics.total_length  # measured with a ruler
layout = scenario.actuation  # the design: chamber spans and sides, no gains
p = scenario.parameters
mass = float(np.sum(np.asarray(p["density"]) * np.pi * p["radius"] ** 2 * np.asarray(p["segment_lengths"])))
print(f"chambers from {layout['start']} to {layout['end']} m, sides {layout['side']}; weighed mass {1e3 * mass:.1f} g")

poses = [rec.poses for rec in data.train]
u = [rec.u for rec in data.train]  # gauge pressures [Pa], (T, 2)
fusion = KinematicFusion(total_length=total_length, pose_std=data.noise).fit(poses)
strains = fusion.transform(poses)
print(f"segmentation: {fusion.n_segments_} segment(s), lengths {np.round(fusion.segment_lengths_, 4)} m")

bending_only = np.zeros((3, 2), dtype=bool)
bending_only[0] = True  # (be, sh, ax) of the one segment: pressure as a bending moment only
val = data.validation
(first,) = fusion.transform([val.poses[:1]])
truth = scenario.robot.actuation
for label, actuation in [
    ("bending and axial gains identified", PressureActuation(layout["start"], layout["end"], layout["side"])),
    ("baseline: bending moments only", LinearActuation(pattern=bending_only)),
]:
    model = EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(mass=mass), actuation=actuation).fit(strains, u)
    sim = model.simulate(first.q[0], np.zeros(first.q.shape[1]), val.t, val.u)
    tip = sim.poses(np.array([fusion.segment_lengths_.sum()]))
    e_p, e_theta = end_effector_errors(tip, val.poses_true[:, -1:, :])
    print(f"{label}: 7 s validation rollout e_p^EE = {1e3 * e_p:.3f} mm, e_theta^EE = {e_theta:.4f} rad")
    if isinstance(actuation, PressureActuation):
        true = np.r_[truth.bending_gain, truth.axial_gain]
        for name, g_hat, g in zip(model.actuation_.gain_names_, model.actuation_.gains_, true, strict=True):
            print(f"  {name}: identified {g_hat:.4g}, true {g:.4g} ({100 * (g_hat / g - 1):+.2f} %)")
        model.print(precision=3)
print(f"total {time.perf_counter() - start:.1f} s")
