"""Planar Piecewise Constant Strain (PCS) kinematics and SE(2) pose algebra.

Conventions (docs/method.md, "Configuration"): the configuration of segment ``i`` is
``q_i = [kappa_be, sigma_sh, sigma_ax]`` where ``sigma_ax`` is the deviation
from the rest axial strain 1, so ``q = 0`` is the straight, unstretched robot
lying along the +y axis of its base frame.  Poses are ``[x, y, theta]`` with
``theta`` counter-clockwise and measured from the +y axis (the local tangent
is ``R(theta) @ [0, 1]``).

Everything is exact at zero curvature: the closed forms are written with
``sin(u)/u``, ``(1 - cos u)/u`` and ``(u/2) cot(u/2)`` evaluated through
identities that have no cancellation, and their derivatives through series
near ``u = 0``.  No epsilon is ever added to the bending strain.

This module is the ground floor of the package: of it, it imports only the sizes, masks and checks it
shares with the spatial description (``core/_segmented.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._segmented import SegmentedStrains, check_lengths

__all__ = [
    "STRAIN_NAMES",
    "SEED_Q_MAX",
    "sinc",
    "cosc",
    "half_cot",
    "sinc_prime",
    "cosc_prime",
    "se2_matrix",
    "se2_from_matrix",
    "se2_compose",
    "se2_inverse",
    "se2_relative",
    "wrap_angle",
    "segment_pose",
    "segment_inverse_kinematics",
    "forward_kinematics",
    "forward_kinematics_jacobian",
    "PlanarPCS",
]

STRAIN_NAMES: tuple[str, str, str] = ("be", "sh", "ax")
#: The seed's strain scales [bending 1/m, shear, axial]: the typical range of each strain, by which
#: kinematic fusion scales strain distances and controllers scale finite differences.
SEED_Q_MAX: tuple[float, float, float] = (60.0, 0.3, 0.3)

_SERIES_LIMIT = 0.1  # |u| below which derivative series replace the closed forms


# --------------------------------------------------------------------------
# Scalar functions that are smooth through u = 0
# --------------------------------------------------------------------------
def sinc(u: ArrayLike) -> NDArray[np.float64]:
    """``sin(u)/u`` with the value 1 at ``u = 0`` (unnormalised sinc)."""
    u = np.asarray(u, dtype=float)
    return np.sinc(u / np.pi)


def cosc(u: ArrayLike) -> NDArray[np.float64]:
    """``(1 - cos u)/u`` with the value 0 at ``u = 0``.

    Written as ``sin(u/2) * sinc(u/2)`` (from ``1 - cos u = 2 sin^2(u/2)``),
    which is free of cancellation for small ``u``.
    """
    u = np.asarray(u, dtype=float)
    return np.sin(0.5 * u) * sinc(0.5 * u)


def half_cot(u: ArrayLike) -> NDArray[np.float64]:
    """``(u/2) cot(u/2)`` with the value 1 at ``u = 0``.

    Written as ``cos(u/2) / sinc(u/2)``; singular only at ``u = ±2π`` (a full
    loop), where the inverse kinematics of a single segment is undefined.
    """
    u = np.asarray(u, dtype=float)
    return np.cos(0.5 * u) / sinc(0.5 * u)


def sinc_prime(u: ArrayLike) -> NDArray[np.float64]:
    """Derivative of :func:`sinc`: ``(u cos u - sin u)/u^2``, series near 0."""
    u = np.asarray(u, dtype=float)
    small = np.abs(u) < _SERIES_LIMIT
    us = np.where(small, u, 0.0)
    ul = np.where(small, 1.0, u)
    u2 = us * us
    series = us * (-1.0 / 3.0 + u2 * (1.0 / 30.0 + u2 * (-1.0 / 840.0 + u2 / 45360.0)))
    closed = (ul * np.cos(ul) - np.sin(ul)) / (ul * ul)
    return np.where(small, series, closed)


def cosc_prime(u: ArrayLike) -> NDArray[np.float64]:
    """Derivative of :func:`cosc`: ``(u sin u - (1 - cos u))/u^2``, series near 0."""
    u = np.asarray(u, dtype=float)
    small = np.abs(u) < _SERIES_LIMIT
    us = np.where(small, u, 0.0)
    ul = np.where(small, 1.0, u)
    u2 = us * us
    series = 0.5 + u2 * (-1.0 / 8.0 + u2 * (1.0 / 144.0 + u2 * (-1.0 / 5760.0 + u2 / 403200.0)))
    closed = (ul * np.sin(ul) - 2.0 * np.sin(0.5 * ul) ** 2) / (ul * ul)
    return np.where(small, series, closed)


# --------------------------------------------------------------------------
# SE(2) on pose vectors [x, y, theta] (seed eq. 9-10), vectorised over leading axes
# --------------------------------------------------------------------------
def _as_pose(pose: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.asarray(pose, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must have a last axis of length 3 ([x, y, theta]); got shape {arr.shape}")
    return arr


def wrap_angle(theta: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles to ``[-π, π)``."""
    theta = np.asarray(theta, dtype=float)
    return (theta + np.pi) % (2.0 * np.pi) - np.pi


