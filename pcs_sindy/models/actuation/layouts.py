"""Actuation terms from JSON-able layouts, and the table of every kind.

:func:`actuation_kinds` imports every module of this package (each built-in kind
registers itself when its class is defined) and returns the registry of
:mod:`.base`; :func:`actuation_from_layout` builds a term from a layout's
``"type"`` (a kind) and parameters.  Names no kind: a new kind's module is found here
without an edit.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from pathlib import Path
from typing import Any

from .base import Actuation, registered_kinds

__all__ = ["actuation_kinds", "actuation_from_layout"]


@functools.cache
def _import_builtin_kinds() -> None:
    # the package's modules, found on disk: a kind added as a module needs no list to be edited
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        importlib.import_module(f"{__package__}.{info.name}")


def actuation_kinds() -> dict[str, type[Actuation]]:
    """Every actuation kind: the built-in ones and those defined since, by their ``kind``.

    Returns
    -------
    dict of str to type
        ``kind -> class`` of every concrete :class:`~pcs_sindy.models.actuation.Actuation`
        subclass (a subclass registers itself when it is defined).
    """
    _import_builtin_kinds()
    return registered_kinds()


def actuation_from_layout(layout: dict[str, Any] | None) -> Actuation:
    """An actuation term from a JSON-able layout (``{"type": "tendon", "end": [...], "side": [...]}`` ...).

    ``None`` or ``{"type": "identity"}`` gives :class:`~pcs_sindy.models.actuation.IdentityActuation`;
    ``"type"`` is any registered kind (:func:`actuation_kinds`).
    """
    if layout is None:
        layout = {"type": "identity"}
    if not isinstance(layout, dict) or "type" not in layout:
        raise ValueError(f"layout must be a dict with a 'type'; got {layout!r}")
    kind = layout["type"]
    kwargs = {k: v for k, v in layout.items() if k != "type"}
    classes = actuation_kinds()
    if not isinstance(kind, str) or kind not in classes:
        raise ValueError(f"layout type must be one of {sorted(classes)}; got {kind!r}")
    try:
        return classes[kind](**kwargs)
    except TypeError as err:
        raise ValueError(f"layout of type {kind!r} has unknown keys: {err}") from None
