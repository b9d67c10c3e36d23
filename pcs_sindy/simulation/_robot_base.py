"""What the planar and the spatial ground-truth robots share: argument checks and the terms built on ``_bias``.

:class:`RobotBase` holds the methods of :class:`~pcs_sindy.simulation.PCSRobot` and
:class:`~pcs_sindy.simulation.SpatialPCSRobot` whose code does not depend on the kinematics: the
checks of the material, damping and gravity arguments, the input checks, the elastic and damping
forces, the energies built on ``mass_matrix`` and ``gravitational_energy``, and the inverse and
forward dynamics built on ``_bias``.  The subclasses set ``_gravity_shape``, ``n_segments``,
``n_q``, ``segment_lengths``, ``n_inputs`` and ``stiffness``, and supply ``mass_matrix``,
``gravitational_energy`` and ``_bias``.  This module must not know either robot's geometry or
kernels.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["RobotBase", "finite_array", "per_segment_values", "positive_int"]


def per_segment_values(value: ArrayLike, m: int, name: str, *, positive: bool) -> NDArray[np.float64]:
    """``value`` as a finite array of shape (m,) (a scalar repeated), > 0 (``positive``) or >= 0."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(m, float(arr))
    if arr.shape != (m,):
        raise ValueError(f"{name} must be a scalar or have shape ({m},) (one per segment); got shape {arr.shape}")
    bad = ~np.isfinite(arr) | ((arr <= 0) if positive else (arr < 0))
    if np.any(bad):
        cond = "> 0" if positive else ">= 0"
        raise ValueError(f"{name} must be finite and {cond}; got {arr.tolist()}")
    return arr


def finite_array(value: ArrayLike, shape: tuple[int, ...], name: str) -> NDArray[np.float64]:
    """``value`` as a float array of exactly ``shape`` with finite entries."""
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}; got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite; got {arr.tolist()}")
    return arr


def positive_int(value: Any, name: str) -> int:
    """``value`` as an int >= 1 (bools and non-integral numbers refused)."""
    if isinstance(value, bool) or int(value) != value or value < 1:
        raise ValueError(f"{name} must be a positive integer; got {value!r}")
    return int(value)


class RobotBase:
    """Methods shared by the planar and spatial robots (see the module docstring for the contract)."""

    _gravity_shape: tuple[int, ...]  # (2,) in the plane, (3,) in space
    n_segments: int
    n_q: int
    n_inputs: int
    segment_lengths: NDArray[np.float64]
    stiffness: NDArray[np.float64]
    damping: NDArray[np.float64]

    # -- construction -------------------------------------------------------------
    def _set_material(
        self,
        density: float | ArrayLike,
        youngs_modulus: float | ArrayLike,
        shear_modulus: float | ArrayLike,
        damping: ArrayLike,
        radius: float | ArrayLike,
        gravity: ArrayLike,
        shear_factor: float,
        stiffness_scaling: str,
    ) -> NDArray[np.float64]:
        """Check and store the material, damping and gravity arguments (``n_segments``, ``n_q`` and
        ``segment_lengths`` already set); return the stiffness factors ``f_L`` (m,)."""
        m = self.n_segments
        self.density = per_segment_values(density, m, "density", positive=True)
        self.youngs_modulus = per_segment_values(youngs_modulus, m, "youngs_modulus", positive=False)
        self.shear_modulus = per_segment_values(shear_modulus, m, "shear_modulus", positive=False)
        self.radius = per_segment_values(radius, m, "radius", positive=True)
        damping_arr = finite_array(damping, (self.n_q,), "damping")
        if np.any(damping_arr < 0):
            raise ValueError(f"damping must be >= 0; got {damping_arr.tolist()}")
        self.damping = damping_arr
        self.gravity = finite_array(gravity, self._gravity_shape, "gravity")
        if not (np.isfinite(shear_factor) and shear_factor > 0):
            raise ValueError(f"shear_factor must be finite and > 0; got {shear_factor!r}")
        self.shear_factor = float(shear_factor)
        if stiffness_scaling not in ("seed", "length"):
            raise ValueError(f"stiffness_scaling must be 'seed' or 'length'; got {stiffness_scaling!r}")
        self.stiffness_scaling = stiffness_scaling
        self.area = np.pi * self.radius**2
        self.second_moment = np.pi * self.radius**4 / 4.0
        return np.ones(m) if stiffness_scaling == "seed" else self.segment_lengths

    # -- input checks -----------------------------------------------------------
    def _check(
        self, name: str, value: ArrayLike, like: NDArray | None = None, size: int | None = None
    ) -> NDArray[np.float64]:
        size = self.n_q if size is None else size
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] != size:
            what = "n_q" if size == self.n_q and name != "u" else "p (the number of inputs)"
            raise ValueError(f"{name} must have a last axis of length {what} = {size}; got shape {arr.shape}")
        if like is not None and arr.shape[:-1] != like.shape[:-1]:
            raise ValueError(f"{name} must have the leading shape of q, {like.shape[:-1]}; got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
        return arr

    def _flatten(self, *arrays: NDArray) -> tuple[tuple[int, ...], list[NDArray]]:
        lead = arrays[0].shape[:-1]
        return lead, [np.ascontiguousarray(a.reshape((-1, a.shape[-1]))) for a in arrays]

    # -- terms every robot builds the same way ---------------------------------------
    def elastic_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """Elastic forces ``K q``, shape (..., n)."""
        return self._check("q", q) * self.stiffness

    def damping_forces(self, qd: ArrayLike) -> NDArray[np.float64]:
        """Damping forces ``D q̇``, shape (..., n)."""
        return self._check("qd", qd) * self.damping

    def potential_energy(self, q: ArrayLike) -> NDArray[np.float64]:
        """``U_g + ½ qᵀ K q``, shape (...)."""
        q = self._check("q", q)
        return self.gravitational_energy(q) + 0.5 * np.sum(self.stiffness * q * q, axis=-1)

    def kinetic_energy(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """``½ q̇ᵀ M(q) q̇``, shape (...)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        return 0.5 * np.einsum("...a,...ab,...b->...", qd, self.mass_matrix(q), qd)

    def total_energy(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Kinetic plus potential energy, shape (...)."""
        return self.kinetic_energy(q, qd) + self.potential_energy(q)

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Generalised forces ``τ = M q̈ + C q̇ + G + K q + D q̇``, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        qdd = self._check("qdd", qdd, q)
        lead, (qf, qdf, qddf) = self._flatten(q, qd, qdd)
        M, bias = self._bias(qf, qdf)
        return (np.einsum("bij,bj->bi", M, qddf) + bias).reshape(lead + (self.n_q,))

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> NDArray[np.float64]:
        """Accelerations ``q̈ = M⁻¹ (τ − C q̇ − G − K q − D q̇)`` under generalised forces τ, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        tau = self._check("tau", tau, q)
        lead, (qf, qdf, tauf) = self._flatten(q, qd, tau)
        M, bias = self._bias(qf, qdf)
        return np.linalg.solve(M, (tauf - bias)[..., None])[..., 0].reshape(lead + (self.n_q,))
