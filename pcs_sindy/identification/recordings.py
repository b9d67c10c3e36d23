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
from ..core.metrics import noise_level
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
    "band_frequency",
    "WEAK_WINDOW",
    "WEAK_WINDOW_BAND",
    "WEAK_WINDOW_BAND_MIN_SAMPLES",
    "WEAK_WINDOW_BAND_SNR",
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


#: the longest default weak-form window [s]: 160 sampling intervals at 1 kHz, measured best on the planar scenarios
#: with pose noise (docs/results.md, noise study); a time span, so the band the bump test function keeps does not
#: depend on the rate
WEAK_WINDOW = 0.16
#: but at least this many sampling intervals: each window averages the per-sample noise of the rates (every rate
#: up to 1 kHz keeps the measured 160 samples; at 100 Hz the servo captures of slow steps needed 120 or more: 20-80
#: biased a stiffness by 11-18 %)
WEAK_WINDOW_MIN_SAMPLES = 160
#: that window is shortened to keep the strains' band: window length x band frequency (the median frequency of the
#: strains' power above their white-noise floor, :func:`band_frequency`) at most this.  At 0.75 the bump test
#: function passes 73 % of the amplitude at the band frequency (half at 1.05 / window, almost nothing above
#: 2 / window).  Measured: the band frequency is 1.3-2 Hz on the 100 Hz spatial benchmark (3-s recordings: the
#: 150 samples the longest default gives kill the inertia band there and fail every noisy draw; 40-50 samples are
#: right, 80 fail), 0.2-0.25 Hz on the servo captures of slow steps (not shortened), 4-7 Hz on the 1 kHz planar
#: scenarios (docs/results.md, "Spatial identification" and the noise study)
WEAK_WINDOW_BAND = 0.75
#: but only when the noise threatens the band: the strains' motion (standard deviation) is less than this many times
#: their per-sample noise (median over strains and recordings).  Without noise a long window loses nothing and its
#: quadrature is finer: on noise-free 200 Hz tendon data (tests/test_spatial_tendons.py) 64 samples put the tendon
#: offsets 1.6 % off, 149 samples 0.2 %.  About 2 on the noisy spatial benchmark, 100 or more on noise-free
#: simulations, 15-30 on the 1 kHz planar scenarios with 0.5-1 mm pose noise (kept at 160), 68 on the real Trunk in
#: 3-D (observations_controlled_1.csv)
WEAK_WINDOW_BAND_SNR = 10.0
#: the shortened window keeps at least this many sampling intervals (16 at 100 Hz left the rates' noise in the rows
#: of the noisy spatial benchmark; 30 did not)
WEAK_WINDOW_BAND_MIN_SAMPLES = 32
#: recordings shorter than this (samples) tell no band
BAND_MIN_SAMPLES = 16
#: the strains' power counts where it stands above this many times their white-noise floor: a strain of pure white
#: noise exceeds 3 x its floor in 5 % of the periodogram's bins (and by e^-3 of the floor on average), so the
#: strains the data do not excite hardly move the band (the tendon-driven spatial benchmark: 1.67-2 Hz with 1 x,
#: 1.67 Hz on every draw with 3 x)
BAND_NOISE_FACTOR = 3.0


def check_list(y: Any, n: int, name: str) -> list:
    """``y`` as a list of one entry per recording (a single 2-D array for one recording)."""
    if isinstance(y, np.ndarray) and y.ndim == 2 and n == 1:
        return [y]
    if not isinstance(y, (list, tuple)):
        raise ValueError(f"{name} must be a list with one array per recording; got {type(y).__name__}")
    if len(y) != n:
        raise ValueError(f"{name} must hold one array per recording of X ({n}); got {len(y)}")
    return list(y)


