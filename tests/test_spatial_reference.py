"""Checks of the extended-precision spatial reference (tests/spatial_reference.py) against independent truth.

The reference is the oracle the package's spatial dynamics are tested against, so it is itself checked
here against: the planar package (an independent implementation: closed-form Jacobians and Christoffel
symbols) on planar states, closed forms at the straight configuration, the exact symmetries of an
isotropic rod (rotation about the gravity axis, a twist offset of a straight segment), the passivity
identity, and its own convergence in the working precision.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from spatial_reference import reference_accelerations, reference_pose, reference_terms

from pcs_sindy.core.kinematics import forward_kinematics
from pcs_sindy.simulation import PCSRobot

RHO, RADIUS = 1070.0, 0.02
AREA, SECOND = np.pi * RADIUS**2, np.pi * RADIUS**4 / 4
TERMS = ("M", "coriolis", "gravity", "elastic", "damping")


def _material(m: int) -> dict:
    return dict(
        rho=RHO,
        radius=RADIUS,
        youngs=np.linspace(1e5, 2e5, m),
        shear=np.linspace(3e4, 5e4, m),
        damping=np.linspace(1e-3, 4e-3, 6 * m),
    )


def _planar_index(m: int) -> np.ndarray:
    return np.concatenate([[6 * i, 6 * i + 3, 6 * i + 5] for i in range(m)])


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(np.asarray(b))))


def _general_state(m: int, seed: int, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Every strain nonzero: bending/twist O(scale) 1/m, shear/axial O(0.05 scale)."""
    rng = np.random.default_rng(seed)
    amp = np.tile([4.0, 4.0, 4.0, 0.05, 0.05, 0.05], m) * scale
    return rng.uniform(-1, 1, 6 * m) * amp, rng.uniform(-1, 1, 6 * m) * np.tile([3, 3, 3, 0.3, 0.3, 0.3], m)


# --------------------------------------------------------------------------
# planar restriction: the planar package is a second, independent implementation
# --------------------------------------------------------------------------
def test_planar_states_reproduce_the_planar_simulator():
    L = [0.1, 0.13]
    m, n = 2, 12
    idx = _planar_index(m)
    rng = np.random.default_rng(3)
    qp = rng.uniform(-1, 1, 3 * m) * np.tile([9.0, 0.1, 0.1], m)
    qdp = rng.uniform(-1, 1, 3 * m) * np.tile([5.0, 0.5, 0.5], m)
    mat = _material(m)
    robot = PCSRobot(L, RHO, mat["youngs"], mat["shear"], mat["damping"][idx], radius=RADIUS, n_quadrature=8)
    q, qd = np.zeros(n), np.zeros(n)
    q[idx], qd[idx] = qp, qdp
    # out-of-plane damping must not leak into the plane either
    ref = reference_terms(q, qd, L, **mat, n_quadrature=8, dps=20)
    want = {
        "M": robot.mass_matrix(qp),
        "coriolis": robot.coriolis_forces(qp, qdp),
        "gravity": robot.gravity_forces(qp),
        "elastic": robot.elastic_forces(qp),
        "damping": robot.damping_forces(qdp),
    }
    for name in TERMS:
        got = ref[name][np.ix_(idx, idx)] if name == "M" else ref[name][idx]
        assert _rel(got, want[name]) <= 1e-9, name
    out = np.setdiff1d(np.arange(n), idx)
    # the planar strains do not couple to the out-of-plane ones, and the plane is an invariant set
    assert np.max(np.abs(ref["M"][np.ix_(idx, out)])) <= 1e-12 * np.max(np.abs(want["M"]))
    for name in ("coriolis", "gravity"):
        assert np.max(np.abs(ref[name][out])) <= 1e-12 * np.max(np.abs(want[name])), name


