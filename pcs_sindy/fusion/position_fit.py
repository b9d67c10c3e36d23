"""Fusion of positions-only markers: base pose, marker arc lengths and bending strains from 2-5 positions.

Motion capture of a soft robot often tracks a few markers (rigid bodies) along
the body by their positions only, with the base untracked.  Without
orientations the closed-form segment strains of :mod:`.chain_geometry` do not
apply; instead a planar PCS model whose segments end on the markers, bending
only (inextensible, unsheared: a few positions do not resolve shear and
stretch), is fitted by least squares:

* :func:`fit_marker_geometry` - the fixed base pose ``[x, y, theta]`` in the
  marker plane and the markers' rest arc lengths, jointly with every sampled
  frame's curvatures (``scipy.optimize.least_squares`` with the problem's
  sparsity);
* :func:`fit_position_strains` - each frame's curvatures for a given geometry and
  segmentation (batched Gauss-Newton with Levenberg damping; samples that are
  missing weigh nothing, frames with too few markers are interpolated in time).

:class:`~pcs_sindy.fusion.KinematicFusion` uses both when it is given
recordings made by :meth:`PoseTrajectory.from_positions`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from ..core.kinematics import forward_kinematics, forward_kinematics_jacobian

__all__ = ["fit_marker_geometry", "fit_position_strains", "bending_strains"]


def bending_strains(kappa: ArrayLike) -> NDArray[np.float64]:
    """Full strains (..., 3m) with curvatures ``kappa`` (..., m) and zero shear and axial strain."""
    k = np.asarray(kappa, dtype=float)
    q = np.zeros(k.shape[:-1] + (k.shape[-1], 3))
    q[..., 0] = k
    return q.reshape(k.shape[:-1] + (3 * k.shape[-1],))


def _initial_geometry(P: NDArray[np.float64], arc_lengths: NDArray | None) -> tuple[NDArray, NDArray]:
    """Base pose and arc lengths to start from: a straight robot through the markers' mean positions."""
    mean = np.nanmean(P, axis=0)  # (N, 2)
    N = mean.shape[0]
    if arc_lengths is None:
        gaps = np.nanmedian(np.linalg.norm(np.diff(P, axis=1), axis=2), axis=0) if N > 1 else np.zeros(0)
        first = gaps.mean() if gaps.size else 0.05
        s = np.cumsum(np.concatenate([[first], gaps]))
    else:
        s = np.asarray(arc_lengths, dtype=float)
    if N > 1:
        d = mean[-1] - mean[0]
        d = d / np.linalg.norm(d)
    else:
        d = np.array([0.0, 1.0])
    base_xy = mean[0] - s[0] * d
    theta = np.arctan2(-d[0], d[1])  # R(theta) [0, 1] = d: the robot at rest along the base's +y
    return np.array([base_xy[0], base_xy[1], theta]), s


def _check_plane_positions(positions: Sequence[ArrayLike]) -> list[NDArray[np.float64]]:
    out = [np.asarray(p, dtype=float) for p in positions]
    n = {p.shape[1] if p.ndim == 3 else -1 for p in out}
    if any(p.ndim != 3 or p.shape[2] != 2 for p in out) or len(n) != 1:
        raise ValueError(f"positions must be arrays (T, N, 2) with one N; got shapes {[p.shape for p in out]}")
    return out


