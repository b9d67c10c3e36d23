"""Positions-only motion capture: PoseTrajectory.from_positions, positions-only KinematicFusion,
read_marker_csv and the simulated capture (issue 19)."""

import warnings

import numpy as np
import pytest

from pcs_sindy.core import MarkerPlane, PoseTrajectory, clean_marker_tracks
from pcs_sindy.core.kinematics import forward_kinematics
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.io import DataFileError, read_marker_csv
from pcs_sindy.simulation import MocapScenario, play_operator


def _rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return q * np.sign(np.diag(r))


def _bending_robot(T=400, seed=0, arc=(0.1, 0.2, 0.3), base=(0.02, -0.01, 0.4)):
    """In-plane marker positions of a 3-spacing robot with independent curvatures (closed-form FK)."""
    t = np.arange(T) * 0.01
    k = np.stack(
        [6 * np.sin(2 * np.pi * 0.4 * t), 5 * np.sin(2 * np.pi * 0.4 * t + 0.5), 4 * np.cos(2 * np.pi * 0.3 * t)], 1
    )
    q = np.zeros((T, 9))
    q[:, 0::3] = k
    s = np.asarray(arc)
    lengths = np.diff(np.concatenate([[0.0], s]))
    return forward_kinematics(q, lengths, s, base_pose=base)[..., :2], q


def _to_capture(planar, wobble, seed=0):
    R = _rotation(seed)
    z = wobble * np.ones(planar.shape[:2])
    return np.concatenate([planar, z[..., None]], axis=2) @ R.T + np.array([0.5, -1.0, 2.0]), R


def test_plane_fit_is_an_isometry_and_reports_the_wobble():
    planar, _ = _bending_robot()
    P3, R = _to_capture(planar, 0.0)
    # every frame twice, 2 mm on either side of the plane: the wobble is uncorrelated with the motion by construction
    P3 = np.stack([P3 + 2e-3 * R[:, 2], P3 - 2e-3 * R[:, 2]], axis=1).reshape(800, 3, 3)
    tr = PoseTrajectory.from_positions(P3, dt=0.01)
    assert tr.positions_only and tr.n_markers == 3 and tr.n_frames == 800
    assert abs(abs(tr.plane.normal @ R[:, 2]) - 1) < 1e-7
    assert tr.metadata["out_of_plane_rms"] == pytest.approx(2e-3, rel=1e-4)
    # distances between markers are kept by the projection
    d_true = np.linalg.norm(planar[:, 0] - planar[:, 2], axis=1)
    d_plane = np.linalg.norm(tr.plane_positions[::2, 0] - tr.plane_positions[::2, 2], axis=1)
    assert np.max(np.abs(d_true - d_plane)) < 1e-9
    wobble = np.tile([[2e-3], [-2e-3]], (400, 3))
    back = tr.plane.from_plane(tr.plane_positions)
    assert np.max(np.abs(back - (P3 - wobble[..., None] * R[:, 2]))) < 1e-9


def test_plane_normal_hint_fixes_the_curvature_sign():
    planar, q = _bending_robot(T=200)
    P3, R = _to_capture(planar, 0.0)
    for sign in (1.0, -1.0):
        plane = MarkerPlane.fit(P3, normal=sign * R[:, 2])
        assert plane.normal @ R[:, 2] == pytest.approx(sign)
        tr = PoseTrajectory.from_positions(P3, dt=0.01, arc_lengths=[0.1, 0.2, 0.3], plane=plane)
        (st,) = KinematicFusion(threshold=0.01).fit(tr).transform(tr)
        # the robot's own frame has its normal along +R[:, 2]: the curvatures keep their sign with it
        assert np.sign(np.sum(st.q[:, 0] * q[:, 0])) == sign


def test_large_wobble_warns_and_2d_passes_through():
    planar, _ = _bending_robot(T=200)
    rng = np.random.default_rng(2)
    P3, R = _to_capture(planar, 0.0)
    with pytest.warns(UserWarning, match="out-of-plane RMS"):
        PoseTrajectory.from_positions(P3 + 0.05 * rng.standard_normal(P3.shape[:2])[..., None] * R[:, 2], dt=0.01)
    planar = planar + 1e-5 * rng.standard_normal(planar.shape)  # noise: no sample repeats exactly
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = PoseTrajectory.from_positions(planar, dt=0.01)
    np.testing.assert_array_equal(tr.plane_positions, planar)
    assert tr.metadata["out_of_plane_rms"] == 0.0


