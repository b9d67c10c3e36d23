"""The command line on recordings a lab produces: every extractor option as a flag, camera JSONs
honoured and checked, truncated and damaged videos, frame folders, the contact sheet, and clean exits
(one line naming the file, Ctrl-C, OpenCV's log).

Truth: the poses the footage was rendered from (closed-form constant-curvature kinematics through a
known camera), the frame counts and rates written into the files, the bytes cut from a video.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest

from pcs_sindy.cli import main as cli_main
from pcs_sindy.cli.commands import pipeline_step
from pcs_sindy.cli.defaults import read_options
from pcs_sindy.cli.main import build_parser, command_kwargs, main
from pcs_sindy.core import Camera, PlanarPCS, PoseTrajectory, forward_kinematics
from pcs_sindy.core.camera import camera_json_path
from pcs_sindy.simulation.rendering import render_video
from pcs_sindy.vision import MarkerPoseExtractor

LENGTHS = (0.06,)
S = PlanarPCS(LENGTHS).marker_arc_lengths(12)
CAM = Camera(2500.0, (160.0, 30.0), (320, 240))
SIZE = (0.008, 0.002)  # 20 x 5 px markers, 12.5 px apart
FPS = 250.0
T = 40
EXE = [sys.executable, "-m", "pcs_sindy.cli.main"]


def _poses() -> np.ndarray:
    t = np.arange(T) / FPS
    q = np.zeros((T, 3))
    q[:, 0] = 15.0 * np.sin(2 * np.pi * 2.0 * t)  # bending, kappa * L up to 0.9 rad
    return forward_kinematics(q, LENGTHS, S)


def _fail(capsys, argv) -> str:
    """Run a command that must fail; return its one-line message."""
    capsys.readouterr()
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pcs-sindy {argv[0]}: error: ")
    return lines[0]


def _chunk_offsets(data: bytes) -> list[int]:
    """Offsets of the video frame chunks ('00dc') of an AVI's movi list, in order (RIFF chunks walked)."""
    movi = data.index(b"movi")
    end = movi + int.from_bytes(data[movi - 4 : movi], "little")
    pos, found = movi + 4, []
    while pos + 8 <= min(end, len(data)):
        tag, size = data[pos : pos + 4], int.from_bytes(data[pos + 4 : pos + 8], "little")
        if tag == b"LIST":
            pos += 12  # a list inside movi ('rec '): walk into it
            continue
        if tag == b"00dc":
            found.append(pos)
        pos += 8 + size + (size & 1)
    return found


@pytest.fixture(scope="module")
def footage(tmp_path_factory):
    """A 40-frame MJPG video with its camera JSON, the same frames as a PNG folder, and the truth."""
    root = tmp_path_factory.mktemp("footage")
    truth = _poses()
    video = render_video(truth, root / "clip.avi", CAM, fps=FPS, marker_size=SIZE).video
    folder = root / "frames"
    folder.mkdir()
    cap = cv2.VideoCapture(str(video))
    for k in range(T):
        ok, frame = cap.read()
        assert ok
        cv2.imwrite(str(folder / f"frame_{k + 1:04d}.png"), frame)
    cap.release()
    return {"root": root, "video": Path(video), "folder": folder, "truth": truth}


