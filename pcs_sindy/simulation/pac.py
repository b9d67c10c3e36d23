"""Planar Piecewise Affine Curvature (PAC) kinematic simulator (seed eq. 22).

One segment whose curvature is affine in arc length, ``c(s) = c0 + c1 s``,
with constant shear and axial strain.  It does not satisfy the constant-strain
assumption, which is what makes it a test of kinematic fusion.  Kinematics
only: there are no dynamics.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["PACRobot", "pac_forward_kinematics"]

_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(16)


def pac_forward_kinematics(config: ArrayLike, length: float, s: ArrayLike) -> NDArray[np.float64]:
    """Poses of a PAC segment at arc lengths ``s``.

    Parameters
    ----------
    config : array_like, shape (4,) or (T, 4)
        ``[c0, c1, sigma_sh, sigma_ax]``: curvature ``c0 + c1 s`` (1/m, 1/m²),
        shear strain and axial strain deviation from 1.
    length : float
        Rest length of the segment in metres.
    s : array_like, shape (P,)
        Arc lengths in ``[0, length]``, non-decreasing.

    Returns
    -------
    ndarray, shape (P, 3) or (T, P, 3)
        ``[x, y, theta]`` in the base frame (robot along +y at rest).

    Notes
    -----
    θ(s) = c0 s + c1 s²/2 is exact; positions integrate ``R(θ) [σ_sh, 1 + σ_ax]``
    with 16-point Gauss–Legendre quadrature on every interval between
    consecutive requested points, which is exact to round-off for the smooth,
    slowly varying integrands of a robot with |θ| of a few radians.
    """
    config = np.asarray(config, dtype=float)
    single = config.ndim == 1
    config = np.atleast_2d(config)
    if config.ndim != 2 or config.shape[1] != 4:
        raise ValueError(f"config must have shape (4,) or (T, 4) [c0, c1, sigma_sh, sigma_ax]; got {np.shape(config)}")
    if not np.all(np.isfinite(config)):
        raise ValueError("config contains NaN or inf")
    if not np.isfinite(length) or length <= 0:
        raise ValueError(f"length must be finite and > 0; got {length!r}")
    s = np.atleast_1d(np.asarray(s, dtype=float))
    if s.ndim != 1 or np.any(np.diff(s) < 0) or s[0] < 0 or s[-1] > length * (1 + 1e-12):
        raise ValueError(f"s must be non-decreasing arc lengths in [0, {length}]; got {s}")
    c0, c1, sh, ax = (config[:, k, None] for k in range(4))

    def theta(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return c0 * v + 0.5 * c1 * v * v

    edges = np.concatenate([[0.0], s])
    a, b = edges[:-1], edges[1:]
    half = 0.5 * (b - a)
    nodes = (0.5 * (a + b))[:, None] + half[:, None] * _GAUSS_NODES[None, :]  # (P, 16)
    th = theta(nodes.reshape(-1)).reshape(config.shape[0], *nodes.shape)  # (T, P, 16)
    c, sn = np.cos(th), np.sin(th)
    dx = c * sh[..., None] - sn * (1.0 + ax[..., None])
    dy = sn * sh[..., None] + c * (1.0 + ax[..., None])
    w = half[:, None] * _GAUSS_WEIGHTS[None, :]
    x = np.cumsum((dx * w).sum(-1), axis=-1)
    y = np.cumsum((dy * w).sum(-1), axis=-1)
    out = np.stack([x, y, theta(s[None, :]) * np.ones_like(x)], axis=-1)
    return out[0] if single else out


class PACRobot:
    """A one-segment PAC robot (kinematics only).

    Parameters
    ----------
    length : float
        Rest length in metres (seed: 0.15).
    """

    def __init__(self, length: float = 0.15) -> None:
        if not np.isfinite(length) or length <= 0:
            raise ValueError(f"length must be finite and > 0; got {length!r}")
        self.length = float(length)

    @property
    def total_length(self) -> float:
        return self.length

    def marker_arc_lengths(self, n_markers: int) -> NDArray[np.float64]:
        """Base and ``n_markers`` equally spaced cross-sections (last at the tip)."""
        if int(n_markers) != n_markers or n_markers < 1:
            raise ValueError(f"n_markers must be a positive integer; got {n_markers!r}")
        return np.linspace(0.0, self.length, int(n_markers) + 1)

    def forward_kinematics(self, config: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """Poses at arc lengths ``s``; see :func:`pac_forward_kinematics`."""
        return pac_forward_kinematics(config, self.length, s)
