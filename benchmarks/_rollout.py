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
(RK45) from sample to sample with the model's ``terms(q, qd)``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from pcs_sindy.forward import CallableModel
from pcs_sindy.integration import SimulationError
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
            sol = solve_ivp(lambda _, yk: rhs(yk, uk), (t[k], t[k + 1]), y, method="RK45", t_eval=(t[k + 1],),
                            rtol=opts["rtol"], atol=opts["atol"])
        except np.linalg.LinAlgError as err:
            raise SimulationError(f"rollout diverged in [{t[k]:.6g}, {t[k + 1]:.6g}] s (singular mass matrix: {err})",
                                  float(t[k]), y) from None
        if not sol.success or np.size(sol.t) == 0:
            raise SimulationError(f"rollout diverged in [{t[k]:.6g}, {t[k + 1]:.6g}] s (solve_ivp RK45: {sol.message})",
                                  float(t[k]), y)
        y = np.asarray(sol.y)[:, -1]
        if not np.all(np.isfinite(y)) or np.abs(y).max() > opts.get("max_abs_state", 1e6):
            raise SimulationError(f"rollout diverged at t = {t[k + 1]:.6g} s (non-finite or |state| > 1e6)",
                                  float(t[k + 1]), y)
        out[k + 1] = y
    return StrainTrajectory(kin.to_full(out[:, :n]), t, segment_lengths=kin.segment_lengths,
                            active_strains=kin.active_strains, qd=kin.to_full(out[:, n:]), base_pose=kin.base_pose)
