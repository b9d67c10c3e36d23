"""Actuators of the ground-truth robot: tendons and pressure chambers, ``τ = A(q) u``.

A robot driven by actuators obeys ``M q̈ + C q̇ + G + K q + D q̇ = A(q) u``
with ``u`` (p,) the actuator inputs (docs/method.md, "Actuation").  Both
layouts are given by arc length along the robot, independent of how the robot
is segmented, and are evaluated by :class:`~pcs_sindy.simulation.dynamics.PCSRobot`
(``PCSRobot(..., actuation=...)``).

**Tendons.**  Tendon k runs at the signed offset ``d_k`` from the backbone
along the cross-section axis ``R(θ) e_x``, from the base to its termination at
arc length ``s_k``.  Its path is the offset curve ``p(s) + d_k R(θ(s)) e_x``
whose tangent inside a constant-strain stretch is
``R(θ) [σ_sh, 1 + σ_ax + d κ]``: a constant length
``ν = √(σ_sh² + (1 + σ_ax + d κ)²)``.  The tendon's length is therefore
``ℓ_k(q) = Σ_i c_ki ν_ki`` with ``c_ki`` the rest length of segment i it
covers (a termination may lie inside a segment), exact at ``κ = 0``.  A
tension ``f_k ≥ 0`` does the virtual work ``−f_k δℓ_k``, so its column of
``A(q)`` is ``−∂ℓ_k/∂q``.  Tensions can only pull: negative inputs are
rejected.

**Servo-wound elastic tendons** (``Tendons(..., drive="displacement")``).  A
servo winds the tendon on a pulley of radius ``r``: at the angle ``φ`` [deg]
it has taken up ``r φ π/180`` of tendon.  The tendon runs from the pulley,
along a fixed path to the base, then along the body (length ``ℓ_k(q)``) to
its termination.  With ``L_n`` its natural (unstretched) length and ``c`` the
fixed path, the tendon is stretched by

    e_k = c + ℓ_k(q) − (L_n − r φ) = r φ π/180 + (ℓ_k(q) − ℓ_k(0)) − s_k,
    s_k = L_n − c − ℓ_k(0),

with ``s_k`` the slack of the straight robot at ``φ = 0`` (negative: a
pretension ``−k_k s_k``).  An elastic tendon of stiffness ``k_k`` [N/m]
carries ``f_k = k_k max(0, e_k)``: the servo's pull stretches it, the body's
bending towards it (``ℓ_k`` shrinks) gives some of it back, and it goes slack
(no force) when the body shortened the path by more than the servo took up.
The generalised forces are ``τ = −Σ_k ∂ℓ_k/∂q f_k`` as for tensions.  The
inputs are servo angles [deg] of either sign.

**Pressure chambers.**  Chamber j spans the arc lengths ``[a_j, b_j]`` on
the side ``σ_j = ±1`` of the backbone.  Its pressure ``p_j`` exerts a bending
moment ``σ_j g^b_j p_j`` and an axial force ``g^a_j p_j`` along the span
(``g^b = area × centroid offset``, ``g^a = area`` for a chamber of that
cross-section).  Their virtual work ``∫_a^b (σ g^b p δκ + g^a p δσ_ax) ds``
with piecewise constant strains gives the constant columns
``A[κ_i, j] = σ_j g^b_j c_ji`` and ``A[σ_ax,i, j] = g^a_j c_ji`` with
``c_ji`` the overlap of the span with segment i.  Pressures are gauge
pressures and may be negative (vacuum).

This module belongs to the simulator (the independent truth); the
identification side has its own actuation terms.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._kernels import ACT_CONSTANT, ACT_SERVO, ACT_TENDON

__all__ = ["Tendons", "PressureChambers"]


def _vector(value: ArrayLike, name: str, size: int | None = None) -> NDArray[np.float64]:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1 or arr.size == 0 or (size is not None and arr.size != size):
        want = f"({size},)" if size is not None else "(p,) with p >= 1"
        raise ValueError(f"{name} must have shape {want}; got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite; got {arr.tolist()}")
    return arr


def _within_robot(value: NDArray, name: str, total: float, *, allow_zero: bool) -> None:
    bad = (value < 0) | (value > total * (1 + 1e-12)) | ((value == 0) & (not allow_zero))
    if np.any(bad):
        k = int(np.argmax(bad))
        lower = "0 <=" if allow_zero else "0 <"
        raise ValueError(
            f"{name}[{k}] = {float(value[k])!r} lies outside the robot: need {lower} {name} <= "
            f"{total:g} m (the total rest length)"
        )


def _cover(start: NDArray, end: NDArray, segment_lengths: NDArray) -> NDArray[np.float64]:
    """Rest length (p, m) of segment i inside the arc-length interval ``[start_k, end_k]``."""
    bounds = np.concatenate([[0.0], np.cumsum(segment_lengths)])
    lo = np.maximum(start[:, None], bounds[None, :-1])
    hi = np.minimum(end[:, None], bounds[None, 1:])
    return np.maximum(hi - lo, 0.0)


class Tendons:
    """Tendons from the base to termination arc lengths at signed offsets from the backbone.

    Parameters
    ----------
    end : array_like, shape (p,)
        Arc length [m] where each tendon terminates, in ``(0, total length]``.
    offset : array_like, shape (p,)
        Signed distance [m] of each tendon from the backbone along the
        cross-section axis ``R(θ) e_x``; a tendon at positive offset bends the
        robot towards negative curvature.
    drive : {"tension", "displacement"}, default "tension"
        What the inputs are.  ``"tension"``: tendon tensions [N], ``>= 0``.
        ``"displacement"``: servo angles [deg] winding elastic tendons (the
        module docstring derives the tensions
        ``f_k = k_k max(0, r_k φ_k π/180 + ℓ_k(q) − ℓ_k(0) − s_k)``).
    stiffness : array_like, shape (p,), optional
        Tendon stiffness ``k`` [N/m] > 0 (``drive="displacement"`` only, required there).
    pulley_radius : array_like, shape (p,), optional
        Servo pulley radius ``r`` [m] > 0 (``drive="displacement"`` only, required there).
    slack : array_like, shape (p,) or float, default 0.0
        Slack ``s`` [m] of each tendon with the robot straight and the servo at
        0 deg; negative for a pretensioned tendon (``drive="displacement"`` only).

    Notes
    -----
    See the module docstring for the closed form of the lengths and the
    displacement drive.  :meth:`tensions` gives the tendon forces of either drive.
    """

    kind = "tendon"

    def __init__(
        self,
        end: ArrayLike,
        offset: ArrayLike,
        drive: str = "tension",
        stiffness: ArrayLike | None = None,
        pulley_radius: ArrayLike | None = None,
        slack: ArrayLike = 0.0,
    ) -> None:
        self.end = end
        self.offset = offset
        self.drive = drive
        self.stiffness = stiffness
        self.pulley_radius = pulley_radius
        self.slack = slack

    @property
    def n_inputs(self) -> int:
        return int(np.atleast_1d(np.asarray(self.end)).size)

    def _drive_parameters(self, p: int) -> NDArray[np.float64]:
        """Rows ``[k, r, s]`` (3, p) of the displacement drive, validated."""
        if self.drive not in ("tension", "displacement"):
            raise ValueError(f"drive must be 'tension' or 'displacement'; got {self.drive!r}")
        if self.drive == "tension":
            return np.zeros((3, 0))
        for name in ("stiffness", "pulley_radius"):
            if getattr(self, name) is None:
                raise ValueError(f"{name} is required with drive='displacement' (one value per tendon, > 0)")
        k = _vector(np.broadcast_to(np.asarray(self.stiffness, dtype=float), (p,)), "stiffness", p)
        r = _vector(np.broadcast_to(np.asarray(self.pulley_radius, dtype=float), (p,)), "pulley_radius", p)
        s = _vector(np.broadcast_to(np.asarray(self.slack, dtype=float), (p,)), "slack", p)
        for name, arr in (("stiffness", k), ("pulley_radius", r)):
            if np.any(arr <= 0):
                raise ValueError(f"{name} must be > 0 per tendon; got {arr.tolist()}")
        return np.stack([k, r, s])

    def layout(self) -> dict[str, Any]:
        """What a user knows from the design: terminations and sides (signs of the offsets), JSON-able.

        A displacement drive adds ``"drive": "displacement"`` (its stiffness, radius and slack are
        what the identification estimates, not part of the layout).
        """
        end = _vector(self.end, "end")
        offset = _vector(self.offset, "offset", end.size)
        out: dict[str, Any] = {"type": "tendon", "end": end.tolist(), "side": np.sign(offset).astype(int).tolist()}
        if self.drive == "displacement":
            out["drive"] = "displacement"
        return out

    def encode(self, segment_lengths: Sequence[float]) -> tuple[int, NDArray, NDArray, NDArray]:
        """Validated arrays for the compiled kernels: ``(kind, offset (p,), span (p, m), matrix)``.

        ``matrix`` is (n, 0) for tensions and the rows ``[k, r, s]`` (3, p) of a displacement drive.
        """
        lengths = np.asarray(segment_lengths, dtype=float)
        end = _vector(self.end, "end")
        offset = _vector(self.offset, "offset", end.size)
        _within_robot(end, "end", float(lengths.sum()), allow_zero=False)
        span = _cover(np.zeros_like(end), end, lengths)
        drive = self._drive_parameters(end.size)
        if self.drive == "displacement":
            return ACT_SERVO, offset, span, drive
        return ACT_TENDON, offset, span, np.zeros((3 * lengths.size, 0))

    def tensions(self, lengths: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Tendon tensions [N] (..., p) at tendon lengths ``lengths`` (..., p) under inputs ``u`` (..., p).

        ``u`` itself for ``drive="tension"``; ``k max(0, r u π/180 + lengths − end − s)`` for a
        displacement drive (``end`` is the length of the straight robot's tendon).
        """
        u = np.asarray(u, dtype=float)
        if self.drive != "displacement":
            return u.copy()
        end = _vector(self.end, "end")
        k, r, s = self._drive_parameters(end.size)
        stretch = r * u * (np.pi / 180.0) + np.asarray(lengths, dtype=float) - end - s
        return k * np.maximum(stretch, 0.0)

    def check_inputs(self, u: NDArray, t: NDArray | float | None, name: str = "u") -> None:
        """Raise a ValueError naming the first negative tension, its input index and time.

        ``t`` holds the time stamps of the rows of ``u`` (first axis), the time
        of a single input, or None when there is no time to name.  Servo angles
        (``drive="displacement"``) may take either sign.
        """
        if self.drive == "displacement" or np.all(u >= 0):
            return
        idx = np.argwhere(u < 0)[0]
        where = f"{name}[{', '.join(str(int(i)) for i in idx)}]"
        when = "" if t is None else f" at t = {float(t if np.ndim(t) == 0 else t[idx[0]]):g} s"
        k = int(idx[-1])
        raise ValueError(
            f"{where} = {float(u[tuple(idx)])!r}{when}: tendon {k} (ending at "
            f"{float(np.atleast_1d(self.end)[k]):g} m) would push; tendon tensions must be >= 0"
        )

    def __repr__(self) -> str:
        extra = ""
        if self.drive != "tension":
            extra = (
                f", drive={self.drive!r}, stiffness={self.stiffness!r}, "
                f"pulley_radius={self.pulley_radius!r}, slack={self.slack!r}"
            )
        return f"Tendons(end={self.end!r}, offset={self.offset!r}{extra})"


