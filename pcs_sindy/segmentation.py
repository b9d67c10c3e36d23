"""Kinematic fusion: from marker poses to a few constant-strain segments.

Implements the seed's Algorithm 1 (docs/method.md, "Kinematic fusion") and, beyond the seed,
a least-squares shape fit with continuously refined segment boundaries.

Markers are the seed's equally spaced cross-sections: a recording holds the
poses of the base and ``N`` markers, shape (T, N + 1, 3), whose arc lengths are
``linspace(0, L_total, N + 1)``.  Marker indices used below always count the
base as index 0 and the tip as index N.

The pieces, as plain functions on numpy arrays:

* :func:`chain_poses` - poses relative to the (fixed or per-frame) base, with
  angles made continuous along the robot;
* :func:`segment_strains` - closed-form inverse kinematics of any segmentation
  whose ends sit on markers (seed eq. 4, 9-10);
* :func:`strain_distances` - seed eq. 11 on scaled strains;
* :func:`merge_runs` - one merge step of Algorithm 1;
* :func:`fuse_segments` - Algorithm 1 to convergence;
* :func:`fit_strains_least_squares` - per-frame Levenberg-Marquardt fit of the
  strains to all marker poses with the analytic Jacobian;
* :func:`refine_boundaries` - continuous boundary arc lengths over a recording;
* :func:`threshold_sweep` / :func:`select_threshold` - the seed's Fig. 8
  trade-off and its "largest decrease of error per added segment" rule.

:class:`KinematicFusion` is the thin scikit-learn transformer on top.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from joblib import Parallel, delayed
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize_scalar
from sklearn.base import BaseEstimator, TransformerMixin, clone
from sklearn.utils.validation import check_is_fitted
from tqdm.auto import tqdm

from ._saving import PersistenceMixin
from .kinematics import (
    forward_kinematics,
    forward_kinematics_jacobian,
    half_cot,
    se2_compose,
    se2_relative,
    segment_inverse_kinematics,
    wrap_angle,
)
from .metrics import distributed_errors
from .trajectory import PoseTrajectory, StrainTrajectory, as_pose_trajectories, as_strain_trajectories

__all__ = [
    "SEED_Q_MAX",
    "SweepRow",
    "KinematicFusion",
    "chain_poses",
    "deformed_lengths",
    "estimate_total_length",
    "jackknife_std",
    "segment_strains",
    "data_q_max",
    "strain_distances",
    "merge_runs",
    "fuse_segments",
    "fit_strains_least_squares",
    "refine_boundaries",
    "threshold_sweep",
    "select_threshold",
]

#: The seed's strain scales: bending 60 1/m, shear and axial 30 %.
SEED_Q_MAX: tuple[float, float, float] = (60.0, 0.3, 0.3)
#: default pose noise (position [m], angle [rad]) that weighs the least-squares shape fit
_POSE_STD: tuple[float, float] = (5e-4, float(np.deg2rad(1.0)))


# --------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------
def _check_chain(P: ArrayLike, name: str = "poses") -> NDArray[np.float64]:
    P = np.asarray(P, dtype=float)
    if P.ndim != 3 or P.shape[2] != 3:
        raise ValueError(f"{name} must have shape (T, N + 1, 3); got {P.shape}")
    if P.shape[1] < 3:
        raise ValueError(f"{name} must hold the base and at least 2 markers (N + 1 >= 3); got N + 1 = {P.shape[1]}")
    if P.shape[0] < 1:
        raise ValueError(f"{name} must hold at least one frame; got shape {P.shape}")
    if not np.all(np.isfinite(P)):
        bad = np.argwhere(~np.isfinite(P))[0]
        raise ValueError(f"{name} contains NaN or inf (first at frame {bad[0]}, marker {bad[1]})")
    return P


def _check_boundaries(boundaries: ArrayLike, n_markers: int) -> NDArray[np.intp]:
    """Segment-end marker indices: strictly increasing, in 1..N, last == N."""
    b = np.asarray(boundaries)
    if b.ndim != 1 or b.size == 0 or not np.issubdtype(b.dtype, np.integer):
        raise ValueError(f"boundaries must be a non-empty 1-D array of marker indices; got {b!r}")
    if b[-1] != n_markers or b[0] < 1 or np.any(np.diff(b) <= 0):
        raise ValueError(f"boundaries must increase strictly from >= 1 to the tip marker {n_markers}; got {b.tolist()}")
    return b.astype(np.intp)


def _check_q_max(q_max: ArrayLike, name: str = "q_max") -> NDArray[np.float64]:
    arr = np.asarray(q_max, dtype=float)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} must be 3 finite positive scales [bending, shear, axial]; got {q_max!r}")
    return arr


# --------------------------------------------------------------------------
# Plain functions
# --------------------------------------------------------------------------
def chain_poses(poses: ArrayLike, fixed_base: bool = True) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Marker poses relative to the robot's base, angles continuous along the robot.

    Parameters
    ----------
    poses : array_like, shape (T, N + 1, 3)
        Base (index 0) and markers, in any common frame.
    fixed_base : bool
        If True the base is clamped: its pose is the median over the recording
        (which averages measurement noise out of every relative pose).  If
        False each frame uses its own measured base pose.

    Returns
    -------
    chain : ndarray, shape (T, N + 1, 3)
        Poses in the base frame; ``chain[:, 0]`` is the base itself (zero when
        ``fixed_base`` is False, the measured deviation otherwise).
    base : ndarray, shape (T, 3)
        The reference base pose of every frame in the input frame.

    Notes
    -----
    Angles are unwrapped along the marker axis: two neighbouring markers are
    always less than π apart in bending angle, so this leaves continuous input
    unchanged and repairs input wrapped to (-π, π].  Relative angles of merged
    segments are then differences of continuous angles, i.e. the true bending
    angle even beyond ±π.
    """
    P = _check_chain(poses)
    P = P.copy()
    P[..., 2] = np.unwrap(P[..., 2], axis=1)
    if fixed_base:
        base_theta = np.unwrap(P[:, 0, 2])
        ref = np.array([np.median(P[:, 0, 0]), np.median(P[:, 0, 1]), np.median(base_theta)])
        base = np.broadcast_to(ref, (P.shape[0], 3)).copy()
        # keep each frame's angles on the branch of the reference angle
        shift = 2.0 * np.pi * np.round((P[:, 0, 2] - base_theta) / (2.0 * np.pi))
        P[..., 2] -= shift[:, None]
    else:
        base = P[:, 0, :].copy()
    chain = se2_relative(base[:, None, :], P)
    return chain, base


