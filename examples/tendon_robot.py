"""A tendon-driven robot identified from its actuator inputs (tensions), not from generalised forces.

The ``two_segment_tendon`` robot (the two_segment robot, 70 + 100 mm) is
pulled by four tendons at ±15 mm from the backbone, two ending at 70 mm and two
at the tip.  A user knows from the design where each tendon ends and on which
side it runs (``scenario.actuation``) and measures the tensions ``u``; the
generalised forces ``tau = A(q) u`` are never seen, and neither are the
offsets.  The example

1. simulates 8 training recordings of 0.5 s (tensions held 10 ms) and a 7 s
   validation recording under slow sinusoidal tensions, with the seed's
   two-segment pose noise (0.1 mm, 0.5°) on the 20 tracked cross-sections;
2. fuses the poses with ``KinematicFusion`` at the former default threshold
   0.2, which merges this robot into one segment, and at the default
   ``threshold="auto"``, which chooses h for this robot from a sweep and finds
   the two: tendons drive both segments' strains together, so the scaled
   distance of their strain trajectories (0.18) is far below that of the same
   robot under independent generalised forces (0.57, ``two_segment``);
3. fits ``EulerLagrangeRegressor(actuation=TendonActuation(end, side, ...))``
   (``A(q) = -dl/dq``, the Lagrangian by least squares for given offsets and
   the offsets by ``scipy.optimize.least_squares`` around it) with one shared
   offset magnitude, with an offset per tendon, and with the design offsets
   given, printing identified against true offsets;
4. rolls each model out from the first (noisy, fused) validation frame under
   the validation tensions (``model.simulate(q0, qd0, t, u)``) and compares
   its tip with the simulator's noise-free truth (seed eq. 25-26).

Run: ``.venv/bin/python examples/tendon_robot.py``
"""

import time

import numpy as np

from pcs_sindy.core import end_effector_errors
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.models import TendonActuation
from pcs_sindy.simulation import get_scenario

start = time.perf_counter()
scenario = get_scenario("two_segment_tendon")
data = scenario.generate(seed=0, noise="seed")  # cached under ~/.cache/pcs_sindy after the first run
total_length = scenario.robot.kinematics.total_length  # measured with a ruler
layout = scenario.actuation  # the design: terminations and sides, no offsets
true_offsets = np.asarray(scenario.robot.actuation.offset)
print(f"design layout: ends {layout['end']} m, sides {layout['side']}; true offsets {1e3 * true_offsets} mm")

poses = [rec.poses for rec in data.train]
u = [rec.u for rec in data.train]  # tensions [N], (T, 4)
val = data.validation


def validate(model, fusion):
    """Tip errors of a 7 s rollout from the first fused validation frame under the validation tensions."""
    (first,) = fusion.transform([val.poses[:1]])
    sim = model.simulate(first.q[0], np.zeros(first.q.shape[1]), val.t, val.u)
    tip = sim.poses(np.array([fusion.segment_lengths_.sum()]))
    return end_effector_errors(tip, val.poses_true[:, -1:, :])


fits = []
for threshold in (0.2, "auto"):
    fusion = KinematicFusion(threshold=threshold, total_length=total_length, pose_std=data.noise).fit(poses)
    print(
        f"KinematicFusion(threshold={threshold!r}): h = {fusion.threshold_:.3g}, {fusion.n_segments_} segment(s), "
        f"lengths {np.round(1e3 * fusion.segment_lengths_, 1)} mm"
    )
    if fusion.n_segments_ == 2:
        # the distance of the two segments' scaled strain trajectories, below the former default 0.2
        print(f"  distance between the two segments: {fusion.history_[-1]['distances'][0]:.3f}")
    strains = fusion.transform(poses)
    models = {"one shared offset identified": TendonActuation(layout["end"], layout["side"], shared=True)}
    if fusion.n_segments_ == 2:
        models["an offset per tendon identified"] = TendonActuation(layout["end"], layout["side"])
        models["design offsets given"] = TendonActuation(layout["end"], layout["side"], offset=np.abs(true_offsets))
    for label, actuation in models.items():
        fit_start = time.perf_counter()
        model = EulerLagrangeRegressor(actuation=actuation).fit(strains, u)
        fit_s = time.perf_counter() - fit_start
        e_p, e_theta = validate(model, fusion)
        offsets = model.actuation_.offsets_
        error = 100 * np.max(np.abs(offsets / true_offsets - 1))
        print(
            f"  {label}: offsets {np.round(1e3 * offsets, 2)} mm (max error {error:.1f} %), fit {fit_s:.1f} s; "
            f"7 s validation rollout: e_p^EE = {1e3 * e_p:.3f} mm, e_theta^EE = {e_theta:.4f} rad"
        )
        fits.append(model)

print("\nmodel with one shared offset on the two fused segments:")
fits[1].print(precision=3)
print(f"total {time.perf_counter() - start:.1f} s")
