"""Choosing the merge threshold h: the seed's Fig. 8 trade-off and the rules that pick a model from it.

Plain functions on numpy arrays (the estimator-level sweep,
:func:`pcs_sindy.fusion.kinematic_fusion.threshold_sweep`, runs
:class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion` for several thresholds and
uses the rules here):

* :class:`SweepRow` - one threshold of a sweep: segment count and pose errors;
* :func:`select_threshold` - pick a row by a rule: ``"largest_drop"``, the seed's
  largest decrease of error per added segment (seed §IV-B2), or ``"relative_drop"``,
  the largest *relative* decrease (log-error) per added segment;
* :func:`segmentation_sweep` - Algorithm 1 for many thresholds on marker chains, each
  segmentation scored by its end-pose reconstruction error (cheap: no shape fit);
* :func:`choose_threshold` - the sweep and a rule together: the ``h`` that
  ``KinematicFusion(threshold="auto")`` uses, with a record of why.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from ..core.kinematics import forward_kinematics
from ..core.metrics import distributed_errors
from .chain_geometry import segment_strains
from .merging import fuse_segments

__all__ = [
    "SweepRow",
    "SELECTION_RULES",
    "AUTO_THRESHOLDS",
    "select_threshold",
    "segmentation_sweep",
    "choose_threshold",
    "choice_from_sweep",
]

#: the rules of :func:`select_threshold` (the first is ``KinematicFusion(threshold="auto")``'s)
SELECTION_RULES = ("relative_drop", "largest_drop")

#: thresholds swept by ``threshold="auto"``: 30 values, geometric from 0.005 to 3 (every scenario's
#: segmentations appear; above 3 every robot here is one segment)
AUTO_THRESHOLDS = np.geomspace(0.005, 3.0, 30)


class SweepRow(NamedTuple):
    """One threshold of a sweep: the segmentation it gives and its pose errors."""

    h: float
    n_segments: int
    e_p_dist: float
    e_theta_dist: float


def _gains(best: dict[int, float], ns: list[int], rule: str) -> list[float]:
    """Error decrease per added segment from each model to the next larger one (``ns`` sorted)."""
    if rule == "largest_drop":
        return [(best[ns[i - 1]] - best[ns[i]]) / (ns[i] - ns[i - 1]) for i in range(1, len(ns))]
    # relative: log-error, floored far below any measurable error so that an exact model stays finite
    floor = 1e-9 * max(best.values()) + 1e-300
    log = {n: np.log(max(best[n], floor)) for n in ns}
    return [(log[ns[i - 1]] - log[ns[i]]) / (ns[i] - ns[i - 1]) for i in range(1, len(ns))]


def select_threshold(
    rows: Sequence[SweepRow | Sequence[float]], error: str = "e_p_dist", rule: str = "largest_drop"
) -> SweepRow:
    """The row of a threshold sweep chosen by ``rule``.

    The rows are reduced to one per number of segments (the one with the
    lowest error) and ordered by segment count; for each model after the
    simplest, the gain relative to the next-simpler model is

    * ``"largest_drop"`` (the seed, §IV-B2): ``(e_prev − e) / (n − n_prev)``;
    * ``"relative_drop"``: ``log(e_prev / e) / (n − n_prev)``, the factor by
      which each added segment cuts the error.  The absolute drop favours the
      first split of a many-segment robot, whose error is largest (it picks
      2 of 3 segments and 3 of 5 on this project's scenarios); the factor does not.

    The model with the largest gain is chosen (ties go to fewer segments);
    among its rows the largest threshold is returned.  With a single
    segmentation in the sweep that one is returned.

    Parameters
    ----------
    rows : sequence of SweepRow or (h, n_segments, e_p_dist, e_theta_dist)
    error : {"e_p_dist", "e_theta_dist"}
    rule : {"largest_drop", "relative_drop"}, default "largest_drop"

    Returns
    -------
    SweepRow
    """
    if error not in ("e_p_dist", "e_theta_dist"):
        raise ValueError(f"error must be 'e_p_dist' or 'e_theta_dist'; got {error!r}")
    if rule not in SELECTION_RULES:
        raise ValueError(f"rule must be one of {SELECTION_RULES}; got {rule!r}")
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
        chosen = ns[1 + int(np.argmax(_gains(best, ns, rule)))]
    candidates = [r for r in rows if r.n_segments == chosen and r[col] == best[chosen]]
    return max(candidates, key=lambda r: r.h)


def segmentation_sweep(
    chains: Sequence[ArrayLike],
    arc_lengths: ArrayLike,
    thresholds: ArrayLike,
    q_max: ArrayLike,
    min_segment_markers: int = 1,
    merge: str = "runs",
    progress: bool = False,
) -> tuple[list[SweepRow], list[NDArray[np.intp]]]:
    """Algorithm 1 (:func:`~pcs_sindy.fusion.merging.fuse_segments`) for each threshold, with its errors.

    Each distinct segmentation is scored once by the distributed pose errors
    (seed eq. 23) of its end-pose model (every segment's strains from its two
    end markers, :func:`~pcs_sindy.fusion.chain_geometry.segment_strains`)
    against the chains' markers.

    Parameters
    ----------
    chains : sequence of array_like, each (T_k, N + 1, 3)
        Marker chains in the base frame (:func:`~pcs_sindy.fusion.chain_geometry.chain_poses`).
    arc_lengths : array_like, shape (N + 1,)
    thresholds : array_like of float
        Values of ``h`` (each finite and > 0).
    q_max : array_like, shape (3,)
    min_segment_markers : int
    merge : {"runs", "closest_pair"}
    progress : bool, default False
        Show a tqdm progress bar over the thresholds.

    Returns
    -------
    rows : list of SweepRow
        One per threshold, in the given order.
    boundaries : list of ndarray of int
        The segmentation of each row (marker index of each segment's end).
    """
    hs = np.atleast_1d(np.asarray(thresholds, dtype=float))
    if hs.ndim != 1 or hs.size == 0 or not np.all(np.isfinite(hs)) or np.any(hs <= 0):
        raise ValueError(f"thresholds must be a non-empty 1-D array of finite values > 0; got {thresholds!r}")
    s = np.asarray(arc_lengths, dtype=float)
    truth = np.concatenate([np.asarray(c, dtype=float)[:, 1:, :] for c in chains], axis=0)
    cache: dict[tuple[int, ...], tuple[float, float]] = {}
    rows, bounds = [], []
    for h in tqdm(hs, desc="threshold sweep", disable=not progress, leave=False):
        b, _ = fuse_segments(chains, s, float(h), q_max, min_segment_markers, merge)
        key = tuple(int(v) for v in b)
        if key not in cache:
            q = np.concatenate([segment_strains(c, s, b) for c in chains], axis=0)
            lengths = np.diff(s[np.concatenate([[0], b])])
            est = forward_kinematics(q.reshape(q.shape[0], -1), lengths, np.clip(s[1:], 0.0, lengths.sum()))
            cache[key] = distributed_errors(est, truth)
        e_p, e_th = cache[key]
        rows.append(SweepRow(float(h), int(b.size), float(e_p), float(e_th)))
        bounds.append(b)
    return rows, bounds


def choose_threshold(
    chains: Sequence[ArrayLike],
    arc_lengths: ArrayLike,
    q_max: ArrayLike,
    *,
    rule: str = "relative_drop",
    thresholds: ArrayLike | None = None,
    min_segment_markers: int = 1,
    merge: str = "runs",
    error: str = "e_p_dist",
    progress: bool = False,
) -> tuple[float, dict[str, Any]]:
    """The merge threshold by a rule over a sweep: what ``KinematicFusion(threshold="auto")`` runs.

    :func:`segmentation_sweep` over ``thresholds``, then :func:`select_threshold`
    with ``rule``.  The chosen segmentation holds over a range of ``h``; the
    returned ``h`` is the geometric middle of that range within the sweep,
    so that the same segmentation also results from data a little different
    from the swept data (e.g. all frames when a subsample was swept).

    Parameters
    ----------
    chains, arc_lengths, q_max, min_segment_markers, merge, progress
        As for :func:`segmentation_sweep`.
    rule : {"relative_drop", "largest_drop"}, default "relative_drop"
    thresholds : array_like of float, optional
        Default :data:`AUTO_THRESHOLDS`.
    error : {"e_p_dist", "e_theta_dist"}

    Returns
    -------
    h : float
    record : dict
        ``h``, ``rule``, ``error``, ``n_segments``, ``candidates`` (a list of
        ``(n_segments, e_p_dist, e_theta_dist, h_min, h_max)`` tuples, one per
        segment count, the lowest error of each) and ``reason`` (a sentence).
    """
    hs = AUTO_THRESHOLDS if thresholds is None else np.sort(np.atleast_1d(np.asarray(thresholds, dtype=float)))
    rows, bounds = segmentation_sweep(chains, arc_lengths, hs, q_max, min_segment_markers, merge, progress)
    return choice_from_sweep(rows, bounds, rule=rule, error=error)


def choice_from_sweep(
    rows: Sequence[SweepRow], bounds: Sequence[NDArray], *, rule: str = "relative_drop", error: str = "e_p_dist"
) -> tuple[float, dict[str, Any]]:
    """The threshold and its record (see :func:`choose_threshold`) from a sweep's rows and segmentations.

    ``bounds[i]`` is the segmentation (segment end markers) that ``rows[i]`` scores;
    rows with the same segmentation form the range of ``h`` whose geometric middle is returned.
    """
    if len(rows) != len(bounds):
        raise ValueError(f"rows and bounds must pair up; got {len(rows)} rows and {len(bounds)} segmentations")
    chosen = select_threshold(rows, error=error, rule=rule)
    key = bounds[rows.index(chosen)]
    same = [r.h for r, b in zip(rows, bounds) if np.array_equal(b, key)]
    h = float(np.sqrt(min(same) * max(same)))
    col = SweepRow._fields.index(error)
    candidates = []
    for n in sorted({r.n_segments for r in rows}):
        of_n = [r for r in rows if r.n_segments == n]
        top = min(of_n, key=lambda r: r[col])
        hs_n = [r.h for r in of_n]
        candidates.append((n, top.e_p_dist, top.e_theta_dist, min(hs_n), max(hs_n)))
    unit = (lambda v: f"{1e3 * v:.3g} mm") if error == "e_p_dist" else (lambda v: f"{v:.3g} rad")
    listed = ", ".join(f"{c[0]}: {unit(c[1 if error == 'e_p_dist' else 2])}" for c in candidates)
    how = {
        "relative_drop": "the largest factor of error decrease per added segment",
        "largest_drop": "the largest error decrease per added segment (the seed's rule)",
    }[rule]
    if len(candidates) == 1:
        reason = f"every swept h gives {chosen.n_segments} segment(s) ({listed})"
    else:
        reason = f"{chosen.n_segments} segment(s): {how} among {error} of the segment counts {listed}"
    record = {
        "h": h,
        "rule": rule,
        "error": error,
        "n_segments": int(chosen.n_segments),
        "candidates": candidates,
        "reason": reason,
    }
    return h, record
