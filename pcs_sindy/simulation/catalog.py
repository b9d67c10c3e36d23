"""The named scenarios: the seed's Table I, five_segment and the actuated robots (docs/method.md).

:func:`get_scenario` builds a :class:`~pcs_sindy.simulation.scenarios.Scenario`
(ground-truth robot and data recipe) from the tables below.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .actuation import PressureChambers, Tendons
from .pac import PACRobot
from .scenarios import Scenario

__all__ = ["get_scenario", "list_scenarios"]


# ----------------------------------------------------------------------
# The table (docs/method.md / seed Table I)
# ----------------------------------------------------------------------
_PCS_TABLE: dict[str, dict[str, Any]] = {
    "one_segment": dict(
        segment_lengths=[0.1],
        density=[1070.0],
        youngs_modulus=[1e4],
        shear_modulus=[1e3],
        damping=[1e-5, 1.5e-1, 1.5e-1],
        seed_noise=(5e-4, np.deg2rad(1.0)),
    ),
    "two_segment": dict(
        segment_lengths=[0.07, 0.1],
        density=[1070.0, 1049.0],
        youngs_modulus=[1e4, 9e3],
        shear_modulus=[1e3, 3e3],
        damping=[3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2],
        seed_noise=(1e-4, np.deg2rad(0.5)),
    ),
    "three_segment": dict(
        segment_lengths=[0.05, 0.1, 0.06],
        density=[1240.0, 1049.0, 1070.0],
        youngs_modulus=[1e4, 6e4, 8e4],
        shear_modulus=[1e3, 3e3, 5e3],
        damping=[5e-5, 4e-2, 5e-2, 5e-5, 5e-3, 5e-2, 5e-5, 5e-3, 5e-2],
        seed_noise=(1e-4, np.deg2rad(0.5)),
    ),
    "one_segment_stiff_shear": dict(
        segment_lengths=[0.1],
        density=[1070.0],
        youngs_modulus=[1e4],
        shear_modulus=[1e6],
        damping=[1e-5, 5e0, 1.5e-1],
        seed_noise=(5e-4, np.deg2rad(1.0)),
    ),
    # beyond the seed (issue 6): five segments of alternating soft and stiffer silicone-like
    # materials, 0.27 m in all, with the damping pattern of three_segment
    "five_segment": dict(
        segment_lengths=[0.04, 0.06, 0.05, 0.07, 0.05],
        density=[1070.0, 1049.0, 1240.0, 1070.0, 1049.0],
        youngs_modulus=[1e4, 4e4, 2e4, 6e4, 1.5e4],
        shear_modulus=[1e3, 3e3, 2e3, 5e3, 1.5e3],
        damping=[5e-5, 4e-2, 5e-2] * 5,
        seed_noise=(1e-4, np.deg2rad(0.5)),
    ),
}


def _stiff_axial_shear() -> dict[str, Any]:
    # the published paper's extra case: segment 1 axial and segment 2 shear stiffness x1000.
    # Stiffness is diag(E I, c_sh G A, E A), so scale the moduli that enter only those entries
    # through the per-strain factors below.
    base = dict(_PCS_TABLE["two_segment"])
    base["stiffness_factors"] = [1.0, 1.0, 1000.0, 1.0, 1000.0, 1.0]
    return base


_PCS_TABLE["two_segment_stiff_axial_shear"] = _stiff_axial_shear()

_DESCRIPTIONS = {
    "one_segment": "one constant-strain segment (seed Case 1)",
    "two_segment": "two constant-strain segments (seed Case 2)",
    "three_segment": "three constant-strain segments (seed Case 3, kinematics in the seed)",
    "one_segment_stiff_shear": "one segment with a very stiff shear strain (seed Case 4)",
    "pac_one_segment": "one piecewise-affine-curvature segment, kinematics only (seed Case 5)",
    "two_segment_stiff_axial_shear": "two segments, segment 1 axial and segment 2 shear stiffness x1000",
    "five_segment": "five constant-strain segments, 0.27 m (beyond the seed)",
    "two_segment_tendon": "two_segment driven by four tendons at +-15 mm, two ending at 70 mm, two at the tip",
    "one_segment_pneumatic": "one_segment driven by two pressure chambers on opposite sides",
}

# actuated robots (beyond the seed, issue 11): a robot of the table driven through actuators instead of by τ.
# Training inputs are off or uniform in [0, input_max]; the maxima keep the strains inside the seed's ranges
# (bending within +-60 1/m, shear and axial within +-0.3: all four tendons at 12 N compress segment 1 by
# about 0.25).  Chamber gains: area 2 cm^2, centroid 15 mm off the backbone.
_ACTUATED: dict[str, dict[str, Any]] = {
    "two_segment_tendon": dict(
        base="two_segment",
        actuation=dict(type="tendon", end=[0.07, 0.07, 0.17, 0.17], offset=[0.015, -0.015, 0.015, -0.015]),
        input_max=(16.0, 16.0, 16.0, 16.0),
    ),
    "one_segment_pneumatic": dict(
        base="one_segment",
        actuation=dict(
            type="pressure",
            start=[0.0, 0.0],
            end=[0.1, 0.1],
            side=[1, -1],
            bending_gain=[3e-6, 3e-6],
            axial_gain=[2e-4, 2e-4],
        ),
        input_max=(9e4, 9e4),
    ),
}


def _actuation_from_spec(spec: dict[str, Any]) -> Any:
    kw = {k: v for k, v in spec.items() if k != "type"}
    return Tendons(**kw) if spec["type"] == "tendon" else PressureChambers(**kw)


# stiffened variants take their actuation magnitudes from the nominal robot
_ACTUATION_REFERENCE = {"one_segment_stiff_shear": "one_segment", "two_segment_stiff_axial_shear": "two_segment"}


def list_scenarios() -> list[str]:
    """Names accepted by :func:`get_scenario`."""
    return list(_DESCRIPTIONS)


def describe_scenarios() -> dict[str, str]:
    """Every name accepted by :func:`get_scenario` with a one-line description of its robot."""
    return dict(_DESCRIPTIONS)


def get_scenario(name: str, **overrides: Any) -> Scenario:
    """Build a named scenario (docs/method.md, "Scenarios and data").

    Parameters
    ----------
    name : str
        One of :func:`list_scenarios`.
    **overrides
        Fields of :class:`Scenario` to change (e.g. ``n_markers=10``) or
        robot options (``stiffness_scaling="length"``).

    Raises
    ------
    ValueError
        For an unknown name.
    """
    if name not in _DESCRIPTIONS:
        raise ValueError(f"unknown scenario name {name!r}; choose one of {list_scenarios()}")
    robot_options = {k: overrides.pop(k) for k in ("stiffness_scaling", "gravity", "radius") if k in overrides}
    if name == "pac_one_segment":
        return Scenario(
            name=name,
            robot=PACRobot(0.15),
            parameters={"length": 0.15},
            description=_DESCRIPTIONS[name],
            seed_noise=(5e-4, np.deg2rad(1.0)),
            **overrides,
        )
    from .dynamics import PCSRobot  # the dynamics are only needed for PCS scenarios

    actuated = _ACTUATED.get(name)
    spec = dict(_PCS_TABLE[actuated["base"] if actuated else name])
    seed_noise = spec.pop("seed_noise")
    factors = spec.pop("stiffness_factors", None)
    actuation = _actuation_from_spec(actuated["actuation"]) if actuated else None
    robot = PCSRobot(radius=robot_options.pop("radius", 0.02), **spec, **robot_options, actuation=actuation)
    if factors is not None:
        robot = _scale_stiffness(robot, np.asarray(factors, dtype=float))
    parameters = {**spec, "radius": robot_options.get("radius", 0.02), "stiffness_factors": factors}
    if actuated:
        parameters["actuation"] = actuated["actuation"]
        overrides.setdefault("input_max", actuated["input_max"])
    reference = overrides.setdefault("actuation_reference", _ACTUATION_REFERENCE.get(name))
    if reference is not None:
        overrides.setdefault("actuation_robot", get_scenario(reference).robot)
    return Scenario(
        name=name,
        robot=robot,
        parameters=parameters,
        seed_noise=seed_noise,
        description=_DESCRIPTIONS[name],
        **overrides,
    )


def _scale_stiffness(robot: Any, factors: NDArray[np.float64]) -> Any:
    """Scale individual diagonal stiffness entries of a PCSRobot."""
    robot.stiffness = robot.stiffness * factors
    return robot
