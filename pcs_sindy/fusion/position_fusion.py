"""Segmentation and strains of positions-only recordings: the path ``KinematicFusion`` takes for them.

Recordings made by :meth:`pcs_sindy.core.PoseTrajectory.from_positions`
carry marker positions in a plane, no orientations and no base.  This module

* fits the markers' rest arc lengths (unless known) and the fixed base pose with a
  uniformly bending robot (:func:`marker_geometry`), and the base pose again for the
  fused segmentation (:func:`pcs_sindy.fusion.position_fit.fit_marker_geometry`);
* runs the seed's Algorithm 1 on the curvatures of one bending-only segment
  per marker spacing (:func:`fuse_position_segments`): adjacent segments
  whose curvature trajectories, scaled by the bending scale of ``q_max``,
  are within ``threshold`` on average merge, and the curvatures of the merged
  segmentation are fitted again, until nothing merges;
* returns strain trajectories whose only active strains are the bending
  strains (:func:`position_strain_trajectories`), carrying the plane so that
  ``KinematicFusion.inverse_transform`` gives positions back in the user's
  frame (:func:`positions_in_user_frame`).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.trajectory import MarkerPlane, PoseTrajectory, StrainTrajectory
from .merging import merge_runs
from .position_fit import fit_marker_geometry, fit_position_strains, marker_positions_jacobian
from .threshold_selection import AUTO_THRESHOLDS, SweepRow, choice_from_sweep

__all__ = [
    "fuse_position_segments",
    "choose_position_threshold",
    "marker_geometry",
    "shared_marker_plane",
    "base_axis_planes",
    "on_plane",
    "recorded_base_position",
    "position_strain_trajectories",
    "positions_in_user_frame",
    "tendon_sides",
    "BENDING_ONLY",
]

#: active strains of every segment of a positions-only fusion: bending
BENDING_ONLY = (True, False, False)


def shared_marker_plane(trajs: Sequence[PoseTrajectory]) -> MarkerPlane:
    """One plane for positions-only recordings of one set-up: fitted to all their markers (and base markers).

    A single recording keeps its own plane.  The normal points to the side of the first
    recording's (so the sign of the curvatures stays the capture's convention).
    """
    if len(trajs) == 1 or trajs[0].plane.dim == 2:
        return trajs[0].plane
    points = [tr.positions.reshape(-1, tr.positions.shape[-1]) for tr in trajs]
    points += [np.atleast_2d(tr.metadata["base_marker"]) for tr in trajs if "base_marker" in tr.metadata]
    return MarkerPlane.fit(np.concatenate(points, axis=0), normal=trajs[0].plane.normal)


def base_axis_planes(
    trajs: Sequence[PoseTrajectory],
    axis: ArrayLike | None = None,
    origin: ArrayLike | None = None,
    side: ArrayLike | None = None,
) -> tuple[list[MarkerPlane], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One plane per recording, all through the recorded base marker and one common axis there.

    A clamped robot driven by tendons at different angles around its body bends, for each
    combination of loads, in its own plane, but every such plane contains the clamp's axis.
    The axis ``a`` minimises the total squared out-of-plane distance of all recordings' markers
    when each recording's plane is the best plane containing ``a`` (its normal the least
    principal direction of the markers' spread across ``a``).  Each plane's in-plane axes are
    ``(a x n, a)``: the robot at rest points along ``+y = a``, and the normals all point to the
    side of the first recording's (the sign of the curvatures is shared).

    Needs ``base_marker`` in every recording's metadata (:meth:`PoseTrajectory.from_positions`)
    unless ``axis``, ``origin`` and ``side`` (a fitted set-up's, for more recordings) are given.

    Returns
    -------
    planes : list of MarkerPlane
    axis, origin, side : ndarray (3,)
        The common axis, the point it passes through, and the direction the normals point to.
    """
    from scipy.optimize import minimize

    if trajs[0].plane.dim != 3:
        raise ValueError("shared_plane='base_axis' needs 3-D positions")
    if origin is None:
        if any("base_marker" not in tr.metadata for tr in trajs):
            raise ValueError("shared_plane='base_axis' needs a recorded base marker (from_positions(base_marker=True))")
        origin = np.mean([np.asarray(tr.metadata["base_marker"], dtype=float) for tr in trajs], axis=0)
    origin = np.asarray(origin, dtype=float)
    clouds = []
    for tr in trajs:
        P = tr.positions.reshape(-1, 3)
        clouds.append(P[np.all(np.isfinite(P), axis=1)] - origin)

    def normals(a):
        out = []
        for X in clouds:
            Xp = X - np.outer(X @ a, a)  # spread across the axis
            w, v = np.linalg.eigh(Xp.T @ Xp + np.outer(a, a) * 1e12 * max(1.0, float(np.sum(Xp**2))))
            out.append(v[:, 0])
        return out

    def cost(angles):
        a = _unit(angles)
        return sum(float(np.sum((X @ n) ** 2)) for X, n in zip(clouds, normals(a)))

    if axis is None:
        # start: from the base marker to the markers' mean position
        start = np.mean(np.concatenate(clouds), axis=0)
        start = start / np.linalg.norm(start)
        x0 = np.array([np.arccos(np.clip(start[2], -1, 1)), np.arctan2(start[1], start[0])])
        a = _unit(minimize(cost, x0, method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-14}).x)
    else:
        a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    ns = normals(a)
    ref = trajs[0].plane.normal if side is None else np.asarray(side, dtype=float)
    ref = ref - (ref @ a) * a
    planes = []
    for n in ns:
        if np.linalg.norm(ref) > 1e-9 and n @ ref < 0:
            n = -n
        u = np.cross(a, n)
        planes.append(MarkerPlane(origin, np.stack([u, a], axis=1)))
    return planes, a, origin, ref


