"""Distortion round trip: a robot filmed through a wide-angle lens, calibrated from rendered checkerboards.

A pinhole camera (fx = 900, fy = 905 px, k1 = -0.28, k2 = 0.11, small
tangential terms, k3 = -0.02: about 9 px of distortion in the image corners)
looks at the robot's plane tilted by ~5° from 0.45 m (~2000 px/m).
``pcs_sindy.vision.calibration.calibrate_camera`` gets N views of a 9x6 board
(12 mm squares) at random positions and tilts, plus one view lying in the
robot's plane (anywhere in it); then the two_segment robot (20 markers,
8 x 2 mm) is rendered through the true lens and extracted with the
calibrated camera.  Errors in pixels of the true plane scale over all
markers and frames; "base frame given": the calibrated camera with the
robot's true base frame (isolates the lens and plane calibration), "found in
the footage": the base marker and rest direction found by the extractor (as
after ``pcs-sindy calibrate``), "no lens model": calibrated from the straight
reference frame and the robot's length as before, ignoring the lens.

Run: ``.venv/bin/python benchmarks/calibration_round_trip.py``
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_calibration import DIST, PATTERN, PLANE_R, PLANE_T, SIZE, SQUARE, K, board_views  # noqa: E402

from pcs_sindy.core import Camera  # noqa: E402
from pcs_sindy.simulation import get_scenario  # noqa: E402
from pcs_sindy.simulation.rendering import render_frames  # noqa: E402
from pcs_sindy.vision import (
    MarkerPoseExtractor,  # noqa: E402
    calibrate_camera,  # noqa: E402
)

from _results import write_section  # noqa: E402


def main() -> None:
    true = Camera.from_pinhole(K, DIST, PLANE_R, PLANE_T, SIZE)
    data = get_scenario("two_segment").generate(seed=0, validation=False)
    truth = data.train[0].poses_true[::5][:100]  # 100 frames spread over 0.5 s
    truth = np.concatenate([_straight(truth), truth])
    frames = render_frames(truth, true, marker_size=(0.008, 0.002))
    rows = []
    for n_views, seed in ((6, 0), (10, 0), (20, 1)):
        cal, report = calibrate_camera(board_views(n_views, seed), PATTERN, SQUARE)
        origin = cal.rectify(true.to_pixels(np.zeros(2)))
        down = cal.rectify(true.to_pixels(np.array([0.0, 0.01]))) - origin
        given = cal.with_base(tuple(origin), float(np.arctan2(down[1], down[0]) - np.pi / 2))
        errs = []
        for kw in (dict(camera=given), dict(camera=cal), dict(camera=None, robot_length=0.17)):
            traj = MarkerPoseExtractor(fps=200.0, progress=False, **kw).transform([frames])[0]
            e = np.linalg.norm(traj.poses[..., :2] - truth[..., :2], axis=-1) * true.pixels_per_metre
            errs.append(f"{np.sqrt(np.mean(e**2)):.3f} / {e.max():.3f}")
        fx_err = 100 * (cal.camera_matrix[0][0] / K[0, 0] - 1)
        rows.append(
            f"| {n_views} + 1 | {report['rms_reprojection_px']:.3f} | {fx_err:+.2f} | " + " | ".join(errs) + " |"
        )
        print(rows[-1], flush=True)
    body = "\n".join(
        [
            __doc__.split("Run:")[0].split("\n\n", 1)[1].strip(),
            "",
            f"{truth.shape[0]} frames (the first straight), true plane scale {true.pixels_per_metre:.0f} px/m.",
            "",
            "| board views (+ plane view) | board reprojection rms "
            "[px] | fx error [%] | marker error rms / max [px], base "
            "frame given | ..., base frame found in the footage | ..., no lens model |",
            "|---|---|---|---|---|---|",
            *rows,
            "",
            "Target (issue 13): marker error after calibration <= 0.1 px rms on rendered distorted frames.",
        ]
    )
    write_section(
        "calibration_round_trip",
        "Lens calibration round trip",
        body,
        ".venv/bin/python benchmarks/calibration_round_trip.py",
    )


def _straight(truth: np.ndarray) -> np.ndarray:
    """The robot at rest (a straight reference frame for the calibration without a lens model)."""
    out = np.zeros_like(truth[:1])
    out[0, :, 1] = np.linspace(0.0, 0.17, truth.shape[1])
    return out


if __name__ == "__main__":
    main()
