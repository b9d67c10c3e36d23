"""Euler–Lagrange regression of a PCS model from strain trajectories and forces.

:class:`EulerLagrangeRegressor` composes three parts and adds nothing of its own
physics:

* a Lagrangian library (the contract :class:`~pcs_sindy.identification.library.base.LagrangianLibrary`:
  :class:`~pcs_sindy.identification.library.physical.PhysicalPCSLibrary` by default, the seed's
  monomial :class:`~pcs_sindy.identification.library.pcs_lagrangian.PCSLagrangianLibrary` in the seed preset),
* a formulation (:mod:`pcs_sindy.identification.formulations`: window integrals by default,
  sample-wise rows in the seed preset),
* an optimizer (:class:`~pcs_sindy.identification.optimizers.StiffnessThresholdOptimizer`, which
  removes strains stiffer than the material maximum, or any pysindy optimizer),

and hands rollouts to the library's compiled forward model
(:mod:`pcs_sindy.models.forward`).  The defaults are the best measured settings
(docs/results.md); :meth:`EulerLagrangeRegressor.seed_method` reproduces the
seed's method.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Sequence
from numbers import Integral, Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.optimizers import BaseOptimizer
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.metrics import r2_score
from sklearn.utils.validation import check_is_fitted

from ..core.kinematics import PlanarPCS
from ..core.recording_list import RecordingList
from ..core.saving import PersistenceMixin
from ..core.simulate_contract import DivergenceError, simulate_inputs
from ..core.spatial import SpatialPCS
from ..core.trajectory import StrainTrajectory, as_strain_trajectories
from ..core.validation import Check, InstanceOf, Interval, InvalidParameterError, Options, validate_parameters
from ..models.actuation import Actuation, IdentityActuation, actuation_from_layout
from ..models.actuation.base import gain_unit
from ..models.forward import reduce_strains
from . import excitation as _exc
from . import formulations as _form
from . import identifiability as _ident
from . import recordings as _rec
from .library.base import LagrangianLibrary
from .library.with_gains import WithGains
from .optimizers import StiffnessThresholdOptimizer, fit_normalized
from .recordings import WEAK_WINDOW
from .variable_projection import fit_offsets

__all__ = [
    "EulerLagrangeRegressor",
    "DivergenceError",
    "PoorFitWarning",
    "SCORE_DERIVATIVES",
    "WEAK_WINDOW",
    "MIN_EXCITATION",
    "EXCITATION_KINDS_DEFAULT",
]

#: Savitzky–Golay window and order of the initial rates of :meth:`EulerLagrangeRegressor.score` and
#: :meth:`EulerLagrangeRegressor.rollout_error` (fixed, so every candidate of a search is scored alike)
SCORE_DERIVATIVES = (7, 3)
_LIBRARIES = ("physical", "monomial")
_REFINE = ("auto", "output_error", "none")
#: the scale convention of a fit in which no absolute quantity is known (no mass, no gains, no forces)
SCALE_CONVENTION_MASS = 1.0
#: default ``min_excitation``: strains of ``excitation_kinds`` moving less than this times their per-sample noise are
#: not identified (measured on the spatial benchmark's tendon and force cases, docs/results.md)
MIN_EXCITATION = 0.5
#: default ``excitation_kinds``: the strain kinds the excitation test removes (twist alone: see the parameter)
EXCITATION_KINDS_DEFAULT = ("twist",)
#: inputs this far (relative to the training range, at least 1e-9) outside it are out of range
INPUT_RANGE_TOL = 0.05


class PoorFitWarning(UserWarning):
    """A fitted model predicts its own training recordings worse than a model with no inputs.

    Warned by :meth:`EulerLagrangeRegressor.fit` when open-loop rollouts of the training
    recordings miss the recorded tip by more, on average over their samples, than the zero-input
    prediction, the tip held where each rollout starts (``training_rollout_error_`` against
    ``no_input_error_``).  The model then cannot represent the data: typically an actuation
    layout that does not match the robot (tendon sides, ends, drive), or inputs in other units.
    The command line's ``fit`` refuses to write such a model.
    """


def _odd_window(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, np.integer)) and value >= 3 and value % 2 == 1


def _expand_gains(reduced: Actuation, full: Actuation, directions: NDArray[np.float64]) -> NDArray[np.float64]:
    """Gains of a learned map on all p inputs from those fitted on the inputs' directions ``u @ directions``."""
    by_term = {tuple(int(v) for v in row): g for row, g in zip(reduced._arrays["index"], reduced.gains_, strict=True)}
    out = np.zeros(full.n_gains)
    for j, (a, k, b, part) in enumerate(full._arrays["index"]):
        out[j] = sum(directions[k, i] * by_term[(int(a), i, int(b), int(part))] for i in range(directions.shape[1]))
    return out


