"""Merging adjacent segments of similar strain: the seed's Algorithm 1 (docs/method.md, "Kinematic fusion").

Plain functions on numpy arrays:

* :func:`data_q_max` - strain scales from the data;
* :func:`strain_distances` - seed eq. 11 on scaled strains;
* :func:`merge_runs` - one merge step of Algorithm 1;
* :func:`fuse_segments` - Algorithm 1 to convergence, with the absorption of
  too short segments beyond the seed.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import SEED_Q_MAX
from .chain_geometry import segment_strains

__all__ = ["MERGE_RULES", "check_q_max", "data_q_max", "strain_distances", "merge_runs", "fuse_segments"]

#: the merge rules of :func:`fuse_segments`
MERGE_RULES = ("runs", "closest_pair")


def check_q_max(q_max: ArrayLike, name: str = "q_max") -> NDArray[np.float64]:
    arr = np.asarray(q_max, dtype=float)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} must be 3 finite positive scales [bending, shear, axial]; got {q_max!r}")
    return arr


def data_q_max(q: ArrayLike, fallback: ArrayLike = SEED_Q_MAX, percentile: float = 99.0) -> NDArray[np.float64]:
    """Strain scales from the data: the ``percentile`` of ``|q|`` per strain type.

    A high percentile rather than the maximum keeps a few outlying frames
    from setting the scale.  A strain that is zero throughout has no range;
    its scale falls back to ``fallback``.
    """
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    out = np.percentile(np.abs(q), percentile, axis=0)
    fallback = check_q_max(fallback, "fallback")
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
        Recordings with continuous angles (see :func:`pcs_sindy.fusion.chain_geometry.chain_poses`).
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
    if merge not in MERGE_RULES:
        raise ValueError(f"merge must be one of {MERGE_RULES}; got {merge!r}")
    q_max = check_q_max(q_max)
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
