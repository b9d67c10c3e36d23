"""The steps of the ``pcs-sindy`` command line as Python functions on files.

simulate (scenario -> recordings), render (poses -> videos), extract
(videos -> poses), fuse (poses -> segmentation + strains), fit (strains + tau
-> model) and rollout (model + tau -> predicted poses, metrics); the demo
that chains them is :func:`pcs_sindy.cli.demo.demo`.  Each takes typed keyword arguments, so
``fit(strains, taus, "model.json", window_length=15)`` does from Python what
``pcs-sindy fit ... --window-length 15`` does; :mod:`pcs_sindy.cli.main` only
parses the command line and calls these.

An option left out (None) means the estimator's own default: the estimators
are the steps of :func:`~pcs_sindy.pipeline.pcs_pipeline.make_pcs_pipeline`
(:func:`pipeline_step`), so the pipeline, the command line and the demo share
one source of defaults.  File formats: :mod:`pcs_sindy.io.data_files`; the demo
report: :mod:`pcs_sindy.cli.report`.

Importing this module loads no stage and no numpy: :mod:`pcs_sindy.cli.main` builds the
parser from these functions' signatures, and ``pcs-sindy --help`` must not wait for the
stages.  Each function imports what it uses.
"""

from __future__ import annotations

import functools
import json
import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .messages import say

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "CLIError",
    "RolloutResult",
    "pipeline_step",
    "build_regressor",
    "scenarios",
    "simulate",
    "render",
    "calibrate",
    "extract",
    "fuse",
    "fit",
    "rollout",
]


class CLIError(Exception):
    """An error caused by the user's input, reported without a traceback."""


def _paths_in(value: Any) -> list[Any]:
    if isinstance(value, (str, os.PathLike)):
        return [value]
    if isinstance(value, (list, tuple)):
        return [v for v in value if isinstance(v, (str, os.PathLike))]
    return []


def reads_inputs(func: Callable) -> Callable:
    """Run ``func`` so that no output replaces a file it reads (:func:`pcs_sindy.core.atomic.protecting`).

    Every path-like argument except ``out`` counts as an input; writing over one raises
    :class:`~pcs_sindy.core.atomic.InputOverwriteError` before anything is replaced.
    """

    @functools.wraps(func)
    def guarded(*args: Any, **kwargs: Any) -> Any:
        import inspect

        from ..core.atomic import protecting

        bound = inspect.signature(func).bind(*args, **kwargs)
        read = [p for name, value in bound.arguments.items() if name != "out" for p in _paths_in(value)]
        with protecting(read):
            return func(*args, **kwargs)

    return guarded


def _given(**options: Any) -> dict[str, Any]:
    """The options that were given (None means: the estimator's default)."""
    return {k: v for k, v in options.items() if v is not None}


def pipeline_step(name: str, **params: Any) -> Any:
    """A fresh estimator of :func:`~pcs_sindy.pipeline.make_pcs_pipeline`'s step ``name`` with ``params`` set.

    Parameters
    ----------
    name : {"poses", "segments", "dynamics"}
    **params
        Parameters to set (``set_params``); None values are left at the step's default.
    """
    from ..pipeline.pcs_pipeline import make_pcs_pipeline

    # from poses unless the extractor is asked for: the other steps need no vision (no OpenCV)
    pipe = make_pcs_pipeline(start="videos" if name == "poses" else "poses")
    return pipe.named_steps[name].set_params(**_given(**params))


def scenarios() -> list[str]:
    """Print the built-in scenarios with a description each; return their names.

    Returns
    -------
    list of str
    """
    from ..simulation.catalog import describe_scenarios

    described = describe_scenarios()
    width = max(map(len, described))
    print("\n".join(f"{name:<{width}}  {text}" for name, text in described.items()))
    return list(described)


def simulate(
    scenario: str,
    out: str | Path,
    *,
    seed: int | None = None,
    noise: tuple[float, float] | str | None = None,
    n_train: int | None = None,
    train_duration: float | None = None,
    validation: bool = True,
    validation_duration: float | None = None,
    quiet: bool = False,
) -> list[Path]:
    """Simulate a scenario: ``train_00.npz`` ..., ``validation.npz`` and ``scenario.json`` in ``out``.

    Parameters
    ----------
    scenario : str
        A name of :func:`pcs_sindy.simulation.catalog.list_scenarios`.
    out : path
        Output folder (created).
    seed, n_train, train_duration, validation, validation_duration
        As :meth:`pcs_sindy.simulation.scenarios.Scenario.generate`; None: its default.
    noise : None, "seed" or (sigma_p, sigma_theta)
        Pose noise in m and rad (None: noise-free poses).
    quiet : bool
        No progress bar or message.

    Returns
    -------
    list of Path
        The recordings, validation last.
    """
    from ..core.atomic import FileSet
    from ..io import data_files as files
    from ..simulation.catalog import get_scenario

    try:
        spec = get_scenario(scenario)
    except ValueError as err:
        raise CLIError(str(err)) from None
    start = time.perf_counter()
    data = spec.generate(
        **_given(seed=seed),
        noise=noise,
        n_train=n_train,
        train_duration=train_duration,
        validation=validation,
        validation_duration=validation_duration,
        progress=not quiet,
    )
    folder = files.output_dir(out)
    with FileSet(folder) as outputs:  # the recordings and scenario.json: all new or all old
        paths = [
            files.write_recording(folder / f"train_{k:02d}.npz", rec, into=outputs) for k, rec in enumerate(data.train)
        ]
        if data.validation is not None:
            paths.append(files.write_recording(folder / "validation.npz", data.validation, into=outputs))
        summary = {
            "scenario": spec.name,
            "description": spec.description,
            "seed": data.seed,
            "noise": list(data.noise),
            "n_markers": spec.n_markers,
            "marker_arc_lengths": spec.marker_arc_lengths.tolist(),
            "segment_lengths": None if spec.is_kinematic else list(spec.robot.kinematics.segment_lengths),
            "actuation": spec.actuation,  # the layout of an actuated robot (None: driven by tau directly)
            "files": [p.name for p in paths],
            "seconds": round(time.perf_counter() - start, 2),
            "units": {
                "noise": ["m", "rad"],
                "marker_arc_lengths": "m",
                "segment_lengths": "m",
                "seconds": "s",
                "recordings": "t [s], q [1/m for be, - for sh and ax], poses [m, m, rad], tau [N·m², N·m, N·m]",
            },
        }
        outputs.write_text(folder / "scenario.json", json.dumps(summary, indent=2))
    say(quiet, f"simulated {spec.name} ({len(paths)} recordings) in {summary['seconds']} s -> {folder}")
    return paths


def _render_one(
    src: str,
    target: str,
    fps: float | None,
    size: tuple[int, int] | None,
    marker_size: tuple[float, float] | None,
    progress: bool,
) -> tuple[str, int]:
    """Render one pose file (module level so joblib can run it in a worker)."""
    import numpy as np

    from ..core.camera import Camera
    from ..io import data_files as files
    from ..simulation.rendering import render_video

    t, poses = files.read_poses(src)
    if fps is None:
        fps = 1.0 / float(np.median(np.diff(t))) if t is not None and t.size > 1 else 1000.0
    try:
        camera = Camera.fit_poses(poses, **_given(image_size=size))
        result = render_video(poses, target, camera, fps=fps, progress=progress, **_given(marker_size=marker_size))
    except ValueError as err:
        raise CLIError(f"{src}: {err}") from None
    return str(result.video), int(poses.shape[0])


