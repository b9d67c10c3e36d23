"""Footage of the kinds another lab records: curled first frames, outlined markers, floors, bright edges.

A new user's first recording rarely looks like the package's own renderings:
the robot may start curled into a ring and straighten later, markers may be
outlines rather than filled rectangles, the robot may swing across a grey
floor or the edge of a brightly lit backdrop, and the frames come as large
JPEG files in a folder.  :func:`render_foreign_footage` writes such
recordings (through :func:`pcs_sindy.simulation.rendering.render_frames` and
:class:`~pcs_sindy.simulation.nuisances.Nuisances`) together with their
true poses, so that extraction with only the frame rate, the marker count
and the robot length given can be measured against the truth.

Kinds (:data:`FOREIGN_KINDS`):

``"curled_start"``
    One segment whose first frame is curled into a ring (tip next to the
    base), straightening over the first third, then swinging.
``"self_approach"``
    Two segments, the second bent more tightly, so that in the first frames
    the tip comes back next to the robot's own body; straightens later.
``"outlined_floor"``
    One segment with outlined markers on colour frames, starting curled and
    swinging down across a grey floor.
``"bright_edge"``
    One segment curled the other way in the first frame, swinging across the
    edge of a brightly lit backdrop, with uneven light and noise.

No camera JSON is written: such footage comes without one.  Knows only
kinematics (the poses are constant-strain segments), not dynamics.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from ..core.camera import Camera
from ..core.kinematics import forward_kinematics
from ..core.optional import require
from .nuisances import Nuisances
from .rendering import render_frames

cv2 = require("cv2", "rendering foreign footage (pcs_sindy.simulation.foreign)")

__all__ = ["FOREIGN_KINDS", "ForeignFootage", "foreign_poses", "render_foreign_footage"]

FOREIGN_KINDS = ("curled_start", "self_approach", "outlined_floor", "bright_edge")

# bending (rad, total over each segment) in the first frame, per kind
_FIRST_BEND = {
    "curled_start": (1.85 * np.pi,),
    "self_approach": (0.8 * np.pi, 1.3 * np.pi),
    "outlined_floor": (1.6 * np.pi,),
    "bright_edge": (-1.8 * np.pi,),
}


class ForeignFootage(NamedTuple):
    """What :func:`render_foreign_footage` wrote and the truth behind it."""

    folder: Path
    """Folder of ``frame_000000.jpg``, ... (no camera JSON)."""
    poses: NDArray[np.float64]
    """True poses (T, N + 1, 3) of the base and the markers, metres/radians in the base frame."""
    camera: Camera
    """The camera the frames were drawn with (for the truth in pixels; not written)."""
    fps: float
    robot_length: float
    n_markers: int
    n_segments: int
    kind: str


def foreign_poses(
    kind: str, n_frames: int = 300, n_markers: int = 10, robot_length: float = 0.2, seed: int = 0
) -> tuple[NDArray[np.float64], int]:
    """True marker poses (T, N + 1, 3) of a footage kind and its segment count.

    Each segment's bending decays from the kind's first-frame value
    (:data:`_FIRST_BEND`) with a time constant of a fifth of the recording
    while a swing of about +-1.2 rad (per unit length) grows in, with the
    phase and frequency drawn from ``seed`` (two segments swing in
    opposition, at different frequencies); a small axial stretch
    oscillates too.  Markers are equally spaced in rest arc length.
    """
    if kind not in FOREIGN_KINDS:
        raise ValueError(f"kind must be one of {FOREIGN_KINDS}; got {kind!r}")
    for name, value, low in (("n_frames", n_frames, 2), ("n_markers", n_markers, 3)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}; got {value!r}")
    if not np.isscalar(robot_length) or not np.isfinite(robot_length) or robot_length <= 0:
        raise ValueError(f"robot_length must be a finite number > 0; got {robot_length!r}")
    rng = np.random.default_rng([seed, FOREIGN_KINDS.index(kind)])
    first = np.asarray(_FIRST_BEND[kind])
    m = first.size
    lengths = np.full(m, robot_length / m)
    t = np.linspace(0.0, 1.0, n_frames)[:, None]
    freq = rng.uniform(2.0, 3.0, m)
    phase = rng.uniform(0.0, 2 * np.pi) + np.pi * np.arange(m)  # segments swing against each other
    grow = 1.0 - np.exp(-t / 0.15)
    bend = first * np.exp(-t / 0.2) + 1.2 * grow * np.sin(2 * np.pi * freq * t + phase) * (1 + 0.8 * np.arange(m))
    q = np.zeros((n_frames, 3 * m))
    q[:, 0::3] = bend / lengths
    q[:, 2::3] = 0.005 * np.sin(2 * np.pi * 1.5 * t + rng.uniform(0, 2 * np.pi))
    s = np.linspace(0.0, robot_length, n_markers + 1)
    return forward_kinematics(q, lengths, s), m


def _nuisances(kind: str, camera: Camera, poses: NDArray[np.float64], seed: int) -> Nuisances:
    if kind in ("curled_start", "self_approach"):
        return Nuisances(lighting_gradient=0.3, gradient_angle=0.8, vignetting=0.2, noise=3.0, seed=seed)
    lowest = camera.to_pixels(poses[..., :2])[..., 1].max(axis=1)
    if kind == "outlined_floor":
        # the floor's top where the robot's lowest marker is in 60 % of the frames: it crosses it again and again
        level = float(np.percentile(lowest, 40)) / camera.image_size[1]
        return Nuisances(
            lighting_gradient=0.35,
            gradient_angle=-0.4,
            vignetting=0.25,
            noise=3.0,
            floor=150.0,
            floor_level=level,
            seed=seed,
        )
    # bright_edge: the backdrop's edge through the middle of the robot's sweep
    u = camera.to_pixels(poses[..., :2])[..., 0]
    edge = float(np.percentile(u, 55)) / camera.image_size[0]
    return Nuisances(
        lighting_gradient=0.4,
        gradient_angle=2.5,
        vignetting=0.3,
        noise=4.0,
        backdrop=255.0,
        backdrop_edge=edge,
        seed=seed,
    )


def render_foreign_footage(
    kind: str,
    path: str | os.PathLike,
    *,
    n_frames: int = 300,
    image_size: tuple[int, int] = (3000, 2360),
    n_markers: int = 10,
    robot_length: float = 0.2,
    fps: float = 100.0,
    jpeg_quality: int = 90,
    seed: int = 0,
    progress: bool = False,
) -> ForeignFootage:
    """Write a recording of a foreign kind as JPEG frames in a folder (no camera JSON) and return its truth.

    Parameters
    ----------
    kind : str
        One of :data:`FOREIGN_KINDS` (see the module docstring).
    path : path
        Folder to create; receives ``frame_000000.jpg``, ...
    n_frames : int
        Frames (300-500 for a benchmark, a few for a test).
    image_size : (width, height)
        Frame size in pixels; the robot fills the frame (:meth:`Camera.fit_robot`).
    n_markers : int
        Markers besides the base.
    robot_length : float
        Rest length in metres (markers 8 % and 2 % of it wide and thick).
    fps : float
        Frame rate the recording is meant to have (returned, not written anywhere).
    jpeg_quality : int
        JPEG quality of the files (1-100).
    seed : int
        Motion, noise and clutter draws.
    progress : bool
        tqdm bar over frames.

    Returns
    -------
    ForeignFootage
    """
    if not np.isscalar(fps) or not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a finite number > 0; got {fps!r}")
    if (
        isinstance(jpeg_quality, bool)
        or not isinstance(jpeg_quality, (int, np.integer))
        or not 1 <= jpeg_quality <= 100
    ):
        raise ValueError(f"jpeg_quality must be an integer in [1, 100]; got {jpeg_quality!r}")
    poses, n_segments = foreign_poses(kind, n_frames, n_markers, robot_length, seed)
    camera = Camera.fit_robot(robot_length, image_size)
    nz = _nuisances(kind, camera, poses, seed)
    style = dict(marker_size=(0.08 * robot_length, 0.02 * robot_length), body_width=0.03 * robot_length)
    if kind == "outlined_floor":
        style.update(
            marker_style="outline",
            colour=True,
            marker_colour=(60, 30, 20),
            body_colour=(205, 210, 220),
            background=(235, 240, 240),
        )
    elif kind == "bright_edge":
        style.update(background=200, marker_colour=30, body_colour=160)
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OSError(f"cannot create path={str(folder)!r}: {err}") from err
    chunk = 25
    with tqdm(total=n_frames, desc=f"render {kind}", unit="frame", disable=not progress) as bar:
        for start in range(0, n_frames, chunk):
            frames = render_frames(poses[start : start + chunk], camera, nuisances=nz, first_frame=start, **style)
            for j, frame in enumerate(frames):
                name = folder / f"frame_{start + j:06d}.jpg"
                if not cv2.imwrite(str(name), frame, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)]):
                    raise OSError(f"cannot write frame {start + j} to {str(name)!r}")
            bar.update(len(frames))
    return ForeignFootage(folder, poses, camera, float(fps), float(robot_length), n_markers, n_segments, kind)
