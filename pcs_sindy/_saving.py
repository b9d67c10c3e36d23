"""``save``/``load`` methods for the estimators, delegating to :mod:`pcs_sindy.persistence`.

The estimators inherit these methods, but the file-format code is imported only
when a method is called: the core modules do not depend on the I/O layer at
import time.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

_UNSET: Any = object()


class PersistenceMixin:
    """``obj.save(path)`` / ``Class.load(path)``: JSON + ``.npz`` model files, never pickle."""

    def save(self, path: str | os.PathLike) -> Path:
        """Write this object to ``path`` (JSON + ``.npz``); returns the JSON path.

        See :func:`pcs_sindy.persistence.save`.
        """
        from .persistence import save

        return save(self, path)

    @classmethod
    def load(cls, path: str | os.PathLike, *, cache_dir: Any = _UNSET) -> Any:
        """Read an object written by :meth:`save`; it must be an instance of ``cls``.

        ``cache_dir`` as in :func:`pcs_sindy.persistence.load`.

        Raises
        ------
        TypeError
            If the file holds another class.
        """
        from .persistence import load

        obj = load(path) if cache_dir is _UNSET else load(path, cache_dir=cache_dir)
        if not isinstance(obj, cls):
            raise TypeError(f"model file {str(path)!r} holds a {type(obj).__name__}, not a {cls.__name__}")
        return obj
