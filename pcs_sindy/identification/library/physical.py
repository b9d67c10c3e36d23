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
(:mod:`pcs_sindy.models.pcs_numeric`) for any number of segments, batched over
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

Weak form
---------
:meth:`PhysicalPCSLibrary.weak_terms` splits ``Psi = dP/dt + R`` with the
generalised momentum per unit parameter ``P`` (``J_p^T p_dot`` for ``rhoA_i``,
``M_I,i q̇`` for ``rhoI_i``, ``q`` for a damping column) and ``R = -dL/dq``;
:func:`pcs_sindy.identification.formulations.weak_rows` integrates them against a test function.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.feature_library.base import x_sequence_or_item
from pysindy.utils import AxesArray, comprehend_axes
from sklearn.utils.validation import check_is_fitted
from tqdm.auto import tqdm

from ...core.kinematics import STRAIN_NAMES
from ...core.units import KILOGRAM, METRE, NEWTON, Unit, generalised_force_unit, strain_rate_unit, strain_unit
from ...core.validation import Check, Interval, Options
from ...models import pcs_numeric as _num
from ._physical_layout import CachedLayout, Spec, rest_kinds
from .base import LagrangianLibrary

__all__ = ["PhysicalPCSLibrary"]

_CHUNK = 512  # samples per vectorised block (bounds the memory of the node arrays)


def _radius_ok(value: Any) -> bool:
    radius = np.asarray(value, dtype=float)
    return radius.ndim <= 1 and radius.size > 0 and bool(np.all(np.isfinite(radius)) and np.all(radius > 0))


def _rest_kinds_ok(value: Any) -> bool:
    return rest_kinds(value) is not None  # raises on anything else; () is no rest strain


def _gravity_ok(value: Any) -> bool:
    g = np.asarray(value, dtype=float)
    return g.shape == (2,) and bool(np.all(np.isfinite(g)))


