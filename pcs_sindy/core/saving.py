"""``save``/``load`` methods for the estimators, without the estimators depending on the file formats.

The model-file format (:mod:`pcs_sindy.io.model_files`) sits on top of every stage: it knows
every class a file may hold.  The estimators sit below it, so they cannot import it.  Instead,
the file format is registered here (the package root does it on import, and the root is always
imported before any submodule), and :class:`PersistenceMixin` calls whatever is registered.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["PersistenceMixin", "register_file_format"]

_UNSET: Any = object()
_FORMAT: dict[str, Callable[..., Any]] = {}


def register_file_format(save: Callable[[Any, str | os.PathLike], Path], load: Callable[..., Any]) -> None:
    """Set the functions behind :meth:`PersistenceMixin.save` and :meth:`PersistenceMixin.load`.

    Parameters
    ----------
    save : callable
        ``save(obj, path) -> Path`` of the written JSON file.
    load : callable
        ``load(path, **kwargs) -> object``.
    """
    if not (callable(save) and callable(load)):
        raise TypeError(f"save and load must be callable; got {type(save).__name__} and {type(load).__name__}")
    _FORMAT.update(save=save, load=load)


def _format(name: str) -> Callable[..., Any]:
    try:
        return _FORMAT[name]
    except KeyError:
        raise RuntimeError(
            "no model-file format is registered; import pcs_sindy (the package root registers it)"
        ) from None


class PersistenceMixin:
    """``obj.save(path)`` / ``Class.load(path)``: JSON + ``.npz`` model files, never pickle."""

    def save(self, path: str | os.PathLike) -> Path:
        """Write this object to ``path`` (JSON + ``.npz``); returns the JSON path.

        See :func:`pcs_sindy.io.save`.
        """
        return _format("save")(self, path)

    @classmethod
    def load(cls, path: str | os.PathLike, *, cache_dir: Any = _UNSET) -> Any:
        """Read an object written by :meth:`save`; it must be an instance of ``cls``.

        ``cache_dir`` as in :func:`pcs_sindy.io.load`.

        Raises
        ------
        TypeError
            If the file holds another class.
        """
        load = _format("load")
        obj = load(path) if cache_dir is _UNSET else load(path, cache_dir=cache_dir)
        if not isinstance(obj, cls):
            raise TypeError(f"model file {str(path)!r} holds a {type(obj).__name__}, not a {cls.__name__}")
        return obj
