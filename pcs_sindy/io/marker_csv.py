"""Marker CSV files of motion-capture systems: 3-D marker positions (and logged inputs) at a nominal rate.

:func:`read_marker_csv` reads the text exports of common systems without
conversion by hand, given the marker names in base-to-tip order:

* one header row naming each coordinate column, e.g. ``frame,u1,M1_X,M1_Y,M1_Z,...``
  (also ``M1 X``, ``M1:X``, ``M1.X``; what :meth:`MocapRecording.to_csv` writes);
* OptiTrack Motive CSV: metadata rows (``Length Units`` is read when present),
  then rows ``Type``, ``Name`` (the marker or rigid-body name repeated over its
  columns), ``ID``, ``Position``/``Rotation`` and ``Frame, Time (Seconds), X, Y, Z, ...``;
  rigid bodies give their ``Position`` columns;
* Vicon Nexus CSV: ``Trajectories``, the rate, a row of ``Subject:Marker`` names
  over every third column, ``Frame, Sub Frame, X, Y, Z, ...`` and a units row (``mm``);
* Qualisys QTM TSV: header lines (``MARKER_NAMES`` ...), then a row ``Frame  Time  M1 X  M1 Y  M1 Z ...``
  (tab-separated; the delimiter is detected);
* the axis letter before the marker name, e.g. ``ID,x1,y1,z1,x2,...,phi1`` (marker names ``"1"``, ``"2"``);
* no header at all (``markers=5``): a frame index, a time column, then x, y, z of every marker,
  unlabelled; the markers are the last ``3 * markers`` columns unless ``columns`` says where.

Orientations (``orientations=True``): rigid-body quaternions in columns named by component and marker,
e.g. ``qx1, qy1, qz1, w1`` (the scalar ``w``/``qw`` wherever it stands: the names say which is which) or
``M1_qx ... M1_qw``; they are converted here to rotation matrices (the package never carries quaternions).

Missing samples (empty cells, ``NaN``) are NaN.  A frame/sample index column,
when present, places each row: skipped indices become NaN rows.  Time stamps
are never read: samples are ``1 / rate`` apart (the nominal rate).

Inputs logged apart from the capture (a Motive export holds no input columns) are read by
:func:`read_input_log` (CSV/TSV, ``.npy`` or ``.npz``) and put on the capture's samples by
:func:`align_inputs`: row for row, or by a frame/index or time column of the log when it has one.
"""

from __future__ import annotations

import csv
import itertools
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.trajectory import PoseTrajectory
from .data_files import DataFileError, check_regular_file

__all__ = ["MarkerData", "read_marker_csv", "UNITS", "InputLog", "read_input_log", "align_inputs"]

#: length units accepted by read_marker_csv and their size in metres
UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "meters": 1.0, "millimeters": 1e-3, "centimeters": 1e-2}
_AXES = ("x", "y", "z")
_FRAME_NAMES = ("frame", "frame #", "frame number", "sample", "index", "sample index", "id")
_TIME_NAMES = ("t", "time", "t [s]", "time [s]", "t (s)", "time (s)", "time (seconds)", "t_s", "time_s", "timestamp")
#: a frame column may skip samples (NaN rows), up to this many samples per data row ...
_MAX_SAMPLES_PER_ROW = 10
#: ... plus this many: beyond, it is not the file's sample index (a 5-line file claiming 2e7 samples)
_MAX_EXTRA_SAMPLES = 100_000
# frame indices beyond this are not counts of samples (and lose integer precision as floats)
_MAX_FRAME_INDEX = 2.0**53
_HEAD_BYTES = 1 << 16  # read first: the encoding and the delimiter
_MAX_HEADER_ROWS = 10_000
_PEEK_ROWS = 50  # data rows read before the layout is fixed (an unnamed leading frame column)
_BLOCK_ROWS = 4096