def deformed_lengths(chain: ArrayLike) -> NDArray[np.float64]:
    """Deformed axial arc length ``l (1 + σ_ax)`` of every inter-marker segment, shape (T, N).

    From the inverse kinematics (docs/method.md, "Closed forms"), ``l (1 + σ_ax) = -(θ/2) x + y (θ/2)cot(θ/2)``
    for the relative pose ``[x, y, θ]``: it does not depend on the rest length
    ``l``, so it measures the robot without knowing its length.
    """
    P = _check_chain(chain, "chain")
    rel = se2_relative(P[:, :-1, :], P[:, 1:, :])
    x, y, th = rel[..., 0], rel[..., 1], rel[..., 2]
    return -0.5 * th * x + y * half_cot(th)


def estimate_total_length(chains: Sequence[ArrayLike]) -> float:
    """Rest length of the robot from poses alone: the median over all frames of the deformed axial length.

    This is the length that makes the median axial strain of the whole robot
    zero.  It is exact for PCS robots whose axial strain is zero at the median
    frame; a robot that is stretched on average (hanging under its weight,
    pulled by its actuation or by its own swinging) reads longer by that mean
    stretch, which no kinematic estimate can tell from length.  Give the
    measured length, or correct this one with the axial rest strain identified
    from the dynamics (:meth:`KinematicFusion.correct_rest_length`,
    :func:`pcs_sindy.rest_length.estimate_rest_length`).
    """
    totals = np.concatenate([deformed_lengths(c).sum(axis=1) for c in chains])
    value = float(np.median(totals))
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"could not estimate the total length from the data (got {value!r}); pass total_length")
    return value


def jackknife_std(values: ArrayLike, full: float | None = None) -> float:
    """Jackknife standard error from leave-one-out estimates ``values`` (NaN for fewer than two)."""
    v = np.asarray(values, dtype=float)
    if v.size < 2:
        return float("nan")
    return float(np.sqrt((v.size - 1) / v.size * np.sum((v - v.mean()) ** 2)))


def segment_strains(chain: ArrayLike, arc_lengths: ArrayLike, boundaries: ArrayLike) -> NDArray[np.float64]:
    """Closed-form strains of a segmentation whose ends sit on markers.

    Parameters
    ----------
    chain : array_like, shape (T, N + 1, 3)
        Poses with continuous angles (see :func:`chain_poses`).
    arc_lengths : array_like, shape (N + 1,)
        Rest arc lengths of the base and markers.
    boundaries : array_like of int, shape (m,)
        Marker index of each segment's end (the last is N).

    Returns
    -------
    ndarray, shape (T, m, 3)
        ``[κ, σ_sh, σ_ax]`` of each segment from its two end poses (seed
        eq. 9-10 and 4); exact at κ = 0.
    """
    P = _check_chain(chain, "chain")
    s = np.asarray(arc_lengths, dtype=float)
    if s.shape != (P.shape[1],):
        raise ValueError(f"arc_lengths must have shape ({P.shape[1]},); got {s.shape}")
    b = _check_boundaries(boundaries, P.shape[1] - 1)
    starts = np.concatenate([[0], b[:-1]])
    rel = se2_relative(P[:, starts, :], P[:, b, :])
    return segment_inverse_kinematics(rel, s[b] - s[starts])


def data_q_max(q: ArrayLike, fallback: ArrayLike = SEED_Q_MAX, percentile: float = 99.0) -> NDArray[np.float64]:
    """Strain scales from the data: the ``percentile`` of ``|q|`` per strain type.

    A high percentile rather than the maximum keeps a few outlying frames
    from setting the scale.  A strain that is zero throughout has no range;
    its scale falls back to ``fallback``.
    """
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    out = np.percentile(np.abs(q), percentile, axis=0)
    fallback = _check_q_max(fallback, "fallback")
    return np.where(out > 0, out, fallback)