def se2_matrix(pose: ArrayLike) -> NDArray[np.float64]:
    """Homogeneous 3×3 matrices of poses ``[..., 3]`` (seed eq. 10)."""
    pose = _as_pose(pose, "pose")
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    out = np.zeros(pose.shape[:-1] + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = c, -s, pose[..., 0]
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = s, c, pose[..., 1]
    out[..., 2, 2] = 1.0
    return out


def se2_from_matrix(matrix: ArrayLike) -> NDArray[np.float64]:
    """Pose vectors ``[..., 3]`` from homogeneous matrices ``[..., 3, 3]``; θ in (-π, π]."""
    matrix = np.asarray(matrix, dtype=float)
    if matrix.shape[-2:] != (3, 3):
        raise ValueError(f"matrix must have trailing shape (3, 3); got {matrix.shape}")
    theta = np.arctan2(matrix[..., 1, 0], matrix[..., 0, 0])
    return np.stack([matrix[..., 0, 2], matrix[..., 1, 2], theta], axis=-1)


def se2_compose(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """``a ∘ b``: pose ``b`` expressed in frame ``a``, mapped to ``a``'s parent.

    Angles add without wrapping so that angles stay continuous along a robot.
    Leading axes must match exactly or be broadcastable by numpy's rules.
    """
    a = _as_pose(a, "a")
    b = _as_pose(b, "b")
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, a[..., 2] + b[..., 2]], axis=-1)


def se2_inverse(a: ArrayLike) -> NDArray[np.float64]:
    """Inverse pose: ``se2_compose(a, se2_inverse(a)) == 0``."""
    a = _as_pose(a, "a")
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -(c * a[..., 0] + s * a[..., 1])
    y = -(-s * a[..., 0] + c * a[..., 1])
    return np.stack([x, y, -a[..., 2]], axis=-1)


