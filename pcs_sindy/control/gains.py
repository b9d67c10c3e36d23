"""Feedback gains: the documented rule that chooses them from a model, their checks and the loop's poles.

The rule (docs/control.md, "Gains") is a discrete-time linear-quadratic
regulator with a prescribed degree of stability, designed on the model's
linearisation at the set-point ``M dq'' + D dq' + K dq = dtau`` (``K`` the
static stiffness ``d(G + K q - f0)/dq``), discretised with the zero-order
hold of the control period:

* states scaled by the strains' typical magnitudes ``s`` (60 1/m bending,
  0.3 shear and axial) and ``rate s`` for the rates, forces by ``|K_ii| s_i``
  (the force that holds a strain at its typical magnitude);
* cost ``sum |dq / s|^2 + effort |dtau / f|^2``;
* the plant matrices multiplied by ``exp(rate dt)`` before solving the
  Riccati equation, which puts every closed-loop pole of the linearisation
  inside the circle ``|z| = exp(-rate dt)``: every mode decays at least as
  fast as ``exp(-rate t)``.

The result ``tau = -Kp dq - Kd dq'`` has full (n, n) matrices.  Designing in
discrete time matters: the shear and axial strains of these robots relax
faster than a 1 kHz control period, and a continuous-time design (per-strain
pole placement) puts derivative gain on them that the held command turns
unstable.  The integral gain ``Ki = integral_rate (K + Kp)`` makes the
integrator's modes decay at about ``integral_rate`` where the proportional
loop is quasi-static.  :func:`loop_poles` gives the discrete closed-loop poles
of any gains, so given gains can be checked the same way.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "force_scales",
    "lqr_gains",
    "open_loop_decay",
    "integral_gain",
    "loop_poles",
    "as_gain_matrix",
    "check_gain",
    "warn_if_cannot_regulate",
    "check_positive",
    "discretise",
]


def check_positive(value: Any, name: str, *, allow_zero: bool = False, allow_inf: bool = False) -> float:
    """``value`` as a float, finite (unless ``allow_inf``) and > 0 (or >= 0); ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number; got {value!r}")
    v = float(value)
    ok = (v >= 0 if allow_zero else v > 0) and (np.isfinite(v) or (allow_inf and v == np.inf))
    if not ok:
        cond = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be {'' if allow_inf else 'finite and '}{cond}; got {value!r}")
    return v


