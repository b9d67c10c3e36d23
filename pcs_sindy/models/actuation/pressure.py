"""The pressure kind: chambers spanning arc-length intervals on either side of the backbone.

A constant map (:class:`~pcs_sindy.models.actuation.constant.ConstantActuation`): each chamber
bends and stretches the segments its span covers, with a bending and an axial gain.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ...core.validation import Check, InvalidParameterError
from ._common import (
    ARC_LENGTHS,
    END,
    SIDE,
    check_inside,
    finite_vector,
    non_negative_vector,
    per_actuator,
    segment_cover,
)
from .constant import ConstantActuation

__all__ = ["PressureActuation"]


class PressureActuation(ConstantActuation):
    """Pressure chambers spanning arc-length intervals on either side of the backbone.

    Chamber k over ``[start_k, end_k]`` on side ``side_k`` exerts a bending
    moment ``side_k g^b_k p_k`` and an axial force ``g^a_k p_k`` along its span;
    by virtual work its columns are ``A[kappa_i, k] = side_k g^b_k c_ki`` and
    ``A[sigma_ax,i, k] = g^a_k c_ki`` with ``c_ki`` the span's overlap with segment i.

    Parameters
    ----------
    start, end : array_like, shape (p,)
        Arc lengths [m] of each chamber's ends.
    side : array_like of {-1, 1}, shape (p,)
        Side of the backbone (a chamber on side +1 bends towards positive curvature).
    bending_gain, axial_gain : array_like, shape (p,), optional
        Gains [m^3], [m^2] when known; default: identified (then the regression
        needs the robot's mass for its scale, see the module docstring).

    Notes
    -----
    Inputs are gauge pressures [Pa] of either sign.
    """

    kind = "pressure"
    _design_keys = ("start", "end", "side")
    _parameter_constraints: dict = {
        "start": [Check(non_negative_vector, f"{ARC_LENGTHS} >= 0 [m]")],
        "end": [END],
        "side": [SIDE],
        "bending_gain": [None, Check(finite_vector, "a non-empty 1-D array of finite gains [m^3]")],
        "axial_gain": [None, Check(finite_vector, "a non-empty 1-D array of finite gains [m^2]")],
    }

    def __init__(
        self,
        start: ArrayLike = (),
        end: ArrayLike = (),
        side: ArrayLike = (),
        bending_gain: ArrayLike | None = None,
        axial_gain: ArrayLike | None = None,
    ) -> None:
        self.start = start
        self.end = end
        self.side = side
        self.bending_gain = bending_gain
        self.axial_gain = axial_gain

    def _entries(self, kinematics):
        end = per_actuator(self, "end")
        p = end.size
        start = per_actuator(self, "start", p)
        side = per_actuator(self, "side", p)
        if np.any(start >= end):
            k = int(np.argmax(start >= end))
            want = f"below end, chamber by chamber (start[{k}] = {start[k]:g} >= end[{k}] = {end[k]:g})"
            raise InvalidParameterError.of(self, "start", want, self.start)
        lengths = np.asarray(kinematics.segment_lengths, dtype=float)
        total = float(lengths.sum())
        check_inside(start, "start", total, allow_zero=True)
        check_inside(end, "end", total, allow_zero=False)
        if (self.bending_gain is None) != (self.axial_gain is None):
            like = "None like bending_gain" if self.bending_gain is None else "given like bending_gain"
            want = f"{like} (give both gains, or neither: identified)"
            raise InvalidParameterError.of(self, "axial_gain", want, self.axial_gain)
        cover = segment_cover(start, np.minimum(end, total), lengths)  # (p, m)
        out = []
        for kind, row in (("b", 0), ("a", 2)):
            for k in range(p):
                unit = np.zeros((3 * lengths.size, p))
                unit[row::3, k] = cover[k] * (side[k] if kind == "b" else 1.0)
                out.append((f"g{kind}_{k + 1}", unit))
        return out, p

    def _given_gains(self, n_inputs):
        if self.bending_gain is None:
            return None
        gb = per_actuator(self, "bending_gain", n_inputs)
        ga = per_actuator(self, "axial_gain", n_inputs)
        return np.concatenate([gb, ga])

    def describe(self, precision: int = 3) -> list[str]:
        g = self.gains_
        p = self.n_inputs_
        how = "identified" if self.n_gains else "given"
        return [
            "A = const: A[be_i, k] = side_k gb_k c_ki, A[ax_i, k] = ga_k c_ki (pressure chambers)",
            f"gains ({how}): gb [m^3] = "
            + ", ".join(f"{v:.{precision}g}" for v in g[:p])
            + "; ga [m^2] = "
            + ", ".join(f"{v:.{precision}g}" for v in g[p:]),
        ]
