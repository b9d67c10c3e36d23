"""The validation rollout every identification benchmark uses: ``simulate(..., method="dopri5", rtol=1e-6, atol=1e-9)``.

Dormand–Prince 5(4) at rtol 1e-6 was the estimator's rollout before the
refactor of issue 10, so the benchmarks keep it to compare their numbers with
the earlier ones.  Physical models take the compiled loop.  Monomial models
(``CallableModel``) should take scipy's RK45 restarted at every held sample, but
``CallableModel.simulate(method="dopri5")`` with tabulated inputs raises
"has no compiled scheme" (``ForwardModel.simulate`` sends every
``COMPILED_METHODS`` name to ``_rollout_compiled``); until that is fixed in the
package, :func:`validation_rollout` runs that path itself through the public
``pcs_sindy.integrators.solve_held`` with the model's ``terms(q, qd)``.
"""

from __future__ import annotations

import numpy as np

from pcs_sindy.forward import CallableModel
from pcs_sindy.integrators import solve_held
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

    names = kin.strain_names(active_only=True)
    y0 = np.concatenate([np.asarray(q0, dtype=float)[mask], np.asarray(qd0, dtype=float)[mask]])
    y = solve_held(rhs, y0, t, np.ascontiguousarray(np.asarray(u, dtype=float)[:, mask]), method="dopri5",
                   rtol=opts["rtol"], atol=opts["atol"], state_names=names + [f"d{nm}/dt" for nm in names],
                   progress=bool(opts.get("progress", False)))
    return StrainTrajectory(kin.to_full(y[:, :n]), np.asarray(t, dtype=float), segment_lengths=kin.segment_lengths,
                            active_strains=kin.active_strains, qd=kin.to_full(y[:, n:]), base_pose=kin.base_pose)
