"""Command line interface: ``pcs-sindy <command> ...``.

Errors in user input end with a one-line message and a non-zero exit code;
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Sequence

import numpy as np

__all__ = ["main"]


class CLIError(Exception):
    """An error caused by the user's input, reported without a traceback."""


def _parse_noise(text: str | None) -> tuple[float, float] | str | None:
    if text is None or text == "none":
        return None
    if text == "seed":
        return "seed"
    try:
        sigma_p, sigma_deg = (float(v) for v in text.split(","))
    except ValueError:
        raise CLIError(f"--noise must be 'seed', 'none' or 'SIGMA_P_M,SIGMA_THETA_DEG'; got {text!r}") from None
    return sigma_p, float(np.deg2rad(sigma_deg))


def _output_dir(path: str) -> Path:
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write_test"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise CLIError(f"output directory {str(out)!r} is not writable: {err.strerror or err}") from None
    return out


def _save_recording(path: Path, rec) -> None:
    arrays = {k: getattr(rec, k) for k in ("t", "q", "qd", "tau", "poses", "poses_true") if getattr(rec, k) is not None}
    np.savez(path, **arrays)


def _simulate(args: argparse.Namespace) -> list[Path]:
    from .simulation import get_scenario

    try:
        scenario = get_scenario(args.scenario)
    except ValueError as err:
        raise CLIError(str(err)) from None
    start = time.perf_counter()
    data = scenario.generate(seed=args.seed, noise=_parse_noise(args.noise), progress=not args.quiet)
    out = _output_dir(args.out)
    paths = []
    for k, rec in enumerate(data.train):
        paths.append(out / f"train_{k:02d}.npz")
        _save_recording(paths[-1], rec)
    if data.validation is not None:
        paths.append(out / "validation.npz")
        _save_recording(paths[-1], data.validation)
    summary = {
        "scenario": scenario.name,
        "description": scenario.description,
        "seed": args.seed,
        "noise": list(data.noise),
        "n_markers": scenario.n_markers,
        "marker_arc_lengths": scenario.marker_arc_lengths.tolist(),
        "segment_lengths": None if scenario.is_kinematic else list(scenario.robot.kinematics.segment_lengths),
        "files": [p.name for p in paths],
        "seconds": round(time.perf_counter() - start, 2),
    }
    (out / "scenario.json").write_text(json.dumps(summary, indent=2))
    if not args.quiet:
        print(f"simulated {scenario.name} ({len(paths)} recordings) in {summary['seconds']} s -> {out}")
    return paths


def _render(args: argparse.Namespace) -> list[Path]:
    from .simulation.rendering import render_video

    out = _output_dir(args.out)
    written = []
    for name in args.inputs:
        src = Path(name)
        if not src.is_file():
            raise CLIError(f"pose file {name!r} does not exist")
        try:
            with np.load(src, allow_pickle=False) as data:
                if "poses" not in data.files:
                    raise CLIError(f"{name!r} holds no 'poses' array (found {data.files})")
                poses = data["poses"]
                t = data["t"] if "t" in data.files else None
        except (OSError, ValueError) as err:
            raise CLIError(f"cannot read pose file {name!r}: {err}") from None
        fps = args.fps or (1.0 / float(np.median(np.diff(t))) if t is not None and t.size > 1 else 1000.0)
        target = out / (src.stem + args.format)
        try:
            result = render_video(poses, target, fps=fps)
        except ValueError as err:
            raise CLIError(f"{name}: {err}") from None
        written.append(Path(result[0] if isinstance(result, (tuple, list)) else result))
        if not args.quiet:
            print(f"rendered {src.name} ({poses.shape[0]} frames) -> {written[-1]}")
    return written


def _demo(args: argparse.Namespace) -> None:
    out = _output_dir(args.out)
    sim_args = argparse.Namespace(scenario="two_segment", seed=args.seed, noise=None, out=str(out / "data"),
                                  quiet=args.quiet)
    paths = _simulate(sim_args)
    render_args = argparse.Namespace(inputs=[str(p) for p in paths], out=str(out / "videos"), fps=None,
                                     format=".mp4", quiet=args.quiet)
    videos = _render(render_args)
    print(f"demo: simulated data in {out / 'data'}, {len(videos)} videos in {out / 'videos'}")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pcs-sindy", description=__doc__.splitlines()[0])
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("scenarios", help="list the built-in scenarios")
    p.set_defaults(func=lambda a: print("\n".join(__import__("pcs_sindy.simulation", fromlist=["x"]).list_scenarios())))

    p = sub.add_parser("simulate", help="simulate a scenario: recordings (.npz) with t, q, qd, tau, poses")
    p.add_argument("scenario", help="scenario name (see 'pcs-sindy scenarios')")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--noise", default=None, help="'seed', 'none' or 'SIGMA_P_M,SIGMA_THETA_DEG'")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=_simulate)

    p = sub.add_parser("render", help="render pose files (.npz with 'poses') to marker videos")
    p.add_argument("inputs", nargs="+", help="pose files")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--fps", type=float, default=None, help="frame rate (default: from the time stamps)")
    p.add_argument("--format", default=".mp4", choices=[".mp4", ".avi"])
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=_render)

    p = sub.add_parser("demo", help="simulate and render the two_segment scenario")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pcs-sindy`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        args.func(args)
    except (CLIError, ValueError, OSError) as err:
        if args.debug:
            raise
        print(f"pcs-sindy {args.command}: error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