def _poses_file(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with np.load(path) as data:
        return data["t"], data["poses"]


# --------------------------------------------------------------------------
# flags: every option a user may need, values checked by the estimator
# --------------------------------------------------------------------------
# parameters with no flag of their own: the command's parallelism, progress (--quiet), dt (--fps)
NO_FLAG = {"n_jobs", "progress", "dt"}


@pytest.mark.parametrize("command", ["extract", "inspect"])
def test_every_extractor_parameter_has_a_flag(command):
    params = set(MarkerPoseExtractor().get_params()) - NO_FLAG
    args = vars(build_parser().parse_args([command, "v.avi", *(["--out", "o"] if command == "extract" else [])]))
    assert params <= set(args), sorted(params - set(args))
    assert all(args[p] is None for p in params), {p: args[p] for p in params if args[p] is not None}


def test_flags_reach_the_extractor_as_typed():
    argv = [
        "extract",
        "v.avi",
        "--out",
        "o",
        "--reference-frame",
        "3",
        "--threshold",
        "0,0,120:90,90,255",
        "--polarity",
        "bright",
        "--roi",
        "1,2,30,40",
        "--area-tolerance",
        "0.4,2",
        "--base-position",
        "10.5,20",
        "--pixels-per-metre",
        "1000",
        "--rest-direction",
        "90",
        "--on-missing",
        "interpolate",
        "--no-fill-missing",
        "--no-refine",
    ]
    kwargs = command_kwargs(cli_main.extract, build_parser().parse_args(argv))
    kwargs = {k: v for k, v in kwargs.items() if k in MarkerPoseExtractor().get_params()}
    ex = pipeline_step("poses", **kwargs)
    assert ex.reference_frame == 3 and ex.polarity == "bright" and ex.on_missing == "interpolate"
    assert ex.threshold == ((0, 0, 120), (90, 90, 255))
    assert ex.roi == (1, 2, 30, 40) and ex.area_tolerance == (0.4, 2) and ex.base_position == (10.5, 20)
    assert ex.pixels_per_metre == 1000 and ex.fill_missing is False and ex.refine is False
    assert ex.rest_direction == pytest.approx(math.pi / 2)  # typed in degrees
    ex.fit()  # every value passes the estimator's own checks


def test_a_bad_value_is_refused_by_the_estimator_in_one_line(footage, tmp_path, capsys):
    line = _fail(capsys, ["extract", str(footage["video"]), "--out", str(tmp_path), "--polarity", "sideways"])
    assert "polarity" in line and "'sideways'" in line and "'dark'" in line
    assert not list(tmp_path.iterdir())  # refused before any work


def test_help_lists_the_words_of_the_estimators_table(capsys):
    table = MarkerPoseExtractor._parameter_constraints
    for name, entry in table.items():
        if entry == "no_validation":
            continue
        words = tuple(w for c in entry if hasattr(c, "options") for w in c.options)
        assert read_options(f"vision.extractor:MarkerPoseExtractor.{name}") == words, name
    with pytest.raises(SystemExit):
        main(["extract", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "words: auto, otsu, local, colour (default auto)" in out
    assert "words: dark, bright (default dark)" in out


# --------------------------------------------------------------------------
# camera JSON: fps honoured, image size optional, bad values named
# --------------------------------------------------------------------------
def test_camera_json_fps_is_honoured_and_image_size_may_be_left_out(footage, tmp_path, capsys):
    cam = json.loads((footage["video"].with_name("clip.avi.camera.json")).read_text())
    del cam["image_size"]  # hand-written: the footage tells the size
    cam["fps"] = 500.0  # a capture rate the frame folder cannot tell
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(cam))
    argv = ["extract", str(footage["folder"]), "--out", str(tmp_path / "p"), "--camera", str(path), "--quiet"]
    assert main(argv) == 0
    t, poses = _poses_file(tmp_path / "p" / "frames.npz")
    np.testing.assert_allclose(t, np.arange(T) / 500.0)
    assert np.abs(poses[..., :2] - footage["truth"][..., :2]).max() < 0.5 / CAM.pixels_per_metre
    # and from Python: camera=path
    (traj,) = MarkerPoseExtractor(camera=str(path), progress=False).fit_transform([str(footage["folder"])])
    np.testing.assert_allclose(traj.t, np.arange(T) / 500.0)


def test_fps_overriding_a_camera_json_is_said(footage, tmp_path, capsys):
    """--fps 100 with a camera JSON saying 500 fps: the user's rate is used, with a warning naming both."""
    cam = json.loads((footage["video"].with_name("clip.avi.camera.json")).read_text())
    cam["fps"] = 500.0
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(cam))
    argv = ["extract", str(footage["folder"]), "--out", str(tmp_path / "p"), "--camera", str(path), "--quiet"]
    capsys.readouterr()
    assert main([*argv, "--fps", "100"]) == 0
    err = capsys.readouterr().err
    assert "fps=100 overrides" in err and "500 fps" in err
    t, _ = _poses_file(tmp_path / "p" / "frames.npz")
    np.testing.assert_allclose(t, np.arange(T) / 100.0)
    assert main([*argv, "--fps", "500"]) == 0  # the same rate: nothing to say
    assert "overrides" not in capsys.readouterr().err


@pytest.mark.parametrize("fps", [0, -5, 1e-300, float("nan"), float("inf"), "fast", True])
@pytest.mark.parametrize("how", ["given", "beside"])
def test_a_bad_frame_rate_in_a_camera_json_is_named(footage, tmp_path, capsys, fps, how):
    cam = json.loads((footage["video"].with_name("clip.avi.camera.json")).read_text())
    cam["fps"] = fps  # json writes nan and inf as NaN and Infinity, which it reads back
    folder = tmp_path / "frames"
    folder.mkdir()
    for f in sorted(footage["folder"].iterdir())[:5]:
        (folder / f.name).write_bytes(f.read_bytes())
    path = tmp_path / "cam.json" if how == "given" else folder / "camera.json"
    path.write_text(json.dumps(cam))
    argv = ["extract", str(folder), "--out", str(tmp_path / "p"), "--quiet"]
    line = _fail(capsys, argv + (["--camera", str(path)] if how == "given" else []))
    assert repr(str(path)) in line and "'fps'" in line and f"got {fps!r}" in line


# --------------------------------------------------------------------------
# truncated and damaged videos: counts checked, time stamps never shift
# --------------------------------------------------------------------------
def test_a_video_cut_at_a_frame_boundary_is_caught(footage, tmp_path, capsys):
    data = footage["video"].read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: _chunk_offsets(data)[25]])  # 25 whole frames, the header still says 40
    (tmp_path / "cut.avi.camera.json").write_text(footage["video"].with_name("clip.avi.camera.json").read_text())
    line = _fail(capsys, ["extract", str(cut), "--out", str(tmp_path / "p"), "--quiet"])
    assert "decoded 25 frames" in line and "container says 40" in line and "camera JSON" in line and "says 40" in line
    assert main(["extract", str(cut), "--out", str(tmp_path / "p"), "--quiet", "--on-missing", "interpolate"]) == 0
    warning = capsys.readouterr().err.strip().splitlines()
    assert len(warning) == 1 and "warning" in warning[0] and "decoded 25 frames" in warning[0]
    t, poses = _poses_file(tmp_path / "p" / "cut.npz")
    np.testing.assert_allclose(t, np.arange(25) / FPS)
    assert np.abs(poses[..., :2] - footage["truth"][:25, :, :2]).max() < 0.5 / CAM.pixels_per_metre


