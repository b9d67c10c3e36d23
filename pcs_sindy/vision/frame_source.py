"""Frames of a recording: a video file, a folder of images, or an array in memory.

:class:`FrameSource` gives the number of frames, the frame rate when the file
knows it, random access to single frames (the reference frame is checked
before anything else is decoded) and a sequential iterator.  Frames are read
as grey images when the extractor needs no colour: Motion-JPEG videos are
then decoded from their JPEG packets straight to grey (no colour conversion,
roughly twice as fast), image files with ``IMREAD_GRAYSCALE``; JPEG data can
also be decoded at 1/2 or 1/4 of the resolution (the decoder skips the fine
DCT coefficients, several times faster), for frames whose markers are large.

Knows nothing of markers or dynamics.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import scipy.sparse
from numpy.typing import NDArray

__all__ = ["FrameSource", "check_recordings", "describe", "read_frames", "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
_REDUCED = {1: cv2.IMREAD_GRAYSCALE, 2: cv2.IMREAD_REDUCED_GRAYSCALE_2, 4: cv2.IMREAD_REDUCED_GRAYSCALE_4}


def _natural_key(path: Path) -> list[Any]:
    return [int(tok) if tok.isdigit() else tok for tok in re.split(r"(\d+)", path.name)]


def describe(recording: Any, index: int) -> str:
    """The name used in messages: the path, or ``array recording <index>``."""
    if isinstance(recording, (str, os.PathLike)):
        return str(recording)
    return f"array recording {index}"


def _grey(frame: NDArray[np.uint8], name: str, k: int) -> NDArray[np.uint8]:
    if frame.ndim == 2:
        return frame
    if frame.ndim == 3 and frame.shape[2] == 3:
        return cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    if frame.ndim == 3 and frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2GRAY)
    raise ValueError(f"recording {name!r}, frame {k}: unsupported image shape {frame.shape}")


def _colour(frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
    if frame.ndim == 3 and frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR)
    return frame


class FrameSource:
    """One recording's frames.

    Parameters
    ----------
    recording : path, folder or array
        A video file, a folder of image files (natural sort order) or a
        uint8 array of frames (T, H, W) / (T, H, W, 3).
    name : str
        Used in error messages.
    """

    def __init__(self, recording: Any, name: str) -> None:
        self.name = name
        self.fps: float | None = None
        self._array: NDArray[np.uint8] | None = None
        self._files: list[Path] | None = None
        self._video: Path | None = None
        self._mjpeg = False
        self.jpeg = False  # every frame is JPEG data (Motion-JPEG, .jpg files): reduced decoding works
        if isinstance(recording, (str, os.PathLike)):
            path = Path(recording)
            if not path.exists():
                raise FileNotFoundError(f"recording {name!r}: no such file or folder")
            if path.is_dir():
                files = sorted((p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key)
                if not files:
                    raise ValueError(
                        f"recording {name!r}: the folder holds no image files ({', '.join(IMAGE_SUFFIXES)})"
                    )
                self._files = files
                self.n_frames = len(files)
                self.jpeg = all(f.suffix.lower() in (".jpg", ".jpeg") for f in files)
                return
            cap = cv2.VideoCapture(str(path))
            try:
                if not cap.isOpened():
                    raise OSError(f"recording {name!r}: OpenCV cannot open it as a video")
                ok, first = cap.read()
                if not ok or first is None:
                    raise OSError(f"recording {name!r}: OpenCV opened it but could not decode frame 0")
                fps = float(cap.get(cv2.CAP_PROP_FPS))
                self.fps = fps if np.isfinite(fps) and fps > 0 else None
                self.n_frames = max(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)), 1)
                fourcc = int(cap.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").decode("latin-1")
                self._mjpeg = self.jpeg = fourcc.upper() in ("MJPG", "JPEG")
            finally:
                cap.release()
            self._video = path
            return
        arr = np.asarray(recording)
        if arr.ndim not in (3, 4) or (arr.ndim == 4 and arr.shape[-1] not in (3, 4)) or arr.shape[0] < 1:
            raise ValueError(
                f"recording {name!r}: an array of frames must have shape (T, H, W) or (T, H, W, 3); got {arr.shape}"
            )
        if arr.dtype != np.uint8:
            raise ValueError(f"recording {name!r}: frames must be uint8 images; got dtype {arr.dtype}")
        self._array = arr
        self.n_frames = arr.shape[0]

    # -- single frames -------------------------------------------------------
    def _read_file(self, k: int, grey: bool, reduce: int = 1) -> NDArray[np.uint8]:
        assert self._files is not None
        img = cv2.imread(str(self._files[k]), _REDUCED[reduce] if grey else cv2.IMREAD_UNCHANGED)
        if img is None:
            raise OSError(f"recording {self.name!r}, frame {k}: cannot read image {str(self._files[k])!r}")
        if img.dtype != np.uint8:
            raise ValueError(f"recording {self.name!r}, frame {k}: images must be 8-bit; got dtype {img.dtype}")
        return img

    def frame(self, k: int, grey: bool = False, reduce: int = 1) -> NDArray[np.uint8]:
        """Frame ``k`` (random access; for videos a seek, exact for intra-coded video).

        ``reduce`` (1, 2 or 4, JPEG data and grey only) divides the resolution.
        """
        self._check_reduce(reduce, grey)
        if not 0 <= k < self.n_frames:
            raise ValueError(
                f"recording {self.name!r}: frame {k} does not exist (the recording has {self.n_frames} frames)"
            )
        if self._array is not None:
            f = self._array[k]
        elif self._files is not None:
            f = self._read_file(k, grey, reduce)
        else:
            cap = cv2.VideoCapture(str(self._video))
            try:
                packets = reduce > 1 and cap.set(cv2.CAP_PROP_FORMAT, -1)
                if k:
                    cap.set(cv2.CAP_PROP_POS_FRAMES, k)
                ok, f = cap.read()
            finally:
                cap.release()
            if not ok or f is None:
                raise OSError(f"recording {self.name!r}, frame {k}: cannot decode it")
            if packets:
                f = cv2.imdecode(f.reshape(-1), _REDUCED[reduce])
        return _grey(f, self.name, k) if grey else _colour(f)

    def _check_reduce(self, reduce: int, grey: bool) -> None:
        if reduce not in _REDUCED or (reduce > 1 and not (grey and self.jpeg)):
            raise ValueError(f"recording {self.name!r}: reduce={reduce!r} needs grey JPEG data and 1, 2 or 4")

    # -- all frames ------------------------------------------------------------
    def frames(self, grey: bool = False, reduce: int = 1) -> Iterator[NDArray[np.uint8]]:
        """Every frame in order, grey (2-D) or as stored; ``reduce`` as in :meth:`frame`."""
        self._check_reduce(reduce, grey)
        if self._array is not None:
            for k, f in enumerate(self._array):
                yield _grey(f, self.name, k) if grey else _colour(f)
        elif self._files is not None:
            for k in range(self.n_frames):
                img = self._read_file(k, grey, reduce)
                yield _grey(img, self.name, k) if grey else _colour(img)
        else:
            yield from self._video_frames(grey, reduce)

    def _video_frames(self, grey: bool, reduce: int = 1) -> Iterator[NDArray[np.uint8]]:
        cap = cv2.VideoCapture(str(self._video))
        # Motion-JPEG: decode each frame's JPEG packet directly to grey
        packets = grey and self._mjpeg and cap.set(cv2.CAP_PROP_FORMAT, -1)
        try:
            k = 0
            while True:
                ok, f = cap.read()
                if not ok or f is None:
                    break
                if packets:
                    img = cv2.imdecode(f.reshape(-1), _REDUCED[reduce])
                    if img is None:
                        raise OSError(f"recording {self.name!r}, frame {k}: cannot decode its JPEG data")
                    yield img
                else:
                    yield _grey(f, self.name, k) if grey else _colour(f)
                k += 1
        finally:
            cap.release()


def check_recordings(X: Any, name: str = "X") -> list[Any]:
    """The recordings of ``X`` as a list, checked without reading a frame."""
    if scipy.sparse.issparse(X):
        raise ValueError(
            f"{name}: sparse input is not supported; give videos (paths, image folders or uint8 frame arrays)"
        )
    if isinstance(X, (str, os.PathLike, np.ndarray)):
        X = [X]
    if not isinstance(X, (list, tuple)) or len(X) == 0:
        raise ValueError(f"{name} must be a non-empty list of recordings; got {type(X).__name__}")
    for k, rec in enumerate(X):
        if isinstance(rec, (str, os.PathLike)):
            continue
        if not isinstance(rec, np.ndarray):
            raise ValueError(
                f"{name}[{k}] must be a video path, an image folder or a uint8 array of frames; "
                f"got {type(rec).__name__}"
            )
        if rec.ndim not in (3, 4) or (rec.ndim == 4 and rec.shape[-1] not in (3, 4)) or 0 in rec.shape:
            raise ValueError(
                f"{name}[{k}]: an array of frames must have shape (T, H, W) or (T, H, W, 3); got {rec.shape}"
            )
        if rec.dtype != np.uint8:
            raise ValueError(f"{name}[{k}]: frames must be uint8 images; got dtype {rec.dtype}")
    return list(X)


def read_frames(recording: Any) -> NDArray[np.uint8]:
    """All frames of a recording (video path, image folder or array) as one array."""
    return np.stack(list(FrameSource(recording, describe(recording, 0)).frames()))