def se2_relative(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Pose of ``b`` relative to ``a``: ``a⁻¹ ∘ b`` (seed eq. 9).

    The relative angle is ``θ_b − θ_a`` without wrapping; callers holding
    unwrapped (continuous) angles therefore get the true bending angle even
    beyond ±π.
    """
    return se2_compose(se2_inverse(a), b)


# --------------------------------------------------------------------------
# One segment: closed-form forward and inverse kinematics (seed eq. 3-4)
# --------------------------------------------------------------------------
def segment_pose(q: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
    """Pose at arc length ``s`` of one constant-strain segment, in its start frame.

    Parameters
    ----------
    q : array_like, shape (..., 3)
        Strains ``[kappa_be, sigma_sh, sigma_ax]``.
    s : array_like, shape broadcastable with ``q[..., 0]``
        Local arc length(s) in metres.

    Returns
    -------
    ndarray, shape (..., 3)
        ``[x, y, theta]`` relative to the segment's start frame.
    """
    q = _as_pose(q, "q")
    s = np.asarray(s, dtype=float)
    kappa, sh, ax = q[..., 0], q[..., 1], q[..., 2]
    u = kappa * s
    S, C = sinc(u), cosc(u)
    x = s * (sh * S - (1.0 + ax) * C)
    y = s * (sh * C + (1.0 + ax) * S)
    return np.stack(np.broadcast_arrays(x, y, u), axis=-1)


def segment_inverse_kinematics(pose: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
    """Strains of the constant-strain segment whose end pose at length ``s`` is ``pose``.

    ``pose`` is relative to the segment's start frame and its angle must be
    the unwrapped bending angle (``|θ| < 2π``).  Inverse of :func:`segment_pose`.

    Parameters
    ----------
    pose : array_like, shape (..., 3)
    s : array_like
        Segment length(s), strictly positive.

    Returns
    -------
    ndarray, shape (..., 3)
        ``[kappa_be, sigma_sh, sigma_ax]``.
    """
    pose = _as_pose(pose, "pose")
    s = np.asarray(s, dtype=float)
    if np.any(~np.isfinite(s)) or np.any(s <= 0):
        raise ValueError(f"segment length s must be finite and > 0; got {s}")
    x, y, th = pose[..., 0], pose[..., 1], pose[..., 2]
    hc = half_cot(th)
    kappa = th / s
    sh = (0.5 * th * y + x * hc) / s
    ax = (-0.5 * th * x + y * hc) / s - 1.0
    return np.stack(np.broadcast_arrays(kappa, sh, ax), axis=-1)


# --------------------------------------------------------------------------
# m segments
# --------------------------------------------------------------------------
def _check_q(q: ArrayLike, n_segments: int) -> NDArray[np.float64]:
    q = np.asarray(q, dtype=float)
    if q.ndim == 0 or q.shape[-1] != 3 * n_segments:
        raise ValueError(f"q must have a last axis of length 3 * n_segments = {3 * n_segments}; got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("q contains NaN or inf")
    return q


def _locate(s: NDArray[np.float64], lengths: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Segment index and local arc length of global arc lengths ``s``."""
    total = lengths.sum()
    tol = 1e-12 * total
    if np.any(~np.isfinite(s)) or np.any(s < -tol) or np.any(s > total + tol):
        raise ValueError(f"arc lengths s must lie in [0, {total:g}] m; got min {s.min():g}, max {s.max():g}")
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    idx = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, lengths.size - 1)
    local = np.clip(s - starts[idx], 0.0, lengths[idx])
    return idx, local


def _segment_start_poses(q: NDArray[np.float64], lengths: NDArray[np.float64], base_pose: NDArray[np.float64]):
    m = lengths.size
    qs = q.reshape(q.shape[:-1] + (m, 3))
    ends = segment_pose(qs, lengths)  # (..., m, 3)
    starts = np.empty_like(ends)
    current = np.broadcast_to(base_pose, ends.shape[:-2] + (3,)).copy()
    for i in range(m):
        starts[..., i, :] = current
        current = se2_compose(current, ends[..., i, :])
    return qs, starts


def forward_kinematics(
    q: ArrayLike,
    segment_lengths: ArrayLike,
    s: ArrayLike,
    base_pose: ArrayLike = (0.0, 0.0, 0.0),
) -> NDArray[np.float64]:
    """Poses of backbone points of an m-segment planar PCS robot.

    Parameters
    ----------
    q : array_like, shape (3m,) or (T, 3m)
        Stacked strains ``[q_1, ..., q_m]``.
    segment_lengths : array_like, shape (m,)
    s : array_like, shape (P,)
        Global arc lengths in ``[0, sum(segment_lengths)]``.
    base_pose : array_like, shape (3,)
        Pose of the base frame (default: origin, robot along +y).

    Returns
    -------
    ndarray, shape (P, 3) or (T, P, 3)
        ``[x, y, theta]`` in the base frame; θ is continuous (not wrapped).
    """
    lengths = check_lengths(segment_lengths)
    q = _check_q(q, lengths.size)
    s = np.atleast_1d(np.asarray(s, dtype=float))
    if s.ndim != 1:
        raise ValueError(f"s must be 1-D; got shape {s.shape}")
    base = _as_pose(base_pose, "base_pose").reshape(3)
    idx, local = _locate(s, lengths)
    qs, starts = _segment_start_poses(q, lengths, base)
    local_pose = segment_pose(qs[..., idx, :], local)
    return se2_compose(starts[..., idx, :], local_pose)


