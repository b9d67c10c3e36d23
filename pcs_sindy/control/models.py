"""What a controller needs from an identified model: statics, linearisation, inputs, strain limits.

A controller accepts anything with ``forward_model()`` (a fitted
:class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`, a pipeline's model) or a
:class:`~pcs_sindy.models.forward.ForwardModel` itself (e.g. the true-parameter model
``PhysicalPCSLibrary(...).forward_model(coef)``).  Everything here works on the
``n`` modelled strains of the model's segmentation and only calls the forward
model's ``terms`` (one compiled state), ``n_inputs`` and ``input_matrix``, so
it holds for models driven by generalised forces and, unchanged, for models
with identified actuators (tendons, chambers).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import SEED_Q_MAX, PlanarPCS
from ..core.spatial import SPATIAL_Q_MAX, SpatialPCS

__all__ = [
    "as_forward_model",
    "strain_scales",
    "strain_limits",
    "static_forces",
    "static_stiffness",
    "Linearisation",
    "linearise",
    "linearised_poles",
    "InputMap",
    "check_strains",
    "ActuatedModel",
]


#: fraction of the training strains' span by which a model's default strain limits extend beyond them
STRAIN_RANGE_MARGIN = 0.1
#: fraction of the strain limits' span beyond them within which a reference is accepted with a warning
REACH_MARGIN = 0.25


def as_forward_model(model: Any) -> Any:
    """The forward model of ``model`` (anything with ``forward_model()``) or ``model`` itself.

    Raises
    ------
    ValueError
        If ``model`` has neither ``forward_model()`` nor ``terms``/``kinematics``.
    """
    if hasattr(model, "forward_model") and callable(model.forward_model):
        fm = model.forward_model()
    else:
        fm = model
    for attr in ("terms", "kinematics", "n_inputs", "input_matrix"):
        if not hasattr(fm, attr):
            raise ValueError(
                f"model must be a fitted identified model (with forward_model()) or a ForwardModel; "
                f"{type(model).__name__} has no {attr!r}"
            )
    return fm


def strain_scales(kinematics: PlanarPCS | SpatialPCS) -> NDArray[np.float64]:
    """Typical magnitude of each modelled strain (the seed's data ranges: 60 1/m, 0.3, 0.3), shape (n,).

    A spatial segmentation takes :data:`~pcs_sindy.core.spatial.SPATIAL_Q_MAX` (its six strains per segment).
    """
    per_segment = SPATIAL_Q_MAX if isinstance(kinematics, SpatialPCS) else SEED_Q_MAX
    return np.tile(np.asarray(per_segment, dtype=float), kinematics.n_segments)[kinematics.active_mask]


def strain_limits(model: Any, fm: Any, limits: ArrayLike | None = None) -> NDArray[np.float64]:
    """Bounds ``(2, n)`` (lower, upper) on the modelled strains inside which a model is trusted.

    ``limits`` as given: a scalar per strain type is not accepted; pass
    ``(n,)`` symmetric bounds or ``(2, n)`` lower/upper bounds on the
    modelled strains.  Default: the range of the model's training strains
    (``strain_range_``) widened by ``STRAIN_RANGE_MARGIN`` (10 %) of its span
    on either side, when the model has one (a model extrapolates a little, not
    far); else the strain ranges the package's data cover (docs/method.md,
    bending ±60 1/m, shear and axial ±0.3).
    """
    n = fm.kinematics.n_active
    if limits is None:
        rng = getattr(model, "strain_range_", None)
        if rng is None:
            s = strain_scales(fm.kinematics)
            return np.stack([-s, s])
        rng = np.asarray(rng, dtype=float)
        limits = rng + STRAIN_RANGE_MARGIN * np.array([-1.0, 1.0])[:, None] * (rng[1] - rng[0])
    arr = np.asarray(limits, dtype=float)
    if arr.shape == (n,):
        arr = np.stack([-np.abs(arr), np.abs(arr)])
    if arr.shape != (2, n) or np.any(np.isnan(arr)) or np.any(arr[0] >= arr[1]):
        raise ValueError(
            f"strain_limits must be (n,) symmetric bounds or (2, n) lower/upper bounds with lower < upper for the "
            f"n = {n} modelled strains; got {np.asarray(limits).tolist()}"
        )
    return arr


def check_strains(value: ArrayLike, fm: Any, limits: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """Modelled strains (n,) of ``value`` ((n,) or all 3m strains), finite and within ``limits``."""
    kin = fm.kinematics
    q = np.asarray(value, dtype=float)
    if q.shape == (kin.n_q,) and kin.n_q != kin.n_active:
        q = q[kin.active_mask]
    if q.shape != (kin.n_active,):
        raise ValueError(
            f"{name} must hold the {kin.n_active} modelled strains {kin.strain_names(active_only=True)} "
            f"(or all {kin.n_q}); got shape {q.shape}"
        )
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{name} contains NaN or inf: {q.tolist()}")
    out = np.flatnonzero((q < limits[0]) | (q > limits[1]))
    if out.size:
        names = kin.strain_names(active_only=True)
        span = limits[1] - limits[0]
        beyond = np.maximum(limits[0] - q, q - limits[1]) / span  # fraction of the range's span
        bad = ", ".join(
            f"{names[i]} = {q[i]:.4g} not in [{limits[0, i]:.4g}, {limits[1, i]:.4g}] "
            f"({100 * beyond[i]:.3g} % of its span beyond)"
            for i in out
        )
        if np.max(beyond) > REACH_MARGIN:
            raise ValueError(
                f"{name} lies outside the model's strain range: {bad}; more than {100 * REACH_MARGIN:g} % beyond "
                "is refused (pass strain_limits to widen it)"
            )
        warnings.warn(
            f"{name} lies a little outside the model's strain range: {bad}; accepted (up to "
            f"{100 * REACH_MARGIN:g} % beyond), the model extrapolates there",
            UserWarning,
            stacklevel=3,
        )
    return q


def static_forces(fm: Any, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``G(q) + K q - f0``: the generalised force that holds the model still at ``q`` (n,)."""
    return fm.terms(np.ascontiguousarray(q, dtype=float), np.zeros(fm.kinematics.n_active))[1]


