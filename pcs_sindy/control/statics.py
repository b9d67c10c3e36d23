"""Static problems on an identified model: equilibria, equilibrium inputs for a tip target, tip inverse kinematics.

The model is held still at ``q`` by the inputs ``u`` when

    G(q) + K q - f0 = A(q) u            (the model's static forces, :func:`~.models.static_forces`)

:func:`equilibrium` solves it for ``q`` given ``u``; :func:`equilibrium_inputs`
finds the inputs within bounds whose equilibrium puts the tip at a target (or,
when none does, as near as the inputs and the model's strain range allow);
:func:`tip_inverse_kinematics` does the same along a tip path.  Every problem
is posed on the modelled strains and the forward model's ``input_matrix``, so
generalised-force models and actuated ones are handled alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize
from tqdm.auto import tqdm

from ..core.spatial import SpatialPCS
from .gains import force_scales
from .models import linearise, static_forces, strain_scales

__all__ = [
    "EquilibriumResult",
    "equilibrium",
    "equilibrium_inputs",
    "tip_inverse_kinematics",
    "model_tip",
    "tip_jacobian",
    "tip_dimension",
    "check_input_bounds",
    "input_scales",
]


def tip_dimension(fm: Any) -> int:
    """Coordinates of a tip position: 2 in the plane (x, y), 3 for a spatial (3-D) model."""
    return 3 if isinstance(fm.kinematics, SpatialPCS) else 2


def model_tip(fm: Any, q: ArrayLike) -> NDArray[np.float64]:
    """Tip positions (..., 2) of the model's segmentation at modelled strains ``q`` (..., n); (..., 3) in 3-D."""
    kin = fm.kinematics
    full = kin.to_full(np.asarray(q, dtype=float))
    if isinstance(kin, SpatialPCS):
        return kin.forward_kinematics(full, [kin.total_length])[0][..., 0, :]
    return kin.forward_kinematics(full, [kin.total_length])[..., 0, :2]


