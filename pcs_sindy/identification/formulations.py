"""Formulations of the Euler–Lagrange regression: strong (samples), weak (window integrals), static (holds).

Both turn recordings ``(t, q, qd[, qdd], tau)`` of the modelled strains into a
linear regression ``y = x @ coef`` over the columns of a
:class:`~pcs_sindy.identification.library.base.LagrangianLibrary`:

* strong: one row per sample and strain, ``tau = Psi(q, qd, qdd) @ coef``
  (needs ``qdd``);
* weak: one row per window and strain, ``int phi tau dt = int phi Psi dt @ coef``.
  With the library's split ``Psi = dP/dt + R`` and a test function ``phi``
  vanishing at the window ends, ``int phi Psi dt = -int phi' P dt + int phi R dt``:
  only ``q`` and ``qd`` enter, averaged over the window, and held (zero-order
  hold) forces are integrated exactly;
* static: one row per hold (a run of samples with one input) and strain, the
  equilibrium ``G(q) + K q - f0 = A(q) u`` at the hold's mean strains
  (:func:`static_recording`): the strong form at ``qd = qdd = 0``, for rigs
  that only hold shapes.  Inertia and damping do not enter (they stay
  undetermined); the scale comes from inputs in physical units (tensions, a
  known tendon stiffness) or from the robot's mass.

Plain functions on arrays; :func:`regression` assembles the rows of several
recordings and the ``design`` callback the optimizer uses to rebuild them for a
library of fewer strains.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.integrate import cumulative_simpson, cumulative_trapezoid
from scipy.signal import savgol_filter

from .library.with_gains import WithGains

__all__ = [
    "FORMULATIONS",
    "PreparedRecording",
    "savgol_derivatives",
    "jump_free",
    "sliding_windows",
    "check_windows",
    "integrate_forces",
    "weak_rows",
    "weak_form_rows",
    "library_rows",
    "input_rows",
    "regression",
    "static_recording",
    "static_pins",
]

#: names of the formulations
FORMULATIONS = ("strong", "weak", "static")
_RULES = ("trapezoid", "simpson")
_CHUNK = 512  # samples per block when evaluating the library (bounds memory)


def sliding_windows(n_samples: int, width: int, stride: int | None = None) -> NDArray[np.intp]:
    """Index pairs ``(start, stop)`` of windows of ``width`` intervals, every ``stride`` samples.

    Parameters
    ----------
    n_samples : int
        Number of samples of the recording.
    width : int
        Number of sampling intervals per window (``stop - start``), >= 1.
    stride : int, optional
        Step between window starts (default: ``width``, i.e. windows that share
        only their end points).

    Returns
    -------
    ndarray of int, shape (n_windows, 2)
    """
    for name, val in (("n_samples", n_samples), ("width", width)):
        if isinstance(val, bool) or int(val) != val or val < 1:
            raise ValueError(f"{name} must be a positive integer; got {val!r}")
    stride = width if stride is None else stride
    if isinstance(stride, bool) or int(stride) != stride or stride < 1:
        raise ValueError(f"stride must be a positive integer; got {stride!r}")
    if width > n_samples - 1:
        raise ValueError(f"width = {width} intervals needs at least {width + 1} samples; got n_samples = {n_samples}")
    starts = np.arange(0, int(n_samples) - int(width), int(stride))
    return np.stack([starts, starts + int(width)], axis=1)


def check_windows(windows: ArrayLike, n_samples: int) -> NDArray[np.intp]:
    """Validate window index pairs ``(start, stop)`` with ``0 <= start < stop < n_samples``."""
    w = np.asarray(windows)
    if w.ndim != 2 or w.shape[1] != 2 or w.shape[0] == 0:
        raise ValueError(f"windows must have shape (n_windows, 2) of (start, stop) indices; got shape {w.shape}")
    if not np.issubdtype(w.dtype, np.integer):
        if not np.all(np.isfinite(w)) or np.any(w != np.round(w)):
            raise ValueError("windows must hold integer sample indices")
        w = w.astype(np.intp)
    bad = (w[:, 0] < 0) | (w[:, 1] <= w[:, 0]) | (w[:, 1] >= n_samples)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"windows must satisfy 0 <= start < stop < n_samples = {n_samples}; window {k} is {w[k].tolist()}"
        )
    return w.astype(np.intp)


def _check_time(t: ArrayLike, n_samples: int) -> NDArray[np.float64]:
    t = np.asarray(t, dtype=float)
    if t.shape != (n_samples,):
        raise ValueError(f"t must have shape ({n_samples},) like the samples; got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("t must be finite and strictly increasing")
    return t


def _cumulative(y: NDArray[np.float64], t: NDArray[np.float64], rule: str) -> NDArray[np.float64]:
    """Running integral from ``t[0]`` along axis 0, value 0 at ``t[0]``."""
    if rule == "trapezoid" or y.shape[0] < 3:
        return cumulative_trapezoid(y, x=t, axis=0, initial=0.0)
    return cumulative_simpson(y, x=t, axis=0, initial=0.0)


# bump test function phi(x) = (4 x (1 - x))^3 on the window's normalised time x in [0, 1]:
# peak 1, vanishes with its first two derivatives at both ends.
_BUMP = Polynomial([0.0, 4.0, -4.0]) ** 3
_BUMP_D = _BUMP.deriv()
_BUMP_I = _BUMP.integ()
_TEST_FUNCTIONS = (None, "bump")


def _check_test_function(test_function: str | None) -> None:
    if test_function not in _TEST_FUNCTIONS:
        raise ValueError(f"test_function must be None or 'bump'; got {test_function!r}")


def _test_weights(t: NDArray[np.float64], w: NDArray[np.intp]) -> tuple[sparse.csr_matrix, sparse.csr_matrix]:
    """Sparse (n_windows, T) matrices: ``A @ f ~ int phi f dt`` and ``B @ f ~ int phi' f dt`` (trapezoid)."""
    rows, cols, va, vb = [], [], [], []
    for r, (a, b) in enumerate(w):
        tt = t[a : b + 1]
        span = tt[-1] - tt[0]
        x = (tt - tt[0]) / span
        dt = np.diff(tt)
        trap = np.zeros(tt.size)
        trap[:-1] += 0.5 * dt
        trap[1:] += 0.5 * dt
        rows.append(np.full(tt.size, r))
        cols.append(np.arange(a, b + 1))
        va.append(_BUMP(x) * trap)
        vb.append(_BUMP_D(x) / span * trap)
    shape = (w.shape[0], t.size)
    idx = (np.concatenate(rows), np.concatenate(cols))
    return (
        sparse.csr_matrix((np.concatenate(va), idx), shape=shape),
        sparse.csr_matrix((np.concatenate(vb), idx), shape=shape),
    )