def _over_files(func: Callable, items: Sequence[tuple], n_jobs: int, desc: str, quiet: bool) -> list:
    """``func(*item, progress)`` per item: serial with the items' own bars, or joblib with one bar over items."""
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    from ..core.progress import ticking

    if n_jobs == 1 or len(items) == 1:
        return [func(*item, not quiet) for item in items]
    jobs = (delayed(func)(*item, False) for item in items)  # workers' bars would interleave
    with tqdm(total=len(items), desc=desc, unit="file", disable=quiet) as bar, ticking(bar):
        out = []
        for result in Parallel(n_jobs=n_jobs, return_as="generator")(jobs):
            out.append(result)
            bar.update()
    return out


def file_target(out: str | Path, name: str) -> Path:
    """The file an ``--out`` names: ``out`` itself, or ``out/name`` when ``out`` is a folder.

    A folder is an existing directory or a path ending in a separator (``--out models/``), which
    is created; anything else is the file (its suffix as given).
    """
    text = str(out)
    if text.endswith(("/", os.sep)) or Path(out).is_dir():
        return Path(out) / name
    return Path(out)


def _unique_stems(names: Sequence[str | Path], what: str) -> None:
    stems = [Path(v).stem for v in names]
    if len(set(stems)) != len(stems):
        raise CLIError(f"{what} share a name (stem); their outputs would overwrite each other")


@reads_inputs
def render(
    inputs: Sequence[str | Path],
    out: str | Path,
    *,
    fps: float | None = None,
    video_format: str = ".avi",
    size: tuple[int, int] | None = None,
    marker_size: tuple[float, float] | None = None,
    n_jobs: int = 1,
    quiet: bool = False,
) -> list[Path]:
    """Render pose files to marker videos, each with its camera as ``<video>.camera.json``.

    Parameters
    ----------
    inputs : sequence of path
        Pose files (recordings qualify); one video each, same stem.
    out : path
        Output folder (created).
    fps : float, optional
        Frame rate; default from the time stamps.
    video_format : {".avi", ".mp4", ".webm", "browser"}
        MJPG (sharp marker edges), MP4 (H.264 when this OpenCV build has it, else mp4v; lossy), WebM
        (VP8; lossy) or ``"browser"``: the first of H.264 MP4 and VP8 WebM that this build writes
        (:func:`pcs_sindy.core.video.browser_video_format`; the videos' suffix says which).
    size : (int, int), optional
        Image width and height; default :meth:`~pcs_sindy.core.camera.Camera.fit_poses`'s.
    marker_size : (float, float), optional
        Marker width and thickness (m); default :func:`~pcs_sindy.simulation.rendering.render_frames`'s.
    n_jobs : int
        Files rendered in parallel (joblib; -1: all cores).
    quiet : bool
        No progress bars or messages.

    Returns
    -------
    list of Path
        The videos.
    """
    from ..io import data_files as files

    if video_format == "browser":
        from ..core.video import browser_video_format

        try:
            video_format = browser_video_format(gif=False)
        except OSError as err:
            raise CLIError(f"--format browser: {err}; use .avi") from None
    folder = files.output_dir(out)
    for name in inputs:  # fail before any work on a bad input
        files.read_arrays(name, ["poses"], "pose file")
    _unique_stems(inputs, "input files")
    items = [(str(src), str(folder / (Path(src).stem + video_format)), fps, size, marker_size) for src in inputs]
    results = _over_files(_render_one, items, n_jobs, "render", quiet)
    for src, (video, n_frames) in zip(inputs, results):
        say(quiet, f"rendered {Path(src).name} ({n_frames} frames) -> {video} (+ camera JSON)")
    return [Path(v) for v, _ in results]


@reads_inputs
def calibrate(
    views: Sequence[str | Path],
    out: str | Path,
    *,
    pattern: tuple[int, int],
    square: float,
    plane: str | Path | None = None,
    fps: float | None = None,
    every: int = 10,
    quiet: bool = False,
) -> tuple[Any, dict[str, Any]]:
    """Lens distortion and the robot's plane from checkerboard views: a camera JSON at ``out``.

    Parameters
    ----------
    views : sequence of path
        Checkerboard images, folders of images or videos.
    out : path
        Camera JSON to write; name it ``<video>.camera.json`` to have ``extract`` find it.
    pattern : (columns, rows)
        Inner corners of the board.
    square : float
        Side of a square in metres.
    plane : path, optional
        Image of the board lying in the robot's plane; default the last view.
    fps : float, optional
        Frame rate stored in the JSON.
    every : int
        Every ``every``-th frame of a video or folder is a view.
    quiet : bool
        No messages.

    Returns
    -------
    camera : Camera
    report : dict
        :func:`~pcs_sindy.vision.calibration.calibrate_camera`'s report.
    """
    from ..vision.calibration import calibrate_camera, read_views

    for name in [*views, *([plane] if plane is not None else [])]:
        if not Path(name).exists():
            raise CLIError(f"view {str(name)!r} does not exist")
    images, names = read_views(views, every)
    if plane is not None:
        extra, extra_names = read_views([plane])
        images, names = images + extra[:1], names + extra_names[:1]
    camera, report = calibrate_camera(images, pattern, square, plane=-1, names=names)
    path = file_target(out, "camera.json")
    path.parent.mkdir(parents=True, exist_ok=True)
    extra_keys: dict[str, Any] = {"calibration": {k: v for k, v in report.items() if k != "pixels_per_metre"}}
    if fps is not None:
        extra_keys["fps"] = float(fps)
    camera.to_json(path, extra=extra_keys)
    if report["lens"]:
        lens = f"lens fitted on {report['views_used']} views, rms reprojection {report['rms_reprojection_px']:.3f} px"
    else:
        lens = "no lens fit (fewer than three views with a board): perspective only"
    missing = report["views_without_board"]
    say(
        quiet,
        f"calibrated {path}: {lens}; plane {camera.pixels_per_metre:.1f} px/m, plane view residual "
        f"{report['plane_reprojection_px']:.3f} px" + (f"; no board in {len(missing)} view(s)" if missing else ""),
    )
    return camera, report


def _extract_one(extractor: Any, video: str, progress: bool) -> tuple[Any, dict[str, Any], list[str]]:
    """Extract one video (module level so joblib can run it in a worker); its warnings returned as text."""
    import warnings

    extractor = extractor.set_params(progress=progress)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        traj = extractor.fit_transform([video])[0]
    return traj, extractor.diagnostics_[0], [str(w.message) for w in caught]


