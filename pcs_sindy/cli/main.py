"""Command line interface: ``pcs-sindy <command> ...``.

Each command is one step of the pipeline and reads/writes plain files:
simulate (scenario -> recordings), render (poses -> videos), extract
(videos -> poses), fuse (poses -> segmentation + strains), fit (strains + tau
-> model), rollout (model + tau -> predicted poses, metrics); ``demo`` chains
them on the two_segment scenario and writes a report.

This module only parses: every sub-command calls the function of the same
name in :mod:`pcs_sindy.cli.commands` (``demo``: :mod:`pcs_sindy.cli.demo`) with the
parsed options as keyword arguments (an option left out is None there: the
estimator's default).
A new sub-command is a function there plus ``add(name, help, function)`` and
its options in :func:`build_parser`.

Errors in user input end with a one-line message and exit code 2;
``--debug`` shows the traceback instead.

Building the parser and parsing the arguments import no stage and no numpy (``pcs-sindy
--help`` answers at once): the commands import the stages when they run, and the defaults
the help shows are read from the stages' source when the help is printed
(:func:`~pcs_sindy.cli.defaults.read_default`), not imported.
"""

from __future__ import annotations

import argparse
import errno
import inspect
import logging
import math
import os
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from .._version import __version__
from .commands import (
    CLIError,
    RolloutResult,
    build_regressor,
    calibrate,
    extract,
    fit,
    fuse,
    pipeline_step,
    render,
    rollout,
    scenarios,
    simulate,
)
from .defaults import read_default, read_options
from .demo import demo
from .sheet import inspect_video

__all__ = [
    "main",
    "build_parser",
    "command_kwargs",
    "CLIError",
    "RolloutResult",
    "scenarios",
    "simulate",
    "render",
    "extract",
    "fuse",
    "fit",
    "rollout",
    "demo",
    "inspect_video",
    "build_regressor",
    "pipeline_step",
]

EXAMPLE = """
example ('pcs-sindy demo' step by step):
  pcs-sindy simulate two_segment --out data
  pcs-sindy render data/train_*.npz --out videos --size 400x300 --marker-size 0.012,0.003 --n-jobs 2
  pcs-sindy extract videos/*.avi --out poses --n-jobs 2
  pcs-sindy fuse poses/*.npz --out strains --total-length 0.17
  pcs-sindy fit strains/train_*.npz --tau data/*.npz --out model/model.json
  pcs-sindy rollout model/model.json --tau data/validation.npz --truth data/validation.npz \\
      --segmentation strains/segmentation.json --out rollout
"""


#: each command's epilog: the file formats it reads or writes (blocks of io.data_files.FILE_FORMATS) and examples
EPILOGS: dict[str, tuple[tuple[str, ...], str]] = {
    "scenarios": ((), "example:\n  pcs-sindy scenarios"),
    "simulate": (
        ("recording",),
        "examples:\n"
        "  pcs-sindy simulate two_segment -o data\n"
        "  pcs-sindy simulate one_segment -o data --n-train 2 --train-duration 1 --noise seed --seed 3",
    ),
    "render": (
        ("pose file",),
        "examples:\n"
        "  pcs-sindy render data/train_*.npz -o videos --size 400x300 --n-jobs 2\n"
        "  pcs-sindy render data/validation.npz -o web --format browser   # H.264 .mp4 or VP8 .webm: what this\n"
        "                                                                 # OpenCV build writes that browsers play",
    ),
    "calibrate": (
        (),
        "example:\n  pcs-sindy calibrate board/ --pattern 9x6 --square 0.025 --plane board_flat.png "
        "-o videos/clip.mp4.camera.json",
    ),
    "extract": (
        ("pose file",),
        "examples:\n"
        "  pcs-sindy extract videos/*.avi -o poses --n-jobs 2\n"
        "  pcs-sindy extract clip.mp4 -o poses --robot-length 0.17 --n-markers 8 --plot",
    ),
    "inspect": ((), "example:\n  pcs-sindy inspect clip.mp4 --frames 6 --threshold otsu -o clip.inspect.png"),
    "fuse": (
        ("pose file", "strain file", "input file", "model files"),
        "examples:\n"
        "  pcs-sindy fuse poses/*.npz -o strains --total-length 0.17\n"
        "  pcs-sindy fuse --markers-csv take1.csv --markers disk1 disk2 disk3 --rate 100 --input-columns u1 u2 "
        "-o strains\n"
        "  pcs-sindy fuse --markers-csv take1.csv --markers disk1 disk2 disk3 --rate 100 --inputs take1_servos.csv "
        "-o strains\n"
        "      # a Motive export without input columns, the inputs from the controller's log (paired by Frame)",
    ),
    "fit": (
        ("strain file", "tau file", "input file", "model files"),
        "examples:\n"
        "  pcs-sindy fit strains/train_*.npz --tau data/train_*.npz -o model/\n"
        "  pcs-sindy fit strains/take1.npz --inputs strains/inputs/take1.npz --actuation tendons.json -o model/",
    ),
    "rollout": (
        ("tau file", "input file", "pose file", "strain file", "model files"),
        "examples:\n"
        "  pcs-sindy rollout model/model.json --tau data/validation.npz --truth data/validation.npz \\\n"
        "      --segmentation strains/segmentation.json -o rollout                       # poses of a recording\n"
        "  pcs-sindy rollout model/model.json --tau data/train_00.npz --truth strains/train_00.npz \\\n"
        "      --initial strains/train_00.npz -o rollout                                  # measured strains\n"
        "  pcs-sindy rollout model/model.json --tau strains/inputs/take2.npz --truth take2.csv \\\n"
        "      --segmentation strains/segmentation.json --initial strains/take2.npz -o rollout\n"
        "      # a motion-capture CSV: compared in the capture frame (markers, rate, units from strains/capture.json)",
    ),
    "demo": (
        (),
        "examples:\n"
        "  pcs-sindy demo                    # the report in out/demo/report\n"
        "  pcs-sindy demo --quick -o smoke   # 2 short recordings and a 1 s validation",
    ),
}


