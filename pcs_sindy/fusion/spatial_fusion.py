"""Spatial (3-D) fusion of motion capture: marker positions (and orientations) -> spatial PCS strains.

The path :class:`~pcs_sindy.fusion.KinematicFusion` takes with ``space="3d"`` (or ``"auto"`` on a
recording that leaves its best-fit plane) for recordings made by
:meth:`pcs_sindy.core.PoseTrajectory.from_positions`: 2-5 markers along the body, positions in the
capture frame, the base untracked (or a marker on the clamp), orientations when the tracker gives
rigid bodies.  The model is the spatial PCS of :mod:`pcs_sindy.core.spatial` (strain order
``bend_z, bend_x, twist, shear_x, shear_z, axial`` per segment); a few positions resolve the two
bendings of each segment, orientations add its torsion (shear and stretch stay 0).

* :func:`base_rotation` - the fixed base frame from the rest direction and the gauge normal: positions
  do not see a rotation of the whole robot about its own rest axis (it only turns the bending
  vectors), so the base's z axis is fixed to the normal of the best-fit plane of the motion and a
  planar recording comes out with ``bend_x = 0`` and ``bend_z`` the planar curvature;
* :func:`spatial_marker_model` - marker positions (and orientations) of a spatial PCS robot with
  markers off the backbone, and their Jacobians;
* :func:`fit_spatial_strains` - every frame's strains for a given geometry (batched Levenberg-Marquardt
  from a closed-form circular-arc start, then frames left worse than their neighbours are started
  again from the previous frame's strains);
* :func:`fit_spatial_geometry` - the fixed base (position and rest direction), the markers' arc
  lengths, offsets off the backbone and rigid-body orientation offsets, jointly with the strains of
  the sampled frames (variable projection);
* :func:`spatial_marker_geometry`, :func:`fuse_spatial_segments`, :func:`choose_spatial_threshold` -
  the seed's Algorithm 1 on the spatial strains of one segment per marker spacing;
* :func:`spatial_strain_trajectories`, :func:`spatial_marker_positions` - the strain trajectories
  (carrying a :class:`~pcs_sindy.core.spatial.SpatialPCS` segmentation) and the way back to
  capture-frame positions.

Knows no images and no dynamics.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from ..core.spatial import SpatialPCS, SpatialStrainTrajectory
from ..core.trajectory import MIN_JUMP, WOBBLE_WARNING, PoseTrajectory
from .merging import merge_runs
from .threshold_selection import AUTO_THRESHOLDS, SweepRow, choice_from_sweep

__all__ = [
    "SPATIAL_BENDING",
    "SPATIAL_BENDING_TWIST",
    "DIRECTION_PRIOR",
    "needs_3d",
    "base_rotation",
    "spatial_marker_model",
    "fit_spatial_strains",
    "fit_spatial_geometry",
    "spatial_marker_geometry",
    "fuse_spatial_segments",
    "choose_spatial_threshold",
    "spatial_strain_trajectories",
    "spatial_marker_positions",
]

#: active strains per segment of a positions-only spatial fusion: the two bendings
SPATIAL_BENDING = (True, True, False, False, False, False)
#: active strains per segment when the markers' orientations are known: the bendings and torsion
SPATIAL_BENDING_TWIST = (True, True, True, False, False, False)
_DEFAULT_STD = (5e-4, float(np.deg2rad(1.0)))
#: angle [rad] of the prior on the first segment's mean bending that fixes a weakly seen rest direction
#: (:func:`fit_spatial_geometry`)
DIRECTION_PRIOR = 0.3


# ----------------------------------------------------------------------------------------- helpers
def needs_3d(trajs: Sequence[PoseTrajectory]) -> bool:
    """Whether positions-only recordings call for the spatial model (``KinematicFusion(space="auto")``).

    True when a recording carries marker orientations, or when some recording leaves its plane by
    more than ``WOBBLE_WARNING`` (0.2) of its in-plane motion RMS and by more than 1 mm - the
    criterion of the warning of :meth:`~pcs_sindy.core.PoseTrajectory.from_positions` (a planar model
    would miss that part of the motion).
    """
    for tr in trajs:
        if getattr(tr, "rotations", None) is not None:
            return True
        oop = float(tr.metadata.get("out_of_plane_rms", 0.0))
        motion = float(tr.metadata.get("motion_rms", 0.0))
        if oop > WOBBLE_WARNING * motion and oop > MIN_JUMP:
            return True
    return False


def base_rotation(direction: ArrayLike, normal: ArrayLike) -> NDArray[np.float64]:
    """The base frame (3, 3) whose y axis is ``direction`` (the rest tangent) and whose z axis is ``normal``
    made perpendicular to it (the gauge: for a planar recording the plane's normal, so the planar
    bending is ``bend_z``); x = y x z."""
    y = np.asarray(direction, dtype=float)
    y = y / np.linalg.norm(y)
    n = np.asarray(normal, dtype=float)
    z = n - (n @ y) * y
    if np.linalg.norm(z) < 1e-9 * max(np.linalg.norm(n), 1e-300):
        # the normal along the rest direction: any perpendicular (the gauge is then arbitrary)
        z = np.cross(y, np.eye(3)[int(np.argmin(np.abs(y)))])
    z = z / np.linalg.norm(z)
    return np.stack([np.cross(y, z), y, z], axis=1)


def _rotvec(R: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation vectors (..., 3) of rotation matrices (..., 3, 3)."""
    shape = R.shape[:-2]
    flat = R.reshape(-1, 3, 3)
    out = np.zeros((flat.shape[0], 3))
    if flat.shape[0]:
        out = Rotation.from_matrix(flat).as_rotvec()
    return out.reshape(shape + (3,))


def _exp_rot(w: NDArray[np.float64]) -> NDArray[np.float64]:
    w = np.asarray(w, dtype=float)
    return Rotation.from_rotvec(w.reshape(-1, 3)).as_matrix().reshape(w.shape[:-1] + (3, 3))