@reads_inputs
def extract(
    videos: Sequence[str | Path],
    out: str | Path,
    *,
    camera: str | Path | None = None,
    n_markers: int | None = None,
    robot_length: float | None = None,
    fps: float | None = None,
    reference_frame: Any = None,
    threshold: Any = None,
    polarity: str | None = None,
    blur: int | None = None,
    roi: tuple[int, int, int, int] | None = None,
    min_area: float | None = None,
    marker_area: float | None = None,
    area_tolerance: tuple[float, float] | None = None,
    aspect_tolerance: float | None = None,
    base_position: tuple[float, float] | None = None,
    pixels_per_metre: float | None = None,
    rest_direction: float | None = None,
    on_missing: str | None = None,
    refine: bool | None = None,
    fill_missing: bool | None = None,
    plot: bool = False,
    n_jobs: int = 1,
    quiet: bool = False,
) -> list[Path]:
    """Extract marker poses from videos: one pose file per video in ``out``.

    Parameters
    ----------
    videos : sequence of path
        Videos or folders of image frames (a folder is one recording; single image files are refused:
        give their folder).
    out : path
        Output folder (created); one pose file per video, same stem.
    camera : path, optional
        Camera JSON for every video, honoured in full (``fps`` and ``n_frames`` included; ``image_size``
        may be left out); default: each video's ``<video>.camera.json`` (a folder's ``camera.json``),
        else calibration.
    n_markers, robot_length, fps, reference_frame, threshold, polarity, blur, roi, min_area : optional
    marker_area, area_tolerance, aspect_tolerance, base_position, pixels_per_metre : optional
    rest_direction, on_missing, refine, fill_missing : optional
        Parameters of :func:`make_pcs_pipeline`'s ``poses`` step
        (:class:`~pcs_sindy.vision.extractor.MarkerPoseExtractor`, which checks them; ``rest_direction``
        in radians as there); None: its default.
    plot : bool
        Also draw ``<stem>.inspect.png`` per video in ``out`` (:func:`~pcs_sindy.cli.sheet.inspect_video`).
    n_jobs : int
        Videos extracted in parallel (joblib; -1: all cores).
    quiet : bool
        No progress bars or messages.

    Returns
    -------
    list of Path
        The pose files.
    """
    import warnings

    from sklearn.base import clone

    from ..core.atomic import FileSet
    from ..io import data_files as files
    from ..vision.extractor import share_scale
    from ..vision.frame_source import group_image_files

    if camera is not None and not Path(camera).is_file():
        raise CLIError(f"camera file {str(camera)!r} does not exist")
    for name in videos:
        if not Path(name).exists():
            raise CLIError(f"video {str(name)!r} does not exist")
    try:
        group_image_files(videos)
    except ValueError as err:
        raise CLIError(str(err)) from None
    _unique_stems(videos, "videos")
    options = dict(
        n_markers=n_markers,
        robot_length=robot_length,
        fps=fps,
        reference_frame=reference_frame,
        threshold=threshold,
        polarity=polarity,
        blur=blur,
        roi=roi,
        min_area=min_area,
        marker_area=marker_area,
        area_tolerance=area_tolerance,
        aspect_tolerance=aspect_tolerance,
        base_position=base_position,
        pixels_per_metre=pixels_per_metre,
        rest_direction=rest_direction,
        on_missing=on_missing,
        refine=refine,
        fill_missing=fill_missing,
    )
    extractor = pipeline_step("poses", camera=None if camera is None else str(camera), **options)
    extractor.fit()  # every option and the camera JSON checked before any work
    folder = files.output_dir(out)
    results = _over_files(_extract_one, [(clone(extractor), str(v)) for v in videos], n_jobs, "extract", quiet)
    # the videos of one call are one set-up: one scale when each was scaled from its own reference frame
    with warnings.catch_warnings(record=True) as shared:
        warnings.simplefilter("always")
        trajs = share_scale([tr for tr, _, _ in results], [diag for _, diag, _ in results])
    results = [(tr, diag, caught) for tr, (_, diag, caught) in zip(trajs, results)]
    for w in shared:
        _warn(str(w.message))
    paths = []
    with FileSet(folder) as outputs:  # the pose files of one call: all new or all old
        for name, (tr, _, _) in zip(videos, results):
            rest = tr.metadata.get("rest_length")
            paths.append(
                files.write_poses(folder / (Path(name).stem + ".npz"), tr.t, tr.poses, rest_length=rest, into=outputs)
            )
    for name, (tr, diag, caught), path in zip(videos, results, paths):
        for message in caught:  # raised in a worker: shown here, once
            _warn(message)
        repaired = len(diag["frames_repaired"])
        outliers = diag.get("outlier_frames", {})
        if outliers:
            shown = "; ".join(f"frame {k}: marker(s) {v}" for k, v in list(outliers.items())[:6])
            _warn(
                f"{Path(name).name}: {len(outliers)} frame(s) have a marker far off its own track ({shown}"
                f"{' ...' if len(outliers) > 6 else ''}): look at them with 'pcs-sindy inspect'"
            )
        say(
            quiet,
            f"extracted {Path(name).name}: {tr.n_frames} frames, {tr.n_markers} markers"
            f"{f', {repaired} frames interpolated' if repaired else ''}"
            f"{f', {len(outliers)} with a marker off its track' if outliers else ''} ({diag['calibration']}) -> {path}",
        )
    if plot:
        from .sheet import inspect_video

        for name, (tr, diag, _) in zip(videos, results):
            inspect_video(name, folder, camera=camera, quiet=quiet, extracted=(tr, diag), **options)
    return paths


def _warn(message: str) -> None:
    import warnings

    warnings.warn(message, UserWarning, stacklevel=3)


@reads_inputs
def fuse(
    poses: Sequence[str | Path],
    out: str | Path,
    *,
    threshold: float | str | None = None,
    total_length: float | None = None,
    shape_fit: str | None = None,
    n_jobs: int | None = None,
    quiet: bool = False,
    markers_csv: Sequence[str | Path] | None = None,
    markers: Sequence[str] | None = None,
    rate: float | None = None,
    units: str | None = None,
    input_columns: Sequence[str] | None = None,
    arc_lengths: Sequence[float] | None = None,
    inputs: Sequence[str | Path] | None = None,
    space: str | None = None,
    orientations: bool = False,
) -> tuple[Any, list[Any], list[Any]]:
    """Kinematic fusion of pose files: ``segmentation.json`` and one strain file per pose file in ``out``.

    With ``markers_csv`` (instead of pose files): motion-capture CSV files of marker positions
    (:func:`pcs_sindy.io.read_marker_csv` with ``markers``, ``rate``, ``units`` and the input
    columns ``input_columns``, whose values go to ``out/inputs/<stem>.npz`` for ``fit --inputs``),
    fused from positions alone (``arc_lengths``: the markers' measured rest arc lengths).  The
    inputs may come from separate logs instead, ``inputs`` (one per CSV file, in order; CSV, ``.npy``
    or ``.npz``, :func:`pcs_sindy.io.read_input_log`), put on the capture's samples row for row or by
    the log's frame/index or time column (:func:`pcs_sindy.io.align_inputs`); ``input_columns`` then
    chooses columns of the logs.  ``out/capture.json`` records the markers, rate and units for
    ``rollout --truth <capture.csv>``.  The fusion is planar (the markers' best-fit plane) or 3-D
    (``space``: ``"auto"``, the default, ``"plane"`` or ``"3d"``, see
    :class:`~pcs_sindy.fusion.KinematicFusion`); ``orientations`` also reads each marker's quaternion
    columns (``qx1, qy1, qz1, w1``) for a 3-D fusion with torsion.

    Parameters
    ----------
    poses : sequence of path
        Pose files (recordings qualify).
    out : path
        Output folder (created).
    threshold, total_length, shape_fit, n_jobs : optional
        Parameters of :func:`make_pcs_pipeline`'s ``segments`` step
        (:class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion`); None: its default.
    quiet : bool
        No progress bars or messages.

    Returns
    -------
    fusion : KinematicFusion
    strains : list of StrainTrajectory
    pose_trajectories : list of PoseTrajectory
    """
    from ..core.atomic import FileSet
    from ..core.trajectory import PoseTrajectory
    from ..io import data_files as files

    if bool(markers_csv) == bool(poses):
        raise CLIError("give either pose files or --markers-csv files (not both)")
    if inputs and not markers_csv:
        raise CLIError("--inputs (input logs) go with --markers-csv; pose files' forces go to 'fit --tau'")
    if markers_csv:
        return _fuse_marker_csv(
            markers_csv,
            out,
            markers,
            rate,
            units,
            input_columns,
            arc_lengths,
            threshold,
            n_jobs,
            quiet,
            inputs,
            space=space,
            orientations=orientations,
        )
    if space is not None or orientations:
        raise CLIError("--space and --orientations apply to --markers-csv files (pose files are planar)")
    trajs = []
    for name in poses:
        t, arr = files.read_poses(name)
        meta: dict[str, Any] = {"source": str(name)}
        rest = files.read_rest_length(name)
        if rest is not None:
            meta["rest_length"] = rest
        try:
            trajs.append(PoseTrajectory(arr, t, dt=None if t is not None else 1e-3, metadata=meta))
        except ValueError as err:
            raise CLIError(f"pose file {str(name)!r}: {err}") from None
    _unique_stems(poses, "pose files")
    folder = files.output_dir(out)
    fusion = pipeline_step(
        "segments",
        threshold=threshold,
        total_length=total_length,
        shape_fit=shape_fit,
        n_jobs=n_jobs,
        progress=not quiet,
    )
    strains = fusion.fit(trajs).transform(trajs)
    with FileSet(folder) as outputs:  # segmentation and strain files: all new or all old
        for name, st in zip(poses, strains):
            files.write_strains(folder / (Path(name).stem + ".npz"), st, into=outputs)
        seg = files.write_model_file(fusion, folder / "segmentation.json", into=outputs)
    lengths = ", ".join(f"{v:.4f}" for v in fusion.segment_lengths_)
    say(
        quiet,
        f"{fusion.n_segments_} segment(s), lengths [{lengths}] m (total {fusion.total_length_:.4f} m), "
        f"threshold h = {fusion.threshold_:.3g}"
        + ("" if fusion.threshold_choice_["rule"] == "given" else f" ({fusion.threshold_choice_['reason']})"),
    )
    if fusion.total_length_source_.startswith("estimated"):  # a hanging robot reads long by its gravity stretch
        say(
            quiet,
            f"note: the rest length was estimated as the median deformed length (standard error "
            f"{1e3 * fusion.total_length_std_:.2f} mm), which biases every length and strain of a stretched robot "
            "('fit' absorbs it in rest strains): pass --total-length, or --robot-length to 'extract'",
        )
    say(quiet, f"segmentation -> {seg}; {len(strains)} strain file(s) -> {folder}")
    return fusion, strains, trajs


