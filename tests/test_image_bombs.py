"""Images that would decode to huge frames are refused from their header, before decoding (issue 27, item 6).

Truth: PNG, JPEG and BMP headers written by OpenCV for small images, then patched to claim a
10000 x 10000 frame (the content after the header is never decoded).
"""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest

from pcs_sindy.cli.main import main
from pcs_sindy.vision.frame_source import MAX_FRAME_PIXELS, FrameSource, image_size


def _patched_png(path, width, height):
    data = bytearray(cv2.imencode(".png", np.full((8, 6), 255, np.uint8))[1].tobytes())
    data[16:20] = width.to_bytes(4, "big")
    data[20:24] = height.to_bytes(4, "big")
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".bmp"])
def test_header_sizes_match_what_opencv_decodes(tmp_path, suffix):
    img = np.zeros((37, 53), np.uint8)
    path = tmp_path / f"a{suffix}"
    assert cv2.imwrite(str(path), img)
    assert image_size(path) == (53, 37)


def test_a_huge_png_in_a_folder_is_refused_before_decoding(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(2):
        _patched_png(folder / f"frame_{k:03d}.png", 10000, 10000)
    src = FrameSource(str(folder), "frames")
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"frame 0 .* is 10000 x 10000 pixels \(100 Mpx\)"):
        src.frame(0, grey=True)
    assert time.perf_counter() - start < 1.0


def test_inspect_refuses_a_huge_image_in_one_line(tmp_path, capsys):
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(2):
        _patched_png(folder / f"frame_{k:03d}.png", 10000, 10000)
    assert main(["inspect", str(folder), "--out", str(tmp_path / "s.png"), "--n-markers", "3"]) == 2
    err = capsys.readouterr().err
    assert "10000 x 10000" in err and str(MAX_FRAME_PIXELS // 10**6) in err
    assert not (tmp_path / "s.png").exists()


def test_frames_at_the_bound_are_read(tmp_path):
    path = tmp_path / "ok.png"
    assert cv2.imwrite(str(path), np.zeros((600, 800), np.uint8))
    assert FrameSource(str(tmp_path), "ok").frame(0, grey=True).shape == (600, 800)
