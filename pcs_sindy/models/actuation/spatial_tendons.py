"""The spatial tendon kind: tendons routed in 3-D from the base to termination arc lengths, pulled by tensions.

The identification's counterpart of the simulator's ``SpatialTendons`` (issue 26 conventions): tendon k
runs at the fixed body offset ``d_k = (d_x, 0, d_z)`` in the cross-section (body x and z axes; the
tangent is y) from the base to its termination arc length.  Its path ``p + R d_k`` has the tangent
``R (v + ω × d_k)``, constant inside a constant-strain stretch, so its length is exactly

    l_k = Σ_i c_ki |v_i + ω_i × d_k|,

``c_ki`` the rest length of segment i the tendon covers, ``v = (shear_x, 1 + axial, shear_z)`` and
``ω = (bend_x, twist, bend_z)`` the segment's body twist.  A tension ``f_k ≥ 0`` does the virtual
work ``−f_k δl_k``: its column of ``A(q)`` is ``−∂l_k/∂q`` (closed form, NumPy; the spatial models'
compiled kernels evaluate the same map from :meth:`SpatialTendonActuation.compiled`).  The offsets are
given (known routing), or their magnitudes are identified along given directions in the cross-section
(variable projection, like the planar tendons' magnitudes along their sides).  Servo-wound elastic
tendons (``drive="displacement"``) pull with ``k max(0, r u π/180 + l(q) − l(0) − s)`` as the planar
ones do.

Imports only :mod:`pcs_sindy.core` and its own package.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...core.spatial import SpatialPCS
from ...core.validation import Check, InvalidParameterError
from ._common import (
    END,
    TENDON_DRIVE_CONSTRAINTS,
    TendonDrive,
    check_inside,
    finite_vector,
    per_actuator,
    segment_cover,
    sides,
)
from .base import Actuation

__all__ = ["SpatialTendonActuation"]

#: the displacement-drive parameters, with the label of their identified values
_SERVO = (("pulley_radius", "r"), ("slack", "s"))


def _motor_ok(value: Any) -> bool:
    arr = np.atleast_1d(np.asarray(value))
    if arr.ndim != 1 or arr.size == 0 or arr.dtype.kind not in "iuf" or not np.all(np.isfinite(arr)):
        return False
    # every servo 0 .. M-1 winds at least one tendon (so M <= the tendons: no index beyond them)
    if not (np.all(arr == np.round(arr)) and arr.min() == 0 and arr.max() < arr.size):
        return False
    return bool(np.unique(arr).size == int(arr.max()) + 1)


def _offsets_ok(value: Any) -> bool:
    arr = np.asarray(value, dtype=float)
    shaped = (arr.ndim == 2 and arr.shape[1] == 2 and arr.shape[0] > 0) or arr.shape == (2,)
    return shaped and bool(np.all(np.isfinite(arr)))


class SpatialTendonActuation(TendonDrive, Actuation):
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
    drive : {"tension", "displacement"}, default "tension"
        ``"tension"``: the inputs are tendon tensions [N].  ``"displacement"``: servo angles [deg]
        winding elastic tendons on pulleys, stretched by ``e_k = r_k u_k π/180 + l_k(q) − l_k(0) − s_k``
        and pulling with ``f_k = k_k max(0, e_k)`` (the planar ``TendonActuation``'s servo law).
    stiffness : array_like, shape (p,), optional
        Tendon stiffness ``k`` [N/m] when known (displacement drive); default identified with the
        Lagrangian (linear gains ``k_<k>``; the regression then needs the robot's mass for its scale).
    pulley_radius : array_like, shape (p,), optional
        Pulley radius ``r`` [m] when known (displacement drive); default identified within ``(0, max_radius]``.
    slack : array_like, shape (p,), optional
        Slack ``s`` [m] of the straight robot at ``u = 0`` when known (displacement drive); default
        identified within ``[-max_slack, max_slack]``.
    max_radius, max_slack : float, default 0.05
        Bounds [m] of identified pulley radii and slacks.
    motor : array_like of int, shape (p,), optional
        Displacement drive: the input (servo) that winds each tendon, numbered from 0; default one servo
        per tendon.  Antagonistic tendons share a servo (``motor=[0, 0, 1, 1, ...]``).
    winding : array_like of {-1, 1}, shape (p,), optional
        With ``motor``: +1 where a positive angle takes the tendon up, -1 where it lets it out (the
        antagonist of a pair); default all +1.

    Attributes
    ----------
    offsets_ : ndarray, shape (2p,) or (4p,)
        The offsets used, ``(d_x, d_z)`` of tendon 1, then of tendon 2, ... (given, or identified by
        the regressor; :attr:`offset_vectors_` as (p, 2)); for a displacement drive followed by the
        pulley radii and the slacks.
    gains_ : ndarray
        Displacement drive: the identified tendon stiffnesses (or the given ones).
    n_tendons_ : int
        Number of tendons ``p`` (the inputs ``n_inputs_`` are the servos with ``motor``).

    Notes
    -----
    Tensions are ``>= 0`` (a negative tension raises); servo angles may take either sign.
    """

    kind = "spatial_tendon"
    spatial = True
    compiled_forms = ("spatial_tendon",)
    depends_on_q = True
    _design_keys = ("end",)
    _parameter_constraints: dict = {
        "end": [END],
        "offset": [None, Check(_offsets_ok, "finite offsets (d_x, d_z) [m], shape (p, 2)")],
        "angle": [None, Check(finite_vector, "a non-empty 1-D array of finite angles [rad]")],
        **TENDON_DRIVE_CONSTRAINTS,
        "motor": [None, Check(_motor_ok, "a non-empty 1-D array of input indices 0, 1, ... (one per tendon)")],
        "winding": [None, Check(sides, "a non-empty 1-D array of -1 or 1 (one per tendon)")],
    }

    def __init__(
        self,
        end: ArrayLike = (),
        offset: ArrayLike | None = None,
        angle: ArrayLike | None = None,
        max_offset: float = 0.05,
        shared: bool = False,
        weighting: str = "residual",
        drive: str = "tension",
        stiffness: ArrayLike | None = None,
        pulley_radius: ArrayLike | None = None,
        slack: ArrayLike | None = None,
        max_radius: float = 0.05,
        max_slack: float = 0.05,
        motor: ArrayLike | None = None,
        winding: ArrayLike | None = None,
    ) -> None:
        self.end = end
        self.offset = offset
        self.angle = angle
        self.max_offset = max_offset
        self.shared = shared
        self.weighting = weighting
        self.drive = drive
        self.stiffness = stiffness
        self.pulley_radius = pulley_radius
        self.slack = slack
        self.max_radius = max_radius
        self.max_slack = max_slack
        self.motor = motor
        self.winding = winding

    @property
    def n_tendons_(self) -> int:
        """Number of tendons (the inputs are the servos when ``motor`` couples several tendons to one)."""
        return int(self._arrays["cover"].shape[0])

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
        if not self.is_displacement:
            for name in ("stiffness", "pulley_radius", "slack", "motor", "winding"):
                if getattr(self, name) is not None:
                    raise InvalidParameterError.of(
                        self, name, "None with drive='tension' (a displacement-drive parameter)", getattr(self, name)
                    )
        cover = segment_cover(np.zeros(p), np.minimum(end, total), lengths)
        out: dict[str, Any] = {"cover": cover, "n_inputs": p, "gain_names": [], "gains": np.zeros(0)}
        if self.winding is not None and self.motor is None:
            raise InvalidParameterError.of(
                self, "winding", "None without motor (it signs each tendon's servo)", self.winding
            )
        if self.motor is not None:  # servos winding several tendons: the inputs are the servos' angles
            motor = per_actuator(self, "motor", p).astype(int)
            winding = np.ones(p) if self.winding is None else per_actuator(self, "winding", p)
            out.update(motor=motor, winding=winding, n_inputs=int(motor.max()) + 1)
        names: list[str] = []
        if self.offset is not None:
            offset = np.asarray(self.offset, dtype=float).reshape(-1, 2)
            if offset.shape[0] != p:
                raise InvalidParameterError.of(self, "offset", f"shape ({p}, 2), one (d_x, d_z) per end", self.offset)
            out["directions"] = None
            full = [offset.reshape(-1)]
        else:
            angle = per_actuator(self, "angle", p)
            directions = np.stack([np.cos(angle), np.sin(angle)], axis=1)
            names += ["d"] if self.shared else [f"d_{k + 1}" for k in range(p)]
            out["directions"] = directions
            full = [(min(0.01, 0.5 * self.max_offset) * directions).reshape(-1)]
        if self.is_displacement:  # pulley radii and slacks: given, or identified (their names and starts)
            for (name, label), start in zip(_SERVO, (min(0.01, 0.5 * self.max_radius), 0.0), strict=True):
                if getattr(self, name) is None:
                    names += [f"{label}_{k + 1}" for k in range(p)]
                    full.append(np.full(p, start))
                else:
                    full.append(per_actuator(self, name, p))
            if self.stiffness is None:
                out.update(gain_names=[f"k_{k + 1}" for k in range(p)], gains=np.zeros(p))
            else:
                out.update(gains=per_actuator(self, "stiffness", p))
            out["rest"] = cover.sum(axis=1)  # l_k(0): the straight robot's offset curves have unit tangents
        out.update(offset_names=names, offsets=np.concatenate(full))
        return out

    def _free(self) -> list[tuple[slice, str, slice]]:
        """(slice of the parameter vector, what, slice of ``offsets_``) of every free nonlinear parameter block."""
        p = self.n_tendons_
        out, k = [], 0
        if self.offset is None:
            size = 1 if self.shared else p
            out.append((slice(k, k + size), "magnitude", slice(0, 2 * p)))
            k += size
        if self.is_displacement:
            for j, (name, label) in enumerate(_SERVO):
                if getattr(self, name) is None:
                    out.append((slice(k, k + p), label, slice((2 + j) * p, (3 + j) * p)))
                    k += p
        return out

    # -- nonlinear parameters (identified magnitudes) -------------------------------
    def offset_bounds(self):
        lo, hi = [], []
        bound = {"magnitude": self.max_offset, "r": self.max_radius}
        for par, what, _ in self._free():
            size = par.stop - par.start
            if what == "s":
                lo.append(np.full(size, -float(self.max_slack)))
                hi.append(np.full(size, float(self.max_slack)))
            else:
                lo.append(np.full(size, 1e-4 * bound[what]))
                hi.append(np.full(size, float(bound[what])))
        return (np.concatenate(lo), np.concatenate(hi)) if lo else (np.zeros(0), np.zeros(0))

    def offset_floor(self) -> NDArray[np.float64]:
        """Magnitudes the relative standard errors never divide below: a slack may be 0 (1 mm then)."""
        out = [np.full(par.stop - par.start, 1e-3 if what == "s" else 0.0) for par, what, _ in self._free()]
        return np.concatenate(out) if out else np.zeros(0)

    def initial_offsets(self):
        out = []
        for par, what, full in self._free():
            vals = self.offsets_[full]
            if what == "magnitude":
                vals = np.linalg.norm(vals.reshape(-1, 2), axis=1)[: par.stop - par.start]
            out.append(vals)
        return np.concatenate(out) if out else np.zeros(0)

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """The map's parameters for the free ones ``offsets`` (default: the fitted ``offsets_``).

        The offsets ``(d_x, d_z)`` per tendon, flat (2p,); for a displacement drive followed by the
        pulley radii and the slacks (4p,).
        """
        if offsets is None or self.n_offsets == 0:
            return self.offsets_
        x = np.asarray(offsets, dtype=float).reshape(-1)
        out = np.array(self.offsets_, dtype=float)
        for par, what, full in self._free():
            if what == "magnitude":  # one shared magnitude broadcasts
                mags = np.broadcast_to(x[par], (self.n_tendons_,))
                out[full] = (mags[:, None] * self._arrays["directions"]).reshape(-1)
            else:
                out[full] = x[par]
        return out

    @property
    def offset_vectors_(self) -> NDArray[np.float64]:
        """The offsets ``(d_x, d_z)`` [m] of every tendon, shape (p, 2)."""
        return np.asarray(self.offsets_, dtype=float)[: 2 * self.n_tendons_].reshape(-1, 2)

    # -- the map --------------------------------------------------------------------------
    def _tangents(self, q: ArrayLike, offsets: ArrayLike | None) -> tuple[NDArray, NDArray, NDArray]:
        """Body tangents ``v_i + ω_i × d_k`` (B, p, m, 3) of the offset curves, their lengths (B, p, m), d (p, 2)."""
        qf = self.kinematics_.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets)[: 2 * self.n_tendons_].reshape(-1, 2)
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

    def stretch(self, q: ArrayLike, u: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Displacement drive: the stretch ``r u π/180 + l(q) − l(0) − s`` [m] (B, p), negative when slack."""
        if not self.is_displacement:
            raise ValueError(
                "stretch needs drive='displacement' (the inputs of this SpatialTendonActuation are tensions)"
            )
        full = self.signed_offsets(offsets)
        p = self.n_tendons_
        r, s = full[2 * p : 3 * p], full[3 * p : 4 * p]
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if "motor" in self._arrays:  # each tendon's angle: its servo's, signed by the winding
            u = u[:, self._arrays["motor"]] * self._arrays["winding"]
        return r * np.deg2rad(u) + self.lengths(q, offsets) - self._arrays["rest"] - s

    def parts(self, q, u, offsets=None):
        jac = self.jacobian(q, offsets)
        u = np.asarray(u, dtype=float)
        if not self.is_displacement:
            known = -np.einsum("bkn,bk->bn", jac, u)
            return known, np.zeros(known.shape + (0,))
        per_unit = -jac * np.maximum(self.stretch(q, u, offsets), 0.0)[:, :, None]  # forces per unit stiffness
        if self.stiffness is None:
            return np.zeros((jac.shape[0], jac.shape[2])), np.transpose(per_unit, (0, 2, 1))
        known = np.einsum("bkn,k->bn", per_unit, per_actuator(self, "stiffness", self.n_tendons_))
        return known, np.zeros(known.shape + (0,))

    def forces(self, q, u, gains=None, offsets=None):
        """Generalised forces ``−(∂l/∂q)ᵀ f`` (B, n) of the tensions ``f`` (:meth:`tensions`)."""
        if not self.is_displacement:
            return super().forces(q, u, gains, offsets)
        q = np.atleast_2d(np.asarray(q, dtype=float))
        jac = self.jacobian(q, offsets)
        return -np.einsum("bkn,bk->bn", jac, self.tensions(q, u, gains, offsets))

    def matrix(self, q: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> NDArray:
        """``A(q)`` (B, n, p): ``−∂l/∂q``, the forces of unit *tensions* (also for a displacement drive)."""
        if not self.is_displacement:
            return super().matrix(q, gains, offsets)
        return -np.transpose(self.jacobian(q, offsets), (0, 2, 1))

    def compiled(self, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> tuple:
        """``("spatial_tendon", offsets (p, 2), cover (p, m), drive)``: ``drive`` (0, p) for tensions, or the rows
        ``[k, r, s, l(0), servo, winding]`` (6, p) of servo-wound elastic tendons (the inputs the servos' angles)."""
        p = self.n_tendons_
        full = self.signed_offsets(offsets)
        if not self.is_displacement:
            drive = np.zeros((0, p))
        else:
            motor = self._arrays.get("motor")
            servo = np.arange(p, dtype=float) if motor is None else np.asarray(motor, dtype=float)
            winding = np.ones(p) if motor is None else np.asarray(self._arrays["winding"], dtype=float)
            r, s = full[2 * p : 3 * p], full[3 * p : 4 * p]
            drive = np.stack([self._stiffness(gains), r, s, self._arrays["rest"], servo, winding])
        return "spatial_tendon", full[: 2 * p].reshape(p, 2), self._arrays["cover"], drive

    def design_layout(self) -> dict[str, Any]:
        out = super().design_layout()
        if self.offset is not None:
            out["offset"] = np.asarray(self.offset, dtype=float).reshape(-1, 2).tolist()
        else:
            out["angle"] = np.asarray(self.angle, dtype=float).reshape(-1).tolist()
        if self.is_displacement:
            out["drive"] = "displacement"
        if self.motor is not None:
            out["motor"] = [int(v) for v in np.atleast_1d(self.motor)]
            out["winding"] = [int(v) for v in (np.ones(len(out["motor"])) if self.winding is None else self.winding)]
        return out

    def describe(self, precision: int = 3) -> list[str]:
        ends = ", ".join(f"{e:.{precision}g}" for e in np.atleast_1d(np.asarray(self.end, dtype=float)))
        how = "identified along the given directions" if self.offset is None else "given"
        offs = ", ".join(f"({1e3 * a:.{precision}g}, {1e3 * b:.{precision}g})" for a, b in self.offset_vectors_)
        out = [
            "A(q) = -dl/dq, l_k = sum_i c_ki |v_i + w_i x d_k|, d_k = (d_x, 0, d_z) (tendons in 3-D, tensions >= 0)",
            f"tendon ends [m]: {ends}; offsets (d_x, d_z) [mm] ({how}): {offs}",
        ]
        if self.is_displacement:
            p = self.n_tendons_

            def fmt(vals, scale=1.0):
                return ", ".join(f"{scale * v:.{precision}g}" for v in vals)

            out += [
                "servo-wound elastic tendons: f_k = k_k max(0, r_k u_k pi/180 + l_k(q) - l_k(0) - s_k), u in deg",
                f"stiffness k [N/m] ({'given' if self.stiffness is not None else 'identified'}): "
                f"{fmt(self._stiffness())}; pulley radius r [mm]: {fmt(self.offsets_[2 * p : 3 * p], 1e3)}; "
                f"slack s [mm]: {fmt(self.offsets_[3 * p :], 1e3)}",
            ]
        return out
