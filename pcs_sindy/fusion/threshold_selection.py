"""Choosing the merge threshold: the seed's Fig. 8 trade-off and its selection rule.

* :func:`threshold_sweep` - the fused segmentation and its pose errors for
  several thresholds;
* :func:`select_threshold` - the model with the largest decrease of error per
  added segment (seed §IV-B2).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import clone
from tqdm.auto import tqdm

from ..core.metrics import distributed_errors
from ..core.trajectory import as_pose_trajectories
from .kinematic_fusion import KinematicFusion

__all__ = ["SweepRow", "threshold_sweep", "select_threshold"]


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
    if fusion is None:
        fusion = KinematicFusion()
    template = fusion
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
