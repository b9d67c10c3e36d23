"""Extraction on small versions of foreign footage, with only fps, marker count and robot length given.

The truth is the constant-strain kinematics the footage was drawn from
(:func:`pcs_sindy.simulation.foreign.foreign_poses`), independent of the
extraction.
"""

from __future__ import annotations

import re

import cv2
import numpy as np
import pytest

from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.simulation.foreign import FOREIGN_KINDS, foreign_poses, render_foreign_footage
from pcs_sindy.vision import MarkerPoseExtractor

SIZE = (720, 567)  # about a quarter of the benchmark's 3000x2360 in each direction


def extract(folder, ff, **kw):
    ex = MarkerPoseExtractor(n_markers=ff.n_markers, robot_length=ff.robot_length, fps=ff.fps, progress=False, **kw)
    return ex, ex.transform([str(folder)])[0]


@pytest.mark.parametrize("kind", FOREIGN_KINDS)
def test_foreign_kinds_extract_with_defaults(kind, tmp_path) -> None:
    # every kind starts bent (curled into a ring, tip next to its own body, ...) and straightens later
    ff = render_foreign_footage(kind, tmp_path / kind, n_frames=24, image_size=SIZE)
    assert not (tmp_path / f"{kind}.camera.json").exists() and len(list(ff.folder.glob("*.jpg"))) == 24
    ex, traj = extract(ff.folder, ff)
    diag = ex.diagnostics_[0]
    assert diag["frames_complete"] == 24 and diag["frames_repaired"] == []
    # started from a plain frame, not the curled frame 0, and tracked back to it
    assert diag["reference_frame"] > 0 and "straightest" in diag["reference_reason"]
    # the base is the clamped end, told by motion; the evidence is kept
    assert diag["base_marker"] == "stays put" and ex.base_evidence_[0] == diag["base_evidence"]
    moved = [float(v) for v in re.findall(r"moved at most ([\d.]+) px.*up to ([\d.]+) px", diag["base_evidence"])[0]]
    assert moved[0] < 1.0 < 50.0 < moved[1]
    err = np.linalg.norm(traj.poses[..., :2] - ff.poses[..., :2], axis=-1)
    # markers ~11 x 3 px here: the scale from the chain length of a frame that is not perfectly straight
    assert err[:, 0].max() < 2e-4 and np.sqrt(np.mean(err**2)) < 1.5e-3, err.max()
    np.testing.assert_allclose(traj.poses[..., 2], ff.poses[..., 2], atol=np.deg2rad(3.0))


def test_true_segment_count_from_fusion_with_defaults(tmp_path) -> None:
    ff = render_foreign_footage("self_approach", tmp_path / "sa", n_frames=40, image_size=(1000, 787))
    assert ff.n_segments == 2
    _, traj = extract(ff.folder, ff)
    assert KinematicFusion().fit([traj]).n_segments_ == 2


def test_fast_curl_is_not_tracked_off_by_one(tmp_path) -> None:
    # 40 frames for the whole motion: the tip moves by more than a marker spacing per frame while the robot
    # uncurls; tracking alone took the next marker for a lost one and filled the tip beyond the robot (20.6 mm
    # off in one frame before the spacing check)
    ff = render_foreign_footage("self_approach", tmp_path / "fast", n_frames=40, image_size=(1000, 787))
    ex, traj = extract(ff.folder, ff)
    err = np.linalg.norm(traj.poses[..., :2] - ff.poses[..., :2], axis=-1)
    assert err.max() < 1e-3, (np.unravel_index(err.argmax(), err.shape), err.max())
    assert ex.diagnostics_[0]["frames_complete"] == 40


