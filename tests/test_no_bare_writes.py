"""io and core.atomic own file writes (issue 27): no other module of the package writes an array file by itself.

Truth: the package's source text; every ``np.savez``/``numpy.savez`` call must sit in ``core/atomic.py`` or
``io/`` (which writes through ``core.atomic``).
"""

from __future__ import annotations

import re
from pathlib import Path

import pcs_sindy

ROOT = Path(pcs_sindy.__file__).parent


def test_array_files_are_written_only_through_core_atomic():
    offenders = []
    for path in sorted(ROOT.rglob("*.py")):
        if path == ROOT / "core" / "atomic.py" or path.parent == ROOT / "io":
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if re.search(r"\b(np|numpy)\.savez(_compressed)?\(", line) and not line.lstrip().startswith("#"):
                offenders.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()}")
    assert offenders == [], "write through pcs_sindy.core.atomic (savez, FileSet) instead:\n" + "\n".join(offenders)
