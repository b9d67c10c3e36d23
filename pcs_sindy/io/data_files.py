"""The plain data files of the ``pcs-sindy`` command line: recordings, poses, forces, strains, models.

Every array file is an ``.npz`` of named arrays, read without pickle; keys a
reader does not know are ignored, so files written by older versions (and
recordings, which hold poses and forces) still load.  :data:`FILE_FORMATS`
lists the keys.  Fitted segmentations and models are JSON + ``.npz`` pairs of
:mod:`pcs_sindy.io.model_files`; :func:`read_model_file` loads one and checks
its class.

Readers raise :class:`DataFileError` (a ``ValueError``) naming the file and
what is wrong with it, or ``FileNotFoundError``.

Writers are atomic (:mod:`pcs_sindy.core.atomic`): a file is replaced only by a complete new
one, and an ``OSError`` (disk full, ``ulimit -f``) names the file and leaves the old one.  Pass
``into=`` a :class:`~pcs_sindy.core.atomic.FileSet` to write several files as one set (the
command line does for a segmentation and its strain files); readers first finish a set a
crash interrupted (:func:`~pcs_sindy.core.atomic.recover`).
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import atomic
from ..core.atomic import FileSet
from ..core.spatial import SpatialStrainTrajectory, se3_matrix
from ..core.trajectory import StrainTrajectory
from .npz_headers import check_npz_headers

__all__ = [
    "FILE_FORMATS",
    "DataFileError",
    "output_dir",
    "read_arrays",
    "read_poses",
    "write_poses",
    "read_tau",
    "write_tau",
    "read_strains",
    "write_strains",
    "write_recording",
    "read_training_files",
    "pair_files",
    "read_model_file",
    "write_model_file",
]

FILE_FORMATS = """\
file formats (all .npz, read without pickle; extra keys are ignored):
  recording    t (T,), q, qd, tau (T, n), poses, poses_true (T, N+1, 3)  (written by 'simulate');
               actuated scenarios add u (T, p), the actuator inputs (tau is then A(q) u at the samples)
  pose file    t (T,), poses (T, N+1, 3): base + N markers, [x, y, theta] in m/rad in the base frame
               optional rest_length (): the robot's measured length in m (written by 'extract --robot-length')
  tau file     t (T,), tau (T, 3m): generalized forces held on [t_k, t_k+1)  (a recording qualifies)
  input file   t (T,), u (T, p): actuator inputs held on [t_k, t_k+1)  (written by 'fuse --markers-csv' to
               OUT/inputs/; actuated recordings qualify)
  strain file  t (T,), q (T, 3m), segment_lengths (m,), active_strains (m, 3),
               base_pose (3,), base_poses (T, 3), marker_arc_lengths (N+1,)  (written by 'fuse')
  model files  JSON + .npz sibling written by pcs_sindy.io.model_files (no pickle)
