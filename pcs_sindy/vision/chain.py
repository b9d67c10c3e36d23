"""The marker chain: which candidates are the robot's markers, and in which order.

Plain functions on candidate tables (see :mod:`pcs_sindy.vision.markers`):

* :func:`link_chains` - the chains of similar, evenly spaced markers lying
  across a common backbone in one frame, found without knowing where the
  base is (the reference frame; clutter, text and a second robot form other
  chains or none);
* :func:`chain_from_base` - order a frame's markers from the base by
  predicting each next marker from the last two (constant strain), able to
  step over one missing marker;
* :func:`track` - the fast path: match every marker of the previous frame to
  the candidate nearest its predicted position, when that is unambiguous;
* :func:`fill_gaps` - the pose of a missing marker from its neighbours
  (exact for constant strain between them; the tip continues the last
  stretch, the clamped base keeps its pose);
* :func:`frame_angles`, :func:`crossings`, :func:`zigzags` - continuous
  angles along the chain and the checks that refuse a misordered chain.

Knows nothing of dynamics; imports only the ground floor.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ..core.kinematics import se2_compose, se2_relative, segment_inverse_kinematics, segment_pose
from .markers import AREA, AXIS, LONG, SHORT

__all__ = [
    "link_chains",
    "chain_from_base",
    "track",
    "fill_gaps",
    "fillable",
    "frame_angles",
    "crossings",
    "zigzags",
    "wrap_half_pi",
]


def wrap_half_pi(a: NDArray[np.float64] | float) -> Any:
    """Wrap to [-pi/2, pi/2)."""
    return (np.asarray(a) + 0.5 * np.pi) % np.pi - 0.5 * np.pi


def _rotate(v: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def link_chains(
    cands: NDArray[np.float64],
    *,
    min_aspect: float = 1.4,
    area_ratio: float = 1.6,
    long_ratio: float = 1.4,
    max_turn: float = np.deg2rad(50.0),
    max_tilt: float = np.deg2rad(40.0),
    max_gap: float = 3.0,
) -> list[NDArray[np.intp]]:
    """Chains of markers among the candidates of one frame, longest first.

    Two candidates are linked when they look alike (area within a factor
    ``area_ratio``, long side within ``long_ratio``, both elongated), their
    long axes differ by at most ``max_turn``, the chord between them is
    within ``max_tilt`` of the backbone direction of both (markers lie
    across the robot), and they are at most ``max_gap`` long sides apart.
    Every candidate keeps the nearest link on each side of it along its
    backbone direction, and a link survives only if both ends keep it; the
    linked candidates then form paths, returned ordered end to end.
    """
    n = len(cands)
    if n < 2:
        return [np.arange(n)] if n else []
    aspect = cands[:, LONG] / np.maximum(cands[:, SHORT], 1e-9)
    ok = (aspect >= min_aspect) & (cands[:, AREA] > 0)
    idx = np.flatnonzero(ok)
    if idx.size < 2:
        return [np.array([i]) for i in idx]
    c = cands[idx]
    pts = c[:, :2]
    # candidate pairs from a k-d tree: a similar neighbour lies within max_gap * long_ratio of a candidate's own
    # long side, so specks of noise (thousands in a large noisy frame) only ever meet their few close neighbours
    near = cKDTree(pts).query_ball_point(pts, max_gap * long_ratio * c[:, LONG])
    ii = np.repeat(np.arange(len(c)), [len(x) for x in near])
    jj = np.concatenate([np.asarray(x, dtype=np.intp) for x in near]) if len(ii) else np.zeros(0, np.intp)
    off = ii != jj
    ii, jj = ii[off], jj[off].astype(np.intp)
    rel = pts[jj] - pts[ii]
    dist = np.linalg.norm(rel, axis=1)
    log_area, log_long = np.log(c[:, AREA]), np.log(c[:, LONG])
    similar = (np.abs(log_area[ii] - log_area[jj]) <= np.log(area_ratio)) & (
        np.abs(log_long[ii] - log_long[jj]) <= np.log(long_ratio)
    )
    turn = np.abs(wrap_half_pi(c[ii, AXIS] - c[jj, AXIS]))
    safe = np.where(dist > 0, dist, 1.0)
    along = (rel[:, 0] * -np.sin(c[ii, AXIS]) + rel[:, 1] * np.cos(c[ii, AXIS])) / safe  # cos to i's backbone
    back = (rel[:, 0] * np.sin(c[jj, AXIS]) - rel[:, 1] * np.cos(c[jj, AXIS])) / safe  # ... and to j's
    tilt_ok = (np.abs(along) >= np.cos(max_tilt)) & (np.abs(back) >= np.cos(max_tilt))
    reach = max_gap * np.maximum(c[ii, LONG], c[jj, LONG])
    valid = (
        similar
        & (turn <= max_turn)
        & tilt_ok
        & (dist <= reach)
        & (dist >= 0.5 * np.minimum(c[ii, SHORT], c[jj, SHORT]))
    )
    side = np.sign(along)
    pick = np.full((len(c), 2), -1)
    for s, col in ((1.0, 0), (-1.0, 1)):
        m = valid & (side == s)
        a, b, d = ii[m], jj[m], dist[m]
        o = np.lexsort((d, a))  # by candidate, nearest first
        a, b = a[o], b[o]
        first = np.r_[True, a[1:] != a[:-1]] if a.size else np.zeros(0, bool)
        pick[a[first], col] = b[first]
    adj: list[list[int]] = [[] for _ in range(len(c))]
    for i in range(len(c)):
        for j in pick[i]:
            if j >= 0 and i in pick[j] and j not in adj[i]:
                adj[i].append(int(j))
                adj[int(j)].append(i)
    seen = np.zeros(len(c), bool)
    chains = []
    for start in sorted(range(len(c)), key=lambda i: len(adj[i])):  # ends (degree <= 1) first
        if seen[start]:
            continue
        path = [start]
        seen[start] = True
        prev, cur = -1, start
        while True:
            nxt = [j for j in adj[cur] if j != prev and not seen[j]]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            seen[cur] = True
            path.append(cur)
        chains.append(idx[np.asarray(path)])
    chains.sort(key=len, reverse=True)
    return chains


def chain_from_base(
    points: NDArray[np.float64],
    axes: NDArray[np.float64],
    base: int,
    spacing: float,
    first_dir: NDArray[np.float64] | None = None,
    n_target: int | None = None,
    allow_gaps: bool = True,
    px_scale: float = 1.0,
) -> tuple[list[int | None], str | None]:
    """Order markers base -> tip by chaining; returns (order, error message or None).

    The first step takes the marker nearest to the base ahead of it (within
    60° of ``first_dir``, the rest direction in the image, when given: a
    robot curled into a full loop has its tip right next to the base).
    Every further step predicts the next centre by rotating the last chord by
    the rotation between the last two markers (exact for a constant-strain
    stretch) and takes the nearest remaining candidate; where strains jump
    (segment boundaries) and the prediction misses, it takes the nearest
    marker ahead if that one is unambiguous; where nothing lies near the
    prediction but a candidate fits the position two markers ahead, one
    missing marker is stepped over (a ``None`` in the order, with
    ``allow_gaps``).  Steps that fit no way, or where a second candidate fits
    almost as well, are refused, so a missing, merged or crossing marker is
    reported rather than silently skipped or swapped.  Chaining stops after
    ``n_target`` markers (gaps included) when given, else when no candidate
    is left.  Distances in the messages are multiplied by ``px_scale`` (the
    footage's pixels when the points come from frames decoded at a reduced
    resolution).
    """
    n = len(points)
    order: list[int | None] = [base]
    last = [base]  # the detected markers of the order, for the predictions
    left = np.ones(n, bool)
    left[base] = False
    target = n if n_target is None else n_target

    def broken(msg: str) -> tuple[list[int | None], str | None]:
        # one marker short, the two before it detected: the tip is missing (hidden or merged with clutter)
        if (
            allow_gaps
            and n_target is not None
            and len(order) == n_target - 1
            and len(order) >= 3
            and None not in order[-2:]
        ):
            return order + [None], None
        return order, msg

    while len(order) < target:
        idx = np.flatnonzero(left)
        if idx.size == 0:
            return broken(f"chaining broke after {len(order)} markers (no candidate left)")
        cur = last[-1]
        rel = points[idx] - points[cur]
        near = np.linalg.norm(rel, axis=1)
        if len(order) == 1:
            cand, dist = idx, near
            if first_dir is not None:
                ahead = np.flatnonzero(rel @ first_dir > 0.5 * near)
                if ahead.size == 0:
                    return order, "chaining broke at the base (no marker ahead of it)"
                cand, dist = idx[ahead], near[ahead]
            srt = np.argsort(dist)
            if dist[srt[0]] > 2.5 * spacing:
                return (
                    order,
                    f"chaining broke at the base (nearest marker {dist[srt[0]] * px_scale:.1f} px away, spacing "
                    f"{spacing * px_scale:.1f} px)",
                )
            if srt.size > 1 and dist[srt[1]] < 1.4 * dist[srt[0]]:
                return order, "chaining is ambiguous at the base (two markers equally near)"
            nxt = int(cand[srt[0]])
            order.append(nxt)
            last.append(nxt)
            left[nxt] = False
            continue
        prev = last[-2]
        gap_before = order[-2] is None
        turn = float(wrap_half_pi(axes[cur] - axes[prev]))
        chord = points[cur] - points[prev]
        if gap_before:
            # the chord spans two constant-strain steps: each is turned by half the span's turn
            turn *= 0.5
            chord = _rotate(chord, 0.5 * turn) / (2.0 * np.cos(0.5 * turn))
        step = float(np.linalg.norm(chord))
        pred = _rotate(chord, turn)
        dist = np.linalg.norm(rel - pred, axis=1)
        srt = np.argsort(dist)
        best = dist[srt[0]]
        fits = best <= 0.6 * step
        if fits and srt.size > 1 and dist[srt[1]] < best + 0.3 * step:
            # two candidates fit the prediction: the next marker must also be clearly the nearer one
            fits = near[srt[0]] < 0.8 * near[srt[1]]
        if fits:
            j = srt[0]
            # the spacing can shrink abruptly at a segment boundary (axial
            # strain), so a prediction one old chord long may land on the
            # marker after next: never step over a marker lying between
            gap = np.linalg.norm(rel - rel[j], axis=1)
            if np.any((near < near[j]) & (gap < near[j])):
                return order, (
                    f"chaining is ambiguous after {len(order)} markers (a marker lies between the current one "
                    "and the predicted next one)"
                )
            nxt = int(idx[j])
        else:
            nxt = -1
            pred2 = pred + _rotate(chord, 2.0 * turn)
            dist2 = np.linalg.norm(rel - pred2, axis=1)
            j2 = int(np.argmin(dist2))
            clear_gap = (
                allow_gaps
                and not gap_before
                and len(order) + 1 < target
                and dist2[j2] <= 0.5 * step
                and best > 0.8 * step
                and np.count_nonzero(dist2 <= 0.7 * step) == 1
            )
            if clear_gap:
                order.append(None)  # one marker missing here, stepped over
                nxt = int(idx[j2])
            else:
                # Strains jump at a segment boundary (shear can turn the chord by
                # tens of degrees): fall back on the nearest marker ahead of the
                # current one, if it is clearly the nearest and not far off.
                ahead = np.flatnonzero(rel @ chord > 0.0)
                if ahead.size == 0:
                    return broken(f"chaining broke after {len(order)} markers (no marker ahead)")
                by_near = ahead[np.argsort(near[ahead])]
                j = by_near[0]
                clear = by_near.size == 1 or near[by_near[1]] >= 1.4 * near[j]
                if not (clear and near[j] <= 3.0 * step and dist[j] <= 1.5 * step):
                    return broken(
                        f"chaining broke after {len(order)} markers (nearest candidate {best * px_scale:.1f} px from "
                        f"the predicted position, spacing {step * px_scale:.1f} px, no unambiguous marker ahead)"
                    )
                nxt = int(idx[j])
        order.append(nxt)
        last.append(nxt)
        left[nxt] = False
    if n_target is not None and left.any() and len(last) >= 2 and order[-1] is not None:
        # a marker-shaped candidate right where the marker after the tip would be: the chain is off by one
        # somewhere (a misjudged gap, a marker missing at the base), or the robot has more markers
        chord = points[last[-1]] - points[last[-2]]
        if order[-2] is None:
            chord = chord / 2.0
        pred = points[last[-1]] + _rotate(chord, float(wrap_half_pi(axes[last[-1]] - axes[last[-2]])))
        rest = points[left]
        if np.any(np.linalg.norm(rest - pred, axis=1) <= 0.4 * np.linalg.norm(chord)):
            return order, f"the chain continues past its {n_target} markers (a marker missed, or an extra one)"
    return order, None


def track(
    previous: NDArray[np.float64], predicted: NDArray[np.float64], points: NDArray[np.float64]
) -> NDArray[np.intp] | None:
    """Candidates matching the markers of the previous frame, or None when ambiguous.

    ``previous`` and ``predicted`` are the markers' positions (N + 1, 2) in
    the last valid frame and predicted for this one.  Each marker takes the
    single candidate within 45 % of the distance to its nearer neighbour of
    its prediction; -1 marks a marker with no candidate there.  Two
    candidates in reach, or one candidate claimed twice, make the frame
    ambiguous (None): the caller then chains it from the base.
    """
    if len(points) == 0:  # nothing in view (a blank frame): every marker lost, none ambiguous
        return np.full(len(previous), -1, dtype=np.intp)
    gaps = np.linalg.norm(np.diff(previous, axis=0), axis=1)
    reach = 0.45 * np.minimum(np.concatenate([gaps[:1], gaps]), np.concatenate([gaps, gaps[-1:]]))
    d = np.linalg.norm(predicted[:, None, :] - points[None, :, :], axis=-1)
    inside = d <= reach[:, None]
    count = inside.sum(axis=1)
    if np.any(count > 1):
        return None
    match = np.where(count == 1, np.argmax(inside, axis=1), -1)
    used = match[match >= 0]
    if used.size != np.unique(used).size:
        return None
    return match


def fillable(missing: NDArray[np.bool_], base_known: bool = False) -> bool:
    """Whether :func:`fill_gaps` can fill these missing markers.

    Interior markers need both neighbours detected, the tip the two markers
    before it, the base a known pose (it is clamped, so its last pose).
    """
    m = np.asarray(missing, bool)
    n = m.size
    inner = m[1:-1] & (m[:-2] | m[2:])
    if inner.any() or (m[0] and not base_known):
        return False
    return not (m[-1] and (n < 4 or m[-2] or m[-3]))


def fill_gaps(
    pixel_poses: NDArray[np.float64], missing: NDArray[np.bool_], base_pose: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Poses of missing markers from their neighbours, assuming constant strain between them.

    ``pixel_poses`` (N + 1, 3) are ``[u, v, phi]`` in an image frame that is a
    rotation and a scaling of the base frame, with continuous angles.  An
    interior missing marker gets the pose halfway along the constant-strain
    arc between its two neighbours (markers are equally spaced in rest arc
    length); a missing tip continues the strain of the last two markers; a
    missing base takes ``base_pose``.  See :func:`fillable`.
    """
    out = pixel_poses.copy()
    m = np.asarray(missing, bool)
    if m[0]:
        out[0] = base_pose
    i = np.flatnonzero(m[1:-1]) + 1
    if i.size:
        # the strains scale with the (unknown) rest length, the halfway pose does not
        q = segment_inverse_kinematics(se2_relative(out[i - 1], out[i + 1]), 2.0)
        out[i] = se2_compose(out[i - 1], segment_pose(q, 1.0))
    if m[-1]:
        out[-1] = se2_compose(out[-2], se2_relative(out[-3], out[-2]))
    return out