def _zoh_test_weights(t: NDArray[np.float64], w: NDArray[np.intp]) -> sparse.csr_matrix:
    """Sparse (n_windows, T): exact ``int phi tau dt`` for ``tau[k]`` held on ``[t_k, t_{k+1})``."""
    rows, cols, vals = [], [], []
    for r, (a, b) in enumerate(w):
        tt = t[a : b + 1]
        span = tt[-1] - tt[0]
        prim = _BUMP_I((tt - tt[0]) / span) * span
        rows.append(np.full(b - a, r))
        cols.append(np.arange(a, b))
        vals.append(np.diff(prim))
    return sparse.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(w.shape[0], t.size)
    )


def integrate_forces(
    t: ArrayLike, tau: ArrayLike, windows: ArrayLike, hold: str = "zoh", test_function: str | None = None
) -> NDArray[np.float64]:
    """Integrals of the generalised forces over windows, ``int_{t_a}^{t_b} tau dt``.

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times.
    tau : array_like, shape (T, n)
        Generalised forces at the samples.
    windows : array_like of int, shape (n_windows, 2)
        ``(start, stop)`` sample indices (see :func:`sliding_windows`).
    hold : {"zoh", "trapezoid", "simpson"}
        ``"zoh"``: ``tau[k]`` is held on ``[t_k, t_{k+1})`` (exact for
        zero-order-hold actuation, the last row is not used);
        ``"trapezoid"`` / ``"simpson"``: the sampled ``tau`` integrated by that
        rule (use the same rule as for the library when ``tau`` is smooth;
        with a test function both mean the trapezoid rule).
    test_function : {None, "bump"}
        ``None``: plain integral over the window; ``"bump"``: weighted by
        ``phi = (4x(1-x))^3`` of the normalised window time ``x`` (the same
        weight as in :meth:`PhysicalPCSLibrary.integrated_euler_lagrange_matrix`).

    Returns
    -------
    ndarray, shape (n_windows, n)
    """
    tau = np.asarray(tau, dtype=float)
    if tau.ndim != 2:
        raise ValueError(f"tau must have shape (T, n); got shape {tau.shape}")
    if not np.all(np.isfinite(tau)):
        raise ValueError("tau contains NaN or inf")
    t = _check_time(t, tau.shape[0])
    w = check_windows(windows, tau.shape[0])
    _check_test_function(test_function)
    if hold not in ("zoh",) + _RULES:
        raise ValueError(f"hold must be 'zoh', 'trapezoid' or 'simpson'; got {hold!r}")
    if test_function == "bump":
        weights = _zoh_test_weights(t, w) if hold == "zoh" else _test_weights(t, w)[0]
        return np.asarray(weights @ tau)
    if hold == "zoh":
        cum = np.concatenate([np.zeros((1, tau.shape[1])), np.cumsum(tau[:-1] * np.diff(t)[:, None], axis=0)])
    elif hold in _RULES:
        cum = _cumulative(tau, t, hold)
    else:
        raise ValueError(f"hold must be 'zoh', 'trapezoid' or 'simpson'; got {hold!r}")
    return cum[w[:, 1]] - cum[w[:, 0]]


