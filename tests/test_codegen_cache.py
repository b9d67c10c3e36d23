"""The derivation cache of the symbolic library: only text of the generator's form is executed.

Each hostile cache file below carries *matching* hashes (the hashes sit in the same file, so
anyone who can write the cache can write them): the shape check, not the hash, must refuse it.
A refused file is a cache miss: a warning, a fresh derivation (compared with a derivation
without any cache) and an atomic rewrite of the file.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from pcs_sindy.identification.library import codegen

# a single-segment state and lengths to evaluate a basis
Q = np.array([[3.0, 0.1, -0.2], [0.5, -0.05, 0.01]])
L = np.array([0.1])


@pytest.fixture(scope="module")
def reference():
    """The m = 1 basis derived without a cache (independent of any file)."""
    return codegen.build_basis(1, cache_dir=False)


@pytest.fixture()
def cache(tmp_path, reference):
    """A valid cache file for m = 1 in a fresh directory."""
    codegen.build_basis(1, cache_dir=tmp_path)
    return next(tmp_path.glob("pcs_basis_m1_*.json"))


def _plant(path, edit) -> None:
    """Replace the cached source by ``edit(source)`` with a matching hash."""
    data = json.loads(path.read_text())
    data["source"] = edit(data["source"])
    data["sha256"] = hashlib.sha256(data["source"].encode()).hexdigest()
    path.write_text(json.dumps(data))


def _rebuilt(path, reference) -> codegen.CompiledBasis:
    """Load through the cache: must warn, re-derive (same values as the reference) and repair the file."""
    with pytest.warns(RuntimeWarning, match="derivation cache .* is not usable"):
        basis = codegen.build_basis(1, cache_dir=path.parent)
    assert not basis.from_cache
    np.testing.assert_array_equal(basis.psi(Q, Q, Q, L), reference.psi(Q, Q, Q, L))
    again = codegen.build_basis(1, cache_dir=path.parent)
    assert again.from_cache and again.source == reference.source  # the file was rewritten
    return basis


HEAD = "def features(q, qd, L):\n"


def _first_line(line: str):
    """An edit that puts ``line`` first in the body of features()."""
    return lambda s: s.replace(HEAD, HEAD + "    " + line + "\n", 1)


HOSTILE = {
    # rebinds numpy's cos for the whole process when psi runs (passed the old check)
    "attribute store": lambda s: s.replace("    return out\n", "    np.cos = np.sin\n    return out\n", 1),
    # a default argument is evaluated when the module is executed: 9**9**9 never finishes
    "default argument": lambda s: s.replace("def features(q, qd, L):", "def features(q, qd, L=9**9**9):"),
    # a default that raises while the text is executed: escaped build_basis before
    "raising default": lambda s: s.replace("def features(q, qd, L):", "def features(q, qd, L=1/0):"),
    "import": _first_line("import os"),
    "loop": _first_line("while 1: pass"),
    "huge power": _first_line("z = 9**9**9"),
    # powers nested through locals: each ** raises a name, but the name holds a Python integer that
    # grows 64-fold in digits per line (issue 27: ran for minutes)
    "nested powers": _first_line("a = 9 * 9\n    b = a**64\n    c = b**64\n    d = c**64\n    e = d**64"),
    "lambda": _first_line("z = (lambda: 0)()"),
    "decorator": lambda s: s.replace("def psi(", "@np.vectorize\ndef psi(", 1),
    "store into an argument": lambda s: s.replace("    return out\n", "    q[:, 0] = 0\n    return out\n", 1),
    "tuple unpacking": _first_line("a, b = 1, 2"),
    "keyword call": lambda s: s.replace("np.empty((q.shape[0],", "np.empty(shape=(q.shape[0],", 1),
    "unknown special function": lambda s: s.replace("SF['IEE']", "SF['IEE" + "_u" * 50 + "']", 1),
    "wrong result shape": lambda s: s.replace("    return out\n", "    out = out[:, :1]\n    return out\n", 1),
    "failing body": lambda s: s.replace("    return out\n", "    out = out[:, 99999]\n    return out\n", 1),
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_cache_text_is_a_cache_miss(name, cache, reference):
    cos = np.cos
    _plant(cache, HOSTILE[name])
    assert json.loads(cache.read_text())["source"] != reference.source  # the edit applied
    _rebuilt(cache, reference)
    assert np.cos is cos


@pytest.mark.parametrize(
    "name",
    ["attribute store", "default argument", "import", "loop", "huge power", "nested powers", "lambda", "decorator"],
)
def test_the_check_refuses_forms_the_generator_never_writes(name, reference):
    """The static check alone (no execution) refuses each form and names it."""
    with pytest.raises(ValueError, match="cached source"):
        codegen._check_generated_source(HOSTILE[name](reference.source))


def test_the_check_accepts_what_the_generator_writes(reference):
    codegen._check_generated_source(reference.source)
    two = codegen.build_basis(2, cache_dir=None)  # the user's cache or a derivation: both generated text
    codegen._check_generated_source(two.source)
