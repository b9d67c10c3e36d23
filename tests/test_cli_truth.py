"""The command line against measurements (issue 28): ``rollout --truth`` with a strain file or a
motion-capture CSV, ``fuse --markers-csv ... --inputs LOG``, the rollout plot without a truth, and
each command's own help epilog.

Truth comes from outside the code under test: marker positions built here from closed-form forward
kinematics and the fitted plane (``MarkerPlane.from_plane``), a known constant offset of the capture,
numpy formulas on the files written, and input logs whose held values are known by construction.
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np
import pytest

from pcs_sindy.cli.main import EPILOGS, build_parser, main
from pcs_sindy.core import MarkerPlane, PlanarPCS
from pcs_sindy.core.kinematics import forward_kinematics
from pcs_sindy.io import DataFileError, align_inputs, load, read_input_log

RATE = 100.0


def _fail(capsys, argv) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"pcs-sindy {argv[0]}: error: "), err
    return err[0]


def _write_capture(path: Path, positions: np.ndarray, inputs: np.ndarray | None = None) -> Path:
    """A one-header-row capture in mm (Frame, [u1, u2,] M1_X ... M3_Z), as MocapRecording.to_csv writes."""
    head = ["Frame"] + ([f"u{k + 1}" for k in range(inputs.shape[1])] if inputs is not None else [])
    head += [f"M{i + 1}_{c}" for i in range(positions.shape[1]) for c in "XYZ"]
    rows = [",".join(head)]
    for k in range(positions.shape[0]):
        cells = [str(k)] + ([f"{v:.9g}" for v in inputs[k]] if inputs is not None else [])
        cells += [f"{1e3 * v:.6f}" for v in positions[k].ravel()]
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def mocap(tmp_path_factory):
    """A simulated 4 s capture fused ('fuse --markers-csv', inputs as CSV columns) and fitted ('fit --inputs')."""
    from pcs_sindy.fusion import tendon_sides
    from pcs_sindy.io import read_strains
    from pcs_sindy.simulation import MocapScenario

    root = tmp_path_factory.mktemp("mocap")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PCS_SINDY_CACHE", str(root / "cache"))
        rec = MocapScenario(duration=8.0).generate(seed=0)
        csv = _write_capture(root / "take.csv", rec.positions, rec.u)
        argv = ["fuse", "--markers-csv", str(csv), "--markers", "M1", "M2", "M3", "--rate", str(RATE)]
        argv += [
            "--units",
            "mm",
            "--input-columns",
            "u1",
            "u2",
            "--threshold",
            "0.2",
            "-o",
            str(root / "strains"),
            "-q",
        ]
        assert main(argv) == 0
        fusion = load(root / "strains" / "segmentation.json")
        strains = read_strains(root / "strains" / "take.npz")
        inputs = root / "strains" / "inputs" / "take.npz"
        with np.load(inputs) as z:
            sides = tendon_sides([strains], [z["u"]])
        end = float(fusion.total_length_) * (1 - 1e-6)
        layout = {"type": "tendon", "end": [end, end], "side": sides, "offset": [0.012, 0.012]}
        (root / "tendons.json").write_text(json.dumps(layout))
        argv = ["fit", str(root / "strains" / "take.npz"), "--inputs", str(inputs), "--actuation"]
        argv += [str(root / "tendons.json"), "-o", str(root / "model") + "/", "-q"]
        assert main(argv) == 0
        yield root


def _rollout(root: Path, out: Path, *extra: str) -> list[str]:
    return [
        "rollout",
        str(root / "model" / "model.json"),
        "--tau",
        str(root / "strains" / "inputs" / "take.npz"),
        "--segmentation",
        str(root / "strains" / "segmentation.json"),
        "-o",
        str(out),
        "-q",
        *extra,
    ]


def _capture_of_model(root: Path) -> tuple[np.ndarray, np.ndarray]:
    """The model's own open-loop markers in the capture frame, by forward kinematics and the fitted plane."""
    model, fusion = load(root / "model" / "model.json"), load(root / "strains" / "segmentation.json")
    with np.load(root / "strains" / "inputs" / "take.npz") as z:
        t, u = z["t"], z["u"]
    n = model.kinematics_.n_q
    sim = model.simulate(np.zeros(n), np.zeros(n), t, u, progress=False)
    assert np.all(fusion.marker_offsets_ == 0)  # markers on the backbone: the formula below holds
    planar = forward_kinematics(sim.q, fusion.segment_lengths_, fusion.marker_arc_lengths_, base_pose=fusion.base_pose_)
    plane = MarkerPlane(fusion.plane_origin_, fusion.plane_axes_)
    return plane.from_plane(planar[:, 1:, :2]), sim.q