def test_planar_accelerations_and_poses_match_the_planar_package():
    L = [0.12]
    idx = _planar_index(1)
    qp, qdp, taup = np.array([7.0, -0.08, 0.06]), np.array([-4.0, 0.3, -0.2]), np.array([1e-3, -2e-2, 3e-2])
    mat = _material(1)
    robot = PCSRobot(L, RHO, mat["youngs"], mat["shear"], mat["damping"][idx], radius=RADIUS, n_quadrature=8)
    q, qd, tau = np.zeros(6), np.zeros(6), np.zeros(6)
    q[idx], qd[idx], tau[idx] = qp, qdp, taup
    qdd = reference_accelerations(q, qd, tau, L, **mat, n_quadrature=8, dps=20)
    assert _rel(qdd[idx], robot.forward_dynamics(qp, qdp, taup)) <= 1e-9
    assert np.max(np.abs(np.delete(qdd, idx))) <= 1e-12 * np.max(np.abs(qdd))

    L2, q2 = [0.1, 0.15], np.array([6.0, 0.05, -0.04, -8.0, -0.1, 0.08])
    q6 = np.zeros(12)
    q6[_planar_index(2)] = q2
    for s in (0.0, 0.04, 0.1, 0.19, 0.25):
        x, y, theta = forward_kinematics(q2, L2, [s])[0]
        p, R = reference_pose(q6, L2, s, dps=20)
        np.testing.assert_allclose(p, [x, y, 0.0], rtol=0, atol=1e-14)
        c, sn = np.cos(theta), np.sin(theta)
        np.testing.assert_allclose(R, [[c, -sn, 0], [sn, c, 0], [0, 0, 1]], rtol=0, atol=1e-14)


# --------------------------------------------------------------------------
# closed forms
# --------------------------------------------------------------------------
@pytest.mark.parametrize("length_scaled", [False, True])
def test_elastic_and_damping_forces(length_scaled):
    Ls, E, G, r, c_sh = [0.1, 0.2], np.array([1e5, 3e5]), np.array([2e4, 4e4]), np.array([0.02, 0.01]), 1.2
    q, qd = _general_state(2, seed=6)
    damping = np.linspace(0.1, 1.2, 12)
    ref = reference_terms(q, qd, Ls, rho=RHO, radius=r, youngs=E, shear=G, damping=damping, c_sh=c_sh,
                          length_scaled=length_scaled, n_quadrature=1, dps=15)
    A, I = np.pi * r**2, np.pi * r**4 / 4
    f = np.asarray(Ls) if length_scaled else np.ones(2)
    K = np.concatenate([f[i] * np.array([E[i] * I[i], E[i] * I[i], G[i] * 2 * I[i], c_sh * G[i] * A[i],
                                         c_sh * G[i] * A[i], E[i] * A[i]]) for i in range(2)])
    np.testing.assert_allclose(ref["elastic"], K * q, rtol=1e-15)
    np.testing.assert_allclose(ref["damping"], damping * qd, rtol=1e-15)


