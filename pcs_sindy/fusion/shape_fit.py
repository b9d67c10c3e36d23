"""The least-squares shape fit: strains and segment boundaries that best explain all marker poses.

Beyond the seed, which reads each segment's strains from its two end poses:

* :func:`fit_strains_least_squares` - per-frame Levenberg-Marquardt fit of the
  strains to all marker poses with the analytic Jacobian (all frames at once);
* :func:`fit_frame_strains` - the same fit for one frame, compiled, for state
  estimation at camera rate;
* :func:`refine_boundaries` - continuous boundary arc lengths over a recording.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize_scalar

from ..core.kinematics import forward_kinematics_jacobian, wrap_angle

__all__ = ["fit_strains_least_squares", "fit_frame_strains", "lengths_from_ends", "refine_boundaries"]

#: default pose noise (position [m], angle [rad]) that weighs the least-squares shape fit
_POSE_STD: tuple[float, float] = (5e-4, float(np.deg2rad(1.0)))


def _ls_residuals(q, lengths, s, target, weights):
    pose, jac = forward_kinematics_jacobian(q, lengths, s)
    r = pose - target
    r[..., 2] = wrap_angle(r[..., 2])
    r = r * weights
    jac = jac * weights[:, None]
    T = q.shape[0]
    return r.reshape(T, -1), jac.reshape(T, -1, q.shape[1])


def fit_strains_least_squares(
    targets: ArrayLike,
    segment_lengths: ArrayLike,
    arc_lengths: ArrayLike,
    q0: ArrayLike,
    pose_std: ArrayLike = _POSE_STD,
    max_iter: int = 50,
    xtol: float = 1e-10,
    ftol: float = 1e-12,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per-frame strains that best fit all marker poses (weighted least squares).

    Minimises, independently for every frame,
    ``Σ_i ‖p̂_i − p_i‖² / σ_p² + (θ̂_i − θ_i)² / σ_θ²`` over the markers by
    Levenberg–Marquardt steps from ``q0`` with the analytic Jacobian of the
    closed-form kinematics; all frames are processed together.

    Parameters
    ----------
    targets : array_like, shape (T, P, 3)
        Marker poses in the base frame.
    segment_lengths : array_like, shape (m,)
    arc_lengths : array_like, shape (P,)
        Rest arc lengths of the markers.
    q0 : array_like, shape (T, 3m)
        Initial strains (e.g. the closed-form end-pose estimate).
    pose_std : (float, float)
        Position [m] and angle [rad] noise levels used as weights.
    max_iter : int
    xtol : float
        A frame has converged when its step is below ``xtol (1 + max|q|)``...
    ftol : float
        ... or when an accepted step lowers its cost by less than the fraction
        ``ftol`` (large-residual frames converge only linearly).

    Returns
    -------
    q : ndarray, shape (T, 3m)
    cost : ndarray, shape (T,)
        Final weighted sum of squared residuals of every frame.
    """
    target = np.asarray(targets, dtype=float)
    q = np.array(q0, dtype=float, copy=True)
    if target.ndim != 3 or target.shape[2] != 3:
        raise ValueError(f"targets must have shape (T, P, 3); got {target.shape}")
    if q.ndim != 2 or q.shape[0] != target.shape[0]:
        raise ValueError(f"q0 must have shape ({target.shape[0]}, 3m); got {q.shape}")
    std = np.asarray(pose_std, dtype=float)
    if std.shape != (2,) or not np.all(np.isfinite(std)) or np.any(std <= 0):
        raise ValueError(f"pose_std must be two positive numbers (position, angle); got {pose_std!r}")
    weights = np.array([1.0 / std[0], 1.0 / std[0], 1.0 / std[1]])
    lengths = np.asarray(segment_lengths, dtype=float)
    s = np.asarray(arc_lengths, dtype=float)

    r, J = _ls_residuals(q, lengths, s, target, weights)
    cost = np.einsum("ti,ti->t", r, r)
    lam = np.full(q.shape[0], 1e-4)
    active = np.ones(q.shape[0], dtype=bool)
    eye = np.eye(q.shape[1])
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        Ja, ra = J[idx], r[idx]
        JtJ = np.einsum("tik,til->tkl", Ja, Ja)
        g = np.einsum("tik,ti->tk", Ja, ra)
        diag = np.einsum("tkk->tk", JtJ)
        # Marquardt scaling keeps the step well posed when a strain is unobservable in a frame
        A = JtJ + lam[idx, None, None] * (diag[:, :, None] * eye + 1e-12 * eye)
        dq = -np.linalg.solve(A, g[..., None])[..., 0]
        q_new = q[idx] + dq
        r_new, J_new = _ls_residuals(q_new, lengths, s, target[idx], weights)
        cost_new = np.einsum("ti,ti->t", r_new, r_new)
        ok = cost_new <= cost[idx]
        flat = cost[idx] - cost_new <= ftol * cost[idx]
        acc = idx[ok]
        q[acc], r[acc], J[acc], cost[acc] = q_new[ok], r_new[ok], J_new[ok], cost_new[ok]
        lam[idx] = np.where(ok, lam[idx] * 0.1, lam[idx] * 10.0)
        small = np.max(np.abs(dq), axis=1) <= xtol * (1.0 + np.max(np.abs(q[idx]), axis=1))
        done = (ok & (small | flat)) | (lam[idx] > 1e12)
        active[idx[done]] = False
    return q, cost


