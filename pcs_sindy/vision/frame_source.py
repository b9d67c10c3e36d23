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
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import scipy.sparse
from numpy.typing import NDArray

__all__ = [
    "FrameSource",
    "check_recordings",
    "describe",
    "read_frames",
    "group_image_files",
    "image_size",
    "check_frame_size",
    "IMAGE_SUFFIXES",
    "MAX_FRAME_PIXELS",
]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: Frames larger than this many pixels are refused before they are decoded (a 240 KB PNG can
#: hold a 10000 x 10000 white image, 100 Mpx and 0.3 GB per decoded copy); 64 Mpx is 8000 x 8000,
#: more than any camera that films a robot.
MAX_FRAME_PIXELS = 64_000_000
_REDUCED = {1: cv2.IMREAD_GRAYSCALE, 2: cv2.IMREAD_REDUCED_GRAYSCALE_2, 4: cv2.IMREAD_REDUCED_GRAYSCALE_4}


def _natural_key(path: Path) -> list[Any]:
    return [int(tok) if tok.isdigit() else tok for tok in re.split(r"(\d+)", path.name)]


def describe(recording: Any, index: int) -> str:
    """The name used in messages: the path, or ``array recording <index>``."""
    if isinstance(recording, (str, os.PathLike)):
        return str(recording)
    return f"array recording {index}"


def _jpeg_size(head: bytes) -> tuple[int, int] | None:
    k = 2
    while k + 9 < len(head):
        if head[k] != 0xFF:
            return None
        marker = head[k + 1]
        if marker == 0xFF:  # fill byte
            k += 1
            continue
        length = int.from_bytes(head[k + 2 : k + 4], "big")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # a start of frame
            return int.from_bytes(head[k + 7 : k + 9], "big"), int.from_bytes(head[k + 5 : k + 7], "big")
        k += 2 + length
    return None


def image_size(path: str | os.PathLike) -> tuple[int, int] | None:
    """Width and height from an image file's header, without decoding it (None: not known from the header).

    Reads PNG, JPEG and BMP headers; other formats give None.
    """
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    if head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) >= 24:
        return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
    if head[:2] == b"\xff\xd8":
        return _jpeg_size(head)
    if head[:2] == b"BM" and len(head) >= 26:
        return abs(int.from_bytes(head[18:22], "little", signed=True)), abs(
            int.from_bytes(head[22:26], "little", signed=True)
        )
    return None


def check_frame_size(width: int, height: int, what: str) -> None:
    """Refuse a frame of more than :data:`MAX_FRAME_PIXELS` pixels, naming ``what`` and its size."""
    if width * height > MAX_FRAME_PIXELS:
        raise ValueError(
            f"{what} is {width} x {height} pixels ({width * height / 1e6:.0f} Mpx); frames of at most "
            f"{MAX_FRAME_PIXELS / 1e6:.0f} Mpx are read: downscale the footage"
        )


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
        #: frames the container lists (videos; None for folders and arrays) and frames decoded by frames()
        self.n_listed: int | None = None
        self.n_decoded: int | None = None
        #: frames missing from a numbered frame folder (a number skipped in the sequence), by index
        self.gaps: list[int] = []
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
                slots = _numbered_slots(files)
                self._files = files if slots is None else slots  # type: ignore[assignment]
                self.n_frames = len(self._files)
                self.gaps = [k for k, f in enumerate(self._files) if f is None]
                self.jpeg = all(f.suffix.lower() in (".jpg", ".jpeg") for f in files)
                return
            cap = cv2.VideoCapture(str(path))
            try:
                if not cap.isOpened():
                    raise OSError(f"recording {name!r}: OpenCV cannot open it as a video")
                check_frame_size(
                    int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)), f"video {name!r}"
                )
                ok, first = cap.read()
                if not ok or first is None:
                    raise OSError(f"recording {name!r}: OpenCV opened it but could not decode frame 0")
                fps = float(cap.get(cv2.CAP_PROP_FPS))
                self.fps = fps if np.isfinite(fps) and fps > 0 else None
                listed = float(cap.get(cv2.CAP_PROP_FRAME_COUNT))
                self.n_listed = int(listed) if np.isfinite(listed) and listed >= 1 else None
                self.n_frames = self.n_listed or 1
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
        if self._files[k] is None:
            before = next((f.name for f in reversed(self._files[:k]) if f is not None), None)
            raise OSError(
                f"recording {self.name!r}, frame {k}: no image file (the numbered sequence skips it, after {before!r})"
            )
        size = image_size(self._files[k])
        if size is not None:
            check_frame_size(*size, f"recording {self.name!r}, frame {k} ({str(self._files[k])!r})")
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
    def frames(self, grey: bool = False, reduce: int = 1, *, damaged: str = "raise") -> Iterator[Any]:
        """Every frame in order, grey (2-D) or as stored; ``reduce`` as in :meth:`frame`.

        ``damaged``: a frame that cannot be decoded (a video frame whose data is corrupt, an unreadable
        image file) raises ``OSError`` naming it (``"raise"``) or is yielded as None (``"none"``) so
        that the frames after it keep their index, hence their time.  After the last frame,
        :attr:`n_decoded` is the number of frames yielded (None included).
        """
        self._check_reduce(reduce, grey)
        if damaged not in ("raise", "none"):
            raise ValueError(f"damaged must be 'raise' or 'none'; got {damaged!r}")
        self.n_decoded = 0
        if self._array is not None:
            for k, f in enumerate(self._array):
                self.n_decoded += 1
                yield _grey(f, self.name, k) if grey else _colour(f)
        elif self._files is not None:
            for k in range(self.n_frames):
                try:
                    img = self._read_file(k, grey, reduce)
                except OSError:
                    if damaged == "raise":
                        raise
                    self.n_decoded += 1
                    yield None
                    continue
                self.n_decoded += 1
                yield _grey(img, self.name, k) if grey else _colour(img)
        else:
            for img in self._video_frames(grey, reduce, damaged):
                self.n_decoded += 1
                yield img

    def _video_frames(self, grey: bool, reduce: int = 1, damaged: str = "raise") -> Iterator[Any]:
        cap = cv2.VideoCapture(str(self._video))
        # Motion-JPEG: decode each frame's JPEG packet ourselves (straight to grey when asked): a corrupt
        # packet is then one known frame, where the demuxer's own decoder would skip it silently
        packets = self._mjpeg and cap.set(cv2.CAP_PROP_FORMAT, -1)
        flag = _REDUCED[reduce] if grey else cv2.IMREAD_UNCHANGED
        try:
            k = 0
            while True:
                ok, f = cap.read()
                if not ok or f is None:
                    break
                if packets:
                    img = cv2.imdecode(f.reshape(-1), flag) if f.size else None
                    if img is None:
                        if damaged == "raise":
                            raise OSError(f"recording {self.name!r}, frame {k}: cannot decode its JPEG data")
                        yield None
                    else:
                        yield _grey(img, self.name, k) if grey else _colour(img)
                else:
                    yield _grey(f, self.name, k) if grey else _colour(f)
                k += 1
        finally:
            cap.release()

    def check_count(self, expected: int | None = None, source: str = "", *, allow: bool = False) -> str | None:
        """Compare the frames :meth:`frames` decoded with those the container and ``expected`` list.

        Parameters
        ----------
        expected : int, optional
            Frames the recording should have (a camera JSON's ``n_frames``).
        source : str
            What says ``expected`` (for the message), e.g. ``"camera JSON 'clip.avi.camera.json'"``.
        allow : bool
            A shortfall warns (the decoded frames keep their time stamps, from the first frame)
            instead of raising.

        Returns
        -------
        str or None
            The warning given, or None when the counts agree.

        Raises
        ------
        ValueError
            Fewer (or more) frames decoded than listed, unless ``allow``: the message names every count.
        """
        if self.n_decoded is None:
            raise RuntimeError("check_count() comes after frames() has run to the end")
        claims = []
        if self.n_listed is not None:
            claims.append(("the container", self.n_listed))
        if expected is not None:
            claims.append((source or "expected", int(expected)))
        wrong = [(who, n) for who, n in claims if n != self.n_decoded]
        if not wrong:
            return None
        said = " and ".join(f"{who} says {n}" for who, n in wrong)
        message = f"recording {self.name!r}: decoded {self.n_decoded} frames but {said}"
        if not allow:
            hint = (
                "the file is truncated or damaged (re-copy it), or the camera JSON belongs to another recording; "
                "on_missing='interpolate' (--on-missing interpolate) keeps the frames decoded"
            )
            raise ValueError(f"{message}: {hint}")
        message += "; the frames decoded are kept with their time stamps from the first frame"
        warnings.warn(message, UserWarning, stacklevel=2)
        return message