class PressureChambers:
    """Pressure chambers spanning arc-length intervals on either side of the backbone.

    Parameters
    ----------
    start, end : array_like, shape (p,)
        Arc lengths [m] of each chamber's ends, ``0 <= start < end <= total length``.
    side : array_like of {-1, 1}, shape (p,)
        Side of the backbone (sign along ``R(θ) e_x``); a chamber on side +1
        bends the robot towards positive curvature.
    bending_gain : array_like, shape (p,)
        ``g^b > 0`` [m³]: bending moment per unit pressure (chamber area times
        the offset of its centroid).
    axial_gain : array_like, shape (p,)
        ``g^a >= 0`` [m²]: axial force per unit pressure (chamber area).

    Notes
    -----
    Inputs are gauge pressures [Pa].  See the module docstring for the
    generalised forces.
    """

    kind = "pressure"

    def __init__(
        self, start: ArrayLike, end: ArrayLike, side: ArrayLike, bending_gain: ArrayLike, axial_gain: ArrayLike
    ) -> None:
        self.start = start
        self.end = end
        self.side = side
        self.bending_gain = bending_gain
        self.axial_gain = axial_gain

    @property
    def n_inputs(self) -> int:
        return int(np.atleast_1d(np.asarray(self.end)).size)

    def _validated(self) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        end = _vector(self.end, "end")
        p = end.size
        start = _vector(self.start, "start", p)
        side = _vector(self.side, "side", p)
        if np.any(np.abs(side) != 1):
            raise ValueError(f"side must hold -1 or 1 per chamber; got {side.tolist()}")
        gb = _vector(self.bending_gain, "bending_gain", p)
        ga = _vector(self.axial_gain, "axial_gain", p)
        if np.any(gb <= 0):
            raise ValueError(f"bending_gain must be > 0; got {gb.tolist()}")
        if np.any(ga < 0):
            raise ValueError(f"axial_gain must be >= 0; got {ga.tolist()}")
        if np.any(start >= end):
            k = int(np.argmax(start >= end))
            raise ValueError(f"start[{k}] = {float(start[k])!r} must be < end[{k}] = {float(end[k])!r}")
        return start, end, side, gb, ga

    def layout(self) -> dict[str, Any]:
        """What a user knows from the design: spans and sides, JSON-able (not the gains)."""
        start, end, side, _, _ = self._validated()
        return {"type": "pressure", "start": start.tolist(), "end": end.tolist(), "side": side.astype(int).tolist()}

    def encode(self, segment_lengths: Sequence[float]) -> tuple[int, NDArray, NDArray, NDArray]:
        """Validated arrays for the compiled kernels: ``(kind, offset (0,), span (0, m), matrix (n, p))``."""
        lengths = np.asarray(segment_lengths, dtype=float)
        start, end, side, gb, ga = self._validated()
        total = float(lengths.sum())
        _within_robot(start, "start", total, allow_zero=True)
        _within_robot(end, "end", total, allow_zero=False)
        cover = _cover(start, end, lengths)  # (p, m)
        m, p = lengths.size, end.size
        matrix = np.zeros((3 * m, p))
        matrix[0::3] = (side * gb)[None, :] * cover.T
        matrix[2::3] = ga[None, :] * cover.T
        return ACT_CONSTANT, np.zeros(0), np.zeros((0, m)), matrix

    def check_inputs(self, u: NDArray, t: NDArray | float | None, name: str = "u") -> None:
        """Pressures may take either sign (gauge pressure): nothing to check beyond finiteness."""

    def __repr__(self) -> str:
        return (
            f"PressureChambers(start={self.start!r}, end={self.end!r}, side={self.side!r}, "
            f"bending_gain={self.bending_gain!r}, axial_gain={self.axial_gain!r})"
        )
