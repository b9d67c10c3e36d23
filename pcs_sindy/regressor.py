"""Euler–Lagrange regression of a PCS model from strain trajectories and forces.

``EulerLagrangeRegressor().fit(strains, taus)`` differentiates the strains
(Savitzky–Golay by default), evaluates the Euler–Lagrange images of the PCS
Lagrangian basis (:class:`~pcs_sindy.library.PCSLagrangianLibrary`), and
solves ``tau = Psi pi+`` with :class:`~pcs_sindy.optimizers.StiffnessThresholdOptimizer`
(which removes over-stiff strains).  The fitted model predicts forces
(inverse dynamics), exposes ``M(q)``, bias and potential forces, and rolls out
(forward dynamics) with an explicit Dormand–Prince 5(4) scheme or, for stiff
models, the linearly implicit Rosenbrock-W scheme ROS34PW2 (``method="rosenbrock"``).

With actuation held piecewise constant (the seed's data), ``qdd`` jumps at
every change of the force and a Savitzky–Golay window straddling a jump
misestimates it; on the seed's one-segment data that bias costs 15-30 % on the
stiffness.  ``window_length=7, exclude_force_jumps=True`` removes most of it;
the weak form ``formulation="weak"`` (window integrals, no ``qdd``, held forces
integrated exactly) with ``basis="physical"`` (numeric physical parameters,
bounded least squares) removes it entirely and is the recommended setting:
``EulerLagrangeRegressor(basis="physical", formulation="weak", window_length=7)``;
see ``benchmarks/dynamic_identification.py`` and ``benchmarks/noise_robustness.py``.
After ``fit``, ``identifiability_`` / :meth:`EulerLagrangeRegressor.identifiability_report`
say which coefficients the recordings determined.

Identification side: never imports :mod:`pcs_sindy.simulation`.
"""

from __future__ import annotations

import time
import warnings
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import savgol_filter
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted

from .integrators import DivergenceError, integrate_zoh
from ._saving import PersistenceMixin
from .kinematics import PlanarPCS
from .optimizers import StiffnessThresholdOptimizer
from .trajectory import StrainTrajectory, as_strain_trajectories

__all__ = ["EulerLagrangeRegressor", "DivergenceError"]

# compiled rollouts: Gauss–Legendre nodes per segment while |kappa_i L_i| stays below the bound
_FAST_QUAD_NODES = 8
_FAST_QUAD_MAX_KL = 6.0


def _check_list(y: Any, n: int, name: str) -> list:
    if isinstance(y, np.ndarray) and y.ndim == 2 and n == 1:
        return [y]
    if not isinstance(y, (list, tuple)):
        raise ValueError(f"{name} must be a list with one array per recording; got {type(y).__name__}")
    if len(y) != n:
        raise ValueError(f"{name} must hold one array per recording of X ({n}); got {len(y)}")
    return list(y)


def _solve3(mass: NDArray[np.float64], rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    # Cramer's rule on Python floats: ~10x cheaper than np.linalg.solve for 3 x 3,
    # which dominates the per-stage cost of a rollout
    (a, b, c), (d, e, f), (g, h, i) = mass.tolist()
    r0, r1, r2 = rhs.tolist()
    c0 = e * i - f * h
    c1 = f * g - d * i
    c2 = d * h - e * g
    det = a * c0 + b * c1 + c * c2
    if det == 0.0 or det != det:
        raise np.linalg.LinAlgError(f"singular mass matrix (det = {det})")
    inv = 1.0 / det
    return np.array(
        [
            (c0 * r0 + (c * h - b * i) * r1 + (b * f - c * e) * r2) * inv,
            (c1 * r0 + (a * i - c * g) * r1 + (c * d - a * f) * r2) * inv,
            (c2 * r0 + (b * g - a * h) * r1 + (a * e - b * d) * r2) * inv,
        ]
    )


def _make_rhs(dyn: Callable, n: int) -> Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]:
    """State derivative ``[qd, M^-1 (tau - bias)]`` with minimal per-call overhead."""
    solve = _solve3 if n == 3 else np.linalg.solve
    out = np.empty(2 * n)

    def rhs(y: NDArray[np.float64], u_k: NDArray[np.float64]) -> NDArray[np.float64]:
        qdk = y[n:]
        mass, bias = dyn(y[:n], qdk)
        res = out.copy()
        res[:n] = qdk
        res[n:] = solve(mass, u_k - bias)
        return res

    return rhs


