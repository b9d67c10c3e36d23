"""Plausibility checks of marker chains before fusion: marker order, swaps, duplicates, units.

A chain given in the wrong order (shuffled, reversed, a marker twice, two
labels swapped part-way), in millimetres or with angles in the wrong unit is
still a finite array of the right shape, and the fusion turns it into many
short segments (or a robot hundreds of metres long) after a long fit.  These
checks say what is wrong in a fraction of a second.  Medians over a subsample
of frames (a few bad frames pass) judge the chain as a whole:

* the chain is at most :data:`MAX_CHAIN_LENGTH` long (positions in metres, not millimetres);
* no two markers coincide (a duplicated marker);
* the chain does not turn back on itself between neighbouring markers (the
  arc length grows monotonically from the base to the tip);

and every frame is looked at for a pair of neighbouring markers in the wrong
order (a tracker that swaps two labels for part of a recording): a chord that
turns back by more than 135 degrees against the chain in more than
:data:`SWAP_FRACTION` of the frames is refused, naming the markers and frames.

Poses (:func:`check_marker_chain`) add: each marker's angle agrees with the
direction to its neighbour (angles in radians; milliradians and degrees are
recognised and named), and the next marker lies ahead of it, not behind
(base first, not tip first).

Positions only (:func:`check_marker_positions`, motion capture without
orientations or base) add: at least :data:`MIN_POSITION_MARKERS` markers; the
first marker moves less than the last (a clamped robot moves most at its tip:
base first, not tip first); and given rest arc lengths are in metres, at most
:data:`MAX_CHAIN_LENGTH`, and consistent with the distances between the markers.

:class:`~pcs_sindy.fusion.KinematicFusion` runs them on every recording it
fits or transforms.  This module knows arrays only: no files, no fitting.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import forward_kinematics, wrap_angle

__all__ = [
    "check_marker_chain",
    "check_marker_positions",
    "check_arc_lengths",
    "MAX_CHECK_FRAMES",
    "MAX_CHAIN_LENGTH",
    "LONG_CHAIN_WARNING",
    "MIN_POSITION_MARKERS",
    "SWAP_FRACTION",
]

#: frames (evenly subsampled) the median checks look at
MAX_CHECK_FRAMES = 256
#: longest plausible marker chain [m]; longer ones are taken for positions in millimetres
MAX_CHAIN_LENGTH = 20.0
#: longer marker chains (or arc lengths) [m] are fused with a warning: positions in centimetres?
LONG_CHAIN_WARNING = 3.0
#: fewest markers along the body a positions-only fusion accepts (docs/mocap.md: 2-5)
MIN_POSITION_MARKERS = 2
#: fraction of the frames (and at least 3) in which two neighbouring markers may be in the wrong order
SWAP_FRACTION = 0.05
# a marker pair closer than this fraction of the median marker spacing (median over frames) is a duplicate
_DUPLICATE_FRACTION = 0.2
# neighbouring chords turning by more than 135 degrees mean the chain runs back
_BACKTRACK_COS = -0.7
# circular-mean mismatch [rad] (median over neighbours) between a marker's angle and the direction to the next
_ANGLE_TOLERANCE = 0.5
_UNITS = ((1e-3, "milliradians"), (np.pi / 180.0, "degrees"))
_LENGTH_UNITS = ((1e-3, "millimetres"), (1e-2, "centimetres"))
# the first marker moving more than this many times as much as the last: the chain is given tip first
_TIP_FIRST_RATIO = 2.0
# ... by more than this many noise levels (static holds move by their noise only)
_TIP_FIRST_NOISE = 10.0
# the markers' largest first-to-last distance over their arc-length difference: outside this range the
# arc lengths and the positions are in different units (a robot curled to this ratio in 95 % of its frames
# is bent by over 300 degrees; one stretched beyond it is no bending-only robot)
_REACH_RANGE = (0.25, 2.0)
_CHUNK = 20000  # frames per block of the per-frame check (bounds its memory)


def _forward_direction() -> float:
    """Angle of the robot's tangent in its own frame (the package's pose convention)."""
    tip = forward_kinematics(np.zeros((1, 3)), [1.0], np.array([0.0, 1.0]))[0, 1]
    return float(np.arctan2(tip[1], tip[0]))


def _angle_mismatch(xy: np.ndarray, theta: np.ndarray, forward: float) -> np.ndarray:
    """Per frame and neighbour pair: direction to the next marker, in the marker's frame, minus the expected one.

    For a constant-strain piece between two markers the chord leaves marker
    ``i`` at half the bending angle to the next marker (plus the shear angle).
    """
    chord = np.diff(xy, axis=1)
    direction = np.arctan2(chord[..., 1], chord[..., 0])
    dtheta = wrap_angle(np.diff(theta, axis=1))
    return wrap_angle(direction - theta[:, :-1] - forward - 0.5 * dtheta)


def _angle_error(mismatch: np.ndarray) -> float:
    """Median over neighbour pairs of the circular-mean mismatch over frames (pi when it has no direction).

    Position noise averages out of the circular mean; a mismatch that turns
    with the motion (angles in another unit) has a short mean vector and
    counts as pi.
    """
    z = np.mean(np.exp(1j * mismatch), axis=0)
    per_pair = np.where(np.abs(z) >= 0.3, np.abs(np.angle(z)), np.pi)
    return float(np.median(per_pair))


def _pairs(pairs: list[tuple[int, int]], limit: int = 5) -> str:
    shown = ", ".join(f"{a} and {b}" for a, b in pairs[:limit])
    return shown + (f" (and {len(pairs) - limit} more)" if len(pairs) > limit else "")


def _nanmedian(a: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    with warnings.catch_warnings():  # an all-missing column is NaN, and says so itself
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(a, axis=axis)


def _subsample(P: NDArray[np.float64]) -> NDArray[np.float64]:
    if P.shape[0] > MAX_CHECK_FRAMES:
        P = P[np.linspace(0, P.shape[0] - 1, MAX_CHECK_FRAMES).round().astype(int)]
    return P


def _unit_hint(factor: float, what: str) -> str:
    """``"look like millimetres (times 0.001: ...)"`` when ``factor`` is near a unit's; else ``""``."""
    for scale, unit in _LENGTH_UNITS:
        if 0.5 < factor * scale < 2.0:
            return f"{what} look like {unit} (times {scale:g} they would fit); "
    return ""