def test_a_damaged_frame_is_interpolated_in_place(footage, tmp_path, capsys):
    data = bytearray(footage["video"].read_bytes())
    start = _chunk_offsets(bytes(data))[12]
    soi = data.index(b"\xff\xd8", start)
    data[soi : soi + 2] = b"\x00\x00"  # frame 12's JPEG data no longer decodes
    bad = tmp_path / "bad.avi"
    bad.write_bytes(bytes(data))
    (tmp_path / "bad.avi.camera.json").write_text(footage["video"].with_name("clip.avi.camera.json").read_text())
    line = _fail(capsys, ["extract", str(bad), "--out", str(tmp_path / "p"), "--quiet", "--on-missing", "raise"])
    assert "frame 12" in line
    # the default interpolates one damaged frame, and says which
    assert main(["extract", str(bad), "--out", str(tmp_path / "p"), "--quiet"]) == 0
    assert "interpolated in time (frames 12;" in capsys.readouterr().err
    ex = MarkerPoseExtractor(on_missing="interpolate", progress=False)
    (traj,) = ex.fit_transform([str(bad)])
    np.testing.assert_allclose(traj.t, np.arange(T) / FPS)  # the frames after keep their time
    assert ex.diagnostics_[0]["frames_repaired"] == [12]
    good = np.r_[0:12, 13:T]
    assert np.abs(traj.poses[good, :, :2] - footage["truth"][good, :, :2]).max() < 0.5 / CAM.pixels_per_metre
    # frame 12 interpolated between its neighbours: within the motion of one frame
    assert np.abs(traj.poses[12, :, :2] - footage["truth"][12, :, :2]).max() < 2e-4


