"""``PCSLagrangianLibrary``: the seed's symbolic Lagrangian basis of a planar PCS robot (a pysindy library)."""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.feature_library.base import x_sequence_or_item
from pysindy.utils import AxesArray, comprehend_axes
from sklearn.utils.validation import check_is_fitted

from ...core.kinematics import PlanarPCS
from ...core.units import DIMENSIONLESS, JOULE, KILOGRAM, METRE, NEWTON, Unit, strain_rate_unit, strain_unit
from ...core.validation import Options, validate_parameters
from ._monomial_dynamics import DynamicsTables
from ._monomial_terms import readable, reduce_product
from .base import LagrangianLibrary
from .codegen import CompiledBasis, build_basis
from .derivation import PARAM_KINDS

__all__ = ["PCSLagrangianLibrary"]

_MEMORY: dict[tuple, CompiledBasis] = {}
_BASES = ("monomial", "physical")
_SCALINGS = ("seed", "length", "physical")
#: unit of each lumped unknown (PARAM_KINDS): line density, rotary line inertia, weight per length, stiffness
_LUMPED_UNITS: dict[str, Unit] = {
    "mA": KILOGRAM / METRE,
    "mI": KILOGRAM * METRE,
    "gx": NEWTON / METRE,
    "gy": NEWTON / METRE,
    "kbe": JOULE / strain_unit("be") ** 2,
    "ksh": JOULE / strain_unit("sh") ** 2,
    "kax": JOULE / strain_unit("ax") ** 2,
}
#: the strain kind of the derivation's atom names (kap_1, sh_1, ax_1)
_ATOM_KIND = {"kap": "be", "sh": "sh", "ax": "ax"}


def _atom_unit(name: str) -> Unit:
    """Unit of one atom of the monomial basis: a strain (``kap_1``), a rate (``dkap_1``), or a pure number.

    The special functions ``F..._i`` of ``u_i = kappa_i L_i`` and the cosines and sines of
    bending-angle sums are pure numbers.
    """
    rate = name.startswith("d") and name[1:].rpartition("_")[0] in _ATOM_KIND
    base = name[1:] if rate else name
    kind = base.rpartition("_")[0]
    if kind not in _ATOM_KIND:
        return DIMENSIONLESS
    return strain_rate_unit(_ATOM_KIND[kind]) if rate else strain_unit(_ATOM_KIND[kind])


def _compiled(m: int, cache_dir, progress: bool = False) -> CompiledBasis:
    key = (m, str(cache_dir))
    if key not in _MEMORY:
        _MEMORY[key] = build_basis(m, cache_dir, progress=progress)
    return _MEMORY[key]


