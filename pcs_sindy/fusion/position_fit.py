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

from ..core.kinematics import forward_kinematics_jacobian

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


def marker_positions_jacobian(
    kappa: ArrayLike,
    lengths: ArrayLike,
    s: ArrayLike,
    base_pose: ArrayLike,
    offsets: ArrayLike | None = None,
    *,
    with_theta: bool = False,
):
    """In-plane marker positions (T, N, 2) of a bending-only robot and their Jacobian (T, N, 2, m).

    A marker at arc length ``s_i`` sits ``offsets[i]`` off the backbone along the cross-section's
    in-plane normal ``(cos theta, sin theta)``.  With ``with_theta`` the backbone poses
    (T, N, 3) are returned too.
    """
    lengths = np.asarray(lengths, dtype=float)
    pose, jac = forward_kinematics_jacobian(bending_strains(kappa), lengths, s, base_pose=base_pose)
    jac = jac[..., 0::3]  # (T, N, 3, m)
    pos, J = pose[..., :2], jac[..., :2, :]
    if offsets is not None and np.any(np.asarray(offsets) != 0):
        d = np.asarray(offsets, dtype=float)
        c, sn = np.cos(pose[..., 2]), np.sin(pose[..., 2])
        pos = pos + d[:, None] * np.stack([c, sn], axis=-1)
        J = J + (d[:, None] * np.stack([-sn, c], axis=-1))[..., None] * jac[..., 2:3, :]
    return (pos, J, pose) if with_theta else (pos, J)


