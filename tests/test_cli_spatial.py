"""``pcs-sindy fit`` and ``pcs-sindy rollout`` on spatial (3-D) strain files.

Truth: the parameters the forces were made from (exact inverse dynamics of the spatial library
along smooth paths: the command line is under test, not the simulator), the loaded model file's own
rollout (the command must write what the model predicts), and the forward kinematics of the truth's
strains (the metrics are recomputed here from the written positions).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pcs_sindy.cli.main import main
from pcs_sindy.core.spatial import SpatialPCS, SpatialStrainTrajectory
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.identification.library.spatial_physical import SpatialPhysicalPCSLibrary
from pcs_sindy.io import load, write_poses, write_strains, write_tau

ACTIVE = np.array([1, 1, 0, 0, 0, 0], dtype=bool)  # both bendings of one segment: a rollout takes seconds
RHO, E, G, R = 1070.0, 1e4, 1e3, 0.02
DAMP = [3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15]


def _path(t, seed):
    rng = np.random.default_rng(seed)
    amp = rng.uniform(2.0, 5.0, (3, 2))
    f = rng.uniform(0.5, 3.0, (3, 2)) * 2 * np.pi
    ph = rng.uniform(0, 2 * np.pi, (3, 2))
    a = f[None] * t[:, None, None] + ph[None]
    return (amp * np.sin(a)).sum(1), (amp * f * np.cos(a)).sum(1), -(amp * f**2 * np.sin(a)).sum(1)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("spatial_cli")
    lib = SpatialPhysicalPCSLibrary([0.1], active_strains=ACTIVE, rest_strain=False).fit(np.zeros((1, 4)))
    coef = lib.coefficients_from_parameters(RHO, R, E, G, DAMP)
    kin = SpatialPCS((0.1,), ACTIVE)
    out = {"coef": coef, "names": lib.coefficient_names()}
    for k, duration in enumerate((1.5, 1.5, 0.12)):
        t = np.arange(0.0, duration, 0.01)
        q, qd, qdd = _path(t, k)
        tau = lib.euler_lagrange_matrix(q, qd, qdd) @ coef
        tr = SpatialStrainTrajectory(kin.to_full(q), t, segment_lengths=[0.1], active_strains=ACTIVE)
        out[f"strains_{k}"] = str(write_strains(d / f"strain_{k}.npz", tr))
        out[f"tau_{k}"] = str(write_tau(d / f"tau_{k}.npz", t, kin.to_full(tau)))
    out["dir"] = d
    return out


def test_fit_on_spatial_strain_files_writes_a_spatial_model(files, capsys):
    model = files["dir"] / "model.json"
    argv = ["fit", files["strains_0"], files["strains_1"], "--tau", files["tau_0"], files["tau_1"], "--out", str(model)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "k_bend_x_1" in text and "N·m³" in text
    reg = load(model)
    assert isinstance(reg, EulerLagrangeRegressor) and isinstance(reg.kinematics_, SpatialPCS)
    assert reg.kinematics_.strain_names(active_only=True) == ["bend_z_1", "bend_x_1"]
    coef = dict(zip(reg.library_.coefficient_names(), reg.model_coef_, strict=True))
    truth = dict(zip(files["names"], files["coef"], strict=True))
    for name in ("k_bend_z_1", "k_bend_x_1"):  # (the inertia of bending alone is weakly determined)
        assert coef[name] == pytest.approx(truth[name], rel=2e-2), name


def test_rollout_of_a_spatial_model_against_a_strain_file(files, capsys):
    model = files["dir"] / "model.json"
    if not model.exists():
        main(
            [
                "fit",
                files["strains_0"],
                files["strains_1"],
                "--tau",
                files["tau_0"],
                files["tau_1"],
                "--out",
                str(model),
            ]
        )
    out = files["dir"] / "rollout"
    argv = ["rollout", str(model), "--tau", files["tau_2"], "--truth", files["strains_2"], "--initial", "truth"]
    assert main([*argv, "--n-markers", "4", "--out", str(out), "--quiet"]) == 0
    with np.load(out / "rollout.npz") as npz:
        got = {k: npz[k] for k in npz.files}
    assert "poses" not in got and got["marker_positions"].shape == (12, 5, 3)
    assert got["marker_rotations"].shape == (12, 5, 3, 3)
    # what the loaded model predicts (same code, same numbers)
    reg = load(model)
    truth = load_strains(files["strains_2"])
    _, tau = np.load(files["tau_2"])["t"], np.load(files["tau_2"])["tau"]
    sim = reg.simulate(truth.q[0], np.zeros(6), truth.t, tau)
    np.testing.assert_array_equal(got["q"], sim.q)
    # the metrics, recomputed from the written positions and the truth's forward kinematics
    s = got["marker_arc_lengths"]
    np.testing.assert_allclose(s, np.linspace(0.0, 0.1, 5))
    p_true, R_true = truth.kinematics.forward_kinematics(truth.q, s)
    tip = np.linalg.norm(got["marker_positions"][:, -1] - p_true[:, -1], axis=-1)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["tip_position_rmse_mm"] == pytest.approx(1e3 * np.sqrt(np.mean(tip**2)), rel=1e-12)
    assert metrics["e_p_ee_mm"] == pytest.approx(1e3 * tip.mean(), rel=1e-12)
    rel = np.einsum("tji,tjk->tik", got["marker_rotations"][:, -1], R_true[:, -1])
    angle = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert metrics["e_theta_ee_rad"] == pytest.approx(angle.mean(), rel=1e-6, abs=1e-9)
    assert metrics["units"]["strain_rmse"] == {"bend_z_1": "1/m", "bend_x_1": "1/m"}
    assert 0 < metrics["tip_position_rmse_mm"] < 5.0  # exact data; the truth starts moving, the rollout at rest
    assert (out / "rollout.png").is_file() and (out / "rollout_strains.png").is_file()


def load_strains(path):
    from pcs_sindy.io import read_strains

    return read_strains(path)


def test_rollout_of_a_spatial_model_refuses_planar_truths_with_the_fix(files, capsys, tmp_path):
    model = files["dir"] / "model.json"
    if not model.exists():
        main(
            [
                "fit",
                files["strains_0"],
                files["strains_1"],
                "--tau",
                files["tau_0"],
                files["tau_1"],
                "--out",
                str(model),
            ]
        )
    t = np.arange(12) * 0.01
    poses = write_poses(tmp_path / "poses.npz", t, np.zeros((12, 5, 3)))
    capsys.readouterr()
    code = main(["rollout", str(model), "--tau", files["tau_2"], "--truth", str(poses), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "planar poses" in err and "strain file" in err
    csv = tmp_path / "capture.csv"
    csv.write_text("t,x\n0,0\n")
    code = main(["rollout", str(model), "--tau", files["tau_2"], "--truth", str(csv), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "give --segmentation" in err
    # a planar segmentation cannot map a spatial model to the capture frame
    from pcs_sindy.core import PoseTrajectory
    from pcs_sindy.core.kinematics import forward_kinematics
    from pcs_sindy.fusion import KinematicFusion
    from pcs_sindy.io import save

    q = np.outer(np.sin(np.linspace(0, 3, 30)), [8.0, 0.0, 0.0])
    poses = forward_kinematics(q, [0.1], np.linspace(0.0, 0.1, 4))
    seg = save(KinematicFusion().fit([PoseTrajectory(poses, np.arange(30) * 0.01)]), tmp_path / "segmentation")
    argv = ["rollout", str(model), "--tau", files["tau_2"], "--truth", str(csv), "--segmentation", str(seg)]
    code = main([*argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "this segmentation is planar" in err
    # a tau file of another width names the strain count per segment
    bad = write_tau(tmp_path / "bad.npz", t, np.zeros((12, 3)))
    code = main(["rollout", str(model), "--tau", str(bad), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "1 segment(s) x 6" in err


def test_fit_and_rollout_from_tensions_of_tendons_routed_in_3d(tmp_path):
    """``fit --inputs --actuation`` with the simulator's own layout, then ``rollout`` of the tendon-driven model."""
    from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot, SpatialTendons

    tendons = SpatialTendons([0.1, 0.1], [[0.01, 0.0], [0.0, -0.01]])
    rob = SpatialPCSRobot([0.1], RHO, E, G, DAMP, actuation=tendons)
    rng = np.random.default_rng(0)
    for k, duration in enumerate((1.5, 1.5, 0.08)):
        t = np.arange(0.0, duration, 0.01)
        f, ph = rng.uniform(0.5, 3.0, (3, 2)), rng.uniform(0, 2 * np.pi, (3, 2))
        u = 1.0 + np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).mean(axis=1)  # tensions [N]
        write_strains(tmp_path / f"strain_{k}.npz", rob.simulate(np.zeros(6), np.zeros(6), t, u))
        write_tau(tmp_path / f"input_{k}.npz", t, u, key="u")
    (tmp_path / "layout.json").write_text(json.dumps(tendons.layout()))
    model = tmp_path / "model.json"
    strains = [str(tmp_path / f"strain_{k}.npz") for k in (0, 1)]
    inputs = [str(tmp_path / f"input_{k}.npz") for k in (0, 1)]
    argv = ["fit", *strains, "--inputs", *inputs, "--actuation", str(tmp_path / "layout.json"), "--out", str(model)]
    assert main([*argv, "--quiet"]) == 0
    reg = load(model)
    assert reg.actuation_.kind == "spatial_tendon" and reg.actuation_.design_layout() == tendons.layout()
    np.testing.assert_allclose(reg.stiffness_[:2], rob.stiffness[:2], rtol=1e-2)
    out = tmp_path / "rollout"
    argv = ["rollout", str(model), "--tau", str(tmp_path / "input_2.npz"), "--truth", str(tmp_path / "strain_2.npz")]
    assert main([*argv, "--initial", "truth", "--n-markers", "2", "--no-plot", "--quiet", "--out", str(out)]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["tip_position_rmse_mm"] < 0.05  # starts at rest like the truth; 80 ms


def test_rollout_of_a_spatial_model_against_a_motion_capture_in_its_frame(tmp_path):
    """``rollout --truth capture.csv --segmentation`` of a 3-D fusion: the prediction in the capture frame."""
    from pcs_sindy.io import read_strains

    # a capture of a robot hanging along -y from a base off the origin, bending both ways (positions in mm)
    true_kin = SpatialPCS((0.06, 0.06), np.tile(ACTIVE, 2))
    T, arcs = 40, [0.04, 0.08, 0.12]
    t = np.arange(T) * 0.01
    q = np.zeros((T, 12))
    q[:, [0, 1, 6, 7]] = 6.0 * np.sin(2 * np.pi * np.array([0.9, 1.3, 1.1, 0.7]) * t[:, None] + [0.3, 1.0, 2.0, 0.5])
    base_R = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    base_p = np.array([0.1, 0.5, 0.2])
    P = true_kin.forward_kinematics(q, arcs)[0] @ base_R.T + base_p
    rows = ["frame," + ",".join(f"M{k}_{a}" for k in (1, 2, 3) for a in "XYZ")]
    rows += [f"{i}," + ",".join(f"{v:.7f}" for v in 1e3 * P[i].ravel()) for i in range(T)]
    csv = tmp_path / "capture.csv"
    csv.write_text("\n".join(rows) + "\n")
    fused = tmp_path / "fused"
    args = ["fuse", "--markers-csv", str(csv), "--markers", "M1", "M2", "M3", "--rate", "100", "--units", "mm"]
    assert main([*args, "--space", "3d", "--arc-lengths", *map(str, arcs), "--out", str(fused), "--quiet"]) == 0
    segmentation = load(fused / "segmentation.json")
    measured = read_strains(fused / "capture.npz")
    # a model of the fused segmentation, fitted on exact data
    kin = measured.kinematics
    lib = SpatialPhysicalPCSLibrary(list(kin.segment_lengths), active_strains=kin.active_strains, rest_strain=False)
    lib.fit(np.zeros((1, 2 * kin.n_active)))
    coef = lib.coefficients_from_parameters(RHO, R, E, G, np.tile(DAMP, kin.n_segments))
    strains, taus = [], []
    for k in range(2):
        tt = np.arange(0.0, 1.5, 0.01)
        rng = np.random.default_rng(k)
        f, ph = rng.uniform(0.5, 3.0, (3, kin.n_active)) * 2 * np.pi, rng.uniform(0, 6, (3, kin.n_active))
        a = f[None] * tt[:, None, None] + ph[None]
        qa, qda, qdda = 3 * np.sin(a).sum(1), 3 * (f * np.cos(a)).sum(1), -3 * (f**2 * np.sin(a)).sum(1)
        tau = kin.to_full(lib.euler_lagrange_matrix(qa, qda, qdda) @ coef)
        tr = SpatialStrainTrajectory(
            kin.to_full(qa), tt, segment_lengths=kin.segment_lengths, active_strains=kin.active_strains
        )
        strains.append(str(write_strains(tmp_path / f"train_{k}.npz", tr)))
        taus.append(str(write_tau(tmp_path / f"train_tau_{k}.npz", tt, tau)))
    model = tmp_path / "model.json"
    assert main(["fit", *strains, "--tau", *taus, "--out", str(model), "--quiet"]) == 0
    zero = write_tau(tmp_path / "hold.npz", t, np.zeros((T, kin.n_q)))
    out = tmp_path / "rollout"
    argv = [
        "rollout",
        str(model),
        "--tau",
        str(zero),
        "--truth",
        str(csv),
        "--segmentation",
        str(fused / "segmentation.json"),
    ]
    assert main([*argv, "--initial", "truth", "--no-plot", "--quiet", "--out", str(out)]) == 0
    with np.load(out / "rollout.npz") as npz:
        got = {key: npz[key] for key in npz.files}
    # the written positions are the 3-D fusion's markers of the rolled-out strains, in the capture frame
    sim = SpatialStrainTrajectory(got["q"], t, segment_lengths=kin.segment_lengths, active_strains=kin.active_strains)
    sim.metadata.update(
        {key: measured.metadata[key] for key in ("base_pose", "marker_offsets") if key in measured.metadata}
    )
    (back,) = segmentation.inverse_transform([sim])
    np.testing.assert_allclose(got["positions"], back.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got["positions_measured"], P, rtol=0, atol=1e-9)
    tip = np.linalg.norm(got["positions"][:, -1] - P[:, -1], axis=1)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["truth_kind"] == "capture" and metrics["frame"] == "capture"
    assert metrics["tip_position_rmse_mm"] == pytest.approx(1e3 * np.sqrt(np.mean(tip**2)), rel=1e-9)
    assert tip[0] < 1e-3  # it starts where the capture starts (the fused first frame, mapped back)