def _fuse_marker_csv(
    csv_files: Sequence[str | Path],
    out: str | Path,
    markers: Sequence[str] | None,
    rate: float | None,
    units: str | None,
    input_columns: Sequence[str] | None,
    arc_lengths: Sequence[float] | None,
    threshold: float | None,
    n_jobs: int | None,
    quiet: bool,
    logs: Sequence[str | Path] | None = None,
    *,
    space: str | None = None,
    orientations: bool = False,
) -> tuple[Any, list[Any], list[Any]]:
    """:func:`fuse` of motion-capture CSV files (positions, and orientations with ``orientations``);
    ``logs``: their input logs."""
    import warnings

    import numpy as np

    from ..core.atomic import FileSet
    from ..core.trajectory import PoseTrajectory
    from ..io import data_files as files
    from ..io.marker_csv import align_inputs, read_input_log, read_marker_csv

    if not markers or rate is None:
        raise CLIError("--markers-csv needs --markers (names, base to tip) and --rate (the nominal rate in Hz)")
    if logs and len(logs) != len(csv_files):
        raise CLIError(
            f"got {len(csv_files)} --markers-csv file(s) but {len(logs)} --inputs file(s): give one input log per "
            "capture, in the same order"
        )
    _unique_stems(csv_files, "marker CSV files")
    trajs, inputs, plane, input_names, detected_units = [], [], None, list(input_columns or []), []
    for k, name in enumerate(csv_files):
        try:
            data = read_marker_csv(
                name,
                markers,
                rate=rate,
                units=units,
                inputs=None if logs else input_columns,
                orientations=orientations,
            )
            if logs:
                log = read_input_log(logs[k], input_columns)
                data.inputs = align_inputs(
                    log, data.positions.shape[0], data.dt, data.metadata.get("first_frame"), str(name)
                )
                input_names = log.names
            tr = PoseTrajectory.from_positions(
                data.positions,
                dt=data.dt,
                arc_lengths=arc_lengths,
                plane=plane,
                metadata={"source": str(name)},
                rotations=data.rotations,
            )
        except ValueError as err:
            raise CLIError(str(err)) from None
        plane = tr.plane  # every file of one set-up in the first file's plane
        trajs.append(tr)
        inputs.append(data.inputs)
        detected_units.append(data.units)
        say(
            quiet,
            f"{name}: {tr.n_frames} samples, out-of-plane RMS {1e3 * tr.metadata['out_of_plane_rms']:.2f} mm, "
            f"{tr.metadata['frozen_samples']} frozen and {tr.metadata['jump_samples']} jump samples set missing",
        )
    folder = files.output_dir(out)
    fusion = pipeline_step("segments", threshold=threshold, n_jobs=n_jobs, progress=not quiet, space=space)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the out-of-plane warning: the fused model says which it is
        strains = fusion.fit(trajs).transform(trajs)
    three_d = fusion.space_ == "3d"
    if any(u is not None for u in inputs):  # the logged inputs, for 'fit --inputs': all new or all old
        in_folder = files.output_dir(folder / "inputs")
        with FileSet(in_folder) as logged:
            for name, st, u in zip(csv_files, strains, inputs):
                files.write_tau(in_folder / (Path(name).stem + ".npz"), st.t, u, into=logged, key="u")
    has_inputs = any(u is not None for u in inputs)
    capture = {  # how the captures were read: 'rollout --truth <capture.csv>' reads them the same way
        "markers": list(markers),
        "rate": float(rate),
        "units": detected_units[0],
        "input_columns": input_names if has_inputs else None,
        "files": [str(name) for name in csv_files],
        "input_logs": [str(name) for name in logs] if logs else None,
    }
    with FileSet(folder) as outputs:  # segmentation, strain files and capture.json: all new or all old
        for name, st in zip(csv_files, strains):
            files.write_strains(folder / (Path(name).stem + ".npz"), st, into=outputs)
        seg = files.write_model_file(fusion, folder / "segmentation.json", into=outputs)
        outputs.write_text(folder / "capture.json", json.dumps(capture, indent=2) + "\n")
    if has_inputs and not three_d:  # tendon sides are those of a plane
        from ..fusion.position_fusion import tendon_sides

        sides = tendon_sides(strains, inputs)
        say(
            quiet,
            "inputs bend the robot towards "
            + ", ".join(f"{c}: {'negative' if v > 0 else 'positive'}" for c, v in zip(input_names, sides))
            + f" curvature (tendons: \"side\": {sides} in the --actuation JSON of 'fit')",
        )
    arcs = ", ".join(f"{1e3 * v:.1f}" for v in fusion.marker_arc_lengths_[1:])
    if three_d:
        say(
            quiet,
            f"3-D fusion (space={fusion.space!r}): marker RMS {1e3 * fusion.position_rms_:.2f} mm, base at "
            f"{np.round(fusion.base_pose_[:3, 3], 4).tolist()} m pointing "
            f"{np.round(fusion.base_pose_[:3, 1], 3).tolist()}"
            + ("" if fusion.rotation_rms_ is None else f", orientation RMS {np.rad2deg(fusion.rotation_rms_):.2f} deg"),
        )
    say(
        quiet,
        f"{fusion.n_segments_} {'3-D ' if three_d else ''}bending segment(s), lengths "
        f"[{', '.join(f'{v:.4f}' for v in fusion.segment_lengths_)}] m; marker arc lengths [{arcs}] mm "
        f"({fusion.total_length_source_}); segmentation -> {seg}; strain files -> {folder}"
        + ("; inputs -> " + str(folder / "inputs") if has_inputs else ""),
    )
    return fusion, strains, trajs


