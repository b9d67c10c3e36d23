"""Model-based control with identified models (docs/control.md).

Controllers take an identified model (anything with ``forward_model()``, or a
:class:`~pcs_sindy.forward.ForwardModel`) and run at the control rate on the
model's strains:

* :class:`SetpointRegulator` — P-satI-D with the model's static forces as feed-forward;
* :class:`ComputedTorqueController` — tracking of strain or tip trajectories;
* :class:`TipRegulator` — equilibrium inputs for a tip target, then feedback, within input bounds.

:func:`closed_loop` runs one against the ground-truth simulator, observing
its state or its noisy marker poses at a camera rate; :mod:`.plots` draws the results.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "Controller": "pcs_sindy.control.base",
    "SetpointRegulator": "pcs_sindy.control.regulators",
    "TipRegulator": "pcs_sindy.control.regulators",
    "ComputedTorqueController": "pcs_sindy.control.tracking",
    "StrainReference": "pcs_sindy.control.tracking",
    "TipReference": "pcs_sindy.control.tracking",
    "tip_circle": "pcs_sindy.control.tracking",
    "closed_loop": "pcs_sindy.control.closed_loop",
    "ClosedLoopResult": "pcs_sindy.control.closed_loop",
    "equilibrium_inputs": "pcs_sindy.control.statics",
    "tip_inverse_kinematics": "pcs_sindy.control.statics",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pcs_sindy.control' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