def weak_rows(
    library: Any,
    t: ArrayLike,
    q: ArrayLike,
    qd: ArrayLike,
    windows: ArrayLike,
    *,
    test_function: str | None = "bump",
    rule: str = "simpson",
) -> NDArray[np.float64]:
    """Weak-form rows ``int_{t_a}^{t_b} phi Psi dt`` per window, from ``q`` and ``qd`` only.

    Pair with :func:`integrate_forces` on the same windows and test function:
    ``int phi tau dt = weak_rows(...) @ coef``.

    Parameters
    ----------
    library : LagrangianLibrary
        Provides ``weak_terms(q, qd) -> (P, R)`` with ``Psi = dP/dt + R``.
    t : array_like, shape (T,)
        Strictly increasing sample times.
    q, qd : array_like, shape (T, n)
        Active strains and rates.
    windows : array_like of int, shape (n_windows, 2)
        ``(start, stop)`` sample indices; see :func:`sliding_windows`.
    test_function : {"bump", None}
        ``"bump"``: weighted by ``phi = (4x(1-x))^3`` (x the normalised window
        time), which vanishes at the ends with two derivatives, so no single
        boundary sample of ``qd`` enters and its noise is averaged over the
        window; trapezoid rule in time.  ``None``: plain window integrals
        ``[P]_{t_a}^{t_b} + int R dt`` (boundary samples of ``qd``).
    rule : {"simpson", "trapezoid"}
        Time quadrature of ``int R dt`` without a test function.

    Returns
    -------
    ndarray, shape (n_windows, n, n_coefficients_)
    """
    if rule not in _RULES:
        raise ValueError(f"rule must be 'simpson' or 'trapezoid'; got {rule!r}")
    _check_test_function(test_function)
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    if q.ndim != 2 or qd.shape != q.shape:
        raise ValueError(f"q and qd must have the same shape (T, n); got {q.shape} and {qd.shape}")
    t = _check_time(t, q.shape[0])
    w = check_windows(windows, q.shape[0])
    p_parts, r_parts = [], []
    for a in range(0, q.shape[0], _CHUNK):
        p_blk, r_blk = library.weak_terms(q[a : a + _CHUNK], qd[a : a + _CHUNK])
        p_parts.append(np.asarray(p_blk, dtype=float))
        r_parts.append(np.asarray(r_blk, dtype=float))
    mom, rest = np.concatenate(p_parts), np.concatenate(r_parts)
    if test_function == "bump":
        A, B = _test_weights(t, w)
        flat = (q.shape[0], -1)
        out = A @ rest.reshape(flat) - B @ mom.reshape(flat)
        return np.asarray(out).reshape((w.shape[0],) + mom.shape[1:])
    cum = _cumulative(rest, t, rule)
    return (mom[w[:, 1]] - mom[w[:, 0]]) + (cum[w[:, 1]] - cum[w[:, 0]])