def fit_marker_geometry(
    positions: Sequence[ArrayLike],
    arc_lengths: ArrayLike | None = None,
    *,
    max_frames: int = 300,
    base_pose: ArrayLike | None = None,
    curvatures: str | ArrayLike = "uniform",
) -> dict[str, NDArray[np.float64] | float]:
    """Fixed base pose and rest arc lengths of position-only markers.

    Model: an inextensible robot bending with one curvature per frame
    (``curvatures="uniform"``) or one per marker spacing (``"per_segment"``);
    unknowns are the base pose, the arc lengths (unless given) and each
    sampled frame's curvatures.  The shape of the curves the markers sweep (a
    marker at arc length ``s`` of a uniformly bending robot moves by about
    ``kappa s^2 / 2``) determines them: the recordings must bend the robot.
    With a curvature per spacing a small bending no longer tells the base's
    distance (any pattern of displacements fits), hence the uniform default;
    its bias when the robot does not bend uniformly is the price.

    Parameters
    ----------
    positions : sequence of array_like, each (T_k, N, 2)
        In-plane marker positions [m] of each recording, NaN for missing.
    arc_lengths : array_like, shape (N,), optional
        Known rest arc lengths of the markers [m] (then only the base is fitted).
    max_frames : int, default 300
        Frames used (evenly spread over all recordings).
    base_pose : array_like, shape (3,), optional
        A known base pose (then only the arc lengths are fitted).
    curvatures : {"uniform", "per_segment"} or array_like of int, default "uniform"
        Or the index (0, 1, ...) of the curvature of each of the N marker spacings, e.g.
        ``[0, 0, 1]`` for a segment over the first two spacings and one over the third.

    Returns
    -------
    dict
        ``base_pose`` (3,), ``arc_lengths`` (N,), ``rms`` (position residual
        RMS [m]), ``std`` (standard errors of base pose and arc lengths, (3 + N,)).
    """
    recs = _check_plane_positions(positions)
    P = np.concatenate(recs, axis=0)
    good = np.any(np.all(np.isfinite(P), axis=2), axis=1)
    P = P[good]
    if P.shape[0] < 3:
        raise ValueError(f"positions: need at least 3 frames with a valid marker; got {P.shape[0]}")
    if P.shape[0] > max_frames:
        P = P[np.linspace(0, P.shape[0] - 1, int(max_frames)).round().astype(int)]
    F, N, _ = P.shape
    b0, s0 = _initial_geometry(P, None if arc_lengths is None else np.asarray(arc_lengths, dtype=float))
    if base_pose is not None:
        b0 = np.asarray(base_pose, dtype=float).reshape(3)
    if isinstance(curvatures, str):
        if curvatures not in ("uniform", "per_segment"):
            raise ValueError(f"curvatures must be 'uniform', 'per_segment' or indices; got {curvatures!r}")
        group = np.zeros(N, dtype=int) if curvatures == "uniform" else np.arange(N)
    else:
        group = np.asarray(curvatures)
        if group.shape != (N,) or group[0] != 0 or not np.all(np.isin(np.diff(group), (0, 1))):
            raise ValueError(
                f"curvatures must be {N} non-decreasing indices from 0 in steps of 0 or 1; got {curvatures!r}"
            )
    nk = int(group[-1]) + 1
    fit_base = base_pose is None
    fit_s = arc_lengths is None
    mask = np.all(np.isfinite(P), axis=2)  # (F, N)
    target = np.where(mask[..., None], P, 0.0)
    # global parameters: base (3) when fitted, log of the gaps (N) when fitted; then F x N curvatures
    n_glob = 3 * fit_base + N * fit_s
    scale = max(float(s0[-1]), 1e-3)

    def unpack(x):
        k = 0
        b = b0
        if fit_base:
            b = x[:3] * np.array([scale, scale, 1.0])
            k = 3
        s = s0
        if fit_s:
            s = np.cumsum(np.exp(x[k : k + N])) * scale
        kappa = x[n_glob:].reshape(F, nk)[:, group] / scale
        return b, s, kappa

    def residuals(x):
        b, s, kappa = unpack(x)
        lengths = np.diff(np.concatenate([[0.0], s]))
        pose = forward_kinematics(bending_strains(kappa), lengths, s, base_pose=b)
        r = (pose[..., :2] - target) * mask[..., None]
        return r.reshape(-1) / scale

    x0 = []
    if fit_base:
        x0 += list(b0 / np.array([scale, scale, 1.0]))
    if fit_s:
        x0 += list(np.log(np.diff(np.concatenate([[0.0], s0])) / scale))
    x0 = np.concatenate([np.asarray(x0, dtype=float), np.zeros(F * nk)])
    sparsity = lil_matrix((2 * F * N, x0.size), dtype=int)
    sparsity[:, :n_glob] = 1
    for f in range(F):
        rows = slice(2 * N * f, 2 * N * (f + 1))
        sparsity[rows, n_glob + nk * f : n_glob + nk * (f + 1)] = 1
    res = least_squares(residuals, x0, jac_sparsity=sparsity, x_scale="jac", method="trf", max_nfev=200)
    b, s, _ = unpack(res.x)
    dof = max(int(mask.sum()) * 2 - x0.size, 1)
    rms = float(np.sqrt(np.sum(res.fun**2) / mask.sum() / 2)) * scale
    std = np.full(n_glob, np.nan)
    if n_glob:
        J = res.jac.toarray() if hasattr(res.jac, "toarray") else np.asarray(res.jac)
        sigma2 = np.sum(res.fun**2) / dof
        try:
            cov = np.linalg.pinv(J.T @ J)[:n_glob, :n_glob] * sigma2
        except np.linalg.LinAlgError:
            cov = np.full((n_glob, n_glob), np.nan)
        # back to physical units: base x, y in metres; arc lengths s_i = scale sum_{j<=i} exp(x_j)
        units = np.eye(n_glob)
        if fit_base:
            units[0, 0] = units[1, 1] = scale
        if fit_s:
            gaps = np.diff(np.concatenate([[0.0], s]))
            k = 3 * fit_base
            units[k:, k:] = np.tril(np.ones((N, N))) * gaps[None, :]
        std = np.sqrt(np.clip(np.diag(units @ cov @ units.T), 0.0, None))
    return {"base_pose": np.asarray(b, dtype=float), "arc_lengths": np.asarray(s, dtype=float), "rms": rms, "std": std}


