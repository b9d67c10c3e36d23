"""Black-box baselines: what a PCS model must beat on the same recordings.

Fitted on the same data as a PCS model, they say how good a prediction is without any physics:

* :class:`LaggedPolynomialMap` - quasi-static: the outputs (e.g. the 3-D tip) as a polynomial (with cross
  terms) of the inputs passed through a first-order lag, its time constant chosen on the training data;
* :class:`ARX` - dynamic: ``y_k = sum_i A_i y_{k-i} + sum_j B_j u_{k-j} + c`` fitted one step ahead by
  least squares and predicted open loop (simulated on its own outputs);
* :class:`LinearLoadInterpolator` - static holds: the shape at a load linearly interpolated between the
  neighbouring measured loads (a Delaunay triangulation of the load space), linearly extrapolated outside;
* :class:`PolynomialLoadMap` - static holds: a polynomial (quadratic by default) in the loads.

Missing samples: an output row holding NaN (a marker the tracker lost) is skipped in fitting - in
:class:`ARX` every regression row that needs it (as target or as a lagged output) is skipped.  Inputs
must be finite (the baselines are driven by them; a NaN input is an error naming the row).  Nothing here
fills in missing data.
"""

from __future__ import annotations

from numbers import Integral
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import LinearNDInterpolator, make_interp_spline
from scipy.signal import lfilter
from sklearn.base import BaseEstimator
from sklearn.preprocessing import PolynomialFeatures
from sklearn.utils.validation import check_is_fitted

from ..core.validation import Check, Interval, Options, validate_parameters

__all__ = ["LaggedPolynomialMap", "ARX", "LinearLoadInterpolator", "PolynomialLoadMap", "first_order_lag"]


# ---------------------------------------------------------------------------- data checks
def _inputs(u: ArrayLike, name: str = "u") -> NDArray[np.float64]:
    a = np.asarray(u, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] < 1:
        raise ValueError(f"{name} must have shape (n_samples, n_inputs); got {np.shape(u)}")
    bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
    if bad.size:
        raise ValueError(
            f"{name} must be finite: the baselines are driven by the inputs; row {bad[0]} "
            f"({bad.size} rows in all) holds NaN or inf"
        )
    return a


def _outputs(y: ArrayLike, n_rows: int, name: str = "y") -> NDArray[np.float64]:
    a = np.asarray(y, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != n_rows:
        raise ValueError(f"{name} must have shape ({n_rows}, n_outputs), one row per input row; got {np.shape(y)}")
    if np.any(np.isinf(a)):
        raise ValueError(f"{name} holds inf; missing samples must be NaN")
    return a


def _dt(dt: Any) -> float:
    if isinstance(dt, (bool, np.bool_)) or not isinstance(dt, (int, float, np.integer, np.floating)):
        raise ValueError(f"dt must be a sample period > 0 [s]; got {dt!r}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a sample period > 0 [s]; got {dt!r}")
    return float(dt)


def _rms(residual: NDArray[np.float64]) -> float:
    """Root of the mean squared Euclidean norm of the residual rows."""
    return float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))


def first_order_lag(u: ArrayLike, dt: float, tau: float, initial: ArrayLike | None = None) -> NDArray[np.float64]:
    """First-order lag ``tau x' + x = u`` of inputs held over each sample (zero-order hold, exact).

    ``x[k] = a x[k-1] + (1 - a) u[k-1]`` with ``a = exp(-dt / tau)``; ``tau = 0`` is a one-sample delay
    (an input held over a sample acts at the next one).

    Parameters
    ----------
    u : array_like, shape (n_samples, n_inputs)
    dt : float
        Sample period [s].
    tau : float
        Time constant [s], >= 0.
    initial : array_like, shape (n_inputs,), optional
        ``x[0]``; default ``u[0]`` (at rest before the recording).

    Returns
    -------
    ndarray, shape (n_samples, n_inputs)
    """
    a_u = _inputs(u)
    if not (np.isfinite(tau) and tau >= 0):
        raise ValueError(f"tau must be a time constant >= 0 [s]; got {tau!r}")
    a = float(np.exp(-_dt(dt) / tau)) if tau > 0 else 0.0
    x0 = a_u[0] if initial is None else np.asarray(initial, dtype=float).reshape(a_u.shape[1])
    # lfilter's transposed direct form: x[0] = zi, then x[k] = a x[k-1] + (1 - a) u[k-1]
    out, _ = lfilter([0.0, 1.0 - a], [1.0, -a], a_u, axis=0, zi=x0[None, :])
    return out


