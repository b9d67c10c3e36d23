"""The contract every Lagrangian library of the Euler–Lagrange regression implements.

A library describes the generalised forces of a planar PCS model as linear in
its coefficients ``c``:

    tau = Psi(q, qd, qdd) @ c,        Psi = d/dt P(q, qd) + R(q, qd)

with the momentum part ``P`` (``dL/dqd`` of each basis term, and ``q`` for a
damping column) and the rest ``R`` (``-dL/dq``).  From that one structure come

* strong-form rows ``Psi`` (:meth:`LagrangianLibrary.euler_lagrange_matrix`),
* weak-form rows, from ``(P, R)`` (:meth:`LagrangianLibrary.weak_terms`, integrated
  against a test function by :func:`pcs_sindy.identification.formulations.weak_rows`),
* the model of given coefficients: ``M(q)``, the bias forces and a compiled
  :class:`~pcs_sindy.models.forward.ForwardModel` (:meth:`LagrangianLibrary.forward_model`)
  that rollouts and controllers call,
* its own printout (:meth:`LagrangianLibrary.equations`), every value with its unit
  (:meth:`LagrangianLibrary.coefficient_units`, from :mod:`pcs_sindy.core.units`),
* the library of fewer strains for sparsification (:meth:`LagrangianLibrary.restrict`).

The segmentation (segment lengths and modelled strains) is set by ``fit`` from
the strain trajectories, or given to the constructor for direct use on arrays.
All ``q``, ``qd``, ``qdd`` arguments hold the *active* strains only.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.feature_library.base import BaseFeatureLibrary
from scipy import sparse
from sklearn.exceptions import NotFittedError
from sklearn.utils import check_array

from ...core.kinematics import PlanarPCS
from ...core.trajectory import kinematics_of
from ...core.units import STRAIN_UNITS, Unit, generalised_force_unit, strain_rate_unit, strain_unit
from ...core.validation import Check, InvalidParameterError, validate_parameters

__all__ = ["LagrangianLibrary"]


def _lengths_ok(value: Any) -> bool:
    lengths = np.atleast_1d(np.asarray(value, dtype=float))
    return lengths.ndim == 1 and lengths.size > 0 and bool(np.all(np.isfinite(lengths)) and np.all(lengths > 0))


def _mask_ok(value: Any) -> bool:
    raw = np.asarray(value)
    shaped = (raw.ndim == 2 and raw.shape[0] >= 1 and raw.shape[1] == 3) or (
        raw.ndim == 1 and raw.size >= 3 and raw.size % 3 == 0
    )
    return shaped and (raw.dtype == bool or bool(np.all(np.isin(raw, (0, 1)))))


class LagrangianLibrary(BaseFeatureLibrary, ABC):
    """Abstract base of the Lagrangian libraries (the contract of the regression).

    Subclasses store their constructor arguments unchanged, with at least
    ``segment_lengths`` and ``active_strains`` (both may be None until ``fit``).

    Attributes
    ----------
    segmentation_ : PlanarPCS
        Set by :meth:`fit` on strain trajectories: their segment lengths and modelled strains.
    n_coefficients_ : int
        Columns of ``Psi`` (Lagrangian terms, optional constant forces, damping last).
    stiffness_index_, damping_index_ : ndarray of int, shape (n,)
        Column of each active strain's stiffness (in units of ``stiffness_factor_``) and damping.
    rest_force_index_ : ndarray of int, shape (n,) or (0,)
        Column of each active strain's constant force, if the library has them.
    lower_bounds_ : ndarray or None
        Lower bounds of the coefficients for a bounded fit, or None (unbounded).
    stiffness_factor_ : float
        Stiffness of strain e = ``stiffness_factor_ * coef[stiffness_index_[e]]``.
    """

    stiffness_factor_: float = 1.0

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Refuse sparse input to a subclass's ``transform`` with scikit-learn's message.

        pysindy's ``x_sequence_or_item`` (which the subclasses' ``transform`` use)
        fails on a sparse matrix with an unrelated error before the method runs.
        """
        super().__init_subclass__(**kwargs)
        inner = cls.__dict__.get("transform")
        if inner is None:
            return

        @functools.wraps(inner)
        def transform(self: Any, x: Any, *args: Any, **kw: Any) -> Any:
            items = x if isinstance(x, (list, tuple)) else [x]
            for item in items:
                if sparse.issparse(item):
                    check_array(item, input_name="x")  # raises: dense data is required
            return inner(self, x, *args, **kw)

        cls.transform = transform

    # ------------------------------------------------------------------ segmentation
    @property
    def kinematics(self) -> PlanarPCS:
        """The segmentation this library describes (fitted, else the constructor's)."""
        fitted = self.__dict__.get("segmentation_")
        if fitted is not None:
            return fitted
        lengths = self.segment_lengths
        if lengths is None:
            raise NotFittedError(
                f"{type(self).__name__} has no segmentation yet: fit it on strain trajectories "
                "(StrainTrajectory carries the segment lengths) or give segment_lengths"
            )
        return PlanarPCS(tuple(np.atleast_1d(np.asarray(lengths, dtype=float))), active_strains=self.active_strains)

    #: the segmentation every library takes; subclasses add their own parameters
    #: (``{**LagrangianLibrary._parameter_constraints, ...}``), read by validate_parameters
    _parameter_constraints: dict = {
        "segment_lengths": [None, Check(_lengths_ok, "a non-empty 1-D sequence of finite lengths > 0 [m]")],
        "active_strains": [None, Check(_mask_ok, "booleans (or 0/1) of shape (m, 3) or (3m,)")],
    }

    def _check_segmentation(self) -> None:
        """What the table cannot say: one row of ``active_strains`` per segment of ``segment_lengths``."""
        lengths, mask = self.segment_lengths, self.active_strains
        if lengths is None or mask is None:
            return
        m = np.atleast_1d(np.asarray(lengths, dtype=float)).size
        if np.shape(mask) not in ((m, 3), (3 * m,)):
            want = f"of shape ({m}, 3) or ({3 * m},) for the {m} segment(s) of segment_lengths"
            raise InvalidParameterError.of(self, "active_strains", want, mask)

    @property
    def n_strains(self) -> int:
        """Number of modelled (active) strains ``n``."""
        return int(self.kinematics.n_active)

    def _set_segmentation(self, x: Any) -> int:
        """Take the segmentation of strain trajectories (checked against the constructor's); return ``2n``."""
        kin = kinematics_of(x)
        if kin is None:
            if "segmentation_" not in self.__dict__:
                _ = self.kinematics  # raises NotFittedError when there is none at all
            return 2 * self.n_strains
        lengths = getattr(self, "segment_lengths", None)
        if lengths is not None:
            own = PlanarPCS(tuple(np.atleast_1d(np.asarray(lengths, dtype=float))), active_strains=self.active_strains)
            if not (
                np.allclose(own.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0)
                and np.array_equal(own.active_strains, kin.active_strains)
            ):
                raise ValueError(
                    f"segment_lengths {list(own.segment_lengths)} with active strains "
                    f"{own.active_strains.astype(int).tolist()} differ from the data's "
                    f"{list(kin.segment_lengths)} with {kin.active_strains.astype(int).tolist()}; "
                    "leave segment_lengths=None to take the data's segmentation"
                )
        self.__dict__["segmentation_"] = kin
        return 2 * int(kin.n_active)

    def fit(self, x: Any, y: Any = None) -> LagrangianLibrary:
        """Set the segmentation and the state width.

        Parameters
        ----------
        x : list of StrainTrajectory, or array_like of shape (n_samples, 2n) (or a list of them)
            Strain trajectories set the segmentation (``segmentation_``); arrays
            ``[q, qd]`` of the active strains need ``segment_lengths`` given to
            the constructor and are only checked for their width ``2n``.
        y : ignored

        Returns
        -------
        self
        """
        validate_parameters(self)
        self._check_segmentation()
        if kinematics_of(x) is None:
            x = self.check_states(x)
        width = self._set_segmentation(x)
        if kinematics_of(x) is None:
            arrays = x
            got = {np.shape(a)[-1] if np.ndim(a) else None for a in arrays}
            if got != {width}:
                raise ValueError(
                    f"x must have 2n = {width} columns [q, qd] of the {width // 2} active strains; "
                    f"got widths {sorted(map(str, got))}"
                )
        _ = self.n_coefficients_  # builds (and checks) the column layout
        self.n_features_in_ = width
        self.n_output_features_ = self.n_lagrangian_terms
        return self

    @staticmethod
    def check_states(x: Any) -> list[NDArray[np.float64]]:
        """State arrays ``[q, qd]`` (one, or a list of them) checked the scikit-learn way.

        :func:`sklearn.utils.check_array` on each: dense (a sparse matrix is
        refused with scikit-learn's message), real numbers (complex and object
        arrays refused), finite (NaN and inf refused), at least one sample and
        one column, 2-D.

        Returns
        -------
        list of ndarray, shape (n_samples, width)
        """
        arrays = list(x) if isinstance(x, (list, tuple)) else [x]
        if not arrays:
            raise ValueError("x must be an array (n_samples, 2n) of states [q, qd] or a non-empty list of them")
        return [check_array(a, dtype=np.float64, input_name="x") for a in arrays]

    def get_feature_names_out(self, input_features: Any = None) -> NDArray[np.object_]:
        """scikit-learn's name of :meth:`get_feature_names`: the Lagrangian basis terms, as an array of str."""
        names = self.get_feature_names(None if input_features is None else list(input_features))
        return np.asarray(names, dtype=object)

    # ------------------------------------------------------------------ inside a plain pysindy.SINDy
    def correct_shape(self, x: Any) -> Any:
        """Refuse a plain ``pysindy.SINDy``: it calls this on its data before anything else.

        ``SINDy`` regresses ``x_dot = Theta(x) Xi`` (first order, one coefficient
        row per state); a Lagrangian library describes ``tau = Psi(q, qd, qdd) @ coef``
        (second order, one row shared by every strain), so that fit would be
        silently meaningless.

        Raises
        ------
        TypeError
            Always, naming the routes that work.
        """
        raise TypeError(
            f"{type(self).__name__} is a Lagrangian library (tau = Psi(q, qd, qdd) @ coef, one coefficient vector "
            "shared by every strain), which a plain pysindy.SINDy (x_dot = Theta(x) Xi) cannot fit: it would print "
            "meaningless equations. Use one of: "
            "EulerLagrangeRegressor(feature_library=...).fit(strain_trajectories, forces); "
            "or the pysindy route WeakEulerLagrangeSINDy(feature_library=...).fit(q, t=t, u=forces) "
            "(pcs_sindy.identification; weak form, no accelerations); or, with exact accelerations, "
            "SINDy(feature_library=StackedEulerLagrangeLibrary(library)) with x = [q, qd, qdd] and "
            "x_dot=stack_forces(tau)"
        )

    # ------------------------------------------------------------------ column layout
    @property
    @abstractmethod
    def n_coefficients_(self) -> int:
        """Number of columns of ``Psi``."""

    @property
    @abstractmethod
    def stiffness_index_(self) -> NDArray[np.intp]:
        """Column of each active strain's stiffness."""

    @property
    @abstractmethod
    def damping_index_(self) -> NDArray[np.intp]:
        """Column of each active strain's damping."""

    @property
    def rest_force_index_(self) -> NDArray[np.intp]:
        """Column of each active strain's constant force (none by default)."""
        return np.zeros(0, dtype=np.intp)

    @property
    def rest_force_rows_(self) -> NDArray[np.intp]:
        """The active strain (row) of each constant-force column (default: one per strain, in order)."""
        return np.arange(np.asarray(self.rest_force_index_).size)

    @property
    def lower_bounds_(self) -> NDArray[np.float64] | None:
        """Lower bounds of the coefficients (None: unbounded)."""
        return None

    def scale_constraint(self) -> tuple[NDArray[np.float64], float] | None:
        """``(a, b)`` with ``a @ coef = b`` fixing the absolute scale of the coefficients, or None.

        Needed when every actuator gain is identified (the regression is then
        homogeneous); a library knowing an absolute quantity of the robot
        (e.g. :class:`~pcs_sindy.identification.library.physical.PhysicalPCSLibrary` given its mass) provides it.
        """
        return None

    @property
    def n_lagrangian_terms(self) -> int:
        """Number of Lagrangian basis terms (the columns that are not damping)."""
        return int(self.n_coefficients_) - int(np.asarray(self.damping_index_).size)

    @abstractmethod
    def coefficient_names(self) -> list[str]:
        """Names of the ``n_coefficients_`` columns."""

    def euler_lagrange_names(self) -> list[str]:
        """Alias of :meth:`coefficient_names`."""
        return self.coefficient_names()

    def coefficient_units(self) -> list[Unit | None]:
        """Unit of each of the ``n_coefficients_`` coefficients (None where this library does not know it).

        ``tau = Psi @ coef`` makes the unit of a coefficient the unit of the generalised force of its
        rows divided by the unit of its column of ``Psi``.  Here, for any library: a stiffness (the
        coefficient times ``stiffness_factor_``, a pure number) is ``tau_e / q_e``, a damping
        ``tau_e / qd_e``, a constant force ``tau_e`` (:func:`pcs_sindy.core.units.generalised_force_unit`);
        the libraries add the units of their other columns.

        Returns
        -------
        list of Unit or None
        """
        names = self.kinematics.strain_names(active_only=True)
        out: list[Unit | None] = [None] * int(self.n_coefficients_)
        for e, j in enumerate(np.asarray(self.stiffness_index_)):
            out[int(j)] = generalised_force_unit(names[e]) / strain_unit(names[e])
        for e, j in enumerate(np.asarray(self.damping_index_)):
            out[int(j)] = generalised_force_unit(names[e]) / strain_rate_unit(names[e])
        for row, j in zip(np.asarray(self.rest_force_rows_), np.asarray(self.rest_force_index_)):
            out[int(j)] = generalised_force_unit(names[int(row)])
        return out

    # ------------------------------------------------------------------ regression rows
    @abstractmethod
    def euler_lagrange_matrix(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Strong-form rows ``Psi`` with ``tau = Psi @ coef``, shape (n_samples, n, n_coefficients_)."""

    @abstractmethod
    def weak_terms(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Momentum part ``P`` and remainder ``R`` of ``Psi = dP/dt + R``, each (n_samples, n, n_coefficients_).

        Integrated against a test function ``phi`` vanishing at both ends of a
        window, ``int phi Psi dt = -int phi' P dt + int phi R dt``: no ``qdd``.
        """

    def integrated_euler_lagrange_matrix(
        self,
        t: ArrayLike,
        q: ArrayLike,
        qd: ArrayLike,
        windows: ArrayLike,
        *,
        rule: str = "simpson",
        test_function: str | None = None,
    ) -> NDArray[np.float64]:
        """Weak-form rows ``int phi Psi dt`` per window, shape (n_windows, n, n_coefficients_).

        :func:`pcs_sindy.identification.formulations.weak_rows` of this library (see there for
        the arguments); pair with :func:`pcs_sindy.identification.formulations.integrate_forces`.
        """
        from ..formulations import weak_rows

        return weak_rows(self, t, q, qd, windows, test_function=test_function, rule=rule)

    # ------------------------------------------------------------------ model of given coefficients
    def _check_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        c = np.asarray(coef, dtype=float)
        if c.ndim == 2 and c.shape[0] == 1:
            c = c[0]
        p = int(self.n_coefficients_)
        if c.shape != (p,):
            raise ValueError(f"coef must have shape ({p},) (n_coefficients_); got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise ValueError("coef contains NaN or inf")
        return c

    @abstractmethod
    def mass_matrix(self, q: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """``M(q)`` of the coefficients, shape (n_samples, n, n)."""

    @abstractmethod
    def bias_forces(self, q: ArrayLike, qd: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """All forces but ``M qdd`` (Coriolis, gravity, elastic, damping, constant), shape (n_samples, n)."""

    def potential_forces(self, q: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """Conservative (and constant) forces, the bias at ``qd = 0``, shape (n_samples, n)."""
        q = np.asarray(q, dtype=float)
        return self.bias_forces(q, np.zeros_like(q), coef)

    @abstractmethod
    def forward_model(self, coef: ArrayLike, actuation: Any = None) -> Any:
        """The :class:`~pcs_sindy.models.forward.ForwardModel` of the coefficients (rollouts, controllers).

        ``actuation``: a fitted :class:`~pcs_sindy.models.actuation.Actuation` mapping
        actuator inputs to generalised forces (default: the inputs are the forces).
        """

    def stiffness_from_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        """Stiffness of every active strain in physical units, shape (n,)."""
        c = self._check_coef(coef)
        return float(self.stiffness_factor_) * c[np.asarray(self.stiffness_index_)]

    def damping_from_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        """Damping coefficient of every active strain, shape (n,)."""
        return self._check_coef(coef)[np.asarray(self.damping_index_)].copy()

    def rest_force_from_coef(self, coef: ArrayLike) -> NDArray[np.float64]:
        """Constant generalised force of every active strain, shape (n,) (0 without such columns)."""
        c = self._check_coef(coef)
        out = np.zeros(self.n_strains)
        idx = np.asarray(self.rest_force_index_)
        if idx.size:
            out[self.rest_force_rows_] = c[idx]
        return out

    # ------------------------------------------------------------------ structure changes and text
    @abstractmethod
    def restrict(self, active_strains: ArrayLike) -> LagrangianLibrary:
        """Library of a subset of the active strains (removed strains held at 0), with ``column_map_``."""

    @abstractmethod
    def equations(self, coef: ArrayLike, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """The model of ``coef`` as text, one line per equation; the last line starts ``D = diag(``."""

    def _damping_line(self, coef: NDArray[np.float64], precision: int) -> str:
        strain = self.kinematics.strain_names(active_only=True)
        damp = self.damping_from_coef(coef)
        return (
            "D = diag("
            + ", ".join(
                f"{s}: {self._with_unit(d, generalised_force_unit(s) / strain_rate_unit(s), precision)}"
                for s, d in zip(strain, damp)
            )
            + ")"
        )

    def _units_line(self) -> str:
        """The units of the modelled strains and of their generalised forces, e.g.
        ``units: be [1/m], sh, ax [-]; tau_be [N·m²], tau_sh, tau_ax [N·m]``."""
        kinds = [k for k in STRAIN_UNITS if any(n.rpartition("_")[0] == k for n in self.kinematics.strain_names(True))]

        def grouped(prefix: str, unit_of: Any) -> str:
            groups: dict[str, list[str]] = {}
            for k in kinds:
                unit = unit_of(k)
                groups.setdefault("-" if unit.dimensionless else str(unit), []).append(prefix + k)
            return ", ".join(f"{', '.join(names)} [{unit}]" for unit, names in groups.items())

        return f"units: {grouped('', strain_unit)}; {grouped('tau_', generalised_force_unit)}"

    @staticmethod
    def _with_unit(value: float, unit: Unit | None, precision: int = 3) -> str:
        """``value`` to ``precision`` significant digits and its unit (nothing for a pure number or None)."""
        text = f"{value:.{precision}g}"
        return text if unit is None or unit.dimensionless else f"{text} {unit}"
