"""Task-space error metrics of the seed (eqs. 23-26).

All functions take pose arrays ``[..., x, y, theta]`` of shape (T, P, 3) for
the estimate and the truth.  The distributed metrics average over the tracked
cross-sections passed in (leave the base out, as the seed does); the
end-effector metrics use the last point.  Angle differences are wrapped to
[-π, π) so that a 2π offset is not an error.  :func:`rollout_scorer` scores
rollouts for scikit-learn's model selection.  :func:`noise_level` estimates a
signal's white-noise level from its second differences (robust to jumps), and
:func:`motion_to_noise` how far a signal's motion stands above that noise.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .kinematics import wrap_angle

__all__ = [
    "distributed_errors",
    "end_effector_errors",
    "pose_errors",
    "rollout_scorer",
    "rollout_r2_scorer",
    "noise_level",
    "motion_to_noise",
]

#: median absolute deviation -> standard deviation of a Gaussian
_MAD_TO_SIGMA = 1.4826


def noise_level(values: ArrayLike, axis: int | tuple[int, ...] | None = None) -> np.ndarray:
    """White-noise standard deviation of samples along their first axis, from second differences.

    The second difference of white noise of level σ has standard deviation √6 σ while a smooth
    signal contributes little to it; the median of its absolute value (times 1.4826, the
    Gaussian MAD factor) ignores the few samples a jump or an outlier spoils.

    Parameters
    ----------
    values : array_like, shape (T, ...)
        Samples in time order along axis 0 (T >= 3).
    axis : int or tuple of int, optional
        Axes of the second differences over which the median is taken (default: all).

    Returns
    -------
    ndarray
        σ, with the remaining axes (a 0-d array when ``axis`` is None).
    """
    x = np.asarray(values, dtype=float)
    if x.ndim < 1 or x.shape[0] < 3:
        raise ValueError(f"values must hold at least 3 samples along axis 0; got shape {x.shape}")
    d2 = np.abs(np.diff(x, n=2, axis=0))
    return _MAD_TO_SIGMA * np.median(d2, axis=axis) / np.sqrt(6.0)


def motion_to_noise(recordings: ArrayLike | list[ArrayLike]) -> np.ndarray:
    """Per column: the standard deviation of the motion net of white noise, over that noise's standard deviation.

    For each recording the variance around its mean and the white-noise variance ``sigma^2`` of
    :func:`noise_level` are pooled over the recordings (weighted by their samples); the ratio is
    ``sqrt(max(var - sigma^2, 0)) / sigma``.  A sinusoid of amplitude ``a`` under white noise of level
    ``sigma`` reads ``a / (sqrt(2) sigma)``; noise alone reads about 0.  Noise-free data read large (``inf``
    when the second differences vanish: a straight line); a column that never moves reads 0.

    Parameters
    ----------
    recordings : array_like (T, n), or a list of them
        Samples in time order (T >= 3 each), the same ``n`` columns in every recording.

    Returns
    -------
    ndarray, shape (n,)
    """
    recs = [np.asarray(r, dtype=float) for r in (recordings if isinstance(recordings, (list, tuple)) else [recordings])]
    if not recs or any(r.ndim != 2 or r.shape[1] != recs[0].shape[1] for r in recs):
        raise ValueError(
            "recordings must be one (T, n) array or a list of them with the same n; "
            f"got shapes {[r.shape for r in recs]}"
        )
    weights = np.array([r.shape[0] for r in recs], dtype=float)
    var = np.average([np.var(r, axis=0) for r in recs], axis=0, weights=weights)
    noise = np.average([noise_level(r, axis=0) ** 2 for r in recs], axis=0, weights=weights)
    motion = np.sqrt(np.maximum(var - noise, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = motion / np.sqrt(noise)
    return np.where(motion > 0, ratio, 0.0)


def _pair(estimate: ArrayLike, truth: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    est = np.asarray(estimate, dtype=float)
    tru = np.asarray(truth, dtype=float)
    if est.shape != tru.shape:
        raise ValueError(f"estimate and truth must have the same shape; got {est.shape} and {tru.shape}")
    if est.ndim != 3 or est.shape[-1] != 3:
        raise ValueError(f"poses must have shape (T, P, 3); got {est.shape}")
    if not (np.all(np.isfinite(est)) and np.all(np.isfinite(tru))):
        raise ValueError("poses contain NaN or inf")
    return est, tru


def pose_errors(estimate: ArrayLike, truth: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample position error norms and absolute angle errors, each (T, P)."""
    est, tru = _pair(estimate, truth)
    ep = np.linalg.norm(est[..., :2] - tru[..., :2], axis=-1)
    eth = np.abs(wrap_angle(est[..., 2] - tru[..., 2]))
    return ep, eth


