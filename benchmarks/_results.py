"""Write a benchmark's numbers into its own section of docs/results.md.

Each benchmark owns one section, delimited by HTML comments, so benchmarks can
be re-run independently without clobbering each other.  Every section is
stamped with the date and the machine it was measured on.
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import re
from pathlib import Path

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "results.md"
_HEADER = (
    "# Measured results\n\n"
    "Numbers written by the scripts in `benchmarks/`; each section says when and where it was measured.\n"
)


def machine_description() -> str:
    """One line naming the CPU, core count, Python and OS."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return f"{cpu}, {cores} cores, Python {platform.python_version()}, {platform.system()} {platform.release()}"


def write_section(name: str, title: str, body: str, command: str) -> Path:
    """Replace (or append) the section ``name`` of docs/results.md.

    Parameters
    ----------
    name : str
        Stable identifier of the section (e.g. the benchmark's file stem).
    title : str
        Markdown heading text.
    body : str
        Markdown content (tables, notes).
    command : str
        The command that produced the numbers.
    """
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    section = (
        f"<!-- BEGIN {name} -->\n## {title}\n\n"
        f"Measured {stamp} on {machine_description()}.  \nCommand: `{command}`\n\n"
        f"{body.rstrip()}\n<!-- END {name} -->\n"
    )
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    text = RESULTS.read_text() if RESULTS.exists() else _HEADER
    pattern = re.compile(rf"<!-- BEGIN {re.escape(name)} -->.*?<!-- END {re.escape(name)} -->\n?", re.S)
    if pattern.search(text):
        text = pattern.sub(lambda _: section, text)
    else:
        text = text.rstrip() + "\n\n" + section
    RESULTS.write_text(text)
    return RESULTS
