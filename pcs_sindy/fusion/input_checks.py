"""Plausibility checks of marker chains before fusion: marker order, duplicates and angle units.

A chain given in the wrong order (shuffled, reversed, a marker twice) or with
angles in the wrong unit is still a finite array of the right shape, and
Algorithm 1 turns it into many short segments after a long fit.  These checks
look at a subsample of frames, take medians over them (a few bad frames pass)
and say what is wrong in a fraction of a second:

* the chain is at most :data:`MAX_CHAIN_LENGTH` long (positions in metres, not millimetres);
* no two markers coincide (a duplicated marker);
* the chain does not turn back on itself between neighbouring markers (the
  arc length grows monotonically from the base, index 0, to the tip);
* each marker's angle agrees with the direction to its neighbour (angles in
  radians; milliradians and degrees are recognised and named), and the next
  marker lies ahead of it, not behind (base first, not tip first).

:func:`check_marker_chain` is run by :class:`~pcs_sindy.fusion.KinematicFusion`
on every recording it fits or transforms; position-only chains (T, N + 1, 2)
get the first two checks.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.kinematics import forward_kinematics, wrap_angle

__all__ = ["check_marker_chain", "MAX_CHECK_FRAMES", "MAX_CHAIN_LENGTH"]

#: frames (evenly subsampled) the checks look at
MAX_CHECK_FRAMES = 256
#: longest plausible marker chain [m]; longer ones are taken for positions in millimetres
MAX_CHAIN_LENGTH = 20.0
# a marker pair closer than this fraction of the median marker spacing (median over frames) is a duplicate
_DUPLICATE_FRACTION = 0.2
# neighbouring chords turning by more than 135 degrees (median over frames) mean the chain runs back
_BACKTRACK_COS = -0.7
# circular-mean mismatch [rad] (median over neighbours) between a marker's angle and the direction to the next
_ANGLE_TOLERANCE = 0.5
_UNITS = ((1e-3, "milliradians"), (np.pi / 180.0, "degrees"))


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
        (duplicated), a chain that turns back between neighbours (shuffled),
        angles that do not match the marker directions (with the unit that
        would fit, milliradians or degrees, when one does), or a chain given
        from the tip to the base.
    """
    P = np.asarray(poses, dtype=float)
    if P.ndim != 3 or P.shape[2] not in (2, 3) or P.shape[1] < 2 or P.shape[0] < 1:
        raise ValueError(f"{name} must have shape (T, N + 1, 3) or (T, N + 1, 2); got {P.shape}")
    if P.shape[0] > MAX_CHECK_FRAMES:
        P = P[np.linspace(0, P.shape[0] - 1, MAX_CHECK_FRAMES).round().astype(int)]
    xy = P[..., :2]
    chord = np.diff(xy, axis=1)
    length = np.hypot(chord[..., 0], chord[..., 1])
    # the marker spacing whatever the order: the median distance of each marker to its nearest other one
    dist = np.median(np.linalg.norm(xy[:, :, None, :] - xy[:, None, :, :], axis=-1), axis=0)
    nearest = np.min(dist + np.diag(np.full(dist.shape[0], np.inf)), axis=1)
    spacing = float(np.median(nearest))
    if not spacing > 0:
        raise ValueError(
            f"{name}: the markers do not move apart (median distance between neighbours {spacing:g} m); "
            "give the base and the markers at their measured positions"
        )
    chain_length = float(np.sum(np.median(length, axis=0)))
    if chain_length > MAX_CHAIN_LENGTH:
        raise ValueError(
            f"{name}: the marker chain is {chain_length:.4g} m long (median over frames), more than "
            f"{MAX_CHAIN_LENGTH:g} m: the positions look like millimetres (times 0.001: {1e-3 * chain_length:.4g} m); "
            "give positions in metres"
        )
    # 1. duplicates: any two markers at (almost) the same place in most frames
    close = np.argwhere(np.triu(dist < _DUPLICATE_FRACTION * spacing, k=1))
    if close.size:
        pairs = [(int(a), int(b)) for a, b in close]
        raise ValueError(
            f"{name}: markers {_pairs(pairs)} coincide (median distance "
            f"{1e3 * float(dist[tuple(close[0])]):.3g} mm against a marker spacing of {1e3 * spacing:.3g} mm): "
            "a marker is given twice; give each marker once, from the base (index 0) to the tip"
        )
    # 2. order along the chain: neighbouring chords must not point back (median over frames)
    if chord.shape[1] >= 2:
        cos = np.sum(chord[:, 1:] * chord[:, :-1], axis=-1) / np.maximum(length[:, 1:] * length[:, :-1], 1e-300)
        back = np.flatnonzero(np.median(cos, axis=0) < _BACKTRACK_COS)
        if back.size:
            pairs = [(int(i) + 1, int(i) + 2) for i in back]
            raise ValueError(
                f"{name}: the chain turns back between markers {_pairs(pairs)} (arc length not increasing "
                f"from the base in most frames, at {back.size} of {chord.shape[1] - 1} markers): the markers are "
                "not in order; order them from the base (index 0) to the tip"
            )
    if P.shape[2] == 2:
        return
    # 3. angles: radians, and the chain runs from the base to the tip
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