def build_regressor(
    *,
    library: str | None = None,
    formulation: str | None = None,
    window_length: int | None = None,
    polyorder: int | None = None,
    exclude_force_jumps: bool | None = None,
    weak_window: int | None = None,
    weak_stride: int | None = None,
    rest_strain: bool | None = None,
    rotary_inertia: str | None = None,
    stiffness_threshold: float | None = None,
) -> Any:
    """The ``dynamics`` step of :func:`make_pcs_pipeline` with the given settings (None: its default).

    Parameters
    ----------
    library : {"physical", "monomial"}, optional
        The regressor's ``library``.
    formulation, window_length, polyorder, exclude_force_jumps, weak_window, weak_stride : optional
        Parameters of :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`.
    rest_strain, rotary_inertia : optional
        Parameters of the library (:class:`~pcs_sindy.identification.library.physical.PhysicalPCSLibrary`).
    stiffness_threshold : float, optional
        The optimizer's ``threshold``: a factor on the material bound (inf: no strain removed).

    Returns
    -------
    EulerLagrangeRegressor
        Not fitted.

    Raises
    ------
    CLIError
        If a library option is given for a library that does not have it.
    """
    if library == "monomial":  # the seed's monomial library derives its equations with sympy
        from ..core.optional import require_installed

        require_installed("sympy", "the monomial library (--library monomial)")
    reg = pipeline_step(
        "dynamics",
        feature_library=library,
        formulation=formulation,
        window_length=window_length,
        polyorder=polyorder,
        exclude_force_jumps=exclude_force_jumps,
        weak_window=weak_window,
        weak_stride=weak_stride,
    )
    lib_options = _given(rest_strain=rest_strain, rotary_inertia=rotary_inertia)
    if lib_options:
        lib = reg.make_library()  # the chosen (or default) library, fresh
        unknown = [k for k in lib_options if k not in lib.get_params()]
        if unknown:
            opts = ", ".join("--" + k.replace("_", "-") for k in unknown)
            raise CLIError(
                f"{opts}: not an option of the {reg.feature_library or 'default'} library ({type(lib).__name__})"
            )
        reg.set_params(feature_library=lib.set_params(**lib_options))
    if stiffness_threshold is not None:
        reg.set_params(optimizer__threshold=stiffness_threshold)
    return reg


@reads_inputs
def fit(
    strains: Sequence[str | Path],
    tau: Sequence[str | Path] | None,
    out: str | Path,
    *,
    inputs: Sequence[str | Path] | None = None,
    actuation: str | Path | dict | None = None,
    library: str | None = None,
    formulation: str | None = None,
    window_length: int | None = None,
    polyorder: int | None = None,
    exclude_force_jumps: bool | None = None,
    weak_window: int | None = None,
    weak_stride: int | None = None,
    rest_strain: bool | None = None,
    rotary_inertia: str | None = None,
    stiffness_threshold: float | None = None,
    pair_by: str = "name",
    quiet: bool = False,
) -> Any:
    """Identify the dynamics from strain files and tau files; write the model file ``out`` (JSON + .npz).

    Parameters
    ----------
    strains : sequence of path
        Strain files (written by :func:`fuse`).
    tau : sequence of path or None
        Tau files (recordings qualify), matched to the strain files by name (see ``pair_by``).
    out : path
        Model file (``model.json`` + ``model.npz``).
    inputs : sequence of path, optional
        Instead of ``tau``: files of actuator inputs (``t``, ``u``), matched like ``tau``; needs ``actuation``.
    actuation : path or dict, optional
        The actuation layout (JSON file, see :func:`pcs_sindy.io.data_files.read_layout`, or the dict itself).
    library, formulation, window_length, polyorder, exclude_force_jumps : optional
    weak_window, weak_stride, rest_strain, rotary_inertia, stiffness_threshold : optional
        As :func:`build_regressor`; None: the default of :class:`~pcs_sindy.identification.EulerLagrangeRegressor`.
    pair_by : {"name", "order"}
        Tau files belong to strain files by name (or are refused, showing the pairing), or by order
        (:func:`pcs_sindy.io.data_files.pair_files`).
    quiet : bool
        Print nothing (else the pairing, the equations, stiffness and damping).

    Returns
    -------
    EulerLagrangeRegressor
        The fitted model.
    """
    from ..core.units import SECOND, generalised_force_unit, strain_unit
    from ..io import data_files as files

    if (tau is None) == (inputs is None):
        raise CLIError("give the forces (--tau) or the actuator inputs (--inputs with --actuation), not both")
    if inputs is not None and actuation is None:
        raise CLIError("--inputs needs --actuation (the layout the inputs act through)")
    layout = files.read_layout(actuation) if isinstance(actuation, (str, Path)) else actuation
    forces = tau if tau is not None else inputs
    skipped = files.model_file_arrays(strains)
    if skipped:  # e.g. the quickstart's strains/*.npz catches segmentation.npz
        if len(skipped) == len(strains):
            raise CLIError(f"{[str(p) for p in skipped]} are model files' arrays, not strain files")
        _warn(
            f"skipping {', '.join(map(str, skipped))}: the array file of a model file (its .json beside it), "
            "not a strain file"
        )
        strains = [s for s in strains if Path(s) not in skipped]
    pairs = files.pair_files(strains, forces, pair_by, "tau" if tau is not None else "input")
    data, taus = files.read_training_files(strains, forces, key="tau" if tau is not None else "u", pairing=pair_by)
    if not quiet and len(pairs) > 1:
        say(quiet, "pairing: " + "; ".join(f"{Path(a).name} <- {b}" for a, b in pairs))
    model = build_regressor(
        library=library,
        formulation=formulation,
        window_length=window_length,
        polyorder=polyorder,
        exclude_force_jumps=exclude_force_jumps,
        weak_window=weak_window,
        weak_stride=weak_stride,
        rest_strain=rest_strain,
        rotary_inertia=rotary_inertia,
        stiffness_threshold=stiffness_threshold,
    )
    if layout is not None:
        model.set_params(actuation=layout)
    from ..identification.regressor import PoorFitWarning

    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", PoorFitWarning)  # a model worse than no model is not written
            model.fit(data, taus)
    except PoorFitWarning as err:
        raise CLIError(f"{err}; no model written") from None
    seconds = time.perf_counter() - start
    target = file_target(out, "model.json")
    path = files.write_model_file(model, files.output_dir(target.parent) / target.name)
    if not quiet:
        names = model.kinematics_.strain_names(active_only=False)
        say(
            quiet,
            f"identified in {seconds:.1f} s from {len(data)} recording(s), "
            f"{model.n_regression_samples_} samples; removed strains: {model.removed_strains_ or 'none'}",
        )
        model.print()
        force = [generalised_force_unit(nm) / strain_unit(nm) for nm in names]  # K q and D qd are forces
        say(quiet, "stiffness: " + ", ".join(f"{nm} {k:.4g} {u}" for nm, k, u in zip(names, model.stiffness_, force)))
        say(
            quiet,
            "damping:   " + ", ".join(f"{nm} {d:.4g} {u * SECOND}" for nm, d, u in zip(names, model.damping_, force)),
        )
        say(quiet, f"model -> {path}")
    return model


@dataclass
class RolloutResult:
    """What :func:`rollout` computed: the strains, the predicted poses and the metrics written to ``metrics.json``.

    ``positions`` are the predicted marker positions in the capture frame when the truth was a
    motion-capture CSV (else None).
    """

    sim: Any
    poses: np.ndarray
    marker_arc_lengths: np.ndarray
    metrics: dict[str, Any] = field(default_factory=dict)
    positions: np.ndarray | None = None