def _unit(angles: NDArray[np.float64]) -> NDArray[np.float64]:
    th, ph = angles
    return np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])


def on_plane(tr: PoseTrajectory, plane: MarkerPlane) -> PoseTrajectory:
    """The positions-only recording ``tr`` projected on ``plane`` (a shallow copy; ``tr`` is unchanged)."""
    if tr.plane is plane:
        return tr
    out = copy.copy(tr)
    out.plane = plane
    out.plane_positions = plane.to_plane(tr.positions)
    out.metadata = dict(tr.metadata)
    return out


def recorded_base_position(trajs: Sequence[PoseTrajectory]) -> NDArray[np.float64] | None:
    """In-plane position of the recorded base marker (``from_positions(base_marker=True)``), or None.

    Recordings of one set-up share the clamp: their base markers are averaged; all or none must have one.
    """
    has = ["base_marker" in tr.metadata for tr in trajs]
    if not any(has):
        return None
    if not all(has):
        raise ValueError("X: give base_marker=True to PoseTrajectory.from_positions for every recording, or none")
    return np.mean([tr.plane.to_plane(np.asarray(tr.metadata["base_marker"], dtype=float)) for tr in trajs], axis=0)


def _known_arc_lengths(trajs: Sequence[PoseTrajectory]) -> NDArray[np.float64] | None:
    given = [tr.metadata.get("marker_arc_lengths") for tr in trajs]
    if all(g is None for g in given):
        return None
    if any(g is None for g in given) or any(not np.allclose(g, given[0]) for g in given):
        raise ValueError("X: give the same arc_lengths to PoseTrajectory.from_positions for every recording, or none")
    return np.asarray(given[0], dtype=float)


def fuse_position_segments(
    trajs: Sequence[PoseTrajectory],
    threshold: float,
    bend_scale: float | None,
    max_frames: int = 300,
    refit_base: bool = True,
    geometry: dict[str, Any] | None = None,
    n_segments: int | None = None,
) -> dict[str, Any]:
    """Base pose, marker arc lengths and the fused segmentation of positions-only recordings.

    Parameters
    ----------
    trajs : sequence of PoseTrajectory
        Made by ``PoseTrajectory.from_positions``, all with the same markers.
    threshold : float
        Merge threshold on the mean scaled curvature distance (seed eq. 11).
    bend_scale : float or None
        Curvature scale [1/m] (the bending entry of ``q_max``); None: the 99th percentile of the
        initial segments' curvature magnitudes (``KinematicFusion(scaling="data")``).
    max_frames : int, default 300
        Frames used to fit the geometry.
    refit_base : bool, default True
        Fit the base pose again for the fused segmentation (constant curvature over each
        fused segment), so that the model's own shape, not the finer initial one, matches the markers.
    geometry : dict, optional
        The marker geometry already fitted (:func:`marker_geometry`), e.g. by a threshold sweep.
    n_segments : int, optional
        Merge the closest adjacent segments until this many remain (``threshold`` is not used),
        e.g. the count chosen by held-out prediction.

    Returns
    -------
    dict
        ``base_pose`` (3,), ``arc_lengths`` (N + 1,) base included, ``arc_lengths_std`` (N,),
        ``base_pose_std`` (3,), ``rms`` [m], ``boundaries`` (m,) marker index of each segment's
        end, ``segment_lengths`` (m,), ``history`` (per merge iteration).
    """
    if geometry is None:
        geometry = marker_geometry(trajs, max_frames)
    if n_segments is not None and not 1 <= n_segments <= geometry["s"].size - 1:
        raise ValueError(
            f"n_segments must be in [1, {geometry['s'].size - 1}] (one per marker at most); got {n_segments}"
        )
    boundaries, history, bend_scale = _merge(trajs, geometry, threshold, bend_scale, n_segments=n_segments)
    return _fused(trajs, geometry, boundaries, history, bend_scale, max_frames, refit_base)


