"""The spatial tendon kind: tendons routed in 3-D from the base to termination arc lengths, pulled by tensions.

The identification's counterpart of the simulator's ``SpatialTendons`` (issue 26 conventions): tendon k
runs at the fixed body offset ``d_k = (d_x, 0, d_z)`` in the cross-section (body x and z axes; the
tangent is y) from the base to its termination arc length.  Its path ``p + R d_k`` has the tangent
``R (v + ω × d_k)``, constant inside a constant-strain stretch, so its length is exactly

    l_k = Σ_i c_ki |v_i + ω_i × d_k|,

``c_ki`` the rest length of segment i the tendon covers, ``v = (shear_x, 1 + axial, shear_z)`` and
``ω = (bend_x, twist, bend_z)`` the segment's body twist.  A tension ``f_k ≥ 0`` does the virtual
work ``−f_k δl_k``: its column of ``A(q)`` is ``−∂l_k/∂q`` (closed form, NumPy; no compiled form, so
forward models evaluate it in Python).  The offsets are given (known routing), or their magnitudes
are identified along given directions in the cross-section (variable projection, like the planar
tendons' magnitudes along their sides).

Imports only :mod:`pcs_sindy.core` and its own package.
"""

from __future__ import annotations

from numbers import Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...core.spatial import SpatialPCS
from ...core.validation import Check, Interval, InvalidParameterError, Options
from ._common import END, check_inside, finite_vector, per_actuator, segment_cover
from .base import Actuation

__all__ = ["SpatialTendonActuation"]

_WEIGHTINGS = ("residual", "none")


def _offsets_ok(value: Any) -> bool:
    arr = np.asarray(value, dtype=float)
    shaped = (arr.ndim == 2 and arr.shape[1] == 2 and arr.shape[0] > 0) or arr.shape == (2,)
    return shaped and bool(np.all(np.isfinite(arr)))