def weak_form_rows(
    library: Any,
    t: ArrayLike,
    q: ArrayLike,
    qd: ArrayLike,
    tau: ArrayLike,
    width: int,
    stride: int | None = None,
    *,
    test_function: str | None = "bump",
    hold: str = "zoh",
    rule: str = "simpson",
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weak-form regression ``y ≈ x @ coef`` of one recording over sliding windows, flattened.

    Returns
    -------
    x : ndarray, shape (n_windows * n, n_coefficients_)
    y : ndarray, shape (n_windows * n,)
    """
    q = np.asarray(q, dtype=float)
    windows = sliding_windows(q.shape[0], width, stride)
    x = weak_rows(library, t, q, qd, windows, test_function=test_function, rule=rule)
    y = integrate_forces(t, tau, windows, hold=hold, test_function=test_function)
    if y.shape != x.shape[:2]:
        raise ValueError(f"tau must have shape {q.shape} like q; got {np.asarray(tau).shape}")
    return x.reshape(-1, x.shape[-1]), y.reshape(-1)


# --------------------------------------------------------------------------
# Derivatives of the recordings
# --------------------------------------------------------------------------
def savgol_derivatives(
    q: ArrayLike, t: ArrayLike, window_length: int, polyorder: int, *, name: str = "X"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``qd`` and ``qdd`` by Savitzky–Golay differentiation of uniformly sampled ``q``.

    Parameters
    ----------
    q : array_like, shape (T, n)
    t : array_like, shape (T,)
        Uniform sample times.
    window_length, polyorder : int
        Savitzky–Golay window (odd, samples) and polynomial order.
    name : str
        The recording's name in error messages.

    Returns
    -------
    qd, qdd : ndarray, shape (T, n)
    """
    q = np.asarray(q, dtype=float)
    t = np.asarray(t, dtype=float)
    wl = int(window_length)
    if q.shape[0] < wl:
        raise ValueError(
            f"{name} has {q.shape[0]} samples, fewer than the Savitzky-Golay window_length = {wl}; "
            "use longer recordings or a shorter window"
        )
    dts = np.diff(t)
    dt = float(np.median(dts))
    if np.max(np.abs(dts - dt)) > 1e-6 * dt:
        raise ValueError(
            f"{name} is not uniformly sampled (sample periods from {dts.min():.6g} to {dts.max():.6g} s); "
            "Savitzky-Golay needs a constant period: resample or pass differentiation_method"
        )
    po = int(polyorder)
    return (
        savgol_filter(q, wl, po, deriv=1, delta=dt, axis=0),
        savgol_filter(q, wl, po, deriv=2, delta=dt, axis=0),
    )


def jump_free(tau: ArrayLike, window: int) -> NDArray[np.bool_]:
    """Samples whose centred window of ``window`` samples holds no change of the held actuation.

    The ``window // 2`` samples at each end are excluded too (their window is incomplete).
    """
    tau = np.asarray(tau)
    n_s = tau.shape[0]
    half = int(window) // 2
    # change[j]: the force differs between samples j - 1 and j
    change = np.r_[False, np.any(np.diff(tau, axis=0) != 0, axis=1)]
    csum = np.r_[0, np.cumsum(change)]
    k = np.arange(n_s)
    lo = np.clip(k - half + 1, 0, n_s)
    hi = np.clip(k + half + 1, 0, n_s)
    keep = (csum[hi] - csum[lo]) == 0
    keep[:half] = False
    keep[n_s - half :] = False
    return keep


# --------------------------------------------------------------------------
# Assembly over recordings
# --------------------------------------------------------------------------
@dataclass
class PreparedRecording:
    """One recording of the modelled strains, ready for a formulation.

    Attributes
    ----------
    t : ndarray, shape (T,)
    q, qd : ndarray, shape (T, n)
        Active strains and rates.
    qdd : ndarray, shape (T, n), or None
        Accelerations (strong form only).
    u : ndarray, shape (T, p)
        Inputs held on ``[t_k, t_{k+1})``: generalised forces or actuator inputs
        (mapped by an :class:`~pcs_sindy.models.actuation.Actuation`).
    rows : ndarray of bool, shape (T,), optional
        Strong form: samples used (default all).
    windows : ndarray of int, shape (n_windows, 2), optional
        Weak form: the windows.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64] | None
    u: NDArray[np.float64]
    rows: NDArray[np.bool_] | None = None
    windows: NDArray[np.intp] | None = None


Design = Callable[[Any, NDArray[np.bool_]], NDArray[np.float64]]


def static_recording(
    t: ArrayLike, q: ArrayLike, u: ArrayLike, *, settle: float = 0.5, name: str = "X"
) -> PreparedRecording:
    """One row per hold: the mean strains of each run of samples with one input, at rest.

    Parameters
    ----------
    t : array_like, shape (T,)
    q : array_like, shape (T, n)
        Modelled strains.
    u : array_like, shape (T, p)
        Inputs; a hold is a run of consecutive samples with identical inputs
        (one sample per hold is fine: equilibria listed one per row).
    settle : float, default 0.5
        Fraction of each hold (its start) left out of the mean: the robot
        settling after the input changed.  At least the hold's last sample is used.
    name : str
        The recording's name in error messages.

    Returns
    -------
    PreparedRecording
        ``t`` the holds' last times, ``q`` their mean strains, ``qd = qdd = 0``,
        ``u`` their inputs.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    u = np.asarray(u, dtype=float)
    if q.ndim != 2 or u.ndim != 2 or q.shape[0] != u.shape[0] or t.shape != (q.shape[0],):
        raise ValueError(
            f"{name}: t (T,), q (T, n) and u (T, p) must have one row per sample; got {t.shape}, {q.shape}, {u.shape}"
        )
    if not 0.0 <= settle < 1.0:
        raise ValueError(f"settle must be in [0, 1); got {settle!r}")
    if not np.all(np.isfinite(q)):
        k = int(np.argwhere(~np.isfinite(q))[0][0])
        raise ValueError(f"{name}: the strains of sample {k} are NaN or inf; drop missing samples before a static fit")
    change = np.r_[True, np.any(np.diff(u, axis=0) != 0, axis=1)]
    starts = np.flatnonzero(change)
    stops = np.r_[starts[1:], q.shape[0]]
    means, times, inputs = [], [], []
    for a, b in zip(starts, stops, strict=True):
        first = min(a + int(np.floor(settle * (b - a))), b - 1)
        means.append(q[first:b].mean(axis=0))
        times.append(t[b - 1])
        inputs.append(u[a])
    qm = np.asarray(means)
    zeros = np.zeros_like(qm)
    return PreparedRecording(np.asarray(times), qm, zeros, zeros.copy(), np.asarray(inputs))


def _check(recordings: Sequence[PreparedRecording], formulation: str) -> list[PreparedRecording]:
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}; got {formulation!r}")
    recs = list(recordings)
    for k, r in enumerate(recs):
        if formulation in ("strong", "static") and r.qdd is None:
            raise ValueError(f"recording {k} has no qdd: the strong form needs accelerations")
        if formulation == "weak" and r.windows is None:
            raise ValueError(f"recording {k} has no windows: the weak form needs them")
    return recs


