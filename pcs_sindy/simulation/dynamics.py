"""Ground-truth dynamics of a planar Piecewise Constant Strain (PCS) robot.

The equations of motion (docs/method.md, "Dynamics") are

    M(q) q̈ + C(q, q̇) q̇ + G(q) + K q + D q̇ = τ = A(q) u

with ``M = Σ_i ∫ (ρ A J_pᵀ J_p + ρ I J_oᵀ J_o) ds``,
``U_g = −Σ_i ∫ ρ A gᵀ p ds`` and ``A(q)`` the identity for a robot driven
directly by generalised forces, or the map of its tendons or pressure
chambers (:mod:`pcs_sindy.simulation.actuation`).  Everything is computed
*numerically*: the integrals along the backbone are Gauss–Legendre
quadratures of closed-form Jacobians (:mod:`pcs_sindy.simulation._backbone`,
batched numpy, and :mod:`pcs_sindy.simulation._kernels`, compiled single
states).  This package is the independent truth the identification side is
checked against, so it shares no derivation code with it.

For a mass distributed along the backbone the Christoffel symbols of the first
kind reduce to ``Γ_ijk = Σ w ρA J_i · ∂²p/∂q_j∂q_k``, hence

    C(q, q̇) = Σ w ρA J_pᵀ J̇_p,        C(q, q̇) q̇ = Σ w ρA J_pᵀ (J̇_p q̇),

exactly (no finite differences).  The orientation Jacobian ``J_o`` is
constant, so rotary inertia only adds a constant matrix to ``M``.
Integration: :mod:`pcs_sindy.simulation.integrate`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import PlanarPCS
from ..core.simulate_contract import SimulationError
from ..core.trajectory import StrainTrajectory
from . import _kernels
from ._backbone import backbone_moments, segment_terms
from ._robot_base import RobotBase, finite_array, positive_int
from .actuation import PressureChambers, Tendons
from .integrate import DEFAULT_STEP, UNSET, advance, simulate

__all__ = ["PCSRobot", "SimulationError", "backbone_moments"]

Inputs = ArrayLike | Callable[[float], ArrayLike]


# --------------------------------------------------------------------------
# Robot
# --------------------------------------------------------------------------
class PCSRobot(RobotBase):
    """Planar PCS soft robot: mass, Coriolis, gravity, elastic, damping and actuation terms, and simulation.

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
        Gravity in the base frame; the default lets the robot hang (docs/method.md).
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
    actuation : Tendons, PressureChambers or None, default None
        How the inputs ``u`` of :meth:`simulate` act: None drives the strains
        directly (``u`` is τ, ``A = I``); otherwise ``τ = A(q) u`` with the
        layout's map (:mod:`pcs_sindy.simulation.actuation`).

    Attributes
    ----------
    kinematics : PlanarPCS
    n_q : int
        ``3m``.
    n_inputs : int
        ``p``, the number of inputs (``n_q`` without actuation).
    stiffness : ndarray, shape (3m,)
        Diagonal of ``K``.
    damping : ndarray, shape (3m,)
        Diagonal of ``D``.
    """

    _gravity_shape = (2,)

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
        actuation: Any = None,
    ) -> None:
        self.kinematics = PlanarPCS(
            tuple(np.atleast_1d(np.asarray(segment_lengths, dtype=float))),
            base_pose=tuple(finite_array(base_pose, (3,), "base_pose")),
        )
        m = self.kinematics.n_segments
        self.segment_lengths = np.asarray(self.kinematics.segment_lengths)
        self.n_segments = m
        self.n_q = 3 * m
        self.base_pose = np.asarray(self.kinematics.base_pose)
        f_len = self._set_material(
            density, youngs_modulus, shear_modulus, damping, radius, gravity, shear_factor, stiffness_scaling
        )
        self.n_quadrature = positive_int(n_quadrature, "n_quadrature")
        self.actuation = actuation
        if actuation is None:
            self._act = (_kernels.ACT_IDENTITY, np.zeros(0), np.zeros((0, m)), np.zeros((self.n_q, 0)))
            self.n_inputs = self.n_q
        elif isinstance(actuation, (Tendons, PressureChambers)):
            self._act = actuation.encode(self.segment_lengths)
            self.n_inputs = int(actuation.n_inputs)
        else:
            raise ValueError(f"actuation must be None, a Tendons or a PressureChambers; got {actuation!r}")

        self.stiffness = (
            f_len[:, None]
            * np.stack(
                [
                    self.youngs_modulus * self.second_moment,
                    self.shear_factor * self.shear_modulus * self.area,
                    self.youngs_modulus * self.area,
                ],
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

    def _jit_geometry(self) -> tuple:
        """Robot structure for the compiled kernels of :mod:`._kernels` (layout in its docstring).

        Built at every call: ``stiffness`` and ``damping`` are public attributes
        that users (and the scenarios) may rescale after construction.
        """
        kind, offset, span, matrix = self._act
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
            int(kind),
            np.ascontiguousarray(offset, dtype=float),
            np.ascontiguousarray(span, dtype=float),
            np.ascontiguousarray(matrix, dtype=float),
        )

    # -- dynamics terms -----------------------------------------------------------
    def _mass(self, J: NDArray) -> NDArray[np.float64]:
        wj = J * self._w_lin[None, :, None]
        return (np.conj(wj).transpose(0, 2, 1) @ J).real + self._mass_rot

    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """Mass matrix ``M(q)``, shape (..., n, n), symmetric positive definite."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        M = self._mass(segment_terms(self, qf, None, "jac")["J"])
        return M.reshape(lead + (self.n_q, self.n_q))

    def coriolis_forces(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Coriolis and centrifugal forces ``C(q, q̇) q̇``, shape (..., n)."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        lead, (qf, qdf) = self._flatten(q, qd)
        return self._coriolis_vector(segment_terms(self, qf, qdf, "acc")).reshape(lead + (self.n_q,))

    def _coriolis_vector(self, t: dict) -> NDArray[np.float64]:
        acc = t["acc"].reshape(t["acc"].shape[0], -1) * self._w_lin
        return np.einsum("bpa,bp->ba", np.conj(t["J"]), acc).real

    def coriolis_matrix(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """Christoffel-based ``C(q, q̇)``, shape (..., n, n); ``Ṁ − 2C`` is skew-symmetric."""
        q = self._check("q", q)
        qd = self._check("qd", qd, q)
        lead, (qf, qdf) = self._flatten(q, qd)
        t = segment_terms(self, qf, qdf, "jdot")
        wj = t["J"] * self._w_lin[None, :, None]
        C = (np.conj(wj).transpose(0, 2, 1) @ t["Jdot"]).real
        return C.reshape(lead + (self.n_q, self.n_q))

    def _gravity(self, J: NDArray) -> NDArray[np.float64]:
        return -((self._g_conj * self._w_lin)[None, :, None] * J).sum(axis=1).real

    def gravity_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """Gravitational forces ``G(q) = ∂U_g/∂q``, shape (..., n)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        return self._gravity(segment_terms(self, qf, None, "jac")["J"]).reshape(lead + (self.n_q,))

    def gravitational_energy(self, q: ArrayLike) -> NDArray[np.float64]:
        """``U_g = −Σ ∫ ρ A gᵀ p ds``, shape (...)."""
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        z = segment_terms(self, qf, None, "pos")["z"].reshape(qf.shape[0], -1)
        return -(self._g_conj * z * self._w_lin).sum(axis=1).real.reshape(lead)

    def _bias(self, qf: NDArray, qdf: NDArray) -> tuple[NDArray, NDArray]:
        """Mass matrix and ``C q̇ + G + K q + D q̇`` for flattened batches."""
        t = segment_terms(self, qf, qdf, "acc")
        M = self._mass(t["J"])
        bias = self._coriolis_vector(t) + self._gravity(t["J"]) + self.stiffness * qf + self.damping * qdf
        return M, bias

    # -- actuation --------------------------------------------------------------------
    def actuation_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """``A(q)``, shape (..., n, p): the generalised forces of unit inputs (the identity without actuation).

        For servo-driven tendons (``Tendons(drive="displacement")``) the map of unit tendon
        *tensions* ``−∂ℓ/∂q``: the forces are ``A(q) f`` with ``f`` = :meth:`tendon_tensions`.
        """
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        kind, offset, span, matrix = self._act
        if kind in (_kernels.ACT_TENDON, _kernels.ACT_SERVO):
            A = -_kernels.tendon_batch(qf, offset, span)[1].transpose(0, 2, 1)
        else:
            A = np.broadcast_to(
                np.eye(self.n_q) if kind == _kernels.ACT_IDENTITY else matrix, (qf.shape[0], self.n_q, self.n_inputs)
            ).copy()
        return A.reshape(lead + (self.n_q, self.n_inputs))

    def actuation_forces(self, q: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Generalised forces ``τ = A(q) u`` of inputs ``u`` (..., p), shape (..., n)."""
        q = self._check("q", q)
        u = self._check("u", u, q, size=self.n_inputs)
        lead, (qf, uf) = self._flatten(q, u)
        return _kernels.actuation_batch(qf, uf, self._jit_geometry()).reshape(lead + (self.n_q,))

    def tendon_lengths(self, q: ArrayLike) -> NDArray[np.float64]:
        """Lengths ``ℓ_k(q)`` [m] of the tendons, shape (..., p) (tendon actuation only)."""
        kind, offset, span, _ = self._act
        if kind not in (_kernels.ACT_TENDON, _kernels.ACT_SERVO):
            raise ValueError(f"tendon_lengths needs a robot with Tendons; this one has {self.actuation!r}")
        q = self._check("q", q)
        lead, (qf,) = self._flatten(q)
        return _kernels.tendon_batch(qf, offset, span)[0].reshape(lead + (self.n_inputs,))

    def tendon_tensions(self, q: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Tendon tensions [N] (..., p) at strains ``q`` (..., n) under inputs ``u`` (..., p) (tendons only).

        The inputs themselves for ``drive="tension"``; for servo-wound elastic tendons
        (``drive="displacement"``) ``k max(0, r u π/180 + ℓ(q) − ℓ(0) − s)``.
        """
        q = self._check("q", q)
        lengths = self.tendon_lengths(q)
        u = self._check("u", u, q, size=self.n_inputs)
        return self.actuation.tensions(lengths, u)

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
    ) -> StrainTrajectory | list[StrainTrajectory]:
        """Integrate the equations of motion and sample them at the time stamps ``t``.

        The contract of :mod:`pcs_sindy.core.simulate_contract`, shared with identified models.

        Parameters
        ----------
        q0, qd0 : array_like, shape (n,) or (B, n)
            Initial configuration and velocity at ``t[0]``.  A leading batch
            axis simulates B robots on the same time grid at once.
        t : array_like, shape (T,)
            Strictly increasing time stamps.
        u : array_like, shape (T, p) or (T, B, p), or callable
            Inputs held constant on ``[t_k, t_{k+1})`` (zero-order hold, the
            last row is not used), or a function ``u(t)`` returning shape
            (p,) or (B, p).  Generalised forces τ (p = n) for a robot without
            actuation; tendon tensions (>= 0) or chamber pressures otherwise,
            applied as ``τ = A(q) u`` at every stage.
        method : str, default "radau"
            A name of :data:`pcs_sindy.core.simulate_contract.METHODS`: ``"radau"``,
            ``"dopri5"``, ``"dop853"``, ``"bdf"``, ``"lsoda"`` or ``"rk23"``.
            ``"radau"`` with tabulated inputs is the simulator's own Radau IIA
            (order 5, L-stable — the shear/axial modes make these robots
            stiff), compiled with numba and stepping across samples without
            restarts, each robot of a batch with its own steps; the first call
            on a machine compiles the kernels (tens of seconds, cached on disk
            afterwards).  Every other method, and callable inputs, use
            :func:`scipy.integrate.solve_ivp` (restarted where a tabulated
            input switches; a batch integrated as one system).  Former names
            (``"Radau"``, ``"RK45"``, ...) work with a FutureWarning.
        rtol, atol : float, optional
            Local error tolerances (defaults 1e-6 and 1e-8).  Giving either
            switches ``step="auto"`` to error control.
        step : float, None or "auto", default "auto"
            A float: fixed Radau steps of this size (shortened to land on every
            sample time), no error control (``rtol``/``atol`` then only set the
            Newton tolerance); needs ``method="radau"`` and tabulated inputs.
            None: error control.  ``"auto"``: fixed 0.5 ms steps for
            ``"radau"`` with tabulated inputs when neither ``rtol`` nor
            ``atol`` is given, error control otherwise.  Fixed steps are much
            faster on these stiff robots, where error control resolves the fast
            shear/axial transient after every switch of a held input; the
            accuracy of 0.5 ms steps is measured by
            benchmarks/simulation_speed.py (docs/results.md).  Lightly damped
            kHz modes (e.g. the ×1000 stiffened strains of
            two_segment_stiff_axial_shear) are numerically damped by such
            steps; use error control to resolve them.
        max_step : float, optional
            Largest internal step (default unbounded).
        progress : bool, default False
            Show a tqdm progress bar over the samples.  (A closed loop that
            advances the plant one control period at a time is cheaper with
            :meth:`advance`.)
        tau : deprecated
            Former name of ``u`` (FutureWarning).
        fixed_step : deprecated
            Former name of ``step`` (FutureWarning).

        Returns
        -------
        StrainTrajectory or list of StrainTrajectory
            ``q``, ``qd`` (T, n), ``t`` and the robot's segment lengths and base
            pose; ``metadata`` holds ``"u"`` (the inputs of this robot: (T, p)
            or the callable), ``"method"``, ``"step"``, ``"rtol"``, ``"atol"``
            and the integrator's ``"counts"``.  A list of B trajectories for a
            batch.

        Raises
        ------
        SimulationError
            If the integration fails (step size collapses or the state becomes
            non-finite), naming the time where it happened.
        ValueError
            For bad arguments, naming them: shapes, non-finite values, a
            negative tendon tension (with its input index and time).
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
        """Advance the state by ``dt`` under inputs ``u`` held constant: one control period of a closed loop.

        The compiled Radau IIA of :meth:`simulate` (``method="radau"``), with
        its integrator state (step size, Jacobian and its factorisations) kept
        between calls: consecutive calls cost the steps of one period (no
        fresh Jacobian, no trajectory object) and reproduce :meth:`simulate`
        over the same held inputs to round-off.  For closed loops that advance
        the true plant one control period at a time (per-call costs of both in
        docs/results.md, section simulation_speed).

        Parameters
        ----------
        q, qd : array_like, shape (n,) or (B, n)
            Current state.  The integrator state is reused while the batch
            shape stays the same; it restarts (fresh Jacobian) when the state
            passed is not the one the last call returned.
        u : array_like, shape (p,) or (B, p)
            Inputs held over the period (tensions >= 0 for tendons).
        dt : float
            Period [s], > 0.
        step : float or None, default 0.5 ms
            Fixed Radau step, or None for error control with ``rtol``/``atol``.
        rtol, atol : float, optional
            Tolerances (defaults 1e-6 and 1e-8).
        max_steps : int, optional
            Most integration steps (accepted or rejected) this call may take;
            exceeded: SimulationError.  Default: no bound (a diverging state can
            take ever smaller steps for minutes).

        Returns
        -------
        q, qd : ndarray, shape of the inputs q, qd

        Raises
        ------
        SimulationError, ValueError
            As :meth:`simulate`.
        """
        return advance(self, q, qd, u, dt, step=step, rtol=rtol, atol=atol, max_steps=max_steps)

    def __repr__(self) -> str:
        act = "" if self.actuation is None else f", actuation={self.actuation!r}"
        return f"PCSRobot(segment_lengths={self.segment_lengths.tolist()}{act})"
