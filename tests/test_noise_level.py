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


def test_motion_to_noise_of_a_sinusoid_under_known_white_noise():
    """A sinusoid of amplitude a under white noise sigma reads a / (sqrt(2) sigma); noise alone about 0; a column
    that never moves 0, a noise-free ramp inf; recordings pooled around their own means."""
    from pcs_sindy.core.metrics import motion_to_noise

    rng = np.random.default_rng(5)
    t = np.arange(0.0, 20.0, 1e-3)
    a, sigma = np.array([1.0, 0.05, 0.0]), np.array([0.1, 0.1, 0.1])
    x = a * np.sin(2 * np.pi * 1.0 * t)[:, None] + sigma * rng.standard_normal((t.size, 3))
    got = motion_to_noise(x)
    np.testing.assert_allclose(got[:2], a[:2] / (np.sqrt(2) * sigma[:2]), rtol=0.05)
    assert got[2] < 0.2  # noise alone: the net variance is the estimation error of sigma^2 (about 1 %)
    # two recordings with different offsets: an offset between recordings is not motion
    y = a[0] * np.sin(2 * np.pi * 0.5 * t)
    pooled = motion_to_noise([np.c_[y + 5.0 + 0.1 * rng.standard_normal(t.size)], np.c_[y - 5.0]])
    # pooled: var a^2/2, noise variance 0.01 in half the samples -> sqrt(0.5 - 0.005) / sqrt(0.005)
    np.testing.assert_allclose(pooled, np.sqrt(0.5 - 0.005) / np.sqrt(0.005), rtol=0.05)
    still = motion_to_noise(np.c_[np.zeros(50), 0.25 * np.arange(50.0), np.linspace(0.0, 1.0, 50)])
    assert still[0] == 0.0 and np.isinf(still[1]) and still[2] > 1e6  # round-off: no noise to speak of
    with pytest.raises(ValueError, match="same n"):
        motion_to_noise([np.zeros((5, 2)), np.zeros((5, 3))])