# --------------------------------------------------------------------------
# Library
# --------------------------------------------------------------------------
class PhysicalPCSLibrary(CachedLayout, LagrangianLibrary):
    """Euler–Lagrange regressor of a planar PCS robot, linear in per-segment physical parameters.

    Implements the :class:`~pcs_sindy.identification.library.base.LagrangianLibrary` contract;
    the default library of :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`.
    All ``q``, ``qd``, ``qdd`` inputs hold the *active* strains only.

    Parameters
    ----------
    segment_lengths : sequence of float, shape (m,), optional
        Segment rest lengths in metres, base to tip.  Default: taken in
        :meth:`fit` from the strain trajectories.
    active_strains : array_like of bool, shape (m, 3) or (3m,), optional
        Modelled strains (default: all, or the data's); inactive strains are held at 0.
    radius : float or sequence of float, default 0.02
        Cross-section radius (m), used by :meth:`coefficients_from_parameters`
        and ``rotary_inertia="tied"``; it does not enter the other columns.
    gravity : sequence of float, shape (2,), default (0, 9.81)
        Known gravity in the base frame (used unless ``identify_gravity``).
    identify_gravity : bool, default False
        Identify ``rhoA_i g`` as two free columns per segment instead.
    n_quadrature : int, default 16
        Gauss–Legendre nodes per segment (see docs/results.md for the
        accuracy of fewer nodes).
    rotary_inertia : {"free", "tied", "none"}, default "free"
        ``"free"``: identify ``rhoI_i`` as its own parameter; ``"tied"``: fix
        ``rhoI_i = rhoA_i r_i^2 / 4`` (solid circular section of the library's
        ``radius``; one mass parameter per segment, better conditioned under
        noise); ``"none"``: neglect rotary inertia.
    rest_strain : bool, default True
        Identify a constant generalised force ``f0_<strain>`` per active strain
        (``M q̈ + C q̇ + G + K q + D q̇ - f0 = tau``; ``f0 = K q*`` for a rest
        strain ``q*``), placed after the stiffnesses and before the damping.
        It models pre-curved robots and absorbs a rest length estimated from
        the videos rather than measured.
    mass : float, optional
        The robot's total mass [kg] when weighed.  Only used to fix the
        absolute scale of the parameters when actuator gains are identified
        (:meth:`scale_constraint`: ``sum_i rhoA_i L_i = mass``); with inputs in
        known units (generalised forces, tendon tensions) the data fix it.

    Attributes
    ----------
    segmentation_ : PlanarPCS
        After :meth:`fit` on strain trajectories: their segmentation.
    n_coefficients_ : int
        Number of parameters (damping last); see the module docstring for the layout.
    stiffness_index_, damping_index_ : ndarray of int, shape (n,)
        Column of each active strain's stiffness / damping parameter.
    rest_force_index_ : ndarray of int, shape (n,) or (0,)
        Column of each active strain's constant force ``f0`` (empty without ``rest_strain``).
    stiffness_factor_ : float
        ``1.0``: the stiffness is the coefficient itself.
    lower_bounds_ : ndarray, shape (n_coefficients_,)
        0 for densities, stiffnesses and damping, ``-inf`` for identified gravity
        terms and constant forces ``f0``.
    column_map_ : ndarray of int
        Only on libraries made by :meth:`restrict`: the parent's column of each column.
    n_features_in_, n_output_features_ : int
        After :meth:`fit`: ``2n`` and the number of Lagrangian basis terms
        (all parameters except damping; ``f0_e`` has ``q_e``).
    """

    def __init__(
        self,
        segment_lengths: Sequence[float] | None = None,
        active_strains: ArrayLike | None = None,
        radius: float | Sequence[float] = 0.02,
        gravity: Sequence[float] = (0.0, 9.81),
        identify_gravity: bool = False,
        n_quadrature: int = 16,
        rotary_inertia: str = "free",
        rest_strain: bool = True,
        mass: float | None = None,
    ) -> None:
        self.segment_lengths = segment_lengths
        self.active_strains = active_strains
        self.radius = radius
        self.gravity = gravity
        self.identify_gravity = identify_gravity
        self.n_quadrature = n_quadrature
        self.rotary_inertia = rotary_inertia
        self.rest_strain = rest_strain
        self.mass = mass

    # -- structure -------------------------------------------------------------
    #: read by validate_parameters in fit and when the column layout is built, and by model files
    _parameter_constraints: dict = {
        **LagrangianLibrary._parameter_constraints,
        "radius": [Check(_radius_ok, "a finite number > 0 or one per segment [m]")],
        "gravity": [Check(_gravity_ok, "two finite numbers (g_x, g_y) [m/s^2]")],
        "identify_gravity": ["boolean"],
        "n_quadrature": [Interval(Integral, 1, None, closed="left")],
        "rotary_inertia": [Options(("free", "tied", "none"))],
        "rest_strain": ["boolean", Check(_rest_kinds_ok, f"a tuple of strain kinds from {STRAIN_NAMES}")],
        "mass": [None, Interval(Real, 0, None, closed="neither")],
    }

    @property
    def rest_strain_kinds(self) -> tuple[str, ...]:
        """The strains (of ``"be"``, ``"sh"``, ``"ax"``) whose rest value this library identifies."""
        return rest_kinds(self.rest_strain)

    def scale_constraint(self) -> tuple[NDArray[np.float64], float] | None:
        """``sum_i rhoA_i L_i = mass`` when ``mass`` is given, else None."""
        if self.mass is None:
            return None
        spec = self._spec
        a = np.zeros(spec.n_coef)
        for j, i in spec.cols_rhoA:
            a[j] = spec.kin.segment_lengths[i]
        if len(spec.cols_rhoA) != spec.kin.n_segments:
            raise ValueError(
                "mass fixes the scale only when every segment's density is identified; a segment whose "
                "strains are all removed has none"
            )
        return a, float(self.mass)

    _layout_class = Spec

    def coefficient_units(self) -> list[Unit]:
        """Unit of each parameter (:mod:`pcs_sindy.core.units`).

        ``rhoA`` kg/m and ``rhoI`` kg·m (the kinetic energy ``1/2 int rhoA |pdot|^2 + rhoI thetadot^2 ds``
        is in J), ``rhoAg`` N/m; per strain ``e`` with generalised force ``tau_e`` (N·m² for bending,
        N·m for shear and axial strain): stiffness ``tau_e / q_e`` (N·m³, N·m), constant force ``tau_e``,
        damping ``tau_e / qd_e`` (N·m³·s, N·m·s).

        Returns
        -------
        list of Unit
        """
        names = self._spec.kin.strain_names()
        per_segment = {"rhoA": KILOGRAM / METRE, "rhoI": KILOGRAM * METRE, "gx": NEWTON / METRE, "gy": NEWTON / METRE}
        out = []
        for kind, _, e in self._spec.kinds:
            if kind in per_segment:
                out.append(per_segment[kind])
                continue
            tau = generalised_force_unit(names[e])
            out.append({"k": tau / strain_unit(names[e]), "f0": tau, "d": tau / strain_rate_unit(names[e])}[kind])
        return out

    # -- input checks ------------------------------------------------------------
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
            out[:, spec.rest_rows, spec.rest_index] = -1.0
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
    def weak_terms(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Momentum part ``P`` and remainder ``R`` of ``Psi = dP/dt + R``, each (n_samples, n, n_coefficients_).

        ``P``: the generalised momentum per unit parameter (``q`` for a damping
        column, so ``int phi qd dt = -int phi' q dt`` needs no ``qd``); ``R``:
        ``-dL/dq`` per unit parameter.
        """
        q, qd = self._check_states(q=q, qd=qd)
        spec = self._spec
        mom = np.empty((q.shape[0], spec.n, spec.n_coef))
        rest = np.empty_like(mom)
        for a in range(0, q.shape[0], _CHUNK):
            b = a + _CHUNK
            mom[a:b], rest[a:b] = self._weak_block(q[a:b], qd[a:b])
        return mom, rest

    def _weak_block(self, q: NDArray, qd: NDArray) -> tuple[NDArray, NDArray]:
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
            integrand[:, spec.rest_rows, spec.rest_index] = -1.0  # integrates to -int phi dt
        mom[:, rows, spec.damping_index] = q  # int qd dt = q(t_b) - q(t_a), exactly
        return mom, integrand

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
        per_segment = {"rhoA": rho * area, "rhoI": rho * inertia, "gx": rho * area * g[0], "gy": rho * area * g[1]}
        per_strain = {"k": stiff, "d": d}
        out = np.empty(spec.n_coef)
        for j, (kind, i, e) in enumerate(spec.kinds):
            out[j] = per_segment[kind][i] if kind in per_segment else per_strain[kind][e] if kind in per_strain else 0.0
        return out

    # -- strain removal -------------------------------------------------------------------
    def restrict(self, active_strains: ArrayLike) -> PhysicalPCSLibrary:
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
            spec.kin.segment_lengths,
            active_strains=new,
            radius=self.radius,
            gravity=self.gravity,
            identify_gravity=self.identify_gravity,
            n_quadrature=self.n_quadrature,
            rotary_inertia=self.rotary_inertia,
            rest_strain=self.rest_strain,
            mass=self.mass,
        )
        child.column_map_ = np.array([spec.col[name] for name in child._spec.names], dtype=int)
        if hasattr(self, "n_features_in_"):  # keep a fitted library fitted
            child.fit(np.zeros((1, 2 * child._spec.n)))
        return child

    # -- the model of given coefficients ---------------------------------------------------
    def forward_model(self, coef: ArrayLike, actuation: Any = None) -> Any:
        """The compiled :class:`~pcs_sindy.models.forward.LumpedPCSModel` of ``coef`` (rollouts, controllers)."""
        from ...models.forward import LumpedPCSModel

        return LumpedPCSModel.from_lumped(self.kinematics, self.lumped_from_coef(coef), actuation)

    def equations(self, coef: ArrayLike, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """The Lagrangian's structure, ``M(q)``, the units, the parameter values and ``D``.

        A physical library's coefficients are parameters of one fixed
        Lagrangian, not weights of basis functions: the structure is printed
        once, then the units of the strains and of their generalised forces, then
        every parameter with ``|value| > threshold`` with its unit
        (:meth:`coefficient_units`; damping on the last line).
        """
        coef = self._check_coef(coef)
        spec = self._spec
        damp_idx = set(int(j) for j in spec.damping_index)
        values = [
            f"{nm} = {self._with_unit(c, unit, precision)}"
            for j, (c, nm, unit) in enumerate(zip(coef, spec.names, self.coefficient_units()))
            if j not in damp_idx and abs(c) > threshold
        ]
        if self.mass is not None:
            values.append(f"mass = sum_i rhoA_i L_i = {float(self.mass):.{precision}g} kg")
        strain = spec.kin.strain_names(active_only=True)
        elastic = " + ".join(f"k_{s} {s}^2" for s in strain)
        if spec.rest_index.size:
            elastic += " - 2 f0^T q"
        gravity = "rhoAg_i . p" if spec.identify_gravity else "rhoA_i g . p"
        # k = f_L (E I, c_sh G A, E A): E I is N·m², G A and E A are N, so f_L is a length (core.units)
        return [
            f"L = 1/2 qd^T M(q) qd + sum_i int_0^L_i {gravity} ds - 1/2 ({elastic})",
            "M(q) = sum_i int_0^L_i (rhoA_i Jp^T Jp + rhoI_i Jo^T Jo) ds",
            self._units_line() + "; k = f_L (E I, c_sh G A, E A), f_L = 1 m (seed) or L_i",
            ", ".join(values) if values else "(all parameters 0)",
            self._damping_line(coef, precision),
        ]

    # -- lumped parameters (compiled rollout) -------------------------------------------------
    def lumped_from_coef(self, coef: ArrayLike) -> dict:
        """Per-segment lumped parameters of ``coef`` (the inputs of :meth:`forward_model`).

        Returns
        -------
        dict
            ``rhoA`` (m,), ``rhoI`` (m,) (rotary inertia per length, including
            the ``rotary_inertia='tied'`` share of ``rhoA``), ``rhoAg`` (m, 2)
            (identified or ``rhoA * gravity``), ``stiffness`` and ``damping`` (n,)
            of the active strains, ``rest_force`` (n,) the constant force ``f0``,
            ``n_quadrature`` (this library's rule, so the compiled model
            reproduces :meth:`mass_matrix` to round-off).
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
            arr = self.check_states(np.asarray(x))[0]
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
