"""The real-data folder for tests: ``PCS_SINDY_REAL_DATA``, else ``<repo>/../shared/real``, else ``/work/shared/real``.

Tests needing a recording call :func:`real_file`, which skips the test when the folder (or the file) is absent.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ENV = "PCS_SINDY_REAL_DATA"


def real_data_dir() -> Path | None:
    """The folder holding ``trunk/`` and ``tentacle/``, or None (a set but missing ``$PCS_SINDY_REAL_DATA``: None)."""
    env = os.environ.get(ENV)
    if env:
        path = Path(env).expanduser()
        return path if path.is_dir() else None
    for path in (REPO / ".." / "shared" / "real", Path("/work/shared/real")):
        if path.is_dir():
            return path.resolve()
    return None


def real_file(*parts: str) -> Path:
    """The path of a real recording (``real_file("trunk", "x.csv")``); skips the calling test when absent."""
    root = real_data_dir()
    if root is None:
        pytest.skip(f"no real-data folder (set {ENV}, or put it at <repo>/../shared/real)")
    path = root.joinpath(*parts)
    if not path.is_file():
        pytest.skip(f"real recording {path} is absent")
    return path
