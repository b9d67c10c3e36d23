"""Least squares with strain sparsification by a stiffness threshold (seed §III-C3).

The Euler–Lagrange regression ``tau = Psi(q, qd, qdd) pi+`` is solved by least
squares on column-scaled data (SVD; never the normal equations).  The
identified stiffness of strain e is ``-2 *`` the coefficient of its ``q_e^2``
basis function (the Lagrangian holds ``-V``).  A strain whose stiffness exceeds
the material maximum ``K_max`` behaves rigidly: it is removed, the basis is
re-evaluated in the limit ``q_e, qd_e, qdd_e -> 0`` (seed eqs. 20-21) and the
fit is repeated until no strain is removed.

How the optimizer gets the re-evaluated basis
---------------------------------------------
The limit rule needs the basis evaluated again on the states, which a plain
``fit(Theta, y)`` does not carry.  pysindy's ``BaseOptimizer.fit`` forwards
extra keyword arguments to ``_reduce``; we use the same idea explicitly:
``fit(x, y, library=lib, states=(q, qd, qdd))``.  ``lib`` is the
:class:`~pcs_sindy.identification.library.pcs_lagrangian.PCSLagrangianLibrary` that produced ``x`` and the
states are the active strains it was evaluated on.  The optimizer asks
``lib.restrict(mask)`` for the limit-rule library of the remaining strains and
evaluates its ``euler_lagrange_matrix`` on the kept state columns.  Without
``library`` the optimizer is a plain scaled least-squares solver (usable inside
``pysindy.SINDy``), with no stiffness to threshold.

Identification side: never imports :mod:`pcs_sindy.simulation`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from numbers import Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.optimizers import BaseOptimizer
from sklearn.base import BaseEstimator
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils.validation import check_is_fitted, validate_data

from ..core.validation import Check, Interval, InvalidParameterError, Options, validate_parameters

__all__ = [
    "StiffnessThresholdOptimizer",
    "stiffness_bounds",
    "scaled_lstsq",
    "fit_normalized",
    "DefaultOptimizerParams",
]

from .least_squares import scaled_lstsq, stiffness_bounds  # noqa: E402 - re-exported: the optimizer's solvers

_STRAIN_LABELS = ("be", "sh", "ax")


def _positive_bounds(value: Any) -> bool:
    bounds = np.asarray(value, dtype=float).reshape(-1)
    return bounds.size > 0 and not np.any(np.isnan(bounds)) and bool(np.all(bounds > 0))


def _whole_at_least_one(value: Any) -> bool:
    return not isinstance(value, (bool, np.bool_)) and int(value) == value and value >= 1


def _is_switch(value: Any) -> bool:
    return isinstance(value, (bool, np.bool_))


class StiffnessThresholdOptimizer(BaseOptimizer):
    """Least squares + removal of strains stiffer than the material maximum.

    Parameters
    ----------
    youngs_modulus_max : float, default 100e6
        ``E_max`` (Pa) of the bending and axial bounds.
    shear_modulus_max : float, default 0.1e6
        ``G_max`` (Pa) of the shear bound.
    radius : float, default 0.02
        Cross-section radius (m) giving ``A = pi r^2`` and ``I = pi r^4 / 4``.
    shear_factor : float, default 4/3
        ``c_sh`` of the shear stiffness ``c_sh G A``.
    stiffness_scaling : {"seed", "length"}, default "seed"
        ``f_L = 1`` or ``f_L = L_i`` in ``K_max = f_L diag(...)``; must match
        the convention of the data (see docs/method.md).
    max_stiffness : array_like of shape (3m,), optional
        Explicit bounds per strain (full strain order); overrides the material
        parameters above.
    threshold : float, default 1.0
        Remove a strain whose identified stiffness exceeds ``threshold`` times
        its bound (``max_stiffness_``); ``np.inf`` fits all strains once.  Lower
        values treat softer strains as rigid (a hyperparameter to search over).
    rcond : float, default 1e-10
        Relative singular-value cut-off of the column-scaled design; a smaller
        singular value means rank deficiency and raises.
    bounded : bool, default True
        When the library declares ``lower_bounds_`` (``PhysicalPCSLibrary``:
        densities, stiffnesses and damping >= 0), solve the bounded least
        squares problem, which keeps the identified mass matrix positive
        definite and the model passive.
    max_iter : int, default 20
        Maximum number of fit-and-remove rounds.
    weight_equations : bool, default False
        With ``library``: in every round, fit once, then scale each strain equation's rows by the
        inverse root mean square of its residual and fit again (one step of feasible generalised
        least squares).  An equation whose strain carries more measurement noise than motion (a
        stiff shear or axial strain fitted from noisy markers) then weighs less in the coefficients
        it shares with the others (the line densities); measured on 3-D data with 0.5 mm marker
        noise (docs/results.md, "Spatial (3-D) PCS identification").
    normalize_columns : bool, default True
        Kept for pysindy compatibility: columns are always scaled to unit
        norm inside the solver and the coefficients (and hence the stiffness
        compared with ``K_max``) are returned in physical units either way.
    copy_X : bool, default True

    Attributes
    ----------
    coef_ : ndarray, shape (n_targets, n_features)
        Coefficients in the columns of the library passed to ``fit``; columns
        dropped by strain removal are 0.
    ind_ : ndarray of bool, same shape
        Non-zero coefficients.
    active_strains_ : ndarray of bool, shape (m, 3) (planar) or (m, 6) (spatial)
        Strains kept (only with ``library``).
    stiffness_ : ndarray, shape (3m,)
        Identified stiffness; ``inf`` for strains removed as rigid (and for
        strains the library never modelled).
    max_stiffness_ : ndarray, shape (3m,)
        The bounds used.
    removed_strains_ : list of str
        Names (``"sh_1"``, ...) of the removed strains, in removal order.
    library_ : the limit-rule library of the kept strains (``library`` itself
        if none was removed).
    column_map_ : ndarray of int
        Columns of the ``library`` passed to ``fit`` kept by ``library_``.
    history_ : list of dict
        One entry per round: ``active_strains`` (m, 3), ``coef`` (n_features,),
        ``stiffness`` (3m,), ``removed`` (names removed after this round),
        ``relative_residual``, ``condition_number``.
    n_rounds_ : int
    n_iter_ : int
        Rounds run (``n_rounds_``; sklearn's name).
    n_features_in_ : int
        Columns of ``x``.
    relative_residual_, condition_number_ : float
        Of the final round.

    Notes
    -----
    Without ``library`` this is a scikit-learn regressor without intercept
    (``predict(x) = x @ coef_.T``, 1-D for a 1-D ``y``) that passes
    ``sklearn.utils.estimator_checks`` except where the rank check applies
    (see ``tests/test_sklearn_compat.py``).
    """

    # pysindy's BaseOptimizer sets these in __init__; as class attributes they
    # keep sklearn's rule that __init__ stores the constructor arguments only
    fit_intercept = False
    positive = False
    unbias = False
    initial_guess = None

    def __init__(
        self,
        youngs_modulus_max: float = 100e6,
        shear_modulus_max: float = 0.1e6,
        radius: float = 0.02,
        shear_factor: float = 4.0 / 3.0,
        stiffness_scaling: str = "seed",
        max_stiffness: ArrayLike | None = None,
        threshold: float = 1.0,
        rcond: float = 1e-10,
        bounded: bool = True,
        max_iter: int = 20,
        normalize_columns: bool = True,
        copy_X: bool = True,
        weight_equations: bool = False,
    ) -> None:
        # not BaseOptimizer.__init__: it validates max_iter (sklearn validates in fit)
        # and sets non-parameter attributes
        self.max_iter = max_iter
        self.normalize_columns = normalize_columns
        self.copy_X = copy_X
        self.youngs_modulus_max = youngs_modulus_max
        self.shear_modulus_max = shear_modulus_max
        self.radius = radius
        self.shear_factor = shear_factor
        self.stiffness_scaling = stiffness_scaling
        self.max_stiffness = max_stiffness
        self.threshold = threshold
        self.rcond = rcond
        self.bounded = bounded
        self.weight_equations = weight_equations

    def set_params(self, **params: Any) -> StiffnessThresholdOptimizer:
        """Set parameters and return ``self`` (pysindy 2.1's returns None, which breaks GridSearchCV)."""
        BaseEstimator.set_params(self, **params)
        return self

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.sparse = False  # LinearRegression's tag; the SVD solver needs dense columns
        tags.target_tags.required = True
        return tags

    def predict(self, x: ArrayLike) -> NDArray[np.float64]:
        """``x @ coef_.T``: shape (n_rows,) after a fit on 1-D ``y``, else (n_rows, n_targets)."""
        check_is_fitted(self, "coef_")
        if isinstance(x, np.ndarray) and x.ndim == 3:  # stacked Psi (n_samples, n, n_features)
            x = x.reshape(-1, x.shape[-1])
        x = validate_data(self, x, reset=False, accept_sparse=False, dtype=float)
        out = x @ np.asarray(self.coef_).T
        return out.ravel() if self._single_target else out

    def _reduce(self, x: NDArray[np.float64], y: NDArray[np.float64], **kwargs: Any) -> None:
        # fit() is overridden and does all the work; kept for the abstract API.
        coef, _ = scaled_lstsq(x, y, rcond=self.rcond)
        self.coef_ = np.atleast_2d(coef.T)

    # ------------------------------------------------------------------
    #: read by validate_parameters in fit, and by model files
    _parameter_constraints: dict = {
        "youngs_modulus_max": [Interval(Real, 0, None, closed="neither")],
        "shear_modulus_max": [Interval(Real, 0, None, closed="neither")],
        "radius": [Interval(Real, 0, None, closed="neither")],
        "shear_factor": [Interval(Real, 0, None, closed="neither")],
        "stiffness_scaling": [Options(("seed", "length"))],
        "max_stiffness": [None, Check(_positive_bounds, "an array of numbers > 0 (3 per segment; inf: unbounded)")],
        "threshold": [
            Interval(Real, 0, None, closed="right"),
            Check(_is_switch, "a boolean (deprecated: use 1.0 or np.inf)"),
        ],
        "rcond": [Interval(Real, 0, 1, closed="neither")],
        "bounded": "no_validation",
        # integral floats (20.0) have always been accepted here
        "max_iter": [Check(_whole_at_least_one, "an integer >= 1")],
        "normalize_columns": "no_validation",
        "copy_X": "no_validation",
        "weight_equations": ["boolean"],
    }

    def _threshold(self) -> float:
        """The removal factor (validated); booleans (the former switch) are translated with a FutureWarning."""
        thr = self.threshold
        if isinstance(thr, (bool, np.bool_)):
            warnings.warn(
                f"threshold={thr!r} (a switch) is deprecated: threshold is the factor on the stiffness bound; "
                f"use threshold={'1.0' if thr else 'np.inf'}",
                FutureWarning,
                stacklevel=3,
            )
            return 1.0 if thr else np.inf
        return float(thr)

    def _bounds(self, library: Any) -> NDArray[np.float64]:
        kin = library.kinematics
        lengths = kin.segment_lengths
        per = kin.n_q // len(lengths)  # strains per segment: 3 planar, 6 spatial
        if self.max_stiffness is not None:
            bounds = np.asarray(self.max_stiffness, dtype=float).reshape(-1)  # values checked by the table
            if bounds.shape != (per * len(lengths),):
                want = f"{per * len(lengths)} values ({per} per segment of the library)"
                raise InvalidParameterError.of(self, "max_stiffness", want, self.max_stiffness)
            return bounds
        bound_fn = stiffness_bounds
        if per == 6:
            from .library.spatial_physical import spatial_stiffness_bounds as bound_fn
        return bound_fn(
            lengths,
            youngs_modulus_max=self.youngs_modulus_max,
            shear_modulus_max=self.shear_modulus_max,
            radius=self.radius,
            shear_factor=self.shear_factor,
            stiffness_scaling=self.stiffness_scaling,
        )

    def _weighted_refit(
        self,
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        coef: NDArray[np.float64],
        n_eq: int,
        names: Sequence[str] | None,
        lower: Any,
        equality: Any,
    ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Fit again with each equation's rows (sample-major, ``n_eq`` per sample) scaled by 1 / its RMS residual."""
        rms = np.sqrt(np.mean(((y - x @ coef).reshape(-1, n_eq)) ** 2, axis=0))
        if not np.all(rms > 0):  # an equation fitted exactly: nothing to weigh by (noise-free data)
            rms = np.where(rms > 0, rms, np.max(rms) if np.any(rms > 0) else 1.0)
        w = np.tile(1.0 / rms, y.size // n_eq)
        return scaled_lstsq(
            x * w[:, None], y * w, rcond=self.rcond, feature_names=names, lower_bounds=lower, equality=equality
        )

    def fit(
        self,
        x: ArrayLike,
        y: ArrayLike,
        sample_weight: ArrayLike | None = None,
        *,
        library: Any = None,
        states: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
        feature_names: Sequence[str] | None = None,
        design: Callable[[Any, NDArray[np.bool_]], ArrayLike] | None = None,
        equality: tuple[ArrayLike, float] | None = None,
    ) -> StiffnessThresholdOptimizer:
        """Fit, removing over-stiff strains when the library and states are given.

        Parameters
        ----------
        x : array_like, shape (n_rows, n_features)
            Regression matrix.  With ``library``: the Euler–Lagrange matrix
            ``Psi`` of shape (n_samples, n, n_features) or stacked sample-major
            to (n_samples * n, n_features).
        y : array_like, shape (n_rows,) or (n_rows, n_targets)
            Targets (the generalized forces, stacked like ``x``).
        sample_weight : array_like, shape (n_rows,), optional
            Row weights (plain least-squares mode only).
        library : PCSLagrangianLibrary, optional
            The library that produced ``x``; enables the stiffness threshold.
        states : tuple (q, qd, qdd), optional
            Active strains, rates and accelerations (n_samples, n) on which
            ``x`` was evaluated; required with ``library``.
        feature_names : sequence of str, optional
            Column names used in error messages.
        design : callable, optional
            ``design(restricted_library, keep)`` returns the regression matrix
            of a restricted library (rows stacked like ``x``, ``keep`` the kept
            strains among the library's active ones), replacing the evaluation
            of ``euler_lagrange_matrix`` on ``states`` after a removal; e.g.
            weak-form (window-integrated) rows.  ``x`` and ``y`` then hold
            ``n_rows * n`` rows ordered row-major like ``(n_rows, n)``.
        equality : tuple (a, b), optional
            With ``library``: a linear equality ``a @ coef = b`` over the
            library's columns, kept in every round (restricted to the kept
            columns), e.g. a known mass fixing the scale when gains are identified.

        Returns
        -------
        self
        """
        validate_parameters(self)
        factor = self._threshold()
        if library is None:
            if isinstance(x, np.ndarray) and x.ndim == 3:  # stacked Psi (n_samples, n, n_features)
                x = x.reshape(-1, x.shape[-1])
            if y is not None:
                try:
                    n_x, n_y = (np.shape(v)[0] if np.ndim(v) else None for v in (x, y))
                except (TypeError, ValueError):  # not array-like: validate_data names it below
                    n_x = n_y = None
                if n_x != n_y:
                    raise ValueError(f"y must have {n_x} rows like x; got {n_y}")
            # sklearn's validation: shapes, dtype, sparse / complex / empty input, n_features_in_
            x, y = validate_data(
                self, x, y, accept_sparse=False, dtype=float, multi_output=True, y_numeric=True, copy=bool(self.copy_X)
            )
            y = np.array(y, dtype=float, copy=True)
            if x.shape[0] < x.shape[1]:
                raise ValueError(
                    f"x has n_samples = {x.shape[0]} rows, fewer than its {x.shape[1]} features (unknowns); "
                    "the regression is underdetermined: record more samples"
                )
        else:
            x = np.array(x, dtype=float, copy=bool(self.copy_X))
            y = np.array(y, dtype=float, copy=True)
        if x.ndim == 3:
            x = x.reshape(-1, x.shape[-1])
        if x.ndim != 2:
            raise ValueError(f"x must have shape (n_rows, n_features) or (n_samples, n, n_features); got {x.shape}")
        self._single_target = y.ndim == 1 or library is not None
        if y.ndim == 2 and library is not None:
            y = y.reshape(-1)
        if y.ndim not in (1, 2) or y.shape[0] != x.shape[0]:
            raise ValueError(f"y must have {x.shape[0]} rows like x; got shape {y.shape}")
        for name, arr in (("x", x), ("y", y)):
            if not np.all(np.isfinite(arr)):
                n_bad = int(np.sum(~np.isfinite(arr)))
                raise ValueError(f"{name} contains {n_bad} NaN or inf value(s); clean the data before fitting")
        if feature_names is None and library is not None and hasattr(library, "euler_lagrange_names"):
            try:
                feature_names = list(library.euler_lagrange_names())
            except Exception:  # names are only cosmetic here
                feature_names = None
        self.n_iter_ = 0
        self.Theta_ = x
        self.n_features_in_ = int(x.shape[1])

        if library is None:
            if states is not None or design is not None or equality is not None:
                raise ValueError("states, design or equality were given without library; pass them with library")
            if sample_weight is not None:
                w = np.asarray(sample_weight, dtype=float)
                if w.shape != (x.shape[0],) or np.any(~np.isfinite(w)) or np.any(w < 0):
                    raise ValueError(f"sample_weight must be ({x.shape[0]},) finite and >= 0; got shape {w.shape}")
                if not np.any(w > 0):
                    raise ValueError("sample_weight is all zero: no sample is left to fit")
                sw = np.sqrt(w)
                x = x * sw[:, None]
                y = y * (sw if y.ndim == 1 else sw[:, None])
            coef, info = scaled_lstsq(x, y, rcond=self.rcond, feature_names=feature_names)
            self.coef_ = np.atleast_2d(coef.T)
            self.ind_ = self.coef_ != 0
            self.history_ = [{"coef": self.coef_.copy(), **info}]
            self.n_rounds_ = 1
            self.n_iter_ = 1
            self.relative_residual_ = info["relative_residual"]
            self.condition_number_ = info["condition_number"]
            self.intercept_ = 0.0
            return self

        if sample_weight is not None:
            raise ValueError(
                "sample_weight is not supported together with library (rows change when strains are removed)"
            )
        kin = library.kinematics
        m = kin.n_segments
        per = kin.n_q // m  # strains per segment: 3 planar, 6 spatial
        start_mask = np.asarray(kin.active_strains, dtype=bool).reshape(-1)
        n_act = int(start_mask.sum())
        n_samples = x.shape[0] // n_act if n_act else 0
        if design is None:
            if states is None or len(states) != 3:
                raise ValueError("states=(q, qd, qdd) of the active strains is required with library (or design=)")
            q, qd, qdd = (np.asarray(s, dtype=float) for s in states)
            for name, arr in (("q", q), ("qd", qd), ("qdd", qdd)):
                if arr.shape != (n_samples, n_act) or n_samples * n_act != x.shape[0]:
                    raise ValueError(
                        f"states[{name}] must have shape (n_samples, {n_act}) with n_samples * {n_act} = {x.shape[0]} "
                        "rows of x; "
                        f"got {arr.shape}"
                    )
                if not np.all(np.isfinite(arr)):
                    raise ValueError(f"states[{name}] contains NaN or inf")

            def design(lib_r: Any, keep: NDArray[np.bool_]) -> Any:
                return lib_r.euler_lagrange_matrix(q[:, keep], qd[:, keep], qdd[:, keep])

        elif not callable(design):
            raise ValueError(f"design must be a callable (library, keep) -> rows; got {type(design).__name__}")
        elif n_samples * n_act != x.shape[0]:
            raise ValueError(f"x must have a multiple of the {n_act} active strains as rows; got {x.shape[0]}")
        n_feat = x.shape[1]
        if n_feat != library.n_coefficients_:
            raise ValueError(f"x has {n_feat} columns but the library has {library.n_coefficients_} coefficients")
        tau = y.reshape(n_samples, n_act)
        bounds = self._bounds(library)
        names = kin.strain_names()

        mask = start_mask.copy()
        lib_r = library
        col_map = np.arange(n_feat)
        x_r, y_r = x, y
        history: list[dict[str, Any]] = []
        removed: list[str] = []
        converged = False
        for rnd in range(int(self.max_iter)):
            sub_names = None if feature_names is None else [feature_names[j] for j in col_map]
            lb = getattr(lib_r, "lower_bounds_", None) if self.bounded else None
            eq = None if equality is None else (np.asarray(equality[0], dtype=float)[col_map], float(equality[1]))
            coef_r, info = scaled_lstsq(
                x_r, y_r, rcond=self.rcond, feature_names=sub_names, lower_bounds=lb, equality=eq
            )
            if self.weight_equations:
                coef_r, info = self._weighted_refit(x_r, y_r, coef_r, int(mask.sum()), sub_names, lb, eq)
            stiff = np.full(per * m, np.inf)
            # a Lagrangian's q_e^2 term carries -k_e/2; a physical library's parameter is k_e itself
            stiff[mask] = float(lib_r.stiffness_factor_) * coef_r[np.asarray(lib_r.stiffness_index_)]
            coef_full = np.zeros(n_feat)
            coef_full[col_map] = coef_r
            exceed = mask & (stiff > factor * bounds) if np.isfinite(factor) else np.zeros_like(mask)
            new_removed = [names[e] for e in np.flatnonzero(exceed)]
            history.append(
                {
                    "active_strains": mask.reshape(m, per).copy(),
                    "coef": coef_full,
                    "stiffness": stiff.copy(),
                    "removed": new_removed,
                    **info,
                }
            )
            self.n_iter_ = rnd + 1
            fitted = (mask.copy(), lib_r, col_map)  # what the last fit used
            if not new_removed:
                converged = True
                break
            mask = mask & ~exceed
            removed.extend(new_removed)
            if not mask.any():
                raise ValueError(
                    f"every strain exceeded its maximum stiffness (removed {removed}); check max_stiffness / units"
                )
            lib_r = library.restrict(mask.reshape(m, per))
            col_map = np.asarray(lib_r.column_map_, dtype=int)
            keep = mask[start_mask]  # kept columns among the library's active strains
            x_r = np.asarray(design(lib_r, keep), dtype=float).reshape(-1, len(col_map))
            if x_r.shape[0] != n_samples * int(keep.sum()):
                raise ValueError(f"design returned {x_r.shape[0]} rows; expected {n_samples * int(keep.sum())}")
            y_r = tau[:, keep].reshape(-1)
        if not converged:
            warnings.warn(
                f"strain removal did not settle within max_iter = {self.max_iter} rounds; the last fit still had "
                f"strains above their bound: {history[-1]['removed']}",
                ConvergenceWarning,
                stacklevel=2,
            )
        final = history[-1]
        mask, lib_r, col_map = fitted
        self.coef_ = final["coef"][None, :]
        self.ind_ = self.coef_ != 0
        self.history_ = history
        self.n_rounds_ = len(history)
        self.active_strains_ = mask.reshape(m, per).copy()
        self.stiffness_ = final["stiffness"]
        self.max_stiffness_ = bounds
        # removals of a non-converged last round were never applied
        self.removed_strains_ = [name for h in history[:-1] for name in h["removed"]]
        self.library_ = lib_r
        self.column_map_ = col_map
        self.relative_residual_ = final["relative_residual"]
        self.condition_number_ = final["condition_number"]
        self.intercept_ = 0.0
        return self


def fit_normalized(optimizer: Any, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Fit a pysindy optimizer on unit-norm columns and a unit-RMS target; return unscaled coefficients.

    pysindy's ``normalize_columns`` idea, made independent of the robot's units:

    1. each equation (strain) is divided by the root mean square of its target,
       so that moments (N m) and forces (N) weigh alike;
    2. each column of the stacked regression is scaled to unit norm.

    A coefficient the optimizer returns is then the norm of its term's
    contribution over all rows, in units of the root mean square of one row of
    the target: ``STLSQ(threshold=0.1)`` removes a term whose whole
    contribution is smaller than a tenth of a typical row (below what the data
    can show), whatever the units of the physical parameters (kg/m next to
    N m²) or the robot's size.  The coefficients are mapped back to the
    physical columns afterwards; an all-zero column keeps coefficient 0.

    Parameters
    ----------
    optimizer : pysindy BaseOptimizer
        Fitted in place (pass a clone).
    x : array_like, shape (n_rows, n_equations, n_columns)
        Regression rows per equation (see :func:`pcs_sindy.identification.formulations.regression`).
    y : array_like, shape (n_rows, n_equations)
        Targets.

    Returns
    -------
    ndarray, shape (n_columns,)

    Raises
    ------
    ValueError
        When ``y`` is zero (nothing to fit) or the optimizer returns coefficients of
        another shape or with NaN.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.ndim != 3 or y.shape != x.shape[:2]:
        raise ValueError(
            f"x must have shape (n_rows, n_equations, n_columns) and y (n_rows, n_equations); "
            f"got shapes {x.shape} and {y.shape}"
        )
    rms = np.sqrt(np.mean(y**2, axis=0))
    if not np.any(rms > 0):
        raise ValueError("y is zero: the regression has nothing to fit")
    eq = np.where(rms > 0, rms, 1.0)  # an unforced equation keeps its units
    x2 = (x / eq[None, :, None]).reshape(-1, x.shape[-1])
    y2 = (y / eq).reshape(-1, 1)
    col = np.linalg.norm(x2, axis=0)
    safe = np.where(col > 0, col, 1.0)
    optimizer.fit(x2 / safe, y2)
    coef = np.asarray(optimizer.coef_, dtype=float).reshape(-1)
    if coef.shape != (x.shape[-1],) or not np.all(np.isfinite(coef)):
        raise ValueError(
            f"{type(optimizer).__name__} returned coefficients of shape {coef.shape} or with NaN; "
            f"expected ({x.shape[-1]},) finite values"
        )
    return np.where(col > 0, coef / safe, 0.0)


class DefaultOptimizerParams:
    """Mixin: an estimator whose ``optimizer=None`` means a default optimizer that can still be searched.

    ``get_params(deep=True)`` lists the default optimizer's parameters as ``optimizer__<name>`` and
    ``set_params(optimizer__<name>=...)`` creates that default (a new object per estimator) and sets
    them, so ``GridSearchCV(est, {"optimizer__threshold": [...]})`` works without naming the optimizer.
    The class says which optimizer ``None`` stands for by defining :meth:`_default_optimizer`.
    """

    def _default_optimizer(self) -> BaseEstimator:
        raise NotImplementedError

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        params = super().get_params(deep=deep)  # type: ignore[misc]
        if deep and getattr(self, "optimizer", None) is None:
            params.update({f"optimizer__{k}": v for k, v in self._default_optimizer().get_params().items()})
        return params

    def set_params(self, **params: Any) -> Any:
        nested = any(k.startswith("optimizer__") for k in params)
        if nested and params.get("optimizer", getattr(self, "optimizer", None)) is None:
            params = {**params, "optimizer": self._default_optimizer()}
        return super().set_params(**params)  # type: ignore[misc]
