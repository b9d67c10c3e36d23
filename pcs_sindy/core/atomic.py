"""Atomic, recoverable file outputs: a file is either the old one or the complete new one.

Every output of the package goes through here (model files, data files, the command line's
results, plots, the derivation cache):

* :func:`write_bytes`, :func:`write_text`, :func:`savez`, :func:`savefig` write one file:
  the content goes to a temporary file in the same folder (created exclusively, ``O_EXCL``,
  so a planted file or link is never followed or overwritten), is flushed and ``fsync``-ed,
  and is renamed over the target (``os.replace``, atomic on POSIX); the folder is then
  ``fsync``-ed.  On any failure (disk full, ``ulimit -f``, an exception while producing the
  content) the temporary is removed and the target is untouched; the ``OSError`` raised
  names the target file.
* :class:`FileSet` writes several files that belong together (a model's JSON and ``.npz``,
  a segmentation and its strain files, a rollout and its metrics): all temporaries are
  written and synced first; only then a small *journal* (``.pcs_sindy-commit.*.json``,
  itself written atomically) records the renames, the renames run, and the journal is
  removed.  The journal's rename is the commit point:

  - a failure or crash before it leaves the old set (and at most hidden temporaries);
  - a crash after it (between two renames) is rolled forward by :func:`recover`, which
    every reader of the package (:func:`pcs_sindy.io.load`, the data-file readers) and every
    later :class:`FileSet` in the folder runs first, so what they see is the complete new set.

  Files of a set must live in one folder.  Nothing a user wrote is ever deleted: only our
  own temporaries and journals are removed.

Inputs are never outputs: inside :func:`protecting` (every command of the command line runs in
one, naming the files it reads) any writer here refuses, with :class:`InputOverwriteError`, a
target that is one of those files, before anything is written.

Guarantee measured by ``tests/test_atomic.py``: a child process killed (``os._exit``) after
every possible number of renames of a three-file set leaves, as read after :func:`recover`,
exactly the old set or exactly the new set; a write under ``RLIMIT_FSIZE`` leaves the old file
bit for bit and raises an ``OSError`` naming the file.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import secrets
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

__all__ = [
    "FileSet",
    "InputOverwriteError",
    "protecting",
    "write_bytes",
    "write_text",
    "savez",
    "savefig",
    "recover",
    "probe_writable",
]

_JOURNAL_PREFIX = ".pcs_sindy-commit."
_JOURNAL_SUFFIX = ".json"

# The files the running command reads, as resolved paths: a context variable so that threads and
# nested commands each see their own.
_PROTECTED: contextvars.ContextVar[frozenset[str]] = contextvars.ContextVar("pcs_sindy_protected", default=frozenset())


class InputOverwriteError(ValueError):
    """An output would replace a file that the same command reads."""


def _identity(path: str | os.PathLike) -> str:
    # realpath: a link or "a/../b" naming an input is the input
    return os.path.normcase(os.path.realpath(os.fspath(path)))


@contextlib.contextmanager
def protecting(paths: Any) -> Iterator[frozenset[str]]:
    """No writer of this module may replace any of ``paths`` while the block runs.

    Parameters
    ----------
    paths : iterable of path
        The files being read (None entries are ignored).  Paths that do not name an existing
        regular file are ignored too: only what exists can be destroyed.

    Yields
    ------
    frozenset of str
        Every protected path (resolved), including those of enclosing blocks.
    """
    added = {_identity(p) for p in paths if p is not None and os.path.isfile(p)}
    token = _PROTECTED.set(_PROTECTED.get() | added)
    try:
        yield _PROTECTED.get()
    finally:
        _PROTECTED.reset(token)


def _refuse_inputs(target: Path) -> None:
    protected = _PROTECTED.get()
    if protected and _identity(target) in protected:
        raise InputOverwriteError(
            f"refusing to write {str(target)!r}: it is one of the files this command reads, and writing it "
            "would destroy it; choose another output (--out)"
        )


def _named_error(err: OSError, path: Path, action: str = "write") -> OSError:
    """``err`` with a message that names ``path`` (``[Errno 27] File too large`` alone names nothing)."""
    if str(path) in str(err):
        return err
    reason = err.strerror or str(err)
    message = f"cannot {action} {str(path)!r}: {reason}"
    return OSError(err.errno, message) if err.errno else OSError(message)


def _fsync_dir(folder: Path) -> None:
    """Make renames in ``folder`` durable (best effort: some file systems refuse directory fsync)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _temporary(target: Path) -> tuple[Path, int]:
    """A new hidden file next to ``target`` (same suffix, so tools that look at it still work), opened exclusively."""
    for _ in range(100):
        tmp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp{target.suffix}")
        try:
            # O_EXCL: never follows or reuses an existing file or link; mode 0o666 minus the umask like open()
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        except OSError as err:
            raise _named_error(err, target) from err
        return tmp, fd
    raise OSError(f"cannot create a temporary file next to {str(target)!r}")


def _unlink_quietly(path: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)


