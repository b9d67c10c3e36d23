"""How many segments a positions-only recording supports: chosen by held-out open-loop prediction.

With a few markers the kinematic fit always improves with segments (three
markers are fitted exactly by three), but the dynamics of the extra segments
are not determined by them: their rollouts drift or diverge.
:func:`select_segmentation` fuses the first part of a training recording at a
few thresholds, identifies a model per distinct segment count, rolls each out
open loop over the rest of the recording (cross-validation in time) and keeps
the count whose predicted markers are closest to the recorded ones in the
capture frame.

This module sits on top of fusion and identification (like the pipeline).
"""

from __future__ import annotations

import warnings
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import clone

from ..core.simulate_contract import DivergenceError
from ..core.trajectory import PoseTrajectory
from ..fusion.kinematic_fusion import KinematicFusion

__all__ = ["SegmentationChoice", "select_segmentation", "SEGMENTATION_THRESHOLDS"]

#: fusion thresholds tried, large to small: one segment, then as many as the marker spacings allow
SEGMENTATION_THRESHOLDS = (1e6, 0.5, 0.2, 0.05, 1e-6)


class SegmentationChoice(NamedTuple):
    """The result of :func:`select_segmentation`."""

    n_segments: int
    """The chosen segment count."""
    threshold: float
    """The fusion threshold that gives it (``KinematicFusion(threshold=...)``)."""
    errors: dict
    """Held-out marker RMSE [m] (capture frame, all markers) per segment count; ``inf`` for a failed rollout."""
    thresholds: dict
    """The threshold that gave each segment count."""


def select_segmentation(
    positions: ArrayLike,
    inputs: ArrayLike,
    *,
    dt: float,
    arc_lengths: ArrayLike | None = None,
    regressor: Any = None,
    thresholds: tuple[float, ...] = SEGMENTATION_THRESHOLDS,
    validation_fraction: float = 0.3,
    plane: Any = None,
) -> SegmentationChoice:
    """Choose the segment count of a positions-only recording by open-loop prediction of held-out data.

    Parameters
    ----------
    positions : array_like, shape (T, N, 3)
        Marker positions (the training recording), base to tip, as for
        :meth:`PoseTrajectory.from_positions`.
    inputs : array_like, shape (T, p)
        The recorded actuator inputs on the same samples.
    dt : float
        Sampling period [s].
    arc_lengths : array_like, shape (N,), optional
        The markers' rest arc lengths, if measured.
    regressor : EulerLagrangeRegressor, optional
        Cloned per candidate; default ``EulerLagrangeRegressor(actuation=LearnedActuation(p))``.
    thresholds : tuple of float
        Fusion thresholds tried (each distinct resulting segment count is scored once).
    validation_fraction : float, default 0.3
        The last part of the recording that is predicted (the rest trains).
    plane : MarkerPlane, optional
        The recording's plane (default: fitted on the training part).

    Returns
    -------
    SegmentationChoice
    """
    from ..identification.regressor import EulerLagrangeRegressor
    from ..models.actuation import LearnedActuation

    P = np.asarray(positions, dtype=float)
    U = np.asarray(inputs, dtype=float)
    if P.ndim != 3 or U.ndim != 2 or U.shape[0] != P.shape[0]:
        raise ValueError(
            f"positions must have shape (T, N, 3) and inputs (T, p) with the same T; got {P.shape} and {U.shape}"
        )
    if not 0.05 <= validation_fraction <= 0.5:
        raise ValueError(f"validation_fraction must be in [0.05, 0.5]; got {validation_fraction}")
    n_fit = int(round(P.shape[0] * (1.0 - validation_fraction)))
    reg0 = EulerLagrangeRegressor(actuation=LearnedActuation(U.shape[1])) if regressor is None else regressor
    train = PoseTrajectory.from_positions(P[:n_fit], dt=dt, arc_lengths=arc_lengths, plane=plane)
    val = PoseTrajectory.from_positions(P[n_fit:], dt=dt, arc_lengths=arc_lengths, plane=train.plane)
    errors: dict = {}
    chosen: dict = {}
    for thr in thresholds:
        fusion = KinematicFusion(threshold=float(thr)).fit(train)
        m = len(fusion.segment_lengths_)
        if m in errors:
            continue
        chosen[m] = float(thr)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                (st,), (sv,) = fusion.transform(train), fusion.transform(val)
                model = clone(reg0).fit([st], [U[:n_fit]])
                sim = model.simulate(sv.q[0], np.zeros(sv.q.shape[1]), sv.t, U[n_fit:])
            sim.metadata.update({k: sv.metadata[k] for k in ("plane", "marker_arc_lengths", "base_poses")})
            (pred,) = fusion.inverse_transform([sim])
            err = float(np.sqrt(np.nanmean(np.sum((pred.positions - P[n_fit:]) ** 2, axis=-1))))
        except (DivergenceError, np.linalg.LinAlgError, ValueError) as exc:
            warnings.warn(f"{m} segment(s): no held-out prediction ({exc})", UserWarning, stacklevel=2)
            err = np.inf
        errors[m] = err if np.isfinite(err) else np.inf
    best = min(errors, key=lambda k: (errors[k], k))
    return SegmentationChoice(best, chosen[best], errors, chosen)
