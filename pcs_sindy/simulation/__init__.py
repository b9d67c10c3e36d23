"""Ground-truth simulators, scenarios and synthetic videos.

Takes in robot parameters (or a scenario name, :func:`get_scenario`) and gives what a lab
would record: strains and rates, marker poses (noisy on request), the forces or actuator
inputs that drove the robot, and rendered videos of it.

* :mod:`.dynamics` - :class:`PCSRobot`: the PCS dynamics, integrated by its own stiff solver;
* :mod:`.spatial_dynamics` - :class:`SpatialPCSRobot`: the spatial (3-D) PCS dynamics, six strains per
  segment, integrated by the same solvers, and its :class:`SpatialTendons`;
* :mod:`.actuation` - the robot's actuators: :class:`Tendons` (tensions or servo-wound),
  :class:`PressureChambers`;
* :mod:`.pac` - :class:`PACRobot`, kinematics only (curvature affine in arc length);
* :mod:`.scenarios`, :mod:`.catalog` - the seed's scenarios and how their data are generated;
* :mod:`.mocap` - :class:`MocapScenario`: a hanging tendon robot tracked by 3 position-only markers;
* :mod:`.rendering`, :mod:`.nuisances`, :mod:`.checkerboard` - synthetic footage with realistic nuisances;
* :mod:`.foreign` - footage of the kinds another lab records (curled first frames, outlined markers,
  floors, bright edges) as large JPEG folders.

This package is the independent truth the identification side is checked against: it
imports only :mod:`pcs_sindy.core`, and identification, fusion and vision never import it.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "dynamics": ["PCSRobot", "SimulationError"],
        "spatial_dynamics": ["SpatialPCSRobot", "SpatialTendons"],
        "pac": ["PACRobot"],
        "scenarios": ["Scenario", "ScenarioData", "Recording"],
        "catalog": ["get_scenario", "list_scenarios", "describe_scenarios"],
        "rendering": ["render_video", "render_frames", "RenderedVideo"],
        "foreign": ["render_foreign_footage", "ForeignFootage", "FOREIGN_KINDS"],
        "actuation": ["Tendons", "PressureChambers"],
        "mocap": ["MocapScenario", "MocapRecording", "play_operator"],
    },
)
