"""The real-data folder for tests: ``PCS_SINDY_REAL_DATA``, else ``<repo>/../shared/real``, else ``/work/shared/real``.

Tests needing a recording call :func:`real_file`, which skips the test when the folder (or the file) is absent.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks._real_data import ENV, real_data_dir  # one lookup for benchmarks and tests  # noqa: F401


def real_file(*parts: str) -> Path:
    """The path of a real recording (``real_file("trunk", "x.csv")``); skips the calling test when absent."""
    root = real_data_dir()
    if root is None:
        pytest.skip(f"no real-data folder (set {ENV}, or put it at <repo>/../shared/real)")
    path = root.joinpath(*parts)
    if not path.is_file():
        pytest.skip(f"real recording {path} is absent")
    return path
