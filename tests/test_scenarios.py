"""Scenarios: the seed's Table I, seeded generation, actuation holds, noise, PAC."""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.simulation import get_scenario, list_scenarios

SHORT = dict(n_train=2, train_duration=0.03, validation=False)


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PCS_SINDY_CACHE", str(tmp_path / "cache"))


def test_table_parameters_reach_the_robot():
    sc = get_scenario("two_segment")
    r = sc.robot
    np.testing.assert_allclose(r.kinematics.segment_lengths, [0.07, 0.1])
    A, I = np.pi * 0.02**2, np.pi * 0.02**4 / 4
    # seed convention: K_i = diag(E I, 4/3 G A, E A), not multiplied by the length
    np.testing.assert_allclose(r.stiffness, [1e4 * I, 4 / 3 * 1e3 * A, 1e4 * A, 9e3 * I, 4 / 3 * 3e3 * A, 9e3 * A])
    np.testing.assert_allclose(r.damping, [3e-5, 5e-1, 5e-2, 3e-5, 2.5e-2, 5e-2])
    stiff = get_scenario("two_segment_stiff_axial_shear").robot.stiffness
    np.testing.assert_allclose(stiff / r.stiffness, [1, 1, 1000, 1, 1000, 1])
    assert set(list_scenarios()) >= {
        "one_segment",
        "two_segment",
        "three_segment",
        "one_segment_stiff_shear",
        "pac_one_segment",
        "two_segment_stiff_axial_shear",
        "five_segment",
        "two_segment_tendon",
        "one_segment_pneumatic",
    }


def test_unknown_scenario_is_named():
    with pytest.raises(ValueError, match="'five_segments'"):
        get_scenario("five_segments")


def test_generation_is_deterministic_and_seeded():
    sc = get_scenario("one_segment")
    a = sc.generate(seed=3, cache=False, **SHORT)
    b = sc.generate(seed=3, cache=False, **SHORT)
    c = sc.generate(seed=4, cache=False, **SHORT)
    np.testing.assert_array_equal(a.train[1].q, b.train[1].q)
    assert not np.allclose(a.train[1].q, c.train[1].q)
    # the disk cache returns exactly what was simulated
    d = sc.generate(seed=3, cache=True, **SHORT)
    e = sc.generate(seed=3, cache=True, **SHORT)
    np.testing.assert_array_equal(d.train[0].q, a.train[0].q)
    np.testing.assert_array_equal(e.train[0].qd, a.train[0].qd)


def test_recordings_are_consistent():
    sc = get_scenario("two_segment")
    data = sc.generate(seed=0, cache=False, **SHORT)
    rec = data.train[0]
    T = 30
    assert rec.t.shape == (T,) and rec.q.shape == (T, 6) and rec.tau.shape == (T, 6)
    assert rec.poses.shape == (T, 21, 3)
    np.testing.assert_allclose(np.diff(rec.t), 1e-3)
    # actuation is held for 10 ms
    for k in range(0, T, 10):
        assert np.all(rec.tau[k : k + 10] == rec.tau[k])
    assert not np.allclose(rec.tau[0], rec.tau[10])
    # poses are the forward kinematics of the strains at 21 equally spaced arc lengths
    s = np.linspace(0, 0.17, 21)
    np.testing.assert_allclose(rec.poses, sc.robot.kinematics.forward_kinematics(rec.q, s), atol=1e-14)
    # velocities are consistent with the strains (the simulated state, not a derivative estimate)
    qd_fd = np.gradient(rec.q, rec.t, axis=0)
    assert np.median(np.abs(qd_fd[1:-1] - rec.qd[1:-1])) < 0.05 * np.median(np.abs(rec.qd))


def test_noise_has_the_requested_statistics():
    sc = get_scenario("one_segment")
    sigma_p, sigma_th = 5e-4, np.deg2rad(1.0)
    data = sc.generate(seed=1, noise=(sigma_p, sigma_th), cache=False, n_train=2, train_duration=0.3, validation=False)
    diff = np.concatenate([r.poses - r.poses_true for r in data.train])
    assert np.all(diff[:, 0] == 0), "the base defines the frame and carries no noise"
    assert np.std(diff[:, 1:, :2]) == pytest.approx(sigma_p, rel=0.03)
    assert np.std(diff[:, 1:, 2]) == pytest.approx(sigma_th, rel=0.03)
    seed_noise = sc.generate(seed=1, noise="seed", cache=False, **SHORT)
    assert seed_noise.noise == pytest.approx((5e-4, np.deg2rad(1.0)))
    with pytest.raises(ValueError, match="noise"):
        sc.generate(seed=1, noise="loud", **SHORT)


def test_pac_scenario_gives_500_configurations():
    data = get_scenario("pac_one_segment").generate(seed=0, cache=False)
    assert data.validation is None and len(data.train) == 1
    rec = data.train[0]
    assert rec.q.shape == (500, 4) and rec.poses.shape == (500, 21, 3)
    curvature_tip = rec.q[:, 0] + rec.q[:, 1] * 0.15
    assert np.abs(curvature_tip).max() <= 60.0
    assert np.abs(rec.q[:, 2:]).max() <= 0.3


def test_stiffened_strain_is_driven_like_the_nominal_robot():
    # the same actuation magnitudes as one_segment: the x1000 stiffer shear hardly moves
    nominal = get_scenario("one_segment").generate(seed=2, cache=False, **SHORT)
    stiff = get_scenario("one_segment_stiff_shear").generate(seed=2, cache=False, **SHORT)
    shear = lambda data: max(np.abs(r.q[:, 1]).max() for r in data.train)  # noqa: E731
    bend = lambda data: max(np.abs(r.q[:, 0]).max() for r in data.train)  # noqa: E731
    assert shear(stiff) < 0.01 * shear(nominal)
    assert bend(stiff) > 0.3 * bend(nominal)


def test_validation_stays_inside_the_seed_strain_ranges():
    data = get_scenario("two_segment").generate(
        seed=0, cache=False, n_train=1, train_duration=0.02, validation_duration=2.0
    )
    v = data.validation
    assert v.q.shape == (2000, 6) and v.tau.shape == (2000, 6)
    assert np.all(np.abs(v.q) <= np.tile([60.0, 0.3, 0.3], 2))
    # sinusoidal actuation: every strain is excited
    assert np.all(np.std(v.tau, axis=0) > 0)