def strain_distances(q_scaled: ArrayLike) -> NDArray[np.float64]:
    """Average strain-space distance of adjacent segments (seed eq. 11).

    Parameters
    ----------
    q_scaled : array_like, shape (T, m, 3)
        Scaled strains.

    Returns
    -------
    ndarray, shape (m - 1,)
        ``mean_k ‖q̄_i(k) − q̄_{i+1}(k)‖``.
    """
    q = np.asarray(q_scaled, dtype=float)
    if q.ndim != 3 or q.shape[2] != 3:
        raise ValueError(f"q_scaled must have shape (T, m, 3); got {q.shape}")
    return np.linalg.norm(q[:, 1:, :] - q[:, :-1, :], axis=2).mean(axis=0)


def merge_runs(distances: ArrayLike, threshold: float) -> list[list[int]]:
    """Groups of segment indices after one merge step of Algorithm 1.

    Every run of adjacent pairs whose distance is ``<= threshold`` becomes one
    group; e.g. distances ``[0.1, 0.5, 0.1, 0.1]`` with threshold 0.2 give
    ``[[0, 1], [2, 3, 4]]``.
    """
    d = np.asarray(distances, dtype=float)
    if d.ndim != 1:
        raise ValueError(f"distances must be 1-D; got shape {d.shape}")
    groups: list[list[int]] = [[0]]
    for i, di in enumerate(d):
        if di <= threshold:
            groups[-1].append(i + 1)
        else:
            groups.append([i + 1])
    return groups


def fuse_segments(
    chains: Sequence[ArrayLike],
    arc_lengths: ArrayLike,
    threshold: float,
    q_max: ArrayLike,
    min_segment_markers: int = 1,
    merge: str = "runs",
    max_iter: int = 1000,
) -> tuple[NDArray[np.intp], list[dict[str, Any]]]:
    """The seed's Algorithm 1 on one or more recordings.

    Starts from one segment per pair of consecutive markers, merges every run
    of adjacent segments whose scaled strains are within ``threshold`` on
    average (over all frames of all recordings), recomputes the strains of the
    merged segments from their end poses, and repeats until nothing merges or
    one segment remains.

    Beyond the seed, ``min_segment_markers > 1`` then absorbs segments spanning
    fewer marker spacings into their nearer neighbour (smaller distance) one
    at a time, resuming Algorithm 1 after each.  When a true boundary falls
    between two markers, the inter-marker segment that straddles it holds a
    blend of both neighbours' strains and can be far from either; the seed's
    algorithm then keeps it as a spurious one-spacing segment.  When noise
    dominates the strains of the initial segments (all distances above
    ``threshold``), absorption acts as agglomeration: a merged, longer
    segment has less noisy strains and is therefore closer to its neighbours
    than two noisy short ones, so it keeps growing from one end until the
    remaining difference is real (right for one- and two-segment PCS robots
    under the seed's noise; for a robot with no constant-strain segments it
    yields one long segment and a rest).

    Parameters
    ----------
    chains : sequence of array_like, each (T_k, N + 1, 3)
        Recordings with continuous angles (see :func:`chain_poses`).
    arc_lengths : array_like, shape (N + 1,)
    threshold : float
        ``h`` (> 0).
    q_max : array_like, shape (3,)
        Strain scales.
    min_segment_markers : int
        Shortest segment, in marker spacings (1 = the seed's algorithm).
    merge : {"runs", "closest_pair"}
        ``"runs"`` merges every run of pairs with distance ``<= threshold`` at
        once (the seed).  ``"closest_pair"`` merges only the closest pair per
        iteration (agglomerative), recomputing strains and distances after
        each merge.  When the distances are nearly uniform along the robot
        (affine curvature: adjacent pieces differ by ``c1 Δs`` everywhere) the
        seed's rule merges all pairs or none; merging one pair at a time
        still yields every model size as ``threshold`` grows.
    max_iter : int

    Returns
    -------
    boundaries : ndarray of int, shape (m,)
        Marker index of each final segment's end.
    history : list of dict
        One entry per iteration: ``boundaries`` (before merging),
        ``distances``, ``groups`` and, for an absorption step, ``absorbed``
        (the index of the absorbed segment).
    """
    if isinstance(threshold, bool) or not np.isfinite(threshold) or threshold <= 0:
        raise ValueError(f"threshold must be finite and > 0; got {threshold!r}")
    if int(min_segment_markers) != min_segment_markers or min_segment_markers < 1:
        raise ValueError(f"min_segment_markers must be a positive integer; got {min_segment_markers!r}")
    if merge not in _MERGES:
        raise ValueError(f"merge must be one of {_MERGES}; got {merge!r}")
    q_max = _check_q_max(q_max)
    s = np.asarray(arc_lengths, dtype=float)
    n_markers = s.size - 1
    boundaries = np.arange(1, n_markers + 1)
    history: list[dict[str, Any]] = []
    for _ in range(max_iter):
        if boundaries.size == 1:
            break
        q = np.concatenate([segment_strains(c, s, boundaries) for c in chains], axis=0)
        d = strain_distances(q / q_max)
        groups = merge_runs(d, threshold)
        if merge == "closest_pair" and len(groups) < boundaries.size:
            lo = int(np.argmin(d))
            groups = [[i] for i in range(lo)] + [[lo, lo + 1]] + [[i] for i in range(lo + 2, boundaries.size)]
        entry: dict[str, Any] = {"boundaries": boundaries.copy(), "distances": d, "groups": groups}
        if len(groups) == boundaries.size:
            widths = np.diff(np.concatenate([[0], boundaries]))
            best = None
            for j in np.flatnonzero(widths < min_segment_markers):
                for nb in (j - 1, j + 1):
                    if 0 <= nb < boundaries.size:
                        dist = d[min(j, nb)]
                        if best is None or dist < best[0]:
                            best = (dist, int(j), nb)
            if best is None:
                history.append(entry)
                break
            _, j, nb = best
            lo = min(j, nb)
            groups = [[i] for i in range(lo)] + [[lo, lo + 1]] + [[i] for i in range(lo + 2, boundaries.size)]
            entry.update(groups=groups, absorbed=j)
        history.append(entry)
        boundaries = np.array([boundaries[g[-1]] for g in groups])
    return boundaries, history


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