def _fd_steps(fm: Any) -> NDArray[np.float64]:
    return 1e-6 * strain_scales(fm.kinematics)


def static_stiffness(fm: Any, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``d(G + K q - f0)/dq`` at ``q``, (n, n), by central differences of compiled evaluations."""
    q = np.asarray(q, dtype=float)
    h = _fd_steps(fm)
    cols = [
        (static_forces(fm, q + h[i] * e) - static_forces(fm, q - h[i] * e)) / (2 * h[i])
        for i, e in enumerate(np.eye(q.size))
    ]
    return np.stack(cols, axis=1)


@dataclass(frozen=True)
class Linearisation:
    """``M dq'' + D dq' + K dq = A du`` about an equilibrium ``(q, u)`` of a model.

    Attributes
    ----------
    q : ndarray (n,)
    mass, stiffness, damping : ndarray (n, n)
        ``M(q)``; ``d(G + K q - f0 - A(q) u)/dq``; ``d bias/d qd`` at rest.
    input_matrix : ndarray (n, p)
        ``A(q)``.
    """

    q: NDArray[np.float64]
    mass: NDArray[np.float64]
    stiffness: NDArray[np.float64]
    damping: NDArray[np.float64]
    input_matrix: NDArray[np.float64]


def linearise(fm: Any, q: ArrayLike, u: ArrayLike | None = None) -> Linearisation:
    """Linearisation of a model about the state ``(q, 0)`` held by inputs ``u`` (default: none).

    The input's configuration dependence ``d(A(q) u)/dq`` enters the stiffness
    (tendons pull harder as the robot bends); it vanishes for a constant ``A``.
    """
    q = np.ascontiguousarray(q, dtype=float)
    n = q.size
    M, _ = fm.terms(q, np.zeros(n))
    K = static_stiffness(fm, q)
    A = np.asarray(fm.input_matrix(q), dtype=float)
    if u is not None:
        u = np.asarray(u, dtype=float)
        h = _fd_steps(fm)
        dA = np.stack(
            [
                (np.asarray(fm.input_matrix(q + h[i] * e)) - np.asarray(fm.input_matrix(q - h[i] * e))) @ u / (2 * h[i])
                for i, e in enumerate(np.eye(n))
            ],
            axis=1,
        )
        K = K - dA
    hd = 1e-6
    D = np.stack([(fm.terms(q, hd * e)[1] - fm.terms(q, -hd * e)[1]) / (2 * hd) for e in np.eye(n)], axis=1)
    return Linearisation(q, M, K, D, A)


def linearised_poles(lin: Linearisation, kp: ArrayLike, kd: ArrayLike) -> NDArray[np.complex128]:
    """Poles of ``M s^2 + (D + Kd) s + (K + Kp)``: the linearised loop of a PD law on the strains (2n,)."""
    n = lin.q.size
    Kp, Kd = np.asarray(kp, dtype=float), np.asarray(kd, dtype=float)
    Minv = np.linalg.inv(lin.mass)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ (lin.stiffness + Kp), -Minv @ (lin.damping + Kd)]])
    return np.linalg.eigvals(A)


class InputMap:
    """Inputs ``u`` (p,) that realise generalised forces ``tau`` (n,) on the modelled strains.

    ``u = A(q)^+ tau`` (minimum norm).  When the model's ``A`` does not depend
    on ``q`` (generalised forces, pressure chambers) the pseudo-inverse is
    computed once; otherwise at the configuration given to :meth:`__call__`.

    Parameters
    ----------
    fm : ForwardModel
    q : ndarray (n,)
        A configuration where ``A`` is evaluated (and checked for full row rank).
    """

    def __init__(self, fm: Any, q: NDArray[np.float64]) -> None:
        self.fm = fm
        A = np.asarray(fm.input_matrix(q), dtype=float)
        n, p = A.shape
        if np.linalg.matrix_rank(A) < n:
            raise ValueError(
                f"the model's {p} inputs cannot set its {n} modelled strains independently (A(q) has rank "
                f"{np.linalg.matrix_rank(A)} < {n}); regulate the tip through the actuators with TipRegulator"
            )
        rng = np.random.default_rng(0)
        probe = q + 0.05 * strain_scales(fm.kinematics) * rng.uniform(-1, 1, n)
        self.constant = bool(np.allclose(np.asarray(fm.input_matrix(probe)), A, rtol=1e-12, atol=0.0))
        self.pinv = np.linalg.pinv(A)

    def __call__(self, tau: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.constant:
            return self.pinv @ tau
        return np.linalg.pinv(np.asarray(self.fm.input_matrix(q), dtype=float)) @ tau


class ActuatedModel:
    """A forward model driven through actuators: ``M qdd + bias = A(q) u``.

    Gives any :class:`~pcs_sindy.models.forward.ForwardModel` (e.g. the true-parameter
    model of a robot) the inputs of a known actuation, for controllers and
    closed loops, until identified models carry their own actuation.  Everything
    else is the wrapped model's.

    Parameters
    ----------
    forward_model : ForwardModel
    input_matrix : callable
        ``input_matrix(q_full) -> (..., 3m, p)``: ``A`` on all strains of the
        model's segmentation (e.g. ``robot.actuation_matrix`` of a simulator
        with the same segmentation); the modelled strains' rows are used.
    n_inputs : int
    input_bounds : None or (lower, upper), optional
        E.g. ``(0, 16)`` for tendon tensions; controllers default to these.
    actuation_layout : dict, optional
        Describes the actuators (e.g. ``scenario.actuation``); closed loops
        compare it with the plant's.
    """

    def __init__(
        self,
        forward_model: Any,
        input_matrix: Any,
        n_inputs: int,
        input_bounds: Any = None,
        actuation_layout: dict | None = None,
    ) -> None:
        self.forward_model_ = forward_model
        self.kinematics = forward_model.kinematics
        self._matrix = input_matrix
        if isinstance(n_inputs, bool) or int(n_inputs) != n_inputs or n_inputs < 1:
            raise ValueError(f"n_inputs must be a positive integer; got {n_inputs!r}")
        self.n_inputs = int(n_inputs)
        self.input_bounds = input_bounds
        self.actuation_layout = actuation_layout

    def terms(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """``M(q)``, ``bias(q, qd)`` of the wrapped model (one state, no checks)."""
        return self.forward_model_.terms(q, qd)

    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray, NDArray]:
        """Batched ``M`` and bias of the wrapped model."""
        return self.forward_model_.mass_and_bias(q, qd)

    def input_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """``A(q)`` (..., n, p) on the modelled strains ``q`` (..., n)."""
        kin = self.kinematics
        A = np.asarray(self._matrix(kin.to_full(np.asarray(q, dtype=float))), dtype=float)
        if A.shape[-2:] != (kin.n_q, self.n_inputs):
            raise ValueError(f"input_matrix must return shape (..., {kin.n_q}, {self.n_inputs}); got {A.shape}")
        return A[..., kin.active_mask, :]
