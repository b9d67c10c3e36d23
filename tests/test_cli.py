"""The ``pcs-sindy`` command line on tiny inputs, in-process through ``main``.

Truth comes from outside the command under test: the recordings' own poses
(closed-form forward kinematics of the simulated strains), the inputs of a
render -> extract round trip, plain numpy formulas for the seed's metrics, and
the files each command was given.  Failure exits check the exit code, a
single stderr line and the absence of a traceback.
"""

from __future__ import annotations

import importlib
import inspect
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pcs_sindy.cli import main as cli_main
from pcs_sindy.cli.commands import CLIError, build_regressor, fit, pipeline_step, rollout
from pcs_sindy.cli.defaults import read_default
from pcs_sindy.cli.main import build_parser, command_kwargs, main
from pcs_sindy.core import PlanarPCS, wrap_angle

COMMANDS = ["scenarios", "simulate", "render", "calibrate", "extract", "fuse", "fit", "rollout", "demo"]


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """Two 0.1 s one_segment recordings (no validation), simulated by the CLI."""
    root = tmp_path_factory.mktemp("cli")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PCS_SINDY_CACHE", str(root / "cache"))  # keep the user's cache out of the tests
        code = main(
            [
                "simulate",
                "one_segment",
                "--out",
                str(root / "data"),
                "--n-train",
                "2",
                "--train-duration",
                "0.1",
                "--no-validation",
                "--quiet",
            ]
        )
        assert code == 0
        yield root


def _fail(capsys, argv) -> str:
    """Run a command that must fail; return its one-line message."""
    capsys.readouterr()
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pcs-sindy {argv[0]}: error: ")
    return lines[0]


# --------------------------------------------------------------------------
def test_console_script_help_lists_every_command():
    exe = Path(sys.executable).with_name("pcs-sindy")
    cmd = [str(exe), "--help"] if exe.exists() else [sys.executable, "-m", "pcs_sindy.cli.main", "--help"]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    for name in COMMANDS:
        assert name in res.stdout
    assert "file formats" in res.stdout


# --------------------------------------------------------------------------
# start-up: parsing imports no stage (speed: benchmarks/cli_startup.py)
# --------------------------------------------------------------------------
#: what a command loads when it runs, never the parser
HEAVY = ("numpy", "scipy", "sklearn", "cv2", "numba", "pysindy", "sympy", "matplotlib", "joblib")

_FRESH_PROCESS = """
import contextlib, io, json, sys

import pcs_sindy

root = set(sys.modules)  # what importing the package root loads (not the command line's doing)
from pcs_sindy.cli.main import build_parser, main

build_parser()
runs = []
for argv in json.loads(sys.argv[1]):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    runs.append({"argv": argv, "code": code, "out": out.getvalue(), "err": err.getvalue(),
                 "modules": sorted(sys.modules)})
print(json.dumps({"root": sorted(root), "runs": runs}))
"""