def _fill(target: Path, produce: Callable[[IO[bytes]], Any]) -> Path:
    """A synced temporary next to ``target`` holding what ``produce(fh)`` writes; removed on any failure."""
    tmp, fd = _temporary(target)
    try:
        with os.fdopen(fd, "wb") as fh:
            produce(fh)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as err:
        _unlink_quietly(tmp)
        raise _named_error(err, target) from err
    except BaseException:
        _unlink_quietly(tmp)
        raise
    return tmp


def _as_producer(data: bytes | str) -> Callable[[IO[bytes]], Any]:
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    return lambda fh: fh.write(payload)


def _savez_producer(arrays: dict[str, Any]) -> Callable[[IO[bytes]], Any]:
    import numpy as np

    def produce(fh: IO[bytes]) -> None:
        np.savez(fh, **arrays)

    return produce


def _savefig_producer(fig: Any, target: Path, kwargs: dict[str, Any]) -> Callable[[IO[bytes]], Any]:
    fmt = kwargs.pop("format", None) or (target.suffix[1:].lower() or "png")

    def produce(fh: IO[bytes]) -> None:
        fig.savefig(fh, format=fmt, **kwargs)

    return produce


class FileSet:
    """Files that belong together, written so that a crash leaves the old set or the new one.

    Use as a context manager: the files are committed when the block ends without an
    exception, and nothing is changed (temporaries removed) when it raises.

    Parameters
    ----------
    folder : path, optional
        The folder of every file of the set (default: the folder of the first file added).

    Examples
    --------
    >>> with FileSet() as files:                                      # doctest: +SKIP
    ...     files.savez("out/rollout.npz", q=q)
    ...     files.write_text("out/metrics.json", text)
    """

    def __init__(self, folder: str | os.PathLike | None = None) -> None:
        self.folder = None if folder is None else Path(folder)
        self._pending: list[tuple[Path, Path]] = []  # (temporary, target), in commit order
        self._done = False

    # -- adding files -------------------------------------------------------
    def _target(self, path: str | os.PathLike) -> Path:
        if self._done:
            raise RuntimeError("this FileSet was already committed or aborted")
        target = Path(path)
        _refuse_inputs(target)
        folder = target.parent
        if self.folder is None:
            self.folder = folder
            recover(folder)  # finish a set a crash interrupted before we add to the folder
        elif os.path.abspath(folder) != os.path.abspath(self.folder):
            raise ValueError(
                f"the files of a FileSet must share one folder: {str(target)!r} is not in {str(self.folder)!r}"
            )
        if any(t == target for _, t in self._pending):
            raise ValueError(f"{str(target)!r} is written twice in one FileSet")
        return target

    def add(self, path: str | os.PathLike, produce: Callable[[IO[bytes]], Any]) -> Path:
        """Write ``path`` with ``produce(fh)`` (a binary file object) as part of the set; returns ``path``."""
        target = self._target(path)
        try:
            tmp = _fill(target, produce)
        except BaseException:
            self.abort()
            raise
        self._pending.append((tmp, target))
        return target

    def write_bytes(self, path: str | os.PathLike, data: bytes) -> Path:
        """Add a file holding ``data``."""
        return self.add(path, _as_producer(data))

    def write_text(self, path: str | os.PathLike, text: str) -> Path:
        """Add a UTF-8 text file."""
        return self.add(path, _as_producer(text))

    def savez(self, path: str | os.PathLike, **arrays: Any) -> Path:
        """Add an ``.npz`` of ``arrays`` (``numpy.savez``, uncompressed)."""
        return self.add(path, _savez_producer(arrays))

    def savefig(self, fig: Any, path: str | os.PathLike, **kwargs: Any) -> Path:
        """Add a matplotlib figure (format from the suffix unless ``format=`` is given)."""
        target = Path(path)
        return self.add(target, _savefig_producer(fig, target, dict(kwargs)))

    @contextlib.contextmanager
    def path_for(self, path: str | os.PathLike) -> Iterator[Path]:
        """A temporary path (same folder and suffix) for a tool that writes by name, e.g. OpenCV's video writer.

        The file the tool wrote there joins the set when the block ends without an exception.
        """
        target = self._target(path)
        tmp, fd = _temporary(target)
        os.close(fd)
        try:
            yield tmp
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        except OSError as err:
            _unlink_quietly(tmp)
            self.abort()
            raise _named_error(err, target) from err
        except BaseException:
            _unlink_quietly(tmp)
            self.abort()
            raise
        self._pending.append((tmp, target))

    # -- ending -------------------------------------------------------------
    def abort(self) -> None:
        """Remove every temporary; the targets keep their old content."""
        for tmp, _ in self._pending:
            _unlink_quietly(tmp)
        self._pending = []
        self._done = True

    def commit(self) -> list[Path]:
        """Rename every temporary over its target, behind a journal (see the module docstring)."""
        if self._done:
            raise RuntimeError("this FileSet was already committed or aborted")
        self._done = True
        pending, self._pending = self._pending, []
        if not pending:
            return []
        folder = self.folder if self.folder is not None else Path(".")
        with _folder_lock(folder):  # another process's commit or recovery in this folder waits
            return self._commit(pending, folder)

    def _commit(self, pending: list[tuple[Path, Path]], folder: Path) -> list[Path]:
        if len(pending) == 1:
            _rename(*pending[0])
            _fsync_dir(folder)
            return [pending[0][1]]
        journal = folder / f"{_JOURNAL_PREFIX}{os.getpid()}.{secrets.token_hex(6)}{_JOURNAL_SUFFIX}"
        record = {"renames": [[tmp.name, target.name] for tmp, target in pending]}
        try:
            jtmp = _fill(journal, _as_producer(json.dumps(record)))
            os.replace(jtmp, journal)
            _fsync_dir(folder)
        except BaseException:
            for tmp, _ in pending:
                _unlink_quietly(tmp)
            raise
        # committed: from here a crash is rolled forward by recover()
        for tmp, target in pending:
            _rename(tmp, target)
        _fsync_dir(folder)
        _unlink_quietly(journal)
        _fsync_dir(folder)
        return [target for _, target in pending]

    def __enter__(self) -> FileSet:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if self._done:
            return
        if exc_type is None:
            self.commit()
        else:
            self.abort()