def _lengths_from_ends(ends: NDArray[np.float64]) -> NDArray[np.float64]:
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
        q, cost = fit_strains_least_squares(target, _lengths_from_ends(trial), s, warm["q"], pose_std, ftol=ftol)
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
    q, _ = fit_strains_least_squares(target, _lengths_from_ends(ends), s, warm["q"], pose_std)
    return ends, q


# --------------------------------------------------------------------------
# The estimator
# --------------------------------------------------------------------------
_SHAPE_FITS = ("end_pose", "least_squares")
_MERGES = ("runs", "closest_pair")
_SCALINGS = ("q_max", "data")


class KinematicFusion(PersistenceMixin, TransformerMixin, BaseEstimator):
    """Segment a continuum robot into constant-strain pieces (seed Algorithm 1).

    Parameters
    ----------
    threshold : float, default 0.2
        Merge threshold ``h`` on the average scaled strain distance (seed eq. 11).
    q_max : sequence of 3 floats, default (60, 0.3, 0.3)
        Strain scales [1/m, -, -] used when ``scaling="q_max"`` (the seed's).
    scaling : {"q_max", "data"}, default "q_max"
        ``"data"`` scales each strain type by the 99th percentile of its
        magnitude over the initial segments and all frames.
    total_length : float, optional
        Rest length of the robot [m].  If None: the length the poses carry
        (``metadata["rest_length"]``, set by ``MarkerPoseExtractor(robot_length=...)``),
        else the median deformed axial length of the marker chain
        (:func:`estimate_total_length`, long by any mean stretch; correct it
        with :meth:`correct_rest_length` or use
        :func:`pcs_sindy.rest_length.estimate_rest_length`).
    shape_fit : {"least_squares", "end_pose"}, default "least_squares"
        ``"end_pose"`` computes each segment's strains from its two end poses
        (the seed).  ``"least_squares"`` fits each frame's strains to all
        marker poses (:func:`fit_strains_least_squares`) and, with
        ``refine_boundaries``, moves the boundaries off the markers.
    refine_boundaries : bool, default True
        With ``shape_fit="least_squares"``, refine the boundary arc lengths
        continuously over the recordings (:func:`refine_boundaries`).
    min_segment_markers : int, default 2
        Segments spanning fewer marker spacings are absorbed into their more
        similar neighbour after Algorithm 1 (see :func:`fuse_segments`); 1
        reproduces the seed's algorithm exactly.
    merge : {"runs", "closest_pair"}, default "runs"
        ``"runs"``: every run of pairs within ``threshold`` merges at once
        (the seed); ``"closest_pair"``: one pair per iteration (see
        :func:`fuse_segments`).
    pose_std : (float, float), default (5e-4, 1°)
        Position [m] and angle [rad] noise levels weighting the least-squares
        residuals (only their ratio matters).
    fixed_base : bool, default True
        The base is clamped: use its median pose per recording as the
        reference frame instead of each frame's measured base pose.
    max_refine_frames : int, default 500
        Frames (evenly subsampled over all recordings) used by the boundary
        search; the final strains use every frame.
    n_jobs : int, optional
        Recordings whose strains :meth:`transform` fits in parallel (joblib;
        ``None`` or 1: sequentially).  Under ``joblib.parallel_backend(...)``
        the work goes to that backend (e.g. a Dask or Ray cluster).
    progress : bool, default False
        Show tqdm progress bars.

    Attributes
    ----------
    total_length_ : float
    total_length_source_ : str
        Where the rest length came from (given, carried by the poses, estimated, corrected).
    total_length_std_ : float
        Its standard error: 0 when given; for the kinematic estimate the
        jackknife over recordings (over blocks of frames for one recording),
        which does not include the bias of a mean stretch.
    marker_arc_lengths_ : ndarray, shape (N + 1,)
        Rest arc lengths of the base and the markers.
    n_markers_ : int
    q_max_ : ndarray, shape (3,)
        Strain scales used.
    distance_profile_ : ndarray, shape (N - 1,)
        First-iteration distances of adjacent initial segments (seed Fig. 6).
    history_ : list of dict
        Per iteration of Algorithm 1: ``boundaries``, ``distances``, ``groups``.
    boundaries_ : ndarray of int, shape (m,)
        Marker index (base = 0, tip = N) of each fused segment's end.
    segment_lengths_ : ndarray, shape (m,)
        Segment rest lengths (off the marker grid after boundary refinement).
    n_segments_ : int
    base_pose_ : ndarray, shape (3,)
        Median base pose of the fitted recordings (the reference of :meth:`transform_frame`).

    Examples
    --------
    >>> fusion = KinematicFusion(threshold=0.2).fit(poses)        # doctest: +SKIP
    >>> strains = fusion.transform(poses)                          # doctest: +SKIP
    """

    def __init__(
        self,
        threshold: float = 0.2,
        q_max: Sequence[float] = SEED_Q_MAX,
        scaling: str = "q_max",
        total_length: float | None = None,
        shape_fit: str = "least_squares",
        refine_boundaries: bool = True,
        min_segment_markers: int = 2,
        merge: str = "runs",
        pose_std: Sequence[float] = (5e-4, float(np.deg2rad(1.0))),
        fixed_base: bool = True,
        max_refine_frames: int = 500,
        n_jobs: int | None = None,
        progress: bool = False,
    ) -> None:
        self.threshold = threshold
        self.q_max = q_max
        self.scaling = scaling
        self.total_length = total_length
        self.shape_fit = shape_fit
        self.refine_boundaries = refine_boundaries
        self.min_segment_markers = min_segment_markers
        self.merge = merge
        self.pose_std = pose_std
        self.fixed_base = fixed_base
        self.max_refine_frames = max_refine_frames
        self.n_jobs = n_jobs
        self.progress = progress

    # -- validation ----------------------------------------------------------
    def _check_params(self) -> None:
        h = self.threshold
        if isinstance(h, bool) or not isinstance(h, (int, float, np.number)) or not np.isfinite(h) or h <= 0:
            raise ValueError(f"threshold must be a finite number > 0; got {h!r}")
        _check_q_max(self.q_max)
        if self.scaling not in _SCALINGS:
            raise ValueError(f"scaling must be one of {_SCALINGS}; got {self.scaling!r}")
        if self.merge not in _MERGES:
            raise ValueError(f"merge must be one of {_MERGES}; got {self.merge!r}")
        if self.shape_fit not in _SHAPE_FITS:
            raise ValueError(f"shape_fit must be one of {_SHAPE_FITS}; got {self.shape_fit!r}")
        if self.total_length is not None and (not np.isfinite(self.total_length) or self.total_length <= 0):
            raise ValueError(f"total_length must be None or finite and > 0; got {self.total_length!r}")
        std = np.asarray(self.pose_std, dtype=float)
        if std.shape != (2,) or not np.all(np.isfinite(std)) or np.any(std <= 0):
            raise ValueError(
                f"pose_std must be two positive numbers (position [m], angle [rad]); got {self.pose_std!r}"
            )
        m = self.min_segment_markers
        if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
            raise ValueError(f"min_segment_markers must be a positive integer; got {m!r}")
        if int(self.max_refine_frames) != self.max_refine_frames or self.max_refine_frames < 1:
            raise ValueError(f"max_refine_frames must be a positive integer; got {self.max_refine_frames!r}")
        nj = self.n_jobs
        if nj is not None and (isinstance(nj, bool) or not isinstance(nj, (int, np.integer)) or nj == 0):
            raise ValueError(f"n_jobs must be None or a non-zero integer (joblib's convention); got {nj!r}")

    def _chains(self, X: Any, name: str = "X") -> tuple[list[PoseTrajectory], list[NDArray], list[NDArray]]:
        trajs = as_pose_trajectories(X, name=name)
        chains, bases = [], []
        for k, tr in enumerate(trajs):
            try:
                c, b = chain_poses(tr.poses, fixed_base=self.fixed_base)
            except ValueError as err:
                raise ValueError(f"{name}[{k}]: {err}") from None
            chains.append(c)
            bases.append(b)
        n = {c.shape[1] for c in chains}
        if len(n) != 1:
            raise ValueError(f"all recordings in {name} must have the same number of markers; got N + 1 in {sorted(n)}")
        return trajs, chains, bases

    # -- fit -------------------------------------------------------------------
    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False  # X is a list of pose recordings
        return tags

    def fit(self, X: Any, y: Any = None) -> KinematicFusion:
        """Find the segmentation from pose recordings.

        Parameters
        ----------
        X : PoseTrajectory, array (T, N + 1, 3), or a list of them
        y : ignored
        """
        self._check_params()
        _, chains, bases = self._chains(X)
        n_markers = chains[0].shape[1] - 1
        total, source, std = self._rest_length(X, chains)
        s = np.linspace(0.0, total, n_markers + 1)

        if self.scaling == "data":
            q_init = np.concatenate([segment_strains(c, s, np.arange(1, n_markers + 1)) for c in chains], axis=0)
            q_max = data_q_max(q_init, fallback=self.q_max)
        else:
            q_max = _check_q_max(self.q_max)

        boundaries, history = fuse_segments(
            chains, s, float(self.threshold), q_max, int(self.min_segment_markers), self.merge
        )
        self.total_length_ = total
        self.total_length_source_ = source
        self.total_length_std_ = std
        self.marker_arc_lengths_ = s
        self.n_markers_ = n_markers
        self.q_max_ = q_max
        self.history_ = history
        self.distance_profile_ = history[0]["distances"] if history else np.zeros(0)
        self.boundaries_ = boundaries
        ends = s[boundaries]
        if self.shape_fit == "least_squares" and self.refine_boundaries and boundaries.size > 1:
            target = np.concatenate([c[:, 1:, :] for c in chains], axis=0)
            q0 = self._end_pose_q(chains)
            if target.shape[0] > self.max_refine_frames:
                pick = np.linspace(0, target.shape[0] - 1, int(self.max_refine_frames)).round().astype(int)
                target, q0 = target[pick], q0[pick]
            ends, _ = refine_boundaries(target, s[1:], ends, q0, self.pose_std)
        self.segment_lengths_ = _lengths_from_ends(ends)
        self.n_segments_ = int(boundaries.size)
        all_bases = np.concatenate(bases)
        self.base_pose_ = np.median(all_bases, axis=0)  # the clamped base of the recordings, for single frames
        return self

    def _rest_length(self, X: Any, chains: list[NDArray]) -> tuple[float, str, float]:
        """(total rest length, where it comes from, its standard error) for :meth:`fit`."""
        if self.total_length is not None:
            return float(self.total_length), "given (total_length)", 0.0
        trajs = as_pose_trajectories(X)
        given = [tr.metadata.get("rest_length") for tr in trajs]
        if any(g is not None for g in given):
            values = {float(g) for g in given if g is not None}
            if None in given or len(values) > 1:
                raise ValueError(
                    "X: the recordings carry different rest lengths in metadata['rest_length'] "
                    f"({[None if g is None else float(g) for g in given]}); give total_length"
                )
            value = values.pop()
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"X: metadata['rest_length'] must be a length > 0 in metres; got {value!r}")
            return value, "given with the poses (metadata['rest_length'])", 0.0
        total = estimate_total_length(chains)
        # leave one recording out (or, for one recording, one of 8 blocks of frames)
        if len(chains) > 1:
            parts = [estimate_total_length(chains[:k] + chains[k + 1 :]) for k in range(len(chains))]
        else:
            blocks = np.array_split(np.arange(chains[0].shape[0]), min(8, chains[0].shape[0]))
            parts = [
                estimate_total_length([np.delete(chains[0], b, axis=0)]) for b in blocks if b.size < chains[0].shape[0]
            ]
        return total, "estimated: median deformed length (biased by any mean stretch)", jackknife_std(parts)

    def correct_rest_length(self, rest_strain: ArrayLike, rest_strain_std: float | None = None) -> KinematicFusion:
        """Rescale the fitted rest lengths by identified axial rest strains; returns self.

        A rest length read ``(1 + e)`` times too long makes an unloaded robot
        look compressed: its identified axial rest strains (the constant force
        per strain of ``EulerLagrangeRegressor(rest_strain=True)`` over the
        stiffness) are ``-e / (1 + e)``.  Every length is scaled by
        ``1 + q̄``, with ``q̄`` the length-weighted mean of the segments'
        axial rest strains (one factor: markers stay equally spaced).

        Parameters
        ----------
        rest_strain : array_like, shape (3m,)
            ``regressor.rest_strain_`` of a model fitted to this fusion's strains.
        rest_strain_std : float, optional
            Standard error of ``q̄``, propagated to :attr:`total_length_std_`.
        """
        check_is_fitted(self, "segment_lengths_")
        q = np.asarray(rest_strain, dtype=float)
        if q.shape != (3 * self.n_segments_,) or not np.all(np.isfinite(q)):
            raise ValueError(
                f"rest_strain must be {3 * self.n_segments_} finite numbers (3 per segment); got shape {q.shape}"
            )
        mean = float(np.sum(self.segment_lengths_ * q[2::3]) / np.sum(self.segment_lengths_))
        if not -0.5 < mean < 0.5:
            raise ValueError(f"rest_strain: mean axial rest strain {mean:+.3f} is no length error; the fit went wrong")
        factor = 1.0 + mean
        self.total_length_ *= factor
        self.marker_arc_lengths_ = self.marker_arc_lengths_ * factor
        self.segment_lengths_ = self.segment_lengths_ * factor
        self.total_length_source_ = (
            f"{self.total_length_source_}, corrected by the identified axial rest strain {mean:+.5f}"
        )
        if rest_strain_std is not None:
            self.total_length_std_ = float(
                np.hypot(self.total_length_std_ * factor, self.total_length_ * rest_strain_std)
            )
        return self

    def _end_pose_q(self, chains: list[NDArray]) -> NDArray[np.float64]:
        q = [segment_strains(c, self.marker_arc_lengths_, self.boundaries_) for c in chains]
        return np.concatenate([v.reshape(v.shape[0], -1) for v in q], axis=0)

    # -- transform -------------------------------------------------------------
    def _strains(self, chain: NDArray[np.float64]) -> NDArray[np.float64]:
        q = self._end_pose_q([chain])
        if self.shape_fit == "least_squares":
            q, _ = fit_strains_least_squares(
                chain[:, 1:, :], self.segment_lengths_, self.marker_arc_lengths_[1:], q, self.pose_std
            )
        return q

    def transform(self, X: Any) -> list[StrainTrajectory]:
        """Strain trajectories of the fitted segmentation, one per recording.

        Each carries ``segment_lengths`` and, in ``metadata``, the marker arc
        lengths, the per-frame base poses (``"base_poses"``), the fused marker
        boundaries and the shape fit used, so :meth:`inverse_transform`
        reproduces the poses in the input frame.
        """
        check_is_fitted(self, "segment_lengths_")
        trajs, chains, bases = self._chains(X)
        if chains[0].shape[1] - 1 != self.n_markers_:
            raise ValueError(f"X has {chains[0].shape[1] - 1} markers; the fusion was fitted with {self.n_markers_}")
        self._check_params()
        if self.n_jobs in (None, 1) or len(chains) == 1:
            qs = [self._strains(c) for c in tqdm(chains, desc="fusion", disable=not self.progress, leave=False)]
        else:
            # one task per recording; the backend (loky, threads, dask, ray) is joblib's choice
            qs = Parallel(n_jobs=self.n_jobs)(delayed(self._strains)(c) for c in chains)
        out = []
        for tr, q, base in zip(trajs, qs, bases):
            meta = dict(tr.metadata)
            meta.update(
                marker_arc_lengths=self.marker_arc_lengths_.copy(),
                base_poses=base,
                boundaries=self.boundaries_.copy(),
                shape_fit=self.shape_fit,
            )
            out.append(
                StrainTrajectory(
                    q, tr.t, segment_lengths=tuple(self.segment_lengths_), base_pose=tuple(base[0]), metadata=meta
                )
            )
        return out

    def transform_frame(self, poses: ArrayLike, q0: ArrayLike | None = None) -> NDArray[np.float64]:
        """Strains (3m,) of one frame of poses (N + 1, 3): state estimation at camera rate.

        The same estimate as :meth:`transform` for that frame (the base is
        :attr:`base_pose_`, the median of the fitted recordings', when
        ``fixed_base``; the frame's own base otherwise), with the
        least-squares shape fit compiled for one frame (tens of
        microseconds; the first call compiles it, cached on disk).

        Parameters
        ----------
        poses : array_like, shape (N + 1, 3)
            Base and markers, as the extractor returns one frame.
        q0 : array_like, shape (3m,), optional
            Start of the least-squares fit, e.g. the previous frame's strains
            (default: the closed-form strains from the segments' end poses;
            ignored by ``shape_fit="end_pose"``).
        """
        check_is_fitted(self, "segment_lengths_")
        P = np.array(poses, dtype=float)
        if P.shape != (self.n_markers_ + 1, 3) or not np.all(np.isfinite(P)):
            raise ValueError(f"poses must be finite with shape ({self.n_markers_ + 1}, 3); got {np.shape(poses)}")
        P[:, 2] = np.unwrap(P[:, 2])
        base = np.array(self.base_pose_ if self.fixed_base else P[0], dtype=float)
        base[2] += 2.0 * np.pi * np.round((P[0, 2] - base[2]) / (2.0 * np.pi))  # the frame's branch of the base angle
        rel = se2_relative(base, P)
        if q0 is not None:
            start = np.asarray(q0, dtype=float).reshape(-1)
            if start.shape != (3 * self.n_segments_,) or not np.all(np.isfinite(start)):
                raise ValueError(f"q0 must be {3 * self.n_segments_} finite strains; got shape {np.shape(q0)}")
        if q0 is None or self.shape_fit == "end_pose":
            q = segment_strains(rel[None], self.marker_arc_lengths_, self.boundaries_)[0].reshape(-1)
        else:
            q = start
        if self.shape_fit == "least_squares":
            from ._frame_fit import fit_frame

            std = np.asarray(self.pose_std, dtype=float)
            w = np.array([1.0 / std[0], 1.0 / std[0], 1.0 / std[1]])
            q, _ = fit_frame(
                np.ascontiguousarray(rel[1:]),
                np.asarray(self.segment_lengths_, dtype=float),
                np.ascontiguousarray(self.marker_arc_lengths_[1:]),
                q.copy(),
                w,
                50,
                1e-10,
            )
        return q

    def inverse_transform(self, X: Any) -> list[PoseTrajectory]:
        """Poses of the base and the markers, shape (T, N + 1, 3), from strain trajectories.

        Uses the marker arc lengths and per-frame base poses carried in each
        trajectory's metadata when present, else the fitted marker arc
        lengths and the trajectory's constant ``base_pose``.
        """
        check_is_fitted(self, "segment_lengths_")
        strains = as_strain_trajectories(X)
        out = []
        for k, st in enumerate(strains):
            s = np.asarray(st.metadata.get("marker_arc_lengths", self.marker_arc_lengths_), dtype=float)
            total = float(np.sum(st.segment_lengths))
            if abs(s[-1] - total) > 1e-9 * total:
                raise ValueError(
                    f"X[{k}]: segment lengths sum to {total:g} m but the marker arc lengths end at {s[-1]:g} m"
                )
            local = forward_kinematics(st.q, st.segment_lengths, np.clip(s, 0.0, total))
            base = st.metadata.get("base_poses")
            if base is None:
                base = np.broadcast_to(np.asarray(st.kinematics.base_pose), (st.n_frames, 3))
            base = np.asarray(base, dtype=float)
            if base.shape != (st.n_frames, 3):
                raise ValueError(f"X[{k}].metadata['base_poses'] must have shape ({st.n_frames}, 3); got {base.shape}")
            out.append(PoseTrajectory(se2_compose(base[:, None, :], local), st.t, metadata=dict(st.metadata)))
        return out

    def reconstruct(self, X: Any) -> list[PoseTrajectory]:
        """``inverse_transform(transform(X))``: the fused model's poses of the same markers."""
        return self.inverse_transform(self.transform(X))

    def score(self, X: Any, y: Any = None) -> float:
        """Minus the distributed position error e_p^dist (seed eq. 23) over markers (not the base)."""
        trajs = as_pose_trajectories(X)
        rec = self.reconstruct(trajs)
        est = np.concatenate([r.poses[:, 1:, :] for r in rec], axis=0)
        tru = np.concatenate([tr.poses[:, 1:, :] for tr in trajs], axis=0)
        e_p, _ = distributed_errors(est, tru)
        return -e_p


