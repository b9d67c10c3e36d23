"""Dependencies only some stages use, and the error that names the pip extra when one is missing.

``pip install pcs_sindy`` installs everything.  A motion-capture user who installed the package with
``--no-deps`` and only the core dependencies (docs/install.md) has no OpenCV (videos, cameras,
rendering), matplotlib (figures) or sympy (the seed's monomial library); the stages that need one
check for it first (:func:`require_installed`, without importing it) or import it through
:func:`require`, and a missing one raises :class:`MissingDependencyError` naming the extra
(``pip install "pcs_sindy[video]"``) instead of a bare ``No module named 'cv2'``.

Knows nothing of the package; the table :data:`EXTRAS` mirrors ``[project.optional-dependencies]`` of
``pyproject.toml`` (checked by ``tests/test_install_extras.py``).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from types import ModuleType

__all__ = ["EXTRAS", "MissingDependencyError", "require", "require_installed"]

#: importable module -> (pip extra of pcs_sindy, distribution that provides it)
EXTRAS: dict[str, tuple[str, str]] = {
    "cv2": ("video", "opencv-python-headless"),
    "matplotlib": ("plots", "matplotlib"),
    "sympy": ("symbolic", "sympy"),
}


class MissingDependencyError(ImportError):
    """An optional dependency is not installed; the message names the pip extra that installs it."""


def _message(module: str, needed_for: str) -> str:
    extra, dist = EXTRAS.get(module, (None, module))
    how = f'pip install "pcs_sindy[{extra}]" (or pip install {dist})' if extra else f"pip install {dist}"
    return f"{needed_for} needs {dist}, which is not installed (import {module!r} failed): {how}"


def require(module: str, needed_for: str) -> ModuleType:
    """Import ``module``, or raise :class:`MissingDependencyError` naming the extra that installs it.

    Parameters
    ----------
    module : str
        The module to import, e.g. ``"cv2"``.
    needed_for : str
        What needs it, for the message (e.g. ``"pcs_sindy.vision (reading videos)"``).

    Returns
    -------
    module
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name is not None and err.name != module and not module.startswith(err.name + "."):
            raise  # the module is there but one of its own imports is missing: not ours to rename
        raise MissingDependencyError(_message(module, needed_for), name=module) from err


def require_installed(module: str, needed_for: str) -> None:
    """Check that ``module`` can be imported, without importing it (a package's first line).

    Raises
    ------
    MissingDependencyError
        When it is not installed (or blocked: ``sys.modules[module] = None``).
    """
    if module in sys.modules:
        if sys.modules[module] is None:
            raise MissingDependencyError(_message(module, needed_for), name=module)
        return
    if importlib.util.find_spec(module) is None:
        raise MissingDependencyError(_message(module, needed_for), name=module)
