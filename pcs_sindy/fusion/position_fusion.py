"""Segmentation and strains of positions-only recordings: the path ``KinematicFusion`` takes for them.

Recordings made by :meth:`pcs_sindy.core.PoseTrajectory.from_positions`
carry marker positions in a plane, no orientations and no base.  This module

* fits the markers' rest arc lengths (unless known) with a uniformly bending
  robot, then the fixed base pose with a curvature per marker spacing
  (:func:`pcs_sindy.fusion.position_fit.fit_marker_geometry`);
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

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.trajectory import PoseTrajectory, StrainTrajectory
from .merging import merge_runs
from .position_fit import fit_marker_geometry, fit_position_strains

__all__ = [
    "fuse_position_segments",
    "position_strain_trajectories",
    "positions_in_user_frame",
    "tendon_sides",
    "BENDING_ONLY",
]

#: active strains of every segment of a positions-only fusion: bending
BENDING_ONLY = (True, False, False)


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

    Returns
    -------
    dict
        ``base_pose`` (3,), ``arc_lengths`` (N + 1,) base included, ``arc_lengths_std`` (N,),
        ``base_pose_std`` (3,), ``rms`` [m], ``boundaries`` (m,) marker index of each segment's
        end, ``segment_lengths`` (m,), ``history`` (per merge iteration).
    """
    known = _known_arc_lengths(trajs)
    given = known is not None
    planar = [tr.plane_positions for tr in trajs]
    arc_std = np.zeros(planar[0].shape[1])
    if known is None:  # the arc lengths from a uniformly bending robot (a curvature per spacing leaves them free)
        first = fit_marker_geometry(planar, None, max_frames=max_frames, curvatures="uniform")
        known, arc_std = first["arc_lengths"], np.asarray(first["std"])[3:]
    # the base pose for those arc lengths with a curvature per marker spacing (no uniform-bending bias)
    geo = fit_marker_geometry(planar, known, max_frames=max_frames, curvatures="per_segment")
    s = np.concatenate([[0.0], geo["arc_lengths"]])
    N = s.size - 1
    std = np.asarray(geo["std"])
    boundaries = np.arange(1, N + 1)
    history: list[dict[str, Any]] = []
    P = [tr.plane_positions for tr in trajs]
    while boundaries.size > 1:
        lengths = np.diff(s[np.concatenate([[0], boundaries])])
        kappa = np.concatenate(
            [fit_position_strains(p, geo["base_pose"], lengths, s[1:])[0][:, 0::3] for p in P], axis=0
        )
        if bend_scale is None:
            bend_scale = float(np.percentile(np.abs(kappa), 99.0)) or 1.0
        distances = np.mean(np.abs(np.diff(kappa, axis=1)), axis=0) / bend_scale
        groups = merge_runs(distances, threshold)
        history.append({"boundaries": boundaries.copy(), "distances": distances, "groups": groups})
        if len(groups) == boundaries.size:
            break
        boundaries = np.array([boundaries[g[-1]] for g in groups])
    if refit_base:  # the base pose of the fused model itself: its curvature is constant over each segment
        group = np.searchsorted(boundaries, np.arange(1, N + 1))
        geo = fit_marker_geometry(planar, s[1:], max_frames=max_frames, base_pose=None, curvatures=group)
        std = np.asarray(geo["std"])
    return {
        "base_pose": np.asarray(geo["base_pose"], dtype=float),
        "arc_lengths": s,
        "base_pose_std": std[:3],
        "arc_lengths_std": np.zeros(N) if given else arc_std,
        "rms": float(geo["rms"]),
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
) -> list[StrainTrajectory]:
    """Bending-only strain trajectories of positions-only recordings for a fitted segmentation."""
    out = []
    m = segment_lengths.size
    active = np.tile(np.array(BENDING_ONLY), (m, 1))
    for tr in trajs:
        q, estimated = fit_position_strains(tr.plane_positions, base_pose, segment_lengths, arc_lengths[1:])
        meta = dict(tr.metadata)
        meta.update(
            marker_arc_lengths=arc_lengths.copy(),
            base_poses=np.tile(base_pose, (tr.n_frames, 1)),
            boundaries=np.asarray(boundaries).copy(),
            shape_fit="positions",
            plane=tr.plane,
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
    return plane.from_plane(poses[:, 1:, :2])


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