def _chord_curvatures(
    P: NDArray[np.float64], base: NDArray[np.float64], lengths: NDArray[np.float64], s: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Curvatures (T, m) to start from: segment by segment, from the chord to its last marker.

    A circular arc of length ``l`` turns its tangent by twice the angle between its start tangent and its
    chord, so each segment's curvature follows from where its last marker lies seen from the segment's
    start pose (propagated through the previous segments); exact for markers on the model, and a start
    close to the least-squares solution otherwise.  Frames missing that marker start straight there.
    """
    T = P.shape[0]
    m = lengths.size
    ends = np.cumsum(lengths)
    starts = ends - lengths
    kappa = np.zeros((T, m))
    x = np.full(T, base[0])
    y = np.full(T, base[1])
    th = np.full(T, base[2])
    for j in range(m):
        inside = np.flatnonzero((s > starts[j] + 1e-12 * ends[-1]) & (s <= ends[j] * (1 + 1e-12)))
        if inside.size:
            i = inside[-1]
            sigma = s[i] - starts[j]
            dx, dy = P[:, i, 0] - x, P[:, i, 1] - y
            # angle of the chord from the tangent (-sin th, cos th), counter-clockwise
            phi = np.arctan2(-(dx * np.cos(th) + dy * np.sin(th)), -dx * np.sin(th) + dy * np.cos(th))
            k = 2.0 * phi / sigma
            kappa[:, j] = np.where(np.isfinite(k), k, 0.0)
        u = kappa[:, j] * lengths[j]
        # segment end in its start frame: (-(1 - cos u)/kappa, sin u / kappa)
        ex = -lengths[j] * np.where(np.abs(u) > 1e-8, (1.0 - np.cos(u)) / np.where(u == 0, 1.0, u), u / 2.0)
        ey = lengths[j] * np.where(np.abs(u) > 1e-8, np.sin(u) / np.where(u == 0, 1.0, u), 1.0)
        x, y = x + np.cos(th) * ex - np.sin(th) * ey, y + np.sin(th) * ex + np.cos(th) * ey
        th = th + u
    return kappa


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
    initial_base_pose: ArrayLike | None = None,
    base_position: ArrayLike | None = None,
    offsets: str | ArrayLike | None = None,
    initial_offsets: ArrayLike | None = None,
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
    initial_base_pose : array_like, shape (3,), optional
        Where the fit of the base pose starts (default: a straight robot through the markers'
        mean positions); e.g. the base of a uniformly bending fit, since with a curvature per
        spacing the base's orientation is only weakly seen by positions.
    base_position : array_like, shape (2,), optional
        A known base position (a marker on the clamp): only the base's orientation is fitted.
    offsets : "fit" or array_like, shape (N,), optional
        Each marker's distance [m] from the backbone along its cross-section's in-plane normal
        (see :func:`fit_position_strains`): given, or ``"fit"`` (one per marker, shared by all
        frames); default 0.
    initial_offsets : array_like, shape (N,), optional
        Where the fit of the offsets starts (default 0), e.g. those of a coarser fit.

    Returns
    -------
    dict
        ``base_pose`` (3,), ``arc_lengths`` (N,), ``rms`` (position residual
        RMS [m]), ``std`` (standard errors of base pose and arc lengths, (3 + N,); a sandwich
        estimate over blocks of consecutive frames, as the residuals are correlated model error;
        0 for what was given), ``offsets`` (N,) and ``offsets_std`` (N,), ``curvatures`` (F, groups)
        of the frames used.
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
    elif initial_base_pose is not None:
        b0 = np.asarray(initial_base_pose, dtype=float).reshape(3)
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
    if base_position is not None:
        bp = np.asarray(base_position, dtype=float).reshape(-1)
        if bp.shape != (2,) or not np.all(np.isfinite(bp)):
            raise ValueError(f"base_position must be 2 finite in-plane coordinates [m]; got {base_position!r}")
        b0 = np.array([bp[0], bp[1], b0[2]])
    fit_xy = base_pose is None and base_position is None
    fit_th = base_pose is None
    fit_s = arc_lengths is None
    fit_d = isinstance(offsets, str)
    if fit_d and offsets != "fit":
        raise ValueError(f"offsets must be 'fit', None or {N} distances [m]; got {offsets!r}")
    d0 = np.zeros(N) if offsets is None or fit_d else np.asarray(offsets, dtype=float).reshape(-1)
    if fit_d and initial_offsets is not None:
        d0 = np.asarray(initial_offsets, dtype=float).reshape(-1)
    if d0.shape != (N,) or not np.all(np.isfinite(d0)):
        raise ValueError(f"offsets must be 'fit', None or {N} finite distances [m]; got {offsets!r}")
    # blocks of the global unknowns: base x, y; base angle; log gaps; offsets
    sizes = [2 * fit_xy, 1 * fit_th, N * fit_s, N * fit_d]
    cuts = np.cumsum([0] + sizes)
    n_glob = int(cuts[-1])
    scale = max(float(s0[-1]), 1e-3)
    ends = np.flatnonzero(np.diff(np.append(group, nk)))  # last marker of each curvature group
    mask = np.all(np.isfinite(P), axis=2)  # (F, N)
    W = np.repeat(mask, 2, axis=1).astype(float)
    target = np.where(mask[..., None], P, 0.0)
    # variable projection: the globals are fitted by least squares on the residual left after every
    # frame's curvatures are solved for them (a batched solve, warm-started)
    state: dict = {"q": None}

    def unpack(x):
        b, sv, d = b0.copy(), s0, d0
        if fit_xy:
            b[:2] = x[cuts[0] : cuts[1]] * scale
        if fit_th:
            b[2] = x[cuts[1]]
        if fit_s:
            sv = np.cumsum(np.exp(x[cuts[2] : cuts[3]])) * scale
        if fit_d:
            d = x[cuts[3] : cuts[4]] * scale
        return b, sv, d

    def solve(x):
        if state.get("x") is not None and np.array_equal(state["x"], x):
            return state["solved"]
        b, sv, d = unpack(x)
        lengths = np.diff(np.concatenate([[0.0], sv[ends]]))
        q, _ = fit_position_strains(P, b, lengths, sv, q0=state["q"], tol=1e-9 * scale, offsets=d)
        state["q"] = q
        kappa = q[:, 0::3]
        pos, Jk, pose = marker_positions_jacobian(kappa, lengths, sv, b, d, with_theta=True)
        state["x"], state["solved"] = np.array(x, copy=True), (b, sv, d, pos, Jk, pose)
        return state["solved"]

    def residuals(x):
        pos = solve(x)[3]
        return ((pos - target) * mask[..., None]).reshape(-1) / scale

    def jacobian(x):
        b, sv, d, p, Jk, pose = solve(x)
        backbone = pose[..., :2]
        theta = pose[..., 2]
        normal = np.stack([np.cos(theta), np.sin(theta)], axis=-1)
        cols = []
        if fit_xy:
            cols += [np.broadcast_to([1.0, 0.0], p.shape) * scale, np.broadcast_to([0.0, 1.0], p.shape) * scale]
        if fit_th:  # rotation of the whole body about the base
            rel = p - b[:2]
            cols.append(np.stack([-rel[..., 1], rel[..., 0]], axis=-1))
        if fit_s:  # lengthening gap j moves the markers beyond along the tangent at s_j, turning them by kappa
            tangent = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)
            kap = state["q"][:, 0::3][:, group]  # (F, N) curvature at each marker's spacing
            gaps = np.diff(np.concatenate([[0.0], sv]))
            for j in range(N):
                rel = p - backbone[:, j : j + 1]
                col = tangent[:, j : j + 1] + kap[:, j, None, None] * np.stack([-rel[..., 1], rel[..., 0]], axis=-1)
                cols.append(col * (np.arange(N) >= j)[None, :, None] * gaps[j])
        if fit_d:
            for j in range(N):
                cols.append(normal * (np.arange(N) == j)[None, :, None] * scale)
        Jg = np.stack(cols, axis=-1) * mask[..., None, None]  # (F, N, 2, n_glob)
        Jg = Jg.reshape(F, 2 * N, n_glob) / scale
        Jk = Jk.reshape(F, 2 * N, nk) * W[..., None] / scale
        # project out what each frame's curvatures absorb (the Schur complement of the frame blocks)
        A = np.einsum("fia,fib->fab", Jk, Jk) + 1e-12 * np.eye(nk)
        B = np.einsum("fia,fig->fag", Jk, Jg)
        Jr = Jg - np.einsum("fia,fag->fig", Jk, np.linalg.solve(A, B))
        return Jr.reshape(2 * F * N, n_glob)

    x0 = np.zeros(n_glob)
    if fit_xy:
        x0[cuts[0] : cuts[1]] = b0[:2] / scale
    if fit_th:
        x0[cuts[1]] = b0[2]
    if fit_s:
        x0[cuts[2] : cuts[3]] = np.log(np.diff(np.concatenate([[0.0], s0])) / scale)
    if fit_d:
        x0[cuts[3] : cuts[4]] = d0 / scale
    if n_glob:
        res = least_squares(
            residuals, x0, jac=jacobian, x_scale="jac", method="trf", max_nfev=100, ftol=1e-12, xtol=1e-12
        )
        x = res.x
    else:
        x = x0
    fun = residuals(x)
    b, sv, d = unpack(x)
    n_obs = int(mask.sum()) * 2
    dof = max(n_obs - n_glob - F * nk, 1)
    rms = float(np.sqrt(np.sum(fun**2) / max(n_obs, 1))) * scale
    std_glob = np.zeros(n_glob)
    if n_glob:
        J = jacobian(x)
        r = residuals(x)
        bread = np.linalg.pinv(J.T @ J)
        # sandwich covariance over blocks of consecutive frames: the residuals are model error, correlated
        # between the markers of a frame and over neighbouring frames, not independent noise
        n_blocks = int(min(F, max(2, round(np.sqrt(F)))))
        block = np.arange(F) * n_blocks // F
        score = np.einsum("fig,fi->fg", J.reshape(F, 2 * N, n_glob), r.reshape(F, 2 * N))
        per_block = np.stack([score[block == k].sum(axis=0) for k in range(n_blocks)])
        meat = per_block.T @ per_block * n_blocks / max(n_blocks - 1, 1)
        cov = bread @ meat @ bread
        cov = np.maximum(cov, bread * np.sum(r**2) / dof)  # never below the white-noise covariance
        # back to physical units: base x, y and offsets in metres; arc lengths s_i = scale sum_{j<=i} exp(x_j)
        units = np.eye(n_glob)
        units[cuts[0] : cuts[1], cuts[0] : cuts[1]] *= scale
        units[cuts[3] : cuts[4], cuts[3] : cuts[4]] *= scale
        if fit_s:
            gaps = np.diff(np.concatenate([[0.0], sv]))
            units[cuts[2] : cuts[3], cuts[2] : cuts[3]] = np.tril(np.ones((N, N))) * gaps[None, :]
        std_glob = np.sqrt(np.clip(np.diag(units @ cov @ units.T), 0.0, None))
    std = np.zeros(3 + N)
    if fit_xy:
        std[:2] = std_glob[cuts[0] : cuts[1]]
    if fit_th:
        std[2] = std_glob[cuts[1]]
    if fit_s:
        std[3:] = std_glob[cuts[2] : cuts[3]]
    offsets_std = std_glob[cuts[3] : cuts[4]] if fit_d else np.zeros(N)
    return {
        "base_pose": np.asarray(b, dtype=float),
        "arc_lengths": np.asarray(sv, dtype=float),
        "rms": rms,
        "std": std,
        "offsets": np.asarray(d, dtype=float),
        "offsets_std": offsets_std,
        "curvatures": state["q"][:, 0::3],
    }


def fit_position_strains(
    positions: ArrayLike,
    base_pose: ArrayLike,
    segment_lengths: ArrayLike,
    marker_arc_lengths: ArrayLike,
    *,
    q0: ArrayLike | None = None,
    max_iter: int = 30,
    tol: float = 1e-7,
    offsets: ArrayLike | None = None,
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
    tol : float, default 1e-7
        A frame has converged when a step moves none of its markers by more than ``tol`` [m].
    offsets : array_like, shape (N,), optional
        Distance [m] of each marker from the backbone along its cross-section's in-plane
        normal ``(cos theta, sin theta)`` (markers on the skin of a thick body); default 0.

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
    if q0 is None:
        kappa = _chord_curvatures(P, base, lengths, s)
    else:
        kappa = np.asarray(q0, dtype=float).reshape(T, m, 3)[..., 0].copy()

    d = np.zeros(N) if offsets is None else np.asarray(offsets, dtype=float).reshape(N)

    def evaluate(rows, k):
        pose, jac = marker_positions_jacobian(k, lengths, s, base, d)
        r = (pose.reshape(rows.size, 2 * N) - target[rows]) * W[rows]
        J = jac.reshape(rows.size, 2 * N, m) * W[rows][..., None]
        return r, J

    # Levenberg-Marquardt per frame; only the frames not yet converged are evaluated again
    active = np.arange(T)
    lam = np.full(T, 1e-3)
    r, J = evaluate(active, kappa)
    cost = np.sum(r**2, axis=1)
    eye = np.eye(m)
    for _ in range(max_iter):
        if active.size == 0:
            break
        JtJ = np.einsum("tia,tib->tab", J, J)
        g = np.einsum("tia,ti->ta", J, r)
        diag = np.einsum("taa->ta", JtJ)
        A = JtJ + lam[active, None, None] * diag[:, :, None] * eye + 1e-12 * eye  # unseen curvatures stay put
        step = -np.linalg.solve(A, g[..., None])[..., 0]
        J_old = J
        r_new, J_new = evaluate(active, kappa[active] + step)
        c_new = np.sum(r_new**2, axis=1)
        better = c_new <= cost
        kappa[active[better]] += step[better]
        r[better], J[better], cost[better] = r_new[better], J_new[better], c_new[better]
        lam[active] = np.clip(np.where(better, lam[active] * 0.3, lam[active] * 10.0), 1e-12, 1e12)
        # converged: the step moves no marker by more than tol (curvatures the markers hardly see converge
        # slowly and matter as little), or the damping has grown so large that nothing moves
        moved = np.max(np.abs(np.einsum("tia,ta->ti", J_old, step)), axis=1)
        done = (moved < tol) | (lam[active] >= 1e12)
        keep = ~done
        active, r, J, cost = active[keep], r[keep], J[keep], cost[keep]
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