def test_frozen_samples_and_jumps_become_missing():
    planar, _ = _bending_robot(T=500)
    rng = np.random.default_rng(3)
    P = planar + 2e-4 * rng.standard_normal(planar.shape)
    P[100:104, 1] = P[99, 1]  # tracker repeats the last value
    P[250, 2] += [0.03, -0.02]
    P[400:402, 0] += [0.0, 0.04]
    clean, counts = clean_marker_tracks(P)
    assert np.all(np.isfinite(clean[99, 1])) and np.all(np.isnan(clean[100:104, 1]))
    assert np.isnan(clean[250, 2]).all() and np.isnan(clean[400:402, 0]).all()
    assert counts["frozen"] == 4 and 3 <= counts["jumps"] <= 12  # a few neighbours of a jump may go too
    assert np.isfinite(clean).all(axis=2).mean() > 0.98


def test_bad_positions_name_the_argument():
    with pytest.raises(ValueError, match="positions must have shape"):
        PoseTrajectory.from_positions(np.zeros((10, 3)), dt=0.01)
    with pytest.raises(ValueError, match="arc_lengths must be 2 increasing"):
        PoseTrajectory.from_positions(np.random.default_rng(0).normal(size=(10, 2, 2)), dt=0.01, arc_lengths=[0.2, 0.1])
    with pytest.raises(ValueError, match="marker 1 has no valid sample"):
        P = np.random.default_rng(0).normal(size=(10, 2, 2))
        P[:, 1] = np.nan
        PoseTrajectory.from_positions(P, dt=0.01)


def test_positions_only_fusion_recovers_strains_and_returns_3d():
    planar, q = _bending_robot()
    P3, _ = _to_capture(planar, 0.0)
    P3[50:53, 2] = np.nan  # a dropout of the tip
    tr = PoseTrajectory.from_positions(P3, dt=0.01, arc_lengths=[0.1, 0.2, 0.3])
    fusion = KinematicFusion(threshold=0.01).fit(tr)
    assert fusion.positions_only_ and fusion.n_segments_ == 3
    np.testing.assert_allclose(fusion.segment_lengths_, [0.1, 0.1, 0.1])
    (st,) = fusion.transform(tr)
    assert st.active_strains.tolist() == [[True, False, False]] * 3
    # the plane's axes are arbitrary: curvatures are recovered up to the orientation's sign
    sign = np.sign(np.sum(st.q[:, 0] * q[:, 0]))
    ok = st.metadata["estimated"]
    assert not ok[50:53].any() and ok.sum() == 397
    np.testing.assert_allclose(sign * st.q[ok][:, 0::3], q[ok][:, 0::3], atol=1e-6)
    (rec,) = fusion.inverse_transform([st])
    assert rec.positions.shape == (400, 3, 3)
    # inverse_transform fills the dropout; elsewhere it reproduces the capture
    good = np.isfinite(P3).all(axis=2)
    assert np.max(np.linalg.norm(rec.positions - P3, axis=2)[good]) < 1e-6
    assert fusion.score(tr) > -1e-6


@pytest.mark.parametrize("arcs", [(0.08, 0.19, 0.3), (0.15, 0.3)])
def test_positions_only_fusion_estimates_base_and_arc_lengths(arcs):
    # a uniformly bending robot: the arc lengths follow from how far each marker swings
    T = 300
    t = np.arange(T) * 0.01
    q = np.zeros((T, 3))
    q[:, 0] = 4 * np.sin(2 * np.pi * 0.5 * t)
    base = np.array([0.03, 0.01, -0.2])
    planar = forward_kinematics(q, [0.3], arcs, base_pose=base)[..., :2]
    rng = np.random.default_rng(4)
    P3, R = _to_capture(planar + 1e-4 * rng.standard_normal(planar.shape), 0.0)
    tr = PoseTrajectory.from_positions(P3, dt=0.01)
    fusion = KinematicFusion().fit(tr)
    base_capture = np.array([base[0], base[1], 0.0]) @ R.T + np.array([0.5, -1.0, 2.0])
    np.testing.assert_allclose(tr.plane.from_plane(fusion.base_pose_[:2]), base_capture, atol=3e-3)
    np.testing.assert_allclose(fusion.marker_arc_lengths_, [0.0, *arcs], atol=3e-3)
    assert np.all(fusion.marker_arc_lengths_std_[1:] < 3e-3)
    assert fusion.n_segments_ == 1 and fusion.position_rms_ < 3e-4