def discretise(
    lin: Any, dt: float, inputs: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Zero-order-hold ``(Ad, Bd)`` of the state ``[dq, dq']`` under forces (or ``inputs``-mapped inputs)."""
    n = lin.q.size
    B_force = np.eye(n) if inputs is None else inputs
    p = B_force.shape[1]
    Minv = np.linalg.inv(lin.mass)
    big = np.zeros((2 * n + p, 2 * n + p))
    big[:n, n : 2 * n] = np.eye(n)
    big[n : 2 * n, :n] = -Minv @ lin.stiffness
    big[n : 2 * n, n : 2 * n] = -Minv @ lin.damping
    big[n : 2 * n, 2 * n :] = Minv @ B_force
    E = sla.expm(big * dt)
    return E[: 2 * n, : 2 * n], E[: 2 * n, 2 * n :]


def force_scales(lin: Any, scales: NDArray[np.float64]) -> NDArray[np.float64]:
    """``|K_ii| s_i``: the generalised force that holds each strain at its typical magnitude (n,).

    Floored at 1e-3 of the largest: a strain the model holds with (almost) no
    stiffness (an identified stiffness of 0, where a low-dimensional model
    absorbs the shape of a robot that is not piecewise constant strain) would
    otherwise get a vanishing scale that wrecks every problem scaled by it.
    """
    f = np.abs(np.diag(lin.stiffness)) * scales
    return np.maximum(f, max(1e-3 * float(np.max(f)), 1e-300))


def lqr_gains(
    lin: Any,
    dt: float,
    rate: float,
    effort: float,
    scales: NDArray[np.float64],
    input_scales: NDArray[np.float64] | None = None,
    decay: float | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(Kp, Kd)`` of the rule of this module: ``u = -Kp dq - Kd dq'``.

    Parameters
    ----------
    lin : Linearisation
        Of the model at the set-point (:func:`~.models.linearise`).
    dt : float
        Control period [s].
    rate : float
        Prescribed degree of stability [1/s].
    effort : float
        Weight of the scaled inputs against the scaled strain errors.
    scales : ndarray (n,)
        Typical magnitudes of the strains.
    input_scales : ndarray (p,), optional
        Design for the inputs ``u`` of ``tau = A u`` (``A = lin.input_matrix``)
        scaled by these; default: design for the forces ``tau`` (n, n),
        scaled by :func:`force_scales`.
    decay : float, optional
        The prescribed degree of stability when it differs from ``rate``
        (which then only scales the rates); ``0`` is the plain LQR.

    Returns
    -------
    Kp, Kd : ndarray, (n, n) or (p, n)
    """
    n = lin.q.size
    if input_scales is None:
        Ad, Bd = discretise(lin, dt)
        u_scale = force_scales(lin, scales)
    else:
        Ad, Bd = discretise(lin, dt, lin.input_matrix)
        u_scale = np.asarray(input_scales, dtype=float)
    Tx = np.concatenate([scales, scales * rate])
    grow = np.exp((rate if decay is None else decay) * dt)
    A = grow * Ad * (Tx[None, :] / Tx[:, None])
    B = grow * Bd * (u_scale[None, :] / Tx[:, None])
    Q = np.diag(np.concatenate([np.ones(n), np.zeros(n)]))
    R = effort * np.eye(u_scale.size)
    P = sla.solve_discrete_are(A, B, Q, R)
    F = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A) * (u_scale[:, None] / Tx[None, :])
    return F[:, :n], F[:, n:]


def open_loop_decay(lin: Any) -> float:
    """Decay rate [1/s] of the slowest mode of the linearisation without feedback (negative if unstable)."""
    n = lin.q.size
    Minv = np.linalg.inv(lin.mass)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ lin.stiffness, -Minv @ lin.damping]])
    return float(-np.max(np.linalg.eigvals(A).real))


def integral_gain(lin: Any, kp: NDArray[np.float64], integral_rate: float) -> NDArray[np.float64]:
    """``Ki = integral_rate (K + Kp)`` (n, n): integrator modes at about ``-integral_rate``."""
    return integral_rate * (lin.stiffness + kp)


def loop_poles(lin: Any, kp: ArrayLike, ki: ArrayLike, kd: ArrayLike, dt: float) -> NDArray[np.complex128]:
    """Discrete poles (3n,) of the linearised loop ``tau = -Kp dq + Ki z - Kd dq'``, ``z+ = z - dt dq``.

    ``|z| < 1`` for all of them means the gains stabilise the model's
    linearisation at the control period ``dt``; ``log|z| / dt`` is the
    continuous-time decay rate of each mode.
    """
    n = lin.q.size
    Ad, Bd = discretise(lin, dt)
    Kp, Ki, Kd = (np.asarray(g, dtype=float) for g in (kp, ki, kd))
    A = np.zeros((3 * n, 3 * n))
    A[: 2 * n, : 2 * n] = Ad - Bd @ np.hstack([Kp, Kd])
    A[: 2 * n, 2 * n :] = Bd @ Ki
    A[2 * n :, :n] = -dt * np.eye(n)
    A[2 * n :, 2 * n :] = np.eye(n)
    return np.linalg.eigvals(A)


def as_gain_matrix(value: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    """A gain as an (n, n) matrix from a scalar, (n,) diagonal or (n, n) matrix; finite, else ValueError."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape == (n,):
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise ValueError(
            f"{name} must be a scalar, an ({n},) diagonal or an ({n}, {n}) matrix for the {n} modelled strains; "
            f"got shape {np.asarray(value).shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr


def check_gain(value: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    """A user's gain as an (n, n) matrix (:func:`as_gain_matrix`), checked for its sign.

    A scalar or diagonal gain must be >= 0 (a negative one pushes each
    strain away from its reference): ValueError naming the entry.  A full
    matrix with a negative diagonal entry gets a UserWarning (coupling may
    make up for it, but rarely does).
    """
    arr = as_gain_matrix(value, n, name)
    given = np.asarray(value, dtype=float)
    diag = np.diag(arr)
    if np.any(diag < 0):
        i = int(np.flatnonzero(diag < 0)[0])
        if given.ndim < 2:
            raise ValueError(
                f"{name} must be >= 0 (a negative gain pushes the strain away from its reference); got "
                f"{given.tolist()} (strain {i}: {float(diag[i])!r}); give gains >= 0, or None for the rule's"
            )
        warnings.warn(
            f"{name}[{i}, {i}] = {float(diag[i])!r} < 0: a negative gain pushes strain {i} away from its reference",
            UserWarning,
            stacklevel=3,
        )
    return arr


def warn_if_cannot_regulate(kp: NDArray[np.float64], ki: NDArray[np.float64] | None, owner: str) -> None:
    """UserWarning when gains cannot correct a strain error: no proportional and no integral action on a strain."""
    acts = np.any(kp != 0, axis=0)
    if ki is not None:
        acts |= np.any(ki != 0, axis=0)
    if not np.all(acts):
        idle = np.flatnonzero(~acts).tolist()
        which = "any strain" if len(idle) == acts.size else f"strain(s) {idle}"
        warnings.warn(
            f"{owner}: the gains cannot regulate {which}: no proportional"
            + (" or integral" if ki is not None else "")
            + " gain acts on the error (all zero), so an error there is never corrected",
            UserWarning,
            stacklevel=3,
        )
