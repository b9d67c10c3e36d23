"""Ground-truth simulators, scenarios and synthetic videos.

This package is the independent truth the identification side is checked
against: it never imports the library, optimizer or regressor, and they never
import it.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "dynamics": ["PCSRobot", "SimulationError"],
        "pac": ["PACRobot"],
        "scenarios": ["Scenario", "ScenarioData", "Recording"],
        "catalog": ["get_scenario", "list_scenarios"],
        "rendering": ["render_video", "render_frames", "RenderedVideo"],
        "actuation": ["Tendons", "PressureChambers"],
    },
)