def library_rows(
    library: Any,
    recordings: Sequence[PreparedRecording],
    formulation: str,
    kept: NDArray[np.bool_] | None = None,
    *,
    test_function: str | None = "bump",
) -> NDArray[np.float64]:
    """Rows of the Lagrangian library (n_rows, n_kept, n_coefficients_) on the strains ``kept`` (default all)."""
    recs = _check(recordings, formulation)
    kept = np.ones(recs[0].q.shape[1], dtype=bool) if kept is None else kept
    parts = []
    for r in recs:
        if formulation in ("strong", "static"):
            sel = slice(None) if r.rows is None else r.rows
            parts.append(
                np.asarray(
                    library.euler_lagrange_matrix(r.q[sel][:, kept], r.qd[sel][:, kept], r.qdd[sel][:, kept]),
                    dtype=float,
                )
            )
        else:
            parts.append(weak_rows(library, r.t, r.q[:, kept], r.qd[:, kept], r.windows, test_function=test_function))
    return np.concatenate(parts)


def input_rows(
    actuation: Any,
    recordings: Sequence[PreparedRecording],
    formulation: str,
    *,
    offsets: NDArray[np.float64] | None = None,
    test_function: str | None = "bump",
    hold: str = "zoh",
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The inputs' generalised forces ``A(q) u = known + linear @ gains`` in the rows of a formulation.

    Weak form with held inputs (``hold="zoh"``): on each sample interval the
    input is constant and ``A(q(t))`` is taken at the interval's midpoint (the
    mean of its ends; exact for a constant ``A``), then integrated exactly
    against the test function.

    Returns
    -------
    known : ndarray, shape (n_rows, n)
    linear : ndarray, shape (n_rows, n, n_gains)
    """
    recs = _check(recordings, formulation)
    known_parts, linear_parts = [], []
    for r in recs:
        if formulation in ("strong", "static"):
            sel = slice(None) if r.rows is None else r.rows
            known, linear = actuation.parts(r.q[sel], r.u[sel], offsets)
        else:
            known, linear = actuation.parts(r.q, r.u, offsets)
            if hold == "zoh" and getattr(actuation, "depends_on_q", False):
                q_next = np.concatenate([r.q[1:], r.q[-1:]])
                k2, l2 = actuation.parts(q_next, r.u, offsets)
                known, linear = 0.5 * (known + k2), 0.5 * (linear + l2)
            T, n = known.shape
            flat = np.concatenate([known, linear.reshape(T, -1)], axis=1)
            integ = integrate_forces(r.t, flat, r.windows, hold=hold, test_function=test_function)
            known, linear = integ[:, :n], integ[:, n:].reshape(integ.shape[0], n, linear.shape[-1])
        known_parts.append(known)
        linear_parts.append(linear)
    return np.concatenate(known_parts), np.concatenate(linear_parts)


def regression(
    library: Any,
    recordings: Sequence[PreparedRecording],
    formulation: str,
    actuation: Any,
    *,
    offsets: NDArray[np.float64] | None = None,
    test_function: str | None = "bump",
    hold: str = "zoh",
) -> tuple[NDArray[np.float64], NDArray[np.float64], Design]:
    """Regression rows of several recordings in one formulation: ``x @ [coef, gains] = y``.

    Parameters
    ----------
    library : LagrangianLibrary
        Fitted on the recordings' segmentation.
    recordings : sequence of PreparedRecording
    formulation : {"strong", "weak", "static"}
    actuation : Actuation
        Fitted input map (:class:`~pcs_sindy.models.actuation.IdentityActuation` when
        the inputs are the generalised forces).
    offsets : ndarray, optional
        The actuation's nonlinear parameters (default: its own).
    test_function : {"bump", None}
        Weak form: the test function (see :func:`weak_rows`).
    hold : {"zoh", "trapezoid", "simpson"}
        Weak form: how the inputs are integrated (see :func:`integrate_forces`).

    Returns
    -------
    x : ndarray, shape (n_rows, n, n_coefficients_ + n_gains)
        The library's rows, then minus the input forces per unit gain.
    y : ndarray, shape (n_rows, n)
        The input forces of the known part of ``A``.
    design : callable
        ``design(restricted_library, kept)`` returns the rows of a library of
        the strains ``kept`` (bool over this library's active strains), stacked
        like ``x``; the optimizer calls it after removing strains.
    """
    recs = _check(recordings, formulation)
    y, linear = input_rows(actuation, recs, formulation, offsets=offsets, test_function=test_function, hold=hold)
    n_pins = 0
    if formulation == "static":  # the inertia and damping columns vanish at rest: pin them to 0
        rows = library_rows(library, recs, formulation)
        n_pins = int(np.sum(~(np.linalg.norm(rows.reshape(-1, rows.shape[-1]), axis=0) > 0)))
        y = np.concatenate([y, np.zeros((n_pins, y.shape[1]))])

    def design(lib: Any, kept: NDArray[np.bool_]) -> NDArray[np.float64]:
        # the optimizer restricts the column layout it was given: with identified gains a WithGains,
        # whose Lagrangian rows are its library's (the gain columns follow from ``linear``)
        lib = lib.library if isinstance(lib, WithGains) else lib
        rows = library_rows(lib, recs, formulation, kept, test_function=test_function)
        x = np.concatenate([rows, -linear[:, kept, :]], axis=2)
        if n_pins:
            x = np.concatenate([x, static_pins(x, n_pins)])
        return x

    x = design(library, np.ones(recs[0].q.shape[1], dtype=bool))
    return x, y, design


def static_pins(x: NDArray[np.float64], n_pins: int) -> NDArray[np.float64]:
    """Rows (n_pins, n, n_cols) that pin the all-zero columns of static rows ``x`` to 0.

    At rest the inertia and damping columns vanish; a tiny row per such column
    (1e-9 of the largest column norm, in the first equation) keeps the
    regression full rank and those coefficients at 0, reported as
    undetermined by the identifiability analysis.  A restricted library may
    have fewer such columns: the rows beyond them stay zero.
    """
    flat = x.reshape(-1, x.shape[-1])
    norms = np.linalg.norm(flat, axis=0)
    zero = np.flatnonzero(~(norms > 0))
    pins = np.zeros((n_pins,) + x.shape[1:])
    weight = 1e-9 * (norms.max() if norms.size and norms.max() > 0 else 1.0)
    for k, j in enumerate(zero[:n_pins]):
        pins[k, 0, j] = weight
    return pins