def choose_position_threshold(
    trajs: Sequence[PoseTrajectory],
    bend_scale: float | None,
    max_frames: int = 300,
    *,
    rule: str = "relative_drop",
    thresholds: ArrayLike | None = None,
    geometry: dict[str, Any] | None = None,
) -> tuple[float, dict[str, Any]]:
    """The merge threshold of positions-only recordings by a rule over a sweep (``threshold="auto"``).

    The marker geometry is fitted once (or given: :func:`marker_geometry`); Algorithm 1 runs for
    every threshold on the geometry's frames, and each distinct segmentation is scored by the RMS
    marker position error of its own strains (constant curvature per fused segment, the fitted
    base), the positions' analogue of ``e_p_dist``.
    The rule and the record are those of :func:`~pcs_sindy.fusion.threshold_selection.choose_threshold`.
    """
    hs = AUTO_THRESHOLDS if thresholds is None else np.sort(np.atleast_1d(np.asarray(thresholds, dtype=float)))
    if geometry is None:
        geometry = marker_geometry(trajs, max_frames)
    frames = geometry["frames"]
    scores: dict[tuple[int, ...], float] = {}
    rows, bounds = [], []
    curvatures: dict[tuple[int, ...], NDArray[np.float64]] = {}
    for h in hs:
        boundaries, _, bend_scale = _merge(trajs, geometry, float(h), bend_scale, curvatures)
        key = tuple(int(b) for b in boundaries)
        if key not in scores:
            # the RMS marker error of the segmentation's own strains for the fitted base, on the geometry's frames
            s = geometry["s"]
            lengths = np.diff(s[np.concatenate([[0], boundaries])])
            base, d = geometry["geo"]["base_pose"], geometry["offsets"]
            q, _ = fit_position_strains(frames, base, lengths, s[1:], offsets=d)
            pos, _ = marker_positions_jacobian(q[:, 0::3], lengths, s[1:], base, d)
            scores[key] = float(np.sqrt(np.nanmean(np.sum((pos - frames) ** 2, axis=2))))
        rows.append(SweepRow(float(h), len(key), scores[key], scores[key]))
        bounds.append(np.asarray(key))
    return choice_from_sweep(rows, bounds, rule=rule, error="e_p_dist")


def marker_geometry(
    trajs: Sequence[PoseTrajectory],
    max_frames: int,
    *,
    offsets: str | ArrayLike | None = None,
    base_position: ArrayLike | None = None,
) -> dict[str, Any]:
    """Marker arc lengths (given or fitted) and the base pose of positions-only recordings.

    The curves the markers sweep fix the base's distance only given how the curvature is
    distributed along the body (with a curvature per spacing any pattern of displacements fits
    a base anywhere near the first marker; a uniformly bending model puts the base too far when
    the bending concentrates near the tip, too near when it concentrates near the base).  So
    the arc lengths, unless given, are the mean of those of a uniform bending and of every split
    of the markers into two curvatures (:func:`fit_marker_geometry`), and their standard errors
    add the spread between these models to the statistical ones; the base pose is then fitted
    for those arc lengths with a uniform bending.

    ``offsets`` (``"fit"``, N distances or None) places the markers off the backbone and
    ``base_position`` (in-plane, e.g. of a recorded base marker) fixes the base's position
    (see :func:`fit_marker_geometry`).

    Returns
    -------
    dict
        ``geo`` (the fit), ``s`` (N + 1,) arc lengths with the base, ``given``, ``arc_std`` (N,),
        ``offsets`` (N,) as given or fitted, ``fit_offsets``, ``base_position``, ``models`` (the fits
        averaged: ``curvatures``, ``arc_lengths``, ``std``, ``rms``, ...),
        ``frames`` (F, N, 2) the in-plane positions of the frames used (at most ``max_frames``,
        evenly over all recordings).
    """
    known = _known_arc_lengths(trajs)
    planar = [tr.plane_positions for tr in trajs]
    N = planar[0].shape[1]
    kw = {"max_frames": max_frames, "offsets": offsets, "base_position": base_position}
    arc_std = np.zeros(N)
    models: list[dict[str, Any]] = []
    if known is None:
        # where the bending concentrates is not seen by a few positions, and the base's distance depends on
        # it: average the arc lengths of a uniform bending and of every split into two curvatures, the
        # spread between them (model uncertainty) added to their standard errors
        groups: list[Any] = ["uniform"] + [(np.arange(N) >= k).astype(int) for k in range(1, N)]
        for g in groups:
            f = fit_marker_geometry(planar, None, curvatures=g, **kw)
            models.append({"curvatures": g if isinstance(g, str) else g.tolist(), **f})
        arcs = np.array([f["arc_lengths"] for f in models])
        stat = np.array([np.asarray(f["std"])[3:] for f in models])
        known = arcs.mean(axis=0)
        arc_std = np.sqrt(np.mean(stat**2, axis=0) + (arcs.var(axis=0, ddof=1) if len(models) > 1 else 0.0))
    geo = fit_marker_geometry(planar, known, curvatures="uniform", **kw)
    s = np.concatenate([[0.0], geo["arc_lengths"]])
    return {
        "geo": geo,
        "s": s,
        "given": not models,
        "arc_std": arc_std,
        "frames": _frames(planar, max_frames),
        "offsets": np.asarray(geo["offsets"], dtype=float),
        "fit_offsets": isinstance(offsets, str),
        "base_position": None if base_position is None else np.asarray(base_position, dtype=float),
        "models": models,
    }


