"""Servo-wound elastic tendons routed in 3-D (``SpatialTendonActuation(drive="displacement")``).

Independent truth: the planar simulator's servo tendons (:class:`~pcs_sindy.simulation.Tendons` with
``drive="displacement"``, its own code) on planar motions, fed each tendon its own angle, and its
recordings (embedded in 3-D) for identification.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core.kinematics import PlanarPCS
from pcs_sindy.core.spatial import SpatialPCS, SpatialStrainTrajectory, planar_to_spatial_strains
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import load, save
from pcs_sindy.models import SpatialTendonActuation
from pcs_sindy.simulation import Tendons
from pcs_sindy.simulation.dynamics import PCSRobot

LENGTHS = [0.07, 0.1]
END = [0.07, 0.17, 0.17, 0.12]
OFFSET = [[0.01, 0.0], [-0.008, 0.004], [0.0, -0.012], [0.005, 0.006]]
PLANAR_BODY = dict(density=[1070.0, 1049.0], youngs_modulus=[1e4, 9e3], shear_modulus=[1e3, 3e3])
PLANAR_DAMP = [3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2]
SERVO = dict(
    end=[0.07, 0.07, 0.17, 0.17],
    offset=[0.015, -0.015, 0.015, -0.015],
    stiffness=[500.0, 500.0, 400.0, 400.0],
    pulley_radius=[0.01, 0.01, 0.012, 0.012],
    slack=[0.001, 0.002, -0.001, 0.0],
)


def _servo_in_3d(**kw) -> SpatialTendonActuation:
    """The planar servo tendons as 3-D ones: offsets along body x (the planar cross-section axis)."""
    offset = [[d, 0.0] for d in SERVO["offset"]]
    return SpatialTendonActuation(SERVO["end"], offset=offset, drive="displacement", **kw)


def test_servo_tendons_equal_the_planar_simulators_on_planar_motions():

    robot = PCSRobot(LENGTHS, **PLANAR_BODY, damping=PLANAR_DAMP, actuation=Tendons(**SERVO, drive="displacement"))
    kin = SpatialPCS.from_planar(PlanarPCS(tuple(LENGTHS)))
    act = _servo_in_3d(stiffness=SERVO["stiffness"], pulley_radius=SERVO["pulley_radius"], slack=SERVO["slack"]).fit(
        kin
    )
    rng = np.random.default_rng(1)
    q = rng.normal(size=(30, 6)) * [15, 0.05, 0.05, 15, 0.05, 0.05]
    u = rng.uniform(-30, 90, (30, 4))  # servo angles [deg] of either sign
    tensions = act.tensions(q, u)
    np.testing.assert_allclose(tensions, robot.tendon_tensions(q, u), rtol=1e-12, atol=1e-15)
    assert np.any(tensions == 0) and np.any(tensions > 0)  # slack and taut tendons
    np.testing.assert_allclose(act.forces(q, u), robot.actuation_forces(q, u), rtol=1e-12, atol=1e-15)
    assert act.input_bounds() is None and not act.linear_in_inputs
    with pytest.raises(ValueError, match="drive='tension'"):
        SpatialTendonActuation(END, offset=OFFSET, slack=[0.0] * 4).fit(SpatialPCS(tuple(LENGTHS)))


def test_servo_pulley_radii_and_slacks_are_identified_from_planar_servo_data(tmp_path):

    robot = PCSRobot(LENGTHS, **PLANAR_BODY, damping=PLANAR_DAMP, actuation=Tendons(**SERVO, drive="displacement"))
    kin = SpatialPCS.from_planar(PlanarPCS(tuple(LENGTHS)))
    rng = np.random.default_rng(0)
    t = np.arange(1500) * 1e-3
    X, U = [], []
    for _ in range(2):  # random servo steps: tendons go slack and taut
        u = np.repeat(rng.uniform(-10, 90, (75, 4)) * (rng.uniform(size=(75, 4)) < 0.5), 20, axis=0)
        tr = robot.simulate(np.zeros(6), np.zeros(6), t, u)
        X.append(
            SpatialStrainTrajectory(
                planar_to_spatial_strains(tr.q), t, segment_lengths=LENGTHS, active_strains=kin.active_strains
            )
        )
        U.append(u)
    act = _servo_in_3d(stiffness=SERVO["stiffness"])  # known routing and stiffness; radii and slacks identified
    reg = EulerLagrangeRegressor(actuation=act).fit(X, U)
    p = 4
    full = reg.actuation_.offsets_
    np.testing.assert_allclose(full[2 * p : 3 * p], SERVO["pulley_radius"], rtol=0.01)
    np.testing.assert_allclose(full[3 * p :], SERVO["slack"], atol=5e-5)
    assert reg.actuation_.offset_names_ == [f"r_{k}" for k in range(1, 5)] + [f"s_{k}" for k in range(1, 5)]
    np.testing.assert_allclose(reg.stiffness_[kin.active_mask], robot.stiffness, rtol=0.01)
    loaded = load(save(reg, tmp_path / "servo"))
    assert loaded.actuation_.design_layout()["drive"] == "displacement"
    q, u = X[0].q[::50], U[0][::50]
    np.testing.assert_array_equal(
        loaded.actuation_.forces(q[:, kin.active_mask], u), reg.actuation_.forces(q[:, kin.active_mask], u)
    )


def test_servos_winding_antagonistic_pairs_equal_the_simulator_fed_each_tendon_its_angle():
    """``motor``/``winding``: one servo takes up one tendon of a pair and lets out the other (the Trunk's way)."""

    pretension = dict(SERVO, slack=[-0.002, -0.001, -0.002, -0.003])  # both tendons of a pair taut at rest
    robot = PCSRobot(LENGTHS, **PLANAR_BODY, damping=PLANAR_DAMP, actuation=Tendons(**pretension, drive="displacement"))
    kin = SpatialPCS.from_planar(PlanarPCS(tuple(LENGTHS)))
    act = _servo_in_3d(
        stiffness=SERVO["stiffness"],
        pulley_radius=SERVO["pulley_radius"],
        slack=pretension["slack"],
        motor=[0, 0, 1, 1],
        winding=[1, -1, 1, -1],
    ).fit(kin)
    assert act.n_inputs_ == 2 and act.n_tendons_ == 4
    rng = np.random.default_rng(4)
    q = rng.normal(size=(20, 6)) * [15, 0.05, 0.05, 15, 0.05, 0.05]
    servo = rng.uniform(-40, 40, (20, 2))
    each = servo[:, [0, 0, 1, 1]] * [1, -1, 1, -1]  # the simulator's inputs: one angle per tendon
    np.testing.assert_allclose(act.tensions(q, servo), robot.tendon_tensions(q, each), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(act.forces(q, servo), robot.actuation_forces(q, each), rtol=1e-12, atol=1e-15)
    assert act.design_layout()["motor"] == [0, 0, 1, 1] and act.design_layout()["winding"] == [1, -1, 1, -1]
    with pytest.raises(ValueError, match=r"shape \(T, 2\)"):
        act.check_inputs(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="input indices"):
        _servo_in_3d(motor=[0, 0, 2, 2]).fit(kin)  # servo 1 winds nothing
    with pytest.raises(ValueError, match="drive='tension'"):
        SpatialTendonActuation(END, offset=OFFSET, motor=[0, 0, 1, 1]).fit(SpatialPCS(tuple(LENGTHS)))


def test_antagonistic_servo_pairs_are_identified_from_the_servo_angles():

    pretension = dict(SERVO, slack=[-0.002, -0.001, -0.002, -0.003])
    robot = PCSRobot(LENGTHS, **PLANAR_BODY, damping=PLANAR_DAMP, actuation=Tendons(**pretension, drive="displacement"))
    kin = SpatialPCS.from_planar(PlanarPCS(tuple(LENGTHS)))
    rng = np.random.default_rng(5)
    t = np.arange(1500) * 1e-3
    X, U = [], []
    for _ in range(2):
        servo = np.repeat(rng.uniform(-60, 60, (75, 2)), 20, axis=0)
        tr = robot.simulate(np.zeros(6), np.zeros(6), t, servo[:, [0, 0, 1, 1]] * [1, -1, 1, -1])
        q = planar_to_spatial_strains(tr.q)
        X.append(SpatialStrainTrajectory(q, t, segment_lengths=LENGTHS, active_strains=kin.active_strains))
        U.append(servo)
    act = _servo_in_3d(stiffness=SERVO["stiffness"], motor=[0, 0, 1, 1], winding=[1, -1, 1, -1])
    reg = EulerLagrangeRegressor(actuation=act).fit(X, U)
    full = reg.actuation_.offsets_
    np.testing.assert_allclose(full[8:12], SERVO["pulley_radius"], rtol=0.01)
    np.testing.assert_allclose(full[12:], pretension["slack"], atol=5e-5)
    np.testing.assert_allclose(reg.stiffness_[kin.active_mask], robot.stiffness, rtol=0.01)
