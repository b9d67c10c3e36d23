"""Spatial (3-D) fusion of motion capture (issue 26, item 3): positions, and orientations when tracked.

Truth comes from the core's spatial PCS forward kinematics (:class:`pcs_sindy.core.spatial.SpatialPCS`)
and, for the planar check, from the planar package's own kinematics and fusion; never from the
fusion code under test.
"""

import time
import warnings

import numpy as np
import pytest
from real_data import real_file
from scipy.spatial.transform import Rotation

from pcs_sindy.core import PoseTrajectory
from pcs_sindy.core.kinematics import forward_kinematics
from pcs_sindy.core.spatial import SpatialPCS, SpatialStrainTrajectory
from pcs_sindy.fusion import KinematicFusion, fit_spatial_strains, needs_3d
from pcs_sindy.io import read_marker_csv

ARCS = np.array([0.105, 0.21, 0.315])  # the Trunk's three disks
NOISE = 5e-4


def _base(direction=(0.1, -1.0, 0.15), roll=0.4):
    """A base frame whose y axis is ``direction``, turned by ``roll`` about it (an arbitrary gauge)."""
    y = np.asarray(direction, dtype=float)
    y /= np.linalg.norm(y)
    x = np.cross(y, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, y, np.cross(x, y)], axis=1)
    return R @ Rotation.from_rotvec([0.0, roll, 0.0]).as_matrix()


def _strains(T, m=3, twist=False, seed=0):
    """Bending (and torsion) strains wandering in both directions around zero, (T, 6m)."""
    t = np.arange(T) * 0.01
    rng = np.random.default_rng(seed)
    q = np.zeros((T, 6 * m))
    for j in range(m):
        w = rng.uniform(1.0, 3.0, 3)
        ph = rng.uniform(0, 2 * np.pi, 3)
        q[:, 6 * j] = 9.0 * np.sin(w[0] * t + ph[0])
        q[:, 6 * j + 1] = 7.0 * np.sin(w[1] * t + ph[1])
        if twist:
            q[:, 6 * j + 2] = 3.0 * np.sin(w[2] * t + ph[2])
    return q


def _markers(q, R0, p0, arcs=ARCS, offsets=None):
    """Truth: marker positions and cross-section frames in the capture frame, from the core's kinematics."""
    lengths = np.diff(np.concatenate([[0.0], arcs]))
    kin = SpatialPCS(tuple(lengths), base_position=tuple(p0), base_rotation=R0)
    p, R = kin.forward_kinematics(q, arcs)
    if offsets is not None:
        d3 = np.stack([offsets[:, 0], np.zeros(len(arcs)), offsets[:, 1]], axis=1)
        p = p + np.einsum("tkij,kj->tki", R, d3)
    return p, R


