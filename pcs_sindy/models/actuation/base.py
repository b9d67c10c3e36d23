"""The contract of an actuation kind, and the registry every kind enters by defining its class.

:class:`Actuation` maps the inputs ``u`` (T, p) of a recording to generalised
forces on the modelled strains of a segmentation,
``A(q) u = known(q, u) + sum_j theta_j B_j(q, u)``.  A kind subclasses it,
names itself with the class attribute :attr:`Actuation.kind` and implements
``_structure``, :meth:`Actuation.parts` and :meth:`Actuation.describe` (and,
to run on the compiled rollouts, :meth:`Actuation.compiled` with
:attr:`Actuation.compiled_forms`).  Defining the class registers it
(``__init_subclass__``): :func:`registered_kinds` gives every kind defined so far,
which is what layouts and model files read.  Knows no kind itself.
"""

from __future__ import annotations

import weakref
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator

from ...core.kinematics import PlanarPCS
from ...core.spatial import SpatialPCS
from ...core.validation import validate_parameters

__all__ = ["Actuation", "registered_kinds", "COMPILED_FORMS", "gain_unit"]

#: The input maps the compiled kernels of :class:`~pcs_sindy.models.LumpedPCSModel` evaluate, by the
#: name :meth:`Actuation.compiled` gives, with the arrays each reads (``offsets`` (p,), ``cover``
#: (p, m), ``matrix``).  A kind whose map is one of these runs on the compiled rollouts without any
#: change elsewhere; a new form needs the kernels (``pcs_sindy.models._jit_dynamics``) to learn it.
COMPILED_FORMS: dict[str, str] = {
    "forces": "the inputs are the forces on the modelled strains (A = I)",
    "tendon": "tendons at signed offsets covering cover[k, i] of segment i: A = -dl/dq",
    "servo": "servo-wound elastic tendons (tension k max(0, r u pi/180 + l(q) - l(0) - s)); matrix rows [k, r, s]",
    "matrix": "a constant A = matrix (n, p)",
    "affine": "A affine in the strains and in the inputs' positive parts: matrix [B0 | B1 | C0 | C1] (n, 2 p (1 + n))",
    "spatial_tendon": "tendons routed in 3-D (spatial models): offsets (p, 2) (d_x, d_z), A = -dl/dq; matrix (0, p) "
    "for tensions, or rows [k, r, s, l(0), servo, winding] (6, p) for servo-wound elastic tendons",
}

#: kind -> class of every concrete subclass defined so far (weak: a class defined and dropped leaves)
_KINDS: weakref.WeakValueDictionary[str, type] = weakref.WeakValueDictionary()


def _abstract(cls: type) -> bool:
    """Whether ``cls`` keeps an abstract method (what ABCMeta computes after ``__init_subclass__`` runs)."""
    if any(getattr(v, "__isabstractmethod__", False) for v in vars(cls).values()):
        return True
    inherited = {name for base in cls.__bases__ for name in getattr(base, "__abstractmethods__", ())}
    return any(getattr(getattr(cls, name, None), "__isabstractmethod__", False) for name in inherited)