def _reduce_gains(reduced: Actuation, full: Actuation, directions: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of :func:`_expand_gains`: a full map's gains on the varying inputs (columns of the identity)."""
    by_term = {tuple(int(v) for v in row): g for row, g in zip(full._arrays["index"], full.gains_, strict=True)}
    column = np.argmax(directions, axis=0)  # the input each direction selects
    return np.array(
        [by_term[(int(a), int(column[i]), int(b), int(part))] for a, i, b, part in reduced._arrays["index"]],
        dtype=float,
    )


class EulerLagrangeRegressor(PersistenceMixin, RegressorMixin, BaseEstimator):
    """Identify ``M(q) qdd + C(q, qd) qd + G(q) + K q + D qd = tau`` by regression.

    The defaults are the package's recommended method; :meth:`seed_method`
    gives the seed's.

    Parameters
    ----------
    feature_library : LagrangianLibrary or {"physical", "monomial"}, optional
        The Lagrangian library (pysindy's name for the term library), cloned and fitted on the data's segmentation in
        :meth:`fit`.  Default ``PhysicalPCSLibrary()``: one coefficient per
        physical unknown (line density, rotary inertia, stiffness, damping,
        rest force per strain), any number of segments, bounded fits (passive
        model, positive-definite ``M``).  For strains fused from marker positions
        alone (motion capture: a fitted plane and base) with an output-error
        refinement, gravity's direction in that plane is not known: the default
        then fits gravity along the rest direction and gravity identified
        (``identify_gravity=True``) and keeps the one whose rollouts follow the
        training markers best (``gravity_choice_``).  ``"monomial"``: the seed's symbolic
        :class:`~pcs_sindy.identification.library.pcs_lagrangian.PCSLagrangianLibrary`.
    formulation : {"weak", "strong", "static"}, default "weak"
        ``"weak"``: regress window integrals ``int phi tau dt = int phi Psi dt @ coef``
        with the bump test function over windows of ``weak_window`` intervals
        (no ``qdd``; held forces integrated exactly).  ``"strong"``: regress
        ``tau = Psi(q, qd, qdd) @ coef`` sample by sample.  ``"static"``: fit
        equilibria alone, ``G(q) + K q - f0 = A(q) u``, one row per hold (a
        run of samples with one input, the mean of its second half), no
        derivatives: for rigs that only hold shapes.  Inertia and damping are
        not determined (zero columns; the model's :meth:`equilibrium` is what
        it predicts).  The scale comes from inputs in physical units
        (tensions, a given tendon stiffness) or from the robot's mass
        (``PhysicalPCSLibrary(mass=...)``) when every input gain is identified.
    optimizer : pysindy optimizer, optional
        Cloned in ``fit``.  Default (None) ``StiffnessThresholdOptimizer()`` (the seed's
        material bounds; removes over-stiff strains); its parameters are those of
        ``get_params(deep=True)`` and ``set_params`` too (``optimizer__threshold``,
        e.g. in a grid search), which then store that optimizer here.  Any other pysindy
        ``BaseOptimizer`` (``STLSQ``, ``SR3``, ...) fits the same rows without
        strain removal or bounds, at its own defaults: it sees each strain's
        equation scaled to a unit-RMS target and unit-norm columns
        (:func:`~pcs_sindy.identification.optimizers.fit_normalized`), so its
        threshold means the same on every robot; a warning says when it removed
        a stiffness or left the mass matrix singular.
    differentiation_method : callable, optional
        ``method(x, t)`` giving ``qd`` from ``q`` and ``qdd`` from ``qd`` (e.g. a
        pysindy differentiation object).  Default: Savitzky–Golay.
    window_length : int, default 7
        Savitzky–Golay window (odd, samples) of the rates (and accelerations).
        Short windows keep the kink of ``qd`` at every jump of a held force.
    polyorder : int, default 3
        Savitzky–Golay polynomial order.
    exclude_force_jumps : bool, default False
        Strong form: leave out every sample whose Savitzky–Golay window contains
        a jump of the held actuation (and the ends); for step actuation only.
    weak_window : int, optional
        Weak form: window length in sampling intervals (every recording needs
        more samples); used as given.  Default, from the data: :data:`WEAK_WINDOW`
        seconds (0.16 s, measured best at 1 kHz with pose noise), at least
        ``WEAK_WINDOW_MIN_SAMPLES`` (160) intervals, at most half the shortest
        recording; when the strains' motion is less than 10 times their noise,
        shortened to keep their band (``recordings.WEAK_WINDOW_BAND`` /
        ``recordings.band_frequency``: 0.75 / the median frequency of their power
        above the noise floor, at least 32 intervals; docs/method.md, weak form).
    weak_stride : int, optional
        Weak form: step between windows in samples; default a quarter of the window.
    weak_hold : {"zoh", "trapezoid"}, default "zoh"
        Weak form: ``tau`` held on ``[t_k, t_{k+1})`` (exact for held actuation)
        or integrated by the trapezoid rule (smooth actuation).
    check_mass_matrix : bool, default True
        Warn after ``fit`` if ``M(q)`` is not positive definite on some training samples.
    rtol, atol : float, default 3e-5, 3e-8
        Default tolerances of :meth:`simulate`.
    progress : bool, default False
        Progress bars in :meth:`simulate` (solve_ivp paths).
    actuation : Actuation or dict, optional
        How the inputs ``y`` of :meth:`fit` (and ``u`` of :meth:`simulate`) act:
        default the generalised forces themselves (T, 3m); a
        :class:`~pcs_sindy.models.actuation.TendonActuation`,
        :class:`~pcs_sindy.models.actuation.PressureActuation` or
        :class:`~pcs_sindy.models.actuation.LinearActuation` (or its JSON layout, e.g.
        a scenario's ``actuation``) maps actuator inputs (T, p) through
        ``A(q)``, whose unknown offsets and gains are identified with the model
        (see :mod:`pcs_sindy.models.actuation`, also for when the scale needs the mass).
        With identified gains and no absolute quantity (no ``mass``, no given
        gain) the fit uses a stated convention instead: a uniform line density
        of total mass :data:`SCALE_CONVENTION_MASS` (1 kg); the motion does
        not depend on it (``scale_convention_``, and the identifiability report).
    refine : {"auto", "output_error", "none"}, default "auto"
        ``"output_error"``: after the equation-error fit, refine stiffness,
        damping, rotary inertia, rest forces and input gains so that open-loop
        rollouts of the training recordings follow them
        (:func:`~pcs_sindy.identification.output_error.refine_output_error`:
        uniform line density at the fit's total mass under the scale convention
        or a given ``mass``, else each segment's refined ``>= 0``; symmetric
        input-stiffness terms, ``K - sum u_k B_k`` positive definite over the
        training input box: passive and bounded by construction).  ``"auto"``:
        so for a :class:`~pcs_sindy.models.actuation.LearnedActuation` (an
        input map of unknown layout, which the equation error fits worst:
        measured on the real Trunk step recordings, docs/results.md) and for a
        spatial fit with inputs in physical units whose strains carry per-frame
        noise (:func:`~pcs_sindy.identification.output_error.strains_are_noisy`;
        noise-free the equation-error fit is already exact), none otherwise;
        skipped (with a warning) when the forward model has no
        compiled rollouts.  A
        spatial fit from positions alone (one weight vector ``rhoA g``) also
        refines gravity's direction, at ``|g|`` of the library; a spatial
        refinement fits the recordings' start states, compares the markers
        (``marker_offsets``, and orientations when the capture measured them)
        and keeps the equation-error fit when its training rollouts are better.
    check_fit : bool, default True
        After :meth:`fit`, roll each training recording out (``training_rollout_error_``,
        ``no_input_error_``) and warn with :class:`PoorFitWarning` when the model is worse than a
        model with no inputs.  This costs one rollout per training recording (on 8 recordings of
        0.5 s at 1 kHz: 0.2-0.6 s, several times the equation-error fit); False skips it, e.g.
        inside a grid search whose scorer rolls the held-out recordings out anyway.
    min_excitation : float or None, default :data:`MIN_EXCITATION`
        Dynamic formulations: a strain of ``excitation_kinds`` whose motion stands less than this above its
        measurement noise in the training recordings is removed before the regression (held at 0 in every
        row and in the model, like a strain the stiffness threshold removes).  The measure is
        :func:`~pcs_sindy.core.metrics.motion_to_noise`: the strain's standard deviation net of its white
        noise, over that noise, per sample, pooled over the recordings (``excitation_``; a sinusoid of
        amplitude ``a`` under noise ``sigma`` reads ``a / (sqrt(2) sigma)``).  Tendons hardly twist a robot,
        and markers with 0.5 mm noise then give the twist as noise alone: its stiffness, damping and inertia
        come from that noise and pull the coefficients the strains share.  Noise-free data read far above
        any threshold.  None or 0 keeps every strain.
    excitation_kinds : tuple of str, default ``("twist",)``
        The strain kinds ``min_excitation`` may remove, among ``"twist"``, ``"shear"``, ``"axial"``
        (bending never: it is what the inputs move).  Shear and axial strains carry the line densities'
        translational inertia: removing them when they move less than their noise helped the tendon-driven
        3-D benchmark with equation weighting (``StiffnessThresholdOptimizer(weight_equations=True)``) but
        left the line density at 0 (a singular mass matrix) without it (docs/results.md, spatial
        identification), so the default removes twist alone.
    library : deprecated
        Former name of ``feature_library`` (a FutureWarning in :meth:`fit`); kept so that
        existing scripts and model files work.

    Attributes
    ----------
    coef_ : ndarray, shape (n_psi,)
        Coefficients in the columns of ``full_library_``; columns dropped by
        strain removal are exactly 0.
    model_coef_ : ndarray
        ``coef_[column_map_]``: the coefficients of ``library_``.
    full_library_, library_ : LagrangianLibrary
        The library fitted on the data and the library of the kept strains.
    column_map_ : ndarray of int
        Columns of ``full_library_`` kept in ``library_``.
    active_strains_ : ndarray of bool, shape (m, 3)
        Modelled strains after sparsification.
    stiffness_, damping_, rest_strain_ : ndarray, shape (3m,)
        Identified stiffness (``inf`` for a strain not modelled), damping (0
        there) and rest strain ``f0 / stiffness`` (0 without constant forces).
    removed_strains_ : list of str
        Strains removed: those not excited above their noise (``min_excitation``), then those the stiffness
        threshold found stiffer than the material bound.
    removal_reasons_ : dict
        Why each of ``removed_strains_`` was removed (its name -> a sentence).
    excitation_ : ndarray, shape (n_q,)
        Each strain's motion-to-noise ratio in the training recordings (full strain order; NaN for a
        strain the data do not model); ``min_excitation`` is compared with it.
    optimizer_ : the fitted optimizer
    kinematics_ : PlanarPCS
        Segmentation with ``active_strains_``.
    identifiability_ : dict or None
        What the data determined (see :mod:`pcs_sindy.identification.identifiability`);
        None when the regression has no more rows than coefficients.
    mass_matrix_not_pd_fraction_ : float
        Fraction of training samples where ``M(q)`` is not positive definite.
    strain_range_ : ndarray, shape (2, n)
        Smallest and largest value of each modelled strain in the training
        data: where the model was identified (controllers stay inside it).
    n_regression_samples_ : int
        Rows of the regression per strain (samples, or windows in the weak form).
    actuation_ : Actuation
        The fitted input map with its identified ``offsets_`` and ``gains_``.
    fit_time_ : float
        Wall time of ``fit`` (s).
    scale_convention_ : str or None
        The convention fixing the scale when nothing absolute was known
        (``"total mass 1 kg, uniform line density"``), else None.
    input_range_ : ndarray, shape (2, p)
        Smallest and largest training value of each actuator input (or
        generalised force): with an actuation, :meth:`simulate` and
        :meth:`equilibrium` warn outside it.
    input_directions_ : ndarray, shape (p, r), or None
        A learned map's inputs that varied in training (columns of the
        identity; a constant input's gains are zero: it acts like the constant
        force ``f0``), None for other maps.
    refinement_ : dict or None
        The output-error refinement's record (``rmse_start``, ``rmse`` [m] of the
        training markers, ``nfev``, ``slope_factor``), None when not refined.
    gravity_choice_ : dict or None
        With the default library on positions-only strains (refined): which gravity model was kept
        (``"known"`` along the rest direction, or ``"identified"``), each one's training rollout RMSE
        [m], failures and the reason; None otherwise.
    training_r2_ : ndarray, shape (n,)
        How well the fitted model balances each modelled strain's equation on the training data:
        ``R^2 = 1 - sum (F - F_hat)^2 / sum (F - mean F)^2`` over the rows the regression fitted
        (window integrals in the weak form, samples in the strong form, holds in the static form),
        with ``F`` the input forces ``A(q) u`` (the generalised forces without actuation) and
        ``F_hat = Psi(q, qd, qdd) @ coef`` the identified model's inverse dynamics, both of the
        final model (after any output-error refinement).  1 is a perfect balance; NaN for a strain
        whose input force does not vary.  The order is ``kinematics_.strain_names(active_only=True)``.
        A strain the inputs barely act on can read far below 0 on a good model (measured: the
        shear equations of a clean 8 s servo capture, -72, -2.7 and -6.5, where its training
        rollouts are within 0.07 mm), so the check of a fit is its rollouts (``no_input_error_``), not this number.
    training_rollout_error_ : ndarray, shape (n_recordings,), or None
        :meth:`rollout_error` of the training recordings themselves [m]: the mean tip error of
        open-loop rollouts from each recording's measured state under its own inputs (``inf``
        for one that diverged).  None when not computed: ``check_fit=False``, the static
        formulation (no dynamics), or a model without compiled rollouts (the monomial library's, whose
        rollouts take seconds, and the spatial model's NumPy loop, minutes).
    no_input_error_ : ndarray, shape (n_recordings,), or None
        The same error for the zero-input prediction, a model the inputs do not move: the tip held
        where each rollout starts [m].  :meth:`fit` warns with :class:`PoorFitWarning` when the
        training rollouts are worse on average (pooled over the samples of all recordings).

    Notes
    -----
    **Which score answers which question.**  :meth:`score` is scikit-learn's ``R^2`` of the
    forces :meth:`predict` returns, sample by sample (inverse dynamics with this estimator's
    rates and accelerations, recordings stacked; ``scoring="r2"`` gives the same).  It asks "how
    well does the model explain the recorded forces?", and with noisy poses the twice
    differentiated strains make those forces noisy: a model whose rollouts follow the tip within
    0.1 mm can score near 0 or below.  To ask "does the model predict the motion?" (choosing
    thresholds, segmentations, libraries for simulation or control) use the rollout scorers of
    :mod:`pcs_sindy.core.metrics`: ``rollout_r2_scorer`` (``R^2`` of the tip path of rollouts of
    held-out recordings, :meth:`rollout_score`) or ``rollout_scorer`` (minus their mean tip error
    in metres, :meth:`rollout_error`), e.g. ``GridSearchCV(EulerLagrangeRegressor(),
    {"optimizer__threshold": [1, 0.3, 0.1]}, scoring=rollout_r2_scorer)``.  After a fit,
    ``training_r2_`` says how well each equation balances on the (integrated) training rows and
    ``training_rollout_error_`` against ``no_input_error_`` whether the model beats doing nothing.

    **pysindy's idioms.**  ``fit(q, t=dt, u=u, segment_lengths=[...])`` with arrays (the strains
    ``q`` (T, 3m) of each recording, ``t`` a sample period, time stamps or a list of them, ``u`` the
    inputs), ``print()`` / ``print(lhs=[...])``, ``coefficients()`` (one row per strain equation),
    ``get_feature_names_out()``, ``simulate(x0, t, u)`` with ``x0 = [q0, qd0]``: it returns a
    :class:`~pcs_sindy.core.StrainTrajectory`, and ``np.asarray`` of it is pysindy's state
    ``[q, qd]`` (T, 6m).
    """

    identifiability_tol = 0.1

    def __init__(
        self,
        feature_library: Any = None,
        formulation: str = "weak",
        optimizer: Any = None,
        differentiation_method: Any = None,
        window_length: int = 7,
        polyorder: int = 3,
        exclude_force_jumps: bool = False,
        weak_window: int | None = None,
        weak_stride: int | None = None,
        weak_hold: str = "zoh",
        check_mass_matrix: bool = True,
        rtol: float = 3e-5,
        atol: float = 3e-8,
        progress: bool = False,
        actuation: Any = None,
        refine: str = "auto",
        check_fit: bool = True,
        min_excitation: float | None = MIN_EXCITATION,
        excitation_kinds: tuple[str, ...] = EXCITATION_KINDS_DEFAULT,
        library: Any = None,
    ) -> None:
        self.feature_library = feature_library
        self.formulation = formulation
        self.optimizer = optimizer
        self.differentiation_method = differentiation_method
        self.window_length = window_length
        self.polyorder = polyorder
        self.exclude_force_jumps = exclude_force_jumps
        self.weak_window = weak_window
        self.weak_stride = weak_stride
        self.weak_hold = weak_hold
        self.check_mass_matrix = check_mass_matrix
        self.rtol = rtol
        self.atol = atol
        self.progress = progress
        self.actuation = actuation
        self.refine = refine
        self.check_fit = check_fit
        self.min_excitation = min_excitation
        self.excitation_kinds = excitation_kinds
        self.library = library

    @classmethod
    def seed_method(cls, **overrides: Any) -> EulerLagrangeRegressor:
        """The seed's method: monomial Lagrangian basis, strong form, Savitzky–Golay 25/3.

        Parameters
        ----------
        **overrides
            Other constructor arguments (e.g. ``optimizer``).

        Returns
        -------
        EulerLagrangeRegressor
        """
        params = {"feature_library": "monomial", "formulation": "strong", "window_length": 25, "polyorder": 3}
        params.update(overrides)
        return cls(**params)

    # ------------------------------------------------------------------ parameters and data
    #: read by validate_parameters in fit and predict, and by model files
    _parameter_constraints: dict = {
        "feature_library": [
            InstanceOf(LagrangianLibrary, "a LagrangianLibrary (PhysicalPCSLibrary, PCSLagrangianLibrary)"),
            Options(_LIBRARIES),
            None,
        ],
        "library": [
            InstanceOf(LagrangianLibrary, "a LagrangianLibrary (PhysicalPCSLibrary, PCSLagrangianLibrary)"),
            Options(_LIBRARIES),
            None,
        ],
        "formulation": [Options(_form.FORMULATIONS)],
        "optimizer": [
            InstanceOf(
                BaseOptimizer,
                "a pysindy optimizer (StiffnessThresholdOptimizer, or a pysindy BaseOptimizer such as STLSQ or SR3)",
            ),
            None,
        ],
        "differentiation_method": "no_validation",
        "window_length": [Check(_odd_window, "an odd integer >= 3")],
        "polyorder": [Interval(Integral, 2, None, closed="left")],
        "exclude_force_jumps": "no_validation",
        "weak_window": [None, Interval(Integral, 2, None, closed="left")],
        "weak_stride": [None, Interval(Integral, 1, None, closed="left")],
        "weak_hold": [Options(("zoh", "trapezoid"))],
        "check_mass_matrix": "no_validation",
        "rtol": [Interval(Real, 0, None, closed="neither")],
        "atol": [Interval(Real, 0, None, closed="neither")],
        "progress": "no_validation",
        "actuation": [None, InstanceOf(Actuation, "an Actuation"), InstanceOf(dict, "a layout dict")],
        "refine": [Options(_REFINE)],
        "check_fit": "no_validation",
        "min_excitation": [None, Interval(Real, 0, None, closed="left")],
        "excitation_kinds": [
            Check(_exc.valid_kinds, f"a tuple of distinct strain kinds among {_exc.EXCITATION_KINDS}")
        ],
    }

    def _check_joint_parameters(self) -> None:
        """What the table cannot say: ``polyorder < window_length``, and a library instance's own table."""
        if self.polyorder >= self.window_length:
            raise InvalidParameterError.of(self, "polyorder", f"< window_length = {self.window_length}", self.polyorder)
        if self.library is not None and self.feature_library is not None:
            raise InvalidParameterError.of(
                self,
                "library",
                "None when feature_library is given (it is feature_library's former name)",
                self.library,
            )
        if isinstance(self._library_choice(), LagrangianLibrary):
            validate_parameters(self._library_choice())

    def _library_choice(self) -> Any:
        """``feature_library``, or the deprecated ``library`` when only that was given (None: the default)."""
        return self.library if self.feature_library is None else self.feature_library

    def make_library(self, kinematics: Any = None) -> LagrangianLibrary:
        """The library this regressor fits: a fresh, unfitted instance of ``feature_library`` (default physical).

        For spatial (3-D) data (``kinematics`` a :class:`~pcs_sindy.core.SpatialPCS`) the default is
        :class:`~pcs_sindy.identification.library.spatial_physical.SpatialPhysicalPCSLibrary`.
        """
        chosen = self._library_choice()
        if isinstance(kinematics, SpatialPCS) and (chosen is None or isinstance(chosen, str)):
            if chosen not in (None, "physical"):
                raise ValueError(
                    f"feature_library={chosen!r} is planar only; spatial strains take the physical library "
                    "(feature_library=None, 'physical' or a SpatialPhysicalPCSLibrary)"
                )
            from .library.spatial_physical import SpatialPhysicalPCSLibrary

            return SpatialPhysicalPCSLibrary()
        if chosen is None or (isinstance(chosen, str) and chosen == "physical"):
            from .library.physical import PhysicalPCSLibrary

            return PhysicalPCSLibrary()
        if isinstance(chosen, str):
            from .library.pcs_lagrangian import PCSLagrangianLibrary

            return PCSLagrangianLibrary()
        return clone(chosen)

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """Parameters (scikit-learn); with ``deep`` and no optimizer given, those of the default one as well.

        ``optimizer=None`` means ``StiffnessThresholdOptimizer()``: its parameters are listed as
        ``optimizer__<name>`` so that a search over them (``optimizer__threshold``) is validated
        like any nested parameter.
        """
        params = super().get_params(deep=deep)
        if deep and self.optimizer is None:
            params.update({f"optimizer__{k}": v for k, v in StiffnessThresholdOptimizer().get_params().items()})
        return params

    def set_params(self, **params: Any) -> EulerLagrangeRegressor:
        """Set parameters (scikit-learn); ``optimizer__<name>`` with no optimizer given sets the default one's.

        The default ``StiffnessThresholdOptimizer()`` is then created and stored as ``optimizer``
        (a new object for this estimator: no default instance is shared between estimators).
        """
        nested = any(k.startswith("optimizer__") for k in params)
        if nested and params.get("optimizer", self.optimizer) is None:
            params = {**params, "optimizer": StiffnessThresholdOptimizer()}
        return super().set_params(**params)

    def _new_actuation(self, kin: PlanarPCS) -> Actuation:
        act = self.actuation
        if act is None or isinstance(act, dict):
            act = actuation_from_layout(act)
        else:
            act = clone(act)
        return act.fit(kin)

    def _derivatives(
        self, rec: StrainTrajectory, k: int, qd: ArrayLike | None, qdd: ArrayLike | None, *, fixed: bool = False
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Rates (and accelerations) of one recording; ``fixed``: Savitzky–Golay :data:`SCORE_DERIVATIVES`."""
        wl, po = SCORE_DERIVATIVES if fixed else (self.window_length, self.polyorder)
        return _rec.derivatives(
            rec, k, qd, qdd, method=None if fixed else self.differentiation_method, window_length=wl, polyorder=po
        )

    def _recordings(
        self,
        X: Any,
        y: Any,
        qd: Any,
        qdd: Any,
        *,
        kin: PlanarPCS | None,
        formulation: str,
        actuation: Actuation | None = None,
    ) -> tuple[PlanarPCS, list[StrainTrajectory], list]:
        """:func:`pcs_sindy.identification.recordings.prepare` with this estimator's settings."""
        return _rec.prepare(
            X,
            y,
            qd,
            qdd,
            kin=kin,
            formulation=formulation,
            actuation=actuation,
            differentiation_method=self.differentiation_method,
            window_length=self.window_length,
            polyorder=self.polyorder,
            weak_window=self.weak_window,
            weak_stride=self.weak_stride,
            exclude_force_jumps=self.exclude_force_jumps,
        )

    # ------------------------------------------------------------------ fit
    def fit(
        self,
        X: Any,
        y: Any = None,
        *,
        t: Any = None,
        u: Any = None,
        segment_lengths: Sequence[float] | None = None,
        qd: Sequence[ArrayLike] | None = None,
        qdd: Sequence[ArrayLike] | None = None,
    ) -> EulerLagrangeRegressor:
        """Identify the model.

        Two call styles: scikit-learn's ``fit(X, y)`` with ``StrainTrajectory`` recordings, and
        pysindy's ``fit(q, t=dt, u=u, segment_lengths=[...])`` with plain arrays (``fit(q, dt,
        u=u, ...)`` too: with ``u`` given, a second positional argument is ``t``, pysindy's order).
        Array strains are differentiated like a trajectory's (``differentiation_method``,
        default Savitzky–Golay).

        Parameters
        ----------
        X : list of StrainTrajectory, or array_like (T, 3m) or a list of them
            Recordings: trajectories (time stamps, full strains ``q`` (T, 3m), segmentation),
            or the full strains ``q`` of each recording as arrays, with ``t`` and ``segment_lengths``.
        y : list of array_like, shape (T, 3m) or (T, p)
            Inputs of each recording, held constant per sample: the generalised forces
            (T, 3m), or with an ``actuation`` the actuator inputs (T, p).
        t : float, array_like (T,), or list of them, optional
            With array strains: the sample period [s], the time stamps, or one per recording.
        u : list of array_like, optional
            pysindy's name for ``y`` (give one of them).
        segment_lengths : sequence of float, optional
            With array strains: the rest length [m] of each segment (m segments: ``q`` (T, 3m)).
        qd, qdd : list of array_like, optional
            Known strain rates and accelerations (e.g. from a simulator)
            instead of differentiating ``q`` (the weak form needs only ``qd``).

        Returns
        -------
        self

        Warns
        -----
        PoorFitWarning
            When the training rollouts are further off than the zero-input prediction (see
            ``no_input_error_``).
        FutureWarning
            When the deprecated ``library`` parameter is set (use ``feature_library``).
        """
        start = time.perf_counter()
        validate_parameters(self)
        self._check_joint_parameters()
        if self.library is not None:
            warnings.warn(
                f"{type(self).__name__}(library=...) is deprecated: the parameter is now feature_library "
                "(pysindy's name); library will be removed in a future release",
                FutureWarning,
                stacklevel=2,
            )
        X, y = self._training_data(X, y, t, u, segment_lengths)
        X = _rec.as_trajectories(X)
        given_inputs = y
        self.gravity_choice_ = None
        if (
            self._library_choice() is None
            and not isinstance(_rec.data_kinematics(X), SpatialPCS)
            and self.formulation != "static"
            and all(x.metadata.get("shape_fit") == "positions" for x in X)
            and self._refines(self._new_actuation(_rec.data_kinematics(X)))
        ):
            return self._fit_choosing_gravity(X, y, qd, qdd, start)
        act = self._new_actuation(_rec.data_kinematics(X))
        full_act, directions, y_inputs = None, None, None
        if act.kind == "learned":
            # an input that never varies acts like the constant force f0 (or not at all): its gains are not
            # determined, so the learned map is fitted on the varying inputs and gives it zero gain
            y_inputs = [act.check_inputs(v, f"y[{k}]") for k, v in enumerate(_rec.check_list(y, len(X), "y"))]
            u_cat = np.concatenate(y_inputs)
            directions = np.eye(act.n_inputs_)[:, np.ptp(u_cat, axis=0) > 0]
            if directions.shape[1] == 0:
                raise ValueError("y (the inputs) never varies in any recording: nothing can be identified")
            if directions.shape[1] < act.n_inputs_:
                full_act = act
                act = clone(act).set_params(n_inputs=int(directions.shape[1])).fit(act.kinematics_)
                y = [v @ directions for v in y_inputs]
        kin, X, recs = self._recordings(X, y, qd, qdd, kin=None, formulation=self.formulation, actuation=act)
        if not any(np.any(r.u) for r in recs):
            raise ValueError(
                "y (the inputs) is zero in every recording: nothing drives the robot, so nothing can be "
                "identified; record with actuation"
            )
        # strains moving less than their noise leave before the regression: held at 0 in every row (the inputs'
        # A(q) too, as in the model's rollouts); the optimizer fits the rest
        self.excitation_, unexcited = (
            (np.full(kin.n_q, np.nan), np.zeros(kin.n_q, dtype=bool))  # holds, not motion: nothing to measure
            if self.formulation == "static"
            else _exc.unexcited_strains(kin, [r.q for r in recs], self.min_excitation, tuple(self.excitation_kinds))
        )
        names_all = kin.strain_names()
        self.removal_reasons_ = {
            names_all[e]: f"not excited: motion {self.excitation_[e]:.2g} x its noise (min_excitation "
            f"{self.min_excitation:g})"
            for e in np.flatnonzero(unexcited)
        }
        for r in recs:
            for arr in (r.q, r.qd, r.qdd):
                if arr is not None:
                    arr[:, unexcited[kin.active_mask]] = 0.0
        lib = self.make_library(kin).fit(X)
        self.scale_convention_ = None
        spatial_default = isinstance(kin, SpatialPCS) and self._library_choice() in (None, "physical")
        if spatial_default and all(x.metadata.get("shape_fit") == "positions" for x in X):
            # strains fused from positions alone hang from a fitted base: gravity's direction in it is not known
            # (the planar path tries both models; in 3-D the one consistent model of a uniform robot is identified:
            # one weight vector rhoA g shared by all segments)
            lib.set_params(density="uniform", identify_gravity="shared").fit(X)
        if (
            act.n_gains
            and "mass" in lib.get_params()
            and lib.scale_constraint() is None
            and not any(np.any(act.parts(r.q, r.u)[0]) for r in recs)
        ):
            # nothing absolute is known (every force is a gain times a known function): the motion is the same
            # for every common scale of densities, stiffness, damping and gains, so fix one and say so
            lib.set_params(mass=SCALE_CONVENTION_MASS)
            if spatial_default:  # the convention's uniform line density, imposed: M positive definite by construction
                lib.set_params(density="uniform").fit(X)
            self.scale_convention_ = (
                f"total mass {SCALE_CONVENTION_MASS:g} kg, uniform line density (no mass, gain or force in known "
                "units was given; the motion does not depend on this scale, the parameters are relative to it)"
            )
        offsets, offset_info = (None, None)
        if act.n_offsets:
            offsets, offset_info = fit_offsets(lib, act, recs, self.formulation, self.weak_hold)
        x, target, design = _form.regression(lib, recs, self.formulation, act, offsets=offsets, hold=self.weak_hold)
        self.n_regression_samples_ = int(x.shape[0])
        columns: Any = WithGains(lib, act.gain_names_, act.gain_lower_bound) if act.n_gains else lib
        equality = columns.scale_constraint() if act.n_gains else None
        if act.n_gains and equality is None and not np.any(target):
            raise ValueError(
                f"{type(act).__name__} with identified gains makes the regression homogeneous: densities, stiffness, "
                "damping and gains are determined only up to one common factor (the motion is the same when all are "
                "scaled alike, known gravity included). Give one absolute quantity: the robot's mass, "
                "feature_library=PhysicalPCSLibrary(mass=...), or the gains themselves"
            )
        opt = StiffnessThresholdOptimizer() if self.optimizer is None else clone(self.optimizer)
        p_lib = lib.n_coefficients_
        fit_cols, x_o, target_o, design_o, eq_o = columns, x, target, design, equality
        cols_o = np.arange(p_lib + act.n_gains)
        if unexcited.any():
            fit_cols, cols_o, x_o, target_o, design_o, eq_o = _exc.restricted_problem(
                columns, design, target, equality, ~unexcited[kin.active_mask]
            )
        coef_all = np.zeros(p_lib + act.n_gains)
        if isinstance(opt, StiffnessThresholdOptimizer):
            opt.fit(x_o, target_o, library=fit_cols, design=design_o, equality=eq_o)
            coef_all[cols_o] = np.asarray(opt.coef_[0], dtype=float)
            active, removed = opt.active_strains_, list(opt.removed_strains_)
            self.removal_reasons_.update({nm: "stiffer than its bound (stiffness threshold)" for nm in removed})
            lib_r = lib.restrict(active) if unexcited.any() else (opt.library_.library if act.n_gains else opt.library_)
            column_map = np.asarray([c for c in cols_o[opt.column_map_] if c < p_lib], dtype=int)
            removed = list(self.removal_reasons_)
        else:
            if equality is not None:
                raise ValueError(
                    f"identified gains need a scale constraint, which {type(opt).__name__} cannot hold; "
                    "use StiffnessThresholdOptimizer"
                )
            # unit-norm columns and target: the optimizer's thresholds mean the same on every robot
            coef_all[cols_o] = fit_normalized(opt, x_o, target_o)
            lib_e = fit_cols.library if act.n_gains else fit_cols
            lib_r, column_map = (lib_e, cols_o[: lib_e.n_coefficients_]) if unexcited.any() else (lib, np.arange(p_lib))
            self._warn_missing_physics(lib_r, coef_all[column_map], type(opt).__name__)
            active = kin.active_strains.copy() & ~unexcited.reshape(kin.n_segments, -1)
            removed = list(self.removal_reasons_)
        coef, library_ = coef_all[:p_lib], lib_r
        self.actuation_ = act.set_identified(
            coef_all[p_lib:] if act.n_gains else act.gains_,
            act.offsets_ if offsets is None else act.signed_offsets(offsets),
        )
        self.optimizer_ = opt
        self.full_library_ = lib
        self.library_ = library_
        self.column_map_ = column_map
        self.coef_ = coef
        self.model_coef_ = coef[column_map]
        self.active_strains_ = np.asarray(active, dtype=bool).reshape(kin.n_segments, -1)
        self.removed_strains_ = removed
        self.kinematics_ = _rec.with_active(kin, self.active_strains_)
        self._set_physical_attributes(kin)
        self.n_features_in_ = kin.n_q
        kept = self.active_strains_.reshape(-1)[kin.active_mask]
        x_final = x if np.all(kept) else np.asarray(design(self.library_, kept), dtype=float)
        final_cols = np.r_[column_map, p_lib + np.arange(act.n_gains)]
        eq = None if equality is None else (equality[0][final_cols], equality[1])
        self.identifiability_ = self._identifiability(
            x_final, np.asarray(target)[:, kept], coef_all[final_cols], eq, offset_info
        )
        q_kept = np.concatenate([r.q[:, kept] for r in recs])
        self.strain_range_ = np.stack([q_kept.min(axis=0), q_kept.max(axis=0)])
        self.input_directions_ = directions
        n_data = sum(r.q.shape[0] for r in recs) if self.formulation == "static" else x_final.shape[0]
        rows = (x_final[:n_data], np.asarray(target)[:n_data][:, kept])
        self._set_training_r2(rows, coef_all[final_cols])
        reduced_act = act
        if full_act is not None:
            full_act.set_identified(_expand_gains(act, full_act, directions), full_act.offsets_)
            self.actuation_ = act = full_act
            if self.identifiability_ is not None:
                self.identifiability_["input_directions"] = directions
        inputs = y_inputs if y_inputs is not None else [np.asarray(r.u, dtype=float) for r in recs]
        u_all = np.concatenate(inputs)
        self.input_range_ = np.stack([u_all.min(axis=0), u_all.max(axis=0)])
        self.__dict__.pop("_forward", None)
        self.refinement_ = None
        if self._refines(act, recs):
            self._refine_output_error(X, recs, kept, inputs)
            gains = reduced_act.gains_ if full_act is None else _reduce_gains(reduced_act, full_act, directions)
            self._set_training_r2(rows, np.r_[self.model_coef_, gains if act.n_gains else []])
        self.mass_matrix_not_pd_fraction_ = 0.0
        if self.check_mass_matrix and self.formulation != "static":  # a static fit leaves the inertia open
            self._check_mass_matrix(q_kept)
        self._check_training_fit(X, given_inputs)
        self.fit_time_ = time.perf_counter() - start
        return self

    @staticmethod
    def _training_data(X: Any, y: Any, t: Any, u: Any, segment_lengths: Any) -> tuple[list[StrainTrajectory], Any]:
        """The recordings and inputs of :meth:`fit`, from either call style."""
        arrays = not (
            isinstance(X, StrainTrajectory)
            or (isinstance(X, (list, tuple)) and len(X) and all(isinstance(r, StrainTrajectory) for r in X))
        )
        if u is not None:
            if y is not None:
                if not arrays or t is not None:
                    raise ValueError(
                        "the inputs were given twice, as y and as u: give them once (y, scikit-learn's name, or u, "
                        "pysindy's)"
                    )
                t = y  # pysindy's positional order: fit(x, t, u=u)
            y = u
        if y is None:
            how = "fit(q, t=dt, u=u, segment_lengths=[...])" if arrays else "fit(X, y)"
            raise ValueError(
                f"the inputs of each recording are required: {how}, the generalised forces (T, 3m) or, with an "
                "actuation, the actuator inputs (T, p)"
            )
        if _rec.spatial_kinematics_of(X) is not None:  # spatial strain trajectories carry their segmentation
            return _rec.as_trajectories(X), y
        return as_strain_trajectories(X, t=t, segment_lengths=segment_lengths), y

    def _fit_choosing_gravity(self, X: list, y: Any, qd: Any, qdd: Any, start: float) -> EulerLagrangeRegressor:
        """Strains fused from marker positions alone: gravity known along the rest direction, or identified.

        Such strains live in a plane fitted to the markers, from a fitted base: how much of gravity lies
        in that plane, and which way it points there, follow only when the robot hangs (or stands) in a
        vertical plane.  Both models are fitted and refined; the one whose rollouts follow the training
        markers better (``refinement_["rmse"]``, training data only) is kept, and ``gravity_choice_``
        says which and why.
        """
        from .library.physical import PhysicalPCSLibrary

        fitted: dict[str, tuple[float, EulerLagrangeRegressor, list]] = {}
        errors: dict[str, str] = {}
        for name, identify in (("known", False), ("identified", True)):
            est = clone(self).set_params(feature_library=PhysicalPCSLibrary(identify_gravity=identify), library=None)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    est.fit(X, y, qd=qd, qdd=qdd)
                except (ValueError, np.linalg.LinAlgError, DivergenceError) as err:
                    errors[name] = f"{type(err).__name__}: {err}"
                    continue
            rmse = (est.refinement_ or {}).get("rmse", np.inf)
            fitted[name] = (float(rmse) if np.isfinite(rmse) else np.inf, est, list(caught))
        if not fitted:
            raise ValueError(f"neither gravity model could be fitted: {errors}")
        best = min(fitted, key=lambda k: fitted[k][0])
        _, est, caught = fitted[best]
        for w in caught:  # the chosen model's own warnings, once
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        self.__dict__.update({k: v for k, v in vars(est).items() if k.endswith("_") and not k.startswith("__")})
        self.__dict__.pop("_forward", None)
        self.gravity_choice_ = {
            "chosen": best,
            "training_rollout_rmse": {k: v[0] for k, v in fitted.items()},
            "failed": errors,
            "reason": "positions-only strains: gravity's direction in the fitted plane is not known; the model "
            "whose output-error rollouts follow the training markers best",
        }
        self.fit_time_ = time.perf_counter() - start
        return self

    def _set_training_r2(self, rows: tuple, coef: NDArray[np.float64]) -> None:
        """``training_r2_`` of the regression rows ``x @ [coef, gains] = known`` (n_rows, n, n_cols)."""
        x, known = rows
        n_lib = self.model_coef_.size
        model = x[..., :n_lib] @ coef[:n_lib]  # Psi @ coef: the model's inverse dynamics
        inputs = known - x[..., n_lib:] @ coef[n_lib:]  # A(q) u: the gain columns hold minus the input forces
        res = np.sum((inputs - model) ** 2, axis=0)
        tot = np.sum((inputs - inputs.mean(axis=0)) ** 2, axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.training_r2_ = np.where(tot > 0, 1.0 - res / tot, np.nan)

    def _check_training_fit(self, X: list[StrainTrajectory], y: Any) -> None:
        """Roll the training recordings out; :class:`PoorFitWarning` when worse than the zero-input prediction."""
        pooled, baseline = self._training_rollouts(X, y)
        if np.isnan(baseline) or pooled <= baseline:
            return
        still = f"the {1e3 * baseline:.3g} mm of the zero-input prediction (the tip held where each rollout starts)"
        what = f"miss the recorded tip by {1e3 * pooled:.3g} mm on average, more than {still}"
        r2 = ", ".join(
            f"{nm} {v:.3g}" for nm, v in zip(self.kinematics_.strain_names(active_only=True), self.training_r2_)
        )
        warnings.warn(
            "the model does not represent its training data: it is worse than a model with no inputs, its open-loop "
            f"rollouts of the training recordings {what if np.isfinite(pooled) else 'diverge, against ' + still}; "
            f"training R^2 per strain equation: {r2}. "
            "Check the actuation layout (tendon sides, ends, drive), the units of the inputs and the segmentation",
            PoorFitWarning,
            stacklevel=3,
        )

    def _training_rollouts(self, X: list[StrainTrajectory], y: Any) -> tuple[float, float]:
        """Pooled mean tip errors [m] of the training rollouts and the zero-input prediction (NaN: none rolled out)."""
        self.training_rollout_error_ = self.no_input_error_ = None
        if not self.check_fit or self.formulation == "static":
            return np.nan, np.nan
        try:
            fm = self.forward_model()
        except (NotImplementedError, AttributeError):  # a library without a forward model
            return np.nan, np.nan
        if fm.default_method not in getattr(fm, "compiled_methods", ()) or not getattr(fm, "compiled_rollouts", True):
            # solve_ivp rollouts (the monomial library) and the NumPy spatial model take seconds to minutes
            return np.nan, np.nan
        try:
            pairs = self._rollout_tips(X, y)
        except (ValueError, np.linalg.LinAlgError):  # the check never makes a fit fail; rollout_error says why
            return np.nan, np.nan
        model = np.array([np.inf if sim is None else np.linalg.norm(sim - true, axis=1).mean() for sim, true in pairs])
        still = np.array([np.linalg.norm(true - true[0], axis=1).mean() for _, true in pairs])
        self.training_rollout_error_, self.no_input_error_ = model, still
        weight = np.array([true.shape[0] for _, true in pairs], dtype=float)
        return float(np.sum(weight * model) / weight.sum()), float(np.sum(weight * still) / weight.sum())

    def _refines(self, act: Actuation, recs: list | None = None) -> bool:
        if self.refine == "none" or self.formulation == "static":
            return False
        if self.refine == "output_error" or act.kind == "learned":
            return True
        # a spatial fit with inputs in physical units (no scale convention, no given mass): refined when its strains
        # are noisy (the equation-error fit regresses their noisy rates); noise-free it is already exact
        # (called before the fit too, without recordings: then only the cases above refine)
        if recs is None or not isinstance(getattr(self, "kinematics_", None), SpatialPCS):
            return False
        from .output_error import strains_are_noisy

        physical = self.scale_convention_ is None and getattr(self.full_library_, "mass", None) is None
        return physical and strains_are_noisy([r.q for r in recs])

    def _refine_output_error(
        self, X: list[StrainTrajectory], recs: list, kept: NDArray[np.bool_], inputs: list[NDArray[np.float64]]
    ) -> None:
        """Output-error refinement of the fitted physical parameters (:mod:`.output_error`)."""
        from .output_error import refine_output_error

        lib = self.library_
        if not hasattr(lib, "lumped_from_coef"):
            raise ValueError(
                f"refine='output_error' needs a library with a compiled forward model (PhysicalPCSLibrary); "
                f"got {type(lib).__name__}: use refine='none'"
            )
        kin = self.kinematics_
        fm = self.forward_model()
        self.__dict__.pop("_forward", None)
        if self.refine == "auto" and not getattr(fm, "compiled_rollouts", True):
            # one rollout of every training recording per refined parameter and step: with an uncompiled forward
            # model (minutes per rollout) not affordable by default; refine="output_error" asks for it anyway
            warnings.warn(
                f"refine='auto' skipped the output-error refinement: {type(fm).__name__} has no "
                "compiled rollouts, so it would take hours; the model is the equation-error fit (refine='output_error' "
                "forces the refinement, refine='none' silences this warning)",
                UserWarning,
                stacklevel=3,
            )
            return
        arcs = [np.asarray(x.metadata.get("marker_arc_lengths", []), dtype=float).reshape(-1) for x in X]
        arc = arcs[0] if arcs[0].size and all(np.array_equal(a, arcs[0]) for a in arcs) else np.zeros(0)
        if not arc.size:
            arc = np.asarray([kin.total_length])
        # 3-D: the markers off the backbone (they see torsion) and, when the capture measured them, the orientations
        offs = [x.metadata.get("marker_offsets") for x in X] if arcs[0].size == arc.size else [None]
        same = all(o is not None and np.array_equal(o, offs[0]) for o in offs)
        oriented = all("rotation_offsets" in x.metadata for x in X)
        rolls = []
        for x, r, u in zip(X, recs, inputs, strict=True):
            # the fusion's per-frame flag of frames whose markers were all seen (interpolated ones are not compared)
            seen = np.asarray(x.metadata.get("measured", x.metadata.get("estimated", [])), dtype=bool)
            valid = seen if seen.shape == (r.q.shape[0],) and seen.any() else np.ones(r.q.shape[0], bool)
            rolls.append((r.t, r.q[:, kept], r.qd[0, kept], u if u.shape[0] == r.t.size else r.u, valid))
        act = self.actuation_
        # no scale convention and no given mass: the inputs are in physical units and determine the densities
        free_density = self.scale_convention_ is None and getattr(self.full_library_, "mass", None) is None
        coef, gains, info = refine_output_error(
            lib,
            self.model_coef_,
            act,
            rolls,
            kin,
            arc,
            (self.input_range_[0], self.input_range_[1]),
            free_density=free_density,
            marker_offsets=np.asarray(offs[0], dtype=float) if same and isinstance(kin, SpatialPCS) else None,
            orientations=oriented and isinstance(kin, SpatialPCS),
        )
        act.set_identified(gains, act.offsets_)
        self.model_coef_ = coef
        self.coef_ = self.coef_.copy()
        self.coef_[self.column_map_] = coef
        self._set_physical_attributes(kin)
        self.refinement_ = info
        self.__dict__.pop("_forward", None)

    @staticmethod
    def _warn_missing_physics(lib: LagrangianLibrary, coef: NDArray[np.float64], optimizer: str) -> None:
        """Warn when a sparsifying optimizer removed a stiffness or left the mass matrix singular."""
        names = lib.kinematics.strain_names(active_only=True)
        stiff = np.asarray(lib.stiffness_from_coef(coef))
        lost = [nm for nm, k in zip(names, stiff) if not k > 0]
        if lost:
            warnings.warn(
                f"{optimizer} removed (or made non-positive) the stiffness of {', '.join(lost)}: an elastic "
                "robot needs every modelled strain's stiffness (a rigid strain is removed with "
                "StiffnessThresholdOptimizer instead); lower the optimizer's threshold or use the default optimizer",
                UserWarning,
                stacklevel=3,
            )
        z = np.zeros((1, lib.n_strains))
        if not np.linalg.eigvalsh(np.asarray(lib.mass_matrix(z, coef), dtype=float))[0, 0] > 0:
            warnings.warn(
                f"{optimizer} removed inertia terms: the mass matrix at the straight pose is singular, so the model "
                "cannot be rolled out; lower the optimizer's threshold or use the default optimizer",
                UserWarning,
                stacklevel=3,
            )

    def _set_physical_attributes(self, kin: PlanarPCS) -> None:
        final = self.active_strains_.reshape(-1)
        lib, coef = self.library_, self.model_coef_
        stiff = np.full(kin.n_q, np.inf)
        stiff[final] = lib.stiffness_from_coef(coef)
        damping = np.zeros(kin.n_q)
        damping[final] = lib.damping_from_coef(coef)
        rest = np.zeros(kin.n_q)
        f0 = lib.rest_force_from_coef(coef)
        with np.errstate(divide="ignore", invalid="ignore"):
            # f0 = K q*; a zero stiffness with a nonzero f0 has no finite rest strain
            rest[final] = np.where(f0 == 0.0, 0.0, f0 / stiff[final])
        self.stiffness_, self.damping_, self.rest_strain_ = stiff, damping, rest

    def _identifiability(
        self,
        x: NDArray[np.float64],
        target: NDArray[np.float64],
        coef: NDArray[np.float64],
        equality: tuple | None,
        offset_info: dict | None,
    ) -> dict | None:
        x2 = x.reshape(-1, x.shape[-1])
        y2 = target.reshape(-1)
        if equality is not None:  # the scale row, as weighted in the fit
            a = np.asarray(equality[0], dtype=float)
            w = 1e6 / np.linalg.norm(a / np.where(np.linalg.norm(x2, axis=0) > 0, np.linalg.norm(x2, axis=0), 1.0))
            x2, y2 = np.vstack([x2, w * a]), np.append(y2, w * equality[1])
        if x2.shape[0] <= x2.shape[1]:
            warnings.warn(
                f"the final regression has {x2.shape[0]} rows for {x2.shape[1]} coefficients: too few to estimate "
                "standard errors (identifiability_ is None); record more data",
                UserWarning,
                stacklevel=3,
            )
            return None
        lib = self.library_
        names = lib.coefficient_names() + list(self.actuation_.gain_names_)
        info = _ident.identifiability(x2, y2, coef, names, tol=self.identifiability_tol)
        info["poorly_excited_strains"] = _ident.strain_excitation(
            info,
            self.kinematics_.strain_names(active_only=True),
            lib.stiffness_index_,
            lib.damping_index_,
            self.identifiability_tol,
        )
        info["coef"] = np.asarray(coef, dtype=float).copy()
        info["formulation"] = self.formulation
        if offset_info is not None:
            info.update(offset_info)
            info["poorly_determined"] += [
                nm
                for nm, r in zip(offset_info["offset_names"], offset_info["offset_relative_standard_errors"])
                if not r <= self.identifiability_tol
            ]
        return info

    def _check_mass_matrix(self, q: NDArray[np.float64]) -> None:
        eig = np.linalg.eigvalsh(self.library_.mass_matrix(q, self.model_coef_))
        frac = float(np.mean(~(eig[:, 0] > 0)))
        self.mass_matrix_not_pd_fraction_ = frac
        if frac > 0:
            bounded = getattr(self.library_, "lower_bounds_", None) is not None and getattr(
                self.optimizer_, "bounded", False
            )
            if bounded and self.formulation == "weak":  # the default's bounds hold: an inertia was fitted to 0
                advice = (
                    "the fit set a line density or rotary inertia to its bound 0, so the data do not support any "
                    "inertia: check the actuation layout (tendon sides, ends, drive) and the units of the inputs, "
                    "or give the robot's mass (PhysicalPCSLibrary(mass=...))"
                )
            else:
                advice = (
                    "use more or cleaner data, or the default EulerLagrangeRegressor() (physical library, bounded "
                    "fit: positive definite unless an inertia is fitted to 0; weak form: no second derivatives)"
                )
            warnings.warn(
                f"the identified mass matrix is not positive definite on {frac:.1%} of the training samples "
                f"(smallest eigenvalue {eig[:, 0].min():.3g}); a rollout will likely diverge: {advice}",
                UserWarning,
                stacklevel=3,
            )

    def identifiability_report(self) -> str:
        """Readable summary of :attr:`identifiability_`: one line per coefficient, then the flags."""
        check_is_fitted(self, "identifiability_")
        text = _ident.report(self.identifiability_, self.identifiability_tol, self._coefficient_unit_names())
        conv = getattr(self, "scale_convention_", None)
        if conv:
            text = f"scale convention: {conv}\n" + text
        dirs = getattr(self, "input_directions_", None)
        if dirs is not None and dirs.shape[1] < dirs.shape[0]:
            text += (
                f"\nonly {dirs.shape[1]} of {dirs.shape[0]} inputs varied (input_directions_): the gains a_*_u<i> "
                "above number the varying inputs; actuation_ holds them per input (zero for a constant one)"
            )
        reasons = getattr(self, "removal_reasons_", None) or {}
        if reasons:
            text += "\nremoved strains (held at 0): " + "; ".join(f"{nm}: {why}" for nm, why in reasons.items())
        ref = getattr(self, "refinement_", None)
        if ref:
            text += (
                "\noutput-error refinement (the values above are the equation-error fit; equations() shows the "
                "refined model): training marker RMSE "
                + (f"{1e3 * ref['rmse_start']:.3g}" if np.isfinite(ref["rmse_start"]) else "diverged")
                + f" -> {1e3 * ref['rmse']:.3g} mm in {ref['nfev']} evaluations"
                + ("" if ref["slope_factor"] == 1.0 else f"; input-stiffness terms shrunk x{ref['slope_factor']:.3g}")
            )
        return text

    def _coefficient_unit_names(self) -> dict[str, str]:
        """Units of the library's coefficients and the actuation's gains, by name (for printouts)."""
        lib = self.full_library_
        out = {nm: ("-" if u is None else str(u)) for nm, u in zip(lib.coefficient_names(), lib.coefficient_units())}
        act = getattr(self, "actuation_", None)
        strains = self.kinematics_.strain_names(active_only=False)
        for nm in getattr(act, "gain_names_", None) or []:
            out.setdefault(nm, gain_unit(nm, strains))
        return out

    # ------------------------------------------------------------------ the identified model
    def _model_q(self, q: ArrayLike, name: str = "q") -> NDArray[np.float64]:
        """Modelled strains from full (..., 3m) or already reduced (..., n_active) input."""
        check_is_fitted(self, "coef_")
        return reduce_strains(self.kinematics_, q, name)

    @staticmethod
    def _batch(fn: Callable, *arrays: NDArray[np.float64]) -> NDArray[np.float64]:
        lead = arrays[0].shape[:-1]
        flat = [a.reshape(-1, a.shape[-1]) for a in arrays]
        out = np.asarray(fn(*flat), dtype=float)
        return out.reshape(lead + out.shape[1:])

    def forward_model(self) -> Any:
        """The identified model's :class:`~pcs_sindy.models.forward.ForwardModel` (built once, cached)."""
        check_is_fitted(self, "coef_")
        fm = self.__dict__.get("_forward")
        if fm is None:
            act = getattr(self, "actuation_", None)
            fm = self.library_.forward_model(
                self.model_coef_, actuation=None if isinstance(act, IdentityActuation) else act
            )
            self.__dict__["_forward"] = fm
        return fm

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        state.pop("_forward", None)  # compiled kernels are rebuilt on demand
        return state

    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """Identified ``M(q)`` over the modelled strains, shape (..., n, n) (``q``: all or modelled strains)."""
        qa = self._model_q(q)
        return self._batch(lambda a: self.library_.mass_matrix(a, self.model_coef_), qa)

    def bias_forces(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """``C(q, qd) qd + G(q) + K q + D qd - f0`` of the identified model, shape (..., n)."""
        qa, qda = self._model_q(q), self._model_q(qd, "qd")
        if qa.shape != qda.shape:
            raise ValueError(f"q and qd must have the same shape; got {qa.shape} and {qda.shape}")
        return self._batch(lambda a, b: self.library_.bias_forces(a, b, self.model_coef_), qa, qda)

    def potential_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """``G(q) + K q - f0`` of the identified model, shape (..., n)."""
        qa = self._model_q(q)
        return self._batch(lambda a: self.library_.potential_forces(a, self.model_coef_), qa)

    def predict(
        self,
        X: Sequence[StrainTrajectory],
        *,
        qd: Sequence[ArrayLike] | None = None,
        qdd: Sequence[ArrayLike] | None = None,
    ) -> RecordingList:
        """Forces ``tau_hat = Psi(q, qd, qdd) coef`` (inverse dynamics) per recording.

        Rates and accelerations come from ``qd``/``qdd`` or from this
        estimator's differentiation settings.

        Returns
        -------
        RecordingList of ndarray, shape (T, 3m)
            Forces on the modelled strains; 0 in the columns of strains that
            are not modelled (the model has no equation for a rigid strain).
            A list with one array per recording; ``np.asarray`` of it stacks
            the recordings (what scikit-learn's string scorers compare).
        """
        check_is_fitted(self, "coef_")
        validate_parameters(self)
        self._check_joint_parameters()
        X = _rec.as_trajectories(X)
        dummy = [np.zeros((r.n_frames, self.kinematics_.n_q)) for r in X]
        kin, _, recs = self._recordings(X, dummy, qd, qdd, kin=self.kinematics_, formulation="strong")
        out = []
        for k, r in enumerate(recs):
            psi = np.asarray(self.library_.euler_lagrange_matrix(r.q, r.qd, r.qdd), dtype=float)
            tau = np.zeros((r.q.shape[0], kin.n_q))
            tau[:, kin.active_mask] = psi @ self.model_coef_
            if not np.all(np.isfinite(tau)):
                raise ValueError(f"the model predicts NaN or inf forces on X[{k}]")
            out.append(tau)
        return RecordingList(out)

    def score(
        self, X: Sequence[StrainTrajectory], y: Sequence[ArrayLike], sample_weight: ArrayLike | None = None
    ) -> float:
        """R^2 of the forces :meth:`predict` returns, the recordings flattened (scikit-learn's ``score``).

        ``r2_score(np.asarray(RecordingList(y)), np.asarray(self.predict(X)))``:
        the same number as ``cross_val_score(..., scoring="r2")``, averaged
        uniformly over the strains (a strain that is not modelled is predicted
        as 0).  It measures how well the identified model explains the recorded
        forces sample by sample (inverse dynamics, with this estimator's rates
        and accelerations); to judge a model by what it is for, its rollouts,
        use :meth:`rollout_score` or :func:`pcs_sindy.core.metrics.rollout_scorer`
        (the scorer for model selection: ``GridSearchCV(..., scoring=rollout_scorer)``).

        Parameters
        ----------
        X : list of StrainTrajectory
        y : list of array_like, shape (T, 3m)
            Generalised forces of each recording (``RecordingList`` or a plain list);
            with an actuation, the actuator inputs (T, p), mapped to forces by the
            identified ``A(q)``.
        sample_weight : array_like, shape (sum T,), optional
            Weights of the flattened samples.
        """
        check_is_fitted(self, "coef_")
        X = _rec.as_trajectories(X)
        ys = _rec.check_list(y, len(X), "y")
        act = getattr(self, "actuation_", None)
        if act is not None and not isinstance(act, IdentityActuation):
            # y holds actuator inputs: the recorded forces are A(q) u of the identified input map
            mask = act.kinematics_.active_mask
            forces = []
            for k, (rec, u) in enumerate(zip(X, ys, strict=True)):
                u = act.check_inputs(u, f"y[{k}]")
                if u.shape[0] != rec.n_frames:
                    raise ValueError(f"y[{k}] has {u.shape[0]} samples but X[{k}] has {rec.n_frames}")
                full = np.zeros((rec.n_frames, rec.kinematics.n_q))
                full[:, mask] = act.forces(rec.q[:, mask], u)
                forces.append(full)
            ys = forces
        truth = np.concatenate([np.asarray(a, dtype=float) for a in ys])
        pred = np.asarray(self.predict(X))
        if truth.shape != pred.shape:
            raise ValueError(
                f"y must hold the forces of X, stacked shape {pred.shape} (one (T, 3m) array per recording); "
                f"got stacked shape {truth.shape}"
            )
        return float(r2_score(truth, pred, sample_weight=sample_weight))

    def rollout_score(self, X: Sequence[StrainTrajectory], y: Sequence[ArrayLike]) -> float:
        """R^2 of the tip positions of rollouts of the recordings ``X`` under their forces ``y``.

        Each recording is rolled out from its measured state (as in
        :meth:`rollout_error`) and the tip path (x, y) compared with the
        recording's own: ``1 - SS_res / SS_tot``, pooled over recordings and
        samples, ``SS_tot`` about the mean tip position.  The targets are the
        recordings themselves, so every candidate of a search is scored on the
        same numbers whatever its settings, and every strain counts: a strain
        removed as rigid is predicted by the reduced model (held at 0).  A
        diverged rollout scores ``-inf`` (never NaN).  (In 0.1.0 this was
        :meth:`score`.)

        Raises
        ------
        ValueError
            When the tip does not move in ``X`` (R^2 undefined).
        """
        check_is_fitted(self, "coef_")
        pairs = self._rollout_tips(X, y)
        truth = np.concatenate([true for _, true in pairs])
        ss_tot = float(np.sum((truth - truth.mean(axis=0)) ** 2))
        if not ss_tot > 1e-12 * float(np.sum(truth**2)):
            raise ValueError("the tip does not move in X; the R^2 of its path is undefined")
        if any(sim is None for sim, _ in pairs):
            return -np.inf
        ss_res = float(sum(np.sum((sim - true) ** 2) for sim, true in pairs))
        return 1.0 - ss_res / ss_tot

    def _rollout_tips(
        self, X: Sequence[StrainTrajectory], y: Sequence[ArrayLike], **simulate_kwargs: Any
    ) -> list[tuple[NDArray[np.float64] | None, NDArray[np.float64]]]:
        """Per recording: the rolled-out and the recorded tip positions (T', 2); None for a diverged rollout."""
        check_is_fitted(self, "coef_")
        X = _rec.as_trajectories(X)
        ys = _rec.check_list(y, len(X), "y")
        out = []
        for k, rec in enumerate(X):
            tau = np.asarray(ys[k], dtype=float)
            act = getattr(self, "actuation_", None)
            if act is not None and not isinstance(act, IdentityActuation):
                tau = act.check_inputs(tau, f"y[{k}]")
                if tau.shape[0] != rec.n_frames:
                    raise ValueError(f"y[{k}] has {tau.shape[0]} samples but X[{k}] has {rec.n_frames}")
            elif tau.shape != rec.q.shape or not np.all(np.isfinite(tau)):
                raise ValueError(f"y[{k}] must be finite with the shape of X[{k}].q {rec.q.shape}; got {tau.shape}")
            # start where the fixed Savitzky-Golay estimate of the rate is centred, not at the edge
            k0 = 0 if rec.qd is not None else min(SCORE_DERIVATIVES[0] // 2, rec.n_frames - 2)
            qd = rec.qd if rec.qd is not None else self._derivatives(rec, k, None, None, fixed=True)[0]
            s = np.asarray([rec.kinematics.total_length])
            true = self._tip_path(rec.kinematics, rec.q[k0:], s)
            try:
                sim = self.simulate(rec.q[k0], qd[k0], rec.t[k0:], tau[k0:], **simulate_kwargs)
            except DivergenceError:
                out.append((None, true))
                continue
            # the recording's frame (fused strains carry their base pose; the model's kinematics do not)
            out.append((self._tip_path(rec.kinematics, sim.q, s), true))
        return out

    @staticmethod
    def _tip_path(kin: Any, q: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Tip positions (T, 2) in the plane, or (T, 3) for a spatial segmentation."""
        if isinstance(kin, SpatialPCS):
            return kin.forward_kinematics(q, s)[0][:, 0, :]
        return kin.forward_kinematics(q, s)[:, 0, :2]

    # ------------------------------------------------------------------ forward dynamics
    def simulate(
        self,
        q0: ArrayLike,
        qd0: ArrayLike | None = None,
        t: ArrayLike | None = None,
        u: ArrayLike | Callable[[float], ArrayLike] | None = None,
        *,
        tau: ArrayLike | Callable[[float], ArrayLike] | None = None,
        method: str | None = None,
        rtol: float | None = None,
        atol: float | None = None,
        step: float | None = None,
        max_step: float | None = None,
        max_abs_state: float = 1e6,
        progress: bool | None = None,
        stats: dict | None = None,
    ) -> StrainTrajectory:
        """Roll the identified model out under the input ``u``: the contract of :mod:`pcs_sindy.core.simulate_contract`.

        Also callable the pysindy way, ``simulate(x0, t, u)`` with the state
        ``x0 = [q0, qd0]`` (shape (6m,) or (2n,)): without ``qd0``, or with
        three positional arguments and no ``u`` when ``x0`` is not itself the
        size of a ``q0`` (``x0`` of all strains, (6m,), is never).

        Parameters
        ----------
        q0, qd0 : array_like, shape (3m,) or (n,)
            Initial strains and rates (all strains, unmodelled ones ignored, or the modelled ones).
        t : array_like, shape (T,)
            Output times (strictly increasing).
        u : array_like, shape (T, 3m), or callable
            Generalised forces held constant on ``[t[k], t[k+1])``, or ``u(time)``
            returning (3m,).  Columns of unmodelled strains are ignored.
        tau : deprecated
            Former name of ``u`` (FutureWarning).  The former argument order
            ``simulate(q0, qd0, tau, t)`` also still works with a FutureWarning.
        method : str, optional
            Integration scheme (see the forward model's ``methods``); default
            the model's best measured one (``"rosenbrock"`` for the physical
            library: L-stable Rosenbrock-W, compiled; ``"radau"`` via solve_ivp
            for the monomial library).
        rtol, atol : float, optional
            Tolerances (default: the estimator's).
        step : float, optional
            Fixed step of the compiled schemes (must divide every sample period).
        max_step : float, optional
            Bound on the adaptive step.
        max_abs_state : float
            A strain or rate larger than this in magnitude means divergence.
        progress : bool, optional
            Progress bar (default: the estimator's ``progress``).
        stats : dict, optional
            Filled with step counts (compiled schemes).

        Returns
        -------
        StrainTrajectory
            Full strains ``q`` and rates ``qd`` (T, 3m) of the segmentation; strains
            that are not modelled stay 0.  ``np.asarray`` of it is the state ``[q, qd]``
            (T, 6m), pysindy's ``simulate`` result (the same type from every ``simulate``
            of the package, :class:`~pcs_sindy.identification.WeakEulerLagrangeSINDy`'s included).

        Raises
        ------
        SimulationError
            (also importable as ``DivergenceError``) if the state becomes
            non-finite or unbounded, ``M(q)`` singular or the step collapses.
        """
        check_is_fitted(self, "coef_")
        q_sizes = (self.kinematics_.n_q, self.kinematics_.n_active)
        if qd0 is None or (u is None and tau is None and t is not None and np.size(q0) not in q_sizes):
            if qd0 is not None:  # simulate(x0, t, u): shift the positional arguments
                t, u = qd0, t
            q0, qd0 = self._split_state(q0)
        t, u = simulate_inputs(t, u, tau)
        if u is not None and not callable(u):
            self._warn_input_range(u)
        return self.forward_model().simulate(
            q0,
            qd0,
            t,
            u,
            method=method,
            rtol=self.rtol if rtol is None else rtol,
            atol=self.atol if atol is None else atol,
            step=step,
            max_step=max_step,
            max_abs_state=max_abs_state,
            progress=self.progress if progress is None else progress,
            stats=stats,
        )

    def equilibrium(self, u: ArrayLike, q0: ArrayLike | None = None, **kwargs: Any) -> NDArray[np.float64]:
        """The strains the identified model rests at under constant inputs (forward statics).

        Parameters
        ----------
        u : array_like, shape (p,) or (B, p)
            Constant inputs (actuator inputs, or generalised forces (3m,) without
            actuation); several rows give one equilibrium each, each solve
            starting from the previous one (order a load sweep by load).
        q0 : array_like, shape (3m,) or (n,), optional
            Starting guess (default: the straight robot).
        **kwargs
            ``tol``, ``n_continuation``, ``progress`` of
            :meth:`pcs_sindy.models.ForwardModel.equilibrium`.

        Returns
        -------
        ndarray, shape (3m,) or (B, 3m)
            All strains of the segmentation at rest (unmodelled ones 0): what
            :func:`pcs_sindy.core.forward_kinematics` turns into the shape.

        Raises
        ------
        SimulationError
            When no equilibrium is found.
        """
        check_is_fitted(self, "coef_")
        self._warn_input_range(u)
        q = self.forward_model().equilibrium(u, q0, **kwargs)
        return self.kinematics_.to_full(q)

    def _warn_input_range(self, u: ArrayLike) -> None:
        """Warn, naming the inputs and their values, when ``u`` leaves the training range (``input_range_``)."""
        rng = getattr(self, "input_range_", None)
        if isinstance(getattr(self, "actuation_", None), IdentityActuation):
            # generalised forces act on a passive model whatever their size: only an input map (whose
            # stiffness-under-input margin holds over the training box) makes the range a stability matter
            return
        arr = np.asarray(u, dtype=float)
        if rng is None or arr.ndim == 0 or arr.shape[-1] != rng.shape[1]:
            return
        arr = arr.reshape(-1, rng.shape[1])
        lo, hi = rng
        tol = np.maximum(INPUT_RANGE_TOL * (hi - lo), 1e-9)
        with np.errstate(invalid="ignore"):
            below, above = arr.min(axis=0) < lo - tol, arr.max(axis=0) > hi + tol
        bad = np.flatnonzero(below | above)
        if bad.size:
            parts = [
                f"input {k} (column {k}) reaches {arr[:, k].min() if below[k] else arr[:, k].max():.4g}, "
                f"trained on [{lo[k]:.4g}, {hi[k]:.4g}]"
                for k in bad
            ]
            warnings.warn(
                "inputs outside the range the model was identified on (its stability and accuracy hold only "
                "inside it): " + "; ".join(parts),
                UserWarning,
                stacklevel=3,
            )

    def _split_state(self, x0: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``[q0, qd0]`` of pysindy's ``simulate(x0, t, u)`` -> ``(q0, qd0)``."""
        x = np.asarray(x0, dtype=float)
        sizes = {2 * self.kinematics_.n_q, 2 * self.kinematics_.n_active}
        if x.ndim != 1 or x.size not in sizes:
            raise ValueError(
                f"x0 must be the state [q0, qd0] of shape ({2 * self.kinematics_.n_q},) (all strains) or "
                f"({2 * self.kinematics_.n_active},) (the modelled ones) in simulate(x0, t, u); got shape {x.shape}. "
                "Or call simulate(q0, qd0, t, u)"
            )
        half = x.size // 2
        return x[:half], x[half:]

    def rollout_error(self, X: Sequence[StrainTrajectory], y: Sequence[ArrayLike], **simulate_kwargs: Any) -> NDArray:
        """Mean tip position error ``e_p^EE`` (m) of rolling each recording out from a measured state under ``y``.

        The rollout starts at the first sample where the Savitzky–Golay rate of
        :data:`SCORE_DERIVATIVES` is centred (sample 3), or at sample 0 when
        ``X[k].qd`` is known.  A diverged rollout counts as ``inf``.

        Returns
        -------
        ndarray, shape (n_recordings,)
        """
        pairs = self._rollout_tips(X, y, **simulate_kwargs)
        return np.array(
            [np.inf if sim is None else float(np.linalg.norm(sim - true, axis=1).mean()) for sim, true in pairs]
        )

    # ------------------------------------------------------------------ text and pysindy
    def equations(self, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """The identified model as text (the library's own format; the last line starts ``D = diag(``).

        Parameters
        ----------
        precision : int
            Significant digits of the coefficients.
        threshold : float
            Terms with ``|coefficient| <= threshold`` are hidden (exact zeros always are).

        Returns
        -------
        list of str
        """
        check_is_fitted(self, "coef_")
        lines = self.library_.equations(self.model_coef_, precision=precision, threshold=threshold)
        act = getattr(self, "actuation_", None)
        if act is None or isinstance(act, IdentityActuation):
            return lines
        return lines[:-1] + act.describe(precision) + lines[-1:]

    def print(
        self,
        lhs: Sequence[str] | None = None,
        precision: int = 3,
        threshold: float = 0.0,
        *,
        by_strain: bool = False,
        **kwargs: Any,
    ) -> None:
        """Print the identified model; with ``lhs`` (pysindy's ``print``), one line per strain equation.

        Parameters
        ----------
        lhs : list of str, optional
            Names of the left-hand sides, one per modelled strain (pysindy's meaning): prints
            ``lhs[i] = <right-hand side of strain i>`` (:meth:`strain_equations`).  Without it,
            :meth:`equations`: the library's own format (Lagrangian, parameters, damping).
        precision : int
            Significant digits.
        threshold : float
            Terms with ``|coefficient| <= threshold`` are hidden.
        by_strain : bool
            One ``tau_<strain> = ...`` line per modelled strain (``lhs`` of those names).
        **kwargs
            Passed to the builtin ``print`` (e.g. ``file=``).
        """
        check_is_fitted(self, "coef_")
        if lhs is not None or by_strain:
            strains = self.kinematics_.strain_names(active_only=True)
            if lhs is None:
                from ..core.units import generalised_force_unit

                names = [f"tau_{nm} [{generalised_force_unit(nm)}]" for nm in strains]
            else:
                names = lhs
            if isinstance(names, str) or not isinstance(names, Sequence) or len(names) != len(strains):
                raise ValueError(
                    f"lhs must be a list of {len(strains)} names, one per modelled strain {strains} "
                    f"(precision is the second argument); got {lhs!r}"
                )
            for name, rhs in zip(names, self.strain_equations(precision=precision, threshold=threshold), strict=True):
                print(f"{name} = {rhs}", **kwargs)
            return
        for line in self.equations(precision=precision, threshold=threshold):
            print(line, **kwargs)

    # pysindy's idioms: coefficients(), get_feature_names(), one equation per coordinate
    def coefficients(self) -> NDArray[np.float64]:
        """The coefficients as pysindy's ``SINDy.coefficients()``: one row per strain equation.

        Row ``i`` holds the coefficients of the terms that enter the equation of the ``i``-th
        modelled strain (``kinematics_.strain_names(active_only=True)``, the lines of
        :meth:`strain_equations` and ``print(lhs=...)``) and 0 for the columns that do not act on
        it.  The columns are those of :meth:`get_feature_names_out` (the full library's
        coefficients, ``coef_``): one physical coefficient (a segment's line density, say)
        enters several equations, so its value repeats down its column: every nonzero entry of
        column ``j`` is ``coef_[j]``.

        Returns
        -------
        ndarray, shape (n, n_features)
        """
        check_is_fitted(self, "coef_")
        acts = np.zeros((self.kinematics_.n_active, self.coef_.size), dtype=bool)
        acts[:, np.asarray(self.column_map_, dtype=int)] = self._equation_terms()
        return np.where(acts, self.coef_[None, :], 0.0)

    def get_feature_names(self) -> list[str]:
        """Names of the columns of :meth:`coefficients` (the full library's coefficient names)."""
        check_is_fitted(self, "coef_")
        return list(self.full_library_.coefficient_names())

    def get_feature_names_out(self, input_features: Any = None) -> NDArray[np.object_]:
        """Names of the columns of :meth:`coefficients`, as scikit-learn's ``get_feature_names_out``.

        Parameters
        ----------
        input_features : None
            scikit-learn's argument; the names are the library's coefficients, whatever the
            inputs are called, so it must be None.

        Returns
        -------
        ndarray of str (object dtype), shape (n_features,)
        """
        if input_features is not None:
            raise ValueError(
                "input_features must be None: the columns are the library's coefficients (e.g. rhoA_1, k_be_1), "
                f"named by the library; got {input_features!r}"
            )
        return np.asarray(self.get_feature_names(), dtype=object)

    def _equation_terms(self) -> NDArray[np.bool_]:
        """Which columns of ``library_`` act on which modelled strain's equation, shape (n, n_columns).

        Read off ``Psi`` at random states inside the training range: a column that acts on an
        equation is nonzero there at almost every state.
        """
        lib = self.library_
        n = lib.n_strains
        rng = np.random.default_rng(0)
        lo, hi = self.strain_range_ if getattr(self, "strain_range_", None) is not None else (-np.ones(n), np.ones(n))
        q = rng.uniform(lo, hi, (4, n)) + 1e-3 * rng.standard_normal((4, n))
        psi = np.asarray(lib.euler_lagrange_matrix(q, rng.standard_normal((4, n)), rng.standard_normal((4, n))))
        return np.any(psi != 0, axis=0)

    def strain_equations(self, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """Right-hand sides of ``tau_e = ...``, one per modelled strain (pysindy's ``equations()`` form).

        Every coefficient carries its unit in brackets (:meth:`LagrangianLibrary.coefficient_units`).
        A stiffness reads ``k e`` (the strain), a damping ``d de/dt``, a constant
        force ``- f0``; every other column ``c EL[name]``, the Euler–Lagrange
        image ``d/dt dL/d(de/dt) - dL/de`` of the Lagrangian term ``name``
        (e.g. ``EL[rhoA_1]``: kinetic and gravitational terms of segment 1's line density).
        Only the terms that act on the strain's equation are listed.

        Parameters
        ----------
        precision : int
            Significant digits.
        threshold : float
            Terms with ``|coefficient| <= threshold`` are hidden (exact zeros always are).

        Returns
        -------
        list of str
        """
        check_is_fitted(self, "coef_")
        lib, coef = self.library_, self.model_coef_
        n = lib.n_strains
        strains = self.kinematics_.strain_names(active_only=True)
        names = lib.coefficient_names()
        acts = self._equation_terms()  # (n, n_psi)
        kind = {int(j): ("k", e) for e, j in enumerate(np.asarray(lib.stiffness_index_))}
        kind.update({int(j): ("d", e) for e, j in enumerate(np.asarray(lib.damping_index_))})
        rest = np.asarray(lib.rest_force_index_)
        kind.update({int(j): ("f0", int(r)) for j, r in zip(rest, np.asarray(lib.rest_force_rows_))})
        factor = float(lib.stiffness_factor_)
        units = lib.coefficient_units()
        out = []
        for e in range(n):
            terms = []
            for j in np.flatnonzero(acts[e]):
                c = float(coef[j])
                kd = kind.get(int(j))
                if kd is not None and kd[0] == "k":
                    c, label = c * factor, strains[kd[1]]
                elif kd is not None and kd[0] == "d":
                    label = f"d{strains[kd[1]]}/dt"
                elif kd is not None and kd[0] == "f0":
                    c, label = -c, "1"
                else:
                    label = f"EL[{names[j]}]"
                if c == 0.0 or abs(c) <= threshold:
                    continue
                unit = "" if units[j] is None or str(units[j]) in ("", "1", "-") else f" [{units[j]}]"
                terms.append(f"{c:.{precision}g}{unit}" + ("" if label == "1" else f" {label}"))
            out.append(" + ".join(terms).replace("+ -", "- ") if terms else "0")
        return out

    @classmethod
    def from_sindy(cls, model: Any) -> EulerLagrangeRegressor:
        """A fitted regressor from a ``pysindy.SINDy`` fit of the stacked Euler–Lagrange form.

        Parameters
        ----------
        model : pysindy.SINDy
            Fitted with ``feature_library=StackedEulerLagrangeLibrary(library)``
            (states ``[q, qd, qdd]``, forces as ``x_dot``).

        Returns
        -------
        EulerLagrangeRegressor
            With ``coef_`` the SINDy coefficients, no strain removed; it rolls
            out (:meth:`simulate`), predicts and prints like any fitted regressor.
        """
        from .library.stacked import StackedEulerLagrangeLibrary

        feat = getattr(model, "feature_library", None)
        if not isinstance(feat, StackedEulerLagrangeLibrary) or not hasattr(model, "optimizer"):
            raise ValueError(
                "model must be a pysindy.SINDy fitted with feature_library=StackedEulerLagrangeLibrary(library); "
                f"got {type(model).__name__} with feature_library {type(feat).__name__}"
            )
        coef = np.asarray(model.coefficients(), dtype=float)
        lib = feat.library
        if coef.shape != (1, lib.n_coefficients_):
            raise ValueError(f"model.coefficients() must have shape (1, {lib.n_coefficients_}); got {coef.shape}")
        reg = cls(feature_library=lib, optimizer=model.optimizer)
        kin = lib.kinematics
        reg.optimizer_ = model.optimizer
        reg.full_library_ = reg.library_ = lib
        reg.column_map_ = np.arange(lib.n_coefficients_)
        reg.coef_ = reg.model_coef_ = coef[0].copy()
        reg.active_strains_ = kin.active_strains.copy()
        reg.removed_strains_ = []
        reg.removal_reasons_ = {}
        reg.excitation_ = np.full(kin.n_q, np.nan)
        reg.kinematics_ = PlanarPCS(kin.segment_lengths, kin.active_strains, kin.base_pose)
        reg._set_physical_attributes(kin)
        reg.actuation_ = IdentityActuation().fit(PlanarPCS(kin.segment_lengths, kin.active_strains))
        reg.n_features_in_ = kin.n_q
        reg.identifiability_ = None
        reg.mass_matrix_not_pd_fraction_ = 0.0
        reg.n_regression_samples_ = 0
        reg.training_r2_ = np.full(kin.n_active, np.nan)
        reg.training_rollout_error_ = reg.no_input_error_ = None
        reg.fit_time_ = 0.0
        return reg

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # samples are recordings (lists of trajectories), not rows of a 2-D array
        tags.input_tags.two_d_array = False
        tags.target_tags.required = True
        tags.target_tags.single_output = False
        tags.target_tags.multi_output = True
        return tags
