"""Recordings for the regression: strain trajectories and their inputs, checked and differentiated.

Plain functions under :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`:
they validate the inputs of every recording (generalised forces, or actuator
inputs through an :class:`~pcs_sindy.models.actuation.Actuation`), estimate the rates
(and accelerations) and cut the weak-form windows or the strong-form rows, so
each recording becomes a :class:`~pcs_sindy.identification.formulations.PreparedRecording`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import PlanarPCS
from ..core.spatial import SpatialPCS
from ..core.trajectory import StrainTrajectory, as_strain_trajectories, kinematics_of
from . import formulations as _form
from .library.spatial_physical import spatial_kinematics_of

__all__ = [
    "check_list",
    "derivatives",
    "prepare",
    "weak_windows",
    "sampling_interval",
    "WEAK_WINDOW",
    "WEAK_WINDOW_MIN_SAMPLES",
    "as_trajectories",
    "data_kinematics",
    "with_active",
]


def as_trajectories(X: Any, *, name: str = "X") -> list:
    """Recordings as a list: planar :class:`StrainTrajectory` objects, or spatial strain trajectories."""
    if spatial_kinematics_of(X) is not None:
        return list(X) if isinstance(X, (list, tuple)) else [X]
    return as_strain_trajectories(X, name=name)


def data_kinematics(X: Any) -> PlanarPCS | SpatialPCS | None:
    """The segmentation shared by the recordings: a SpatialPCS for spatial strains, else a PlanarPCS."""
    spatial = spatial_kinematics_of(X)
    return spatial if spatial is not None else kinematics_of(X)


def with_active(kin: PlanarPCS | SpatialPCS, active: ArrayLike) -> PlanarPCS | SpatialPCS:
    """The segmentation ``kin`` (same type, lengths and base) with the modelled strains ``active``."""
    if isinstance(kin, SpatialPCS):
        return SpatialPCS(kin.segment_lengths, active, kin.base_position, kin.base_rotation)
    return PlanarPCS(kin.segment_lengths, active, kin.base_pose)


#: default weak-form window [s]: 160 sampling intervals at 1 kHz, measured best on the planar scenarios with pose
#: noise (docs/results.md); a time span, so the band the bump test function keeps does not depend on the rate
WEAK_WINDOW = 0.16
#: but at least this many sampling intervals: each window averages the per-sample noise of the rates, and fewer
#: samples leave it in the rows.  160 keeps every rate up to 1 kHz at the measured 160 samples: a floor of 40
#: (0.4 s at 100 Hz) was better on the noisy spatial benchmark, the simulated capture and Trunk motor4, but it
#: broke three 100 Hz servo/tendon fits (a clean servo capture, a swapped-sides warning, a 3-D tendon fit: a
#: zero inertia), so it is not the default (docs/results.md, "Spatial identification")
WEAK_WINDOW_MIN_SAMPLES = 160


def check_list(y: Any, n: int, name: str) -> list:
    """``y`` as a list of one entry per recording (a single 2-D array for one recording)."""
    if isinstance(y, np.ndarray) and y.ndim == 2 and n == 1:
        return [y]
    if not isinstance(y, (list, tuple)):
        raise ValueError(f"{name} must be a list with one array per recording; got {type(y).__name__}")
    if len(y) != n:
        raise ValueError(f"{name} must hold one array per recording of X ({n}); got {len(y)}")
    return list(y)


def weak_windows(
    shortest: int, weak_window: int | None, weak_stride: int | None, dt: float | None = None
) -> tuple[int, int]:
    """Weak-form window and stride in samples: the given ones, or the defaults for the data.

    Parameters
    ----------
    shortest : int
        Samples of the shortest recording.
    weak_window, weak_stride : int or None
        The user's window (sampling intervals) and stride (samples); None for the defaults.
    dt : float, optional
        Sampling interval [s] of the recordings (their median).  The default window spans
        :data:`WEAK_WINDOW` seconds, at least :data:`WEAK_WINDOW_MIN_SAMPLES` intervals (without
        ``dt``, that minimum), at most half the shortest recording.

    Returns
    -------
    width, stride : int
    """
    width = weak_window
    if width is None:
        span = 0 if dt is None else int(round(WEAK_WINDOW / dt))
        width = max(2, min(max(span, WEAK_WINDOW_MIN_SAMPLES), (shortest - 1) // 2))
    stride = weak_stride if weak_stride is not None else max(1, int(width) // 4)
    return int(width), int(stride)


def sampling_interval(X: list) -> float | None:
    """Median sampling interval [s] over the recordings (None when no recording has two samples)."""
    steps = [np.diff(np.asarray(rec.t, dtype=float)) for rec in X]
    steps = [d for d in steps if d.size]
    return float(np.median(np.concatenate(steps))) if steps else None


def derivatives(
    rec: StrainTrajectory,
    k: int,
    qd: ArrayLike | None,
    qdd: ArrayLike | None,
    *,
    method: Callable | None,
    window_length: int,
    polyorder: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Rates and accelerations of recording ``k``: given, by ``method(x, t)``, or Savitzky–Golay."""
    q, t = rec.q, rec.t
    if qd is not None:
        out = []
        for name, arr in (("qd", qd), ("qdd", qdd)):
            if arr is None:
                out.append(None)
                continue
            arr = np.asarray(arr, dtype=float)
            if arr.shape != q.shape:
                raise ValueError(f"{name}[{k}] must have the shape of X[{k}].q {q.shape}; got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name}[{k}] contains NaN or inf")
            out.append(arr)
        return out[0], out[1]
    if method is not None:
        rate = np.asarray(method(q, t), dtype=float)
        acc = np.asarray(method(rate, t), dtype=float)
        if (
            rate.shape != q.shape
            or acc.shape != q.shape
            or not (np.all(np.isfinite(rate)) and np.all(np.isfinite(acc)))
        ):
            raise ValueError(
                f"differentiation_method returned derivatives of shape {rate.shape}/{acc.shape} or with NaN for "
                f"X[{k}] (q has shape {q.shape}); NaN edges are not accepted"
            )
        return rate, acc
    return _form.savgol_derivatives(q, t, window_length, polyorder, name=f"X[{k}]")