def _format_blocks(text: str) -> tuple[str, dict[str, str]]:
    """The heading of :data:`~pcs_sindy.io.data_files.FILE_FORMATS` and its entries by name (``"pose file"``: lines)."""
    heading, *lines = text.rstrip("\n").splitlines()
    blocks: dict[str, str] = {}
    name = ""
    for line in lines:
        if line.startswith("  ") and not line.startswith("   "):  # an entry: its name, then two spaces or more
            name = line.strip().split("  ")[0]
            blocks[name] = line
        elif name:
            blocks[name] += "\n" + line
    return heading, blocks


def _epilog(command: str) -> str:
    """The epilog of ``command``: the file formats it reads or writes, then its examples (:data:`EPILOGS`)."""
    formats, examples = EPILOGS[command]
    if not formats:
        return examples
    heading, blocks = _format_blocks(read_default("io.data_files:FILE_FORMATS"))
    return "\n".join([heading, *(blocks[name] for name in formats)]) + "\n\n" + examples


#: where the estimators behind the commands are written (their defaults are read from there)
POSES = "vision.extractor:MarkerPoseExtractor"
SEGMENTS = "fusion.kinematic_fusion:KinematicFusion"
DYNAMICS = "identification.regressor:EulerLagrangeRegressor"
LIBRARY = "identification.library.physical:PhysicalPCSLibrary"  # the regressor's default library
OPTIMIZER = "identification.optimizers:StiffnessThresholdOptimizer"  # and its default optimizer
CAMERA = "core.camera:Camera"


def _default(func: Callable, name: str) -> Any:
    """Default of parameter ``name`` of ``func``, a function of the command line (never re-typed)."""
    return inspect.signature(func).parameters[name].default


def _of(owner: str, name: str) -> Any:
    """Default ``name`` of ``owner`` (``"module:Class"``), read from the source (see :func:`read_default`)."""
    return read_default(f"{owner}.{name}")


def _on_off(value: bool) -> str:
    return "on" if value else "off"


# --------------------------------------------------------------------------
# help texts written when printed: only the help asked for reads the stages' source
# --------------------------------------------------------------------------
class _Deferred(str):
    """A help text (or epilog) written by ``write()`` when it is printed, not when the parser is built.

    Its value as a string is a placeholder; :class:`_HelpFormatter` prints ``write()`` instead.
    """

    write: Callable[[], str]


def _later(write: Callable[[], str]) -> str:
    """A help text that ``write()`` writes when the help is printed."""
    text = _Deferred("(written when the help is printed)")
    text.write = write
    return text


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Description and epilog kept as written; help texts made by :func:`_later` written when printed."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help
        return text.write() if isinstance(text, _Deferred) else text

    def _format_text(self, text: str) -> str:
        return super()._format_text(text.write() if isinstance(text, _Deferred) else text)


