"""The generated API reference is up to date and covers the public surface."""

from __future__ import annotations

import importlib
import importlib.util
from pathlib import Path

import pcs_sindy

ROOT = Path(__file__).resolve().parents[1]


def _builder():
    spec = importlib.util.spec_from_file_location("build_api", ROOT / "docs" / "build_api.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_api_reference_is_current():
    text = _builder().render()
    committed = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    assert text == committed, "docs/api.md is stale: run `make docs` (python docs/build_api.py)"


def test_api_reference_lists_every_public_entry_point():
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    missing = [name for name in pcs_sindy.__all__ if name != "__version__" and f"### `{name}`" not in text]
    assert not missing, missing


def test_every_listed_name_exists():
    for _, module_name, names in _builder().SECTIONS:
        module = importlib.import_module(module_name)
        absent = [n for n in names if not hasattr(module, n)]
        assert not absent, (module_name, absent)