# --------------------------------------------------------------------------
# Threshold sweep (seed Fig. 8) and selection rule
# --------------------------------------------------------------------------
class SweepRow(NamedTuple):
    """One threshold of a sweep: the segmentation it gives and its pose errors."""

    h: float
    n_segments: int
    e_p_dist: float
    e_theta_dist: float


def threshold_sweep(
    X: Any,
    thresholds: ArrayLike,
    *,
    fusion: KinematicFusion | None = None,
    truth: Any = None,
    progress: bool = False,
) -> list[SweepRow]:
    """Fused segmentation and pose errors for several thresholds (seed Fig. 8).

    Parameters
    ----------
    X : pose recordings (see :meth:`KinematicFusion.fit`)
    thresholds : array_like of float
        Values of ``h`` (each > 0).
    fusion : KinematicFusion, optional
        Template whose other parameters are used (default ``KinematicFusion()``).
    truth : pose recordings, optional
        Poses to measure the errors against (default ``X`` itself), markers
        only; must match ``X`` recording by recording.

    Returns
    -------
    list of SweepRow
        ``(h, n_segments, e_p_dist, e_theta_dist)`` in the order of ``thresholds``.
    """
    hs = np.atleast_1d(np.asarray(thresholds, dtype=float))
    if hs.ndim != 1 or hs.size == 0 or not np.all(np.isfinite(hs)) or np.any(hs <= 0):
        raise ValueError(f"thresholds must be a non-empty 1-D array of finite values > 0; got {thresholds!r}")
    template = KinematicFusion() if fusion is None else fusion
    trajs = as_pose_trajectories(X)
    truths = trajs if truth is None else as_pose_trajectories(truth, name="truth")
    if len(truths) != len(trajs) or any(a.poses.shape != b.poses.shape for a, b in zip(trajs, truths)):
        raise ValueError("truth must hold one recording of the same shape per recording of X")
    tru = np.concatenate([tr.poses[:, 1:, :] for tr in truths], axis=0)
    cache: dict[tuple[int, ...], tuple[int, float, float]] = {}
    rows = []
    for h in tqdm(hs, desc="threshold sweep", disable=not progress):
        # Algorithm 1 alone is cheap; the shape fit is done once per distinct segmentation
        probe = clone(template).set_params(threshold=float(h), shape_fit="end_pose").fit(trajs)
        key = tuple(int(b) for b in probe.boundaries_)
        if key not in cache:
            est = clone(template).set_params(threshold=float(h)).fit(trajs)
            rec = est.reconstruct(trajs)
            e_p, e_th = distributed_errors(np.concatenate([r.poses[:, 1:, :] for r in rec], axis=0), tru)
            cache[key] = (est.n_segments_, e_p, e_th)
        n, e_p, e_th = cache[key]
        rows.append(SweepRow(float(h), int(n), float(e_p), float(e_th)))
    return rows


