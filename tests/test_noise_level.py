"""core.metrics.noise_level: the white-noise level from second differences, against known noise."""

import numpy as np
import pytest


def test_noise_level_recovers_white_noise_on_a_smooth_signal_with_jumps():
    """σ of Gaussian noise on a slow sine, with 1 % of the samples thrown far off: within 5 %."""
    from pcs_sindy.core.metrics import noise_level

    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 10.0, 20_000)
    sigma = np.array([1e-3, 4e-3])
    x = np.stack([np.sin(t), np.cos(0.5 * t)], axis=1) + sigma * rng.standard_normal((t.size, 2))
    x[rng.choice(t.size, 200, replace=False)] += 0.5
    np.testing.assert_allclose(noise_level(x, axis=0), sigma, rtol=0.05)
    assert float(noise_level(np.zeros((5, 3)))) == 0.0
    with pytest.raises(ValueError, match="at least 3 samples"):
        noise_level(np.zeros((2, 3)))