@dataclass
class MarkerData:
    """Marker positions and inputs read from a capture file.

    Attributes
    ----------
    positions : ndarray, shape (T, N, 3)
        Marker positions [m] in the capture frame, base to tip; NaN = missing.
    inputs : ndarray, shape (T, p) or None
        The input columns asked for.
    dt : float
        Sample period [s] (1 / rate).
    markers : list of str
    units : str
        Units the file was in.
    source : str
    rotations : ndarray, shape (T, N, 3, 3) or None
        The markers' (rigid bodies') orientations in the capture frame when read
        (``orientations=True``); NaN where missing.
    """

    positions: NDArray[np.float64]
    inputs: NDArray[np.float64] | None
    dt: float
    markers: list[str]
    units: str
    source: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)
    rotations: NDArray[np.float64] | None = None

    @property
    def t(self) -> NDArray[np.float64]:
        return np.arange(self.positions.shape[0]) * self.dt

    def trajectory(self, **kwargs: Any) -> PoseTrajectory:
        """``PoseTrajectory.from_positions(positions, dt=dt, rotations=rotations, **kwargs)``."""
        if self.rotations is not None:
            kwargs.setdefault("rotations", self.rotations)
        meta = {"source": self.source, "markers": list(self.markers)}
        return PoseTrajectory.from_positions(self.positions, dt=self.dt, metadata=meta, **kwargs)


def _norm(cell: str) -> str:
    return cell.strip().strip('"').strip().lower()


def _name_matches(cell: str, name: str) -> bool:
    """``Subject:M1`` and ``M1`` both name marker ``M1``."""
    c = _norm(cell)
    n = name.lower()
    return c == n or c.endswith(":" + n)


def _split_name_axis(cell: str) -> tuple[str, str] | None:
    """``('m1', 'x')`` from ``M1_X``, ``M1 X``, ``M1:X``, ``M1.X``; None otherwise."""
    m = re.fullmatch(r"(.+?)[\s_:.\-]+([xyz])", _norm(cell))
    return (m.group(1), m.group(2)) if m else None


def _split_axis_name(cell: str) -> tuple[str, str] | None:
    """``('1', 'x')`` from ``x1``, ``X_1``, ``x.disk1`` (the axis letter first); None otherwise."""
    m = re.fullmatch(r"([xyz])[\s_:.\-]*(.+)", _norm(cell))
    return (m.group(2), m.group(1)) if m else None


def _number(cell: str) -> float:
    c = cell.strip()
    if c == "" or c.lower() in ("nan", "na", "null", "-"):
        return np.nan
    return float(c)


def _numeric_row(row: list[str]) -> bool:
    cells = [c for c in row if c.strip() != ""]
    if not cells:
        return False
    try:
        [_number(c) for c in cells]
    except ValueError:
        return False
    return True


def _find_columns(header: list[list[str]], markers: Sequence[str]) -> tuple[dict[str, list[int]], int]:
    """Columns of every marker's X, Y, Z and the index of the row naming the axes."""
    # layout 1: one row with combined names, the name first (M1_X) or the axis first (x1)
    for split in (_split_name_axis, _split_axis_name):
        for r, row in enumerate(header):
            found: dict[str, list[int]] = {}
            for name in markers:
                cols = {}
                for j, cell in enumerate(row):
                    sa = split(cell)
                    if sa and (sa[0] == name.lower() or sa[0].endswith(":" + name.lower())):
                        cols.setdefault(sa[1], j)
                if len(cols) == 3:
                    found[name] = [cols[a] for a in _AXES]
            if len(found) == len(markers):
                return found, r
    # layout 2: a row of bare axes (X, Y, Z) under a row of names (Motive, Vicon), names forward-filled
    for r, row in enumerate(header):
        axes = [_norm(c) for c in row]
        if sum(a in _AXES for a in axes) < 3:
            continue
        for rn in range(r - 1, -1, -1):
            names = list(header[rn]) + [""] * max(0, len(row) - len(header[rn]))
            filled, last = [], ""
            for c in names:
                last = c if c.strip() else last
                filled.append(last)
            kind = next((header[k] for k in range(rn + 1, r) if any(_norm(c) == "position" for c in header[k])), None)
            found = {}
            for name in markers:
                cols = {}
                for j, a in enumerate(axes):
                    if a not in _AXES or not _name_matches(filled[j], name):
                        continue
                    if kind is not None and j < len(kind) and _norm(kind[j]) not in ("position", ""):
                        continue  # a rigid body's rotation columns
                    cols.setdefault(a, j)
                if len(cols) == 3:
                    found[name] = [cols[a] for a in _AXES]
            if len(found) == len(markers):
                return found, r
    raise ValueError(
        f"no X, Y, Z columns found for every marker of {list(markers)}; the header rows name "
        f"{sorted({c.strip() for row in header for c in row if c.strip()})[:40]}"
    )


