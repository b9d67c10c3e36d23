"""The marker chain's geometry: poses in the base frame, deformed lengths, rest length, segment strains.

Markers are the seed's equally spaced cross-sections: a recording holds the
poses of the base and ``N`` markers, shape (T, N + 1, 3), whose arc lengths are
``linspace(0, L_total, N + 1)``.  Marker indices always count the base as
index 0 and the tip as index N.

Plain functions on numpy arrays:

* :func:`chain_poses` - poses relative to the (fixed or per-frame) base, with
  angles made continuous along the robot; :func:`frame_chain` for one frame;
* :func:`deformed_lengths` - the deformed axial length of every inter-marker
  segment, which does not depend on the rest length;
* :func:`estimate_total_length` / :func:`kinematic_rest_length` - the rest
  length from poses alone (and its jackknife standard error);
* :func:`rest_length_factor` - the correction of a rest length by identified
  axial rest strains;
* :func:`segment_strains` - closed-form inverse kinematics of any segmentation
  whose ends sit on markers (seed eq. 4, 9-10).

Knows nothing of dynamics; imports only the ground floor.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import half_cot, se2_relative, segment_inverse_kinematics

__all__ = [
    "chain_poses",
    "frame_chain",
    "deformed_lengths",
    "estimate_total_length",
    "kinematic_rest_length",
    "jackknife_std",
    "rest_length_factor",
    "segment_strains",
]


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


def frame_chain(poses: ArrayLike, base_pose: ArrayLike | None = None) -> NDArray[np.float64]:
    """One frame's poses (N + 1, 3) relative to a reference base, angles continuous along the robot.

    The single-frame counterpart of :func:`chain_poses`: ``base_pose`` is the
    clamped base (e.g. the median of the recordings a fusion was fitted on),
    moved to the frame's branch of the base angle; None uses the frame's own
    measured base.
    """
    P = np.array(poses, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or not np.all(np.isfinite(P)):
        raise ValueError(f"poses must be finite with shape (N + 1, 3); got {np.shape(poses)}")
    P[:, 2] = np.unwrap(P[:, 2])
    base = np.array(P[0] if base_pose is None else base_pose, dtype=float)
    if base.shape != (3,):
        raise ValueError(f"base_pose must be a pose (x, y, theta); got shape {base.shape}")
    base[2] += 2.0 * np.pi * np.round((P[0, 2] - base[2]) / (2.0 * np.pi))  # the frame's branch of the base angle
    return se2_relative(base, P)


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
    :func:`pcs_sindy.pipeline.rest_length.estimate_rest_length`).
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


def kinematic_rest_length(chains: Sequence[NDArray[np.float64]]) -> tuple[float, float]:
    """:func:`estimate_total_length` and its jackknife standard error.

    The jackknife leaves one recording out or, for a single recording, one of
    8 blocks of frames; it does not include the bias of a mean stretch.
    """
    chains = list(chains)
    total = estimate_total_length(chains)
    if len(chains) > 1:
        parts = [estimate_total_length(chains[:k] + chains[k + 1 :]) for k in range(len(chains))]
    else:
        blocks = np.array_split(np.arange(chains[0].shape[0]), min(8, chains[0].shape[0]))
        parts = [
            estimate_total_length([np.delete(chains[0], b, axis=0)]) for b in blocks if b.size < chains[0].shape[0]
        ]
    return total, jackknife_std(parts)


def rest_length_factor(segment_lengths: ArrayLike, rest_strain: ArrayLike) -> tuple[float, float]:
    """The factor ``1 + q̄`` that corrects rest lengths by identified axial rest strains, and ``q̄``.

    A rest length read ``(1 + e)`` times too long makes an unloaded robot look
    compressed: its identified axial rest strains are ``-e / (1 + e)``.
    ``q̄`` is the length-weighted mean of the segments' axial rest strains
    (one factor for all lengths: markers stay equally spaced).

    Parameters
    ----------
    segment_lengths : array_like, shape (m,)
    rest_strain : array_like, shape (3m,)
        ``[κ, σ_sh, σ_ax]`` rest strains of every segment.
    """
    lengths = np.asarray(segment_lengths, dtype=float)
    q = np.asarray(rest_strain, dtype=float)
    if q.shape != (3 * lengths.size,) or not np.all(np.isfinite(q)):
        raise ValueError(f"rest_strain must be {3 * lengths.size} finite numbers (3 per segment); got shape {q.shape}")
    mean = float(np.sum(lengths * q[2::3]) / np.sum(lengths))
    if not -0.5 < mean < 0.5:
        raise ValueError(f"rest_strain: mean axial rest strain {mean:+.3f} is no length error; the fit went wrong")
    return 1.0 + mean, mean


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