def _inputs(X: list[StrainTrajectory], y: Any, kin: PlanarPCS, actuation: Any) -> list[NDArray[np.float64]]:
    ys = check_list(y, len(X), "y")
    forces = actuation is None or getattr(actuation, "is_identity", False)
    out = []
    for k, rec in enumerate(X):
        tau = np.asarray(ys[k], dtype=float)
        if not forces:
            tau = actuation.check_inputs(tau, f"y[{k}]", rec.t if tau.shape[:1] == rec.t.shape else None)
            if tau.shape[0] != rec.n_frames:
                raise ValueError(f"y[{k}] has {tau.shape[0]} samples but X[{k}] has {rec.n_frames}")
            out.append(tau)
            continue
        if tau.ndim != 2 or tau.shape[1] != kin.n_q:
            raise ValueError(f"y[{k}] must have shape (T, {kin.n_q}) (one force per strain); got {tau.shape}")
        if tau.shape[0] != rec.n_frames:
            raise ValueError(f"y[{k}] has {tau.shape[0]} samples but X[{k}] has {rec.n_frames}")
        if not np.all(np.isfinite(tau)):
            raise ValueError(f"y[{k}] contains NaN or inf (first at sample {np.argwhere(~np.isfinite(tau))[0][0]})")
        out.append(tau)
    return out


def prepare(
    X: Any,
    y: Any,
    qd: Any = None,
    qdd: Any = None,
    *,
    kin: PlanarPCS | None = None,
    formulation: str,
    actuation: Any = None,
    differentiation_method: Callable | None = None,
    window_length: int = 7,
    polyorder: int = 3,
    weak_window: int | None = None,
    weak_stride: int | None = None,
    exclude_force_jumps: bool = False,
) -> tuple[PlanarPCS, list[StrainTrajectory], list[_form.PreparedRecording]]:
    """Validated recordings of the strains ``kin`` models (default: the data's), ready for a formulation.

    Parameters
    ----------
    X : list of StrainTrajectory
    y : list of array_like
        Inputs per recording: generalised forces (T, 3m), or actuator inputs
        (T, p) checked by the fitted ``actuation``.
    qd, qdd : list of array_like, optional
        Known rates and accelerations.
    kin : PlanarPCS, optional
        The model's segmentation (checked against the data's).
    formulation : {"strong", "weak", "static"}
    actuation : Actuation, optional
    differentiation_method, window_length, polyorder, weak_window, weak_stride, exclude_force_jumps
        As in :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`.

    Returns
    -------
    kin : PlanarPCS
    X : list of StrainTrajectory
    recordings : list of PreparedRecording
    """
    X = as_trajectories(X)
    data_kin = data_kinematics(X)
    if kin is not None and not np.allclose(data_kin.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0):
        raise ValueError(
            f"X has segment_lengths {list(data_kin.segment_lengths)}, the model {list(kin.segment_lengths)}; "
            "transform the poses with the model's segmentation"
        )
    kin = data_kin if kin is None else kin
    mask = kin.active_mask
    if not mask.any():
        raise ValueError("the data model no strain (active_strains all False)")
    taus = _inputs(X, y, kin, actuation)
    qds = None if qd is None else check_list(qd, len(X), "qd")
    qdds = None if qdd is None else check_list(qdd, len(X), "qdd")
    if (qds is None) != (qdds is None) and formulation == "strong":
        raise ValueError("give both qd and qdd (known derivatives) or neither")
    width, stride = (
        (0, 0)
        if formulation == "static"
        else weak_windows(min(rec.n_frames for rec in X), weak_window, weak_stride, sampling_interval(X))
    )
    recs = []
    for k, (rec, tau) in enumerate(zip(X, taus)):
        if formulation == "static":  # equilibria: no derivatives, one row per hold
            recs.append(_form.static_recording(rec.t, rec.q[:, mask], tau, name=f"X[{k}]"))
            continue
        rate, acc = derivatives(
            rec,
            k,
            None if qds is None else qds[k],
            None if qdds is None else qdds[k],
            method=differentiation_method,
            window_length=window_length,
            polyorder=polyorder,
        )
        r = _form.PreparedRecording(rec.t, rec.q[:, mask], rate[:, mask], None if acc is None else acc[:, mask], tau)
        if formulation == "weak":
            if rec.n_frames <= width:
                raise ValueError(
                    f"X[{k}] has {rec.n_frames} samples, too few for weak_window = {width} sampling intervals "
                    f"(needs at least {width + 1}); use a shorter weak_window"
                )
            r.windows = _form.sliding_windows(rec.n_frames, width, stride)
        elif exclude_force_jumps:
            r.rows = _form.jump_free(tau, window_length)
        recs.append(r)
    if formulation == "strong" and exclude_force_jumps and not any(r.rows.any() for r in recs):
        raise ValueError(
            f"exclude_force_jumps left no sample: every window of {window_length} samples contains a jump "
            "of the actuation; use a window shorter than the actuation hold (or smooth actuation without "
            "exclude_force_jumps)"
        )
    return kin, X, recs
