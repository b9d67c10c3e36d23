"""What the planar and spatial PCS descriptions and strain trajectories share: sizes, strain masks, checks.

:class:`SegmentedStrains` is the base of the frozen dataclasses
:class:`~pcs_sindy.core.PlanarPCS` (3 strains per segment) and :class:`~pcs_sindy.core.SpatialPCS`
(6): the segment lengths and the mask of modelled strains, and the sizes derived from them.
:class:`StrainSeries` is the base of :class:`~pcs_sindy.core.StrainTrajectory` and
:class:`~pcs_sindy.core.SpatialStrainTrajectory`: the checks of ``q``, ``t`` and ``qd`` against the
trajectory's ``kinematics``.  :func:`check_time` (re-exported by :mod:`pcs_sindy.core.trajectory`)
validates time stamps.

This module knows no geometry (no kinematics maps) and imports nothing of the package.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["SegmentedStrains", "StrainSeries", "check_lengths", "check_time"]


def check_lengths(segment_lengths: ArrayLike) -> NDArray[np.float64]:
    """Segment lengths as a non-empty 1-D array of finite numbers > 0."""
    lengths = np.atleast_1d(np.asarray(segment_lengths, dtype=float))
    if lengths.ndim != 1 or lengths.size == 0:
        raise ValueError(f"segment_lengths must be a non-empty 1-D sequence; got shape {lengths.shape}")
    if not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
        raise ValueError(f"segment_lengths must be finite and > 0; got {lengths.tolist()}")
    return lengths


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


class SegmentedStrains:
    """Segment lengths and the modelled-strain mask of a frozen PCS dataclass.

    The subclass is a frozen dataclass with the fields ``segment_lengths``, ``active_strains`` and
    ``_mask``, sets the class attribute ``_n_strains`` (strains per segment) and calls
    :meth:`_init_strains` first in ``__post_init__``.
    """

    _n_strains: int
    segment_lengths: tuple[float, ...]
    active_strains: Any
    _mask: NDArray[np.bool_]

    def _init_strains(self) -> None:
        """Check and freeze ``segment_lengths`` and ``active_strains`` (set ``_mask``, the flat mask)."""
        lengths = check_lengths(self.segment_lengths)
        object.__setattr__(self, "segment_lengths", tuple(float(v) for v in lengths))
        m, per = lengths.size, self._n_strains
        if self.active_strains is None:
            mask = np.ones((m, per), dtype=bool)
        else:
            raw = np.asarray(self.active_strains)
            if raw.shape not in ((m, per), (per * m,)):
                raise ValueError(
                    f"active_strains must have shape ({m}, {per}) or ({per * m},) for {m} segment(s); got {raw.shape}"
                )
            if raw.dtype != bool and not np.all(np.isin(raw, (0, 1))):
                raise ValueError(f"active_strains must be boolean; got {raw.tolist()}")
            mask = raw.astype(bool).reshape(m, per)
        mask = mask.copy()
        mask.setflags(write=False)
        object.__setattr__(self, "active_strains", mask)
        object.__setattr__(self, "_mask", mask.reshape(-1))

    @property
    def n_segments(self) -> int:
        """Number of segments ``m``."""
        return len(self.segment_lengths)

    @property
    def n_active(self) -> int:
        """Number of modelled strains."""
        return int(self._mask.sum())

    @property
    def total_length(self) -> float:
        """Rest length of the robot."""
        return float(sum(self.segment_lengths))

    @property
    def boundaries(self) -> NDArray[np.float64]:
        """Arc lengths of the segment ends, shape (m,)."""
        return np.cumsum(self.segment_lengths)

    def _strain_names(self, names: tuple[str, ...] | list[str], active_only: bool) -> list[str]:
        """``names`` suffixed by the segment number, segment by segment (the modelled ones only)."""
        out = [f"{n}_{i + 1}" for i in range(self.n_segments) for n in names]
        if active_only:
            out = [n for n, a in zip(out, self._mask) if a]
        return out


class StrainSeries:
    """Strains over time checked against the trajectory's ``kinematics`` (set before :meth:`_init_series`)."""

    kinematics: Any

    def _init_series(
        self,
        q: ArrayLike,
        t: ArrayLike | None,
        qd: ArrayLike | None,
        dt: float | None,
        metadata: Mapping[str, Any] | None,
    ) -> None:
        """Check and store ``q`` (T, n_q), the time stamps, the rates ``qd`` (or None) and ``metadata``."""
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