# --------------------------------------------------------------------------
# frame folders and single images
# --------------------------------------------------------------------------
def test_a_frame_missing_from_a_numbered_folder_keeps_the_others_in_time(footage, tmp_path, capsys):
    folder = tmp_path / "frames"
    folder.mkdir()
    for f in sorted(footage["folder"].iterdir()):
        if f.name != "frame_0013.png":  # frame 12 lost when copying
            (folder / f.name).write_bytes(f.read_bytes())
    argv = ["extract", str(folder), "--out", str(tmp_path / "p"), "--quiet", "--fps", str(FPS), "--on-missing", "raise"]
    line = _fail(capsys, argv)
    assert "frame 12" in line and "frame_0012.png" in line
    ex = MarkerPoseExtractor(camera=CAM, fps=FPS, on_missing="interpolate", progress=False)
    (traj,) = ex.fit_transform([str(folder)])
    np.testing.assert_allclose(traj.t, np.arange(T) / FPS)
    assert ex.diagnostics_[0]["frames_repaired"] == [12]
    good = np.r_[0:12, 13:T]
    assert np.abs(traj.poses[good, :, :2] - footage["truth"][good, :, :2]).max() < 0.5 / CAM.pixels_per_metre
    # every 5th frame kept on purpose is a sequence with step 5, not 80 % of it missing
    sparse = tmp_path / "sparse"
    sparse.mkdir()
    for f in sorted(footage["folder"].iterdir())[::5]:
        (sparse / f.name).write_bytes(f.read_bytes())
    (traj,) = MarkerPoseExtractor(camera=CAM, fps=FPS / 5, progress=False).fit_transform([str(sparse)])
    assert traj.n_frames == T // 5
    assert np.abs(traj.poses[..., :2] - footage["truth"][::5, :, :2]).max() < 0.5 / CAM.pixels_per_metre


def test_single_image_files_are_refused_with_their_folder_named(footage, tmp_path, capsys):
    files = [str(p) for p in sorted(footage["folder"].iterdir())[:3]]
    line = _fail(capsys, ["extract", *files, "--out", str(tmp_path / "p")])
    assert "3 image file(s)" in line and repr(str(footage["folder"])) in line
    assert not (tmp_path / "p").exists()


# --------------------------------------------------------------------------
# contact sheet
# --------------------------------------------------------------------------
def test_inspect_draws_the_chain_where_the_markers_are(footage, tmp_path, monkeypatch):
    from pcs_sindy.plotting import stills

    drawn = {}
    real = stills.plot_contact_sheet

    def spy(frames, **kw):
        drawn.update(kw, frames=frames)
        return real(frames, **kw)

    monkeypatch.setattr(stills, "plot_contact_sheet", spy)
    out = tmp_path / "sheet.png"
    out.write_bytes(b"old")
    assert main(["inspect", str(footage["video"]), "--out", str(out), "--frames", "4", "--quiet"]) == 0
    image = cv2.imread(str(out))
    assert image is not None and image.shape[0] > 200 and image.shape[1] > 400  # a PNG replaced the old file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet.png"]  # no temporary left
    picks = [int(re.match(r"frame (\d+)", t).group(1)) for t in drawn["titles"]]
    assert picks == [0, 13, 26, 39]
    for k, chain in zip(picks, drawn["chains"], strict=True):
        true_px = CAM.to_pixels(footage["truth"][k])[:, :2]
        assert np.abs(chain - true_px).max() < 0.5  # markers in order, base first
        assert len(drawn["rejected"][picks.index(k)]) == 0  # clean footage: nothing rejected


