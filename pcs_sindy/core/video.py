"""Which video formats this OpenCV build writes, and which of them a web browser plays.

Holds the table of video suffixes and their FourCC codes (:data:`VIDEO_CODECS`), a probe that
writes a tiny file with a codec and reads it back (:func:`codec_works`, once per process), the
codec chosen for a suffix (:func:`video_codec`) and the browser-playable format of this build
(:func:`browser_video_format`).  pip's OpenCV wheels ship FFmpeg without an H.264 encoder
(licensing), so ``avc1`` usually fails and VP8 in WebM is what a browser gets; the probe says.

Knows nothing of the package; imports OpenCV only when a probe runs.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["VIDEO_CODECS", "BROWSER_FORMATS", "codec_works", "video_codec", "browser_video_format", "open_video_writer"]

#: FourCC codes per suffix, in order of preference: ``.mp4`` is H.264 (``avc1``, browser-playable) when
#: the build has an encoder for it, else MPEG-4 Part 2 (``mp4v``, which browsers often refuse)
VIDEO_CODECS: dict[str, tuple[str, ...]] = {".avi": ("MJPG",), ".mp4": ("avc1", "mp4v"), ".webm": ("VP80",)}

#: (suffix, FourCC) pairs web browsers play, in order of preference; ``.gif`` (no FourCC) needs no encoder
BROWSER_FORMATS: tuple[tuple[str, str | None], ...] = ((".mp4", "avc1"), (".webm", "VP80"), (".gif", None))

_PROBE_FRAMES = 3
_PROBE_SIZE = (64, 48)  # width, height: even, as every codec wants


@contextlib.contextmanager
def _stderr_silenced() -> Iterator[None]:
    """Standard error (the file descriptor) to /dev/null: FFmpeg logs a failed encoder from C."""
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):  # no real descriptor (an IDE's stream): leave it
        yield
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


@functools.cache
def codec_works(suffix: str, fourcc: str) -> bool:
    """Whether OpenCV writes a ``suffix`` file with codec ``fourcc`` that reads back frame for frame.

    Writes :data:`_PROBE_FRAMES` small frames to a temporary file and counts the frames read back
    (an encoder that opens but writes nothing, as some builds do, fails too).  Cached per process.

    Parameters
    ----------
    suffix : str
        Container, e.g. ``".mp4"``.
    fourcc : str
        Four-character code, e.g. ``"avc1"``.

    Returns
    -------
    bool
    """
    import cv2
    import numpy as np

    if len(fourcc) != 4:
        raise ValueError(f"fourcc must be a four-character code such as 'mp4v'; got {fourcc!r}")
    width, height = _PROBE_SIZE
    with tempfile.TemporaryDirectory() as tmp, _stderr_silenced():
        path = str(Path(tmp) / f"probe{suffix}")
        writer = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*fourcc), 10.0, (width, height))
        if not writer.isOpened():
            return False
        for k in range(_PROBE_FRAMES):
            writer.write(np.full((height, width, 3), 60 * k, dtype=np.uint8))
        writer.release()
        capture = cv2.VideoCapture(path)
        n = 0
        while capture.read()[0]:
            n += 1
        capture.release()
    return n == _PROBE_FRAMES


def video_codec(suffix: str) -> str:
    """The FourCC OpenCV writes a ``suffix`` video with: the first of :data:`VIDEO_CODECS` that works.

    Raises
    ------
    ValueError
        If the suffix is not one of :data:`VIDEO_CODECS`.
    OSError
        If this OpenCV build writes none of its codecs.
    """
    key = suffix.lower()
    if key not in VIDEO_CODECS:
        raise ValueError(f"video suffix must be one of {sorted(VIDEO_CODECS)}; got {suffix!r}")
    for fourcc in VIDEO_CODECS[key]:
        if codec_works(key, fourcc):
            return fourcc
    raise OSError(f"this OpenCV build writes no {key} video (tried codecs {', '.join(VIDEO_CODECS[key])})")


def open_video_writer(path: str | os.PathLike, fourcc: str, fps: float, size: tuple[int, int], colour: bool = True):
    """An opened ``cv2.VideoWriter``, opened without FFmpeg's notes on standard error.

    FFmpeg says ``tag 'VP80' is not supported with codec id 139 and format 'webm'`` (it stores the
    codec by its id instead: the file is fine) when a WebM writer opens; a command's output has no
    use for it.

    Raises
    ------
    OSError
        If OpenCV cannot open the writer, naming the path and the codec.
    """
    import cv2

    with _stderr_silenced():
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), float(fps), tuple(size), colour)
    if not writer.isOpened():
        raise OSError(f"OpenCV cannot open a {fourcc} video writer for {str(path)!r}")
    return writer


def browser_video_format(gif: bool = True) -> str:
    """The suffix of the first browser-playable format of :data:`BROWSER_FORMATS` this build writes.

    ``".mp4"`` (H.264) when OpenCV has an H.264 encoder, else ``".webm"`` (VP8), else ``".gif"``
    (written without OpenCV; with ``gif=False`` an ``OSError`` instead).

    Parameters
    ----------
    gif : bool
        Whether GIF is an acceptable answer (the caller can write one).

    Returns
    -------
    str
    """
    for suffix, fourcc in BROWSER_FORMATS:
        if fourcc is None:
            if gif:
                return suffix
            continue
        if codec_works(suffix, fourcc):
            return suffix
    raise OSError("this OpenCV build writes no browser-playable video (neither H.264 in .mp4 nor VP8 in .webm)")
