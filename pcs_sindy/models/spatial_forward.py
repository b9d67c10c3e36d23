"""Spatial (3-D) PCS dynamics from per-segment lumped parameters: node terms and the forward model.

The identified model of a spatial PCS robot (issue 26 conventions) is

    M(q) q̈ + bias(q, q̇) = A(q) u,
    M = Σ_i ρA_i ∫_i J_pᵀ J_p ds + ρI_i ∫_i J_wᵀ Ī J_w ds,          Ī = diag(1, 2, 1),
    bias = Σ_i ρA_i ∫_i J_pᵀ J̇_p q̇ ds − ∫_i J_pᵀ (ρA g)_i ds
           + ρI_i ∫_i J_wᵀ (Ī J̇_w q̇ + ω × Ī ω) ds + K q + D q̇ − f0,

with the position Jacobian ``J_p`` (base frame) and the body angular Jacobian ``J_w`` of
:class:`~pcs_sindy.core.spatial.SpatialPCS` at Gauss–Legendre nodes of every segment, and
``ω = J_w q̇`` the body angular velocity.  :func:`node_terms` evaluates the per-segment integrals
once per state (the identification library builds its regression columns from the same
integrals); :class:`SpatialPCSModel` is the :class:`~pcs_sindy.models.forward.ForwardModel` of given
parameters, rolled out by the L-stable Rosenbrock-W scheme :data:`~pcs_sindy.models.integrators.ROS34PW2`
(a NumPy loop with the structural Jacobian ``[[0, I], [−M⁻¹K, −M⁻¹D]]``, steps never straddling a
sample of the held input; the default) or any ``solve_ivp`` scheme.

This module imports only :mod:`pcs_sindy.core` and its own stage; never the simulator.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.simulate_contract import SCIPY_METHODS, SimulationError
from ..core.spatial import SpatialPCS, SpatialStrainTrajectory
from .forward import ForwardModel
from .integrators import ROS34PW2, describe_state

__all__ = ["SpatialPCSModel", "spatial_quadrature", "node_terms", "BODY_INERTIA"]

#: the body inertia of a circular cross-section per unit ρI: bending about x and z, torsion about y (J = 2I)
BODY_INERTIA = np.array([1.0, 2.0, 1.0])


def spatial_quadrature(
    segment_lengths: ArrayLike, n_quadrature: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
    """Gauss–Legendre nodes of every segment: global arc lengths (K,), weights (K,), segment of each node (K,)."""
    L = np.asarray(segment_lengths, dtype=float)
    n = int(n_quadrature)
    if n < 1:
        raise ValueError(f"n_quadrature must be >= 1; got {n_quadrature!r}")
    x, w = np.polynomial.legendre.leggauss(n)
    starts = np.concatenate([[0.0], np.cumsum(L)[:-1]])
    s = (starts[:, None] + 0.5 * (x + 1.0)[None, :] * L[:, None]).reshape(-1)
    weights = (0.5 * w[None, :] * L[:, None]).reshape(-1)
    seg = np.repeat(np.arange(L.size), n)
    return s, weights, seg


def node_terms(
    kin: SpatialPCS,
    quadrature: tuple[NDArray, NDArray, NDArray],
    q: NDArray[np.float64],
    qd: NDArray[np.float64] | None = None,
    qdd: NDArray[np.float64] | None = None,
    *,
    mass: bool = False,
) -> dict[str, NDArray[np.float64]]:
    """Per-segment integrals of the spatial PCS dynamics at states of all strains.

    Parameters
    ----------
    kin : SpatialPCS
    quadrature : tuple
        :func:`spatial_quadrature` of the segmentation.
    q, qd, qdd : ndarray, shape (B, 6m)
        Full strains (unmodelled ones at 0), rates and accelerations.  Without ``qd`` the rate
        terms are not computed; ``qdd`` None counts as 0.
    mass : bool
        Also return the per-segment mass matrices.

    Returns
    -------
    dict
        ``"grav"`` (B, m, 6m, 3): ``∫_i J_pᵀ ds`` (contract with a force per length);
        with ``qd``: ``"trans"`` (B, m, 6m): ``∫_i J_pᵀ (J_p q̈ + J̇_p q̇) ds`` and ``"rot"``
        (B, m, 6m): ``∫_i J_wᵀ (Ī (J_w q̈ + J̇_w q̇) + ω × Ī ω) ds``; with ``mass``:
        ``"M_trans"``, ``"M_rot"`` (B, m, 6m, 6m): ``∫_i J_pᵀ J_p ds`` and ``∫_i J_wᵀ Ī J_w ds``.
    """
    s, w, seg = quadrature
    m = kin.n_segments
    B = q.shape[0]
    _, _, Jp, Jw = kin.jacobian(q, s)  # (B, K, 3, 6m)
    onehot = np.zeros((s.size, m))
    onehot[np.arange(s.size), seg] = w  # weight of node k in segment i
    out: dict[str, NDArray[np.float64]] = {"grav": np.einsum("kj,bkxn->bjnx", onehot, Jp)}
    if mass:
        out["M_trans"] = np.einsum("kj,bkxa,bkxc->bjac", onehot, Jp, Jp, optimize=True)
        out["M_rot"] = np.einsum("kj,bkxa,x,bkxc->bjac", onehot, Jw, BODY_INERTIA, Jw, optimize=True)
    if qd is None:
        return out
    ap, aw = kin.velocity_products(q, qd, s)  # (B, K, 3)
    omega = np.einsum("bkxn,bn->bkx", Jw, qd)
    if qdd is not None:
        ap = ap + np.einsum("bkxn,bn->bkx", Jp, qdd)
        aw = aw + np.einsum("bkxn,bn->bkx", Jw, qdd)
    moment = BODY_INERTIA * aw + np.cross(omega, BODY_INERTIA * omega)
    out["trans"] = np.einsum("kj,bkxn,bkx->bjn", onehot, Jp, ap, optimize=True)
    out["rot"] = np.einsum("kj,bkxn,bkx->bjn", onehot, Jw, moment, optimize=True)
    del B
    return out


class SpatialPCSModel(ForwardModel):
    """Spatial PCS dynamics from lumped per-segment parameters (rollouts, controllers).

    Parameters
    ----------
    kinematics : SpatialPCS
        Segmentation; its active strains are the modelled ones (``n``).
    rhoA, rhoI : array_like, shape (m,)
        Line density [kg/m] and rotary line inertia [kg m] of every segment (body inertia
        ``diag(1, 2, 1) ρI``).
    rhoAg : array_like, shape (m, 3)
        Gravity force per length of every segment in the base frame [N/m] (``ρA_i g``).
    stiffness, damping : array_like, shape (n,)
        Diagonal of ``K`` and ``D`` on the modelled strains.
    rest_force : array_like, shape (n,), optional
        Constant generalised force ``f0`` (``... + K q − f0 = A(q) u``); default 0.
    n_quadrature : int, default 16
        Gauss–Legendre nodes per segment.
    actuation : Actuation, optional
        Fitted input map (default: the inputs are generalised forces).
    """

    methods = ("rosenbrock",) + tuple(SCIPY_METHODS)
    compiled_methods = ("rosenbrock",)
    default_method = "rosenbrock"
    #: the Rosenbrock loop is NumPy, not compiled: a 5-s rollout of six strains takes minutes
    compiled_rollouts = False

    def __init__(
        self,
        kinematics: SpatialPCS,
        rhoA: ArrayLike,
        rhoI: ArrayLike,
        rhoAg: ArrayLike,
        stiffness: ArrayLike,
        damping: ArrayLike,
        rest_force: ArrayLike | None = None,
        n_quadrature: int = 16,
        actuation: Any = None,
    ) -> None:
        if not isinstance(kinematics, SpatialPCS):
            raise ValueError(f"kinematics must be a SpatialPCS; got {type(kinematics).__name__}")
        super().__init__(kinematics, actuation)
        m, n = kinematics.n_segments, self.n

        def arr(name: str, val: Any, shape: tuple) -> NDArray[np.float64]:
            a = np.asarray(val, dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite with shape {shape}; got {np.shape(val)}")
            return a

        self.rhoA = arr("rhoA", rhoA, (m,))
        self.rhoI = arr("rhoI", rhoI, (m,))
        self.rhoAg = arr("rhoAg", rhoAg, (m, 3))
        self.stiffness = arr("stiffness", stiffness, (n,))
        self.damping = arr("damping", damping, (n,))
        self.rest_force = np.zeros(n) if rest_force is None else arr("rest_force", rest_force, (n,))
        self.quadrature = spatial_quadrature(kinematics.segment_lengths, n_quadrature)

    def _batch_terms(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        kin = self.kinematics
        mask = kin.active_mask
        qf = np.zeros((q.shape[0], kin.n_q))
        qdf = np.zeros_like(qf)
        qf[:, mask], qdf[:, mask] = q, qd
        f = node_terms(kin, self.quadrature, qf, qdf, None, mass=True)
        M = np.einsum("j,bjac->bac", self.rhoA, f["M_trans"]) + np.einsum("j,bjac->bac", self.rhoI, f["M_rot"])
        bias = (
            np.einsum("j,bjn->bn", self.rhoA, f["trans"])
            - np.einsum("bjnx,jx->bn", f["grav"], self.rhoAg)
            + np.einsum("j,bjn->bn", self.rhoI, f["rot"])
        )
        M = M[:, mask][:, :, mask]
        bias = bias[:, mask] + q * self.stiffness + qd * self.damping - self.rest_force
        return M, bias

    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        q = np.atleast_2d(self._reduce(q, "q"))
        qd = np.atleast_2d(self._reduce(qd, "qd"))
        if q.shape != qd.shape:
            raise ValueError(f"q and qd must have the same shape; got {q.shape} and {qd.shape}")
        return self._batch_terms(q, qd)

    def terms(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        M, bias = self._batch_terms(q[None], qd[None])
        return M[0], bias[0]

    def _state_derivative(self, y: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        n = self.n
        M, bias = self.terms(y[:n], y[n:])
        return np.concatenate([y[n:], np.linalg.solve(M, self.input_forces(y[:n], u) - bias)])

    def _trajectory(self, q_full: NDArray, qd_full: NDArray, t: NDArray, metadata: dict) -> Any:
        kin = self.kinematics
        return SpatialStrainTrajectory(
            q_full,
            t,
            segment_lengths=kin.segment_lengths,
            active_strains=kin.active_strains,
            qd=qd_full,
            base_position=kin.base_position,
            base_rotation=kin.base_rotation,
            metadata=metadata,
        )

    # ------------------------------------------------------------------ rollout (NumPy Rosenbrock-W loop)
    def _rollout_compiled(
        self,
        y0: NDArray[np.float64],
        t: NDArray[np.float64],
        u: NDArray[np.float64],
        method: str,
        *,
        step: float | None,
        rtol: float,
        atol: float,
        max_step: float | None,
        max_abs_state: float,
        state_names: list[str],
        stats: dict | None,
    ) -> NDArray[np.float64]:
        """ROS34PW2 over held inputs: adaptive (or fixed ``step``) steps inside every sample interval."""
        tab = ROS34PW2
        n = self.n
        eye = np.eye(2 * n)
        y = np.array(y0, dtype=float)
        out = np.empty((t.size, 2 * n))
        out[0] = y
        h = float(np.min(np.diff(t))) if step is None else float(step)
        if max_step is not None:
            h = min(h, float(max_step))
        n_steps = n_rej = n_eval = 0

        def rhs(state: NDArray[np.float64], uk: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
            M, bias = self.terms(state[:n], state[n:])
            acc = np.linalg.solve(M, self.input_forces(state[:n], uk) - bias)
            return np.concatenate([state[n:], acc]), M

        for k in range(t.size - 1):
            tk, t_end, uk = float(t[k]), float(t[k + 1]), u[k]
            while t_end - tk > 1e-12 * max(1.0, abs(t_end)):
                hh = min(h, t_end - tk)
                try:
                    f0, M = rhs(y, uk)
                    n_eval += 1
                    Minv = np.linalg.inv(M)
                    J = np.zeros((2 * n, 2 * n))
                    J[:n, n:] = np.eye(n)
                    J[n:, :n] = -Minv * self.stiffness[None, :]
                    J[n:, n:] = -Minv * self.damping[None, :]
                    W = eye / (hh * tab.gamma) - J
                    stages = []
                    for i in range(tab.stages):
                        if i == 0:
                            fi = f0
                        else:
                            yi = y + sum(tab.at[i, j] * stages[j] for j in range(i))
                            fi = rhs(yi, uk)[0]
                            n_eval += 1
                        rhs_i = fi + sum(tab.ct[i, j] * stages[j] for j in range(i)) / hh
                        stages.append(np.linalg.solve(W, rhs_i))
                except np.linalg.LinAlgError as err:
                    raise SimulationError(
                        f"singular mass matrix at t = {tk:.6g} s ({describe_state(y, state_names)})", tk, y
                    ) from err
                y_new = y + sum(tab.mt[i] * stages[i] for i in range(tab.stages))
                if step is None:
                    err_v = sum(tab.et[i] * stages[i] for i in range(tab.stages))
                    scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
                    e = float(np.sqrt(np.mean((err_v / scale) ** 2)))
                    if not np.isfinite(e):
                        e = np.inf
                    factor = 5.0 if e == 0 else min(5.0, max(0.2, 0.9 * e ** (-1.0 / 3.0)))
                    if e > 1.0:
                        n_rej += 1
                        h = hh * factor
                        if h < 1e-12 * max(1.0, abs(t_end)):
                            raise SimulationError(f"step size collapsed at t = {tk:.6g} s", tk, y)
                        continue
                    if hh == h:  # a step cut short by the sample does not change h
                        h = hh * factor
                    if max_step is not None:
                        h = min(h, float(max_step))
                tk += hh
                y = y_new
                n_steps += 1
                if not np.all(np.isfinite(y)) or np.abs(y).max() > max_abs_state:
                    raise SimulationError(
                        f"the state diverged at t = {tk:.6g} s ({describe_state(y, state_names)})", tk, y
                    )
            out[k + 1] = y
        if stats is not None:
            stats.update(n_steps=n_steps, n_rejected=n_rej, n_evaluations=n_eval)
        return out