def forward_kinematics_jacobian(
    q: ArrayLike,
    segment_lengths: ArrayLike,
    s: ArrayLike,
    base_pose: ArrayLike = (0.0, 0.0, 0.0),
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Poses of backbone points and their Jacobian with respect to ``q``.

    Returns
    -------
    pose : ndarray, shape (..., P, 3)
    jacobian : ndarray, shape (..., P, 3, 3m)
        ``d[x, y, theta] / dq``.  Rows 0–1 are the positional Jacobian J_p,
        row 2 the orientation Jacobian J_o.
    """
    lengths = check_lengths(segment_lengths)
    q = _check_q(q, lengths.size)
    m = lengths.size
    s = np.atleast_1d(np.asarray(s, dtype=float))
    base = _as_pose(base_pose, "base_pose").reshape(3)
    idx, local = _locate(s, lengths)
    qs, starts = _segment_start_poses(q, lengths, base)
    ends = se2_compose(starts, segment_pose(qs, lengths))
    pose = se2_compose(starts[..., idx, :], segment_pose(qs[..., idx, :], local))

    lead = q.shape[:-1]
    P = s.size
    jac = np.zeros(lead + (P, 3, 3 * m))
    for j in range(m):
        # points in segment j use their own arc length, points beyond it the full L_j
        affected = idx >= j
        if not np.any(affected):
            continue
        sj = np.where(idx == j, local, lengths[j])[affected]
        qj = qs[..., j, :][..., None, :]  # (..., 1, 3)
        kappa, sh, ax = qj[..., 0], qj[..., 1], qj[..., 2]
        u = kappa * sj
        S, C = sinc(u), cosc(u)
        dS, dC = sinc_prime(u), cosc_prime(u)
        # derivatives of the local position eta_p(q_j, s_j) in segment j's start frame
        d_local = np.empty(lead + (sj.size, 2, 3))
        d_local[..., 0, 0] = sj**2 * (sh * dS - (1.0 + ax) * dC)
        d_local[..., 1, 0] = sj**2 * (sh * dC + (1.0 + ax) * dS)
        d_local[..., 0, 1] = sj * S
        d_local[..., 1, 1] = sj * C
        d_local[..., 0, 2] = -sj * C
        d_local[..., 1, 2] = sj * S
        th0 = starts[..., j, 2][..., None]
        c0, s0 = np.cos(th0), np.sin(th0)
        dp = np.empty_like(d_local)
        dp[..., 0, :] = c0[..., None] * d_local[..., 0, :] - s0[..., None] * d_local[..., 1, :]
        dp[..., 1, :] = s0[..., None] * d_local[..., 0, :] + c0[..., None] * d_local[..., 1, :]
        # distal points also swing rigidly about segment j's end when its bending angle changes
        beyond = idx[affected] > j
        if np.any(beyond):
            lever = pose[..., affected, :2] - ends[..., j, None, :2]  # (..., n, 2)
            Lj = lengths[j]
            dp[..., 0, 0] += np.where(beyond, -Lj * lever[..., 1], 0.0)
            dp[..., 1, 0] += np.where(beyond, Lj * lever[..., 0], 0.0)
        jac[..., affected, 0:2, 3 * j : 3 * j + 3] = dp
        jac[..., affected, 2, 3 * j] = sj
    return pose, jac


# --------------------------------------------------------------------------
# Kinematic model object
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class PlanarPCS(SegmentedStrains):
    """Kinematic description of a planar PCS robot.

    Parameters
    ----------
    segment_lengths : sequence of float
        Rest lengths ``L_i`` in metres, base to tip.
    active_strains : array_like of bool, shape (m, 3), optional
        Which of ``[bending, shear, axial]`` are modelled in each segment
        (default: all).  Inactive strains are held at 0.
    base_pose : sequence of float, optional
        Pose ``[x, y, theta]`` of the base frame (default: origin, along +y).
    """

    segment_lengths: tuple[float, ...]
    active_strains: NDArray[np.bool_] | None = None
    base_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    _mask: NDArray[np.bool_] = field(init=False, repr=False, compare=False)
    _n_strains = 3

    def __post_init__(self) -> None:
        self._init_strains()
        base = _as_pose(self.base_pose, "base_pose").reshape(3)
        object.__setattr__(self, "base_pose", tuple(float(v) for v in base))

    # -- sizes -----------------------------------------------------------
    @property
    def n_q(self) -> int:
        """Size of the full configuration, ``3m``."""
        return 3 * self.n_segments

    @property
    def active_mask(self) -> NDArray[np.bool_]:
        """Flat boolean mask of shape (3m,) of the modelled strains."""
        return self._mask

    def strain_names(self, active_only: bool = False) -> list[str]:
        """Names such as ``"be_1"``, ``"sh_1"``, ``"ax_1"``, ``"be_2"``, ..."""
        return self._strain_names(STRAIN_NAMES, active_only)

    # -- configuration maps ----------------------------------------------
    def to_active(self, q_full: ArrayLike) -> NDArray[np.float64]:
        """Select the modelled strains from full configurations (..., 3m)."""
        q_full = _check_q(q_full, self.n_segments)
        return q_full[..., self._mask]

    def to_full(self, q_active: ArrayLike) -> NDArray[np.float64]:
        """Embed modelled strains (..., n_active) into full configurations, zeros elsewhere."""
        q_active = np.asarray(q_active, dtype=float)
        if q_active.ndim == 0 or q_active.shape[-1] != self.n_active:
            raise ValueError(f"q_active must have a last axis of length {self.n_active}; got shape {q_active.shape}")
        out = np.zeros(q_active.shape[:-1] + (self.n_q,))
        out[..., self._mask] = q_active
        return out

    def marker_arc_lengths(self, n_markers: int) -> NDArray[np.float64]:
        """Arc lengths of the base and ``n_markers`` equally spaced cross-sections (the last at the tip)."""
        if int(n_markers) != n_markers or n_markers < 1:
            raise ValueError(f"n_markers must be a positive integer; got {n_markers!r}")
        return np.linspace(0.0, self.total_length, int(n_markers) + 1)

    # -- kinematics --------------------------------------------------------
    def forward_kinematics(self, q: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """Poses at global arc lengths ``s`` for full configurations ``q`` (..., 3m)."""
        return forward_kinematics(q, self.segment_lengths, s, self.base_pose)

    def jacobian(self, q: ArrayLike, s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Poses and their Jacobian with respect to the full ``q``; see :func:`forward_kinematics_jacobian`."""
        return forward_kinematics_jacobian(q, self.segment_lengths, s, self.base_pose)

    def inverse_kinematics(self, segment_end_poses: ArrayLike) -> NDArray[np.float64]:
        """Full strains from the poses of the segment ends in the base frame.

        Parameters
        ----------
        segment_end_poses : array_like, shape (..., m, 3) or (..., m + 1, 3)
            Poses of the ends of the m segments; when ``m + 1`` poses are given,
            the first is taken as the base pose instead of :attr:`base_pose`.
            Angles must be continuous along the robot (unwrapped).

        Returns
        -------
        ndarray, shape (..., 3m)
            Strains; inactive strains are returned as computed (not zeroed).
        """
        poses = _as_pose(segment_end_poses, "segment_end_poses")
        m = self.n_segments
        if poses.ndim < 2 or poses.shape[-2] not in (m, m + 1):
            raise ValueError(f"segment_end_poses must have shape (..., {m} or {m + 1}, 3); got {poses.shape}")
        if poses.shape[-2] == m:
            base = np.broadcast_to(np.asarray(self.base_pose), poses.shape[:-2] + (1, 3))
            poses = np.concatenate([base, poses], axis=-2)
        rel = se2_relative(poses[..., :-1, :], poses[..., 1:, :])
        q = segment_inverse_kinematics(rel, np.asarray(self.segment_lengths))
        return q.reshape(q.shape[:-2] + (3 * m,))
