"""Command line interface: ``pcs-sindy <command> ...``.

Each command is one step of the pipeline and reads/writes plain files:
simulate (scenario -> recordings), render (poses -> videos), extract
(videos -> poses), fuse (poses -> segmentation + strains), fit (strains + tau
-> model), rollout (model + tau -> predicted poses, metrics); ``demo`` chains
them on the two_segment scenario and writes a report.

Errors in user input end with a one-line message and exit code 2;
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
import zipfile
from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["main", "build_parser", "CLIError"]

FILE_FORMATS = """\
file formats (all .npz, read without pickle; extra keys are ignored):
  recording    t (T,), q, qd, tau (T, n), poses, poses_true (T, N+1, 3)  (written by 'simulate')
  pose file    t (T,), poses (T, N+1, 3): base + N markers, [x, y, theta] in m/rad in the base frame
  tau file     t (T,), tau (T, 3m): generalized forces held on [t_k, t_k+1)  (a recording qualifies)
  strain file  t (T,), q (T, 3m), segment_lengths (m,), active_strains (m, 3),
               base_pose (3,), base_poses (T, 3), marker_arc_lengths (N+1,)  (written by 'fuse')
  model files  JSON + .npz sibling written by pcs_sindy.persistence (no pickle)
"""

EXAMPLE = """
example ('pcs-sindy demo' step by step):
  pcs-sindy simulate two_segment --out data
  pcs-sindy render data/train_*.npz --out videos --size 400x300 --marker-size 0.012,0.003 --n-jobs 2
  pcs-sindy extract videos/*.avi --out poses --n-jobs 2
  pcs-sindy fuse poses/*.npz --out strains
  pcs-sindy fit strains/train_*.npz --tau data/*.npz --out model/model.json
  pcs-sindy rollout model/model.json --tau data/validation.npz --truth data/validation.npz \\
      --segmentation strains/segmentation.json --out rollout
"""

SEED_TWO_SEGMENT = {  # DESIGN.md section 6, two_segment, no noise
    "segment_lengths": [0.068, 0.102],
    "e_p_dist_fusion": 2.40e-4,
    "e_theta_dist_fusion": 1.15e-2,
    "e_p_ee": 5.22e-3,
    "e_theta_ee": 0.138,
}

# The demo's video settings, measured on two_segment (seed 0): MJPG .avi keeps
# marker edges (mp4v blurs them: 72 mm tip error after identification), and
# 12 x 3 mm markers at 400 x 300 px give 0.03 mm / 0.23 deg rms pose errors,
# close to 640 x 480 with 8 x 2 mm markers at a third of the pixels.
DEMO_SIZE = (400, 300)
DEMO_MARKER_SIZE = (0.012, 0.003)


class CLIError(Exception):
    """An error caused by the user's input, reported without a traceback."""


class _Parser(argparse.ArgumentParser):
    """Argument parser whose usage errors are one line (no usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


# --------------------------------------------------------------------------
# argument types and file helpers
# --------------------------------------------------------------------------
def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer; got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer; got {text!r}")
    return value


def _n_jobs(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer or -1 (all cores); got {text!r}") from None
    if value == 0 or value < -1:
        raise argparse.ArgumentTypeError(f"expected a positive integer or -1 (all cores); got {text!r}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0; got {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0; got {text!r}")
    return value


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
    if not (np.isfinite(a) and np.isfinite(b)) or a <= 0 or b <= 0:
        raise argparse.ArgumentTypeError(f"expected two numbers > 0; got {text!r}")
    return a, b


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


def _output_dir(path: str | Path) -> Path:
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write_test"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise CLIError(f"output directory {str(out)!r} is not writable: {err.strerror or err}") from None
    return out


def _read_npz(
    path: str | Path, required: Sequence[str], what: str, optional: Sequence[str] = ()
) -> dict[str, np.ndarray]:
    """The ``required`` (and present ``optional``) arrays of an .npz file; CLIError otherwise."""
    src = Path(path)
    if not src.is_file():
        raise CLIError(f"{what} {str(path)!r} does not exist")
    try:
        with np.load(src, allow_pickle=False) as data:
            if not hasattr(data, "files"):
                raise CLIError(f"{what} {str(path)!r} is a single .npy array, not an .npz file with named arrays")
            missing = [k for k in required if k not in data.files]
            if missing:
                raise CLIError(f"{what} {str(path)!r} lacks {missing} (found {sorted(data.files)})")
            return {k: np.asarray(data[k]) for k in (*required, *optional) if k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise CLIError(f"cannot read {what} {str(path)!r}: {err}") from None


def _read_poses(path: str | Path, key: str = "poses") -> tuple[np.ndarray | None, np.ndarray]:
    data = _read_npz(path, [key], "pose file", optional=["t"])
    poses = data[key].astype(float)
    if poses.ndim != 3 or poses.shape[-1] != 3 or poses.shape[1] < 2:
        raise CLIError(f"pose file {str(path)!r}: '{key}' must have shape (T, N + 1, 3); got {poses.shape}")
    t = data.get("t")
    if t is not None and t.shape != (poses.shape[0],):
        raise CLIError(f"pose file {str(path)!r}: 't' must have shape ({poses.shape[0]},); got {t.shape}")
    return (None if t is None else t.astype(float)), poses


def _read_tau(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    data = _read_npz(path, ["t", "tau"], "tau file")
    t, tau = data["t"].astype(float), data["tau"].astype(float)
    if tau.ndim != 2 or t.shape != (tau.shape[0],):
        raise CLIError(f"tau file {str(path)!r}: need t (T,) and tau (T, n); got {t.shape} and {tau.shape}")
    return t, tau


def _read_strains(path: str | Path):
    from .trajectory import StrainTrajectory

    data = _read_npz(
        path, ["t", "q", "segment_lengths"], "strain file",
        optional=["active_strains", "base_pose", "base_poses", "marker_arc_lengths", "boundaries"],
    )
    meta: dict[str, Any] = {"source": str(path)}
    for key in ("base_poses", "marker_arc_lengths", "boundaries"):
        if key in data:
            meta[key] = data[key]
    try:
        return StrainTrajectory(
            data["q"], data["t"], segment_lengths=tuple(np.atleast_1d(data["segment_lengths"]).astype(float)),
            active_strains=data.get("active_strains"),
            base_pose=tuple(data["base_pose"]) if "base_pose" in data else (0.0, 0.0, 0.0),
            metadata=meta,
        )
    except ValueError as err:
        raise CLIError(f"strain file {str(path)!r}: {err}") from None


def _write_strains(path: Path, st) -> None:
    arrays = {
        "t": st.t,
        "q": st.q,
        "segment_lengths": np.asarray(st.segment_lengths, dtype=float),
        "active_strains": st.active_strains,
        "base_pose": np.asarray(st.kinematics.base_pose, dtype=float),
    }
    for key in ("base_poses", "marker_arc_lengths", "boundaries"):
        if key in st.metadata:
            arrays[key] = np.asarray(st.metadata[key])
    np.savez(path, **arrays)


def _save_model(obj: Any, path: Path) -> Path:
    try:
        from .persistence import save
    except ImportError as err:  # the module lands separately
        raise CLIError(f"cannot write model files: pcs_sindy.persistence is not available ({err})") from None
    return Path(save(obj, path))


def _load_model(path: str | Path, expected: type, what: str) -> Any:
    try:
        from .persistence import load
    except ImportError as err:
        raise CLIError(f"cannot read model files: pcs_sindy.persistence is not available ({err})") from None
    src = Path(path)
    if not (src.exists() or src.with_suffix(".json").exists()):
        raise CLIError(f"{what} {str(path)!r} does not exist")
    try:
        obj = load(src)
    except (ValueError, OSError, KeyError, TypeError) as err:
        raise CLIError(f"cannot read {what} {str(path)!r}: {err}") from None
    if not isinstance(obj, expected):
        raise CLIError(f"{what} {str(path)!r} holds a {type(obj).__name__}, not a {expected.__name__}")
    return obj


def _say(args: argparse.Namespace, text: str) -> None:
    if not getattr(args, "quiet", False):
        print(text)


# --------------------------------------------------------------------------
# simulate
# --------------------------------------------------------------------------
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
    data = scenario.generate(
        seed=args.seed,
        noise=_parse_noise(args.noise),
        n_train=getattr(args, "n_train", None),
        train_duration=getattr(args, "train_duration", None),
        validation=not getattr(args, "no_validation", False),
        validation_duration=getattr(args, "validation_duration", None),
        progress=not args.quiet,
    )
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
    _say(args, f"simulated {scenario.name} ({len(paths)} recordings) in {summary['seconds']} s -> {out}")
    return paths


# --------------------------------------------------------------------------
# render
# --------------------------------------------------------------------------
def _render_one(src: str, target: str, fps: float | None, size: tuple[int, int], marker_size: tuple[float, float],
                progress: bool) -> tuple[str, int, str]:
    """Render one pose file (module level so joblib can run it in a worker)."""
    from .camera import Camera
    from .simulation.rendering import render_video

    t, poses = _read_poses(src)
    if fps is None:
        fps = 1.0 / float(np.median(np.diff(t))) if t is not None and t.size > 1 else 1000.0
    try:
        camera = Camera.fit_poses(poses, size)
        result = render_video(poses, target, camera, fps=fps, marker_size=marker_size, progress=progress)
    except ValueError as err:
        raise CLIError(f"{src}: {err}") from None
    return str(result.video), int(poses.shape[0]), str(result.camera)


def _render(args: argparse.Namespace) -> list[Path]:
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    out = _output_dir(args.out)
    for name in args.inputs:  # fail before any work on a bad input
        _read_npz(name, ["poses"], "pose file")
    targets = [str(out / (Path(name).stem + args.format)) for name in args.inputs]
    if len(set(targets)) != len(targets):
        raise CLIError("input files share a name (stem); their videos would overwrite each other")
    common = (args.fps, tuple(args.size), tuple(args.marker_size))
    if args.n_jobs == 1 or len(args.inputs) == 1:
        results = [
            _render_one(src, dst, *common, progress=not args.quiet) for src, dst in zip(args.inputs, targets)
        ]
    else:
        jobs = (delayed(_render_one)(src, dst, *common, progress=False) for src, dst in zip(args.inputs, targets))
        results = list(tqdm(Parallel(n_jobs=args.n_jobs, return_as="generator")(jobs), total=len(targets),
                            desc="render", unit="video", disable=args.quiet))
    for src, (video, n_frames, _) in zip(args.inputs, results):
        _say(args, f"rendered {Path(src).name} ({n_frames} frames) -> {video} (+ camera JSON)")
    return [Path(v) for v, _, _ in results]


# --------------------------------------------------------------------------
# extract
# --------------------------------------------------------------------------
def _extract_one(video: str, params: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """Extract one video (module level so joblib can run it in a worker)."""
    from .vision import MarkerPoseExtractor

    extractor = MarkerPoseExtractor(**params, progress=False)
    traj = extractor.fit_transform([video])[0]
    return traj, extractor.diagnostics_[0]


def _extract(args: argparse.Namespace) -> list[Path]:
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    from .camera import Camera
    from .vision import MarkerPoseExtractor

    camera: Any = "auto"
    if args.camera is not None:
        if not Path(args.camera).is_file():
            raise CLIError(f"camera file {args.camera!r} does not exist")
        camera = Camera.from_json(args.camera)
    for name in args.videos:
        if not Path(name).exists():
            raise CLIError(f"video {name!r} does not exist")
    stems = [Path(v).stem for v in args.videos]
    if len(set(stems)) != len(stems):
        raise CLIError("videos share a name (stem); their pose files would overwrite each other")
    out = _output_dir(args.out)
    params = dict(n_markers=args.n_markers, camera=camera, robot_length=args.robot_length, fps=args.fps,
                  on_missing=args.on_missing)
    if args.n_jobs == 1 or len(args.videos) == 1:
        extractor = MarkerPoseExtractor(**params, progress=not args.quiet)
        results = [(tr, diag) for tr, diag in zip(extractor.fit_transform(list(args.videos)), extractor.diagnostics_)]
    else:  # one video per job, one bar over videos (per-frame bars of parallel workers would interleave)
        jobs = (delayed(_extract_one)(v, params) for v in args.videos)
        results = list(tqdm(Parallel(n_jobs=args.n_jobs, return_as="generator")(jobs), total=len(args.videos),
                            desc="extract", unit="video", disable=args.quiet))
    trajs, diags = [r[0] for r in results], [r[1] for r in results]
    paths = []
    for name, tr, diag in zip(args.videos, trajs, diags):
        path = out / (Path(name).stem + ".npz")
        np.savez(path, t=tr.t, poses=tr.poses)
        paths.append(path)
        repaired = len(diag["frames_repaired"])
        _say(args, f"extracted {Path(name).name}: {tr.n_frames} frames, {tr.n_markers} markers"
                   f"{f', {repaired} frames interpolated' if repaired else ''} ({diag['calibration']}) -> {path}")
    return paths


# --------------------------------------------------------------------------
# fuse
# --------------------------------------------------------------------------
def _fuse(args: argparse.Namespace):
    from .segmentation import KinematicFusion
    from .trajectory import PoseTrajectory

    trajs = []
    for name in args.poses:
        t, poses = _read_poses(name)
        try:
            trajs.append(PoseTrajectory(poses, t, dt=None if t is not None else 1e-3, metadata={"source": name}))
        except ValueError as err:
            raise CLIError(f"pose file {name!r}: {err}") from None
    stems = [Path(v).stem for v in args.poses]
    if len(set(stems)) != len(stems):
        raise CLIError("pose files share a name (stem); their strain files would overwrite each other")
    out = _output_dir(args.out)
    fusion = KinematicFusion(
        threshold=args.threshold, total_length=args.total_length, shape_fit=args.shape_fit, progress=not args.quiet
    )
    fusion.fit(trajs)
    strains = fusion.transform(trajs)
    paths = []
    for name, st in zip(args.poses, strains):
        paths.append(out / (Path(name).stem + ".npz"))
        _write_strains(paths[-1], st)
    seg = _save_model(fusion, out / "segmentation.json")
    lengths = ", ".join(f"{v:.4f}" for v in fusion.segment_lengths_)
    _say(args, f"{fusion.n_segments_} segment(s), lengths [{lengths}] m (total {fusion.total_length_:.4f} m), "
               f"threshold h = {args.threshold:g}")
    if args.total_length is None:
        _say(args, "note: the rest length was estimated as the median deformed length; a robot stretched on average "
                   "(e.g. hanging) reads long by that stretch, which biases every length and strain ('fit' absorbs it "
                   "in identified rest strains unless --no-rest-strain): pass --total-length with the measured "
                   "rest length")
    _say(args, f"segmentation -> {seg}; {len(paths)} strain file(s) -> {out}")
    return fusion, strains, trajs


# --------------------------------------------------------------------------
# fit
# --------------------------------------------------------------------------
def _match_tau(strain_files: Sequence[str], tau_files: Sequence[str]) -> list[str]:
    """Tau file of each strain file: by stem when every stem has one, else by order."""
    by_stem = {Path(p).stem: p for p in tau_files}
    if len(by_stem) == len(tau_files) and all(Path(s).stem in by_stem for s in strain_files):
        return [by_stem[Path(s).stem] for s in strain_files]
    if len(tau_files) != len(strain_files):
        raise CLIError(
            f"got {len(strain_files)} strain file(s) but {len(tau_files)} tau file(s), and their names (stems) "
            "do not match; give one tau file per strain file, in the same order or with the same names"
        )
    return list(tau_files)


def _fit(args: argparse.Namespace):
    from .regressor import EulerLagrangeRegressor

    strains = [_read_strains(p) for p in args.strains]
    tau_files = _match_tau(args.strains, args.tau)
    taus = []
    for sfile, tfile, st in zip(args.strains, tau_files, strains):
        t, tau = _read_tau(tfile)
        n = st.kinematics.n_q
        if tau.shape[1] != n:
            raise CLIError(
                f"tau file {tfile!r} has {tau.shape[1]} force columns but strain file {sfile!r} has {n} strains "
                f"({st.kinematics.n_segments} segment(s) x 3): tau must act on the same segmentation"
            )
        if t.shape[0] != st.n_frames:
            raise CLIError(f"tau file {tfile!r} has {t.shape[0]} samples but strain file {sfile!r} has {st.n_frames}")
        dt = float(np.median(np.diff(st.t))) if st.n_frames > 1 else 1.0
        if np.max(np.abs((t - t[0]) - (st.t - st.t[0]))) > 0.5 * dt:
            raise CLIError(
                f"time stamps of tau file {tfile!r} and strain file {sfile!r} differ by more than half a sample"
            )
        taus.append(tau)
    formulation = args.formulation or ("weak" if args.basis == "physical" else "strong")
    model = EulerLagrangeRegressor(
        basis=args.basis, formulation=formulation, window_length=args.window_length, polyorder=args.polyorder,
        exclude_force_jumps=not args.no_exclude_force_jumps,
        rest_strain=args.rest_strain and args.basis == "physical",
    )
    start = time.perf_counter()
    model.fit(strains, taus)
    seconds = time.perf_counter() - start
    path = _save_model(model, _output_dir(Path(args.out).parent) / Path(args.out).name)
    if not args.quiet:
        names = model.kinematics_.strain_names(active_only=False)
        print(f"identified in {seconds:.1f} s from {len(strains)} recording(s), "
              f"{model.n_regression_samples_} samples; removed strains: {model.removed_strains_ or 'none'}")
        for line in model.equations():
            print(line)
        print("stiffness: " + ", ".join(f"{nm} {k:.4g}" for nm, k in zip(names, model.stiffness_)))
        print("damping:   " + ", ".join(f"{nm} {d:.4g}" for nm, d in zip(names, model.damping_)))
        print(f"model -> {path}")
    return model


# --------------------------------------------------------------------------
# rollout
# --------------------------------------------------------------------------
def _rollout(args: argparse.Namespace, model: Any = None, fusion: Any = None) -> dict[str, Any]:
    from .metrics import distributed_errors, end_effector_errors
    from .regressor import EulerLagrangeRegressor
    from .segmentation import KinematicFusion

    if model is None:
        model = _load_model(args.model, EulerLagrangeRegressor, "model file")
    if fusion is None and args.segmentation is not None:
        fusion = _load_model(args.segmentation, KinematicFusion, "segmentation file")
    t, tau = _read_tau(args.tau)
    kin = model.kinematics_
    n = kin.n_q
    if tau.shape[1] != n:
        raise CLIError(f"tau file {args.tau!r} has {tau.shape[1]} force columns; the model has {n} strains "
                       f"({kin.n_segments} segment(s) x 3)")
    truth = None
    if args.truth is not None:
        keys = _read_npz(args.truth, [], "truth file", optional=["poses_true", "poses"])
        key = "poses_true" if "poses_true" in keys else "poses"
        t_true, truth = _read_poses(args.truth, key)
        if truth.shape[0] != t.shape[0]:
            raise CLIError(
                f"truth file {args.truth!r} has {truth.shape[0]} frames but tau file {args.tau!r} has {t.shape[0]}"
            )
    q0, qd0 = np.zeros(n), np.zeros(n)
    if args.initial is not None:
        st = _read_strains(args.initial)
        if st.kinematics.n_q != n:
            raise CLIError(f"initial strain file {args.initial!r} has {st.kinematics.n_q} strains; the model has {n}")
        q0 = st.q[0]
    # marker arc lengths: the segmentation's, else N equally spaced markers on the model's length
    total = float(np.sum(kin.segment_lengths))
    if fusion is not None:
        s = np.asarray(fusion.marker_arc_lengths_, dtype=float)
        s = np.clip(s, 0.0, total)
    else:
        n_markers = truth.shape[1] - 1 if truth is not None else args.n_markers
        s = np.linspace(0.0, total, n_markers + 1)
    if truth is not None and truth.shape[1] != s.size:
        raise CLIError(f"truth file {args.truth!r} has {truth.shape[1] - 1} markers; the segmentation has {s.size - 1}")
    out = _output_dir(args.out)
    start = time.perf_counter()
    tol = {"rtol": 3e-5, "atol": 3e-8} if args.method == "rosenbrock" else {}
    sim = model.simulate(q0, qd0, tau, t, progress=not args.quiet, method=args.method, **tol)
    seconds = time.perf_counter() - start
    poses = sim.poses(s)
    np.savez(out / "rollout.npz", t=t, q=sim.q, qd=sim.qd, poses=poses, marker_arc_lengths=s,
             segment_lengths=np.asarray(kin.segment_lengths, dtype=float))
    result: dict[str, Any] = {
        "model": str(args.model), "tau": str(args.tau), "duration_s": float(t[-1] - t[0]),
        "rollout_seconds": round(seconds, 3), "n_markers": int(s.size - 1),
    }
    _say(args, f"rolled out {t[-1] - t[0]:.3g} s in {seconds:.1f} s -> {out / 'rollout.npz'}")
    if truth is not None:
        e_p, e_th = end_effector_errors(poses[:, 1:], truth[:, 1:])
        d_p, d_th = distributed_errors(poses[:, 1:], truth[:, 1:])
        result.update(truth=str(args.truth), e_p_ee=e_p, e_theta_ee=e_th, e_p_dist=d_p, e_theta_dist=d_th)
        (out / "metrics.json").write_text(json.dumps(result, indent=2) + "\n")
        _say(args, f"e_p^EE = {e_p * 1e3:.3f} mm, e_theta^EE = {e_th:.4f} rad, "
                   f"e_p^dist = {d_p * 1e3:.3f} mm, e_theta^dist = {d_th:.4f} rad -> {out / 'metrics.json'}")
    if not args.no_plot:
        result["plot"] = str(_rollout_plot(out / "rollout.png", t, sim, poses, truth))
    return result | {"_sim": sim, "_poses": poses, "_s": s}


def _rollout_plot(path: Path, t: np.ndarray, sim: Any, poses: np.ndarray, truth: np.ndarray | None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .plotting import plot_end_effector

    if truth is not None:
        fig = plot_end_effector(t, truth[:, -1], poses[:, -1], labels=["model"], title="end effector: model vs truth")
    else:
        names = sim.kinematics.strain_names(active_only=False)
        fig, axes = plt.subplots(3, 1, figsize=(8, 6), sharex=True)
        for j, nm in enumerate(names):
            axes[j % 3].plot(t, sim.q[:, j], label=nm)
        for ax, label in zip(axes, ("bending [1/m]", "shear [-]", "axial [-]")):
            ax.set_ylabel(label)
            ax.legend(loc="upper right", fontsize="small")
        axes[-1].set_xlabel("t [s]")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------
# demo
# --------------------------------------------------------------------------
# Compiles (or loads from numba's cache) the kernels of the identified model's rollout with the
# types the demo's two-segment model uses; run in a separate process during the single-threaded
# simulation, so that a cold start compiles them on the otherwise idle second core.
_ROLLOUT_WARMUP = """
import numpy as np
from pcs_sindy._jit_rollout import LumpedModel
model = LumpedModel([0.07, 0.1], np.ones(6, bool), [1.0, 1.0], [1e-4, 1e-4], [[0.0, 10.0], [0.0, 10.0]],
                    np.ones(6), 0.1 * np.ones(6))
model.rollout(np.zeros(12), np.arange(3) * 1e-3, np.zeros((3, 6)))
"""


def _start_rollout_warmup() -> Any:
    import subprocess

    try:
        return subprocess.Popen([sys.executable, "-c", _ROLLOUT_WARMUP], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:  # an optimisation only
        return None


def _demo(args: argparse.Namespace) -> Path:
    warmup = _start_rollout_warmup()
    try:
        return _run_demo(args, warmup)
    finally:
        if warmup is not None and warmup.poll() is None:
            warmup.kill()
            warmup.wait()


def _run_demo(args: argparse.Namespace, warmup: Any) -> Path:
    out = _output_dir(args.out)
    quiet = args.quiet
    clock: dict[str, float] = {}
    load_start = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    t_all = time.perf_counter()

    def stage(name: str, start: float) -> None:
        clock[name] = round(time.perf_counter() - start, 1)
        _say(args, f"[demo] {name}: {clock[name]} s")

    ns = argparse.Namespace
    t0 = time.perf_counter()
    sim_args = ns(scenario="two_segment", seed=args.seed, noise=None, out=str(out / "data"), quiet=quiet,
                  n_train=2 if args.quick else None, train_duration=0.2 if args.quick else None,
                  validation_duration=1.0 if args.quick else None, no_validation=False)
    paths = _simulate(sim_args)
    train_files, val_file = [str(p) for p in paths[:-1]], str(paths[-1])
    stage("simulate", t0)

    t0 = time.perf_counter()
    videos = _render(ns(inputs=train_files, out=str(out / "videos"), fps=None, format=".avi", size=DEMO_SIZE,
                        marker_size=DEMO_MARKER_SIZE, n_jobs=args.n_jobs, quiet=quiet))
    stage("render", t0)

    t0 = time.perf_counter()
    pose_files = _extract(ns(videos=[str(v) for v in videos], out=str(out / "poses"), camera=None, n_markers=None,
                             robot_length=None, fps=None, on_missing="raise", n_jobs=args.n_jobs, quiet=quiet))
    stage("extract", t0)

    t0 = time.perf_counter()
    # The rest length is what a user measures with a ruler; estimated from the videos of a robot hanging
    # under its weight it reads ~1 % long (gravity stretch), which biases the fused lengths and the model.
    rest_length = float(sum(json.loads((out / "data" / "scenario.json").read_text())["segment_lengths"]))
    fusion, strains, pose_trajs = _fuse(ns(poses=[str(p) for p in pose_files], out=str(out / "strains"),
                                           threshold=args.threshold, total_length=rest_length,
                                           shape_fit="least_squares", quiet=quiet))
    stage("fuse", t0)

    t0 = time.perf_counter()
    strain_files = [str(out / "strains" / (Path(p).stem + ".npz")) for p in pose_files]
    model = _fit(ns(strains=strain_files, tau=train_files, out=str(out / "model" / "model.json"), basis="physical",
                    window_length=7, polyorder=3, no_exclude_force_jumps=False, formulation=None,
                    rest_strain=True, quiet=quiet))
    stage("fit", t0)

    t0 = time.perf_counter()
    if warmup is not None:
        try:  # never write numba's cache from two processes at once
            warmup.wait(timeout=120)
        except Exception:  # noqa: BLE001 - an optimisation only
            warmup.kill()
    roll = _rollout(ns(model=str(out / "model" / "model.json"), tau=val_file, segmentation=None, truth=val_file,
                       initial=None, n_markers=20, out=str(out / "rollout"), no_plot=True, method="rosenbrock",
                       quiet=quiet),
                    model=model, fusion=fusion)
    stage("rollout", t0)

    t0 = time.perf_counter()
    marks = [time.perf_counter()]

    def tick(name: str) -> None:
        stage(name, marks[-1])
        marks.append(time.perf_counter())

    report = _demo_report(out, args, fusion, model, roll, train_files, val_file, pose_trajs, tick)
    stage("report", t0)
    clock["total"] = round(time.perf_counter() - t_all, 1)
    load_end = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    report["machine"] = (f"{os.cpu_count()} cores; 1-minute load average {load_start:.1f} at the start, "
                         f"{load_end:.1f} at the end (other jobs slow every stage)")
    _write_report_md(report, clock)
    print(f"demo report: {report['dir'] / 'report.md'} (total {clock['total']} s)")
    return report["dir"] / "report.md"


def _demo_report(out: Path, args: argparse.Namespace, fusion: Any, model: Any, roll: dict[str, Any],
                 train_files: list[str], val_file: str, pose_trajs: list, tick: Any) -> dict[str, Any]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .camera import Camera
    from .metrics import distributed_errors
    from .plotting import (animate_rollout, plot_end_effector, plot_error_vs_segments, plot_rollout, plot_stills,
                           plot_strain_distance_profile)
    from .segmentation import KinematicFusion, threshold_sweep
    from .simulation.rendering import render_frames
    from .trajectory import PoseTrajectory
    from .vision import MarkerPoseExtractor

    rep = _output_dir(out / "report")
    files: dict[str, str] = {}

    def save(fig: Any, name: str, key: str) -> None:
        fig.savefig(rep / name, dpi=100)
        plt.close(fig)
        files[key] = name

    # kinematic fusion on the training videos against the noise-free simulated poses
    truths = [_read_poses(p, "poses_true")[1] for p in train_files]
    rec = fusion.reconstruct(pose_trajs)
    fd_p, fd_th = distributed_errors(np.concatenate([r.poses[:, 1:] for r in rec]),
                                     np.concatenate([p[:, 1:] for p in truths]))
    save(plot_strain_distance_profile(fusion.distance_profile_, args.threshold,
                                      marker_arc_lengths=fusion.marker_arc_lengths_,
                                      segment_lengths=fusion.segment_lengths_,
                                      title=f"strain distance of adjacent segments (h = {args.threshold:g})"),
         "fig6_strain_distance.png", "fig6")

    # Fig. 8: the seed's Algorithm 1 with end-pose strains, one merge per iteration (every model size
    # appears as h grows), swept on every 10th frame against the noise-free poses
    step = 10
    sub = [PoseTrajectory(tr.poses[::step], tr.t[::step]) for tr in pose_trajs]
    sub_truth = [PoseTrajectory(p[::step], tr.t[::step]) for p, tr in zip(truths, pose_trajs)]
    d = np.asarray(fusion.distance_profile_, dtype=float)
    hs = np.unique(np.r_[np.geomspace(0.01, 1.0, 12), 1.0001 * np.quantile(d, np.linspace(0.0, 1.0, 9))])
    template = KinematicFusion(min_segment_markers=1, merge="closest_pair", shape_fit="end_pose",
                               total_length=fusion.total_length_)
    rows = threshold_sweep(sub, hs[hs > 0], truth=sub_truth, fusion=template)
    tick("report: sweep")
    save(plot_error_vs_segments(rows, selected=int(fusion.n_segments_), logy=True,
                                title="fusion error against the number of segments"), "fig8_error_vs_segments.png",
         "fig8")

    # Fig. 9: rollout of the validation actuation against the simulated truth
    val = _read_npz(val_file, ["t", "q", "poses_true"], "recording")
    t, sim, poses = val["t"], roll["_sim"], roll["_poses"]
    truth = val["poses_true"]
    save(plot_rollout(t, val["q"], sim.q, labels=["model"], title="configuration: model vs truth"),
         "fig9_strains.png", "fig9_strains")
    save(plot_end_effector(t, truth[:, -1], poses[:, -1], labels=["model"], title="end effector: model vs truth"),
         "fig9_end_effector.png", "fig9_ee")

    # Fig. 10: validation stills rendered as the videos are, markers detected, model backbone overlaid
    picks = np.linspace(0, t.size - 1, 5).round().astype(int)[1:]
    # a camera framing these stills (a robot curled over its base can leave the training cameras' view)
    xy = truth[picks][..., :2].reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    margin = 25.0
    ppm = float(min((DEMO_SIZE[0] - 2 * margin) / max(hi[0] - lo[0], 1e-6),
                    (DEMO_SIZE[1] - 2 * margin) / max(hi[1] - lo[1], 1e-6)))
    centre = 0.5 * (lo + hi)
    camera = Camera(pixels_per_metre=ppm, image_size=DEMO_SIZE,
                    origin=(0.5 * (DEMO_SIZE[0] - 1) - ppm * centre[0], 0.5 * (DEMO_SIZE[1] - 1) - ppm * centre[1]))
    frames = render_frames(truth[picks], camera, marker_size=DEMO_MARKER_SIZE)
    s_dense = np.linspace(0.0, float(np.sum(model.kinematics_.segment_lengths)), 60)
    backbone = sim.poses(s_dense)
    # each still on its own: they are far apart in time, so no tracking across them; a still whose
    # markers touch (a tight curl) shows no detections rather than invented ones
    det = []
    for frame in frames:
        try:
            det.append(MarkerPoseExtractor(truth.shape[1] - 1, camera=camera, dt=1e-3, progress=False)
                       .fit_transform([frame[None]])[0].poses[0])
        except ValueError:
            det.append(np.empty((0, 3)))
    save(plot_stills(frames, detected=det, backbone=backbone[picks], times=list(t[picks]), camera=camera,
                     title="validation stills: detected markers and the model's backbone"), "fig10_stills.png", "fig10")

    tick("report: figures")
    # animation of the rollout
    animate_rollout(rep / "rollout.mp4", t, truth, backbone, truth[:, 1:], fps=15.0, labels=("truth", "model"),
                    size=(400, 400), progress=not args.quiet)
    files["animation"] = "rollout.mp4"
    tick("report: animation")
    (rep / "equations.txt").write_text("\n".join(model.equations(precision=4)) + "\n")
    files["equations"] = "equations.txt"

    metrics = {
        "segment_lengths": [float(v) for v in fusion.segment_lengths_],
        "e_p_dist_fusion": fd_p, "e_theta_dist_fusion": fd_th,
        "e_p_ee": roll["e_p_ee"], "e_theta_ee": roll["e_theta_ee"],
        "e_p_dist_rollout": roll["e_p_dist"], "e_theta_dist_rollout": roll["e_theta_dist"],
        "stiffness": [float(v) for v in model.stiffness_], "damping": [float(v) for v in model.damping_],
        "removed_strains": list(model.removed_strains_),
        "sweep": [list(map(float, r)) for r in rows],
    }
    (rep / "metrics.json").write_text(json.dumps({"this_run": metrics, "seed": SEED_TWO_SEGMENT}, indent=2) + "\n")
    files["metrics"] = "metrics.json"
    return {"dir": rep, "files": files, "metrics": metrics, "quick": args.quick, "seed": args.seed,
            "n_train": len(train_files), "threshold": args.threshold, "equations": model.equations(precision=4),
            "duration": float(t[-1] - t[0])}


def _write_report_md(report: dict[str, Any], clock: dict[str, float]) -> None:
    m, s, f = report["metrics"], SEED_TWO_SEGMENT, report["files"]
    lengths = ", ".join(f"{v:.4f}" for v in m["segment_lengths"])
    lines = [
        "# pcs-sindy demo: two_segment from rendered videos",
        "",
        f"Scenario two_segment (true segment lengths [0.07, 0.1] m), seed {report['seed']}, no noise"
        f"{' (--quick: short data, numbers not comparable)' if report['quick'] else ''}. "
        f"{report['n_train']} training recordings simulated, rendered to {DEMO_SIZE[0]}x{DEMO_SIZE[1]} MJPG videos, "
        "markers extracted from the videos, kinematic fusion (h = "
        f"{report['threshold']:g}, rest length given as measured), identification (physical basis, weak form: "
        "bump-weighted window integrals, no accelerations), "
        f"rollout of the {report['duration']:g} s validation actuation from rest (Rosenbrock-W, rtol 3e-5). "
        "The validation truth is the "
        "simulated noise-free marker poses (the validation video is not rendered; see the stills).",
        "",
        "| quantity | this run | seed |",
        "|---|---|---|",
        f"| fused segment lengths [m] | [{lengths}] | {s['segment_lengths']} |",
        f"| e_p^dist fusion, training, vs noise-free poses [m] | {m['e_p_dist_fusion']:.3g} "
        f"| {s['e_p_dist_fusion']:.3g} |",
        f"| e_θ^dist fusion, training, vs noise-free poses [rad] | {m['e_theta_dist_fusion']:.3g} "
        f"| {s['e_theta_dist_fusion']:.3g} |",
        f"| e_p^EE rollout [mm] | {m['e_p_ee'] * 1e3:.3g} | {s['e_p_ee'] * 1e3:.3g} |",
        f"| e_θ^EE rollout [rad] | {m['e_theta_ee']:.3g} | {s['e_theta_ee']:.3g} |",
        f"| e_p^dist rollout [mm] | {m['e_p_dist_rollout'] * 1e3:.3g} | – |",
        f"| e_θ^dist rollout [rad] | {m['e_theta_dist_rollout']:.3g} | – |",
        "",
        "Identified stiffness per strain (be, sh, ax of each segment): "
        + ", ".join(f"{v:.4g}" for v in m["stiffness"])
        + f"; removed strains: {', '.join(m['removed_strains']) or 'none'}.",
        "",
        "## Identified equations",
        "",
        "```",
        *report["equations"],
        "```",
        "",
        "## Figures",
        "",
        f"- Strain-distance profile with the threshold and the resulting segments (seed Fig. 6): ![]({f['fig6']})",
        f"- Fusion error against the number of segments (seed Fig. 8; the seed's Algorithm 1 with end-pose "
        "strains, one merge per iteration, on every 10th training frame, errors against the noise-free poses): "
        f"![]({f['fig8']})",
        f"- Configuration rollout against the truth (seed Fig. 9a): ![]({f['fig9_strains']})",
        f"- End-effector rollout against the truth (seed Fig. 9b): ![]({f['fig9_ee']})",
        f"- Stills with the detected markers and the model's backbone (seed Fig. 3/10): ![]({f['fig10']})",
        f"- Animation of the rollout: [{f['animation']}]({f['animation']})",
        "",
        "## Wall time [s]",
        "",
        "| " + " | ".join(clock) + " |",
        "|" + "---|" * len(clock),
        "| " + " | ".join(str(v) for v in clock.values()) + " |",
        "",
        f"Machine: {report.get('machine', 'unknown')}. Stages marked 'report:' are part of 'report'.",
        "",
    ]
    (report["dir"] / "report.md").write_text("\n".join(lines))


# --------------------------------------------------------------------------
# parser
# --------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    """The ``pcs-sindy`` argument parser (one sub-command per pipeline step)."""
    fmt = argparse.RawDescriptionHelpFormatter
    parser = _Parser(prog="pcs-sindy", description=__doc__.split("\n\n")[1], epilog=FILE_FORMATS + EXAMPLE,
                     formatter_class=fmt)
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, help_: str, func: Any) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_, description=help_, epilog=FILE_FORMATS, formatter_class=fmt)
        p.set_defaults(func=func)
        return p

    def common(p: argparse.ArgumentParser, jobs: bool = False) -> None:
        if jobs:
            p.add_argument("--n-jobs", type=_n_jobs, default=1,
                           help="parallel jobs over files (-1: all cores; default 1)")
        p.add_argument("--quiet", action="store_true", help="no progress bars or messages")

    p = add("scenarios", "list the built-in scenarios", None)
    p.set_defaults(func=lambda a: print("\n".join(__import__("pcs_sindy.simulation", fromlist=["x"]).list_scenarios())))

    p = add("simulate", "simulate a scenario: recordings (.npz with t, q, qd, tau, poses, poses_true)", _simulate)
    p.add_argument("scenario", help="scenario name (see 'pcs-sindy scenarios')")
    p.add_argument("--out", required=True, help="output directory (train_00.npz ..., validation.npz, scenario.json)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--noise", default=None, help="pose noise: 'seed', 'none' or 'SIGMA_P_M,SIGMA_THETA_DEG'")
    p.add_argument("--n-train", type=_positive_int, default=None,
                   help="training recordings (default: the scenario's 8)")
    p.add_argument("--train-duration", type=_positive_float, default=None,
                   help="seconds per training recording (default 0.5)")
    p.add_argument("--validation-duration", type=_positive_float, default=None,
                   help="seconds of validation (default 7)")
    p.add_argument("--no-validation", action="store_true", help="do not simulate the validation recording")
    common(p)

    p = add("render", "render pose files to marker videos, each with a camera JSON (<video>.camera.json)", _render)
    p.add_argument("inputs", nargs="+", help="pose files (.npz with 'poses'; recordings qualify)")
    p.add_argument("--out", required=True, help="output directory (one video per input, same stem)")
    p.add_argument("--fps", type=_positive_float, default=None, help="frame rate (default: from the time stamps)")
    p.add_argument("--format", default=".avi", choices=[".avi", ".mp4"],
                   help=".avi (MJPG, default: sharp marker edges) or .mp4 (mp4v, lossy: larger pose errors)")
    p.add_argument("--size", type=_size, default=(640, 480), help="image WIDTHxHEIGHT (default 640x480)")
    p.add_argument("--marker-size", type=_pair, default=(0.008, 0.002),
                   help="marker WIDTH,THICKNESS in metres (default 0.008,0.002)")
    common(p, jobs=True)

    from .calibration import configure_parser as _calibrate_args  # the command lives with the calibration
    p = add("calibrate", "lens distortion and the robot's plane from checkerboard views: a camera JSON", None)
    _calibrate_args(p)
    common(p)

    p = add("extract", "extract marker poses from videos: one pose file (.npz with t, poses) per video", _extract)
    p.add_argument("videos", nargs="+", help="videos (or folders of image frames)")
    p.add_argument("--out", required=True, help="output directory (one pose file per video, same stem)")
    p.add_argument("--camera", default=None,
                   help="camera JSON for every video (default: <video>.camera.json next to each video, "
                        "as 'render' writes)")
    p.add_argument("--robot-length", type=_positive_float, default=None,
                   help="without a camera JSON: calibrate from the straight first frame and this length [m]")
    p.add_argument("--n-markers", type=_positive_int, default=None, help="markers besides the base (default: as found)")
    p.add_argument("--fps", type=_positive_float, default=None,
                   help="frame rate (default: the video's or the camera JSON's)")
    p.add_argument("--on-missing", choices=["raise", "interpolate"], default="raise",
                   help="frames whose markers cannot be found: fail (default) or interpolate")
    common(p, jobs=True)

    p = add("fuse", "kinematic fusion: segmentation (segmentation.json/.npz) and one strain file per pose file", _fuse)
    p.add_argument("poses", nargs="+", help="pose files (.npz with t, poses)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--threshold", type=float, default=0.2, help="merge threshold h (default 0.2, the seed's)")
    p.add_argument("--total-length", type=_positive_float, default=None,
                   help="robot rest length [m], measured (recommended; default: the median deformed length of the "
                        "marker chain, ~1%% long for a robot hanging under its weight)")
    p.add_argument("--shape-fit", choices=["least_squares", "end_pose"], default="least_squares",
                   help="strains fitted to all markers (default) or from segment end poses (the seed)")
    common(p)

    p = add("fit", "identify the dynamics from strain files and tau files: a model file", _fit)
    p.add_argument("strains", nargs="+", help="strain files (written by 'fuse')")
    p.add_argument("--tau", nargs="+", required=True,
                   help="tau files (.npz with t, tau), matched to the strain files by name (stem) or else by order")
    p.add_argument("--out", required=True, help="model file (model.json + model.npz)")
    p.add_argument("--basis", choices=["physical", "monomial"], default="physical",
                   help="Lagrangian basis: 7 lumped physical unknowns per segment (default) or the seed's monomials")
    p.add_argument("--window-length", type=_positive_int, default=7, help="Savitzky-Golay window (odd; default 7)")
    p.add_argument("--polyorder", type=_positive_int, default=3, help="Savitzky-Golay order (default 3)")
    p.add_argument("--no-exclude-force-jumps", action="store_true",
                   help="keep samples whose window straddles a jump of the held actuation (default: left out)")
    p.add_argument("--rest-strain", action=argparse.BooleanOptionalAction, default=True,
                   help="identify a constant force per strain, i.e. a rest strain: pre-curved robots, or a rest "
                        "length estimated rather than measured (default on; physical basis only)")
    p.add_argument("--formulation", choices=["weak", "strong"], default=None,
                   help="regress window integrals (weak: no accelerations, robust to noise; default with the physical "
                        "basis) or every sample with Savitzky-Golay accelerations (strong; the seed's, default with "
                        "the monomial basis)")
    common(p)

    p = add("rollout", "simulate a model under tau: predicted strains and poses, metrics against a truth", _rollout)
    p.add_argument("model", help="model file (written by 'fit')")
    p.add_argument("--tau", required=True, help="tau file (.npz with t, tau)")
    p.add_argument("--segmentation", default=None, help="segmentation file (written by 'fuse'): marker arc lengths")
    p.add_argument("--truth", default=None,
                   help="pose file of the truth ('poses_true' when present, as in recordings, else 'poses')")
    p.add_argument("--initial", default=None,
                   help="strain file whose first frame is q0 (default: rest, q0 = 0); qd0 = 0")
    p.add_argument("--n-markers", type=_positive_int, default=20,
                   help="markers on the prediction without truth or segmentation (default 20)")
    p.add_argument("--out", required=True, help="output directory (rollout.npz, metrics.json, rollout.png)")
    p.add_argument("--no-plot", action="store_true", help="do not draw rollout.png")
    p.add_argument("--method", choices=["rosenbrock", "dopri5"], default="rosenbrock",
                   help="integrator: L-stable Rosenbrock-W, rtol 3e-5 (default, fast on stiff shear/axial modes) "
                        "or explicit Dormand-Prince 5(4) at the model's tolerances (the seed's kind)")
    common(p)

    p = add("demo", "the whole pipeline on two_segment from rendered videos, with a report folder", _demo)
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo; the report in OUT/report)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--threshold", type=_positive_float, default=0.2, help="fusion threshold h (default 0.2)")
    p.add_argument("--quick", action="store_true", help="2 short recordings and a 1 s validation (a smoke test)")
    p.add_argument("--n-jobs", type=_n_jobs, default=2, help="parallel jobs for rendering and extraction (default 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bars or stage messages")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pcs-sindy`` console script; returns the exit code."""
    from .integrators import DivergenceError

    parser = build_parser()
    args = parser.parse_args(argv)

    def one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
        print(f"pcs-sindy {args.command}: warning: {' '.join(str(message).split())}", file=sys.stderr)

    try:
        with warnings.catch_warnings():  # restores showwarning on exit
            if not args.debug:
                warnings.showwarning = one_line_warning
            args.func(args)
    except (CLIError, ValueError, OSError, DivergenceError, np.linalg.LinAlgError) as err:
        if args.debug:
            raise
        message = " ".join(str(err).split()) or type(err).__name__  # one line
        print(f"pcs-sindy {args.command}: error: {message}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