class PCSLagrangianLibrary(LagrangianLibrary):
    """Lagrangian basis of an m-segment planar PCS robot (seed §III-C, eqs. 12–21).

    The Lagrangian ``L = T - U_g - U_e`` of a planar PCS robot with known
    segment lengths is exactly ``sum_j pi_j f_j(q, qd)``; the ``f_j`` are
    derived symbolically once per number of segments (cached on disk) from
    closed-form integrals of the PCS energies, and are exact and smooth at
    zero curvature.  Each coefficient ``pi_j`` is a known linear expression
    of the lumped unknowns ``rho_i A_i``, ``rho_i I_i``, ``rho_i A_i g``,
    ``-k_e/2`` (see :meth:`coefficients_from_parameters`).

    As a pysindy feature library it maps states ``x = [q, qd]`` (active
    strains only) to the ``f_j``.  For the Euler–Lagrange regression
    ``tau = Psi(q, qd, qdd) pi+`` use :meth:`euler_lagrange_matrix`; ``pi+``
    is ``pi`` followed by one damping coefficient per active strain.

    Implements the :class:`~pcs_sindy.identification.library.base.LagrangianLibrary` contract;
    the library of the seed's method (:meth:`EulerLagrangeRegressor.seed_method
    <pcs_sindy.identification.regressor.EulerLagrangeRegressor.seed_method>`).

    Parameters
    ----------
    segment_lengths : sequence of float, optional
        Rest lengths ``L_i`` in metres; default: taken in :meth:`fit` from the
        strain trajectories (the kinematic fusion's segmentation).
    active_strains : array_like of bool, shape (m, 3) or (3m,), optional
        Modelled strains (default all).  Removed strains follow the limit rule
        (seed eqs. 20–21): ``q_e, qd_e, qdd_e -> 0``, their rows dropped and
        every column that becomes identically zero removed (including functions
        that become constants, whose Euler–Lagrange image vanishes).  Columns
        that become exact multiples of an earlier column are merged into it.
    cache_dir : path, None or False
        Derivation cache (default ``$PCS_SINDY_CACHE`` or ``~/.cache/pcs_sindy``);
        ``False`` disables it.  The cache holds generated code that is executed: use
        only a directory that no one you do not trust can write (its hashes detect
        damage, not tampering; see :mod:`pcs_sindy.identification.library.codegen`).
    basis : {"monomial", "physical"}, default "monomial"
        ``"monomial"``: one basis function per distinct product of atoms
        (strains, rates, special functions of ``kappa_i L_i``, cos/sin of
        bending-angle sums), each with its own coefficient (the seed's
        approach).  ``"physical"``: one basis function per lumped unknown
        (7 per segment); the identification then has far fewer unknowns.
    progress : bool, default False
        tqdm progress bar while deriving (only when the cache misses).

    Attributes
    ----------
    n_features_in_ : int
        ``2 n`` (n active strains).
    n_output_features_ : int
        Number of Lagrangian basis functions ``n_f``.
    n_coefficients_ : int
        ``n_f + n`` (damping columns last).
    stiffness_index_ : ndarray of int, shape (n,)
        Column of each active strain's ``q_e^2`` function; ``k_e = -2 coef[idx]``.
    damping_index_ : ndarray of int, shape (n,)
    column_map_ : ndarray of int or None
        Set by :meth:`restrict`: indices of the kept columns in the parent's ``pi+``.
    segmentation_ : PlanarPCS
        After :meth:`fit` on strain trajectories: their segmentation.
    """

    stiffness_factor_ = -2.0

    def __init__(
        self,
        segment_lengths: Sequence[float] | None = None,
        active_strains: ArrayLike | None = None,
        cache_dir=None,
        basis: str = "monomial",
        progress: bool = False,
    ) -> None:
        self.segment_lengths = segment_lengths
        self.active_strains = active_strains
        self.cache_dir = cache_dir
        self.basis = basis
        self.progress = progress

    # ------------------------------------------------------------------ setup
    #: read by validate_parameters in fit and before the basis is set up, and by model files
    _parameter_constraints: dict = {
        **LagrangianLibrary._parameter_constraints,
        "cache_dir": "no_validation",
        "basis": [Options(_BASES)],
        "progress": "no_validation",
    }

    def _take_segmentation(self) -> None:
        """The segmentation's arrays the setup works on (lengths, mask); a model needs one strain."""
        kin = self.kinematics
        lengths = np.asarray(kin.segment_lengths, dtype=float)
        if kin.n_active == 0:
            raise ValueError("active_strains must keep at least one strain; got none active")
        self._lengths = lengths
        self._kin = kin
        self._mask = np.asarray(kin.active_mask, dtype=bool)

    def _ensure_setup(self) -> None:
        if getattr(self, "_setup_key", None) == self._current_key():
            return
        validate_parameters(self)
        self._take_segmentation()
        m = self._lengths.size
        cb = _compiled(m, self.cache_dir, bool(self.progress))
        self._cb = cb
        q_names = [f"{n}_{i + 1}" for i in range(m) for n in ("kap", "sh", "ax")]
        removed = {q_names[k] for k in range(3 * m) if not self._mask[k]}
        removed_kappa = {i for i in range(m) if not self._mask[3 * i]}
        products = cb.products
        n_g = len(products)
        prod_index = {p: j for j, p in enumerate(products)}
        L = self._lengths
        lumped = [f"{k}_{i + 1}" for i in range(m) for k in PARAM_KINDS]
        lumped_index = {p: k for k, p in enumerate(lumped)}
        # P[j, p]: coefficient of lumped unknown p in pi_j (monomial basis of the full model)
        P = np.zeros((n_g, len(lumped)))
        for t in cb.terms:
            P[prod_index[t.atoms], lumped_index[t.param]] += float(t.coefficient) * float(
                np.prod(L ** np.array(t.length_exponents))
            )
        reduced = [reduce_product(p, removed, removed_kappa) for p in products]
        self._lumped_names = lumped
        if self.basis == "monomial":
            groups: dict[tuple, int] = {}
            reps: list[int] = []
            ratio_rows = []
            for j, (factor, red) in enumerate(reduced):
                if factor == 0 or not red:
                    continue  # zero, or a constant whose Euler-Lagrange image vanishes
                if red not in groups:
                    groups[red] = len(reps)
                    reps.append(j)
                    ratio_rows.append([])
                ratio_rows[groups[red]].append((j, float(factor / reduced[reps[groups[red]]][0])))
            self._select = np.array(reps, dtype=int)
            W = None
            coef_map = np.zeros((len(reps), len(lumped)))
            for r, members in enumerate(ratio_rows):
                for j, ratio in members:
                    coef_map[r] += ratio * P[j]
            self._column_atoms = [products[j] for j in reps]
            self._column_reduced = [reduced[j][1] for j in reps]
            self._column_factor = [reduced[j][0] for j in reps]
        else:
            cols = []
            W = np.zeros((n_g, 0))
            wcols = []
            for p_idx, pname in enumerate(lumped):
                exact: dict[tuple, Fraction] = {}
                w = np.zeros(n_g)
                scale = -0.5 if pname.startswith("k") else 1.0
                for t in cb.terms:
                    if t.param != pname:
                        continue
                    factor, red = reduced[prod_index[t.atoms]]
                    if not red:
                        continue  # constants do not enter the Euler-Lagrange equations
                    key = (red, t.length_exponents)
                    exact[key] = exact.get(key, Fraction(0)) + t.coefficient * factor
                    w[prod_index[t.atoms]] += (
                        float(t.coefficient) * float(np.prod(L ** np.array(t.length_exponents))) / scale
                    )
                if any(v != 0 for v in exact.values()):
                    cols.append(p_idx)
                    wcols.append(w)
            W = np.stack(wcols, axis=1)
            self._select = None
            coef_map = np.zeros((len(cols), len(lumped)))
            for r, p_idx in enumerate(cols):
                coef_map[r, p_idx] = -0.5 if lumped[p_idx].startswith("k") else 1.0
            self._physical_cols = cols
        self._W = W
        self._coef_map = coef_map
        n_f = coef_map.shape[0]
        n = int(self._mask.sum())
        self._n = n
        self._n_f = n_f
        # stiffness columns: the column whose Lagrangian coefficient carries -k_e/2
        stiff = []
        kinds = ("kbe", "ksh", "kax")
        for k in np.flatnonzero(self._mask):
            pname = f"{kinds[k % 3]}_{k // 3 + 1}"
            col = np.flatnonzero(coef_map[:, lumped_index[pname]] != 0)
            if col.size != 1:
                raise ArithmeticError(f"stiffness of strain {k} is not carried by a single column")
            stiff.append(int(col[0]))
        self._stiffness_index = np.array(stiff, dtype=int)
        self._damping_index = np.arange(n_f, n_f + n)
        self._dyn_cache: dict = {}
        self._setup_key = self._current_key()

    def __getstate__(self):
        # generated functions are not picklable: drop them, they are rebuilt lazily (memory/disk cache)
        state = super().__getstate__()
        for key in ("_cb", "_dyn_cache", "_setup_key"):
            state.pop(key, None)
        return state

    def _current_key(self):
        kin = self.kinematics
        return (kin.segment_lengths, kin.active_strains.tobytes(), self.basis, str(self.cache_dir))

    @property
    def n_coefficients_(self) -> int:
        self._ensure_setup()
        return self._n_f + self._n

    @property
    def stiffness_index_(self) -> NDArray[np.intp]:
        self._ensure_setup()
        return self._stiffness_index.copy()

    @property
    def damping_index_(self) -> NDArray[np.intp]:
        self._ensure_setup()
        return self._damping_index.copy()

    @property
    def lumped_parameter_names(self) -> list[str]:
        """Names of the 7m lumped unknowns of :meth:`lumped_parameters` (``mA_1, mI_1, gx_1, ...``)."""
        self._ensure_setup()
        return list(self._lumped_names)

    def coefficient_map(self) -> NDArray[np.float64]:
        """Matrix P (n_f, 7m) with ``pi = P @ lumped_parameters(...)`` (the coefficients' expressions)."""
        self._ensure_setup()
        return self._coef_map.copy()

    @property
    def n_lagrangian_(self) -> int:
        """Number of Lagrangian basis functions ``n_f``."""
        self._ensure_setup()
        return self._n_f

    # ------------------------------------------------------------------ input checks
    def _states(self, name: str, value, n_samples: int | None = None) -> NDArray[np.float64]:
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self._n:
            raise ValueError(f"{name} must have shape (n_samples, {self._n}) (active strains); got {np.shape(value)}")
        if n_samples is not None and arr.shape[0] != n_samples:
            raise ValueError(f"{name} must have {n_samples} samples like q; got {arr.shape[0]}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
        return arr

    def _full(self, arr: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros((arr.shape[0], self._mask.size))
        out[:, self._mask] = arr
        return out

    def _coef(self, coef) -> NDArray[np.float64]:
        c = np.asarray(coef, dtype=float).reshape(-1)
        if c.size != self._n_f + self._n:
            raise ValueError(f"coef must have length n_coefficients_ = {self._n_f + self._n}; got {c.size}")
        if not np.all(np.isfinite(c)):
            raise ValueError("coef contains NaN or inf")
        return c

    def _columns(self, arr: NDArray[np.float64]) -> NDArray[np.float64]:
        """Map atom-product columns (last axis) to the library's columns."""
        if self._select is not None:
            return arr[..., self._select]
        return arr @ self._W

    # ------------------------------------------------------------------ pysindy
    @x_sequence_or_item
    def transform(self, x_full):
        """Basis functions ``f_j(q, qd)`` of states ``x = [q, qd]`` -> (n_samples, n_f)."""
        check_is_fitted(self, "n_output_features_")
        self._ensure_setup()
        out = []
        for x in x_full:
            arr = self.check_states(np.asarray(x))[0]
            if arr.shape[-1] != self.n_features_in_:
                raise ValueError(f"x must have {self.n_features_in_} columns [q, qd]; got {arr.shape[-1]}")
            if not np.all(np.isfinite(arr)):
                raise ValueError("x contains NaN or inf")
            flat = arr.reshape(-1, arr.shape[-1])
            n = self._n
            g = self._cb.features(self._full(flat[:, :n]), self._full(flat[:, n:]), self._lengths)
            f = self._columns(g).reshape(arr.shape[:-1] + (self._n_f,))
            out.append(AxesArray(f, comprehend_axes(f)))
        return out

    def _default_inputs(self) -> list[str]:
        names = self._kin.strain_names(active_only=True)
        return names + ["d" + n for n in names]

    def _state_name_map(self, input_features) -> dict[str, str]:
        inputs = self._default_inputs() if input_features is None else list(input_features)
        if len(inputs) != 2 * self._n:
            raise ValueError(f"input_features must have {2 * self._n} names; got {len(inputs)}")
        m = self._lengths.size
        internal = [f"{n}_{i + 1}" for i in range(m) for n in ("kap", "sh", "ax")]
        active = [internal[k] for k in np.flatnonzero(self._mask)]
        mapping = {a: inputs[k] for k, a in enumerate(active)}
        mapping.update({"d" + a: inputs[self._n + k] for k, a in enumerate(active)})
        return mapping

    def get_feature_names(self, input_features=None) -> list[str]:
        """Readable names of the basis functions (``u<i> = L_i * kappa_i``)."""
        self._ensure_setup()
        names = self._state_name_map(input_features)
        if self.basis == "monomial":
            out = []
            for factor, red in zip(self._column_factor, self._column_reduced):
                txt = readable(red, names, True)
                out.append(txt if factor == 1 else f"{factor} {txt}")
            return out
        labels = {"mA": "T_A", "mI": "T_I", "gx": "Ug_x", "gy": "Ug_y", "kbe": "be^2", "ksh": "sh^2", "kax": "ax^2"}
        out = []
        for p_idx in self._physical_cols:
            kind, seg = self._lumped_names[p_idx].split("_")
            if kind.startswith("k"):
                k = 3 * (int(seg) - 1) + ("kbe", "ksh", "kax").index(kind)
                internal = ("kap", "sh", "ax")[k % 3] + f"_{seg}"
                out.append(f"{names[internal]}^2")
            else:
                out.append(f"{labels[kind]}_{seg}")
        return out

    def coefficient_names(self) -> list[str]:
        """Names of the ``n_psi`` Euler–Lagrange columns (damping last)."""
        self._ensure_setup()
        names = [f"EL[{n}]" for n in self.get_feature_names()]
        return names + [f"damping {n}" for n in self._default_inputs()[self._n :]]

    def coefficient_units(self) -> list[Unit | None]:
        """Unit of each of the ``n_psi`` coefficients (:mod:`pcs_sindy.core.units`).

        The Lagrangian is an energy [J]: the coefficient of a basis function is J over the function's
        unit (strains 1/m or pure numbers, rates per second; special functions and trigonometric factors
        are pure numbers), e.g. N·m³ for ``be_1^2``, kg·m² for ``dax_1^2``; with ``basis="physical"``
        the lumped unknowns' units (rhoA kg/m, rhoI kg·m, rhoA g N/m, stiffness); damping as for every library.
        """
        self._ensure_setup()
        out = super().coefficient_units()
        if self.basis == "monomial":
            for j, atoms in enumerate(self._column_reduced):
                unit = DIMENSIONLESS
                for name, power in atoms:
                    unit = unit * _atom_unit(name) ** power
                out[j] = JOULE / unit
        else:
            for r, p_idx in enumerate(self._physical_cols):
                out[r] = _LUMPED_UNITS[self._lumped_names[p_idx].split("_")[0]]
        return out

    # ------------------------------------------------------------------ regression matrix
    def euler_lagrange_matrix(self, q, qd, qdd) -> NDArray[np.float64]:
        """``Psi(q, qd, qdd)`` of shape (n_samples, n, n_psi): ``tau = Psi @ pi+``.

        q, qd, qdd are the active strains, shape (n_samples, n).
        """
        self._ensure_setup()
        q = self._states("q", q)
        qd = self._states("qd", qd, q.shape[0])
        qdd = self._states("qdd", qdd, q.shape[0])
        return self._psi(q, qd, qdd)

    def _psi(self, q, qd, qdd) -> NDArray[np.float64]:
        g = self._cb.psi(self._full(q), self._full(qd), self._full(qdd), self._lengths)[:, self._mask, :]
        lag = self._columns(g)
        damp = np.zeros((q.shape[0], self._n, self._n))
        idx = np.arange(self._n)
        damp[:, idx, idx] = qd
        return np.concatenate([lag, damp], axis=2)

    def weak_terms(self, q, qd) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Momentum part ``P = df/dqd`` and remainder ``R = -df/dq`` of ``Psi = dP/dt + R``, each (n_samples, n, n_psi).

        Removed strains follow the limit rule as in :meth:`euler_lagrange_matrix`;
        a damping column has ``P = q_e``, ``R = 0``.
        """
        self._ensure_setup()
        q = self._states("q", q)
        qd = self._states("qd", qd, q.shape[0])
        mom, rest = self._cb.weak(self._full(q), self._full(qd), self._lengths)
        n, B = self._n, q.shape[0]
        idx = np.arange(n)
        p_damp = np.zeros((B, n, n))
        p_damp[:, idx, idx] = q
        return (
            np.concatenate([self._columns(mom[:, self._mask, :]), p_damp], axis=2),
            np.concatenate([self._columns(rest[:, self._mask, :]), np.zeros((B, n, n))], axis=2),
        )

    def _tables(self) -> DynamicsTables:
        if "dyn" not in self._dyn_cache:
            self._dyn_cache["dyn"] = DynamicsTables(self)
        return self._dyn_cache["dyn"]

    def _pi_products(self, c: NDArray[np.float64]) -> NDArray[np.float64]:
        """Coefficients of the Lagrangian on the full model's atom products."""
        if self._select is None:
            return self._W @ c[: self._n_f]
        pi_g = np.zeros(len(self._cb.products))
        pi_g[self._select] = c[: self._n_f]
        return pi_g

    def mass_matrix(self, q, coef) -> NDArray[np.float64]:
        """``M(q) = sum_j coef_j d2f_j/dqd2`` of shape (n_samples, n, n)."""
        self._ensure_setup()
        q = self._states("q", q)
        c = self._coef(coef)
        return self._tables().evaluate(self._pi_products(c), c[self._n_f :], q, np.zeros_like(q))[0]

    def bias_forces(self, q, qd, coef) -> NDArray[np.float64]:
        """Everything in ``Psi coef`` except ``M qdd`` (Coriolis, gravity, elastic, damping), (n_samples, n)."""
        self._ensure_setup()
        q = self._states("q", q)
        qd = self._states("qd", qd, q.shape[0])
        c = self._coef(coef)
        return self._tables().evaluate(self._pi_products(c), c[self._n_f :], q, qd)[1]

    def potential_forces(self, q, coef) -> NDArray[np.float64]:
        """``G(q) + K q`` (the part of ``-dL/dq`` independent of qd), (n_samples, n)."""
        self._ensure_setup()
        q = self._states("q", q)
        c = self._coef(coef)
        return self._tables().evaluate(self._pi_products(c), c[self._n_f :], q, np.zeros_like(q))[1]

    # ------------------------------------------------------------------ physical parameters
    def lumped_parameters(
        self,
        density,
        radius,
        youngs_modulus,
        shear_modulus,
        gravity=(0.0, 9.81),
        shear_factor=4.0 / 3.0,
        stiffness_scaling="seed",
    ) -> NDArray[np.float64]:
        """Lumped unknowns ``[rho A, rho I, rho A g_x, rho A g_y, k_be, k_sh, k_ax]`` per segment."""
        self._ensure_setup()
        m = self._lengths.size

        def per_segment(name, value):
            arr = (
                np.broadcast_to(np.asarray(value, dtype=float), (m,))
                if np.ndim(value) == 0
                else np.asarray(value, dtype=float)
            )
            if arr.shape != (m,):
                raise ValueError(f"{name} must be a scalar or have shape ({m},); got shape {np.shape(value)}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains NaN or inf: {arr.tolist()}")
            return arr

        rho = per_segment("density", density)
        r = per_segment("radius", radius)
        E = per_segment("youngs_modulus", youngs_modulus)
        G = per_segment("shear_modulus", shear_modulus)
        g = np.asarray(gravity, dtype=float)
        if g.shape != (2,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity must be a finite vector of length 2; got {gravity!r}")
        if stiffness_scaling not in _SCALINGS:
            raise ValueError(f"stiffness_scaling must be one of {_SCALINGS}; got {stiffness_scaling!r}")
        if not np.isfinite(shear_factor) or shear_factor <= 0:
            raise ValueError(f"shear_factor must be finite and > 0; got {shear_factor!r}")
        fL = np.ones(m) if stiffness_scaling == "seed" else self._lengths
        A, I = np.pi * r**2, np.pi * r**4 / 4.0
        vals = np.stack(
            [rho * A, rho * I, rho * A * g[0], rho * A * g[1], fL * E * I, fL * shear_factor * G * A, fL * E * A],
            axis=1,
        )
        return vals.reshape(-1)

    def coefficients_from_parameters(
        self,
        density,
        radius,
        youngs_modulus,
        shear_modulus,
        damping,
        gravity=(0.0, 9.81),
        shear_factor=4.0 / 3.0,
        stiffness_scaling="seed",
    ) -> NDArray[np.float64]:
        """``pi+`` of the robot with these physical parameters (per segment values or scalars).

        ``damping`` is the diagonal of D for all 3m strains (removed strains' entries ignored)
        or for the n active ones.  ``stiffness_scaling``: ``"seed"`` (``f_L = 1``) or
        ``"length"``/``"physical"`` (``f_L = L_i``).
        """
        lumped = self.lumped_parameters(
            density, radius, youngs_modulus, shear_modulus, gravity, shear_factor, stiffness_scaling
        )
        d = np.asarray(damping, dtype=float).reshape(-1)
        if d.size == self._mask.size:
            d = d[self._mask]
        if d.size != self._n or not np.all(np.isfinite(d)):
            raise ValueError(
                f"damping must have {self._mask.size} or {self._n} finite entries; got {np.asarray(damping).tolist()}"
            )
        return np.concatenate([self._coef_map @ lumped, d])

    # ------------------------------------------------------------------ limit rule
    def restrict(self, active_strains) -> PCSLagrangianLibrary:
        """Library with fewer strains by the limit rule (seed eqs. 20–21), no re-derivation.

        The result has ``column_map_``: for each of its ``pi+`` columns, the index
        of the same column in this library's ``pi+``.
        """
        self._ensure_setup()
        new_mask = np.asarray(PlanarPCS(tuple(self._lengths), active_strains=active_strains).active_mask)
        if np.any(new_mask & ~self._mask):
            raise ValueError(
                "active_strains must be a subset of the current active strains; "
                f"got {np.asarray(active_strains).tolist()}"
            )
        if not np.any(new_mask):
            raise ValueError("active_strains must keep at least one strain; got none active")
        child = type(self)(
            tuple(self._lengths),
            active_strains=new_mask.reshape(-1, 3),
            cache_dir=self.cache_dir,
            basis=self.basis,
            progress=self.progress,
        )
        child._ensure_setup()
        if self.basis == "monomial":
            parent_cols = {int(j): k for k, j in enumerate(self._select)}
            lag = [parent_cols[int(j)] for j in child._select]
        else:
            parent_cols = {p: k for k, p in enumerate(self._physical_cols)}
            lag = [parent_cols[p] for p in child._physical_cols]
        active_parent = np.flatnonzero(self._mask)
        damp = [self._n_f + int(np.flatnonzero(active_parent == k)[0]) for k in np.flatnonzero(new_mask)]
        child.column_map_ = np.array(lag + damp, dtype=int)
        if hasattr(self, "n_features_in_"):
            child.fit(np.zeros((1, 2 * child._n)))
        return child

    # ------------------------------------------------------------------ lumped parameters
    def lumped_from_coef(self, coef) -> dict:
        """Per-segment lumped parameters of ``coef`` (``basis="physical"`` only), for the compiled rollouts.

        Returns
        -------
        dict
            ``rhoA``, ``rhoI`` (m,), ``rhoAg`` (m, 2), ``stiffness``, ``damping``
            (n,) of the active strains, and ``n_quadrature`` = 16 (Gauss–Legendre
            nodes per segment that reproduce the closed-form energies to
            round-off for ``|kappa L| <~ 3``).  Unknowns that do not enter the
            reduced model (no column) are 0.

        Raises
        ------
        ValueError
            For ``basis="monomial"`` (its coefficients are not lumped parameters).
        """
        self._ensure_setup()
        if self.basis != "physical":
            raise ValueError(f"lumped_from_coef needs basis='physical'; got basis={self.basis!r}")
        c = self._coef(coef)
        lumped = np.zeros(len(self._lumped_names))
        for r, p_idx in enumerate(self._physical_cols):
            lumped[p_idx] = c[r] / self._coef_map[r, p_idx]
        per_seg = lumped.reshape(-1, len(PARAM_KINDS))  # mA, mI, gx, gy, kbe, ksh, kax
        stiff = per_seg[:, 4:].reshape(-1)[self._mask]
        return {
            "rhoA": per_seg[:, 0].copy(),
            "rhoI": per_seg[:, 1].copy(),
            "rhoAg": per_seg[:, 2:4].copy(),
            "stiffness": stiff,
            "damping": c[self._n_f :].copy(),
            "n_quadrature": 16,
        }

    # ------------------------------------------------------------------ the model of given coefficients
    def forward_model(self, coef, actuation: Any = None) -> Any:
        """The :class:`~pcs_sindy.models.forward.ForwardModel` of ``coef``.

        ``basis="physical"``: the compiled :class:`~pcs_sindy.models.forward.LumpedPCSModel`
        of its lumped parameters.  ``basis="monomial"``: a
        :class:`~pcs_sindy.models.forward.CallableModel` evaluating ``M`` and the bias
        forces from the monomials of the Euler–Lagrange images (the structure is
        built once per library; a call is a fixed number of numpy operations).
        """
        from ...models.forward import CallableModel, LumpedPCSModel

        self._ensure_setup()
        c = self._coef(coef)
        if self.basis == "physical":
            return LumpedPCSModel.from_lumped(self.kinematics, self.lumped_from_coef(c), actuation)
        tables = self._tables()
        pi_g, damping = self._pi_products(c), c[self._n_f :]
        return CallableModel(
            self.kinematics,
            tables.make(pi_g, damping),
            lambda q, qd: tables.evaluate(pi_g, damping, q, qd),
            actuation=actuation,
        )

    def equations(self, coef, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """``L = c_1 [unit_1] f_1 + c_2 [unit_2] f_2 + ...`` over the basis functions, the units, ``D = diag(...)``.

        Terms with ``|c_j| <= threshold`` (and exact zeros) are hidden; each coefficient carries its
        unit in brackets (:meth:`coefficient_units`; ``L`` in J).
        """
        self._ensure_setup()
        c = self._coef(coef)
        terms = []
        units = self.coefficient_units()
        for cj, name, unit in zip(c[: self._n_f], self.get_feature_names(), units):
            if cj == 0 or abs(cj) <= threshold:
                continue
            tag = "" if unit is None or unit.dimensionless else f" [{unit}]"
            terms.append(f"{'-' if cj < 0 else '+'} {abs(cj):.{precision}g}{tag} {name}")
        lag = " ".join(terms) if terms else "0"
        lag = lag[2:] if lag.startswith("+ ") else "-" + lag[2:] if lag.startswith("- ") else lag
        return [f"L = {lag}", self._units_line() + "; L [J]", self._damping_line(c, precision)]
