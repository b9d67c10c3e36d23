"""MarkerPoseExtractor on rendered frames: poses back within 0.5 px and 1°."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from joblib import parallel_backend
from sklearn.base import clone

from pcs_sindy.core import Camera, PlanarPCS, PoseTrajectory, forward_kinematics
from pcs_sindy.simulation.nuisances import Nuisances
from pcs_sindy.simulation.rendering import marker_corners, render_frames, render_video
from pcs_sindy.vision import MarkerPoseExtractor, read_frames

LENGTHS = (0.05, 0.05)
S = PlanarPCS(LENGTHS).marker_arc_lengths(20)
CAM = Camera(3000.0, (320.0, 90.0), (640, 480))
SIZE = (0.008, 0.002)  # 24 x 6 px markers, 15 px apart
POS_TOL = 0.5 / CAM.pixels_per_metre  # half a pixel, in metres
ANG_TOL = np.deg2rad(1.0)


def strains(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, (n, 6)) * np.array([30.0, 0.1, 0.1] * 2)
    q[0] = 0.0  # a straight frame (also the reference frame)
    return q


def smooth_strains(n: int) -> np.ndarray:
    """A smooth motion whose tip curls from +3.8 rad to -3.8 rad (past ±180°)."""
    t = np.linspace(0.0, 1.0, n)
    q = np.zeros((n, 6))
    q[:, 0] = q[:, 3] = 38.0 * np.sin(2 * np.pi * t)  # kappa * L = 3.8 rad over the robot
    q[:, 1] = 0.05 * np.sin(4 * np.pi * t)
    q[:, 5] = 0.08 * np.cos(2 * np.pi * t) - 0.08
    return q


def poses_of(q: np.ndarray) -> np.ndarray:
    return forward_kinematics(q, LENGTHS, S)


def check(traj: PoseTrajectory, truth: np.ndarray, *, pos_tol: float = POS_TOL, ang_tol: float = ANG_TOL) -> None:
    assert traj.poses.shape == truth.shape
    pos = np.linalg.norm(traj.poses[..., :2] - truth[..., :2], axis=-1)
    ang = np.abs(traj.poses[..., 2] - truth[..., 2])  # unwrapped: a 2π slip is an error
    assert pos.max() < pos_tol, f"position error {pos.max() * CAM.pixels_per_metre:.3f} px"
    assert ang.max() < ang_tol, f"angle error {np.degrees(ang.max()):.3f} deg"


def extractor(**kw) -> MarkerPoseExtractor:
    return MarkerPoseExtractor(**{"camera": CAM, "fps": 100.0, "progress": False, **kw})


@pytest.fixture(scope="module")
def random_set() -> tuple[np.ndarray, np.ndarray]:
    truth = poses_of(strains(12, seed=0))
    return truth, render_frames(truth, CAM, marker_size=SIZE)


@pytest.fixture(scope="module")
def curl_set() -> tuple[np.ndarray, np.ndarray]:
    truth = poses_of(smooth_strains(24))
    return truth, render_frames(truth, CAM, marker_size=SIZE)


def test_random_frames_recovered(random_set) -> None:
    truth, frames = random_set
    ex = extractor()
    (traj,) = ex.transform([frames])
    check(traj, truth)
    np.testing.assert_allclose(traj.t, np.arange(len(frames)) / 100.0)
    diag = ex.diagnostics_[0]
    assert diag["frames_repaired"] == [] and np.all(diag["markers_found"] == 21)
    assert traj.n_markers == 20


def test_curl_past_180_degrees_continuous(curl_set) -> None:
    truth, frames = curl_set
    assert truth[..., -1, 2].max() > 3.6 and truth[..., -1, 2].min() < -3.6  # the test means something
    (traj,) = extractor().transform([frames])
    check(traj, truth)
    # continuous in time and along the robot: no jumps of pi/2, pi or 2pi
    assert np.abs(np.diff(traj.poses[..., 2], axis=0)).max() < 1.3  # the truth moves up to 1.03 rad per frame
    assert np.abs(np.diff(traj.poses[..., 2], axis=1)).max() < 0.5


def test_body_drawn_and_colour_frames(random_set) -> None:
    truth = random_set[0][:6]
    grey = render_frames(truth, CAM, marker_size=SIZE, body=True, body_colour=200)
    check(extractor().transform([grey])[0], truth)
    colour = render_frames(
        truth, CAM, marker_size=SIZE, colour=True, marker_colour=(160, 40, 20), body_colour=(200, 230, 240)
    )
    check(extractor().transform([colour])[0], truth)
    # a colour range finds the markers by colour; edge pixels are weighted by their colour mix
    ranged = extractor(threshold=((120, 0, 0), (200, 90, 60))).transform([colour])[0]
    check(ranged, truth)
    # a grey-level range on a grey image works the same way
    grey_range = extractor(threshold=(0, 100)).transform([grey])[0]
    check(grey_range, truth)


def test_bright_markers_and_plain_min_area_rect(random_set) -> None:
    truth = random_set[0][:6]
    inverted = render_frames(truth, CAM, marker_size=SIZE, background=0, marker_colour=255, body_colour=60)
    check(extractor(polarity="bright").transform([inverted])[0], truth)
    check(extractor(polarity="bright", threshold=128).transform([inverted])[0], truth)
    # without the moment refinement, minAreaRect's centre and angle are coarser
    check(
        extractor(refine=False).transform([random_set[1][:6]])[0], truth, pos_tol=1.0 / 3000.0, ang_tol=np.deg2rad(6.0)
    )


def test_noisy_frames(random_set) -> None:
    truth, frames = random_set
    rng = np.random.default_rng(5)
    noisy = np.clip(frames + rng.normal(0.0, 8.0, frames.shape), 0, 255).astype(np.uint8)
    check(extractor().transform([noisy])[0], truth)


def test_background_clutter_and_roi(random_set) -> None:
    truth, frames = random_set
    cluttered = frames.copy()
    for f in cluttered:
        cv2.rectangle(f, (0, 440), (639, 479), 0, -1)  # a floor
        cv2.circle(f, (585, 60), 40, 30, -1)  # a mount
        cv2.line(f, (20, 40), (120, 60), 0, 2)  # a cable
    check(extractor().transform([cluttered])[0], truth)
    # a marker-shaped distractor off the chain is clutter: it does not count, but it is reported
    for f in cluttered:
        cv2.rectangle(f, (590, 300), (613, 305), 0, -1)
    ex = extractor()
    check(ex.transform([cluttered])[0], truth)
    assert np.all(ex.diagnostics_[0]["ignored_components"] == 1)
    check(extractor(n_markers=20).transform([cluttered])[0], truth)
    check(extractor(roi=(0, 0, 560, 480)).transform([cluttered])[0], truth)
    # more specks of dirt than markers: the known number of markers picks the markers
    rng = np.random.default_rng(1)
    for f in cluttered:
        for x, y in zip(rng.integers(0, 550, 60), rng.integers(410, 432, 60), strict=True):
            f[y : y + 3, x : x + 3] = 0
    check(extractor(n_markers=20, roi=(0, 0, 560, 480)).transform([cluttered])[0], truth)


def test_outlined_markers(random_set) -> None:
    truth = random_set[0][:6]
    frames = render_frames(truth, CAM, marker_size=SIZE, marker_style="outline", outline_width=1.5, body=False)
    check(extractor().transform([frames])[0], truth)


def test_calibration_from_straight_reference_frame(random_set) -> None:
    truth = random_set[0]
    # a camera the extractor is not told about: rotated, shifted, another scale
    hidden = Camera(2500.0, (300.0, 160.0), (640, 520), angle=0.4)
    frames = render_frames(truth, hidden, marker_size=SIZE)
    ex = extractor(camera=None, robot_length=0.1)
    traj = ex.transform([frames])[0]
    diag = ex.diagnostics_[0]
    assert diag["base_marker"] == "stays put"
    assert diag["camera"]["pixels_per_metre"] == pytest.approx(2500.0, rel=2e-3)
    assert diag["camera"]["angle"] == pytest.approx(0.4, abs=2e-3)
    check(traj, truth, pos_tol=1.5 / 2500.0)
    # the same with everything given explicitly
    given = extractor(
        camera=None, pixels_per_metre=2500.0, base_position=(300.0, 160.0), rest_direction=0.4 + np.pi / 2
    )
    check(given.transform([frames])[0], truth, pos_tol=0.5 / 2500.0)


def test_static_recording_base_is_ambiguous(random_set) -> None:
    frames = np.repeat(random_set[1][:1], 3, axis=0)
    with pytest.raises(ValueError, match="base marker is ambiguous"):
        extractor(camera=None, robot_length=0.1).transform([frames])
    with pytest.raises(ValueError, match="calibration"):
        extractor(camera=None, base_position=(320.0, 90.0)).transform([frames])


def test_all_markers_found_but_not_chained_says_so(curl_set) -> None:
    """Every marker is there but the chain cannot start at the base: not "found 21, expected 21" (issue 27)."""
    truth, frames = curl_set
    frames = frames.copy()
    pix = CAM.to_pixels(truth)
    _erase_marker(frames[6], pix[6], 0)  # the base marker moved 150 px aside: same count, no chain from the base
    w, t = np.asarray(SIZE) * CAM.pixels_per_metre
    moved = pix[6, 0] + np.array([150.0, 0.0, 0.0])
    cv2.fillPoly(frames[6], [np.round(marker_corners(moved, w, t)).astype(np.int32)], 0)
    with pytest.raises(ValueError, match=r"frame 6: found all 21 marker-shaped components \(base \+ 20 markers\), but"):
        extractor(on_missing="raise").transform([frames])


def test_auto_interpolates_short_gaps_and_refuses_long_ones(curl_set) -> None:
    """The default on_missing='auto': up to MAX_AUTO_GAP frames in a row interpolated with a warning, more refused."""
    from pcs_sindy.vision.extraction import MAX_AUTO_GAP

    truth, frames = curl_set
    short = frames.copy()
    short[[4, 10, 11]] = 255  # blank frames: no markers
    with pytest.warns(UserWarning, match=r"3 frame\(s\) could not be extracted .*frames 4, 10-11"):
        (traj,) = extractor().transform([short])
    good = np.setdiff1d(np.arange(len(frames)), [4, 10, 11])
    check(PoseTrajectory(traj.poses[good], t=traj.t[good]), truth[good])
    # interpolated frames lie between their neighbours' poses (truth: the neighbours themselves)
    assert np.all(np.abs(traj.poses[4] - 0.5 * (traj.poses[3] + traj.poses[5])) < 1e-12)
    long = frames.copy()
    long[6 : 7 + MAX_AUTO_GAP] = 255
    with pytest.raises(ValueError, match=rf"frames 6-{6 + MAX_AUTO_GAP}: {MAX_AUTO_GAP + 1} consecutive .*inspect"):
        extractor().transform([long])
    (traj,) = extractor(on_missing="interpolate").transform([long])  # asked for: interpolated without limit
    assert np.isfinite(traj.poses).all()


def test_video_png_folder_and_parallel(tmp_path: Path, curl_set) -> None:
    truth, _ = curl_set
    truth = truth[::3]
    avi = render_video(truth, tmp_path / "clip.avi", CAM, fps=50.0, marker_size=SIZE).video
    png, png_json = render_video(truth, tmp_path / "frames", CAM, fps=50.0, marker_size=SIZE)
    assert png_json == png / "camera.json"
    ex = MarkerPoseExtractor(progress=False)  # camera and fps from the JSON files
    a, b = ex.transform([str(avi), png])
    for traj in (a, b):
        check(traj, truth)
        np.testing.assert_allclose(traj.t, np.arange(len(truth)) / 50.0)
    assert "camera JSON" in ex.diagnostics_[0]["calibration"]
    assert read_frames(avi).shape == (len(truth), 480, 640, 3)
    assert read_frames(png).shape == (len(truth), 480, 640)
    # the n_jobs path (joblib); threads keep the test fast, processes are benchmarked
    with parallel_backend("threading"):
        par = clone(ex).set_params(n_jobs=2).transform([str(avi), png])
    for one, two in zip((a, b), par, strict=True):
        np.testing.assert_array_equal(one.poses, two.poses)


def _erase_marker(frame: np.ndarray, pix: np.ndarray, i: int) -> None:
    w, t = np.asarray(SIZE) * CAM.pixels_per_metre + 2.0  # the marker and its anti-aliased edge, not its neighbours
    cv2.fillPoly(frame, [np.round(marker_corners(pix[i], w, t)).astype(np.int32)], 255)


def test_missing_merged_extra_markers(curl_set) -> None:
    truth, frames = curl_set
    frames = frames.copy()
    pix = CAM.to_pixels(truth)
    _erase_marker(frames[5], pix[5], 7)  # missing
    a, b = pix[9, 12, :2], pix[9, 13, :2]  # merged: a blob joining two markers
    cv2.line(frames[9], tuple(int(round(c)) for c in a), tuple(int(round(c)) for c in b), 0, 6)
    frames[14] = 255  # blank
    cases = (
        ("found 20", 5, dict(fill_missing=False, on_missing="raise")),
        ("found 19", 9, dict(on_missing="raise")),
        ("no markers", 14, dict(on_missing="raise")),
    )
    for msg, k, kw in cases:
        with pytest.raises(ValueError, match=rf"recording 'array recording 0', frame {k}: {msg}"):
            bad = frames.copy()
            for j in {5, 9, 14} - {k}:
                bad[j] = curl_set[1][j]
            extractor(**kw).transform([bad])
    ex = extractor(on_missing="interpolate")
    traj = ex.transform([frames])[0]
    diag = ex.diagnostics_[0]
    # one missing marker between two detected ones is filled from them (constant strain), the frame kept
    assert diag["markers_filled"] == {5: [7]}
    assert diag["frames_repaired"] == [9, 14]
    assert set(diag["repair_reasons"]) == {9, 14}
    assert diag["frames_complete"] == len(frames) - 3
    assert list(diag["markers_found"][[5, 9, 14]]) == [20, 19, 0]
    good = np.setdiff1d(np.arange(len(frames)), [9, 14])
    check(PoseTrajectory(traj.poses[good], dt=1.0), truth[good])
    # the repaired frames are interpolated in time from their neighbours, not dropped
    for k in (9, 14):
        np.testing.assert_allclose(traj.poses[k], 0.5 * (traj.poses[k - 1] + traj.poses[k + 1]), atol=1e-12)
    # an extra marker-shaped component off the chain is clutter: ignored, and reported
    extra = curl_set[1].copy()
    cv2.rectangle(extra[3], (590, 300), (613, 305), 0, -1)
    ex = extractor()
    check(ex.transform([extra])[0], truth)
    assert ex.diagnostics_[0]["ignored_components"][3] == 1 and ex.diagnostics_[0]["ignored_components"].sum() == 1


def test_n_markers_and_reference_frame(random_set) -> None:
    truth, frames = random_set
    check(extractor(n_markers=20).transform([frames])[0], truth)
    with pytest.raises(ValueError, match=r"frame 0 \(reference frame\): expected a chain of 20 markers .* chain of 21"):
        extractor(n_markers=19).transform([frames])
    with pytest.raises(ValueError, match="reference_frame=40"):
        extractor(reference_frame=40).transform([frames])


def test_bad_recordings(tmp_path: Path, random_set) -> None:
    frames = random_set[1][:3]
    missing = tmp_path / "nope.mp4"
    with pytest.raises(FileNotFoundError, match="nope.mp4"):
        extractor().transform([str(missing)])
    junk = tmp_path / "junk.avi"
    junk.write_text("this is not a video")
    with pytest.raises(OSError, match="junk.avi"):
        extractor().transform([str(junk)])
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="no image files"):
        extractor().transform([empty])
    broken = tmp_path / "broken"
    broken.mkdir()
    for k, f in enumerate(frames):
        cv2.imwrite(str(broken / f"f{k}.png"), f)
    (broken / "f1.png").write_bytes(b"garbage")
    with pytest.raises(OSError, match="frame 1"):
        extractor(on_missing="raise").transform([broken])
    with pytest.warns(UserWarning, match=r"1 frame\(s\) could not be extracted .*frames 1;.*cannot be decoded"):
        extractor().transform([broken])  # the default interpolates one damaged frame, and says so
    with pytest.raises(ValueError, match="uint8"):
        extractor().transform([frames.astype(float)])
    with pytest.raises(ValueError, match="shape"):
        extractor().transform([frames[0]])
    with pytest.raises(ValueError, match="frame rate"):
        extractor(fps=None).transform([frames])
    with pytest.raises(ValueError, match="non-empty list"):
        extractor().transform([])
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for k, f in enumerate(frames):
        cv2.imwrite(str(mixed / f"f{k}.png"), f if k != 2 else f[:400])
    with pytest.raises(ValueError, match="frame 2: size 640x400"):
        extractor().transform([mixed])
    with pytest.raises(ValueError, match="640x480 pixels but the camera"):
        extractor(camera=Camera(3000.0, (320.0, 90.0), (800, 600))).transform([frames])


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(n_markers=0), "n_markers"),
        (dict(threshold="mean"), "threshold"),
        (dict(threshold=300), "threshold"),
        (dict(threshold=((0, 0, 0), (10, 10))), "threshold"),
        (dict(polarity="grey"), "polarity"),
        (dict(blur=4), "blur"),
        (dict(roi=(0, 0, 0, 10)), "roi"),
        (dict(area_tolerance=(1.2, 2.0)), "area_tolerance"),
        (dict(camera=3), "camera"),
        (dict(pixels_per_metre=-1.0), "pixels_per_metre"),
        (dict(fps=100.0, dt=0.01), "fps or dt"),
        (dict(on_missing="skip"), "on_missing"),
        (dict(reference_frame=-1), "reference_frame"),
    ],
)
def test_bad_parameters(kwargs: dict, word: str) -> None:
    with pytest.raises(ValueError, match=word):
        extractor(**kwargs).fit()


def test_sklearn_clone_and_params(random_set) -> None:
    ex = MarkerPoseExtractor(n_markers=20, threshold=100.0, roi=(0, 0, 600, 480), camera=CAM, fps=30.0, progress=False)
    twin = clone(ex)
    assert twin is not ex and twin.get_params() == ex.get_params()
    assert twin.set_params(threshold="otsu") is twin and twin.threshold == "otsu"
    assert ex.fit() is ex
    truth, frames = random_set
    a = ex.fit_transform([frames[:4]])[0]
    b = clone(ex).transform([frames[:4]])[0]
    check(a, truth[:4])
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_allclose(a.t, np.arange(4) / 30.0)


def test_strain_jumps_at_segment_boundaries() -> None:
    # shear and axial strain jump at the boundaries (as in the three_segment data)
    lengths = (0.03, 0.04, 0.03)
    q = np.array(
        [
            [7.0, 0.35, -0.4, -9.0, -0.38, 0.25, 10.0, 0.1, -0.1],
            [20.0, -0.3, 0.3, -25.0, 0.3, -0.35, 30.0, -0.2, 0.2],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        ]
    )[[2, 0, 1]]
    truth = forward_kinematics(q, lengths, S)
    frames = render_frames(truth, CAM, marker_size=SIZE)
    check(extractor().transform([frames])[0], truth)


def test_never_silently_misordered() -> None:
    # extreme random strains: robots curled over themselves, markers merging,
    # tips interleaved with the base region.  Every frame is either flagged
    # (and listed as repaired) or extracted correctly.
    rng = np.random.default_rng(2)
    lengths = (0.07, 0.1)
    s = PlanarPCS(lengths).marker_arc_lengths(20)
    q = rng.uniform(-1, 1, (60, 6)) * np.array([60.0, 0.3, 0.3] * 2)
    q[0] = 0.0
    q[1] = [45.64, -0.09, 0.02, 47.28, -0.17, 0.04]  # tip a full turn back over the base
    truth = forward_kinematics(q, lengths, s)
    cam = Camera(Camera.fit_robot(0.17).pixels_per_metre, (640.0, 480.0), (1280, 960))
    ex = extractor(camera=cam, on_missing="interpolate")
    traj = ex.transform([render_frames(truth, cam)])[0]
    repaired = ex.diagnostics_[0]["frames_repaired"]
    assert 1 in repaired and 0 not in repaired
    good = np.setdiff1d(np.arange(len(q)), repaired)
    assert len(good) > 30  # the test keeps its teeth
    pos = np.linalg.norm(traj.poses[good, :, :2] - truth[good, :, :2], axis=-1) * cam.pixels_per_metre
    ang = np.degrees(np.abs(traj.poses[good, :, 2] - truth[good, :, 2]))
    assert pos.max() < 1.0 and ang.max() < 3.0  # markers 10 px wide, 2.6 px thick here


def test_bad_footage_named_by_recording_and_frame(tmp_path: Path, random_set) -> None:
    truth, frames = random_set
    # no markers at all: the reference frame says so first
    blank = np.full((3, 480, 640), 230, np.uint8)
    with pytest.raises(ValueError, match=r"array recording 0', frame 0 \(reference frame\): .*no markers found"):
        extractor().transform([blank])
    # a second robot: in the reference frame, and appearing later in the recording
    shifted = np.full_like(frames[:4], 255)
    shifted[:, :, 150:] = frames[:4, :, :-150]  # the same robot again, 150 px to the right
    both = np.minimum(frames[:4], shifted)
    with pytest.raises(ValueError, match=r"frame 0 \(reference frame\): two chains of markers"):
        extractor().transform([both])
    later = frames[:4].copy()
    later[2] = both[2]
    with pytest.raises(ValueError, match=r"array recording 0', frame 2: .*second chain"):
        extractor(on_missing="raise").transform([later])
    # a camera JSON made at another resolution, found next to the video
    avi = render_video(truth[:3], tmp_path / "clip.avi", CAM, fps=50.0, marker_size=SIZE).video
    Camera(3000.0, (320.0, 90.0), (800, 600)).to_json(tmp_path / "clip.avi.camera.json", extra={"fps": 50.0})
    with pytest.raises(ValueError, match=r"clip.avi', frame 0: frames are 640x480 pixels but the camera \(camera JSON"):
        MarkerPoseExtractor(progress=False).transform([str(avi)])


def test_uneven_light_and_floor_choose_the_local_threshold() -> None:
    # strong light fall-off and a dark floor the robot hangs into: one global level cannot separate the markers
    truth = poses_of(smooth_strains(12))
    nz = Nuisances(lighting_gradient=1.2, gradient_angle=0.0, vignetting=0.5, floor=120.0, floor_level=0.55, noise=2.0)
    frames = render_frames(truth, CAM, marker_size=SIZE, nuisances=nz)
    with pytest.raises(ValueError, match=r"array recording 0', frames? \d+"):
        extractor(threshold="otsu").transform([frames])  # part of the robot merges with the floor
    with pytest.raises(
        ValueError, match=r"frame 0 \(reference frame\): expected a chain of 21 .*otsu: a chain of \d+ .*Try: "
    ):
        extractor(threshold="otsu", n_markers=20, reference_frame=0).transform([frames])
    ex = extractor()
    check(ex.transform([frames])[0], truth)
    choice = ex.diagnostics_[0]["binarisation"]
    assert choice["chosen"].startswith("local") and "a chain of 21 " not in choice["candidates"]["otsu"]


def test_degraded_footage_with_defaults() -> None:
    # every nuisance at once, drawn at random: extracted with default settings, at sub-pixel accuracy
    truth = poses_of(smooth_strains(200)[:40])  # a fifth of the curl: motion blur of a few pixels at the tip
    frames = render_frames(truth, CAM, marker_size=SIZE, nuisances=Nuisances.random(3, len(truth), 20))
    ex = extractor(on_missing="interpolate")
    traj = ex.transform([frames])[0]
    diag = ex.diagnostics_[0]
    assert diag["frames_repaired"] == [] and diag["frames_complete"] >= len(truth) - 4
    pos = np.linalg.norm(traj.poses[..., :2] - truth[..., :2], axis=-1) * CAM.pixels_per_metre
    ang = np.degrees(np.abs(traj.poses[..., 2] - truth[..., 2]))
    assert np.sqrt(np.mean(pos**2)) < 0.3 and np.sqrt(np.mean(ang**2)) < 1.5


def test_coloured_outlined_markers_on_a_grey_floor() -> None:
    truth = poses_of(smooth_strains(10))
    nz = Nuisances(floor=150.0, floor_level=0.6, lighting_gradient=0.3, noise=2.0)
    frames = render_frames(
        truth,
        CAM,
        marker_size=(0.008, 0.0025),
        marker_style="outline",
        colour=True,
        marker_colour=(190, 90, 30),
        body_colour=(215, 215, 225),
        nuisances=nz,
    )
    ex = extractor()
    check(ex.transform([frames])[0], truth)
    assert ex.diagnostics_[0]["binarisation"]["chosen"].startswith("colour")


@pytest.mark.parametrize("fraction", [0.35, 0.6])
def test_partly_hidden_marker_measured_from_its_visible_part(fraction: float) -> None:
    # a finger covers one end of marker 9 in frames 4-6: the visible part is found where the chain predicts the
    # marker, and its centre moved by half the hidden length (the visible part's own centre is 4-7 px off)
    truth = poses_of(smooth_strains(24))
    frames = render_frames(truth, CAM, marker_size=SIZE, nuisances=Nuisances(occlusion=(9, 4, 3, fraction)))
    ex = extractor()
    traj = ex.transform([frames])[0]
    diag = ex.diagnostics_[0]
    assert diag["markers_filled"] == {} and diag["frames_complete"] == len(truth)
    assert diag["markers_partial"] == {4: [9], 5: [9], 6: [9]}
    pos = np.linalg.norm(traj.poses[4:7, 9, :2] - truth[4:7, 9, :2], axis=-1) * CAM.pixels_per_metre
    ang = np.degrees(np.abs(traj.poses[4:7, 9, 2] - truth[4:7, 9, 2]))
    assert pos.max() < 0.3 and ang.max() < 2.0, (pos, ang)
    others = np.ones(truth.shape[:2], bool)
    others[4:7, 9] = False
    assert np.linalg.norm(traj.poses[..., :2] - truth[..., :2], axis=-1)[others].max() < POS_TOL
    assert np.abs(traj.poses[..., 2] - truth[..., 2])[others].max() < ANG_TOL


def test_motion_blurred_tip_measured_where_the_chain_predicts_it() -> None:
    # the fast tip of the two_segment robot, blurred over 87 % of the frame interval at ~2400 px/m, falls
    # below the marker-shape test in three frames; it is measured there, as accurately as in the frames around
    from pcs_sindy.simulation import get_scenario

    truth = get_scenario("two_segment").generate(seed=0, validation=False).train[0].poses_true[417:431]
    cam = Camera.fit_robot(0.17, (960, 720))
    frames = render_frames(truth, cam, nuisances=Nuisances(motion_blur=0.87))
    ex = MarkerPoseExtractor(camera=cam, fps=1000.0, progress=False)
    traj = ex.transform([frames])[0]
    diag = ex.diagnostics_[0]
    assert diag["markers_filled"] == {} and diag["frames_complete"] == len(truth)
    assert diag["markers_partial"] and set(sum(diag["markers_partial"].values(), [])) == {20}
    pos = np.linalg.norm(traj.poses[..., :2] - truth[..., :2], axis=-1) * cam.pixels_per_metre
    ang = np.degrees(np.abs(traj.poses[..., 2] - truth[..., 2]))
    assert pos.max() < 1.0 and ang.max() < 3.0


def test_no_marker_taken_from_a_component_unlike_it() -> None:
    # marker 9 erased and replaced at its very place by a short bar turned by 25 degrees, or by a blob: neither
    # is taken for the marker, which is filled from its neighbours instead
    truth = poses_of(smooth_strains(24))
    frames = render_frames(truth, CAM, marker_size=SIZE)
    pix = CAM.to_pixels(truth)
    w, t = np.asarray(SIZE) * CAM.pixels_per_metre
    for k, (turn, length) in {4: (np.deg2rad(25.0), 0.5 * w), 5: (0.0, 0.2 * w)}.items():
        _erase_marker(frames[k], pix[k], 9)
        fake = pix[k, 9].copy()
        fake[2] += turn
        cv2.fillPoly(frames[k], [np.round(marker_corners(fake, length, t)).astype(np.int32)], 0)
    ex = extractor()
    traj = ex.transform([frames])[0]
    assert ex.diagnostics_[0]["markers_filled"] == {4: [9], 5: [9]}
    assert ex.diagnostics_[0]["markers_partial"] == {}
    check(traj, truth)