@contextlib.contextmanager
def _folder_lock(folder: Path) -> Iterator[None]:
    """Serialise the commits and recoveries of every process in ``folder``.

    Two processes committing sets of the same files would otherwise interleave their renames
    and leave one's JSON beside the other's ``.npz``.  The lock is an advisory ``flock`` on the
    folder itself (no lock file is left behind); where there is none (not POSIX, or a folder
    that cannot be opened) the commit runs unlocked, as before.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        fcntl = None
    fd = None
    if fcntl is not None:
        try:
            fd = os.open(folder, os.O_RDONLY)
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError:
            if fd is not None:
                os.close(fd)
            fd = None
    try:
        yield
    finally:
        if fd is not None:
            os.close(fd)  # releases the lock


def _rename(tmp: Path, target: Path) -> None:
    try:
        os.replace(tmp, target)
    except FileNotFoundError:
        if not target.exists():  # else a concurrent recover() renamed it for us
            raise
    except OSError as err:
        raise _named_error(err, target, "replace") from err


def recover(folder: str | os.PathLike) -> list[Path]:
    """Finish the file sets a crash interrupted in ``folder`` (roll forward their journals).

    Safe to call at any time and from readers: a folder that cannot be listed or written
    is left alone.  Only files named in a journal of this module are renamed, and only
    journals are removed.

    Returns
    -------
    list of Path
        The files renamed into place.
    """
    folder = Path(folder)
    try:
        if not any(p.name.startswith(_JOURNAL_PREFIX) for p in folder.iterdir()):
            return []
    except OSError:
        return []
    with _folder_lock(folder):  # never roll forward a set whose own commit is still renaming
        return _recover(folder)


def _recover(folder: Path) -> list[Path]:
    try:
        journals = [
            p for p in folder.iterdir() if p.name.startswith(_JOURNAL_PREFIX) and p.name.endswith(_JOURNAL_SUFFIX)
        ]
    except OSError:
        return []
    done: list[Path] = []
    for journal in sorted(journals):
        try:
            with open(journal, "rb") as fh:
                record = json.loads(fh.read(1 << 20).decode("utf-8"))
            renames = record["renames"]
            pairs = [(str(a), str(b)) for a, b in renames]
        except (OSError, ValueError, KeyError, TypeError):
            continue  # not ours or half-written (the journal is renamed into place only once complete)
        try:
            for tmp_name, target_name in pairs:
                if "/" in tmp_name or "/" in target_name or not tmp_name.startswith("."):
                    raise ValueError("not a journal of this module")
                tmp = folder / tmp_name
                if tmp.exists():
                    os.replace(tmp, folder / target_name)
                    done.append(folder / target_name)
            _fsync_dir(folder)
            os.unlink(journal)
        except (OSError, ValueError):
            continue
    return done


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Atomically replace ``path`` with ``data`` (see the module docstring); returns ``path``."""
    with FileSet() as fs:
        fs.write_bytes(path, data)
    return Path(path)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Atomically replace ``path`` with the UTF-8 ``text``; returns ``path``."""
    return write_bytes(path, text.encode("utf-8"))


def savez(path: str | os.PathLike, **arrays: Any) -> Path:
    """Atomically replace ``path`` with an ``.npz`` of ``arrays``; returns ``path``."""
    with FileSet() as fs:
        fs.savez(path, **arrays)
    return Path(path)


def savefig(fig: Any, path: str | os.PathLike, **kwargs: Any) -> Path:
    """Atomically replace ``path`` with a matplotlib figure; returns ``path``."""
    with FileSet() as fs:
        fs.savefig(fig, path, **kwargs)
    return Path(path)


def probe_writable(folder: str | os.PathLike) -> None:
    """Raise ``OSError`` unless a new file can be created in ``folder`` (removes only its own probe)."""
    tmp, fd = _temporary(Path(folder) / ".write_probe")
    os.close(fd)
    _unlink_quietly(tmp)
