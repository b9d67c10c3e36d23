"""The validation rollout of the identification benchmarks and its tip errors.

Every identified model is rolled out with ``simulate(..., method="dopri5",
rtol=1e-6, atol=1e-9)``: Dormand–Prince 5(4) at rtol 1e-6 was the estimator's
rollout before the refactor of issue 10, so the benchmarks keep it to compare
their numbers with the earlier ones (the compiled loop for physical models,
scipy's RK45 restarted at every held sample for monomial ones).
"""

from __future__ import annotations

import time

import numpy as np

from pcs_sindy.core import SimulationError, StrainTrajectory, end_effector_errors

ROLLOUT = dict(method="dopri5", rtol=1e-6, atol=1e-9)


def validation_rollout(model, q0, qd0, t, u, **kwargs) -> StrainTrajectory:
    """``model.simulate(q0, qd0, t, u)`` with the benchmarks' integrator and tolerances (:data:`ROLLOUT`)."""
    return model.simulate(q0, qd0, t, u, **dict(ROLLOUT, **kwargs))


def validate(model, validation, total_length: float) -> dict:
    """Roll ``model`` out from rest under the validation inputs; tip errors against the noise-free poses.

    Returns
    -------
    dict
        ``e_p`` [m] and ``e_theta`` [rad] (None if the rollout diverged),
        ``diverged`` (the message or None), ``diverged_at`` (time or None),
        ``rollout_time`` and ``rollout_cpu`` [s], ``duration`` of the validation [s].
    """
    val = validation
    n = model.kinematics_.n_q
    t0, c0 = time.perf_counter(), time.process_time()
    out = dict(duration=float(val.t[-1] - val.t[0]))
    try:
        sim = validation_rollout(model, np.zeros(n), np.zeros(n), val.t, val.tau)
        tip = sim.poses(np.array([float(total_length)]))
        e_p, e_th = end_effector_errors(tip, val.poses_true[:, -1:, :])
        out.update(e_p=e_p, e_theta=e_th, diverged=None, diverged_at=None)
    except SimulationError as err:
        out.update(e_p=None, e_theta=None, diverged=str(err)[:160], diverged_at=err.t)
    out.update(rollout_time=time.perf_counter() - t0, rollout_cpu=time.process_time() - c0)
    return out