def distributed_errors(estimate: ArrayLike, truth: ArrayLike) -> tuple[float, float]:
    """``(e_p^dist, e_θ^dist)``: mean over frames and points (seed eqs. 23-24)."""
    ep, eth = pose_errors(estimate, truth)
    return float(ep.mean()), float(eth.mean())


def end_effector_errors(estimate: ArrayLike, truth: ArrayLike) -> tuple[float, float]:
    """``(e_p^EE, e_θ^EE)``: mean over frames at the last point (seed eqs. 25-26)."""
    ep, eth = pose_errors(estimate, truth)
    return float(ep[:, -1].mean()), float(eth[:, -1].mean())


def rollout_scorer(estimator: Any, X: Any, y: Any) -> float:
    """Scorer of rollouts for scikit-learn's model selection: minus the mean tip position error (m).

    Each held-out recording is rolled out from its first state under its own
    forces (``estimator.rollout_error(X, y)``, which
    :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor` and
    :class:`~pcs_sindy.pipeline.pcs_pipeline.PCSPipeline` provide) and its tip path compared
    with the recording's.  Higher is better; a diverged rollout scores ``-inf``
    (never NaN).  Use as ``GridSearchCV(..., scoring=rollout_scorer)``.

    Parameters
    ----------
    estimator : fitted estimator with ``rollout_error(X, y)``
    X, y : recordings and their forces

    Returns
    -------
    float
    """
    if not hasattr(estimator, "rollout_error"):
        raise ValueError(f"rollout_scorer needs an estimator with rollout_error(X, y); got {type(estimator).__name__}")
    errors = np.asarray(estimator.rollout_error(X, y), dtype=float)
    if errors.size == 0 or np.any(np.isnan(errors)):
        raise ValueError(f"rollout_error returned {errors!r}; expected one finite or inf error per recording")
    return -float(np.mean(errors))


def rollout_r2_scorer(estimator: Any, X: Any, y: Any) -> float:
    """Scorer of rollouts for scikit-learn's model selection: the R^2 of the tip path (``estimator.rollout_score``).

    Each held-out recording is rolled out from its measured state under its
    own forces and its tip path compared with the recording's:
    ``1 - SS_res / SS_tot`` pooled over recordings (``-inf`` for a diverged
    rollout).  Dimensionless, unlike :func:`rollout_scorer` (minus the mean tip
    error in m); both rank candidates by their rollouts, which the estimators'
    ``score`` (the R^2 of the forces ``predict`` returns, scikit-learn's rule)
    does not.  Use as ``GridSearchCV(..., scoring=rollout_r2_scorer)``.

    Parameters
    ----------
    estimator : fitted estimator with ``rollout_score(X, y)``
        :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor` or
        :class:`~pcs_sindy.pipeline.pcs_pipeline.PCSPipeline`.
    X, y : recordings and their forces

    Returns
    -------
    float
    """
    if not hasattr(estimator, "rollout_score"):
        raise ValueError(
            f"rollout_r2_scorer needs an estimator with rollout_score(X, y); got {type(estimator).__name__}"
        )
    return float(estimator.rollout_score(X, y))