# --------------------------------------------------------------------------
# parser: each sub-command's options are the keyword arguments of its function
# --------------------------------------------------------------------------
class _Parser(argparse.ArgumentParser):
    """Argument parser whose usage errors are one line (no usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")

    def _check_help(self, action: argparse.Action) -> None:
        # Python >= 3.14 formats every help text as its option is added, to check it: that would
        # read the stages' source for every command on every run. A deferred text is checked
        # when it is printed (tests/test_cli.py prints them all).
        if not isinstance(action.help, _Deferred):
            super()._check_help(action)  # type: ignore[misc]


def _number(kind: type, check: Callable[[Any], bool], expected: str) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}; got {text!r}") from None
        if not check(value):
            raise argparse.ArgumentTypeError(f"expected {expected}; got {text!r}")
        return value

    return parse


_positive_int = _number(int, lambda v: v >= 1, "a positive integer")


def _pattern(text: str) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected COLSxROWS inner corners such as 9x6; got {text!r}") from None
    if cols < 2 or rows < 2:
        raise argparse.ArgumentTypeError(f"a checkerboard has at least 2x2 inner corners; got {text!r}")
    return cols, rows


_n_jobs = _number(int, lambda v: v >= 1 or v == -1, "a positive integer or -1 (all cores)")
_positive_float = _number(float, lambda v: math.isfinite(v) and v > 0, "a finite number > 0")
_threshold = _number(float, lambda v: v > 0, "a number > 0 or inf")
_FUSION_RULES = ("auto", "relative_drop", "largest_drop")  # KinematicFusion's threshold rules


def _fusion_threshold(text: str) -> float | str:
    """A merge threshold h: a finite number > 0 or a rule that chooses it (``auto``)."""
    if text in _FUSION_RULES:
        return text
    try:
        return _positive_float(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected a finite number > 0 or one of {', '.join(_FUSION_RULES)}; got {text!r}"
        ) from None


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, e.g. 400x300; got {text!r}") from None
    if w < 16 or h < 16:
        raise argparse.ArgumentTypeError(f"image size must be at least 16x16 pixels; got {text!r}")
    return w, h


def _pair(text: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two numbers 'A,B'; got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)) or a <= 0 or b <= 0:
        raise argparse.ArgumentTypeError(f"expected two numbers > 0; got {text!r}")
    return a, b


def _noise(text: str) -> tuple[float, float] | str | None:
    if text in ("none", "seed"):
        return None if text == "none" else "seed"
    try:
        sigma_p, sigma_deg = (float(v) for v in text.split(","))
    except ValueError:
        expected = "'seed', 'none' or 'SIGMA_P_M,SIGMA_THETA_DEG'"
        raise argparse.ArgumentTypeError(f"expected {expected}; got {text!r}") from None
    return sigma_p, math.radians(sigma_deg)


def _value(text: str) -> Any:
    """A value of an estimator parameter as typed: a number, a word, ``A,B,...`` (a tuple) or ``LOW:HIGH`` (a pair).

    Only the form is parsed here; the estimator checks the value (one validation layer) and its
    error names the parameter, the value and what it must be.
    """
    text = text.strip()
    if ":" in text:
        return tuple(_value(part) for part in text.split(":"))
    if "," in text:
        return tuple(_value(part) for part in text.split(","))
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _degrees(text: str) -> Any:
    """An angle typed in degrees, as radians (a word passes through to the estimator)."""
    value = _value(text)
    if isinstance(value, (int, float)):
        return math.radians(value)
    return value


#: MarkerPoseExtractor parameters with a flag on 'extract' and 'inspect': (parameter, metavar, help, parse)
EXTRACTOR_OPTIONS: list[tuple[str, str, str, Callable[[str], Any]]] = [
    ("reference_frame", "K", "frame used for the typical marker, the marker count and the calibration", _value),
    (
        "threshold",
        "T",
        "binarisation: a word, a grey level 0-255, or a colour range LOW:HIGH of grey levels or B,G,R triples "
        "(e.g. 0,0,120:90,90,255)",
        _value,
    ),
    ("polarity", "P", "markers darker or brighter than the background", _value),
    ("blur", "K", "odd Gaussian kernel before thresholding, 0 for none", _value),
    ("roi", "X,Y,W,H", "region of interest in pixels; components outside are ignored", _value),
    ("min_area", "PX", "components smaller than this many pixels are noise", _value),
    ("marker_area", "PX", "typical marker area in pixels (default: the median in the reference frame)", _value),
    ("area_tolerance", "LOW,HIGH", "marker areas outside marker_area * [LOW, HIGH] are not markers", _value),
    ("aspect_tolerance", "F", "long/short ratio tolerance of a marker, a factor >= 1", _value),
    (
        "base_position",
        "U,V",
        "pixel position of the base marker (default: the camera origin, or found in the footage)",
        _value,
    ),
    ("pixels_per_metre", "S", "scale when no camera is used", _value),
    (
        "rest_direction",
        "DEG",
        "image angle of the robot's rest direction in DEGREES, atan2(dv, du) (default: base to next marker)",
        _degrees,
    ),
    ("on_missing", "WHAT", "frames whose markers (or data) cannot be read: fail, or interpolate them in time", _value),
]


def add_extractor_options(p: argparse.ArgumentParser) -> None:
    """The MarkerPoseExtractor flags of :data:`EXTRACTOR_OPTIONS`, plus ``--refine``/``--fill-missing``.

    Words the estimator's ``_parameter_constraints`` accept and its defaults are read from its source
    when the help is printed; values are checked by the estimator.
    """

    def text(name: str, what: str) -> Callable[[], str]:
        def write() -> str:
            words = [w for w in read_options(f"{POSES}.{name}") if name != "on_missing" or w != "predict"]
            listed = f"; words: {', '.join(map(str, words))}" if words else ""
            default = _of(POSES, name)
            if name == "rest_direction" and isinstance(default, (int, float)):
                default = math.degrees(default)
            return f"{what}{listed} (default {default})" if default is not None else f"{what}{listed}"

        return write

    for name, metavar, what, parse in EXTRACTOR_OPTIONS:
        p.add_argument("--" + name.replace("_", "-"), type=parse, metavar=metavar, help=_later(text(name, what)))
    for name, what in (
        ("refine", "sub-pixel centres and axes from intensity-weighted moments (--no-refine: minAreaRect)"),
        ("fill_missing", "an isolated missing marker between two found neighbours is filled on the arc"),
    ):
        p.add_argument(
            "--" + name.replace("_", "-"),
            action=argparse.BooleanOptionalAction,
            help=_later(lambda name=name, what=what: f"{what} (default {_on_off(_of(POSES, name))})"),
        )


def command_kwargs(func: Callable, args: argparse.Namespace) -> dict[str, Any]:
    """The parsed options of ``args`` that are parameters of the command ``func``."""
    params = inspect.signature(func).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):  # takes every option
        return {k: v for k, v in vars(args).items() if k not in ("command", "func", "debug", "verbose")}
    return {k: v for k, v in vars(args).items() if k in params}


def _global_options(p: argparse.ArgumentParser, *, defaults: bool) -> None:
    """``-q``, ``-v`` and ``--debug``, on the main parser (with defaults) and on every command (without:
    a value given before the command is not reset by the command's parser)."""
    kw: dict[str, Any] = {} if defaults else {"default": argparse.SUPPRESS}
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars or messages (warnings remain)", **kw)
    p.add_argument("-v", "--verbose", action="store_true", help="also debug messages (options, timings)", **kw)
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors", **kw)


def build_parser() -> argparse.ArgumentParser:
    """The ``pcs-sindy`` argument parser (one sub-command per pipeline step).

    Defaults shown in the help are the estimators' and the commands' own, read from where they are
    written (:func:`~pcs_sindy.cli.defaults.read_default`; signatures of :mod:`.commands`), never
    re-typed here.  Building it imports no stage.
    """
    file_formats = _later(lambda: read_default("io.data_files:FILE_FORMATS"))
    fmt = _HelpFormatter
    parser = _Parser(
        prog="pcs-sindy",
        description=__doc__.split("\n\n")[1],
        epilog=_later(lambda: file_formats.write() + EXAMPLE),
        formatter_class=fmt,
    )
    parser.add_argument("--version", action="version", version=f"pcs-sindy {__version__}")
    _global_options(parser, defaults=True)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, help_: str, func: Callable) -> argparse.ArgumentParser:
        """A sub-command calling ``func`` with the parsed options named like its parameters."""
        epilog = _later(lambda: _epilog(name))
        p = sub.add_parser(name, help=help_, description=help_, epilog=epilog, formatter_class=fmt)
        p.set_defaults(func=lambda args: func(**command_kwargs(func, args)))
        params = inspect.signature(func).parameters
        if "n_jobs" in params:
            jobs = params["n_jobs"].default
            p.add_argument(
                "--n-jobs",
                type=_n_jobs,
                default=jobs,
                help=f"parallel jobs over files (-1: all cores; default {jobs if jobs is not None else 'serial'})",
            )
        _global_options(p, defaults=False)  # also after the command: 'pcs-sindy fit ... -q'
        return p

    add("scenarios", "list the built-in scenarios", scenarios)

    scenario = "simulation.scenarios:Scenario"
    p = add("simulate", "simulate a scenario: recordings (.npz with t, q, qd, tau, poses, poses_true)", simulate)
    p.add_argument("scenario", help="scenario name (see 'pcs-sindy scenarios')")
    p.add_argument(
        "-o", "--out", required=True, help="output directory (train_00.npz ..., validation.npz, scenario.json)"
    )
    p.add_argument("--seed", type=int, help=_later(lambda: f"random seed (default {_of(scenario, 'generate.seed')})"))
    p.add_argument("--noise", type=_noise, help="pose noise: 'seed', 'none' (default) or 'SIGMA_P_M,SIGMA_THETA_DEG'")
    p.add_argument(
        "--n-train",
        type=_positive_int,
        help=_later(lambda: f"training recordings (default: the scenario's, {_of(scenario, 'n_train')})"),
    )
    p.add_argument(
        "--train-duration",
        type=_positive_float,
        help=_later(lambda: f"seconds per training recording (default {_of(scenario, 'train_duration'):g})"),
    )
    p.add_argument(
        "--validation-duration",
        type=_positive_float,
        help=_later(lambda: f"seconds of validation (default {_of(scenario, 'validation_duration'):g})"),
    )
    p.add_argument(
        "--no-validation", dest="validation", action="store_false", help="do not simulate the validation recording"
    )

    p = add("render", "render pose files to marker videos, each with a camera JSON (<video>.camera.json)", render)
    p.add_argument("inputs", nargs="+", help="pose files (.npz with 'poses'; recordings qualify)")
    p.add_argument("-o", "--out", required=True, help="output directory (one video per input, same stem)")
    p.add_argument("--fps", type=_positive_float, help="frame rate (default: from the time stamps)")
    p.add_argument(
        "--format",
        dest="video_format",
        default=_default(render, "video_format"),
        choices=[".avi", ".mp4", ".webm", "browser"],
        help=".avi (MJPG, default: sharp marker edges for 'extract'), .mp4 (H.264 if this OpenCV build has it, "
        "else mp4v), .webm (VP8), or browser: the first of H.264 .mp4 and VP8 .webm this build writes (lossy "
        "formats give larger pose errors)",
    )
    p.add_argument(
        "--size",
        type=_size,
        help=_later(lambda: "image WIDTHxHEIGHT (default {}x{})".format(*_of(CAMERA, "fit_poses.image_size"))),
    )
    p.add_argument(
        "--marker-size",
        type=_pair,
        help=_later(
            lambda: (
                "marker WIDTH,THICKNESS in metres (default "
                f"{','.join(map(str, _of('simulation.rendering:render_frames', 'marker_size')))})"
            )
        ),
    )

    p = add("calibrate", "lens distortion and the robot's plane from checkerboard views: a camera JSON", calibrate)
    p.add_argument("views", nargs="+", help="checkerboard images, folders of images or videos (every --every-th frame)")
    p.add_argument("--pattern", type=_pattern, required=True, help="inner corners COLSxROWS, e.g. 9x6 for 10x7 squares")
    p.add_argument("--square", type=_positive_float, required=True, help="side of a square in metres")
    p.add_argument("--plane", help="image of the board lying in the robot's plane (default: the last view)")
    p.add_argument(
        "-o",
        "--out",
        required=True,
        help="camera JSON to write (name it <video>.camera.json to have 'extract' find it; a folder gets camera.json)",
    )
    p.add_argument("--fps", type=_positive_float, help="frame rate to store in the JSON (optional)")
    p.add_argument(
        "--every",
        type=_positive_int,
        default=_default(calibrate, "every"),
        help="use every N-th frame of a video (default %(default)s)",
    )

    p = add("extract", "extract marker poses from videos: one pose file (.npz with t, poses) per video", extract)
    p.add_argument("videos", nargs="+", help="videos or folders of image frames (a folder is one recording)")
    p.add_argument("-o", "--out", required=True, help="output directory (one pose file per video, same stem)")
    p.add_argument(
        "--camera",
        help="camera JSON for every video, honoured in full (fps, n_frames; image_size may be left out) "
        "(default: <video>.camera.json next to each video, or camera.json in a frame folder, as 'render' writes)",
    )
    p.add_argument(
        "--robot-length",
        type=_positive_float,
        help="the robot's measured rest length [m]: stored in the pose files for 'fuse', and without a camera "
        "JSON the scale is calibrated from it and the straightest frame (--reference-frame)",
    )
    p.add_argument("--n-markers", type=_positive_int, help="markers besides the base (default: as found)")
    p.add_argument(
        "--fps", type=_positive_float, help="frame rate (default: the camera JSON's, else the video container's)"
    )
    add_extractor_options(p)
    p.add_argument(
        "--plot",
        action="store_true",
        help="also draw <stem>.inspect.png per video: a contact sheet of frames with the markers found",
    )

    p = add(
        "inspect",
        "draw a contact sheet (PNG) of a few frames with the markers found, the chain order, the base and "
        "the components rejected: to check what 'extract' sees",
        inspect_video,
    )
    p.add_argument("video", help="a video, a folder of image frames or one image")
    p.add_argument("-o", "--out", help="PNG to write (default <video stem>.inspect.png beside the video)")
    p.add_argument(
        "--frames",
        type=_positive_int,
        default=_default(inspect_video, "frames"),
        help="frames on the sheet, spread over the recording (default %(default)s)",
    )
    p.add_argument("--camera", help="camera JSON (default: the video's own, as for 'extract')")
    p.add_argument("--robot-length", type=_positive_float, help="as for 'extract'")
    p.add_argument("--n-markers", type=_positive_int, help="as for 'extract'")
    p.add_argument("--fps", type=_positive_float, help="as for 'extract'")
    add_extractor_options(p)

    p = add("fuse", "kinematic fusion: segmentation (segmentation.json/.npz) and one strain file per pose file", fuse)
    p.add_argument("poses", nargs="*", help="pose files (.npz with t, poses); or --markers-csv")
    p.add_argument("-o", "--out", required=True, help="output directory")
    p.add_argument(
        "--markers-csv",
        nargs="+",
        help="instead of pose files: motion-capture CSV/TSV exports of marker positions (Motive, Vicon, Qualisys "
        "or one header row like M1_X,M1_Y,M1_Z); needs --markers and --rate (docs/mocap.md)",
    )
    p.add_argument("--markers", nargs="+", help="marker names in the CSV, base to tip (base not included)")
    p.add_argument("--rate", type=_positive_float, help="nominal capture rate [Hz] of --markers-csv")
    p.add_argument("--units", choices=["m", "mm", "cm"], help="length units of --markers-csv (default: from the file)")
    p.add_argument(
        "--input-columns",
        nargs="+",
        help="input columns of --markers-csv (or, with --inputs, of the input logs), written to OUT/inputs/ for "
        "'fit --inputs'",
    )
    p.add_argument(
        "--inputs",
        nargs="+",
        help="input logs apart from the captures, one per --markers-csv file in order: CSV (a header optional), .npy "
        "or .npz (u; optional index or t); rows pair with capture samples one to one, or by the log's "
        "Frame/Index/ID/Sample column (the capture's frame numbers) or time column t/time [s] (from the "
        "capture's first sample), the last logged input held",
    )
    p.add_argument(
        "--arc-lengths",
        nargs="+",
        type=_positive_float,
        help="measured rest arc lengths [m] of the --markers (default: fitted to the positions)",
    )
    p.add_argument(
        "--space",
        choices=["auto", "plane", "3d"],
        help="--markers-csv: fuse in the markers' best-fit plane or in 3-D (default auto: 3-D when the motion "
        "leaves its plane or with --orientations)",
    )
    p.add_argument(
        "--orientations",
        action="store_true",
        help="--markers-csv: also read each marker's quaternion columns (qx1, qy1, qz1, w1; scalar anywhere, by "
        "name) for a 3-D fusion with torsion",
    )
    p.add_argument(
        "--threshold",
        type=_fusion_threshold,
        help=_later(
            lambda: (
                f"merge threshold h, or a rule choosing it per robot from a sweep: {', '.join(_FUSION_RULES)} "
                f"(default {_of(SEGMENTS, 'threshold')})"
            )
        ),
    )
    p.add_argument(
        "--total-length",
        type=_positive_float,
        help="robot rest length [m], measured (recommended; default: the median deformed length of the "
        "marker chain, ~1%% long for a robot hanging under its weight)",
    )
    p.add_argument(
        "--shape-fit",
        choices=["least_squares", "end_pose"],
        help=_later(
            lambda: (
                "strains fitted to all markers or from segment end poses (the seed) "
                f"(default {_of(SEGMENTS, 'shape_fit')})"
            )
        ),
    )

    p = add("fit", "identify the dynamics from strain files and tau files: a model file", fit)
    p.add_argument("strains", nargs="+", help="strain files (written by 'fuse')")
    p.add_argument(
        "--tau",
        nargs="+",
        help="tau files (.npz with t, tau), matched to the strain files by name (stem); see --pair-by",
    )
    p.add_argument(
        "--inputs",
        nargs="+",
        help="instead of --tau: actuator input files (.npz with t, u; actuated recordings qualify), "
        "matched like --tau; needs --actuation",
    )
    p.add_argument(
        "--pair-by",
        choices=["name", "order"],
        default="name",
        help="how tau (or input) files belong to strain files: by name (same stem, or the same name after a "
        "prefix/suffix shared by all files of a side; refused otherwise, the default) or by order",
    )
    p.add_argument(
        "--actuation",
        help='actuation layout (JSON: {"type": "tendon", "end": [...], "side": [...]} or '
        "pressure/linear; a scenario.json written by 'simulate' qualifies); offsets or gains not given "
        "are identified",
    )
    p.add_argument(
        "-o", "--out", required=True, help="model file (model.json + model.npz); a folder (dir/) gets dir/model.json"
    )
    p.add_argument(
        "--library",
        "--basis",
        choices=["physical", "monomial"],
        help="Lagrangian library: lumped physical unknowns per segment (the default) or the seed's "
        "monomials (--basis: former name)",
    )
    p.add_argument(
        "--formulation",
        choices=["weak", "strong"],
        help=_later(
            lambda: (
                "regress window integrals (weak: no accelerations, robust to noise) or every sample with "
                f"Savitzky-Golay accelerations (strong; the seed's) (default {_of(DYNAMICS, 'formulation')})"
            )
        ),
    )
    p.add_argument(
        "--window-length",
        type=_positive_int,
        help=_later(lambda: f"Savitzky-Golay window (odd; default {_of(DYNAMICS, 'window_length')})"),
    )
    p.add_argument(
        "--polyorder",
        type=_positive_int,
        help=_later(lambda: f"Savitzky-Golay order (default {_of(DYNAMICS, 'polyorder')})"),
    )
    p.add_argument(
        "--weak-window",
        type=_positive_int,
        help=_later(
            lambda: (
                "weak form: window in sampling intervals (default those in "
                f"{read_default('identification.recordings:WEAK_WINDOW'):g} s, at least "
                f"{read_default('identification.recordings:WEAK_WINDOW_MIN_SAMPLES')}, at most half the shortest "
                "recording; shortened to "
                f"{read_default('identification.recordings:WEAK_WINDOW_BAND'):g} / the strains' band frequency "
                f"(at least {read_default('identification.recordings:WEAK_WINDOW_BAND_MIN_SAMPLES')}) when their "
                f"motion is less than {read_default('identification.recordings:WEAK_WINDOW_BAND_SNR'):g} x their "
                "noise)"
            )
        ),
    )
    p.add_argument(
        "--weak-stride",
        type=_positive_int,
        help="weak form: step between windows in samples (default a quarter of the window)",
    )
    p.add_argument(
        "--exclude-force-jumps",
        action=argparse.BooleanOptionalAction,
        help=_later(
            lambda: (
                "strong form: leave out samples whose window straddles a jump of the held actuation "
                f"(default {_on_off(_of(DYNAMICS, 'exclude_force_jumps'))})"
            )
        ),
    )
    p.add_argument(
        "--rest-strain",
        action=argparse.BooleanOptionalAction,
        help=_later(
            lambda: (
                "physical library: identify a constant force per strain, i.e. a rest strain (pre-curved "
                "robots, or a rest length estimated rather than measured) "
                f"(default {_on_off(_of(LIBRARY, 'rest_strain'))})"
            )
        ),
    )
    p.add_argument(
        "--rotary-inertia",
        choices=["free", "tied", "none"],
        help=_later(
            lambda: (
                "physical library: identify rotary inertia (free), tie it to the line density (tied) or "
                f"neglect it (default {_of(LIBRARY, 'rotary_inertia')})"
            )
        ),
    )
    p.add_argument(
        "--stiffness-threshold",
        type=_threshold,
        help=_later(
            lambda: (
                "remove strains stiffer than this factor times the material bound (inf: no removal; "
                f"default {_of(OPTIMIZER, 'threshold'):g})"
            )
        ),
    )

    p = add("rollout", "simulate a model under tau: predicted strains and poses, metrics against a truth", rollout)
    p.add_argument("model", help="model file (written by 'fit')")
    p.add_argument(
        "--tau",
        required=True,
        help="tau file (.npz with t, tau); for a model fitted with --actuation, its actuator inputs (t, u)",
    )
    p.add_argument("--segmentation", help="segmentation file (written by 'fuse'): marker arc lengths")
    p.add_argument(
        "--truth",
        help="what the prediction is compared with: a pose file or recording ('poses_true' when present, else "
        "'poses'), a strain file (written by 'fuse'), or a motion-capture CSV (with the --segmentation that "
        "'fuse --markers-csv' wrote: compared in the capture frame); writes metrics.json and the plot",
    )
    p.add_argument(
        "--markers",
        nargs="+",
        help="marker names of a --truth CSV, base to tip (default: those of capture.json beside --segmentation)",
    )
    p.add_argument(
        "--rate",
        type=_positive_float,
        help="capture rate [Hz] of a --truth CSV (default: capture.json's, else the --tau file's)",
    )
    p.add_argument(
        "--units",
        choices=["m", "mm", "cm"],
        help="length units of a --truth CSV (default: capture.json's or the file's)",
    )
    p.add_argument(
        "--initial",
        help="strain file whose first frame is q0 (default: rest, q0 = 0), or 'truth': the first frame of a --truth "
        "strain file or capture (a capture fused with --segmentation); qd0 = 0",
    )
    p.add_argument(
        "--n-markers",
        type=_positive_int,
        default=_default(rollout, "n_markers"),
        help="markers on the prediction without truth or segmentation (default %(default)s)",
    )
    p.add_argument("-o", "--out", required=True, help="output directory (rollout.npz, metrics.json, rollout.png)")
    p.add_argument("--no-plot", dest="plot", action="store_false", help="do not draw rollout.png")
    p.add_argument(
        "--method",
        choices=list(read_default("core.simulate_contract:METHODS")),  # checked when parsing: read now
        help=_later(_method_help),
    )
    p.add_argument(
        "--rtol",
        type=_positive_float,
        help=_later(lambda: f"relative tolerance (default: the model's, {_of(DYNAMICS, 'rtol'):g})"),
    )
    p.add_argument(
        "--atol",
        type=_positive_float,
        help=_later(lambda: f"absolute tolerance (default: the model's, {_of(DYNAMICS, 'atol'):g})"),
    )

    p = add("demo", "the whole pipeline on two_segment from rendered videos, with a report folder", demo)
    p.add_argument(
        "-o",
        "--out",
        default=_default(demo, "out"),
        help="output directory (default %(default)s; the report in OUT/report)",
    )
    p.add_argument("--seed", type=int, default=_default(demo, "seed"), help="random seed (default %(default)s)")
    p.add_argument(
        "--threshold",
        type=_fusion_threshold,
        help=_later(lambda: f"fusion threshold h or auto (default {_of(SEGMENTS, 'threshold')})"),
    )
    p.add_argument("--quick", action="store_true", help="2 short recordings and a 1 s validation (a smoke test)")
    return parser