def _frames(planar: Sequence[NDArray[np.float64]], max_frames: int) -> NDArray[np.float64]:
    """At most ``max_frames`` frames with a valid marker, evenly over all recordings (as fit_marker_geometry)."""
    P = np.concatenate(planar, axis=0)
    P = P[np.any(np.all(np.isfinite(P), axis=2), axis=1)]
    if P.shape[0] > max_frames:
        P = P[np.linspace(0, P.shape[0] - 1, int(max_frames)).round().astype(int)]
    return P


def _merge(
    trajs: Sequence[PoseTrajectory],
    geometry: dict[str, Any],
    threshold: float,
    bend_scale: float | None,
    curvatures: dict[tuple[int, ...], NDArray[np.float64]] | None = None,
    n_segments: int | None = None,
) -> tuple[NDArray[np.intp], list[dict[str, Any]], float]:
    """Algorithm 1 on the bending strains between markers: segment end markers, history, curvature scale.

    ``curvatures`` (segmentation -> fitted curvatures) is filled and reused across calls, so a sweep over
    thresholds fits each segmentation's strains once.  With ``n_segments`` the threshold is not used:
    the closest adjacent pair merges, one per iteration, until ``n_segments`` remain.
    """
    geo, s = geometry["geo"], geometry["s"]
    N = s.size - 1
    boundaries = np.arange(1, N + 1)
    history: list[dict[str, Any]] = []
    frames = geometry["frames"]  # Algorithm 1's mean distances, on the evenly spread frames of the geometry fit
    while boundaries.size > (1 if n_segments is None else n_segments):
        key = tuple(int(b) for b in boundaries)
        kappa = None if curvatures is None else curvatures.get(key)
        if kappa is None:
            lengths = np.diff(s[np.concatenate([[0], boundaries])])
            kappa = fit_position_strains(frames, geo["base_pose"], lengths, s[1:], offsets=geometry["offsets"])[0][
                :, 0::3
            ]
            if curvatures is not None:
                curvatures[key] = kappa
        if bend_scale is None:
            bend_scale = float(np.percentile(np.abs(kappa), 99.0)) or 1.0
        distances = np.mean(np.abs(np.diff(kappa, axis=1)), axis=0) / bend_scale
        if n_segments is None:
            groups = merge_runs(distances, threshold)
        else:
            k = int(np.argmin(distances))
            groups = [[i] for i in range(k)] + [[k, k + 1]] + [[i] for i in range(k + 2, boundaries.size)]
        history.append({"boundaries": boundaries.copy(), "distances": distances, "groups": groups})
        if len(groups) == boundaries.size:
            break
        boundaries = np.array([boundaries[g[-1]] for g in groups])
    return boundaries, history, (1.0 if bend_scale is None else bend_scale)