def test_positions_only_fusion_rejects_mixing_and_total_length():
    planar, _ = _bending_robot(T=100)
    tr = PoseTrajectory.from_positions(planar, dt=0.01, arc_lengths=[0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="total_length=0.3 is not used"):
        KinematicFusion(total_length=0.3).fit(tr)
    poses = np.zeros((100, 4, 3))
    poses[:, :, 1] = [0, 0.1, 0.2, 0.3]
    with pytest.raises(ValueError, match="mixes positions-only"):
        KinematicFusion().fit([tr, PoseTrajectory(poses, dt=0.01)])


def _write(path, text):
    path.write_text(text)
    return path


def test_read_marker_csv_generic_motive_vicon_qualisys(tmp_path):
    expected = np.array([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], [[1.5, 2.5, 3.5], [np.nan, np.nan, np.nan]]])
    generic = _write(
        tmp_path / "g.csv", "frame,servo,M1_X,M1_Y,M1_Z,M2_X,M2_Y,M2_Z\n0,10,1,2,3,4,5,6\n1,20,1.5,2.5,3.5,,,\n"
    )
    d = read_marker_csv(generic, ["M1", "M2"], rate=100, units="mm", inputs=["servo"])
    np.testing.assert_allclose(d.positions, 1e-3 * expected)
    np.testing.assert_allclose(d.inputs[:, 0], [10, 20])
    assert d.dt == 0.01
    motive = _write(
        tmp_path / "m.csv",
        "Format Version,1.23,Length Units,Meters,Export Frame Rate,100\n\n"
        ",,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Marker,Marker,Marker\n"
        "Name,,disk1,disk1,disk1,disk1,disk1,disk1,disk1,M2,M2,M2\n"
        ",,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Position,Position,Position\n"
        "Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,X,Y,Z\n"
        "0,0.0,0.1,0.2,0.3,0.9,1,2,3,4,5,6\n"
        "1,0.01,0.1,0.2,0.3,0.9,1.5,2.5,3.5,,,\n",
    )
    d = read_marker_csv(motive, ["disk1", "M2"], rate=100)
    assert d.units == "meters"
    np.testing.assert_allclose(d.positions, expected)
    vicon = _write(
        tmp_path / "v.csv",
        "Trajectories\n100\n,,R:M1,,,R:M2,,\nFrame,Sub Frame,X,Y,Z,X,Y,Z\n,,mm,mm,mm,mm,mm,mm\n"
        "1,0,1,2,3,4,5,6\n3,0,1.5,2.5,3.5,,,\n",
    )
    d = read_marker_csv(vicon, ["M1", "M2"], rate=100)
    assert d.units == "mm" and d.metadata["skipped_samples"] == 1
    np.testing.assert_allclose(d.positions[[0, 2]], 1e-3 * expected)
    assert np.isnan(d.positions[1]).all()
    qualisys = _write(
        tmp_path / "q.tsv",
        "NO_OF_FRAMES\t2\nMARKER_NAMES\tM1\tM2\nFrame\tTime\tM1 X\tM1 Y\tM1 Z\tM2 X\tM2 Y\tM2 Z\n"
        "1\t0.0\t1\t2\t3\t4\t5\t6\n2\t0.01\t1.5\t2.5\t3.5\t\t\t\n",
    )
    d = read_marker_csv(qualisys, ["M1", "M2"], rate=100, units="mm")
    np.testing.assert_allclose(d.positions, 1e-3 * expected)


def test_read_marker_csv_errors_name_the_problem(tmp_path):
    f = _write(tmp_path / "g.csv", "frame,M1_X,M1_Y,M1_Z\n0,1,2,3\n")
    with pytest.raises(DataFileError, match="length units"):
        read_marker_csv(f, ["M1"], rate=100)
    with pytest.raises(DataFileError, match="no X, Y, Z columns found for every marker of \\['M1', 'M9'\\]"):
        read_marker_csv(f, ["M1", "M9"], rate=100, units="mm")
    with pytest.raises(DataFileError, match="rate must be"):
        read_marker_csv(f, ["M1"], rate=0, units="mm")
    with pytest.raises(DataFileError, match="no input column named 'servo'"):
        read_marker_csv(f, ["M1"], rate=100, units="mm", inputs=["servo"])


