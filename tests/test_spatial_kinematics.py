"""Spatial PCS kinematics against independent truth.

* the planar package (:mod:`pcs_sindy.core.kinematics`) on states in the plane;
* a 40-digit mpmath evaluation that shares nothing with the closed forms: the pose is the matrix
  exponential (``mpmath.expm``) of the 4×4 twist of each segment, Jacobians and velocity products
  are derivatives of it by ``mpmath.diff``;
* round trips and the argument checks.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from pcs_sindy.core import (
    PlanarPCS,
    SpatialPCS,
    forward_kinematics_jacobian,
    planar_to_spatial_pose,
    planar_to_spatial_strains,
    quaternion_to_rotation,
    rotation_to_quaternion,
    se3_compose,
    se3_exp,
    se3_from_matrix,
    se3_inverse,
    se3_log,
    se3_matrix,
    se3_relative,
    spatial_to_planar_strains,
    tangent_coefficients,
)

DPS = 40


# --------------------------------------------------------------------------
# the independent route: 4x4 matrix exponentials at 40 digits
# --------------------------------------------------------------------------
def twist_matrix(q6):
    """4×4 twist ξ^ of one segment's strains, from the conventions (not from the package)."""
    kz, kx, ky, sx, sz, sy = q6
    w = (kx, ky, kz)
    v = (sx, 1 + sy, sz)
    return mp.matrix(
        [
            [0, -w[2], w[1], v[0]],
            [w[2], 0, -w[0], v[1]],
            [-w[1], w[0], 0, v[2]],
            [0, 0, 0, 0],
        ]
    )


def mp_poses(q, lengths, s_points, base=None):
    """Stacked mp column: for every point, its position (3) then rotation (9, row-major)."""
    m = len(lengths)
    bounds = [mp.mpf(0)]
    for L in lengths:
        bounds.append(bounds[-1] + mp.mpf(L))
    seg = [twist_matrix([q[6 * i + k] for k in range(6)]) for i in range(m)]
    ends = []
    g = mp.eye(4) if base is None else base
    for i in range(m):
        ends.append(g)
        g = g * mp.expm(mp.mpf(lengths[i]) * seg[i])
    out = []
    for s in s_points:
        s = mp.mpf(s)
        i = min(max(k for k in range(m) if bounds[k] <= s), m - 1)
        gi = ends[i] * mp.expm((s - bounds[i]) * seg[i])
        out += [gi[r, 3] for r in range(3)] + [gi[r, c] for r in range(3) for c in range(3)]
    return mp.matrix(out)


def unpack(col, K):
    arr = np.array([float(x) for x in col]).reshape(K, 12)
    return arr[:, :3], arr[:, 3:].reshape(K, 3, 3)


def mp_rotation(col, k):
    return mp.matrix([[col[12 * k + 3 + 3 * r + c] for c in range(3)] for r in range(3)])


def vee(S):
    return [S[2, 1], S[0, 2], S[1, 0]]


def mp_reference(q, qd, lengths, s_points):
    """FK, J_p, J_w (body), J̇_p q̇ and J̇_w q̇ at 40 digits."""
    with mp.workdps(DPS):
        q = [mp.mpf(float(x)) for x in q]
        qd = [mp.mpf(float(x)) for x in qd]
        n, K = len(q), len(s_points)

        def F(x):
            return mp_poses(x, lengths, s_points)

        base = F(q)
        Jp = np.zeros((K, 3, n))
        Jw = np.zeros((K, 3, n))
        for c in range(n):
            d = mp.diff(lambda t, c=c: F([q[i] + (t if i == c else 0) for i in range(n)]), 0)
            for k in range(K):
                Jp[k, :, c] = [float(d[12 * k + r]) for r in range(3)]
                Jw[k, :, c] = [float(x) for x in vee(mp_rotation(base, k).T * mp_rotation(d, k))]
        line = lambda t: F([q[i] + t * qd[i] for i in range(n)])  # noqa: E731 - q(t) = q + t q̇, q̈ = 0
        dd = mp.diff(line, 0, 2)
        acc = np.zeros((K, 3))
        ang = np.zeros((K, 3))
        for k in range(K):
            acc[k] = [float(dd[12 * k + r]) for r in range(3)]
            # ω̇_b = vee of the skew part of Rᵀ R̈ (Ṙᵀ Ṙ is symmetric)
            S = mp_rotation(base, k).T * mp_rotation(dd, k)
            ang[k] = [float(x) for x in vee((S - S.T) / 2)]
        p, R = unpack(base, K)
        return p, R, Jp, Jw, acc, ang


