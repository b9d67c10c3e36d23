"""The generated API reference is up to date and covers the public surface."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
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
    names = [n for n in pcs_sindy.__all__ if n != "__version__" and not inspect.ismodule(getattr(pcs_sindy, n))]
    missing = [name for name in names if f"### `{name}`" not in text]
    assert not missing, missing
    stages = [n for n in pcs_sindy.__all__ if inspect.ismodule(getattr(pcs_sindy, n))]
    assert [s for s in stages if f"## `pcs_sindy.{s}`" not in text] == []


def test_every_exported_name_exists():
    # a name in a stage's lazy table that its module does not define fails here, not in a user's import
    for _, module_name, names in _builder().sections():
        module = importlib.import_module(module_name)
        absent = [n for n in module.__all__ if not hasattr(module, n)]
        assert not absent, (module_name, absent)
        assert names, module_name
