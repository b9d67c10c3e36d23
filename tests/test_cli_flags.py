"""Global command-line options (issue 28): -q/-v/--debug before or after the command, -o for --out,
messages through logging, sparse progress bars in log files.

Truth: what each run prints, and the files it writes, compared between spellings of the same command.
"""

from __future__ import annotations

import logging
import subprocess
import sys

import numpy as np
import pytest

from pcs_sindy.cli.main import build_parser, main

SIM = ["simulate", "one_segment", "--n-train", "1", "--train-duration", "0.02", "--no-validation"]


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PCS_SINDY_CACHE", str(tmp_path / "cache"))


@pytest.mark.parametrize(
    "argv",
    [
        ["-q", *SIM, "-o", "OUT"],
        [*SIM, "-q", "--out", "OUT"],
        [*SIM, "--quiet", "-o", "OUT"],
        ["--quiet", *SIM, "--out", "OUT"],
    ],
)
def test_quiet_and_out_before_or_after_the_command(argv, tmp_path, capsys):
    argv = [str(tmp_path / "d") if a == "OUT" else a for a in argv]
    capsys.readouterr()
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert out == "" and err == ""
    with np.load(tmp_path / "d" / "train_00.npz") as rec:
        assert rec["q"].shape == (20, 3)


def test_messages_go_through_logging_and_verbose_adds_debug(tmp_path, capsys):
    capsys.readouterr()
    assert main([*SIM, "-o", str(tmp_path / "a")]) == 0
    normal = capsys.readouterr().out
    assert main(["-v", *SIM, "-o", str(tmp_path / "b")]) == 0
    verbose = capsys.readouterr().out
    assert normal.strip() and "options" not in normal
    assert "pcs-sindy simulate: options" in verbose and "done in" in verbose
    assert normal.strip().splitlines()[-1].split(" in ")[0] == verbose.strip().splitlines()[-2].split(" in ")[0]
    # the handler is gone after the command: the package logs nothing by itself when used from Python
    logger = logging.getLogger("pcs_sindy")
    assert not [h for h in logger.handlers if type(h) is logging.StreamHandler]
    assert logger.level == logging.NOTSET and logger.propagate


def test_debug_after_the_command_shows_the_traceback(tmp_path):
    with pytest.raises(FileNotFoundError):
        main(["fuse", str(tmp_path / "nope.npz"), "-o", str(tmp_path), "--debug"])


def test_every_command_with_an_output_takes_o():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    with_out = [name for name, p in sub.choices.items() if any("--out" in a.option_strings for a in p._actions)]
    assert len(with_out) >= 7
    for name in with_out:
        p = sub.choices[name]
        assert any(a.option_strings[:2] == ["-o", "--out"] for a in p._actions), name


def test_progress_bars_are_sparse_when_not_on_a_terminal(tmp_path):
    """stderr to a file or pipe (a log): the command's bars redraw at most every 30 s (tqdm's mininterval)."""
    code = (
        "import sys; from pcs_sindy.cli.main import main; main(['scenarios']); "
        "import io; from tqdm.auto import tqdm; print('mininterval', tqdm(total=1, file=io.StringIO()).mininterval)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "mininterval 30.0" in proc.stdout
