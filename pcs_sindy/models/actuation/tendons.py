"""The tendon kind: tendons from the base to termination arc lengths, pulled by tensions or wound by servos.

``A(q) = -dl/dq`` of the tendon lengths ``l_k(q)`` (closed form per constant-strain
segment); the offsets from the backbone (and, for servo drives, pulley radii and
slacks) enter nonlinearly and are identified by variable projection.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...core.kinematics import PlanarPCS
from ...core.validation import Check, InvalidParameterError
from ._common import (
    END,
    SIDE,
    TENDON_DRIVE_CONSTRAINTS,
    TendonDrive,
    check_inside,
    per_actuator,
    positive_vector,
    segment_cover,
)
from .base import Actuation

__all__ = ["TendonActuation"]


class TendonActuation(TendonDrive, Actuation):
    """Tendons from the base to termination arc lengths, at offsets along the cross-section axis.

    Tendon k runs at the signed offset ``d_k`` from the backbone along
    ``R(theta) e_x`` from the base to arc length ``end_k``.  Inside a
    constant-strain stretch the offset curve's tangent has the constant length
    ``nu = sqrt(sigma_sh^2 + (1 + sigma_ax + d kappa)^2)``, so
    ``l_k = sum_i c_ki nu_ki`` with ``c_ki`` the rest length of segment i the
    tendon covers, and its column of ``A`` is ``-dl_k/dq`` (a tension pulls).

    Parameters
    ----------
    end : array_like, shape (p,)
        Termination arc lengths [m], in ``(0, total rest length]``.
    side : array_like of {-1, 1}, shape (p,)
        Sign of each offset (the side of the backbone the tendon runs on).
    offset : array_like, shape (p,), optional
        Offset magnitudes [m] when known; default: identified (variable
        projection, within ``(0, max_offset]``).
    max_offset : float, default 0.05
        Upper bound [m] of identified offsets.
    shared : bool, default False
        Identify one offset magnitude for all tendons (tendons routed at one
        radius).  From the seed's pose noise both are determined to a few
        tenths of a percent (docs/results.md, "Identification from actuator
        inputs"); the regressor's ``identifiability_report()`` gives each
        offset's standard error and says when the recordings do not
        determine them, when one shared offset is the remedy.
    weighting : {"residual", "none"}, default "residual"
        How the equations of the strains are weighted when the offsets are
        identified.  ``"residual"``: each by the inverse RMS of its own
        residual, iterated (feasible generalised least squares; measured best
        when the model has the robot's segments, where the residual is
        noise).  ``"none"``: plain least squares over all equations.  When
        the model is coarser than the robot (a continuum, a stiffness that
        varies along a segment) the residual is the model's own error and
        neither rule is right in general: choose by rollout score, e.g.
        ``GridSearchCV(..., scoring=rollout_r2_scorer)`` over ``actuation__weighting``
        (docs/method.md, "Actuation").
    drive : {"tension", "displacement"}, default "tension"
        What the inputs are.  ``"tension"``: tendon tensions [N].
        ``"displacement"``: servo angles [deg] winding elastic tendons on
        pulleys: the tendon is stretched by
        ``e_k = r_k u_k pi/180 + l_k(q) - l_k(0) - s_k`` (the servo takes up
        ``r u``, the body's shortening gives back ``l(0) - l(q)``) and pulls
        with ``f_k = k_k max(0, e_k)`` (slack: no force).
    stiffness : array_like, shape (p,), optional
        Tendon stiffness ``k`` [N/m] when known (displacement drive only);
        default: identified with the Lagrangian (linear gains ``k_<k>``; the
        regression then needs the robot's mass for its scale).
    pulley_radius : array_like, shape (p,), optional
        Pulley radius ``r`` [m] when known (displacement drive only); default:
        identified (variable projection, within ``(0, max_radius]``).
    slack : array_like, shape (p,), optional
        Slack ``s`` [m] of the straight robot at ``u = 0`` when known (negative:
        pretension ``-k s``; displacement drive only); default: identified
        (variable projection, within ``[-max_slack, max_slack]``).
    max_radius : float, default 0.05
        Upper bound [m] of identified pulley radii.
    max_slack : float, default 0.05
        Bound [m] of identified slacks.

    Attributes
    ----------
    offsets_ : ndarray, shape (p,) or (3p,)
        Signed offsets used (given, or identified by the regressor); for a
        displacement drive followed by the pulley radii and the slacks.
    gains_ : ndarray
        Displacement drive: the identified tendon stiffnesses (or the given ones).

    Notes
    -----
    Tension inputs are tensions [N], ``>= 0``; a negative tension raises.
    Servo angles may take either sign.  :meth:`tensions` gives the tendon
    forces of either drive.
    """

    kind = "tendon"
    compiled_forms = ("tendon", "servo")
    _design_keys = ("end", "side")
    _parameter_constraints: dict = {
        "end": [END],
        "side": [SIDE],
        "offset": [None, Check(positive_vector, "a non-empty 1-D array of finite magnitudes > 0 [m]")],
        **TENDON_DRIVE_CONSTRAINTS,
    }

    depends_on_q = True

    def __init__(
        self,
        end: ArrayLike = (),
        side: ArrayLike = (),
        offset: ArrayLike | None = None,
        max_offset: float = 0.05,
        shared: bool = False,
        weighting: str = "residual",
        drive: str = "tension",
        stiffness: ArrayLike | None = None,
        pulley_radius: ArrayLike | None = None,
        slack: ArrayLike | None = None,
        max_radius: float = 0.05,
        max_slack: float = 0.05,
    ) -> None:
        self.end = end
        self.side = side
        self.offset = offset
        self.max_offset = max_offset
        self.shared = shared
        self.weighting = weighting
        self.drive = drive
        self.stiffness = stiffness
        self.pulley_radius = pulley_radius
        self.slack = slack
        self.max_radius = max_radius
        self.max_slack = max_slack

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        end = per_actuator(self, "end")
        p = end.size
        side = per_actuator(self, "side", p)
        lengths = np.asarray(kinematics.segment_lengths, dtype=float)
        total = float(lengths.sum())
        check_inside(end, "end", total, allow_zero=False)
        if not self.is_displacement:
            for name in ("stiffness", "pulley_radius", "slack"):
                if getattr(self, name) is not None:
                    raise InvalidParameterError.of(
                        self, name, "None with drive='tension' (a displacement-drive parameter)", getattr(self, name)
                    )
        cover = segment_cover(np.zeros(p), np.minimum(end, total), lengths)
        out = {"cover": cover, "side": side, "n_inputs": p, "gain_names": [], "gains": np.zeros(0)}
        # nonlinear parameters: offset magnitudes, then (displacement drive) pulley radii and slacks
        free: list[NDArray[np.bool_]] = []
        names: list[str] = []
        if self.offset is None:
            names += ["d"] if self.shared else [f"d_{k + 1}" for k in range(p)]
            d = side * min(0.01, 0.5 * self.max_offset)
            free.append(np.ones(1 if self.shared else p, dtype=bool))
        else:
            d = side * per_actuator(self, "offset", p)
        full = [d]
        if self.is_displacement:
            for name, start, label in (
                ("pulley_radius", min(0.01, 0.5 * self.max_radius), "r"),
                ("slack", 0.0, "s"),
            ):
                if getattr(self, name) is None:
                    names += [f"{label}_{k + 1}" for k in range(p)]
                    full.append(np.full(p, start))
                else:
                    full.append(per_actuator(self, name, p))
            if self.stiffness is None:
                out.update(gain_names=[f"k_{k + 1}" for k in range(p)], gains=np.zeros(p))
            else:
                out.update(gains=per_actuator(self, "stiffness", p))
            out["rest"] = cover.sum(axis=1)  # l_k(0): unit tangents when straight
        out.update(offset_names=names, offsets=np.concatenate(full))
        return out

    def _free(self) -> list[tuple[slice, slice]]:
        """Pairs (slice of the parameter vector, slice of ``offsets_``) of the free nonlinear parameters."""
        p = self.n_inputs_
        pairs, k = [], 0
        if self.offset is None:
            n_d = 1 if self.shared else p
            pairs.append((slice(k, k + n_d), slice(0, p)))
            k += n_d
        if self.is_displacement:
            for j, name in ((1, "pulley_radius"), (2, "slack")):
                if getattr(self, name) is None:
                    pairs.append((slice(k, k + p), slice(j * p, (j + 1) * p)))
                    k += p
        return pairs

    def offset_bounds(self):
        lo, hi = [], []
        p = self.n_inputs_
        for par, full in self._free():
            size = par.stop - par.start
            if full.start == 0:
                lo.append(np.full(size, 1e-4 * self.max_offset))
                hi.append(np.full(size, float(self.max_offset)))
            elif full.start == p:
                lo.append(np.full(size, 1e-4 * self.max_radius))
                hi.append(np.full(size, float(self.max_radius)))
            else:
                lo.append(np.full(size, -float(self.max_slack)))
                hi.append(np.full(size, float(self.max_slack)))
        return (np.concatenate(lo), np.concatenate(hi)) if lo else (np.zeros(0), np.zeros(0))

    def offset_floor(self) -> NDArray[np.float64]:
        """Magnitudes that the relative standard errors of the nonlinear parameters never divide below.

        A slack may be identified at 0: its error is reported relative to 1 mm.
        """
        out = []
        p = self.n_inputs_
        for par, full in self._free():
            out.append(np.full(par.stop - par.start, 1e-3 if full.start == 2 * p else 0.0))
        return np.concatenate(out) if out else np.zeros(0)

    def initial_offsets(self):
        out = []
        for par, full in self._free():
            vals = self.offsets_[full]
            if full.start == 0:
                vals = np.abs(vals[: par.stop - par.start])
            out.append(vals)
        return np.concatenate(out) if out else np.zeros(0)

    def signed_offsets(self, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """The map's nonlinear parameters for the free ones ``offsets`` (default: the fitted ``offsets_``).

        The signed offsets (p,) (sides times the magnitudes); for a displacement drive
        followed by the pulley radii and slacks (3p,).
        """
        if offsets is None or self.n_offsets == 0:
            return self.offsets_
        x = np.asarray(offsets, dtype=float)
        out = self.offsets_.copy()
        side = self._arrays["side"]
        for par, full in self._free():
            if full.start == 0:
                out[full] = side * x[par]  # one shared magnitude broadcasts
            else:
                out[full] = x[par]
        return out

    def lengths(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Tendon lengths (B, p) at modelled strains ``q`` (B, n)."""
        qf = self.kinematics_.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets)[: self.n_inputs_]
        kap, sh, ax = qf[:, 0::3], qf[:, 1::3], qf[:, 2::3]
        w = 1.0 + ax[:, None, :] + d[None, :, None] * kap[:, None, :]
        return np.sum(self._arrays["cover"][None] * np.sqrt(sh[:, None, :] ** 2 + w**2), axis=-1)

    def jacobian(self, q: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """``dl/dq`` (B, p, n) on the modelled strains."""
        kin = self.kinematics_
        qf = kin.to_full(np.atleast_2d(np.asarray(q, dtype=float)))
        d = self.signed_offsets(offsets)[: self.n_inputs_]
        B, m = qf.shape[0], kin.n_segments
        kap, sh, ax = qf[:, 0::3], qf[:, 1::3], qf[:, 2::3]
        w = 1.0 + ax[:, None, :] + d[None, :, None] * kap[:, None, :]  # (B, p, m)
        nu = np.sqrt(sh[:, None, :] ** 2 + w**2)
        c = self._arrays["cover"][None]
        jac = np.zeros((B, self.n_inputs_, m, 3))
        jac[..., 0] = c * d[None, :, None] * w / nu
        jac[..., 1] = c * sh[:, None, :] / nu
        jac[..., 2] = c * w / nu
        return jac.reshape(B, self.n_inputs_, 3 * m)[:, :, kin.active_mask]

    def stretch(self, q: ArrayLike, u: ArrayLike, offsets: ArrayLike | None = None) -> NDArray[np.float64]:
        """Displacement drive: the tendons' stretch ``r u pi/180 + l(q) - l(0) - s`` [m] (B, p), negative when slack."""
        if not self.is_displacement:
            raise ValueError("stretch needs drive='displacement' (the inputs of this TendonActuation are tensions)")
        full = self.signed_offsets(None if offsets is None else np.asarray(offsets, dtype=float))
        p = self.n_inputs_
        r, s = full[p : 2 * p], full[2 * p : 3 * p]
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return r * np.deg2rad(u) + self.lengths(q, offsets) - self._arrays["rest"] - s

    def parts(self, q, u, offsets=None):
        jac = self.jacobian(q, offsets)
        u = np.asarray(u, dtype=float)
        if not self.is_displacement:
            known = -np.einsum("bkn,bk->bn", jac, u)
            return known, np.zeros(known.shape + (0,))
        taut = np.maximum(self.stretch(q, u, offsets), 0.0)  # (B, p)
        per_unit = -jac * taut[:, :, None]  # (B, p, n): forces per unit stiffness
        if self.stiffness is None:
            return np.zeros((jac.shape[0], jac.shape[2])), np.transpose(per_unit, (0, 2, 1))
        k = per_actuator(self, "stiffness", self.n_inputs_)
        known = np.einsum("bkn,k->bn", per_unit, k)
        return known, np.zeros(known.shape + (0,))

    def forces(self, q, u, gains=None, offsets=None):
        """Generalised forces ``-dl/dq^T f`` (B, n) of the tensions ``f`` (:meth:`tensions`)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if not self.is_displacement:
            return super().forces(q, u, gains, offsets)
        jac = self.jacobian(q, None if offsets is None else np.asarray(offsets, float))
        return -np.einsum("bkn,bk->bn", jac, self.tensions(q, u, gains, offsets))

    def matrix(self, q: ArrayLike, gains: ArrayLike | None = None, offsets: ArrayLike | None = None) -> NDArray:
        """``A(q)`` (B, n, p): ``-dl/dq``, the forces of unit *tensions* (also for a displacement drive)."""
        if not self.is_displacement:
            return super().matrix(q, gains, offsets)
        jac = self.jacobian(q, None if offsets is None else np.asarray(offsets, float))
        return -np.transpose(jac, (0, 2, 1))

    def compiled(self, gains=None, offsets=None) -> tuple:
        full = self.signed_offsets(offsets)
        p = self.n_inputs_
        if self.is_displacement:
            drive = np.stack([self._stiffness(gains), full[p : 2 * p], full[2 * p : 3 * p]])
            return "servo", full[:p].copy(), self._arrays["cover"].copy(), drive
        return (
            "tendon",
            full[:p].copy(),
            self._arrays["cover"].copy(),
            np.zeros((self.kinematics_.n_active, 0)),
        )

    def design_layout(self) -> dict[str, Any]:
        out = super().design_layout()
        if self.is_displacement:
            out["drive"] = "displacement"
        return out

    def describe(self, precision: int = 3) -> list[str]:
        ends = ", ".join(f"{e:.{precision}g}" for e in np.atleast_1d(np.asarray(self.end, dtype=float)))
        p = self.n_inputs_
        offs = ", ".join(f"{1e3 * d:.{precision}g}" for d in self.offsets_[:p])
        how = "identified" if self.offset is None else "given"
        out = [
            "A(q) = -dl/dq, l_k = sum_i c_ki sqrt(sh_i^2 + (1 + ax_i + d_k be_i)^2) (tendons, tensions >= 0)",
            f"tendon ends [m]: {ends}; offsets d [mm] ({how}): {offs}",
        ]
        if self.is_displacement:

            def fmt(vals, scale=1.0):
                return ", ".join(f"{scale * v:.{precision}g}" for v in vals)

            k = self._stiffness()
            out += [
                "servo-wound elastic tendons: f_k = k_k max(0, r_k u_k pi/180 + l_k(q) - l_k(0) - s_k), u in deg",
                f"stiffness k [N/m] ({'given' if self.stiffness is not None else 'identified'}): {fmt(k)}; "
                f"pulley radius r [mm]: {fmt(self.offsets_[p : 2 * p], 1e3)}; "
                f"slack s [mm]: {fmt(self.offsets_[2 * p :], 1e3)}",
            ]
        return out