def fit_position_strains(
    positions: ArrayLike,
    base_pose: ArrayLike,
    segment_lengths: ArrayLike,
    marker_arc_lengths: ArrayLike,
    *,
    q0: ArrayLike | None = None,
    max_iter: int = 30,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Bending strains of every frame from in-plane marker positions.

    Parameters
    ----------
    positions : array_like, shape (T, N, 2)
        In-plane positions [m], NaN for missing samples.
    base_pose : array_like, shape (3,)
    segment_lengths : array_like, shape (m,)
    marker_arc_lengths : array_like, shape (N,)
        Rest arc lengths of the markers (base excluded).
    q0 : array_like, shape (T, 3m), optional
        Start; default straight.
    max_iter : int, default 30

    Returns
    -------
    q : ndarray, shape (T, 3m)
        Full strains (shear and axial zero).
    estimated : ndarray of bool, shape (T,)
        False where some curvature of the frame was not determined by its
        valid markers (too few, or none beyond the segment's start) and was
        interpolated in time.
    """
    P = np.asarray(positions, dtype=float)
    lengths = np.asarray(segment_lengths, dtype=float)
    s = np.asarray(marker_arc_lengths, dtype=float)
    base = np.asarray(base_pose, dtype=float)
    T, N, _ = P.shape
    m = lengths.size
    mask = np.all(np.isfinite(P), axis=2)
    W = np.repeat(mask, 2, axis=1).astype(float)  # (T, 2N)
    target = np.where(mask[..., None], P, 0.0).reshape(T, 2 * N)
    kappa = np.zeros((T, m)) if q0 is None else np.asarray(q0, dtype=float).reshape(T, m, 3)[..., 0].copy()
    lam = np.full(T, 1e-3)

    def evaluate(k):
        pose, jac = forward_kinematics_jacobian(bending_strains(k), lengths, s, base_pose=base)
        r = (pose[..., :2].reshape(T, 2 * N) - target) * W
        J = jac[:, :, :2, 0::3].reshape(T, 2 * N, m) * W[..., None]
        return r, J

    r, J = evaluate(kappa)
    cost = np.sum(r**2, axis=1)
    eye = np.eye(m)
    for _ in range(max_iter):
        JtJ = np.einsum("tia,tib->tab", J, J)
        g = np.einsum("tia,ti->ta", J, r)
        diag = np.einsum("taa->ta", JtJ)
        A = JtJ + lam[:, None, None] * diag[:, :, None] * eye + 1e-12 * eye  # unseen curvatures stay put
        step = -np.linalg.solve(A, g[..., None])[..., 0]
        r_new, J_new = evaluate(kappa + step)
        c_new = np.sum(r_new**2, axis=1)
        better = c_new <= cost
        kappa[better] += step[better]
        r[better], J[better], cost[better] = r_new[better], J_new[better], c_new[better]
        lam = np.clip(np.where(better, lam * 0.3, lam * 10.0), 1e-12, 1e12)
        if np.max(np.abs(step[better]), initial=0.0) < 1e-10 and np.all(better):
            break
    # curvature j is seen by the valid markers beyond the start of segment j; frames that do not see it
    # (or have fewer valid coordinates than curvatures) get it interpolated in time
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    beyond = s[None, :] > starts[:, None] + 1e-12  # (m, N)
    seen = (mask.astype(int) @ beyond.T.astype(int)) > 0  # (T, m)
    seen &= (mask.sum(axis=1) * 2 >= m)[:, None]
    estimated = seen.all(axis=1)
    t = np.arange(T)
    for j in range(m):
        if not seen[:, j].any():
            raise ValueError(f"no frame has a valid marker beyond the start of segment {j}; cannot estimate it")
        if not seen[:, j].all():
            kappa[~seen[:, j], j] = np.interp(t[~seen[:, j]], t[seen[:, j]], kappa[seen[:, j], j])
    return bending_strains(kappa), estimated