#: suffixes of a motion-capture truth (read by :func:`pcs_sindy.io.read_marker_csv`)
_CAPTURE_SUFFIXES = (".csv", ".tsv", ".txt")

#: units of the numbers rollout writes to metrics.json
_METRIC_UNITS = {
    "duration_s": "s",
    "rollout_seconds": "s",
    "e_p_ee_mm": "mm",
    "e_theta_ee_rad": "rad",
    "e_p_dist_mm": "mm",
    "e_theta_dist_rad": "rad",
    "tip_position_rmse_mm": "mm",
    "tip_position_mean_mm": "mm",
    "tip_position_max_mm": "mm",
    "marker_position_mean_mm": "mm",
}


def _capture_settings(segmentation_path: str | Path | None) -> dict[str, Any]:
    """``capture.json`` beside a segmentation file (written by ``fuse --markers-csv``), or {}."""
    if segmentation_path is None:
        return {}
    path = Path(segmentation_path).with_name("capture.json")
    if not path.is_file():
        return {}
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise CLIError(f"cannot read {str(path)!r}: {err}") from None
    return doc if isinstance(doc, dict) else {}


def _strain_units(names: Sequence[str]) -> dict[str, str]:
    """The unit of each strain as metrics.json writes it: ``1/m`` for curvatures and twist, ``-`` otherwise."""
    from ..core.units import strain_unit

    return {nm: "-" if strain_unit(nm).dimensionless else str(strain_unit(nm)) for nm in names}


def _rotation_angles(R_a: Any, R_b: Any) -> Any:
    """The angle [rad] of the relative rotation of two stacks of rotations (..., 3, 3)."""
    import numpy as np

    # sin and cos of the angle from the skew and symmetric parts: accurate at small angles (arccos is not)
    rel = np.einsum("...ji,...jk->...ik", R_a, R_b)
    skew = np.stack([rel[..., 2, 1] - rel[..., 1, 2], rel[..., 0, 2] - rel[..., 2, 0], rel[..., 1, 0] - rel[..., 0, 1]])
    return np.arctan2(0.5 * np.linalg.norm(skew, axis=0), 0.5 * (np.trace(rel, axis1=-2, axis2=-1) - 1.0))


def _strain_rmse(names: Sequence[str], q_pred: Any, q_true: Any, keep: Any) -> dict[str, float]:
    """RMS difference of each modelled strain (``keep``) over the frames where the truth is finite."""
    import numpy as np

    out = {}
    for k in np.flatnonzero(keep):
        ok = np.isfinite(q_true[:, k])
        out[names[k]] = float(np.sqrt(np.mean((q_pred[ok, k] - q_true[ok, k]) ** 2)))
    return out


