"""Trajectory containers: the sample unit that flows through every estimator.

A recording is one trajectory.  Estimators take lists of them (one entry per
recording), so cross-validation splits by recording.  Containers validate on
construction and are otherwise plain holders of numpy arrays.

Ground floor: imports only :mod:`pcs_sindy.core.kinematics`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .kinematics import PlanarPCS

__all__ = [
    "PoseTrajectory",
    "StrainTrajectory",
    "check_time",
    "as_pose_trajectories",
    "as_strain_trajectories",
    "kinematics_of",
]


def check_time(t: ArrayLike | None, n_samples: int, *, dt: float | None = None, name: str = "t") -> NDArray[np.float64]:
    """Validate (or build) time stamps of length ``n_samples``.

    Parameters
    ----------
    t : array_like or None
        Strictly increasing, finite time stamps.  When ``None`` they are built
        from ``dt``.
    n_samples : int
    dt : float, optional
        Sample period used when ``t`` is None.
    name : str
        Argument name used in error messages.
    """
    if t is None:
        if dt is None:
            raise ValueError(f"either {name} (time stamps) or dt must be given")
        if not np.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be finite and > 0; got {dt!r}")
        return np.arange(n_samples) * float(dt)
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.shape[0] != n_samples:
        raise ValueError(f"{name} must have shape ({n_samples},); got {t.shape}")
    if not np.all(np.isfinite(t)):
        k = int(np.argmax(~np.isfinite(t)))
        raise ValueError(f"{name} contains NaN or inf ({name}[{k}] = {float(t[k])!r}); time stamps must be finite")
    if n_samples > 1 and np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0))
        raise ValueError(
            f"{name} must be strictly increasing; {name}[{k + 1}] = {float(t[k + 1])!r} <= "
            f"{name}[{k}] = {float(t[k])!r}"
        )
    return t


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
    """

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

    @property
    def n_frames(self) -> int:
        return self.poses.shape[0]

    @property
    def n_markers(self) -> int:
        """Number of tracked cross-sections N (the base not counted)."""
        return self.poses.shape[1] - 1

    def __len__(self) -> int:
        return self.n_frames

    def __repr__(self) -> str:
        return f"PoseTrajectory(n_frames={self.n_frames}, n_markers={self.n_markers})"


class StrainTrajectory:
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
        n = self.kinematics.n_q
        q = np.asarray(q, dtype=float)
        if q.ndim != 2 or q.shape[1] != n:
            raise ValueError(f"q must have shape (T, {n}) for {self.kinematics.n_segments} segment(s); got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError(f"q contains NaN or inf (first at frame {np.argwhere(~np.isfinite(q))[0][0]})")
        self.q = q
        self.t = check_time(t, q.shape[0], dt=dt)
        if qd is not None:
            qd = np.asarray(qd, dtype=float)
            if qd.shape != q.shape:
                raise ValueError(f"qd must have the shape of q {q.shape}; got {qd.shape}")
            if not np.all(np.isfinite(qd)):
                raise ValueError("qd contains NaN or inf")
        self.qd = qd
        self.metadata = dict(metadata or {})

    @property
    def segment_lengths(self) -> tuple[float, ...]:
        return self.kinematics.segment_lengths

    @property
    def active_strains(self) -> NDArray[np.bool_]:
        return self.kinematics.active_strains

    @property
    def n_frames(self) -> int:
        return self.q.shape[0]

    def __len__(self) -> int:
        return self.n_frames

    def poses(self, s: ArrayLike) -> NDArray[np.float64]:
        """Poses (T, P, 3) at global arc lengths ``s``."""
        return self.kinematics.forward_kinematics(self.q, s)

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


def as_strain_trajectories(X: Any, *, name: str = "X") -> list[StrainTrajectory]:
    """Coerce a StrainTrajectory or a list of them to a list; raise otherwise."""
    if isinstance(X, StrainTrajectory):
        return [X]
    _reject_sparse(X, name)
    if not isinstance(X, (list, tuple)) or len(X) == 0:
        raise ValueError(f"{name} must be a non-empty list of StrainTrajectory; got {type(X).__name__}")
    for k, rec in enumerate(X):
        if not isinstance(rec, StrainTrajectory):
            raise ValueError(
                f"{name}[{k}] must be a StrainTrajectory (it carries the segmentation); got {type(rec).__name__}"
            )
    return list(X)


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