def select_threshold(rows: Sequence[SweepRow | Sequence[float]], error: str = "e_p_dist") -> SweepRow:
    """The model with the largest decrease of error per added segment (seed §IV-B2).

    The rows are reduced to one per number of segments (the one with the
    lowest error) and ordered by segment count; for each model after the
    simplest, the gain is ``(e_prev − e) / (n − n_prev)`` relative to the
    next-simpler model.  The model with the largest gain is chosen (ties go to
    fewer segments); among its rows the largest threshold is returned.  With a
    single segmentation in the sweep that one is returned.

    Parameters
    ----------
    rows : sequence of SweepRow or (h, n_segments, e_p_dist, e_theta_dist)
    error : {"e_p_dist", "e_theta_dist"}
    """
    if error not in ("e_p_dist", "e_theta_dist"):
        raise ValueError(f"error must be 'e_p_dist' or 'e_theta_dist'; got {error!r}")
    rows = [SweepRow(*r) for r in rows]
    if not rows:
        raise ValueError("rows must not be empty")
    for r in rows:
        if not (np.isfinite(r.e_p_dist) and np.isfinite(r.e_theta_dist)):
            raise ValueError(f"rows contain a non-finite error: {r}")
    col = SweepRow._fields.index(error)
    best: dict[int, float] = {}
    for r in rows:
        best[r.n_segments] = min(best.get(r.n_segments, np.inf), r[col])
    ns = sorted(best)
    chosen = ns[0]
    if len(ns) > 1:
        gains = [(best[ns[i - 1]] - best[ns[i]]) / (ns[i] - ns[i - 1]) for i in range(1, len(ns))]
        chosen = ns[1 + int(np.argmax(gains))]
    candidates = [r for r in rows if r.n_segments == chosen and r[col] == best[chosen]]
    return max(candidates, key=lambda r: r.h)
