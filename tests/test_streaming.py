"""State estimation at camera rate: streaming extraction and the single-frame fusion."""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy._frame_fit import fk_jacobian
from pcs_sindy.camera import Camera
from pcs_sindy.kinematics import PlanarPCS, forward_kinematics, forward_kinematics_jacobian
from pcs_sindy.segmentation import KinematicFusion
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