def _lag_grid(lags: Any, dt: float) -> NDArray[np.float64]:
    if isinstance(lags, str):
        # from no lag, through the sampling (2 dt) to 200 samples: lags the data resolve
        return np.concatenate([[0.0], np.geomspace(2 * dt, 200 * dt, 25)])
    return np.atleast_1d(np.asarray(lags, dtype=float))


def _lags_ok(value: Any) -> bool:
    a = np.atleast_1d(np.asarray(value, dtype=float))
    return a.ndim == 1 and a.size >= 1 and bool(np.all(np.isfinite(a) & (a >= 0)))


# ---------------------------------------------------------------------------- lagged polynomial
class LaggedPolynomialMap(BaseEstimator):
    """Quasi-static baseline: outputs as a polynomial of first-order-lagged inputs, ``y = P(lag(u))``.

    Every input passes through the same first-order lag (:func:`first_order_lag`); the lagged inputs,
    standardised on the training data, enter a full polynomial of ``degree`` (cross terms included, a
    constant), fitted to the outputs by least squares.  The lag's time constant is the one of ``lags``
    with the least training RMS error.

    Parameters
    ----------
    degree : int, default 3
        Total degree of the polynomial.
    lags : "auto", float or array_like of float, default "auto"
        Candidate time constants [s] (>= 0).  ``"auto"``: 0 and 25 log-spaced values from 2 to 200
        sample periods.

    Attributes
    ----------
    lag_ : float
        The chosen time constant [s].
    lags_ : ndarray
        The candidates tried.
    lag_rmse_ : ndarray
        Training RMS error (Euclidean over the outputs) per candidate.
    coef_ : ndarray, shape (n_terms, n_outputs)
        Polynomial coefficients (of the standardised lagged inputs, in ``powers_`` order).
    powers_ : ndarray, shape (n_terms, n_inputs)
        Exponents of each term.
    input_mean_, input_scale_ : ndarray, shape (n_inputs,)
        Standardisation of the lagged inputs.
    dt_ : float
        Training sample period [s].
    n_features_in_ : int
        Number of inputs.
    n_outputs_ : int
    training_rmse_ : float
        RMS error on the valid training rows at ``lag_``.

    Notes
    -----
    Output rows holding NaN are skipped in the fit (the inputs, which must be finite, are still filtered
    through them).
    """

    _parameter_constraints: dict = {
        "degree": [Interval(Integral, 1, None, closed="left")],
        "lags": [Options(("auto",)), Check(_lags_ok, "one or more finite time constants >= 0 [s]")],
    }

    def __init__(self, degree: int = 3, lags: Any = "auto") -> None:
        self.degree = degree
        self.lags = lags

    def _design(self, lagged: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._poly.transform((lagged - self.input_mean_) / self.input_scale_)

    def fit(self, u: ArrayLike, y: ArrayLike, dt: float) -> LaggedPolynomialMap:
        """Fit the polynomial for each candidate lag and keep the best.

        Parameters
        ----------
        u : array_like, shape (n_samples, n_inputs)
            Inputs (finite).
        y : array_like, shape (n_samples, n_outputs) or (n_samples,)
            Outputs; NaN rows (missing samples) are skipped.
        dt : float
            Sample period [s].

        Returns
        -------
        self
        """
        validate_parameters(self)
        dt = _dt(dt)
        a_u = _inputs(u)
        a_y = _outputs(y, a_u.shape[0])
        ok = np.all(np.isfinite(a_y), axis=1)
        grid = _lag_grid(self.lags, dt)
        self._poly = PolynomialFeatures(self.degree, include_bias=True).fit(np.zeros((1, a_u.shape[1])))
        n_terms = self._poly.n_output_features_
        if ok.sum() < n_terms:
            raise ValueError(
                f"y has {int(ok.sum())} valid (non-NaN) rows, fewer than the {n_terms} terms of a degree-"
                f"{self.degree} polynomial of {a_u.shape[1]} inputs: record more samples or lower degree"
            )
        self.dt_ = dt
        self.n_features_in_, self.n_outputs_ = a_u.shape[1], a_y.shape[1]
        self.powers_ = self._poly.powers_
        scores, fits = [], []
        for tau in grid:
            lagged = first_order_lag(a_u, dt, tau)
            mean, scale = lagged[ok].mean(axis=0), lagged[ok].std(axis=0)
            self.input_mean_, self.input_scale_ = mean, np.where(scale > 0, scale, 1.0)
            X = self._design(lagged)[ok]
            coef, *_ = np.linalg.lstsq(X, a_y[ok], rcond=None)
            scores.append(_rms(X @ coef - a_y[ok]))
            fits.append((coef, self.input_mean_, self.input_scale_))
        best = int(np.argmin(scores))
        self.lags_, self.lag_rmse_ = grid, np.asarray(scores)
        self.lag_, self.training_rmse_ = float(grid[best]), float(scores[best])
        self.coef_, self.input_mean_, self.input_scale_ = fits[best]
        return self

    def predict(self, u: ArrayLike, dt: float | None = None, initial: ArrayLike | None = None) -> NDArray[np.float64]:
        """Outputs for the inputs ``u`` (open loop: no measured output is used).

        Parameters
        ----------
        u : array_like, shape (n_samples, n_inputs)
        dt : float, optional
            Sample period [s]; default the training one.
        initial : array_like, shape (n_inputs,), optional
            Lag state at the first sample; default ``u[0]`` (at rest).  To predict the continuation of a
            recording, predict the whole input record and keep the rows wanted.

        Returns
        -------
        ndarray, shape (n_samples, n_outputs)
        """
        check_is_fitted(self, "coef_")
        a_u = _inputs(u)
        if a_u.shape[1] != self.n_features_in_:
            raise ValueError(f"u must have {self.n_features_in_} input columns like the training u; got {a_u.shape[1]}")
        lagged = first_order_lag(a_u, self.dt_ if dt is None else _dt(dt), self.lag_, initial)
        return self._design(lagged) @ self.coef_


# ---------------------------------------------------------------------------- ARX
class ARX(BaseEstimator):
    """Linear ARX model ``y_k = sum_{i<=na} A_i y_{k-i} + sum_{j<=nb} B_j u_{k-j} + c``, multi-output.

    Fitted one step ahead by least squares; :meth:`predict` simulates it open loop, on its own past
    outputs, from ``max(na, nb)`` initial outputs.

    Parameters
    ----------
    na : int, default 2
        Output lags.
    nb : int, default 2
        Input lags (the input acts from the next sample on).

    Attributes
    ----------
    coef_ : ndarray, shape (na * n_outputs + nb * n_inputs + 1, n_outputs)
        Stacked coefficients, rows ``[y_{k-1}, ..., y_{k-na}, u_{k-1}, ..., u_{k-nb}, 1]``.
    ar_coef_ : ndarray, shape (na, n_outputs, n_outputs)
        ``A_i`` (``y_k = A_i @ y_{k-i} + ...``).
    input_coef_ : ndarray, shape (nb, n_outputs, n_inputs)
        ``B_j``.
    intercept_ : ndarray, shape (n_outputs,)
    spectral_radius_ : float
        Largest eigenvalue modulus of the autoregressive part (companion matrix): the open-loop
        rollout is bounded for bounded inputs when it is < 1.
    n_features_in_ : int
        Number of inputs.
    n_outputs_ : int
    n_rows_ : int
        Regression rows used (those with every needed output present).

    Notes
    -----
    A regression row ``k`` is skipped when ``y_k`` or any of ``y_{k-1} .. y_{k-na}`` is missing (NaN).
    """

    _parameter_constraints: dict = {
        "na": [Interval(Integral, 1, None, closed="left")],
        "nb": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(self, na: int = 2, nb: int = 2) -> None:
        self.na = na
        self.nb = nb

    @property
    def _start(self) -> int:
        return max(self.na, self.nb)

    def _regressors(self, y: NDArray, u: NDArray, k: NDArray) -> NDArray[np.float64]:
        cols = [y[k - i] for i in range(1, self.na + 1)] + [u[k - j] for j in range(1, self.nb + 1)]
        return np.concatenate([*cols, np.ones((k.size, 1))], axis=1)

    def fit(self, u: ArrayLike, y: ArrayLike) -> ARX:
        """Least-squares fit of the one-step-ahead prediction.

        Parameters
        ----------
        u : array_like, shape (n_samples, n_inputs)
            Inputs (finite).
        y : array_like, shape (n_samples, n_outputs) or (n_samples,)
            Outputs; NaN rows (missing samples) are skipped with every row that needs them.

        Returns
        -------
        self
        """
        validate_parameters(self)
        a_u = _inputs(u)
        a_y = _outputs(y, a_u.shape[0])
        ok = np.all(np.isfinite(a_y), axis=1)
        k = np.arange(self._start, a_u.shape[0])
        valid = ok[k].copy()
        for i in range(1, self.na + 1):
            valid &= ok[k - i]
        k = k[valid]
        n_y, n_u = a_y.shape[1], a_u.shape[1]
        n_coef = self.na * n_y + self.nb * n_u + 1
        if k.size < n_coef:
            raise ValueError(
                f"only {k.size} regression rows have all their outputs present (y without NaN at k, k-1, .., "
                f"k-{self.na}), fewer than the {n_coef} coefficients of ARX({self.na}, {self.nb}); record more samples"
            )
        coef, *_ = np.linalg.lstsq(self._regressors(a_y, a_u, k), a_y[k], rcond=None)
        self.coef_ = coef
        self.n_features_in_, self.n_outputs_, self.n_rows_ = n_u, n_y, int(k.size)
        self.ar_coef_ = np.stack([coef[i * n_y : (i + 1) * n_y].T for i in range(self.na)])
        off = self.na * n_y
        self.input_coef_ = np.stack([coef[off + j * n_u : off + (j + 1) * n_u].T for j in range(self.nb)])
        self.intercept_ = coef[-1].copy()
        companion = np.zeros((self.na * n_y, self.na * n_y))
        companion[:n_y] = np.concatenate(list(self.ar_coef_), axis=1)
        companion[n_y:, :-n_y] = np.eye((self.na - 1) * n_y)
        self.spectral_radius_ = float(np.max(np.abs(np.linalg.eigvals(companion))))
        return self

    def predict(self, u: ArrayLike, y_initial: ArrayLike) -> NDArray[np.float64]:
        """Open-loop simulation: each output from the model's own previous outputs.

        Parameters
        ----------
        u : array_like, shape (n_samples, n_inputs)
            Inputs (finite) from the first initial sample on.
        y_initial : array_like, shape (max(na, nb), n_outputs)
            The measured outputs of the first ``max(na, nb)`` samples (finite).

        Returns
        -------
        ndarray, shape (n_samples, n_outputs)
            ``y_initial`` followed by the simulated outputs.
        """
        check_is_fitted(self, "coef_")
        a_u = _inputs(u)
        if a_u.shape[1] != self.n_features_in_:
            raise ValueError(f"u must have {self.n_features_in_} input columns like the training u; got {a_u.shape[1]}")
        y0 = np.asarray(y_initial, dtype=float).reshape(-1, self.n_outputs_) if np.size(y_initial) else None
        if y0 is None or y0.shape[0] != self._start or not np.all(np.isfinite(y0)):
            raise ValueError(
                f"y_initial must be {self._start} finite rows of {self.n_outputs_} outputs (the first max(na, nb) "
                f"samples); got shape {np.shape(y_initial)}"
            )
        if a_u.shape[0] < self._start:
            raise ValueError(f"u must have at least {self._start} rows; got {a_u.shape[0]}")
        out = np.empty((a_u.shape[0], self.n_outputs_))
        out[: self._start] = y0
        coef = self.coef_
        for k in range(self._start, a_u.shape[0]):
            x = np.concatenate(
                [*(out[k - i] for i in range(1, self.na + 1)), *(a_u[k - j] for j in range(1, self.nb + 1)), [1.0]]
            )
            out[k] = x @ coef
        return out


# ---------------------------------------------------------------------------- static holds
def _loads_and_targets(loads: ArrayLike, targets: ArrayLike) -> tuple[NDArray, NDArray, tuple[int, ...]]:
    L = np.asarray(loads, dtype=float)
    if L.ndim == 1:
        L = L[:, None]
    if L.ndim != 2 or not np.all(np.isfinite(L)):
        raise ValueError(f"loads must be a finite array (n_holds, n_loads); got shape {np.shape(loads)}")
    Y = np.asarray(targets, dtype=float)
    if Y.shape[:1] != L.shape[:1]:
        raise ValueError(f"targets must have one entry per hold ({L.shape[0]}) like loads; got shape {Y.shape}")
    shape = Y.shape[1:]
    Y = Y.reshape(Y.shape[0], -1)
    ok = np.all(np.isfinite(Y), axis=1)
    return L[ok], Y[ok], shape


def _query(loads: ArrayLike, n_loads: int) -> NDArray[np.float64]:
    L = np.asarray(loads, dtype=float)
    L = L.reshape(1, -1) if L.ndim <= 1 and n_loads > 1 else L.reshape(-1, n_loads)
    if L.shape[1] != n_loads or not np.all(np.isfinite(L)):
        raise ValueError(f"loads must be finite with {n_loads} columns like the training loads; got {np.shape(loads)}")
    return L


class LinearLoadInterpolator(BaseEstimator):
    """Static-hold baseline: a shape linearly interpolated between the neighbouring measured loads.

    Inside the convex hull of the training loads: piecewise-linear interpolation on their Delaunay
    triangulation (:class:`scipy.interpolate.LinearNDInterpolator`; with one load, between the two
    neighbouring loads).  Outside: an affine map (a least-squares plane) fitted on the nearest training
    holds - the fewest nearest holds that determine it (``n_loads + 1`` unless they are degenerate,
    e.g. collinear, then the next nearest are added).

    Parameters
    ----------
    n_neighbors : "auto" or int, default "auto"
        Holds for the plane outside the hull; ``"auto"``: the fewest nearest that determine it.

    Attributes
    ----------
    loads_ : ndarray, shape (n_holds, n_loads)
        The training loads (holds with missing targets dropped).
    targets_ : ndarray, shape (n_holds, n_targets)
        The flattened training targets.
    target_shape_ : tuple
        Shape of one target (e.g. ``(n_markers, 3)``).
    n_features_in_ : int
        Number of loads.

    Notes
    -----
    Holds whose target holds NaN are skipped in fitting.  Loads must be distinct.
    """

    _parameter_constraints: dict = {
        "n_neighbors": [Options(("auto",)), Interval(Integral, 2, None, closed="left")],
    }

    def __init__(self, n_neighbors: Any = "auto") -> None:
        self.n_neighbors = n_neighbors

    def fit(self, loads: ArrayLike, targets: ArrayLike) -> LinearLoadInterpolator:
        """Store the holds and triangulate their loads.

        Parameters
        ----------
        loads : array_like, shape (n_holds, n_loads) or (n_holds,)
        targets : array_like, shape (n_holds, ...)
            One target (a shape: marker positions) per hold; holds with NaN are skipped.

        Returns
        -------
        self
        """
        validate_parameters(self)
        L, Y, shape = _loads_and_targets(loads, targets)
        d = L.shape[1]
        if L.shape[0] < d + 1:
            raise ValueError(f"need at least {d + 1} holds with complete targets for {d} loads; got {L.shape[0]}")
        if np.unique(L, axis=0).shape[0] != L.shape[0]:
            raise ValueError("loads must be distinct (average repeated holds first); got repeated load rows")
        if np.linalg.matrix_rank(L - L.mean(axis=0)) < d:
            raise ValueError(f"the training loads lie in a lower-dimensional set than their {d} columns")
        self.loads_, self.targets_, self.target_shape_, self.n_features_in_ = L, Y, shape, d
        if d == 1:
            order = np.argsort(L[:, 0])
            self._inside = make_interp_spline(L[order, 0], Y[order], k=1)
            self._range = (L[order[0], 0], L[order[-1], 0])
        else:
            self._inside = LinearNDInterpolator(L, Y)
        return self

    def _plane(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        L, Y, d = self.loads_, self.targets_, self.n_features_in_
        order = np.argsort(np.linalg.norm(L - x, axis=1), kind="stable")
        n = d + 1 if self.n_neighbors == "auto" else min(int(self.n_neighbors), L.shape[0])
        while True:
            A = np.concatenate([np.ones((n, 1)), L[order[:n]] - x], axis=1)
            if np.linalg.matrix_rank(A) == d + 1 or n == L.shape[0]:
                break
            n += 1
        coef, *_ = np.linalg.lstsq(A, Y[order[:n]], rcond=None)
        return coef[0]  # the plane's value at x (loads centred on x)

    def predict(self, loads: ArrayLike) -> NDArray[np.float64]:
        """Interpolated (or extrapolated) targets.

        Parameters
        ----------
        loads : array_like, shape (n_queries, n_loads) or (n_loads,)

        Returns
        -------
        ndarray, shape (n_queries, *target_shape_)
        """
        check_is_fitted(self, "targets_")
        Q = _query(loads, self.n_features_in_)
        if self.n_features_in_ == 1:
            lo, hi = self._range
            inside = (Q[:, 0] >= lo) & (Q[:, 0] <= hi)
            out = np.full((Q.shape[0], self.targets_.shape[1]), np.nan)
            if inside.any():
                out[inside] = self._inside(Q[inside, 0])
        else:
            out = np.asarray(self._inside(Q), dtype=float).reshape(Q.shape[0], -1)
        for i in np.flatnonzero(~np.all(np.isfinite(out), axis=1)):  # outside the hull
            out[i] = self._plane(Q[i])
        return out.reshape(Q.shape[0], *self.target_shape_)


class PolynomialLoadMap(BaseEstimator):
    """Static-hold baseline: each target coordinate as a polynomial (with cross terms) in the loads.

    Parameters
    ----------
    degree : int, default 2
        Total degree.

    Attributes
    ----------
    coef_ : ndarray, shape (n_terms, n_targets)
        Coefficients of ``PolynomialFeatures(degree)`` of the loads (with a constant).
    target_shape_ : tuple
    n_features_in_ : int

    Notes
    -----
    Holds whose target holds NaN are skipped in fitting.  With fewer holds than terms the
    least-squares solution of minimum norm is used.
    """

    _parameter_constraints: dict = {"degree": [Interval(Integral, 1, None, closed="left")]}

    def __init__(self, degree: int = 2) -> None:
        self.degree = degree

    def fit(self, loads: ArrayLike, targets: ArrayLike) -> PolynomialLoadMap:
        """Least-squares fit.

        Parameters
        ----------
        loads : array_like, shape (n_holds, n_loads) or (n_holds,)
        targets : array_like, shape (n_holds, ...)

        Returns
        -------
        self
        """
        validate_parameters(self)
        L, Y, shape = _loads_and_targets(loads, targets)
        if L.shape[0] < 1:
            raise ValueError("no hold with a complete target")
        self._poly = PolynomialFeatures(self.degree, include_bias=True).fit(L)
        self.coef_, *_ = np.linalg.lstsq(self._poly.transform(L), Y, rcond=None)
        self.target_shape_, self.n_features_in_ = shape, L.shape[1]
        return self

    def predict(self, loads: ArrayLike) -> NDArray[np.float64]:
        """Targets at the loads.

        Parameters
        ----------
        loads : array_like, shape (n_queries, n_loads) or (n_loads,)

        Returns
        -------
        ndarray, shape (n_queries, *target_shape_)
        """
        check_is_fitted(self, "coef_")
        Q = _query(loads, self.n_features_in_)
        return (self._poly.transform(Q) @ self.coef_).reshape(Q.shape[0], *self.target_shape_)
