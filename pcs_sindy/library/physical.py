"""Physically parameterised PCS library: the regressor is linear in per-segment physics.

For a planar PCS robot with known segment lengths the generalised forces are
linear in the per-segment parameters

    theta_i = (rhoA_i, rhoI_i, k_be,i, k_sh,i, k_ax,i, d_be,i, d_sh,i, d_ax,i)

(line density, rotary line inertia, stiffnesses, damping).  With the
positional Jacobian ``J_p`` and the backbone acceleration ``a = J_p q̈ + J̇_p q̇``

    tau = sum_i rhoA_i int_{seg i} J_p^T (a - g) ds + rhoI_i M_I,i q̈ + K q + D q̇,

(``M_I,i = int_{seg i} J_o^T J_o ds`` is constant because the orientation is
linear in the strains).  Every column of the Euler–Lagrange matrix ``Psi`` is
the inverse dynamics with one unit parameter, computed numerically by
Gauss–Legendre quadrature of closed-form Jacobians
(:mod:`pcs_sindy.library._pcs_numeric`) for any number of segments, batched over
samples.  No symbolic derivation.

Coefficient layout (``n_coefficients_`` columns)
-------------------------------------------------
Per segment ``i``: ``rhoA_i``, ``rhoI_i``, (with ``identify_gravity``:
``rhoAgx_i``, ``rhoAgy_i`` = ``rhoA_i g_x``, ``rhoA_i g_y``), then the
stiffness ``k_<strain>_i`` of each active strain of the segment; after all
segments (with ``rest_strain=True``) the constant generalised force
``f0_<strain>_i`` of every active strain, then the damping ``d_<strain>_i`` of
every active strain (damping last).
With ``rotary_inertia="tied"`` (or ``"none"``) there is no ``rhoI_i``: the
``rhoA_i`` column carries ``r_i^2/4`` (or 0) times the rotary-inertia terms.
Columns that vanish identically because every strain they act through is
inactive are dropped (e.g. the rotary inertia of a segment when no bending
strain at or before it is active).

Rest strain
-----------
With ``rest_strain=True`` the model is
``M q̈ + C q̇ + G + K q + D q̇ - f0 = tau``: ``f0 = K q*`` is the elastic force
of a rest strain ``q*`` (``K (q - q*)``), a column ``-1`` in the row of its
strain, lower bound ``-inf``.  It also absorbs a wrong rest length: with
lengths scaled by ``1 + e`` the PCS shape is reproduced with strains scaled by
``1 / (1 + e)`` except for a constant axial force ``k_ax e (1 + e)``.

Stiffness convention
--------------------
The stiffness coefficient is the physical stiffness ``k_e`` itself
(``stiffness_factor_ = 1``), not ``-k_e/2`` as for the coefficient of ``q_e^2``
in the monomial Lagrangian library (factor ``-2``).  Use
:meth:`PhysicalPCSLibrary.stiffness_from_coef` to read stiffness in physical
units whichever library produced the coefficients.

Weak (integral) form
--------------------
Over a window ``[t_a, t_b]``

    int (M q̈ + C q̇) dt = [M q̇]_{t_a}^{t_b} - int dT/dq dt,

so :meth:`PhysicalPCSLibrary.integrated_euler_lagrange_matrix` needs only ``q``
and ``q̇`` (no ``q̈``); :func:`integrate_forces` integrates ``tau`` over the same
windows (exactly for a zero-order hold).  The damping column integrates
exactly to ``q(t_b) - q(t_a)``.  With ``test_function="bump"`` the integrals
are weighted by a smooth bump ``phi`` that vanishes at the window ends, so
``int phi (d/dt p) dt = -int phi' p dt`` replaces the single-sample boundary
terms by averages over the window (much less sensitive to noise in ``q̇``).

Identification side: never imports :mod:`pcs_sindy.simulation`.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.feature_library.base import BaseFeatureLibrary, x_sequence_or_item
from pysindy.utils import AxesArray, comprehend_axes
from numpy.polynomial import Polynomial
from scipy import sparse
from scipy.integrate import cumulative_simpson, cumulative_trapezoid
from sklearn.utils.validation import check_is_fitted
from tqdm.auto import tqdm

from pcs_sindy.kinematics import STRAIN_NAMES, PlanarPCS
from pcs_sindy.library import _pcs_numeric as _num

__all__ = [
    "PhysicalPCSLibrary",
    "integrate_forces",
    "sliding_windows",
    "check_windows",
    "weak_form_rows",
    "identifiability",
]

_CHUNK = 512  # samples per vectorised block (bounds the memory of the node arrays)
_RULES = ("trapezoid", "simpson")


# --------------------------------------------------------------------------
# Plain functions: windows and time integration
# --------------------------------------------------------------------------
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


def weak_form_rows(
    library: "PhysicalPCSLibrary",
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
    """Weak-form regression rows of one recording: ``y ≈ x @ coef`` without ``q̈``.

    Parameters
    ----------
    library : PhysicalPCSLibrary
    t : array_like, shape (T,)
    q, qd, tau : array_like, shape (T, n)
        Active strains, rates and generalised forces.
    width, stride : int
        Window length in sampling intervals and step between windows (see
        :func:`sliding_windows`).
    test_function, hold, rule
        As in :meth:`PhysicalPCSLibrary.integrated_euler_lagrange_matrix` and
        :func:`integrate_forces`.

    Returns
    -------
    x : ndarray, shape (n_windows * n, n_coefficients_)
    y : ndarray, shape (n_windows * n,)
    """
    q = np.asarray(q, dtype=float)
    windows = sliding_windows(q.shape[0], width, stride)
    x = library.integrated_euler_lagrange_matrix(t, q, qd, windows, rule=rule, test_function=test_function)
    y = integrate_forces(t, tau, windows, hold=hold, test_function=test_function)
    if y.shape != x.shape[:2]:
        raise ValueError(f"tau must have shape {q.shape} like q; got {np.asarray(tau).shape}")
    return x.reshape(-1, x.shape[-1]), y.reshape(-1)


def identifiability(
    x: ArrayLike,
    y: ArrayLike,
    coef: ArrayLike,
    names: Sequence[str] | None = None,
    *,
    rcond: float = 1e-12,
    tol: float = 0.1,
) -> dict:
    """Which coefficients a least-squares fit ``y ≈ x @ coef`` actually determined.

    Standard errors come from the residual of the fit, ``cov = s^2 (x^T x)^-1``
    with ``s^2 = |y - x coef|^2 / (n_rows - n_coef)``, evaluated through the SVD
    of the column-scaled ``x`` (never an explicit inverse).  Directions of
    ``x`` with singular value below ``rcond * s_max`` are not determined at
    all: every coefficient they involve gets an infinite standard error.

    Parameters
    ----------
    x : array_like, shape (n_rows, n_coef) or (n_samples, n, n_coef)
        Regression matrix (e.g. ``Psi`` or its weak form).
    y : array_like, shape (n_rows,) or (n_samples, n)
        Targets stacked like ``x``.
    coef : array_like, shape (n_coef,)
        The fitted coefficients.
    names : sequence of str, optional
        Coefficient names (default ``c0, c1, ...``).
    rcond : float
        Relative singular-value cut-off of the column-scaled ``x``.
    tol : float
        Relative standard error above which a coefficient is reported as poorly determined.

    Returns
    -------
    dict
        ``condition_number`` (of the column-scaled ``x``; inf if rank deficient),
        ``rank``, ``singular_values``, ``residual_std``, ``standard_errors``,
        ``relative_standard_errors`` (``se / |coef|``), ``names`` and
        ``poorly_determined`` (names whose relative error exceeds ``tol``).
    """
    x = np.asarray(x, dtype=float)
    if x.ndim == 3:
        x = x.reshape(-1, x.shape[-1])
    y = np.asarray(y, dtype=float).reshape(-1)
    if x.ndim != 2 or y.shape != (x.shape[0],):
        raise ValueError(f"x must be (n_rows, n_coef) and y (n_rows,) stacked alike; got x {x.shape}, y {y.shape}")
    p = x.shape[1]
    coef = np.asarray(coef, dtype=float).reshape(-1)
    if coef.shape != (p,):
        raise ValueError(f"coef must have shape ({p},); got shape {coef.shape}")
    for name, arr in (("x", x), ("y", y), ("coef", coef)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
    if x.shape[0] <= p:
        raise ValueError(f"x needs more rows than coefficients to estimate errors; got {x.shape[0]} rows for {p}")
    if not (0 < rcond < 1) or not tol > 0:
        raise ValueError(f"rcond must be in (0, 1) and tol > 0; got rcond={rcond!r}, tol={tol!r}")
    names = [f"c{j}" for j in range(p)] if names is None else list(names)
    if len(names) != p:
        raise ValueError(f"names must hold {p} names; got {len(names)}")
    scale = np.linalg.norm(x, axis=0)
    safe = np.where(scale > 0, scale, 1.0)
    _, sv, vt = np.linalg.svd(x / safe, full_matrices=False)
    keep = sv > rcond * sv[0] if sv[0] > 0 else np.zeros_like(sv, dtype=bool)
    rank = int(keep.sum())
    resid = y - x @ coef
    s2 = float(resid @ resid) / (x.shape[0] - p)
    v = vt[keep].T / sv[keep]  # columns V S^-1 of the determined directions
    se = np.sqrt(s2 * np.sum(v * v, axis=1)) / safe
    # coefficients touched by an undetermined direction (or an all-zero column) are not determined
    null = vt[~keep]
    undetermined = (scale == 0) | (np.abs(null).max(axis=0) > 1e-8 if null.size else np.zeros(p, dtype=bool))
    se = np.where(undetermined, np.inf, se)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(coef != 0, se / np.abs(coef), np.inf)
    cond = float(sv[0] / sv[-1]) if rank == p else np.inf
    return {
        "condition_number": cond,
        "rank": rank,
        "singular_values": sv,
        "residual_std": float(np.sqrt(s2)),
        "standard_errors": se,
        "relative_standard_errors": rel,
        "names": names,
        "poorly_determined": [nm for nm, r in zip(names, rel) if not r <= tol],
    }


# --------------------------------------------------------------------------
# Library
# --------------------------------------------------------------------------
class _Spec:
    """Validated structure of a library (column layout, quadrature, constant matrices)."""

    def __init__(self, lib: "PhysicalPCSLibrary") -> None:
        lengths = np.atleast_1d(np.asarray(lib.segment_lengths, dtype=float))
        if lengths.ndim != 1 or lengths.size == 0 or not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
            raise ValueError(
                f"segment_lengths must be a non-empty 1-D sequence of finite lengths > 0; got {lib.segment_lengths!r}"
            )
        self.kin = PlanarPCS(tuple(lengths), active_strains=lib.active_strains)
        m = self.kin.n_segments
        radius = np.asarray(lib.radius, dtype=float)
        if radius.ndim == 0:
            radius = np.full(m, float(radius))
        if radius.shape != (m,) or not np.all(np.isfinite(radius)) or np.any(radius <= 0):
            raise ValueError(f"radius must be a finite value > 0 or one per segment ({m}); got {lib.radius!r}")
        self.radius = radius
        g = np.asarray(lib.gravity, dtype=float)
        if g.shape != (2,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity must be a finite vector of shape (2,); got {lib.gravity!r}")
        self.gravity = g
        if not isinstance(lib.identify_gravity, (bool, np.bool_)):
            raise ValueError(f"identify_gravity must be True or False; got {lib.identify_gravity!r}")
        if lib.rotary_inertia not in ("free", "tied", "none"):
            raise ValueError(f"rotary_inertia must be 'free', 'tied' or 'none'; got {lib.rotary_inertia!r}")
        self.rotary = lib.rotary_inertia
        # rhoI_i = tie_i * rhoA_i when not identified: r^2/4 for a full circular section, or 0
        self.tie = radius**2 / 4.0 if self.rotary == "tied" else np.zeros(m)
        nq = lib.n_quadrature
        if isinstance(nq, bool) or not isinstance(nq, (int, np.integer)) or nq < 1:
            raise ValueError(f"n_quadrature must be a positive integer; got {nq!r}")
        self.quad = _num.make_quadrature(lengths, int(nq))
        self.mask = self.kin.active_mask.copy()
        self.active = np.flatnonzero(self.mask)
        self.n = self.active.size
        if self.n == 0:
            raise ValueError("active_strains must leave at least one strain active")
        row_of = -np.ones(3 * m, dtype=int)
        row_of[self.active] = np.arange(self.n)
        self.row_of = row_of
        rot = _num.rotary_mass(lengths)
        self.rot = rot[:, self.active][:, :, self.active]  # (m, n, n)

        names: list[str] = []
        kinds: list[tuple[str, int, int]] = []  # (kind, segment, full strain index)
        for i in range(m):
            any_before = bool(self.mask[: 3 * (i + 1)].any())
            bend_before = bool(self.mask[0 : 3 * (i + 1) : 3].any())
            seg = i + 1
            if any_before:
                names.append(f"rhoA_{seg}")
                kinds.append(("rhoA", i, -1))
            if bend_before and self.rotary == "free":
                names.append(f"rhoI_{seg}")
                kinds.append(("rhoI", i, -1))
            if lib.identify_gravity and any_before:
                names += [f"rhoAgx_{seg}", f"rhoAgy_{seg}"]
                kinds += [("gx", i, -1), ("gy", i, -1)]
            for c in range(3):
                e = 3 * i + c
                if self.mask[e]:
                    names.append(f"k_{STRAIN_NAMES[c]}_{seg}")
                    kinds.append(("k", i, e))
        rest = getattr(lib, "rest_strain", False)  # libraries pickled before the parameter existed
        if not isinstance(rest, (bool, np.bool_)):
            raise ValueError(f"rest_strain must be True or False; got {rest!r}")
        self.rest_strain = bool(rest)
        if self.rest_strain:
            for e in self.active:
                names.append(f"f0_{STRAIN_NAMES[e % 3]}_{e // 3 + 1}")
                kinds.append(("f0", e // 3, e))
        for e in self.active:
            names.append(f"d_{STRAIN_NAMES[e % 3]}_{e // 3 + 1}")
            kinds.append(("d", e // 3, e))
        self.names = names
        self.kinds = kinds
        self.n_coef = len(names)
        self.col = {name: j for j, name in enumerate(names)}
        kind_arr = np.array([k[0] for k in kinds])
        self.stiffness_index = np.array([j for j, k in enumerate(kinds) if k[0] == "k"], dtype=int)
        self.damping_index = np.array([j for j, k in enumerate(kinds) if k[0] == "d"], dtype=int)
        self.rest_index = np.array([j for j, k in enumerate(kinds) if k[0] == "f0"], dtype=int)
        lower = np.zeros(self.n_coef)
        lower[(kind_arr == "gx") | (kind_arr == "gy") | (kind_arr == "f0")] = -np.inf
        self.lower = lower
        # columns per kind for fast assembly
        self.cols_rhoA = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "rhoA"]
        self.cols_rhoI = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "rhoI"]
        self.cols_gx = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "gx"]
        self.cols_gy = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "gy"]
        self.identify_gravity = bool(lib.identify_gravity)
        self.g_complex = complex(g[0], g[1])


class PhysicalPCSLibrary(BaseFeatureLibrary):
    """Euler–Lagrange regressor of a planar PCS robot, linear in per-segment physical parameters.

    Same contract as the monomial :class:`~pcs_sindy.library.PCSLagrangianLibrary`
    (``euler_lagrange_matrix``, ``mass_matrix``, ``bias_forces``,
    ``potential_forces``, ``compile_dynamics``, ``restrict``, index attributes),
    so :class:`~pcs_sindy.regressor.EulerLagrangeRegressor` can use either.
    All ``q``, ``qd``, ``qdd`` inputs hold the *active* strains only.

    Parameters
    ----------
    segment_lengths : sequence of float, shape (m,)
        Segment rest lengths in metres, base to tip.
    active_strains : array_like of bool, shape (m, 3) or (3m,), optional
        Modelled strains (default: all); inactive strains are held at 0.
    radius : float or sequence of float, default 0.02
        Cross-section radius (m), used by :meth:`coefficients_from_parameters`
        and by stiffness bounds; it does not enter the regressor columns.
    gravity : sequence of float, shape (2,), default (0, 9.81)
        Known gravity in the base frame (used unless ``identify_gravity``).
    identify_gravity : bool, default False
        Identify ``rhoA_i g`` as two free columns per segment instead.
    n_quadrature : int, default 16
        Gauss–Legendre nodes per segment.  Measured against 32 nodes: 12 and 16
        nodes agree to round-off up to ``|kappa L| = 9`` rad; 8 nodes to 1e-11
        at ``|kappa L| = 6`` (half the cost of the batched evaluations).
    rotary_inertia : {"free", "tied", "none"}, default "free"
        ``"free"``: identify ``rhoI_i`` as its own parameter; ``"tied"``: fix
        ``rhoI_i = rhoA_i r_i^2 / 4`` (solid circular section of the library's
        ``radius``; one mass parameter per segment, better conditioned under
        noise); ``"none"``: neglect rotary inertia.
    rest_strain : bool, default False
        Identify a constant generalised force ``f0_<strain>`` per active strain
        (``M q̈ + C q̇ + G + K q + D q̇ - f0 = tau``; ``f0 = K q*`` for a rest
        strain ``q*``), placed after the stiffnesses and before the damping.

    Attributes
    ----------
    n_coefficients_ : int
        Number of parameters (damping last); see the module docstring for the layout.
    stiffness_index_, damping_index_ : ndarray of int, shape (n,)
        Column of each active strain's stiffness / damping parameter.
    rest_force_index_ : ndarray of int, shape (n,) or (0,)
        Column of each active strain's constant force ``f0`` (empty without ``rest_strain``).
    stiffness_factor_ : float
        ``1.0``: the stiffness is the coefficient itself (monomial library: ``-2``).
    lower_bounds_ : ndarray, shape (n_coefficients_,)
        0 for densities, stiffnesses and damping, ``-inf`` for identified gravity
        terms and constant forces ``f0``; pass ``(lower_bounds_, inf)`` to :func:`scipy.optimize.lsq_linear`.
    column_map_ : ndarray of int
        Only on libraries made by :meth:`restrict`: the parent's column of each column.
    n_features_in_, n_output_features_ : int
        After :meth:`fit` on states ``[q, qd]``: ``2n`` and the number of
        Lagrangian basis terms (all parameters except damping; ``f0_e`` has ``q_e``).
    """

    def __init__(
        self,
        segment_lengths: Sequence[float],
        active_strains: ArrayLike | None = None,
        radius: float | Sequence[float] = 0.02,
        gravity: Sequence[float] = (0.0, 9.81),
        identify_gravity: bool = False,
        n_quadrature: int = 16,
        rotary_inertia: str = "free",
        rest_strain: bool = False,
    ) -> None:
        self.segment_lengths = segment_lengths
        self.active_strains = active_strains
        self.radius = radius
        self.gravity = gravity
        self.identify_gravity = identify_gravity
        self.n_quadrature = n_quadrature
        self.rotary_inertia = rotary_inertia
        self.rest_strain = rest_strain

    # -- structure -------------------------------------------------------------
    def _key(self) -> tuple:
        act = None if self.active_strains is None else np.asarray(self.active_strains).tobytes()
        return (
            np.asarray(self.segment_lengths, dtype=float).tobytes(),
            act,
            np.asarray(self.radius, dtype=float).tobytes(),
            np.asarray(self.gravity, dtype=float).tobytes(),
            self.identify_gravity,
            self.n_quadrature,
            self.rotary_inertia,
            self.rest_strain,
        )

    @property
    def _spec(self) -> _Spec:
        key = self._key()
        cached = self.__dict__.get("_spec_cache")
        if cached is None or cached[0] != key:
            cached = (key, _Spec(self))
            self.__dict__["_spec_cache"] = cached
        return cached[1]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_spec_cache", None)
        return state

    @property
    def kinematics(self) -> PlanarPCS:
        """The kinematic model (segment lengths and active strains)."""
        return self._spec.kin

    @property
    def n_coefficients_(self) -> int:
        return self._spec.n_coef

    @property
    def stiffness_index_(self) -> NDArray[np.intp]:
        return self._spec.stiffness_index.copy()

    @property
    def damping_index_(self) -> NDArray[np.intp]:
        return self._spec.damping_index.copy()

    @property
    def rest_force_index_(self) -> NDArray[np.intp]:
        return self._spec.rest_index.copy()

    @property
    def lower_bounds_(self) -> NDArray[np.float64]:
        return self._spec.lower.copy()

    stiffness_factor_: float = 1.0

    def euler_lagrange_names(self) -> list[str]:
        """Names of the ``n_coefficients_`` parameters, e.g. ``rhoA_1``, ``k_be_1``, ``d_ax_2``."""
        return list(self._spec.names)

    def stiffness_from_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        """Stiffness of every active strain in physical units, shape (n,).

        ``stiffness_factor_ * coef[stiffness_index_]``; the factor is 1 here
        (the parameter is the stiffness) and -2 for the monomial library.
        """
        coef = self._check_coef(coef)
        return self.stiffness_factor_ * coef[self._spec.stiffness_index]

    def damping_from_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        """Damping coefficient of every active strain, shape (n,)."""
        coef = self._check_coef(coef)
        return coef[self._spec.damping_index].copy()

    def rest_force_from_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        """Constant generalised force ``f0`` of every active strain, shape (n,) (0 without ``rest_strain``)."""
        coef = self._check_coef(coef)
        spec = self._spec
        out = np.zeros(spec.n)
        if spec.rest_index.size:
            out[:] = coef[spec.rest_index]
        return out

    # -- input checks ------------------------------------------------------------
    def _check_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        spec = self._spec
        c = np.asarray(coef, dtype=float)
        if c.ndim == 2 and c.shape[0] == 1:
            c = c[0]
        if c.shape != (spec.n_coef,):
            raise ValueError(f"coef must have shape ({spec.n_coef},) (n_coefficients_); got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise ValueError("coef contains NaN or inf")
        return c

    def _check_states(self, **arrays: ArrayLike) -> list[NDArray[np.float64]]:
        n = self._spec.n
        out = []
        shape = None
        for name, value in arrays.items():
            a = np.asarray(value, dtype=float)
            if a.ndim != 2 or a.shape[1] != n:
                raise ValueError(f"{name} must have shape (n_samples, {n}) (active strains); got shape {a.shape}")
            if shape is not None and a.shape != shape:
                raise ValueError(f"{name} must have the same shape as {next(iter(arrays))}, {shape}; got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} contains NaN or inf")
            shape = a.shape
            out.append(a)
        return out

    def _full(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        spec = self._spec
        out = np.zeros((a.shape[0], 3 * spec.kin.n_segments))
        out[:, spec.active] = a
        return out

    # -- Euler–Lagrange matrix -----------------------------------------------------
    def _psi_block(self, q: NDArray, qd: NDArray, qdd: NDArray) -> NDArray[np.float64]:
        spec = self._spec
        B, n = q.shape
        quad = spec.quad
        qf, qdf, qddf = self._full(q), self._full(qd), self._full(qdd)
        f = _num.kinematic_fields(quad, qf, qdf, qddf)
        out = np.zeros((B, n, spec.n_coef))
        act = spec.active
        if spec.cols_rhoA:
            v = f["zdd"] if spec.identify_gravity else f["zdd"] - spec.g_complex
            P = _num.project(quad, f["own"], f["z"], f["zend"], v).real.reshape(B, quad.lengths.size, -1)
            for j, i in spec.cols_rhoA:
                out[:, :, j] = P[:, i, act]
                if spec.tie[i]:
                    out[:, :, j] += spec.tie[i] * (qdd @ spec.rot[i].T)
        if spec.cols_gx:
            P1 = _num.project(quad, f["own"], f["z"], f["zend"], 1.0).reshape(B, quad.lengths.size, -1)
            for j, i in spec.cols_gx:
                out[:, :, j] = -P1.real[:, i, act]
            for j, i in spec.cols_gy:
                out[:, :, j] = P1.imag[:, i, act]
        for j, i in spec.cols_rhoI:
            out[:, :, j] = qdd @ spec.rot[i].T
        rows = np.arange(n)
        out[:, rows, spec.stiffness_index] = q
        out[:, rows, spec.damping_index] = qd
        if spec.rest_index.size:
            out[:, rows, spec.rest_index] = -1.0
        return out

    def euler_lagrange_matrix(
        self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, *, progress: bool = False
    ) -> NDArray[np.float64]:
        """Regressor ``Psi`` with ``tau = Psi @ coef``, shape (n_samples, n, n_coefficients_).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n)
            Active strains, rates and accelerations.
        progress : bool
            Show a tqdm bar over blocks of samples.
        """
        q, qd, qdd = self._check_states(q=q, qd=qd, qdd=qdd)
        out = np.empty((q.shape[0], self._spec.n, self._spec.n_coef))
        starts = range(0, q.shape[0], _CHUNK)
        for a in tqdm(starts, disable=not progress, desc="Psi", unit="block"):
            b = a + _CHUNK
            out[a:b] = self._psi_block(q[a:b], qd[a:b], qdd[a:b])
        return out

    def _mass_block(self, q: NDArray, coef: NDArray) -> NDArray[np.float64]:
        spec = self._spec
        quad = spec.quad
        f = _num.kinematic_fields(quad, self._full(q))
        J = _num.jacobian(quad, f)[..., spec.active]  # (B, m, K, n)
        rhoA = np.zeros(quad.lengths.size)
        for j, i in spec.cols_rhoA:
            rhoA[i] = coef[j]
        M = np.einsum("bikp,bikr,ik->bpr", np.conj(J), J, quad.weights * rhoA[:, None]).real
        for j, i in spec.cols_rhoA:
            if spec.tie[i]:
                M = M + coef[j] * spec.tie[i] * spec.rot[i]
        for j, i in spec.cols_rhoI:
            M = M + coef[j] * spec.rot[i]
        return M

    def mass_matrix(self, q: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """Mass matrix ``M(q)`` of the parameters ``coef``, shape (n_samples, n, n)."""
        coef = self._check_coef(coef)
        (q,) = self._check_states(q=q)
        out = np.empty((q.shape[0], self._spec.n, self._spec.n))
        for a in range(0, q.shape[0], _CHUNK):
            out[a : a + _CHUNK] = self._mass_block(q[a : a + _CHUNK], coef)
        return out

    def bias_forces(self, q: ArrayLike, qd: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """All forces but ``M q̈``: ``C q̇ + G + K q + D q̇ - f0``, shape (n_samples, n)."""
        coef = self._check_coef(coef)
        q, qd = self._check_states(q=q, qd=qd)
        return self.euler_lagrange_matrix(q, qd, np.zeros_like(q)) @ coef

    def potential_forces(self, q: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """Conservative forces ``G + K q - f0``, shape (n_samples, n)."""
        coef = self._check_coef(coef)
        (q,) = self._check_states(q=q)
        z = np.zeros_like(q)
        return self.euler_lagrange_matrix(q, z, z) @ coef

    # -- weak form -------------------------------------------------------------------
    def _weak_block(self, q: NDArray, qd: NDArray) -> tuple[NDArray, NDArray]:
        """Per-sample boundary term (generalised momentum part) and integrand, both (B, n, n_coef)."""
        spec = self._spec
        B, n = q.shape
        quad = spec.quad
        m = quad.lengths.size
        f = _num.kinematic_fields(quad, self._full(q), self._full(qd), jacobian_rate=True)
        act = spec.active
        mom = np.zeros((B, n, spec.n_coef))
        integrand = np.zeros((B, n, spec.n_coef))
        if spec.cols_rhoA:
            Pm = _num.project(quad, f["own"], f["z"], f["zend"], f["zd"]).real.reshape(B, m, -1)
            dT = _num.project(quad, f["owndot"], f["zd"], f["zdend"], f["zd"]).real.reshape(B, m, -1)
            if spec.identify_gravity:
                grav = np.zeros_like(dT)
            else:
                grav = _num.project(quad, f["own"], f["z"], f["zend"], spec.g_complex).real.reshape(B, m, -1)
            for j, i in spec.cols_rhoA:
                mom[:, :, j] = Pm[:, i, act]
                if spec.tie[i]:
                    mom[:, :, j] += spec.tie[i] * (qd @ spec.rot[i].T)
                integrand[:, :, j] = -dT[:, i, act] - grav[:, i, act]
        if spec.cols_gx:
            P1 = _num.project(quad, f["own"], f["z"], f["zend"], 1.0).reshape(B, m, -1)
            for j, i in spec.cols_gx:
                integrand[:, :, j] = -P1.real[:, i, act]
            for j, i in spec.cols_gy:
                integrand[:, :, j] = P1.imag[:, i, act]
        for j, i in spec.cols_rhoI:
            mom[:, :, j] = qd @ spec.rot[i].T
        rows = np.arange(n)
        integrand[:, rows, spec.stiffness_index] = q
        if spec.rest_index.size:
            integrand[:, rows, spec.rest_index] = -1.0  # integrates to -int phi dt
        mom[:, rows, spec.damping_index] = q  # int qd dt = q(t_b) - q(t_a), exactly
        return mom, integrand

    def integrated_euler_lagrange_matrix(
        self,
        t: ArrayLike,
        q: ArrayLike,
        qd: ArrayLike,
        windows: ArrayLike,
        *,
        rule: str = "simpson",
        test_function: str | None = None,
        progress: bool = False,
    ) -> NDArray[np.float64]:
        """Weak form: ``int_{t_a}^{t_b} Psi dt`` per window, from ``q`` and ``qd`` only.

        ``int (M q̈ + C q̇) dt = [M q̇] - int dT/dq dt``; pair it with
        :func:`integrate_forces` on the same windows: ``int tau dt = result @ coef``.

        Parameters
        ----------
        t : array_like, shape (T,)
            Strictly increasing sample times.
        q, qd : array_like, shape (T, n)
            Active strains and rates.
        windows : array_like of int, shape (n_windows, 2)
            ``(start, stop)`` sample indices; see :func:`sliding_windows`.
        rule : {"simpson", "trapezoid"}
            Quadrature in time of the non-boundary terms (the boundary terms
            and the damping column are exact); without a test function only.
        test_function : {None, "bump"}
            ``None``: plain window integrals, whose boundary terms use single
            samples of ``qd`` at the window ends.  ``"bump"``: integrals weighted
            by ``phi = (4x(1-x))^3`` (x the normalised window time), which
            vanishes at the ends, so ``int phi (d/dt p) dt = -int phi' p dt``:
            no boundary samples, the noise of ``qd`` is averaged over the window
            and the damping column becomes ``-int phi' q dt`` (no ``qd``).
            Time quadrature: trapezoid (accurate to high order because the
            integrand vanishes smoothly at the ends).  Pair with
            ``integrate_forces(..., test_function="bump")``.
        progress : bool
            Show a tqdm bar over blocks of samples.

        Returns
        -------
        ndarray, shape (n_windows, n, n_coefficients_)
        """
        if rule not in _RULES:
            raise ValueError(f"rule must be 'simpson' or 'trapezoid'; got {rule!r}")
        _check_test_function(test_function)
        q, qd = self._check_states(q=q, qd=qd)
        t = _check_time(t, q.shape[0])
        w = check_windows(windows, q.shape[0])
        spec = self._spec
        mom = np.empty((q.shape[0], spec.n, spec.n_coef))
        integrand = np.empty_like(mom)
        for a in tqdm(range(0, q.shape[0], _CHUNK), disable=not progress, desc="weak Psi", unit="block"):
            b = a + _CHUNK
            mom[a:b], integrand[a:b] = self._weak_block(q[a:b], qd[a:b])
        if test_function == "bump":
            A, B = _test_weights(t, w)
            flat = (q.shape[0], -1)
            out = A @ integrand.reshape(flat) - B @ mom.reshape(flat)
            return np.asarray(out).reshape(w.shape[0], spec.n, spec.n_coef)
        cum = _cumulative(integrand, t, rule)
        return (mom[w[:, 1]] - mom[w[:, 0]]) + (cum[w[:, 1]] - cum[w[:, 0]])

    # -- physical parameters ------------------------------------------------------------
    def coefficients_from_parameters(
        self,
        density: float | ArrayLike,
        radius: float | ArrayLike | None,
        youngs_modulus: float | ArrayLike,
        shear_modulus: float | ArrayLike,
        damping: ArrayLike,
        gravity: ArrayLike | None = None,
        shear_factor: float = 4.0 / 3.0,
        stiffness_scaling: str = "seed",
    ) -> NDArray[np.float64]:
        """Coefficients of a robot with the given material, shape (n_coefficients_,).

        Parameters
        ----------
        density, youngs_modulus, shear_modulus : float or array_like, shape (m,)
            ``rho`` (kg/m^3), ``E``, ``G`` (Pa) per segment.
        radius : float or array_like, shape (m,), or None
            Cross-section radius (m); ``None`` uses the library's ``radius``.
        damping : array_like, shape (3m,) or (n,)
            Diagonal of ``D`` for all strains (inactive entries are ignored) or
            for the n active strains.
        gravity : array_like, shape (2,), optional
            With ``identify_gravity`` the gravity that fills the ``rhoA g``
            columns (default: the library's ``gravity``); otherwise it must equal
            the library's ``gravity`` if given.
        shear_factor : float
            ``c_sh`` in ``k_sh = f_L c_sh G A``.
        stiffness_scaling : {"seed", "length"}
            ``f_L = 1`` (the seed's simulator) or ``f_L = L_i``.

        Returns
        -------
        ndarray
            ``rhoA = rho pi r^2``, ``rhoI = rho pi r^4 / 4``,
            ``k = f_L [E I, c_sh G A, E A]``, ``d`` (and ``f0 = 0``: no rest strain), in the layout of
            :meth:`euler_lagrange_names`.
        """
        spec = self._spec
        m = spec.kin.n_segments

        def per_seg(val, name, positive):
            arr = np.asarray(val, dtype=float)
            if arr.ndim == 0:
                arr = np.full(m, float(arr))
            if arr.shape != (m,):
                raise ValueError(f"{name} must be a scalar or have shape ({m},); got shape {arr.shape}")
            if not np.all(np.isfinite(arr)) or np.any(arr <= 0 if positive else arr < 0):
                raise ValueError(f"{name} must be finite and {'> 0' if positive else '>= 0'}; got {arr.tolist()}")
            return arr

        rho = per_seg(density, "density", True)
        r = spec.radius if radius is None else per_seg(radius, "radius", True)
        if spec.rotary == "tied" and not np.allclose(r, spec.radius, rtol=1e-12, atol=0.0):
            raise ValueError(
                f"radius {r.tolist()} differs from the library's radius {spec.radius.tolist()}, which ties "
                "rhoI = rhoA r^2/4 (rotary_inertia='tied')"
            )
        E = per_seg(youngs_modulus, "youngs_modulus", False)
        G = per_seg(shear_modulus, "shear_modulus", False)
        d = np.asarray(damping, dtype=float)
        if d.shape == (spec.n,) and spec.n != 3 * m:
            d_full = np.zeros(3 * m)
            d_full[spec.active] = d
            d = d_full
        if d.shape != (3 * m,) or not np.all(np.isfinite(d)) or np.any(d < 0):
            raise ValueError(
                f"damping must have shape ({3 * m},) (all strains) or ({spec.n},) (active), finite and >= 0; "
                f"got {np.asarray(damping).tolist()}"
            )
        if not (np.isfinite(shear_factor) and shear_factor > 0):
            raise ValueError(f"shear_factor must be finite and > 0; got {shear_factor!r}")
        if stiffness_scaling == "seed":
            f_l = np.ones(m)
        elif stiffness_scaling == "length":
            f_l = spec.quad.lengths
        else:
            raise ValueError(f"stiffness_scaling must be 'seed' or 'length'; got {stiffness_scaling!r}")
        g = spec.gravity if gravity is None else np.asarray(gravity, dtype=float)
        if g.shape != (2,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity must be a finite vector of shape (2,); got {gravity!r}")
        if not spec.identify_gravity and not np.allclose(g, spec.gravity, rtol=1e-12, atol=0.0):
            raise ValueError(
                f"gravity {g.tolist()} differs from the library's known gravity {spec.gravity.tolist()}; "
                "use identify_gravity=True or build the library with this gravity"
            )
        area, inertia = np.pi * r**2, np.pi * r**4 / 4.0
        stiff = (f_l[:, None] * np.stack([E * inertia, shear_factor * G * area, E * area], axis=1)).reshape(-1)
        out = np.empty(spec.n_coef)
        for j, (kind, i, e) in enumerate(spec.kinds):
            out[j] = {
                "rhoA": lambda: rho[i] * area[i],
                "rhoI": lambda: rho[i] * inertia[i],
                "gx": lambda: rho[i] * area[i] * g[0],
                "gy": lambda: rho[i] * area[i] * g[1],
                "k": lambda: stiff[e],
                "d": lambda: d[e],
                "f0": lambda: 0.0,
            }[kind]()
        return out

    # -- strain removal -------------------------------------------------------------------
    def restrict(self, active_strains: ArrayLike) -> "PhysicalPCSLibrary":
        """Library of a subset of the active strains (removed strains held at 0).

        Parameters
        ----------
        active_strains : array_like of bool, shape (m, 3) or (3m,)
            Strains to keep; must be a subset of this library's active strains.

        Returns
        -------
        PhysicalPCSLibrary
            With ``column_map_``: this library's column of each of its columns.
            Its ``Psi`` equals this library's evaluated with the removed strains
            at 0, their rows and their (stiffness, damping and vanishing) columns dropped.
        """
        spec = self._spec
        m = spec.kin.n_segments
        new = np.asarray(active_strains)
        if new.shape not in ((m, 3), (3 * m,)):
            raise ValueError(f"active_strains must have shape ({m}, 3) or ({3 * m},); got {new.shape}")
        if new.dtype != bool and not np.all(np.isin(new, (0, 1))):
            raise ValueError(f"active_strains must be boolean; got {new.tolist()}")
        new = new.astype(bool).reshape(m, 3)
        extra = new.reshape(-1) & ~spec.mask
        if np.any(extra):
            names = [spec.kin.strain_names()[e] for e in np.flatnonzero(extra)]
            raise ValueError(f"active_strains may only remove strains; {names} are not active in this library")
        child = PhysicalPCSLibrary(
            self.segment_lengths,
            active_strains=new,
            radius=self.radius,
            gravity=self.gravity,
            identify_gravity=self.identify_gravity,
            n_quadrature=self.n_quadrature,
            rotary_inertia=self.rotary_inertia,
            rest_strain=self.rest_strain,
        )
        child.column_map_ = np.array([spec.col[name] for name in child._spec.names], dtype=int)
        if hasattr(self, "n_features_in_"):  # keep a fitted library fitted
            child.fit(np.zeros((1, 2 * child._spec.n)))
        return child

    # -- lumped parameters (compiled rollout) -------------------------------------------------
    def lumped_from_coef(self, coef: ArrayLike) -> dict:
        """Per-segment lumped parameters of ``coef``, for :mod:`pcs_sindy._jit_rollout`.

        Returns
        -------
        dict
            ``rhoA`` (m,), ``rhoI`` (m,) (rotary inertia per length, including
            the ``rotary_inertia='tied'`` share of ``rhoA``), ``rhoAg`` (m, 2)
            (identified or ``rhoA * gravity``), ``stiffness`` and ``damping`` (n,)
            of the active strains, ``rest_force`` (n,) the constant force ``f0``
            (not part of the compiled model: add it to the actuation),
            ``n_quadrature`` (this library's rule, so the compiled kernels
            reproduce :meth:`mass_matrix` to round-off).
            Parameters of segments that no active strain moves are 0.
        """
        coef = self._check_coef(coef)
        spec = self._spec
        m = spec.kin.n_segments
        rhoA, rhoI, rhoAg = np.zeros(m), np.zeros(m), np.zeros((m, 2))
        for j, i in spec.cols_rhoA:
            rhoA[i] = coef[j]
            rhoI[i] += spec.tie[i] * coef[j]
        for j, i in spec.cols_rhoI:
            rhoI[i] += coef[j]
        if spec.identify_gravity:
            for j, i in spec.cols_gx:
                rhoAg[i, 0] = coef[j]
            for j, i in spec.cols_gy:
                rhoAg[i, 1] = coef[j]
        else:
            rhoAg = rhoA[:, None] * spec.gravity[None, :]
        return {
            "rhoA": rhoA,
            "rhoI": rhoI,
            "rhoAg": rhoAg,
            "stiffness": self.stiffness_from_coef(coef),
            "damping": self.damping_from_coef(coef),
            "rest_force": self.rest_force_from_coef(coef),
            "n_quadrature": int(self.n_quadrature),
        }

    # -- fast single-sample dynamics ----------------------------------------------------------
    def compile_dynamics(self, coef: ArrayLike) -> Callable[[NDArray, NDArray], tuple[NDArray, NDArray]]:
        """Fast single-sample dynamics ``f(q, qd) -> (M (n, n), bias (n,))``.

        ``bias = C q̇ + G + K q + D q̇ - f0`` so that ``q̈ = solve(M, tau - bias)``.
        ``q`` and ``qd`` are 1-D arrays of the n active strains; they are not
        validated (integrator inner loop).  Everything that does not depend on
        the state (gather indices of the Jacobian, weights, constant rotary
        mass) is built here once, so a call is a fixed number of small numpy
        operations on (m, K) arrays.
        """
        coef = self._check_coef(coef)
        spec = self._spec
        quad = spec.quad
        L, ell, wts = quad.lengths, quad.ell, quad.weights
        m, K = L.size, quad.n_nodes
        n, act = spec.n, spec.active
        all_active = n == 3 * m
        rhoA = np.zeros(m)
        for j, i in spec.cols_rhoA:
            rhoA[i] = coef[j]
        wA = (wts * rhoA[:, None]).reshape(-1)  # (m K,) mass weight of each node
        M_rot = np.zeros((n, n))
        for j, i in spec.cols_rhoI:
            M_rot += coef[j] * spec.rot[i]
        for j, i in spec.cols_rhoA:
            M_rot += coef[j] * spec.tie[i] * spec.rot[i]
        if spec.identify_gravity:
            g_seg = np.zeros(m, dtype=complex)
            for j, i in spec.cols_gx:
                g_seg[i] += coef[j]
            for j, i in spec.cols_gy:
                g_seg[i] += 1j * coef[j]
            gw = (g_seg[:, None] * wts).reshape(-1)  # rhoA g w per node
        else:
            gw = spec.g_complex * wA
        stiff = coef[spec.stiffness_index].copy()
        damp = coef[spec.damping_index].copy()
        f0 = self.rest_force_from_coef(coef)
        # Jacobian at the nodes as one gather from src = [own_be, own_sh, own_ax, 0] (each (m, K+1))
        # plus the rigid swing of earlier bending strains: J[p, col] += i L_k (z_p - zend_k)
        Kp = K + 1
        zero_idx = 3 * m * Kp
        gather = np.full((m * K, n), zero_idx, dtype=np.intp)
        swing = np.zeros((m * K, n), dtype=complex)
        col_seg = act // 3
        for i in range(m):
            for p in range(K):
                row = i * K + p
                for col, e in enumerate(act):
                    k, c = divmod(int(e), 3)
                    if k < i:
                        gather[row, col] = c * m * Kp + k * Kp + K
                        if c == 0:
                            swing[row, col] = 1j * L[k]
                    elif k == i:
                        gather[row, col] = c * m * Kp + k * Kp + p
        zero = np.zeros(1, dtype=complex)
        ell2i = 1j * ell**2
        ell3n = -(ell**3)
        one = 1.0

        def dynamics(q: NDArray, qd: NDArray) -> tuple[NDArray, NDArray]:
            if all_active:
                qf, qdf = q, qd
            else:
                qf = np.zeros(3 * m)
                qf[act] = q
                qdf = np.zeros(3 * m)
                qdf[act] = qd
            kap = qf[0::3]
            e0, e1, e2 = _num.moments(kap[:, None] * ell)
            F = ell * e0
            Fk = ell2i * e1
            turn = kap * L
            eph = np.exp(1j * (np.cumsum(turn) - turn))
            w = qf[1::3] + 1j * (one + qf[2::3])
            kd = qdf[0::3]
            wd = qdf[1::3] + 1j * qdf[2::3]
            turn_d = kd * L
            phid = np.cumsum(turn_d) - turn_d
            ew = eph * w
            sh = eph[:, None] * F
            be = ew[:, None] * Fk
            T = w[:, None] * sh
            Tend = T[:, K]
            zstart = np.cumsum(Tend) - Tend
            z = (zstart[:, None] + T[:, :K]).reshape(-1)
            zend = zstart + Tend
            # convective acceleration of the nodes (q̈ = 0), e^{i phi} (c0 F + c1 F_k + c2 F_kk)
            ipd = 2j * phid
            c0 = ew * (-(phid * phid)) + ipd * eph * wd
            c1 = (ipd * ew + 2.0 * eph * wd) * kd
            c2 = ew * (kd * kd)
            Tdd = c0[:, None] * F + c1[:, None] * Fk + c2[:, None] * (ell3n * e2)
            Tdd_end = Tdd[:, K]
            acc = ((np.cumsum(Tdd_end) - Tdd_end)[:, None] + Tdd[:, :K]).reshape(-1)
            shf = sh.reshape(-1)
            J = np.concatenate([be.reshape(-1), shf, 1j * shf, zero])[gather]
            J += swing * (z[:, None] - zend[col_seg])
            Jc = J.conj().T
            M = (Jc @ (J * wA[:, None])).real + M_rot
            bias = (Jc @ (wA * acc - gw)).real + stiff * q + damp * qd - f0
            return M, bias

        return dynamics

    # -- pysindy feature library on states [q, qd] ----------------------------------------------
    def _energy_block(self, q: NDArray, qd: NDArray) -> NDArray[np.float64]:
        spec = self._spec
        quad = spec.quad
        f = _num.kinematic_fields(quad, self._full(q), self._full(qd))
        cols = [j for j, k in enumerate(spec.kinds) if k[0] != "d"]
        out = np.zeros((q.shape[0], len(cols)))
        kin_A = 0.5 * np.sum(quad.weights * np.abs(f["zd"]) ** 2, axis=-1)  # (B, m)
        pos = np.sum(quad.weights * f["z"], axis=-1)  # (B, m) int z ds per segment
        for out_j, j in enumerate(cols):
            kind, i, e = spec.kinds[j]
            if kind == "rhoA":
                pot = 0.0 if spec.identify_gravity else (np.conj(spec.g_complex) * pos[:, i]).real
                out[:, out_j] = kin_A[:, i] + pot
                if spec.tie[i]:
                    out[:, out_j] += spec.tie[i] * 0.5 * np.einsum("ba,ac,bc->b", qd, spec.rot[i], qd)
            elif kind == "rhoI":
                out[:, out_j] = 0.5 * np.einsum("ba,ac,bc->b", qd, spec.rot[i], qd)
            elif kind == "gx":
                out[:, out_j] = pos[:, i].real
            elif kind == "gy":
                out[:, out_j] = pos[:, i].imag
            elif kind == "f0":  # the Lagrangian holds f0 q (potential -f0 q)
                out[:, out_j] = q[:, spec.row_of[e]]
            else:  # stiffness: the Lagrangian holds -1/2 k q^2
                out[:, out_j] = -0.5 * q[:, spec.row_of[e]] ** 2
        return out

    @x_sequence_or_item
    def fit(self, x_full, y=None) -> "PhysicalPCSLibrary":
        """Validate the parameters and the state width ``2n`` of ``x = [q, qd]``.

        Parameters
        ----------
        x_full : array_like, shape (n_samples, 2n), or a list of them

        Returns
        -------
        self
        """
        spec = self._spec
        width = x_full[0].shape[-1]
        if width != 2 * spec.n:
            raise ValueError(f"x must have 2n = {2 * spec.n} columns [q, qd] of the active strains; got {width}")
        self.n_features_in_ = width
        self.n_output_features_ = spec.n_coef - spec.n
        return self

    @x_sequence_or_item
    def transform(self, x_full):
        """Lagrangian basis ``f_j(q, qd)`` of every non-damping parameter, ``L = sum coef_j f_j``.

        ``rhoA_i``: ``1/2 int |ṗ|^2 ds + int g.p ds`` over segment i (kinetic
        energy and minus the gravitational energy per unit line density);
        ``rhoI_i``: ``1/2 int θ̇^2 ds`` (with ``rotary_inertia="tied"`` added to
        the ``rhoA_i`` term times ``r_i^2/4``); ``rhoAgx_i``/``rhoAgy_i``: ``int x ds``,
        ``int y ds``; ``k_e``: ``-q_e^2 / 2``.

        Parameters
        ----------
        x_full : array_like, shape (n_samples, 2n), or a list of them

        Returns
        -------
        ndarray, shape (n_samples, n_output_features_)
        """
        check_is_fitted(self, "n_features_in_")
        spec = self._spec
        out = []
        for x in x_full:
            arr = np.asarray(x, dtype=float)
            if arr.ndim != 2 or arr.shape[-1] != self.n_features_in_:
                raise ValueError(f"x must have shape (n_samples, {self.n_features_in_}); got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError("x contains NaN or inf")
            n = spec.n
            res = np.empty((arr.shape[0], spec.n_coef - n))
            for a in range(0, arr.shape[0], _CHUNK):
                blk = arr[a : a + _CHUNK]
                res[a : a + _CHUNK] = self._energy_block(blk[:, :n], blk[:, n:])
            out.append(AxesArray(res, comprehend_axes(res)))
        return out

    def get_feature_names(self, input_features: Sequence[str] | None = None) -> list[str]:
        """Names of the Lagrangian basis terms (see :meth:`transform`)."""
        spec = self._spec
        names = spec.kin.strain_names(active_only=True)
        if input_features is not None:
            if len(input_features) != 2 * spec.n:
                raise ValueError(f"input_features must have {2 * spec.n} names; got {len(input_features)}")
            names = list(input_features[: spec.n])
        out = []
        for kind, i, e in spec.kinds:
            seg = i + 1
            if kind == "rhoA":
                out.append(f"T_A{seg}" if spec.identify_gravity else f"T_A{seg} + int g.p ds ({seg})")
            elif kind == "rhoI":
                out.append(f"T_I{seg}")
            elif kind == "gx":
                out.append(f"int x ds ({seg})")
            elif kind == "gy":
                out.append(f"int y ds ({seg})")
            elif kind == "k":
                out.append(f"-1/2 {names[spec.row_of[e]]}^2")
            elif kind == "f0":
                out.append(f"{names[spec.row_of[e]]}")
        return out
