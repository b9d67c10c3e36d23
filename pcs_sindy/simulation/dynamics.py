"""Ground-truth dynamics of a planar Piecewise Constant Strain (PCS) robot.

The equations of motion (DESIGN.md §3) are

    M(q) q̈ + C(q, q̇) q̇ + G(q) + K q + D q̇ = τ

with ``M = Σ_i ∫ (ρ A J_pᵀ J_p + ρ I J_oᵀ J_o) ds`` and
``U_g = −Σ_i ∫ ρ A gᵀ p ds``.  Everything is computed *numerically*: the
integrals along the backbone are Gauss–Legendre quadratures of closed-form
Jacobians.  This module is the independent truth the symbolic identification
library is checked against, so it shares no derivation code with it.

Implementation notes
--------------------
Backbone positions are handled as complex numbers ``z = x + i y``.  With the
shear/axial strain packed into ``w = σ_sh + i (1 + σ_ax)`` the position inside
a segment that starts at ``z0`` with orientation ``φ`` is

    z(s) = z0 + e^{iφ} s w E_0(κ s),     E_n(u) = ∫_0^1 t^n e^{iut} dt,

and ``dE_n/du = i E_{n+1}``, so every derivative with respect to ``q`` (and
with respect to time, for the Coriolis terms) is again a closed form in
``E_0, E_1, E_2``.  These are evaluated without cancellation at ``κ = 0``
through ``sinc`` and its first two derivatives (series near 0) — no epsilon
is added to the curvature.

For a mass distributed along the backbone the Christoffel symbols of the first
kind reduce to ``Γ_ijk = Σ w ρA J_i · ∂²p/∂q_j∂q_k``, hence

    C(q, q̇) = Σ w ρA J_pᵀ J̇_p,        C(q, q̇) q̇ = Σ w ρA J_pᵀ (J̇_p q̇),

exactly (no finite differences).  The orientation Jacobian ``J_o`` is
constant, so rotary inertia only adds a constant matrix to ``M``.

Time integration steps across sample boundaries without restarting and
always lands on the sample times, where a zero-order-hold actuation may
switch.  The default, Radau IIA (L-stable, for the stiff shear/axial modes),
runs its whole loop over the time grid compiled with numba
(:mod:`pcs_sindy.simulation._jit`: single-state kernels of the same closed
forms, a velocity-reduced Newton system, per-robot steps); a batched numpy
version of the same scheme serves callable actuation.  Batched explicit
Runge–Kutta (the Dormand–Prince tableaux of :mod:`scipy.integrate`) and the
:func:`scipy.integrate.solve_ivp` methods are available as well.  The public
batched evaluations (mass matrix, inverse dynamics, ...) stay in numpy, which
is fast for large batches.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import DOP853, RK45, solve_ivp

from pcs_sindy.kinematics import PlanarPCS

__all__ = ["PCSRobot", "SimulationError", "backbone_moments"]

_OWN_RK = {"RK45": RK45, "DOP853": DOP853}
_SCIPY_METHODS = ("RK23", "BDF", "LSODA")
_METHODS = ("Radau", "DOP853", "RK45") + _SCIPY_METHODS

# Radau IIA, 3 stages, order 5 (Hairer & Wanner, Solving ODEs II, §IV.8)
_S6 = np.sqrt(6.0)
_RADAU_C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
_RADAU_A = np.array(
    [
        [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
        [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
        [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0],
    ]
)
_RADAU_E = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0  # embedded error estimate weights
_RADAU_MU = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)  # real eigenvalue of A^{-1}
_NEWTON_MAXITER = 7
# compiled Radau: refresh the Jacobian after a step whose Newton contraction rate exceeded this (as the numpy
# loop).  Measured: 0.03 is ~25 % faster on five_segment but ~25 % slower on the two_segment validation run.
_JAC_REFRESH_RATE = 1e-3
_RADAU_NODES = np.array([0.0, *_RADAU_C])  # collocation polynomial nodes of a step (normalised time)


def _extrapolation_weights(ratio: float) -> NDArray[np.float64]:
    """Lagrange weights (3, 4) evaluating the last step's collocation polynomial at the next stages."""
    x = _RADAU_NODES
    s = 1.0 + ratio * _RADAU_C
    w = np.ones((3, 4))
    for j in range(4):
        for k in range(4):
            if k != j:
                w[:, j] *= (s - x[k]) / (x[j] - x[k])
    return w
_SERIES_LIMIT = 0.25  # |v| below which sinc and its derivatives use their Taylor series


class SimulationError(RuntimeError):
    """Raised when the time integration of a :class:`PCSRobot` fails."""


# --------------------------------------------------------------------------
# Plain functions
# --------------------------------------------------------------------------
def _sinc_derivatives(v: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """``sin(v)/v`` and its first two derivatives, without cancellation at 0; also ``sin v``, ``cos v``."""
    small = np.abs(v) < _SERIES_LIMIT
    any_small = bool(small.any())
    sn, cs = np.sin(v), np.cos(v)
    inv = 1.0 / (np.where(small, 1.0, v) if any_small else v)
    s0 = sn * inv
    s1 = (cs - s0) * inv
    s2 = -s0 - 2.0 * s1 * inv  # differentiating v·sinc' = cos v − sinc
    if any_small:
        vs = v[small]
        v2 = vs * vs
        # Taylor series of sin(v)/v = Σ (-1)^k v^{2k} / (2k+1)!, differentiated termwise;
        # at |v| < 0.25 the first omitted terms are below 1e-19.
        s0[small] = 1.0 + v2 * (
            -1 / 6 + v2 * (1 / 120 + v2 * (-1 / 5040 + v2 * (1 / 362880 + v2 * (-1 / 39916800 + v2 / 6227020800))))
        )
        s1[small] = vs * (
            -1 / 3 + v2 * (1 / 30 + v2 * (-1 / 840 + v2 * (1 / 45360 + v2 * (-1 / 3991680 + v2 / 518918400))))
        )
        s2[small] = -1 / 3 + v2 * (1 / 10 + v2 * (-1 / 168 + v2 * (1 / 6480 + v2 * (-1 / 443520 + v2 / 47174400))))
    return s0, s1, s2, sn, cs


def backbone_moments(u: ArrayLike) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128]]:
    """The moments ``E_n(u) = ∫_0^1 t^n e^{iut} dt`` for ``n = 0, 1, 2``.

    With ``t = 1/2 + τ`` and ``v = u/2`` they are
    ``E_0 = e^{iv} sinc v``, ``E_1 = e^{iv} (sinc v − i sinc' v)/2`` and
    ``E_2 = e^{iv} (sinc v − 2i sinc' v − sinc'' v)/4``, which are exact at
    ``u = 0`` (values 1, 1/2, 1/3).

    Parameters
    ----------
    u : array_like of float

    Returns
    -------
    E0, E1, E2 : ndarray of complex, shape of ``u``
    """
    v = 0.5 * np.asarray(u, dtype=float)
    s0, s1, s2, sn, cs = _sinc_derivatives(np.atleast_1d(v))
    ph = cs + 1j * sn
    e0 = ph * s0
    a = ph * s1
    e1 = 0.5 * e0 - 0.5j * a
    e2 = 0.25 * (e0 - ph * s2) - 0.5j * a
    shape = v.shape
    return e0.reshape(shape), e1.reshape(shape), e2.reshape(shape)


