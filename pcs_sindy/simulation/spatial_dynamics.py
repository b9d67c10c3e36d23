"""Ground-truth dynamics of a spatial (3-D) Piecewise Constant Strain robot, and its tendons.

The spatial counterpart of :mod:`pcs_sindy.simulation.dynamics` (issue 26 conventions, six strains
per segment in the order of :data:`pcs_sindy.core.SPATIAL_STRAIN_NAMES`):

    M(q) q̈ + C(q, q̇) q̇ + G(q) + K q + D q̇ = τ = A(q) u

with ``M = Σ_i ∫ (ρA J_pᵀ J_p + J_wᵀ I_b J_w) ds``, ``I_b = diag(ρI, 2ρI, ρI)`` in the body frame
(the polar moment about the tangent y), ``J_w`` the body angular Jacobian,
``C q̇ = Σ_i ∫ ρA J_pᵀ (J̇_p q̇) + J_wᵀ (I_b (J̇_w q̇) + ω × I_b ω) ds``,
``G = −Σ_i ρA ∫ J_pᵀ g ds`` and ``K_i = f_L diag(E I, E I, G J, c_sh G A, c_sh G A, E A)``
(``J = 2I``).  The integrals are Gauss–Legendre quadratures of closed-form Jacobians evaluated by
the compiled kernels of :mod:`pcs_sindy.core.spatial_kernels` (shared with the identified spatial model;
one state at a time, batches by a compiled loop) and :mod:`pcs_sindy.simulation._spatial_kernels`
(stiffness, damping, actuation), and the robot is integrated by the planar robot's integrators
(:mod:`pcs_sindy.simulation.integrate`), with the same :meth:`SpatialPCSRobot.simulate` contract.
Restricted to the plane (only ``bend_z``, ``shear_x`` and ``axial``), every term equals the planar
robot's (:class:`~pcs_sindy.simulation.PCSRobot`).

**Tendons** (:class:`SpatialTendons`): tendon k runs at the body offset ``d_k = (d_x, 0, d_z)`` in
the cross-section from the base to its termination at arc length ``s_k``; its path
``p + R d_k`` has the tangent ``R (v + ω × d_k)``, constant inside a constant-strain stretch, so
its length is ``ℓ_k = Σ_i c_ki |v_i + ω_i × d_k|`` exactly (``c_ki`` the rest length of segment i
it covers).  A tension ``f_k ≥ 0`` does the virtual work ``−f_k δℓ_k``: its column of ``A(q)`` is
``−∂ℓ_k/∂q``.

Like the planar simulator this module imports only :mod:`pcs_sindy.core` of the package.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import spatial_kernels
from ..core.simulate_contract import SimulationError
from ..core.spatial import SpatialPCS, SpatialStrainTrajectory
from . import _spatial_kernels
from ._kernels import ACT_IDENTITY, ACT_TENDON
from ._robot_base import RobotBase, finite_array, positive_int
from .integrate import DEFAULT_STEP, UNSET, advance, simulate

__all__ = ["SpatialPCSRobot", "SpatialTendons", "SimulationError"]

Inputs = ArrayLike | Callable[[float], ArrayLike]


# --------------------------------------------------------------------------
# tendons
# --------------------------------------------------------------------------
class SpatialTendons:
    """Tendons from the base to termination arc lengths at fixed offsets in the cross-section.

    Parameters
    ----------
    end : array_like, shape (p,)
        Arc length [m] where each tendon terminates, in ``(0, total length]``.
    offset : array_like, shape (p, 2)
        Offset ``(d_x, d_z)`` [m] of each tendon from the backbone along the body x and z axes.  A
        tendon at ``d_x > 0`` bends the robot towards negative ``bend_z`` (as a planar
        :class:`~pcs_sindy.simulation.Tendons` at offset ``d_x``); one at ``d_z > 0`` towards
        positive ``bend_x``.

    Notes
    -----
    Inputs are tensions [N], ``>= 0``.  Lengths and their gradients in the module docstring.
    """

    kind = "tendon"

    def __init__(self, end: ArrayLike, offset: ArrayLike) -> None:
        self.end = end
        self.offset = offset

    @property
    def n_inputs(self) -> int:
        return int(np.atleast_1d(np.asarray(self.end)).size)

    def _validated(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        end = np.atleast_1d(np.asarray(self.end, dtype=float))
        if end.ndim != 1 or end.size == 0 or not np.all(np.isfinite(end)):
            raise ValueError(f"end must be a non-empty 1-D array of finite arc lengths; got {self.end!r}")
        offset = np.asarray(self.offset, dtype=float)
        if offset.shape == (2,) and end.size == 1:
            offset = offset[None, :]
        offset = finite_array(offset, (end.size, 2), "offset")
        return end, offset

    def layout(self) -> dict[str, Any]:
        """Terminations and offsets, JSON-able."""
        end, offset = self._validated()
        return {"type": "spatial_tendon", "end": end.tolist(), "offset": offset.tolist()}

    def encode(self, segment_lengths: Sequence[float]) -> tuple[int, NDArray, NDArray, NDArray]:
        """Arrays for the compiled kernels: ``(kind, offset (p, 2), span (p, m), matrix (n, 0))``."""
        lengths = np.asarray(segment_lengths, dtype=float)
        end, offset = self._validated()
        total = float(lengths.sum())
        bad = (end <= 0) | (end > total * (1 + 1e-12))
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ValueError(f"end[{k}] = {float(end[k])!r} lies outside the robot: need 0 < end <= {total:g} m")
        bounds = np.concatenate([[0.0], np.cumsum(lengths)])
        span = np.maximum(np.minimum(end[:, None], bounds[None, 1:]) - bounds[None, :-1], 0.0)
        return ACT_TENDON, offset, span, np.zeros((6 * lengths.size, 0))

    def tensions(self, lengths: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Tendon tensions [N]: the inputs themselves."""
        return np.array(u, dtype=float)

    def check_inputs(self, u: NDArray, t: NDArray | float | None, name: str = "u") -> None:
        """Raise a ValueError naming the first negative tension, its input index and time."""
        if np.all(u >= 0):
            return
        idx = np.argwhere(u < 0)[0]
        where = f"{name}[{', '.join(str(int(i)) for i in idx)}]"
        when = "" if t is None else f" at t = {float(t if np.ndim(t) == 0 else t[idx[0]]):g} s"
        k = int(idx[-1])
        raise ValueError(
            f"{where} = {float(u[tuple(idx)])!r}{when}: tendon {k} (ending at "
            f"{float(np.atleast_1d(self.end)[k]):g} m) would push; tendon tensions must be >= 0"
        )

    def __repr__(self) -> str:
        return f"SpatialTendons(end={self.end!r}, offset={self.offset!r})"


