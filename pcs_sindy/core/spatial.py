"""Spatial (3-D) Piecewise Constant Strain (PCS) kinematics and SE(3) pose algebra.

Conventions (issue 26; the planar ones of :mod:`.kinematics` extended).  Segment ``i`` has six
strains, in the order of :data:`SPATIAL_STRAIN_NAMES`:

==  ===========  =====================================================================
0   ``bend_z``   κ_z, bending about the body z axis (the planar bending κ_be) [1/m]
1   ``bend_x``   κ_x, bending about the body x axis (out of the plane) [1/m]
2   ``twist``    κ_y, torsion about the tangent (body y) [1/m]
3   ``shear_x``  σ_x, shear along body x (the planar shear σ_sh) [-]
4   ``shear_z``  σ_z, shear along body z [-]
5   ``axial``    σ_y, elongation, deviation from the rest axial strain 1 (the planar σ_ax) [-]
==  ===========  =====================================================================

At ``q = 0`` the robot lies along +y of its base frame; the body tangent is body +y and the
cross-section axes are body x (the planar shear direction) and body z = x × y.  The body twist of
a constant-strain segment is ω = (κ_x, κ_y, κ_z) = (q[1], q[2], q[0]) and
v = (σ_x, 1 + σ_y, σ_z) = (q[3], 1 + q[5], q[4]); ``dR/ds = R [ω]×``, ``dp/ds = R v``, so inside a
segment ``g(s) = g(start) · exp(s ξ^)``.

**Poses** are pairs ``(position, rotation)``: positions ``(..., 3)`` and rotation matrices
``(..., 3, 3)`` in the base frame (body-to-base; the columns are the body axes).  Every function
taking or returning a pose uses this pair; :func:`se3_matrix` and :func:`se3_from_matrix` convert
to and from 4×4 homogeneous matrices.  Quaternions appear only at the I/O boundary
(:func:`quaternion_to_rotation`, :func:`rotation_to_quaternion`; scalar last by default, as the
Trunk's CSV stores them).

**Accuracy.**  With ``W = s ω``, ``V = s v`` and ``u = |W|`` the segment's pose is
``R = I + a Ŵ + b Ŵ²``, ``p = J(W) V`` with ``J(W) = I + b Ŵ + c Ŵ²`` (the left Jacobian of SO(3)),
``a = sin u / u``, ``b = (1 − cos u)/u²``, ``c = (u − sin u)/u³``.  Jacobians and the velocity
products need ``b1 = b'/u``, ``c1 = c'/u`` (closed forms with 1/u⁴ and 1/u⁵ cancelling terms) and
``b2 = b1'/u``, ``c2 = c1'/u``.  Each function is evaluated by its Taylor series in ``u²`` below a
switch point and by its closed form above it, the switch chosen where both are accurate to round-off
(:func:`tangent_coefficients`); nothing adds an epsilon to a strain, so zero strain is exact.

This module is part of the ground floor: of the package it imports only the sizes, masks and checks it
shares with the planar containers (``core/_segmented.py``), and :mod:`pcs_sindy.core.kinematics` inside
:meth:`SpatialPCS.to_planar`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from math import factorial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation
from scipy.special import bernoulli

from ._segmented import SegmentedStrains, StrainSeries

__all__ = [
    "SPATIAL_STRAIN_NAMES",
    "SPATIAL_Q_MAX",
    "tangent_coefficients",
    "strains_to_twist",
    "twist_to_strains",
    "se3_exp",
    "se3_log",
    "se3_compose",
    "se3_inverse",
    "se3_relative",
    "se3_matrix",
    "se3_from_matrix",
    "quaternion_to_rotation",
    "rotation_to_quaternion",
    "planar_to_spatial_strains",
    "spatial_to_planar_strains",
    "planar_to_spatial_pose",
    "SpatialPCS",
    "SpatialStrainTrajectory",
]

#: the six strains of a segment, in the order of ``q_i`` (module docstring)
SPATIAL_STRAIN_NAMES: tuple[str, ...] = ("bend_z", "bend_x", "twist", "shear_x", "shear_z", "axial")
#: typical range of each strain [1/m for bending and twist, - for shear and axial]: the scales by
#: which kinematic fusion compares strains (the planar :data:`~pcs_sindy.core.kinematics.SEED_Q_MAX`)
SPATIAL_Q_MAX: tuple[float, ...] = (60.0, 60.0, 60.0, 0.3, 0.3, 0.3)

#: index in ``q_i`` of ω_x, ω_y, ω_z and of v_x, v_y, v_z
_Q_OF_OMEGA = np.array([1, 2, 0])
_Q_OF_V = np.array([3, 5, 4])
#: index in ``q_i`` of the planar strains (κ_be, σ_sh, σ_ax)
_PLANAR = np.array([0, 3, 5])

# --------------------------------------------------------------------------
# scalar functions of u = |W|: Taylor series in u² below a switch, closed forms above
# --------------------------------------------------------------------------
# Measured against 40-digit mpmath: above u = 3 the closed forms of b1, c1, b2, c2 lose less than
# 1e-15 (relative to the function's scale), below it the series (24 terms: the first omitted one
# is below 1e-30 at u = 3) are accurate to round-off.  a and b have closed forms free of
# cancellation: their series only avoid 0/0.
_SWITCH = 3.0
_SWITCH_AB = 0.5
_N_TERMS = 24


def _alternating(offset: int, n: int) -> list[float]:
    """Coefficients in x = u² of Σ (-1)^k u^{2k} / (2k + offset)!."""
    return [(-1) ** k / factorial(2 * k + offset) for k in range(n)]


def _over_u_derivative(coefs: list[float]) -> list[float]:
    """Coefficients of f'(u)/u from those of f (both in x = u²)."""
    return [2 * k * coefs[k] for k in range(1, len(coefs))]


