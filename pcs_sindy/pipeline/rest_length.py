"""The robot's rest length when nobody measured it: kinematics, corrected by the identified dynamics.

Poses alone cannot tell a robot's rest length from a constant stretch: a
robot hanging under its weight, pulled by its actuation or stretched by its
own swinging simply looks longer, and the median deformed length
(:func:`pcs_sindy.fusion.chain_geometry.estimate_total_length`) reads long by that
mean stretch (about 1 % on two_segment, 3.6 % on a soft robot hanging 3 %
stretched).  The dynamics can: with gravity known and the mass fixed by the
inertia, an Euler–Lagrange model with a constant force per strain
(``PhysicalPCSLibrary(rest_strain=True)``, the default) explains the stretch by
gravity, stiffness and actuation, and what is left in the axial rest strain
is the length error.  :func:`estimate_rest_length` fits the fusion on the
kinematic estimate, identifies the model, rescales the lengths by the
identified axial rest strain (:meth:`KinematicFusion.correct_rest_length`),
and refits; the uncertainty is the jackknife over recordings.

This module sits on top of fusion and identification (like the pipeline);
neither imports it.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import clone

from ..core.trajectory import PoseTrajectory, as_pose_trajectories
from ..fusion.chain_geometry import jackknife_std
from ..fusion.kinematic_fusion import KinematicFusion

__all__ = ["RestLengthEstimate", "estimate_rest_length"]


class RestLengthEstimate(NamedTuple):
    """The result of :func:`estimate_rest_length`."""

    total_length: float
    """Rest length [m] after the correction."""
    std: float
    """Its standard error [m] (jackknife over recordings; NaN with one recording)."""
    kinematic_length: float
    """The median deformed length it started from [m]."""
    segment_lengths: NDArray[np.float64]
    """Rest lengths of the fused segments [m]."""
    fusion: Any
    """The fusion, fitted and corrected (``total_length_`` = ``total_length``)."""
    regressor: Any
    """The regressor refitted on the corrected strains (its axial rest strains are then ~0)."""


def _default_regressor() -> Any:
    from ..identification.regressor import EulerLagrangeRegressor

    return EulerLagrangeRegressor()  # the physical library identifies rest strains by default


def _identifies_axial_rest_strain(regressor: Any) -> bool:
    from ..identification.library.physical import PhysicalPCSLibrary

    make = getattr(regressor, "make_library", None)
    library = make() if make is not None else PhysicalPCSLibrary()
    return isinstance(library, PhysicalPCSLibrary) and "ax" in library.rest_strain_kinds


def _one(poses: list, taus: list, fusion: KinematicFusion, regressor: Any) -> tuple[KinematicFusion, Any, float, float]:
    fus = clone(fusion).fit(poses)
    kinematic = fus.total_length_
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # identifiability notes of the intermediate fit
        reg = clone(regressor).fit(fus.transform(poses), taus)
    q = np.asarray(reg.rest_strain_, dtype=float)
    fus.correct_rest_length(q)
    return fus, reg, kinematic, float(np.sum(fus.segment_lengths_ * q[2::3]) / np.sum(fus.segment_lengths_))


def estimate_rest_length(
    poses: Any,
    taus: Sequence[ArrayLike],
    *,
    fusion: KinematicFusion | None = None,
    regressor: Any = None,
    jackknife: bool = True,
) -> RestLengthEstimate:
    """Rest length from poses and the forces applied, without the stretch bias of poses alone.

    Parameters
    ----------
    poses : pose recordings
        As for :meth:`KinematicFusion.fit` (``total_length`` and any
        ``metadata["rest_length"]`` are ignored: this estimates it).
    taus : list of arrays (T, 3m)
        The forces of each recording, for the fused segmentation (as for the regressor).
    fusion : KinematicFusion, optional
        Template (default ``KinematicFusion()``).
    regressor : EulerLagrangeRegressor, optional
        Template; its library must identify axial rest strains (default:
        ``EulerLagrangeRegressor()``, whose physical library does).
    jackknife : bool
        Repeat the estimate leaving out one recording at a time for the
        standard error (one more fit per recording).

    Returns
    -------
    RestLengthEstimate
    """
    trajs = as_pose_trajectories(poses, name="poses")
    taus = list(taus)
    if len(taus) != len(trajs):
        raise ValueError(f"taus must hold one array per recording ({len(trajs)}); got {len(taus)}")
    template = (KinematicFusion() if fusion is None else clone(fusion)).set_params(total_length=None)
    # estimate the length, do not take one the poses carry (copies: the caller's metadata stay)
    trajs = [
        PoseTrajectory(tr.poses, tr.t, metadata={k: v for k, v in tr.metadata.items() if k != "rest_length"})
        for tr in trajs
    ]
    reg_template = _default_regressor() if regressor is None else regressor
    if not _identifies_axial_rest_strain(reg_template):
        raise ValueError(
            "regressor must identify axial rest strains (a PhysicalPCSLibrary with rest_strain=True or a tuple "
            "holding 'ax'): that is what corrects the length; got "
            f"feature_library={getattr(reg_template, 'feature_library', None)!r}"
        )
    fus, _, kinematic, _ = _one(trajs, taus, template, reg_template)
    # the corrected strains are refitted, so the model matches the corrected segmentation
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reg = clone(reg_template).fit(fus.transform(trajs), taus)
    std = float("nan")
    if jackknife and len(trajs) > 1:
        parts = []
        for k in range(len(trajs)):
            try:
                parts.append(
                    _one(trajs[:k] + trajs[k + 1 :], taus[:k] + taus[k + 1 :], template, reg_template)[0].total_length_
                )
            except ValueError:
                continue  # without this recording the fusion finds another segmentation: no comparable estimate
        std = jackknife_std(parts)
        fus.total_length_std_ = std
    return RestLengthEstimate(fus.total_length_, std, kinematic, fus.segment_lengths_.copy(), fus, reg)
