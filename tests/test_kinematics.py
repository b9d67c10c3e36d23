"""Kinematics: closed forms against direct integration, exactness at zero curvature, round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from pcs_sindy.core import (
    PlanarPCS,
    forward_kinematics,
    forward_kinematics_jacobian,
    se2_compose,
    se2_from_matrix,
    se2_inverse,
    se2_matrix,
    se2_relative,
    segment_inverse_kinematics,
    segment_pose,
)
from pcs_sindy.core.kinematics import cosc, cosc_prime, half_cot, sinc, sinc_prime

strain = st.tuples(
    st.one_of(st.just(0.0), st.floats(-60.0, 60.0)),
    st.floats(-0.3, 0.3),
    st.floats(-0.3, 0.3),
)


def integrate_backbone(q_stack, lengths, s_eval):
    """Independent truth: integrate dθ/ds = κ, dp/ds = R(θ)[σ_sh, 1 + σ_ax] with an ODE solver."""
    bounds = np.concatenate([[0.0], np.cumsum(lengths)])

    def rhs(s, y):
        i = min(np.searchsorted(bounds, s, side="right") - 1, len(lengths) - 1)
        k, sh, ax = q_stack[3 * i : 3 * i + 3]
        th = y[2]
        return [np.cos(th) * sh - np.sin(th) * (1 + ax), np.sin(th) * sh + np.cos(th) * (1 + ax), k]

    out = solve_ivp(
        rhs,
        (0, bounds[-1]),
        [0.0, 0.0, 0.0],
        t_eval=s_eval,
        rtol=1e-12,
        atol=1e-14,
        method="DOP853",
        max_step=min(lengths) / 50,
    )
    return out.y.T


def test_scalar_functions_exact_at_zero_and_smooth():
    assert sinc(0.0) == 1.0 and cosc(0.0) == 0.0 and half_cot(0.0) == 1.0
    u = np.array([1e-9, 1e-5, 0.05, 0.5, 2.0, -3.0])
    np.testing.assert_allclose(sinc(u), np.sin(u) / u, rtol=1e-14)
    np.testing.assert_allclose(cosc(u[2:]), (1 - np.cos(u[2:])) / u[2:], rtol=1e-12)
    np.testing.assert_allclose(cosc(u[:2]), u[:2] / 2, rtol=1e-6)
    np.testing.assert_allclose(half_cot(u[2:]), (u[2:] / 2) / np.tan(u[2:] / 2), rtol=1e-12)


@pytest.mark.parametrize("func, prime", [(sinc, sinc_prime), (cosc, cosc_prime)])
def test_derivative_series_match_closed_form_and_finite_differences(func, prime):
    # both sides of the switch between series and closed form
    u = np.array([-0.3, -0.1000001, -0.0999999, -1e-3, 0.0, 1e-6, 0.05, 0.0999999, 0.1000001, 1.0, 3.0])
    h = 1e-6
    fd = (func(u + h) - func(u - h)) / (2 * h)
    np.testing.assert_allclose(prime(u), fd, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(q=strain, s=st.floats(0.01, 0.2))
def test_segment_fk_ik_round_trip(q, s):
    q = np.array(q)
    pose = segment_pose(q, s)
    np.testing.assert_allclose(segment_inverse_kinematics(pose, s), q, atol=1e-10, rtol=0)


def test_zero_curvature_limits_are_exact():
    s = 0.1
    pose = segment_pose(np.array([0.0, 0.2, -0.1]), s)
    np.testing.assert_array_equal(pose, [0.2 * s, 0.9 * s, 0.0])
    q = segment_inverse_kinematics(np.array([0.01, 0.12, 0.0]), s)
    np.testing.assert_allclose(q, [0.0, 0.1, 0.2], atol=1e-15)
    # continuity through kappa = 0: no epsilon means tiny curvature gives tiny differences
    near = segment_pose(np.array([1e-9, 0.2, -0.1]), s)
    np.testing.assert_allclose(near, pose, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "lengths, q",
    [
        ([0.1], [37.0, 0.1, -0.2]),
        ([0.1], [0.0, -0.25, 0.3]),
        ([0.07, 0.1], [20.0, 0.05, 0.1, -45.0, -0.2, 0.05]),
        ([0.05, 0.1, 0.06], [10.0, 0.0, 0.0, 0.0, 0.3, -0.1, -60.0, 0.1, 0.2]),
    ],
)
def test_forward_kinematics_matches_integrated_backbone(lengths, q):
    s = np.linspace(0, sum(lengths), 23)
    expected = integrate_backbone(np.array(q), np.array(lengths), s)
    np.testing.assert_allclose(forward_kinematics(q, lengths, s), expected, atol=1e-9)


def test_rest_configuration_lies_along_plus_y():
    s = np.linspace(0, 0.17, 5)
    poses = forward_kinematics(np.zeros(6), [0.07, 0.1], s)
    np.testing.assert_allclose(poses, np.column_stack([0 * s, s, 0 * s]), atol=0)


def test_positive_bending_turns_counter_clockwise():
    tip = forward_kinematics([10.0, 0.0, 0.0], [0.1], [0.1])[0]
    assert tip[2] > 0 and tip[0] < 0  # θ CCW from +y moves the tip towards -x


@settings(max_examples=60, deadline=None)
@given(q1=strain, q2=strain, q3=strain)
def test_multi_segment_ik_round_trip(q1, q2, q3):
    pcs = PlanarPCS((0.05, 0.1, 0.06))
    q = np.concatenate([q1, q2, q3])
    ends = pcs.forward_kinematics(q, pcs.boundaries)
    np.testing.assert_allclose(pcs.inverse_kinematics(ends), q, atol=1e-10, rtol=0)


def test_vectorised_over_time_and_points():
    rng = np.random.default_rng(1)
    q = rng.uniform(-1, 1, (7, 6)) * [60, 0.3, 0.3, 60, 0.3, 0.3]
    s = np.linspace(0, 0.17, 9)
    batched = forward_kinematics(q, [0.07, 0.1], s)
    assert batched.shape == (7, 9, 3)
    for k in range(7):
        np.testing.assert_allclose(batched[k], forward_kinematics(q[k], [0.07, 0.1], s), atol=0)


def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(2)
    lengths = [0.05, 0.1, 0.06]
    q = rng.uniform(-1, 1, (4, 9)) * np.tile([60, 0.3, 0.3], 3)
    q[0, [0, 3, 6]] = 0.0  # straight segments
    q[1, 3] = 1e-3  # series branch
    s = np.linspace(0, 0.21, 15)
    pose, jac = forward_kinematics_jacobian(q, lengths, s)
    np.testing.assert_allclose(pose, forward_kinematics(q, lengths, s), atol=1e-15)
    scale = np.tile([1.0, 1e-3, 1e-3], 3) * 1e-4
    fd = np.empty_like(jac)
    for k in range(9):
        dq = np.zeros(9)
        dq[k] = scale[k]
        fd[..., k] = (forward_kinematics(q + dq, lengths, s) - forward_kinematics(q - dq, lengths, s)) / (2 * scale[k])
    np.testing.assert_allclose(jac, fd, atol=1e-7)


def test_se2_algebra_matches_matrices():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(5, 3))
    b = rng.normal(size=(5, 3))
    composed = se2_matrix(a) @ se2_matrix(b)
    c = se2_compose(a, b)
    np.testing.assert_allclose(se2_matrix(c), composed, atol=1e-12)
    np.testing.assert_allclose(se2_matrix(se2_inverse(a)), np.linalg.inv(se2_matrix(a)), atol=1e-12)
    rel = se2_relative(a, b)
    np.testing.assert_allclose(se2_matrix(rel), np.linalg.inv(se2_matrix(a)) @ se2_matrix(b), atol=1e-12)
    np.testing.assert_allclose(se2_from_matrix(se2_matrix(a))[:, :2], a[:, :2])


def test_planar_pcs_masks_and_names():
    pcs = PlanarPCS((0.1, 0.2), active_strains=[[True, False, True], [True, True, True]])
    assert pcs.n_q == 6 and pcs.n_active == 5
    assert pcs.strain_names(active_only=True) == ["be_1", "ax_1", "be_2", "sh_2", "ax_2"]
    qa = np.arange(5.0)
    full = pcs.to_full(qa)
    assert full[1] == 0 and np.array_equal(pcs.to_active(full), qa)
    np.testing.assert_allclose(pcs.marker_arc_lengths(4), [0, 0.075, 0.15, 0.225, 0.3])


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: PlanarPCS((0.1, -0.2)), "segment_lengths"),
        (lambda: PlanarPCS((0.1,), active_strains=[True, False]), "active_strains"),
        (lambda: forward_kinematics([0, 0], [0.1], [0.05]), "q must have"),
        (lambda: forward_kinematics([np.nan, 0, 0], [0.1], [0.05]), "NaN"),
        (lambda: forward_kinematics([0, 0, 0], [0.1], [0.2]), "arc lengths"),
        (lambda: segment_inverse_kinematics([0, 0.1, 0], 0.0), "segment length"),
    ],
)
def test_bad_input_is_named(call, match):
    with pytest.raises(ValueError, match=match):
        call()