def _detect_units(header: list[list[str]]) -> str | None:
    for row in header:
        cells = [_norm(c) for c in row]
        for k, c in enumerate(cells):
            if c in ("length units", "units") and k + 1 < len(cells) and cells[k + 1] in UNITS:
                return cells[k + 1]
        if cells and all(c in ("mm", "m", "") for c in cells) and any(cells):
            return next(c for c in cells if c)  # Vicon's units row
    return None


def _unnamed_columns(
    path: Path, first_row: list[str], n: int, columns: Sequence[int] | None
) -> tuple[dict[str, list[int]], list[str]]:
    """x, y, z columns of ``n`` unnamed markers (``m0``, ``m1``, ...) and empty column names."""
    width = len(first_row)
    if columns is None:
        if 3 * n > width:
            raise DataFileError(f"{path}: markers={n} needs {3 * n} columns; the data rows have {width}")
        starts = [width - 3 * n + 3 * k for k in range(n)]
    else:
        starts = [int(c) for c in columns]
        if len(starts) != n or any(c != int(c) for c in columns):
            raise DataFileError(f"{path}: columns must give the x column of each of the {n} markers; got {columns!r}")
        bad = [c for c in starts if not 0 <= c <= width - 3]
        if bad:
            raise DataFileError(f"{path}: columns {bad} leave no room for x, y, z in the {width} columns")
    return {f"m{k}": [c, c + 1, c + 2] for k, c in enumerate(starts)}, [""] * width


def _is_index_column(rows: list[list[str]], j: int) -> bool:
    try:
        v = np.array([float(r[j]) for r in rows[: min(len(rows), 50)] if r and r[j].strip()])
    except (ValueError, IndexError):
        return False
    return v.size > 1 and bool(np.all(v == np.round(v)) and np.all(np.diff(v) > 0))


def _check_text(path: Path, head: bytes) -> None:
    """Refuse a file that is not 8-bit text: UTF-16/32 (by its byte-order mark or NUL bytes) or binary."""
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise DataFileError(
            f"{path}: the file is UTF-16 (or UTF-32) text (byte-order mark {head[:2]!r}), not UTF-8: save it as "
            "UTF-8 (or ASCII) CSV (e.g. iconv -f UTF-16 -t UTF-8)"
        )
    if b"\x00" in head:
        nul = head.count(b"\x00")
        kind = "UTF-16 text without a byte-order mark" if 0.3 < nul / len(head) < 0.6 else "a binary file"
        raise DataFileError(
            f"{path}: {nul} of the first {len(head)} bytes are NUL: {kind}, not a text CSV; give the "
            "motion-capture system's CSV/TSV text export (UTF-8 or ASCII)"
        )


def _data_rows(reader: Any) -> Iterator[tuple[int, list[str]]]:
    """(line number, cells) of the rows that are not blank."""
    for row in reader:
        if any(c.strip() for c in row):
            yield reader.line_num, row


def _header_rows(path: Path, reader: Any) -> tuple[list[list[str]], Iterator[tuple[int, list[str]]]]:
    """The rows before the first data row, and the data rows from it on (an iterator).

    The first data row is the first numeric row with a few cells (a lone number, e.g. Vicon's rate, is header).
    """
    header: list[list[str]] = []
    for row in reader:
        if _numeric_row(row) and sum(c.strip() != "" for c in row) >= 3:
            return header, itertools.chain([(reader.line_num, row)], _data_rows(reader))
        header.append(row)
        if len(header) > _MAX_HEADER_ROWS:
            raise DataFileError(f"{path}: no numeric data rows in the first {_MAX_HEADER_ROWS} rows")
    raise DataFileError(f"{path}: no numeric data rows")


_QUATERNION_PARTS = {"qx": 0, "qy": 1, "qz": 2, "qw": 3, "w": 3}


