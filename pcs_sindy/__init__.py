"""pcs_sindy: videos of a planar continuum soft robot to a Piecewise Constant Strain model.

The package is laid out like the pipeline, one subpackage per stage::

    core            kinematics, trajectories, metrics, camera model, the simulate contract
    vision          frames -> marker poses
    fusion          marker poses -> segments and strains
    identification  strains + inputs -> Lagrangian coefficients (regressor, libraries, optimizers)
    models          coefficients -> forward models, actuation maps, rollouts
    control         identified models -> controllers and closed loops
    pipeline        the stages composed into one scikit-learn Pipeline

and beside them ``simulation`` (the ground truth, independent of identification), ``io``
(model and data files), ``cli`` (the ``pcs-sindy`` command) and ``plotting``.

The public entry points are importable from here; they, and the subpackages, are loaded
lazily so that importing the package stays cheap.
"""

from . import _version
from .core import saving as _saving

__version__ = _version.__version__


def _save(obj, path):
    from .io.model_files import save

    return save(obj, path)


def _load(path, **kwargs):
    from .io.model_files import load

    return load(path, **kwargs)


# The estimators' save/load methods live on the ground floor and reach the file formats,
# which sit on top of every stage, through these two functions.
_saving.register_file_format(_save, _load)

import lazy_loader as _lazy  # noqa: E402

__getattr__, __dir__, _names = _lazy.attach(
    __name__,
    submodules=[
        "core",
        "vision",
        "fusion",
        "identification",
        "models",
        "control",
        "pipeline",
        "simulation",
        "io",
        "plotting",
    ],
    submod_attrs={
        "core": ["PlanarPCS", "PoseTrajectory", "StrainTrajectory", "Camera", "SimulationError"],
        "vision": ["MarkerPoseExtractor"],
        "fusion": ["KinematicFusion"],
        "identification": [
            "EulerLagrangeRegressor",
            "StiffnessThresholdOptimizer",
            "PCSLagrangianLibrary",
            "PhysicalPCSLibrary",
        ],
        "models": ["TendonActuation", "PressureActuation", "LinearActuation", "LearnedActuation"],
        "pipeline": ["make_pcs_pipeline", "PCSPipeline"],
        "io": ["save", "load"],
    },
)
__all__ = ["__version__", *_names]
