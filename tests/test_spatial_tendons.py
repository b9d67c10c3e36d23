"""Tendons routed in 3-D as an actuation kind of the identification (``SpatialTendonActuation``).

Independent truths: the tendon length integrated along the offset curve ``p(s) + R(s) d`` of the spatial
forward kinematics (:mod:`pcs_sindy.core.spatial`; tangents by central differences in ``s``, Gauss–Legendre
over every covered stretch); the simulator's compiled tendon kernel and its robot
(:class:`~pcs_sindy.simulation.spatial_dynamics.SpatialPCSRobot` with ``SpatialTendons``, written
separately); the planar tendon kind on planar motions.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core.kinematics import PlanarPCS
from pcs_sindy.core.spatial import SpatialPCS
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import load, save
from pcs_sindy.models import SpatialTendonActuation, TendonActuation, actuation_from_layout
from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot, SpatialTendons

LENGTHS = [0.07, 0.1]
END = [0.07, 0.17, 0.17, 0.12]  # the last ends inside segment 2
OFFSET = [[0.01, 0.0], [-0.008, 0.004], [0.0, -0.012], [0.005, 0.006]]
SCALE = np.array([20.0, 20.0, 20.0, 0.1, 0.1, 0.1])


def _states(n, seed=0, m=2):
    q = np.random.default_rng(seed).uniform(-1, 1, (n, 6 * m)) * np.tile(SCALE, m)
    q[0] = 0.0
    return q


def _length_along_the_offset_curve(kin, q, end, d, n_nodes=12, h=1e-6):
    """``∫_0^end |d/ds (p + R d)| ds`` from the forward kinematics alone."""
    x, w = np.polynomial.legendre.leggauss(n_nodes)
    bounds = np.concatenate([[0.0], np.cumsum(kin.segment_lengths)])
    total = 0.0
    offset = np.array([d[0], 0.0, d[1]])
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        hi = min(b, end)
        if hi <= a:
            continue
        s = a + 0.5 * (x + 1) * (hi - a)
        p_plus, R_plus = kin.forward_kinematics(q, s + h)
        p_minus, R_minus = kin.forward_kinematics(q, s - h)
        tangent = ((p_plus + R_plus @ offset) - (p_minus + R_minus @ offset)) / (2 * h)
        total += 0.5 * (hi - a) * np.sum(w * np.linalg.norm(tangent, axis=-1))
    return total


def test_lengths_equal_the_length_of_the_offset_curve_from_forward_kinematics():
    kin = SpatialPCS(tuple(LENGTHS))
    act = SpatialTendonActuation(end=END, offset=OFFSET).fit(kin)
    q = _states(6)
    got = act.lengths(q)
    for b in range(q.shape[0]):
        for k in range(len(END)):
            ref = _length_along_the_offset_curve(kin, q[b], END[k], OFFSET[k])
            assert got[b, k] == pytest.approx(ref, rel=1e-9), (b, k)
    np.testing.assert_allclose(got[0], END, rtol=1e-15)  # straight: the rest lengths


def test_input_map_is_minus_the_gradient_of_the_length_and_matches_the_simulator_kernel():
    kin = SpatialPCS(tuple(LENGTHS))
    act = SpatialTendonActuation(end=END, offset=OFFSET).fit(kin)
    q = _states(5, seed=1)
    jac = act.jacobian(q)
    # central differences of the (independently checked) lengths
    h = 1e-4 * np.tile(SCALE, 2)
    fd = np.stack(
        [
            (act.lengths(q + h[j] * np.eye(12)[j]) - act.lengths(q - h[j] * np.eye(12)[j])) / (2 * h[j])
            for j in range(12)
        ],
        axis=-1,
    )
    np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-7 * np.abs(fd).max())
    u = np.random.default_rng(2).uniform(0, 3, (5, 4))
    np.testing.assert_allclose(act.forces(q, u), -np.einsum("bkn,bk->bn", jac, u), rtol=1e-14)
    np.testing.assert_allclose(act.matrix(q), -np.transpose(jac, (0, 2, 1)), rtol=1e-14)
    # the simulator's compiled tendons (its own code, in the simulator's layout)
    rob = SpatialPCSRobot(LENGTHS, 1070.0, 1e4, 1e3, np.zeros(12), actuation=SpatialTendons(END, OFFSET))
    np.testing.assert_allclose(act.lengths(q), rob.tendon_lengths(q), rtol=1e-14)
    A = rob.actuation_matrix(q)
    np.testing.assert_allclose(act.matrix(q), A, rtol=0, atol=1e-14 * np.abs(A).max())
    np.testing.assert_allclose(act.forces(q, u), rob.actuation_forces(q, u), rtol=0, atol=1e-14 * np.abs(A).max())


def test_on_planar_motions_the_spatial_tendons_are_the_planar_ones():
    planar = PlanarPCS(tuple(LENGTHS))
    kin = SpatialPCS.from_planar(planar)
    d = np.array([0.01, -0.008, 0.012])
    end = [0.07, 0.17, 0.12]
    flat = TendonActuation(end=end, side=np.sign(d), offset=np.abs(d)).fit(planar)
    spatial = SpatialTendonActuation(end=end, offset=np.stack([d, np.zeros(3)], axis=1)).fit(kin)
    q = np.random.default_rng(3).uniform(-1, 1, (6, 6)) * np.tile([20.0, 0.1, 0.1], 2)
    np.testing.assert_allclose(spatial.lengths(q), flat.lengths(q), rtol=1e-14)
    np.testing.assert_allclose(spatial.jacobian(q), flat.jacobian(q), rtol=1e-13, atol=1e-17)


def test_layouts_checks_and_model_files(tmp_path):
    kin = SpatialPCS(tuple(LENGTHS))
    # the simulator's layout is the kind's layout
    act = actuation_from_layout(SpatialTendons(END, OFFSET).layout()).fit(kin)
    assert type(act) is SpatialTendonActuation and act.n_inputs_ == 4 and act.offset_names_ == []
    np.testing.assert_array_equal(act.offset_vectors_, OFFSET)
    loaded = load(save(act, tmp_path / "act"))
    assert loaded.design_layout() == act.design_layout() == {"type": "spatial_tendon", "end": END, "offset": OFFSET}
    q = _states(3)
    np.testing.assert_array_equal(loaded.forces(q, np.ones((3, 4))), act.forces(q, np.ones((3, 4))))
    with pytest.raises(ValueError, match="exactly one of them"):
        SpatialTendonActuation(end=END).fit(kin)
    with pytest.raises(ValueError, match=r"shape \(4, 2\)"):
        SpatialTendonActuation(end=END, offset=OFFSET[:3]).fit(kin)
    with pytest.raises(ValueError, match="beyond the robot"):
        SpatialTendonActuation(end=[0.2], offset=[[0.01, 0.0]]).fit(kin)
    with pytest.raises(ValueError, match="would push"):
        act.check_inputs(-np.ones((1, 4)))
    with pytest.raises(ValueError, match="planar segmentations only"):
        TendonActuation(end=[0.1], side=[1]).fit(kin)
    with pytest.raises(ValueError, match="SpatialPCS|spatial"):
        SpatialTendonActuation(end=[0.1], offset=[[0.01, 0.0]]).fit(PlanarPCS((0.1,)))


# ----------------------------------------------------------------------
# identification from a simulated robot driven by 3-D tendons
# ----------------------------------------------------------------------
RHO, E, G = 1070.0, 1e4, 1e3
DAMP = np.array([3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15])
BENDING = np.array([1, 1, 0, 0, 0, 0], dtype=bool)


def _tensions(t, seed, p=4):
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.5, 4.0, (3, p))
    ph = rng.uniform(0, 2 * np.pi, (3, p))
    return 1.0 * (1.0 + np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).mean(axis=1))


@pytest.fixture(scope="module")
def tendon_data():
    # the simulator moves all six strains of both segments; its shear and axial stiffness keep those tiny
    rob = SpatialPCSRobot(LENGTHS, RHO, E, G, np.tile(DAMP, 2), actuation=SpatialTendons(END, OFFSET))
    t = np.arange(0.0, 1.5, 0.005)
    X, U = [], []
    for seed in range(2):
        u = _tensions(t, seed)
        tr = rob.simulate(np.zeros(12), np.zeros(12), t, u)
        X.append(tr)
        U.append(u)
    return rob, X, U


def test_known_routing_identifies_the_simulated_robot(tendon_data):
    rob, X, U = tendon_data
    reg = EulerLagrangeRegressor(actuation={"type": "spatial_tendon", "end": END, "offset": OFFSET})
    reg.fit(X, U, qd=[x.qd for x in X])
    assert type(reg.actuation_) is SpatialTendonActuation
    kept = reg.active_strains_.reshape(-1)
    assert np.all(kept[[0, 1, 6, 7]])  # both bendings of both segments
    np.testing.assert_allclose(reg.stiffness_[[0, 1, 6, 7]], rob.stiffness[[0, 1, 6, 7]], rtol=1e-2)
    coef = dict(zip(reg.library_.coefficient_names(), reg.model_coef_, strict=True))
    assert coef["rhoA_2"] == pytest.approx(RHO * rob.area[1], rel=5e-2)
    # the identified model rolls out like the simulator (the actuation evaluated in Python)
    t, u = X[1].t[:20], U[1][:20]
    sim = reg.simulate(np.zeros(12), np.zeros(12), t, u)
    tip_true = rob.kinematics.forward_kinematics(X[1].q[:20], [0.17])[0][:, 0]
    tip_sim = rob.kinematics.forward_kinematics(sim.q, [0.17])[0][:, 0]
    motion = np.abs(tip_true - tip_true[0]).max()
    assert motion > 5e-4  # the tendons move the tip by a millimetre in 0.1 s
    assert np.abs(tip_sim - tip_true).max() < 0.02 * motion


def test_offset_magnitudes_are_identified_along_known_directions(tendon_data):
    rob, X, U = tendon_data
    d = np.asarray(OFFSET)
    angle = np.arctan2(d[:, 1], d[:, 0])
    reg = EulerLagrangeRegressor(actuation={"type": "spatial_tendon", "end": END, "angle": angle.tolist()})
    reg.fit(X, U, qd=[x.qd for x in X])
    np.testing.assert_allclose(reg.actuation_.offset_vectors_, d, rtol=1e-2, atol=1e-5)
    np.testing.assert_allclose(reg.stiffness_[[0, 1, 6, 7]], rob.stiffness[[0, 1, 6, 7]], rtol=2e-2)


def test_forces_on_a_model_without_unexcited_strains_are_the_gradient_at_those_strains_held_at_zero():
    """The output-error refinement's rest-force balance reads the tendons' forces on the model's strains when
    strains were removed as not excited while the actuation keeps all of them (it once read them on all)."""
    from pcs_sindy.identification.output_error import _model_forces

    full = SpatialPCS(tuple(LENGTHS))
    active = np.ones((2, 6), dtype=bool)
    active[:, 2] = False  # twist of both segments removed
    model_kin = SpatialPCS(tuple(LENGTHS), active)
    act = SpatialTendonActuation(end=END, offset=OFFSET).fit(full)
    q_kept = _states(2, seed=3)[1][active.reshape(-1)][None]
    u = np.array([0.4, 1.1, 0.0, 2.3])
    got = _model_forces(act, model_kin, q_kept, u[None], None)
    assert got.shape == (10,)

    # -(dl/dq)^T u by central differences of the lengths along the kept strains only (twist at 0)
    def lengths(x):
        q = np.zeros((1, 12))
        q[0, active.reshape(-1)] = x
        return act.lengths(q)[0]

    h = 1e-4 * np.tile(SCALE, 2)[active.reshape(-1)]
    step = np.eye(10) * h
    fd = np.stack([(lengths(q_kept[0] + step[j]) - lengths(q_kept[0] - step[j])) / (2 * h[j]) for j in range(10)])
    np.testing.assert_allclose(got, -fd @ u, rtol=0, atol=1e-7 * np.abs(fd @ u).max())