def band_frequency(strains: list, dt: float) -> float | None:
    """Median frequency [Hz] of the strains' power above their white-noise floor.

    Per recording: the Hann-windowed periodogram of every strain (mean removed), less :data:`BAND_NOISE_FACTOR`
    times its white-noise floor ``sigma**2`` (:func:`~pcs_sindy.core.metrics.noise_level`; white noise of level
    sigma has ``sigma**2`` in every bin), in units of that floor (so a strain counts by its signal-to-noise ratio,
    not its unit), summed over the strains; the frequency below which half of that excess lies.  The median over
    the recordings.  Noise-free strains have a floor too (their second differences): at a rate well above their
    band it is far below their power.

    Parameters
    ----------
    strains : list of array_like, shape (T, n)
        The modelled strains of each recording.
    dt : float
        Sampling interval [s].

    Returns
    -------
    float or None
        None when no recording of at least :data:`BAND_MIN_SAMPLES` samples has a strain above its noise floor.
    """
    found = []
    for q in strains:
        q = np.asarray(q, dtype=float)
        if q.ndim != 2 or q.shape[0] < BAND_MIN_SAMPLES or not np.all(np.isfinite(q)):
            continue
        floor = noise_level(q, axis=0) ** 2
        keep = floor > 0  # a strain without noise (constant, or exactly polynomial) has no floor to stand above
        if not keep.any():
            continue
        hann = np.hanning(q.shape[0])[:, None]
        x = (q[:, keep] - q[:, keep].mean(axis=0)) * hann
        power = np.abs(np.fft.rfft(x, axis=0)[1:]) ** 2 / np.sum(hann**2)  # white noise sigma -> sigma**2 a bin
        excess = (np.maximum(power - BAND_NOISE_FACTOR * floor[keep], 0.0) / floor[keep]).sum(axis=1)
        if excess.sum() <= 0:
            continue
        freq = np.fft.rfftfreq(q.shape[0], dt)[1:]
        found.append(float(freq[np.searchsorted(np.cumsum(excess), 0.5 * excess.sum())]))
    return float(np.median(found)) if found else None


def _motion_to_noise(strains: list) -> float:
    """Median over strains and recordings of a strain's standard deviation over its white-noise level (inf: none)."""
    ratios = []
    for q in strains:
        q = np.asarray(q, dtype=float)
        if q.ndim != 2 or q.shape[0] < BAND_MIN_SAMPLES or not np.all(np.isfinite(q)):
            continue
        sigma = noise_level(q, axis=0)
        keep = sigma > 0
        ratios.extend(q[:, keep].std(axis=0) / sigma[keep])
    return float(np.median(ratios)) if ratios else np.inf


def weak_windows(
    shortest: int,
    weak_window: int | None,
    weak_stride: int | None,
    dt: float | None = None,
    strains: list | None = None,
) -> tuple[int, int]:
    """Weak-form window and stride in samples: the given ones, or the defaults for the data.

    Parameters
    ----------
    shortest : int
        Samples of the shortest recording.
    weak_window, weak_stride : int or None
        The user's window (sampling intervals) and stride (samples); None for the defaults.
    dt : float, optional
        Sampling interval [s] of the recordings (their median).
    strains : list of array_like, optional
        The modelled strains of each recording, shape (T, n).  The default window spans :data:`WEAK_WINDOW`
        seconds, at least :data:`WEAK_WINDOW_MIN_SAMPLES` intervals (without ``dt``, that many), shortened to
        :data:`WEAK_WINDOW_BAND` / :func:`band_frequency` seconds when the strains' band needs it (the bump test
        function keeps the band) and their noise threatens it (motion less than :data:`WEAK_WINDOW_BAND_SNR` times
        the noise) but not below :data:`WEAK_WINDOW_BAND_MIN_SAMPLES` intervals; at most half the shortest
        recording.

    Returns
    -------
    width, stride : int
    """
    width = weak_window
    if width is None:
        width = WEAK_WINDOW_MIN_SAMPLES if dt is None else max(int(round(WEAK_WINDOW / dt)), WEAK_WINDOW_MIN_SAMPLES)
        noisy = strains is not None and _motion_to_noise(strains) < WEAK_WINDOW_BAND_SNR
        band = band_frequency(strains, dt) if noisy and dt is not None else None
        if band is not None:
            width = min(width, max(int(round(WEAK_WINDOW_BAND / (band * dt))), WEAK_WINDOW_BAND_MIN_SAMPLES))
        width = max(2, min(width, (shortest - 1) // 2))
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
        else weak_windows(
            min(rec.n_frames for rec in X),
            weak_window,
            weak_stride,
            sampling_interval(X),
            strains=None if weak_window is not None else [rec.q[:, mask] for rec in X],
        )
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