def test_poses_of_pure_strain_modes():
    L, k = [0.2], 7.0
    # bending about body x: a circle in the y-z plane, curving towards +z
    p, R = reference_pose([0, k, 0, 0, 0, 0], L, 0.15, dps=20)
    a = 0.15 * k
    np.testing.assert_allclose(p, [0, np.sin(a) / k, (1 - np.cos(a)) / k], rtol=0, atol=1e-15)
    np.testing.assert_allclose(R, [[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]], atol=1e-15)
    # torsion only: straight, the cross-section turns about y
    p, R = reference_pose([0, 0, k, 0, 0, 0.1], L, 0.15, dps=20)
    np.testing.assert_allclose(p, [0, 0.15 * 1.1, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(R, [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]], atol=1e-15)
    # shears and stretch only: a straight, sheared line
    p, R = reference_pose([0, 0, 0, 0.1, -0.2, 0.3], L, 0.15, dps=20)
    np.testing.assert_allclose(p, 0.15 * np.array([0.1, 1.3, -0.2]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-15)


def _straight_jacobians(L, s_global):
    """Translational and body-angular Jacobians (3, 6m) of the straight, unstretched robot at arc s.

    At q = 0, a strain perturbation (dω, dv) of segment j rotates it by σ dω after σ of its length and
    moves it by σ²/2 dω × e_y + σ dv; the rest of the robot follows rigidly.
    """
    L = np.asarray(L, float)
    ends = np.cumsum(L)
    ey = np.array([0.0, 1.0, 0.0])
    Jp, Jw = np.zeros((3, 6 * L.size)), np.zeros((3, 6 * L.size))
    for j in range(L.size):
        start = ends[j] - L[j]
        if s_global < start:
            break
        sig = min(s_global - start, L[j])  # how much of segment j lies before the point
        after = s_global - start - sig  # the rigidly carried rest
        for c, (dw, dv) in enumerate(
            [((0, 0, 1), (0, 0, 0)), ((1, 0, 0), (0, 0, 0)), ((0, 1, 0), (0, 0, 0)),
             ((0, 0, 0), (1, 0, 0)), ((0, 0, 0), (0, 0, 1)), ((0, 0, 0), (0, 1, 0))]
        ):
            dw, dv = np.array(dw, float), np.array(dv, float)
            rot = sig * dw
            Jw[:, 6 * j + c] = rot
            Jp[:, 6 * j + c] = sig**2 / 2 * np.cross(dw, ey) + sig * dv + after * np.cross(rot, ey)
    return Jp, Jw


def test_straight_robot_mass_and_gravity_closed_forms():
    g = 9.81
    # one segment, by hand
    L = 0.15
    ref = reference_terms(np.zeros(6), np.zeros(6), [L], **_material(1), n_quadrature=8, dps=30)
    rA, rI = RHO * AREA, RHO * SECOND
    M = np.zeros((6, 6))
    M[0, 0] = M[1, 1] = rA * L**5 / 20 + rI * L**3 / 3
    M[2, 2] = 2 * rI * L**3 / 3
    M[3, 3] = M[4, 4] = M[5, 5] = rA * L**3 / 3
    M[0, 3] = M[3, 0] = -rA * L**4 / 8  # bending about z moves the backbone towards -x
    M[1, 4] = M[4, 1] = rA * L**4 / 8
    np.testing.assert_allclose(ref["M"], M, rtol=1e-14, atol=1e-14 * np.abs(M).max())
    np.testing.assert_allclose(ref["gravity"], [0, 0, 0, 0, 0, -rA * g * L**2 / 2], rtol=1e-14, atol=1e-20)

    # three segments of different radii: the straight Jacobians, integrated exactly (degree-4 polynomials)
    Ls, radii = [0.1, 0.07, 0.12], np.array([0.02, 0.015, 0.01])
    mat = {**_material(3), "radius": radii}
    ref = reference_terms(np.zeros(18), np.zeros(18), Ls, **mat, n_quadrature=8, dps=30)
    x, w = np.polynomial.legendre.leggauss(5)
    M = np.zeros((18, 18))
    G = np.zeros(18)
    start = 0.0
    for i, Li in enumerate(Ls):
        rA, rI = RHO * np.pi * radii[i] ** 2, RHO * np.pi * radii[i] ** 4 / 4
        for xk, wk in zip(x, w, strict=True):
            Jp, Jw = _straight_jacobians(Ls, start + (xk + 1) * Li / 2)
            M += wk * Li / 2 * (rA * Jp.T @ Jp + Jw.T @ np.diag([rI, 2 * rI, rI]) @ Jw)
            G -= wk * Li / 2 * rA * g * Jp[1]
        start += Li
    np.testing.assert_allclose(ref["M"], M, rtol=1e-13, atol=1e-14 * np.abs(M).max())
    np.testing.assert_allclose(ref["gravity"], G, rtol=1e-13, atol=1e-15 * np.abs(G).max())


def test_straight_twisted_stretched_robot_has_no_bending_gravity():
    # hanging straight along gravity, twisted and stretched: only the axial strains feel gravity
    Ls, g = [0.1, 0.14], 9.81
    q = np.array([0, 0, 6.0, 0, 0, 0.05, 0, 0, -9.0, 0, 0, -0.03])
    ref = reference_terms(q, np.zeros(12), Ls, **_material(2), n_quadrature=8, dps=20)
    rA = RHO * AREA
    want = np.zeros(12)
    want[5] = -g * rA * (Ls[0] ** 2 / 2 + Ls[0] * Ls[1])
    want[11] = -g * rA * Ls[1] ** 2 / 2
    np.testing.assert_allclose(ref["gravity"], want, rtol=1e-13, atol=1e-13 * np.abs(want).max())


# --------------------------------------------------------------------------
# invariants
# --------------------------------------------------------------------------
def test_rotation_about_the_gravity_axis_is_a_symmetry():
    """Conjugating every pose by Ry(φ) rotates (κx, κz) and (σx, σz): M, C q̇ and G transform with it.

    With q' = P q, g'(s) = H g(s) H⁻¹ for H = (Ry(φ), 0), so p' = Ry p and ω_b' = Ry ω_b; the inertia
    diag(ρI, 2ρI, ρI) commutes with Ry and g ∥ y, hence T(Pq, Pq̇) = T(q, q̇) and U_g(Pq) = U_g(q).
    """
    Ls = [0.1, 0.12]
    q, qd = _general_state(2, seed=5)
    c, s = np.cos(0.7), np.sin(0.7)
    block = np.eye(6)
    block[np.ix_([1, 0], [1, 0])] = [[c, s], [-s, c]]  # (κx, κz) -> Ry (κx, κz)
    block[np.ix_([3, 4], [3, 4])] = [[c, s], [-s, c]]  # (σx, σz) -> Ry (σx, σz)
    P = np.kron(np.eye(2), block)
    mat = {**_material(2), "damping": np.ones(12) * 1e-3}
    a = reference_terms(q, qd, Ls, **mat, n_quadrature=4, dps=20)
    b = reference_terms(P @ q, P @ qd, Ls, **mat, n_quadrature=4, dps=20)
    assert np.max(np.abs(a["M"] - P.T @ b["M"] @ P)) <= 1e-13 * np.max(np.abs(a["M"]))
    for name in ("coriolis", "gravity", "elastic", "damping"):
        assert _rel(P.T @ b[name], a[name]) <= 1e-13, name
    eig = np.linalg.eigvalsh(a["M"])
    assert np.allclose(a["M"], a["M"].T, rtol=0, atol=0)
    assert eig.min() > 0


def test_the_tip_segment_moves_like_a_robot_of_its_own():
    """What precedes the tip segment only moves its base frame rigidly.

    With segment 1 at rest (q̇_1 = 0) in any configuration, segment 2's points are p_1 + R_1 p_2(s) and
    its body angular velocities those of segment 2 alone; T is invariant under that rigid motion, so
    the segment-2 blocks of M and C q̇ equal those of the one-segment robot made of segment 2.  Gravity
    (along y) sees the rigid motion unless R_1 turns about y only: a straight segment 1 that is only
    twisted and stretched (a "pure twist offset") leaves the segment-2 block of G unchanged too.
    """
    Ls = [0.1, 0.12]
    q1, _ = _general_state(1, seed=4)
    q2, qd2 = _general_state(1, seed=8)
    mat2 = {**_material(2), "damping": np.ones(12) * 1e-3}
    mat1 = {**mat2, "youngs": mat2["youngs"][1], "shear": mat2["shear"][1], "damping": np.ones(6) * 1e-3}
    alone = reference_terms(q2, qd2, Ls[1:], **mat1, n_quadrature=4, dps=20)
    both = reference_terms(np.concatenate([q1, q2]), np.concatenate([np.zeros(6), qd2]), Ls, **mat2,
                           n_quadrature=4, dps=20)
    tail = slice(6, 12)
    assert np.max(np.abs(both["M"][tail, tail] - alone["M"])) <= 1e-13 * np.max(np.abs(alone["M"]))
    assert _rel(both["coriolis"][tail], alone["coriolis"]) <= 1e-13
    assert _rel(both["gravity"][tail], alone["gravity"]) > 1e-3  # the bent segment 1 tilts segment 2
    for twist in (5.0, -8.0):
        q = np.concatenate([[0, 0, twist, 0, 0, 0.04], q2])
        offset = reference_terms(q, np.zeros(12), Ls, **mat2, n_quadrature=4, dps=20)
        assert np.max(np.abs(offset["M"][tail, tail] - alone["M"])) <= 1e-13 * np.max(np.abs(alone["M"]))
        assert _rel(offset["gravity"][tail], alone["gravity"]) <= 1e-13


def test_passivity_of_the_coriolis_forces():
    """q̇ · (Ṁ q̇ − 2 C q̇) = 0, with Ṁ = dM(q + ε q̇)/dε by mpmath.diff of the reference's M."""
    Ls = [0.1, 0.12]
    q, qd = _general_state(2, seed=11)
    mat = _material(2)
    ref = reference_terms(q, qd, Ls, **mat, n_quadrature=4, dps=20, as_mpmath=True)
    with mpmath.workdps(20):
        qdm = mpmath.matrix(qd.tolist())

        def energy_rate(eps):
            x = mpmath.matrix(q.tolist()) + eps * qdm
            M = reference_terms(x, np.zeros(12), Ls, **mat, n_quadrature=4, dps=20, as_mpmath=True)["M"]
            return (qdm.T * M * qdm)[0]

        # h = 1e-7: truncation ~1e-14, and 20 - 7 digits survive the cancellation
        qMdq = mpmath.diff(energy_rate, 0, h=mpmath.mpf("1e-7"))
        qCq = (qdm.T * ref["coriolis"])[0]
        scale = abs(qMdq) + 2 * abs(qCq)
        assert scale > 0
        assert abs(qMdq - 2 * qCq) <= mpmath.mpf("1e-11") * scale


# --------------------------------------------------------------------------
# the working precision is enough: more digits change nothing that was claimed
# --------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e-9 / 4, 10.0 / 4])
def test_results_converge_in_the_precision(scale):
    # scale 1e-9/4: strains ~1e-9 (nearly straight); 10/4: bending and twist up to 10 1/m
    Ls = [0.15]
    q, qd = _general_state(1, seed=2, scale=scale)
    mat = _material(1)
    lo = reference_terms(q, qd, Ls, **mat, n_quadrature=4, dps=30, as_mpmath=True)
    hi = reference_terms(q, qd, Ls, **mat, n_quadrature=4, dps=50, as_mpmath=True)
    with mpmath.workdps(60):
        for name in TERMS:
            size = mpmath.mnorm(hi[name], 1)
            assert size > 0, name
            assert mpmath.mnorm(lo[name] - hi[name], 1) <= mpmath.mpf("1e-20") * size, name


def test_bad_inputs_are_named():
    mat = _material(1)
    with pytest.raises(ValueError, match="q must have shape"):
        reference_terms(np.zeros(5), np.zeros(6), [0.1], **mat)
    with pytest.raises(ValueError, match="segment_lengths"):
        reference_terms(np.zeros(6), np.zeros(6), [-0.1], **mat)
    with pytest.raises(ValueError, match="damping"):
        reference_terms(np.zeros(6), np.zeros(6), [0.1], **{**mat, "damping": np.ones(3)})
    with pytest.raises(ValueError, match="s must be in"):
        reference_pose(np.zeros(6), [0.1], 0.2)
