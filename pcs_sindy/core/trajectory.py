"""Trajectory containers: the sample unit that flows through every estimator.

A recording is one trajectory.  Estimators take lists of them (one entry per
recording), so cross-validation splits by recording.  Containers validate on
construction and are otherwise plain holders of numpy arrays.

Ground floor: imports only :mod:`pcs_sindy.core.kinematics`, :mod:`pcs_sindy.core.metrics` and the
shared strain-container checks of ``core/_segmented.py``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._segmented import StrainSeries, check_time
from .kinematics import PlanarPCS
from .metrics import noise_level

__all__ = [
    "PoseTrajectory",
    "StrainTrajectory",
    "check_time",
    "as_pose_trajectories",
    "as_strain_trajectories",
    "kinematics_of",
    "MarkerPlane",
    "clean_marker_tracks",
]

# default jump detection never flags less than this [m] (a smooth, noise-free track has a tiny noise estimate)
MIN_JUMP = 1e-3
# out-of-plane RMS above this fraction of the in-plane motion RMS warns in PoseTrajectory.from_positions
WOBBLE_WARNING = 0.2


class MarkerPlane:
    """The plane a planar model of 3-D marker positions lives in, and the maps in and out of it.

    Parameters
    ----------
    origin : array_like, shape (D,)
        A point of the plane in the user's frame (D = 2 or 3).
    axes : array_like, shape (D, 2)
        Orthonormal in-plane axes (columns) in the user's frame; for D = 2 the
        identity, so 2-D positions pass through unchanged.

    Attributes
    ----------
    origin, axes
    normal : ndarray, shape (3,) or None
        Unit normal of the plane (3-D only).
    """

    def __init__(self, origin: ArrayLike, axes: ArrayLike) -> None:
        self.origin = np.asarray(origin, dtype=float).reshape(-1)
        self.axes = np.asarray(axes, dtype=float)
        d = self.origin.size
        if d not in (2, 3) or self.axes.shape != (d, 2):
            raise ValueError(
                f"origin must have 2 or 3 entries and axes shape (D, 2); got {self.origin.shape}, {self.axes.shape}"
            )
        if not np.allclose(self.axes.T @ self.axes, np.eye(2), atol=1e-9):
            raise ValueError("axes must be two orthonormal columns")
        self.normal = np.cross(self.axes[:, 0], self.axes[:, 1]) if d == 3 else None

    @property
    def dim(self) -> int:
        """Dimension D of the user's frame."""
        return self.origin.size

    @classmethod
    def fit(cls, points: ArrayLike, normal: ArrayLike | None = None) -> MarkerPlane:
        """Best-fit (total least squares) plane of finite points (..., 3); identity for 2-D points.

        The plane's normal (and so the handedness of the in-plane axes, i.e. the sign of the
        curvatures) points to the side of ``normal`` when given, else to the side of the
        capture axis it is most aligned with (a deterministic, data-independent choice).
        """
        P = np.asarray(points, dtype=float)
        P = P.reshape(-1, P.shape[-1])
        P = P[np.all(np.isfinite(P), axis=1)]
        if P.shape[1] == 2:
            return cls(np.zeros(2), np.eye(2))
        if P.shape[0] < 3:
            raise ValueError(f"need at least 3 finite 3-D positions to fit a plane; got {P.shape[0]}")
        origin = P.mean(axis=0)
        _, _, vt = np.linalg.svd(P - origin, full_matrices=False)
        axes = vt[:2].T.copy()
        n = np.cross(axes[:, 0], axes[:, 1])
        hint = np.eye(3)[int(np.argmax(np.abs(n)))] if normal is None else np.asarray(normal, dtype=float)
        if hint.shape != (3,) or not np.all(np.isfinite(hint)) or not np.any(hint):
            raise ValueError(f"normal must be a non-zero 3-vector; got {normal!r}")
        if n @ hint < 0:
            axes[:, 1] *= -1.0
        return cls(origin, axes)

    def to_plane(self, points: ArrayLike) -> NDArray[np.float64]:
        """In-plane coordinates (..., 2) of points (..., D); NaN stays NaN."""
        P = np.asarray(points, dtype=float)
        if P.shape[-1] != self.dim:
            raise ValueError(f"points must end in {self.dim} coordinates; got shape {P.shape}")
        return (P - self.origin) @ self.axes

    def from_plane(self, points: ArrayLike) -> NDArray[np.float64]:
        """Points (..., D) in the user's frame of in-plane coordinates (..., 2)."""
        P = np.asarray(points, dtype=float)
        if P.shape[-1] != 2:
            raise ValueError(f"in-plane points must end in 2 coordinates; got shape {P.shape}")
        return self.origin + P @ self.axes.T

    def distance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Signed distance (...) of 3-D points from the plane (zeros for 2-D)."""
        P = np.asarray(points, dtype=float)
        if self.normal is None:
            return np.zeros(P.shape[:-1])
        return (P - self.origin) @ self.normal

    def to_dict(self) -> dict[str, list]:
        return {"origin": self.origin.tolist(), "axes": self.axes.tolist()}

    def __repr__(self) -> str:
        return f"MarkerPlane(dim={self.dim}, origin={np.round(self.origin, 4).tolist()})"


def clean_marker_tracks(
    positions: ArrayLike,
    *,
    frozen_tol: float = 0.0,
    jump_threshold: float | None = None,
    jump_factor: float = 10.0,
    window: int = 9,
    consistency: float | None = 5.0,
) -> tuple[NDArray[np.float64], dict[str, int]]:
    """Mark frozen samples and jumps of marker tracks as missing (NaN).

    A sample is *frozen* when every coordinate of a marker equals the previous
    sample's within ``frozen_tol`` (trackers repeat the last value when they
    lose a marker; real, noisy measurements never repeat exactly).

    A sample is a *jump* when it lies farther than a limit from the running
    median (``window`` samples) of its track - ``jump_threshold`` [m], or by
    default ``jump_factor * sigma * sqrt(D)`` (at least 1 mm) with ``sigma``
    the noise level estimated robustly from the track's second differences -
    **and**, with ``consistency`` (the default) and at least two markers, the
    other markers do not move alike at that sample.  The markers of one body
    accelerate together: genuine fast motion (a step of the actuators, or a
    late sample of the capture) takes every marker off its running median at
    once, each in proportion to how much that marker moves (its RMS speed),
    whereas a tracker glitch takes one marker off alone.  So a sample of marker
    ``i`` is a jump only when its deviation exceeds ``consistency`` times the
    largest deviation of a valid other marker at that sample, each deviation
    (plus three noise levels) divided by its marker's RMS speed.  Samples where
    no other marker is valid are judged by the limit alone only for a single
    marker; otherwise they are kept (no evidence either way).
    ``consistency=None`` judges every track alone (flags fast motion too).

    Parameters
    ----------
    positions : array_like, shape (T, N, D)
        Marker positions, NaN for samples already missing.
    frozen_tol : float, default 0.0
    jump_threshold : float, optional
    jump_factor : float, default 10.0
    window : int, default 9
        Odd width of the running median: bursts of up to ``window // 2``
        samples are caught.
    consistency : float or None, default 5.0
        Factor (> 1) by which a jump must exceed what the other markers' motion at
        the same sample explains.

    Returns
    -------
    cleaned : ndarray, shape (T, N, D)
    counts : dict
        ``{"missing": ..., "frozen": ..., "jumps": ...}`` sample counts (marker-samples).
    """
    from scipy.ndimage import median_filter

    P = np.array(positions, dtype=float, copy=True)
    if P.ndim != 3:
        raise ValueError(f"positions must have shape (T, N, D); got {P.shape}")
    if not (np.isfinite(frozen_tol) and frozen_tol >= 0):
        raise ValueError(f"frozen_tol must be finite and >= 0; got {frozen_tol!r}")
    if jump_threshold is not None and not (np.isfinite(jump_threshold) and jump_threshold > 0):
        raise ValueError(f"jump_threshold must be a distance > 0 in metres or None; got {jump_threshold!r}")
    if isinstance(window, bool) or int(window) != window or window < 3 or window % 2 == 0:
        raise ValueError(f"window must be an odd integer >= 3; got {window!r}")
    if consistency is not None and not (np.isfinite(consistency) and consistency > 1):
        raise ValueError(f"consistency must be a factor > 1 or None; got {consistency!r}")
    missing0 = ~np.all(np.isfinite(P), axis=2)
    P[missing0] = np.nan
    frozen = np.zeros(P.shape[:2], dtype=bool)
    frozen[1:] = np.all(np.abs(np.diff(P, axis=0)) <= frozen_tol, axis=2)  # NaN compares False
    # a run of repeats keeps its first (the last real) value: compare with the previous sample
    P[frozen] = np.nan
    T, N, D = P.shape
    idx = np.arange(T)
    dist = np.zeros((T, N))
    limit = np.full(N, np.inf)
    sigma = np.zeros(N)
    speed = np.full(N, np.nan)
    usable = np.zeros((T, N), dtype=bool)
    for i in range(N):
        ok = np.all(np.isfinite(P[:, i]), axis=1)
        if ok.sum() < window:
            continue
        filled = np.stack([np.interp(idx, idx[ok], P[ok, i, c]) for c in range(D)], axis=1)
        med = median_filter(filled, size=(int(window), 1), mode="nearest")
        dist[:, i] = np.linalg.norm(filled - med, axis=1)
        usable[:, i] = ok
        sigma[i] = float(noise_level(filled[ok])) if ok.sum() >= 3 else 0.0
        speed[i] = float(np.sqrt(np.mean(np.sum(np.diff(filled[ok], axis=0) ** 2, axis=1))))
        if jump_threshold is not None:
            limit[i] = float(jump_threshold)
        elif sigma[i] > 0:
            limit[i] = max(jump_factor * sigma[i] * np.sqrt(D), MIN_JUMP)
    jumps = usable & (dist > limit)
    if consistency is not None and N > 1:
        # each marker's deviation in units of its own motion; a jump stands out from every other valid marker
        scale = np.where(np.isfinite(speed) & (speed > 0), speed, np.inf)
        z = np.where(usable, (dist + 3.0 * sigma) / scale, -np.inf)
        for i in range(N):
            others = np.max(np.delete(z, i, axis=1), axis=1)
            explained = np.isfinite(others) & (dist[:, i] <= consistency * scale[i] * others)
            jumps[:, i] &= ~explained & np.isfinite(others)
    P[jumps] = np.nan
    counts = {"missing": int(missing0.sum()), "frozen": int((frozen & ~missing0).sum()), "jumps": int(jumps.sum())}
    return P, counts


class PoseTrajectory:
    """Poses of the base and N tracked cross-sections over time.

    Parameters
    ----------
    poses : array_like, shape (T, N + 1, 3)
        ``[x, y, theta]`` of the base (index 0) and the markers, ordered base
        to tip, in metres and radians in the robot's base frame.
    t : array_like, shape (T,), optional
        Time stamps in seconds (strictly increasing).
    dt : float, optional
        Sample period, used when ``t`` is not given.
    metadata : mapping, optional
        Free-form information (source file, diagnostics, ...).

    Attributes
    ----------
    poses, t, metadata
    positions : ndarray, shape (T, N, D) or None
        Marker positions in the user's frame (D = 2 or 3, NaN = missing) when
        the trajectory was built by :meth:`from_positions` or returned by
        ``KinematicFusion.inverse_transform`` of such one; ``poses`` is None
        for a positions-only recording.
    plane : MarkerPlane or None
        The plane the positions are modelled in.
    plane_positions : ndarray, shape (T, N, 2) or None
        Marker positions in that plane.
    rotations : ndarray, shape (T, N, 3, 3) or None
        Marker orientations in the user's frame when the tracker gives them
        (``from_positions(rotations=...)``), or the model's cross-section orientations at the
        markers returned by a spatial ``KinematicFusion.inverse_transform``; NaN = missing.
    """

    positions: NDArray[np.float64] | None = None
    plane: MarkerPlane | None = None
    plane_positions: NDArray[np.float64] | None = None
    rotations: NDArray[np.float64] | None = None

    def __init__(
        self,
        poses: ArrayLike,
        t: ArrayLike | None = None,
        *,
        dt: float | None = None,
        metadata: Mapping[str, Any] | None = None,
    ) -> None:
        poses = np.asarray(poses, dtype=float)
        if poses.ndim != 3 or poses.shape[2] != 3 or poses.shape[1] < 2:
            raise ValueError(f"poses must have shape (T, N + 1, 3) with N >= 1; got {poses.shape}")
        if not np.all(np.isfinite(poses)):
            bad = np.argwhere(~np.isfinite(poses))[0]
            raise ValueError(f"poses contains NaN or inf (first at frame {bad[0]}, marker {bad[1]})")
        self.poses = poses
        self.t = check_time(t, poses.shape[0], dt=dt)
        self.metadata = dict(metadata or {})

    @classmethod
    def from_positions(
        cls,
        positions: ArrayLike,
        t: ArrayLike | None = None,
        *,
        dt: float | None = None,
        arc_lengths: ArrayLike | None = None,
        metadata: Mapping[str, Any] | None = None,
        frozen_tol: float = 0.0,
        jump_threshold: float | None = None,
        jump_factor: float = 10.0,
        normal: ArrayLike | None = None,
        plane: MarkerPlane | None = None,
        base_marker: bool = False,
        rotations: ArrayLike | None = None,
    ) -> PoseTrajectory:
        """A positions-only recording: marker positions without orientations or base.

        3-D positions are projected on their best-fit plane
        (:class:`MarkerPlane`); the out-of-plane RMS is reported in
        ``metadata["out_of_plane_rms"]`` (and the in-plane motion RMS in
        ``metadata["motion_rms"]``), with a warning when it exceeds
        ``WOBBLE_WARNING`` (0.2) of the motion (and 1 mm).  Frozen samples and jumps are
        detected (:func:`clean_marker_tracks`) and set missing (NaN);
        ``KinematicFusion`` fits the robot's fixed base pose and, unless given,
        the markers' rest arc lengths from such recordings.

        Parameters
        ----------
        positions : array_like, shape (T, N, 2) or (T, N, 3)
            Markers ordered base to tip, the base not included, in metres; NaN
            for missing samples.
        t : array_like, shape (T,), optional
            Time stamps [s]; otherwise ``dt``.
        dt : float, optional
            Sample period [s] (e.g. 0.01 for a 100 Hz capture without time stamps).
        arc_lengths : array_like, shape (N,), optional
            Rest arc lengths of the markers from the base [m], when measured.
        metadata : mapping, optional
        frozen_tol, jump_threshold, jump_factor
            Passed to :func:`clean_marker_tracks`.
        normal : array_like, shape (3,), optional
            A direction the plane's normal should point to (its side fixes the sign of the
            curvatures, so which tendon bends the robot which way); see :meth:`MarkerPlane.fit`.
        plane : MarkerPlane, optional
            Project on this plane instead of fitting one: give the ``.plane`` of the
            recording a fusion was fitted on to transform more recordings of the same set-up.
        base_marker : bool, default False
            ``positions[:, 0]`` is a marker on the clamped base: its median position (in the
            user's frame, ``metadata["base_marker"]``) fixes the base position of the fusion, and
            the trajectory's markers are the others (``n_markers = N - 1``).
        rotations : array_like, shape (T, N, 3, 3), optional
            The markers' orientations (rotation matrices in the user's frame, e.g.
            :attr:`pcs_sindy.io.MarkerData.rotations`; NaN for missing), when the tracker gives
            them: a spatial fusion (``KinematicFusion(space="3d")``) then fits torsion too.
            Samples whose position is missing or cleaned are missing here too.
        """
        P = np.asarray(positions, dtype=float)
        if P.ndim != 3 or P.shape[2] not in (2, 3) or P.shape[1] < 1:
            raise ValueError(f"positions must have shape (T, N, 2) or (T, N, 3) with N >= 1; got {P.shape}")
        if np.any(np.isinf(P)):
            raise ValueError("positions contains inf; use NaN for missing samples")
        if arc_lengths is not None:
            s = np.asarray(arc_lengths, dtype=float)
            if (
                s.shape != (P.shape[1] - bool(base_marker),)
                or not np.all(np.isfinite(s))
                or s[0] <= 0
                or np.any(np.diff(s) <= 0)
            ):
                raise ValueError(
                    f"arc_lengths must be {P.shape[1] - bool(base_marker)} increasing rest arc lengths > 0 [m], "
                    f"one per marker (the base marker excluded); got {s!r}"
                )
        if base_marker and P.shape[1] < 2:
            raise ValueError(
                f"base_marker=True needs the base marker and at least one more; got {P.shape[1]} marker(s)"
            )
        rot = None
        if rotations is not None:
            rot = np.array(rotations, dtype=float)
            if rot.shape != P.shape[:2] + (3, 3) or P.shape[2] != 3:
                raise ValueError(
                    f"rotations must have shape {P.shape[:2] + (3, 3)} (one 3-D rotation per marker sample); "
                    f"got {rot.shape} for positions of shape {P.shape}"
                )
            ok_r = np.all(np.isfinite(rot), axis=(2, 3))
            err = np.abs(np.einsum("tnji,tnjk->tnik", rot[ok_r][None], rot[ok_r][None])[0] - np.eye(3))
            if err.size and float(err.max()) > 1e-3:
                raise ValueError(
                    "rotations must be rotation matrices (orthonormal within 1e-3); the worst deviates by "
                    f"{err.max():.3g}"
                )
        cleaned, counts = clean_marker_tracks(
            P, frozen_tol=frozen_tol, jump_threshold=jump_threshold, jump_factor=jump_factor
        )
        if rot is not None:
            rot[~np.all(np.isfinite(cleaned), axis=2)] = np.nan
        base_at = None
        if base_marker:
            if not np.any(np.all(np.isfinite(cleaned[:, 0]), axis=1)):
                raise ValueError("positions: the base marker (positions[:, 0]) has no valid sample")
            base_at = np.nanmedian(cleaned[:, 0], axis=0)
            if plane is None:  # the base marker belongs to the body's plane
                plane = MarkerPlane.fit(cleaned, normal)
            cleaned, P = cleaned[:, 1:], P[:, 1:]
            rot = None if rot is None else rot[:, 1:]
        ok = np.all(np.isfinite(cleaned), axis=2)
        if ok.sum() < 3:
            raise ValueError(f"positions has only {int(ok.sum())} valid marker samples; need at least 3")
        for i in range(P.shape[1]):
            if not ok[:, i].any():
                raise ValueError(f"positions: marker {i} has no valid sample (all NaN, frozen or jumps)")
        if plane is None:
            plane = MarkerPlane.fit(cleaned, normal)
        elif not isinstance(plane, MarkerPlane) or plane.dim != P.shape[2]:
            raise ValueError(f"plane must be a MarkerPlane of {P.shape[2]}-D positions; got {plane!r}")
        inplane = plane.to_plane(cleaned)
        oop = float(np.sqrt(np.nanmean(plane.distance(cleaned) ** 2))) if plane.dim == 3 else 0.0
        dev = inplane - np.nanmean(inplane, axis=0, keepdims=True)
        motion = float(np.sqrt(np.nanmean(np.sum(dev**2, axis=2))))
        # static recordings (holds) have noise-level motion: their out-of-plane noise says nothing
        if plane.dim == 3 and oop > WOBBLE_WARNING * motion and oop > MIN_JUMP:
            warnings.warn(
                f"positions: out-of-plane RMS {1e3 * oop:.3g} mm is {oop / max(motion, 1e-300):.2f} of the in-plane "
                f"motion RMS {1e3 * motion:.3g} mm; a planar model will miss that part of the motion "
                "(KinematicFusion(space='3d'), or the default space='auto', fits a spatial model instead)",
                UserWarning,
                stacklevel=2,
            )
        obj = cls.__new__(cls)
        obj.poses = None
        obj.positions = cleaned
        obj.plane = plane
        obj.plane_positions = inplane
        obj.rotations = rot
        obj.t = check_time(t, P.shape[0], dt=dt)
        meta = dict(metadata or {})
        meta.update(
            out_of_plane_rms=oop,
            motion_rms=motion,
            missing_fraction=float(1.0 - ok.mean()),
            frozen_samples=counts["frozen"],
            jump_samples=counts["jumps"],
        )
        if arc_lengths is not None:
            meta["marker_arc_lengths"] = np.asarray(arc_lengths, dtype=float)
        if base_at is not None:
            meta["base_marker"] = base_at
        obj.metadata = meta
        return obj

    @property
    def positions_only(self) -> bool:
        """True for a recording of marker positions without poses (:meth:`from_positions`)."""
        return self.poses is None

    @property
    def n_frames(self) -> int:
        return self.t.shape[0]

    @property
    def n_markers(self) -> int:
        """Number of tracked cross-sections N (the base not counted)."""
        return self.positions.shape[1] if self.poses is None else self.poses.shape[1] - 1

    def __len__(self) -> int:
        return self.n_frames

    def __repr__(self) -> str:
        return f"PoseTrajectory(n_frames={self.n_frames}, n_markers={self.n_markers})"


class StrainTrajectory(StrainSeries):
    """Strains of a PCS segmentation over time, carrying the segmentation.

    Parameters
    ----------
    q : array_like, shape (T, 3m)
        Full strains ``[q_1, ..., q_m]``; strains that are not modelled are 0.
    t : array_like, shape (T,), optional
        Time stamps in seconds.
    segment_lengths : sequence of float
        The segmentation ``q`` refers to.
    active_strains : array_like of bool, shape (m, 3), optional
        Which strains are modelled (default all).
    qd : array_like, shape (T, 3m), optional
        Strain rates when known (simulation); estimators otherwise
        differentiate ``q``.
    dt : float, optional
        Sample period, used when ``t`` is not given.
    metadata : mapping, optional

    Notes
    -----
    ``np.asarray(traj)`` is the state ``[q, qd]``, shape (T, 6m), all strains (unmodelled ones
    0): what pysindy's ``simulate`` returns, for the trajectories every ``simulate`` of the
    package returns.  A trajectory without rates (measured strains) has no such state and
    refuses the conversion; read ``traj.q``.
    """

    def __init__(
        self,
        q: ArrayLike,
        t: ArrayLike | None = None,
        *,
        segment_lengths: Sequence[float],
        active_strains: ArrayLike | None = None,
        qd: ArrayLike | None = None,
        dt: float | None = None,
        base_pose: Sequence[float] = (0.0, 0.0, 0.0),
        metadata: Mapping[str, Any] | None = None,
    ) -> None:
        self.kinematics = PlanarPCS(tuple(np.atleast_1d(segment_lengths)), active_strains, tuple(base_pose))
        self._init_series(q, t, qd, dt, metadata)

    def poses(self, s: ArrayLike) -> NDArray[np.float64]:
        """Poses (T, P, 3) at global arc lengths ``s``."""
        return self.kinematics.forward_kinematics(self.q, s)

    @property
    def state(self) -> NDArray[np.float64]:
        """The state ``[q, qd]`` (T, 6m) (pysindy's ``x``); ``np.asarray(traj)`` gives the same array.

        Raises
        ------
        ValueError
            When the trajectory has no rates ``qd`` (measured strains).
        """
        if self.qd is None:
            raise ValueError(
                "this StrainTrajectory has no rates qd (measured strains), so no state [q, qd]; "
                "read its strains as .q (rollouts of simulate carry both)"
            )
        return np.hstack([self.q, self.qd])

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray:
        state = self.state
        return state if dtype is None else state.astype(dtype, copy=False)

    def __repr__(self) -> str:
        return (
            f"StrainTrajectory(n_frames={self.n_frames}, segment_lengths={list(self.segment_lengths)}, "
            f"n_active={self.kinematics.n_active})"
        )


def _reject_sparse(X: Any, name: str) -> None:
    # a scipy.sparse matrix would otherwise become a 0-d object array with a puzzling message
    if hasattr(X, "tocsr") and hasattr(X, "nnz"):
        raise ValueError(f"{name}: sparse input is not supported; give a list of recordings (trajectories)")


def as_pose_trajectories(X: Any, *, dt: float | None = None, name: str = "X") -> list[PoseTrajectory]:
    """Coerce a recording or a list of recordings to a list of :class:`PoseTrajectory`.

    Accepts PoseTrajectory objects, arrays of shape (T, N + 1, 3) (time stamps
    from ``dt``, default 1 ms), or a list mixing both.  A single 3-D array is
    one recording; a 4-D array is a stack of recordings.
    """
    if isinstance(X, PoseTrajectory):
        return [X]
    _reject_sparse(X, name)
    if isinstance(X, np.ndarray):
        if X.ndim == 3:
            X = [X]
        elif X.ndim == 4:
            X = list(X)
        else:
            raise ValueError(f"{name} as an array must have shape (T, N + 1, 3) or (R, T, N + 1, 3); got {X.shape}")
    if not isinstance(X, (list, tuple)) or len(X) == 0:
        raise ValueError(f"{name} must be a non-empty list of recordings; got {type(X).__name__}")
    out = []
    for k, rec in enumerate(X):
        if isinstance(rec, PoseTrajectory):
            out.append(rec)
        else:
            arr = np.asarray(rec, dtype=float)
            try:
                out.append(PoseTrajectory(arr, dt=1e-3 if dt is None else dt))
            except ValueError as err:
                raise ValueError(f"{name}[{k}]: {err}") from None
    return out


def as_strain_trajectories(
    X: Any, *, name: str = "X", t: Any = None, segment_lengths: Sequence[float] | None = None
) -> list[StrainTrajectory]:
    """Coerce a StrainTrajectory, a list of them, or strain arrays with their segmentation to a list.

    Parameters
    ----------
    X : StrainTrajectory, list of StrainTrajectory, or array_like (T, 3m) or a list of them
        Recordings.  Plain arrays are the full strains of each recording and need
        ``segment_lengths`` and ``t``.
    name : str
        The argument's name in error messages.
    t : float, array_like (T,), or list of them, optional
        With arrays: the sample period [s] of every recording, the time stamps of a single
        recording, or one of either per recording.
    segment_lengths : sequence of float, optional
        With arrays: the rest length [m] of each segment the strains refer to.

    Returns
    -------
    list of StrainTrajectory

    Raises
    ------
    ValueError
        For anything else, and for arrays without ``segment_lengths`` (saying how to give them).
    """
    if isinstance(X, StrainTrajectory):
        X = [X]
    _reject_sparse(X, name)
    if isinstance(X, np.ndarray):
        if X.ndim not in (2, 3):
            raise ValueError(
                f"{name} as an array must be the strains (T, 3m) of one recording or (R, T, 3m) of R; got {X.shape}"
            )
        X = [X] if X.ndim == 2 else list(X)
    if not isinstance(X, (list, tuple)) or len(X) == 0:
        raise ValueError(
            f"{name} must be a non-empty list of StrainTrajectory (or of strain arrays with segment_lengths); "
            f"got {type(X).__name__}"
        )
    trajectories = [isinstance(rec, StrainTrajectory) for rec in X]
    if all(trajectories):
        if t is not None or segment_lengths is not None:
            raise ValueError(
                f"{name} holds StrainTrajectory objects, which carry their own time stamps and segmentation: "
                "give t and segment_lengths only with plain strain arrays"
            )
        return list(X)
    if any(trajectories):
        k = trajectories.index(False)
        raise ValueError(
            f"{name}[{k}] is a {type(X[k]).__name__} among StrainTrajectory objects; give only StrainTrajectory "
            "objects, or only strain arrays"
        )
    if segment_lengths is None:
        raise ValueError(
            f"{name}[0] is a {type(X[0]).__name__}, a plain array that does not say which segmentation its strains "
            "refer to (a StrainTrajectory carries it): give segment_lengths=[L_1, ..., L_m], the rest length of each "
            "segment in metres (q has 3 strains per segment, shape (T, 3m)), and t= (the sample period [s], the time "
            "stamps, or one per recording), e.g. fit(q, t=0.001, u=u, segment_lengths=[0.07, 0.1]); or build "
            "StrainTrajectory(q, t, segment_lengths=[0.07, 0.1]) per recording"
        )
    if t is None:
        raise ValueError(
            f"{name} holds strain arrays: give t= (the sample period [s], the time stamps, or one per recording)"
        )
    if isinstance(t, (list, tuple)):
        ts = list(t)
        if len(ts) != len(X):
            raise ValueError(
                f"t must give one sample period or time array per recording of {name} ({len(X)}); got {len(ts)}"
            )
    elif np.ndim(t) == 0 or len(X) == 1:
        ts = [t] * len(X)
    else:
        raise ValueError(
            f"t is one time array but {name} holds {len(X)} recordings: give a sample period [s] or a list of "
            "time arrays, one per recording"
        )
    out = []
    for k, (rec, tk) in enumerate(zip(X, ts)):
        scalar = np.ndim(tk) == 0
        try:
            out.append(
                StrainTrajectory(
                    rec,
                    None if scalar else tk,
                    dt=float(tk) if scalar else None,
                    segment_lengths=segment_lengths,
                )
            )
        except (TypeError, ValueError) as err:
            raise ValueError(f"{name}[{k}]: {err}") from None
    return out


def kinematics_of(x: Any) -> PlanarPCS | None:
    """The kinematics (segmentation) shared by strain trajectories, or None when ``x`` holds plain arrays.

    Raises
    ------
    ValueError
        When the trajectories carry different segmentations.
    """
    items = [x] if isinstance(x, StrainTrajectory) else list(x) if isinstance(x, (list, tuple)) else []
    if not items or not all(isinstance(r, StrainTrajectory) for r in items):
        if any(isinstance(r, StrainTrajectory) for r in items):
            raise ValueError("x must hold only StrainTrajectory objects or only arrays, not both")
        return None
    kin = items[0].kinematics
    for k, rec in enumerate(items[1:], start=1):
        rk = rec.kinematics
        same = np.allclose(rk.segment_lengths, kin.segment_lengths, rtol=1e-9, atol=0) and np.array_equal(
            rk.active_strains, kin.active_strains
        )
        if not same:
            raise ValueError(
                f"x[{k}] has segment_lengths {list(rk.segment_lengths)} and active strains "
                f"{rk.active_strains.astype(int).tolist()}, x[0] {list(kin.segment_lengths)} and "
                f"{kin.active_strains.astype(int).tolist()}; every recording must share one segmentation"
            )
    return PlanarPCS(kin.segment_lengths, kin.active_strains)