def _method_help() -> str:
    """Help of ``rollout --method``: the integrators each kind of model supports, and its default."""
    # LumpedPCSModel.methods is computed in models/forward.py (the compiled schemes first, then scipy's
    # others): the same rule here, checked against the class by tests/test_cli.py
    compiled = read_default("models.integrators:COMPILED_METHODS")
    scipy = list(read_default("core.simulate_contract:SCIPY_METHODS"))
    lumped = [*compiled, *(m for m in scipy if m not in compiled)]
    best = [_of(f"models.forward:{cls}", "default_method") for cls in ("LumpedPCSModel", "CallableModel")]
    return (
        f"integrator, one the model supports (physical library: {', '.join(lumped)}; monomial: {', '.join(scipy)}); "
        f"default: the model's best ({best[0]} / {best[1]})"
    )


#: the file last opened for writing while a command runs (see :func:`_watch_writes`): an OSError that
#: names no file (a full disk: "[Errno 28] No space left on device") is reported with this name
_WRITING: dict[str, str | None] = {"path": None, "active": None}


#: errors only a write raises: a full disk, a file size limit, a quota
_WRITE_ERRORS = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}


def _watch_writes() -> None:
    """Remember the file each ``open`` for writing names (a ``sys.audit`` hook, added once per process).

    An error while writing (disk full, ``ulimit -f``) is raised by ``write`` or ``close`` without a file
    name; the command's one-line message then names the file being written.  Hooks cannot be removed:
    the hook records only while :func:`main` runs a command.
    """
    if _WRITING["active"] is not None:
        return

    def hook(event: str, args: tuple) -> None:
        if event == "open" and _WRITING["active"]:
            path, mode, flags = (args + (None, None, None))[:3]
            writing = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
                isinstance(flags, int) and flags & 3 != 0  # os.O_WRONLY | os.O_RDWR
            )
            if writing and isinstance(path, (str, bytes, os.PathLike)):
                _WRITING["path"] = os.fsdecode(os.fspath(path))

    sys.addaudithook(hook)
    _WRITING["active"] = False


