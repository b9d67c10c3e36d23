"""What an ``.npz`` archive claims before any of it is read: array shapes checked against the bytes.

An ``.npy`` header states a shape; ``numpy.load`` allocates that shape before reading, so a
240-byte file whose header claims 10^13 elements exhausts memory.  :func:`check_npz_headers`
reads only the headers and refuses an archive whose arrays claim more bytes than their members
hold, or more than a bound.  Knows nothing of what the arrays mean (the readers in
:mod:`pcs_sindy.io` do).
"""

from __future__ import annotations

import math
import zipfile

import numpy as np

__all__ = ["check_npz_headers", "MAX_NPZ_ARRAY_BYTES"]

#: No array read from a file may claim more than this (16 GiB: far beyond any recording this
#: package reads, well below what would take a machine down with it).
MAX_NPZ_ARRAY_BYTES = 16 * 2**30


def _claimed_bytes(member: zipfile.ZipExtFile) -> tuple[tuple[int, ...], np.dtype, int]:
    version = np.lib.format.read_magic(member)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(member)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(member)
    else:  # (3, 0) has the 2.0 layout with a utf-8 header
        shape, _, dtype = np.lib.format._read_array_header(member, version)  # noqa: SLF001
    return shape, dtype, math.prod(shape) * dtype.itemsize


def check_npz_headers(npz: np.lib.npyio.NpzFile, what: str, *, limit: int = MAX_NPZ_ARRAY_BYTES) -> None:
    """Refuse an archive whose arrays claim more data than they hold (or than ``limit`` bytes).

    Parameters
    ----------
    npz : numpy.lib.npyio.NpzFile
        An open archive (``numpy.load`` of an ``.npz``); nothing of its arrays is loaded.
    what : str
        The file, named in the error (e.g. ``"pose file 'a.npz'"``).
    limit : int
        Bytes one array may claim at most.

    Raises
    ------
    ValueError
        Naming the array, the shape its header claims and what the member holds.
    """
    for info in npz.zip.infolist():
        if not info.filename.endswith(".npy"):
            continue
        name = info.filename[:-4]
        try:
            with npz.zip.open(info) as member:
                shape, dtype, claimed = _claimed_bytes(member)
                header_end = member.tell()
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as err:
            raise ValueError(f"{what}: array {name!r} has an unreadable header: {err}") from None
        if dtype.hasobject:
            continue  # refused later by allow_pickle=False, with numpy's own message
        held = info.file_size - header_end
        if claimed > limit:
            raise ValueError(f"{what}: array {name!r} claims shape {shape} ({claimed} bytes; at most {limit})")
        if claimed > held:
            raise ValueError(
                f"{what}: array {name!r} claims shape {shape} ({claimed} bytes) but holds {held} bytes: "
                "the file is damaged or not what it says"
            )
