"""Set-point targets stated as shapes (ShapeTarget, shape_strains) and the strain-range tolerance.

Truth: closed forms.  A PCS shape of segments scaled by ``c`` is reproduced
exactly by a segmentation scaled by ``c`` with ``κ/c``, ``σ_sh/c`` and
``(1 + σ_ax)/c − 1`` (the same curve, arc length stretched), rigid motions of
the shape do not change its strains, and angles may be wrapped by 2π.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.control import SetpointRegulator, ShapeTarget, TipRegulator, shape_strains
from pcs_sindy.core import PlanarPCS, forward_kinematics, se2_compose
from pcs_sindy.identification import PhysicalPCSLibrary
from pcs_sindy.simulation import get_scenario

PLANT_LENGTHS = [0.07, 0.1]
Q = np.array([12.0, 0.02, 0.03, -8.0, -0.01, 0.02])


class _Kinematic:
    """The least a shape fit needs of a model: its kinematics."""

    def __init__(self, lengths, base=(0.0, 0.0, 0.0)) -> None:
        self.kinematics = PlanarPCS(tuple(lengths), base_pose=tuple(base))


def scaled(q: np.ndarray, c: float) -> np.ndarray:
    """Strains of segments scaled by ``c`` drawing the same curve (closed form)."""
    out = q.reshape(-1, 3).copy()
    out[:, 0] /= c
    out[:, 1] /= c
    out[:, 2] = (1.0 + out[:, 2]) / c - 1.0
    return out.ravel()


def test_shape_of_a_longer_segmentation_maps_to_the_closed_form_strains():
    c = 1.01  # the fused segments read 1 % long
    model = _Kinematic(np.array(PLANT_LENGTHS) * c)
    target = ShapeTarget.from_strains(Q, PLANT_LENGTHS)
    q, fit = shape_strains(model, target)
    np.testing.assert_allclose(q, scaled(Q, c), rtol=1e-7, atol=1e-9)
    assert fit["tip_error"] < 1e-9 and fit["max_position_error"] < 1e-9
    # the plant's strains given as they are miss the tip by millimetres
    s = [sum(PLANT_LENGTHS) * c]
    tip_raw = forward_kinematics(Q, np.array(PLANT_LENGTHS) * c, s)[0, :2]
    tip_true = forward_kinematics(Q, PLANT_LENGTHS, [sum(PLANT_LENGTHS)])[0, :2]
    assert np.linalg.norm(tip_raw - tip_true) > 1e-3


def test_marker_poses_in_a_camera_frame_with_wrapped_angles():
    s = np.linspace(0.0, 0.17, 21)
    markers = forward_kinematics(Q, PLANT_LENGTHS, s)
    camera = np.array([0.3, -0.1, 2.5])  # the base's pose in the camera frame
    seen = se2_compose(camera, markers)
    seen[:, 2] = np.angle(np.exp(1j * seen[:, 2])) + 2 * np.pi  # wrapped, then shifted by a turn
    q, fit = shape_strains(_Kinematic(PLANT_LENGTHS), ShapeTarget(seen))  # arc lengths: equally spaced
    np.testing.assert_allclose(q, Q, rtol=1e-7, atol=1e-9)
    assert fit["rms_position_error"] < 1e-9


def test_only_modelled_strains_are_fitted():
    kin = PlanarPCS((0.07, 0.1), active_strains=(True, False, True, True, False, True))
    model = type("M", (), {"kinematics": kin})()
    q_true = np.array([12.0, 0.0, 0.03, -8.0, 0.0, 0.02])
    q, _ = shape_strains(model, ShapeTarget.from_strains(q_true, PLANT_LENGTHS))
    np.testing.assert_allclose(q, q_true[kin.active_mask], rtol=1e-7, atol=1e-9)


def test_setpoint_regulator_takes_a_shape():
    robot = get_scenario("two_segment").robot
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    fm = lib.forward_model(
        lib.coefficients_from_parameters(
            robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
        )
    )
    t = np.arange(20) * 1e-3
    ctrl = SetpointRegulator(fm).start(ShapeTarget.from_strains(Q, robot.segment_lengths), t)
    np.testing.assert_allclose(ctrl.setpoint_, Q, rtol=1e-7, atol=1e-9)
    assert ctrl.shape_fit_["tip_error"] < 1e-9
    plain = SetpointRegulator(fm).start(Q, t)
    assert plain.shape_fit_ is None
    np.testing.assert_allclose(plain.setpoint_, ctrl.setpoint_, rtol=1e-7, atol=1e-9)


def test_a_little_beyond_the_strain_range_warns_and_far_is_refused():
    robot = get_scenario("two_segment").robot
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    fm = lib.forward_model(
        lib.coefficients_from_parameters(
            robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
        )
    )
    t = np.arange(20) * 1e-3
    limits = np.tile([20.0, 0.1, 0.1], 2)  # span of the bending range: 40 1/m
    near = np.array([22.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # 2 1/m = 5 % of the span beyond
    with pytest.warns(UserWarning, match=r"be_1 = 22 not in \[-20, 20\] \(5 % of its span beyond\)"):
        ctrl = SetpointRegulator(fm, strain_limits=limits).start(near, t)
    np.testing.assert_array_equal(ctrl.setpoint_, near)
    far = np.array([40.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # 50 % beyond
    with pytest.raises(ValueError, match=r"be_1 = 40 not in \[-20, 20\] \(50 % of its span beyond\).*refused"):
        SetpointRegulator(fm, strain_limits=limits).start(far, t)


def test_bad_targets_name_the_argument():
    with pytest.raises(ValueError, match=r"poses must be finite \[x, y, theta\] rows"):
        ShapeTarget(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="arc_lengths must be 3 finite, increasing"):
        ShapeTarget(np.zeros((3, 3)), arc_lengths=[0.0, 0.2, 0.1])
    with pytest.raises(ValueError, match="total_length must be a length > 0"):
        ShapeTarget(np.zeros((3, 3)), arc_lengths=[0.0, 0.1, 0.2], total_length=0.1)
    with pytest.raises(ValueError, match="q must hold 3 finite strains per segment"):
        ShapeTarget.from_strains(Q[:5], PLANT_LENGTHS)
    with pytest.raises(ValueError, match="n_points must be an integer >= 2"):
        ShapeTarget.from_strains(Q, PLANT_LENGTHS, n_points=1)
    with pytest.raises(TypeError, match="target must be a ShapeTarget"):
        shape_strains(_Kinematic(PLANT_LENGTHS), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="pose_std must be two finite numbers"):
        shape_strains(_Kinematic(PLANT_LENGTHS), ShapeTarget(np.zeros((3, 3))), pose_std=(0.0, 1.0))


def test_tip_regulator_accepts_a_tip_a_little_beyond_the_strain_range():
    robot = get_scenario("two_segment").robot
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity)
    fm = lib.forward_model(
        lib.coefficients_from_parameters(
            robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
        )
    )
    limits = np.tile([20.0, 0.01, 0.01], 2)
    t = np.arange(10) * 1e-3

    def tip_of(bending):
        return robot.kinematics.forward_kinematics(np.array([bending, 0, 0, bending, 0, 0]), [0.17])[0, :2]

    near = tip_of(23.0)  # both segments 15 % of the bound beyond it: ~8 % of the span
    with pytest.warns(UserWarning, match=r"be_1 = [\d.]+ not in \[-20, 20\] \([\d.]+ % of its span beyond\)"):
        ctrl = TipRegulator(fm, strain_limits=limits).start(near, t)
    assert ctrl.equilibrium_.reachable
    np.testing.assert_allclose(ctrl.target_, near)
    with pytest.raises(ValueError, match="not reachable"):
        TipRegulator(fm, strain_limits=limits).start(tip_of(40.0), t)