@reads_inputs
def rollout(
    model: Any,
    tau: str | Path,
    out: str | Path,
    *,
    segmentation: Any = None,
    truth: str | Path | None = None,
    initial: str | Path | None = None,
    n_markers: int = 20,
    method: str | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    plot: bool = True,
    quiet: bool = False,
    markers: Sequence[str] | None = None,
    rate: float | None = None,
    units: str | None = None,
) -> RolloutResult:
    """Simulate a model under the forces of a tau file; ``rollout.npz`` (and metrics against a truth) in ``out``.

    Parameters
    ----------
    model : path or EulerLagrangeRegressor
        Model file (written by :func:`fit`) or a fitted model.
    tau : path
        Tau file (recordings qualify); for a model with an actuation, its input file (``t``, ``u``).
    out : path
        Output folder (created).
    segmentation : path or KinematicFusion, optional
        Gives the marker arc lengths; else those of ``truth``, else ``n_markers`` equally spaced markers.
    truth : path, optional
        What the prediction is compared with (writes ``metrics.json``, and ``rollout.png`` shows the
        tip against it with the error over time):

        * a pose file or recording (``'poses_true'`` when present, else ``'poses'``);
        * a strain file (``q`` and ``segment_lengths``, written by :func:`fuse`): the strains, and the
          poses both give at the marker arc lengths (``rollout_strains.png`` adds the strains);
        * a motion-capture CSV (``.csv``, ``.tsv``, ``.txt``; :func:`pcs_sindy.io.read_marker_csv`), with
          the positions-only ``segmentation`` written by ``fuse --markers-csv``: the prediction is mapped
          to the capture frame (:meth:`KinematicFusion.inverse_transform`) and compared with the
          measured markers (samples the tracker lost or froze left out).
    initial : path or "truth", optional
        Strain file whose first frame is ``q0`` (default: rest); ``"truth"``: the first frame of a
        strain-file or capture ``truth`` (a capture's fused in ``segmentation``); ``qd0 = 0``.
    method : str, optional
        One of the model's ``forward_model().methods``; default its ``default_method``.
    rtol, atol : float, optional
        Default: the model's.
    plot : bool
        Draw ``rollout.png``.
    quiet : bool
        No progress bar or messages.
    markers, rate, units : optional
        How a CSV ``truth`` is read (marker names base to tip, rate [Hz], length units); default:
        ``capture.json`` beside the segmentation file (written by ``fuse --markers-csv``), the rate
        else from the tau file's time stamps, the units else from the file.

    Returns
    -------
    RolloutResult
    """
    import numpy as np

    from ..core.atomic import FileSet
    from ..core.metrics import distributed_errors, end_effector_errors
    from ..core.spatial import SpatialPCS
    from ..fusion.kinematic_fusion import KinematicFusion
    from ..identification.regressor import EulerLagrangeRegressor
    from ..io import data_files as files
    from .report import rollout_figure, spatial_rollout_figure, strains_figure

    if plot:  # before the rollout: a missing matplotlib is said at once
        from ..core.optional import MissingDependencyError, require_installed

        try:
            require_installed("matplotlib", "rollout.png")
        except MissingDependencyError as err:
            raise CLIError(f"{err}; or --no-plot") from None
    model_name = str(model) if not isinstance(model, EulerLagrangeRegressor) else "(in memory)"
    if not isinstance(model, EulerLagrangeRegressor):
        model = files.read_model_file(model, EulerLagrangeRegressor, "model file")
    segmentation_path = None
    if segmentation is not None and not isinstance(segmentation, KinematicFusion):
        segmentation_path = segmentation
        segmentation = files.read_model_file(segmentation, KinematicFusion, "segmentation file")
    actuated = getattr(model, "actuation_", None) is not None and model.actuation_.layout()["type"] != "identity"
    t, u = files.read_tau(tau, "u" if actuated else "tau")
    kin = model.kinematics_
    n = kin.n_q
    spatial = isinstance(kin, SpatialPCS)  # a 3-D model: positions and rotations, not planar poses
    if not actuated and u.shape[1] != n:
        raise CLIError(
            f"tau file {str(tau)!r} has {u.shape[1]} force columns; the model has {n} strains "
            f"({kin.n_segments} segment(s) x {n // kin.n_segments})"
        )
    forward = model.forward_model()
    if method is not None and method not in forward.methods:
        raise CLIError(f"--method {method!r}: this model ({type(forward).__name__}) supports {list(forward.methods)}")
    kind, true_poses, true_q, capture = None, None, None, None
    if truth is not None:
        if Path(truth).suffix.lower() in _CAPTURE_SUFFIXES:
            kind = "capture"
            if spatial and segmentation is not None and getattr(segmentation, "space_", "plane") != "3d":
                raise CLIError(
                    f"--truth {str(truth)!r} is a motion-capture CSV and the model is spatial (3-D): give the "
                    "segmentation.json of a 3-D fusion ('fuse --markers-csv' of a recording that leaves its plane, "
                    "or --space 3d); this segmentation is planar"
                )
            if segmentation is None or not getattr(segmentation, "positions_only_", False):
                raise CLIError(
                    f"--truth {str(truth)!r} is a motion-capture CSV: give --segmentation, the segmentation.json "
                    "that 'fuse --markers-csv' wrote (it maps the model's frame to the capture frame)"
                )
            settings = _capture_settings(segmentation_path)
            markers = markers or settings.get("markers")
            if not markers:
                raise CLIError(
                    f"--truth {str(truth)!r}: give --markers (the marker names, base to tip), or keep the "
                    "capture.json that 'fuse --markers-csv' wrote beside the segmentation file"
                )
            if rate is None:
                rate = settings.get("rate") or (1.0 / float(np.median(np.diff(t))) if t.size > 1 else None)
            if rate is None:
                raise CLIError(f"--truth {str(truth)!r}: give --rate (the capture rate in Hz)")
            capture = _read_capture_truth(truth, segmentation, markers, rate, units or settings.get("units"), t.size)
        else:
            keys = files.read_arrays(truth, [], "truth file", optional=["poses_true", "poses", "q", "segment_lengths"])
            if (
                spatial
                and ("poses_true" in keys or "poses" in keys)
                and not ("q" in keys and "segment_lengths" in keys)
            ):
                raise CLIError(
                    f"truth file {str(truth)!r} holds planar poses; a spatial model is compared with a strain "
                    "file (q and segment_lengths) of the same segmentation"
                )
            if not spatial and ("poses_true" in keys or "poses" in keys):
                kind = "poses"
                true_poses = files.read_poses(truth, "poses_true" if "poses_true" in keys else "poses")[1]
                frames = true_poses.shape[0]
            elif "q" in keys and "segment_lengths" in keys:
                kind = "strains"
                measured = files.read_strains(truth)
                if measured.kinematics.n_q != n:
                    raise CLIError(
                        f"truth file {str(truth)!r} has {measured.kinematics.n_q} strains; the model has {n}"
                    )
                lengths = np.asarray(measured.segment_lengths, dtype=float)
                if not np.allclose(lengths, kin.segment_lengths, rtol=1e-6, atol=0.0):
                    raise CLIError(
                        f"truth file {str(truth)!r} has segment lengths {lengths.tolist()} m; the model's are "
                        f"{list(map(float, kin.segment_lengths))} m: strains of other segments cannot be compared"
                    )
                true_q, frames = measured.q, measured.n_frames
            else:
                with np.load(truth, allow_pickle=False) as found:  # read_arrays checked it is an .npz
                    names = sorted(found.files)
                raise CLIError(
                    f"truth file {str(truth)!r} holds neither poses ('poses_true' or 'poses') nor strains ('q' and "
                    f"'segment_lengths'); found {names}"
                )
            if frames != t.shape[0]:
                raise CLIError(
                    f"truth file {str(truth)!r} has {frames} frames but tau file {str(tau)!r} has {t.shape[0]}"
                )
    q0, qd0 = np.zeros(n), np.zeros(n)
    if initial == "truth":  # the measured first frame: a strain file's, or a capture's fused in the segmentation
        if kind not in ("strains", "capture"):
            raise CLIError("--initial truth needs a --truth strain file or motion-capture CSV (their first frame)")
        q0 = (true_q if kind == "strains" else capture["strains"].q)[0].copy()
    elif initial is not None:
        st = files.read_strains(initial)
        if st.kinematics.n_q != n:
            raise CLIError(f"initial strain file {str(initial)!r} has {st.kinematics.n_q} strains; the model has {n}")
        q0 = st.q[0]
    total = float(np.sum(kin.segment_lengths))
    if segmentation is not None:
        s = np.clip(np.asarray(segmentation.marker_arc_lengths_, dtype=float), 0.0, total)
    else:
        s = np.linspace(0.0, total, (true_poses.shape[1] - 1 if true_poses is not None else n_markers) + 1)
    if true_poses is not None and true_poses.shape[1] != s.size:
        raise CLIError(
            f"truth file {str(truth)!r} has {true_poses.shape[1] - 1} markers; the segmentation has {s.size - 1}"
        )
    folder = files.output_dir(out)
    start = time.perf_counter()
    sim = model.simulate(q0, qd0, t, u, method=method, rtol=rtol, atol=atol, progress=not quiet)
    seconds = time.perf_counter() - start
    poses = sim.poses(s)  # planar (T, K, 3) poses, or spatial (positions (T, K, 3), rotations (T, K, 3, 3))
    names = sim.kinematics.strain_names(active_only=False)
    removed = set(getattr(model, "removed_strains_", None) or ())
    modelled = np.asarray(sim.kinematics.active_mask) & np.array([nm not in removed for nm in names])
    metrics: dict[str, Any] = {
        "model": model_name,
        "tau": str(tau),
        "duration_s": float(t[-1] - t[0]),
        "rollout_seconds": round(seconds, 3),
        "n_markers": int(s.size - 1),
        "method": method or forward.default_method,
    }
    positions = None
    if kind == "strains":  # the measured strains' own poses, in the prediction's frame
        true_poses = sim.kinematics.forward_kinematics(true_q, s)
    if true_poses is not None and spatial:
        # the seed's errors in 3-D: position distances, and the angles of the relative rotations
        dist = np.linalg.norm(poses[0][:, 1:] - true_poses[0][:, 1:], axis=-1)
        angle = _rotation_angles(poses[1][:, 1:], true_poses[1][:, 1:])
        e_p, e_th, d_p, d_th = (
            float(dist[:, -1].mean()),
            float(angle[:, -1].mean()),
            float(dist.mean()),
            float(angle.mean()),
        )
        tip_err = dist[:, -1]
        metrics.update(
            truth=str(truth),
            truth_kind=kind,
            e_p_ee_mm=1e3 * e_p,
            e_theta_ee_rad=e_th,
            e_p_dist_mm=1e3 * d_p,
            e_theta_dist_rad=d_th,
            tip_position_rmse_mm=1e3 * float(np.sqrt(np.mean(tip_err**2))),
            tip_position_max_mm=1e3 * float(tip_err.max()),
        )
    elif true_poses is not None:
        e_p, e_th = end_effector_errors(poses[:, 1:], true_poses[:, 1:])
        d_p, d_th = distributed_errors(poses[:, 1:], true_poses[:, 1:])
        tip_err = np.linalg.norm(poses[:, -1, :2] - true_poses[:, -1, :2], axis=1)
        # the units in the keys, the numbers as printed (mm, rad)
        metrics.update(
            truth=str(truth),
            truth_kind=kind,
            e_p_ee_mm=1e3 * e_p,
            e_theta_ee_rad=e_th,
            e_p_dist_mm=1e3 * d_p,
            e_theta_dist_rad=d_th,
        )
        metrics.update(
            tip_position_rmse_mm=1e3 * float(np.sqrt(np.mean(tip_err**2))),
            tip_position_max_mm=1e3 * float(tip_err.max()),
        )
    if kind == "strains":
        rmse = _strain_rmse(names, sim.q, true_q, modelled)
        metrics["strain_rmse"] = rmse
        metrics.setdefault("units_of", {})["strain_rmse"] = _strain_units(rmse)
    if kind == "capture":
        positions, rmse = _capture_prediction(sim, segmentation, capture)
        measured_pos = capture["positions"]
        ok = np.all(np.isfinite(measured_pos[:, -1]), axis=1)
        tip_err = np.linalg.norm(positions[ok, -1] - measured_pos[ok, -1], axis=1)
        every = np.linalg.norm(positions - measured_pos, axis=2)
        metrics.update(
            truth=str(truth),
            truth_kind="capture",
            frame="capture",
            n_samples=int(t.size),
            n_samples_measured=int(ok.sum()),
            tip_position_rmse_mm=1e3 * float(np.sqrt(np.mean(tip_err**2))),
            tip_position_mean_mm=1e3 * float(np.mean(tip_err)),
            tip_position_max_mm=1e3 * float(np.max(tip_err)),
            marker_position_mean_mm=1e3 * float(np.nanmean(every)),
            strain_rmse=rmse,
        )
        metrics.setdefault("units_of", {})["strain_rmse"] = _strain_units(rmse)
    if kind is not None:
        metrics["units"] = {k: v for k, v in _METRIC_UNITS.items() if k in metrics}
        metrics["units"].update(metrics.pop("units_of", {}))
    title = f"rollout of {Path(model_name).name} under {Path(str(tau)).name}"
    with FileSet(folder) as outputs:  # rollout.npz, metrics.json and the plots: all new or all old
        arrays = dict(t=t, q=sim.q, qd=sim.qd)
        if spatial:  # 3-D: the markers' positions and rotations in the base frame
            arrays.update(marker_positions=poses[0], marker_rotations=poses[1])
        else:
            arrays.update(poses=poses)
        arrays.update(marker_arc_lengths=s, segment_lengths=np.asarray(kin.segment_lengths, dtype=float))
        if positions is not None:  # the prediction and the measurement in the capture frame
            arrays.update(positions=positions, positions_measured=capture["positions"])
        outputs.savez(folder / "rollout.npz", **arrays)
        if kind is not None:
            outputs.write_text(folder / "metrics.json", json.dumps(metrics, indent=2) + "\n")
        if plot and spatial:
            if positions is not None:  # the prediction against the capture, in the capture frame
                shown, truth_shown = positions, capture["positions"]
            else:
                shown, truth_shown = poses[0], None if true_poses is None else true_poses[0]
            figure = spatial_rollout_figure(
                folder / "rollout.png",
                t,
                sim.q,
                shown,
                truth_shown,
                names,
                modelled,
                into=outputs,
                title=title + (f" vs {Path(str(truth)).name}" if truth is not None else " (no truth given)"),
            )
        if plot and not spatial:
            tip = None if positions is None else (capture["positions"][:, -1], positions[:, -1])
            figure = rollout_figure(
                folder / "rollout.png",
                t,
                sim.q,
                poses,
                true_poses,
                names,
                into=outputs,
                title=title + (f" vs {Path(str(truth)).name}" if truth is not None else " (no truth given)"),
                modelled=modelled,
                tip=tip,
            )
        if plot and kind == "strains":
            strains_figure(
                folder / "rollout_strains.png",
                t,
                sim.q,
                true_q,
                names,
                modelled,
                title=f"strains: model vs {Path(str(truth)).name}",
                into=outputs,
            )
    say(quiet, f"rolled out {t[-1] - t[0]:.3g} s in {seconds:.1f} s -> {folder / 'rollout.npz'}")
    if true_poses is not None:
        say(
            quiet,
            f"e_p^EE = {e_p * 1e3:.3f} mm, e_theta^EE = {e_th:.4f} rad, e_p^dist = {d_p * 1e3:.3f} mm, "
            f"e_theta^dist = {d_th:.4f} rad -> {folder / 'metrics.json'}",
        )
    if kind in ("strains", "capture") and metrics["strain_rmse"]:
        what = "measured" if kind == "capture" else "truth"
        say(
            quiet,
            f"strain RMSE against the {what} strains: "
            + ", ".join(
                f"{nm} {v:.4g} {'(-)' if unit == '-' else unit}"
                for (nm, v), unit in zip(
                    metrics["strain_rmse"].items(), _strain_units(metrics["strain_rmse"]).values(), strict=True
                )
            ),
        )
    if kind == "capture":
        say(
            quiet,
            f"tip position error in the capture frame ({metrics['n_samples_measured']} of {t.size} samples measured): "
            f"RMSE {metrics['tip_position_rmse_mm']:.2f} mm, mean {metrics['tip_position_mean_mm']:.2f} mm, "
            f"max {metrics['tip_position_max_mm']:.2f} mm; all markers mean "
            f"{metrics['marker_position_mean_mm']:.2f} mm -> {folder / 'metrics.json'}",
        )
    if plot:
        metrics["plot"] = str(figure)
    return RolloutResult(sim, poses, s, metrics, positions)


