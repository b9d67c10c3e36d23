"""The package root keeps every public name of release 0.1.0, and each stage exports what it says."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys

import pytest

import pcs_sindy

#: the names ``pcs_sindy`` exported in release 0.1.0 (its ``__all__``), written down before the move
RELEASE_0_1_0 = (
    "__version__",
    "PlanarPCS",
    "PoseTrajectory",
    "StrainTrajectory",
    "MarkerPoseExtractor",
    "KinematicFusion",
    "PCSLagrangianLibrary",
    "PhysicalPCSLibrary",
    "Camera",
    "StiffnessThresholdOptimizer",
    "EulerLagrangeRegressor",
    "make_pcs_pipeline",
    "save",
    "load",
    "PCSPipeline",
)
STAGES = ("core", "vision", "fusion", "identification", "models", "control", "pipeline", "simulation", "io", "plotting")


@pytest.mark.parametrize("name", RELEASE_0_1_0)
def test_every_former_root_name_is_still_there(name):
    assert name in pcs_sindy.__all__
    assert getattr(pcs_sindy, name) is not None


def test_the_root_names_are_the_stages_own_objects():
    from pcs_sindy.core import SimulationError
    from pcs_sindy.fusion.kinematic_fusion import KinematicFusion
    from pcs_sindy.identification.regressor import EulerLagrangeRegressor
    from pcs_sindy.simulation import SimulationError as SimulatorError

    assert pcs_sindy.KinematicFusion is KinematicFusion
    assert pcs_sindy.EulerLagrangeRegressor is EulerLagrangeRegressor
    # one error class for every simulate: the simulator's and the identified models'
    assert pcs_sindy.SimulationError is SimulationError is SimulatorError
    assert issubclass(SimulationError, RuntimeError)


@pytest.mark.parametrize("stage", STAGES)
def test_each_stage_is_a_package_with_a_docstring_and_exports(stage):
    module = importlib.import_module(f"pcs_sindy.{stage}")
    assert getattr(pcs_sindy, stage) is module
    doc = module.__doc__ or ""
    assert len(doc.splitlines()) >= 3, f"pcs_sindy.{stage} needs a docstring saying what it takes in and gives out"
    assert module.__all__ and all(hasattr(module, name) for name in module.__all__)


def test_unknown_names_raise_attribute_error():
    with pytest.raises(AttributeError):
        pcs_sindy.KinematicFussion  # noqa: B018
    with pytest.raises(ImportError):
        exec("from pcs_sindy.fusion import EulerLagrangeRegressor", {})


@pytest.mark.slow  # a fresh interpreter
def test_importing_the_package_loads_no_stage():
    script = "import sys, pcs_sindy; print(sorted(m for m in sys.modules if m.startswith('pcs_sindy')))"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=120)
    loaded = ast.literal_eval(out.stdout.strip())
    assert set(loaded) <= {"pcs_sindy", "pcs_sindy._version", "pcs_sindy.core", "pcs_sindy.core.saving"}, loaded
    heavy = "import sys, pcs_sindy; print([m for m in ('numpy', 'scipy', 'sklearn', 'cv2') if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", heavy], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == "[]"