def _quaternion_columns(header: list[list[str]], markers: Sequence[str]) -> dict[str, list[int]]:
    """Columns of every marker's quaternion (x, y, z, w order): ``qx1 ... w1`` or ``M1_qx ... M1_qw``."""
    for row in header:
        found: dict[str, list[int]] = {}
        for name in markers:
            n = name.lower()
            cols: dict[int, int] = {}
            for j, cell in enumerate(row):
                c = _norm(cell)
                for part, k in _QUATERNION_PARTS.items():
                    for pattern in (rf"{part}[\s_:.\-]*(.+)", rf"(.+?)[\s_:.\-]+{part}"):
                        m = re.fullmatch(pattern, c)
                        if m and (m.group(1) == n or m.group(1).endswith(":" + n)):
                            cols.setdefault(k, j)
            if len(cols) == 4:
                found[name] = [cols[k] for k in range(4)]
        if len(found) == len(markers):
            return found
    raise DataFileError(
        f"no quaternion columns (qx, qy, qz and w or qw) found for every marker of {list(markers)}; the header "
        f"rows name {sorted({c.strip() for row in header for c in row if c.strip()})[:40]}"
    )


def _rotations(quaternions: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4) in (x, y, z, w) order; NaN where not finite."""
    from scipy.spatial.transform import Rotation

    Q = np.asarray(quaternions, dtype=float)
    out = np.full(Q.shape[:-1] + (3, 3), np.nan)
    norm = np.linalg.norm(Q, axis=-1)
    ok = np.all(np.isfinite(Q), axis=-1) & (norm > 0.5) & (norm < 2.0)  # a zero or garbage quaternion is missing
    if np.any(ok):
        out[ok] = Rotation.from_quat(Q[ok]).as_matrix()  # scipy normalises; (x, y, z, w) is its order
    return out


def _layout(
    path: Path,
    header: list[list[str]],
    peek: list[tuple[int, list[str]]],
    markers: Sequence[str] | int,
    columns: Sequence[int] | None,
    inputs: Sequence[str | int] | None,
    frame_column: str | int | None,
    units: str | None,
    unnamed: bool,
) -> dict[str, Any]:
    """Where the markers, inputs and frame index are, and the units, from the header and the first data rows."""
    first_row = peek[0][1]
    if unnamed:
        cols, names = _unnamed_columns(path, first_row, int(markers), columns)  # type: ignore[arg-type]
        markers = list(cols)
        header_row: list[str] = header[-1] if header else []
    else:
        try:
            cols, axis_row = _find_columns(header, list(markers))  # type: ignore[arg-type]
        except ValueError as err:
            raise DataFileError(f"{path}: {err}") from None
        header_row = header[axis_row]
        names = [_norm(c) for c in header_row]
    unit = units.lower() if units is not None else _detect_units(header)
    if unit is None:
        raise DataFileError(f"{path}: the file does not say its length units; give units='mm' or units='m'")
    width_data = len(first_row)
    in_cols = []
    for name in inputs or []:
        if isinstance(name, (int, np.integer)) and not isinstance(name, bool):
            if not 0 <= name < width_data:
                raise DataFileError(f"{path}: input column {name!r} is not one of the {width_data} columns")
            in_cols.append(int(name))
            continue
        hits = [j for row in header for j, c in enumerate(row) if _norm(c) == str(name).lower()]
        if not hits:
            raise DataFileError(f"{path}: no input column named {name!r}; header cells: {header_row}")
        in_cols.append(hits[0])
    frame_col = None
    if frame_column == "auto":
        frame_col = next((j for j, c in enumerate(names) if c in _FRAME_NAMES), None)
        if frame_col is None and not header and _is_index_column([row for _, row in peek], 0):
            frame_col = 0  # a file without a header: a leading column of increasing integers is the frame
    elif isinstance(frame_column, (int, np.integer)) and not isinstance(frame_column, bool):
        if not 0 <= frame_column < width_data:
            raise DataFileError(f"{path}: frame_column {frame_column!r} is not one of the {width_data} columns")
        frame_col = int(frame_column)
    elif frame_column is not None:
        if frame_column.lower() not in names:
            raise DataFileError(f"{path}: no frame column {frame_column!r} in {header_row}")
        frame_col = names.index(frame_column.lower())
    width = max(max(c) for c in cols.values()) + 1
    frame_name = (
        None
        if frame_col is None
        else repr(header_row[frame_col].strip())
        if frame_col < len(header_row) and header_row[frame_col].strip()
        else f"(column {frame_col})"
    )
    return {
        "cols": cols,
        "markers": list(markers),  # type: ignore[arg-type]
        "in_cols": in_cols,
        "frame_col": frame_col,
        "frame_name": frame_name,
        "unit": unit,
        "width": max(width, max(in_cols, default=0) + 1, (frame_col or 0) + 1),
    }


def _parse_rows(path: Path, rows: Iterable[tuple[int, list[str]]], width: int) -> NDArray[np.float64]:
    """The first ``width`` cells of every data row as numbers (NaN for empty), parsed in blocks of rows.

    Rows become numbers as they are read (a list of strings per row costs ten times the array).
    """
    blocks: list[NDArray[np.float64]] = []
    block: list[list[float]] = []
    pad = [np.nan] * width
    for line, row in rows:
        try:
            vals = [float(c) for c in row]
        except ValueError:
            if not _numeric_row(row):
                raise DataFileError(f"{path}: row {line} is not numeric: {row[:8]}") from None
            vals = [_number(c) for c in row]
        block.append(vals[:width] if len(vals) >= width else vals + pad[len(vals) :])
        if len(block) == _BLOCK_ROWS:
            blocks.append(np.array(block, dtype=float))
            block = []
    if block or not blocks:
        blocks.append(np.array(block, dtype=float).reshape(-1, width))
    return blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=0)


def read_marker_csv(
    path: str | Path,
    markers: Sequence[str] | int,
    *,
    rate: float,
    units: str | None = None,
    inputs: Sequence[str | int] | None = None,
    frame_column: str | int | None = "auto",
    columns: Sequence[int] | None = None,
    orientations: bool = False,
) -> MarkerData:
    """Read marker positions (and input columns) from a motion-capture CSV/TSV export.

    Parameters
    ----------
    path : str or Path
    markers : sequence of str or int
        Marker (or rigid-body) names, ordered base to tip, the base not
        included, as the file names them (``Subject:`` prefixes are matched too;
        ``"1"`` matches ``x1, y1, z1``).  An int: the number of unnamed markers of a
        file without a header (or whose header does not name them), read from
        ``columns``; they are named ``"m0"``, ``"m1"``, ... in column order, which is
        the file's, not necessarily base to tip (see
        :func:`pcs_sindy.core.order_markers`).
    rate : float
        Nominal sample rate [Hz]; samples are ``1 / rate`` apart.
    units : {"m", "mm", "cm"}, optional
        Length units of the file; by default read from the file (Motive's
        ``Length Units``, Vicon's units row), else an error asks for them.
    inputs : sequence of str or int, optional
        Names (or 0-based positions) of columns holding the inputs (e.g. servo angles), in order.
    frame_column : str, int, "auto" or None
        Column of the sample index (name or 0-based position); ``"auto"`` looks for
        ``Frame``/``Sample``/``Index``/``ID`` and, in a file without a header, takes the
        first column when it holds increasing integers.
    columns : sequence of int, optional
        With ``markers`` an int: the 0-based column of each marker's x (its y and z
        follow).  Default: the last ``3 * markers`` columns.
    orientations : bool, default False
        Also read each marker's orientation quaternion (named columns, see the module docstring:
        ``qx1, qy1, qz1, w1`` for marker ``"1"``), returned as rotation matrices in
        :attr:`MarkerData.rotations`.

    Returns
    -------
    MarkerData

    Raises
    ------
    DataFileError
        Naming the file and what is missing or malformed.
    """
    path = Path(path)
    if not (isinstance(rate, (int, float)) and np.isfinite(rate) and rate > 0):
        raise DataFileError(f"{path}: rate must be a sample rate > 0 in Hz; got {rate!r}")
    unnamed = isinstance(markers, (int, np.integer)) and not isinstance(markers, bool)
    if unnamed:
        if markers < 1:
            raise DataFileError(f"{path}: markers must be a number of markers >= 1 or a list of names; got {markers!r}")
    elif isinstance(markers, str) or len(markers) < 1:
        raise DataFileError(f"{path}: markers must be a list of marker names, base to tip; got {markers!r}")
    if columns is not None and not unnamed:
        raise DataFileError(f"{path}: columns={columns!r} applies to unnamed markers only (markers=<int>)")
    if units is not None and units.lower() not in UNITS:
        raise DataFileError(f"{path}: units must be one of {sorted(set(UNITS))}; got {units!r}")
    check_regular_file(path, "marker CSV file")
    with open(path, "rb") as raw:
        head = raw.read(_HEAD_BYTES)
    _check_text(path, head)
    sample = head.decode("utf-8", errors="replace")
    delimiter = "\t" if sample.count("\t") > sample.count(",") else ","
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            reader = csv.reader(f, delimiter=delimiter)
            header, rows = _header_rows(path, reader)
            first_data = len(header)
            peek = list(itertools.islice(rows, _PEEK_ROWS))  # the first data rows: columns and the frame index
            layout = _layout(path, header, peek, markers, columns, inputs, frame_column, units, unnamed)
            width = layout["width"]
            if orientations:
                if unnamed:
                    raise DataFileError(
                        f"{path}: orientations=True needs named markers (their quaternion columns are found by name)"
                    )
                try:
                    q_cols = _quaternion_columns(header, list(markers))
                except DataFileError as err:
                    raise DataFileError(f"{path}: {err}") from None
                width = max(width, max(max(c) for c in q_cols.values()) + 1)
            values = _parse_rows(path, itertools.chain(peek, rows), width)
    except UnicodeDecodeError as err:
        raise DataFileError(
            f"{path}: not UTF-8 text ({err.reason}, byte {err.object[err.start : err.start + 1]!r}): save the file "
            "as UTF-8 (or ASCII) CSV"
        ) from None
    cols, markers, in_cols, frame_col, unit = (
        layout["cols"],
        layout["markers"],
        layout["in_cols"],
        layout["frame_col"],
        layout["unit"],
    )
    scale = UNITS[unit]
    pos = np.stack([values[:, cols[name]] for name in markers], axis=1) * scale
    u = values[:, in_cols] if in_cols else None
    quat = np.stack([values[:, q_cols[name]] for name in markers], axis=1) if orientations else None
    meta: dict[str, Any] = {}
    if frame_col is not None:
        frame = values[:, frame_col]
        column = layout["frame_name"]
        bad = np.flatnonzero(~np.isfinite(frame) | (frame != np.round(frame)) | (np.abs(frame) > _MAX_FRAME_INDEX))
        if bad.size:
            k = int(bad[0])
            raise DataFileError(
                f"{path}: the frame column {column} holds {float(frame[k]):.6g} in data row {k + 1}: not a whole "
                f"sample index (at most {_MAX_FRAME_INDEX:.0e}); fix the column or read with frame_column=None"
            )
        idx = (frame - frame[0]).astype(np.int64)
        if np.any(np.diff(idx) <= 0):
            k = int(np.argmax(np.diff(idx) <= 0))
            raise DataFileError(f"{path}: frame indices must increase; row {first_data + k + 2} repeats or goes back")
        n_samples = int(idx[-1]) + 1
        limit = _MAX_SAMPLES_PER_ROW * idx.size + _MAX_EXTRA_SAMPLES
        if n_samples > limit:
            k = int(np.argmax(np.diff(idx)))  # the largest jump (two rows at least: idx[-1] > 0)
            raise DataFileError(
                f"{path}: the frame column {column} runs from {int(frame[0])} to {int(frame[-1])} (it jumps from "
                f"{int(frame[k])} to {int(frame[k + 1])} after data row {k + 1}): "
                f"{n_samples} samples for {idx.size} rows, more than {limit} (the rows times "
                f"{_MAX_SAMPLES_PER_ROW}, plus {_MAX_EXTRA_SAMPLES}); the column is not this file's sample index: "
                "fix it or read with frame_column=None"
            )
        if n_samples != idx.size:  # skipped samples: NaN rows at their places
            full = np.full((n_samples,) + pos.shape[1:], np.nan)
            full[idx] = pos
            pos = full
            if quat is not None:
                qf = np.full((n_samples,) + quat.shape[1:], np.nan)
                qf[idx] = quat
                quat = qf
            if u is not None:
                uf = np.full((n_samples, u.shape[1]), np.nan)
                uf[idx] = u
                # inputs are held: a skipped sample keeps the last logged input
                ok = np.isfinite(uf[:, 0])
                last = np.maximum.accumulate(np.where(ok, np.arange(ok.size), 0))
                u = uf[last]
            meta["skipped_samples"] = int(n_samples - idx.size)
        meta["first_frame"] = int(frame[0])
    if u is not None and not np.all(np.isfinite(u)):
        raise DataFileError(f"{path}: input columns {list(inputs or [])} have empty or NaN cells")
    rot = None if quat is None else _rotations(quat)
    return MarkerData(pos, u, 1.0 / float(rate), list(markers), unit, str(path), meta, rot)


@dataclass
class InputLog:
    """Inputs logged apart from a capture: one row per logged sample.

    Attributes
    ----------
    inputs : ndarray, shape (K, p)
    names : list of str
        The input columns' names (``u0``, ``u1``, ... when the file names none).
    index : ndarray, shape (K,), or None
        Frame (sample) numbers of the rows, when the log has such a column.
    t : ndarray, shape (K,), or None
        Time stamps [s] of the rows, when the log has a time column (and no index column).
    source : str
    """

    inputs: NDArray[np.float64]
    names: list[str]
    index: NDArray[np.int64] | None = None
    t: NDArray[np.float64] | None = None
    source: str = ""


def _pick_columns(path: Path, names: list[str], columns: Sequence[str | int] | None, skip: set[int]) -> list[int]:
    """Positions of the input columns: those asked for (names or 0-based positions), else all but ``skip``."""
    if columns is None:
        return [j for j in range(len(names)) if j not in skip]
    out = []
    for c in columns:
        if isinstance(c, (int, np.integer)) and not isinstance(c, bool):
            j = int(c)
        elif str(c).lower() in names:
            j = names.index(str(c).lower())
        elif str(c).isdigit():
            j = int(c)
        else:
            raise DataFileError(f"{path}: no input column named {c!r}; the log's columns are {names}")
        if not 0 <= j < len(names):
            raise DataFileError(f"{path}: input column {c!r} is not one of the {len(names)} columns")
        out.append(j)
    return out


def read_input_log(path: str | Path, columns: Sequence[str | int] | None = None) -> InputLog:
    """Read an input log: a CSV/TSV (a header row optional), an ``.npy`` array or an ``.npz``.

    A CSV column named like a frame index (``Frame``, ``Index``, ``ID``, ``Sample``) becomes
    :attr:`InputLog.index`, one named like a time (``t``, ``time``, ``Time (s)``, ``timestamp``)
    :attr:`InputLog.t` [s]; every other column is an input unless ``columns`` chooses.  An ``.npz``
    holds ``u`` (K, p) and optionally ``index`` (or ``frame``) and ``t``; an ``.npy`` is the inputs
    alone, (K,) or (K, p).

    Parameters
    ----------
    path : str or Path
    columns : sequence of str or int, optional
        The input columns (CSV: names or 0-based positions; ``.npy``/``.npz``: positions), in order.

    Returns
    -------
    InputLog

    Raises
    ------
    DataFileError
        Naming the file and what is wrong with it.
    """
    path = Path(path)
    if not path.is_file():
        raise DataFileError(f"input log {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    index = t = None
    if suffix in (".npy", ".npz"):
        try:
            data = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as err:
            raise DataFileError(f"cannot read input log {str(path)!r}: {err}") from None
        if isinstance(data, np.ndarray):
            u = data
        else:
            with data:
                if "u" not in data.files:
                    raise DataFileError(f"input log {str(path)!r} lacks 'u' (the inputs; found {sorted(data.files)})")
                u = data["u"]
                key = next((k for k in ("index", "frame") if k in data.files), None)
                index = None if key is None else np.asarray(data[key])
                t = np.asarray(data["t"]) if "t" in data.files and index is None else None
        u = np.asarray(u, dtype=float)
        u = u[:, None] if u.ndim == 1 else u
        if u.ndim != 2 or u.shape[0] < 1:
            raise DataFileError(f"input log {str(path)!r}: the inputs must have shape (K,) or (K, p); got {u.shape}")
        names = [f"u{k}" for k in range(u.shape[1])]
        picked = _pick_columns(path, names, columns, set())
        u, names = u[:, picked], [names[j] for j in picked]
    else:
        text = path.read_text(encoding="utf-8-sig")
        delimiter = "\t" if text.count("\t") > text.count(",") else ","
        rows = [r for r in csv.reader(text.splitlines(), delimiter=delimiter) if any(c.strip() for c in r)]
        if not rows:
            raise DataFileError(f"input log {str(path)!r} is empty")
        header = not _numeric_row(rows[0])
        names = [_norm(c) for c in rows[0]] if header else [f"u{k}" for k in range(len(rows[0]))]
        body = rows[1:] if header else rows
        if not body:
            raise DataFileError(f"input log {str(path)!r} has a header but no data rows")
        values = np.full((len(body), len(names)), np.nan)
        for k, row in enumerate(body):
            try:
                vals = [_number(c) for c in row[: len(names)]]
            except ValueError:
                raise DataFileError(
                    f"input log {str(path)!r}: row {k + 1 + header} is not numeric: {row[:8]}"
                ) from None
            values[k, : len(vals)] = vals
        frame_col = next((j for j, c in enumerate(names) if header and c in _FRAME_NAMES), None)
        time_col = next((j for j, c in enumerate(names) if header and c in _TIME_NAMES), None)
        picked = _pick_columns(path, names, columns, {j for j in (frame_col, time_col) if j is not None})
        if not picked:
            raise DataFileError(f"input log {str(path)!r} has no input column besides the index/time ({names})")
        u = values[:, picked]
        names = [names[j] if header else f"u{j}" for j in picked]
        if frame_col is not None:
            index = values[:, frame_col]
        elif time_col is not None:
            t = values[:, time_col]
    if index is not None:
        index = np.asarray(index, dtype=float)
        if index.shape != (u.shape[0],) or not np.all(np.isfinite(index)) or np.any(index != np.round(index)):
            raise DataFileError(f"input log {str(path)!r}: the frame/index column must hold one integer per row")
        index = index.astype(np.int64)
        if np.any(np.diff(index) <= 0):
            raise DataFileError(f"input log {str(path)!r}: the frame/index column must increase row by row")
    if t is not None:
        t = np.asarray(t, dtype=float)
        if t.shape != (u.shape[0],) or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise DataFileError(f"input log {str(path)!r}: the time column must hold increasing finite times [s]")
    if not np.all(np.isfinite(u)):
        k = int(np.argwhere(~np.isfinite(u))[0, 0])
        raise DataFileError(f"input log {str(path)!r}: the inputs have an empty or NaN cell (row {k + 1} of the data)")
    return InputLog(u, names, index, t, str(path))


def align_inputs(
    log: InputLog, n_samples: int, dt: float, first_frame: int | None = None, capture: str = ""
) -> NDArray:
    """The logged inputs on the capture's ``n_samples`` samples (``dt`` apart), shape (n_samples, p).

    * With a frame/index column: the capture's sample k is frame ``first_frame + k`` (the capture's
      own frame numbers; without them the log's index counts from its first row); each sample takes
      the last input logged at or before its frame (inputs are held).
    * With a time column [s]: the log and the capture start together (the log's first time is the
      capture's first sample); each sample takes the last input logged at or before its time.
    * Otherwise row k is sample k: the counts must be equal.

    Raises
    ------
    DataFileError
        When the counts differ (row pairing), or the log starts after the capture or ends more
        than one logging interval before it.
    """
    src = log.source or "the input log"
    if log.index is None and log.t is None:
        if log.inputs.shape[0] != n_samples:
            raise DataFileError(
                f"input log {src!r} has {log.inputs.shape[0]} rows but the capture {capture!r} has {n_samples} "
                "samples; rows pair with samples one to one, or by a frame/index column (Frame, Index, ID, Sample) "
                "or a time column (t, time [s]) in the log"
            )
        return log.inputs.copy()
    if log.index is not None:
        start = int(first_frame) if first_frame is not None else int(log.index[0])
        where, at = (log.index - start).astype(float), np.arange(n_samples, dtype=float)
        unit, what = 1.0, "frame"
    else:
        start, where, at = 0, log.t - log.t[0], np.arange(n_samples) * float(dt)
        unit, what = float(dt), "time"
    if where[0] > 1e-9 * unit:
        raise DataFileError(
            f"input log {src!r} starts at {what} {where[0] + start:g}, after the capture's first sample "
            f"({what} {start:g}): the capture's first inputs are not logged"
        )
    step = float(np.median(np.diff(where))) if where.size > 1 else unit
    if at[-1] > where[-1] + step + 1e-9 * unit:
        raise DataFileError(
            f"input log {src!r} ends {at[-1] - where[-1]:g} {'frames' if what == 'frame' else 's'} before the "
            f"capture {capture!r} does: its last inputs are not logged"
        )
    k = np.searchsorted(where, at + 1e-9 * unit, side="right") - 1
    return log.inputs[k]
