"""The validation rollout every identification benchmark uses: ``simulate(..., method="dopri5", rtol=1e-6, atol=1e-9)``.

Dormand–Prince 5(4) at rtol 1e-6 was the estimator's rollout before the
refactor of issue 10, so the benchmarks keep it to compare their numbers with
the earlier ones.  Physical models take the compiled loop.  Monomial models
(``CallableModel``) should take scipy's RK45 restarted at every held sample, but
``CallableModel.simulate(method="dopri5")`` with tabulated inputs raises
"has no compiled scheme" (``ForwardModel.simulate`` sends every
``COMPILED_METHODS`` name to ``_rollout_compiled``), and
``pcs_sindy.integrators.solve_held`` raises ``AttributeError`` instead of
``SimulationError`` when solve_ivp fails inside a sample interval (``sol.t`` is
then an empty list).  Until both are fixed in the package,
:func:`validation_rollout` runs that path itself: ``scipy.integrate.solve_ivp``
(RK45) from sample to sample with the model's ``terms(q, qd)``, reporting the
time of the last step reached when it fails.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from pcs_sindy.forward import CallableModel
from pcs_sindy.integration import SimulationError
from pcs_sindy.metrics import end_effector_errors
from pcs_sindy.trajectory import StrainTrajectory

ROLLOUT = dict(method="dopri5", rtol=1e-6, atol=1e-9)


def validation_rollout(model, q0, qd0, t, u, **kwargs) -> StrainTrajectory:
    """``model.simulate(q0, qd0, t, u, **ROLLOUT, **kwargs)`` for a fitted EulerLagrangeRegressor."""
    opts = dict(ROLLOUT, **kwargs)
    fm = model.forward_model()
    if not (isinstance(fm, CallableModel) and opts["method"] == "dopri5" and not callable(u)):
        return model.simulate(q0, qd0, t, u, **opts)
    kin = fm.kinematics
    mask, n = kin.active_mask, fm.n

    def rhs(y, tau):
        M, bias = fm.terms(y[:n], y[n:])
        return np.concatenate([y[n:], np.linalg.solve(M, tau - bias)])

    y = np.concatenate([np.asarray(q0, dtype=float)[mask], np.asarray(qd0, dtype=float)[mask]])
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)[:, mask]
    out = np.empty((t.size, y.size))
    out[0] = y
    for k in range(t.size - 1):
        uk = u[k]
        try:
            # no t_eval: the steps' own times give the time of a failure inside the sample interval
            sol = solve_ivp(lambda _, yk: rhs(yk, uk), (t[k], t[k + 1]), y, method="RK45", rtol=opts["rtol"],
                            atol=opts["atol"])
        except np.linalg.LinAlgError as err:
            raise SimulationError(f"rollout diverged in [{t[k]:.6g}, {t[k + 1]:.6g}] s (singular mass matrix: {err})",
                                  float(t[k]), y) from None
        ys = sol.y.T
        bad = ~np.all(np.isfinite(ys), axis=1) | (np.abs(ys).max(axis=1) > opts.get("max_abs_state", 1e6))
        if bad.any():
            j = int(np.argmax(bad))
            raise SimulationError(f"rollout diverged at t = {sol.t[j]:.6g} s (non-finite or |state| > 1e6)",
                                  float(sol.t[j]), ys[j])
        if not sol.success:
            raise SimulationError(f"rollout diverged at t = {sol.t[-1]:.6g} s (solve_ivp RK45: {sol.message})",
                                  float(sol.t[-1]), ys[-1])
        y = ys[-1]
        out[k + 1] = y
    return StrainTrajectory(kin.to_full(out[:, :n]), t, segment_lengths=kin.segment_lengths,
                            active_strains=kin.active_strains, qd=kin.to_full(out[:, n:]), base_pose=kin.base_pose)


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