# --------------------------------------------------------------------------
# robot
# --------------------------------------------------------------------------
class SpatialPCSRobot(RobotBase):
    """Spatial PCS soft robot: mass, Coriolis, gravity, elastic, damping and actuation terms, and simulation.

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
    damping : array_like, shape (6m,)
        Diagonal of the damping matrix ``D``.
    radius : float or array_like, shape (m,), default 0.02
        Cross-section radius ``r`` (``A = π r²``, ``I = π r⁴/4``, ``J = 2I``).
    gravity : array_like, shape (3,), default (0, 9.81, 0)
        Gravity in the base frame; the default lets the robot hang.
    shear_factor : float, default 4/3
        ``c_sh`` in ``K_i = f_L diag(E I, E I, G J, c_sh G A, c_sh G A, E A)``.
    stiffness_scaling : {"seed", "length"}, default "seed"
        ``f_L = 1`` (the seed's simulator) or ``f_L = L_i``.
    base_position : array_like, shape (3,), default (0, 0, 0)
    base_rotation : array_like, shape (3, 3), optional
        Pose of the base frame (default identity: the robot along +y at rest).
    n_quadrature : int, default 16
        Gauss–Legendre nodes per segment, at most: the dynamics terms give a segment that bends
        little fewer nodes, as many as keep M, G and C q̇ within 2e-14 (relative) of a 48-node
        rule (measured, as close as 16 nodes get): 5 nodes up to ``|ω_i| L_i`` = 0.15 rad, 6 up to
        0.5, 7 up to 1, 8 up to 2, 10 up to 3, 12 up to 6, 14 up to 8 (11 nodes reach only 1e-12
        at 6 rad), ``n_quadrature`` above.
        :meth:`node_jacobians` and the energies use all ``n_quadrature`` nodes.
    actuation : SpatialTendons or None, default None
        None drives the strains directly (``u`` is τ); otherwise ``τ = A(q) u``.

    Attributes
    ----------
    kinematics : SpatialPCS
    n_q : int
        ``6m``.
    n_inputs : int
        ``p``, the number of inputs (``n_q`` without actuation).
    stiffness : ndarray, shape (6m,)
        Diagonal of ``K``.
    damping : ndarray, shape (6m,)
        Diagonal of ``D``.
    """

    _gravity_shape = (3,)

    def __init__(
        self,
        segment_lengths: Sequence[float],
        density: float | ArrayLike,
        youngs_modulus: float | ArrayLike,
        shear_modulus: float | ArrayLike,
        damping: ArrayLike,
        radius: float | ArrayLike = 0.02,
        gravity: ArrayLike = (0.0, 9.81, 0.0),
        shear_factor: float = 4.0 / 3.0,
        stiffness_scaling: str = "seed",
        base_position: ArrayLike = (0.0, 0.0, 0.0),
        base_rotation: ArrayLike | None = None,
        n_quadrature: int = 16,
        actuation: Any = None,
    ) -> None:
        self.kinematics = SpatialPCS(
            tuple(np.atleast_1d(np.asarray(segment_lengths, dtype=float))),
            base_position=tuple(finite_array(base_position, (3,), "base_position")),
            base_rotation=base_rotation,
        )
        m = self.kinematics.n_segments
        self.segment_lengths = np.asarray(self.kinematics.segment_lengths)
        self.n_segments = m
        self.n_q = 6 * m
        self.base_position, self.base_rotation = self.kinematics.base_pose
        f_len = self._set_material(
            density, youngs_modulus, shear_modulus, damping, radius, gravity, shear_factor, stiffness_scaling
        )
        self.n_quadrature = positive_int(n_quadrature, "n_quadrature")
        self.actuation = actuation
        if actuation is None:
            self._act = (ACT_IDENTITY, np.zeros((0, 2)), np.zeros((0, m)), np.zeros((self.n_q, 0)))
            self.n_inputs = self.n_q
        elif isinstance(actuation, SpatialTendons):
            self._act = actuation.encode(self.segment_lengths)
            self.n_inputs = int(actuation.n_inputs)
        else:
            raise ValueError(f"actuation must be None or a SpatialTendons; got {actuation!r}")

        E, G, A, second = self.youngs_modulus, self.shear_modulus, self.area, self.second_moment
        c_sh = self.shear_factor
        per_segment = np.stack([E * second, E * second, 2.0 * G * second, c_sh * G * A, c_sh * G * A, E * A], axis=1)
        self.stiffness = (f_len[:, None] * per_segment).reshape(-1)
        self._precompute()

    def _precompute(self) -> None:
        K, L = self.n_quadrature, self.segment_lengths
        x, w = np.polynomial.legendre.leggauss(K)
        nodes = 0.5 * (x + 1.0)[None, :] * L[:, None]  # (m, K)
        weights = 0.5 * w[None, :] * L[:, None]
        self._ell = np.concatenate([nodes, L[:, None]], axis=1)  # the K nodes, then the segment's end
        starts = np.concatenate([[0.0], np.cumsum(L)[:-1]])
        self._node_arcs = (starts[:, None] + nodes).reshape(-1)  # global arc lengths of the nodes
        self._w_lin = (weights * (self.density * self.area)[:, None]).reshape(-1)
        inertia = (self.density * self.second_moment)[:, None] * np.array([1.0, 2.0, 1.0])[None, :]  # (m, 3)
        self._w_rot = (weights[:, :, None] * inertia[:, None, :]).reshape(-1, 3)
        # the compiled kernels' body: quadrature tiers (fewer nodes where a segment bends little, as accurate)
        # and node weights; the gravity weights are set from the public ``gravity`` at every call
        self._body = spatial_kernels.body_tuple(
            L, K, self.density * self.area, inertia, np.zeros((L.size, 3)), self.base_position, self.base_rotation
        )

    def _jit_geometry(self) -> tuple:
        """Robot structure for :mod:`._spatial_kernels` (layout in its docstring); rebuilt at every call
        because ``stiffness``, ``damping`` and ``gravity`` are public attributes users may change."""
        kind, offset, span, matrix = self._act
        body = list(self._body)
        body[4] = body[2][..., None] * np.asarray(self.gravity, dtype=float)  # w ρA g per node
        return (
            tuple(body),
            np.ascontiguousarray(self.stiffness, dtype=float),
            np.ascontiguousarray(self.damping, dtype=float),
            int(kind),
            np.ascontiguousarray(offset, dtype=float),
            np.ascontiguousarray(span, dtype=float),
            np.ascontiguousarray(matrix, dtype=float),
        )

    def _trajectory(self, q: NDArray, t: NDArray, qd: NDArray, metadata: dict) -> SpatialStrainTrajectory:
        """The container :func:`~pcs_sindy.simulation.integrate.simulate` returns for this robot."""
        return SpatialStrainTrajectory(
            q,
            t,
            segment_lengths=self.segment_lengths,
            qd=qd,
            base_position=tuple(self.base_position),
            base_rotation=self.base_rotation,
            metadata=metadata,
        )

    def _terms(self, qf: NDArray, qdf: NDArray | None) -> tuple[NDArray, NDArray, NDArray]:
        qd = qf if qdf is None else qdf
        return spatial_kernels.terms_batch(qf, qd, self._jit_geometry()[0], qdf is not None)

    # -- dynamics terms -----------------------------------------------------------
    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """Mass matrix ``M(q)``, shape (..., n, n), symmetric positive definite."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        return self._terms(qf, None)[0].reshape(lead + (self.n_q, self.n_q))

    def coriolis_forces(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Coriolis, centrifugal and gyroscopic forces ``C(q, q̇) q̇``, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        lead, (qf, qdf) = self._flatten(q, qd)
        return self._terms(qf, qdf)[2].reshape(lead + (self.n_q,))

    def gravity_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """Gravitational forces ``G(q) = ∂U_g/∂q``, shape (..., n)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        return self._terms(qf, None)[1].reshape(lead + (self.n_q,))

    def node_jacobians(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``J_p`` (base frame) and body ``J_w`` at the quadrature nodes, each (..., m K, 3, n)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        jp, jw = spatial_kernels.jacobian_batch(qf, self._body)
        shape = lead + jp.shape[1:]
        return jp.reshape(shape), jw.reshape(shape)

    def gravitational_energy(self, q: ArrayLike) -> NDArray[np.float64]:
        """``U_g = −Σ ρA ∫ gᵀ p ds``, shape (...)."""
        q = self._check("q", q)
        positions, _ = self.kinematics.forward_kinematics(q, self._node_arcs)
        return -np.einsum("...k,k->...", positions @ self.gravity, self._w_lin)

    def _bias(self, qf: NDArray, qdf: NDArray) -> tuple[NDArray, NDArray]:
        M, G, C = self._terms(qf, qdf)
        return M, C + G + self.stiffness * qf + self.damping * qdf

    # -- actuation --------------------------------------------------------------------
    def actuation_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """``A(q)``, shape (..., n, p): generalised forces of unit inputs (the identity without actuation)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        kind, offset, span, _ = self._act
        if kind == ACT_TENDON:
            A = -spatial_kernels.tendon_batch(qf, offset, span)[1].transpose(0, 2, 1)
        else:
            A = np.broadcast_to(np.eye(self.n_q), (qf.shape[0], self.n_q, self.n_q)).copy()
        return A.reshape(lead + (self.n_q, self.n_inputs))

    def actuation_forces(self, q: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Generalised forces ``τ = A(q) u`` of inputs ``u`` (..., p), shape (..., n)."""
        q = self._check("q", q)
        u = self._check("u", u, q, size=self.n_inputs)
        lead, (qf, uf) = self._flatten(q, u)
        return _spatial_kernels.actuation_batch(qf, uf, self._jit_geometry()).reshape(lead + (self.n_q,))

    def tendon_lengths(self, q: ArrayLike) -> NDArray[np.float64]:
        """Lengths ``ℓ_k(q)`` [m] of the tendons, shape (..., p) (tendon actuation only)."""
        kind, offset, span, _ = self._act
        if kind != ACT_TENDON:
            raise ValueError(f"tendon_lengths needs a robot with SpatialTendons; this one has {self.actuation!r}")
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        return spatial_kernels.tendon_batch(qf, offset, span)[0].reshape(lead + (self.n_inputs,))

    # -- simulation -----------------------------------------------------------------
    def simulate(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        t: ArrayLike,
        u: Inputs | None = None,
        *,
        method: str = "radau",
        rtol: float | None = None,
        atol: float | None = None,
        step: float | None | str = "auto",
        max_step: float | None = None,
        progress: bool = False,
        tau: Inputs | None = None,
        fixed_step: Any = UNSET,
    ) -> SpatialStrainTrajectory | list[SpatialStrainTrajectory]:
        """Integrate the equations of motion and sample them at the time stamps ``t``.

        The contract and integrators of :meth:`PCSRobot.simulate <pcs_sindy.simulation.PCSRobot.simulate>`
        (arguments, methods, fixed or error-controlled Radau IIA steps, errors), for states of
        ``n = 6m`` strains; returns :class:`~pcs_sindy.core.SpatialStrainTrajectory` (a list for a
        batch of initial states).  The first call on a machine compiles the spatial kernels.
        """
        return simulate(
            self,
            q0,
            qd0,
            t,
            u,
            method=method,
            rtol=rtol,
            atol=atol,
            step=step,
            max_step=max_step,
            progress=progress,
            tau=tau,
            fixed_step=fixed_step,
        )

    def advance(
        self,
        q: ArrayLike,
        qd: ArrayLike,
        u: ArrayLike,
        dt: float,
        *,
        step: float | None = DEFAULT_STEP,
        rtol: float | None = None,
        atol: float | None = None,
        max_steps: int | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Advance the state by ``dt`` under inputs ``u`` held constant (as :meth:`PCSRobot.advance
        <pcs_sindy.simulation.PCSRobot.advance>`)."""
        return advance(self, q, qd, u, dt, step=step, rtol=rtol, atol=atol, max_steps=max_steps)

    def __repr__(self) -> str:
        act = "" if self.actuation is None else f", actuation={self.actuation!r}"
        return f"SpatialPCSRobot(segment_lengths={self.segment_lengths.tolist()}{act})"