_A = _alternating(1, _N_TERMS)
_B = _alternating(2, _N_TERMS + 2)
_C = _alternating(3, _N_TERMS + 2)
_B1 = _over_u_derivative(_B)
_C1 = _over_u_derivative(_C)
_B2 = _over_u_derivative(_B1)
_C2 = _over_u_derivative(_C1)
# d(u) = (1 − (u/2) cot(u/2)) / u² of the inverse left Jacobian: −Σ_{k≥1} (−1)^k B_{2k} u^{2k−2} / (2k)!
_BERN = bernoulli(2 * _N_TERMS + 2)
_D = [-((-1) ** k) * float(_BERN[2 * k]) / factorial(2 * k) for k in range(1, _N_TERMS + 1)]
_SWITCH_D = 2.0  # the series converges for u < 2π; at 2 its terms shrink by 10 per order


def _horner(coefs: list[float], x: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.full(x.shape, coefs[-1])
    for c in coefs[-2::-1]:
        out = out * x + c
    return out


def _switched(u: NDArray, limit: float, coefs: list[float], closed) -> NDArray[np.float64]:
    small = u < limit
    x = np.where(small, u * u, 0.0)
    big = np.where(small, 2.0 * limit, u)  # any value where the closed form is defined
    with np.errstate(invalid="ignore", divide="ignore"):
        far = closed(big)
    return np.where(small, _horner(coefs, x), far)


def _a(u):
    return np.sin(u) / u


def _b(u):
    return 2.0 * (np.sin(0.5 * u) / u) ** 2


def _c(u):
    return (u - np.sin(u)) / u**3


def _b1(u):
    return (u * np.sin(u) - 4.0 * np.sin(0.5 * u) ** 2) / u**4


def _c1(u):
    return (3.0 * np.sin(u) - u * np.cos(u) - 2.0 * u) / u**5


def _b2(u):
    return (u * u * np.cos(u) - 5.0 * u * np.sin(u) + 16.0 * np.sin(0.5 * u) ** 2) / u**6


def _c2(u):
    return (u * u * np.sin(u) + 7.0 * u * np.cos(u) + 8.0 * u - 15.0 * np.sin(u)) / u**7


def _d(u):
    return 1.0 / (u * u) - np.cos(0.5 * u) / (2.0 * u * np.sin(0.5 * u))


def tangent_coefficients(u: ArrayLike, order: int = 0) -> tuple[NDArray[np.float64], ...]:
    """Scalar functions of ``u = |s ω|`` behind the SE(3) exponential and its derivatives.

    ``a = sin u/u``, ``b = (1 − cos u)/u²``, ``c = (u − sin u)/u³`` and, for ``order >= 1``,
    ``b1 = b'(u)/u``, ``c1 = c'(u)/u``; for ``order >= 2`` also ``b2 = b1'(u)/u``,
    ``c2 = c1'(u)/u``.  All are even, smooth functions of ``u``: evaluated by their Taylor
    series in ``u²`` near 0 and by closed forms elsewhere, accurate to a few units of round-off
    (relative to the function's scale) at every magnitude.

    Parameters
    ----------
    u : array_like
        Rotation angles ``|W|`` (the sign is ignored).
    order : {0, 1, 2}, default 0

    Returns
    -------
    tuple of ndarray
        ``(a, b, c)``, ``(a, b, c, b1, c1)`` or ``(a, b, c, b1, c1, b2, c2)``, each of the shape of ``u``.
    """
    if order not in (0, 1, 2):
        raise ValueError(f"order must be 0, 1 or 2; got {order!r}")
    u = np.abs(np.asarray(u, dtype=float))
    out = [
        _switched(u, _SWITCH_AB, _A, _a),
        _switched(u, _SWITCH_AB, _B[:_N_TERMS], _b),
        _switched(u, _SWITCH, _C[:_N_TERMS], _c),
    ]
    if order >= 1:
        out += [_switched(u, _SWITCH, _B1[:_N_TERMS], _b1), _switched(u, _SWITCH, _C1[:_N_TERMS], _c1)]
    if order >= 2:
        out += [_switched(u, _SWITCH, _B2[:_N_TERMS], _b2), _switched(u, _SWITCH, _C2[:_N_TERMS], _c2)]
    return tuple(out)


def _inverse_jacobian_coefficient(u: NDArray) -> NDArray[np.float64]:
    """``d(u) = (1 − (u/2) cot(u/2)) / u²``: ``J(W)⁻¹ = I − Ŵ/2 + d Ŵ²``."""
    return _switched(np.abs(u), _SWITCH_D, _D, _d)


# --------------------------------------------------------------------------
# small vector algebra, vectorised over leading axes (broadcasting)
# --------------------------------------------------------------------------
def _cross(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _dot(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    return np.sum(a * b, axis=-1)


def _matvec(R: NDArray, x: NDArray) -> NDArray[np.float64]:
    return np.einsum("...ij,...j->...i", R, x)


def _rot_t_vec(R: NDArray, x: NDArray) -> NDArray[np.float64]:
    return np.einsum("...ji,...j->...i", R, x)


def _jl(W: NDArray, X: NDArray, b: NDArray, c: NDArray) -> NDArray[np.float64]:
    """``J(W) X = X + b W×X + c W×(W×X)``; ``b``, ``c`` carry a trailing axis of length 1."""
    WX = _cross(W, X)
    return X + b * WX + c * _cross(W, WX)


def _djl(W, Wd, X, co) -> NDArray[np.float64]:
    """Derivative of ``J(W) X`` (X fixed) along ``Ẇ``: ``(∂J/∂W · Ẇ) X``."""
    _, b, c, b1, c1 = co[:5]
    wwd = _dot(W, Wd)[..., None]
    WX = _cross(W, X)
    WdX = _cross(Wd, X)
    return b1 * wwd * WX + b * WdX + c1 * wwd * _cross(W, WX) + c * (_cross(Wd, WX) + _cross(W, WdX))


def _ddjl(W, Wd, X, co) -> NDArray[np.float64]:
    """Second derivative of ``J(W) X`` (X fixed) along ``Ẇ`` twice (``Ẅ = 0``)."""
    _, b, c, b1, c1, b2, c2 = co
    wwd = _dot(W, Wd)[..., None]
    wdwd = _dot(Wd, Wd)[..., None]
    WX = _cross(W, X)
    WdX = _cross(Wd, X)
    return (
        (b2 * wwd * wwd + b1 * wdwd) * WX
        + 2.0 * b1 * wwd * WdX
        + (c2 * wwd * wwd + c1 * wdwd) * _cross(W, WX)
        + 2.0 * c1 * wwd * (_cross(Wd, WX) + _cross(W, WdX))
        + 2.0 * c * _cross(Wd, WdX)
    )


def _hat(w: NDArray) -> NDArray[np.float64]:
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def _rotation(W: NDArray, a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """``exp(Ŵ) = I + a Ŵ + b Ŵ²`` (a, b without trailing axis)."""
    H = _hat(W)
    return np.eye(3) + a[..., None, None] * H + b[..., None, None] * (H @ H)


def _local(W: NDArray, V: NDArray, order: int) -> tuple:
    """Coefficients (trailing axis 1), rotation and position of ``exp`` of the scaled twist (W, V)."""
    co = tangent_coefficients(np.linalg.norm(W, axis=-1), order)
    R = _rotation(W, co[0], co[1])
    co = tuple(x[..., None] for x in co)
    return co, R, _jl(W, V, co[1], co[2])


# --------------------------------------------------------------------------
# argument checks
# --------------------------------------------------------------------------
def _finite(arr: NDArray, name: str) -> NDArray:
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr


def _as_vectors(x: ArrayLike, name: str, size: int = 3) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ValueError(f"{name} must have a last axis of length {size}; got shape {arr.shape}")
    return _finite(arr, name)


def _as_rotations(x: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=float)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have trailing shape (3, 3) (rotation matrices); got shape {arr.shape}")
    return _finite(arr, name)


def _check_arc(s: ArrayLike, name: str = "s") -> NDArray[np.float64]:
    arr = np.asarray(s, dtype=float)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} (segment length) must be finite and > 0; got {arr.tolist()}")
    return arr


# --------------------------------------------------------------------------
# SE(3) on (position, rotation) pairs
# --------------------------------------------------------------------------
def strains_to_twist(q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body twist ``(ω, v)`` (..., 3) each of segment strains ``q`` (..., 6); ``v`` includes the rest 1."""
    q = _as_vectors(q, "q", 6)
    v = q[..., _Q_OF_V].copy()
    v[..., 1] += 1.0
    return q[..., _Q_OF_OMEGA], v


def twist_to_strains(omega: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Strains (..., 6) of the body twist ``(ω, v)``; inverse of :func:`strains_to_twist`."""
    omega = _as_vectors(omega, "omega")
    v = _as_vectors(v, "v")
    omega, v = np.broadcast_arrays(omega, v)
    q = np.empty(omega.shape[:-1] + (6,))
    q[..., _Q_OF_OMEGA] = omega
    q[..., _Q_OF_V] = v
    q[..., 5] -= 1.0
    return q


def se3_exp(q: ArrayLike, s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pose at arc length ``s`` of one constant-strain segment, in its start frame: ``exp(s ξ^)``.

    Parameters
    ----------
    q : array_like, shape (..., 6)
        Strains of the segment (order of :data:`SPATIAL_STRAIN_NAMES`).
    s : array_like
        Arc length(s) [m], broadcastable with ``q[..., 0]``.

    Returns
    -------
    position : ndarray, shape (..., 3)
    rotation : ndarray, shape (..., 3, 3)
    """
    omega, v = strains_to_twist(q)
    s = _finite(np.asarray(s, dtype=float), "s")[..., None]
    _, R, p = _local(s * omega, s * v, 0)
    return p, R


def se3_log(position: ArrayLike, rotation: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
    """Strains of the constant-strain segment of length ``s`` whose end pose is the given one.

    Inverse of :func:`se3_exp` for segments that turn by less than π (``|s ω| < π``, the principal
    logarithm); exact near the identity.

    Parameters
    ----------
    position : array_like, shape (..., 3)
    rotation : array_like, shape (..., 3, 3)
        End pose relative to the segment's start frame.
    s : array_like
        Segment length(s) [m] > 0, broadcastable with the leading shape.

    Returns
    -------
    ndarray, shape (..., 6)
    """
    p = _as_vectors(position, "position")
    R = _as_rotations(rotation, "rotation")
    s = _check_arc(s)
    lead = np.broadcast_shapes(p.shape[:-1], R.shape[:-2])
    p = np.broadcast_to(p, lead + (3,))
    R = np.broadcast_to(R, lead + (3, 3))
    W = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_rotvec().reshape(lead + (3,))
    d = _inverse_jacobian_coefficient(np.linalg.norm(W, axis=-1))[..., None]
    Wp = _cross(W, p)
    V = p - 0.5 * Wp + d * _cross(W, Wp)
    s = s[..., None]
    return twist_to_strains(W / s, V / s)


def se3_compose(
    position_a: ArrayLike, rotation_a: ArrayLike, position_b: ArrayLike, rotation_b: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``a ∘ b``: pose ``b`` given in frame ``a``, expressed in ``a``'s parent; leading axes broadcast."""
    pa, Ra = _as_vectors(position_a, "position_a"), _as_rotations(rotation_a, "rotation_a")
    pb, Rb = _as_vectors(position_b, "position_b"), _as_rotations(rotation_b, "rotation_b")
    return pa + _matvec(Ra, pb), Ra @ Rb


def se3_inverse(position: ArrayLike, rotation: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Inverse pose ``(−Rᵀ p, Rᵀ)``."""
    p, R = _as_vectors(position, "position"), _as_rotations(rotation, "rotation")
    Rt = np.swapaxes(R, -1, -2)
    return -_matvec(Rt, p), Rt


def se3_relative(
    position_a: ArrayLike, rotation_a: ArrayLike, position_b: ArrayLike, rotation_b: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pose of ``b`` relative to ``a``: ``a⁻¹ ∘ b``."""
    pa, Ra = _as_vectors(position_a, "position_a"), _as_rotations(rotation_a, "rotation_a")
    pb, Rb = _as_vectors(position_b, "position_b"), _as_rotations(rotation_b, "rotation_b")
    Rt = np.swapaxes(Ra, -1, -2)
    return _matvec(Rt, pb - pa), Rt @ Rb


def se3_matrix(position: ArrayLike, rotation: ArrayLike) -> NDArray[np.float64]:
    """Homogeneous 4×4 matrices (..., 4, 4) of poses."""
    p, R = _as_vectors(position, "position"), _as_rotations(rotation, "rotation")
    lead = np.broadcast_shapes(p.shape[:-1], R.shape[:-2])
    out = np.zeros(lead + (4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = p
    out[..., 3, 3] = 1.0
    return out


def se3_from_matrix(matrix: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Poses ``(position (..., 3), rotation (..., 3, 3))`` of homogeneous matrices (..., 4, 4)."""
    H = np.asarray(matrix, dtype=float)
    if H.ndim < 2 or H.shape[-2:] != (4, 4):
        raise ValueError(f"matrix must have trailing shape (4, 4); got shape {H.shape}")
    _finite(H, "matrix")
    return H[..., :3, 3].copy(), H[..., :3, :3].copy()


def quaternion_to_rotation(quaternion: ArrayLike, scalar_first: bool = False) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4), normalised first.

    Parameters
    ----------
    quaternion : array_like, shape (..., 4)
        ``(x, y, z, w)`` (default, the Trunk's CSV) or ``(w, x, y, z)`` with ``scalar_first=True``.
    scalar_first : bool, default False
    """
    quat = _as_vectors(quaternion, "quaternion", 4)
    if scalar_first:
        quat = np.roll(quat, -1, axis=-1)  # scipy < 1.14 reads scalar-last only
    norm = np.linalg.norm(quat, axis=-1)
    if np.any(norm == 0):
        raise ValueError(f"quaternion has zero norm at index {np.argwhere(norm == 0)[0].tolist()}")
    lead = quat.shape[:-1]
    return Rotation.from_quat(quat.reshape(-1, 4)).as_matrix().reshape(lead + (3, 3))


def rotation_to_quaternion(rotation: ArrayLike, scalar_first: bool = False) -> NDArray[np.float64]:
    """Unit quaternions (..., 4) of rotation matrices (..., 3, 3), with ``w >= 0``.

    Scalar last ``(x, y, z, w)`` by default, ``(w, x, y, z)`` with ``scalar_first=True``.
    """
    R = _as_rotations(rotation, "rotation")
    lead = R.shape[:-2]
    quat = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat().reshape(lead + (4,))
    quat = np.where(quat[..., 3:] < 0, -quat, quat)
    return np.roll(quat, 1, axis=-1) if scalar_first else quat


# --------------------------------------------------------------------------
# the planar embedding
# --------------------------------------------------------------------------
def planar_to_spatial_strains(q_planar: ArrayLike) -> NDArray[np.float64]:
    """Spatial strains (..., 6m) of planar ones (..., 3m): ``(κ, σ_sh, σ_ax) -> (κ, 0, 0, σ_sh, 0, σ_ax)``."""
    q = np.asarray(q_planar, dtype=float)
    if q.ndim == 0 or q.shape[-1] % 3 or q.shape[-1] == 0:
        raise ValueError(f"q_planar must have a last axis of length 3m; got shape {q.shape}")
    _finite(q, "q_planar")
    m = q.shape[-1] // 3
    out = np.zeros(q.shape[:-1] + (m, 6))
    out[..., _PLANAR] = q.reshape(q.shape[:-1] + (m, 3))
    return out.reshape(q.shape[:-1] + (6 * m,))


def spatial_to_planar_strains(q: ArrayLike, atol: float | None = 0.0) -> NDArray[np.float64]:
    """Planar strains (..., 3m) of spatial ones (..., 6m) that lie in the plane.

    Parameters
    ----------
    q : array_like, shape (..., 6m)
    atol : float or None, default 0.0
        Largest out-of-plane strain (``bend_x``, ``twist``, ``shear_z``) accepted; None drops them unchecked.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim == 0 or q.shape[-1] % 6 or q.shape[-1] == 0:
        raise ValueError(f"q must have a last axis of length 6m; got shape {q.shape}")
    _finite(q, "q")
    m = q.shape[-1] // 6
    qs = q.reshape(q.shape[:-1] + (m, 6))
    if atol is not None:
        off = np.abs(qs[..., [1, 2, 4]])
        if np.any(off > atol):
            worst = float(off.max())
            raise ValueError(f"q has out-of-plane strains (bend_x, twist, shear_z) up to {worst:g} > atol = {atol:g}")
    return qs[..., _PLANAR].reshape(q.shape[:-1] + (3 * m,))


def planar_to_spatial_pose(pose: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Spatial poses of planar ones ``[x, y, θ]`` (..., 3): ``p = (x, y, 0)``, ``R = Rz(θ)``."""
    pose = _as_vectors(pose, "pose")
    p = np.zeros(pose.shape)
    p[..., :2] = pose[..., :2]
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    R = np.zeros(pose.shape[:-1] + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    return p, R


# --------------------------------------------------------------------------
# the robot's kinematics
# --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SpatialPCS(SegmentedStrains):
    """Kinematic description of a spatial PCS robot (six strains per segment).

    Parameters
    ----------
    segment_lengths : sequence of float
        Rest lengths ``L_i`` in metres, base to tip.
    active_strains : array_like of bool, shape (m, 6) or (6m,), optional
        Which strains (order of :data:`SPATIAL_STRAIN_NAMES`) are modelled in each segment
        (default: all).  Inactive strains are held at 0.
    base_position : sequence of float, shape (3,), optional
        Position of the base frame (default: origin).
    base_rotation : array_like, shape (3, 3), optional
        Rotation of the base frame (default: identity: the robot along +y at rest).

    Notes
    -----
    Batched evaluations take configurations ``q`` (..., 6m) and global arc lengths ``s`` (K,)
    in ``[0, total_length]`` and return arrays (..., K, ...).  Angular quantities are in the
    body frame of the cross-section at ``s``; positions, position Jacobians and accelerations in
    the base frame.
    """

    segment_lengths: tuple[float, ...]
    active_strains: NDArray[np.bool_] | None = None
    base_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_rotation: NDArray[np.float64] | None = None
    _mask: NDArray[np.bool_] = field(init=False, repr=False, compare=False)
    _n_strains = 6

    def __post_init__(self) -> None:
        self._init_strains()
        base_p = np.asarray(self.base_position, dtype=float)
        if base_p.shape != (3,) or not np.all(np.isfinite(base_p)):
            raise ValueError(f"base_position must be 3 finite numbers; got {self.base_position!r}")
        object.__setattr__(self, "base_position", tuple(float(v) for v in base_p))
        if self.base_rotation is None:
            base_R = np.eye(3)
        else:
            base_R = np.array(self.base_rotation, dtype=float)
            if base_R.shape != (3, 3) or not np.all(np.isfinite(base_R)):
                raise ValueError(f"base_rotation must be a finite (3, 3) matrix; got {self.base_rotation!r}")
            if np.abs(base_R.T @ base_R - np.eye(3)).max() > 1e-9 or np.linalg.det(base_R) <= 0:
                raise ValueError(
                    f"base_rotation must be a rotation matrix (orthonormal, det +1); got {base_R.tolist()}"
                )
        base_R.setflags(write=False)
        object.__setattr__(self, "base_rotation", base_R)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SpatialPCS):
            return NotImplemented
        return (
            self.segment_lengths == other.segment_lengths
            and np.array_equal(self.active_strains, other.active_strains)
            and self.base_position == other.base_position
            and np.array_equal(self.base_rotation, other.base_rotation)
        )

    def __hash__(self) -> int:
        return hash(
            (self.segment_lengths, self.active_strains.tobytes(), self.base_position, self.base_rotation.tobytes())
        )

    # -- sizes -----------------------------------------------------------
    @property
    def n_q(self) -> int:
        """Size of the full configuration, ``6m``."""
        return 6 * self.n_segments

    @property
    def active_mask(self) -> NDArray[np.bool_]:
        """Flat boolean mask of shape (6m,) of the modelled strains."""
        return self._mask

    @property
    def base_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(position (3,), rotation (3, 3))`` of the base frame."""
        return np.asarray(self.base_position), np.asarray(self.base_rotation)

    def strain_names(self, active_only: bool = False) -> list[str]:
        """Names such as ``"bend_z_1"``, ..., ``"axial_1"``, ``"bend_z_2"``, ..."""
        return self._strain_names(SPATIAL_STRAIN_NAMES, active_only)

    def marker_arc_lengths(self, n_markers: int) -> NDArray[np.float64]:
        """Arc lengths of the base and ``n_markers`` equally spaced cross-sections (the last at the tip)."""
        if isinstance(n_markers, bool) or int(n_markers) != n_markers or n_markers < 1:
            raise ValueError(f"n_markers must be a positive integer; got {n_markers!r}")
        return np.linspace(0.0, self.total_length, int(n_markers) + 1)

    # -- configuration maps ----------------------------------------------
    def _check_q(self, q: ArrayLike, name: str = "q") -> NDArray[np.float64]:
        q = np.asarray(q, dtype=float)
        if q.ndim == 0 or q.shape[-1] != self.n_q:
            raise ValueError(f"{name} must have a last axis of length 6 * n_segments = {self.n_q}; got shape {q.shape}")
        return _finite(q, name)

    def to_active(self, q_full: ArrayLike) -> NDArray[np.float64]:
        """Select the modelled strains from full configurations (..., 6m)."""
        return self._check_q(q_full, "q_full")[..., self._mask]

    def to_full(self, q_active: ArrayLike) -> NDArray[np.float64]:
        """Embed modelled strains (..., n_active) into full configurations, zeros elsewhere."""
        q_active = np.asarray(q_active, dtype=float)
        if q_active.ndim == 0 or q_active.shape[-1] != self.n_active:
            raise ValueError(f"q_active must have a last axis of length {self.n_active}; got shape {q_active.shape}")
        _finite(q_active, "q_active")
        out = np.zeros(q_active.shape[:-1] + (self.n_q,))
        out[..., self._mask] = q_active
        return out

    # -- the planar embedding ----------------------------------------------
    @classmethod
    def from_planar(cls, planar: Any) -> SpatialPCS:
        """The spatial robot of a :class:`~pcs_sindy.core.PlanarPCS`: the plane is the base's x-y plane.

        Planar strains ``(κ, σ_sh, σ_ax)`` become ``bend_z``, ``shear_x``, ``axial``; the others are
        inactive.  The planar base pose ``(x, y, θ)`` becomes ``p = (x, y, 0)``, ``R = Rz(θ)``.
        """
        mask = np.zeros((planar.n_segments, 6), dtype=bool)
        mask[:, _PLANAR] = np.asarray(planar.active_strains, dtype=bool)
        p, R = planar_to_spatial_pose(planar.base_pose)
        return cls(tuple(planar.segment_lengths), mask, tuple(p), R)

    def to_planar(self) -> Any:
        """The :class:`~pcs_sindy.core.PlanarPCS` of a robot whose base frame keeps the plane z = 0.

        Raises ValueError if an out-of-plane strain is active or the base is out of the plane.
        """
        from .kinematics import PlanarPCS

        if np.any(self.active_strains[:, [1, 2, 4]]):
            raise ValueError("to_planar: bend_x, twist and shear_z must be inactive for a planar robot")
        R = self.base_rotation
        if abs(self.base_position[2]) > 1e-12 or np.abs(R[2, :2]).max() > 1e-12 or np.abs(R[:2, 2]).max() > 1e-12:
            raise ValueError(
                f"to_planar: the base pose must keep the x-y plane (z = 0, rotation about z); got position "
                f"{self.base_position}, rotation {R.tolist()}"
            )
        theta = float(np.arctan2(R[1, 0], R[0, 0]))
        return PlanarPCS(
            self.segment_lengths,
            self.active_strains[:, _PLANAR],
            (self.base_position[0], self.base_position[1], theta),
        )

    # -- kinematics --------------------------------------------------------
    def _arcs(self, s: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if s.ndim != 1:
            raise ValueError(f"s must be 1-D (arc lengths); got shape {s.shape}")
        lengths = np.asarray(self.segment_lengths)
        total = lengths.sum()
        if not np.all(np.isfinite(s)) or np.any(s < -1e-12 * total) or np.any(s > total * (1 + 1e-12)):
            raise ValueError(f"s must lie in [0, {total:g}] m; got {s.tolist()}")
        starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
        idx = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, lengths.size - 1)
        return idx, np.clip(s - starts[idx], 0.0, lengths[idx])

    def _motion(self, q: NDArray, qd: NDArray | None, s: ArrayLike, order: int) -> dict[str, NDArray]:
        """Poses (B, K, ...) and, for rates ``qd`` (B, C, n), velocities (``order`` 1) and accelerations at q̈ = 0.

        Recursion along the segments in the base frame: a point ``p = p0 + R0 r`` of a segment whose
        start frame moves with angular velocity Ω0 and angular acceleration α0 has
        ``ṗ = ṗ0 + Ω0×R0r + R0ṙ`` and ``p̈ = p̈0 + α0×R0r + Ω0×(Ω0×R0r) + 2Ω0×R0ṙ + R0r̈``; its
        frame ``R = R0 R_loc`` turns with ``Ω = Ω0 + R0 Ω_loc``,
        ``α = α0 + Ω0×R0Ω_loc + R0 Ω̇_loc``, where ``r = J(W)V``, ``Ω_loc = J(W)Ẇ`` and their
        rates are the derivatives of ``J`` along ``Ẇ``.
        """
        idx, local = self._arcs(s)
        L = np.asarray(self.segment_lengths)
        m = L.size
        B = q.shape[0]
        qs = q.reshape(B, m, 6)
        omega = qs[..., _Q_OF_OMEGA]
        v = qs[..., _Q_OF_V] + np.array([0.0, 1.0, 0.0])
        # each segment's end in its start frame, and each point in its segment's start frame
        W_end, V_end = L[:, None] * omega, L[:, None] * v
        co_end, R_end, r_end = _local(W_end, V_end, order)
        W_pt, V_pt = local[:, None] * omega[:, idx], local[:, None] * v[:, idx]
        co_pt, R_pt, r_pt = _local(W_pt, V_pt, order)
        # start frames of the segments
        p0 = np.empty((B, m, 3))
        R0 = np.empty((B, m, 3, 3))
        p_cur = np.broadcast_to(np.asarray(self.base_position), (B, 3))
        R_cur = np.broadcast_to(np.asarray(self.base_rotation), (B, 3, 3))
        for i in range(m):
            p0[:, i], R0[:, i] = p_cur, R_cur
            p_cur = p_cur + _matvec(R_cur, r_end[:, i])
            R_cur = R_cur @ R_end[:, i]
        Rs = R0[:, idx] @ R_pt
        out = {"position": p0[:, idx] + _matvec(R0[:, idx], r_pt), "rotation": Rs}
        if order == 0:
            return out
        C = qd.shape[1]
        qds = qd.reshape(B, C, m, 6)
        omega_d = qds[..., _Q_OF_OMEGA]
        v_d = qds[..., _Q_OF_V]

        def advance(start, R0j, W, V, r, co, Wd, Vd):
            """Motion of the frame at (W, V) (batch axis first) of a segment whose start frame moves as ``start``.

            ``start``, ``Wd``, ``Vd`` carry the axis of the C rate vectors second; the others do not.
            """
            pd0, Om0 = start[:2]
            R0j, W, V = R0j[:, None], W[:, None], V[:, None]
            co = tuple(x[:, None] for x in co)
            rb = _matvec(R0j, r[:, None])
            rd = _matvec(R0j, _djl(W, Wd, V, co) + _jl(W, Vd, co[1], co[2]))
            Om_loc = _matvec(R0j, _jl(W, Wd, co[1], co[2]))
            Om0_rb = _cross(Om0, rb)
            res = [pd0 + Om0_rb + rd, Om0 + Om_loc]
            if order == 2:
                pdd0, al0 = start[2:]
                rdd = _matvec(R0j, _ddjl(W, Wd, V, co) + 2.0 * _djl(W, Wd, Vd, co))
                Om_loc_d = _matvec(R0j, _djl(W, Wd, Wd, co))
                res.append(pdd0 + _cross(al0, rb) + _cross(Om0, Om0_rb) + 2.0 * _cross(Om0, rd) + rdd)
                res.append(al0 + _cross(Om0, Om_loc) + Om_loc_d)
            return res

        zero = np.zeros((B, C, 3))
        start = [zero] * (2 * order)
        starts = []
        for i in range(m):
            starts.append(start)
            start = advance(
                start,
                R0[:, i],
                W_end[:, i],
                V_end[:, i],
                r_end[:, i],
                tuple(x[:, i] for x in co_end),
                L[i] * omega_d[:, :, i],
                L[i] * v_d[:, :, i],
            )
        # every point from the start state of its segment
        start_pt = [np.stack([st[k] for st in starts], axis=2)[:, :, idx] for k in range(2 * order)]
        Wd_pt = local[:, None] * omega_d[:, :, idx]
        Vd_pt = local[:, None] * v_d[:, :, idx]
        res = _advance_points(advance, start_pt, R0[:, idx], W_pt, V_pt, r_pt, co_pt, Wd_pt, Vd_pt)
        Rs_b = Rs[:, None]
        out["velocity"] = res[0]
        out["angular_velocity"] = _rot_t_vec(Rs_b, res[1])
        if order == 2:
            out["acceleration"] = res[2]
            out["angular_acceleration"] = _rot_t_vec(Rs_b, res[3])
        return out

    def forward_kinematics(self, q: ArrayLike, s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Poses at global arc lengths ``s`` for full configurations ``q``.

        Parameters
        ----------
        q : array_like, shape (6m,) or (T, 6m)
        s : array_like, shape (K,)

        Returns
        -------
        positions : ndarray, shape ([T,] K, 3)
        rotations : ndarray, shape ([T,] K, 3, 3)
        """
        q = self._check_q(q)
        lead = q.shape[:-1]
        out = self._motion(q.reshape(-1, self.n_q), None, s, 0)
        K = out["position"].shape[1]
        return out["position"].reshape(lead + (K, 3)), out["rotation"].reshape(lead + (K, 3, 3))

    def jacobian(
        self, q: ArrayLike, s: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Poses and Jacobians at global arc lengths ``s``.

        Returns
        -------
        positions : ndarray, shape ([T,] K, 3)
        rotations : ndarray, shape ([T,] K, 3, 3)
        J_p : ndarray, shape ([T,] K, 3, 6m)
            ``∂p/∂q`` in the base frame.
        J_w : ndarray, shape ([T,] K, 3, 6m)
            Body angular Jacobian: ``ω_b = J_w q̇`` with ``[ω_b]× = Rᵀ Ṙ``.
        """
        q = self._check_q(q)
        lead = q.shape[:-1]
        n = self.n_q
        qf = q.reshape(-1, n)
        eye = np.broadcast_to(np.eye(n), (qf.shape[0], n, n))
        out = self._motion(qf, eye, s, 1)
        K = out["position"].shape[1]
        J_p = out["velocity"].transpose(0, 2, 3, 1)
        J_w = out["angular_velocity"].transpose(0, 2, 3, 1)
        return (
            out["position"].reshape(lead + (K, 3)),
            out["rotation"].reshape(lead + (K, 3, 3)),
            J_p.reshape(lead + (K, 3, n)),
            J_w.reshape(lead + (K, 3, n)),
        )

    def velocities(self, q: ArrayLike, qd: ArrayLike, s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Velocities ``J_p q̇`` (base frame) and body angular velocities ``J_w q̇``, each ([T,] K, 3)."""
        out = self._rates(q, qd, s, 1)
        return out["velocity"], out["angular_velocity"]

    def velocity_products(
        self, q: ArrayLike, qd: ArrayLike, s: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``J̇_p q̇`` and ``J̇_w q̇``, each ([T,] K, 3): the accelerations at ``q̈ = 0``.

        ``J̇_p q̇`` is the base-frame acceleration of the backbone point, ``J̇_w q̇`` the rate of its body
        angular velocity (``ω̇_b = J_w q̈ + J̇_w q̇``).
        """
        out = self._rates(q, qd, s, 2)
        return out["acceleration"], out["angular_acceleration"]

    def _rates(self, q: ArrayLike, qd: ArrayLike, s: ArrayLike, order: int) -> dict[str, NDArray]:
        q = self._check_q(q)
        qd = self._check_q(qd, "qd")
        if qd.shape != q.shape:
            raise ValueError(f"qd must have the shape of q {q.shape}; got shape {qd.shape}")
        lead = q.shape[:-1]
        out = self._motion(q.reshape(-1, self.n_q), qd.reshape(-1, 1, self.n_q), s, order)
        K = out["position"].shape[1]
        keys = ("velocity", "angular_velocity") + (("acceleration", "angular_acceleration") if order == 2 else ())
        return {k: out[k][:, 0].reshape(lead + (K, 3)) for k in keys}

    def inverse_kinematics(self, positions: ArrayLike, rotations: ArrayLike) -> NDArray[np.float64]:
        """Full strains from the poses of the segment ends in the base frame (one log per segment).

        Parameters
        ----------
        positions : array_like, shape (..., m, 3) or (..., m + 1, 3)
        rotations : array_like, shape (..., m, 3, 3) or (..., m + 1, 3, 3)
            Poses of the ends of the m segments; with ``m + 1`` poses the first is the base pose
            (instead of :attr:`base_position`, :attr:`base_rotation`).  Each segment must turn by
            less than π (the principal logarithm).

        Returns
        -------
        ndarray, shape (..., 6m)
            Strains; inactive strains are returned as computed (not zeroed).
        """
        p = _as_vectors(positions, "positions")
        R = _as_rotations(rotations, "rotations")
        m = self.n_segments
        if p.ndim < 2 or p.shape[-2] not in (m, m + 1):
            raise ValueError(f"positions must have shape (..., {m} or {m + 1}, 3); got {p.shape}")
        if R.shape[:-2] != p.shape[:-1]:
            raise ValueError(f"rotations must have shape {p.shape[:-1] + (3, 3)} (as positions); got {R.shape}")
        if p.shape[-2] == m:
            lead = p.shape[:-2]
            p = np.concatenate([np.broadcast_to(np.asarray(self.base_position), lead + (1, 3)), p], axis=-2)
            R = np.concatenate([np.broadcast_to(np.asarray(self.base_rotation), lead + (1, 3, 3)), R], axis=-3)
        p_rel, R_rel = se3_relative(p[..., :-1, :], R[..., :-1, :, :], p[..., 1:, :], R[..., 1:, :, :])
        q = se3_log(p_rel, R_rel, np.asarray(self.segment_lengths))
        return q.reshape(q.shape[:-2] + (6 * m,))


def _advance_points(advance, start_pt, R0_pt, W, V, r, co, Wd, Vd):
    """Apply ``advance`` to every point: fold the point axis K into the batch axis and back."""
    B, K = W.shape[:2]
    C = Wd.shape[1]

    def fold(x, has_c):
        # (B, [C,] K, ...) -> (B*K, [C,] ...)
        if has_c:
            x = np.moveaxis(x, 2, 1)
        return x.reshape((B * K,) + x.shape[2:])

    res = advance(
        [fold(x, True) for x in start_pt],
        fold(R0_pt, False),
        fold(W, False),
        fold(V, False),
        fold(r, False),
        tuple(fold(x, False) for x in co),
        fold(Wd, True),
        fold(Vd, True),
    )
    return [np.moveaxis(x.reshape((B, K, C, 3)), 2, 1) for x in res]


class SpatialStrainTrajectory(StrainSeries):
    """Strains of a spatial PCS segmentation over time, carrying the segmentation.

    The spatial counterpart of :class:`~pcs_sindy.core.StrainTrajectory` (what
    ``SpatialPCSRobot.simulate`` returns).

    Parameters
    ----------
    q : array_like, shape (T, 6m)
        Full strains ``[q_1, ..., q_m]`` (order of :data:`SPATIAL_STRAIN_NAMES`); strains that are
        not modelled are 0.
    t : array_like, shape (T,), optional
        Time stamps in seconds.
    segment_lengths : sequence of float
    active_strains : array_like of bool, shape (m, 6), optional
    qd : array_like, shape (T, 6m), optional
        Strain rates when known (simulation).
    dt : float, optional
        Sample period, used when ``t`` is not given.
    base_position : sequence of float, shape (3,), optional
    base_rotation : array_like, shape (3, 3), optional
    metadata : mapping, optional
    """

    def __init__(
        self,
        q: ArrayLike,
        t: ArrayLike | None = None,
        *,
        segment_lengths: Sequence[float],
        active_strains: ArrayLike | None = None,
        qd: ArrayLike | None = None,
        dt: float | None = None,
        base_position: Sequence[float] = (0.0, 0.0, 0.0),
        base_rotation: ArrayLike | None = None,
        metadata: Mapping[str, Any] | None = None,
    ) -> None:
        self.kinematics = SpatialPCS(
            tuple(np.atleast_1d(segment_lengths)), active_strains, tuple(base_position), base_rotation
        )
        self._init_series(q, t, qd, dt, metadata)

    def poses(self, s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Positions (T, K, 3) and rotations (T, K, 3, 3) at global arc lengths ``s``."""
        return self.kinematics.forward_kinematics(self.q, s)

    def __repr__(self) -> str:
        return (
            f"SpatialStrainTrajectory(n_frames={self.n_frames}, segment_lengths={list(self.segment_lengths)}, "
            f"n_active={self.kinematics.n_active})"
        )