def tip_jacobian(fm: Any, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``d tip / d q`` (2, n) on the modelled strains; (3, n) for a spatial model."""
    kin = fm.kinematics
    if isinstance(kin, SpatialPCS):
        return kin.jacobian(kin.to_full(q), [kin.total_length])[2][0][:, kin.active_mask]
    _, jac = kin.jacobian(kin.to_full(q), [kin.total_length])
    return jac[0, :2][:, kin.active_mask]


def check_input_bounds(bounds: Any, p: int, name: str = "input_bounds") -> NDArray[np.float64]:
    """``(2, p)`` lower/upper input bounds from None (unbounded) or a pair of scalars / (p,) arrays."""
    if bounds is None:
        return np.stack([np.full(p, -np.inf), np.full(p, np.inf)])
    try:
        lo, hi = bounds
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be None or a pair (lower, upper); got {bounds!r}") from None
    out = []
    for side, val in (("lower", lo), ("upper", hi)):
        arr = np.asarray(-np.inf if (val is None and side == "lower") else np.inf if val is None else val, dtype=float)
        arr = np.full(p, float(arr)) if arr.ndim == 0 else arr
        if arr.shape != (p,) or np.any(np.isnan(arr)):
            raise ValueError(
                f"{name}: the {side} bound must be a scalar or have shape ({p},) (one per input); "
                f"got {np.asarray(val).tolist()}"
            )
        out.append(arr)
    res = np.stack(out)
    if np.any(res[0] > res[1]):
        raise ValueError(f"{name}: lower bound exceeds upper bound: {res.tolist()}")
    return res


def input_scales(lin: Any, bounds: NDArray[np.float64], scales: NDArray[np.float64]) -> NDArray[np.float64]:
    """Typical magnitude of each input (p,): the span of its bounds, else the input that exerts the force
    holding the strains at their typical magnitudes (:func:`~.gains.force_scales`)."""
    col = np.linalg.norm(lin.input_matrix / force_scales(lin, scales)[:, None], axis=0)
    span = bounds[1] - bounds[0]
    return np.where(np.isfinite(span) & (span > 0), span, 1.0 / np.maximum(col, 1e-300))


def equilibrium(
    fm: Any, u: ArrayLike, q0: ArrayLike | None = None, *, tol: float = 1e-10, max_iter: int = 50
) -> NDArray[np.float64]:
    """Configuration (n,) where the inputs ``u`` hold the model still (Newton from ``q0``, default straight).

    Raises
    ------
    RuntimeError
        If Newton's method does not converge (e.g. no equilibrium near ``q0``).
    """
    n = fm.kinematics.n_active
    u = np.asarray(u, dtype=float)
    q = np.zeros(n) if q0 is None else np.array(q0, dtype=float)
    scale = strain_scales(fm.kinematics)
    for _ in range(max_iter):
        r = static_forces(fm, q) - np.asarray(fm.input_matrix(q), dtype=float) @ u
        lin = linearise(fm, q, u)
        dq = -np.linalg.solve(lin.stiffness, r)
        q = q + dq
        if np.max(np.abs(dq) / scale) < tol:
            return q
    raise RuntimeError(f"no static equilibrium found for inputs {u.tolist()} (Newton did not converge)")


@dataclass
class EquilibriumResult:
    """Inputs whose model equilibrium puts the tip at (or nearest to) a target.

    Attributes
    ----------
    u : ndarray (p,)
        Inputs (within the bounds).
    q : ndarray (n,)
        The model's equilibrium under ``u``.
    tip : ndarray (2,) or (3,)
        Its tip: the target when reachable, else the nearest reachable tip.
    target : ndarray (2,) or (3,)
    error : float
        ``|tip - target|`` [m].
    reachable : bool
        ``error <= tol``.
    stable : bool
        The equilibrium is stable without feedback (positive definite linearised stiffness).
    """

    u: NDArray[np.float64]
    q: NDArray[np.float64]
    tip: NDArray[np.float64]
    target: NDArray[np.float64]
    error: float
    reachable: bool
    stable: bool


class _Problem:
    """Scaled decision vector ``x = [q / q_scale, u / u_scale]`` and the static constraint."""

    def __init__(self, fm: Any, bounds: NDArray[np.float64], limits: NDArray[np.float64]) -> None:
        self.fm = fm
        kin = fm.kinematics
        self.n, self.p = kin.n_active, int(fm.n_inputs)
        self.qs = strain_scales(kin)
        lin = linearise(fm, np.zeros(self.n))
        self.fs = force_scales(lin, self.qs)
        self.us = input_scales(lin, bounds, self.qs)
        self.bounds = bounds
        self.length = kin.total_length
        self.x_bounds = [(lo / s, hi / s) for lo, hi, s in zip(limits[0], limits[1], self.qs)] + [
            (None if not np.isfinite(lo) else lo / s, None if not np.isfinite(hi) else hi / s)
            for lo, hi, s in zip(bounds[0], bounds[1], self.us)
        ]

    def split(self, x: NDArray) -> tuple[NDArray, NDArray]:
        return x[: self.n] * self.qs, x[self.n :] * self.us

    def constraint(self, x: NDArray) -> NDArray:
        q, u = self.split(x)
        return (static_forces(self.fm, q) - np.asarray(self.fm.input_matrix(q)) @ u) / self.fs

    def constraint_jac(self, x: NDArray) -> NDArray:
        q, u = self.split(x)
        lin = linearise(self.fm, q, u)
        return np.hstack([lin.stiffness * self.qs[None, :], -lin.input_matrix * self.us[None, :]]) / self.fs[:, None]

    def tip_error(self, x: NDArray, target: NDArray) -> tuple[NDArray, NDArray]:
        q, _ = self.split(x)
        r = (model_tip(self.fm, q) - target) / self.length
        J = np.zeros((r.size, x.size))
        J[:, : self.n] = tip_jacobian(self.fm, q) * self.qs[None, :] / self.length
        return r, J

    def effort(self, x: NDArray, u_ref: NDArray) -> tuple[float, NDArray]:
        d = x[self.n :] - u_ref / self.us
        g = np.zeros(x.size)
        g[self.n :] = 2 * d
        return float(d @ d), g

    def x0(self, q: NDArray, u: NDArray) -> NDArray:
        return np.concatenate([q / self.qs, u / self.us])

    def clip_u(self, u: NDArray) -> NDArray:
        return np.clip(u, self.bounds[0], self.bounds[1])


_SLSQP = {"maxiter": 300, "ftol": 1e-14}


def _nearest(prob: _Problem, target: NDArray, x0: NDArray, effort_weight: float) -> Any:
    def fun(x):
        r, J = prob.tip_error(x, target)
        e, ge = prob.effort(x, np.zeros(prob.p))
        return float(r @ r) + effort_weight * e, 2 * J.T @ r + effort_weight * ge

    cons = {"type": "eq", "fun": prob.constraint, "jac": prob.constraint_jac}
    return minimize(fun, x0, jac=True, method="SLSQP", bounds=prob.x_bounds, constraints=[cons], options=_SLSQP)


def _exact(prob: _Problem, target: NDArray, x0: NDArray) -> Any:
    def fun(x):
        return prob.effort(x, np.zeros(prob.p))

    cons = [
        {"type": "eq", "fun": prob.constraint, "jac": prob.constraint_jac},
        {"type": "eq", "fun": lambda x: prob.tip_error(x, target)[0], "jac": lambda x: prob.tip_error(x, target)[1]},
    ]
    return minimize(fun, x0, jac=True, method="SLSQP", bounds=prob.x_bounds, constraints=cons, options=_SLSQP)


def _result(prob: _Problem, x: NDArray, target: NDArray, tol: float) -> EquilibriumResult:
    q, u = prob.split(x)
    u = prob.clip_u(u)
    tip = model_tip(prob.fm, q)
    err = float(np.linalg.norm(tip - target))
    K = linearise(prob.fm, q, u).stiffness
    stable = bool(np.all(np.linalg.eigvalsh(0.5 * (K + K.T)) > 0))
    return EquilibriumResult(u, q, tip, target.copy(), err, err <= tol, stable)


def _check_target(target: ArrayLike, name: str, dim: int = 2) -> NDArray[np.float64]:
    p = np.asarray(target, dtype=float)
    if p.shape != (dim,) or not np.all(np.isfinite(p)):
        coords = "[x, y]" if dim == 2 else "[x, y, z] (a spatial model)"
        raise ValueError(f"{name} must be a finite tip position {coords} ({dim},); got {np.asarray(target).tolist()}")
    return p


def equilibrium_inputs(
    fm: Any,
    target: ArrayLike,
    input_bounds: Any = None,
    strain_limits: NDArray[np.float64] | None = None,
    *,
    q0: ArrayLike | None = None,
    u0: ArrayLike | None = None,
    tol: float | None = None,
    n_starts: int = 3,
    seed: int = 0,
) -> EquilibriumResult:
    """Inputs within bounds whose model equilibrium puts the tip at ``target``, or nearest to it.

    Two bounded SLSQP problems on ``(q, u)`` with the static equilibrium as an
    equality constraint and the model's strain range as bounds on ``q``:
    first the nearest tip (squared tip distance plus a 1e-8 share of the
    scaled input effort); then, when the target is reachable, the least
    scaled effort ``sum((u / u_scale)^2)`` with the tip exactly at the target
    (which picks one of the many equilibria of a redundant robot).  Several
    starts (the passive equilibrium and random inputs) guard against local minima.

    Parameters
    ----------
    fm : ForwardModel
    target : array_like, shape (2,)
        Tip position [m] in the base frame; (3,) for a spatial (3-D) model.
    input_bounds : None or (lower, upper)
        Scalars or (p,) arrays (e.g. ``(0, 16)`` for tendon tensions in N).
    strain_limits : ndarray (2, n), optional
        Bounds on the modelled strains (default: the seed's data ranges).
    q0, u0 : array_like, optional
        A starting guess (e.g. the previous solution along a path).
    tol : float, optional
        Tip distance [m] under which the target counts as reachable; default
        1e-3 of the model's length.
    n_starts : int
    seed : int

    Returns
    -------
    EquilibriumResult
    """
    p_target = _check_target(target, "target", tip_dimension(fm))
    kin = fm.kinematics
    bounds = check_input_bounds(input_bounds, int(fm.n_inputs))
    limits = np.stack([-strain_scales(kin), strain_scales(kin)]) if strain_limits is None else strain_limits
    prob = _Problem(fm, bounds, limits)
    tol = 1e-3 * kin.total_length if tol is None else float(tol)
    starts = []
    if q0 is not None and u0 is not None:
        starts.append(prob.x0(np.asarray(q0, dtype=float), prob.clip_u(np.asarray(u0, dtype=float))))
    rng = np.random.default_rng(seed)
    u_pass = prob.clip_u(np.zeros(prob.p))
    span = prob.bounds[1] - prob.bounds[0]
    for k in range(max(int(n_starts), 1)):
        if k == 0:
            u_start = u_pass
        elif np.all(np.isfinite(span)):
            u_start = prob.bounds[0] + rng.uniform(0, 1, prob.p) * span
        else:
            u_start = prob.clip_u(rng.normal(0, 0.3, prob.p) * prob.us)
        try:
            q_start = equilibrium(fm, u_start, None if q0 is None else q0)
        except (RuntimeError, np.linalg.LinAlgError):
            continue
        starts.append(prob.x0(q_start, u_start))
    if not starts:
        raise RuntimeError("no static equilibrium of the model found to start from")
    best = None
    for x0 in starts:
        res = _nearest(prob, p_target, x0, 1e-8)
        if np.max(np.abs(prob.constraint(res.x))) > 1e-6:
            continue
        cand = _result(prob, res.x, p_target, tol)
        if best is None or cand.error < best[0].error - 1e-12:
            best = (cand, res.x)
        if cand.reachable:
            break
    if best is None:
        raise RuntimeError(f"the equilibrium search failed from every start for target {p_target.tolist()}")
    cand, x = best
    if cand.reachable:
        res = _exact(prob, p_target, x)
        if res.success and np.max(np.abs(prob.constraint(res.x))) <= 1e-8:
            cand = _result(prob, res.x, p_target, tol)
    return cand


def tip_inverse_kinematics(
    fm: Any,
    path: ArrayLike,
    input_bounds: Any = None,
    strain_limits: NDArray[np.float64] | None = None,
    *,
    q0: ArrayLike | None = None,
    progress: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least-effort equilibria ``q`` (T, n) and inputs ``u`` (T, p) that put the model's tip on ``path`` (T, 2).

    A spatial model's path is (T, 3).

    Each point is solved by :func:`equilibrium_inputs` from the previous
    solution, so the strains vary continuously along a continuous path.

    Raises
    ------
    ValueError
        Naming the first point of ``path`` the model cannot reach within its
        input bounds and strain range, with the nearest reachable tip.
    """
    pts = np.asarray(path, dtype=float)
    dim = tip_dimension(fm)
    if pts.ndim != 2 or pts.shape[1] != dim or not np.all(np.isfinite(pts)):
        raise ValueError(f"path must be finite tip positions of shape (T, {dim}); got shape {pts.shape}")
    Q, U = [], []
    q_prev = None if q0 is None else np.asarray(q0, dtype=float)
    u_prev = None
    for k in tqdm(range(pts.shape[0]), desc="tip IK", disable=not progress, leave=False):
        res = equilibrium_inputs(
            fm, pts[k], input_bounds, strain_limits, q0=q_prev, u0=u_prev, n_starts=3 if u_prev is None else 1
        )
        if not res.reachable:
            raise ValueError(
                f"path[{k}] = {pts[k].tolist()} is not reachable by the model (nearest reachable tip "
                f"{res.tip.round(6).tolist()}, {1e3 * res.error:.3g} mm away)"
            )
        Q.append(res.q)
        U.append(res.u)
        q_prev, u_prev = res.q, res.u
    return np.array(Q), np.array(U)