def random_state(rng, magnitude, m):
    """Strains of m segments: bending/twist of the given norm in a random direction, shear/axial random."""
    q = np.zeros((m, 6))
    for i in range(m):
        d = rng.normal(size=3)
        q[i, :3] = magnitude * d / np.linalg.norm(d)
        q[i, 3:] = rng.uniform(-1, 1, 3) * min(0.2, magnitude)
    qd = rng.normal(size=(m, 6)) * np.array([5.0, 5.0, 5.0, 0.1, 0.1, 0.1])
    return q.reshape(-1), qd.reshape(-1)


def rel_err(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


@pytest.mark.parametrize("magnitude", [0.0, 1e-9, 1e-7, 1e-5, 1e-3, 0.1, 1.0, 10.0, 40.0])
def test_against_matrix_exponential_at_40_digits(magnitude):
    rng = np.random.default_rng(int(magnitude * 1e3) % 1000 + 7)
    lengths = [0.1, 0.13]
    robot = SpatialPCS(lengths)
    q, qd = random_state(rng, magnitude, 2)
    s = np.array([0.0, 0.037, 0.1, 0.16, 0.23])
    p_ref, R_ref, Jp_ref, Jw_ref, acc_ref, ang_ref = mp_reference(q, qd, lengths, s)
    p, R, Jp, Jw = robot.jacobian(q, s)
    acc, ang = robot.velocity_products(q, qd, s)
    assert rel_err(p, p_ref) <= 1e-12
    assert np.abs(R - R_ref).max() <= 1e-12
    p2, R2 = robot.forward_kinematics(q, s)
    np.testing.assert_array_equal(p2, p)
    np.testing.assert_array_equal(R2, R)
    assert rel_err(Jp, Jp_ref) <= 1e-10
    assert rel_err(Jw, Jw_ref) <= 1e-10
    assert rel_err(acc, acc_ref) <= 1e-10
    assert rel_err(ang, ang_ref) <= 1e-10
    v, w = robot.velocities(q, qd, s)
    np.testing.assert_allclose(v, Jp_ref @ qd, rtol=0, atol=1e-10 * np.abs(Jp_ref @ qd).max())
    np.testing.assert_allclose(w, Jw_ref @ qd, rtol=0, atol=1e-10 * np.abs(Jw_ref @ qd).max())


def test_batches_of_states_match_single_states():
    rng = np.random.default_rng(3)
    robot = SpatialPCS([0.1, 0.1])
    Q = rng.normal(size=(4, 12)) * 5
    QD = rng.normal(size=(4, 12))
    s = np.linspace(0, 0.2, 6)
    p, R, Jp, Jw = robot.jacobian(Q, s)
    acc, ang = robot.velocity_products(Q, QD, s)
    assert p.shape == (4, 6, 3) and R.shape == (4, 6, 3, 3) and Jp.shape == Jw.shape == (4, 6, 3, 12)
    for t in range(4):
        one = robot.jacobian(Q[t], s)
        for a, b in zip(one, (p, R, Jp, Jw), strict=True):
            np.testing.assert_allclose(a, b[t], rtol=0, atol=1e-15)
        one = robot.velocity_products(Q[t], QD[t], s)
        np.testing.assert_allclose(one[0], acc[t], rtol=0, atol=1e-14)
        np.testing.assert_allclose(one[1], ang[t], rtol=0, atol=1e-14)


# --------------------------------------------------------------------------
# the scalar functions: series and closed forms meet without loss
# --------------------------------------------------------------------------
MP_FUNCTIONS = {
    "a": lambda u: mp.sin(u) / u,
    "b": lambda u: (1 - mp.cos(u)) / u**2,
    "c": lambda u: (u - mp.sin(u)) / u**3,
    "b1": lambda u: (u * mp.sin(u) + 2 * mp.cos(u) - 2) / u**4,
    "c1": lambda u: -(u * mp.cos(u) + 2 * u - 3 * mp.sin(u)) / u**5,
    "b2": lambda u: (u**2 * mp.cos(u) - 5 * u * mp.sin(u) - 8 * mp.cos(u) + 8) / u**6,
    "c2": lambda u: (u**2 * mp.sin(u) + 7 * u * mp.cos(u) + 8 * u - 15 * mp.sin(u)) / u**7,
}
#: bounds of the terms of each closed form: the scale of an oscillating function far from 0 (where it has zeros)
ENVELOPES = {
    "a": lambda u: 1 / u,
    "b": lambda u: 4 / u**2,
    "c": lambda u: (u + 1) / u**3,
    "b1": lambda u: (u + 4) / u**4,
    "c1": lambda u: (3 * u + 3) / u**5,
    "b2": lambda u: (u**2 + 5 * u + 16) / u**6,
    "c2": lambda u: (u**2 + 15 * u + 15) / u**7,
}


def test_tangent_coefficients_accurate_at_every_magnitude_and_at_the_switches():
    u = np.concatenate(
        [
            [0.0, 1e-12, 1e-8, 1e-4, 1e-2],
            0.5 * (1 + np.array([-1e-13, 0, 1e-13])),  # switch of a, b
            3.0 * (1 + np.array([-1e-13, 0, 1e-13])),  # switch of c, b1, c1, b2, c2
            np.linspace(0.1, 12.0, 120),
            [30.0, 100.0, 1e3],
        ]
    )
    got = dict(zip(MP_FUNCTIONS, tangent_coefficients(u, 2), strict=True))
    with mp.workdps(150):  # the closed forms lose up to 7 |log10 u| digits to cancellation: 150 leave > 40
        for name, f in MP_FUNCTIONS.items():
            # the exact value: the closed form at 150 digits, its limit at 0
            ref = np.array([float(f(mp.mpf(x))) if x > 0 else float(mp.limit(f, 0)) for x in u])
            # relative error; beyond u = 3, where these functions oscillate through zeros, relative to their envelope
            scale = np.where(u > 3.0, np.maximum(np.abs(ref), ENVELOPES[name](np.maximum(u, 1.0))), np.abs(ref))
            err = np.abs(got[name] - ref) / scale
            assert err.max() <= 2e-15, (name, u[np.argmax(err)], err.max())
    # even functions, and the documented arities
    np.testing.assert_array_equal(tangent_coefficients(-u, 2)[6], got["c2"])
    assert len(tangent_coefficients(u)) == 3 and len(tangent_coefficients(u, 1)) == 5
    with pytest.raises(ValueError, match="order"):
        tangent_coefficients(u, 3)


# --------------------------------------------------------------------------
# the planar restriction
# --------------------------------------------------------------------------
@pytest.mark.parametrize("kappa_scale", [0.0, 1e-8, 1.0, 40.0])
def test_planar_states_reproduce_the_planar_package(kappa_scale):
    rng = np.random.default_rng(11)
    lengths = [0.1, 0.08, 0.12]
    base = (0.01, -0.02, 0.3)
    planar = PlanarPCS(tuple(lengths), base_pose=base)
    spatial = SpatialPCS.from_planar(planar)
    q3 = rng.normal(size=(5, 9)) * np.array([kappa_scale, 0.1, 0.1] * 3)
    q6 = planar_to_spatial_strains(q3)
    s = np.linspace(0.0, planar.total_length, 11)
    pose, J = forward_kinematics_jacobian(q3, lengths, s, base)
    p, R, Jp, Jw = spatial.jacobian(q6, s)
    p_ref, R_ref = planar_to_spatial_pose(pose)
    np.testing.assert_allclose(p, p_ref, rtol=0, atol=1e-12 * np.abs(p_ref).max())
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-12)
    planar_cols = np.array([[6 * i, 6 * i + 3, 6 * i + 5] for i in range(3)]).reshape(-1)
    other_cols = np.setdiff1d(np.arange(18), planar_cols)
    scale = np.abs(J).max()
    np.testing.assert_allclose(Jp[..., :2, planar_cols], J[..., :2, :], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(Jw[..., 2, planar_cols], J[..., 2, :], rtol=0, atol=1e-12 * scale)
    # in the plane, planar strains neither lift the backbone nor tilt the cross-section out of the plane
    assert np.abs(Jp[..., 2, planar_cols]).max() <= 1e-15 and np.abs(Jw[..., :2, planar_cols]).max() <= 1e-15
    # out-of-plane strains move the backbone only out of the plane (at first order)
    assert np.abs(Jp[..., :2, other_cols]).max() <= 1e-14 * scale
    back = spatial.to_planar()
    assert back.segment_lengths == planar.segment_lengths
    np.testing.assert_allclose(back.base_pose, planar.base_pose, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(back.active_strains, planar.active_strains)
    assert SpatialPCS.from_planar(back) == spatial
    np.testing.assert_array_equal(spatial_to_planar_strains(q6), q3)


def test_planar_velocity_products_against_planar_finite_differences_of_the_planar_jacobian():
    # J̇_p q̇ of the planar package, by a central difference of its (exact) Jacobian along q̇
    rng = np.random.default_rng(5)
    lengths = [0.1, 0.1]
    q3, qd3 = rng.normal(size=6) * np.array([8, 0.1, 0.1] * 2), rng.normal(size=6)
    s = np.linspace(0, 0.2, 5)
    h = 1e-6
    Jp = [forward_kinematics_jacobian(q3 + k * h * qd3, lengths, s)[1] for k in (1, -1)]
    ref = (Jp[0] - Jp[1]) @ qd3 / (2 * h)
    acc, ang = SpatialPCS(lengths).velocity_products(planar_to_spatial_strains(q3), planar_to_spatial_strains(qd3), s)
    np.testing.assert_allclose(acc[:, :2], ref[:, :2], rtol=0, atol=1e-7 * np.abs(ref).max())
    assert np.abs(acc[:, 2]).max() <= 1e-15
    np.testing.assert_allclose(ang, 0.0, atol=1e-15)  # planar angular velocity ∝ q̇ only


# --------------------------------------------------------------------------
# round trips
# --------------------------------------------------------------------------
@pytest.mark.parametrize("magnitude", [0.0, 1e-9, 1e-5, 0.1, 1.0, 10.0, 25.0])
def test_exp_log_round_trip(magnitude):
    rng = np.random.default_rng(2)
    q = rng.normal(size=(20, 6))
    q[:, :3] *= magnitude / np.linalg.norm(q[:, :3], axis=1, keepdims=True)
    q[:, 3:] *= 0.1
    s = rng.uniform(0.05, 0.12, 20)  # |s ω| < 3 < π: the principal logarithm
    p, R = se3_exp(q, s)
    back = se3_log(p, R, s)
    scale = np.maximum(np.abs(q), 1.0)
    assert (np.abs(back - q) / scale).max() <= 1e-13
    if magnitude == 0.0:
        # exactly straight: no spurious bending from the logarithm
        np.testing.assert_array_equal(back[:, :3], 0.0)
    # the rotation is orthonormal to round-off
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=2e-15)


def test_exp_of_a_pure_bend_is_an_arc():
    # closed form of a circular arc about body z (the planar formula), no shear: independent truth
    k, s = 7.0, 0.1
    p, R = se3_exp([k, 0, 0, 0, 0, 0], s)
    np.testing.assert_allclose(p, [(np.cos(k * s) - 1) / k, np.sin(k * s) / k, 0.0], rtol=0, atol=1e-16)
    # a pure twist leaves the backbone straight and turns the section about y
    p, R = se3_exp([0, 0, 5.0, 0, 0, 0.1], 0.2)
    np.testing.assert_allclose(p, [0, 0.22, 0], atol=1e-16)
    np.testing.assert_allclose(R[[0, 2]][:, [0, 2]], [[np.cos(1.0), np.sin(1.0)], [-np.sin(1.0), np.cos(1.0)]])


def test_compose_inverse_relative_and_matrices():
    rng = np.random.default_rng(8)
    pa, Ra = se3_exp(rng.normal(size=(6, 6)) * 5, 0.3)
    pb, Rb = se3_exp(rng.normal(size=(6, 6)) * 5, 0.2)
    Ha, Hb = se3_matrix(pa, Ra), se3_matrix(pb, Rb)
    pc, Rc = se3_compose(pa, Ra, pb, Rb)
    np.testing.assert_allclose(se3_matrix(pc, Rc), Ha @ Hb, atol=1e-15)
    pi, Ri = se3_inverse(pa, Ra)
    np.testing.assert_allclose(se3_matrix(pi, Ri), np.linalg.inv(Ha), atol=1e-14)
    pr, Rr = se3_relative(pa, Ra, pc, Rc)
    np.testing.assert_allclose(pr, pb, atol=1e-15)
    np.testing.assert_allclose(Rr, Rb, atol=1e-15)
    back = se3_from_matrix(Ha)
    np.testing.assert_array_equal(back[0], pa)
    np.testing.assert_array_equal(back[1], Ra)


def test_quaternions_scalar_last_by_default():
    th = 0.7
    xyzw = [0.0, 0.0, np.sin(th / 2), np.cos(th / 2)]
    Rz = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
    np.testing.assert_allclose(quaternion_to_rotation(xyzw), Rz, atol=1e-15)
    np.testing.assert_allclose(quaternion_to_rotation(np.roll(xyzw, 1), scalar_first=True), Rz, atol=1e-15)
    np.testing.assert_allclose(quaternion_to_rotation(np.multiply(xyzw, 3.0)), Rz, atol=1e-15)  # normalised
    np.testing.assert_allclose(rotation_to_quaternion(Rz), xyzw, atol=1e-15)
    np.testing.assert_allclose(rotation_to_quaternion(Rz, scalar_first=True), np.roll(xyzw, 1), atol=1e-15)
    rng = np.random.default_rng(1)
    _, R = se3_exp(rng.normal(size=(3, 4, 6)) * 10, 0.2)
    quat = rotation_to_quaternion(R)
    assert quat.shape == (3, 4, 4) and np.all(quat[..., 3] >= 0)
    np.testing.assert_allclose(quaternion_to_rotation(quat), R, atol=2e-15)


@pytest.mark.parametrize("magnitude", [0.0, 1e-9, 1e-3, 1.0, 20.0])
def test_inverse_kinematics_of_forward_kinematics(magnitude):
    rng = np.random.default_rng(4)
    _, base_R = se3_exp(rng.normal(size=6), 1.0)
    robot = SpatialPCS([0.1, 0.12, 0.09], base_position=(0.1, 0.2, -0.3), base_rotation=base_R)
    q = np.stack([random_state(rng, magnitude, 3)[0] for _ in range(4)])
    p, R = robot.forward_kinematics(q, robot.boundaries)
    back = robot.inverse_kinematics(p, R)
    assert np.abs(back - q).max() <= 1e-12 * max(1.0, magnitude)
    # with the base given as the first pose
    pb, Rb = robot.forward_kinematics(q, np.concatenate([[0.0], robot.boundaries]))
    np.testing.assert_allclose(robot.inverse_kinematics(pb, Rb), back, atol=1e-12 * max(1.0, magnitude))


def test_active_strains_and_names():
    robot = SpatialPCS([0.1, 0.2], active_strains=[[1, 0, 0, 1, 0, 1], [1, 1, 1, 0, 0, 0]])
    assert robot.n_q == 12 and robot.n_active == 6
    assert robot.strain_names(active_only=True) == [
        "bend_z_1",
        "shear_x_1",
        "axial_1",
        "bend_z_2",
        "bend_x_2",
        "twist_2",
    ]
    qa = np.arange(1.0, 7.0)
    full = robot.to_full(qa)
    np.testing.assert_array_equal(full, [1, 0, 0, 2, 0, 3, 4, 5, 6, 0, 0, 0])
    np.testing.assert_array_equal(robot.to_active(full), qa)
    with pytest.raises(ValueError, match="to_planar"):
        robot.to_planar()


# --------------------------------------------------------------------------
# errors name the argument
# --------------------------------------------------------------------------
def test_errors_name_the_argument():
    robot = SpatialPCS([0.1, 0.1])
    s = [0.0, 0.1]
    with pytest.raises(ValueError, match=r"q must have a last axis of length 6 \* n_segments = 12"):
        robot.forward_kinematics(np.zeros(6), s)
    with pytest.raises(ValueError, match="q contains NaN"):
        robot.jacobian(np.full(12, np.nan), s)
    with pytest.raises(ValueError, match="qd must have the shape of q"):
        robot.velocity_products(np.zeros((2, 12)), np.zeros(12), s)
    with pytest.raises(ValueError, match="qd contains NaN"):
        robot.velocity_products(np.zeros(12), np.full(12, np.inf), s)
    with pytest.raises(ValueError, match=r"s must lie in \[0, 0.2\]"):
        robot.forward_kinematics(np.zeros(12), [0.3])
    with pytest.raises(ValueError, match="s must be 1-D"):
        robot.forward_kinematics(np.zeros(12), [[0.1]])
    with pytest.raises(ValueError, match="segment_lengths must be finite and > 0"):
        SpatialPCS([0.1, -0.1])
    with pytest.raises(ValueError, match=r"active_strains must have shape \(2, 6\)"):
        SpatialPCS([0.1, 0.1], active_strains=np.ones((2, 3), dtype=bool))
    with pytest.raises(ValueError, match="base_rotation must be a rotation matrix"):
        SpatialPCS([0.1], base_rotation=2 * np.eye(3))
    with pytest.raises(ValueError, match="base_position must be 3 finite numbers"):
        SpatialPCS([0.1], base_position=(0, np.nan, 0))
    with pytest.raises(ValueError, match="rotation must have trailing shape"):
        se3_log(np.zeros(3), np.eye(4), 0.1)
    with pytest.raises(ValueError, match="position contains NaN"):
        se3_log([np.nan, 0, 0], np.eye(3), 0.1)
    with pytest.raises(ValueError, match="segment length"):
        se3_log(np.zeros(3), np.eye(3), 0.0)
    with pytest.raises(ValueError, match="q must have a last axis of length 6"):
        se3_exp(np.zeros(5), 0.1)
    with pytest.raises(ValueError, match="quaternion has zero norm"):
        quaternion_to_rotation(np.zeros(4))
    with pytest.raises(ValueError, match="positions must have shape"):
        robot.inverse_kinematics(np.zeros((4, 3)), np.zeros((4, 3, 3)))
    with pytest.raises(ValueError, match="rotations must have shape"):
        robot.inverse_kinematics(np.zeros((2, 3)), np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="q_active must have a last axis of length 12"):
        robot.to_full(np.zeros(3))
    with pytest.raises(ValueError, match="out-of-plane strains"):
        spatial_to_planar_strains(np.eye(6)[1])
