"""Variable projection: nonlinear actuation parameters (tendon offsets) around the linear fit.

For given offsets the Euler–Lagrange regression is linear in the Lagrangian
coefficients (and gains), so its least-squares residual is a function of the
offsets alone; :func:`fit_offsets` minimises it with
:func:`scipy.optimize.least_squares` within the actuation's bounds and takes
standard errors from its Jacobian.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from . import formulations as _form

__all__ = ["fit_offsets"]


def fit_offsets(
    library: Any, actuation: Any, recordings: list[_form.Recording], formulation: str, hold: str = "zoh"
) -> tuple[NDArray[np.float64], dict]:
    """Offsets minimising the profiled residual, and what the data determined of them.

    Parameters
    ----------
    library : LagrangianLibrary
        Fitted on the recordings' segmentation.
    actuation : Actuation
        Fitted, with nonlinear parameters (``offset_names_``).
    recordings : list of Recording
    formulation : {"strong", "weak"}
    hold : str
        Weak form: how the inputs are integrated.

    Returns
    -------
    offsets : ndarray
        In the actuation's parameterisation (magnitudes).
    info : dict
        ``offset_names``, ``offsets``, ``offset_standard_errors``,
        ``offset_relative_standard_errors``, ``offset_fit_success``.
    """
    rows = _form.library_rows(library, recordings, formulation)
    x = rows.reshape(-1, rows.shape[-1])
    norms = np.linalg.norm(x, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    u_, sv, _ = np.linalg.svd(x / norms, full_matrices=False)
    u_ = u_[:, sv > 1e-10 * sv[0]]

    def residual(d: NDArray[np.float64]) -> NDArray[np.float64]:
        y, linear = _form.input_rows(actuation, recordings, formulation, offsets=d, hold=hold)
        y = y.reshape(-1)
        if linear.shape[-1]:  # gains with offsets: one joint linear solve
            xa = np.concatenate([rows, -linear], axis=2).reshape(-1, rows.shape[-1] + linear.shape[-1])
            return xa @ np.linalg.lstsq(xa, y, rcond=None)[0] - y
        return u_ @ (u_.T @ y) - y

    lo, hi = actuation.offset_bounds()
    d0 = np.clip(actuation.initial_offsets(), lo, hi)
    sol = least_squares(
        residual,
        d0,
        bounds=(lo, hi),
        x_scale=np.maximum(np.abs(d0), 1e-3),
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=200,
    )
    r, jac = sol.fun, sol.jac
    dof = max(r.size - jac.shape[1] - rows.shape[-1], 1)
    s2 = float(r @ r) / dof
    se = np.sqrt(np.maximum(np.diag(s2 * np.linalg.pinv(jac.T @ jac)), 0.0))
    info = {
        "offset_names": list(actuation.offset_names_),
        "offsets": sol.x.copy(),
        "offset_standard_errors": se,
        "offset_relative_standard_errors": se / np.abs(sol.x),
        "offset_fit_success": bool(sol.success),
    }
    return sol.x, info
