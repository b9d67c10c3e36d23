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
parameters: its terms are evaluated by compiled kernels (:mod:`pcs_sindy.models._jit_spatial` on
the shared :mod:`pcs_sindy.core.spatial_kernels`, also the simulator's), and it is rolled out by the
compiled loops of the planar models (:mod:`pcs_sindy.models._jit_rollout`: the L-stable Rosenbrock-W
scheme :data:`~pcs_sindy.models.integrators.ROS34PW2` with the structural Jacobian
``[[0, I], [−M⁻¹K, −M⁻¹D]]``, steps never straddling a sample of the held input, the default; or
Dormand–Prince 5(4)) or any ``solve_ivp`` scheme.  :func:`node_terms` (NumPy) stays the independent
evaluation the tests hold the kernels to.

This module imports only :mod:`pcs_sindy.core` and its own stage; never the simulator.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.simulate_contract import SCIPY_METHODS
from ..core.spatial import SpatialPCS, SpatialStrainTrajectory
from ..core.spatial_kernels import body_tuple
from .forward import CompiledForwardModel, ForwardModel
from .integrators import COMPILED_METHODS

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


class SpatialPCSModel(CompiledForwardModel):
    """Spatial PCS dynamics from lumped per-segment parameters, evaluated by compiled kernels (rollouts, controllers).

    Parameters
    ----------
    kinematics : SpatialPCS
        Segmentation; its active strains are the modelled ones (``n``), the others held at 0.
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
        Gauss–Legendre nodes per segment, at most: as in the spatial simulator, a segment that bends
        little gets fewer nodes, as many as keep ``M`` and ``bias`` as accurate as this rule
        (:data:`pcs_sindy.core.spatial_kernels.QUADRATURE_TIERS`; measured within 1e-15 relative of it).
    actuation : Actuation, optional
        Fitted input map (default: the inputs are generalised forces).  A kind whose map is not one
        the compiled kernels evaluate (``"forces"``, ``"matrix"``, ``"affine"``, ``"spatial_tendon"``)
        is evaluated in Python: the model then rolls out with the ``solve_ivp`` methods only
        (:attr:`methods`).
    """

    methods = COMPILED_METHODS + tuple(m for m in SCIPY_METHODS if m not in COMPILED_METHODS)
    compiled_methods = COMPILED_METHODS
    default_method = "rosenbrock"

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
        from . import _jit_dynamics, _jit_spatial  # numba kernels load only when a model is built

        m, n = kinematics.n_segments, self.n

        def arr(name: str, val: Any, shape: tuple) -> NDArray[np.float64]:
            a = np.asarray(val, dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite with shape {shape}; got {np.shape(val)}")
            return np.ascontiguousarray(a)

        self.rhoA = arr("rhoA", rhoA, (m,))
        self.rhoI = arr("rhoI", rhoI, (m,))
        self.rhoAg = arr("rhoAg", rhoAg, (m, 3))
        self.stiffness = arr("stiffness", stiffness, (n,))
        self.damping = arr("damping", damping, (n,))
        self.rest_force = np.zeros(n) if rest_force is None else arr("rest_force", rest_force, (n,))
        if isinstance(n_quadrature, bool) or not isinstance(n_quadrature, (int, np.integer)) or n_quadrature < 1:
            raise ValueError(f"n_quadrature must be a positive integer; got {n_quadrature!r}")
        self.n_quadrature = int(n_quadrature)
        self.quadrature = spatial_quadrature(kinematics.segment_lengths, n_quadrature)
        self._jit = _jit_spatial

        #: True when the actuation has no compiled form the spatial kernels evaluate: its forces are computed
        #: in Python (``actuation.forces``) and rollouts take the solve_ivp methods only
        self.python_inputs = self.actuation is not None and not (
            set(self.actuation.compiled_forms) & set(_jit_spatial.INPUT_FORMS)
        )
        if self.actuation is None or self.python_inputs:
            form, aoff, acover, amat = "forces", np.zeros(0), np.zeros((0, m)), np.zeros((n, 0))
        else:
            form, aoff, acover, amat = self.actuation.compiled()
            if form not in _jit_spatial.INPUT_FORMS:
                self.python_inputs = True
                form, aoff, acover, amat = "forces", np.zeros(0), np.zeros((0, m)), np.zeros((n, 0))
        if self.python_inputs:
            self.methods = tuple(SCIPY_METHODS)
            self.compiled_methods = ()
            self.default_method = ForwardModel.default_method
        base_position, base_rotation = kinematics.base_pose
        body = body_tuple(
            kinematics.segment_lengths,
            self.n_quadrature,
            self.rhoA,
            self.rhoI[:, None] * BODY_INERTIA[None, :],
            self.rhoAg,
            base_position,
            base_rotation,
        )
        self._params = (
            np.flatnonzero(kinematics.active_mask).astype(np.int64),
            body,
            self.rest_force,
            np.array([_jit_dynamics.INPUT_MAPS[form]], dtype=np.int64),
            np.ascontiguousarray(np.reshape(aoff, (-1, 2)), dtype=float),  # (p, 2): one compiled signature
            np.ascontiguousarray(acover, dtype=float),
            np.ascontiguousarray(amat, dtype=float),
            self.stiffness,
            self.damping,
        )
        self._work = _jit_spatial.workspace(self._params)

    @classmethod
    def from_lumped(cls, kinematics: SpatialPCS, lumped: dict, actuation: Any = None) -> SpatialPCSModel:
        """The model of a library's ``lumped_from_coef`` dictionary (``rest_force``, ``n_quadrature`` optional)."""
        keys = ("rhoA", "rhoI", "rhoAg", "stiffness", "damping", "rest_force", "n_quadrature")
        return cls(kinematics, **{k: lumped[k] for k in keys if k in lumped}, actuation=actuation)

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

    def _rollout_compiled(
        self, y0, t, u, method, *, step, rtol, atol, max_step, max_abs_state, state_names, stats
    ) -> NDArray[np.float64]:
        return self._loop(self._params, y0, t, u, method, step, rtol, atol, max_step, max_abs_state, state_names, stats)