def _where(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _register(cls: type) -> None:
    """Enter a concrete subclass under its own :attr:`Actuation.kind` (unique, as its class name is)."""
    if _abstract(cls):
        return
    kind = vars(cls).get("kind")
    if not isinstance(kind, str) or not kind:
        inherited = getattr(cls, "kind", "")
        raise TypeError(
            f"{_where(cls)} must declare its own kind (a class attribute kind = '<name>', the 'type' of its "
            f"layouts and its key in the actuation registry); it inherits kind = {inherited!r}"
        )
    forms = cls.compiled_forms
    if not (isinstance(forms, tuple) and all(isinstance(f, str) and f in COMPILED_FORMS for f in forms)):
        raise TypeError(
            f"{_where(cls)}.compiled_forms must be a tuple of names from {sorted(COMPILED_FORMS)}; got {forms!r}"
        )
    for other_kind, other in list(_KINDS.items()):
        if _where(other) == _where(cls):
            continue  # the same class defined again (a module reloaded): the new one replaces it
        if other_kind == kind:
            raise TypeError(f"{_where(cls)}: kind {kind!r} is taken by {_where(other)}")
        if other.__name__ == cls.__name__:
            # model files name a kind by its class name
            raise TypeError(
                f"{_where(cls)}: the class name {cls.__name__!r} is taken by {_where(other)} (kind {other_kind!r})"
            )
    for other_kind, other in list(_KINDS.items()):
        if _where(other) == _where(cls):
            del _KINDS[other_kind]
    _KINDS[kind] = cls


def registered_kinds() -> dict[str, type[Actuation]]:
    """Every concrete :class:`Actuation` subclass defined so far, by its :attr:`~Actuation.kind`.

    The built-in kinds are defined when their modules are imported:
    :func:`~pcs_sindy.models.actuation.actuation_kinds` imports them first.
    """
    return dict(sorted(_KINDS.items()))


class Actuation(BaseEstimator, ABC):
    """Base of the actuation terms: ``A(q; theta, d) u`` on the modelled strains of a segmentation.

    ``fit(kinematics)`` sets the segmentation; then ``n_inputs_`` (p),
    ``gain_names_`` (the linear parameters theta identified with the Lagrangian,
    possibly none) and ``offset_names_`` (nonlinear parameters, possibly none).

    A concrete subclass is a kind: it declares ``kind = "<name>"`` (unique, the
    ``"type"`` of its layouts) and is registered when it is defined, so layouts,
    model files and forward models take it without a change elsewhere (a class
    that keeps an abstract method is not registered; a concrete one without its
    own ``kind`` raises ``TypeError``).  Its forward models use the compiled
    kernels when :attr:`compiled_forms` names the form :meth:`compiled` gives,
    and :meth:`forces` in Python otherwise.
    """

    #: read by validate_parameters in fit (and by model files); a subclass lists its parameters
    _parameter_constraints: dict = {}
    #: lower bound of every identified gain (0: gains are positive by design)
    gain_lower_bound = 0.0
    #: the kind's name: the ``"type"`` of its layouts (:func:`~pcs_sindy.models.actuation.actuation_from_layout`)
    #: and its key in the registry; every concrete subclass declares its own
    kind: ClassVar[str] = ""
    #: the input maps of the compiled kernels :meth:`compiled` may give (names of :data:`COMPILED_FORMS`);
    #: empty: no compiled form, and forward models compute ``A(q) u`` with :meth:`forces` (in Python)
    compiled_forms: ClassVar[tuple[str, ...]] = ()
    #: True when the inputs are the generalised forces themselves (``A = I``)
    is_identity: ClassVar[bool] = False
    #: True when ``A`` depends on the strains (then a held input's forces are averaged over the interval's ends)
    depends_on_q: ClassVar[bool] = False
    #: True when the kind is defined for spatial (3-D) segmentations too (six strains per segment)
    spatial: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        _register(cls)

    @property
    def linear_in_inputs(self) -> bool:
        """True when the forces are ``A(q) u`` (linear in the inputs); False for servo-wound tendons."""
        return True

    def fit(self, kinematics: PlanarPCS) -> Actuation:
        """Take the segmentation the inputs act on.

        Parameters
        ----------
        kinematics : PlanarPCS
            Segmentation and modelled strains (the data's).

        Returns
        -------
        self
        """
        validate_parameters(self)
        if not isinstance(kinematics, (PlanarPCS, SpatialPCS)):
            raise ValueError(f"kinematics must be a PlanarPCS or a SpatialPCS; got {type(kinematics).__name__}")
        if isinstance(kinematics, SpatialPCS) and not self.spatial:
            raise ValueError(
                f"{type(self).__name__} (kind {self.kind!r}) is defined for planar segmentations only; for spatial "
                "strains use IdentityActuation (generalised forces) or LearnedActuation"
            )
        self.kinematics_ = kinematics
        self.__dict__.pop("_arrays_cache", None)
        arrays = self._arrays
        self.n_inputs_ = int(arrays["n_inputs"])
        self.gain_names_ = list(arrays["gain_names"])
        self.offset_names_ = list(arrays["offset_names"])
        self.gains_ = np.asarray(arrays["gains"], dtype=float)
        self.offsets_ = np.asarray(arrays["offsets"], dtype=float)
        return self

    @property
    def _arrays(self) -> dict[str, Any]:
        """Structure of the map on the fitted segmentation (rebuilt after loading a model file)."""
        cached = self.__dict__.get("_arrays_cache")
        if cached is None or cached[0] is not self.kinematics_:
            cached = (self.kinematics_, self._structure(self.kinematics_))
            self.__dict__["_arrays_cache"] = cached
        return cached[1]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_arrays_cache", None)
        return state

    @abstractmethod
    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        """Validate the parameters against the segmentation; return the arrays of the map and
        ``n_inputs``, ``gain_names``, ``offset_names`` and the starting ``gains``, ``offsets``."""

    # -- parameters -----------------------------------------------------------
    @property
    def n_gains(self) -> int:
        return len(self.gain_names_)

    @property
    def n_offsets(self) -> int:
        return len(self.offset_names_)

    def offset_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Bounds of the nonlinear parameters (none by default)."""
        return np.zeros(0), np.zeros(0)

    def initial_offsets(self) -> NDArray[np.float64]:
        """Starting point of the nonlinear parameters."""
        return np.zeros(0)

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """The map's signed offsets for the nonlinear parameters ``offsets`` (default: the fitted ``offsets_``)."""
        return self.offsets_

    # -- inputs -----------------------------------------------------------------
    def check_inputs(self, u: ArrayLike, name: str = "u", t: NDArray | None = None) -> NDArray[np.float64]:
        """Validated inputs (T, p): finite, the right width, one row per time of ``t`` when it is given
        (subclasses add sign rules)."""
        arr = np.asarray(u, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != self.n_inputs_:
            raise ValueError(
                f"{name} must have shape (T, {self.n_inputs_}) (one column per actuator input of "
                f"{type(self).__name__}); got {arr.shape}"
            )
        if t is not None and arr.shape[0] != np.size(t):
            # the compiled loops read row k on [t[k], t[k+1]): a short table would be read past its end
            raise ValueError(
                f"{name} must have shape ({np.size(t)}, {self.n_inputs_}) (one row per time in t, one column per "
                f"actuator input); got shape {arr.shape}: give one row of inputs for each of the {np.size(t)} times"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf (first at sample {np.argwhere(~np.isfinite(arr))[0][0]})")
        return arr

    # -- the map ------------------------------------------------------------------
    @abstractmethod
    def parts(
        self, q: NDArray[np.float64], u: NDArray[np.float64], offsets: NDArray[np.float64] | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``A(q) u = known + linear @ gains`` on the modelled strains.

        Parameters
        ----------
        q : ndarray, shape (B, n)
            Modelled strains.
        u : ndarray, shape (B, p)
            Inputs.
        offsets : ndarray, optional
            Nonlinear parameters (default: the given or identified ones).

        Returns
        -------
        known : ndarray, shape (B, n)
        linear : ndarray, shape (B, n, n_gains)
        """

    def forces(
        self, q: ArrayLike, u: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Generalised forces ``A(q) u`` (B, n) for gains (default: given or identified) and offsets."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        u = np.atleast_2d(np.asarray(u, dtype=float))
        known, linear = self.parts(q, u, None if offsets is None else np.asarray(offsets, float))
        g = self._gains(gains)
        return known + (linear @ g if g.size else 0.0)

    def matrix(self, q: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> NDArray:
        """``A(q)`` (B, n, p) on the modelled strains."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        eye = np.eye(self.n_inputs_)
        cols = [
            self.forces(q, np.broadcast_to(eye[j], (q.shape[0], self.n_inputs_)), gains, offsets)
            for j in range(self.n_inputs_)
        ]
        return np.stack(cols, axis=-1)

    def _gains(self, gains: ArrayLike | None) -> NDArray[np.float64]:
        if gains is None:
            gains = getattr(self, "gains_", np.zeros(0))
        g = np.asarray(gains, dtype=float).reshape(-1)
        if g.size != self.n_gains:
            raise ValueError(f"gains must hold {self.n_gains} values ({self.gain_names_}); got {g.size}")
        return g

    def compiled(self, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> tuple:
        """``(form, offsets (p,), cover (p, m), matrix)``: the map as one of the compiled kernels' input maps.

        ``form`` is one of :attr:`compiled_forms` (see :data:`COMPILED_FORMS` for the arrays each
        form reads); the forward model hands the arrays to its compiled dynamics.

        Raises
        ------
        NotImplementedError
            For a kind without a compiled form (empty :attr:`compiled_forms`): its forward models
            evaluate :meth:`forces` instead and roll out with the ``solve_ivp`` methods.
        """
        raise NotImplementedError(f"{type(self).__name__} has no compiled form; roll out with a solve_ivp method")

    def set_identified(self, gains: ArrayLike, offsets: ArrayLike) -> Actuation:
        """Store identified gains and offsets (``gains_``, ``offsets_``)."""
        self.gains_ = np.asarray(gains, dtype=float).reshape(-1)
        self.offsets_ = np.asarray(offsets, dtype=float).reshape(-1)
        return self

    @abstractmethod
    def describe(self, precision: int = 3) -> list[str]:
        """The map and its identified parameters as text."""

    #: the constructor parameters that describe the design (what a user knows), in :meth:`design_layout`
    _design_keys: tuple[str, ...] = ()

    def design_layout(self) -> dict[str, Any]:
        """The layout as the robot's design gives it (terminations and sides, spans), JSON-able."""
        out: dict[str, Any] = {"type": self.kind}
        for key in self._design_keys:
            out[key] = np.asarray(getattr(self, key), dtype=float).tolist()
            if key == "side":
                out[key] = [int(v) for v in out[key]]
        return out

    def input_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Bounds (lower, upper) of the inputs, or None (unbounded)."""
        return None

    def layout(self) -> dict[str, Any]:
        """The JSON-able layout (constructor parameters)."""
        return {
            "type": self.kind,
            **{k: (np.asarray(v).tolist() if v is not None else None) for k, v in self.get_params().items()},
        }


def gain_unit(gain_name: str, strain_names: list[str]) -> str:
    """Unit of an input-map gain named ``a_<strain>_<input>[_<strain b>]``, per unit of the input.

    The gain turns an input into the generalised force of ``<strain>`` (N·m² for a curvature, N·m
    for a shear or axial strain), divided by the unit of ``<strain b>`` when it scales with that
    strain; inputs keep the user's units (servo degrees, bar, ...), written ``/u``.
    """
    from ...core.units import generalised_force_unit, strain_unit

    by_length = sorted(strain_names, key=len, reverse=True)
    rest = gain_name[2:] if gain_name.startswith("a_") else gain_name
    row = next((nm for nm in by_length if rest.startswith(nm + "_")), None)
    if row is None:
        return "?"
    unit = generalised_force_unit(row)
    col = next((nm for nm in by_length if rest.endswith("_" + nm) and len(rest) > len(row) + len(nm) + 1), None)
    if col is not None:
        unit = unit / strain_unit(col)
    return f"{unit}/u"
