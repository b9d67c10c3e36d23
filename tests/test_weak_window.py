"""The default weak-form window from the data: the band of the strains above their white-noise floor.

Truth: closed forms.  A sinusoid of known frequency in known white noise has its whole excess power in its own
periodogram bin (the Hann window leaks 1/16 of it into each neighbour), so the band frequency is the sinusoid's and
the default window is ``WEAK_WINDOW_BAND / f`` seconds, bounded by the sample counts; a strain of pure noise does not
move it; a window the user gives is used as given.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.identification.recordings import (
    WEAK_WINDOW,
    WEAK_WINDOW_BAND,
    WEAK_WINDOW_BAND_MIN_SAMPLES,
    WEAK_WINDOW_BAND_SNR,
    WEAK_WINDOW_MIN_SAMPLES,
    band_frequency,
    weak_windows,
)


def _sine_in_noise(freq, dt, duration=30.0, sigma=0.1, seed=0):
    """One excited strain (unit sinusoid, a whole number of periods) and one of pure noise, both with noise sigma."""
    t = np.arange(int(round(duration / dt))) * dt
    rng = np.random.default_rng(seed)
    q = np.stack([np.sin(2 * np.pi * freq * t + 0.3), np.zeros_like(t)], axis=1)
    return q + sigma * rng.standard_normal(q.shape)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_band_of_a_sinusoid_in_white_noise_is_its_frequency(seed):
    q = _sine_in_noise(1.5, 0.01, seed=seed)
    assert band_frequency([q], 0.01) == pytest.approx(1.5, abs=1e-9)
    # the median over recordings: two at 1.5 Hz and one at 2 Hz
    assert band_frequency([q, q, _sine_in_noise(2.0, 0.01, seed=seed)], 0.01) == pytest.approx(1.5, abs=1e-9)


def test_default_window_keeps_the_band_of_a_sinusoid():
    dt, n = 0.01, 3000
    q = _sine_in_noise(1.5, dt)
    width = round(WEAK_WINDOW_BAND / (1.5 * dt))  # 0.75 / 1.5 Hz = 0.5 s: 50 intervals
    assert WEAK_WINDOW_BAND_MIN_SAMPLES < width < WEAK_WINDOW_MIN_SAMPLES
    assert weak_windows(n, None, None, dt, strains=[q]) == (width, width // 4)
    # a band too fast for the sample floor: the floor (10 Hz -> 7.5 intervals)
    fast = _sine_in_noise(10.0, dt)
    assert weak_windows(n, None, None, dt, strains=[fast]) == (WEAK_WINDOW_BAND_MIN_SAMPLES, 8)
    # a slow band never lengthens the window past the longest default: 1.5 Hz at 1 kHz asks for 500 intervals
    slow = _sine_in_noise(1.5, 1e-3, duration=4.0)
    assert weak_windows(4000, None, None, 1e-3, strains=[slow]) == (160, 40)
    assert round(WEAK_WINDOW / 1e-3) == 160
    # nor past half the shortest recording
    assert weak_windows(81, None, None, dt, strains=[q]) == (40, 10)


def test_the_window_is_shortened_only_when_the_noise_threatens_the_band():
    dt, n = 0.01, 3000
    # motion / noise: the sinusoid 0.707 / sigma, the unexcited strain 1; the median of the two
    assert 0.5 * (1 / np.sqrt(2) / 0.1 + 1) < WEAK_WINDOW_BAND_SNR < 0.5 * (1 / np.sqrt(2) / 0.01 + 1)
    assert weak_windows(n, None, None, dt, strains=[_sine_in_noise(1.5, dt, sigma=0.1)])[0] == 50
    # the same band with 10 x less noise: the longest default (0.16 s, at least 160 intervals)
    assert weak_windows(n, None, None, dt, strains=[_sine_in_noise(1.5, dt, sigma=0.01)]) == (160, 40)
    assert band_frequency([_sine_in_noise(1.5, dt, sigma=0.01)], dt) == pytest.approx(1.5, abs=1e-9)


def test_no_band_keeps_the_longest_default_and_a_user_window_is_untouched():
    dt = 0.01
    still = np.ones((500, 3))  # no noise floor, no motion: no band
    assert band_frequency([still], dt) is None
    assert band_frequency([_sine_in_noise(1.5, dt)[:10]], dt) is None  # too short to tell
    assert weak_windows(100_000, None, None, dt, strains=[still]) == (WEAK_WINDOW_MIN_SAMPLES, 40)
    q = _sine_in_noise(1.5, dt)
    assert weak_windows(3000, 30, None, dt, strains=[q]) == (30, 7)
    assert weak_windows(3000, 30, 3, dt, strains=[q]) == (30, 3)
    assert weak_windows(3000, 120, None, dt, strains=[q]) == (120, 30)
