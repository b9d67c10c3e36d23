"""Progress feedback for work that cannot report its own progress (a batched integration, a job pool).

:func:`ticking` keeps a tqdm bar's elapsed time moving while one long step runs, so a command that
waits a minute for a compiled integrator or for worker processes says that it is working.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["ticking"]


@contextmanager
def ticking(bar: Any, interval: float = 1.0) -> Iterator[Any]:
    """Redraw ``bar`` (a tqdm bar) every ``interval`` seconds until the block ends; yields the bar.

    A disabled bar is left alone (no thread).  The numbers are untouched: only the elapsed time and
    rate shown move while the block runs.

    Parameters
    ----------
    bar : tqdm
    interval : float
        Seconds between redraws (> 0).
    """
    if not interval > 0:
        raise ValueError(f"interval must be a number of seconds > 0; got {interval!r}")
    if getattr(bar, "disable", True):
        yield bar
        return
    done = threading.Event()

    def redraw() -> None:
        while not done.wait(interval):
            bar.refresh()

    thread = threading.Thread(target=redraw, name="pcs_sindy-progress", daemon=True)
    thread.start()
    try:
        yield bar
    finally:
        done.set()
        thread.join()