def _chordal_mean(R: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rotation nearest (Frobenius) the mean of rotations (K, 3, 3)."""
    u, _, vt = np.linalg.svd(np.mean(R, axis=0))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    return u @ D @ vt


def _as_offsets(offsets: ArrayLike | None, n: int) -> NDArray[np.float64]:
    """Marker offsets (n, 2) along body x and body z: None -> 0, (n,) -> along x only, (n, 2) as given."""
    if offsets is None:
        return np.zeros((n, 2))
    d = np.asarray(offsets, dtype=float)
    if d.shape == (n,):
        d = np.stack([d, np.zeros(n)], axis=1)
    if d.shape != (n, 2) or not np.all(np.isfinite(d)):
        raise ValueError(
            f"offsets must be {n} distances [m] along the body x axis or ({n}, 2) along body x and z; got {offsets!r}"
        )
    return d


def _lengths(arc_lengths: NDArray[np.float64], boundaries: ArrayLike) -> NDArray[np.float64]:
    """Segment lengths of segments ending on the markers ``boundaries`` (1-based, base = 0)."""
    s = np.concatenate([[0.0], arc_lengths])
    return np.diff(s[np.concatenate([[0], np.asarray(boundaries, dtype=int)])])


# ----------------------------------------------------------------------------------------- the model
def _backbone(
    q: NDArray[np.float64],
    lengths: NDArray[np.float64],
    s: NDArray[np.float64],
    columns: NDArray[np.intp] | None = None,
) -> tuple[NDArray[np.float64], ...]:
    """Backbone positions (T, K, 3) and rotations (T, K, 3, 3) at arc lengths ``s``, the base at the origin,
    and with ``columns`` the position and body angular Jacobians (T, K, 3, len(columns)) of those strains."""
    kin = SpatialPCS(tuple(float(v) for v in lengths))
    p, R = kin.forward_kinematics(q, s)
    if columns is None:
        return p, R
    # one velocity per fitted strain: a fusion fits 2-3 of the 6 strains per segment, so this is a
    # fraction of the full Jacobian's cost
    Jp = np.empty(p.shape + (columns.size,))
    Jw = np.empty(p.shape + (columns.size,))
    unit = np.zeros_like(q)
    for k, c in enumerate(columns):
        unit[:] = 0.0
        unit[..., c] = 1.0
        Jp[..., k], Jw[..., k] = kin.velocities(q, unit, s)
    return p, R, Jp, Jw


def spatial_marker_model(
    q: ArrayLike,
    segment_lengths: ArrayLike,
    marker_arc_lengths: ArrayLike,
    base_rotation: ArrayLike,
    base_position: ArrayLike,
    offsets: ArrayLike | None = None,
    rotation_offsets: ArrayLike | None = None,
    *,
    jacobian: bool = False,
    columns: ArrayLike | None = None,
) -> dict[str, NDArray[np.float64]]:
    """Markers of a spatial PCS robot in the capture frame.

    A marker at arc length ``s_k`` sits at ``p(s_k) + R(s_k) (d_x, 0, d_z)`` (``offsets[k]``: off the
    backbone in its cross-section) and, for a rigid body, is oriented ``R(s_k) C_k``
    (``rotation_offsets[k]``: the rigid body's frame in the cross-section's), where ``(R, p)`` is the
    cross-section's pose: the base pose composed with the body's (:class:`~pcs_sindy.core.spatial.SpatialPCS`).

    Parameters
    ----------
    q : array_like, shape (T, 6m)
    segment_lengths : array_like, shape (m,)
    marker_arc_lengths : array_like, shape (N,)
    base_rotation : array_like, shape (3, 3)
    base_position : array_like, shape (3,)
    offsets : array_like, shape (N,) or (N, 2), optional
    rotation_offsets : array_like, shape (N, 3, 3), optional
    jacobian : bool, default False
    columns : array_like of int, optional
        With ``jacobian``: the strains (indices into ``q``'s last axis) to differentiate by (default all).

    Returns
    -------
    dict
        ``positions`` (T, N, 3), ``rotations`` (T, N, 3, 3) (the markers' frames), ``backbone`` (T, N, 3)
        and, with ``jacobian``, ``J_positions`` (T, N, 3, n) and ``J_rotations`` (T, N, 3, n), the
        latter the angular velocity in the marker's frame per strain rate (n = ``len(columns)``, default 6m).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    lengths = np.asarray(segment_lengths, dtype=float)
    s = np.asarray(marker_arc_lengths, dtype=float)
    Rb = np.asarray(base_rotation, dtype=float)
    pb = np.asarray(base_position, dtype=float)
    d = _as_offsets(offsets, s.size)
    d3 = np.stack([d[:, 0], np.zeros(s.size), d[:, 1]], axis=1)  # (N, 3) in the cross-section's frame
    cols = None
    if jacobian:
        cols = np.arange(q.shape[-1]) if columns is None else np.asarray(columns, dtype=int).reshape(-1)
    out = _backbone(q, lengths, s, cols)
    p_loc, R_loc = out[0], out[1]
    R = Rb @ R_loc
    backbone = pb + p_loc @ Rb.T
    pos = backbone + np.einsum("tkij,kj->tki", R, d3)
    C = None if rotation_offsets is None else np.asarray(rotation_offsets, dtype=float)
    res = {"positions": pos, "rotations": R if C is None else R @ C, "backbone": backbone}
    if jacobian:
        Jp, Jw = out[2], out[3]
        # d(R d)/dq = R (J_w dq) x d = -R [d]x J_w dq
        cross = np.cross(d3[None, :, :, None], Jw, axisa=2, axisb=2, axisc=2)  # (T, N, 3, n): d x J_w
        res["J_positions"] = np.einsum("ij,tkjn->tkin", Rb, Jp) - np.einsum("tkij,tkjn->tkin", R, cross)
        res["J_rotations"] = Jw if C is None else np.einsum("kji,tkjn->tkin", C, Jw)
    return res


# ----------------------------------------------------------------------------------------- strains
def _chord_strains(
    P: NDArray[np.float64],
    Rb: NDArray[np.float64],
    pb: NDArray[np.float64],
    lengths: NDArray[np.float64],
    s: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Strains (T, 6m) to start from: segment by segment, the circular arc from the segment's start pose
    through its last marker (exact for markers on the backbone of a torsion-free model); a missing
    marker leaves its segment straight."""
    T = P.shape[0]
    m = lengths.size
    ends = np.cumsum(lengths)
    starts = ends - lengths
    q = np.zeros((T, 6 * m))
    R = np.broadcast_to(Rb, (T, 3, 3)).copy()
    p = np.broadcast_to(pb, (T, 3)).copy()
    for j in range(m):
        inside = np.flatnonzero((s > starts[j] + 1e-12 * ends[-1]) & (s <= ends[j] * (1 + 1e-12)))
        if inside.size:
            i = inside[-1]
            sigma = s[i] - starts[j]
            c = np.einsum("tji,tj->ti", R, P[:, i] - p)  # the chord in the segment's start frame
            lateral = np.hypot(c[:, 0], c[:, 2])
            phi = np.arctan2(lateral, c[:, 1])  # angle between the tangent (body y) and the chord
            kappa = 2.0 * phi / sigma
            with np.errstate(invalid="ignore", divide="ignore"):
                ax, az = c[:, 2] / lateral, -c[:, 0] / lateral  # the bending axis y x c / |y x c|
            ok = np.isfinite(kappa) & np.isfinite(ax) & np.isfinite(az) & (lateral > 0)
            q[:, 6 * j + 1] = np.where(ok, kappa * np.where(ok, ax, 0.0), 0.0)  # bend_x = kappa_x
            q[:, 6 * j + 0] = np.where(ok, kappa * np.where(ok, az, 0.0), 0.0)  # bend_z = kappa_z
        seg = np.zeros((T, 6))
        seg[:] = q[:, 6 * j : 6 * j + 6]
        pe, Re = _backbone(seg, lengths[j : j + 1], lengths[j : j + 1])
        p = p + np.einsum("tij,tj->ti", R, pe[:, 0])
        R = R @ Re[:, 0]
    return q


def _check_positions(positions: ArrayLike, name: str = "positions") -> NDArray[np.float64]:
    P = np.asarray(positions, dtype=float)
    if P.ndim != 3 or P.shape[2] != 3:
        raise ValueError(f"{name} must have shape (T, N, 3) (3-D marker positions); got {P.shape}")
    return P


def fit_spatial_strains(
    positions: ArrayLike,
    base_rotation: ArrayLike,
    base_position: ArrayLike,
    segment_lengths: ArrayLike,
    marker_arc_lengths: ArrayLike,
    *,
    active: ArrayLike | None = None,
    rotations: ArrayLike | None = None,
    offsets: ArrayLike | None = None,
    rotation_offsets: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    pose_std: Sequence[float] = _DEFAULT_STD,
    max_iter: int = 40,
    tol: float = 1e-7,
    warm_start: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Spatial strains of every frame from 3-D marker positions (and orientations).

    Each frame's active strains minimise the squared marker position errors over ``pose_std[0]``
    plus, with ``rotations``, the squared rotation errors (angles of ``R_measured^T R_model``) over
    ``pose_std[1]``.  All frames are solved at once (Levenberg-Marquardt, batched); the start is
    ``q0`` or the circular arc of each segment through its last marker; then, with ``warm_start``,
    frames whose residual is well above the typical one are solved again from the straight robot and
    from the previous and the next frame's strains (a few passes, each carrying good solutions one
    frame on), keeping the best.

    Parameters
    ----------
    positions : array_like, shape (T, N, 3)
        Marker positions [m] in the capture frame, NaN for missing samples.
    base_rotation, base_position : array_like, shapes (3, 3) and (3,)
        The fixed base pose in the capture frame.
    segment_lengths : array_like, shape (m,)
    marker_arc_lengths : array_like, shape (N,)
        Rest arc lengths of the markers [m] (the base excluded).
    active : array_like of bool, shape (m, 6) or (6,), optional
        Strains fitted (default :data:`SPATIAL_BENDING`); the others stay 0 (or at ``q0``).
    rotations : array_like, shape (T, N, 3, 3), optional
        Measured marker orientations (NaN = missing).
    offsets, rotation_offsets
        See :func:`spatial_marker_model`.
    q0 : array_like, shape (T, 6m), optional
    pose_std : (float, float), default (5e-4, 1 deg)
        Position [m] and angle [rad] noise levels weighting the residuals.
    max_iter : int, default 40
    tol : float, default 1e-7
        A frame has converged when a step moves no marker by more than ``tol`` [m].
    warm_start : bool, default True

    Returns
    -------
    q : ndarray, shape (T, 6m)
    estimated : ndarray of bool, shape (T,)
        False where some strain was not seen by the frame's valid markers and was interpolated in time.
    """
    P = _check_positions(positions)
    Rb = np.asarray(base_rotation, dtype=float)
    pb = np.asarray(base_position, dtype=float)
    lengths = np.asarray(segment_lengths, dtype=float)
    s = np.asarray(marker_arc_lengths, dtype=float)
    T, N, _ = P.shape
    m = lengths.size
    if s.shape != (N,):
        raise ValueError(f"marker_arc_lengths must hold {N} arc lengths (one per marker); got {s.shape}")
    act = np.broadcast_to(np.asarray(SPATIAL_BENDING if active is None else active, dtype=bool), (m, 6))
    cols = np.flatnonzero(act.reshape(-1))
    na = cols.size
    sp, sa = (float(v) for v in pose_std)
    mask = np.all(np.isfinite(P), axis=2)
    target = np.where(mask[..., None], P, 0.0)
    Rm = None
    if rotations is not None:
        Rm = np.asarray(rotations, dtype=float)
        if Rm.shape != (T, N, 3, 3):
            raise ValueError(f"rotations must have shape ({T}, {N}, 3, 3); got {Rm.shape}")
        rmask = np.all(np.isfinite(Rm), axis=(2, 3)) & mask
        Rm = np.where(rmask[..., None, None], Rm, np.eye(3))
    d = _as_offsets(offsets, N)
    C = None if rotation_offsets is None else np.asarray(rotation_offsets, dtype=float)
    if q0 is None:
        q = _chord_strains(P, Rb, pb, lengths, s)
        q[:, ~act.reshape(-1)] = 0.0
    else:
        q = np.array(q0, dtype=float).reshape(T, 6 * m)

    def evaluate(rows: NDArray[np.intp], qa: NDArray[np.float64]):
        full = q[rows].copy()
        full[:, cols] = qa
        mod = spatial_marker_model(full, lengths, s, Rb, pb, d, C, jacobian=True, columns=cols)
        w = mask[rows][..., None]
        r = [((mod["positions"] - target[rows]) * w / sp).reshape(rows.size, -1)]
        J = [(mod["J_positions"] * w[..., None] / sp).reshape(rows.size, -1, na)]
        if Rm is not None:
            wr = rmask[rows][..., None]
            err = _rotvec(np.swapaxes(Rm[rows], -1, -2) @ mod["rotations"])
            r.append((err * wr / sa).reshape(rows.size, -1))
            J.append((mod["J_rotations"] * wr[..., None] / sa).reshape(rows.size, -1, na))
        return np.concatenate(r, axis=1), np.concatenate(J, axis=1)

    # each segment turns by at most one full turn (bending) and half a turn (torsion): beyond, a few markers
    # cannot tell a strain from a wrapped one, and a marker glitch would pull the segment round and round
    where = {c: k for k, c in enumerate(cols)}
    limits = []
    for j in range(m):
        iz, ix, it = where.get(6 * j), where.get(6 * j + 1), where.get(6 * j + 2)
        limits.append((iz, ix, it, 2.0 * np.pi / lengths[j]))

    def bound(qa: NDArray[np.float64]) -> NDArray[np.float64]:
        for iz, ix, it, lim in limits:
            if iz is not None and ix is not None:
                mag = np.hypot(qa[:, iz], qa[:, ix])
                f = np.where(mag > lim, lim / np.where(mag > 0, mag, 1.0), 1.0)
                qa[:, iz] *= f
                qa[:, ix] *= f
            else:
                for i in (iz, ix):
                    if i is not None:
                        qa[:, i] = np.clip(qa[:, i], -lim, lim)
            if it is not None:
                qa[:, it] = np.clip(qa[:, it], -0.5 * lim, 0.5 * lim)
        return qa

    def solve(rows: NDArray[np.intp], qa: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Batched Levenberg-Marquardt of the frames ``rows`` from ``qa``; returns their strains and costs."""
        qa = bound(qa.copy())
        active_rows = np.arange(rows.size)
        lam = np.full(rows.size, 1e-3)
        r, J = evaluate(rows, qa)
        cost = np.sum(r**2, axis=1)
        final = cost.copy()
        eye = np.eye(na)
        for _ in range(max_iter):
            if active_rows.size == 0:
                break
            JtJ = np.einsum("tia,tib->tab", J, J)
            g = np.einsum("tia,ti->ta", J, r)
            diag = np.einsum("taa->ta", JtJ)
            A = JtJ + lam[active_rows, None, None] * diag[:, :, None] * eye + 1e-12 * eye
            step = -np.linalg.solve(A, g[..., None])[..., 0]
            step = bound(qa[active_rows] + step) - qa[active_rows]
            J_old = J
            r_new, J_new = evaluate(rows[active_rows], qa[active_rows] + step)
            c_new = np.sum(r_new**2, axis=1)
            better = c_new <= cost
            idx = active_rows[better]
            qa[idx] += step[better]
            final[idx] = c_new[better]
            r[better], J[better], cost[better] = r_new[better], J_new[better], c_new[better]
            lam[active_rows] = np.clip(np.where(better, lam[active_rows] * 0.3, lam[active_rows] * 10.0), 1e-12, 1e12)
            moved = np.max(np.abs(np.einsum("tia,ta->ti", J_old, step)), axis=1) * sp  # [m] (or sp-scaled rad)
            done = (moved < tol) | (lam[active_rows] >= 1e12)
            keep = ~done
            active_rows, r, J, cost = active_rows[keep], r[keep], J[keep], cost[keep]
        return qa, final

    rows = np.arange(T)
    qa, cost = solve(rows, q[:, cols])
    q[:, cols] = qa
    if warm_start and T > 1:
        # frames left far above the typical residual (a start in the wrong basin) try their neighbours'
        # strains, the previous frame's and the next one's in turn; each pass carries a good solution one
        # frame along a run of bad frames
        typical = float(np.median(cost))
        bad = np.flatnonzero(cost > 4.0 * typical + 1.0)
        if bad.size:  # and the straight robot: a start the circular arcs miss when markers sit far off the backbone
            qb, cb = solve(bad, np.zeros((bad.size, na)))
            better = cb < cost[bad]
            q[bad[better][:, None], cols[None, :]] = qb[better]
            cost[bad[better]] = cb[better]
        changed = np.ones(T, dtype=bool)
        quiet = 0
        for k in range(12):
            step_back = 1 if k % 2 == 0 else -1
            t_all = np.arange(T)
            nb = t_all - step_back
            ok = (nb >= 0) & (nb < T)
            # a frame far worse than its neighbour (not a stretch the model fits badly throughout), whose
            # neighbour has a solution it has not tried yet
            cand = t_all[ok][(cost[ok] > 4.0 * cost[nb[ok]] + 1.0) & changed[nb[ok]]]
            improved = np.zeros(T, dtype=bool)
            if cand.size:
                qb, cb = solve(cand, q[cand - step_back][:, cols])
                better = cb < cost[cand]
                q[cand[better][:, None], cols[None, :]] = qb[better]
                cost[cand[better]] = cb[better]
                improved[cand[better]] = True
            quiet = 0 if improved.any() else quiet + 1
            if quiet >= 2:
                break
            changed = improved | (k == 0)
    # a segment's strains are seen by the valid markers beyond its start; frames that do not see them
    # (or have fewer valid coordinates than strains) get them interpolated in time
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    beyond = s[None, :] > starts[:, None] + 1e-12  # (m, N)
    seen = (mask.astype(int) @ beyond.T.astype(int)) > 0  # (T, m)
    seen &= (mask.sum(axis=1) * 3 >= na)[:, None]
    estimated = seen.all(axis=1)
    t = np.arange(T)
    for j in range(m):
        if not seen[:, j].any():
            raise ValueError(f"no frame has a valid marker beyond the start of segment {j}; cannot estimate it")
        if not seen[:, j].all():
            for c in range(6 * j, 6 * j + 6):
                q[~seen[:, j], c] = np.interp(t[~seen[:, j]], t[seen[:, j]], q[seen[:, j], c])
    return q, estimated


# ----------------------------------------------------------------------------------------- geometry
def _frames(
    positions: Sequence[NDArray[np.float64]],
    rotations: Sequence[NDArray[np.float64] | None] | None,
    max_frames: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """At most ``max_frames`` frames with a valid marker, evenly over all recordings (and their rotations)."""
    P = np.concatenate(positions, axis=0)
    Rm = None
    if rotations is not None and any(r is not None for r in rotations):
        Rm = np.concatenate(
            [np.full(p.shape + (3,), np.nan) if r is None else r for p, r in zip(positions, rotations)], axis=0
        )
    good = np.any(np.all(np.isfinite(P), axis=2), axis=1)
    P = P[good]
    Rm = None if Rm is None else Rm[good]
    if P.shape[0] > max_frames:
        pick = np.linspace(0, P.shape[0] - 1, int(max_frames)).round().astype(int)
        P = P[pick]
        Rm = None if Rm is None else Rm[pick]
    return P, Rm


def _groups(curvatures: str | ArrayLike, N: int) -> NDArray[np.intp]:
    if isinstance(curvatures, str):
        if curvatures not in ("uniform", "per_segment"):
            raise ValueError(f"curvatures must be 'uniform', 'per_segment' or indices; got {curvatures!r}")
        return np.zeros(N, dtype=int) if curvatures == "uniform" else np.arange(N)
    group = np.asarray(curvatures)
    if group.shape != (N,) or group[0] != 0 or not np.all(np.isin(np.diff(group), (0, 1))):
        raise ValueError(f"curvatures must be {N} non-decreasing indices from 0 in steps of 0 or 1; got {curvatures!r}")
    return group.astype(int)


def _perpendiculars(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    e1 = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def fit_spatial_geometry(
    positions: Sequence[ArrayLike],
    arc_lengths: ArrayLike | None = None,
    *,
    normal: ArrayLike,
    rotations: Sequence[ArrayLike | None] | None = None,
    max_frames: int = 300,
    curvatures: str | ArrayLike = "uniform",
    base_position: ArrayLike | None = None,
    base_direction: ArrayLike | None = None,
    initial_base: tuple[ArrayLike, ArrayLike] | None = None,
    offsets: str | ArrayLike | None = None,
    initial_offsets: ArrayLike | None = None,
    initial_rotation_offsets: ArrayLike | None = None,
    pose_std: Sequence[float] = _DEFAULT_STD,
    direction_prior: float | None = DIRECTION_PRIOR,
) -> dict[str, Any]:
    """Fixed base, rest arc lengths and marker offsets of 3-D markers, with the strains of sampled frames.

    Model: a robot bending in 3-D (two bendings per segment, torsion too when ``rotations`` are given)
    whose segments end on the markers of each curvature group (``"uniform"``: one segment, ``"per_segment"``:
    one per marker spacing).  Unknowns: the base position (unless ``base_position``), its rest direction
    (2 angles, unless ``base_direction``; the rotation about it is the gauge fixed by ``normal``, see
    :func:`base_rotation`), the arc lengths (unless given), the offsets (``"fit"``: two per marker, along
    body x and z), the rigid bodies' orientation offsets (with ``rotations``: three per marker), and every
    sampled frame's strains, all at once (Levenberg-Marquardt as in bundle adjustment: the frames' strain
    blocks are eliminated by their Schur complement; the strains start from :func:`fit_spatial_strains`).

    Parameters
    ----------
    positions : sequence of array_like, each (T_k, N, 3)
        Marker positions [m] in the capture frame, NaN for missing.
    arc_lengths : array_like, shape (N,), optional
        Known rest arc lengths of the markers [m].
    normal : array_like, shape (3,)
        The gauge: the base's z axis is this direction made perpendicular to the rest direction.
    rotations : sequence of array_like (T_k, N, 3, 3) or None, optional
        Measured marker orientations.
    max_frames : int, default 300
    curvatures : {"uniform", "per_segment"} or array_like of int, default "uniform"
        Curvature group of each of the N marker spacings (as :func:`pcs_sindy.fusion.fit_marker_geometry`).
    base_position : array_like, shape (3,), optional
        A known base position (a marker on the clamp).
    base_direction : array_like, shape (3,), optional
        A known rest direction of the body at the base (e.g. straight down for a hanging robot).
    initial_base : (rotation (3, 3), position (3,)), optional
        Where the base starts (default: a straight robot through the markers' mean positions).
    offsets : "fit" or array_like, shape (N,) or (N, 2), optional
        Markers off the backbone (see :func:`spatial_marker_model`); default 0.
    initial_offsets : array_like, shape (N, 2), optional
    initial_rotation_offsets : array_like, shape (N, 3, 3), optional
    pose_std : (float, float)
        Position [m] and angle [rad] weights.
    direction_prior : float or None, default :data:`DIRECTION_PRIOR` (0.3 rad)
        Positions hardly see the rest direction: tilting the base trades against a mean bending of
        the first segment, and real recordings move the fit by tens of degrees for a fraction of a
        millimetre (the Trunk's 3-D recording: 1.60 against 1.63 mm RMS between a base tilted 25
        degrees and one straight down).  A prior then fixes it: every frame adds
        ``|L_1 bend_1 / direction_prior|^2`` to the cost (in units of ``pose_std``), which over the frames
        is ``F`` times the squared mean bending angle of the first segment (the part the tilt changes)
        plus its spread; so the base tangent is the body's mean tangent there unless the data say
        otherwise (each frame's strains move by a fraction of a percent).  With orientations the same
        prior on every segment's torsion angle separates a constant torsion from the rigid bodies'
        orientation offsets.  None: no prior.

    Returns
    -------
    dict
        ``base_rotation`` (3, 3), ``base_position`` (3,), ``arc_lengths`` (N,), ``offsets`` (N, 2),
        ``rotation_offsets`` (N, 3, 3) or None, ``rms`` (position residual RMS per marker [m]),
        ``rotation_rms`` [rad] or None, ``std`` (standard errors of the base position (3), the rest
        direction's two angles [rad] and the arc lengths (N); a sandwich estimate over blocks of
        frames; 0 for what was given), ``offsets_std`` (N, 2), ``strains`` (F, 6m) of the frames used,
        ``segment_lengths``.
    """
    recs = [_check_positions(p, "positions[k]") for p in positions]
    if isinstance(offsets, str) and offsets == "fit" and initial_offsets is None and initial_base is None:
        # offsets and the base's pose trade against each other far from the solution: start the offsets
        # from the base of markers on the backbone
        first = fit_spatial_geometry(
            recs,
            arc_lengths,
            normal=normal,
            rotations=rotations,
            max_frames=max_frames,
            curvatures=curvatures,
            base_position=base_position,
            base_direction=base_direction,
            pose_std=pose_std,
            direction_prior=direction_prior,
        )
        initial_base = (first["base_rotation"], first["base_position"])
        initial_rotation_offsets = first["rotation_offsets"]
    rots = None
    if rotations is not None:
        rots = [None if r is None else np.asarray(r, dtype=float) for r in rotations]
    P, Rm = _frames(recs, rots, max_frames)
    if P.shape[0] < 3:
        raise ValueError(f"positions: need at least 3 frames with a valid marker; got {P.shape[0]}")
    F, N, _ = P.shape
    sp, sa = (float(v) for v in pose_std)
    group = _groups(curvatures, N)
    nk = int(group[-1]) + 1
    ends = np.flatnonzero(np.diff(np.append(group, nk))) + 1  # the marker (1-based) ending each segment
    twist = Rm is not None
    active = np.tile(np.array(SPATIAL_BENDING_TWIST if twist else SPATIAL_BENDING), (nk, 1))
    n_hat = np.asarray(normal, dtype=float)
    mean = np.nanmean(P, axis=0)  # (N, 3)
    # the start: a straight robot through the markers' mean positions
    if base_direction is not None:
        a0 = np.asarray(base_direction, dtype=float).reshape(3)
        if not np.all(np.isfinite(a0)) or np.linalg.norm(a0) == 0:
            raise ValueError(f"base_direction must be a non-zero 3-vector; got {base_direction!r}")
        a0 = a0 / np.linalg.norm(a0)
        pb0 = None if initial_base is None else np.asarray(initial_base[1], dtype=float)
    elif initial_base is not None:
        R0 = np.asarray(initial_base[0], dtype=float)
        a0 = R0[:, 1].copy()
        pb0 = np.asarray(initial_base[1], dtype=float)
    else:
        if base_position is not None:
            a0 = mean[-1] - np.asarray(base_position, dtype=float)
        elif N > 1:
            a0 = mean[-1] - mean[0]
        else:
            a0 = -n_hat if abs(n_hat[1]) < 0.9 else np.array([0.0, -1.0, 0.0])
        a0 = a0 / np.linalg.norm(a0)
        pb0 = None
    if arc_lengths is None:
        gaps = np.nanmedian(np.linalg.norm(np.diff(P, axis=1), axis=2), axis=0) if N > 1 else np.zeros(0)
        if base_position is not None:
            first = float(np.linalg.norm(mean[0] - np.asarray(base_position, dtype=float)))
        else:
            first = float(gaps.mean()) if gaps.size else 0.05
        s0 = np.cumsum(np.concatenate([[first], gaps]))
    else:
        s0 = np.asarray(arc_lengths, dtype=float).reshape(-1)
        if s0.shape != (N,):
            raise ValueError(f"arc_lengths must hold {N} arc lengths; got {np.shape(arc_lengths)}")
    if base_position is not None:
        pb0 = np.asarray(base_position, dtype=float).reshape(3)
    elif pb0 is None:
        pb0 = mean[0] - s0[0] * a0
    e1, e2 = _perpendiculars(a0)
    fit_p = base_position is None
    fit_a = base_direction is None
    fit_s = arc_lengths is None
    fit_d = isinstance(offsets, str)
    if fit_d and offsets != "fit":
        raise ValueError(f"offsets must be 'fit', None or {N} distances [m]; got {offsets!r}")
    d0 = _as_offsets(None if fit_d else offsets, N)
    if fit_d and initial_offsets is not None:
        d0 = _as_offsets(initial_offsets, N)
    scale = max(float(s0[-1]), 1e-3)
    sizes = [3 * fit_p, 2 * fit_a, N * fit_s, 2 * N * fit_d, 3 * N * twist]
    cuts = np.cumsum([0] + sizes)
    n_glob = int(cuts[-1])
    C0 = None
    if twist:
        C0 = (
            np.tile(np.eye(3), (N, 1, 1))
            if initial_rotation_offsets is None
            else np.asarray(initial_rotation_offsets, dtype=float)
        )
    mask = np.all(np.isfinite(P), axis=2)
    rmask = None if Rm is None else np.all(np.isfinite(Rm), axis=(2, 3)) & mask
    target = np.where(mask[..., None], P, 0.0)
    Rt = None if Rm is None else np.where(rmask[..., None, None], Rm, np.eye(3))

    def unpack(x: NDArray[np.float64]):
        pb = pb0 + x[cuts[0] : cuts[1]] * scale if fit_p else pb0
        u = x[cuts[1] : cuts[2]] if fit_a else np.zeros(2)
        a = a0 + u[0] * e1 + u[1] * e2
        Rb = base_rotation(a, n_hat)
        sv = np.cumsum(np.exp(x[cuts[2] : cuts[3]])) * scale if fit_s else s0
        d = x[cuts[3] : cuts[4]].reshape(N, 2) * scale if fit_d else d0
        C = None if not twist else C0 @ _exp_rot(x[cuts[4] : cuts[5]].reshape(N, 3))
        return pb, Rb, sv, d, C

    cols = np.flatnonzero(active.reshape(-1))
    na = cols.size
    use_prior = fit_a and direction_prior is not None
    ridge_0 = ridge = 1.0 / float(direction_prior) if use_prior else 0.0
    twist_ridge_0 = twist_ridge = 0.0 if direction_prior is None else 1.0 / float(direction_prior)
    state = {"scale": sp}  # the residual level the priors are weighed against
    n_prior = (2 if use_prior else 0) + (nk if twist and direction_prior is not None else 0)

    def model_residual(qa: NDArray[np.float64], x: NDArray[np.float64], jacobian: bool = False):
        """Residuals (F, n_res) of every frame (data, then the prior's two rows) and, with ``jacobian``,
        their Jacobian (F, n_res, n_active) in the frame's own active strains."""
        pb, Rb, sv, d, C = unpack(x)
        lengths = _lengths(sv, ends)
        q = np.zeros((F, 6 * nk))
        q[:, cols] = qa
        mod = spatial_marker_model(q, lengths, sv, Rb, pb, d, C, jacobian=jacobian, columns=cols)
        r = [((mod["positions"] - target) * mask[..., None] / sp).reshape(F, -1)]
        J = [(mod["J_positions"] * mask[..., None, None] / sp).reshape(F, -1, na)] if jacobian else []
        if twist:
            err = _rotvec(np.swapaxes(Rt, -1, -2) @ mod["rotations"])
            r.append((err * rmask[..., None] / sa).reshape(F, -1))
            if jacobian:
                J.append((mod["J_rotations"] * rmask[..., None, None] / sa).reshape(F, -1, na))
        if use_prior:
            # the first segment's bending angle over the prior's angle, in every frame: over the frames its
            # sum of squares is F times the squared mean plus the spread, which the tilt leaves alone
            r.append(ridge * lengths[0] * qa[:, :2])
            if jacobian:
                Jr = np.zeros((F, 2, na))
                Jr[:, 0, 0] = Jr[:, 1, 1] = ridge * lengths[0]
                J.append(Jr)
        if twist and direction_prior is not None:
            # a constant torsion trades against the rigid bodies' orientation offsets: the same prior on every
            # segment's torsion angle lets the offsets take what does not change
            r.append(twist_ridge * lengths[None, :] * qa[:, 2::3])
            if jacobian:
                Jt = np.zeros((F, nk, na))
                Jt[:, np.arange(nk), 3 * np.arange(nk) + 2] = twist_ridge * lengths
                J.append(Jt)
        res = np.concatenate(r, axis=1)
        return (res, np.concatenate(J, axis=1)) if jacobian else res

    def global_jacobian(qa: NDArray[np.float64], x: NDArray[np.float64], r0: NDArray[np.float64]):
        """Forward differences in the globals at fixed strains (F, n_res, n_glob): a few model evaluations."""
        Jg = np.empty(r0.shape + (n_glob,))
        for k in range(n_glob):
            h = 1e-7 * max(1.0, abs(x[k]))
            xk = x.copy()
            xk[k] += h
            Jg[..., k] = (model_residual(qa, xk) - r0) / h
        return Jg

    def bounded(qa: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
        # the limits of fit_spatial_strains: a full turn of bending and half a turn of torsion per segment
        lengths = _lengths(unpack(x)[2], ends)
        per = 3 if twist else 2
        out = qa.reshape(F, nk, per).copy()
        lim = 2.0 * np.pi / lengths
        mag = np.hypot(out[..., 0], out[..., 1])
        out[..., :2] *= np.where(mag > lim, lim / np.where(mag > 0, mag, 1.0), 1.0)[..., None]
        if twist:
            out[..., 2] = np.clip(out[..., 2], -0.5 * lim, 0.5 * lim)
        return out.reshape(F, na)

    x = np.zeros(n_glob)
    if fit_s:
        x[cuts[2] : cuts[3]] = np.log(np.maximum(np.diff(np.concatenate([[0.0], s0])), 1e-4 * scale) / scale)
    if fit_d:
        x[cuts[3] : cuts[4]] = d0.reshape(-1) / scale

    def frame_strains(x: NDArray[np.float64], C: NDArray[np.float64] | None) -> NDArray[np.float64]:
        pb, Rb, sv, d, _ = unpack(x)
        q, _ = fit_spatial_strains(
            P,
            Rb,
            pb,
            _lengths(sv, ends),
            sv,
            active=active if C is not None else active & np.array(SPATIAL_BENDING),  # torsion needs orientations
            rotations=Rt if C is not None else None,
            offsets=d,
            rotation_offsets=C,
            pose_std=pose_std,
        )
        return q[:, cols]

    if twist and initial_rotation_offsets is None:
        # the rigid bodies' frames in the cross-sections': the mean over frames at the starting geometry
        pb, Rb, sv, d, _ = unpack(x)
        q = np.zeros((F, 6 * nk))
        q[:, cols] = frame_strains(x, None)
        R_model = spatial_marker_model(q, _lengths(sv, ends), sv, Rb, pb, d)["rotations"]
        rel = np.swapaxes(R_model, -1, -2) @ Rt
        C0 = np.stack([_chordal_mean(rel[rmask[:, k], k]) if rmask[:, k].any() else np.eye(3) for k in range(N)])
    qa = frame_strains(x, unpack(x)[4])
    eye_q, eye_g = np.eye(na), np.eye(n_glob)

    def bundle(x: NDArray[np.float64], qa: NDArray[np.float64]):
        """Levenberg-Marquardt on the globals and every frame's strains together (bundle adjustment): the
        normal equations are block-diagonal in the frames, so the globals' step solves their Schur complement."""
        r, Jq = model_residual(qa, x, jacobian=True)
        cost = float(np.sum(r**2))
        lam = 1e-3
        for _ in range(100):
            Jg = global_jacobian(qa, x, r)
            A = np.einsum("fia,fib->fab", Jq, Jq)
            B = np.einsum("fia,fig->fag", Jq, Jg)
            G = np.einsum("fia,fib->ab", Jg, Jg)
            gq = np.einsum("fia,fi->fa", Jq, r)
            gg = np.einsum("fia,fi->a", Jg, r)
            improved = False
            while lam < 1e10:
                Al = A + lam * np.einsum("faa->fa", A)[:, :, None] * eye_q + 1e-12 * eye_q
                Ainv_B = np.linalg.solve(Al, B)
                Ainv_g = np.linalg.solve(Al, gq[..., None])[..., 0]
                if n_glob:
                    S = G + lam * np.diag(np.diag(G)) + 1e-12 * eye_g - np.einsum("fag,fah->gh", B, Ainv_B)
                    dx = np.linalg.solve(S, -gg + np.einsum("fag,fa->g", B, Ainv_g))
                else:
                    dx = np.zeros(0)
                dq = -Ainv_g - np.einsum("fag,g->fa", Ainv_B, dx)
                x_new = x + dx
                q_new = bounded(qa + dq, x_new)
                r_new, Jq_new = model_residual(q_new, x_new, jacobian=True)
                c_new = float(np.sum(r_new**2))
                if np.isfinite(c_new) and c_new <= cost:
                    small = cost - c_new <= 1e-5 * cost
                    x, qa, r, Jq, cost = x_new, q_new, r_new, Jq_new, c_new
                    lam = max(lam / 3.0, 1e-12)
                    improved = not small
                    break
                lam *= 10.0
            if not improved:
                break
        return x, qa, r, Jq

    x, qa, r, Jq = bundle(x, qa)
    if n_prior:
        # the priors weigh against the data at the noise level pose_std; residuals well above it are model
        # error, whose weight the data must not claim: refit with the priors scaled by the residual level
        for _ in range(3):
            level = np.sqrt(np.sum(r[:, : 3 * N] ** 2) / max(3 * int(mask.sum()), 1))  # in units of pose_std
            factor = max(1.0, float(level))
            if abs(np.log(factor * sp / state["scale"])) < np.log(1.5):
                break
            state["scale"] = factor * sp
            ridge, twist_ridge = ridge_0 * factor, twist_ridge_0 * factor
            x, qa, r, Jq = bundle(x, qa)
    pb, Rb, sv, d, C = unpack(x)
    q = np.zeros((F, 6 * nk))
    q[:, cols] = qa
    n_data = r.shape[1] - n_prior
    rr = r[:, :n_data]
    pos_r = rr[:, : 3 * N].reshape(F, N, 3) * sp
    rms = float(np.sqrt(np.sum(pos_r**2) / max(int(mask.sum()), 1)))
    rot_rms = None
    if twist:
        rot_r = rr[:, 3 * N :].reshape(F, N, 3) * sa
        rot_rms = float(np.sqrt(np.sum(rot_r**2) / max(int(rmask.sum()), 1)))
    # standard errors of the globals with the strains marginalised (the Schur complement is the inverse
    # covariance); a sandwich over blocks of consecutive frames, as the residuals are correlated model error
    std_glob = np.zeros(n_glob)
    if n_glob:
        Jg = global_jacobian(qa, x, r)
        A = np.einsum("fia,fib->fab", Jq, Jq) + 1e-12 * eye_q
        B = np.einsum("fia,fig->fag", Jq, Jg)
        Jr = Jg - np.einsum("fia,fag->fig", Jq, np.linalg.solve(A, B))  # what the strains cannot absorb
        bread = np.linalg.pinv(np.einsum("fig,fih->gh", Jr, Jr))
        n_blocks = int(min(F, max(2, round(np.sqrt(F)))))
        block = np.arange(F) * n_blocks // F
        score = np.einsum("fig,fi->fg", Jr[:, :n_data], rr)
        per_block = np.stack([score[block == k].sum(axis=0) for k in range(n_blocks)])
        meat = per_block.T @ per_block * n_blocks / max(n_blocks - 1, 1)
        dof = max(rr.size - n_glob - F * na, 1)
        cov = np.maximum(bread @ meat @ bread, bread * float(np.sum(rr**2)) / dof)
        units = np.eye(n_glob)
        units[cuts[0] : cuts[1], cuts[0] : cuts[1]] *= scale
        units[cuts[3] : cuts[4], cuts[3] : cuts[4]] *= scale
        if fit_s:
            gaps = np.diff(np.concatenate([[0.0], sv]))
            units[cuts[2] : cuts[3], cuts[2] : cuts[3]] = np.tril(np.ones((N, N))) * gaps[None, :]
        std_glob = np.sqrt(np.clip(np.diag(units @ cov @ units.T), 0.0, None))
    std = np.zeros(5 + N)
    if fit_p:
        std[:3] = std_glob[cuts[0] : cuts[1]]
    if fit_a:
        std[3:5] = std_glob[cuts[1] : cuts[2]]
    if fit_s:
        std[5:] = std_glob[cuts[2] : cuts[3]]
    offsets_std = std_glob[cuts[3] : cuts[4]].reshape(N, 2) if fit_d else np.zeros((N, 2))
    return {
        "base_rotation": Rb,
        "base_position": np.asarray(pb, dtype=float),
        "arc_lengths": np.asarray(sv, dtype=float),
        "segment_lengths": _lengths(sv, ends),
        "offsets": np.asarray(d, dtype=float),
        "rotation_offsets": C,
        "rms": rms,
        "rotation_rms": rot_rms,
        "std": std,
        "offsets_std": offsets_std,
        "strains": q,
        "frames": P,
        "frame_rotations": Rt,
    }


# ----------------------------------------------------------------------------------------- Algorithm 1
def _known_arc_lengths(trajs: Sequence[PoseTrajectory]) -> NDArray[np.float64] | None:
    given = [tr.metadata.get("marker_arc_lengths") for tr in trajs]
    if all(g is None for g in given):
        return None
    if any(g is None for g in given) or any(not np.allclose(g, given[0]) for g in given):
        raise ValueError("X: give the same arc_lengths to PoseTrajectory.from_positions for every recording, or none")
    return np.asarray(given[0], dtype=float)


def _base_marker(trajs: Sequence[PoseTrajectory]) -> NDArray[np.float64] | None:
    has = ["base_marker" in tr.metadata for tr in trajs]
    if not any(has):
        return None
    if not all(has):
        raise ValueError("X: give base_marker=True to PoseTrajectory.from_positions for every recording, or none")
    return np.mean([np.asarray(tr.metadata["base_marker"], dtype=float) for tr in trajs], axis=0)


def spatial_marker_geometry(
    trajs: Sequence[PoseTrajectory],
    max_frames: int,
    *,
    normal: ArrayLike,
    offsets: str | ArrayLike | None = None,
    pose_std: Sequence[float] = _DEFAULT_STD,
) -> dict[str, Any]:
    """Marker arc lengths (given or fitted) and the base of positions-only recordings in 3-D.

    Without given arc lengths (``from_positions(arc_lengths=...)``) and without a recorded base marker
    (``from_positions(base_marker=True)``, which fixes the base position) the base's distance depends on
    how the bending is distributed, and, as :func:`pcs_sindy.fusion.marker_geometry` in the plane, the arc
    lengths are the mean of those of a uniform bending and of every split of the markers into two
    segments (their spread added to the standard errors), the base (and offsets) then fitted for those
    arc lengths with a uniform bending.  Otherwise one segment per marker spacing fits the base, the arc
    lengths (unless given) and the offsets.  Orientations (``from_positions(rotations=...)``) add torsion.

    Returns
    -------
    dict
        ``geo`` (the :func:`fit_spatial_geometry` result), ``s`` (N + 1,) arc lengths with the base,
        ``given``, ``arc_std`` (N,), ``offsets``, ``fit_offsets``, ``base_position``, ``normal``,
        ``models``, ``frames`` (F, N, 3) and ``frame_rotations`` (or None) of the frames used.
    """
    known = _known_arc_lengths(trajs)
    positions = [tr.positions for tr in trajs]
    rotations = [getattr(tr, "rotations", None) for tr in trajs]
    if all(r is None for r in rotations):
        rotations = None
    N = positions[0].shape[1]
    base_position = _base_marker(trajs)
    kw = {
        "normal": normal,
        "rotations": rotations,
        "max_frames": max_frames,
        "offsets": offsets,
        "base_position": base_position,
        "pose_std": pose_std,
    }
    arc_std = np.zeros(N)
    models: list[dict[str, Any]] = []
    if known is None and base_position is None:
        # neither the arc lengths nor the base: where the bending concentrates decides the base's distance
        # (as in the plane); average the arc lengths of a uniform bending and of every split into two
        groups: list[Any] = ["uniform"] + [(np.arange(N) >= k).astype(int) for k in range(1, N)]
        for g in groups:
            f = fit_spatial_geometry(positions, None, curvatures=g, **kw)
            models.append({"curvatures": g if isinstance(g, str) else g.tolist(), **f})
        arcs = np.array([f["arc_lengths"] for f in models])
        stat = np.array([np.asarray(f["std"])[5:] for f in models])
        known = arcs.mean(axis=0)
        arc_std = np.sqrt(np.mean(stat**2, axis=0) + (arcs.var(axis=0, ddof=1) if len(models) > 1 else 0.0))
        geo = fit_spatial_geometry(positions, known, curvatures="uniform", **kw)
    else:
        # the arc lengths or a recorded base marker anchor the base's distance: one segment per marker
        # spacing fits the base, the (free) arc lengths and offsets without assuming how the body bends
        geo = fit_spatial_geometry(positions, known, curvatures="per_segment", **kw)
        if known is None:
            arc_std = np.asarray(geo["std"])[5:]
    return {
        "geo": geo,
        "s": np.concatenate([[0.0], geo["arc_lengths"]]),
        "given": not models,
        "arc_std": arc_std,
        "offsets": geo["offsets"],
        "fit_offsets": isinstance(offsets, str),
        "base_position": base_position,
        "normal": np.asarray(normal, dtype=float),
        "models": models,
        "frames": geo["frames"],
        "frame_rotations": geo["frame_rotations"],
        "pose_std": tuple(float(v) for v in pose_std),
    }


def _strain_scales(bend_scale: float, twist_scale: float) -> NDArray[np.float64]:
    return np.array([bend_scale, bend_scale, twist_scale])


def _segment_strains(geometry: dict[str, Any], boundaries: NDArray[np.intp]) -> NDArray[np.float64]:
    """Active strains (F, m, 2 or 3) of the geometry's frames for segments ending on ``boundaries``."""
    geo, s = geometry["geo"], geometry["s"]
    twist = geometry["frame_rotations"] is not None
    m = boundaries.size
    active = np.tile(np.array(SPATIAL_BENDING_TWIST if twist else SPATIAL_BENDING), (m, 1))
    q, _ = fit_spatial_strains(
        geometry["frames"],
        geo["base_rotation"],
        geo["base_position"],
        _lengths(s[1:], boundaries),
        s[1:],
        active=active,
        rotations=geometry["frame_rotations"],
        offsets=geo["offsets"],
        rotation_offsets=geo["rotation_offsets"],
        pose_std=geometry["pose_std"],
    )
    return q.reshape(q.shape[0], m, 6)[..., :3] if twist else q.reshape(q.shape[0], m, 6)[..., :2]


def _merge(
    geometry: dict[str, Any],
    threshold: float,
    scales: NDArray[np.float64] | None,
    cache: dict[tuple[int, ...], NDArray[np.float64]] | None = None,
    n_segments: int | None = None,
) -> tuple[NDArray[np.intp], list[dict[str, Any]], NDArray[np.float64]]:
    """Algorithm 1 on the spatial strains between markers: segment end markers, history, strain scales.

    The distance of adjacent segments is the mean over frames of the norm of the difference of their
    scaled active strains (bend_z and bend_x share the bending scale: the distance does not depend on
    the gauge); ``scales`` None: the 99th percentile of the initial segments' bending magnitudes (and
    twists).
    """
    N = geometry["s"].size - 1
    boundaries = np.arange(1, N + 1)
    history: list[dict[str, Any]] = []
    while boundaries.size > (1 if n_segments is None else n_segments):
        key = tuple(int(b) for b in boundaries)
        w = None if cache is None else cache.get(key)
        if w is None:
            w = _segment_strains(geometry, boundaries)
            if cache is not None:
                cache[key] = w
        if scales is None:
            bend = float(np.percentile(np.hypot(w[..., 0], w[..., 1]), 99.0)) or 1.0
            twist = float(np.percentile(np.abs(w[..., 2]), 99.0)) or 1.0 if w.shape[-1] == 3 else 1.0
            scales = _strain_scales(bend, twist)
        distances = np.mean(np.linalg.norm(np.diff(w / scales[: w.shape[-1]], axis=1), axis=2), axis=0)
        if n_segments is None:
            groups = merge_runs(distances, threshold)
        else:
            k = int(np.argmin(distances))
            groups = [[i] for i in range(k)] + [[k, k + 1]] + [[i] for i in range(k + 2, boundaries.size)]
        history.append({"boundaries": boundaries.copy(), "distances": distances, "groups": groups})
        if len(groups) == boundaries.size:
            break
        boundaries = np.array([boundaries[g[-1]] for g in groups])
    if scales is None:
        scales = _strain_scales(1.0, 1.0)
    return boundaries, history, scales


def _position_rms(geometry: dict[str, Any], boundaries: NDArray[np.intp], w: NDArray[np.float64]) -> float:
    geo, s = geometry["geo"], geometry["s"]
    m = boundaries.size
    q = np.zeros((w.shape[0], m, 6))
    q[..., : w.shape[-1]] = w
    mod = spatial_marker_model(
        q.reshape(w.shape[0], -1),
        _lengths(s[1:], boundaries),
        s[1:],
        geo["base_rotation"],
        geo["base_position"],
        geo["offsets"],
    )
    return float(np.sqrt(np.nanmean(np.sum((mod["positions"] - geometry["frames"]) ** 2, axis=2))))


def choose_spatial_threshold(
    geometry: dict[str, Any],
    scales: NDArray[np.float64] | None,
    *,
    rule: str = "relative_drop",
    thresholds: ArrayLike | None = None,
) -> tuple[float, dict[str, Any]]:
    """The merge threshold of a spatial fusion by a rule over a sweep (``threshold="auto"``).

    Algorithm 1 runs for every threshold on the geometry's frames (:func:`spatial_marker_geometry`);
    each distinct segmentation is scored by the RMS marker position error of its own strains, and the
    rule and the record are those of :func:`~pcs_sindy.fusion.threshold_selection.choose_threshold`.
    """
    hs = AUTO_THRESHOLDS if thresholds is None else np.sort(np.atleast_1d(np.asarray(thresholds, dtype=float)))
    cache: dict[tuple[int, ...], NDArray[np.float64]] = {}
    scores: dict[tuple[int, ...], float] = {}
    rows, bounds = [], []
    for h in hs:
        boundaries, _, scales = _merge(geometry, float(h), scales, cache)
        key = tuple(int(b) for b in boundaries)
        if key not in scores:
            w = cache.get(key)
            if w is None:
                w = cache[key] = _segment_strains(geometry, boundaries)
            scores[key] = _position_rms(geometry, boundaries, w)
        rows.append(SweepRow(float(h), len(key), scores[key], scores[key]))
        bounds.append(np.asarray(key))
    return choice_from_sweep(rows, bounds, rule=rule, error="e_p_dist")


def fuse_spatial_segments(
    trajs: Sequence[PoseTrajectory],
    geometry: dict[str, Any],
    threshold: float,
    scales: NDArray[np.float64] | None,
    *,
    n_segments: int | None = None,
    refit_base: bool = True,
) -> dict[str, Any]:
    """Algorithm 1 on spatial strains and the base (and offsets) fitted again for the fused segmentation.

    Returns
    -------
    dict
        ``base_rotation``, ``base_position``, ``arc_lengths`` (N + 1,) with the base, ``arc_lengths_std`` (N,),
        ``base_std`` (5,) (position, rest direction), ``rms`` [m], ``rotation_rms``, ``offsets`` (N, 2),
        ``offsets_std``, ``rotation_offsets``, ``boundaries``, ``segment_lengths``, ``history``, ``scales``
        (bending, bending, twist).
    """
    N = geometry["s"].size - 1
    if n_segments is not None and not 1 <= n_segments <= N:
        raise ValueError(f"n_segments must be in [1, {N}] (one per marker at most); got {n_segments}")
    boundaries, history, scales = _merge(geometry, threshold, scales, n_segments=n_segments)
    geo, s = geometry["geo"], geometry["s"]
    if refit_base:  # the base of the fused model itself: its strains are constant over each fused segment
        group = np.searchsorted(boundaries, np.arange(1, N + 1))
        rotations = [getattr(tr, "rotations", None) for tr in trajs]
        geo = fit_spatial_geometry(
            [tr.positions for tr in trajs],
            s[1:],
            normal=geometry["normal"],
            rotations=None if all(r is None for r in rotations) else rotations,
            max_frames=geometry["frames"].shape[0],
            curvatures=group,
            base_position=geometry["base_position"],
            initial_base=(geo["base_rotation"], geo["base_position"]),
            offsets="fit" if geometry["fit_offsets"] else geo["offsets"],
            initial_offsets=geo["offsets"],
            initial_rotation_offsets=geo["rotation_offsets"],
            pose_std=geometry["pose_std"],
        )
    return {
        "base_rotation": geo["base_rotation"],
        "base_position": geo["base_position"],
        "arc_lengths": s,
        "arc_lengths_std": np.zeros(N) if geometry["given"] else geometry["arc_std"],
        "base_std": np.asarray(geo["std"])[:5],
        "rms": float(geo["rms"]),
        "rotation_rms": geo["rotation_rms"],
        "offsets": geo["offsets"],
        "offsets_std": geo["offsets_std"],
        "rotation_offsets": geo["rotation_offsets"],
        "boundaries": boundaries,
        "segment_lengths": _lengths(s[1:], boundaries),
        "history": history,
        "scales": scales,
    }


# ----------------------------------------------------------------------------------------- trajectories
def _homogeneous(R: NDArray[np.float64], p: NDArray[np.float64]) -> NDArray[np.float64]:
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = R, p
    return H


def spatial_strain_trajectories(
    trajs: Sequence[PoseTrajectory],
    base_pose: ArrayLike,
    segment_lengths: ArrayLike,
    arc_lengths: ArrayLike,
    boundaries: ArrayLike,
    *,
    offsets: ArrayLike | None = None,
    rotation_offsets: ArrayLike | None = None,
    pose_std: Sequence[float] = _DEFAULT_STD,
) -> list[SpatialStrainTrajectory]:
    """Spatial strain trajectories of positions-only recordings for a fitted segmentation.

    Parameters
    ----------
    trajs : sequence of PoseTrajectory
        Made by ``PoseTrajectory.from_positions`` (3-D positions; ``rotations`` used when present and
        ``rotation_offsets`` is given).
    base_pose : array_like, shape (4, 4)
        The fixed base pose (homogeneous matrix) in the capture frame.
    segment_lengths : array_like, shape (m,)
    arc_lengths : array_like, shape (N + 1,)
        Rest arc lengths of the base (0) and the markers.
    boundaries : array_like of int, shape (m,)
    offsets : array_like, shape (N, 2), optional
    rotation_offsets : array_like, shape (N, 3, 3), optional

    Returns
    -------
    list of SpatialStrainTrajectory
        Their ``kinematics`` is a :class:`~pcs_sindy.core.spatial.SpatialPCS` with the base pose;
        ``metadata``: ``marker_arc_lengths``, ``marker_offsets`` (N, 2), ``rotation_offsets``, ``boundaries``,
        ``shape_fit="positions"``, ``estimated`` (frames whose strains were all seen).
    """
    H = np.asarray(base_pose, dtype=float)
    lengths = np.asarray(segment_lengths, dtype=float)
    s = np.asarray(arc_lengths, dtype=float)
    m = lengths.size
    d = _as_offsets(offsets, s.size - 1)
    C = None if rotation_offsets is None else np.asarray(rotation_offsets, dtype=float)
    twist = C is not None
    active = np.tile(np.array(SPATIAL_BENDING_TWIST if twist else SPATIAL_BENDING), (m, 1))
    out = []
    for tr in trajs:
        rot = getattr(tr, "rotations", None) if twist else None
        q, estimated = fit_spatial_strains(
            tr.positions,
            H[:3, :3],
            H[:3, 3],
            lengths,
            s[1:],
            active=active,
            rotations=rot,
            offsets=d,
            rotation_offsets=C if rot is not None else None,
            pose_std=pose_std,
        )
        meta = dict(tr.metadata)
        meta.update(
            marker_arc_lengths=s.copy(),
            boundaries=np.asarray(boundaries).copy(),
            shape_fit="positions",
            marker_offsets=d.copy(),
            estimated=estimated,
        )
        if C is not None:
            meta["rotation_offsets"] = C.copy()
        out.append(
            SpatialStrainTrajectory(
                q,
                tr.t,
                segment_lengths=tuple(lengths),
                active_strains=active,
                base_position=tuple(H[:3, 3]),
                base_rotation=H[:3, :3],
                metadata=meta,
            )
        )
    return out


def spatial_marker_positions(
    st: SpatialStrainTrajectory,
    arc_lengths: ArrayLike,
    base_pose: ArrayLike,
    offsets: ArrayLike | None = None,
    rotation_offsets: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Marker positions (T, N, 3) and orientations (T, N, 3, 3) in the capture frame of a spatial strain trajectory.

    ``arc_lengths`` (N + 1,) include the base (0); ``base_pose`` (4, 4); ``offsets`` (N, 2) and
    ``rotation_offsets`` (N, 3, 3) as fitted (:func:`spatial_marker_model`).
    """
    s = np.asarray(arc_lengths, dtype=float)
    H = np.asarray(base_pose, dtype=float)
    total = float(np.sum(st.segment_lengths))
    if abs(s[-1] - total) > 1e-9 * total:
        raise ValueError(f"segment lengths sum to {total:g} m but the marker arc lengths end at {s[-1]:g} m")
    mod = spatial_marker_model(
        st.q, st.segment_lengths, np.clip(s[1:], 0.0, total), H[:3, :3], H[:3, 3], offsets, rotation_offsets
    )
    return mod["positions"], mod["rotations"]
