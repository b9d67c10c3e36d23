"""The ground-truth simulator's rollouts as plain arrays, for tests on the identification side."""

from __future__ import annotations

import numpy as np


def simulate_truth(robot, q0, qd0, t, u, **kwargs) -> tuple[np.ndarray, np.ndarray]:
    """``(q, qd)`` of ``robot.simulate(q0, qd0, t, u, rtol=1e-10, atol=1e-12, ...)``."""
    sim = robot.simulate(q0, qd0, t, u, **({"rtol": 1e-10, "atol": 1e-12} | kwargs))
    return sim.q, sim.qd