def _warn_long(what: str, fix: str) -> None:
    warnings.warn(
        f"{what}, more than {LONG_CHAIN_WARNING:g} m for a soft robot: if the lengths are in centimetres or "
        f"millimetres, {fix}",
        UserWarning,
        stacklevel=4,
    )


def _check_chain(xy: NDArray[np.float64], name: str, first: str, fix: str, units: str) -> None:
    """Length, duplicates, order (medians over frames) and per-frame swaps of a chain (T, N, D), NaN allowed.

    ``first`` says what index 0 is, ``fix`` how to relabel markers, ``units`` how to give metres.
    """
    sub = _subsample(xy)
    length = np.linalg.norm(np.diff(sub, axis=1), axis=-1)
    # the marker spacing whatever the order: the median distance of each marker to its nearest other one
    dist = _nanmedian(np.linalg.norm(sub[:, :, None, :] - sub[:, None, :, :], axis=-1), axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        nearest = np.nanmin(np.where(np.eye(dist.shape[0], dtype=bool), np.inf, dist), axis=1)
    # markers at one place are duplicates (named below), not the spacing
    apart = nearest[np.isfinite(nearest) & (nearest > 0)]
    spacing = float(np.median(apart)) if apart.size else 0.0
    if not spacing > 0:
        raise ValueError(
            f"{name}: the markers do not move apart (median distance between neighbours {spacing:g} m); "
            "give the markers at their measured positions"
        )
    chain_length = float(np.nansum(_nanmedian(length, axis=0)))
    if chain_length > MAX_CHAIN_LENGTH:
        raise ValueError(
            f"{name}: the marker chain is {chain_length:.4g} m long (median over frames), more than "
            f"{MAX_CHAIN_LENGTH:g} m: the positions look like millimetres (times 0.001: {1e-3 * chain_length:.4g} m); "
            f"{units}"
        )
    if chain_length > LONG_CHAIN_WARNING:
        _warn_long(f"{name}: the marker chain is {chain_length:.4g} m long (median over frames)", units)
    # 1. duplicates: any two markers at (almost) the same place in most frames
    close = np.argwhere(np.triu(dist < _DUPLICATE_FRACTION * spacing, k=1))
    if close.size:
        pairs = [(int(a), int(b)) for a, b in close]
        raise ValueError(
            f"{name}: markers {_pairs(pairs)} coincide (median distance "
            f"{1e3 * float(dist[tuple(close[0])]):.3g} mm against a marker spacing of {1e3 * spacing:.3g} mm): "
            f"a marker is given twice; give each marker once, from {first} to the tip"
        )
    # 2. order along the chain: neighbouring chords must not point back (median over frames)
    chord = np.diff(sub, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.sum(chord[:, 1:] * chord[:, :-1], axis=-1) / (length[:, 1:] * length[:, :-1])
    back = np.flatnonzero(_nanmedian(cos, axis=0) < _BACKTRACK_COS) if xy.shape[1] > 2 else np.zeros(0, int)
    if back.size:
        pairs = [(int(i) + 1, int(i) + 2) for i in back]
        raise ValueError(
            f"{name}: the chain turns back between markers {_pairs(pairs)} (arc length not increasing "
            f"from {first} in most frames, at {back.size} of {chord.shape[1] - 1} markers): the markers are "
            f"not in order; order them from {first} to the tip"
        )
    # 3. a pair in the wrong order or at one place in some frames only (a tracker swapping two labels part-way)
    _check_frames(xy, name, fix, spacing)


def _bad_chords(xy: NDArray[np.float64], spacing: float) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray]:
    """Per frame and chord (T, N - 1): the chord runs back along the chain; its markers coincide; frames judged.

    A chord runs back when it turns by more than 135 degrees from a neighbouring chord and points against
    the chain there (from the marker before it to the one after it: of the two chords at a sharp turn, the
    one that goes back); its
    two markers coincide when it is shorter than a fifth of the chain's marker spacing.
    """
    chord = np.diff(xy, axis=1)
    length = np.linalg.norm(chord, axis=-1)
    judged = np.all(np.isfinite(length), axis=1)
    close = (length < _DUPLICATE_FRACTION * spacing) & judged[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = chord / length[..., None]
        turn = np.sum(unit[:, 1:] * unit[:, :-1], axis=-1) < _BACKTRACK_COS
        # the way the chain runs locally: from the marker before the chord to the one after it
        n = xy.shape[1]
        span = xy[:, np.minimum(np.arange(n - 1) + 2, n - 1)] - xy[:, np.maximum(np.arange(n - 1) - 1, 0)]
        against = np.sum(chord * span, axis=-1) < 0
    sharp = np.zeros(length.shape, dtype=bool)
    sharp[:, 1:] |= turn
    sharp[:, :-1] |= turn
    return sharp & against & judged[:, None] & ~close, close, judged


def _frame_ranges(frames: NDArray[np.intp], limit: int = 4) -> str:
    """``"120-199, 240"``: runs of consecutive frames (the first few)."""
    cuts = np.flatnonzero(np.diff(frames) > 1) + 1
    runs = [(int(r[0]), int(r[-1])) for r in np.split(frames, cuts)]
    shown = ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in runs[:limit])
    return shown + (f" (and {len(runs) - limit} more runs)" if len(runs) > limit else "")


def _check_frames(xy: NDArray[np.float64], name: str, fix: str, spacing: float) -> None:
    """Refuse a chain with two neighbouring markers in the wrong order, or at one place, in many frames.

    Many: at least 3 and :data:`SWAP_FRACTION` of the frames judged (every marker present).
    """
    T = xy.shape[0]
    counts = np.zeros((2, xy.shape[1] - 1), dtype=int)
    n_judged = 0
    for a in range(0, T, _CHUNK):
        back, close, judged = _bad_chords(xy[a : a + _CHUNK], spacing)
        counts += np.stack([back.sum(axis=0), close.sum(axis=0)])
        n_judged += int(judged.sum())
    bad = np.argwhere(counts >= max(3.0, SWAP_FRACTION * n_judged))
    if not bad.size:
        return
    kind, j = (int(v) for v in bad[np.argmax(counts[tuple(bad.T)])])
    frames = np.concatenate(
        [a + np.flatnonzero(_bad_chords(xy[a : a + _CHUNK], spacing)[kind][:, j]) for a in range(0, T, _CHUNK)]
    )
    others = [(int(i), int(i) + 1) for k, i in bad if (k, i) != (kind, j)]
    where = f"in {int(counts[kind, j])} of {n_judged} frames, frames {_frame_ranges(frames)}" + (
        f"; also markers {_pairs(others)}" if others else ""
    )
    if kind == 0:
        raise ValueError(
            f"{name}: markers {j} and {j + 1} are in the wrong order (the chain turns back between them) {where}: "
            f"two markers swap places part-way through the recording; {fix}"
        )
    raise ValueError(
        f"{name}: markers {j} and {j + 1} coincide (closer than {1e3 * _DUPLICATE_FRACTION * spacing:.3g} mm, a "
        f"fifth of the marker spacing {1e3 * spacing:.3g} mm) {where}: one marker stands for both there (merged, "
        f"or one lost); {fix}"
    )


def check_marker_chain(poses: ArrayLike, name: str = "poses") -> None:
    """Refuse marker chains in the wrong order, with a marker twice or in the wrong units.

    Parameters
    ----------
    poses : array_like, shape (T, N + 1, 3) or (T, N + 1, 2)
        Base (index 0) then the markers towards the tip: ``x, y`` [m] and,
        with three columns, the angle [rad].  Finite (checked before).
    name : str
        Named in the messages (e.g. ``"X[2]"``).

    Raises
    ------
    ValueError
        Naming the markers concerned and the fix: a chain longer than
        :data:`MAX_CHAIN_LENGTH` (positions in millimetres), markers that coincide
        (duplicated), a chain that turns back between neighbours (shuffled), two
        neighbouring markers in the wrong order in more than :data:`SWAP_FRACTION`
        of the frames (labels swapped part-way, naming the frames), angles that do
        not match the marker directions (with the unit that would fit, milliradians
        or degrees, when one does), or a chain given from the tip to the base.
    """
    P = np.asarray(poses, dtype=float)
    if P.ndim != 3 or P.shape[2] not in (2, 3) or P.shape[1] < 2 or P.shape[0] < 1:
        raise ValueError(f"{name} must have shape (T, N + 1, 3) or (T, N + 1, 2); got {P.shape}")
    _check_chain(
        P[..., :2],
        name,
        first="the base (index 0)",
        fix="correct the tracking in those frames (or leave them out)",
        units="give positions in metres",
    )
    if P.shape[2] == 2:
        return
    # 4. angles: radians, and the chain runs from the base to the tip
    P = _subsample(P)
    xy = P[..., :2]
    forward = _forward_direction()
    theta = P[..., 2]
    err = _angle_error(_angle_mismatch(xy, theta, forward))
    if err <= _ANGLE_TOLERANCE:
        return
    if _angle_error(_angle_mismatch(xy, theta, forward + np.pi)) <= _ANGLE_TOLERANCE:
        raise ValueError(
            f"{name}: each marker lies behind the next one (the chain is given from the tip to the base); "
            "reverse the markers so that index 0 is the base and the last one the tip"
        )
    fits = sorted(
        (e, scale, unit)
        for scale, unit in _UNITS
        if (e := _angle_error(_angle_mismatch(xy, theta * scale, forward))) <= _ANGLE_TOLERANCE
    )
    hint = (
        f"they look like {fits[0][2]} (times {fits[0][1]:.6g} they fit, mismatch {fits[0][0]:.2g} rad); "
        if fits
        else ""
    )
    raise ValueError(
        f"{name}: the marker angles do not match the directions between neighbouring markers (mismatch "
        f"{err:.2g} rad; in radians it is below {_ANGLE_TOLERANCE} for a continuum robot, max |angle| "
        f"{float(np.max(np.abs(theta))):.4g}): {hint}give the angles in radians (column 2 of the poses)"
    )


def _motion(P: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per marker: RMS distance from its mean position, and the noise level of its track (second differences)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        spread = np.sqrt(np.nanmean(np.sum((P - np.nanmean(P, axis=0)) ** 2, axis=-1), axis=0))
        d2 = np.linalg.norm(np.diff(P, n=2, axis=0), axis=-1) if P.shape[0] > 2 else np.full(P.shape[:2], np.nan)
        # |second difference| of white noise: sigma sqrt(6) per coordinate
        noise = np.nanmedian(d2, axis=0) / np.sqrt(6.0 * P.shape[2])
    return spread, noise


def check_marker_positions(
    positions: ArrayLike | Sequence[ArrayLike],
    arc_lengths: ArrayLike | None = None,
    name: str = "X",
) -> None:
    """Refuse positions-only marker recordings that are not a chain from the base to the tip in metres.

    Parameters
    ----------
    positions : array_like (T, N, D) or sequence of them (one per recording of one set-up)
        Marker positions [m] (``D`` = 2 or 3), ordered from the marker nearest the base
        (the base itself not included) to the tip; NaN for missing samples.
    arc_lengths : array_like, shape (N,), optional
        The markers' rest arc lengths from the base [m], when given.
    name : str
        Named in the messages (recording ``k`` as ``name[k]``).

    Raises
    ------
    ValueError
        Naming the recording, the markers or frames concerned and the fix: fewer than
        :data:`MIN_POSITION_MARKERS` markers; a chain longer than :data:`MAX_CHAIN_LENGTH`
        (positions in millimetres); markers that coincide; a chain that turns back
        (shuffled) in most frames, or between two neighbouring markers in more than
        :data:`SWAP_FRACTION` of the frames (labels swapped part-way); a first marker
        that moves more than twice as much as the last (tip first); arc lengths beyond
        :data:`MAX_CHAIN_LENGTH` or not matching the distances between the markers
        (another unit).
    """
    single = isinstance(positions, np.ndarray) and positions.ndim == 3
    recs = [np.asarray(positions, dtype=float)] if single else [np.asarray(p, dtype=float) for p in positions]
    units = (
        "give positions in metres (read_marker_csv(..., units='mm') or 'pcs-sindy fuse --units mm' "
        "for a file in millimetres)"
    )
    for k, P in enumerate(recs):
        rec = name if single else f"{name}[{k}]"
        if P.ndim != 3 or P.shape[2] not in (2, 3):
            raise ValueError(f"{rec} must have shape (T, N, 2) or (T, N, 3); got {P.shape}")
        if P.shape[1] < MIN_POSITION_MARKERS:
            raise ValueError(
                f"{rec}: {P.shape[1]} marker(s); positions-only fusion needs at least {MIN_POSITION_MARKERS} markers "
                "along the body (2-5, docs/mocap.md; a recorded base marker does not count): with one marker the "
                "base's distance and the bending are not told apart; track more markers, or give their poses"
            )
        _check_chain(
            P,
            rec,
            first="the marker nearest the base (index 0)",
            fix="relabel the markers frame by frame (pcs_sindy.core.order_markers) or leave those frames out",
            units=units,
        )
    # base first: a clamped robot moves most at its tip (over all recordings: static holds differ by their loads)
    spread, noise = _motion(np.concatenate(recs, axis=0))
    level = float(np.nanmax([noise[0], noise[-1], 0.0]))
    if spread[0] > _TIP_FIRST_RATIO * spread[-1] and spread[0] - spread[-1] > _TIP_FIRST_NOISE * level:
        raise ValueError(
            f"{name}: the first marker moves {1e3 * spread[0]:.3g} mm (RMS about its mean position) and the last "
            f"only {1e3 * spread[-1]:.3g} mm, but a robot clamped at its base moves most at its tip: the markers look "
            "given from the tip to the base; reverse them so that index 0 is the marker nearest the base"
        )
    if arc_lengths is not None:
        check_arc_lengths(recs, arc_lengths)


def check_arc_lengths(positions: Sequence[ArrayLike], arc_lengths: ArrayLike, arcs_name: str = "arc_lengths") -> None:
    """Refuse marker rest arc lengths in another unit than the positions, or longer than a soft robot.

    Parameters
    ----------
    positions : sequence of array_like (T, N, D)
        Marker positions [m] of the recordings, base to tip; NaN for missing samples.
    arc_lengths : array_like, shape (N,)
        The markers' rest arc lengths from the base [m].
    arcs_name : str, default "arc_lengths"
        What they are called in the messages (e.g. ``"the fitted marker arc lengths"``).

    Raises
    ------
    ValueError
        The last arc length beyond :data:`MAX_CHAIN_LENGTH` (millimetres), or the first-to-last
        arc-length difference not within 1/4 to 2 times the markers' largest distance (95th
        percentile over frames): another unit, other markers, or markers out of order.
        Beyond :data:`LONG_CHAIN_WARNING` a warning asks for the unit.
    """
    recs = [np.asarray(p, dtype=float) for p in positions]
    s = np.asarray(arc_lengths, dtype=float).reshape(-1)
    give = "give them in metres (PoseTrajectory.from_positions(arc_lengths=...), 'pcs-sindy fuse --arc-lengths')"
    if s.size >= 2:  # first the distances between the markers: they tell the unit
        P = np.concatenate(recs, axis=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            reach = float(np.nanpercentile(np.linalg.norm(P[:, -1] - P[:, 0], axis=-1), 95.0))
        arc = float(s[-1] - s[0])
        ratio = reach / arc
        if not _REACH_RANGE[0] <= ratio <= _REACH_RANGE[1]:
            raise ValueError(
                f"{arcs_name} {np.round(s, 6).tolist()} put the first and the last marker {arc:.4g} m apart along "
                f"the body, but they are at most {reach:.4g} m apart (95th percentile over frames; a robot at rest "
                f"has them about its arc length apart): {_unit_hint(1.0 / ratio, 'the arc lengths')}the arc "
                "lengths and the positions are in different units, or the arc lengths belong to other markers, or "
                f"the markers are not in order; {give}, for these markers"
            )
    if s.size and s[-1] > MAX_CHAIN_LENGTH:
        raise ValueError(
            f"{arcs_name}: the last marker {s[-1]:.4g} m from the base, more than {MAX_CHAIN_LENGTH:g} m for a "
            f"soft robot: the arc lengths look like millimetres (times 0.001: {1e-3 * s[-1]:.4g} m); {give}"
        )
    if s.size and s[-1] > LONG_CHAIN_WARNING:
        _warn_long(f"{arcs_name}: the last marker {s[-1]:.4g} m from the base", give)
