"""What the recordings determined: standard errors of the identified coefficients.

:func:`identifiability` works on any least-squares fit ``y ≈ x @ coef``;
:func:`strain_excitation` adds which strains the data did not excite, and
:func:`report` prints it all.  The standard errors assume independent rows,
so they are optimistic for overlapping weak-form windows.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["identifiability", "strain_excitation", "report"]


def identifiability(
    x: ArrayLike,
    y: ArrayLike,
    coef: ArrayLike,
    names: Sequence[str] | None = None,
    *,
    rcond: float = 1e-12,
    tol: float = 0.1,
) -> dict:
    """Which coefficients a least-squares fit ``y ≈ x @ coef`` actually determined.

    Standard errors come from the residual of the fit, ``cov = s^2 (x^T x)^-1``
    with ``s^2 = |y - x coef|^2 / (n_rows - n_coef)``, evaluated through the SVD
    of the column-scaled ``x`` (never an explicit inverse).  Directions of
    ``x`` with singular value below ``rcond * s_max`` are not determined at
    all: every coefficient they involve gets an infinite standard error.

    Parameters
    ----------
    x : array_like, shape (n_rows, n_coef) or (n_samples, n, n_coef)
        Regression matrix (e.g. ``Psi`` or its weak form).
    y : array_like, shape (n_rows,) or (n_samples, n)
        Targets stacked like ``x``.
    coef : array_like, shape (n_coef,)
        The fitted coefficients.
    names : sequence of str, optional
        Coefficient names (default ``c0, c1, ...``).
    rcond : float
        Relative singular-value cut-off of the column-scaled ``x``.
    tol : float
        Relative standard error above which a coefficient is reported as poorly determined.

    Returns
    -------
    dict
        ``condition_number`` (of the column-scaled ``x``; inf if rank deficient),
        ``rank``, ``singular_values``, ``residual_std``, ``standard_errors``,
        ``relative_standard_errors`` (``se / |coef|``), ``names`` and
        ``poorly_determined`` (names whose relative error exceeds ``tol``).
    """
    x = np.asarray(x, dtype=float)
    if x.ndim == 3:
        x = x.reshape(-1, x.shape[-1])
    y = np.asarray(y, dtype=float).reshape(-1)
    if x.ndim != 2 or y.shape != (x.shape[0],):
        raise ValueError(f"x must be (n_rows, n_coef) and y (n_rows,) stacked alike; got x {x.shape}, y {y.shape}")
    p = x.shape[1]
    coef = np.asarray(coef, dtype=float).reshape(-1)
    if coef.shape != (p,):
        raise ValueError(f"coef must have shape ({p},); got shape {coef.shape}")
    for name, arr in (("x", x), ("y", y), ("coef", coef)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
    if x.shape[0] <= p:
        raise ValueError(f"x needs more rows than coefficients to estimate errors; got {x.shape[0]} rows for {p}")
    if not (0 < rcond < 1) or not tol > 0:
        raise ValueError(f"rcond must be in (0, 1) and tol > 0; got rcond={rcond!r}, tol={tol!r}")
    names = [f"c{j}" for j in range(p)] if names is None else list(names)
    if len(names) != p:
        raise ValueError(f"names must hold {p} names; got {len(names)}")
    scale = np.linalg.norm(x, axis=0)
    safe = np.where(scale > 0, scale, 1.0)
    _, sv, vt = np.linalg.svd(x / safe, full_matrices=False)
    keep = sv > rcond * sv[0] if sv[0] > 0 else np.zeros_like(sv, dtype=bool)
    rank = int(keep.sum())
    resid = y - x @ coef
    s2 = float(resid @ resid) / (x.shape[0] - p)
    v = vt[keep].T / sv[keep]  # columns V S^-1 of the determined directions
    se = np.sqrt(s2 * np.sum(v * v, axis=1)) / safe
    # coefficients touched by an undetermined direction (or an all-zero column) are not determined
    null = vt[~keep]
    undetermined = (scale == 0) | (np.abs(null).max(axis=0) > 1e-8 if null.size else np.zeros(p, dtype=bool))
    se = np.where(undetermined, np.inf, se)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(coef != 0, se / np.abs(coef), np.inf)
    cond = float(sv[0] / sv[-1]) if rank == p else np.inf
    return {
        "condition_number": cond,
        "rank": rank,
        "singular_values": sv,
        "residual_std": float(np.sqrt(s2)),
        "standard_errors": se,
        "relative_standard_errors": rel,
        "names": names,
        "poorly_determined": [nm for nm, r in zip(names, rel) if not r <= tol],
    }


def strain_excitation(
    info: dict, strain_names: Sequence[str], stiffness_index: ArrayLike, damping_index: ArrayLike, tol: float = 0.1
) -> list[str]:
    """Strains whose stiffness or damping the data did not determine (relative standard error above ``tol``).

    Parameters
    ----------
    info : dict
        Output of :func:`identifiability`.
    strain_names : sequence of str
        Names of the active strains, in the order of the index arrays.
    stiffness_index, damping_index : array_like of int, shape (n,)
        Column of each strain's stiffness and damping.
    tol : float
    """
    rel = np.asarray(info["relative_standard_errors"])
    bad = ~(rel <= tol)
    cols = np.stack([np.asarray(stiffness_index), np.asarray(damping_index)], axis=1)
    return [nm for nm, c in zip(strain_names, cols) if np.any(bad[c])]


def report(info: dict | None, tol: float = 0.1, units: dict[str, str] | None = None) -> str:
    """Readable summary of an identifiability dict: one line per coefficient, then the flags.

    ``units`` maps coefficient names to their units (shown beside value and standard error).
    """
    units = units or {}
    if info is None:
        return "identifiability not available: the regression had no more rows than coefficients"
    lines = [
        f"{info.get('formulation', 'the')}-form regression: condition number {info['condition_number']:.3g} "
        f"(column-scaled), rank {info['rank']} of {len(info['names'])}, residual std {info['residual_std']:.3g}",
        f"{'coefficient':<14} {'value':>12} {'std error':>12} {'rel. error':>11}  unit",
    ]
    for nm, c, se, rel in zip(info["names"], info["coef"], info["standard_errors"], info["relative_standard_errors"]):
        flag = "" if rel <= tol else "  <- poorly determined"
        lines.append(f"{nm:<14} {c:>12.4g} {se:>12.3g} {rel:>11.2%}  {units.get(nm, '?')}{flag}")
    lines += _offset_lines(info, tol)
    lines.append(f"poorly determined (rel. error > {tol:.0%}): " + (", ".join(info["poorly_determined"]) or "none"))
    excited = info.get("poorly_excited_strains", [])
    lines.append(
        "strains the data did not excite enough (stiffness or damping poorly determined): "
        + (", ".join(excited) if excited else "none")
    )
    return "\n".join(lines)


def _offset_lines(info: dict, tol: float) -> list[str]:
    """The actuation's nonlinear parameters (tendon offsets) of a variable-projection fit, if any."""
    names = info.get("offset_names") or []
    if not names:
        return []
    values, se = np.asarray(info["offsets"]), np.asarray(info["offset_standard_errors"])
    rel = np.asarray(info["offset_relative_standard_errors"])
    how = "unweighted" if info.get("offset_weighting") == "none" else "each strain's equation weighted by its residual"
    lines = [f"actuation offsets (variable projection, {how}):"]
    units = info.get("offset_units") or ["?"] * len(names)
    for nm, v, s, r, unit in zip(names, values, se, rel, units, strict=True):
        flag = "" if r <= tol else "  <- poorly determined"
        lines.append(f"{nm:<14} {v:>12.4g} {s:>12.3g} {r:>11.2%}  {unit}{flag}")
    corr = np.asarray(info.get("offset_correlation", np.eye(len(names))))
    if len(names) > 1 and np.all(np.isfinite(corr)):
        off = np.abs(corr - np.diag(np.diag(corr)))
        i, j = np.unravel_index(np.argmax(off), off.shape)
        lines.append(f"largest correlation between offsets: {corr[i, j]:+.3f} ({names[i]}, {names[j]})")
    bad = [nm for nm, r in zip(names, rel) if not r <= tol]
    if bad:
        lines.append(
            f"the recordings do not determine the offsets {', '.join(bad)} (std error above {tol:.0%} of the value): "
            "identify one offset shared by all tendons (TendonActuation(shared=True)), give the measured offsets, "
            "or record inputs that pull each tendon on its own"
        )
    return lines
