"""Lens model, checkerboard calibration and the distortion round trip, against OpenCV's own projection."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pcs_sindy.cli.main import main
from pcs_sindy.core import Camera, PlanarPCS, forward_kinematics
from pcs_sindy.io import load, save
from pcs_sindy.simulation.checkerboard import render_checkerboard
from pcs_sindy.simulation.rendering import render_frames
from pcs_sindy.vision import MarkerPoseExtractor, calibrate_camera, find_board

K = np.array([[900.0, 0.0, 322.0], [0.0, 905.0, 236.0], [0.0, 0.0, 1.0]])
DIST = np.array([-0.28, 0.11, 0.0008, -0.0006, -0.02])  # a wide-angle lens: ~9 px at the corners
SIZE = (640, 480)
PLANE_R = np.array([0.08, -0.05, 0.0])  # the robot's plane, slightly tilted, 0.45 m away
PLANE_T = np.array([0.0, -0.085, 0.45])
PATTERN, SQUARE = (9, 6), 0.012
LENGTHS = (0.07, 0.1)


def board_views(n: int, seed: int = 0) -> list[np.ndarray]:
    """Boards all over the image at random tilts, then one lying in the robot's plane."""
    rng = np.random.default_rng(seed)
    views = []
    while len(views) < n:
        rv = rng.normal(0.0, 0.35, 3)
        R, _ = cv2.Rodrigues(rv)
        centre = np.linalg.inv(K) @ [rng.uniform(100, 540), rng.uniform(90, 390), 1.0] * rng.uniform(0.28, 0.45)
        img = render_checkerboard(K, DIST, rv, centre - R @ [0.048, 0.03, 0.0], SIZE, pattern=PATTERN, square=SQUARE)
        if find_board(img, PATTERN) is not None:
            views.append(img)
    Rp, _ = cv2.Rodrigues(PLANE_R)
    psi = 0.3  # the board lies anywhere in the plane, turned
    Rz = np.array([[np.cos(psi), -np.sin(psi), 0.0], [np.sin(psi), np.cos(psi), 0.0], [0.0, 0.0, 1.0]])
    rvec, _ = cv2.Rodrigues(Rp @ Rz)
    views.append(
        render_checkerboard(K, DIST, rvec, PLANE_T + Rp @ [-0.05, 0.03, 0.0], SIZE, pattern=PATTERN, square=SQUARE)
    )
    return views