def _read_capture_truth(
    path: str | Path, segmentation: Any, markers: Sequence[str], rate: float, units: str | None, n_samples: int
) -> dict[str, Any]:
    """A motion-capture truth: its cleaned positions (T, N, 3) and its strains in the segmentation's plane (or 3-D)."""
    from ..core.trajectory import PoseTrajectory
    from ..io.marker_csv import read_marker_csv

    # a 3-D fusion fitted with the markers' orientations transforms captures read with them
    orientations = getattr(segmentation, "marker_rotation_offsets_", None) is not None
    try:
        data = read_marker_csv(path, list(markers), rate=float(rate), units=units, orientations=orientations)
    except ValueError as err:
        raise CLIError(str(err)) from None
    if data.positions.shape[0] != n_samples:
        raise CLIError(
            f"truth file {str(path)!r} has {data.positions.shape[0]} samples (at {rate:g} Hz) but the tau file has "
            f"{n_samples}"
        )
    if data.positions.shape[1] != segmentation.n_markers_:
        raise CLIError(
            f"truth file {str(path)!r}: {data.positions.shape[1]} markers ({list(markers)}); the segmentation has "
            f"{segmentation.n_markers_}"
        )
    try:
        # the fuse's own cleaning (frozen samples, jumps -> missing) and plane, so measured means the same
        tr = PoseTrajectory.from_positions(
            data.positions, dt=data.dt, plane=segmentation.plane_, rotations=data.rotations if orientations else None
        )
        (measured,) = segmentation.transform([tr])
    except ValueError as err:
        raise CLIError(f"truth file {str(path)!r}: {err}") from None
    return {"positions": tr.positions, "strains": measured}


def _capture_prediction(sim: Any, segmentation: Any, capture: dict[str, Any]) -> tuple[Any, dict[str, float]]:
    """Predicted marker positions in the capture frame (T, N, 3) and the strain RMSE against the measured strains."""
    import numpy as np

    measured = capture["strains"]
    if getattr(segmentation, "space_", "plane") == "3d":  # the 3-D fusion's marker model (spatial_marker_positions)
        keys: tuple[str, ...] = ("marker_arc_lengths", "base_pose", "marker_offsets", "rotation_offsets")
    else:
        keys = ("plane", "marker_arc_lengths", "base_poses", "marker_offsets")
    sim.metadata.update({k: measured.metadata[k] for k in keys if k in measured.metadata})
    try:
        (back,) = segmentation.inverse_transform([sim])
    except ValueError as err:
        raise CLIError(f"the segmentation does not fit the model: {err}") from None
    names = sim.kinematics.strain_names(active_only=False)
    keep = np.asarray(sim.kinematics.active_mask) & np.asarray(measured.kinematics.active_mask)
    # 'estimated' is False where a frame's strains were interpolated in time (markers missing): not measured
    determined = np.asarray(measured.metadata.get("estimated", np.ones(measured.n_frames, bool)), dtype=bool)
    q_true = np.where(determined[:, None], measured.q, np.nan)
    return back.positions, _strain_rmse(names, sim.q, q_true, keep)
