"""Start-up time of the ``pcs-sindy`` command line against ``python -c "import numpy"``.

Wall time of a fresh process, median over ``--runs`` runs, of ``import numpy`` (the reference),
``import pcs_sindy``, ``pcs-sindy --help``, ``pcs-sindy fit --help``, ``pcs-sindy extract --help`` (the
extractor's flags, with the words of its parameter table read from the source), ``pcs-sindy --version``
and an argument error (an unknown option: exit code 2).  The target is at most 3x the numpy
import.  The cases run interleaved (one of each per round, after one warm-up round that is not
counted), so that a change of the machine's load falls on every case alike.

Run: ``.venv/bin/python benchmarks/cli_startup.py [--runs 15]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_section  # noqa: E402

TARGET = 3.0  # the command line may take at most this many times the numpy import


def cases() -> list[tuple[str, list[str], int]]:
    """(label, command, expected exit code) of each process to time; the numpy import first."""
    script = Path(sys.executable).with_name("pcs-sindy")
    cli = [str(script)] if script.exists() else [sys.executable, "-m", "pcs_sindy.cli.main"]
    py = sys.executable
    return [
        ('python -c "import numpy"', [py, "-c", "import numpy"], 0),
        ('python -c "pass"', [py, "-c", "pass"], 0),
        ('python -c "import pcs_sindy"', [py, "-c", "import pcs_sindy"], 0),
        ("pcs-sindy --help", [*cli, "--help"], 0),
        ("pcs-sindy fit --help", [*cli, "fit", "--help"], 0),
        ("pcs-sindy extract --help", [*cli, "extract", "--help"], 0),
        ("pcs-sindy --version", [*cli, "--version"], 0),
        (
            "pcs-sindy fit s.npz --tau t.npz --out m --no-such-option (argument error)",
            [*cli, "fit", "s.npz", "--tau", "t.npz", "--out", "m", "--no-such-option"],
            2,
        ),
    ]


def wall_time(command: list[str], expected: int) -> float:
    """Seconds from starting ``command`` to its exit; raises if it exits with another code."""
    start = time.perf_counter()
    code = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    seconds = time.perf_counter() - start
    if code != expected:
        raise RuntimeError(f"{' '.join(command)!r} exited with {code}, expected {expected}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=15, help="fresh processes per case (default %(default)s)")
    args = parser.parse_args()
    if args.runs < 1:
        parser.error(f"--runs must be at least 1; got {args.runs}")
    todo = cases()
    load_start = os.getloadavg()
    for _, command, expected in todo:  # warm-up: file cache, compiled bytecode
        wall_time(command, expected)
    times: dict[str, list[float]] = {label: [] for label, _, _ in todo}
    for _ in range(args.runs):
        for label, command, expected in todo:
            times[label].append(wall_time(command, expected))
    load_end = os.getloadavg()

    median = {label: statistics.median(t) for label, t in times.items()}
    reference = median[todo[0][0]]
    rows = []
    for label, t in times.items():
        ratio = median[label] / reference
        if label.startswith("pcs-sindy"):
            verdict = "met" if ratio <= TARGET else f"missed by {ratio / TARGET:.2f}x ({ratio - TARGET:.2f} over)"
        else:
            verdict = "reference" if label == todo[0][0] else ""
        rows.append(
            f"| `{label}` | {1e3 * median[label]:.0f} | {1e3 * min(t):.0f} | {1e3 * max(t):.0f} | {ratio:.2f} "
            f"| {verdict} |"
        )
        print(f"{label:75s} median {1e3 * median[label]:6.0f} ms  ratio {ratio:5.2f}  {verdict}")
    body = "\n".join(
        [
            f"Wall time of a fresh process (start to exit, output discarded), median of {args.runs} runs per case; "
            "the cases run interleaved, one of each per round, after one warm-up round that is not counted. "
            f'Target: every `pcs-sindy` row at most {TARGET:g}x `python -c "import numpy"`.',
            "",
            f"Load average (1/5/15 min): {load_start[0]:.2f} / {load_start[1]:.2f} / {load_start[2]:.2f} at the "
            f"start, {load_end[0]:.2f} / {load_end[1]:.2f} / {load_end[2]:.2f} at the end, on a machine shared with "
            "other jobs: a busy core lengthens every row.",
            "",
            "| process | median [ms] | min [ms] | max [ms] | / numpy import | target (<= 3x) |",
            "|---|---|---|---|---|---|",
            *rows,
            "",
            "Parsing imports no stage and no numpy (checked by `tests/test_cli.py`); the help reads the "
            "estimators' defaults from their source files (`pcs_sindy.cli.defaults.read_default`) only for the "
            "help that is printed, and a command imports its stages when it runs.",
        ]
    )
    path = write_section(
        "cli_startup",
        "Command line start-up",
        body,
        f".venv/bin/python benchmarks/cli_startup.py --runs {args.runs}",
    )
    print(f"written to {path}")


if __name__ == "__main__":
    main()