def test_rollout_against_a_capture_compares_in_the_capture_frame(mocap, tmp_path, capsys):
    truth, _ = _capture_of_model(mocap)
    csv = _write_capture(tmp_path / "truth.csv", truth)  # a Motive-like export: positions only
    capsys.readouterr()
    assert main(_rollout(mocap, tmp_path / "a", "--truth", str(csv))) == 0  # markers/rate/units from capture.json
    metrics = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert metrics["truth_kind"] == "capture" and metrics["frame"] == "capture"
    assert metrics["n_samples_measured"] > 0.5 * truth.shape[0]
    assert metrics["tip_position_rmse_mm"] < 1e-3  # the model's own motion, written to 1 nm
    assert metrics["units"]["tip_position_rmse_mm"] == "mm" and metrics["units"]["strain_rmse"] == {"be_1": "1/m"}
    with np.load(tmp_path / "a" / "rollout.npz") as z:
        measured, predicted = z["positions_measured"], z["positions"]
    ok = np.isfinite(measured)
    assert ok.mean() > 0.5
    np.testing.assert_allclose(measured[ok], truth[ok], atol=1e-9)  # the CSV as written, frozen samples left out
    tip = np.all(ok[:, -1], axis=1)
    err = np.linalg.norm(predicted[tip, -1] - measured[tip, -1], axis=1)
    assert metrics["tip_position_rmse_mm"] == pytest.approx(1e3 * np.sqrt(np.mean(err**2)), rel=1e-9, abs=1e-12)

    # the capture moved by a known 5 mm along X: the error is that offset, in every sample
    shifted = _write_capture(tmp_path / "shifted.csv", truth + np.array([0.005, 0.0, 0.0]))
    assert main(_rollout(mocap, tmp_path / "b", "--truth", str(shifted))) == 0
    metrics = json.loads((tmp_path / "b" / "metrics.json").read_text())
    assert metrics["tip_position_rmse_mm"] == pytest.approx(5.0, abs=2e-3)
    assert metrics["tip_position_mean_mm"] == pytest.approx(5.0, abs=2e-3)
    assert metrics["marker_position_mean_mm"] == pytest.approx(5.0, abs=2e-3)
    assert (tmp_path / "b" / "rollout.png").stat().st_size > 0


def test_rollout_from_the_captures_first_frame(mocap, tmp_path, capsys):
    """--initial truth: q0 is the capture's first frame fused in the segmentation, as 'fuse' wrote it."""
    csv = mocap / "take.csv"
    assert main(_rollout(mocap, tmp_path / "a", "--truth", str(csv), "--initial", "truth", "--no-plot")) == 0
    with np.load(tmp_path / "a" / "rollout.npz") as roll, np.load(mocap / "strains" / "take.npz") as fused:
        np.testing.assert_allclose(roll["q"][0], fused["q"][0], rtol=0, atol=1e-9)
        assert abs(fused["q"][0, 0]) > 1e-3  # not the rest state
    recording = tmp_path / "rec.npz"
    np.savez(recording, poses=np.zeros((800, 4, 3)))
    line = _fail(capsys, _rollout(mocap, tmp_path / "b", "--truth", str(recording), "--initial", "truth"))
    assert "--initial truth needs" in line


def test_rollout_capture_truth_errors_are_one_line(mocap, tmp_path, capsys):
    truth, _ = _capture_of_model(mocap)
    short = _write_capture(tmp_path / "short.csv", truth[:-5])
    assert "has 795 samples" in _fail(capsys, _rollout(mocap, tmp_path / "o", "--truth", str(short)))
    argv = _rollout(mocap, tmp_path / "o", "--truth", str(short))
    i = argv.index("--segmentation")
    assert "give --segmentation" in _fail(capsys, argv[:i] + argv[i + 2 :])
    two = _write_capture(tmp_path / "two.csv", truth[:, :2])
    assert "M3" in _fail(capsys, _rollout(mocap, tmp_path / "o", "--truth", str(two)))