def fit_frame_strains(
    targets: ArrayLike,
    segment_lengths: ArrayLike,
    arc_lengths: ArrayLike,
    q0: ArrayLike,
    pose_std: ArrayLike = _POSE_STD,
) -> NDArray[np.float64]:
    """:func:`fit_strains_least_squares` for one frame, compiled (tens of microseconds).

    Parameters
    ----------
    targets : array_like, shape (P, 3)
        Marker poses in the base frame.
    segment_lengths : array_like, shape (m,)
    arc_lengths : array_like, shape (P,)
    q0 : array_like, shape (3m,)
        Initial strains.
    pose_std : (float, float)
        Position [m] and angle [rad] noise levels used as weights.

    Returns
    -------
    ndarray, shape (3m,)
    """
    # the first call compiles the fit (cached on disk): only when a frame is fitted
    from ._frame_fit import fit_frame

    std = np.asarray(pose_std, dtype=float)
    w = np.array([1.0 / std[0], 1.0 / std[0], 1.0 / std[1]])
    q, _ = fit_frame(
        np.ascontiguousarray(targets, dtype=float),
        np.asarray(segment_lengths, dtype=float),
        np.ascontiguousarray(arc_lengths, dtype=float),
        np.array(q0, dtype=float),
        w,
        50,
        1e-10,
    )
    return q


def lengths_from_ends(ends: NDArray[np.float64]) -> NDArray[np.float64]:
    """Segment lengths (m,) from the arc lengths of their ends (m,), the first segment starting at the base."""
    return np.diff(np.concatenate([[0.0], ends]))


def refine_boundaries(
    targets: ArrayLike,
    arc_lengths: ArrayLike,
    boundary_ends: ArrayLike,
    q0: ArrayLike,
    pose_std: ArrayLike = _POSE_STD,
    window: float | None = None,
    xatol: float = 1e-5,
    max_sweeps: int = 4,
    ftol: float = 1e-9,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Continuous arc lengths of the segment boundaries that best explain a recording.

    Coordinate descent over the interior boundaries: each one is moved by a
    bounded scalar search (:func:`scipy.optimize.minimize_scalar`) that
    minimises the total least-squares residual of all frames, with the
    per-frame strain fit (:func:`fit_strains_least_squares`) inside.  The
    cost grows as m² (m - 1 searches of fits with 3m unknowns): seconds for
    m <= 3 and a few hundred frames, impractical for m of 10 or more.

    Parameters
    ----------
    targets : array_like, shape (T, P, 3)
        Marker poses in the base frame.
    arc_lengths : array_like, shape (P,)
        Marker rest arc lengths (the last one is the robot's tip).
    boundary_ends : array_like, shape (m,)
        Initial arc lengths of the segment ends (the last is the tip, fixed).
    q0 : array_like, shape (T, 3m)
        Initial strains.
    window : float, optional
        How far [m] a boundary may move from its start (default: one and a half
        marker spacings); boundaries also keep a quarter spacing from their
        neighbours.
    xatol : float
        Absolute tolerance [m] of each scalar search.
    max_sweeps : int
        Passes over the boundaries (stops earlier once none moves by more
        than ``10 xatol``).
    ftol : float
        Relative cost tolerance of the inner strain fits.

    Returns
    -------
    ends : ndarray, shape (m,)
        Refined arc lengths of the segment ends.
    q : ndarray, shape (T, 3m)
        Strains fitted with the refined boundaries.
    """
    target = np.asarray(targets, dtype=float)
    s = np.asarray(arc_lengths, dtype=float)
    ends = np.array(boundary_ends, dtype=float)
    q0 = np.asarray(q0, dtype=float)
    spacing = float(np.min(np.diff(np.concatenate([[0.0], s]))))
    if window is None:
        window = 1.5 * spacing
    m = ends.size
    if m == 1:
        q, _ = fit_strains_least_squares(target, ends, s, q0, pose_std)
        return ends, q

    # successive trial boundaries are close, so the last fit is a better start than q0
    warm = {"q": q0}

    def objective(value: float, j: int) -> float:
        trial = ends.copy()
        trial[j] = value
        q, cost = fit_strains_least_squares(target, lengths_from_ends(trial), s, warm["q"], pose_std, ftol=ftol)
        warm["q"] = q
        return float(cost.sum())

    start = ends.copy()
    for sweep in range(max_sweeps):
        moved = 0.0
        for j in range(m - 1):
            # later sweeps only correct for the neighbours' moves: search close to the current value
            reach = window if sweep == 0 else 0.25 * spacing
            lo = max(ends[j] - reach, start[j] - window, (ends[j - 1] if j > 0 else 0.0) + 0.25 * spacing)
            hi = min(ends[j] + reach, start[j] + window, ends[j + 1] - 0.25 * spacing)
            current = objective(ends[j], j)
            res = minimize_scalar(objective, bounds=(lo, hi), args=(j,), method="bounded", options={"xatol": xatol})
            if res.fun < current:  # a bounded Brent search is local: never accept a worse boundary
                moved = max(moved, abs(res.x - ends[j]))
                ends[j] = res.x
        if moved <= 10 * xatol:
            break
    q, _ = fit_strains_least_squares(target, lengths_from_ends(ends), s, warm["q"], pose_std)
    return ends, q