def crossings(points: NDArray[np.float64]) -> int:
    """Number of proper crossings between non-adjacent links of a polyline.

    A real robot cannot pass through itself, so the polyline through its
    ordered markers never crosses itself; a chain that does was ordered wrongly
    (typically a curled tip interleaved with the markers near the base).
    """
    a, b = points[:-1], points[1:]

    def orient(p, q, r):  # sign of the turn p -> q -> r, broadcast over link pairs
        return np.sign(
            (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])
        )

    A, B = a[:, None], b[:, None]
    C, D = a[None, :], b[None, :]
    cross = (orient(A, B, C) * orient(A, B, D) < 0) & (orient(C, D, A) * orient(C, D, B) < 0)
    i, j = np.triu_indices(len(a), k=2)  # skip a link and its neighbours
    return int(np.count_nonzero(cross[i, j]))


def zigzags(phi: NDArray[np.float64], tol: float = np.deg2rad(8.0)) -> int:
    """Number of large alternating second differences of the angles along a chain.

    Bending is piecewise constant along a PCS robot; increments that
    alternate big/small mark two interleaved stretches of the robot (a tip
    curled more than a full turn back over the base).
    """
    d2 = np.diff(phi, n=2)
    big = np.abs(d2) > tol
    return int(np.count_nonzero(big[1:] & big[:-1] & (np.sign(d2[1:]) != np.sign(d2[:-1]))))