def _quiet_positions(P, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the out-of-plane warning: the point of these recordings
        return PoseTrajectory.from_positions(P, dt=0.01, **kw)


def _gauge_aligned(q_true, R_true, R_fit):
    """The true strains in the fitted gauge: the two base frames differ by a turn about the rest axis,
    which turns every bending vector (bend_x, bend_z) of a torsion-free robot alike."""
    rel = R_true.T @ R_fit
    a = np.arctan2(rel[0, 2], rel[0, 0])  # rel ~ Ry(a)
    assert abs(rel[1, 1]) == pytest.approx(1.0, abs=2e-3)  # the rest directions agree
    out = q_true.reshape(q_true.shape[0], -1, 6).copy()
    kx, kz = out[..., 1].copy(), out[..., 0].copy()
    c, s = np.cos(a), np.sin(a)
    # (kx, kz) in the fitted body axes: Ry(a)^T applied to (kx, 0, kz)
    out[..., 1] = c * kx - s * kz
    out[..., 0] = s * kx + c * kz
    return out.reshape(q_true.shape)


# ----------------------------------------------------------------------------- synthetic truth
def test_noisy_3d_markers_give_back_strains_positions_and_base():
    T = 600
    q = _strains(T)
    R0, p0 = _base(), np.array([0.1, 0.0, 0.1])
    P, _ = _markers(q, R0, p0)
    noisy = P + NOISE * np.random.default_rng(1).standard_normal(P.shape)
    tr = _quiet_positions(noisy, arc_lengths=ARCS)
    fusion = KinematicFusion(space="3d", n_segments=3).fit(tr)
    assert fusion.space_ == "3d" and fusion.base_pose_.shape == (4, 4)
    (st,) = fusion.transform(tr)
    assert isinstance(st, SpatialStrainTrajectory) and st.q.shape == (T, 18)
    assert st.active_strains[:, :2].all() and not st.active_strains[:, 2:].any()
    # the base: its position and rest direction (the roll about it is the gauge)
    np.testing.assert_allclose(fusion.base_pose_[:3, 3], p0, atol=1.5e-3)
    assert fusion.base_pose_[:3, 1] @ R0[:, 1] > np.cos(np.deg2rad(1.5))
    # positions: the fitted model is closer to the noise-free truth than the noise
    (rec,) = fusion.inverse_transform([st])
    err_truth = np.sqrt(np.mean((rec.positions - P) ** 2))
    assert err_truth < NOISE, err_truth
    # strains in the fitted gauge: within a small fraction of their 6-7 1/m RMS
    q_ref = _gauge_aligned(q, R0, fusion.base_pose_[:3, :3])
    bend = np.concatenate([np.arange(0, 18, 6), np.arange(1, 18, 6)])
    rms_err = np.sqrt(np.mean((st.q[:, bend] - q_ref[:, bend]) ** 2, axis=0))
    assert np.all(rms_err < 0.8), rms_err
    assert -fusion.score(tr) < 1.5 * np.sqrt(3) * NOISE  # mean marker distance, noise included


def test_a_planar_recording_comes_out_planar_and_agrees_with_the_planar_fusion():
    T = 500
    t = np.arange(T) * 0.01
    kappa = np.stack([8 * np.sin(2.1 * t), 6 * np.sin(1.3 * t + 1.0), -7 * np.cos(1.7 * t)], axis=1)
    q_planar = np.zeros((T, 9))
    q_planar[:, 0::3] = kappa
    pose = forward_kinematics(q_planar, np.diff(np.concatenate([[0.0], ARCS])), ARCS, (0.01, 0.02, 0.1))
    # the plane of the motion in an arbitrary capture frame
    R, _ = np.linalg.qr(np.random.default_rng(2).standard_normal((3, 3)))
    P = np.concatenate([pose[..., :2], np.zeros(pose.shape[:2] + (1,))], axis=2) @ R.T + [0.3, 0.1, -0.2]
    P = P + NOISE * np.random.default_rng(3).standard_normal(P.shape)
    tr = PoseTrajectory.from_positions(P, dt=0.01, arc_lengths=ARCS)
    assert not needs_3d([tr])  # auto keeps the planar path
    assert KinematicFusion(n_segments=3).fit(tr).space_ == "plane"
    flat = KinematicFusion(space="plane", n_segments=3).fit(tr)
    space = KinematicFusion(space="3d", n_segments=3).fit(tr)
    (st_flat,), (st_3d,) = flat.transform(tr), space.transform(tr)
    q3 = st_3d.q.reshape(T, 3, 6)
    # planar: no bending out of the plane beyond what the out-of-plane noise makes (exactly none without
    # noise), and bend_z is the planar curvature with its sign
    assert np.sqrt(np.mean(q3[..., 1] ** 2)) < 0.1 * np.sqrt(np.mean(q3[..., 0] ** 2))
    assert np.all(np.abs(q3[..., 1].mean(axis=0)) < 0.25)
    np.testing.assert_allclose(q3[..., 0], st_flat.q[:, 0::3], atol=0.5)
    assert np.sqrt(np.mean((q3[..., 0] - kappa) ** 2)) < 0.5  # 0.5 mm noise on 0.1 m segments
    # the same markers in the capture frame: in the plane alike; off it the 3-D model follows the noise (one
    # bend_x per marker: three out-of-plane coordinates, three strains), the planar one projects it away
    (r_flat,), (r_3d,) = flat.inverse_transform([st_flat]), space.inverse_transform([st_3d])
    plane = flat.plane_
    in_plane = plane.to_plane(r_3d.positions) - plane.to_plane(r_flat.positions)
    assert np.sqrt(np.mean(np.sum(in_plane**2, axis=2))) < 3e-4
    assert np.sqrt(np.mean(plane.distance(r_3d.positions) ** 2)) < 1.2 * NOISE
    assert abs(space.base_pose_[:3, 2] @ flat.plane_.normal) > 0.999  # the gauge: base z = the plane's normal


def test_transform_and_inverse_transform_round_trip():
    T = 200
    R0, p0 = _base(), np.array([0.0, 0.2, 0.0])
    P, _ = _markers(_strains(T, seed=4), R0, p0)
    tr = _quiet_positions(P + NOISE * np.random.default_rng(5).standard_normal(P.shape), arc_lengths=ARCS)
    fusion = KinematicFusion(space="3d", threshold=0.05).fit(tr)
    (st,) = fusion.transform(tr)
    (rec,) = fusion.inverse_transform([st])
    # positions of the fused model are the model's: transforming them gives the same strains back
    (st2,) = fusion.transform(_quiet_positions(rec.positions, arc_lengths=ARCS))
    np.testing.assert_allclose(st2.q, st.q, atol=1e-5)
    (rec2,) = fusion.inverse_transform(st2)
    np.testing.assert_allclose(rec2.positions, rec.positions, atol=1e-8)
    # a prediction carrying only strains maps back with the fitted base, arc lengths and offsets
    bare = SpatialStrainTrajectory(st.q, st.t, segment_lengths=fusion.segment_lengths_)
    (rec3,) = fusion.inverse_transform([bare])
    np.testing.assert_allclose(rec3.positions, rec.positions, atol=1e-12)
    assert rec3.rotations.shape == (T, 3, 3, 3)
    # and the model's frames at the markers are rotations
    gram = np.einsum("tkji,tkjl->tkil", rec3.rotations, rec3.rotations)
    np.testing.assert_allclose(gram, np.broadcast_to(np.eye(3), gram.shape), atol=1e-12)


def test_saved_spatial_fusion_maps_alike(tmp_path):
    P, _ = _markers(_strains(150, seed=6), _base(), np.zeros(3))
    tr = _quiet_positions(P, arc_lengths=ARCS)
    fusion = KinematicFusion(space="3d", n_segments=2).fit(tr)
    loaded = KinematicFusion.load(fusion.save(tmp_path / "fusion"))
    assert loaded.space_ == "3d"
    (a,), (b,) = fusion.transform(tr), loaded.transform(tr)
    np.testing.assert_array_equal(a.q, b.q)


def test_markers_off_the_backbone():
    T = 200
    R0, p0 = _base((0.0, -1.0, 0.0), 0.0), np.zeros(3)
    offsets = np.array([[0.02, 0.0], [0.015, 0.01], [-0.01, 0.02]])
    q = _strains(T, seed=7)
    P, _ = _markers(q, R0, p0, offsets=offsets)
    tr = _quiet_positions(P + 1e-4 * np.random.default_rng(8).standard_normal(P.shape), arc_lengths=ARCS)
    ignored = KinematicFusion(space="3d", n_segments=3, max_refine_frames=150).fit(tr)
    fitted = KinematicFusion(space="3d", n_segments=3, marker_offsets="fit", max_refine_frames=150).fit(tr)
    assert fitted.position_rms_ < 3e-4 < ignored.position_rms_
    assert fitted.marker_offsets_.shape == (3, 2) and np.all(np.abs(fitted.marker_offsets_) < 0.05)
    # the fitted model's markers are the true ones within the noise (the tip marker's offset and the last
    # segment's bending trade against each other, so the offsets themselves are only loosely determined)
    (rec,) = fitted.inverse_transform(fitted.transform(tr))
    assert np.sqrt(np.mean((rec.positions - P) ** 2)) < 1.5e-4  # 1e-4 noise


def test_orientations_give_torsion():
    T = 300
    R0, p0 = _base(), np.array([0.05, 0.0, 0.05])
    q = _strains(T, twist=True, seed=9)
    P, R = _markers(q, R0, p0)
    rng = np.random.default_rng(10)
    C = Rotation.random(3, random_state=11).as_matrix()  # each rigid body's frame on its disk
    noisy_R = Rotation.from_rotvec(np.deg2rad(0.3) * rng.standard_normal((T, 3, 3))).as_matrix() @ (R @ C)
    tr = _quiet_positions(P + 2e-4 * rng.standard_normal(P.shape), arc_lengths=ARCS, rotations=noisy_R)
    assert needs_3d([tr])
    fusion = KinematicFusion(n_segments=3).fit(tr)
    assert fusion.space_ == "3d" and fusion.marker_rotation_offsets_.shape == (3, 3, 3)
    (st,) = fusion.transform(tr)
    assert st.active_strains[:, :3].all()
    # torsion does not depend on the gauge: the recovered torsion follows the truth
    err = np.sqrt(np.mean((st.q[:, 2::6] - q[:, 2::6]) ** 2, axis=0))
    assert np.all(err < 0.6), err
    assert fusion.rotation_rms_ < np.deg2rad(1.0)
    with pytest.raises(ValueError, match="orientations"):
        fusion.transform(_quiet_positions(P, arc_lengths=ARCS))


def test_strains_batched_fit_is_exact_on_model_markers():
    q = _strains(50, seed=12)
    R0, p0 = _base(), np.array([0.0, 0.1, 0.0])
    P, _ = _markers(q, R0, p0)
    lengths = np.diff(np.concatenate([[0.0], ARCS]))
    fit, estimated = fit_spatial_strains(P, R0, p0, lengths, ARCS)
    np.testing.assert_allclose(fit, q, atol=1e-6)
    assert estimated.all()
    P[7, 2] = np.nan  # the last disk lost: its segment is interpolated in time
    fit, estimated = fit_spatial_strains(P, R0, p0, lengths, ARCS)
    assert not estimated[7] and estimated.sum() == 49
    np.testing.assert_allclose(fit[7, 12:14], (fit[6, 12:14] + fit[8, 12:14]) / 2)


def test_space_choice_and_errors():
    P, _ = _markers(_strains(400, seed=13), _base(), np.zeros(3))
    tr = _quiet_positions(P, arc_lengths=ARCS)
    assert needs_3d([tr]) and KinematicFusion(n_segments=1).fit(tr).space_ == "3d"
    assert KinematicFusion(n_segments=1, space="plane").fit(tr).space_ == "plane"
    with pytest.raises(ValueError, match="space"):
        KinematicFusion(space="4d").fit(tr)
    poses = np.zeros((10, 3, 3))
    poses[:, 1:, 1] = [0.1, 0.2]
    with pytest.raises(ValueError, match="positions-only"):
        KinematicFusion(space="3d").fit(poses)
    flat = _quiet_positions(P[..., :2], arc_lengths=ARCS)
    with pytest.raises(ValueError, match="3-D"):
        KinematicFusion(space="3d").fit(flat)
    fusion = KinematicFusion(space="3d", n_segments=1).fit(tr)
    with pytest.raises(ValueError, match="SpatialStrainTrajectory"):
        fusion.inverse_transform([object()])


# ----------------------------------------------------------------------------- reading orientations
def test_quaternions_are_read_scalar_last_into_rotations(tmp_path):
    axis, angle = np.array([1.0, 2.0, 2.0]) / 3.0, 0.7
    qx, qy, qz = axis * np.sin(angle / 2)
    w = np.cos(angle / 2)
    f = tmp_path / "rigid.csv"
    f.write_text(
        "ID,x1,y1,z1,qx1,qy1,qz1,w1,phi1\n"
        f"0,0.1,0.2,0.3,{qx},{qy},{qz},{w},1.0\n"
        f"1,0.1,0.2,0.3,{-qx},{-qy},{-qz},{-w},1.0\n"  # the same rotation (the tracker's sign flip)
        "2,0.1,0.2,0.3,,,,,1.0\n"
    )
    d = read_marker_csv(f, ["1"], rate=100, units="m", orientations=True)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rodrigues = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    np.testing.assert_allclose(d.rotations[0, 0], rodrigues, atol=1e-12)
    np.testing.assert_allclose(d.rotations[1, 0], rodrigues, atol=1e-12)
    assert np.isnan(d.rotations[2, 0]).all()
    assert read_marker_csv(f, ["1"], rate=100, units="m").rotations is None


# ----------------------------------------------------------------------------- the Trunk
def test_real_trunk_in_3d_fuses_within_a_few_mm():
    d = read_marker_csv(real_file("trunk", "observations_controlled_1.csv"), ["1", "2", "3"], rate=100, units="m")
    tr = _quiet_positions(d.positions[:3000])
    assert needs_3d([tr])
    start = time.perf_counter()
    fusion = KinematicFusion().fit(tr)
    (st,) = fusion.transform(tr)
    seconds = time.perf_counter() - start
    (rec,) = fusion.inverse_transform([st])
    rms = np.sqrt(np.nanmean(np.sum((rec.positions - tr.positions) ** 2, axis=2)))
    print(
        f"Trunk controlled_1, 3000 frames: {fusion.n_segments_} segment(s), "
        f"marker RMS {1e3 * rms:.2f} mm, {seconds:.1f} s"
    )
    assert fusion.space_ == "3d"
    assert rms < 4e-3
    assert fusion.base_pose_[:3, 1] @ [0.0, -1.0, 0.0] > np.cos(np.deg2rad(20))  # it hangs


def test_real_trunk_at_rest_with_orientations():
    d = read_marker_csv(
        real_file("trunk", "observations_zeros_0g.csv"), ["1", "2", "3"], rate=100, units="m", orientations=True
    )
    assert d.rotations.shape == (3001, 3, 3, 3)
    tr = _quiet_positions(d.positions[:1000], rotations=d.rotations[:1000])
    fusion = KinematicFusion().fit(tr)
    assert fusion.space_ == "3d" and fusion.rotation_rms_ < np.deg2rad(1.0)
    (st,) = fusion.transform(tr)
    (rec,) = fusion.inverse_transform([st])
    rms = np.sqrt(np.nanmean(np.sum((rec.positions - tr.positions) ** 2, axis=2)))
    print(
        f"Trunk zeros_0g with orientations: marker RMS {1e3 * rms:.2f} mm, rotation RMS "
        f"{np.rad2deg(fusion.rotation_rms_):.2f} deg"
    )
    assert rms < 4e-3
    assert np.sqrt(np.mean(st.q[:, 2::6] ** 2)) < 1.0  # at rest: no torsion (the offsets take the rest)


# ----------------------------------------------------------------------------- the command line
def test_cli_fuses_a_3d_capture_without_forcing_a_plane(tmp_path, capsys):
    from pcs_sindy.cli.main import main
    from pcs_sindy.io import load
    from pcs_sindy.io.data_files import read_strains

    T = 300
    P, _ = _markers(_strains(T, seed=14), _base(), np.array([0.2, 0.1, 0.0]))
    rows = ["frame," + ",".join(f"M{k}_{a}" for k in (1, 2, 3) for a in "XYZ")]
    rows += [f"{i}," + ",".join(f"{v:.7f}" for v in 1e3 * P[i].ravel()) for i in range(T)]  # in mm
    f = tmp_path / "capture.csv"
    f.write_text("\n".join(rows) + "\n")
    out = tmp_path / "out"
    args = ["fuse", "--markers-csv", str(f), "--markers", "M1", "M2", "M3", "--rate", "100", "--units", "mm"]
    assert main([*args, "--arc-lengths", *map(str, ARCS), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "3-D fusion" in printed
    st = read_strains(out / "capture.npz")
    assert isinstance(st, SpatialStrainTrajectory) and st.q.shape[1] % 6 == 0
    fusion = load(out / "segmentation.json")
    assert fusion.space_ == "3d"
    (rec,) = fusion.inverse_transform([st])
    assert np.sqrt(np.mean((rec.positions - P) ** 2)) < 2e-4  # the capture frame, from the files alone
    assert main([*args, "--space", "plane", "--out", str(tmp_path / "flat")]) == 0
    assert "3-D fusion" not in capsys.readouterr().out
    assert main(["fuse", str(f), "--space", "3d", "--out", str(tmp_path / "x")]) != 0  # pose files are planar
