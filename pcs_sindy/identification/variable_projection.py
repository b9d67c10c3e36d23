"""Variable projection: nonlinear actuation parameters (tendon offsets) around the linear fit.

For given offsets the Euler–Lagrange regression is linear in the Lagrangian
coefficients (and gains), so its least-squares residual is a function of the
offsets alone; :func:`fit_offsets` minimises it with
:func:`scipy.optimize.least_squares` within the actuation's bounds and takes
standard errors from its Jacobian.

Weighting.  The equations of the different strains have different units and
errors: with noisy poses the shear and axial equations' residuals are two to
three orders of magnitude above the bending equations' (forces against
moments, and a shear strain barely above its noise).  The offsets act through
the bending equations, so an unweighted residual lets the shear and axial
noise set them — through the densities and rotary inertias the equations share
— and its standard errors pool that noise too.  The outer problem is therefore
generalised least squares: each strain's equation is divided by the standard
deviation of its own residual, estimated from the previous fit and iterated
until the weights settle (feasible GLS; maximum likelihood for independent
errors of one variance per equation).  ``TendonActuation(weighting="none")``
solves once with all equations weighted alike.  See docs/method.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from . import formulations as _form

__all__ = ["fit_offsets", "equation_weights"]

#: at most this many reweighting passes; weights that change by less than ``_SETTLED`` (relative) stop them
_MAX_PASSES, _SETTLED = 4, 0.05


def equation_weights(residual: NDArray[np.float64]) -> NDArray[np.float64]:
    """One weight per equation: the inverse RMS of its residual column, normalised to a largest weight of 1.

    Parameters
    ----------
    residual : ndarray, shape (n_rows, n)
        Residual of each row of each strain's equation.

    Returns
    -------
    ndarray, shape (n,)
        An equation without residual (an exact fit) gets 1e6 times the weight
        of the worst-fitted equation rather than an infinite one.
    """
    r = np.asarray(residual, dtype=float)
    if r.ndim != 2 or not np.all(np.isfinite(r)):
        raise ValueError(f"residual must be a finite (n_rows, n) array; got shape {r.shape}")
    rms = np.sqrt(np.mean(r * r, axis=0))
    if not np.any(rms > 0):
        return np.ones(r.shape[1])
    rms = np.maximum(rms, 1e-6 * rms.max())
    return rms.min() / rms


def fit_offsets(
    library: Any, actuation: Any, recordings: list[_form.PreparedRecording], formulation: str, hold: str = "zoh"
) -> tuple[NDArray[np.float64], dict]:
    """Offsets minimising the profiled, equation-weighted residual, and what the data determined of them.

    Parameters
    ----------
    library : LagrangianLibrary
        Fitted on the recordings' segmentation.
    actuation : Actuation
        Fitted, with nonlinear parameters (``offset_names_``).
    recordings : list of PreparedRecording
    formulation : {"strong", "weak"}
    hold : str
        Weak form: how the inputs are integrated.

    Returns
    -------
    offsets : ndarray
        In the actuation's parameterisation (magnitudes).
    info : dict
        ``offset_names``, ``offsets``, ``offset_standard_errors``,
        ``offset_relative_standard_errors``, ``offset_correlation`` (between
        the offsets, after the linear parameters are profiled out),
        ``offset_fit_success``, ``equation_weights`` (the weight of each
        strain's equation in the outer problem) and ``offset_weighting``
        (the actuation's ``weighting``: ``"none"`` solves once, unweighted).
    """
    rows = _form.library_rows(library, recordings, formulation)
    n_rows, n, n_lib = rows.shape
    scale_of = getattr(library, "scale_constraint", None)
    scale = scale_of() if (callable(scale_of) and actuation.n_gains) else None

    def inputs(d: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return _form.input_rows(actuation, recordings, formulation, offsets=d, hold=hold)

    def outer(w: NDArray[np.float64]):
        """Weighted residual of the linear fit at offsets d (the linear parameters solved exactly)."""
        xw = (rows * w[None, :, None]).reshape(-1, n_lib)
        norms = np.linalg.norm(xw, axis=0)
        u_, sv, _ = np.linalg.svd(xw / np.where(norms > 0, norms, 1.0), full_matrices=False)
        basis = u_[:, sv > 1e-10 * sv[0]]

        def residual(d: NDArray[np.float64]) -> NDArray[np.float64]:
            y, linear = inputs(d)
            yw = (y * w).reshape(-1)
            if linear.shape[-1]:  # gains with offsets: one joint linear solve
                xa = np.concatenate([rows, -linear], axis=2) * w[None, :, None]
                xa = xa.reshape(-1, xa.shape[-1])
                if scale is None:
                    return xa @ np.linalg.lstsq(xa, yw, rcond=None)[0] - yw
                # homogeneous equations (every input gain identified): the scale row (the robot's mass),
                # weighted to hold, keeps the inner solve off the trivial zero
                a = np.r_[scale[0], np.zeros(linear.shape[-1])]
                col = np.linalg.norm(xa, axis=0)
                wa = 1e6 / max(np.linalg.norm(a / np.where(col > 0, col, 1.0)), 1e-300)
                sol = np.linalg.lstsq(np.vstack([xa, wa * a]), np.r_[yw, wa * scale[1]], rcond=None)[0]
                return xa @ sol - yw
            return basis @ (basis.T @ yw) - yw

        return residual

    lo, hi = actuation.offset_bounds()
    d = np.clip(actuation.initial_offsets(), lo, hi)
    w = np.ones(n)
    weighting = getattr(actuation, "weighting", "residual")
    passes = _MAX_PASSES if weighting == "residual" else 1
    for k in range(passes):
        sol = least_squares(
            outer(w),
            d,
            bounds=(lo, hi),
            x_scale=np.maximum(np.abs(d), 1e-3),
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=200,
        )
        d = sol.x
        if k == passes - 1:
            break
        w_new = equation_weights(sol.fun.reshape(n_rows, n) / w)
        if np.max(np.abs(w_new / w - 1)) < _SETTLED:
            break
        w = w_new
    r, jac = sol.fun, sol.jac  # of the weights the last solve used
    # relative to the value, or to a typical magnitude for parameters that may be 0 (a tendon's slack)
    floor_of = getattr(actuation, "offset_floor", None)
    floor = np.asarray(floor_of(), dtype=float) if callable(floor_of) else np.zeros(d.size)
    floor = np.where(floor > 0, floor, 1e-300)
    dof = max(r.size - jac.shape[1] - n_lib, 1)
    cov = float(r @ r) / dof * np.linalg.pinv(jac.T @ jac)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        corr = cov / np.outer(se, se)
    info = {
        "offset_names": list(actuation.offset_names_),
        # the nonlinear parameters of every input map are lengths: tendon offsets from the backbone
        "offset_units": ["m"] * d.size,
        "offsets": d.copy(),
        "offset_standard_errors": se,
        "offset_relative_standard_errors": se / np.maximum(np.abs(d), floor),
        "offset_correlation": corr,
        "offset_fit_success": bool(sol.success),
        "equation_weights": w.copy(),
        "offset_weighting": weighting,
    }
    return d, info
