"""Where the real recordings are: ``PCS_SINDY_REAL_DATA``, else ``<repo>/../shared/real``, else ``/work/shared/real``.

The recordings are never copied into the repository; benchmarks read them at run time.
"""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ENV = "PCS_SINDY_REAL_DATA"


def real_data_dir() -> Path | None:
    """The real-data folder (holding ``trunk/`` and ``tentacle/``), or None when there is none.

    ``$PCS_SINDY_REAL_DATA`` wins when set (even if it does not exist: a set variable is the user's
    choice, so a wrong one reports None rather than silently falling back).
    """
    env = os.environ.get(ENV)
    if env:
        path = Path(env).expanduser()
        return path if path.is_dir() else None
    for path in (REPO / ".." / "shared" / "real", Path("/work/shared/real")):
        if path.is_dir():
            return path.resolve()
    return None