class SpatialTendonActuation(Actuation):
    """Tendons in 3-D: from the base to termination arc lengths at offsets ``(d_x, d_z)`` in the cross-section.

    ``A(q) = −∂l/∂q`` with the exact tendon lengths ``l_k = Σ_i c_ki |v_i + ω_i × d_k|`` (module
    docstring).  A tendon at ``d_x > 0`` bends the robot towards negative ``bend_z``, one at
    ``d_z > 0`` towards positive ``bend_x`` (as the simulator's ``SpatialTendons``).

    Parameters
    ----------
    end : array_like, shape (p,)
        Termination arc lengths [m], in ``(0, total rest length]``.
    offset : array_like, shape (p, 2), optional
        Known offsets ``(d_x, d_z)`` [m] of every tendon (the routing of the design).
    angle : array_like, shape (p,), optional
        Instead of ``offset``: the direction of every tendon in the cross-section [rad], from the body
        x axis towards the body z axis (``d = r (cos a, sin a)``); the magnitudes ``r`` are identified
        (variable projection, within ``(0, max_offset]``).
    max_offset : float, default 0.05
        Upper bound [m] of identified magnitudes.
    shared : bool, default False
        Identify one magnitude for all tendons (tendons routed at one radius).
    weighting : {"residual", "none"}, default "residual"
        How the strains' equations are weighted when magnitudes are identified (as
        :class:`~pcs_sindy.models.actuation.TendonActuation`).

    Attributes
    ----------
    offsets_ : ndarray, shape (2p,)
        The offsets used, ``(d_x, d_z)`` of tendon 1, then of tendon 2, ... (given, or identified by
        the regressor); :attr:`offset_vectors_` as (p, 2).

    Notes
    -----
    Inputs are tensions [N], ``>= 0``; a negative tension raises.
    """

    kind = "spatial_tendon"
    spatial = True
    depends_on_q = True
    _design_keys = ("end",)
    _parameter_constraints: dict = {
        "end": [END],
        "offset": [None, Check(_offsets_ok, "finite offsets (d_x, d_z) [m], shape (p, 2)")],
        "angle": [None, Check(finite_vector, "a non-empty 1-D array of finite angles [rad]")],
        "max_offset": [Interval(Real, 0, None, closed="neither")],
        "shared": ["boolean"],
        "weighting": [Options(_WEIGHTINGS)],
    }

    def __init__(
        self,
        end: ArrayLike = (),
        offset: ArrayLike | None = None,
        angle: ArrayLike | None = None,
        max_offset: float = 0.05,
        shared: bool = False,
        weighting: str = "residual",
    ) -> None:
        self.end = end
        self.offset = offset
        self.angle = angle
        self.max_offset = max_offset
        self.shared = shared
        self.weighting = weighting

    def input_bounds(self):
        """Tensions pull: ``[0, inf)``."""
        return np.zeros(self.n_inputs_), np.full(self.n_inputs_, np.inf)

    def _structure(self, kinematics: SpatialPCS) -> dict[str, Any]:
        if not isinstance(kinematics, SpatialPCS):
            raise ValueError(
                f"{type(self).__name__} routes tendons in 3-D: kinematics must be a SpatialPCS; got "
                f"{type(kinematics).__name__} (for a planar robot use TendonActuation, kind 'tendon')"
            )
        end = per_actuator(self, "end")
        p = end.size
        lengths = np.asarray(kinematics.segment_lengths, dtype=float)
        total = float(lengths.sum())
        check_inside(end, "end", total, allow_zero=False)
        if (self.offset is None) == (self.angle is None):
            raise InvalidParameterError(
                f"{type(self).__name__}: give the tendons' offsets (offset, shape ({p}, 2), known routing) or their "
                f"directions (angle, shape ({p},), magnitudes identified), exactly one of them; got "
                f"offset={self.offset!r}, angle={self.angle!r}"
            )
        cover = segment_cover(np.zeros(p), np.minimum(end, total), lengths)
        out: dict[str, Any] = {"cover": cover, "n_inputs": p, "gain_names": [], "gains": np.zeros(0)}
        if self.offset is not None:
            offset = np.asarray(self.offset, dtype=float).reshape(-1, 2)
            if offset.shape[0] != p:
                raise InvalidParameterError.of(self, "offset", f"shape ({p}, 2), one (d_x, d_z) per end", self.offset)
            out.update(directions=None, offset_names=[], offsets=offset.reshape(-1))
            return out
        angle = per_actuator(self, "angle", p)
        directions = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        start = min(0.01, 0.5 * self.max_offset)
        names = ["r"] if self.shared else [f"r_{k + 1}" for k in range(p)]
        out.update(directions=directions, offset_names=names, offsets=(start * directions).reshape(-1))
        return out

    # -- nonlinear parameters (identified magnitudes) -------------------------------
    def offset_bounds(self):
        if self.n_offsets == 0:
            return np.zeros(0), np.zeros(0)
        return np.full(self.n_offsets, 1e-4 * self.max_offset), np.full(self.n_offsets, float(self.max_offset))

    def initial_offsets(self):
        if self.n_offsets == 0:
            return np.zeros(0)
        mags = np.linalg.norm(self.offsets_.reshape(-1, 2), axis=1)
        return mags[:1] if self.shared else mags

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """The offsets ``(d_x, d_z)`` per tendon, flat (2p,), for the identified magnitudes ``offsets``.

        Default: the fitted ``offsets_``.
        """
        if offsets is None or self.n_offsets == 0:
            return self.offsets_
        mags = np.broadcast_to(np.asarray(offsets, dtype=float).reshape(-1), (self.n_inputs_,))
        return (mags[:, None] * self._arrays["directions"]).reshape(-1)

    @property
    def offset_vectors_(self) -> NDArray[np.float64]:
        """The offsets ``(d_x, d_z)`` [m] of every tendon, shape (p, 2)."""
        return np.asarray(self.offsets_, dtype=float).reshape(-1, 2)

    # -- inputs -------------------------------------------------------------------------
    def check_inputs(self, u, name="u", t=None):
        arr = super().check_inputs(u, name, t)
        if np.any(arr < 0):
            idx = np.argwhere(arr < 0)[0]
            when = "" if t is None else f" at t = {float(np.asarray(t)[idx[0]]):g} s"
            raise ValueError(
                f"{name}[{idx[0]}, {idx[1]}] = {float(arr[tuple(idx)])!r}{when}: tendon {idx[1]} would push; "
                "tendon tensions must be >= 0"
            )
        return arr

    # -- the map --------------------------------------------------------------------------
    def _tangents(self, q: ArrayLike, offsets: ArrayLike | None) -> tuple[NDArray, NDArray, NDArray]:
        """Body tangents ``v_i + ω_i × d_k`` (B, p, m, 3) of the offset curves, their lengths (B, p, m), d (p, 2)."""
        qf = self.kinematics_.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets).reshape(-1, 2)
        B, m = qf.shape[0], self.kinematics_.n_segments
        s = qf.reshape(B, 1, m, 6)
        kz, kx, ky, sx, sz, ax = (s[..., c] for c in range(6))
        dx, dz = d[None, :, None, 0], d[None, :, None, 1]
        tangent = np.stack(
            np.broadcast_arrays(sx + ky * dz, 1.0 + ax + kz * dx - kx * dz, sz - ky * dx), axis=-1
        )  # (B, p, m, 3)
        return tangent, np.linalg.norm(tangent, axis=-1), d

    def lengths(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Tendon lengths (B, p) [m] at modelled strains ``q`` (B, n)."""
        _, nu, _ = self._tangents(q, offsets)
        return np.sum(self._arrays["cover"][None] * nu, axis=-1)

    def jacobian(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """``∂l/∂q`` (B, p, n) on the modelled strains (0 for segments a tendon does not cover)."""
        tangent, nu, d = self._tangents(q, offsets)
        cover = self._arrays["cover"][None]
        # c / nu where the tendon covers the segment (a covered stretch of zero length has no gradient: NaN)
        f = np.where(cover > 0, cover / np.where(cover > 0, nu, 1.0), 0.0)
        t0, t1, t2 = tangent[..., 0], tangent[..., 1], tangent[..., 2]
        dx, dz = d[None, :, None, 0], d[None, :, None, 1]
        jac = np.stack([t1 * dx, -t1 * dz, t0 * dz - t2 * dx, t0, t2, t1], axis=-1) * f[..., None]
        B, p, m = nu.shape
        return jac.reshape(B, p, 6 * m)[:, :, self.kinematics_.active_mask]

    def parts(self, q, u, offsets=None):
        jac = self.jacobian(q, offsets)
        known = -np.einsum("bkn,bk->bn", jac, np.asarray(u, dtype=float))
        return known, np.zeros(known.shape + (0,))

    def tensions(self, q: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Tendon tensions [N] (B, p): the inputs."""
        return np.atleast_2d(np.asarray(u, dtype=float)).copy()

    def design_layout(self) -> dict[str, Any]:
        out = super().design_layout()
        if self.offset is not None:
            out["offset"] = np.asarray(self.offset, dtype=float).reshape(-1, 2).tolist()
        else:
            out["angle"] = np.asarray(self.angle, dtype=float).reshape(-1).tolist()
        return out

    def describe(self, precision: int = 3) -> list[str]:
        ends = ", ".join(f"{e:.{precision}g}" for e in np.atleast_1d(np.asarray(self.end, dtype=float)))
        how = "identified along the given directions" if self.offset is None else "given"
        offs = ", ".join(f"({1e3 * a:.{precision}g}, {1e3 * b:.{precision}g})" for a, b in self.offset_vectors_)
        return [
            "A(q) = -dl/dq, l_k = sum_i c_ki |v_i + w_i x d_k|, d_k = (d_x, 0, d_z) (tendons in 3-D, tensions >= 0)",
            f"tendon ends [m]: {ends}; offsets (d_x, d_z) [mm] ({how}): {offs}",
        ]
