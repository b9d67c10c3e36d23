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
"""

from __future__ import annotations

import csv
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.trajectory import PoseTrajectory
from .data_files import DataFileError

__all__ = ["MarkerData", "read_marker_csv", "UNITS"]

#: length units accepted by read_marker_csv and their size in metres
UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "meters": 1.0, "millimeters": 1e-3, "centimeters": 1e-2}
_AXES = ("x", "y", "z")
_FRAME_NAMES = ("frame", "frame #", "frame number", "sample", "index", "sample index", "id")


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
        meta = {"source": self.source, "markers": list(self.markers)}
        if self.rotations is not None:
            kwargs.setdefault("rotations", self.rotations)
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
    raise ValueError(
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
    if orientations and unnamed:
        raise DataFileError(f"{path}: orientations=True needs named markers (their quaternion columns are found by name)")
    if units is not None and units.lower() not in UNITS:
        raise DataFileError(f"{path}: units must be one of {sorted(set(UNITS))}; got {units!r}")
    text = path.read_text(encoding="utf-8-sig")
    delimiter = "\t" if text.count("\t") > text.count(",") else ","
    rows = list(csv.reader(text.splitlines(), delimiter=delimiter))
    # the first numeric row with a few cells (a lone number, e.g. Vicon's rate, is header)
    first_data = next(
        (k for k, row in enumerate(rows) if _numeric_row(row) and sum(c.strip() != "" for c in row) >= 3), None
    )
    if first_data is None:
        raise DataFileError(f"{path}: no numeric data rows")
    if unnamed:
        cols, names = _unnamed_columns(path, rows[first_data], int(markers), columns)
        markers = list(cols)
        header_row: list[str] = rows[first_data - 1] if first_data else []
    else:
        try:
            cols, axis_row = _find_columns(rows[:first_data], list(markers))
        except ValueError as err:
            raise DataFileError(f"{path}: {err}") from None
        header_row = rows[axis_row]
        names = [_norm(c) for c in header_row]
        if orientations:
            try:
                q_cols = _quaternion_columns(rows[:first_data], list(markers))
            except ValueError as err:
                raise DataFileError(f"{path}: {err}") from None
    unit = units.lower() if units is not None else _detect_units(rows[:first_data])
    if unit is None:
        raise DataFileError(f"{path}: the file does not say its length units; give units='mm' or units='m'")
    width_data = len(rows[first_data])
    in_cols = []
    for name in inputs or []:
        if isinstance(name, (int, np.integer)) and not isinstance(name, bool):
            if not 0 <= name < width_data:
                raise DataFileError(f"{path}: input column {name!r} is not one of the {width_data} columns")
            in_cols.append(int(name))
            continue
        hits = [j for row in rows[:first_data] for j, c in enumerate(row) if _norm(c) == str(name).lower()]
        if not hits:
            raise DataFileError(f"{path}: no input column named {name!r}; header cells: {header_row}")
        in_cols.append(hits[0])
    frame_col = None
    if frame_column == "auto":
        frame_col = next((j for j, c in enumerate(names) if c in _FRAME_NAMES), None)
        if frame_col is None and first_data == 0 and _is_index_column(rows, 0):
            frame_col = 0  # a file without a header: a leading column of increasing integers is the frame
    elif isinstance(frame_column, (int, np.integer)) and not isinstance(frame_column, bool):
        if not 0 <= frame_column < width_data:
            raise DataFileError(f"{path}: frame_column {frame_column!r} is not one of the {width_data} columns")
        frame_col = int(frame_column)
    elif frame_column is not None:
        if frame_column.lower() not in names:
            raise DataFileError(f"{path}: no frame column {frame_column!r} in {header_row}")
        frame_col = names.index(frame_column.lower())
    data = [row for row in rows[first_data:] if any(c.strip() for c in row)]
    width = max(max(c) for c in cols.values()) + 1
    if orientations:
        width = max(width, max(max(c) for c in q_cols.values()) + 1)
    values = np.full((len(data), max(width, max(in_cols, default=0) + 1, (frame_col or 0) + 1)), np.nan)
    for k, row in enumerate(data):
        if not _numeric_row(row):
            raise DataFileError(f"{path}: row {first_data + k + 1} is not numeric: {row[:8]}")
        vals = [_number(c) for c in row]
        values[k, : len(vals)] = vals[: values.shape[1]]
    scale = UNITS[unit]
    pos = np.stack([values[:, cols[name]] for name in markers], axis=1) * scale
    u = values[:, in_cols] if in_cols else None
    quat = np.stack([values[:, q_cols[name]] for name in markers], axis=1) if orientations else None
    meta: dict[str, Any] = {}
    if frame_col is not None:
        frame = values[:, frame_col]
        if np.any(~np.isfinite(frame)) or np.any(frame != np.round(frame)):
            raise DataFileError(f"{path}: the frame column holds non-integer or empty values")
        idx = (frame - frame[0]).astype(int)
        if np.any(np.diff(idx) <= 0):
            k = int(np.argmax(np.diff(idx) <= 0))
            raise DataFileError(f"{path}: frame indices must increase; row {first_data + k + 2} repeats or goes back")
        if idx[-1] + 1 != idx.size:  # skipped samples: NaN rows at their places
            full = np.full((idx[-1] + 1,) + pos.shape[1:], np.nan)
            full[idx] = pos
            pos = full
            if quat is not None:
                qf = np.full((idx[-1] + 1,) + quat.shape[1:], np.nan)
                qf[idx] = quat
                quat = qf
            if u is not None:
                uf = np.full((idx[-1] + 1, u.shape[1]), np.nan)
                uf[idx] = u
                # inputs are held: a skipped sample keeps the last logged input
                ok = np.isfinite(uf[:, 0])
                last = np.maximum.accumulate(np.where(ok, np.arange(ok.size), 0))
                u = uf[last]
            meta["skipped_samples"] = int(idx[-1] + 1 - idx.size)
        meta["first_frame"] = int(frame[0])
    if u is not None and not np.all(np.isfinite(u)):
        raise DataFileError(f"{path}: input columns {list(inputs or [])} have empty or NaN cells")
    rot = None if quat is None else _rotations(quat)
    return MarkerData(pos, u, 1.0 / float(rate), list(markers), unit, str(path), meta, rot)