def test_extract_plot_writes_a_sheet_beside_the_poses(footage, tmp_path):
    out = tmp_path / "p"
    assert main(["extract", str(footage["video"]), "--out", str(out), "--plot", "--quiet"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["clip.inspect.png", "clip.npz"]
    assert cv2.imread(str(out / "clip.inspect.png")) is not None


def test_inspect_draws_a_sheet_when_extraction_fails(footage, tmp_path, capsys):
    out = tmp_path / "s.png"
    code = main(["inspect", str(footage["video"]), "--out", str(out), "--on-missing", "raise", "--n-markers", "5"])
    assert code == 0 and cv2.imread(str(out)) is not None
    assert "extraction failed" in capsys.readouterr().out


# --------------------------------------------------------------------------
# clean exits
# --------------------------------------------------------------------------
def test_ctrl_c_exits_130_with_one_line(monkeypatch, capsys):
    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_main, "scenarios", interrupted)
    assert main(["scenarios"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["pcs-sindy scenarios: interrupted"]


def test_fit_out_folder_means_a_folder(tmp_path):
    from pcs_sindy.cli.commands import file_target

    assert file_target(f"{tmp_path}/models/", "model.json") == tmp_path / "models" / "model.json"
    (tmp_path / "existing").mkdir()
    assert file_target(tmp_path / "existing", "model.json") == tmp_path / "existing" / "model.json"
    assert file_target(tmp_path / "m.json", "model.json") == tmp_path / "m.json"


def _run(argv: list[str], env: dict | None = None, limit: int | None = None) -> subprocess.CompletedProcess:
    def preexec() -> None:
        if limit is not None:
            import resource

            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    environ = {k: v for k, v in os.environ.items() if not k.startswith("OPENCV_")}
    environ.update(env or {}, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    return subprocess.run(
        EXE + argv, capture_output=True, text=True, env=environ, preexec_fn=preexec, timeout=120, check=False
    )


def test_a_full_disk_names_the_file(footage, tmp_path):
    out = tmp_path / "p"
    done = _run(["extract", str(footage["video"]), "--out", str(out), "--quiet"], limit=2000)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Errno 27" in lines[0], done.stderr
    assert str(out / "clip.npz") in lines[0]


def test_opencv_and_ffmpeg_say_nothing(footage, tmp_path):
    data = footage["video"].read_bytes()
    cut = tmp_path / "torn.avi"
    cut.write_bytes(data[: _chunk_offsets(data)[20] + 300])  # ends inside frame 20's JPEG data
    (tmp_path / "torn.avi.camera.json").write_text(footage["video"].with_name("clip.avi.camera.json").read_text())
    argv = ["extract", str(cut), "--out", str(tmp_path / "p"), "--quiet", "--on-missing", "interpolate"]
    done = _run(argv)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pcs-sindy extract: warning: "), done.stderr
    assert "@" not in done.stderr  # no "[mjpeg @ 0x...] ..." from FFmpeg


def test_calibrate_refuses_a_pattern_that_cannot_fit(tmp_path, capsys):
    from pcs_sindy.vision import calibrate_camera

    with pytest.raises(ValueError, match=r"pattern 100000x100000 .* 64x48 .* at most 15 corners"):
        calibrate_camera([np.zeros((48, 64), np.uint8)], (100000, 100000), 0.01)
    cv2.imwrite(str(tmp_path / "board.png"), np.full((48, 64), 255, np.uint8))
    argv = ["calibrate", str(tmp_path / "board.png"), "--pattern", "100000x100000", "--square", "0.01"]
    line = _fail(capsys, [*argv, "--out", str(tmp_path / "cam.json")])
    assert "cannot fit" in line


def test_contact_sheet_draws_what_it_is_given_and_checks_its_lengths():
    import matplotlib.pyplot as plt

    from pcs_sindy.plotting import plot_contact_sheet

    frames = [np.full((30, 40), 255, np.uint8), np.zeros((30, 40, 3), np.uint8)]
    chain = np.array([[5.0, 5.0], [10.0, 12.0], [15.0, 20.0]])
    fig = plot_contact_sheet(frames, chains=[chain, None], rejected=[np.zeros((0, 2)), np.array([[3.0, 4.0]])])
    first, second = fig.axes[:2]
    base = [ln for ln in first.get_lines() if ln.get_label() == "base"][0]
    assert np.allclose(base.get_xydata(), chain[:1])  # the base is the first marker
    markers = [ln for ln in first.get_lines() if ln.get_label() == "marker (chain order)"][0]
    assert np.allclose(markers.get_xydata(), chain[1:])
    assert [ln.get_label() for ln in second.get_lines()] == ["rejected component"]
    assert np.allclose(second.get_lines()[0].get_xydata(), [[3.0, 4.0]])
    plt.close(fig)
    with pytest.raises(ValueError, match=r"chains must hold one entry per frame \(2\); got 1"):
        plot_contact_sheet(frames, chains=[chain])
    with pytest.raises(ValueError, match=r"frames\[0\] must be a uint8 image"):
        plot_contact_sheet([np.zeros((3, 3))], chains=[None])


def test_a_camera_json_with_only_a_scale_and_a_rate_is_enough(footage, tmp_path):
    """Origin, angle and image size are told by the footage (the base stays put, frame 0 is straight)."""
    path = tmp_path / "cam.json"
    path.write_text(json.dumps({"pixels_per_metre": CAM.pixels_per_metre, "fps": FPS}))
    argv = ["extract", str(footage["folder"]), "--out", str(tmp_path / "p"), "--camera", str(path), "--quiet"]
    assert main(argv) == 0
    t, poses = _poses_file(tmp_path / "p" / "frames.npz")
    np.testing.assert_allclose(t, np.arange(T) / FPS)
    assert np.abs(poses[..., :2] - footage["truth"][..., :2]).max() < 0.5 / CAM.pixels_per_metre
    assert np.abs(poses[..., 2] - footage["truth"][..., 2]).max() < np.radians(1.0)


# --------------------------------------------------------------------------
# one scale for a set of videos without camera JSONs
# --------------------------------------------------------------------------
def test_videos_without_camera_share_one_scale(tmp_path):
    """Three videos of one set-up, only the robot length given, each stretched differently in its first frame.

    Alone, each is scaled from its own reference frame (straight, but stretched by -8, 0 or +8 %), so
    two are 8 % off; together they take one scale from the median chain length of all frames, with a
    warning, and every video's markers come out at their true distances (truth: the rendered kinematics).
    """
    t = np.arange(T) / FPS
    videos, truths = [], []
    for k, stretch in enumerate((-0.08, 0.0, 0.08)):
        q = np.zeros((T, 3))
        q[:, 0] = 10.0 * np.sin(2 * np.pi * 2.0 * t)
        q[:, 2] = stretch + 0.01 * np.sin(2 * np.pi * 3.0 * t)
        truth = forward_kinematics(q, LENGTHS, S)
        video = render_video(truth, tmp_path / f"v{k}.avi", CAM, fps=FPS, marker_size=SIZE).video
        camera_json_path(video).unlink()  # no camera JSON: the scale must come from the footage
        videos.append(str(video))
        truths.append(truth)

    def tip_error(traj, truth):
        dist = np.linalg.norm(traj.poses[:, -1, :2] - traj.poses[:, 0, :2], axis=-1)
        return np.abs(dist / np.linalg.norm(truth[:, -1, :2] - truth[:, 0, :2], axis=-1) - 1).max()

    extractor = MarkerPoseExtractor(robot_length=LENGTHS[0], fps=FPS, progress=False)
    (alone,) = extractor.transform([videos[2]])
    assert tip_error(alone, truths[2]) > 0.05  # alone, a stretched reference frame gives a wrong scale
    with pytest.warns(UserWarning, match=r"own scales .* differ by up to 1[5-9] %.* median chain length"):
        both = extractor.transform(videos)
    for traj, truth in zip(both, truths, strict=True):
        assert tip_error(traj, truth) < 0.015
    assert "rescaled" in extractor.diagnostics_[2]["calibration"]
    assert len({traj.metadata["camera"]["pixels_per_metre"] for traj in both}) == 1
    # the command line extracts video by video, and shares the scale the same way
    argv = ["extract", *videos, "--out", str(tmp_path / "p"), "--robot-length", str(LENGTHS[0]), "--fps", str(FPS)]
    assert main([*argv, "--quiet"]) == 0
    for k, truth in enumerate(truths):
        t, poses = _poses_file(tmp_path / "p" / f"v{k}.npz")
        assert tip_error(PoseTrajectory(poses, t=t), truth) < 0.015


def test_scenarios_are_listed_with_descriptions(capsys):
    from pcs_sindy.simulation import describe_scenarios, list_scenarios

    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == list_scenarios()
    for line, (name, text) in zip(lines, describe_scenarios().items(), strict=True):
        assert line.startswith(name) and line.endswith(text) and len(text) > 10


def test_a_closed_pipe_ends_quietly():
    """``pcs-sindy scenarios | head -1``: no error message when the reader goes away before the output."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "pcs_sindy.cli.main", "scenarios"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    proc.stdout.close()  # the reader is gone before the command writes
    err = proc.stderr.read()
    proc.wait(timeout=60)
    proc.stderr.close()
    assert "rror" not in err and "Traceback" not in err, err


def test_a_marker_off_its_track_is_flagged(tmp_path, capsys):
    """A frame whose marker 7 sits 2 mm aside (still a complete chain) is named, not summarised as fine (issue 27)."""
    truth = _poses()
    drawn = truth.copy()
    k, i = 17, 7
    normal = np.array([np.cos(truth[k, i, 2]), np.sin(truth[k, i, 2])])  # across the backbone
    drawn[k, i, :2] += 0.002 * normal
    video = render_video(drawn, tmp_path / "clip.avi", CAM, fps=FPS, marker_size=SIZE).video
    ex = MarkerPoseExtractor(progress=False)
    (traj,) = ex.transform([str(video)])
    assert ex.diagnostics_[0]["outlier_frames"] == {k: [i]}
    capsys.readouterr()
    assert main(["extract", str(video), "--out", str(tmp_path / "p")]) == 0
    out, err = capsys.readouterr()
    assert "1 frame(s) have a marker far off its own track (frame 17: marker(s) [7])" in err
    assert "1 with a marker off its track" in out
    # the undisturbed footage flags nothing
    clean = render_video(truth, tmp_path / "clean.avi", CAM, fps=FPS, marker_size=SIZE).video
    ex.transform([str(clean)])
    assert ex.diagnostics_[0]["outlier_frames"] == {}


def test_fps_overriding_the_video_container_is_said(tmp_path):
    """No camera JSON, --fps a tenth of the container's rate: used, with a warning naming both rates."""
    t = np.arange(T) / FPS
    q = np.zeros((T, 3))
    q[:, 0] = 10.0 * np.sin(2 * np.pi * 2.0 * t)
    video = render_video(forward_kinematics(q, LENGTHS, S), tmp_path / "v.avi", CAM, fps=FPS, marker_size=SIZE).video
    camera_json_path(video).unlink()
    with pytest.warns(UserWarning, match=rf"fps={FPS / 10:g} overrides the video container's {FPS:g} fps"):
        (traj,) = MarkerPoseExtractor(robot_length=LENGTHS[0], fps=FPS / 10, progress=False).transform([str(video)])
    np.testing.assert_allclose(np.diff(traj.t), 10.0 / FPS)
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*overrides the video container.*")
        MarkerPoseExtractor(robot_length=LENGTHS[0], fps=FPS, progress=False).transform([str(video)])
