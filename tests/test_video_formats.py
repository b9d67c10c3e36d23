"""Video formats (issue 28): which codecs this OpenCV build writes, the browser-playable choice, and
that the probe and the writers say nothing on standard error.

Truth: the files each writer leaves, read back by OpenCV (frame count, size) or Pillow (GIF).
"""

from __future__ import annotations

import subprocess
import sys

import cv2
import numpy as np
import pytest

from pcs_sindy.core.video import BROWSER_FORMATS, VIDEO_CODECS, browser_video_format, codec_works, video_codec


def _count_frames(path) -> int:
    cap = cv2.VideoCapture(str(path))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    return n


def test_motion_jpeg_works_and_a_made_up_codec_does_not():
    assert codec_works(".avi", "MJPG")
    assert not codec_works(".avi", "ZZZZ")
    with pytest.raises(ValueError, match="four-character"):
        codec_works(".avi", "MJPEG")


def test_the_codec_of_each_suffix_writes_files_that_read_back(tmp_path):
    for suffix in VIDEO_CODECS:
        fourcc = video_codec(suffix)
        assert fourcc in VIDEO_CODECS[suffix]
        path = str(tmp_path / f"v{suffix}")
        writer = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*fourcc), 10.0, (64, 48))
        assert writer.isOpened(), (suffix, fourcc)
        for k in range(7):
            writer.write(np.full((48, 64, 3), 30 * k, dtype=np.uint8))
        writer.release()
        assert _count_frames(path) == 7, (suffix, fourcc)
    with pytest.raises(ValueError, match="suffix"):
        video_codec(".mkv")


def test_browser_format_is_the_first_that_works():
    suffix = browser_video_format()
    works = [s for s, fourcc in BROWSER_FORMATS if fourcc is None or codec_works(s, fourcc)]
    assert suffix == works[0]
    if suffix == ".gif":
        with pytest.raises(OSError, match="browser"):
            browser_video_format(gif=False)
    else:
        assert browser_video_format(gif=False) == suffix


def test_probing_prints_nothing_on_stderr():
    """FFmpeg reports a missing H.264 encoder on file descriptor 2; the probe keeps it quiet."""
    code = (
        "from pcs_sindy.core.video import codec_works, browser_video_format; "
        "print(codec_works('.mp4', 'avc1'), codec_works('.mp4', 'H264'), browser_video_format())"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert proc.stdout.split()[-1] in {s for s, _ in BROWSER_FORMATS}


def test_render_browser_format_reads_back(tmp_path):
    from pcs_sindy.cli.commands import render
    from pcs_sindy.io import write_poses

    T = 6
    poses = np.zeros((T, 3, 3))
    poses[:, 1, 1], poses[:, 2, 1] = 0.05, 0.1
    poses[:, 2, 0] = np.linspace(0.0, 0.01, T)
    write_poses(tmp_path / "p.npz", np.arange(T) * 0.04, poses)
    (video,) = render([tmp_path / "p.npz"], tmp_path / "v", video_format="browser", size=(96, 64), quiet=True)
    assert video.suffix == browser_video_format(gif=False)
    assert _count_frames(video) == T


def test_writing_webm_says_nothing_on_stderr(tmp_path):
    """FFmpeg notes that WebM stores VP8 by codec id when a writer opens; the writers keep it off stderr."""
    code = (
        "import numpy as np; from pcs_sindy.plotting import animate_rollout; "
        "from pcs_sindy.simulation import render_video; "
        "xy = np.zeros((4, 5, 2)); xy[..., 1] = np.linspace(0, 0.1, 5); t = np.arange(4) * 0.05; "
        f"animate_rollout({str(tmp_path / 'a.webm')!r}, t, xy, xy, fps=20, size=(64, 64), dpi=20, progress=False); "
        "poses = np.zeros((4, 3, 3)); poses[:, 1, 1], poses[:, 2, 1] = 0.05, 0.1; "
        f"render_video(poses, {str(tmp_path / 'r.webm')!r}, fps=20)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert _count_frames(tmp_path / "a.webm") == 4 and _count_frames(tmp_path / "r.webm") == 4
