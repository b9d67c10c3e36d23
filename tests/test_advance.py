"""PCSRobot.advance: one held control period at a time, against PCSRobot.simulate over the same grid."""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.simulation import get_scenario


def commands(robot, rng, K, batch=()):
    if robot.actuation is not None:
        return rng.uniform(0.0, 12.0, (K,) + batch + (robot.n_inputs,))
    q_star = rng.uniform(-1, 1, (K,) + batch + (robot.n_q,)) * np.tile([30.0, 0.2, 0.2], robot.n_segments)
    return robot.elastic_forces(q_star) + robot.gravity_forces(q_star)


@pytest.mark.parametrize("name", ["two_segment", "two_segment_tendon"])
@pytest.mark.parametrize("kw", [{}, dict(step=None, rtol=1e-7, atol=1e-10)])
def test_consecutive_periods_reproduce_simulate(name, kw):
    robot = get_scenario(name).robot
    rng = np.random.default_rng(0)
    K, dt = 25, 1e-3
    u = commands(robot, rng, K)
    t = np.arange(K + 1) * dt
    ref = robot.simulate(np.zeros(robot.n_q), np.zeros(robot.n_q), t, np.concatenate([u, u[-1:]]), **kw)
    q, qd = np.zeros(robot.n_q), np.zeros(robot.n_q)
    for k in range(K):
        q, qd = robot.advance(q, qd, u[k], dt, **kw)
        # the same scheme, steps and carried Jacobian: step sizes differ only by the round-off of the grid's time
        # stamps (restarting each period with a fresh Jacobian would differ by ~1e-8)
        np.testing.assert_allclose(q, ref.q[k + 1], rtol=0, atol=1e-11 * np.abs(ref.q).max())
        np.testing.assert_allclose(qd, ref.qd[k + 1], rtol=0, atol=1e-11 * np.abs(ref.qd).max())
    assert np.abs(ref.q[-1]).max() > 1e-3  # the robot moved


def test_a_batch_and_a_restart_from_another_state():
    robot = get_scenario("two_segment").robot
    rng = np.random.default_rng(1)
    u = commands(robot, rng, 10, (3,))
    t = np.arange(11) * 1e-3
    q0 = rng.uniform(-1, 1, (3, 6)) * [10, 0.05, 0.05, 10, 0.05, 0.05]
    runs = robot.simulate(q0, np.zeros((3, 6)), t, np.concatenate([u, u[-1:]]))
    q, qd = q0, np.zeros((3, 6))
    for k in range(10):
        q, qd = robot.advance(q, qd, u[k], 1e-3)
        assert q.shape == qd.shape == (3, 6)
        for b in range(3):
            np.testing.assert_allclose(q[b], runs[b].q[k + 1], rtol=0, atol=1e-11 * np.abs(runs[b].q).max())
    # a state the last call did not return starts afresh: one period of simulate from that state
    other = runs[1].q[4], runs[1].qd[4]
    q1, qd1 = robot.advance(*other, u[4, 1], 1e-3)
    one = robot.simulate(*other, t[:2], np.stack([u[4, 1], u[4, 1]]))
    np.testing.assert_array_equal(q1, one.q[1])
    np.testing.assert_array_equal(qd1, one.qd[1])


def test_bad_advance_arguments():
    robot = get_scenario("two_segment_tendon").robot
    z = np.zeros(6)
    with pytest.raises(ValueError, match=r"u\[2\] = -1\.0: tendon 2"):
        robot.advance(z, z, np.array([1.0, 1.0, -1.0, 1.0]), 1e-3)
    with pytest.raises(ValueError, match=r"u must have shape .*\(4,\)"):
        robot.advance(z, z, np.ones(6), 1e-3)
    with pytest.raises(ValueError, match="dt"):
        robot.advance(z, z, np.ones(4), 0.0)
    with pytest.raises(ValueError, match="step"):
        robot.advance(z, z, np.ones(4), 1e-3, step=-1.0)
    with pytest.raises(ValueError, match="qd"):
        robot.advance(z, np.zeros(5), np.ones(4), 1e-3)