def test_errors_name_the_frame_and_full_resolution_pixels(tmp_path) -> None:
    # large JPEG frames are decoded at half resolution; messages still quote the footage's pixels
    ff = render_foreign_footage("curled_start", tmp_path / "big", n_frames=12, image_size=(1800, 1416))
    base_px = ff.camera.to_pixels(np.zeros(2))
    # frame 3 loses its base marker (covered by a hand): the chain cannot start there
    path = ff.folder / "frame_000003.jpg"
    img = cv2.imread(str(path))
    u, v = np.round(base_px).astype(int)
    cv2.circle(img, (int(u), int(v)), 40, (255, 255, 255), -1)
    cv2.imwrite(str(path), img)
    with pytest.raises(ValueError, match=r"frame 3: .*the base position \[([\d.]+), ([\d.]+)\]") as info:
        extract(ff.folder, ff, on_missing="raise")
    quoted = np.array([float(x) for x in re.search(r"base position \[([\d.]+), ([\d.]+)\]", str(info.value)).groups()])
    assert np.linalg.norm(quoted - base_px) < 3.0, (quoted, base_px)
    ex, traj = extract(ff.folder, ff, on_missing="interpolate")
    assert "1/2 resolution" in ex.diagnostics_[0]["binarisation"]["decoding"]
    assert ex.diagnostics_[0]["frames_repaired"] == [3]


def test_given_reference_frame_and_base_position_still_rule(tmp_path) -> None:
    ff = render_foreign_footage("outlined_floor", tmp_path / "of", n_frames=16, image_size=SIZE)
    base_px = tuple(float(c) for c in ff.camera.to_pixels(np.zeros(2)))
    ex, traj = extract(ff.folder, ff, reference_frame=15, base_position=base_px)
    diag = ex.diagnostics_[0]
    assert diag["reference_frame"] == 15 and "given" in diag["reference_reason"]
    assert diag["base_marker"] == "given" and "base_position" in ex.base_evidence_[0]
    assert np.linalg.norm(traj.poses[..., :2] - ff.poses[..., :2], axis=-1).max() < 5e-3


def test_robot_that_does_not_move_is_ambiguous_and_says_why(tmp_path) -> None:
    poses, _ = foreign_poses("curled_start", 30)
    ff = render_foreign_footage("curled_start", tmp_path / "still", n_frames=30, image_size=SIZE)
    still = cv2.imread(str(ff.folder / "frame_000029.jpg"))
    for k in range(30):
        cv2.imwrite(str(ff.folder / f"frame_{k:06d}.jpg"), still)
    with pytest.raises(ValueError, match=r"both ends of the marker chain stay put .*moved at most .*base_position"):
        extract(ff.folder, ff)


def test_blank_frame_in_a_predicting_stream_names_the_frame(tmp_path) -> None:
    ff = render_foreign_footage("curled_start", tmp_path / "s", n_frames=60, image_size=SIZE)
    frames = [cv2.imread(str(ff.folder / f"frame_{k:06d}.jpg"), cv2.IMREAD_GRAYSCALE) for k in range(40, 46)]
    base_px = tuple(float(c) for c in ff.camera.to_pixels(np.zeros(2)))
    ex = MarkerPoseExtractor(robot_length=0.2, base_position=base_px, on_missing="predict", progress=False)
    stream = ex.stream(frames[0])
    for f in frames[1:4]:
        stream.update(f)
    blank = np.full_like(frames[4], 200)
    with pytest.raises(
        ValueError, match=r"stream, frame 4: found 0 marker-shaped components \(a blank frame\?\).*nothing in view"
    ):
        stream.update(blank)
    stream.update(frames[5])  # chained from the base again


def test_foreign_footage_arguments_are_checked(tmp_path) -> None:
    with pytest.raises(ValueError, match="kind must be one of"):
        render_foreign_footage("underwater", tmp_path / "x")
    with pytest.raises(ValueError, match="jpeg_quality must be an integer"):
        render_foreign_footage("curled_start", tmp_path / "x", jpeg_quality=0)
    with pytest.raises(ValueError, match="n_markers must be an integer >= 3"):
        foreign_poses("curled_start", 10, n_markers=2)


def test_backdrop_nuisance_is_checked_and_drawn() -> None:
    from pcs_sindy.simulation.nuisances import Nuisances
    from pcs_sindy.simulation.rendering import render_frames

    with pytest.raises(ValueError, match="backdrop must be None or a grey level"):
        Nuisances(backdrop=300.0)
    with pytest.raises(ValueError, match="backdrop_edge must lie in"):
        Nuisances(backdrop=250.0, backdrop_edge=1.5)
    poses, _ = foreign_poses("bright_edge", 2)
    img = render_frames(poses[:1], nuisances=Nuisances(backdrop=250.0, backdrop_edge=0.75), background=180)[0]
    assert img[5, 500] == 250 and img[5, 400] == 180  # right of 0.75 * 640 = 480 px: the lit backdrop