def test_help_version_and_usage_errors_import_no_stage():
    argvs = [
        ["--help"],
        *([command, "--help"] for command in COMMANDS),
        ["--version"],
        ["fit", "s.npz", "--tau", "t.npz", "--out", "m", "--no-such-option"],
        ["fit", "s.npz", "--tau", "t.npz"],
        ["rollout", "m.json", "--tau", "t.npz", "--out", "o", "--method", "euler"],
    ]
    res = subprocess.run(
        [sys.executable, "-c", _FRESH_PROCESS, json.dumps(argvs)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout)
    assert len(report["runs"]) == len(argvs)
    for run in report["runs"]:
        assert run["code"] == (0 if run["argv"][-1] in ("--help", "--version") else 2), run
        modules = set(run["modules"])
        heavy = sorted(m for m in modules if m.split(".")[0] in HEAVY)
        assert not heavy, f"{run['argv']} imported {heavy[:5]}"
        stages = sorted(m for m in modules - set(report["root"]) if m.startswith("pcs_sindy."))
        assert all(m == "pcs_sindy.cli" or m.startswith("pcs_sindy.cli.") for m in stages), f"{run['argv']}: {stages}"


def test_version_is_the_packages(capsys):
    import pcs_sindy

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"pcs-sindy {pcs_sindy.__version__}\n"
    exe = Path(sys.executable).with_name("pcs-sindy")
    cmd = [str(exe), "--version"] if exe.exists() else [sys.executable, "-m", "pcs_sindy.cli.main", "--version"]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert (res.returncode, res.stdout) == (0, f"pcs-sindy {pcs_sindy.__version__}\n"), res.stderr


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: pcs-sindy {command}")


def test_simulate_writes_recordings_with_true_poses(work):
    data = work / "data"
    summary = json.loads((data / "scenario.json").read_text())
    assert summary["files"] == ["train_00.npz", "train_01.npz"]
    assert summary["units"]["marker_arc_lengths"] == "m" and summary["units"]["noise"] == ["m", "rad"]
    kin = PlanarPCS((0.1,))
    s = np.asarray(summary["marker_arc_lengths"])
    for name in summary["files"]:
        with np.load(data / name) as rec:
            assert rec["t"].shape == (100,) and rec["tau"].shape == (100, 3) and rec["poses"].shape == (100, 21, 3)
            np.testing.assert_allclose(rec["poses_true"], kin.forward_kinematics(rec["q"], s), atol=1e-12)
            assert np.ptp(rec["q"][:, 0]) > 1.0  # the robot moves


def test_render_then_extract_recovers_the_poses(work, capsys):
    recs = [str(work / "data" / f"train_0{k}.npz") for k in range(2)]
    videos = work / "videos"
    assert (
        main(["render", *recs, "--out", str(videos), "--size", "320x240", "--marker-size", "0.010,0.0025", "--quiet"])
        == 0
    )
    for k in range(2):
        assert (videos / f"train_0{k}.avi").is_file()
        cam = json.loads((videos / f"train_0{k}.avi.camera.json").read_text())
        assert cam["image_size"] == [320, 240] and cam["fps"] == pytest.approx(1000.0)
    serial, parallel = work / "poses", work / "poses_par"
    assert main(["extract", *[str(videos / f"train_0{k}.avi") for k in range(2)], "--out", str(serial), "--quiet"]) == 0
    assert (
        main(
            [
                "extract",
                *[str(videos / f"train_0{k}.avi") for k in range(2)],
                "--out",
                str(parallel),
                "--n-jobs",
                "2",
                "--quiet",
            ]
        )
        == 0
    )
    for k in range(2):
        with (
            np.load(recs[k]) as rec,
            np.load(serial / f"train_0{k}.npz") as got,
            np.load(parallel / f"train_0{k}.npz") as par,
        ):
            np.testing.assert_allclose(got["t"], rec["t"], atol=1e-9)
            err_p = np.linalg.norm(got["poses"][..., :2] - rec["poses"][..., :2], axis=-1)
            err_th = np.abs(wrap_angle(got["poses"][..., 2] - rec["poses"][..., 2]))
            assert err_p.max() < 5e-4 and np.sqrt(np.mean(err_p**2)) < 1e-4  # metres
            assert np.rad2deg(err_th.max()) < 5.0
            np.testing.assert_array_equal(par["poses"], got["poses"])


def test_rest_length_travels_through_pose_files(work, tmp_path, capsys):
    from pcs_sindy.io import write_poses
    from pcs_sindy.io.data_files import read_rest_length

    recs = [work / "data" / f"train_0{k}.npz" for k in range(2)]
    files = []
    for k, rec in enumerate(recs):
        with np.load(rec) as data:
            files.append(str(write_poses(tmp_path / f"p{k}.npz", data["t"], data["poses"], rest_length=0.1)))
    assert read_rest_length(files[0]) == 0.1
    capsys.readouterr()
    assert main(["fuse", *files, "--out", str(tmp_path / "fused")]) == 0
    printed = capsys.readouterr().out
    assert "total 0.1000 m" in printed and "note:" not in printed  # given with the poses, not estimated
    with np.load(tmp_path / "fused" / "p0.npz") as st:
        assert np.sum(st["segment_lengths"]) == pytest.approx(0.1, rel=1e-12)
    # without it the length is estimated, and the user is told so
    with np.load(recs[0]) as data:
        write_poses(tmp_path / "bare.npz", data["t"], data["poses"])
    assert read_rest_length(tmp_path / "bare.npz") is None
    assert main(["fuse", str(tmp_path / "bare.npz"), "--out", str(tmp_path / "bare")]) == 0
    assert "note: the rest length was estimated" in capsys.readouterr().out


def test_fuse_strains_reproduce_the_poses(work, capsys):
    recs = [str(work / "data" / f"train_0{k}.npz") for k in range(2)]
    out = work / "strains"
    capsys.readouterr()
    assert main(["fuse", *recs, "--out", str(out), "--total-length", "0.1"]) == 0
    printed = capsys.readouterr().out
    assert "1 segment(s)" in printed
    assert (out / "segmentation.json").is_file()
    for k in range(2):
        with np.load(out / f"train_0{k}.npz") as st, np.load(recs[k]) as rec:
            lengths = st["segment_lengths"]
            assert lengths.shape == (1,) and lengths[0] == pytest.approx(0.1, rel=1e-12)
            assert st["q"].shape == (100, 3)
            # independent forward kinematics of the fused strains gives back the recorded markers
            poses = PlanarPCS(tuple(lengths)).forward_kinematics(st["q"], st["marker_arc_lengths"])
            assert np.abs(poses[..., :2] - rec["poses"][..., :2]).max() < 2e-5
            # and the strains are the simulated ones (same single segment)
            np.testing.assert_allclose(st["q"], rec["q"], atol=5e-3 * np.abs(rec["q"]).max())
    from pcs_sindy.io import load

    fusion = load(out / "segmentation.json")
    with np.load(out / "train_00.npz") as st:
        np.testing.assert_array_equal(fusion.segment_lengths_, st["segment_lengths"])


def test_fit_and_rollout_reproduce_a_training_recording(work, capsys):
    recs = [str(work / "data" / f"train_0{k}.npz") for k in range(2)]
    strains = [str(work / "strains" / f"train_0{k}.npz") for k in range(2)]
    if not Path(strains[0]).exists():
        assert main(["fuse", *recs, "--out", str(work / "strains"), "--total-length", "0.1", "--quiet"]) == 0
    model = work / "model" / "model.json"
    capsys.readouterr()
    # tau files in the reverse order: matched by name (stem), not by position
    assert main(["fit", *strains, "--tau", *recs[::-1], "--out", str(model)]) == 0
    printed = capsys.readouterr().out
    assert "L = " in printed and "D = diag(" in printed and "stiffness:" in printed
    assert model.is_file()
    # identified bending stiffness near the simulator's E I (f_L = 1): 1e4 * pi * 0.02**4 / 4
    value, unit = printed.split("stiffness: be_1 ")[1].split(",")[0].split()
    assert float(value) == pytest.approx(1e4 * np.pi * 0.02**4 / 4, rel=0.15)
    assert unit == "N·m³"  # K q is a generalised force: N·m² per curvature unit 1/m
    assert "damping:   be_1 " in printed and printed.split("damping:   be_1 ")[1].split(",")[0].endswith("N·m³·s")

    out = work / "rollout"
    assert (
        main(
            [
                "rollout",
                str(model),
                "--tau",
                recs[0],
                "--truth",
                recs[0],
                "--initial",
                strains[0],
                "--segmentation",
                str(work / "strains" / "segmentation.json"),
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    metrics = json.loads((out / "metrics.json").read_text())
    with np.load(out / "rollout.npz") as roll, np.load(recs[0]) as rec:
        truth = rec["poses_true"][:, 1:]
        pred = roll["poses"][:, 1:]
        ep = np.linalg.norm(pred[..., :2] - truth[..., :2], axis=-1)
        eth = np.abs(np.angle(np.exp(1j * (pred[..., 2] - truth[..., 2]))))
        # stored as printed: positions in mm, angles in rad, the unit in the key
        assert metrics["e_p_ee_mm"] == pytest.approx(1e3 * ep[:, -1].mean(), rel=1e-12)
        assert metrics["e_theta_ee_rad"] == pytest.approx(eth[:, -1].mean(), rel=1e-12)
        assert metrics["e_p_dist_mm"] == pytest.approx(1e3 * ep.mean(), rel=1e-12)
        assert metrics["e_theta_dist_rad"] == pytest.approx(eth.mean(), rel=1e-12)
        assert ep[:, -1].mean() < 2e-3  # the identified model tracks the recording it was fitted on
        np.testing.assert_allclose(
            roll["poses"],
            PlanarPCS(tuple(roll["segment_lengths"])).forward_kinematics(roll["q"], roll["marker_arc_lengths"]),
            atol=1e-12,
        )
    assert (out / "rollout.png").is_file()

    # rest strains are identified by default; --no-rest-strain leaves them out, with the same bending stiffness
    rs_model = work / "model" / "model_plain.json"
    assert main(["fit", *strains, "--tau", *recs, "--out", str(rs_model), "--no-rest-strain", "--quiet"]) == 0
    from pcs_sindy.io import load

    plain, default = load(rs_model), load(model)
    assert plain.library_.rest_strain is False and default.library_.rest_strain is True
    assert default.rest_strain_.shape == (3,) and np.all(plain.rest_strain_ == 0)
    assert plain.stiffness_[0] == pytest.approx(1e4 * np.pi * 0.02**4 / 4, rel=0.15)

    bare = work / "rollout_bare"
    assert main(["rollout", str(model), "--tau", recs[1], "--n-markers", "5", "--out", str(bare), "--quiet"]) == 0
    with np.load(bare / "rollout.npz") as roll:
        assert roll["poses"].shape == (100, 6, 3)
        np.testing.assert_allclose(roll["q"][0], 0.0)  # from rest by default
    assert not (bare / "metrics.json").exists() and (bare / "rollout.png").is_file()


def _fitted(work) -> tuple[list[str], list[str], Path]:
    """Training recordings, their strain files and the model file of the module's data (made once)."""
    recs = [str(work / "data" / f"train_0{k}.npz") for k in range(2)]
    strains = [str(work / "strains" / f"train_0{k}.npz") for k in range(2)]
    if not Path(strains[0]).exists():
        assert main(["fuse", *recs, "--out", str(work / "strains"), "--total-length", "0.1", "--quiet"]) == 0
    model = work / "model" / "model.json"
    if not model.exists():
        assert main(["fit", *strains, "--tau", *recs, "--out", str(model), "--quiet"]) == 0
    return recs, strains, model


def test_commands_are_python_functions(work, tmp_path):
    recs, strains, _ = _fitted(work)
    from pcs_sindy.io import load

    model = fit(strains, recs, tmp_path / "m.json", window_length=15, rest_strain=False, quiet=True)
    assert model.window_length == 15 and model.library_.rest_strain is False
    saved = load(tmp_path / "m.json")
    np.testing.assert_array_equal(saved.coef_, model.coef_)
    result = rollout(model, recs[0], tmp_path / "roll", truth=recs[0], plot=False, quiet=True)
    with np.load(recs[0]) as rec:
        tip_err = np.linalg.norm(result.poses[:, -1, :2] - rec["poses_true"][:, -1, :2], axis=-1).mean()
    assert result.metrics["e_p_ee_mm"] == pytest.approx(1e3 * tip_err, rel=1e-12)
    assert not (tmp_path / "roll" / "rollout.png").exists()


# --------------------------------------------------------------------------
# one source of defaults: the estimators'
# --------------------------------------------------------------------------
def test_fit_without_options_builds_the_default_regressor():
    from pcs_sindy.identification import EulerLagrangeRegressor, StiffnessThresholdOptimizer

    args = build_parser().parse_args(["fit", "s.npz", "--tau", "t.npz", "--out", "m.json"])
    got = build_regressor(**command_kwargs(build_regressor, args)).get_params(deep=False)
    want = EulerLagrangeRegressor().get_params(deep=False)
    # the default optimizer (None) is StiffnessThresholdOptimizer(); the pipeline makes it explicit
    assert want.pop("optimizer") is None
    assert got.pop("optimizer").get_params() == StiffnessThresholdOptimizer().get_params()
    assert got == want


@pytest.mark.parametrize(
    "argv, step, estimator",
    [
        (["fuse", "p.npz", "--out", "o"], "segments", "pcs_sindy.fusion.kinematic_fusion.KinematicFusion"),
        (["extract", "v.avi", "--out", "o"], "poses", "pcs_sindy.vision.extractor.MarkerPoseExtractor"),
        (
            ["fit", "s.npz", "--tau", "t.npz", "--out", "m"],
            "dynamics",
            "pcs_sindy.identification.regressor.EulerLagrangeRegressor",
        ),
    ],
)
def test_options_left_out_are_the_estimators_defaults(argv, step, estimator):
    import importlib

    module, name = estimator.rsplit(".", 1)
    default = getattr(importlib.import_module(module), name)().get_params(deep=False)
    args = vars(build_parser().parse_args(argv))
    # n_jobs of 'extract'/'render' is the command's own parallelism over files
    shared = {k: args[k] for k in args if k in default and not (k == "n_jobs" and step == "poses")}
    assert shared, "the command has options of the estimator"
    assert all(v is None for v in shared.values()), shared  # never a re-typed default
    built = pipeline_step(step, **shared).get_params(deep=False)
    assert {k: v for k, v in built.items() if k != "optimizer"} == {
        k: v for k, v in default.items() if k != "optimizer"
    }


def test_fit_options_reach_the_regressor_library_and_optimizer():
    from pcs_sindy.identification import PhysicalPCSLibrary

    args = build_parser().parse_args(
        [
            "fit",
            "s.npz",
            "--tau",
            "t.npz",
            "--out",
            "m",
            "--formulation",
            "strong",
            "--window-length",
            "15",
            "--exclude-force-jumps",
            "--no-rest-strain",
            "--rotary-inertia",
            "tied",
            "--stiffness-threshold",
            "inf",
        ]
    )
    reg = build_regressor(**command_kwargs(build_regressor, args))
    assert (reg.formulation, reg.window_length, reg.exclude_force_jumps) == ("strong", 15, True)
    assert reg.feature_library.get_params() == PhysicalPCSLibrary(rest_strain=False, rotary_inertia="tied").get_params()
    assert reg.optimizer.threshold == np.inf
    seed = build_parser().parse_args(["fit", "s.npz", "--tau", "t.npz", "--out", "m", "--basis", "monomial"])
    assert build_regressor(**command_kwargs(build_regressor, seed)).feature_library == "monomial"  # former option name
    with pytest.raises(CLIError, match="--rest-strain"):
        build_regressor(library="monomial", rest_strain=True)


def test_help_prints_the_estimators_defaults(capsys):
    from pcs_sindy.fusion import KinematicFusion

    with pytest.raises(SystemExit):
        main(["fuse", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "merge threshold h, or a rule choosing it per robot" in out
    assert f"largest_drop (default {KinematicFusion().threshold})" in out
    assert f"(default {KinematicFusion().shape_fit})" in out


def _imported(where: str) -> Any:
    """What ``read_default(where)`` must find, taken from the imported code instead of its source."""
    module, _, dotted = where.partition(":")
    obj: Any = importlib.import_module(f"pcs_sindy.{module}")
    *path, name = dotted.split(".")
    for part in path:
        obj = getattr(obj, part)
    if isinstance(obj, type) and name in vars(obj):  # a class attribute (dataclass fields included)
        return vars(obj)[name]
    if callable(obj):  # a parameter of a function, or of a class's constructor
        return inspect.signature(obj).parameters[name].default
    return getattr(obj, name)  # a module constant


def _commands_estimators() -> dict[str, Any]:
    """The estimators the commands run with options left out, by where the help reads their defaults."""
    return {
        cli_main.POSES: pipeline_step("poses"),
        cli_main.SEGMENTS: pipeline_step("segments"),
        cli_main.DYNAMICS: pipeline_step("dynamics"),
        cli_main.LIBRARY: pipeline_step("dynamics").make_library(),
        cli_main.OPTIMIZER: pipeline_step("dynamics").optimizer,
    }


def test_every_default_the_help_reads_from_the_source_is_the_codes(monkeypatch, capsys):
    """The help reads defaults from the stages' source; each equals the imported code's (and the pipeline's)."""
    read: dict[str, Any] = {}

    def recording(where: str) -> Any:
        read[where] = read_default(where)
        return read[where]

    monkeypatch.setattr(cli_main, "read_default", recording)
    build_parser()  # read when the parser is built: --method's choices
    for argv in [["--help"], *([command, "--help"] for command in COMMANDS)]:
        with pytest.raises(SystemExit):
            main(argv)
    capsys.readouterr()
    assert len(read) >= 20, sorted(read)  # every command's help, the file formats, the integrators
    estimators = _commands_estimators()
    for where, value in read.items():
        assert value == _imported(where), where
        owner, name = where.rsplit(".", 1)
        if owner in estimators:  # and what the command runs with the option left out
            assert value == estimators[owner].get_params()[name], where
    assert set(estimators) <= {where.rsplit(".", 1)[0] for where in read}


def test_rollout_help_lists_the_methods_of_each_model(capsys):
    from pcs_sindy.core import METHODS
    from pcs_sindy.models.forward import CallableModel, LumpedPCSModel

    with pytest.raises(SystemExit):
        main(["rollout", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert f"{{{','.join(METHODS)}}}" in out  # the choices
    assert (
        f"physical library: {', '.join(LumpedPCSModel.methods)}; monomial: {', '.join(CallableModel.methods)}); "
        f"default: the model's best ({LumpedPCSModel.default_method} / {CallableModel.default_method})"
    ) in out


@pytest.mark.parametrize(
    "where, found",
    [
        ("models.forward:LumpedPCSModel.methods", "not a literal"),  # computed
        ("fusion.kinematic_fusion:KinematicFusion.no_such", "no parameter 'no_such'"),
        ("simulation.scenarios:Scenario.name", "no 'name' with a value"),  # a dataclass field without default
        ("simulation.scenarios:Scenario.generate", "names a function"),
        ("no_such_module:X", "cannot read its source"),
    ],
)
def test_read_default_names_what_it_could_not_read(where, found):
    with pytest.raises(LookupError, match=found) as exc:
        read_default(where)
    assert where.split(":")[0] in str(exc.value)


def test_rollout_method_and_tolerances_default_to_the_models(work, tmp_path, monkeypatch):
    from pcs_sindy.io import load

    recs, strains, model_file = _fitted(work)
    out = tmp_path / "default"
    assert (
        main(
            [
                "rollout",
                str(model_file),
                "--tau",
                recs[0],
                "--initial",
                strains[0],
                "--out",
                str(out),
                "--no-plot",
                "--quiet",
            ]
        )
        == 0
    )
    model = load(model_file)
    with np.load(recs[0]) as rec, np.load(strains[0]) as st, np.load(out / "rollout.npz") as roll:
        direct = model.simulate(st["q"][0], np.zeros(3), rec["t"], rec["tau"])  # the model's own defaults
        np.testing.assert_array_equal(roll["q"], direct.q)
    assert (
        main(
            [
                "rollout",
                str(model_file),
                "--tau",
                recs[0],
                "--truth",
                recs[0],
                "--out",
                str(tmp_path / "d5"),
                "--method",
                "dopri5",
                "--rtol",
                "1e-6",
                "--no-plot",
                "--quiet",
            ]
        )
        == 0
    )
    metrics = json.loads((tmp_path / "d5" / "metrics.json").read_text())
    assert metrics["method"] == "dopri5"
    with np.load(tmp_path / "d5" / "rollout.npz") as roll, np.load(recs[0]) as rec:
        direct = model.simulate(np.zeros(3), np.zeros(3), rec["t"], rec["tau"], method="dopri5", rtol=1e-6)
        np.testing.assert_array_equal(roll["q"], direct.q)

    class OnlyRadau:
        methods, default_method = ("radau",), "radau"

    monkeypatch.setattr(model, "forward_model", lambda: OnlyRadau())
    with pytest.raises(CLIError, match=r"supports \['radau'\]"):
        rollout(model, recs[0], tmp_path / "x", method="rosenbrock", quiet=True)


# --------------------------------------------------------------------------
# failure exits
# --------------------------------------------------------------------------
def test_failures_are_one_line_without_traceback(work, tmp_path, capsys):
    rec = str(work / "data" / "train_00.npz")
    missing = str(tmp_path / "nope.npz")
    np.savez(tmp_path / "wrong.npz", x=np.zeros(3))
    (tmp_path / "text.npz").write_text("not an npz")
    np.savez(tmp_path / "tau4.npz", t=np.arange(100) * 1e-3, tau=np.zeros((100, 4)))
    out = str(tmp_path / "out")

    assert "nope.npz" in _fail(capsys, ["fuse", missing, "--out", out])
    assert "'poses'" in _fail(capsys, ["fuse", str(tmp_path / "wrong.npz"), "--out", out])
    assert "cannot read" in _fail(capsys, ["render", str(tmp_path / "text.npz"), "--out", out])
    assert "does not exist" in _fail(capsys, ["extract", str(tmp_path / "nope.avi"), "--out", out])
    assert "unknown" in _fail(capsys, ["simulate", "no_such_robot", "--out", out]).lower()
    strain = str(work / "strains" / "train_00.npz")
    if not Path(strain).exists():
        assert (
            main(
                [
                    "fuse",
                    rec,
                    str(work / "data" / "train_01.npz"),
                    "--out",
                    str(work / "strains"),
                    "--total-length",
                    "0.1",
                    "--quiet",
                ]
            )
            == 0
        )
    assert "4 force columns" in _fail(capsys, ["fit", strain, "--tau", str(tmp_path / "tau4.npz"), "--out", out])
    assert "tau file" in _fail(capsys, ["fit", strain, "--tau", rec, rec, "--out", out])
    assert "model file" in _fail(capsys, ["rollout", str(tmp_path / "text.npz"), "--tau", rec, "--out", out])


@pytest.mark.parametrize(
    "argv, option",
    [
        (["render", "x.npz", "--out", "o", "--n-jobs", "0"], "--n-jobs"),
        (["fuse", "x.npz", "--out", "o", "--threshold", "-1"], "--threshold"),
        (["fit", "x.npz", "--tau", "t.npz", "--out", "m", "--window-length", "two"], "--window-length"),
        (["rollout", "m.json", "--tau", "t.npz", "--out", "o", "--method", "euler"], "--method"),
        (["fit", "s.npz", "--tau", "t.npz", "--out", "m", "--no-such-option"], "--no-such-option"),
        (["fit", "s.npz", "--tau", "t.npz"], "--out"),  # a required option missing
        (["simulate", "--out", "o"], "scenario"),  # a required positional argument missing
        (["no-such-command"], "no-such-command"),
    ],
)
def test_usage_errors_are_one_line(argv, option, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0]
    assert err[0].startswith("pcs-sindy") and ": error: " in err[0]


def test_debug_reraises(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        main(["--debug", "fuse", str(tmp_path / "nope.npz"), "--out", str(tmp_path)])


@pytest.mark.slow
def test_quick_demo_writes_a_complete_report(tmp_path, monkeypatch, capsys):
    import cv2

    monkeypatch.setenv("PCS_SINDY_CACHE", str(tmp_path / "cache"))
    capsys.readouterr()
    assert main(["demo", "--quick", "--n-jobs", "1", "--quiet", "--out", str(tmp_path / "demo")]) == 0
    rep = tmp_path / "demo" / "report"
    assert capsys.readouterr().out.strip().startswith(f"demo report: {rep / 'report.md'}")
    for name in (
        "report.md",
        "equations.txt",
        "metrics.json",
        "fig6_strain_distance.png",
        "fig8_error_vs_segments.png",
        "fig9_strains.png",
        "fig9_end_effector.png",
        "fig10_stills.png",
    ):
        assert (rep / name).stat().st_size > 0, name
    from pcs_sindy.core.video import browser_video_format

    animation = rep / ("rollout" + browser_video_format())  # browser-playable (issue 28)
    video = cv2.VideoCapture(str(animation))
    assert video.isOpened() and video.get(cv2.CAP_PROP_FRAME_COUNT) > 1
    video.release()
    assert f"]({animation.name})" in (rep / "report.md").read_text()
    metrics = json.loads((rep / "metrics.json").read_text())
    # the scenario's true segmentation, recovered from the rendered videos
    np.testing.assert_allclose(metrics["this_run"]["segment_lengths_m"], [0.07, 0.1], atol=3e-3)
    assert metrics["this_run"]["e_p_ee_mm"] < 20
    assert metrics["seed"]["e_p_ee_mm"] == pytest.approx(5.22)  # the seed's 5.22 mm, stored in mm as printed
    assert metrics["this_run"]["stiffness"]["be_1"]["unit"] == "N·m³"
    text = (rep / "report.md").read_text()
    assert "| 5.22 |" in text and "| 0.138 |" in text  # the seed's numbers beside ours
    assert (rep / "equations.txt").read_text().startswith("L = ")


def test_fit_and_rollout_from_actuator_inputs(tmp_path):
    """An actuated robot through the CLI: inputs u and a layout file instead of tau."""
    root = str(tmp_path)
    assert (
        main(
            [
                "simulate",
                "two_segment_tendon",
                "--out",
                f"{root}/data",
                "--n-train",
                "2",
                "--train-duration",
                "0.3",
                "--validation-duration",
                "0.3",
                "--quiet",
            ]
        )
        == 0
    )
    layout = json.loads((tmp_path / "data" / "scenario.json").read_text())["actuation"]
    assert layout == {"type": "tendon", "end": [0.07, 0.07, 0.17, 0.17], "side": [1, -1, 1, -1]}
    train = sorted(str(p) for p in (tmp_path / "data").glob("train_*.npz"))
    assert (
        main(["fuse", *train, "--out", f"{root}/strains", "--total-length", "0.17", "--threshold", "0.05", "--quiet"])
        == 0
    )
    strains = sorted(str(p) for p in (tmp_path / "strains").glob("train_*.npz"))
    model = f"{root}/model/model.json"
    assert (
        main(
            [
                "fit",
                *strains,
                "--inputs",
                *train,
                "--actuation",
                f"{root}/data/scenario.json",
                "--out",
                model,
                "--quiet",
            ]
        )
        == 0
    )
    from pcs_sindy.io import load

    fitted = load(model)
    # the true offsets of the scenario (+-15 mm), which the layout file does not hold
    np.testing.assert_allclose(fitted.actuation_.offsets_, [0.015, -0.015, 0.015, -0.015], rtol=0.02)
    assert (
        main(
            [
                "rollout",
                model,
                "--tau",
                f"{root}/data/validation.npz",
                "--truth",
                f"{root}/data/validation.npz",
                "--segmentation",
                f"{root}/strains/segmentation.json",
                "--out",
                f"{root}/roll",
                "--no-plot",
                "--quiet",
            ]
        )
        == 0
    )
    metrics = json.loads((tmp_path / "roll" / "metrics.json").read_text())
    assert metrics["e_p_ee_mm"] < 1
    assert main(["fit", *strains, "--inputs", *train, "--out", model, "--quiet"]) == 2  # no layout


def test_fit_out_ending_in_a_separator_is_a_folder(work, tmp_path):
    """``fit --out models/`` writes models/model.json (it wrote models.json)."""
    strains = work / "strains"
    if not (strains / "train_00.npz").exists():
        data = [str(work / "data" / f"train_0{k}.npz") for k in range(2)]
        assert main(["fuse", *data, "--out", str(strains), "--total-length", "0.1", "--quiet"]) == 0
    rec = str(work / "data" / "train_00.npz")
    out = f"{tmp_path / 'models'}{'/'}"
    assert main(["fit", str(strains / "train_00.npz"), "--tau", rec, "--out", out, "--quiet"]) == 0
    assert (tmp_path / "models" / "model.json").is_file() and (tmp_path / "models" / "model.npz").is_file()
    assert not (tmp_path / "models.json").exists()