def _per_segment(value: ArrayLike, m: int, name: str, *, positive: bool) -> NDArray[np.float64]:
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


def _finite_vector(value: ArrayLike, size: int, name: str) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite; got {arr.tolist()}")
    return arr


# --------------------------------------------------------------------------
# Robot
# --------------------------------------------------------------------------
class PCSRobot:
    """Planar PCS soft robot: mass, Coriolis, gravity, elastic and damping terms, and simulation.

    Parameters
    ----------
    segment_lengths : sequence of float, shape (m,)
        Rest lengths ``L_i`` in metres, base to tip.
    density : float or array_like, shape (m,)
        Mass density ``ρ`` in kg/m³.
    youngs_modulus : float or array_like, shape (m,)
        ``E`` in Pa.
    shear_modulus : float or array_like, shape (m,)
        ``G`` in Pa.
    damping : array_like, shape (3m,)
        Diagonal of the damping matrix ``D``.
    radius : float or array_like, shape (m,), default 0.02
        Cross-section radius ``r`` in metres (``A = π r²``, ``I = π r⁴/4``).
    gravity : array_like, shape (2,), default (0, 9.81)
        Gravity in the base frame; the default lets the robot hang (DESIGN.md §3).
    shear_factor : float, default 4/3
        ``c_sh`` in ``K_i = f_L diag(E I, c_sh G A, E A)``.
    stiffness_scaling : {"seed", "length"}, default "seed"
        ``"seed"``: ``f_L = 1`` (the seed's simulator); ``"length"``: ``f_L = L_i``
        (the elastic energy of a constant-strain segment).
    base_pose : array_like, shape (3,), default (0, 0, 0)
        Pose ``[x, y, θ]`` of the base frame.
    n_quadrature : int, default 16
        Gauss–Legendre nodes per segment.  The integrands are smooth in ``s``
        with frequency ``|κ|``; with 16 nodes M and G agree with a 60-node
        quadrature to ~1e-14 for ``|κ L|`` up to 12 rad.

    Attributes
    ----------
    kinematics : PlanarPCS
    n_q : int
        ``3m``.
    stiffness : ndarray, shape (3m,)
        Diagonal of ``K``.
    damping : ndarray, shape (3m,)
        Diagonal of ``D``.
    """

    def __init__(
        self,
        segment_lengths: Sequence[float],
        density: float | ArrayLike,
        youngs_modulus: float | ArrayLike,
        shear_modulus: float | ArrayLike,
        damping: ArrayLike,
        radius: float | ArrayLike = 0.02,
        gravity: ArrayLike = (0.0, 9.81),
        shear_factor: float = 4.0 / 3.0,
        stiffness_scaling: str = "seed",
        base_pose: ArrayLike = (0.0, 0.0, 0.0),
        n_quadrature: int = 16,
    ) -> None:
        self.kinematics = PlanarPCS(tuple(np.atleast_1d(np.asarray(segment_lengths, dtype=float))),
                                    base_pose=tuple(_finite_vector(base_pose, 3, "base_pose")))
        m = self.kinematics.n_segments
        self.segment_lengths = np.asarray(self.kinematics.segment_lengths)
        self.n_segments = m
        self.n_q = 3 * m
        self.density = _per_segment(density, m, "density", positive=True)
        self.youngs_modulus = _per_segment(youngs_modulus, m, "youngs_modulus", positive=False)
        self.shear_modulus = _per_segment(shear_modulus, m, "shear_modulus", positive=False)
        self.radius = _per_segment(radius, m, "radius", positive=True)
        damping_arr = _finite_vector(damping, self.n_q, "damping")
        if np.any(damping_arr < 0):
            raise ValueError(f"damping must be >= 0; got {damping_arr.tolist()}")
        self.damping = damping_arr
        self.gravity = _finite_vector(gravity, 2, "gravity")
        if not (np.isfinite(shear_factor) and shear_factor > 0):
            raise ValueError(f"shear_factor must be finite and > 0; got {shear_factor!r}")
        self.shear_factor = float(shear_factor)
        if stiffness_scaling not in ("seed", "length"):
            raise ValueError(f"stiffness_scaling must be 'seed' or 'length'; got {stiffness_scaling!r}")
        self.stiffness_scaling = stiffness_scaling
        self.base_pose = np.asarray(self.kinematics.base_pose)
        if isinstance(n_quadrature, bool) or int(n_quadrature) != n_quadrature or n_quadrature < 1:
            raise ValueError(f"n_quadrature must be a positive integer; got {n_quadrature!r}")
        self.n_quadrature = int(n_quadrature)

        self.area = np.pi * self.radius**2
        self.second_moment = np.pi * self.radius**4 / 4.0
        f_len = np.ones(m) if stiffness_scaling == "seed" else self.segment_lengths
        self.stiffness = (
            f_len[:, None]
            * np.stack(
                [self.youngs_modulus * self.second_moment, self.shear_factor * self.shear_modulus * self.area,
                 self.youngs_modulus * self.area],
                axis=1,
            )
        ).reshape(-1)
        self._precompute()

    # -- structure shared by every evaluation --------------------------------
    def _precompute(self) -> None:
        m, K, L = self.n_segments, self.n_quadrature, self.segment_lengths
        x, w = np.polynomial.legendre.leggauss(K)
        nodes = 0.5 * (x + 1.0)[None, :] * L[:, None]  # (m, K)
        weights = 0.5 * w[None, :] * L[:, None]
        # arc lengths per segment: the K nodes, then the segment's full length (its end)
        self._ell = np.concatenate([nodes, L[:, None]], axis=1)  # (m, K+1)
        self._ell2 = self._ell**2
        self._ell3 = self._ell**3
        self._i_ell = 1j * self._ell
        self._i_ell2 = 1j * self._ell2
        self._nodes = nodes
        self._w_lin = (weights * (self.density * self.area)[:, None]).reshape(-1)  # ρ A w per node
        self._strict = np.tril(np.ones((m, m)), -1)  # [i, j] = 1 where segment j precedes i
        self._strict_b = self._strict[None, :, None, :, None].astype(bool)  # (1, m, 1, m, 1)
        self._diag = np.arange(m)
        self._g_conj = complex(self.gravity[0], -self.gravity[1])
        self._z_base = complex(self.base_pose[0], self.base_pose[1])
        # orientation Jacobian: dθ(s)/dκ_j = L_j for j before the node's segment, s in it
        jo = np.zeros((m, K, self.n_q))
        for i in range(m):
            for j in range(i):
                jo[i, :, 3 * j] = L[j]
            jo[i, :, 3 * i] = nodes[i]
        jo = jo.reshape(m * K, self.n_q)
        w_rot = (weights * (self.density * self.second_moment)[:, None]).reshape(-1)
        self._mass_rot = jo.T @ (w_rot[:, None] * jo)
        # accepted steps, Newton iterations, Jacobians, rejected/repeated steps of the last compiled Radau run
        self._radau_stats = np.zeros(4, dtype=np.int64)

    # -- input checks -----------------------------------------------------------
    def _check(self, name: str, value: ArrayLike, like: NDArray | None = None) -> NDArray[np.float64]:
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] != self.n_q:
            raise ValueError(f"{name} must have a last axis of length n_q = {self.n_q}; got shape {arr.shape}")
        if like is not None and arr.shape != like.shape:
            raise ValueError(f"{name} must have the same shape as q, {like.shape}; got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
        return arr

    # -- kinematic core ---------------------------------------------------------
    def _segment_terms(self, q: NDArray, qd: NDArray | None, need: str):
        """Closed-form terms at every node and segment end for flattened batches (B, n).

        ``need`` is one of ``"pos"`` (positions), ``"jac"`` (+ Jacobian),
        ``"acc"`` (+ convective accelerations J̇ q̇) or ``"jdot"`` (+ J̇).
        """
        B, m, K = q.shape[0], self.n_segments, self.n_quadrature
        L = self.segment_lengths
        qs = q.reshape(B, m, 3)
        kappa, w = qs[..., 0], qs[..., 1] + 1j * (1.0 + qs[..., 2])  # (B, m)
        ell, ell2 = self._ell, self._ell2
        e0, e1, e2 = backbone_moments(kappa[..., None] * ell)  # (B, m, K+1)
        phi = self.base_pose[2] + np.cumsum(kappa * L, axis=1) - kappa * L  # start angle of each segment
        eph = np.exp(1j * phi)[..., None]  # (B, m, 1)
        wk = w[..., None]
        local = ell * wk * e0
        tseg = eph * local  # (B, m, K+1): displacement from the segment start
        z_start = self._z_base + np.cumsum(tseg[..., K], axis=1) - tseg[..., K]  # (B, m)
        z_end = z_start + tseg[..., K]
        z_nodes = z_start[..., None] + tseg[..., :K]  # (B, m, K)
        out = {"z": z_nodes}
        if need == "pos":
            return out
        # derivative of each segment's displacement w.r.t. its own strains (κ, σ_sh, σ_ax)
        own = np.empty((B, m, K + 1, 3), dtype=complex)
        own[..., 0] = self._i_ell2 * wk * e1
        own[..., 1] = ell * e0
        own[..., 2] = self._i_ell * e0
        own *= eph[..., None]
        out["J"] = self._assemble(own, z_nodes, z_end)
        if need == "jac":
            return out
        qds = qd.reshape(B, m, 3)
        kd, wd = qds[..., 0], qds[..., 1] + 1j * qds[..., 2]
        phid = (np.cumsum(kd * L, axis=1) - kd * L)[..., None]  # angular velocity of each segment start
        kdk, wdk = kd[..., None], wd[..., None]
        local_d = self._i_ell2 * wk * e1 * kdk + ell * e0 * wdk
        if need == "acc":
            local_dd = (-self._ell3 * wk * e2 * kdk + 2.0 * self._i_ell2 * e1 * wdk) * kdk
            tdd = eph * (-(phid**2) * local + 2j * phid * local_d + local_dd)
            acc = np.cumsum(tdd[..., K], axis=1) - tdd[..., K]
            out["acc"] = acc[..., None] + tdd[..., :K]
            return out
        td = eph * (1j * phid * local + local_d)
        zd_start = np.cumsum(td[..., K], axis=1) - td[..., K]
        zd_end = zd_start + td[..., K]
        zd_nodes = zd_start[..., None] + td[..., :K]
        own_local = own / eph[..., None]
        own_d = np.stack(
            [1j * ell2 * (wdk * e1 + 1j * ell * wk * e2 * kdk), 1j * ell2 * e1 * kdk, -ell2 * e1 * kdk], axis=-1
        )
        owndot = eph[..., None] * (1j * phid[..., None] * own_local + own_d)
        out["Jdot"] = self._assemble(owndot, zd_nodes, zd_end)
        return out

    def _assemble(self, own: NDArray, z_nodes: NDArray, z_end: NDArray) -> NDArray[np.complex128]:
        """Jacobian (B, m·K, n) at the nodes from per-segment own derivatives and positions.

        Works for the Jacobian and, fed with time derivatives, for its time derivative.
        """
        B, m, K = z_nodes.shape
        jac = np.empty((B, m, K, m, 3), dtype=complex)
        jac[...] = np.where(self._strict_b, own[:, None, None, :, K, :], 0.0)
        jac[:, self._diag, :, self._diag, :] = own[:, :, :K, :].transpose(1, 0, 2, 3)
        # bending of an earlier segment j swings the node rigidly about that segment's end
        lever = 1j * self.segment_lengths[None, None, None, :] * (z_nodes[..., None] - z_end[:, None, None, :])
        jac[..., 0] += self._strict[None, :, None, :] * lever
        return jac.reshape(B, m * K, self.n_q)

    def _flatten(self, *arrays: NDArray) -> tuple[tuple[int, ...], list[NDArray]]:
        lead = arrays[0].shape[:-1]
        return lead, [a.reshape(-1, self.n_q) for a in arrays]

    # -- dynamics terms -----------------------------------------------------------
    def _mass(self, J: NDArray) -> NDArray[np.float64]:
        wj = J * self._w_lin[None, :, None]
        return (np.conj(wj).transpose(0, 2, 1) @ J).real + self._mass_rot

    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """Mass matrix ``M(q)``, shape (..., n, n), symmetric positive definite."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        M = self._mass(self._segment_terms(qf, None, "jac")["J"])
        return M.reshape(lead + (self.n_q, self.n_q))

    def coriolis_forces(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Coriolis and centrifugal forces ``C(q, q̇) q̇``, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        lead, (qf, qdf) = self._flatten(q, qd)
        t = self._segment_terms(qf, qdf, "acc")
        return self._coriolis_vector(t).reshape(lead + (self.n_q,))

    def _coriolis_vector(self, t: dict) -> NDArray[np.float64]:
        acc = t["acc"].reshape(t["acc"].shape[0], -1) * self._w_lin
        return np.einsum("bpa,bp->ba", np.conj(t["J"]), acc).real

    def coriolis_matrix(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Christoffel-based ``C(q, q̇)``, shape (..., n, n); ``Ṁ − 2C`` is skew-symmetric."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        lead, (qf, qdf) = self._flatten(q, qd)
        t = self._segment_terms(qf, qdf, "jdot")
        wj = t["J"] * self._w_lin[None, :, None]
        C = (np.conj(wj).transpose(0, 2, 1) @ t["Jdot"]).real
        return C.reshape(lead + (self.n_q, self.n_q))

    def _gravity(self, J: NDArray) -> NDArray[np.float64]:
        return -((self._g_conj * self._w_lin)[None, :, None] * J).sum(axis=1).real

    def gravity_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """Gravitational forces ``G(q) = ∂U_g/∂q``, shape (..., n)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        return self._gravity(self._segment_terms(qf, None, "jac")["J"]).reshape(lead + (self.n_q,))

    def elastic_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """Elastic forces ``K q``, shape (..., n)."""
        return self._check("q", q) * self.stiffness

    def damping_forces(self, qd: ArrayLike) -> NDArray[np.float64]:
        """Damping forces ``D q̇``, shape (..., n)."""
        return self._check("qd", qd) * self.damping

    def gravitational_energy(self, q: ArrayLike) -> NDArray[np.float64]:
        """``U_g = −Σ ∫ ρ A gᵀ p ds``, shape (...)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        z = self._segment_terms(qf, None, "pos")["z"].reshape(qf.shape[0], -1)
        return -(self._g_conj * z * self._w_lin).sum(axis=1).real.reshape(lead)

    def potential_energy(self, q: ArrayLike) -> NDArray[np.float64]:
        """``U_g + ½ qᵀ K q``, shape (...)."""
        q = self._check("q", q)
        return self.gravitational_energy(q) + 0.5 * np.sum(self.stiffness * q * q, axis=-1)

    def kinetic_energy(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """``½ q̇ᵀ M(q) q̇``, shape (...)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        M = self.mass_matrix(q)
        return 0.5 * np.einsum("...a,...ab,...b->...", qd, M, qd)

    def total_energy(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Kinetic plus potential energy, shape (...)."""
        return self.kinetic_energy(q, qd) + self.potential_energy(q)

    def _bias(self, qf: NDArray, qdf: NDArray) -> tuple[NDArray, NDArray]:
        """Mass matrix and ``C q̇ + G + K q + D q̇`` for flattened batches."""
        t = self._segment_terms(qf, qdf, "acc")
        M = self._mass(t["J"])
        bias = self._coriolis_vector(t) + self._gravity(t["J"]) + self.stiffness * qf + self.damping * qdf
        return M, bias

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Generalised forces ``τ = M q̈ + C q̇ + G + K q + D q̇``, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        qdd = self._check("qdd", qdd, q)
        lead, (qf, qdf, qddf) = self._flatten(q, qd, qdd)
        M, bias = self._bias(qf, qdf)
        return (np.einsum("bij,bj->bi", M, qddf) + bias).reshape(lead + (self.n_q,))

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> NDArray[np.float64]:
        """Accelerations ``q̈ = M⁻¹ (τ − C q̇ − G − K q − D q̇)``, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        tau = self._check("tau", tau, q)
        lead, (qf, qdf, tauf) = self._flatten(q, qd, tau)
        return self._accel(qf, qdf, tauf).reshape(lead + (self.n_q,))

    def _accel(self, qf: NDArray, qdf: NDArray, tauf: NDArray) -> NDArray[np.float64]:
        M, bias = self._bias(qf, qdf)
        return np.linalg.solve(M, (tauf - bias)[..., None])[..., 0]

    # -- simulation -----------------------------------------------------------------
    def simulate(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        t: ArrayLike,
        tau: ArrayLike | Callable[[float], ArrayLike],
        *,
        rtol: float | None = None,
        atol: float | None = None,
        method: str = "Radau",
        max_step: float = np.inf,
        fixed_step: float | None | str = "auto",
        progress: bool = False,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Integrate the equations of motion and sample them at the time stamps ``t``.

        Parameters
        ----------
        q0, qd0 : array_like, shape (n,) or (B, n)
            Initial configuration and velocity at ``t[0]``.  A leading batch
            axis simulates B robots on the same time grid at once.
        t : array_like, shape (T,)
            Strictly increasing time stamps.
        tau : array_like, shape (T, n) or (T, B, n), or callable
            Actuation held constant on ``[t_k, t_{k+1})`` (zero-order hold, the
            last row is not used), or a function ``tau(t)`` returning shape
            (n,) or (B, n).
        rtol, atol : float, optional
            Local error tolerances (defaults 1e-6 and 1e-8).  Giving either
            switches the default ``"Radau"`` to error-controlled stepping.
        method : str, default "Radau"
            ``"Radau"``: implicit Radau IIA (order 5, L-stable) — the
            shear/axial modes make these robots stiff.  With tabulated ``tau``
            it runs compiled (numba), each robot of a batch with its own steps
            and Newton iterations; the first call on a machine compiles the
            kernels (~30 s, cached on disk afterwards).  ``"DOP853"``,
            ``"RK45"``: explicit Runge–Kutta (accurate at very tight
            tolerances, slow on stiff robots), also compiled with tabulated
            ``tau`` (each robot its own steps).  All three step across samples
            without restarts and land on every sample time.  ``"BDF"``,
            ``"LSODA"``, ``"RK23"``: :func:`scipy.integrate.solve_ivp`,
            restarted wherever the held actuation changes (one robot only).
        max_step : float, default inf
            Largest internal step.
        fixed_step : float, None or "auto", default "auto"
            A float turns error control off and takes steps of this size
            (shortened to land on every sample time); ``rtol``/``atol`` then
            only set the Newton tolerance.  None keeps error control on.
            ``"auto"``: 0.5 ms for ``"Radau"`` when neither ``rtol`` nor
            ``atol`` is given, error control otherwise.  Fixed steps are much
            faster on these stiff robots, where error control resolves the fast
            shear/axial transient after every switch of a held actuation; on
            two_segment, 0.5 ms Radau steps stay within ~1e-6 of the exact
            samples relative to each strain's range (see
            benchmarks/simulation_speed.py).  Lightly damped kHz modes (e.g.
            the ×1000 stiffened strains of two_segment_stiff_axial_shear) are
            numerically damped by such steps; use error control to resolve them.
        progress : bool, default False
            Show a tqdm progress bar over the samples.

        Returns
        -------
        q, qd : ndarray, shape (T, n) or (T, B, n)

        Raises
        ------
        SimulationError
            If the integration fails (step size collapses or the state becomes
            non-finite), naming the time where it happened.
        """
        q0 = self._check("q0", q0)
        qd0 = self._check("qd0", qd0, q0)
        if q0.ndim > 2:
            raise ValueError(f"q0 must have shape (n,) or (B, n); got shape {q0.shape}")
        t = np.asarray(t, dtype=float)
        if t.ndim != 1 or t.size < 1:
            raise ValueError(f"t must be a non-empty 1-D array of time stamps; got shape {t.shape}")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ValueError("t must be finite and strictly increasing")
        if isinstance(fixed_step, str):
            if fixed_step != "auto":
                raise ValueError(f"fixed_step must be a float, None or 'auto'; got {fixed_step!r}")
            fixed_step = 5e-4 if (method == "Radau" and rtol is None and atol is None) else None
        rtol = 1e-6 if rtol is None else rtol
        atol = 1e-8 if atol is None else atol
        for name, val in (("rtol", rtol), ("atol", atol)):
            if not (np.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be finite and > 0; got {val!r}")
        if not (max_step > 0):
            raise ValueError(f"max_step must be > 0; got {max_step!r}")
        if fixed_step is not None:
            if not (np.isfinite(fixed_step) and fixed_step > 0):
                raise ValueError(f"fixed_step must be finite and > 0 or None; got {fixed_step!r}")
            if method not in _OWN_RK and method != "Radau":
                raise ValueError(f"fixed_step needs method 'Radau', 'DOP853' or 'RK45'; got {method!r}")
            max_step = min(max_step, fixed_step)
        batch_shape = q0.shape[:-1]
        if callable(tau):
            tau_fn = self._wrap_tau_callable(tau, batch_shape)
            tau_rows = None
        else:
            tau_rows = self._check("tau", tau)
            if tau_rows.shape != (t.size,) + q0.shape:
                raise ValueError(
                    f"tau must have shape (len(t),) + q0.shape = {(t.size,) + q0.shape}; got shape {tau_rows.shape}"
                )
            tau_fn = None
        if method == "Radau":
            return self._simulate_radau(q0, qd0, t, tau_rows, tau_fn, rtol, atol, max_step, fixed_step, progress)
        if method in _OWN_RK:
            return self._simulate_rk(
                q0, qd0, t, tau_rows, tau_fn, _OWN_RK[method], rtol, atol, max_step, fixed_step, progress
            )
        if method in _SCIPY_METHODS:
            if q0.ndim != 1:
                raise ValueError(f"method {method!r} simulates one robot at a time; q0 must have shape ({self.n_q},)")
            return self._simulate_scipy(q0, qd0, t, tau_rows, tau_fn, method, rtol, atol, max_step, progress)
        raise ValueError(f"method must be one of {list(_METHODS)}; got {method!r}")

    def _wrap_tau_callable(self, tau: Callable, batch_shape: tuple[int, ...]) -> Callable[[float], NDArray]:
        shape = batch_shape + (self.n_q,)

        def fn(time: float) -> NDArray:
            val = np.asarray(tau(time), dtype=float)
            if val.shape != shape:
                raise ValueError(f"tau(t) must return shape {shape}; got shape {val.shape} at t = {time:g}")
            if not np.all(np.isfinite(val)):
                raise ValueError(f"tau(t) returned NaN or inf at t = {time:g}")
            return val

        return fn

    def _jit_geometry(self) -> tuple:
        """Robot structure for the compiled kernels of :mod:`._jit`.

        Built at every call: ``stiffness`` and ``damping`` are public attributes
        that users (and the scenarios) may rescale after construction.
        """
        return (
            np.ascontiguousarray(self.segment_lengths, dtype=float),
            np.ascontiguousarray(self._ell),
            np.ascontiguousarray(self._w_lin),
            np.ascontiguousarray(self._mass_rot),
            np.ascontiguousarray(self.stiffness, dtype=float),
            np.ascontiguousarray(self.damping, dtype=float),
            complex(self._g_conj),
            complex(self._z_base),
            float(self.base_pose[2]),
        )

    def _rhs_flat(self, y: NDArray, tau: NDArray) -> NDArray:
        """State derivative for states (B, 2n) (compiled; NaN rows where M is not positive definite)."""
        from . import _jit

        return _jit.rhs_batch(np.ascontiguousarray(y, dtype=float), np.ascontiguousarray(tau, dtype=float),
                              self._jit_geometry())

    def _rhs_numpy(self, y: NDArray, tau: NDArray) -> NDArray:
        """State derivative for states (B, 2n), batched numpy (the reference for the compiled path)."""
        n = self.n_q
        try:
            qdd = self._accel(y[:, :n], y[:, n:], tau)
        except np.linalg.LinAlgError:
            # a state the model cannot handle: let the integrator shrink the step or fail clearly
            return np.full(y.shape, np.nan)
        return np.concatenate([y[:, n:], qdd], axis=1)

    def _jacobian_fd(self, y: NDArray, f0: NDArray, tau: NDArray) -> NDArray[np.float64]:
        """Jacobian of the state derivative, (B, N, N), by forward differences in one batched call."""
        B, N = y.shape
        delta = 1.5e-8 * np.maximum(np.abs(y), 1e-3)
        yp = np.repeat(y[:, None, :], N, axis=1)
        yp[:, np.arange(N), np.arange(N)] += delta
        fp = self._rhs_flat(yp.reshape(B * N, N), np.repeat(tau, N, axis=0)).reshape(B, N, N)
        return ((fp - f0[:, None, :]) / delta[:, :, None]).transpose(0, 2, 1)

    def _simulate_radau(self, q0, qd0, t, tau_rows, tau_fn, rtol, atol, max_step, fixed_step, progress):
        """Batched Radau IIA (order 5) with simplified Newton iterations.

        The three stages are evaluated in one batched call per Newton
        iteration; the Jacobian comes from one batched call of forward
        differences and is reused while Newton converges quickly.
        """
        from . import _jit

        from tqdm.auto import tqdm

        if tau_fn is None and self._own_rhs():
            return self._simulate_radau_jit(q0, qd0, t, tau_rows, rtol, atol, max_step, fixed_step, progress)
        n, T = self.n_q, t.size
        single = q0.ndim == 1
        y = np.concatenate([np.atleast_2d(q0), np.atleast_2d(qd0)], axis=1)  # (B, N)
        B, N = y.shape
        out = np.empty((T, B, N))
        out[0] = y
        eye_n = np.eye(N)
        newton_tol = max(10 * np.finfo(float).eps / rtol, min(0.03, rtol**0.5))
        zoh = tau_fn is None

        def tau_at(k: int, time: float) -> NDArray:
            if zoh:
                return tau_rows[k].reshape(B, n)
            return np.atleast_2d(tau_fn(time)).reshape(B, n)

        def rhs_stages(time, h, Z, k, with_y0):
            """f at the stage states (B, 3, N), plus f(t, y) when with_y0."""
            states = y[:, None, :] + Z
            if zoh:
                taus = np.repeat(tau_at(k, time)[:, None, :], 3, axis=1)
            else:
                taus = np.stack([tau_at(k, time + c * h) for c in _RADAU_C], axis=1)
            if with_y0:
                states = np.concatenate([y[:, None, :], states], axis=1)
                taus = np.concatenate([tau_at(k, time)[:, None, :], taus], axis=1)
            f = self._rhs_flat(states.reshape(-1, N), taus.reshape(-1, n)).reshape(B, -1, N)
            return (f[:, 0], f[:, 1:]) if with_y0 else (None, f)

        def rms(x, scale):
            return float(np.max(np.sqrt(np.mean((x / scale) ** 2, axis=-1))))

        time = t[0]
        h = min(t[1] - t[0], max_step) if T > 1 else 0.0
        jac = None
        jac_current = False
        z_prev, h_prev = None, 1.0
        rate_last = None
        inv_cache: dict = {}
        bar = tqdm(total=T - 1, disable=not progress, desc="simulate", unit="sample")
        try:
            for k in range(T - 1):
                t_next = t[k + 1]
                while time < t_next:
                    span = t_next - time
                    step = _jit.step_to_sample(h, time, t_next, max_step)
                    if step < 0.0:
                        raise SimulationError(f"step size collapsed to {-step:.3g} s at t = {time:.6g} s")
                    scale = atol + np.abs(y) * rtol
                    if z_prev is None:
                        Z = np.zeros((B, 3, N))
                    else:
                        # continue the last step's collocation polynomial (Newton starts closer)
                        Z = np.einsum("ij,bjn->bin", _extrapolation_weights(step / h_prev)[:, 1:], z_prev)
                        Z -= z_prev[:, 2:3]
                    f0, F = rhs_stages(time, step, Z, k, True)
                    if not np.all(np.isfinite(f0)):
                        raise SimulationError(f"the state derivative is not finite at t = {time:.6g} s")
                    if jac is None:
                        jac = self._jacobian_fd(y, f0, tau_at(k, time))
                        jac_current = True
                        inv_cache.clear()
                    key = step
                    if key not in inv_cache:
                        # Newton matrix I - h (A ⊗ J) and the error-estimate matrix (mu/h) I - J
                        big = np.eye(3 * N) - step * np.einsum("ij,bkl->bikjl", _RADAU_A, jac).reshape(B, 3 * N, 3 * N)
                        small_m = (_RADAU_MU / step) * eye_n - jac
                        if len(inv_cache) > 8:
                            inv_cache.clear()
                        inv_cache[key] = (np.linalg.inv(big), np.linalg.inv(small_m))
                    inv_big, inv_err = inv_cache[key]
                    hA = step * _RADAU_A
                    converged, rate, dz_old, n_iter = False, None, None, 0
                    for n_iter in range(1, _NEWTON_MAXITER + 1):
                        if n_iter > 1:
                            _, F = rhs_stages(time, step, Z, k, False)
                        if not np.all(np.isfinite(F)):
                            break
                        resid = np.einsum("ij,bjn->bin", hA, F) - Z
                        dZ = (inv_big @ resid.reshape(B, 3 * N, 1)).reshape(B, 3, N)
                        dz = rms(dZ, scale[:, None, :])
                        if dz_old is not None:
                            rate = dz / dz_old
                            if rate >= 1 or rate ** (_NEWTON_MAXITER - n_iter) / (1 - rate) * dz > newton_tol:
                                Z = Z + dZ
                                break
                        Z = Z + dZ
                        # first iteration: judge with the rate seen in the last step (Hairer's RADAU5)
                        known = rate if rate is not None else rate_last
                        if dz == 0 or (known is not None and known < 1 and known / (1 - known) * dz < newton_tol):
                            converged = True
                            break
                        dz_old = dz
                    if not converged:
                        z_prev = None
                        if not jac_current:
                            jac = self._jacobian_fd(y, f0, tau_at(k, time))
                            jac_current = True
                            inv_cache.clear()
                        else:
                            h = 0.5 * step
                        continue
                    if rate is not None:
                        rate_last = rate
                    y_new = y + Z[:, 2]
                    if fixed_step is not None:
                        time = t_next if step == span else time + step
                        y, z_prev, h_prev, h = y_new, Z, step, max_step
                        if n_iter > 2 and rate is not None and rate > 1e-3:
                            jac = None
                        else:
                            jac_current = False
                        continue
                    ZE = np.einsum("i,bin->bn", _RADAU_E, Z) / step
                    err = (inv_err @ (f0 + ZE)[..., None])[..., 0]
                    err_scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
                    err_norm = rms(err, err_scale)
                    safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
                    if err_norm > 1:
                        # refined estimate (Hairer & Wanner) before rejecting: filters stiff components
                        f_err = self._rhs_flat(y + err, tau_at(k, time))
                        err = (inv_err @ (f_err + ZE)[..., None])[..., 0]
                        err_norm = rms(err, err_scale) if np.all(np.isfinite(err)) else np.inf
                    if not err_norm <= 1:
                        factor = 0.2 if not np.isfinite(err_norm) else max(0.2, safety * err_norm**-0.25)
                        h = step * factor
                        z_prev = None
                        continue
                    # accept
                    z_prev, h_prev = Z, step
                    time = t_next if step == span else time + step
                    y = y_new
                    factor = 10.0 if err_norm == 0 else min(10.0, safety * err_norm**-0.25)
                    h = max(h, step * factor) if step < h else step * factor
                    if n_iter > 2 and rate is not None and rate > 1e-3:
                        jac = None  # slow Newton convergence: refresh the Jacobian next step
                    else:
                        jac_current = False
                out[k + 1] = y
                bar.update(1)
        finally:
            bar.close()
        q, qd = out[..., :n], out[..., n:]
        if single:
            q, qd = q[:, 0], qd[:, 0]
        return q, qd

    def _own_rhs(self) -> bool:
        """Whether the state derivative is this class's own (the compiled loop evaluates it directly)."""
        return "_rhs_flat" not in vars(self) and type(self)._rhs_flat is PCSRobot._rhs_flat

    def _simulate_radau_jit(self, q0, qd0, t, tau_rows, rtol, atol, max_step, fixed_step, progress):
        """Radau IIA with the whole time loop compiled (zero-order-hold actuation).

        Same scheme and step-size logic as :meth:`_simulate_radau`, but every
        robot of a batch has its own step size and Newton iteration.  Runs in
        chunks of samples only to update the progress bar.
        """
        from tqdm.auto import tqdm

        from . import _jit

        n, T = self.n_q, t.size
        single = q0.ndim == 1
        y0 = np.concatenate([np.atleast_2d(q0), np.atleast_2d(qd0)], axis=1)
        B, N = y0.shape
        out = np.empty((T, B, N))
        out[0] = y0
        taus = np.ascontiguousarray(tau_rows.reshape(T, B, n))
        t_c = np.ascontiguousarray(t, dtype=float)
        h0 = min(t[1] - t[0], max_step) if T > 1 else 0.0
        h = np.full(B, h0)
        h_prev = np.ones(B)
        have_z = np.zeros(B, dtype=bool)
        z_prev = np.zeros((B, 3, N))
        rate_last = np.full(B, -1.0)
        jac = np.zeros((B, n, N))  # [∂q̈/∂q, ∂q̈/∂q̇]
        jac_state = np.zeros(B, dtype=np.int64)
        h_lu = np.full(B, -1.0)
        lu_big, piv_big = np.zeros((B, 3 * n, 3 * n)), np.zeros((B, 3 * n), dtype=np.int64)
        lu_small, piv_small = np.zeros((B, n, n)), np.zeros((B, n), dtype=np.int64)
        geo = self._jit_geometry()
        fixed = fixed_step is not None
        # accepted steps, Newton iterations, Jacobians, rejected/repeated steps of the last run (diagnostics)
        self._radau_stats = np.zeros(4, dtype=np.int64)
        chunk = max(1, (T - 1) // 20) if progress else max(T - 1, 1)
        bar = tqdm(total=T - 1, disable=not progress, desc="simulate", unit="sample")
        try:
            for k0 in range(0, T - 1, chunk):
                k1 = min(k0 + chunk, T - 1)
                status, when, _ = _jit.radau_run(
                    k0, k1, t_c, taus, out, h, h_prev, have_z, z_prev, rate_last, jac, jac_state, h_lu, lu_big, piv_big,
                    lu_small, piv_small, geo,
                    float(rtol), float(atol), float(max_step), fixed, _RADAU_A, _RADAU_C, _RADAU_E, _RADAU_MU,
                    _JAC_REFRESH_RATE, self._radau_stats,
                )
                if status == _jit.NONFINITE:
                    raise SimulationError(f"the state derivative is not finite at t = {when:.6g} s")
                if status == _jit.COLLAPSE:
                    raise SimulationError(f"step size collapsed at t = {when:.6g} s")
                bar.update(k1 - k0)
        finally:
            bar.close()
        q, qd = out[..., :n], out[..., n:]
        if single:
            q, qd = q[:, 0], qd[:, 0]
        return q, qd

    def _simulate_rk_jit(self, q0, qd0, t, tau_rows, tableau, rtol, atol, max_step, fixed_step):
        """Explicit Runge–Kutta with the whole time loop compiled; every robot of a batch has its own steps."""
        from . import _jit

        n, T = self.n_q, t.size
        single = q0.ndim == 1
        y0 = np.concatenate([np.atleast_2d(q0), np.atleast_2d(qd0)], axis=1)
        B, N = y0.shape
        out = np.empty((T, B, N))
        out[0] = y0
        S = tableau.n_stages
        is_dop853 = tableau is DOP853
        dummy = np.zeros(S + 1)
        self._rk_stats = np.zeros(2, dtype=np.int64)
        status, when, _ = _jit.rk_run(
            np.ascontiguousarray(t, dtype=float), np.ascontiguousarray(tau_rows.reshape(T, B, n)), out,
            self._jit_geometry(), float(rtol), float(atol), float(max_step), fixed_step is not None,
            np.ascontiguousarray(tableau.A[:S, :S], dtype=float), np.ascontiguousarray(tableau.B, dtype=float),
            np.ascontiguousarray(tableau.C[:S], dtype=float),
            dummy if is_dop853 else np.ascontiguousarray(tableau.E, dtype=float),
            np.ascontiguousarray(tableau.E3[: S + 1], dtype=float) if is_dop853 else dummy,
            np.ascontiguousarray(tableau.E5[: S + 1], dtype=float) if is_dop853 else dummy,
            is_dop853, -1.0 / (tableau.error_estimator_order + 1), self._rk_stats,
        )
        if status == _jit.NONFINITE:
            raise SimulationError(f"the state derivative is not finite at t = {when:.6g} s")
        if status == _jit.COLLAPSE:
            raise SimulationError(f"step size collapsed at t = {when:.6g} s")
        q, qd = out[..., :n], out[..., n:]
        if single:
            q, qd = q[:, 0], qd[:, 0]
        return q, qd

    def _simulate_rk(self, q0, qd0, t, tau_rows, tau_fn, tableau, rtol, atol, max_step, fixed_step, progress):
        from tqdm.auto import tqdm

        from . import _jit

        if tau_fn is None and self._own_rhs():
            with tqdm(total=t.size - 1, disable=not progress, desc="simulate", unit="sample") as bar:
                out = self._simulate_rk_jit(q0, qd0, t, tau_rows, tableau, rtol, atol, max_step, fixed_step)
                bar.update(t.size - 1)
            return out

        n, T = self.n_q, t.size
        single = q0.ndim == 1
        y = np.concatenate([np.atleast_2d(q0), np.atleast_2d(qd0)], axis=1)  # (B, 2n)
        B = y.shape[0]
        out = np.empty((T, B, 2 * n))
        out[0] = y
        n_stages = tableau.n_stages
        A, Bw, Cc = tableau.A[:n_stages, :n_stages], tableau.B, tableau.C[:n_stages]
        is_dop853 = tableau is DOP853
        err_exp = -1.0 / (tableau.error_estimator_order + 1)
        K = np.empty((n_stages, B, 2 * n))

        def tau_at(k: int, time: float) -> NDArray:
            if tau_fn is not None:
                return np.atleast_2d(tau_fn(time)).reshape(B, n)
            return tau_rows[k].reshape(B, n)

        time = t[0]
        h = min(t[1] - t[0], max_step) if T > 1 else 0.0
        fsal = None
        bar = tqdm(total=T - 1, disable=not progress, desc="simulate", unit="sample")
        try:
            for k in range(T - 1):
                t_next = t[k + 1]
                tau_const = None if tau_fn is not None else tau_at(k, time)
                if tau_fn is None and k > 0 and not np.array_equal(tau_rows[k], tau_rows[k - 1]):
                    fsal = None  # the held actuation switched: the last derivative is stale
                while time < t_next:
                    span = t_next - time
                    step = _jit.step_to_sample(h, time, t_next, max_step)
                    if step < 0.0:
                        raise SimulationError(f"step size collapsed to {-step:.3g} s at t = {time:.6g} s")
                    # stages
                    for s in range(n_stages):
                        if s == 0 and fsal is not None:
                            K[0] = fsal
                            continue
                        ys = y + step * np.tensordot(A[s, :s], K[:s], axes=(0, 0)) if s else y
                        tau_s = tau_const if tau_const is not None else tau_at(k, time + Cc[s] * step)
                        K[s] = self._rhs_flat(ys, tau_s)
                    y_new = y + step * np.tensordot(Bw, K, axes=(0, 0))
                    tau_new = tau_const if tau_const is not None else tau_at(k, time + step)
                    if fixed_step is not None and np.all(np.isfinite(y_new)):
                        err_norm = 0.0
                        f_new = None
                    elif not np.all(np.isfinite(y_new)):
                        err_norm = np.inf
                        f_new = None
                    else:
                        f_new = self._rhs_flat(y_new, tau_new)
                        scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
                        if is_dop853:
                            e5 = np.tensordot(tableau.E5[:n_stages], K, axes=(0, 0)) + tableau.E5[-1] * f_new
                            e3 = np.tensordot(tableau.E3[:n_stages], K, axes=(0, 0)) + tableau.E3[-1] * f_new
                            e5n = np.sum((e5 / scale) ** 2, axis=1)
                            e3n = np.sum((e3 / scale) ** 2, axis=1)
                            denom = e5n + 0.01 * e3n
                            with np.errstate(invalid="ignore", divide="ignore"):
                                norms = np.where(denom > 0, step * e5n / np.sqrt(denom * 2 * n), 0.0)
                        else:
                            err = step * (np.tensordot(tableau.E[:n_stages], K, axes=(0, 0)) + tableau.E[-1] * f_new)
                            norms = np.sqrt(np.mean((err / scale) ** 2, axis=1))
                        err_norm = float(np.max(norms))
                        if not np.all(np.isfinite(f_new)):
                            err_norm = np.inf
                    if err_norm <= 1.0:
                        time = t_next if step == span else time + step
                        y = y_new
                        fsal = f_new
                        factor = 10.0 if err_norm == 0 else min(10.0, 0.9 * err_norm**err_exp)
                        # a step shortened to land on a sample must not shrink the proposal
                        h = max(h, step * factor) if step < h else step * factor
                    else:
                        h = step * (0.2 if not np.isfinite(err_norm) else max(0.2, 0.9 * err_norm**err_exp))
                out[k + 1] = y
                bar.update(1)
        finally:
            bar.close()
        q, qd = out[..., :n], out[..., n:]
        if single:
            q, qd = q[:, 0], qd[:, 0]
        return q, qd

    def _simulate_scipy(self, q0, qd0, t, tau_rows, tau_fn, method, rtol, atol, max_step, progress):
        from tqdm.auto import tqdm

        n, T = self.n_q, t.size
        out = np.empty((T, 2 * n))
        out[0] = np.concatenate([q0, qd0])
        # restart only where the held actuation changes; sample in between with t_eval
        if tau_fn is None:
            change = np.flatnonzero(np.any(np.diff(tau_rows[:-1], axis=0) != 0, axis=1)) + 1
            starts = np.concatenate([[0], change]).astype(int)
            ends = np.concatenate([change, [T - 1]]).astype(int)
        else:
            starts, ends = np.array([0]), np.array([T - 1])
        bar = tqdm(total=T - 1, disable=not progress, desc="simulate", unit="sample")
        try:
            for a, b in zip(starts, ends):
                if b <= a:
                    continue
                if tau_fn is None:
                    held = tau_rows[a][None, :]
                    fun = lambda tt, yy, held=held: self._rhs_flat(yy[None, :], held)[0]  # noqa: E731
                else:
                    fun = lambda tt, yy: self._rhs_flat(yy[None, :], tau_fn(tt)[None, :])[0]  # noqa: E731
                sol = solve_ivp(fun, (t[a], t[b]), out[a], method=method, t_eval=t[a + 1 : b + 1],
                                rtol=rtol, atol=atol, max_step=max_step)
                if sol.status != 0 or sol.y.shape[1] != b - a or not np.all(np.isfinite(sol.y)):
                    raise SimulationError(f"{method} failed on [{t[a]:.6g}, {t[b]:.6g}] s: {sol.message}")
                out[a + 1 : b + 1] = sol.y.T
                bar.update(b - a)
        finally:
            bar.close()
        return out[:, :n], out[:, n:]
