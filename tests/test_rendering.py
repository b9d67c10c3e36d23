"""Renderer and camera: checked with plain OpenCV measurements and closed forms."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pcs_sindy.core import Camera, PlanarPCS, forward_kinematics, read_camera_json
from pcs_sindy.core.camera import camera_json_path
from pcs_sindy.simulation.rendering import marker_corners, render_frames, render_video

LENGTHS = (0.05, 0.05)
S = PlanarPCS(LENGTHS).marker_arc_lengths(20)
CAM = Camera(3000.0, (320.0, 90.0), (640, 480))
SIZE = (0.008, 0.002)  # 24 x 6 px markers


def random_poses(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, (n, 6)) * np.array([30.0, 0.1, 0.1] * 2)
    q[0] = 0.0
    return forward_kinematics(q, LENGTHS, S)


def contour_centres(frame: np.ndarray) -> list[tuple[np.ndarray, tuple]]:
    """(centre from cv2.moments of the binary contour, minAreaRect) of every dark component."""
    grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    binary = (grey < 128).astype(np.uint8)
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    out = []
    for c in contours:
        m = cv2.moments(c)
        out.append((np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]), cv2.minAreaRect(c)))
    return out


def match(projected: np.ndarray, found: np.ndarray) -> np.ndarray:
    """Index of the found centre nearest to each projected one; asserts a one-to-one match."""
    d = np.linalg.norm(projected[:, None] - found[None], axis=-1)
    j = d.argmin(axis=1)
    assert len(set(j.tolist())) == len(projected), "two markers matched the same contour"
    return j


@pytest.mark.parametrize("colour", [False, True])
@pytest.mark.parametrize("body", [False, True])
def test_contour_centres_match_projected_markers(body: bool, colour: bool) -> None:
    poses = random_poses(6)
    frames = render_frames(poses, CAM, marker_size=SIZE, body=body, colour=colour)
    assert frames.dtype == np.uint8
    assert frames.shape == ((6, 480, 640, 3) if colour else (6, 480, 640))
    pix = CAM.to_pixels(poses)
    for k, frame in enumerate(frames):
        found = contour_centres(frame)
        assert len(found) == poses.shape[1], f"frame {k}: {len(found)} contours"
        centres = np.array([c for c, _ in found])
        j = match(pix[k, :, :2], centres)
        err = np.linalg.norm(centres[j] - pix[k, :, :2], axis=1)
        assert err.max() < 1.0, f"frame {k}: centre error {err.max():.3f} px"


def test_rectangles_are_across_the_backbone() -> None:
    poses = random_poses(5, seed=1)
    frames = render_frames(poses, CAM, marker_size=SIZE, body=False)
    pix = CAM.to_pixels(poses)
    for k, frame in enumerate(frames):
        found = contour_centres(frame)
        centres = np.array([c for c, _ in found])
        j = match(pix[k, :, :2], centres)
        for i, jj in enumerate(j):
            (_, _), (w, h), ang = found[jj][1]
            long_axis = np.deg2rad(ang if w >= h else ang + 90.0)
            diff = (long_axis - pix[k, i, 2] + np.pi / 2) % np.pi - np.pi / 2
            assert abs(np.degrees(diff)) < 4.0
            # the contour runs through the centres of the boundary pixels: one pixel short
            assert max(w, h) == pytest.approx(SIZE[0] * CAM.pixels_per_metre - 1.0, abs=1.5)
            assert min(w, h) == pytest.approx(SIZE[1] * CAM.pixels_per_metre - 1.0, abs=1.5)
        # the long side is nearly perpendicular to the chord towards the next marker (small shear)
        chord = np.diff(pix[k, :, :2], axis=0)
        axis_dir = np.stack([np.cos(pix[k, :-1, 2]), np.sin(pix[k, :-1, 2])], axis=1)
        cosang = np.abs(np.sum(chord * axis_dir, axis=1)) / np.linalg.norm(chord, axis=1)
        assert np.all(cosang < np.sin(np.deg2rad(12)))  # |shear| <= 0.1 plus half a marker's turn


def test_antialiasing_gives_exact_area_and_centroid() -> None:
    # one isolated marker at random sub-pixel poses: the summed darkness is its area
    rng = np.random.default_rng(2)
    for _ in range(10):
        pose = np.array([[rng.uniform(-0.01, 0.01), rng.uniform(0.01, 0.03), rng.uniform(-np.pi, np.pi)]])
        frame = render_frames(pose[None], CAM, marker_size=SIZE, body=False)[0]
        coverage = (255.0 - frame) / 255.0
        area = SIZE[0] * SIZE[1] * CAM.pixels_per_metre**2
        assert coverage.sum() == pytest.approx(area, rel=0.02)
        m = cv2.moments(coverage.astype(np.float32))
        centre = np.array([m["m10"], m["m01"]]) / m["m00"]
        assert np.linalg.norm(centre - CAM.to_pixels(pose)[0, :2]) < 0.1


def test_outline_markers_are_hollow() -> None:
    poses = random_poses(1)
    frame = render_frames(poses, CAM, marker_size=(0.01, 0.003), marker_style="outline", body=False)[0]
    pix = CAM.to_pixels(poses)[0]
    for u, v, _ in pix:
        assert frame[int(round(v)), int(round(u))] > 200  # centre is background
    assert len(contour_centres(frame)) == poses.shape[1]


def test_body_is_lighter_than_markers() -> None:
    poses = random_poses(1)
    frame = render_frames(poses, CAM, marker_size=SIZE, body=True, body_colour=180)[0]
    mid = 0.5 * (CAM.to_pixels(poses)[0, 3, :2] + CAM.to_pixels(poses)[0, 4, :2])
    assert frame[int(round(mid[1])), int(round(mid[0]))] == 180
    assert np.count_nonzero(frame == 180) > 100
    # a given backbone is drawn instead of the polyline through the markers
    fine = forward_kinematics(np.zeros(6), LENGTHS, np.linspace(0.0, 0.1, 50))
    shifted = fine[None, :, :2] + np.array([0.02, 0.0])
    frame = render_frames(poses, CAM, marker_size=SIZE, body=shifted, body_colour=180)[0]
    u, v = CAM.to_pixels(shifted[0, 25])
    assert frame[int(round(v)), int(round(u))] == 180
    assert frame[int(round(mid[1])), int(round(mid[0]))] == 255  # no body between the markers any more


@pytest.mark.parametrize(
    "camera, length",
    [(Camera(), 0.1), (Camera(), 0.2), (Camera.fit_robot(0.1), 0.1), (Camera.fit_robot(0.2, (1280, 720)), 0.2)],
)
def test_default_cameras_fit_robot_bending_past_180_degrees(camera: Camera, length: float) -> None:
    s = np.linspace(0, length, 21)
    kl = np.linspace(-4.0, 4.0, 33)  # total bending angle, beyond ±180°
    q = np.stack([np.repeat(kl / length, 3), np.zeros(99), np.tile([-0.3, 0.0, 0.3], 33)], axis=1)
    pix = camera.to_pixels(forward_kinematics(q, [length], s))
    margin = 0.5 * SIZE[0] * camera.pixels_per_metre
    w, h = camera.image_size
    assert pix[..., 0].min() > margin and pix[..., 0].max() < w - 1 - margin
    assert pix[..., 1].min() > margin and pix[..., 1].max() < h - 1 - margin


def test_default_camera_fitted_to_the_poses() -> None:
    poses = random_poses(3)
    cam = Camera.fit_poses(poses)
    # marker polyline of a 0.1 m robot with |axial strain| <= 0.1: length within 10 %
    ref = Camera.fit_robot(0.1)
    assert cam.image_size == (640, 480)
    assert cam.pixels_per_metre == pytest.approx(ref.pixels_per_metre, rel=0.1)
    np.testing.assert_array_equal(render_frames(poses, marker_size=SIZE), render_frames(poses, cam, marker_size=SIZE))
    with pytest.raises(ValueError, match="poses"):
        Camera.fit_poses(np.zeros((2, 1, 3)))


def test_camera_mapping_closed_form_and_round_trip() -> None:
    cam = Camera(2000.0, (100.0, 50.0), (400, 300), angle=0.0)
    # +x of the base frame is image-right, +y image-down
    np.testing.assert_allclose(cam.to_pixels([0.01, 0.02, 0.3]), [120.0, 90.0, 0.3])
    rot = Camera(2000.0, (100.0, 50.0), (400, 300), angle=np.pi / 2)
    np.testing.assert_allclose(rot.to_pixels([0.01, 0.0]), [100.0, 70.0], atol=1e-12)
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(7, 5, 3))
    for c in (cam, rot, Camera(1234.5, (3.2, -7.0), (10, 10), angle=-2.1)):
        np.testing.assert_allclose(c.to_metres(c.to_pixels(pts)), pts, atol=1e-12)
        # distances scale by pixels_per_metre
        d_m = np.linalg.norm(pts[:, 1, :2] - pts[:, 0, :2], axis=1)
        p = c.to_pixels(pts)
        np.testing.assert_allclose(np.linalg.norm(p[:, 1, :2] - p[:, 0, :2], axis=1), c.pixels_per_metre * d_m)


def test_camera_json_round_trip(tmp_path: Path) -> None:
    cam = Camera(1500.5, (10.25, 20.5), (320, 240), angle=0.125)
    path = cam.to_json(tmp_path / "c.json", extra={"fps": 100.0})
    assert Camera.from_json(path) == cam
    assert read_camera_json(path)["fps"] == 100.0
    assert camera_json_path(tmp_path / "v.mp4") == tmp_path / "v.mp4.camera.json"
    assert camera_json_path(tmp_path) == tmp_path / "camera.json"


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(pixels_per_metre=0.0), "pixels_per_metre"),
        (dict(pixels_per_metre=float("nan")), "pixels_per_metre"),
        (dict(origin=(1.0, float("inf"))), "origin"),
        (dict(image_size=(640, 0)), "image_size"),
        (dict(image_size=(640.5, 480)), "image_size"),
        (dict(angle=float("nan")), "angle"),
    ],
)
def test_camera_bad_input(kwargs: dict, word: str) -> None:
    with pytest.raises(ValueError, match=word):
        Camera(**kwargs)


def test_camera_json_errors(tmp_path: Path) -> None:
    with pytest.raises(OSError, match="missing.json"):
        Camera.from_json(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="bad.json"):
        Camera.from_json(bad)
    (tmp_path / "partial.json").write_text(json.dumps({"origin": [1.0, 2.0]}))
    with pytest.raises(ValueError, match=r"partial.json.*lacks \['pixels_per_metre', 'image_size'\]"):
        Camera.from_json(tmp_path / "partial.json")
    # what the footage tells may be left out: the image size (given by the caller) and the base frame
    (tmp_path / "scale.json").write_text(json.dumps({"pixels_per_metre": 3.0}))
    assert Camera.from_json(tmp_path / "scale.json", image_size=(64, 48)) == Camera(3.0, None, (64, 48), None)


@pytest.mark.parametrize("suffix", [".avi", ".mp4", ""])
def test_render_video_files_and_camera_json(tmp_path: Path, suffix: str) -> None:
    poses = random_poses(5)
    cam = Camera(1500.0, (160.0, 40.0), (320, 240))
    out = render_video(poses, tmp_path / f"clip{suffix}", cam, fps=250.0, marker_size=SIZE)
    assert Camera.from_json(out.camera) == cam
    assert read_camera_json(out.camera)["fps"] == 250.0
    if suffix:
        cap = cv2.VideoCapture(str(out.video))
        n = 0
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            assert frame.shape == (240, 320, 3)
            n += 1
        cap.release()
        assert n == 5
        assert out.camera == camera_json_path(out.video)
    else:
        files = sorted(out.video.glob("*.png"))
        assert len(files) == 5
        expected = render_frames(poses, cam, marker_size=SIZE)
        for f, e in zip(files, expected, strict=True):
            np.testing.assert_array_equal(cv2.imread(str(f), cv2.IMREAD_UNCHANGED), e)


def test_render_bad_input(tmp_path: Path) -> None:
    poses = random_poses(2)
    with pytest.raises(ValueError, match="poses"):
        render_frames(poses[..., :2], CAM)
    bad = poses.copy()
    bad[1, 3, 0] = np.nan
    with pytest.raises(ValueError, match="frame 1, marker 3"):
        render_frames(bad, CAM)
    with pytest.raises(ValueError, match="marker_size"):
        render_frames(poses, CAM, marker_size=(0.002, 0.008))
    with pytest.raises(ValueError, match="marker_style"):
        render_frames(poses, CAM, marker_style="dotted")
    with pytest.raises(ValueError, match="supersample"):
        render_frames(poses, CAM, supersample=0)
    with pytest.raises(ValueError, match="body"):
        render_frames(poses, CAM, body=np.zeros((3, 4, 2)))
    with pytest.raises(ValueError, match="camera"):
        render_frames(poses, camera="default")
    with pytest.raises(ValueError, match="path"):
        render_video(poses, tmp_path / "clip.gif", CAM)
    with pytest.raises(ValueError, match="fps"):
        render_video(poses, tmp_path / "clip.avi", CAM, fps=0)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(OSError, match="file"):
        render_video(poses, blocker / "sub" / "clip.avi", CAM)


def test_nuisances_photometry_and_blur() -> None:
    from pcs_sindy.simulation.nuisances import Nuisances

    poses = random_poses(3)
    # light multiplies every pixel: the ratio to the clean frame is the illumination field, brighter up-gradient
    lit = render_frames(
        poses, CAM, marker_size=SIZE, body=False, background=150, nuisances=Nuisances(lighting_gradient=0.4)
    ).astype(float)
    # falls along +u from 1.2 to 0.8 over the half-diagonal either side of the centre
    half = np.hypot(319.5, 239.5)
    for u in (10, 320, 629):
        assert lit[0, 470, u] == pytest.approx(150 * (1 - 0.2 * (u - 319.5) / half), abs=0.6)
    # noise has the requested standard deviation on the background, and the same seed repeats it
    noisy = render_frames(poses, CAM, marker_size=SIZE, body=False, nuisances=Nuisances(noise=4.0, seed=1))
    resid = noisy.astype(float)[:, 100:200, 20:120] - 255.0
    assert np.std(np.clip(resid, None, 0)) > 1.0  # clipped at white, but present
    np.testing.assert_array_equal(
        noisy, render_frames(poses, CAM, marker_size=SIZE, body=False, nuisances=Nuisances(noise=4.0, seed=1))
    )
    # motion blur averages the exposure: a marker moving at constant speed keeps its darkness and its centroid
    moving = np.zeros((3, 1, 3))
    moving[:, 0, 0] = [0.0, 0.002, 0.004]  # 6 px per frame along x
    moving[:, 0, 1] = 0.03
    sharp = render_frames(moving, CAM, marker_size=SIZE, body=False)[1]
    blurred = render_frames(moving, CAM, marker_size=SIZE, body=False, nuisances=Nuisances(motion_blur=1.0))[1]
    for img in (sharp, blurred):
        m = cv2.moments(((255.0 - img) / 255.0).astype(np.float32))
        assert abs(m["m00"] - SIZE[0] * SIZE[1] * CAM.pixels_per_metre**2) < 3.0
        assert np.linalg.norm([m["m10"] / m["m00"] - CAM.to_pixels(moving[1, 0])[0], m["m01"] / m["m00"] - 180.0]) < 0.1
    assert np.count_nonzero(blurred < 250) > np.count_nonzero(sharp < 250)  # smeared over more pixels


def test_nuisances_scene_and_occlusion() -> None:
    from pcs_sindy.simulation.nuisances import Nuisances

    poses = random_poses(4)
    plain = render_frames(poses, CAM, marker_size=SIZE, body=False)
    floor = render_frames(poses, CAM, marker_size=SIZE, body=False, nuisances=Nuisances(floor=120.0, floor_level=0.9))
    assert np.all(floor[:, 440:, :] <= 120) and np.array_equal(floor[:, :400], plain[:, :400])
    cluttered = render_frames(poses, CAM, marker_size=SIZE, body=False, nuisances=Nuisances(clutter=True, seed=2))
    assert np.count_nonzero(cluttered[0] < 128) > 2 * np.count_nonzero(plain[0] < 128)
    # the occluder covers the requested share of one marker's width, in the requested frames only
    occ = render_frames(poses, CAM, marker_size=SIZE, body=False, nuisances=Nuisances(occlusion=(5, 1, 2, 0.5)))
    pix = CAM.to_pixels(poses)
    for k in range(4):
        # the marker's inside (one pixel in from its anti-aliased edges)
        corners = np.round(
            marker_corners(pix[k, 5], SIZE[0] * CAM.pixels_per_metre - 2, SIZE[1] * CAM.pixels_per_metre - 2)
        )
        mask = np.zeros((480, 640), np.uint8)
        cv2.fillPoly(mask, [corners.astype(np.int32)], 1)
        dark = np.count_nonzero((occ[k] < 100) & (mask > 0)) / np.count_nonzero(mask)
        assert (0.35 < dark < 0.65) if k in (1, 2) else dark > 0.95
    with pytest.raises(ValueError, match="occlusion"):
        Nuisances(occlusion=(1, 0, 0, 0.5))
    with pytest.raises(ValueError, match="noise"):
        Nuisances(noise=-1.0)
    with pytest.raises(ValueError, match="jpeg_quality"):
        Nuisances(jpeg_quality=0)
    with pytest.raises(ValueError, match="nuisances"):
        render_frames(poses, CAM, nuisances={"noise": 1.0})


@pytest.mark.parametrize("suffix", [".avi", ".mp4"])
def test_interrupted_render_leaves_no_video_under_its_name(tmp_path: Path, monkeypatch, suffix: str) -> None:
    """Ctrl-C while frames are written: nothing under the final name, the old video kept, no temporaries."""
    import pcs_sindy.simulation.rendering as rendering

    poses = random_poses(600)  # three chunks of frames
    cam = Camera(1500.0, (160.0, 40.0), (320, 240))
    target = tmp_path / f"clip{suffix}"
    calls = {"n": 0}
    real = rendering.render_frames

    def interrupted(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:  # after a first chunk reached the writer
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(rendering, "render_frames", interrupted)
    with pytest.raises(KeyboardInterrupt):
        render_video(poses, target, cam, fps=100.0, marker_size=SIZE)
    assert calls["n"] == 2
    assert list(tmp_path.iterdir()) == []  # no truncated video, no hidden temporary

    target.write_bytes(b"an older video")
    calls["n"] = 0
    with pytest.raises(KeyboardInterrupt):
        render_video(poses, target, cam, fps=100.0, marker_size=SIZE)
    assert target.read_bytes() == b"an older video"
    assert [p.name for p in tmp_path.iterdir()] == [target.name]