def _quiet_opencv() -> None:
    """Silence OpenCV's own log and FFmpeg's (``[mjpeg @ 0x...] overread``) unless the user set them.

    OpenCV reads ``OPENCV_LOG_LEVEL`` when it is imported and its FFmpeg back-end reads
    ``OPENCV_FFMPEG_LOGLEVEL`` (FFmpeg's ``AV_LOG_QUIET`` = -8) when the first video is opened, so both
    are set before any command runs (measured: with the second set, a truncated Motion-JPEG video no
    longer prints ``[mjpeg @ ...] huffman table decode error``; ``OPENCV_LOG_LEVEL`` alone does not
    silence FFmpeg).  Problems the footage has are reported by the extractor itself, naming the
    recording and frame.
    """
    os.environ.setdefault("OPENCV_LOG_LEVEL", "OFF")
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    cv2 = sys.modules.get("cv2")  # imported already (in-process use): OpenCV's own level set directly
    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    if logging is not None and os.environ["OPENCV_LOG_LEVEL"] == "OFF":
        logging.setLogLevel(logging.LOG_LEVEL_SILENT)


def _one_line(err: BaseException) -> str:
    """The error as one line; an OSError names its file (the one being written when it names none)."""
    message = " ".join(str(err).split()) or type(err).__name__
    if isinstance(err, OSError):
        names = [os.fsdecode(f) for f in (err.filename, err.filename2) if f is not None]
        if not names and _WRITING["path"] is not None and err.errno in _WRITE_ERRORS:
            names = [_WRITING["path"]]
            message = f"cannot write {names[0]!r}: {message}"
        elif names and not any(n in message for n in names):
            message = f"{names[0]!r}: {message}"
    return message


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pcs-sindy`` console script; returns the exit code.

    0 on success, 2 on an error in the user's input or files (one line on stderr naming the file),
    130 when interrupted (Ctrl-C: one line, no traceback).
    """
    try:
        args = build_parser().parse_args(argv)
    except KeyboardInterrupt:
        print("pcs-sindy: interrupted", file=sys.stderr)
        return 130
    _quiet_opencv()
    _watch_writes()
    _WRITING.update(path=None, active=True)
    if not sys.stderr.isatty():
        # a log file, not a terminal: a bar line every 30 s, not ten a second (tqdm reads this when first
        # imported, which in a command-line process is after this point)
        os.environ.setdefault("TQDM_MININTERVAL", "30")
    logger = logging.getLogger("pcs_sindy")
    before = (logger.level, logger.propagate)
    handler = _log_to_stdout(args)
    try:
        return _run(args)
    except KeyboardInterrupt:
        if args.debug:
            raise
        print(f"pcs-sindy {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (pcs-sindy scenarios | head): not an error of the command
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's final flush must not raise again
        return 141
    finally:
        _WRITING.update(path=None, active=False)
        logger.removeHandler(handler)
        logger.setLevel(before[0])
        logger.propagate = before[1]


def _log_to_stdout(args: argparse.Namespace) -> logging.Handler:
    """The command's messages go through ``logging`` (logger ``pcs_sindy``) to standard output.

    Level INFO; ``-q``: WARNING (no messages); ``-v``: DEBUG.  Warnings go to standard error as one
    line each (:func:`_run`).
    """
    handler = logging.StreamHandler(sys.stdout)
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger = logging.getLogger("pcs_sindy")
    level = logging.DEBUG if getattr(args, "verbose", False) else logging.INFO
    if getattr(args, "quiet", False):
        level = logging.WARNING
    logger.setLevel(level)
    logger.addHandler(handler)
    logger.propagate = False  # the user's root logger configuration (if any) does not print them twice
    return handler


def _run(args: argparse.Namespace) -> int:
    """Run the parsed command: its errors become one line and exit code 2 (``--debug``: the traceback)."""
    # Only now that a command runs: the errors it may raise come from numpy and the stages.
    import numpy as np

    from ..core.optional import MissingDependencyError
    from ..core.simulate_contract import SimulationError

    def one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
        print(f"pcs-sindy {args.command}: warning: {' '.join(str(message).split())}", file=sys.stderr)

    try:
        with warnings.catch_warnings():  # restores showwarning on exit
            if not args.debug:
                warnings.showwarning = one_line_warning
            log = logging.getLogger("pcs_sindy.cli")
            options = {k: v for k, v in vars(args).items() if k not in ("func",)}
            log.debug("pcs-sindy %s: options %s", args.command, options)
            start = time.perf_counter()
            args.func(args)
            log.debug("pcs-sindy %s: done in %.2f s", args.command, time.perf_counter() - start)
    except BrokenPipeError:
        raise  # handled by main()
    except (CLIError, ValueError, OSError, SimulationError, np.linalg.LinAlgError, MissingDependencyError) as err:
        if args.debug:
            raise
        print(f"pcs-sindy {args.command}: error: {_one_line(err)}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