def test_rollout_against_a_strain_file(mocap, tmp_path):
    strain_file = mocap / "strains" / "take.npz"
    assert main(_rollout(mocap, tmp_path, "--truth", str(strain_file), "--initial", str(strain_file))) == 0
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["truth_kind"] == "strains"
    with np.load(tmp_path / "rollout.npz") as roll, np.load(strain_file) as st:
        q_pred, q_true, s = roll["q"], st["q"], roll["marker_arc_lengths"]
        kin = PlanarPCS(tuple(st["segment_lengths"]))
    assert metrics["strain_rmse"]["be_1"] == pytest.approx(np.sqrt(np.mean((q_pred[:, 0] - q_true[:, 0]) ** 2)))
    assert set(metrics["strain_rmse"]) == {"be_1"}  # shear and stretch are not modelled
    tip_pred, tip_true = kin.forward_kinematics(q_pred, s)[:, -1], kin.forward_kinematics(q_true, s)[:, -1]
    assert metrics["e_p_ee_mm"] == pytest.approx(
        1e3 * np.mean(np.hypot(*(tip_pred[:, :2] - tip_true[:, :2]).T)), rel=1e-9
    )
    assert (tmp_path / "rollout_strains.png").stat().st_size > 0
    assert metrics["units"]["e_p_ee_mm"] == "mm" and metrics["units"]["e_theta_ee_rad"] == "rad"


def test_rollout_truth_that_is_neither_poses_nor_strains(mocap, tmp_path, capsys):
    np.savez(tmp_path / "odd.npz", x=np.zeros(3))
    line = _fail(capsys, _rollout(mocap, tmp_path / "o", "--truth", str(tmp_path / "odd.npz")))
    assert "neither poses" in line and "['x']" in line


def test_rollout_plot_without_truth_has_a_title_and_only_modelled_strains(mocap, tmp_path, monkeypatch):
    from pcs_sindy.cli import report

    drawn = []
    monkeypatch.setattr(report, "_save", lambda fig, path, into: drawn.append(fig) or Path(path))
    assert main(_rollout(mocap, tmp_path)) == 0
    (fig,) = drawn
    assert len(fig.axes) == 1  # bending only: the model has no shear or stretch
    ax = fig.axes[0]
    assert "no truth" in ax.get_title() and "model.json" in ax.get_title()
    assert [line.get_label() for line in ax.get_lines()] == ["be_1"]
    assert "[1/m]" in ax.get_ylabel()


# --------------------------------------------------------------------------
# fuse --markers-csv ... --inputs LOG
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    from pcs_sindy.simulation import MocapScenario

    root = tmp_path_factory.mktemp("capture")
    rec = MocapScenario(duration=2.0).generate(seed=1)
    # the logged inputs: any numbers do (fuse only puts them on the capture's samples)
    u = np.random.default_rng(3).uniform(0.0, 1.0, size=(rec.positions.shape[0], 2))
    return _write_capture(root / "take.csv", rec.positions), u


def _fuse_with_log(capture_csv: Path, log: Path, out: Path, *extra: str) -> list[str]:
    argv = ["fuse", "--markers-csv", str(capture_csv), "--markers", "M1", "M2", "M3", "--rate", str(RATE)]
    return [*argv, "--units", "mm", "--inputs", str(log), "--threshold", "0.2", "-o", str(out), "-q", *extra]


