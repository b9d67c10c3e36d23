"""Strains the recordings do not excite above their measurement noise, removed before the regression.

A strain that moves less than its per-frame noise (a tendon-driven robot's twist and shear fitted from
noisy markers) gives stiffness, damping and inertia columns made of noise, which pull the coefficients
every strain shares (the line densities) and degrade the whole fit.  :func:`unexcited_strains` measures
each strain's motion against its white-noise level (:func:`pcs_sindy.core.metrics.motion_to_noise`) and
names those below a threshold among the strain kinds asked for (:data:`EXCITATION_KINDS`);
:func:`restricted_problem` gives the regression without them (held at 0, like the stiffness threshold's
removal).  Bending is never removed: it is what the inputs move.

Knows the regression's column layout and the strain names; nothing of how the rows are built.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.metrics import motion_to_noise
from .library.with_gains import WithGains

__all__ = ["EXCITATION_KINDS", "STRAIN_KIND", "unexcited_strains", "restricted_problem", "valid_kinds"]

#: the strain kinds the excitation test may remove (bending never: it is what the inputs move)
EXCITATION_KINDS = ("twist", "shear", "axial")
#: strain name (planar and spatial, without the segment number) -> its kind
STRAIN_KIND = {"twist": "twist", "shear_x": "shear", "shear_z": "shear", "sh": "shear", "axial": "axial", "ax": "axial"}


def valid_kinds(value: object) -> bool:
    """A tuple or list of distinct :data:`EXCITATION_KINDS` (possibly empty)."""
    return (
        isinstance(value, (tuple, list)) and len(set(value)) == len(value) and all(v in EXCITATION_KINDS for v in value)
    )


def unexcited_strains(
    kin: Any, q_active: list[NDArray[np.float64]], min_excitation: float | None, kinds: tuple = EXCITATION_KINDS
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Each modelled strain's motion-to-noise ratio, and which ones fall below ``min_excitation``.

    Parameters
    ----------
    kin : PlanarPCS or SpatialPCS
        The data's segmentation (its active strains are the columns of ``q_active``).
    q_active : list of ndarray (T, n_active)
        The modelled strains of every recording.
    min_excitation : float or None
        Threshold on :func:`~pcs_sindy.core.metrics.motion_to_noise`; None or 0 removes nothing.
    kinds : tuple of str
        The strain kinds that may be removed (of :data:`EXCITATION_KINDS`).

    Returns
    -------
    ratio : ndarray, shape (n_q,)
        The ratio of every strain (NaN for a strain the data do not model).
    remove : ndarray of bool, shape (n_q,)
        Strains of ``kinds`` below the threshold (never a bending strain, never every modelled strain).
    """
    mask = np.asarray(kin.active_mask, dtype=bool)
    ratio = np.full(mask.size, np.nan)
    ratio[mask] = motion_to_noise(list(q_active))
    remove = np.zeros(mask.size, dtype=bool)
    if not min_excitation:
        return ratio, remove
    eligible = mask & np.array([STRAIN_KIND.get(name.rpartition("_")[0]) in kinds for name in kin.strain_names()])
    remove = eligible & (ratio < float(min_excitation))
    if not np.any(mask & ~remove):  # a model needs a strain: keep them all rather than none
        remove[:] = False
    return ratio, remove


def restricted_problem(
    columns: Any,
    design: Callable[[Any, NDArray[np.bool_]], NDArray[np.float64]],
    target: NDArray[np.float64],
    equality: tuple[NDArray[np.float64], float] | None,
    keep: NDArray[np.bool_],
) -> tuple[Any, NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], Callable, tuple | None]:
    """The regression of the strains ``keep`` (bool over the library's active strains), the others held at 0.

    Parameters
    ----------
    columns : LagrangianLibrary or WithGains
        The full regression's column layout.
    design, target, equality
        As :func:`~pcs_sindy.identification.formulations.regression` and the scale constraint give them.
    keep : ndarray of bool, shape (n_active,)

    Returns
    -------
    columns_r : the layout of the kept strains (a fresh ``WithGains`` around the restricted library)
    cols : ndarray of int
        Each of its columns' index in ``columns``.
    x, target : the rows and targets of the kept strains
    design_r : ``design`` of a further restriction, ``keep`` over the kept strains
    equality_r : the scale constraint on the kept columns (or None)
    """
    with_gains = isinstance(columns, WithGains)
    lib = columns.library if with_gains else columns
    full = np.asarray(lib.kinematics.active_mask, dtype=bool).copy()
    full[full] = keep
    per = full.size // lib.kinematics.n_segments
    lib_r = lib.restrict(full.reshape(-1, per))
    cols = np.asarray(lib_r.column_map_, dtype=int)
    if with_gains:
        cols = np.r_[cols, lib.n_coefficients_ + np.arange(len(columns.gain_names))]
        lib_r = WithGains(lib_r, columns.gain_names, columns.gain_lower)
    index = np.flatnonzero(keep)

    def design_r(lib_rr: Any, kept: NDArray[np.bool_]) -> NDArray[np.float64]:
        sub = np.zeros(keep.size, dtype=bool)
        sub[index[np.asarray(kept, dtype=bool)]] = True
        return design(lib_rr, sub)

    eq = None if equality is None else (np.asarray(equality[0], dtype=float)[cols], float(equality[1]))
    return lib_r, cols, np.asarray(design(lib_r, keep), dtype=float), np.asarray(target)[:, keep], design_r, eq
