"""State estimation at camera rate: streaming extraction and the single-frame fusion."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pcs_sindy.core import Camera, PlanarPCS, forward_kinematics, forward_kinematics_jacobian
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.fusion._frame_fit import fk_jacobian
from pcs_sindy.simulation.rendering import render_frames
from pcs_sindy.vision import MarkerPoseExtractor

LENGTHS = (0.07, 0.1)
S = PlanarPCS(LENGTHS).marker_arc_lengths(20)


def smooth_motion(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)[:, None]
    q = (
        rng.uniform(-1, 1, (1, 6))
        * np.array([35.0, 0.1, 0.1] * 2)
        * np.sin(2 * np.pi * rng.uniform(0.5, 1.5, (1, 6)) * t)
    )
    q[0] = 0.0
    return q


def test_compiled_jacobian_matches_the_numpy_kinematics() -> None:
    rng = np.random.default_rng(0)
    for lengths in ((0.1,), LENGTHS, (0.05, 0.1, 0.06)):
        s = PlanarPCS(lengths).marker_arc_lengths(20)[1:]
        for q in (
            np.zeros(3 * len(lengths)),
            rng.normal(0, 1, 3 * len(lengths)) * np.tile([30.0, 0.2, 0.2], len(lengths)),
        ):
            ref_pose, ref_jac = forward_kinematics_jacobian(q, lengths, s)
            pose, jac = np.empty((s.size, 3)), np.empty((s.size, 3, q.size))
            fk_jacobian(q, np.asarray(lengths, dtype=float), s, pose, jac)
            np.testing.assert_allclose(pose, ref_pose, atol=1e-12)
            np.testing.assert_allclose(jac, ref_jac, atol=1e-10)


@pytest.mark.parametrize("shape_fit", ["least_squares", "end_pose"])
def test_transform_frame_matches_transform(shape_fit: str) -> None:
    rng = np.random.default_rng(1)
    q = smooth_motion(80)
    poses = forward_kinematics(q, LENGTHS, S)
    noisy = poses.copy()
    noisy[:, 1:, :2] += rng.normal(0, 1e-4, noisy[:, 1:, :2].shape)
    noisy[:, 1:, 2] += rng.normal(0, 0.005, noisy[:, 1:, 2].shape)
    fusion = KinematicFusion(total_length=0.17, shape_fit=shape_fit).fit([noisy])
    batch = fusion.transform([noisy])[0].q
    q_prev = None
    for k in range(len(noisy)):
        q_prev = fusion.transform_frame(noisy[k], q_prev)
        np.testing.assert_allclose(q_prev, batch[k], atol=1e-6 * (1 + np.abs(batch[k]).max()))
    with pytest.raises(ValueError, match="shape"):
        fusion.transform_frame(noisy[0, :5])
    with pytest.raises(ValueError, match="q0"):
        fusion.transform_frame(noisy[0], np.zeros(2))


def test_stream_gives_the_batch_poses_frame_by_frame() -> None:
    poses = forward_kinematics(smooth_motion(40, seed=2), LENGTHS, S)
    cam = Camera.fit_robot(0.17, (640, 480))
    frames = render_frames(poses, cam)
    batch = MarkerPoseExtractor(camera=cam, fps=100.0, progress=False).transform([frames])[0].poses
    stream = MarkerPoseExtractor(camera=cam, progress=False).stream(frames[0])
    assert stream.n_markers == 20
    np.testing.assert_allclose(stream.last, batch[0], atol=1e-12)
    for k in range(1, len(frames)):
        np.testing.assert_allclose(stream.update(frames[k]), batch[k], atol=1e-12)
    # a frame without markers raises, naming it; the next good frame is extracted again
    with pytest.raises(ValueError, match="stream, frame 40: found 0"):
        stream.update(np.full_like(frames[0], 255))
    np.testing.assert_allclose(stream.update(frames[-1]), batch[-1], atol=1e-9)
    np.testing.assert_allclose(stream.last[..., :2], poses[-1, :, :2], atol=0.3 / cam.pixels_per_metre)
    with pytest.raises(ValueError, match="expected a uint8 image of 640x480"):
        stream.update(frames[0][:100])
    # without a camera: the base must be given, the scale from the straight first frame
    free = MarkerPoseExtractor(
        camera=None, robot_length=0.17, base_position=tuple(cam.to_pixels(np.zeros(2))), progress=False
    )
    np.testing.assert_allclose(free.stream(frames[0]).update(frames[5])[..., :2], poses[5, :, :2], atol=1e-4)
    with pytest.raises(ValueError, match="base_position or a camera"):
        MarkerPoseExtractor(camera=None, robot_length=0.17, progress=False).stream(frames[0])


def _hide(frame: np.ndarray, cam: Camera, poses: np.ndarray) -> np.ndarray:
    """The frame with these markers painted over in the background colour (a 4.5 mm disc covers an 8 x 2 mm one)."""
    out = frame.copy()
    radius = int(np.ceil(0.0045 * cam.pixels_per_metre))
    for pose in poses:
        u, v = np.round(cam.to_pixels(pose[:2])).astype(int)
        cv2.circle(out, (int(u), int(v)), radius, 255, -1)
    return out


def test_stream_predicts_a_few_lost_markers_from_the_last_frames() -> None:
    # 1 kHz-like motion: the tip moves up to about 7 px per frame at this scale
    poses = forward_kinematics(smooth_motion(400, seed=2), LENGTHS, S)[130:145]
    cam = Camera.fit_robot(0.17, (640, 480))
    frames = render_frames(poses, cam)
    lost = [5, 6]  # the two tip markers vanish for two frames (merged or blurred away in real footage)
    seen = [_hide(f, cam, poses[k, -2:]) if k in lost else f for k, f in enumerate(frames)]
    # the default still raises on such a frame
    plain = MarkerPoseExtractor(camera=cam, progress=False).stream(frames[0])
    for k in range(1, lost[0]):
        plain.update(seen[k])
    with pytest.raises(ValueError, match=f"stream, frame {lost[0]}: found 19 marker-shaped"):
        plain.update(seen[lost[0]])

    stream = MarkerPoseExtractor(camera=cam, progress=False, on_missing="predict").stream(frames[0])
    px = 1.0 / cam.pixels_per_metre
    for k in range(1, len(frames)):
        out = stream.update(seen[k])
        if k not in lost:
            assert stream.last_predicted == []
            np.testing.assert_allclose(out[:, :2], poses[k, :, :2], atol=0.3 * px)
            continue
        assert stream.last_predicted == [19, 20]
        # the others are measured as on a complete frame
        np.testing.assert_allclose(out[:19, :2], poses[k, :19, :2], atol=0.3 * px)
        # constant velocity from frames k - 1, k - 2 (themselves predicted after the first lost frame):
        # the truth's own departure from constant velocity over those frames, plus the measurement error
        # amplified by the extrapolation (3x after one frame, 5x after two)
        first = lost[0] - 1
        steps = k - first
        extrap = poses[first, -2:] + steps * (poses[first, -2:] - poses[first - 1, -2:])
        measured = np.array([0.3 * px, 0.3 * px, np.deg2rad(0.35)])  # per marker: x, y, angle
        bound = np.abs(extrap - poses[k, -2:]) + (1 + 2 * steps) * measured
        assert np.all(np.abs(out[-2:] - poses[k, -2:]) <= bound)
        # and in absolute terms: within half a millimetre and 2 degrees
        assert np.abs(out[-2:, :2] - poses[k, -2:, :2]).max() < 5e-4
        assert np.abs(out[-2:, 2] - poses[k, -2:, 2]).max() < np.deg2rad(2.0)
    assert stream.diagnostics["frames_predicted"] == 2
    assert stream.diagnostics["markers_predicted"] == 4

    # three lost markers are too many for max_predicted=2; with max_predicted=3 they are predicted
    three = _hide(frames[5], cam, poses[5, -3:])
    for max_predicted, ok in ((2, False), (3, True)):
        s = MarkerPoseExtractor(camera=cam, progress=False, on_missing="predict").stream(
            frames[0], max_predicted=max_predicted
        )
        for k in range(1, 5):
            s.update(frames[k])
        if ok:
            s.update(three)
            assert s.last_predicted == [18, 19, 20]
        else:
            with pytest.raises(ValueError, match=r"frame 5: .*3 markers lost \(\[18, 19, 20\]\), at most 2"):
                s.update(three)
    # no history: the frame right after the reference, or right after a frame that raised
    s = MarkerPoseExtractor(camera=cam, progress=False, on_missing="predict").stream(frames[0])
    with pytest.raises(ValueError, match="frame 1: .*the two frames before were not both extracted"):
        s.update(_hide(frames[1], cam, poses[1, -2:]))
    s.update(frames[2])
    with pytest.raises(ValueError, match="frame 3: .*the two frames before"):
        s.update(_hide(frames[3], cam, poses[3, -2:]))
    # at most max_run frames in a row are predicted
    s = MarkerPoseExtractor(camera=cam, progress=False, on_missing="predict").stream(frames[0], max_run=1)
    for k in range(1, 5):
        s.update(frames[k])
    s.update(_hide(frames[5], cam, poses[5, -2:]))
    with pytest.raises(ValueError, match="frame 6: .*already 1 frames in a row predicted"):
        s.update(_hide(frames[6], cam, poses[6, -2:]))


def test_on_missing_predict_is_validated_and_for_streams_only() -> None:
    frames = render_frames(forward_kinematics(smooth_motion(3), LENGTHS, S), Camera.fit_robot(0.17, (640, 480)))
    with pytest.raises(ValueError, match="on_missing must be one of 'auto', 'raise', 'interpolate', 'predict'; got"):
        MarkerPoseExtractor(on_missing="hold").fit()
    with pytest.raises(ValueError, match="on_missing='predict' is for stream"):
        MarkerPoseExtractor(on_missing="predict", fps=100.0, progress=False).transform([frames])
    ext = MarkerPoseExtractor(camera=Camera.fit_robot(0.17, (640, 480)), on_missing="predict", progress=False)
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match=f"max_predicted must be a positive integer; got {bad!r}"):
            ext.stream(frames[0], max_predicted=bad)
    with pytest.raises(ValueError, match="max_run must be a positive integer; got -1"):
        ext.stream(frames[0], max_run=-1)
