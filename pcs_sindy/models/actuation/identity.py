"""The identity kind: the inputs are the generalised forces themselves (``A = I``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.kinematics import PlanarPCS
from .base import Actuation

__all__ = ["IdentityActuation"]


class IdentityActuation(Actuation):
    """The inputs are the generalised forces themselves: ``u`` (T, 3m), ``A = I``."""

    kind = "identity"
    compiled_forms = ("forces",)
    is_identity = True
    spatial = True
    _parameter_constraints: dict = {}  # no parameters

    def _structure(self, kinematics: PlanarPCS) -> dict[str, Any]:
        return {
            "n_inputs": kinematics.n_q,
            "gain_names": [],
            "offset_names": [],
            "gains": np.zeros(0),
            "offsets": np.zeros(0),
        }

    def parts(self, q, u, offsets=None):
        mask = self.kinematics_.active_mask
        return np.asarray(u, dtype=float)[:, mask], np.zeros((u.shape[0], int(mask.sum()), 0))

    def compiled(self, gains=None, offsets=None) -> tuple:
        m = self.kinematics_.n_segments
        return "forces", np.zeros(0), np.zeros((0, m)), np.zeros((self.kinematics_.n_active, 0))

    def describe(self, precision: int = 3) -> list[str]:
        return ["A = I (inputs are the generalised forces)"]