def _numbered_slots(files: list[Path]) -> list[Path | None] | None:
    """Files of a numbered sequence in their frame slots, None where a number is skipped.

    Applies when every name is one pattern with one varying number (``frame_0001.png`` ...): the
    numbers step by their greatest common difference (``0, 10, 20`` steps by 10), and a skipped
    number is a missing frame, so the frames after it keep their time.  Returns None for names that
    are not such a sequence, or when nothing is skipped.
    """
    if len(files) < 3:
        return None
    parts = [re.fullmatch(r"(.*?)(\d+)(\D*)", f.name) for f in files]
    if any(m is None for m in parts) or len({(m.group(1), m.group(3)) for m in parts}) != 1:  # type: ignore[union-attr]
        return None
    numbers = [int(m.group(2)) for m in parts]  # type: ignore[union-attr]
    diffs = np.diff(numbers)
    if np.any(diffs <= 0):
        return None  # repeated numbers: not one sequence
    step = int(np.gcd.reduce(diffs))
    span = (numbers[-1] - numbers[0]) // step + 1
    if span == len(files) or span > 2 * len(files):  # nothing skipped, or too sparse to be frames lost
        return None
    slots: list[Path | None] = [None] * span
    for number, f in zip(numbers, files):
        slots[(number - numbers[0]) // step] = f
    return slots


def group_image_files(paths: Any) -> list[Any]:
    """Recordings from command-line paths: single image files refused (they are frames, not recordings).

    A shell glob such as ``frames/*.jpg`` gives one path per frame; each would be a one-frame
    recording.  A recording made of image files is their folder.

    Parameters
    ----------
    paths : sequence of path
        Videos, folders of images, or image files.

    Returns
    -------
    list
        ``paths`` unchanged when none is an image file.

    Raises
    ------
    ValueError
        When any is an image file: the message names the folder(s) to give instead.
    """
    images = [Path(p) for p in paths if Path(p).suffix.lower() in IMAGE_SUFFIXES and not Path(p).is_dir()]
    if not images:
        return list(paths)
    folders = sorted({str(p.parent) for p in images})
    shown = ", ".join(repr(f) for f in folders[:3]) + (" ..." if len(folders) > 3 else "")
    raise ValueError(
        f"{len(images)} image file(s) given (e.g. {str(images[0])!r}): a recording of image frames is "
        f"their folder, one recording per folder; give the folder instead: {shown}"
    )


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