class EulerLagrangeRegressor(PersistenceMixin, RegressorMixin, BaseEstimator):
    """Identify ``M(q) qdd + C(q, qd) qd + G(q) + K q + D qd = tau`` by regression.

    Parameters
    ----------
    library : PCSLagrangianLibrary, PhysicalPCSLibrary or {"monomial", "physical"}, optional
        Library to use; default: one built in ``fit`` from the segmentation
        carried by the strain trajectories.  A given library must describe the
        same segmentation and active strains as the data.  A string names the
        ``basis`` of the default library.
    basis : {"monomial", "physical"}, default "monomial"
        Basis of the default library.  ``"monomial"``: the seed's symbolic
        :class:`~pcs_sindy.library.PCSLagrangianLibrary`, one coefficient per
        distinct basis function.  ``"physical"``: the numeric
        :class:`~pcs_sindy.library.PhysicalPCSLibrary`, one coefficient per
        physical unknown (line density, rotary inertia, stiffness and damping
        per segment; no symbolic derivation, any number of segments), fitted by
        bounded least squares so every density, stiffness and damping is
        ``>= 0`` (positive-definite mass matrix, passive model).  The symbolic
        lumped basis stays available as
        ``library=PCSLagrangianLibrary(lengths, basis="physical")``.  Ignored
        when ``library`` is a library object.
    optimizer : StiffnessThresholdOptimizer, optional
        Cloned in ``fit``; default ``StiffnessThresholdOptimizer()`` (the
        seed's bounds, ``f_L = 1``).
    differentiation_method : pysindy differentiation object, optional
        Called as ``method(x, t)``; used for ``qd`` from ``q`` and ``qdd`` from
        ``qd``.  Default: Savitzky–Golay (``window_length``, ``polyorder``).
    window_length : int, default 25
        Savitzky–Golay window (odd, samples).
    polyorder : int, default 3
        Savitzky–Golay polynomial order.
    exclude_force_jumps : bool, default False
        Leave out of the regression every sample whose Savitzky–Golay window
        contains a jump of the (piecewise-constant, held) actuation, and the
        ``window_length // 2`` samples at each end.  ``qdd`` jumps with the
        force, so a polynomial fit across a jump misestimates it; with the
        seed's data (forces held 10 ms, axial/shear time constants below 1 ms)
        this bias dominates.  Needs a window shorter than the hold (e.g. 5 or 7
        samples for 10 ms holds at 1 kHz); raises if no sample is left.  Only
        for held (step) actuation: smooth actuation changes every sample.
    cache_dir : str, optional
        Disk cache of the default library.
    check_mass_matrix : bool, default True
        After fit, evaluate ``M(q)`` on the training samples and warn if it is
        not positive definite on some of them.
    rtol, atol : float
        Tolerances of the adaptive rollout in :meth:`simulate`.
    progress : bool, default False
        Progress bars in ``simulate``.
    formulation : {"strong", "weak"}, default "strong"
        ``"strong"``: regress ``tau`` sample by sample on ``Psi(q, qd, qdd)``
        (needs ``qdd``).  ``"weak"``: regress the window integrals
        ``int phi tau dt = (int phi Psi dt) coef`` with the bump test function
        ``phi = (4x(1-x))^3`` over windows of ``weak_window`` sampling
        intervals; integration by parts removes ``qdd`` and moves the time
        derivative onto ``phi``, so only ``q`` and ``qd`` (Savitzky–Golay of
        ``window_length``, or given) enter, averaged over each window; the
        forces are integrated exactly as held (zero-order hold, see
        ``weak_hold``).  Needs a library with ``integrated_euler_lagrange_matrix``
        (``basis="physical"``).  ``exclude_force_jumps`` is not used (held
        forces integrate exactly across their jumps).  :meth:`predict` and
        :meth:`score` stay strong-form force predictions (they need ``qdd``).
        Use a short ``window_length`` (e.g. 7): ``qd`` has a kink at every
        force jump, which a long Savitzky–Golay window smooths away (measured
        on two_segment, noise-free, 7 s validation tip error: 0.024 mm with
        7, 0.26 mm with 15).
    weak_window : int, default 40
        Window length of the weak form in sampling intervals (>= 2); every
        recording needs more samples than this.
    weak_stride : int, default 20
        Step between consecutive weak-form windows in samples (>= 1).
        Overlapping windows (stride < window) reuse data; their residuals are
        correlated, which ``identifiability_`` (independent rows assumed)
        does not account for: its standard errors are then optimistic.
    weak_hold : {"zoh", "trapezoid"}, default "zoh"
        How ``tau`` is integrated in the weak form: held constant on
        ``[t_k, t_{k+1})`` (exact for the scenarios' and the seed's held
        actuation) or by the trapezoid rule (smooth actuation).
    gravity : sequence of float, shape (2,), default (0, 9.81)
        Known gravity in the base frame for ``basis="physical"`` (the monomial
        basis identifies gravity inside its coefficients).
    identify_gravity : bool, default False
        ``basis="physical"``: identify ``rho A g`` per segment (two free
        columns each) instead of using ``gravity``.
    rotary_inertia : {"free", "tied", "none"}, default "free"
        ``basis="physical"``: rotary inertia per segment identified
        (``"free"``), tied to the line density for a solid circular section of
        the optimizer's ``radius`` (``"tied"``; one mass unknown per segment,
        better conditioned under noise), or neglected.
    rest_strain : bool, default False
        ``basis="physical"``: identify a constant generalised force ``f0`` per
        strain (``... + K q - f0 = tau``, ``f0 = K q*`` for a rest strain
        ``q*``); also absorbs a wrong rest length.  Not available with the
        monomial basis; ignored when ``library`` is a library object (set
        ``PhysicalPCSLibrary(..., rest_strain=True)`` there).

    Attributes
    ----------
    coef_ : ndarray, shape (n_psi,)
        Coefficients in the columns of ``full_library_`` (Lagrangian terms,
        then one damping coefficient per strain); columns dropped by strain
        removal are exactly 0.
    model_coef_ : ndarray
        ``coef_[column_map_]``: coefficients of ``library_``.
    full_library_, library_ : PCSLagrangianLibrary
        The library of the data's strains and the limit-rule library of the
        kept strains (the same object when nothing was removed).
    column_map_ : ndarray of int
        Columns of ``full_library_`` kept in ``library_``.
    active_strains_ : ndarray of bool, shape (m, 3)
        Modelled strains after sparsification.
    stiffness_ : ndarray, shape (3m,)
        Identified stiffness: ``-2 *`` the ``q_e^2`` coefficient of a Lagrangian
        basis, the stiffness parameter itself for ``PhysicalPCSLibrary``; ``inf``
        for a strain that is not modelled (removed as rigid, or absent from the data).
    damping_ : ndarray, shape (3m,)
        Identified damping; ``0`` for strains that are not modelled.
    rest_strain_ : ndarray, shape (3m,)
        Identified rest strain ``f0 / stiffness`` (library with ``rest_strain``);
        ``0`` without ``f0`` columns and for strains that are not modelled
        (``inf`` for a strain of zero stiffness and nonzero ``f0``).
    removed_strains_ : list of str
        Strains removed by the stiffness threshold.
    optimizer_ : StiffnessThresholdOptimizer
        The fitted optimizer (``history_`` of the removal rounds).
    kinematics_ : PlanarPCS
        Segmentation with ``active_strains_``.
    mass_matrix_not_pd_fraction_ : float
        Fraction of training samples where the identified ``M(q)`` is not
        positive definite (reported as 0 when ``check_mass_matrix=False``).
    n_regression_samples_ : int
        Samples used in the regression (after ``exclude_force_jumps``); with
        ``formulation="weak"`` the number of windows.
    identifiability_ : dict or None
        What the data determined, from the final regression (strong rows or
        weak-form windows) of the kept strains:
        ``condition_number`` (column-scaled regression matrix), ``rank``,
        ``singular_values``, ``residual_std``, ``names`` (``model_coef_``
        names), ``standard_errors`` and ``relative_standard_errors`` of
        ``model_coef_`` (``s^2 (X^T X)^-1`` with the residual variance ``s^2``;
        ``inf`` for undetermined coefficients), ``poorly_determined`` (names
        with relative standard error above ``identifiability_tol``) and
        ``poorly_excited_strains`` (strains whose stiffness or damping is
        poorly determined: the recordings did not excite them enough).
        Coefficients held at a bound of the bounded fit are reported like the
        others.  None (with a warning) when the regression has no more rows
        than coefficients.  See :meth:`identifiability_report`.
    identifiability_tol : float
        (class attribute, 0.1) relative standard error above which a
        coefficient is reported as poorly determined.
    fit_time_ : float
        Wall time of ``fit`` (s).
    """

    def __init__(
        self,
        library: Any = None,
        basis: str = "monomial",
        optimizer: StiffnessThresholdOptimizer | None = None,
        differentiation_method: Any = None,
        window_length: int = 25,
        polyorder: int = 3,
        exclude_force_jumps: bool = False,
        cache_dir: str | None = None,
        check_mass_matrix: bool = True,
        rtol: float = 1e-6,
        atol: float = 1e-9,
        progress: bool = False,
        formulation: str = "strong",
        weak_window: int = 40,
        weak_stride: int = 20,
        weak_hold: str = "zoh",
        gravity: Sequence[float] = (0.0, 9.81),
        identify_gravity: bool = False,
        rotary_inertia: str = "free",
        rest_strain: bool = False,
    ) -> None:
        self.library = library
        self.basis = basis
        self.optimizer = optimizer
        self.differentiation_method = differentiation_method
        self.window_length = window_length
        self.polyorder = polyorder
        self.exclude_force_jumps = exclude_force_jumps
        self.cache_dir = cache_dir
        self.check_mass_matrix = check_mass_matrix
        self.rtol = rtol
        self.atol = atol
        self.progress = progress
        self.formulation = formulation
        self.weak_window = weak_window
        self.weak_stride = weak_stride
        self.weak_hold = weak_hold
        self.gravity = gravity
        self.identify_gravity = identify_gravity
        self.rotary_inertia = rotary_inertia
        self.rest_strain = rest_strain

    identifiability_tol = 0.1

    # ------------------------------------------------------------------
    # data handling
    # ------------------------------------------------------------------
    def _check_params(self) -> None:
        wl, po = self.window_length, self.polyorder
        if isinstance(wl, bool) or int(wl) != wl or wl < 3 or wl % 2 == 0:
            raise ValueError(f"window_length must be an odd integer >= 3; got {wl!r}")
        if isinstance(po, bool) or int(po) != po or po < 2 or po >= wl:
            raise ValueError(f"polyorder must be an integer with 2 <= polyorder < window_length; got {po!r}")
        if self.formulation not in ("strong", "weak"):
            raise ValueError(f"formulation must be 'strong' or 'weak'; got {self.formulation!r}")
        ww, ws = self.weak_window, self.weak_stride
        if isinstance(ww, bool) or not isinstance(ww, (int, np.integer)) or ww < 2:
            raise ValueError(f"weak_window must be an integer >= 2 (sampling intervals); got {ww!r}")
        if isinstance(ws, bool) or not isinstance(ws, (int, np.integer)) or ws < 1:
            raise ValueError(f"weak_stride must be an integer >= 1 (samples); got {ws!r}")
        if self.weak_hold not in ("zoh", "trapezoid"):
            raise ValueError(f"weak_hold must be 'zoh' or 'trapezoid'; got {self.weak_hold!r}")
        basis = self.library if isinstance(self.library, str) else self.basis
        if basis not in ("monomial", "physical"):
            name = "library" if isinstance(self.library, str) else "basis"
            raise ValueError(f"{name} must be 'monomial' or 'physical'; got {basis!r}")
        if not isinstance(self.rest_strain, (bool, np.bool_)):
            raise ValueError(f"rest_strain must be True or False; got {self.rest_strain!r}")
        if self.rest_strain and (self.library is None or isinstance(self.library, str)) and basis != "physical":
            raise ValueError(
                f"rest_strain=True needs the physical basis (basis='physical'); got basis {basis!r}, whose "
                "Lagrangian has no constant-force term"
            )

    def _derivatives(
        self, rec: StrainTrajectory, k: int, qd: ArrayLike | None, qdd: ArrayLike | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        q, t = rec.q, rec.t
        n_s = q.shape[0]
        if (qd is None) != (qdd is None):
            raise ValueError("give both qd and qdd (known derivatives) or neither")
        if qd is not None:
            out = []
            for name, arr in (("qd", qd), ("qdd", qdd)):
                arr = np.asarray(arr, dtype=float)
                if arr.shape != q.shape:
                    raise ValueError(f"{name}[{k}] must have the shape of X[{k}].q {q.shape}; got {arr.shape}")
                if not np.all(np.isfinite(arr)):
                    raise ValueError(f"{name}[{k}] contains NaN or inf")
                out.append(arr)
            return out[0], out[1]
        if self.differentiation_method is not None:
            rate = np.asarray(self.differentiation_method(q, t), dtype=float)
            acc = np.asarray(self.differentiation_method(rate, t), dtype=float)
            if rate.shape != q.shape or acc.shape != q.shape or not (np.all(np.isfinite(rate)) and np.all(np.isfinite(acc))):
                raise ValueError(
                    f"differentiation_method returned derivatives of shape {rate.shape}/{acc.shape} or with NaN for X[{k}] "
                    f"(q has shape {q.shape}); NaN edges are not accepted"
                )
            return rate, acc
        wl = int(self.window_length)
        if n_s < wl:
            raise ValueError(
                f"X[{k}] has {n_s} samples, fewer than the Savitzky-Golay window_length = {wl}; "
                "use longer recordings or a shorter window"
            )
        dts = np.diff(t)
        dt = float(np.median(dts))
        if np.max(np.abs(dts - dt)) > 1e-6 * dt:
            raise ValueError(
                f"X[{k}] is not uniformly sampled (sample periods from {dts.min():.6g} to {dts.max():.6g} s); "
                "Savitzky-Golay needs a constant period: resample or pass differentiation_method"
            )
        po = int(self.polyorder)
        rate = savgol_filter(q, wl, po, deriv=1, delta=dt, axis=0)
        acc = savgol_filter(q, wl, po, deriv=2, delta=dt, axis=0)
        return rate, acc

    def _prepare(
        self, X: Any, y: Any | None, qd: Any | None, qdd: Any | None, *, kin: PlanarPCS | None = None
    ) -> tuple[PlanarPCS, list[tuple[NDArray, NDArray, NDArray, NDArray | None]]]:
        X = as_strain_trajectories(X)
        if kin is None:
            kin = X[0].kinematics
        for k, rec in enumerate(X):
            rk = rec.kinematics
            if not np.allclose(rk.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0):
                raise ValueError(
                    f"X[{k}] has segment_lengths {list(rk.segment_lengths)}, expected {list(kin.segment_lengths)}; "
                    "every recording must share one segmentation"
                )
        n_full = kin.n_q
        ys = None if y is None else _check_list(y, len(X), "y")
        qds = None if qd is None else _check_list(qd, len(X), "qd")
        qdds = None if qdd is None else _check_list(qdd, len(X), "qdd")
        out = []
        for k, rec in enumerate(X):
            tau = None
            if ys is not None:
                tau = np.asarray(ys[k], dtype=float)
                if tau.ndim != 2 or tau.shape[1] != n_full:
                    raise ValueError(f"y[{k}] must have shape (T, {n_full}) (one force per strain); got {tau.shape}")
                if tau.shape[0] != rec.n_frames:
                    raise ValueError(f"y[{k}] has {tau.shape[0]} samples but X[{k}] has {rec.n_frames}")
                if not np.all(np.isfinite(tau)):
                    raise ValueError(f"y[{k}] contains NaN or inf (first at sample {np.argwhere(~np.isfinite(tau))[0][0]})")
            rate, acc = self._derivatives(rec, k, None if qds is None else qds[k], None if qdds is None else qdds[k])
            out.append((rec.q, rate, acc, tau))
        return kin, out

    @staticmethod
    def _jump_free(tau: NDArray[np.float64], window: int) -> NDArray[np.bool_]:
        """Samples whose centred window holds no change of the held actuation."""
        n_s = tau.shape[0]
        half = int(window) // 2
        # change[j]: the force differs between samples j - 1 and j
        change = np.r_[False, np.any(np.diff(tau, axis=0) != 0, axis=1)]
        # a window k - half .. k + half contains a jump if change[j] for k - half < j <= k + half
        csum = np.r_[0, np.cumsum(change)]
        k = np.arange(n_s)
        lo = np.clip(k - half + 1, 0, n_s)
        hi = np.clip(k + half + 1, 0, n_s)
        keep = (csum[hi] - csum[lo]) == 0
        keep[:half] = False
        keep[n_s - half :] = False
        return keep

    def _make_library(self, kin: PlanarPCS) -> Any:
        """The library of ``fit``: the given object (checked against the data) or a default one."""
        if self.library is None or isinstance(self.library, str):
            basis = self.basis if self.library is None else self.library
            if basis == "physical":
                from .library import PhysicalPCSLibrary

                radius = getattr(self.optimizer, "radius", 0.02)
                return PhysicalPCSLibrary(
                    kin.segment_lengths,
                    active_strains=kin.active_strains,
                    radius=radius,
                    gravity=self.gravity,
                    identify_gravity=self.identify_gravity,
                    rotary_inertia=self.rotary_inertia,
                    rest_strain=bool(self.rest_strain),
                )
            from .library import PCSLagrangianLibrary

            return PCSLagrangianLibrary(
                kin.segment_lengths, active_strains=kin.active_strains, basis=basis, cache_dir=self.cache_dir
            )
        lib = self.library
        lk = lib.kinematics
        if not (
            np.allclose(lk.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0)
            and np.array_equal(lk.active_strains, kin.active_strains)
        ):
            raise ValueError(
                f"library describes segments {list(lk.segment_lengths)} with active strains "
                f"{lk.active_strains.astype(int).tolist()}, the data {list(kin.segment_lengths)} with "
                f"{kin.active_strains.astype(int).tolist()}"
            )
        return lib

    def _weak_windows(self, n_samples: int, k: int) -> NDArray[np.intp]:
        """Weak-form windows ``(start, stop)`` of recording ``k``."""
        from .library.physical import sliding_windows

        width, stride = int(self.weak_window), int(self.weak_stride)
        if n_samples <= width:
            raise ValueError(
                f"X[{k}] has {n_samples} samples, too few for weak_window = {width} sampling intervals "
                f"(needs at least {width + 1}); use a shorter weak_window"
            )
        return sliding_windows(n_samples, width, stride)

    def _identifiability(
        self, design: Callable, psi: NDArray[np.float64], target: NDArray[np.float64], mask: NDArray[np.bool_]
    ) -> dict | None:
        """:func:`~pcs_sindy.library.physical.identifiability` of the final regression (None if too few rows)."""
        from .library.physical import identifiability

        final = self.active_strains_.reshape(-1)
        kept = final[mask]
        # the first round's matrix is the final one unless a strain was removed
        x = psi if np.all(kept) else np.asarray(design(self.library_, kept), dtype=float)
        x = x.reshape(-1, x.shape[-1])
        y = np.asarray(target, dtype=float)[:, kept].reshape(-1)
        try:
            names = list(self.library_.euler_lagrange_names())
        except AttributeError:
            names = [f"c{j}" for j in range(x.shape[1])]
        if x.shape[0] <= x.shape[1]:
            warnings.warn(
                f"the final regression has {x.shape[0]} rows for {x.shape[1]} coefficients: too few to estimate "
                "standard errors (identifiability_ is None); record more data",
                UserWarning,
                stacklevel=3,
            )
            return None
        info = identifiability(x, y, self.model_coef_, names, tol=self.identifiability_tol)
        rel = info["relative_standard_errors"]
        bad = ~(rel <= self.identifiability_tol)
        strains = self.kinematics_.strain_names(active_only=True)
        cols = np.stack([np.asarray(self.library_.stiffness_index_), np.asarray(self.library_.damping_index_)], axis=1)
        info["poorly_excited_strains"] = [nm for nm, c in zip(strains, cols) if np.any(bad[c])]
        info["coef"] = self.model_coef_.copy()
        info["formulation"] = self.formulation
        return info

    def identifiability_report(self) -> str:
        """Readable summary of :attr:`identifiability_`: one line per coefficient, then the flags."""
        check_is_fitted(self, "identifiability_")
        info = self.identifiability_
        if info is None:
            return "identifiability not available: the regression had no more rows than coefficients"
        tol = self.identifiability_tol
        lines = [
            f"{info['formulation']}-form regression: condition number {info['condition_number']:.3g} "
            f"(column-scaled), rank {info['rank']} of {len(info['names'])}, residual std {info['residual_std']:.3g}",
            f"{'coefficient':<14} {'value':>12} {'std error':>12} {'rel. error':>11}",
        ]
        for nm, c, se, rel in zip(info["names"], info["coef"], info["standard_errors"], info["relative_standard_errors"]):
            flag = "" if rel <= tol else "  <- poorly determined"
            lines.append(f"{nm:<14} {c:>12.4g} {se:>12.3g} {rel:>11.2%}{flag}")
        lines.append(
            f"poorly determined (rel. error > {tol:.0%}): " + (", ".join(info["poorly_determined"]) or "none")
        )
        excited = info["poorly_excited_strains"]
        lines.append(
            "strains the data did not excite enough (stiffness or damping poorly determined): "
            + (", ".join(excited) if excited else "none")
        )
        return "\n".join(lines)

    # ------------------------------------------------------------------
    def fit(
        self,
        X: Sequence[StrainTrajectory],
        y: Sequence[ArrayLike],
        *,
        qd: Sequence[ArrayLike] | None = None,
        qdd: Sequence[ArrayLike] | None = None,
    ) -> "EulerLagrangeRegressor":
        """Identify the model.

        Parameters
        ----------
        X : list of StrainTrajectory
            Recordings (time stamps, full strains ``q`` (T, 3m), segmentation).
        y : list of array_like, shape (T, 3m)
            Generalized forces of each recording (held constant per sample).
        qd, qdd : list of array_like, optional
            Known strain rates and accelerations (e.g. from a simulator)
            instead of differentiating ``q``.

        Returns
        -------
        self
        """
        start = time.perf_counter()
        self._check_params()
        kin, data = self._prepare(X, y, qd, qdd)
        mask = kin.active_mask
        if not mask.any():
            raise ValueError("the data model no strain (active_strains all False)")
        weak = self.formulation == "weak"
        if weak:
            times = [rec.t for rec in as_strain_trajectories(X)]
            windows = [self._weak_windows(d[0].shape[0], k) for k, d in enumerate(data)]
            keep = [np.ones(d[0].shape[0], dtype=bool) for d in data]
        elif self.exclude_force_jumps:
            keep = [self._jump_free(d[3], self.window_length) for d in data]
            if not any(k.any() for k in keep):
                raise ValueError(
                    f"exclude_force_jumps left no sample: every window of {self.window_length} samples contains a jump "
                    "of the actuation; use a window shorter than the actuation hold (or smooth actuation without "
                    "exclude_force_jumps)"
                )
        else:
            keep = [np.ones(d[0].shape[0], dtype=bool) for d in data]
        q = np.concatenate([d[0][k][:, mask] for d, k in zip(data, keep)])
        rate = np.concatenate([d[1][k][:, mask] for d, k in zip(data, keep)])
        acc = np.concatenate([d[2][k][:, mask] for d, k in zip(data, keep)])
        tau = np.concatenate([d[3][k][:, mask] for d, k in zip(data, keep)])
        self.n_regression_samples_ = int(q.shape[0])

        lib = self._make_library(kin)
        if weak and not hasattr(lib, "integrated_euler_lagrange_matrix"):
            raise ValueError(
                f"formulation='weak' needs a library with integrated_euler_lagrange_matrix (PhysicalPCSLibrary, "
                f"basis='physical'); got {type(lib).__name__}"
                + (f"(basis={lib.basis!r})" if hasattr(lib, "basis") else "")
            )
        lib.fit(np.hstack([q, rate]))
        opt = StiffnessThresholdOptimizer() if self.optimizer is None else clone(self.optimizer)
        if weak:
            from .library.physical import integrate_forces

            def design(lib_r: Any, kept: NDArray[np.bool_]) -> NDArray[np.float64]:
                # kept: strains of lib_r among the data's active strains
                return np.concatenate(
                    [
                        lib_r.integrated_euler_lagrange_matrix(
                            tk, d[0][:, mask][:, kept], d[1][:, mask][:, kept], wk, test_function="bump"
                        )
                        for tk, d, wk in zip(times, data, windows)
                    ]
                )

            target = np.concatenate(
                [
                    integrate_forces(tk, d[3][:, mask], wk, hold=self.weak_hold, test_function="bump")
                    for tk, d, wk in zip(times, data, windows)
                ]
            )
            psi = design(lib, np.ones(int(mask.sum()), dtype=bool))
            self.n_regression_samples_ = int(psi.shape[0])
            opt.fit(psi, target, library=lib, design=design)
        else:

            def design(lib_r: Any, kept: NDArray[np.bool_]) -> NDArray[np.float64]:
                return lib_r.euler_lagrange_matrix(q[:, kept], rate[:, kept], acc[:, kept])

            target = tau
            psi = np.asarray(design(lib, np.ones(int(mask.sum()), dtype=bool)), dtype=float)
            opt.fit(psi, tau, library=lib, states=(q, rate, acc))

        self.optimizer_ = opt
        self.full_library_ = lib
        self.library_ = opt.library_
        self.column_map_ = np.asarray(opt.column_map_)
        self.coef_ = np.asarray(opt.coef_[0], dtype=float)
        self.model_coef_ = self.coef_[self.column_map_]
        self.active_strains_ = opt.active_strains_
        self.removed_strains_ = list(opt.removed_strains_)
        self.stiffness_ = np.asarray(opt.stiffness_, dtype=float)
        final_mask = self.active_strains_.reshape(-1)
        damping = np.zeros(kin.n_q)
        damping[final_mask] = self.model_coef_[np.asarray(self.library_.damping_index_)]
        self.damping_ = damping
        rest = np.zeros(kin.n_q)
        if hasattr(self.library_, "rest_force_from_coef"):
            f0 = self.library_.rest_force_from_coef(self.model_coef_)
            stiff = self.stiffness_[final_mask]
            # f0 = K q*; a zero stiffness with a nonzero f0 has no finite rest strain
            with np.errstate(divide="ignore", invalid="ignore"):
                rest[final_mask] = np.where(f0 == 0.0, 0.0, f0 / stiff)
        self.rest_strain_ = rest
        self.kinematics_ = PlanarPCS(kin.segment_lengths, self.active_strains_, kin.base_pose)
        self.n_features_in_ = kin.n_q
        self.identifiability_ = self._identifiability(
            design, np.asarray(psi, dtype=float), np.asarray(target).reshape(-1, int(mask.sum())), mask
        )
        self.mass_matrix_not_pd_fraction_ = 0.0
        if self.check_mass_matrix:
            q_fin = np.concatenate([d[0] for d in data])[:, final_mask]
            eig = np.linalg.eigvalsh(self.library_.mass_matrix(q_fin, self.model_coef_))
            bad = ~(eig[:, 0] > 0)
            frac = float(np.mean(bad))
            self.mass_matrix_not_pd_fraction_ = frac
            if frac > 0:
                warnings.warn(
                    f"the identified mass matrix is not positive definite on {frac:.1%} of the training samples "
                    f"(smallest eigenvalue {eig[:, 0].min():.3g}); a rollout will likely diverge: use more or "
                    "cleaner data, or basis='physical' (bounded: positive definite by construction) with "
                    "formulation='weak' (no second derivatives)",
                    UserWarning,
                    stacklevel=2,
                )
        self.fit_time_ = time.perf_counter() - start
        return self

    # ------------------------------------------------------------------
    # model evaluation
    # ------------------------------------------------------------------
    def _model_q(self, q: ArrayLike, name: str = "q") -> NDArray[np.float64]:
        """Modelled strains from full (..., 3m) or already reduced (..., n_active) input."""
        check_is_fitted(self, "coef_")
        q = np.asarray(q, dtype=float)
        mask = self.active_strains_.reshape(-1)
        if q.ndim == 0 or q.shape[-1] not in (mask.size, int(mask.sum())):
            raise ValueError(
                f"{name} must have a last axis of {mask.size} (all strains) or {int(mask.sum())} (modelled strains); "
                f"got shape {q.shape}"
            )
        if not np.all(np.isfinite(q)):
            raise ValueError(f"{name} contains NaN or inf")
        return q[..., mask] if q.shape[-1] == mask.size else q

    @staticmethod
    def _batch(fn: Callable, *arrays: NDArray[np.float64]) -> NDArray[np.float64]:
        lead = arrays[0].shape[:-1]
        flat = [a.reshape(-1, a.shape[-1]) for a in arrays]
        out = np.asarray(fn(*flat), dtype=float)
        return out.reshape(lead + out.shape[1:])

    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """Identified ``M(q)`` over the modelled strains, shape (..., n, n).

        ``q`` holds all 3m strains (unmodelled ones are ignored) or only the
        n modelled ones.
        """
        qa = self._model_q(q)
        return self._batch(lambda a: self.library_.mass_matrix(a, self.model_coef_), qa)

    def bias_forces(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """``C(q, qd) qd + G(q) + K q + D qd`` of the identified model, shape (..., n)."""
        qa, qda = self._model_q(q), self._model_q(qd, "qd")
        if qa.shape != qda.shape:
            raise ValueError(f"q and qd must have the same shape; got {qa.shape} and {qda.shape}")
        return self._batch(lambda a, b: self.library_.bias_forces(a, b, self.model_coef_), qa, qda)

    def potential_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """``G(q) + K q`` of the identified model, shape (..., n)."""
        qa = self._model_q(q)
        return self._batch(lambda a: self.library_.potential_forces(a, self.model_coef_), qa)

    def predict(
        self,
        X: Sequence[StrainTrajectory],
        *,
        qd: Sequence[ArrayLike] | None = None,
        qdd: Sequence[ArrayLike] | None = None,
    ) -> list[NDArray[np.float64]]:
        """Forces ``tau_hat = Psi(q, qd, qdd) pi+`` (inverse dynamics) per recording.

        Returns
        -------
        list of ndarray, shape (T, 3m)
            Forces on the modelled strains; 0 in the columns of strains that
            are not modelled (the model has no equation for a rigid strain).
        """
        check_is_fitted(self, "coef_")
        self._check_params()
        _, data = self._prepare(X, None, qd, qdd, kin=self.kinematics_)
        mask = self.active_strains_.reshape(-1)
        out = []
        for k, (q, rate, acc, _) in enumerate(data):
            psi = np.asarray(self.library_.euler_lagrange_matrix(q[:, mask], rate[:, mask], acc[:, mask]), dtype=float)
            tau = np.zeros_like(q)
            tau[:, mask] = psi @ self.model_coef_
            if not np.all(np.isfinite(tau)):
                raise ValueError(f"the model predicts NaN or inf forces on X[{k}]")
            out.append(tau)
        return out

    def score(
        self,
        X: Sequence[StrainTrajectory],
        y: Sequence[ArrayLike],
        sample_weight: None = None,
        *,
        qd: Sequence[ArrayLike] | None = None,
        qdd: Sequence[ArrayLike] | None = None,
    ) -> float:
        """Coefficient of determination R^2 of the forces on the modelled strains.

        Pooled over all samples and modelled strains: ``1 - SS_res / SS_tot``
        with ``SS_tot`` about each strain's mean.  Higher is better; raises
        (instead of returning NaN) when ``y`` has no variance.
        """
        if sample_weight is not None:
            raise ValueError("sample_weight is not supported; weight recordings by their length instead")
        pred = self.predict(X, qd=qd, qdd=qdd)
        ys = _check_list(y, len(pred), "y")
        mask = self.active_strains_.reshape(-1)
        true = []
        for k, yk in enumerate(ys):
            yk = np.asarray(yk, dtype=float)
            if yk.shape != pred[k].shape:
                raise ValueError(f"y[{k}] must have shape {pred[k].shape}; got {yk.shape}")
            if not np.all(np.isfinite(yk)):
                raise ValueError(f"y[{k}] contains NaN or inf")
            true.append(yk[:, mask])
        yt = np.concatenate(true)
        yp = np.concatenate([p[:, mask] for p in pred])
        ss_tot = float(np.sum((yt - yt.mean(axis=0)) ** 2))
        if not ss_tot > 0:
            raise ValueError("y has no variance on the modelled strains; R^2 is undefined")
        return 1.0 - float(np.sum((yt - yp) ** 2)) / ss_tot

    # ------------------------------------------------------------------
    # forward dynamics
    # ------------------------------------------------------------------
    def simulate(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        tau: ArrayLike | Callable[[float], ArrayLike],
        t: ArrayLike,
        *,
        step: float | None = None,
        rtol: float | None = None,
        atol: float | None = None,
        max_step: float | None = None,
        max_abs_state: float = 1e6,
        progress: bool | None = None,
        backend: str = "auto",
        method: str = "dopri5",
    ) -> StrainTrajectory:
        """Roll the identified model out under the actuation ``tau``.

        Parameters
        ----------
        q0, qd0 : array_like, shape (3m,) or (n,)
            Initial strains and rates (all strains, unmodelled ones ignored, or
            only the modelled ones).
        tau : array_like, shape (T, 3m), or callable
            Forces held constant on ``[t[k], t[k+1])``, or ``tau(time)``
            returning (3m,).  Columns of unmodelled strains are ignored.
        t : array_like, shape (T,)
            Output times (strictly increasing).
        step : float, optional
            Fixed step (must divide every sample period); default adaptive
            with ``rtol``/``atol`` (default: the estimator's).
        max_step : float, optional
            Bound on the adaptive step (default: the sample period).
        max_abs_state : float
            A strain or rate larger than this in magnitude means divergence.
        progress : bool, optional
            Progress bar (default: the estimator's ``progress``; the compiled
            path has none, it is one call).
        backend : {"auto", "numba", "python"}
            ``"numba"``: compiled kernels of :mod:`pcs_sindy._jit_rollout`
            (same Dormand–Prince scheme and step control, ~100x faster); needs a
            library with lumped physical parameters (``lumped_from_coef``:
            ``PhysicalPCSLibrary``, ``PCSLagrangianLibrary(basis="physical")``)
            and an array ``tau``.  ``"python"``: ``integrate_zoh`` with
            ``library.compile_dynamics``.  ``"auto"`` (default): ``"numba"``
            when possible, else ``"python"``.  The compiled path evaluates
            the model with 8 Gauss–Legendre nodes per segment (measured
            within 2e-11 of the library's 16 for ``|kappa_i L_i| <= 6``) and
            repeats the run with the library's rule if the rollout bends further.
        method : {"dopri5", "rosenbrock"}
            ``"dopri5"`` (default): explicit Dormand–Prince 5(4); its step is
            bounded by the stiff, strongly damped shear/axial modes (time
            constants of 0.1-3 ms), hence slow for two or more segments.
            ``"rosenbrock"``: the L-stable Rosenbrock-W method ROS34PW2 (order 3),
            linearly implicit in the structural Jacobian ``[[0, I], [-M^-1 K,
            -M^-1 D]]`` on the compiled backend (finite differences of the
            right-hand side on the Python backend); its step is set by accuracy
            alone.  Adaptive, it filters its error estimate through
            ``(I - h gamma J)^-1`` and measures it against the largest magnitude
            each state has reached (strain rates cross zero).  Recommended for
            validation rollouts: ``method="rosenbrock", rtol=3e-5, atol=3e-8``,
            measured (true parameters, 7 s validation, ``benchmarks/rollout_speed.py``)
            at 6.5e-6 / 6.3e-5 / 3.9e-5 relative error against the simulator and
            53x / 13x / 6x real time (2-core machine at load 2.5) for one /
            two / three segments, against 12x / 3.1x / 1.9x for ``"dopri5"`` at
            rtol 1e-6.
            Fixed steps are cheaper but not error controlled (``step=dt/3``:
            3.8e-5 on two segments, 1.6e-3 on three).

        Returns
        -------
        StrainTrajectory
            Full strains ``q`` and rates ``qd`` (T, 3m) of the segmentation;
            strains that are not modelled stay 0.

        Raises
        ------
        DivergenceError
            If the state becomes non-finite or unbounded or ``M(q)`` singular;
            the message names the time and the state.
        """
        check_is_fitted(self, "coef_")
        if backend not in ("auto", "numba", "python"):
            raise ValueError(f"backend must be 'auto', 'numba' or 'python'; got {backend!r}")
        if method not in ("dopri5", "rosenbrock"):
            raise ValueError(f"method must be 'dopri5' or 'rosenbrock'; got {method!r}")
        kin = self.kinematics_
        mask = kin.active_mask
        n = int(mask.sum())
        q0a = self._model_q(np.asarray(q0, dtype=float).reshape(-1), "q0")
        qd0a = self._model_q(np.asarray(qd0, dtype=float).reshape(-1), "qd0")
        t = np.asarray(t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise ValueError(f"t must be a 1-D array of at least 2 times; got shape {t.shape}")
        if callable(tau):
            tau_fn = tau

            def u(time_: float) -> NDArray[np.float64]:
                val = np.asarray(tau_fn(time_), dtype=float).reshape(-1)
                if val.size != mask.size:
                    raise ValueError(f"tau(t) must return {mask.size} forces; got {val.size} at t = {time_!r}")
                return val[mask]

            u_in: Any = u
        else:
            tau_arr = np.asarray(tau, dtype=float)
            if tau_arr.ndim != 2 or tau_arr.shape != (t.size, mask.size):
                raise ValueError(f"tau must have shape ({t.size}, {mask.size}) (one row per time); got {tau_arr.shape}")
            if not np.all(np.isfinite(tau_arr)):
                raise ValueError("tau contains NaN or inf")
            u_in = np.ascontiguousarray(tau_arr[:, mask])

        names = kin.strain_names(active_only=True)
        state_names = names + [f"d{nm}/dt" for nm in names]
        lumped_model = None
        if backend != "python":
            lumped_model, why = self._lumped_model(callable(tau))
            if lumped_model is None and backend == "numba":
                raise ValueError(f"backend='numba' is not available: {why}")
        tol = dict(
            step=step,
            rtol=self.rtol if rtol is None else rtol,
            atol=self.atol if atol is None else atol,
            max_step=max_step,
            max_abs_state=max_abs_state,
            state_names=state_names,
        )
        if lumped_model is not None:
            # the compiled model has no constant force f0: it acts like extra actuation
            f0 = self.library_.lumped_from_coef(self.model_coef_).get("rest_force")
            if f0 is not None and np.any(f0 != 0):
                u_in = np.ascontiguousarray(u_in + f0[None, :])
            y = lumped_model.rollout(np.concatenate([q0a, qd0a]), t, u_in, method=method, **tol)
            if lumped_model.reduced_quadrature:
                # the reduced quadrature is only used where it is measured exact (see _lumped_model)
                bend = kin.to_full(y[:, :n])[:, 0::3] * kin.segment_lengths
                if not np.abs(bend).max() <= _FAST_QUAD_MAX_KL:
                    lumped_model, _ = self._lumped_model(False, reduced=False)
                    y = lumped_model.rollout(np.concatenate([q0a, qd0a]), t, u_in, method=method, **tol)
        else:
            rhs = _make_rhs(self.library_.compile_dynamics(self.model_coef_), n)
            y = integrate_zoh(
                rhs, np.concatenate([q0a, qd0a]), t, u_in, progress=self.progress if progress is None else progress,
                method=method, **tol
            )
        q_full = kin.to_full(y[:, :n])
        qd_full = kin.to_full(y[:, n:])
        return StrainTrajectory(
            q_full,
            t,
            segment_lengths=kin.segment_lengths,
            active_strains=self.active_strains_,
            qd=qd_full,
            base_pose=kin.base_pose,
            metadata={"source": "EulerLagrangeRegressor.simulate"},
        )

    def _lumped_model(self, tau_callable: bool, reduced: bool = True) -> tuple[Any, str]:
        """Compiled model of the fitted library, or ``(None, reason)`` when unsupported.

        ``reduced``: at most ``_FAST_QUAD_NODES`` Gauss–Legendre nodes per segment
        (~30 % cheaper per call on two segments).  Measured against the
        library's 16 nodes: <= 5e-13 relative on ``M`` and the bias forces for
        ``|kappa_i L_i| <= 4``, <= 2e-11 up to 6 (tests/test_rollout_jit.py);
        ``simulate`` repeats a run with the library's rule when the rollout
        leaves ``|kappa_i L_i| <= _FAST_QUAD_MAX_KL``.
        """
        if tau_callable:
            return None, "tau is a callable (the compiled path needs an array held per sample)"
        lib = self.library_
        if not hasattr(lib, "lumped_from_coef"):
            return None, f"{type(lib).__name__} has no lumped physical parameters (lumped_from_coef)"
        if getattr(lib, "basis", "physical") != "physical":
            return None, f"{type(lib).__name__}(basis={lib.basis!r}) has no lumped physical parameters"
        from ._jit_rollout import LumpedModel  # numba import and kernel load only when used

        model = LumpedModel.from_library(lib, self.model_coef_)
        model.reduced_quadrature = False
        if reduced and model.wts.shape[1] > _FAST_QUAD_NODES:
            model = LumpedModel.from_library(lib, self.model_coef_, n_quadrature=_FAST_QUAD_NODES)
            model.reduced_quadrature = True
        return model, ""

    # ------------------------------------------------------------------
    def equations(self, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """The identified Lagrangian and damping as text, like pysindy's ``equations``.

        Parameters
        ----------
        precision : int
            Significant digits of the coefficients.
        threshold : float
            Terms with ``|coefficient| <= threshold`` are hidden (exact zeros
            always are).

        Returns
        -------
        list of str
            ``["L = c1 f1 + c2 f2 + ...", "D = diag(d_be_1, ...)"]``; for a
            physically parameterised library the Lagrangian's structure, the
            mass matrix, the identified parameters (``rhoA_i``, ``rhoI_i``,
            ``k_<strain>``) and ``D`` (the last line always starts ``D = diag(``).
        """
        check_is_fitted(self, "coef_")
        if hasattr(self.library_, "coefficients_from_parameters"):
            return self._physical_equations(precision, threshold)
        # the Euler-Lagrange column of f is named "EL[f]"; the Lagrangian is written in the f
        names = [nm[3:-1] if nm.startswith("EL[") and nm.endswith("]") else nm for nm in self.library_.euler_lagrange_names()]
        damp_idx = set(int(j) for j in np.asarray(self.library_.damping_index_))
        terms = []
        for j, (c, nm) in enumerate(zip(self.model_coef_, names)):
            if j in damp_idx or c == 0 or abs(c) <= threshold:
                continue
            sign = "-" if c < 0 else "+"
            terms.append(f"{sign} {abs(c):.{precision}g} {nm}")
        lag = " ".join(terms).lstrip("+ ") if terms else "0"
        if lag.startswith("- "):
            lag = "-" + lag[2:]
        strain = self.kinematics_.strain_names(active_only=True)
        damp = ", ".join(
            f"{s}: {self.model_coef_[j]:.{precision}g}" for s, j in zip(strain, np.asarray(self.library_.damping_index_))
        )
        return [f"L = {lag}", f"D = diag({damp})"]

    def _physical_equations(self, precision: int, threshold: float) -> list[str]:
        # A physical library's coefficients are parameters of a fixed Lagrangian, not weights of
        # basis functions: print the Lagrangian's structure once, then the parameter values.
        names = list(self.library_.euler_lagrange_names())
        damp_idx = set(int(j) for j in np.asarray(self.library_.damping_index_))
        values = [
            f"{nm} = {c:.{precision}g}"
            for j, (c, nm) in enumerate(zip(self.model_coef_, names))
            if j not in damp_idx and abs(c) > threshold
        ]
        strain = self.kinematics_.strain_names(active_only=True)
        elastic = " + ".join(f"k_{s} {s}^2" for s in strain)
        gravity = "rhoAg_i . p" if getattr(self.library_, "identify_gravity", False) else "rhoA_i g . p"
        damp = ", ".join(
            f"{s}: {self.model_coef_[j]:.{precision}g}" for s, j in zip(strain, np.asarray(self.library_.damping_index_))
        )
        if np.asarray(getattr(self.library_, "rest_force_index_", [])).size:
            elastic += " - 2 f0^T q"
        return [
            f"L = 1/2 qd^T M(q) qd + sum_i int_0^L_i {gravity} ds - 1/2 ({elastic})",
            "M(q) = sum_i int_0^L_i (rhoA_i Jp^T Jp + rhoI_i Jo^T Jo) ds",
            ", ".join(values) if values else "(all parameters 0)",
            f"D = diag({damp})",
        ]

    def print(self, precision: int = 3, threshold: float = 0.0) -> None:
        """Print :meth:`equations`."""
        for line in self.equations(precision=precision, threshold=threshold):
            print(line)
