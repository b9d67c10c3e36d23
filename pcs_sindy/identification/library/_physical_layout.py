"""Column layout of :class:`~pcs_sindy.identification.PhysicalPCSLibrary`: which parameter each column holds.

Built from the library's parameters and the segmentation it describes;
validated once and cached by the library.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.kinematics import STRAIN_NAMES, PlanarPCS
from ...core.validation import validate_parameters
from ...models import pcs_numeric as _num

__all__ = ["Spec", "rest_kinds"]


def rest_kinds(rest_strain: object) -> tuple[str, ...]:
    """The strain kinds with a constant force: all (True), none (False) or the named ones."""
    if isinstance(rest_strain, (bool, np.bool_)):
        return STRAIN_NAMES if rest_strain else ()
    if isinstance(rest_strain, (tuple, list)) and all(k in STRAIN_NAMES for k in rest_strain):
        return tuple(rest_strain)
    raise ValueError(
        f"rest_strain must be True, False or a tuple of strain kinds from {STRAIN_NAMES}; got {rest_strain!r}"
    )


class Spec:
    """Validated structure of a library (column layout, quadrature, constant matrices)."""

    def __init__(self, lib: Any, kin: PlanarPCS) -> None:
        validate_parameters(lib)
        lengths = np.asarray(kin.segment_lengths, dtype=float)
        self.kin = kin
        m = self.kin.n_segments
        radius = np.asarray(lib.radius, dtype=float)
        if radius.ndim == 0:
            radius = np.full(m, float(radius))
        if radius.shape != (m,):
            raise ValueError(f"radius must be one value or one per segment ({m}); got {lib.radius!r}")
        self.radius = radius
        self.gravity = np.asarray(lib.gravity, dtype=float)
        self.rotary = lib.rotary_inertia
        # rhoI_i = tie_i * rhoA_i when not identified: r^2/4 for a full circular section, or 0
        self.tie = radius**2 / 4.0 if self.rotary == "tied" else np.zeros(m)
        self.quad = _num.make_quadrature(lengths, int(lib.n_quadrature))
        self.mask = self.kin.active_mask.copy()
        self.active = np.flatnonzero(self.mask)
        self.n = self.active.size
        if self.n == 0:
            raise ValueError("active_strains must leave at least one strain active")
        row_of = -np.ones(3 * m, dtype=int)
        row_of[self.active] = np.arange(self.n)
        self.row_of = row_of
        rot = _num.rotary_mass(lengths)
        self.rot = rot[:, self.active][:, :, self.active]  # (m, n, n)

        names: list[str] = []
        kinds: list[tuple[str, int, int]] = []  # (kind, segment, full strain index)
        for i in range(m):
            any_before = bool(self.mask[: 3 * (i + 1)].any())
            bend_before = bool(self.mask[0 : 3 * (i + 1) : 3].any())
            seg = i + 1
            if any_before:
                names.append(f"rhoA_{seg}")
                kinds.append(("rhoA", i, -1))
            if bend_before and self.rotary == "free":
                names.append(f"rhoI_{seg}")
                kinds.append(("rhoI", i, -1))
            if lib.identify_gravity and any_before:
                names += [f"rhoAgx_{seg}", f"rhoAgy_{seg}"]
                kinds += [("gx", i, -1), ("gy", i, -1)]
            for c in range(3):
                e = 3 * i + c
                if self.mask[e]:
                    names.append(f"k_{STRAIN_NAMES[c]}_{seg}")
                    kinds.append(("k", i, e))
        with_rest = rest_kinds(lib.rest_strain)
        self.rest_strain = bool(with_rest)
        for e in self.active:
            if STRAIN_NAMES[e % 3] in with_rest:
                names.append(f"f0_{STRAIN_NAMES[e % 3]}_{e // 3 + 1}")
                kinds.append(("f0", e // 3, e))
        for e in self.active:
            names.append(f"d_{STRAIN_NAMES[e % 3]}_{e // 3 + 1}")
            kinds.append(("d", e // 3, e))
        self.names = names
        self.kinds = kinds
        self.n_coef = len(names)
        self.col = {name: j for j, name in enumerate(names)}
        kind_arr = np.array([k[0] for k in kinds])
        self.stiffness_index = np.array([j for j, k in enumerate(kinds) if k[0] == "k"], dtype=int)
        self.damping_index = np.array([j for j, k in enumerate(kinds) if k[0] == "d"], dtype=int)
        self.rest_index = np.array([j for j, k in enumerate(kinds) if k[0] == "f0"], dtype=int)
        self.rest_rows = np.array([row_of[k[2]] for k in kinds if k[0] == "f0"], dtype=int)
        lower = np.zeros(self.n_coef)
        lower[(kind_arr == "gx") | (kind_arr == "gy") | (kind_arr == "f0")] = -np.inf
        self.lower = lower
        # columns per kind for fast assembly
        self.cols_rhoA = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "rhoA"]
        self.cols_rhoI = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "rhoI"]
        self.cols_gx = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "gx"]
        self.cols_gy = [(j, k[1]) for j, k in enumerate(kinds) if k[0] == "gy"]
        self.identify_gravity = bool(lib.identify_gravity)
        self.g_complex = complex(self.gravity[0], self.gravity[1])


class CachedLayout:
    """What the planar and spatial physical libraries share: a column layout cached per parameter set.

    A mixin before :class:`~pcs_sindy.identification.library.base.LagrangianLibrary`.  The library names
    its layout class (``_layout_class``, built as ``_layout_class(library, kinematics)``) and may add
    parameters to the cache key (:meth:`_layout_key_extra`); the layout answers ``n_coef``, ``names``,
    ``stiffness_index``, ``damping_index``, ``rest_index``, ``rest_rows`` and ``lower``.
    """

    _layout_class: type

    def _layout_key_extra(self) -> tuple:
        return ()

    @property
    def _spec(self) -> Any:
        kin = self.kinematics  # type: ignore[attr-defined]
        key = (
            kin.segment_lengths,
            kin.active_strains.tobytes(),
            np.asarray(self.radius, dtype=float).tobytes(),  # type: ignore[attr-defined]
            np.asarray(self.gravity, dtype=float).tobytes(),  # type: ignore[attr-defined]
            self.identify_gravity,  # type: ignore[attr-defined]
            self.n_quadrature,  # type: ignore[attr-defined]
            self.rotary_inertia,  # type: ignore[attr-defined]
            str(self.rest_strain),  # type: ignore[attr-defined]
            self.mass,  # type: ignore[attr-defined]
            *self._layout_key_extra(),
        )
        cached = self.__dict__.get("_spec_cache")
        if cached is None or cached[0] != key:
            cached = (key, self._layout_class(self, kin))
            self.__dict__["_spec_cache"] = cached
        return cached[1]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_spec_cache", None)
        return state

    @property
    def n_coefficients_(self) -> int:
        return self._spec.n_coef

    @property
    def stiffness_index_(self) -> np.ndarray:
        return self._spec.stiffness_index.copy()

    @property
    def damping_index_(self) -> np.ndarray:
        return self._spec.damping_index.copy()

    @property
    def rest_force_index_(self) -> np.ndarray:
        return self._spec.rest_index.copy()

    @property
    def rest_force_rows_(self) -> np.ndarray:
        return self._spec.rest_rows.copy()

    @property
    def lower_bounds_(self) -> np.ndarray:
        return self._spec.lower.copy()

    stiffness_factor_: float = 1.0

    def coefficient_names(self) -> list[str]:
        """Names of the ``n_coefficients_`` parameters (``rhoA_1``, ``k_<strain>_1``, ``d_<strain>_2``, ...)."""
        return list(self._spec.names)
