"""Least squares on column-scaled regressors, and the material stiffness bounds of strain removal."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import NDArray

__all__ = ["stiffness_bounds", "scaled_lstsq"]


def stiffness_bounds(
    segment_lengths: Sequence[float],
    *,
    youngs_modulus_max: float = 100e6,
    shear_modulus_max: float = 0.1e6,
    radius: float = 0.02,
    shear_factor: float = 4.0 / 3.0,
    stiffness_scaling: str = "seed",
) -> NDArray[np.float64]:
    """Maximum stiffness of every strain, ``f_L * [I E_max, c_sh A G_max, A E_max]`` per segment.

    Parameters
    ----------
    segment_lengths : sequence of float
        Rest lengths of the m segments (m).
    youngs_modulus_max, shear_modulus_max : float
        Material maxima (Pa); the seed uses 100 MPa and 0.1 MPa.
    radius : float
        Radius of the circular cross-section (m).
    shear_factor : float
        ``c_sh`` multiplying the shear stiffness (4/3 in the seed's simulator).
    stiffness_scaling : {"seed", "length"}
        ``"seed"``: ``f_L = 1`` (the convention of every number in the seed);
        ``"length"``: ``f_L = L_i`` (elastic energy ``1/2 L_i q^T K q``).

    Returns
    -------
    ndarray, shape (3m,)
        For r = 0.02 m and the seed defaults: 12.6 N m^2, 168 N, 126 kN per segment.
    """
    lengths = np.atleast_1d(np.asarray(segment_lengths, dtype=float))
    if lengths.ndim != 1 or lengths.size == 0 or not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
        raise ValueError(f"segment_lengths must be positive finite lengths; got {segment_lengths!r}")
    for name, val in (
        ("youngs_modulus_max", youngs_modulus_max),
        ("shear_modulus_max", shear_modulus_max),
        ("radius", radius),
        ("shear_factor", shear_factor),
    ):
        if not np.isfinite(val) or val <= 0:
            raise ValueError(f"{name} must be finite and > 0; got {val!r}")
    if stiffness_scaling == "seed":
        f_l = np.ones_like(lengths)
    elif stiffness_scaling == "length":
        f_l = lengths
    else:
        raise ValueError(f"stiffness_scaling must be 'seed' or 'length'; got {stiffness_scaling!r}")
    area = np.pi * radius**2
    inertia = np.pi * radius**4 / 4
    per_seg = np.array(
        [inertia * youngs_modulus_max, shear_factor * area * shear_modulus_max, area * youngs_modulus_max]
    )
    return (f_l[:, None] * per_seg[None, :]).reshape(-1)


def scaled_lstsq(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    *,
    rcond: float = 1e-10,
    feature_names: Sequence[str] | None = None,
    lower_bounds: NDArray[np.float64] | None = None,
    equality: tuple[NDArray[np.float64], float] | None = None,
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Least squares on unit-norm columns via the SVD; raise when rank deficient.

    Parameters
    ----------
    x : ndarray, shape (n_rows, n_features)
    y : ndarray, shape (n_rows,) or (n_rows, n_targets)
    rcond : float
        Singular values below ``rcond * s_max`` (of the column-scaled matrix)
        count as zero.
    feature_names : sequence of str, optional
        Used to name the offending columns in errors.
    lower_bounds : ndarray, shape (n_features,), optional
        Lower bounds on the coefficients (``-inf`` where free); when the
        unconstrained solution violates them, the bounded problem is solved
        with :func:`scipy.optimize.lsq_linear` on the scaled columns
        (one target only).
    equality : tuple (a, b), optional
        A linear equality ``a @ coef = b`` (one target only), enforced as a row
        weighted 1e6 times the scaled columns (e.g. a known total mass fixing
        the scale of a homogeneous regression).

    Returns
    -------
    coef : ndarray, shape (n_features,) or (n_features, n_targets)
        In the units of the unscaled columns.
    info : dict
        ``rank``, ``condition_number`` (of the scaled matrix), ``relative_residual``.

    Raises
    ------
    ValueError
        On an all-zero column or a rank-deficient (non-exciting) design; the
        message names the columns involved.
    """
    names = list(feature_names) if feature_names is not None else [f"x{j}" for j in range(x.shape[1])]
    if equality is not None:
        a, b = np.asarray(equality[0], dtype=float).reshape(-1), float(equality[1])
        if a.shape != (x.shape[1],) or y.ndim != 1 or not np.all(np.isfinite(a)) or not np.isfinite(b):
            raise ValueError(f"equality must be (a, b) with a finite a of shape ({x.shape[1]},) and one target")
        col = np.linalg.norm(x, axis=0)
        scaled = np.linalg.norm(a / np.where(col > 0, col, 1.0))
        if not scaled > 0:
            raise ValueError("equality row a is zero on every column")
        w = 1e6 / scaled
        x = np.vstack([x, w * a[None, :]])
        y = np.append(y, w * b)
    if x.shape[0] < x.shape[1]:
        raise ValueError(f"regression has fewer rows ({x.shape[0]}) than unknowns ({x.shape[1]}); record more samples")
    norms = np.linalg.norm(x, axis=0)
    zero = ~(norms > 0)
    if np.any(zero):
        bad = [names[j] for j in np.flatnonzero(zero)][:8]
        raise ValueError(
            f"the data do not excite {int(zero.sum())} basis column(s) (all zero), e.g. {bad}; "
            "the regression is rank deficient: record exciting trajectories or remove those strains"
        )
    xs = x / norms
    u, s, vt = scipy.linalg.svd(xs, full_matrices=False, lapack_driver="gesdd", check_finite=False)
    rank = int(np.sum(s > rcond * s[0]))
    if rank < x.shape[1]:
        # the weakest right singular vector shows which columns are (nearly) collinear
        null = np.abs(vt[-1])
        worst = [names[j] for j in np.argsort(null)[::-1][:6]]
        raise ValueError(
            f"rank-deficient regression: rank {rank} < {x.shape[1]} unknowns (singular value ratio "
            f"{s[-1] / s[0]:.2e} < rcond = {rcond:g}); the data do not excite the basis enough to separate "
            f"e.g. {worst}; record more exciting trajectories (constant data excite nothing)"
        )
    coef_s = vt.T @ ((u.T @ y) / (s if y.ndim == 1 else s[:, None]))
    coef = coef_s / (norms if y.ndim == 1 else norms[:, None])
    bounded = False
    if lower_bounds is not None:
        lb = np.asarray(lower_bounds, dtype=float)
        if lb.shape != (x.shape[1],) or y.ndim != 1:
            raise ValueError(f"lower_bounds must have shape ({x.shape[1]},) with one target; got {lb.shape}")
        if np.any(coef < lb):
            # bounds scale with the columns: coef_s = coef * norm
            sol = scipy.optimize.lsq_linear(xs, y, bounds=(lb * norms, np.inf), method="bvls")
            coef = sol.x / norms
            bounded = True
    res = y - x @ coef
    ynorm = np.linalg.norm(y)
    info = {
        "rank": rank,
        "bounded": bounded,
        "condition_number": float(s[0] / s[-1]),
        "relative_residual": float(np.linalg.norm(res) / ynorm) if ynorm > 0 else float(np.linalg.norm(res)),
    }
    return coef, info