def _fused(
    trajs: Sequence[PoseTrajectory],
    geometry: dict[str, Any],
    boundaries: NDArray[np.intp],
    history: list[dict[str, Any]],
    bend_scale: float,
    max_frames: int,
    refit_base: bool,
) -> dict[str, Any]:
    geo, s = geometry["geo"], geometry["s"]
    N = s.size - 1
    std = np.asarray(geo["std"])
    if refit_base:  # the base pose of the fused model itself: its curvature is constant over each segment
        planar = [tr.plane_positions for tr in trajs]
        group = np.searchsorted(boundaries, np.arange(1, N + 1))
        geo = fit_marker_geometry(
            planar,
            s[1:],
            max_frames=max_frames,
            curvatures=group,
            initial_base_pose=geo["base_pose"],
            base_position=geometry["base_position"],
            offsets="fit" if geometry["fit_offsets"] else geometry["offsets"],
            initial_offsets=geometry["offsets"],
        )
        std = np.asarray(geo["std"])
    return {
        "base_pose": np.asarray(geo["base_pose"], dtype=float),
        "arc_lengths": s,
        "base_pose_std": std[:3],
        "arc_lengths_std": np.zeros(N) if geometry["given"] else geometry["arc_std"],
        "rms": float(geo["rms"]),
        "offsets": np.asarray(geo["offsets"], dtype=float),
        "offsets_std": np.asarray(geo["offsets_std"], dtype=float),
        "boundaries": boundaries,
        "segment_lengths": np.diff(s[np.concatenate([[0], boundaries])]),
        "history": history,
        "bend_scale": bend_scale,
    }


def position_strain_trajectories(
    trajs: Sequence[PoseTrajectory],
    base_pose: NDArray[np.float64],
    segment_lengths: NDArray[np.float64],
    arc_lengths: NDArray[np.float64],
    boundaries: NDArray[np.intp],
    offsets: NDArray[np.float64] | None = None,
) -> list[StrainTrajectory]:
    """Bending-only strain trajectories of positions-only recordings for a fitted segmentation.

    ``offsets`` (N,) are the markers' distances off the backbone (carried in
    ``metadata["marker_offsets"]`` for :func:`positions_in_user_frame`).
    """
    d = np.zeros(arc_lengths.size - 1) if offsets is None else np.asarray(offsets, dtype=float)
    out = []
    m = segment_lengths.size
    active = np.tile(np.array(BENDING_ONLY), (m, 1))
    for tr in trajs:
        q, estimated = fit_position_strains(tr.plane_positions, base_pose, segment_lengths, arc_lengths[1:], offsets=d)
        meta = dict(tr.metadata)
        meta.update(
            marker_arc_lengths=arc_lengths.copy(),
            base_poses=np.tile(base_pose, (tr.n_frames, 1)),
            boundaries=np.asarray(boundaries).copy(),
            shape_fit="positions",
            plane=tr.plane,
            marker_offsets=d.copy(),
            estimated=estimated,
        )
        out.append(
            StrainTrajectory(
                q,
                tr.t,
                segment_lengths=tuple(segment_lengths),
                active_strains=active,
                base_pose=tuple(base_pose),
                metadata=meta,
            )
        )
    return out


def positions_in_user_frame(st: StrainTrajectory, poses: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Marker positions (T, N, D) in the frame the positions came in, or None without a plane in the metadata."""
    plane = st.metadata.get("plane")
    if plane is None:
        return None
    xy = poses[:, 1:, :2]
    d = st.metadata.get("marker_offsets")
    if d is not None and np.any(np.asarray(d) != 0):  # markers off the backbone, along the cross-section normal
        th = poses[:, 1:, 2]
        xy = xy + np.asarray(d, dtype=float)[None, :, None] * np.stack([np.cos(th), np.sin(th)], axis=-1)
    return plane.from_plane(xy)


def tendon_sides(strains: Sequence[StrainTrajectory], inputs: Sequence[NDArray[np.float64]]) -> list[int]:
    """The side (+1 / -1) of each tendon in the fused plane, from the data.

    A tendon at a positive offset bends the robot towards negative curvature
    (:class:`pcs_sindy.models.TendonActuation`); the orientation of a plane fitted
    to 3-D positions (the sign of its curvatures) is the capture's, so the side of
    each tendon follows from the sign of the correlation of its input with the
    mean curvature of the segments.

    Parameters
    ----------
    strains : sequence of StrainTrajectory
    inputs : sequence of array_like, each (T_k, p)
        The tendon inputs (tensions, servo angles) of each recording.

    Returns
    -------
    list of int, length p
    """
    if len(strains) != len(inputs):
        raise ValueError(f"got {len(strains)} strain trajectories but {len(inputs)} input arrays")
    kappa = np.concatenate([st.q[:, 0::3].mean(axis=1) for st in strains])
    u = np.concatenate([np.asarray(v, dtype=float).reshape(len(st.q), -1) for st, v in zip(strains, inputs)])
    corr = (u - u.mean(axis=0)).T @ (kappa - kappa.mean())
    return [-1 if c > 0 else 1 for c in corr]
