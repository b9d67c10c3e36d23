"""Physically parameterised library of a spatial (3-D) PCS robot: linear in per-segment physics.

The spatial counterpart of :class:`~pcs_sindy.identification.library.physical.PhysicalPCSLibrary`
(issue 26 conventions: six strains per segment, :data:`~pcs_sindy.core.spatial.SPATIAL_STRAIN_NAMES`).
With the position Jacobian ``J_p`` (base frame), the body angular Jacobian ``J_w``, the body
angular velocity ``ω = J_w q̇`` and ``Ī = diag(1, 2, 1)`` (bending about x and z, torsion about
the tangent y with the polar moment ``J = 2I``) the generalised forces are

    τ = Σ_i ρA_i ∫_i J_pᵀ (J_p q̈ + J̇_p q̇ − g) ds
      + Σ_i ρI_i ∫_i J_wᵀ (Ī (J_w q̈ + J̇_w q̇) + ω × Ī ω) ds + K q + D q̇ − f0,

linear in the per-segment parameters (line density ``ρA_i``, rotary line inertia ``ρI_i``,
the stiffness and damping of every active strain, optional constant forces ``f0``).  Every
column of ``Psi`` is that inverse dynamics with one unit parameter, by Gauss–Legendre quadrature
of the closed-form spatial Jacobians (:func:`pcs_sindy.models.spatial_forward.node_terms`),
exact at every strain magnitude (no ε anywhere).

Coefficient layout: per segment ``i``: ``rhoA_i``, ``rhoI_i`` (``rotary_inertia="free"``), with
``identify_gravity`` ``rhoAgx_i``, ``rhoAgy_i``, ``rhoAgz_i``, then ``k_<strain>_i`` of each active
strain; after all segments ``f0_<strain>_i`` (``rest_strain``) and the dampings ``d_<strain>_i``
(last).  Columns that vanish because no strain they act through is active are dropped (``rhoI_i``
needs a bending or twist strain at or before segment ``i``).  ``density="uniform"`` replaces the
``rhoA_i`` by one line density ``rhoA`` of the whole robot (first column), and
``identify_gravity="shared"`` the ``rhoAg<a>_i`` by one weight vector ``rhoAgx, rhoAgy, rhoAgz``
(after it; with ``density="segment"``: ``rhoAg<a>_i = rhoA_i g_a`` needs per-segment columns), the
physically consistent model of a uniform robot whose gravity direction in the base frame is not
known (a base fitted to markers): the mass matrix is positive definite whenever ``rhoA > 0``.

Weak form: ``P`` (generalised momentum per unit parameter: ``∫ J_pᵀ ṗ ds``, ``∫ J_wᵀ Ī ω ds``, ``q``
for damping) exactly, and ``R = −∂L/∂q`` with the kinetic-energy gradients by a central
difference at fixed rates (steps ``1e-6`` of :data:`~pcs_sindy.core.spatial.SPATIAL_Q_MAX`,
relative error about 1e-10).

This module imports only core and models (never the simulator).
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.feature_library.base import x_sequence_or_item
from pysindy.utils import AxesArray, comprehend_axes
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import check_is_fitted

from ...core.spatial import SPATIAL_Q_MAX, SPATIAL_STRAIN_NAMES, SpatialPCS
from ...core.units import (
    KILOGRAM,
    METRE,
    NEWTON,
    generalised_force_unit,
    strain_rate_unit,
    strain_unit,
)
from ...core.validation import Check, Interval, InvalidParameterError, Options, validate_parameters
from ...models.spatial_forward import BODY_INERTIA, node_terms, spatial_quadrature
from ..least_squares import stiffness_bounds
from ._physical_layout import CachedLayout
from .base import LagrangianLibrary

__all__ = ["SpatialPhysicalPCSLibrary", "spatial_kinematics_of", "spatial_stiffness_bounds"]

_CHUNK = 256  # samples per vectorised block
_ROTATIONAL = (0, 1, 2)  # bend_z, bend_x, twist: the strains that turn the cross-sections
_FD_STEP = 1e-6 * np.asarray(SPATIAL_Q_MAX)


def spatial_kinematics_of(x: Any) -> SpatialPCS | None:
    """The :class:`~pcs_sindy.core.spatial.SpatialPCS` shared by spatial strain trajectories, else None.

    Any trajectory whose ``kinematics`` is a ``SpatialPCS`` counts (``SpatialStrainTrajectory``, or a
    ``StrainTrajectory`` of spatial strains).  None for planar trajectories or arrays.

    Raises
    ------
    ValueError
        When spatial and planar trajectories are mixed or the segmentations differ.
    """
    items = list(x) if isinstance(x, (list, tuple)) else [x]
    spatial = [isinstance(getattr(r, "kinematics", None), SpatialPCS) for r in items]
    if not items or not any(spatial):
        return None
    if not all(spatial):
        raise ValueError("x must hold only spatial strain trajectories or only planar ones, not both")
    kin = items[0].kinematics
    for k, rec in enumerate(items[1:], start=1):
        rk = rec.kinematics
        if not (
            np.allclose(rk.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0)
            and np.array_equal(rk.active_strains, kin.active_strains)
        ):
            raise ValueError(
                f"x[{k}] has segment_lengths {list(rk.segment_lengths)} and active strains "
                f"{rk.active_strains.astype(int).tolist()}, x[0] {list(kin.segment_lengths)} and "
                f"{kin.active_strains.astype(int).tolist()}; every recording must share one segmentation"
            )
    return SpatialPCS(kin.segment_lengths, kin.active_strains)


def spatial_stiffness_bounds(
    segment_lengths: Sequence[float],
    *,
    youngs_modulus_max: float = 100e6,
    shear_modulus_max: float = 0.1e6,
    radius: float = 0.02,
    shear_factor: float = 4.0 / 3.0,
    stiffness_scaling: str = "seed",
) -> NDArray[np.float64]:
    """Maximum stiffness of every spatial strain, ``f_L diag(I E, I E, 2 I G, c A G, c A G, A E)`` per segment.

    Returns
    -------
    ndarray, shape (6m,)
        In the strain order of :data:`~pcs_sindy.core.spatial.SPATIAL_STRAIN_NAMES`.
    """
    # the planar bounds f_L [I E, c A G, A E] (arguments checked there) and the torsion f_L 2 I G from them
    bend, shear, axial = (
        stiffness_bounds(
            segment_lengths,
            youngs_modulus_max=youngs_modulus_max,
            shear_modulus_max=shear_modulus_max,
            radius=radius,
            shear_factor=shear_factor,
            stiffness_scaling=stiffness_scaling,
        )
        .reshape(-1, 3)
        .T
    )
    twist = bend * (2.0 * shear_modulus_max / youngs_modulus_max)
    return np.stack([bend, bend, twist, shear, shear, axial], axis=1).reshape(-1)


def _mask6_ok(value: Any) -> bool:
    raw = np.asarray(value)
    shaped = (raw.ndim == 2 and raw.shape[0] >= 1 and raw.shape[1] == 6) or (
        raw.ndim == 1 and raw.size >= 6 and raw.size % 6 == 0
    )
    return shaped and (raw.dtype == bool or bool(np.all(np.isin(raw, (0, 1)))))


def _radius_ok(value: Any) -> bool:
    radius = np.asarray(value, dtype=float)
    return radius.ndim <= 1 and radius.size > 0 and bool(np.all(np.isfinite(radius)) and np.all(radius > 0))


def _gravity3_ok(value: Any) -> bool:
    g = np.asarray(value, dtype=float)
    return g.shape == (3,) and bool(np.all(np.isfinite(g)))


def _rest_kinds(rest_strain: Any) -> tuple[str, ...]:
    if isinstance(rest_strain, (bool, np.bool_)):
        return SPATIAL_STRAIN_NAMES if rest_strain else ()
    if isinstance(rest_strain, (tuple, list)) and all(k in SPATIAL_STRAIN_NAMES for k in rest_strain):
        return tuple(rest_strain)
    raise ValueError(
        f"rest_strain must be True, False or a tuple of strain kinds from {SPATIAL_STRAIN_NAMES}; got {rest_strain!r}"
    )


def _rest_ok(value: Any) -> bool:
    try:
        _rest_kinds(value)
    except ValueError:
        return False
    return True


class _Layout:
    """Validated column layout and quadrature of a library on one segmentation."""

    def __init__(self, lib: SpatialPhysicalPCSLibrary, kin: SpatialPCS) -> None:
        validate_parameters(lib)
        m = kin.n_segments
        radius = np.asarray(lib.radius, dtype=float)
        radius = np.full(m, float(radius)) if radius.ndim == 0 else radius
        if radius.shape != (m,):
            raise ValueError(f"radius must be one value or one per segment ({m}); got {lib.radius!r}")
        self.kin, self.radius = kin, radius
        self.gravity = np.asarray(lib.gravity, dtype=float)
        self.tie = radius**2 / 4.0 if lib.rotary_inertia == "tied" else np.zeros(m)
        self.quadrature = spatial_quadrature(kin.segment_lengths, int(lib.n_quadrature))
        self.mask = kin.active_mask.copy()
        self.active = np.flatnonzero(self.mask)
        self.n = self.active.size
        if self.n == 0:
            raise ValueError("active_strains must leave at least one strain active")
        row_of = -np.ones(6 * m, dtype=int)
        row_of[self.active] = np.arange(self.n)
        self.row_of = row_of
        self.identify_gravity = bool(lib.identify_gravity)
        self.shared_gravity = lib.identify_gravity == "shared"
        self.uniform = lib.density == "uniform"
        names: list[str] = []
        kinds: list[tuple[str, int, int]] = []  # (kind, segment (-1: every segment), full strain index or axis)
        if self.uniform:
            names.append("rhoA")
            kinds.append(("rhoA", -1, -1))
        if self.shared_gravity:
            for a, axis in enumerate("xyz"):
                names.append(f"rhoAg{axis}")
                kinds.append(("g", -1, a))
        for i in range(m):
            seg = i + 1
            before = self.mask[: 6 * (i + 1)].reshape(-1, 6)
            if before.any() and not self.uniform:
                names.append(f"rhoA_{seg}")
                kinds.append(("rhoA", i, -1))
            if before[:, _ROTATIONAL].any() and lib.rotary_inertia == "free":
                names.append(f"rhoI_{seg}")
                kinds.append(("rhoI", i, -1))
            if self.identify_gravity and not self.shared_gravity and before.any():
                for a, axis in enumerate("xyz"):
                    names.append(f"rhoAg{axis}_{seg}")
                    kinds.append(("g", i, a))
            for c in range(6):
                e = 6 * i + c
                if self.mask[e]:
                    names.append(f"k_{SPATIAL_STRAIN_NAMES[c]}_{seg}")
                    kinds.append(("k", i, e))
        with_rest = _rest_kinds(lib.rest_strain)
        for e in self.active:
            if SPATIAL_STRAIN_NAMES[e % 6] in with_rest:
                names.append(f"f0_{SPATIAL_STRAIN_NAMES[e % 6]}_{e // 6 + 1}")
                kinds.append(("f0", e // 6, e))
        for e in self.active:
            names.append(f"d_{SPATIAL_STRAIN_NAMES[e % 6]}_{e // 6 + 1}")
            kinds.append(("d", e // 6, e))
        self.names, self.kinds = names, kinds
        self.n_coef = len(names)
        self.col = {name: j for j, name in enumerate(names)}
        self.stiffness_index = np.array([j for j, k in enumerate(kinds) if k[0] == "k"], dtype=int)
        self.damping_index = np.array([j for j, k in enumerate(kinds) if k[0] == "d"], dtype=int)
        self.rest_index = np.array([j for j, k in enumerate(kinds) if k[0] == "f0"], dtype=int)
        self.rest_rows = np.array([row_of[k[2]] for k in kinds if k[0] == "f0"], dtype=int)
        self.lower = np.where([k[0] in ("g", "f0") for k in kinds], -np.inf, 0.0)
        self.cols = {
            kind: [(j, k[1], k[2]) for j, k in enumerate(kinds) if k[0] == kind] for kind in ("rhoA", "rhoI", "g")
        }

    def segments(self, i: int) -> list[int]:
        """The segments a column of segment ``i`` acts on (``i = -1``: all of them)."""
        return list(range(self.kin.n_segments)) if i < 0 else [i]


class SpatialPhysicalPCSLibrary(CachedLayout, LagrangianLibrary):
    """Euler–Lagrange regressor of a spatial PCS robot, linear in per-segment physical parameters.

    Implements the :class:`~pcs_sindy.identification.library.base.LagrangianLibrary` contract for a
    :class:`~pcs_sindy.core.spatial.SpatialPCS` segmentation; chosen by
    :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor` for spatial strain
    trajectories.  All ``q``, ``qd``, ``qdd`` inputs hold the *active* strains only.

    Parameters
    ----------
    segment_lengths : sequence of float, shape (m,), optional
        Segment rest lengths [m]; default: the data's (set in :meth:`fit`).
    active_strains : array_like of bool, shape (m, 6) or (6m,), optional
        Modelled strains (default: all, or the data's).
    radius : float or sequence of float, default 0.02
        Cross-section radius [m] (``coefficients_from_parameters`` and ``rotary_inertia="tied"``).
    gravity : sequence of float, shape (3,), default (0, 9.81, 0)
        Known gravity in the base frame (the robot hangs along +y by default).
    identify_gravity : bool or "shared", default False
        Identify ``rhoA_i g`` as three free columns per segment instead; ``"shared"``: one weight
        vector ``rhoA g`` for all segments (needs ``density="uniform"``).
    density : {"segment", "uniform"}, default "segment"
        One line density per segment, or one for the whole robot.
    n_quadrature : int, default 16
        Gauss–Legendre nodes per segment.
    rotary_inertia : {"free", "tied", "none"}, default "free"
        Identify ``rhoI_i``; tie it to ``rhoA_i r_i^2 / 4``; or neglect it.
    rest_strain : bool or tuple of str, default True
        Identify a constant force ``f0`` per active strain (all, none, or the named kinds).
    mass : float, optional
        Total mass [kg]: fixes the scale when every input gain is identified (``Σ rhoA_i L_i = mass``).

    Attributes
    ----------
    segmentation_ : SpatialPCS
        After :meth:`fit` on strain trajectories: their segmentation.
    n_coefficients_, stiffness_index_, damping_index_, rest_force_index_, lower_bounds_
        As in :class:`~pcs_sindy.identification.library.physical.PhysicalPCSLibrary`.
    column_map_ : ndarray of int
        Only on libraries made by :meth:`restrict`: the parent's column of each column.
    """

    def __init__(
        self,
        segment_lengths: Sequence[float] | None = None,
        active_strains: ArrayLike | None = None,
        radius: float | Sequence[float] = 0.02,
        gravity: Sequence[float] = (0.0, 9.81, 0.0),
        identify_gravity: bool | str = False,
        n_quadrature: int = 16,
        rotary_inertia: str = "free",
        rest_strain: Any = True,
        mass: float | None = None,
        density: str = "segment",
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
        self.density = density

    _parameter_constraints: dict = {
        "segment_lengths": LagrangianLibrary._parameter_constraints["segment_lengths"],
        "active_strains": [None, Check(_mask6_ok, "booleans (or 0/1) of shape (m, 6) or (6m,)")],
        "radius": [Check(_radius_ok, "a finite number > 0 or one per segment [m]")],
        "gravity": [Check(_gravity3_ok, "three finite numbers (g_x, g_y, g_z) [m/s^2]")],
        "identify_gravity": ["boolean", Options(("shared",))],
        "n_quadrature": [Interval(Integral, 1, None, closed="left")],
        "rotary_inertia": [Options(("free", "tied", "none"))],
        "rest_strain": ["boolean", Check(_rest_ok, f"a tuple of strain kinds from {SPATIAL_STRAIN_NAMES}")],
        "mass": [None, Interval(Real, 0, None, closed="neither")],
        "density": [Options(("segment", "uniform"))],
    }

    # -- segmentation ------------------------------------------------------------
    @property
    def kinematics(self) -> SpatialPCS:
        """The segmentation this library describes (fitted, else the constructor's)."""
        fitted = self.__dict__.get("segmentation_")
        if fitted is not None:
            return fitted
        if self.segment_lengths is None:
            raise NotFittedError(
                f"{type(self).__name__} has no segmentation yet: fit it on spatial strain trajectories or give "
                "segment_lengths"
            )
        lengths = tuple(np.atleast_1d(np.asarray(self.segment_lengths, dtype=float)))
        return SpatialPCS(lengths, active_strains=self.active_strains)

    def _check_segmentation(self) -> None:
        lengths, mask = self.segment_lengths, self.active_strains
        if lengths is None or mask is None:
            return
        m = np.atleast_1d(np.asarray(lengths, dtype=float)).size
        if np.shape(mask) not in ((m, 6), (6 * m,)):
            want = f"of shape ({m}, 6) or ({6 * m},) for the {m} segment(s) of segment_lengths"
            raise InvalidParameterError.of(self, "active_strains", want, mask)

    def fit(self, x: Any, y: Any = None) -> SpatialPhysicalPCSLibrary:
        """Set the segmentation (from spatial strain trajectories) or check state arrays ``[q, qd]``.

        Parameters
        ----------
        x : list of spatial strain trajectories, or array_like of shape (n_samples, 2n) (or a list of them)
        y : ignored

        Returns
        -------
        self
        """
        validate_parameters(self)
        self._check_segmentation()
        if self.identify_gravity == "shared" and self.density != "uniform":
            raise ValueError(
                f"identify_gravity='shared' needs density='uniform' (one weight vector rhoA g is one line density "
                f"times one gravity); got density={self.density!r}: set density='uniform' or identify_gravity=True"
            )
        kin = spatial_kinematics_of(x)
        if kin is None:
            arrays = self.check_states(x)
            _ = self.kinematics  # raises NotFittedError without any segmentation
            width = 2 * int(self.kinematics.n_active)
            got = {a.shape[-1] for a in arrays}
            if got != {width}:
                raise ValueError(
                    f"x must have 2n = {width} columns [q, qd] of the {width // 2} active strains; got widths "
                    f"{sorted(got)}"
                )
        else:
            if self.segment_lengths is not None:
                own = SpatialPCS(
                    tuple(np.atleast_1d(np.asarray(self.segment_lengths, dtype=float))),
                    active_strains=self.active_strains,
                )
                if not (
                    np.allclose(own.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0)
                    and np.array_equal(own.active_strains, kin.active_strains)
                ):
                    raise ValueError(
                        f"segment_lengths {list(own.segment_lengths)} with active strains "
                        f"{own.active_strains.astype(int).tolist()} differ from the data's {list(kin.segment_lengths)} "
                        f"with {kin.active_strains.astype(int).tolist()}; leave segment_lengths=None"
                    )
            self.__dict__["segmentation_"] = kin
            width = 2 * int(kin.n_active)
        _ = self.n_coefficients_
        self.n_features_in_ = width
        self.n_output_features_ = self.n_lagrangian_terms
        return self

    _layout_class = _Layout

    def _layout_key_extra(self) -> tuple:
        return (self.density,)

    def scale_constraint(self) -> tuple[NDArray[np.float64], float] | None:
        """``Σ_i rhoA_i L_i = mass`` when ``mass`` is given, else None."""
        if self.mass is None:
            return None
        lay = self._spec
        if not lay.uniform and len(lay.cols["rhoA"]) != lay.kin.n_segments:
            raise ValueError("mass fixes the scale only when every segment's density is identified")
        a = np.zeros(lay.n_coef)
        for j, i, _ in lay.cols["rhoA"]:
            a[j] = sum(lay.kin.segment_lengths[k] for k in lay.segments(i))
        return a, float(self.mass)

    # -- evaluation ------------------------------------------------------------------
    def _check_states(self, **arrays: ArrayLike) -> list[NDArray[np.float64]]:
        n = self._spec.n
        out, shape = [], None
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
        lay = self._spec
        out = np.zeros((a.shape[0], lay.kin.n_q))
        out[:, lay.active] = a
        return out

    def _psi_block(self, q: NDArray, qd: NDArray, qdd: NDArray) -> NDArray[np.float64]:
        lay = self._spec
        B, n = q.shape
        act = lay.active
        f = node_terms(lay.kin, lay.quadrature, self._full(q), self._full(qd), self._full(qdd))
        out = np.zeros((B, n, lay.n_coef))
        g = np.zeros(3) if lay.identify_gravity else lay.gravity
        for j, i, _ in lay.cols["rhoA"]:
            col = np.zeros((B, lay.kin.n_q))
            for k in lay.segments(i):
                col += f["trans"][:, k] - f["grav"][:, k] @ g
                if lay.tie[k]:
                    col = col + lay.tie[k] * f["rot"][:, k]
            out[:, :, j] = col[:, act]
        for j, i, _ in lay.cols["rhoI"]:
            out[:, :, j] = f["rot"][:, i][:, act]
        for j, i, a in lay.cols["g"]:
            out[:, :, j] = -f["grav"][..., a][:, lay.segments(i)].sum(axis=1)[:, act]
        rows = np.arange(n)
        out[:, rows, lay.stiffness_index] = q
        out[:, rows, lay.damping_index] = qd
        if lay.rest_index.size:
            out[:, lay.rest_rows, lay.rest_index] = -1.0
        return out

    def euler_lagrange_matrix(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Regressor ``Psi`` with ``tau = Psi @ coef``, shape (n_samples, n, n_coefficients_)."""
        q, qd, qdd = self._check_states(q=q, qd=qd, qdd=qdd)
        out = np.empty((q.shape[0], self._spec.n, self._spec.n_coef))
        for a in range(0, q.shape[0], _CHUNK):
            b = a + _CHUNK
            out[a:b] = self._psi_block(q[a:b], qd[a:b], qdd[a:b])
        return out

    def _lumped_inertia(self, coef: NDArray) -> tuple[NDArray, NDArray]:
        lay = self._spec
        m = lay.kin.n_segments
        rhoA, rhoI = np.zeros(m), np.zeros(m)
        for j, i, _ in lay.cols["rhoA"]:
            for k in lay.segments(i):
                rhoA[k] = coef[j]
                rhoI[k] += lay.tie[k] * coef[j]
        for j, i, _ in lay.cols["rhoI"]:
            rhoI[i] += coef[j]
        return rhoA, rhoI

    def mass_matrix(self, q: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """Mass matrix ``M(q)`` of the parameters ``coef``, shape (n_samples, n, n)."""
        coef = self._check_coef(coef)
        (q,) = self._check_states(q=q)
        lay = self._spec
        rhoA, rhoI = self._lumped_inertia(coef)
        out = np.empty((q.shape[0], lay.n, lay.n))
        for a in range(0, q.shape[0], _CHUNK):
            f = node_terms(lay.kin, lay.quadrature, self._full(q[a : a + _CHUNK]), mass=True)
            M = np.einsum("j,bjac->bac", rhoA, f["M_trans"]) + np.einsum("j,bjac->bac", rhoI, f["M_rot"])
            out[a : a + _CHUNK] = M[:, lay.active][:, :, lay.active]
        return out

    def bias_forces(self, q: ArrayLike, qd: ArrayLike, coef: ArrayLike) -> NDArray[np.float64]:
        """All forces but ``M q̈``: Coriolis, gravity, ``K q + D q̇ − f0``, shape (n_samples, n)."""
        coef = self._check_coef(coef)
        q, qd = self._check_states(q=q, qd=qd)
        return self.euler_lagrange_matrix(q, qd, np.zeros_like(q)) @ coef

    # -- weak form -------------------------------------------------------------------
    def weak_terms(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Momentum part ``P`` and remainder ``R`` of ``Psi = dP/dt + R``, each (n_samples, n, n_coefficients_).

        ``P``: ``∫_i J_pᵀ ṗ ds`` (``rhoA_i``), ``∫_i J_wᵀ Ī ω ds`` (``rhoI_i``), ``q`` (damping);
        ``R = −∂L/∂q`` per unit parameter, the kinetic-energy gradients by central differences.
        """
        q, qd = self._check_states(q=q, qd=qd)
        lay = self._spec
        mom = np.empty((q.shape[0], lay.n, lay.n_coef))
        rest = np.empty_like(mom)
        for a in range(0, q.shape[0], _CHUNK):
            b = a + _CHUNK
            mom[a:b], rest[a:b] = self._weak_block(q[a:b], qd[a:b])
        return mom, rest

    def _energies(self, qf: NDArray, qdf: NDArray) -> tuple[NDArray, NDArray]:
        """Per-segment ``1/2 ∫ |ṗ|² ds`` and ``1/2 ∫ ωᵀ Ī ω ds``, each (B, m)."""
        lay = self._spec
        s, w, seg = lay.quadrature
        v, om = lay.kin.velocities(qf, qdf, s)  # (B, K, 3)
        onehot = np.zeros((s.size, lay.kin.n_segments))
        onehot[np.arange(s.size), seg] = w
        return 0.5 * np.sum(v**2, axis=-1) @ onehot, 0.5 * np.sum(BODY_INERTIA * om**2, axis=-1) @ onehot

    def _weak_block(self, q: NDArray, qd: NDArray) -> tuple[NDArray, NDArray]:
        lay = self._spec
        B, n = q.shape
        m = lay.kin.n_segments
        act = lay.active
        qf, qdf = self._full(q), self._full(qd)
        f = node_terms(lay.kin, lay.quadrature, qf, mass=True)
        # generalised momenta per unit parameter: M_i q̇
        P_t = np.einsum("bjac,bc->bja", f["M_trans"], qdf)[:, :, act]
        P_r = np.einsum("bjac,bc->bja", f["M_rot"], qdf)[:, :, act]
        # kinetic-energy gradients at fixed rates, central differences along every active strain
        h = _FD_STEP[act % 6]
        shifts = np.zeros((2 * n, lay.kin.n_q))
        shifts[np.arange(n), act] = h
        shifts[n + np.arange(n), act] = -h
        qs = (qf[:, None, :] + shifts[None]).reshape(-1, lay.kin.n_q)
        qds = np.repeat(qdf, 2 * n, axis=0)
        T_t, T_r = (e.reshape(B, 2 * n, m) for e in self._energies(qs, qds))
        dT_t = (T_t[:, :n] - T_t[:, n:]) / (2 * h[None, :, None])  # (B, n, m)
        dT_r = (T_r[:, :n] - T_r[:, n:]) / (2 * h[None, :, None])
        g = np.zeros(3) if lay.identify_gravity else lay.gravity
        mom = np.zeros((B, n, lay.n_coef))
        rest = np.zeros((B, n, lay.n_coef))
        for j, i, _ in lay.cols["rhoA"]:
            for k in lay.segments(i):
                mom[:, :, j] += P_t[:, k] + lay.tie[k] * P_r[:, k]
                rest[:, :, j] += -dT_t[:, :, k] - lay.tie[k] * dT_r[:, :, k] - (f["grav"][:, k] @ g)[:, act]
        for j, i, _ in lay.cols["rhoI"]:
            mom[:, :, j] = P_r[:, i]
            rest[:, :, j] = -dT_r[:, :, i]
        for j, i, a in lay.cols["g"]:
            rest[:, :, j] = -f["grav"][..., a][:, lay.segments(i)].sum(axis=1)[:, act]
        rows = np.arange(n)
        rest[:, rows, lay.stiffness_index] = q
        if lay.rest_index.size:
            rest[:, lay.rest_rows, lay.rest_index] = -1.0
        mom[:, rows, lay.damping_index] = q
        return mom, rest

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
        """Coefficients of a robot of the given material (the simulator's parameters), shape (n_coefficients_,).

        ``rhoA = ρ π r²``, ``rhoI = ρ π r⁴/4``, ``k = f_L (E I, E I, G 2I, c G A, c G A, E A)``,
        ``d`` (``damping``: (6m,) all strains or (n,) active), ``f0 = 0``; ``gravity`` (3,) fills the
        ``rhoAg`` columns with ``identify_gravity`` (default the library's).
        """
        lay = self._spec
        m = lay.kin.n_segments

        def per_seg(val: Any, name: str, positive: bool) -> NDArray[np.float64]:
            arr = np.asarray(val, dtype=float)
            arr = np.full(m, float(arr)) if arr.ndim == 0 else arr
            if arr.shape != (m,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0 if positive else arr < 0):
                raise ValueError(f"{name} must be a finite scalar or ({m},) array {'> 0' if positive else '>= 0'}")
            return arr

        rho = per_seg(density, "density", True)
        r = lay.radius if radius is None else per_seg(radius, "radius", True)
        E = per_seg(youngs_modulus, "youngs_modulus", False)
        G = per_seg(shear_modulus, "shear_modulus", False)
        d = np.asarray(damping, dtype=float)
        if d.shape == (lay.n,) and lay.n != 6 * m:
            full = np.zeros(6 * m)
            full[lay.active] = d
            d = full
        if d.shape != (6 * m,) or not np.all(np.isfinite(d)) or np.any(d < 0):
            raise ValueError(f"damping must have shape ({6 * m},) or ({lay.n},), finite and >= 0; got {d.shape}")
        if stiffness_scaling not in ("seed", "length"):
            raise ValueError(f"stiffness_scaling must be 'seed' or 'length'; got {stiffness_scaling!r}")
        f_l = np.ones(m) if stiffness_scaling == "seed" else np.asarray(lay.kin.segment_lengths)
        g = lay.gravity if gravity is None else np.asarray(gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity must be a finite vector of shape (3,); got {gravity!r}")
        if not lay.identify_gravity and not np.allclose(g, lay.gravity, rtol=1e-12, atol=0.0):
            raise ValueError(f"gravity {g.tolist()} differs from the library's known gravity {lay.gravity.tolist()}")
        area, inertia = np.pi * r**2, np.pi * r**4 / 4.0
        if lay.uniform and not np.allclose(rho * area, rho[0] * area[0], rtol=1e-12, atol=0.0):
            raise ValueError(
                f"density='uniform' needs one line density rho pi r^2 for every segment; got {(rho * area).tolist()}"
            )
        c = shear_factor
        per = np.stack([E * inertia, E * inertia, 2 * G * inertia, c * G * area, c * G * area, E * area], axis=1)
        stiff = (f_l[:, None] * per).reshape(-1)
        out = np.empty(lay.n_coef)
        for j, (kind, i, e) in enumerate(lay.kinds):
            if kind == "rhoA":
                out[j] = rho[max(i, 0)] * area[max(i, 0)]
            elif kind == "rhoI":
                out[j] = rho[i] * inertia[i]
            elif kind == "g":
                out[j] = rho[max(i, 0)] * area[max(i, 0)] * g[e]
            elif kind == "k":
                out[j] = stiff[e]
            elif kind == "d":
                out[j] = d[e]
            else:
                out[j] = 0.0
        return out

    # -- structure changes -------------------------------------------------------------------
    def restrict(self, active_strains: ArrayLike) -> SpatialPhysicalPCSLibrary:
        """Library of a subset of the active strains (removed strains held at 0), with ``column_map_``."""
        lay = self._spec
        m = lay.kin.n_segments
        new = np.asarray(active_strains)
        if new.shape not in ((m, 6), (6 * m,)):
            raise ValueError(f"active_strains must have shape ({m}, 6) or ({6 * m},); got {new.shape}")
        if new.dtype != bool and not np.all(np.isin(new, (0, 1))):
            raise ValueError(f"active_strains must be boolean; got {new.tolist()}")
        new = new.astype(bool).reshape(m, 6)
        extra = new.reshape(-1) & ~lay.mask
        if np.any(extra):
            names = [lay.kin.strain_names()[e] for e in np.flatnonzero(extra)]
            raise ValueError(f"active_strains may only remove strains; {names} are not active in this library")
        child = SpatialPhysicalPCSLibrary(
            lay.kin.segment_lengths,
            active_strains=new,
            radius=self.radius,
            gravity=self.gravity,
            identify_gravity=self.identify_gravity,
            n_quadrature=self.n_quadrature,
            rotary_inertia=self.rotary_inertia,
            rest_strain=self.rest_strain,
            mass=self.mass,
            density=self.density,
        )
        child.column_map_ = np.array([lay.col[name] for name in child._spec.names], dtype=int)
        if hasattr(self, "n_features_in_"):
            child.fit(np.zeros((1, 2 * child._spec.n)))
        return child

    # -- the model of given coefficients ---------------------------------------------------
    def lumped_from_coef(self, coef: ArrayLike) -> dict:
        """Per-segment lumped parameters of ``coef``: the arguments of :class:`~pcs_sindy.models.SpatialPCSModel`."""
        coef = self._check_coef(coef)
        lay = self._spec
        rhoA, rhoI = self._lumped_inertia(coef)
        if lay.identify_gravity:
            rhoAg = np.zeros((lay.kin.n_segments, 3))
            for j, i, a in lay.cols["g"]:
                rhoAg[lay.segments(i), a] = coef[j]
        else:
            rhoAg = rhoA[:, None] * lay.gravity[None, :]
        return {
            "rhoA": rhoA,
            "rhoI": rhoI,
            "rhoAg": rhoAg,
            "stiffness": self.stiffness_from_coef(coef),
            "damping": self.damping_from_coef(coef),
            "rest_force": self.rest_force_from_coef(coef),
            "n_quadrature": int(self.n_quadrature),
        }

    def forward_model(self, coef: ArrayLike, actuation: Any = None) -> Any:
        """The :class:`~pcs_sindy.models.SpatialPCSModel` of ``coef`` (rollouts, controllers)."""
        from ...models.spatial_forward import SpatialPCSModel

        return SpatialPCSModel(self.kinematics, **self.lumped_from_coef(coef), actuation=actuation)

    def coefficient_units(self) -> list[Any]:
        """Unit of each parameter (:mod:`pcs_sindy.core.units`): ``rhoA`` kg/m, ``rhoI`` kg·m, ``rhoAg`` N/m,
        stiffness ``tau_e / q_e``, constant force ``tau_e``, damping ``tau_e / qd_e``."""
        names = self._spec.kin.strain_names()
        per_segment = {"rhoA": KILOGRAM / METRE, "rhoI": KILOGRAM * METRE, "g": NEWTON / METRE}
        out = []
        for kind, _, e in self._spec.kinds:
            if kind in per_segment:
                out.append(per_segment[kind])
                continue
            tau = generalised_force_unit(names[e])
            out.append({"k": tau / strain_unit(names[e]), "f0": tau, "d": tau / strain_rate_unit(names[e])}[kind])
        return out

    def equations(self, coef: ArrayLike, precision: int = 3, threshold: float = 0.0) -> list[str]:
        """The Lagrangian's structure, ``M(q)``, the units, the parameter values with units, and ``D``."""
        coef = self._check_coef(coef)
        lay = self._spec
        damp = set(int(j) for j in lay.damping_index)
        values = [
            f"{nm} = {self._with_unit(c, unit, precision)}"
            for j, (c, nm, unit) in enumerate(zip(coef, lay.names, self.coefficient_units(), strict=True))
            if j not in damp and abs(c) > threshold
        ]
        if self.mass is not None:
            values.append(f"mass = sum_i rhoA_i L_i = {float(self.mass):.{precision}g} kg")
        strain = lay.kin.strain_names(active_only=True)
        elastic = " + ".join(f"k_{s} {s}^2" for s in strain)
        if lay.rest_index.size:
            elastic += " - 2 f0^T q"
        gravity = "rhoAg_i . p" if lay.identify_gravity else "rhoA_i g . p"
        if lay.shared_gravity:
            gravity = "rhoAg . p"
        return [
            f"L = 1/2 qd^T M(q) qd + sum_i int_0^L_i {gravity} ds - 1/2 ({elastic})",
            "M(q) = sum_i int_0^L_i (rhoA_i Jp^T Jp + rhoI_i Jw^T diag(1, 2, 1) Jw) ds  (Jw: body angular Jacobian)",
            self._units_line() + "; k = f_L (E I, E I, G 2I, c_sh G A, c_sh G A, E A), f_L = 1 m (seed) or L_i",
            ", ".join(values) if values else "(all parameters 0)",
            self._damping_line(coef, precision),
        ]

    # -- pysindy feature library on states [q, qd] ----------------------------------------------
    @x_sequence_or_item
    def transform(self, x_full):
        """Lagrangian basis ``f_j(q, qd)`` of every non-damping parameter, ``L = Σ coef_j f_j``.

        ``rhoA_i``: ``1/2 ∫ |ṗ|² ds + ∫ g·p ds``; ``rhoI_i``: ``1/2 ∫ ωᵀ Ī ω ds``; ``rhoAg<a>_i``:
        ``∫ p_a ds``; ``k_e``: ``−q_e²/2``; ``f0_e``: ``q_e``.
        """
        check_is_fitted(self, "n_features_in_")
        lay = self._spec
        s, w, seg = lay.quadrature
        onehot = np.zeros((s.size, lay.kin.n_segments))
        onehot[np.arange(s.size), seg] = w
        cols = [j for j, k in enumerate(lay.kinds) if k[0] != "d"]
        out = []
        for x in x_full:
            arr = self.check_states(np.asarray(x))[0]
            if arr.shape[-1] != self.n_features_in_:
                raise ValueError(f"x must have shape (n_samples, {self.n_features_in_}); got shape {arr.shape}")
            n = lay.n
            qf, qdf = self._full(arr[:, :n]), self._full(arr[:, n:])
            T_t, T_r = self._energies(qf, qdf)
            pos = np.einsum("bkx,kj->bjx", lay.kin.forward_kinematics(qf, s)[0], onehot)  # (B, m, 3)
            g = np.zeros(3) if lay.identify_gravity else lay.gravity
            res = np.empty((arr.shape[0], len(cols)))
            for c, j in enumerate(cols):
                kind, i, e = lay.kinds[j]
                if kind == "rhoA":
                    segs = lay.segments(i)
                    res[:, c] = sum(T_t[:, k] + pos[:, k] @ g + lay.tie[k] * T_r[:, k] for k in segs)
                elif kind == "rhoI":
                    res[:, c] = T_r[:, i]
                elif kind == "g":
                    res[:, c] = pos[:, lay.segments(i), e].sum(axis=1)
                elif kind == "f0":
                    res[:, c] = arr[:, lay.row_of[e]]
                else:
                    res[:, c] = -0.5 * arr[:, lay.row_of[e]] ** 2
            out.append(AxesArray(res, comprehend_axes(res)))
        return out

    def get_feature_names(self, input_features: Sequence[str] | None = None) -> list[str]:
        """Names of the Lagrangian basis terms (see :meth:`transform`)."""
        lay = self._spec
        names = lay.kin.strain_names(active_only=True)
        if input_features is not None:
            if len(input_features) != 2 * lay.n:
                raise ValueError(f"input_features must have {2 * lay.n} names; got {len(input_features)}")
            names = list(input_features[: lay.n])
        out = []
        for kind, i, e in lay.kinds:
            seg = i + 1 if i >= 0 else "all"
            if kind == "rhoA":
                out.append(f"T_A{seg}" if lay.identify_gravity else f"T_A{seg} + int g.p ds ({seg})")
            elif kind == "rhoI":
                out.append(f"T_I{seg}")
            elif kind == "g":
                out.append(f"int {'xyz'[e]} ds ({seg})")
            elif kind == "k":
                out.append(f"-1/2 {names[lay.row_of[e]]}^2")
            elif kind == "f0":
                out.append(f"{names[lay.row_of[e]]}")
        return out
