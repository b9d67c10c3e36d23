"""``pcs-sindy demo``: the whole pipeline on two_segment from rendered videos, with a report.

:func:`demo` runs the command-line steps of :mod:`pcs_sindy.cli.commands` on files
(simulate, render, extract, fuse, fit, rollout) with the estimators' default
settings and writes the report of :mod:`pcs_sindy.cli.report`.  Importing this module loads no
stage (the parser of :mod:`pcs_sindy.cli.main` reads :func:`demo`'s signature).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from .commands import extract, fit, fuse, render, rollout, simulate
from .messages import say

__all__ = ["demo"]

# Compiles (or loads from numba's cache) the rollout kernels of a two-segment model in a separate
# process during the single-threaded simulation, so that a cold start compiles them on the idle core.
_ROLLOUT_WARMUP = """
import numpy as np
from pcs_sindy.models.forward import LumpedPCSModel
from pcs_sindy.core.kinematics import PlanarPCS
model = LumpedPCSModel(PlanarPCS((0.07, 0.1)), [1.0, 1.0], [1e-4, 1e-4], [[0.0, 10.0], [0.0, 10.0]],
                       np.ones(6), 0.1 * np.ones(6))
model.simulate(np.zeros(6), np.zeros(6), np.arange(3) * 1e-3, np.zeros((3, 6)))
"""


def demo(
    out: str | Path = "out/demo",
    *,
    seed: int = 0,
    threshold: float | str | None = None,
    quick: bool = False,
    n_jobs: int = 2,
    quiet: bool = False,
) -> Path:
    """The whole pipeline on two_segment from rendered videos, with a report in ``out/report``.

    Every estimator has its default settings (:func:`~pcs_sindy.pipeline.pcs_pipeline.make_pcs_pipeline`)
    except the fusion's rest length, given as measured, and ``threshold``.

    Parameters
    ----------
    out : path
        Output folder: data, videos, poses, strains, model, rollout and report.
    seed : int
        Random seed of the simulated data.
    threshold : float, optional
        Fusion threshold h; default :class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion`'s.
    quick : bool
        2 recordings of 0.2 s and a 1 s validation (a smoke test; numbers not comparable).
    n_jobs : int
        Videos rendered and extracted in parallel.
    quiet : bool
        No progress bars or stage messages.

    Returns
    -------
    Path
        ``report.md``.
    """
    from ..io import data_files as files
    from .report import DEMO_MARKER_SIZE, DEMO_SIZE, demo_report, write_report_md

    try:
        warmup = subprocess.Popen(
            [sys.executable, "-c", _ROLLOUT_WARMUP], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
    except OSError:  # an optimisation only
        warmup = None
    out = files.output_dir(out)
    clock: dict[str, float] = {}
    load_start = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    marks = [time.perf_counter()]

    def tick(name: str) -> None:
        marks.append(time.perf_counter())
        clock[name] = round(marks[-1] - marks[-2], 1)
        say(quiet, f"[demo] {name}: {clock[name]} s")

    try:
        paths = simulate(
            "two_segment",
            out / "data",
            seed=seed,
            n_train=2 if quick else None,
            train_duration=0.2 if quick else None,
            validation_duration=1.0 if quick else None,
            quiet=quiet,
        )
        train, val = paths[:-1], paths[-1]
        tick("simulate")
        videos = render(train, out / "videos", size=DEMO_SIZE, marker_size=DEMO_MARKER_SIZE, n_jobs=n_jobs, quiet=quiet)
        tick("render")
        pose_files = extract(videos, out / "poses", n_jobs=n_jobs, quiet=quiet)
        tick("extract")
        # The rest length is what a user measures with a ruler; estimated from the videos of a robot hanging
        # under its weight it reads ~1 % long (gravity stretch), which biases the fused lengths and the model.
        rest_length = float(sum(json.loads((out / "data" / "scenario.json").read_text())["segment_lengths"]))
        fusion, _, pose_trajs = fuse(
            pose_files, out / "strains", threshold=threshold, total_length=rest_length, quiet=quiet
        )
        tick("fuse")
        model = fit(
            [out / "strains" / (p.stem + ".npz") for p in pose_files], train, out / "model" / "model.json", quiet=quiet
        )
        tick("fit")
        if warmup is not None:
            try:  # never write numba's cache from two processes at once
                warmup.wait(timeout=120)
            except subprocess.TimeoutExpired:
                warmup.kill()
        roll = rollout(model, val, out / "rollout", truth=val, plot=False, quiet=quiet)
        tick("rollout")
        start = marks[-1]
        report = demo_report(
            out / "report",
            fusion=fusion,
            model=model,
            sim=roll.sim,
            poses=roll.poses,
            train_files=train,
            validation_file=val,
            pose_trajectories=pose_trajs,
            progress=not quiet,
            tick=tick,
        )
        clock["report"] = round(time.perf_counter() - start, 1)
    finally:
        if warmup is not None and warmup.poll() is None:
            warmup.kill()
            warmup.wait()
    clock["total"] = round(time.perf_counter() - marks[0], 1)
    load_end = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    p = model.get_params()
    identification = (
        f"identification with EulerLagrangeRegressor()'s defaults ({type(model.library_).__name__}, "
        f"{p['formulation']} form, Savitzky-Golay {p['window_length']}/{p['polyorder']})"
    )
    integration = f"{roll.metrics['method']}, rtol {p['rtol']:g}, atol {p['atol']:g}"
    machine = (
        f"{os.cpu_count()} cores; 1-minute load average {load_start:.1f} at the start, {load_end:.1f} at the "
        "end (other jobs slow every stage)"
    )
    path = write_report_md(
        report, clock, seed=seed, quick=quick, identification=identification, integration=integration, machine=machine
    )
    print(f"demo report: {path} (total {clock['total']} s)")  # the result, shown even with -q
    return path
