"""Ground-truth simulators, scenarios and synthetic videos.

This package is the independent truth the identification side is checked
against: it never imports the library, optimizer or regressor, and they never
import it.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "PCSRobot": "pcs_sindy.simulation.dynamics",
    "PACRobot": "pcs_sindy.simulation.pac",
    "Scenario": "pcs_sindy.simulation.scenarios",
    "ScenarioData": "pcs_sindy.simulation.scenarios",
    "Recording": "pcs_sindy.simulation.scenarios",
    "get_scenario": "pcs_sindy.simulation.catalog",
    "list_scenarios": "pcs_sindy.simulation.catalog",
    "render_video": "pcs_sindy.simulation.rendering",
    "render_frames": "pcs_sindy.simulation.rendering",
    "RenderedVideo": "pcs_sindy.simulation.rendering",
    "SimulationError": "pcs_sindy.integration",
    "TendonActuation": "pcs_sindy.simulation.actuation",
    "PressureActuation": "pcs_sindy.simulation.actuation",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pcs_sindy.simulation' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