"""

_RECORDING_KEYS = ("t", "q", "qd", "tau", "poses", "poses_true")
_STRAIN_METADATA = ("base_poses", "marker_arc_lengths", "boundaries")
#: what a spatial strain file (a 3-D fusion's) carries besides: the fusion's marker model
_SPATIAL_METADATA = ("marker_offsets", "rotation_offsets")


class DataFileError(ValueError):
    """A data file that cannot be read: not an ``.npz`` of named arrays, missing keys or wrong shapes."""


def output_dir(path: str | Path) -> Path:
    """Create ``path`` (and parents) and check that it is writable.

    Raises
    ------
    DataFileError
        If it cannot be created or written to.
    """
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        atomic.probe_writable(out)  # a fresh, exclusively created probe: never a user's file
    except OSError as err:
        raise DataFileError(f"output directory {str(out)!r} is not writable: {err.strerror or err}") from None
    return out


def check_regular_file(path: str | Path, what: str) -> None:
    """Refuse, naming what it is, a path that is not an existing regular file (a folder, a FIFO, a device).

    Raises
    ------
    FileNotFoundError
        When nothing is there.
    DataFileError
        When something else than a regular file is (reading a FIFO would wait forever,
        ``/dev/zero`` never ends).
    """
    import stat

    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} {str(path)!r} does not exist") from None
    except OSError as err:
        raise DataFileError(f"cannot read {what} {str(path)!r}: {err.strerror or err}") from None
    if stat.S_ISDIR(mode):
        raise DataFileError(f"{what} {str(path)!r} is a folder, not a file (give the files in it)")
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO (named pipe)"
            if stat.S_ISFIFO(mode)
            else "a device"
            if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
            else "not a regular file"
        )
        raise DataFileError(f"{what} {str(path)!r} is {kind}, not a regular file")


def read_arrays(
    path: str | Path, required: Sequence[str], what: str = "data file", optional: Sequence[str] = ()
) -> dict[str, NDArray]:
    """The ``required`` arrays (and those of ``optional`` that are present) of an ``.npz`` file.

    Parameters
    ----------
    path : str or Path
    required, optional : sequence of str
        Keys that must be present / are read when present.
    what : str
        The kind of file, named in error messages (e.g. ``"pose file"``).

    Returns
    -------
    dict of str to ndarray

    Raises
    ------
    FileNotFoundError
        If ``path`` is not a file.
    DataFileError
        If it is not an ``.npz`` of named arrays or lacks a required key.
    """
    src = Path(path)
    atomic.recover(src.parent)  # finish a set of files a crash interrupted
    check_regular_file(src, what)
    try:
        data = np.load(src, allow_pickle=False)
    except (OSError, EOFError, ValueError, zipfile.BadZipFile) as err:
        raise DataFileError(f"cannot read {what} {str(path)!r}: {err}") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise DataFileError(f"{what} {str(path)!r} is a single .npy array, not an .npz file with named arrays")
    with data:
        try:
            check_npz_headers(data, f"{what} {str(path)!r}")
        except ValueError as err:
            raise DataFileError(str(err)) from None
        missing = [k for k in required if k not in data.files]
        if missing:
            raise DataFileError(f"{what} {str(path)!r} lacks {missing} (found {sorted(data.files)})")
        try:
            return {k: np.asarray(data[k]) for k in (*required, *optional) if k in data.files}
        except (OSError, ValueError, zipfile.BadZipFile) as err:  # e.g. an object array (pickle refused)
            raise DataFileError(f"cannot read {what} {str(path)!r}: {err}") from None


def read_poses(path: str | Path, key: str = "poses") -> tuple[NDArray[np.float64] | None, NDArray[np.float64]]:
    """Time stamps (None when the file has none) and poses (T, N + 1, 3) of a pose file or recording.

    Parameters
    ----------
    path : str or Path
    key : str
        The poses' key: ``"poses"`` (measured) or ``"poses_true"`` (a recording's noise-free poses).

    Returns
    -------
    t : ndarray, shape (T,), or None
    poses : ndarray, shape (T, N + 1, 3)
    """
    data = read_arrays(path, [key], "pose file", optional=["t"])
    poses = data[key].astype(float)
    if poses.ndim != 3 or poses.shape[-1] != 3 or poses.shape[1] < 2:
        raise DataFileError(f"pose file {str(path)!r}: '{key}' must have shape (T, N + 1, 3); got {poses.shape}")
    t = data.get("t")
    if t is not None and t.shape != (poses.shape[0],):
        raise DataFileError(f"pose file {str(path)!r}: 't' must have shape ({poses.shape[0]},); got {t.shape}")
    return (None if t is None else t.astype(float)), poses


def _savez(path: str | Path, arrays: dict[str, Any], into: FileSet | None) -> Path:
    """``np.savez`` made atomic, alone or as part of the set ``into``."""
    if into is None:
        return atomic.savez(path, **arrays)
    return into.savez(path, **arrays)


def write_poses(
    path: str | Path,
    t: ArrayLike,
    poses: ArrayLike,
    rest_length: float | None = None,
    *,
    into: FileSet | None = None,
) -> Path:
    """Write a pose file (``t``, ``poses`` and, when known, the robot's ``rest_length``); returns its path.

    ``into``: a :class:`~pcs_sindy.core.atomic.FileSet` the file joins (written when the set
    commits); default: written atomically on its own.
    """
    t, poses = np.asarray(t, dtype=float), np.asarray(poses, dtype=float)
    if poses.ndim != 3 or poses.shape[-1] != 3 or t.shape != (poses.shape[0],):
        raise ValueError(f"need t (T,) and poses (T, N + 1, 3); got {t.shape} and {poses.shape}")
    extra = {} if rest_length is None else {"rest_length": np.float64(rest_length)}
    _savez(path, {"t": t, "poses": poses, **extra}, into)
    return Path(path)


def read_rest_length(path: str | Path) -> float | None:
    """The robot's rest length in metres stored in a pose file, or None."""
    data = read_arrays(path, [], "pose file", optional=["rest_length"])
    value = data.get("rest_length")
    if value is None:
        return None
    value = float(np.asarray(value))
    if not np.isfinite(value) or value <= 0:
        raise DataFileError(f"pose file {str(path)!r}: 'rest_length' must be a length > 0 in metres; got {value!r}")
    return value


def read_tau(path: str | Path, key: str = "tau") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Time stamps (T,) and generalised forces (T, n) of a tau file or recording (``key="u"``: actuator inputs)."""
    what = "tau file" if key == "tau" else "input file"
    data = read_arrays(path, ["t", key], what)
    t, tau = data["t"].astype(float), data[key].astype(float)
    if tau.ndim != 2 or t.shape != (tau.shape[0],):
        raise DataFileError(f"{what} {str(path)!r}: need t (T,) and {key} (T, n); got {t.shape} and {tau.shape}")
    return t, tau


def read_layout(path: str | Path) -> dict[str, Any]:
    """An actuation layout from JSON: the layout itself, or a file holding it under ``"actuation"``.

    A layout names its ``type`` (``"tendon"``, ``"pressure"``, ``"linear"``,
    ``"identity"``) and the design parameters of :mod:`pcs_sindy.models.actuation`,
    e.g. ``{"type": "tendon", "end": [0.07, 0.17], "side": [1, -1]}``; the
    ``scenario.json`` written by ``pcs-sindy simulate`` qualifies.
    """
    src = Path(path)
    try:
        doc = json.loads(src.read_text())
    except FileNotFoundError:
        raise DataFileError(f"layout file {str(path)!r} does not exist") from None
    except (OSError, ValueError) as err:
        raise DataFileError(f"cannot read layout file {str(path)!r}: {err}") from None
    layout = doc.get("actuation", doc) if isinstance(doc, dict) else None
    if not isinstance(layout, dict) or "type" not in layout:
        raise DataFileError(f"layout file {str(path)!r} holds no actuation layout (a JSON object with a 'type')")
    return layout


def write_tau(path: str | Path, t: ArrayLike, tau: ArrayLike, *, into: FileSet | None = None, key: str = "tau") -> Path:
    """Write a tau file (``t``, ``tau``); returns its path (``into`` as in :func:`write_poses`).

    ``key="u"`` writes an input file (actuator inputs ``u``, read by ``fit --inputs``) instead.
    """
    if key not in ("tau", "u"):
        raise ValueError(f"key must be 'tau' or 'u'; got {key!r}")
    t, tau = np.asarray(t, dtype=float), np.asarray(tau, dtype=float)
    if tau.ndim != 2 or t.shape != (tau.shape[0],):
        raise ValueError(f"need t (T,) and {key} (T, n); got {t.shape} and {tau.shape}")
    _savez(path, {"t": t, key: tau}, into)
    return Path(path)


def read_strains(path: str | Path) -> StrainTrajectory | SpatialStrainTrajectory:
    """A strain file as a :class:`~pcs_sindy.core.trajectory.StrainTrajectory`, or a
    :class:`~pcs_sindy.core.spatial.SpatialStrainTrajectory` when it holds spatial strains (a
    ``base_rotation``).

    ``base_poses``, ``marker_arc_lengths`` and ``boundaries`` (and, for spatial strains, the base pose as
    ``base_pose`` (4, 4), ``marker_offsets``, ``rotation_offsets``), when present, go to ``metadata``
    (with ``source``, the path).
    """
    data = read_arrays(
        path,
        ["t", "q", "segment_lengths"],
        "strain file",
        optional=[
            "active_strains",
            "base_pose",
            "base_position",
            "base_rotation",
            *_STRAIN_METADATA,
            *_SPATIAL_METADATA,
        ],
    )
    meta: dict[str, Any] = {"source": str(path)}
    meta.update({key: data[key] for key in _STRAIN_METADATA if key in data})
    lengths = tuple(np.atleast_1d(data["segment_lengths"]).astype(float))
    try:
        if "base_rotation" in data:
            position = np.asarray(data.get("base_position", np.zeros(3)), dtype=float)
            meta.update({key: data[key] for key in _SPATIAL_METADATA if key in data})
            meta["base_pose"] = se3_matrix(position, data["base_rotation"])
            return SpatialStrainTrajectory(
                data["q"],
                data["t"],
                segment_lengths=lengths,
                active_strains=data.get("active_strains"),
                base_position=tuple(position),
                base_rotation=data["base_rotation"],
                metadata=meta,
            )
        return StrainTrajectory(
            data["q"],
            data["t"],
            segment_lengths=lengths,
            active_strains=data.get("active_strains"),
            base_pose=tuple(data["base_pose"]) if "base_pose" in data else (0.0, 0.0, 0.0),
            metadata=meta,
        )
    except ValueError as err:
        raise DataFileError(f"strain file {str(path)!r}: {err}") from None


def write_strains(
    path: str | Path, st: StrainTrajectory | SpatialStrainTrajectory, *, into: FileSet | None = None
) -> Path:
    """Write a strain trajectory (and its ``base_poses``, ``marker_arc_lengths``, ``boundaries`` metadata).

    A :class:`~pcs_sindy.core.spatial.SpatialStrainTrajectory` writes its base as ``base_position`` and
    ``base_rotation`` and the fusion's ``marker_offsets`` and ``rotation_offsets`` when present.
    ``into`` as in :func:`write_poses`.
    """
    arrays = {
        "t": st.t,
        "q": st.q,
        "segment_lengths": np.asarray(st.segment_lengths, dtype=float),
        "active_strains": st.active_strains,
    }
    if isinstance(st, SpatialStrainTrajectory):
        position, rotation = st.kinematics.base_pose
        arrays.update(base_position=np.asarray(position, dtype=float), base_rotation=np.asarray(rotation, dtype=float))
        keys = ("marker_arc_lengths", "boundaries", *_SPATIAL_METADATA)
    else:
        arrays["base_pose"] = np.asarray(st.kinematics.base_pose, dtype=float)
        keys = _STRAIN_METADATA
    arrays.update({key: np.asarray(st.metadata[key]) for key in keys if st.metadata.get(key) is not None})
    _savez(path, arrays, into)
    return Path(path)


def write_recording(path: str | Path, rec: Any, *, into: FileSet | None = None) -> Path:
    """Write a simulated recording (its ``t``, ``q``, ``qd``, ``tau``, ``poses``, ``poses_true`` that are not None).

    An actuated recording also writes its actuator inputs ``u``.  ``into`` as in :func:`write_poses`.
    """
    arrays = {k: getattr(rec, k) for k in _RECORDING_KEYS if getattr(rec, k, None) is not None}
    u = getattr(rec, "u", None)
    if u is not None and u is not getattr(rec, "tau", None):
        arrays["u"] = u
    _savez(path, arrays, into)
    return Path(path)


def _kind(c: str) -> int:
    return 0 if c.isdigit() else 1 if c.isalpha() else 2


def _whole_parts(stems: list[str], n: int, from_end: bool) -> int:
    """The longest ``k <= n`` such that the first (last) ``k`` characters end on a name-part boundary in every stem.

    Parts are runs of digits, of letters, and of anything else: ``run_10`` is ``run``, ``_``, ``10``.
    """
    for k in range(n, 0, -1):
        ok = True
        for st in stems:
            cut = len(st) - k if from_end else k
            if 0 < cut < len(st) and _kind(st[cut - 1]) == _kind(st[cut]):
                ok = False
                break
        if ok:
            return k
    return 0


def _keys(stems: list[str]) -> list[str]:
    """Stems without the prefix and suffix they all share (``strain_a``, ``strain_b`` -> ``a``, ``b``).

    Only whole name parts are cut (runs of digits, of letters, of other characters): ``run_10``,
    ``run_11`` keep ``10``, ``11``, so they never pair with ``run_0``, ``run_1``.
    """
    if len(stems) < 2:
        return list(stems)
    prefix = os.path.commonprefix(stems)
    prefix = prefix[: _whole_parts(stems, len(prefix), from_end=False)]
    suffix = os.path.commonprefix([st[::-1] for st in stems])[::-1]
    k = _whole_parts(stems, len(suffix), from_end=True)
    suffix = suffix[len(suffix) - k :] if k else ""
    cut = [st[len(prefix) :] for st in stems]
    return [c[: len(c) - len(suffix)] if suffix and len(c) >= len(suffix) else c for c in cut]


def pair_files(
    strain_files: Sequence[str | Path], tau_files: Sequence[str | Path], pairing: str = "name", what: str = "tau"
) -> list[tuple[str | Path, str | Path]]:
    """The (strain file, tau file) pairs: matched by name, or refused showing the pairing.

    Parameters
    ----------
    strain_files, tau_files : sequence of path
    pairing : {"name", "order"}
        ``"name"``: every strain file takes the tau file of the same stem
        (``strains/rec_a.npz`` - ``taus/rec_a.npz``), or, when the stems differ
        only by a prefix or suffix all files of a side share, of the same
        remaining part (``strain_a`` - ``tau_a``); one file on each side pair
        up whatever their names.  ``"order"``: the k-th strain file takes the
        k-th tau file.
    what : str
        The kind of the second list in messages (``"tau"`` or ``"input"``).

    Returns
    -------
    list of (strain file, tau file)

    Raises
    ------
    DataFileError
        When the names do not match (with ``pairing="name"``) or the counts
        differ (with ``pairing="order"``); the message shows the pairing by
        order and how to choose it.
    """
    if pairing not in ("name", "order"):
        raise ValueError(f"pairing must be 'name' or 'order'; got {pairing!r}")
    strain_files, tau_files = list(strain_files), list(tau_files)
    by_order = list(zip(strain_files, tau_files))
    shown = "; ".join(f"{str(a)!r} <- {str(b)!r}" for a, b in by_order[:6]) + ("; ..." if len(by_order) > 6 else "")
    if pairing == "order" or (len(strain_files) == 1 and len(tau_files) == 1):
        if len(tau_files) != len(strain_files):
            raise DataFileError(
                f"got {len(strain_files)} strain file(s) but {len(tau_files)} {what} file(s); pairing by order "
                f"needs one {what} file per strain file"
            )
        return by_order
    by_stem = {Path(p).stem: p for p in tau_files}
    if len(by_stem) == len(tau_files) and all(Path(s).stem in by_stem for s in strain_files):
        return [(s, by_stem[Path(s).stem]) for s in strain_files]
    if len(tau_files) == len(strain_files):
        skeys = _keys([Path(p).stem for p in strain_files])
        tkeys = _keys([Path(p).stem for p in tau_files])
        if len(set(skeys)) == len(skeys) and len(set(tkeys)) == len(tkeys) and set(skeys) == set(tkeys):
            by_key = dict(zip(tkeys, tau_files))
            return [(s, by_key[k]) for s, k in zip(strain_files, skeys)]
    if len(tau_files) != len(strain_files):
        unmatched = [str(s) for s in strain_files if Path(s).stem not in by_stem]
        raise DataFileError(
            f"got {len(strain_files)} strain file(s) but {len(tau_files)} {what} file(s), and their names (stems) "
            f"do not match (strain files without a {what} file of the same name: {unmatched[:6]}"
            f"{' ...' if len(unmatched) > 6 else ''}); give one {what} file per strain file, named like it (same stem)"
        )
    raise DataFileError(
        f"the names of the {len(tau_files)} {what} file(s) do not match those of the {len(strain_files)} strain "
        f"file(s), so which forces belong to which recording is not known (by order it would be: {shown}); "
        f"name each {what} file like its strain file (same stem), or, if that order is right, pair by order "
        "(pairing='order', on the command line --pair-by order)"
    )


def model_file_arrays(paths: Sequence[str | Path]) -> list[Path]:
    """The paths that are the array half (``.npz``) of a model file (a ``.json`` of the same stem beside it).

    ``pcs-sindy fuse`` writes ``segmentation.json`` + ``segmentation.npz`` next to the strain
    files, so a glob ``strains/*.npz`` catches the segmentation's arrays too.
    """
    found = []
    for p in paths:
        path = Path(p)
        sibling = path.with_suffix(".json")
        if path.suffix == ".npz" and sibling.is_file():
            try:
                with open(sibling, "rb") as fh:
                    head = fh.read(4096)
            except OSError:
                continue
            if b'"format"' in head and b"pcs_sindy.model" in head:
                found.append(path)
    return found


def read_training_files(
    strain_files: Sequence[str | Path], tau_files: Sequence[str | Path], key: str = "tau", pairing: str = "name"
) -> tuple[list[StrainTrajectory], list[NDArray[np.float64]]]:
    """Strain trajectories and their forces, checked to belong together.

    Parameters
    ----------
    strain_files : sequence of path
        Strain files (written by ``pcs-sindy fuse``).
    tau_files : sequence of path
        Tau files, matched to the strain files by name (see :func:`pair_files`).
    key : {"tau", "u"}
        ``"u"``: the files hold actuator inputs (any width), not generalised forces.
    pairing : {"name", "order"}
        ``"name"``: match by name or refuse (showing the pairing by order);
        ``"order"``: the k-th tau file belongs to the k-th strain file.

    Returns
    -------
    strains : list of StrainTrajectory
    taus : list of ndarray, shape (T, 3m)

    Raises
    ------
    DataFileError
        If the files do not pair up (names, counts), a tau file's width differs from the
        strains' or its time stamps from the strain file's by more than half a sample.
    """
    pairs = pair_files(strain_files, tau_files, pairing, "tau" if key == "tau" else "input")
    strains = [read_strains(p) for p in strain_files]
    taus = []
    for (sfile, tfile), st in zip(pairs, strains):
        t, tau = read_tau(tfile, key)
        n = st.kinematics.n_q
        if key == "tau" and tau.shape[1] != n:
            raise DataFileError(
                f"tau file {str(tfile)!r} has {tau.shape[1]} force columns but strain file {str(sfile)!r} has {n} "
                f"strains ({st.kinematics.n_segments} segment(s) x {n // st.kinematics.n_segments}): tau must act "
                "on the same segmentation"
            )
        if t.shape[0] != st.n_frames:
            raise DataFileError(
                f"tau file {str(tfile)!r} has {t.shape[0]} samples but strain file {str(sfile)!r} has {st.n_frames}"
            )
        dt = float(np.median(np.diff(st.t))) if st.n_frames > 1 else 1.0
        if np.max(np.abs((t - t[0]) - (st.t - st.t[0]))) > 0.5 * dt:
            dt_tau = float(np.median(np.diff(t))) if t.size > 1 else dt
            raise DataFileError(
                f"time stamps of tau file {str(tfile)!r} and strain file {str(sfile)!r} differ by more than half a "
                f"sample: the strains are sampled at {1.0 / dt:.6g} Hz, the {key} at {1.0 / dt_tau:.6g} Hz "
                "(check the frame rate given to extract, --fps, against the rate of the inputs)"
            )
        taus.append(tau)
    return strains, taus


def read_model_file(path: str | Path, expected: type, what: str = "model file") -> Any:
    """An object saved by :func:`pcs_sindy.io.model_files.save`, checked to be an ``expected`` instance.

    Parameters
    ----------
    path : str or Path
        ``model.json`` (or the stem, or the ``.npz``).
    expected : type
        E.g. ``EulerLagrangeRegressor`` or ``KinematicFusion`` (a segmentation file).
    what : str
        The kind of file, named in error messages.
    """
    from .model_files import load

    src = Path(path)
    if not (src.exists() or src.with_suffix(".json").exists()):
        raise FileNotFoundError(f"{what} {str(path)!r} does not exist")
    try:
        obj = load(src)
    except (ValueError, OSError, KeyError, TypeError) as err:
        raise DataFileError(f"cannot read {what} {str(path)!r}: {err}") from None
    if not isinstance(obj, expected):
        raise DataFileError(f"{what} {str(path)!r} holds a {type(obj).__name__}, not a {expected.__name__}")
    return obj


def write_model_file(obj: Any, path: str | Path, *, into: FileSet | None = None) -> Path:
    """Save a fitted estimator as JSON + ``.npz`` (:func:`pcs_sindy.io.model_files.save`); returns the JSON path.

    ``into`` as in :func:`write_poses` (the pair always commits together).
    """
    from .model_files import save

    return Path(save(obj, path, into=into))
