"""The simulate contract of the ground-truth robot (pcs_sindy.core): return type, names, errors, methods.

Truth: a tight explicit reference (scipy's DOP853 at rtol 1e-11) for every method; the class
identities and warnings of the contract itself.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pcs_sindy.core.simulate_contract as integration
from pcs_sindy.core import SimulationError, StrainTrajectory
from pcs_sindy.simulation import dynamics, get_scenario
from pcs_sindy.simulation.integrate import METHODS_SUPPORTED


@pytest.fixture(scope="module")
def robot():
    return get_scenario("two_segment").robot


@pytest.fixture(scope="module")
def run():
    t = np.arange(31) * 1e-3
    tau = np.repeat(np.random.default_rng(0).uniform(-1, 1, (4, 6)) * [5e-3, 0.05, 0.1, 3e-3, 0.05, 0.1], 10, axis=0)[
        : t.size
    ]
    q0 = np.array([5.0, 0.02, -0.01, -8.0, 0.03, 0.02])
    return q0, t, tau


def test_returns_a_strain_trajectory_carrying_the_robot_and_inputs(robot, run):
    q0, t, tau = run
    sim = robot.simulate(q0, np.zeros(6), t, tau)
    assert isinstance(sim, StrainTrajectory)
    assert sim.q.shape == sim.qd.shape == (t.size, 6)
    np.testing.assert_array_equal(sim.t, t)
    assert sim.segment_lengths == (0.07, 0.1)
    np.testing.assert_array_equal(sim.q[0], q0)
    np.testing.assert_array_equal(sim.metadata["u"], tau)
    assert sim.metadata["method"] == "radau" and sim.metadata["step"] == 5e-4
    assert sim.metadata["counts"]["steps"] == 2 * (t.size - 1)  # fixed 0.5 ms steps on a 1 ms grid
    # poses come from the trajectory's own kinematics
    np.testing.assert_allclose(sim.poses([0.17])[:, 0], robot.kinematics.forward_kinematics(sim.q, [0.17])[:, 0])


def test_a_batch_returns_one_trajectory_per_robot(robot, run):
    q0, t, tau = run
    q0s = np.stack([q0, -q0, 0 * q0])
    taus = np.stack([tau, -tau, tau], axis=1)
    runs = robot.simulate(q0s, np.zeros((3, 6)), t, taus)
    assert isinstance(runs, list) and len(runs) == 3
    for b, r in enumerate(runs):
        single = robot.simulate(q0s[b], np.zeros(6), t, taus[:, b])
        np.testing.assert_array_equal(r.q, single.q)
        np.testing.assert_array_equal(r.metadata["u"], taus[:, b])


def test_error_class_is_the_contract_one():
    assert SimulationError is integration.SimulationError is dynamics.SimulationError
    assert issubclass(SimulationError, RuntimeError)


@pytest.mark.parametrize("method", METHODS_SUPPORTED)
def test_every_method_agrees_with_a_tight_reference(robot, run, method):
    q0, t, tau = run
    ref = robot.simulate(q0, np.zeros(6), t, tau, method="dop853", rtol=1e-11, atol=1e-14)
    # rk23 is third order: a looser tolerance keeps it quick; its bound follows
    rtol, bound = (1e-5, 1e-3) if method == "rk23" else (1e-8, 1e-5)
    sim = robot.simulate(q0, np.zeros(6), t, tau, method=method, rtol=rtol, atol=rtol * 1e-3)
    assert sim.metadata["method"] == method and sim.metadata["step"] is None
    span = np.ptp(ref.q, axis=0)
    assert np.all(np.abs(sim.q - ref.q).max(axis=0) <= bound * span), method


def test_callable_inputs_with_a_batch(robot, run):
    q0, t, tau = run
    amp = np.array([5e-3, 0.05, 0.1, 3e-3, 0.05, 0.1])
    fn = lambda time: np.stack([amp * np.sin(80 * time), -amp * np.cos(50 * time)])  # noqa: E731
    runs = robot.simulate(np.zeros((2, 6)), np.zeros((2, 6)), t, fn, rtol=1e-9, atol=1e-12)
    for b in range(2):
        ref = robot.simulate(
            np.zeros(6), np.zeros(6), t, lambda time, b=b: fn(time)[b], method="dop853", rtol=1e-11, atol=1e-14
        )
        assert runs[b].metadata["u"] is not None
        np.testing.assert_allclose(runs[b].q, ref.q, rtol=0, atol=1e-6 * np.abs(ref.q).max())


def test_former_names_work_with_a_future_warning(robot, run):
    q0, t, tau = run
    new = robot.simulate(q0, np.zeros(6), t, tau, step=2.5e-4)
    with pytest.warns(FutureWarning, match="use u"):
        old = robot.simulate(q0, np.zeros(6), t, tau=tau, step=2.5e-4)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.warns(FutureWarning, match="use step"):
        old = robot.simulate(q0, np.zeros(6), t, tau, fixed_step=2.5e-4)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.warns(FutureWarning, match="'radau'"):
        old = robot.simulate(q0, np.zeros(6), t, tau, method="Radau", step=2.5e-4)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.warns(FutureWarning, match="'dopri5'"):
        robot.simulate(q0, np.zeros(6), t[:3], tau[:3], method="RK45")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        robot.simulate(q0, np.zeros(6), t[:3], tau[:3], method="dopri5")  # the new names warn about nothing


def test_bad_contract_arguments_are_named(robot, run):
    q0, t, tau = run
    with pytest.raises(ValueError, match="not both"):
        robot.simulate(q0, np.zeros(6), t, tau, tau=tau)
    with pytest.raises(ValueError, match="needs the inputs u"):
        robot.simulate(q0, np.zeros(6), t)
    with pytest.raises(ValueError, match="'rosenbrock'"):
        robot.simulate(q0, np.zeros(6), t, tau, method="rosenbrock")  # identified models only
    with pytest.raises(ValueError, match="step must be"):
        robot.simulate(q0, np.zeros(6), t, tau, step="fast")
    with pytest.raises(ValueError, match="rtol"):
        robot.simulate(q0, np.zeros(6), t, tau, rtol=-1.0)
    with pytest.raises(ValueError, match="max_step"):
        robot.simulate(q0, np.zeros(6), t, tau, max_step=0.0)