def test_lens_camera_matches_opencv_projection() -> None:
    cam = Camera.from_pinhole(K, DIST, PLANE_R, PLANE_T, SIZE)
    rng = np.random.default_rng(0)
    poses = np.column_stack([rng.uniform(-0.08, 0.08, 40), rng.uniform(0.0, 0.17, 40), rng.uniform(-3, 3, 40)])
    pix = cam.to_pixels(poses)
    ref, _ = cv2.projectPoints(np.column_stack([poses[:, :2], np.zeros(40)]), PLANE_R, PLANE_T, K, DIST)
    np.testing.assert_allclose(pix[:, :2], ref.reshape(-1, 2), atol=1e-6)
    # an angle is the image direction of a short segment along the marker's axis
    eps = 1e-6
    axis = np.column_stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])])
    ends = np.concatenate([poses[:, :2] - eps * axis, poses[:, :2] + eps * axis])
    ref_ends, _ = cv2.projectPoints(np.column_stack([ends, np.zeros(80)]), PLANE_R, PLANE_T, K, DIST)
    d = ref_ends.reshape(2, 40, 2)[1] - ref_ends.reshape(2, 40, 2)[0]
    diff = (np.arctan2(d[:, 1], d[:, 0]) - pix[:, 2] + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(diff).max() < 1e-4
    back = cam.to_metres(pix)
    np.testing.assert_allclose(back[:, :2], poses[:, :2], atol=1e-9)
    np.testing.assert_allclose(back[:, 2], poses[:, 2], atol=1e-6)
    assert Camera.from_dict(json.loads(json.dumps(cam.to_dict()))) == cam


def test_camera_with_open_base_frame(tmp_path: Path) -> None:
    cam = Camera.from_pinhole(K, DIST, PLANE_R, PLANE_T, SIZE)
    open_ = Camera(cam.pixels_per_metre, None, SIZE, None, cam.camera_matrix, cam.dist_coeffs, cam.rectification)
    assert (
        load(save(open_, tmp_path / "cam")) == open_ and Camera.from_json(open_.to_json(tmp_path / "c.json")) == open_
    )
    with pytest.raises(ValueError, match="base frame"):
        open_.to_pixels([0.0, 0.0])
    np.testing.assert_allclose(open_.rectify([[100.0, 200.0]]), cam.rectify([[100.0, 200.0]]))
    assert open_.with_base(cam.origin, cam.angle) == cam
    with pytest.raises(ValueError, match="dist_coeffs"):
        Camera(dist_coeffs=DIST)
    with pytest.raises(ValueError, match="camera_matrix"):
        Camera(camera_matrix=np.eye(2))


def test_rendered_distorted_markers_sit_at_projected_centres() -> None:
    cam = Camera.from_pinhole(K, DIST, PLANE_R, PLANE_T, SIZE)
    q = np.array([[30.0, 0.05, 0.05, -25.0, -0.05, 0.1]])
    poses = forward_kinematics(q, LENGTHS, PlanarPCS(LENGTHS).marker_arc_lengths(20))
    frame = render_frames(poses, cam, marker_size=(0.008, 0.002), body=False)[0]
    contours, _ = cv2.findContours((frame < 128).astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    cov = (255.0 - frame) / 255.0
    centres = []
    for c in contours:
        x, y, w, h = cv2.boundingRect(c)
        m = cv2.moments(cov[y - 2 : y + h + 2, x - 2 : x + w + 2].astype(np.float32))
        centres.append([x - 2 + m["m10"] / m["m00"], y - 2 + m["m01"] / m["m00"]])
    ref, _ = cv2.projectPoints(np.column_stack([poses[0, :, :2], np.zeros(21)]), PLANE_R, PLANE_T, K, DIST)
    d = np.linalg.norm(ref.reshape(-1, 1, 2) - np.asarray(centres)[None], axis=-1).min(axis=1)
    assert len(centres) == 21 and d.max() < 0.1


def test_calibration_round_trip_on_rendered_distorted_frames() -> None:
    views = board_views(10)
    cal, report = calibrate_camera(views, PATTERN, SQUARE)
    assert report["lens"] and report["views_used"] == 11 and report["rms_reprojection_px"] < 0.15
    np.testing.assert_allclose(np.asarray(cal.camera_matrix), K, rtol=5e-3, atol=1.0)
    assert cal.origin is None and cal.angle is None
    # a robot filmed through the lens, extracted with the calibrated camera and the true base frame
    true = Camera.from_pinhole(K, DIST, PLANE_R, PLANE_T, SIZE)
    rng = np.random.default_rng(1)
    q = rng.uniform(-1, 1, (6, 6)) * np.array([25.0, 0.1, 0.1] * 2)
    q[0] = 0.0
    poses = forward_kinematics(q, LENGTHS, PlanarPCS(LENGTHS).marker_arc_lengths(20))
    frames = render_frames(poses, true, marker_size=(0.008, 0.002))
    origin = cal.rectify(true.to_pixels(np.zeros(2)))
    down = cal.rectify(true.to_pixels(np.array([0.0, 0.01]))) - origin
    given = cal.with_base(tuple(origin), float(np.arctan2(down[1], down[0]) - np.pi / 2))
    errors = {}
    for label, kw in (
        ("calibrated", dict(camera=given)),
        ("found base", dict(camera=cal)),
        ("no lens", dict(camera=None, robot_length=0.17)),
    ):
        traj = MarkerPoseExtractor(fps=100.0, progress=False, **kw).transform([frames])[0]
        e = np.linalg.norm(traj.poses[..., :2] - poses[..., :2], axis=-1) * true.pixels_per_metre
        errors[label] = float(np.sqrt(np.mean(e**2)))
    assert errors["calibrated"] < 0.15 and errors["found base"] < 0.25
    assert errors["no lens"] > 1.0  # the test can fail: the lens matters at this distortion


def test_calibration_without_lens_views_is_a_homography() -> None:
    views = board_views(0)
    cal, report = calibrate_camera(views, PATTERN, SQUARE)
    assert not report["lens"] and cal.camera_matrix is None and cal.rectification is not None


def test_calibration_bad_input() -> None:
    blank = np.full((480, 640), 200, np.uint8)
    with pytest.raises(ValueError, match="plane view.*no 9x6 checkerboard"):
        calibrate_camera([blank], PATTERN, SQUARE, names=["blank.png"])
    with pytest.raises(ValueError, match="pattern"):
        calibrate_camera([blank], (1, 6), SQUARE)
    with pytest.raises(ValueError, match="square"):
        calibrate_camera([blank], PATTERN, -1.0)
    with pytest.raises(ValueError, match="differs"):
        calibrate_camera([blank, blank[:400]], PATTERN, SQUARE)
    with pytest.raises(ValueError, match="at least one"):
        calibrate_camera([], PATTERN, SQUARE)


def test_cli_calibrate_writes_a_camera_json(tmp_path: Path) -> None:
    views = board_views(3, seed=2)
    for k, img in enumerate(views[:-1]):
        cv2.imwrite(str(tmp_path / f"view_{k}.png"), img)
    cv2.imwrite(str(tmp_path / "plane.png"), views[-1])
    out = tmp_path / "clip.avi.camera.json"
    args = [
        "calibrate",
        *sorted(str(p) for p in tmp_path.glob("view_*.png")),
        "--plane",
        str(tmp_path / "plane.png"),
        "--pattern",
        "9x6",
        "--square",
        str(SQUARE),
        "--out",
        str(out),
        "--fps",
        "500",
        "--quiet",
    ]
    assert main(args) == 0
    cam = Camera.from_json(out)
    assert cam.camera_matrix is not None and cam.origin is None
    assert json.loads(out.read_text())["fps"] == 500.0
    assert (
        main(
            [
                "calibrate",
                str(tmp_path / "view_0.png"),
                "--pattern",
                "7x7",
                "--square",
                "0.01",
                "--out",
                str(tmp_path / "x.json"),
                "--quiet",
            ]
        )
        == 2
    )
