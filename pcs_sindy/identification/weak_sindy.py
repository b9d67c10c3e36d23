"""The weak (window-integrated) Euler–Lagrange regression as a ``pysindy.SINDy``.

A plain ``pysindy.SINDy`` regresses ``x_dot = Theta(x) Xi``: a first-order model
with one coefficient row per state.  The PCS dynamics are second order and
linear in ONE vector of physical coefficients shared by every strain,

    tau = Psi(q, qd, qdd) @ coef,

so a Lagrangian library inside a plain ``SINDy`` fits nonsense (its
``correct_shape`` refuses it).  :class:`WeakEulerLagrangeSINDy` is the
``SINDy`` that fits this form the way video data allow:

* states ``x = q`` (the strains of the library's segmentation; rates come from
  ``differentiation_method``, Savitzky–Golay by default), forces passed the
  pysindy way as ``u``;
* the weak form of :mod:`pcs_sindy.identification.formulations`: window
  integrals ``int phi tau dt = int phi Psi dt @ coef`` with the bump test
  function, so no accelerations are needed and held forces integrate exactly;
* any pysindy ``optimizer`` (default ``STLSQ()``), fitted on unit-norm columns
  (:func:`pcs_sindy.identification.optimizers.fit_normalized`), or the
  package's :class:`~pcs_sindy.identification.optimizers.StiffnessThresholdOptimizer`;
* pysindy's read-outs: ``coefficients()`` (one row per strain equation),
  ``get_feature_names()`` / ``get_feature_names_out()``, ``equations()`` and ``print()``
  (``tau_<strain> = ...`` per strain), ``predict(x)`` (the forces), ``score`` and
  ``simulate(x0, t, u)`` with ``x0 = [q0, qd0]``, which returns a
  :class:`~pcs_sindy.core.StrainTrajectory` like every ``simulate`` of the package:
  ``np.asarray`` of it is pysindy's ``[q, qd]``.

The rows, the optimizer call and the rollout are those of
:class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor` (fitted
inside, ``regressor_``): the same settings give the same coefficients.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy import SINDy
from pysindy.optimizers import STLSQ, BaseOptimizer
from sklearn.metrics import r2_score
from sklearn.utils.validation import check_is_fitted

from ..core.trajectory import StrainTrajectory
from ..core.validation import InstanceOf, Interval, validate_parameters
from .library.base import LagrangianLibrary
from .optimizers import DefaultOptimizerParams
from .regressor import EulerLagrangeRegressor

__all__ = ["WeakEulerLagrangeSINDy"]


class WeakEulerLagrangeSINDy(DefaultOptimizerParams, SINDy):
    """``pysindy.SINDy`` of the weak Euler–Lagrange form: strains in, forces as ``u``, no accelerations.

    Parameters
    ----------
    feature_library : LagrangianLibrary
        A PCS library with its segmentation (``PhysicalPCSLibrary([0.1, 0.1])``,
        ``PCSLagrangianLibrary(...)``); the states are its modelled strains.
    optimizer : pysindy optimizer, optional
        Default ``pysindy.STLSQ()`` (its defaults: the columns are scaled to unit
        norm first, see :func:`~pcs_sindy.identification.optimizers.fit_normalized`);
        its parameters are searchable as ``optimizer__<name>`` without naming it.
    differentiation_method : callable, optional
        ``method(x, t)`` giving the strain rates (a pysindy differentiation
        object); default Savitzky–Golay (``window_length``, ``polyorder``).
    weak_window, weak_stride : int, optional
        Window length and step in samples (default: the regressor's).
    window_length, polyorder : int
        Savitzky–Golay rates (default 7, 3).

    Attributes
    ----------
    regressor_ : EulerLagrangeRegressor
        The fitted weak-form regression (rollouts, identifiability, physical parameters).
    n_features_in_ : int
        ``n`` strains (the states).
    n_control_features_ : int
        ``n`` forces.
    n_output_features_ : int
        Columns of ``Psi``.
    dt_ : float
        Median sample period of the first trajectory (the default ``t`` of :meth:`predict`).
    """

    _parameter_constraints: dict = {
        "feature_library": [InstanceOf(LagrangianLibrary, "a LagrangianLibrary (PhysicalPCSLibrary, ...)")],
        "optimizer": [None, InstanceOf(BaseOptimizer, "a pysindy optimizer (STLSQ, SR3, ...)")],
        "differentiation_method": "no_validation",
        "weak_window": [None, Interval(Integral, 2, None, closed="left")],
        "weak_stride": [None, Interval(Integral, 1, None, closed="left")],
        "window_length": [Interval(Integral, 3, None, closed="left")],
        "polyorder": [Interval(Integral, 2, None, closed="left")],
    }

    def __init__(
        self,
        feature_library: Any = None,
        optimizer: Any = None,
        differentiation_method: Any = None,
        weak_window: int | None = None,
        weak_stride: int | None = None,
        window_length: int = 7,
        polyorder: int = 3,
    ) -> None:
        self.feature_library = feature_library
        self.optimizer = optimizer
        self.differentiation_method = differentiation_method
        self.weak_window = weak_window
        self.weak_stride = weak_stride
        self.window_length = window_length
        self.polyorder = polyorder

    # ------------------------------------------------------------------ data
    def _strain_names(self) -> list[str]:
        return self.feature_library.kinematics.strain_names(active_only=True)

    def _full(self, arr: ArrayLike, name: str, k: int, n_rows: int | None = None) -> NDArray[np.float64]:
        """Strains or forces of the modelled strains (T, n) -> all strains (T, 3m)."""
        kin = self.feature_library.kinematics
        a = np.asarray(arr, dtype=float)
        if a.ndim == 1 and kin.n_active == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[1] != kin.n_active or (n_rows is not None and a.shape[0] != n_rows):
            rows = "T" if n_rows is None else str(n_rows)
            raise ValueError(
                f"{name}[{k}] must have shape ({rows}, {kin.n_active}): the {kin.n_active} modelled strains "
                f"{self._strain_names()} of the library's segmentation; got shape {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}[{k}] contains NaN or inf")
        out = np.zeros((a.shape[0], kin.n_q))
        out[:, kin.active_mask] = a
        return out

    def _recordings(self, x: Any, t: Any) -> list[StrainTrajectory]:
        kin = self.feature_library.kinematics
        xs = list(x) if isinstance(x, (list, tuple)) else [x]
        if not xs:
            raise ValueError("x must be a non-empty array (T, n) of strains or a list of them")
        if isinstance(t, (list, tuple)):
            ts = list(t)
        else:
            ts = [t] * len(xs)
        if len(ts) != len(xs):
            raise ValueError(f"t must give one time array per trajectory of x ({len(xs)}); got {len(ts)}")
        out = []
        for k, (xi, ti) in enumerate(zip(xs, ts, strict=True)):
            q = self._full(xi, "x", k)
            dt = float(ti) if np.ndim(ti) == 0 and ti is not None else None
            out.append(
                StrainTrajectory(
                    q,
                    None if dt is not None else ti,
                    dt=dt,
                    segment_lengths=kin.segment_lengths,
                    active_strains=kin.active_strains,
                )
            )
        return out

    def _forces(self, u: Any, X: list[StrainTrajectory]) -> list[NDArray[np.float64]]:
        if u is None:
            raise ValueError("u (the generalised forces of the modelled strains, (T, n) per trajectory) is required")
        us = list(u) if isinstance(u, (list, tuple)) else [u]
        if len(us) != len(X):
            raise ValueError(f"u must give one force array per trajectory of x ({len(X)}); got {len(us)}")
        return [self._full(ui, "u", k, rec.n_frames) for k, (ui, rec) in enumerate(zip(us, X, strict=True))]

    def _default_optimizer(self) -> STLSQ:
        return STLSQ()

    def _regressor(self) -> EulerLagrangeRegressor:
        return EulerLagrangeRegressor(
            feature_library=self.feature_library,
            formulation="weak",
            optimizer=self._default_optimizer() if self.optimizer is None else self.optimizer,
            differentiation_method=self.differentiation_method,
            window_length=self.window_length,
            polyorder=self.polyorder,
            weak_window=self.weak_window,
            weak_stride=self.weak_stride,
        )

    # ------------------------------------------------------------------ pysindy's methods
    def fit(
        self,
        x: Any,
        t: Any,
        x_dot: Any = None,
        u: Any = None,
        feature_names: Sequence[str] | None = None,
    ) -> WeakEulerLagrangeSINDy:
        """Fit the weak Euler–Lagrange form.

        Parameters
        ----------
        x : array_like, shape (T, n), or a list of them
            Strains of the library's ``n`` modelled strains (e.g. from video).
        t : array_like, shape (T,), float (the sample period), or a list of them
        x_dot : None
            Not used (the weak form needs no derivatives); must be None.
        u : array_like, shape (T, n), or a list of them
            Generalised forces on the modelled strains, held over each sample.
        feature_names : list of str, optional
            Names of the ``n`` strains (default the library's, e.g. ``be_1``).

        Returns
        -------
        self
        """
        validate_parameters(self)
        if x_dot is not None:
            raise ValueError(
                "x_dot must be None: the weak form integrates the forces u against a test function and needs no "
                "derivatives (pass the forces as u)"
            )
        X = self._recordings(x, t)
        taus = self._forces(u, X)
        names = self._strain_names()
        if feature_names is not None and len(feature_names) != len(names):
            raise ValueError(f"feature_names must name the {len(names)} strains {names}; got {list(feature_names)}")
        reg = self._regressor().fit(X, taus)
        self.regressor_ = reg
        self.feature_names = list(names if feature_names is None else feature_names)
        self.n_features_in_ = len(names)
        self.n_control_features_ = len(names)
        self.n_output_features_ = int(reg.coef_.size)
        self.dt_ = float(np.median(np.diff(X[0].t)))
        return self

    def coefficients(self) -> NDArray[np.float64]:
        """Coefficients per strain equation, shape (n, n_output_features_) (``EulerLagrangeRegressor.coefficients``).

        Row ``i`` holds the coefficients of the terms acting on strain ``i``'s equation (0
        elsewhere); the columns are the full library's (``regressor_.coef_``).
        """
        check_is_fitted(self, "regressor_")
        return self.regressor_.coefficients()

    def get_feature_names(self) -> list[str]:
        """Names of the columns of :meth:`coefficients`."""
        check_is_fitted(self, "regressor_")
        return self.regressor_.get_feature_names()

    def get_feature_names_out(self, input_features: Any = None) -> NDArray[np.object_]:
        """Names of the columns of :meth:`coefficients` (scikit-learn's spelling; ``input_features`` must be None)."""
        check_is_fitted(self, "regressor_")
        return self.regressor_.get_feature_names_out(input_features)

    def equations(self, precision: int = 3) -> list[str]:
        """Right-hand sides ``tau_<strain> = ...``, one per strain (see ``EulerLagrangeRegressor.strain_equations``)."""
        check_is_fitted(self, "regressor_")
        return self.regressor_.strain_equations(precision=precision)

    def print(self, lhs: Sequence[str] | None = None, precision: int = 3, **kwargs: Any) -> None:
        """Print ``tau_<strain> = ...`` per strain (``lhs``: other left-hand sides)."""
        eqs = self.equations(precision)
        names = [f"tau_{nm}" for nm in self.feature_names] if lhs is None else list(lhs)
        if len(names) != len(eqs):
            raise ValueError(f"lhs must have {len(eqs)} names (one per strain); got {len(names)}")
        for name, eq in zip(names, eqs, strict=True):
            print(f"{name} = {eq}", **kwargs)

    def predict(self, x: Any, u: Any = None, t: Any = None) -> Any:
        """Forces ``Psi(q, qd, qdd) @ coef`` on the strains ``x`` (inverse dynamics), shape (T, n) each.

        ``t`` (default: the sample period of the fit's first trajectory) gives
        the rates and accelerations by ``differentiation_method``.  ``u`` is ignored
        (the forces are what is predicted).
        """
        check_is_fitted(self, "regressor_")
        single = not isinstance(x, (list, tuple))
        xs = [x] if single else list(x)
        X = self._recordings(xs, self.dt_ if t is None else t)
        active = self.feature_library.kinematics.active_mask
        out = [p[:, active] for p in self.regressor_.predict(X)]
        return out[0] if single else out

    def score(self, x: Any, t: Any, x_dot: Any = None, u: Any = None, metric: Any = None, **metric_kws: Any) -> float:
        """``metric`` (default ``sklearn.metrics.r2_score``) of the predicted against the recorded forces ``u``.

        Trajectories stacked; ``t`` gives the rates and accelerations of the prediction.
        """
        check_is_fitted(self, "regressor_")
        xs = list(x) if isinstance(x, (list, tuple)) else [x]
        X = self._recordings(xs, t)
        taus = self._forces(u, X)
        active = self.feature_library.kinematics.active_mask
        pred = np.concatenate([p[:, active] for p in self.regressor_.predict(X)])
        truth = np.concatenate([tau[:, active] for tau in taus])
        return float((r2_score if metric is None else metric)(truth, pred, **metric_kws))

    def simulate(self, x0: ArrayLike, t: ArrayLike, u: Any = None, **simulate_kwargs: Any) -> StrainTrajectory:
        """Roll the model out from ``x0 = [q0, qd0]`` under the forces ``u``.

        ``u``: (T, n) forces held over each sample, or a callable ``u(time)``;
        other keywords go to ``EulerLagrangeRegressor.simulate`` (``method``,
        ``rtol``, ...).  Raises ``SimulationError`` when the rollout diverges.

        Returns
        -------
        StrainTrajectory
            Like every ``simulate`` of the package: strains ``q`` and rates ``qd`` (T, 3m) of all
            strains of the segmentation.  ``np.asarray`` of it is the state ``[q, qd]`` (T, 6m),
            pysindy's ``simulate`` result when the library models every strain (the default; the
            states ``x`` are ``sim.q[:, feature_library.kinematics.active_mask]`` otherwise).
        """
        check_is_fitted(self, "regressor_")
        kin = self.feature_library.kinematics
        if u is None:
            raise ValueError("u (the forces, (T, n) or a callable of time) is required: simulate(x0, t, u)")
        if not callable(u):
            u = self._full(u, "u", 0, np.size(t))
        else:
            fn = u

            def u(time: float) -> NDArray[np.float64]:
                full = np.zeros(kin.n_q)
                full[kin.active_mask] = np.asarray(fn(time), dtype=float).reshape(-1)
                return full

        x = np.asarray(x0, dtype=float)
        n = kin.n_active
        if x.shape != (2 * n,):
            raise ValueError(f"x0 must be [q0, qd0] of the {n} modelled strains, shape ({2 * n},); got {x.shape}")
        q0 = self._full(x[None, :n], "x0", 0)[0]
        qd0 = self._full(x[None, n:], "x0", 0)[0]
        return self.regressor_.simulate(q0, qd0, t, u, **simulate_kwargs)

    @property
    def complexity(self) -> int:
        """Number of nonzero coefficients."""
        check_is_fitted(self, "regressor_")
        return int(np.count_nonzero(self.regressor_.coef_))
