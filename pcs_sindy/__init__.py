"""pcs_sindy: videos of a planar continuum soft robot to a Piecewise Constant Strain model.

The public entry points are importable from the package root;
they are loaded lazily so that importing the package stays cheap and a
missing optional piece does not break the others.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_LAZY = {
    "PlanarPCS": "pcs_sindy.kinematics",
    "PoseTrajectory": "pcs_sindy.trajectory",
    "StrainTrajectory": "pcs_sindy.trajectory",
    "MarkerPoseExtractor": "pcs_sindy.vision",
    "KinematicFusion": "pcs_sindy.segmentation",
    "PCSLagrangianLibrary": "pcs_sindy.library",
    "PhysicalPCSLibrary": "pcs_sindy.library",
    "Camera": "pcs_sindy.camera",
    "StiffnessThresholdOptimizer": "pcs_sindy.optimizers",
    "EulerLagrangeRegressor": "pcs_sindy.regressor",
    "make_pcs_pipeline": "pcs_sindy.pipeline",
    "save": "pcs_sindy.persistence",
    "load": "pcs_sindy.persistence",
    "PCSPipeline": "pcs_sindy.pipeline",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pcs_sindy' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