def test_play_operator_is_a_backlash():
    u = np.array([0.0, 1.0, 0.95, 0.9, 0.5, 0.5])[:, None]
    np.testing.assert_allclose(play_operator(u, 0.2)[:, 0], [0.0, 0.9, 0.9, 0.9, 0.6, 0.6])


def test_simulated_capture_has_the_nuisances_and_round_trips_through_csv(tmp_path):
    scenario = MocapScenario(duration=3.0, frozen_fraction=0.05, jump_rate=0.003)
    rec = scenario.generate(seed=1)
    assert rec.positions.shape == (300, 3, 3) and rec.u.shape == (300, 2)
    # frozen samples repeat the previous value exactly; the rest does not
    rep = np.all(np.diff(rec.positions, axis=0) == 0, axis=2)
    np.testing.assert_array_equal(rep, rec.frozen[1:])
    assert 0.02 < rec.frozen.mean() < 0.1
    # noise-free positions back in the robot frame: in plane up to the wobble, markers at their arc lengths' distance
    local = (rec.positions_true - rec.offset) @ rec.rotation
    assert np.max(np.abs(local[..., 2])) <= scenario.wobble + 1e-12
    assert np.all(np.linalg.norm(local[:, 0, :2], axis=1) <= 0.1 + 1e-3)
    data = read_marker_csv(
        rec.to_csv(tmp_path / "c.csv"), ["M1", "M2", "M3"], rate=100, units="mm", inputs=["u1", "u2"]
    )
    np.testing.assert_allclose(data.positions, rec.positions, atol=1e-7)
    np.testing.assert_allclose(data.inputs, rec.u, rtol=1e-5)


def test_cli_fuse_reads_marker_csv_and_writes_inputs(tmp_path, capsys):
    from pcs_sindy.cli.main import main

    planar, q = _bending_robot(T=300)
    P3, _ = _to_capture(planar + 1e-5 * np.random.default_rng(5).standard_normal(planar.shape), 0.0)
    u = np.stack([np.maximum(q[:, 0], 0), np.maximum(-q[:, 0], 0)], axis=1)  # pulls with the bending
    rows = ["Frame,servo_a,servo_b," + ",".join(f"d{i}_{c}" for i in (1, 2, 3) for c in "XYZ")]
    rows += [f"{k},{u[k, 0]},{u[k, 1]}," + ",".join(f"{1e3 * v:.5f}" for v in P3[k].ravel()) for k in range(300)]
    (tmp_path / "run1.csv").write_text("\n".join(rows) + "\n")
    argv = ["fuse", "--markers-csv", str(tmp_path / "run1.csv"), "--markers", "d1", "d2", "d3", "--rate", "100"]
    argv += ["--units", "mm", "--input-columns", "servo_a", "servo_b", "--arc-lengths", "0.1", "0.2", "0.3"]
    assert main([*argv, "--out", str(tmp_path / "out"), "--quiet"]) in (0, None)
    with np.load(tmp_path / "out" / "run1.npz") as z:
        np.testing.assert_allclose(z["marker_arc_lengths"], [0.0, 0.1, 0.2, 0.3])
        assert z["q"].shape == (300, 3 * len(z["segment_lengths"]))
        np.testing.assert_allclose(z["t"], np.arange(300) * 0.01)
    with np.load(tmp_path / "out" / "inputs" / "run1.npz") as z:
        np.testing.assert_allclose(z["u"], u, rtol=1e-12, atol=1e-12)
    capsys.readouterr()
    assert main(["fuse", "--out", str(tmp_path / "o2"), "--quiet"]) == 2
    assert "give either pose files or --markers-csv" in capsys.readouterr().err


