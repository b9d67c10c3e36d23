"""Unlabelled markers: which one is the base, and their order along the body, per recording and per frame.

Motion-capture systems that track loose markers (not rigid bodies) give them in an
arbitrary column order that differs between files, and a tracker may swap two labels
in the middle of a recording.  :func:`order_markers` puts every frame's markers in
order along the body from the base:

* the **base** marker is the one that does not move: the least moving marker within a
  recording and, over several recordings of one set-up (e.g. static holds under different
  loads), the marker found at the same place in all of them (or given by index);
* the **order** of the others is, frame by frame, the shortest path through all markers
  starting at the base (a continuum body visits its markers in arc-length order, and no
  other order is shorter unless the body folds back within a marker spacing).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import permutations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

__all__ = ["order_markers", "find_base_marker"]

# above this many markers the shortest path is found greedily (nearest unvisited marker)
_EXHAUSTIVE_MAX = 8


def _as_recordings(positions: ArrayLike | Sequence[ArrayLike]) -> tuple[list[NDArray[np.float64]], bool]:
    single = isinstance(positions, np.ndarray) and positions.ndim == 3
    recs = [np.asarray(positions, dtype=float)] if single else [np.asarray(p, dtype=float) for p in positions]
    if not recs:
        raise ValueError("positions must be an array (T, N, D) or a non-empty list of them")
    for k, p in enumerate(recs):
        if p.ndim != 3 or p.shape[2] not in (2, 3) or p.shape[1] < 2:
            raise ValueError(f"positions[{k}] must have shape (T, N, 2 or 3) with N >= 2 markers; got {p.shape}")
        if p.shape[1:] != recs[0].shape[1:]:
            raise ValueError(f"positions[{k}] has shape {p.shape}; every recording must have {recs[0].shape[1:]}")
        if not np.any(np.all(np.isfinite(p), axis=(1, 2))) and not np.any(np.isfinite(p)):
            raise ValueError(f"positions[{k}] has no finite sample")
    return recs, single


def find_base_marker(positions: ArrayLike | Sequence[ArrayLike]) -> list[int]:
    """Column of the base marker in each recording: the marker that stays put.

    Within a recording the score of a marker is how much it moves (median distance from its
    median position); over several recordings it adds, for each other recording, the distance to the
    nearest marker there (the base is at the same place in all of them, the other markers
    move with the load).  The marker of least score is the base.

    Parameters
    ----------
    positions : array_like (T, N, D) or sequence of them
        One or more recordings of one set-up, markers in any order.

    Returns
    -------
    list of int
        The base marker's column in each recording.
    """
    recs, _ = _as_recordings(positions)
    medians = [np.nanmedian(p, axis=0) for p in recs]  # (N, D) each
    out = []
    for r, (p, m) in enumerate(zip(recs, medians)):
        # median distance from the median position: robust to the frames where a tracker swapped labels
        score = np.nanmedian(np.linalg.norm(p - m, axis=2), axis=0)
        for r2, m2 in enumerate(medians):
            if r2 != r:
                score = score + np.nanmin(np.linalg.norm(m[:, None, :] - m2[None, :, :], axis=2), axis=1)
        if not np.any(np.isfinite(score)):
            raise ValueError(f"positions[{r}]: no marker has a finite position; cannot find the base")
        out.append(int(np.nanargmin(score)))
    return out


def _path_orders(D: NDArray[np.float64], start: NDArray[np.intp]) -> NDArray[np.intp]:
    """Per frame, the marker order (T, N) of the shortest path from ``start`` through all markers."""
    T, N, _ = D.shape
    rows = np.arange(T)
    if N <= _EXHAUSTIVE_MAX:
        perms = np.array(list(permutations(range(N - 1))), dtype=np.intp)  # orders of the non-base markers
        others = np.array([np.delete(np.arange(N), b) for b in range(N)])  # (N, N - 1)
        best = np.empty((T, N), dtype=np.intp)
        for b in np.unique(start):
            sel = np.flatnonzero(start == b)
            paths = np.concatenate([np.full((perms.shape[0], 1), b), others[b][perms]], axis=1)  # (P, N)
            length = D[sel[:, None, None], paths[None, :, :-1], paths[None, :, 1:]].sum(axis=2)  # (t, P)
            best[sel] = paths[np.argmin(length, axis=1)]
        return best
    order = np.empty((T, N), dtype=np.intp)
    order[:, 0] = start
    visited = np.zeros((T, N), dtype=bool)
    visited[rows, start] = True
    for k in range(1, N):
        d = np.where(visited, np.inf, D[rows, order[:, k - 1]])
        order[:, k] = np.argmin(d, axis=1)
        visited[rows, order[:, k]] = True
    return order


def order_markers(
    positions: ArrayLike | Sequence[ArrayLike],
    *,
    base: int | Sequence[int] | None = None,
    return_order: bool = False,
) -> (
    NDArray[np.float64]
    | list[NDArray[np.float64]]
    | tuple[NDArray[np.float64] | list[NDArray[np.float64]], list[NDArray[np.intp]]]
):
    """Unlabelled markers in order along the body from the base, per recording and per frame.

    Parameters
    ----------
    positions : array_like (T, N, D) or sequence of them
        Marker positions in any column order (and possibly swapped between frames), NaN for
        missing samples; several recordings of one set-up (e.g. static holds) as a list.
    base : int or sequence of int, optional
        The base marker's column (one for all recordings, or one per recording).  Default:
        :func:`find_base_marker` (the marker that stays put within and across recordings).
    return_order : bool, default False
        Also return, per recording, the column each ordered marker came from (T, N).

    Returns
    -------
    ordered : ndarray (T, N, D) or list of them (as ``positions`` was given)
        ``ordered[:, 0]`` is the base marker, then the others from the base to the tip.
    orders : list of ndarray (T, N) of int, only with ``return_order``

    Notes
    -----
    In every frame the base is the marker nearest the base column's median position (a
    tracker may swap labels) and the order is the shortest path from it through all markers.
    A frame with a missing marker is labelled by matching its valid markers to the
    recording's median ordered shape (least total distance).
    """
    recs, single = _as_recordings(positions)
    if base is None:
        bases = find_base_marker(recs)
    else:
        bases = [base] * len(recs) if np.ndim(base) == 0 else list(base)
        N = recs[0].shape[1]
        if len(bases) != len(recs) or any(
            isinstance(b, (bool, np.bool_)) or int(b) != b or not 0 <= int(b) < N for b in bases
        ):
            raise ValueError(
                f"base must be a marker column in [0, {N}) or one per recording ({len(recs)}); got {base!r}"
            )
        bases = [int(b) for b in bases]
    out, orders = [], []
    for p, b in zip(recs, bases):
        T, N, _ = p.shape
        complete = np.all(np.isfinite(p), axis=(1, 2))
        base_at = np.nanmedian(p[:, b], axis=0)
        start = np.argmin(np.where(np.isfinite(p[..., 0]), np.linalg.norm(p - base_at, axis=2), np.inf), axis=1)
        order = np.tile(np.arange(N), (T, 1))
        if complete.any():
            D = np.linalg.norm(p[complete][:, :, None, :] - p[complete][:, None, :, :], axis=3)
            order[complete] = _path_orders(D, start[complete])
            rows = np.flatnonzero(complete)
            shape = np.nanmedian(p[rows[:, None], order[complete]], axis=0)  # (N, D) the median ordered shape
        else:
            shape = np.nanmedian(p, axis=0)
        for t in np.flatnonzero(~complete):
            valid = np.flatnonzero(np.all(np.isfinite(p[t]), axis=1))
            slots = np.arange(N)
            if valid.size:
                cost = np.linalg.norm(p[t, valid][:, None, :] - shape[None, :, :], axis=2)
                vi, si = linear_sum_assignment(cost)
                taken = np.full(N, -1)
                taken[si] = valid[vi]
                rest = [c for c in range(N) if c not in set(valid[vi])]
                taken[taken < 0] = rest  # missing markers fill the free slots (they stay NaN)
                order[t] = taken
            else:
                order[t] = slots
        out.append(np.take_along_axis(p, order[:, :, None], axis=1))
        orders.append(order)
    result = out[0] if single else out
    return (result, orders) if return_order else result
