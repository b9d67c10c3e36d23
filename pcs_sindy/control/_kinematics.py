"""Compiled poses of one configuration of a planar PCS segmentation: the per-step kinematics of the loop.

:meth:`pcs_sindy.core.kinematics.PlanarPCS.forward_kinematics` evaluates whole
batches with numpy; one state through it costs tens of microseconds of call
overhead, too much for a 1 kHz loop that needs the tip at every step.  This
module chains the closed forms of docs/method.md ("Conventions") for one
configuration (about a microsecond for the tip); the tests check it against
the numpy kinematics.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["tip_pose", "marker_poses", "pose_jacobian"]

_SERIES = 1e-3  # |u| below which sin(u)/u and (1 - cos u)/u use their Taylor series


@numba.njit(cache=True)
def _sinc_cosc(u: float) -> tuple[float, float]:
    if abs(u) < _SERIES:
        u2 = u * u
        return 1.0 - u2 / 6.0 + u2 * u2 / 120.0, u * (0.5 - u2 / 24.0 + u2 * u2 / 720.0)
    return math.sin(u) / u, (1.0 - math.cos(u)) / u


@numba.njit(cache=True)
def tip_pose(q: np.ndarray, lengths: np.ndarray, base: np.ndarray, out: np.ndarray) -> None:
    """Pose ``[x, y, theta]`` of the tip of full strains ``q`` (3m,) into ``out`` (3,).

    Segment ``i`` ends at ``L_i [sh S - (1 + ax) C, sh C + (1 + ax) S]`` in its start
    frame (``S = sin(u)/u``, ``C = (1 - cos u)/u``, ``u = kappa L_i``) and turns by ``u``.
    """
    x = base[0]
    y = base[1]
    th = base[2]
    for i in range(lengths.size):
        L = lengths[i]
        u = q[3 * i] * L
        S, C = _sinc_cosc(u)
        lx = L * (q[3 * i + 1] * S - (1.0 + q[3 * i + 2]) * C)
        ly = L * (q[3 * i + 1] * C + (1.0 + q[3 * i + 2]) * S)
        c = math.cos(th)
        s = math.sin(th)
        x += c * lx - s * ly
        y += s * lx + c * ly
        th += u
    out[0] = x
    out[1] = y
    out[2] = th


@numba.njit(cache=True)
def marker_poses(q: np.ndarray, lengths: np.ndarray, base: np.ndarray, s: np.ndarray, out: np.ndarray) -> None:
    """Poses (P, 3) at increasing global arc lengths ``s`` (P,) of full strains ``q`` into ``out``."""
    x = base[0]
    y = base[1]
    th = base[2]
    start = 0.0
    j = 0
    m = lengths.size
    for i in range(m):
        L = lengths[i]
        k, sh, ax = q[3 * i], q[3 * i + 1], q[3 * i + 2]
        c = math.cos(th)
        sn = math.sin(th)
        # points inside this segment (the last segment takes every point beyond, e.g. round-off at the tip)
        while j < s.size and (s[j] <= start + L or i == m - 1):
            ell = s[j] - start
            S, C = _sinc_cosc(k * ell)
            lx = ell * (sh * S - (1.0 + ax) * C)
            ly = ell * (sh * C + (1.0 + ax) * S)
            out[j, 0] = x + c * lx - sn * ly
            out[j, 1] = y + sn * lx + c * ly
            out[j, 2] = th + k * ell
            j += 1
        S, C = _sinc_cosc(k * L)
        lx = L * (sh * S - (1.0 + ax) * C)
        ly = L * (sh * C + (1.0 + ax) * S)
        x += c * lx - sn * ly
        y += sn * lx + c * ly
        th += k * L
        start += L


@numba.njit(cache=True)
def pose_jacobian(
    q: np.ndarray, lengths: np.ndarray, base: np.ndarray, s: np.ndarray, h: np.ndarray, out: np.ndarray
) -> None:
    """``d poses / d q`` (3P, 3m) by central differences with steps ``h`` (3m,) into ``out``."""
    P = s.size
    plus = np.empty((P, 3))
    minus = np.empty((P, 3))
    qq = q.copy()
    for a in range(q.size):
        qq[a] = q[a] + h[a]
        marker_poses(qq, lengths, base, s, plus)
        qq[a] = q[a] - h[a]
        marker_poses(qq, lengths, base, s, minus)
        qq[a] = q[a]
        for p in range(P):
            for c in range(3):
                out[3 * p + c, a] = (plus[p, c] - minus[p, c]) / (2.0 * h[a])