def test_fuse_takes_inputs_from_a_log_paired_by_frame(capture, tmp_path):
    csv, u = capture
    T = u.shape[0]
    frames = np.arange(0, T, 3)  # logged at a third of the capture rate
    lines = ["Frame,Time (s),servo_a,servo_b"] + [
        f"{k},{k / RATE + 7.0},{float(u[k, 0])!r},{float(u[k, 1])!r}" for k in frames
    ]
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    assert main(_fuse_with_log(csv, tmp_path / "log.csv", tmp_path / "out")) == 0
    with np.load(tmp_path / "out" / "inputs" / "take.npz") as z:
        held = u[(np.arange(T) // 3) * 3]  # each sample holds the last logged row
        np.testing.assert_array_equal(z["u"], held)
    capture_json = json.loads((tmp_path / "out" / "capture.json").read_text())
    assert capture_json["input_columns"] == ["servo_a", "servo_b"] and capture_json["units"] == "mm"


@pytest.mark.parametrize("kind", ["npy", "npz_t", "csv_rows"])
def test_fuse_input_logs_by_count_or_time(capture, tmp_path, kind):
    csv, u = capture
    if kind == "npy":
        np.save(tmp_path / "log.npy", u)
        log = tmp_path / "log.npy"
    elif kind == "npz_t":  # a clock starting elsewhere; logged every 20 ms: held over two capture samples
        np.savez(tmp_path / "log.npz", u=u[::2], t=1000.0 + np.arange(0, u.shape[0], 2) / RATE)
        log = tmp_path / "log.npz"
    else:
        (tmp_path / "log.csv").write_text("\n".join(f"{float(a)!r},{float(b)!r}" for a, b in u) + "\n")  # no header
        log = tmp_path / "log.csv"
    assert main(_fuse_with_log(csv, log, tmp_path / "out")) == 0
    expected = u[(np.arange(u.shape[0]) // 2) * 2] if kind == "npz_t" else u
    with np.load(tmp_path / "out" / "inputs" / "take.npz") as z:
        np.testing.assert_array_equal(z["u"], expected)


def test_fuse_input_log_errors_are_one_line(capture, tmp_path, capsys):
    csv, u = capture
    np.save(tmp_path / "short.npy", u[:-3])
    line = _fail(capsys, _fuse_with_log(csv, tmp_path / "short.npy", tmp_path / "o"))
    assert f"has {u.shape[0] - 3} rows" in line and f"has {u.shape[0]} samples" in line and "Frame" in line
    (tmp_path / "late.csv").write_text("index,u\n5,1\n6,2\n")
    assert "after the capture's first sample" in _fail(
        capsys, _fuse_with_log(csv, tmp_path / "late.csv", tmp_path / "o")
    )
    argv = _fuse_with_log(csv, tmp_path / "short.npy", tmp_path / "o")
    i = argv.index("--inputs")
    two = [*argv[: i + 2], str(tmp_path / "short.npy"), *argv[i + 2 :]]
    assert "one input log per capture" in _fail(capsys, two)


def test_input_log_reader_and_alignment(tmp_path):
    (tmp_path / "a.tsv").write_text("Sample\tt\tleft\tright\n10\t0.0\t1\t2\n12\t0.02\t3\t4\n13\t0.03\t5\t6\n")
    log = read_input_log(tmp_path / "a.tsv", ["right"])
    assert log.names == ["right"] and log.index.tolist() == [10, 12, 13] and log.t is None
    # capture frames 10..14: frame 11 holds frame 10's input, 14 holds 13's (within one logging step)
    np.testing.assert_array_equal(align_inputs(log, 5, 0.01, first_frame=10)[:, 0], [2, 2, 4, 6, 6])
    with pytest.raises(DataFileError, match="starts at frame 10"):
        align_inputs(log, 3, 0.01, first_frame=9)
    with pytest.raises(DataFileError, match="ends"):
        align_inputs(log, 9, 0.01, first_frame=10)
    with pytest.raises(DataFileError, match="no input column named 'middle'"):
        read_input_log(tmp_path / "a.tsv", ["middle"])
    (tmp_path / "b.csv").write_text("t,u\n0,1\n0.5,\n")
    with pytest.raises(DataFileError, match="empty or NaN"):
        read_input_log(tmp_path / "b.csv")


# --------------------------------------------------------------------------
# help epilogs
# --------------------------------------------------------------------------
def _helps(capsys) -> dict[str, str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    out = {}
    for name in sub.choices:
        with pytest.raises(SystemExit):
            main([name, "--help"])
        out[name] = capsys.readouterr().out
    return out


def test_every_command_has_its_own_epilog_with_examples_that_parse(capsys):
    helps = _helps(capsys)
    assert set(helps) == set(EPILOGS)
    epilogs = {name: text[text.index("\nexample") :] for name, text in helps.items()}
    formats = {name: text[text.find("\nfile formats") : text.index("\nexample")] for name, text in helps.items()}
    assert len(set(epilogs.values())) == len(epilogs)  # no two commands share one
    parser = build_parser()
    for name, text in epilogs.items():
        commands = " ".join(line.split("#")[0] for line in text.replace("\\\n", " ").splitlines()).split("pcs-sindy ")
        examples = [shlex.split(c) for c in commands[1:]]
        assert examples and all(ex[0] == name for ex in examples), name
        for ex in examples:  # every flag of an example exists and its values parse
            parser.parse_args(ex)
    # the file formats a command reads or writes, and only those
    assert "strain file" in formats["fuse"] and "  recording" not in formats["fuse"]
    assert "tau file" in formats["fit"] and "pose file" not in formats["fit"]
    assert "strain file" in formats["rollout"] and "input file" in formats["rollout"]
    assert "file formats" not in helps["scenarios"]