def frame_angles(
    points: NDArray[np.float64], axes: NDArray[np.float64], phi0_hint: float | None
) -> tuple[NDArray[np.float64], int]:
    """Continuous image-frame angles phi of ordered markers, and the number of conflicts.

    phi is the angle of the long axis with the tangent ``[-sin phi, cos phi]``
    pointing towards the tip.  The base's pi-ambiguity is resolved by the
    direction to the next marker (and its 2pi one by ``phi0_hint``, the
    previous frame's value); every further marker takes the representative of
    its axis closest to its predecessor (neighbours differ by far less than
    pi/2).  A conflict is a marker whose tangent points against the chain.
    """
    chord = points[1] - points[0]
    a = axes[0]
    if -np.sin(a) * chord[0] + np.cos(a) * chord[1] < 0:
        a += np.pi
    if phi0_hint is not None:
        a += 2 * np.pi * np.round((phi0_hint - a) / (2 * np.pi))
    # phi[i - 1] equals axes[i - 1] modulo pi, so each step is the wrapped axis difference
    phi = a + np.concatenate([[0.0], np.cumsum(wrap_half_pi(np.diff(axes)))])
    nxt = np.vstack([points[1:], points[-1:]])
    prv = np.vstack([points[:1], points[:-1]])
    chords = nxt - prv
    conflicts = int(np.count_nonzero(-np.sin(phi) * chords[:, 0] + np.cos(phi) * chords[:, 1] <= 0))
    return phi, conflicts
