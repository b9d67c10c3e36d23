"""The learned kind: an input map of unknown layout, affine in the strains, every term a gain.

For mechanisms whose layout is not known (an unknown tendon routing, a servo's linkage):
``A(q) = B0 + sum_b B1_b q_b``, optionally also in the inputs' positive parts.
"""

from __future__ import annotations

from numbers import Integral
from typing import Any

import numpy as np

from ...core.kinematics import PlanarPCS
from ...core.validation import Check, Interval, Options
from .base import Actuation, gain_unit

__all__ = ["LearnedActuation"]

_LEARNED_TERMS = ("u", "u*q", "pull", "pull*q")
_LEARNED_STRAINS = ("bending", "all")


def _learned_terms(value: Any) -> bool:
    if isinstance(value, str):
        return False
    try:
        terms = list(value)
    except TypeError:
        return False
    return (
        bool(terms)
        and all(isinstance(t, str) and t in _LEARNED_TERMS for t in terms)
        and ("u" in terms or "pull" in terms)
        and ("u*q" not in terms or "u" in terms)
        and ("pull*q" not in terms or "pull" in terms)
    )


class LearnedActuation(Actuation):
    """An input map of unknown layout, linear in its parameters: ``A(q) = B0 + sum_b B1_b q_b``.

    For a mechanism whose layout is not known (an unknown tendon routing, a
    servo's linkage), every input ``u_k`` may act on every chosen strain's
    equation through a small basis:

        tau_a = sum_k (g_{a,k} + sum_b g_{a,k,b} q_b) u_k
              + sum_k (h_{a,k} + sum_b h_{a,k,b} q_b) max(0, u_k)

    (term ``"u"``: the constant part; term ``"u*q"``: the part proportional to
    the modelled bending strains ``q_b``, which set the moment arms and
    directions of tendons and linkages; ``"pull"`` and ``"pull*q"`` the same
    for the positive part of the input: a one-sided mechanism such as a
    servo winding a tendon, which pulls one way and goes slack the other).
    Every term vanishes with its input, so with the inputs off the map
    vanishes and the identified model stays passive (its own stiffness and
    damping, both non-negative, are all that acts).  The gains are identified
    with the Lagrangian, so the equations are homogeneous: give the robot's
    mass (``PhysicalPCSLibrary(mass=...)``).

    Parameters
    ----------
    terms : sequence of {"u", "u*q", "pull", "pull*q"}, default ("u", "u*q")
        The basis: ``"u"`` or ``"pull"`` is required, and a ``"*q"`` term needs its constant term.
    strains : {"bending", "all"}, default "bending"
        The equations the inputs act on: the modelled bending strains' (a
        tendon or a servo mostly bends a slender robot; fewer gains) or every
        modelled strain's (when the inputs also stretch or shear it).

    Attributes
    ----------
    gains_ : ndarray
        The identified gains, named by ``gain_names_`` (``a_<strain>_u<k>`` and
        ``a_<strain>_u<k>_<strain b>``).

    Notes
    -----
    Inputs are in the user's units (servo angles, pressures, ...), of either
    sign.  For a displacement drive with slack (a tendon that stops pulling)
    the affine map is the first-order picture; if the layout is known,
    :class:`TendonActuation` with ``drive="displacement"`` models the slack.
    """

    kind = "learned"
    compiled_forms = ("affine",)
    gain_lower_bound = -np.inf
    _parameter_constraints: dict = {
        "terms": [
            Check(
                _learned_terms,
                f"a non-empty sequence of terms from {_LEARNED_TERMS} with 'u' or 'pull' (and each '*q' term's own)",
            )
        ],
        "strains": [Options(_LEARNED_STRAINS)],
        "n_inputs": [Interval(Integral, 1, None, closed="left")],
    }
    depends_on_q = True
    spatial = True

    def __init__(self, n_inputs: int = 1, terms: Any = ("u", "u*q"), strains: str = "bending") -> None:
        self.n_inputs = n_inputs
        self.terms = terms
        self.strains = strains

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        p = int(self.n_inputs)
        names = kinematics.strain_names(active_only=True)
        n = len(names)
        mask = kinematics.active_mask
        per = kinematics.n_q // kinematics.n_segments  # 3 planar strains per segment, 6 spatial
        kinds = np.tile(np.arange(per), kinematics.n_segments)[mask]
        # bending: the planar kappa, or the spatial bend_z and bend_x
        bending = kinds == 0 if per == 3 else np.isin(kinds, (0, 1))
        rows = np.flatnonzero(bending) if self.strains == "bending" else np.arange(n)
        if not np.any(bending):
            raise ValueError(
                "LearnedActuation needs a modelled bending strain (its rows with strains='bending', its "
                f"'u*q' terms); the segmentation models {names}"
            )
        bends = np.flatnonzero(bending)
        terms = list(self.terms)
        index, gain_names = [], []
        for a in rows:
            for k in range(p):
                for part, (const, slope, label) in enumerate((("u", "u*q", "u"), ("pull", "pull*q", "pull"))):
                    if const not in terms:
                        continue
                    index.append((a, k, -1, part))
                    gain_names.append(f"a_{names[a]}_{label}{k + 1}")
                    if slope in terms:
                        for b in bends:
                            index.append((a, k, b, part))
                            gain_names.append(f"a_{names[a]}_{label}{k + 1}_{names[b]}")
        return {
            "n_inputs": p,
            "gain_names": gain_names,
            "gains": np.zeros(len(gain_names)),
            "offset_names": [],
            "offsets": np.zeros(0),
            "index": np.asarray(index, dtype=int).reshape(-1, 4),
            "n": n,
        }

    def parts(self, q, u, offsets=None):
        q = np.atleast_2d(np.asarray(q, dtype=float))
        u = np.atleast_2d(np.asarray(u, dtype=float))
        idx = self._arrays["index"]
        B, n = q.shape[0], self._arrays["n"]
        inputs = np.stack([u, np.maximum(u, 0.0)])  # (2, B, p): the inputs and their positive parts
        vals = inputs[idx[:, 3], :, idx[:, 1]].T  # (B, J)
        mult = idx[:, 2] >= 0
        vals[:, mult] *= q[:, idx[mult, 2]]
        linear = np.zeros((B, n, idx.shape[0]))
        linear[:, idx[:, 0], np.arange(idx.shape[0])] = vals
        return np.zeros((B, n)), linear

    @property
    def linear_in_inputs(self) -> bool:
        """False with ``"pull"`` terms (the positive part of an input is not linear in it)."""
        return "pull" not in list(self.terms)

    def compiled(self, gains=None, offsets=None) -> tuple:
        g = self._gains(gains)
        idx = self._arrays["index"]
        n, p = self._arrays["n"], self.n_inputs_
        block = p * (1 + n)
        amat = np.zeros((n, 2 * block))  # [B0 | B1] of the inputs, then of their positive parts
        for (a, k, b, part), gj in zip(idx, g, strict=True):
            col = k if b < 0 else p + k * n + b
            amat[a, part * block + col] += gj
        return "affine", np.zeros(0), np.zeros((0, self.kinematics_.n_segments)), amat

    def describe(self, precision: int = 3) -> list[str]:
        strains = self.kinematics_.strain_names(active_only=True)
        body = ", ".join(
            f"{nm} = {v:.{precision}g} {gain_unit(nm, strains)}"
            for nm, v in zip(self.gain_names_, self.gains_, strict=True)
        )
        return [
            "tau = sum_k (a_k + sum_b a_k,b q_b) u_k [+ the same in max(0, u_k)] (learned, zero with the inputs off)",
            f"gains (u: the input's own unit): {body}",
        ]

    def layout(self) -> dict[str, Any]:
        return {"type": self.kind, "n_inputs": int(self.n_inputs), "terms": list(self.terms), "strains": self.strains}

    def design_layout(self) -> dict[str, Any]:
        return self.layout()