def test_positions_only_fusion_saves_and_loads(tmp_path):
    planar, _ = _bending_robot(T=200)
    P3, _ = _to_capture(planar + 1e-5 * np.random.default_rng(6).standard_normal(planar.shape), 0.0)
    tr = PoseTrajectory.from_positions(P3, dt=0.01, arc_lengths=[0.1, 0.2, 0.3])
    fusion = KinematicFusion(threshold=0.01).fit(tr)
    loaded = KinematicFusion.load(fusion.save(tmp_path / "seg.json"))
    assert loaded.positions_only_
    (a,), (b,) = fusion.transform(tr), loaded.transform(tr)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(fusion.base_pose_, loaded.base_pose_)


def _servo_stretch(q, u, scenario):
    """Closed-form tendon stretch of the servo scenario: r u pi/180 + l(q) - l(0) - s, both tendons to the tip."""
    act = scenario.actuation
    d = np.array([scenario.tendon_offset, -scenario.tendon_offset])
    c = np.asarray(scenario.segment_lengths)
    kappa, shear, axial = q[:, 0::3], q[:, 1::3], q[:, 2::3]
    length = np.stack(
        [np.sum(c * np.sqrt(shear**2 + (1 + axial + dk * kappa) ** 2), axis=1) for dk in d], axis=1
    )  # each segment's tendon path is an offset curve of constant tangent length
    return np.asarray(act.pulley_radius) * np.deg2rad(u) + length - np.sum(c) - np.asarray(act.slack)


def test_servo_scenario_tendons_pull_only_when_stretched():
    scenario = MocapScenario.servo(duration=6.0)
    assert scenario.actuation.drive == "displacement" and scenario.input_max == 90.0 and scenario.play == 4.0
    rec = scenario.generate(seed=0)
    applied = play_operator(rec.u, scenario.play)
    assert np.all(rec.u >= scenario.pretension) and np.max(rec.u) <= 90.0
    tension = scenario.robot.tendon_tensions(rec.q, applied)
    stretch = _servo_stretch(rec.q, applied, scenario)
    slack = stretch < 0
    assert 0.05 < slack.mean() < 0.95  # the tendons go slack and taut
    np.testing.assert_array_equal(tension[slack], 0.0)
    np.testing.assert_allclose(tension, 150.0 * np.maximum(stretch, 0.0), atol=1e-9)
    with pytest.raises(TypeError, match="actuation"):
        MocapScenario.servo(actuation=None)


def test_displacement_drive_identified_on_a_clean_servo_capture():
    """The simulator's servo drive and the identification's displacement drive are written independently:
    on the scenario's true strains the identified servo gain r k and the body stiffness match the truth."""
    from pcs_sindy.core import StrainTrajectory
    from pcs_sindy.identification import EulerLagrangeRegressor
    from pcs_sindy.models import TendonActuation

    scenario = MocapScenario.servo(duration=8.0)
    rec = scenario.generate(seed=0)
    strains = StrainTrajectory(rec.q, rec.t, segment_lengths=list(scenario.segment_lengths))
    # tendon stiffness and slack given, the pulley radius identified (variable projection)
    act = TendonActuation(
        [0.3, 0.3], [1, -1], offset=[0.012] * 2, drive="displacement", stiffness=[150.0] * 2, slack=[0.002] * 2
    )
    model = EulerLagrangeRegressor(actuation=act).fit([strains], [play_operator(rec.u, scenario.play)])
    r = model.actuation_.offsets_[2:4]
    np.testing.assert_allclose(r * 150.0, 0.012 * 150.0, rtol=5e-3)  # measured 1e-4
    ei = scenario.youngs_modulus * np.pi * scenario.radius**4 / 4
    ea = scenario.youngs_modulus * np.pi * scenario.radius**2
    np.testing.assert_allclose(model.stiffness_[0::3], ei, rtol=0.04)  # measured 1.3 %
    np.testing.assert_allclose(model.stiffness_[2::3], ea, rtol=5e-3)  # measured 0.03 %
    # passive with the servos at 0 deg (the tendons slack): released bent, the model comes to rest
    t = np.arange(1001) * 0.01
    sim = model.simulate(rec.q[np.argmax(np.abs(rec.q[:, 0]))], np.zeros(9), t, np.zeros((t.size, 2)))
    assert np.all(np.isfinite(sim.q)) and np.max(np.abs(sim.q[-50:, 0::3])) < 0.05 * np.max(np.abs(rec.q[:, 0::3]))
