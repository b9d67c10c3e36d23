"""The report of ``pcs-sindy demo`` and the figure of ``pcs-sindy rollout``.

:func:`demo_report` draws the seed's figures for a demo run (strain-distance
profile, error against the number of segments, rollout against the truth,
stills with detections, an animation) and writes ``metrics.json`` with the
seed's two_segment numbers beside this run's; :func:`write_report_md` writes
``report.md`` from them.  :func:`rollout_figure` draws ``rollout.png`` (and :func:`strains_figure`
``rollout_strains.png`` against a strain file); :func:`spatial_rollout_figure` draws ``rollout.png``
of a spatial (3-D) model.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import atomic
from ..core.kinematics import STRAIN_NAMES
from ..core.units import generalised_force_unit, strain_rate_unit, strain_unit
from ..io.data_files import output_dir, read_arrays, read_poses

__all__ = [
    "SEED_TWO_SEGMENT",
    "DEMO_SIZE",
    "DEMO_MARKER_SIZE",
    "rollout_figure",
    "spatial_rollout_figure",
    "strains_figure",
    "demo_report",
    "stored_metrics",
    "write_report_md",
]

SEED_TWO_SEGMENT = {  # the seed's dynamics table, two_segment, no noise
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


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")  # files only; no display is needed or wanted
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | Path, into: Any) -> Path:
    plt = _pyplot()
    try:
        if into is None:
            atomic.savefig(fig, path, dpi=100)
        else:
            into.savefig(fig, path, dpi=100)
    finally:
        plt.close(fig)
    return Path(path)


def rollout_figure(
    path: str | Path,
    t: NDArray,
    q: NDArray,
    poses: NDArray,
    truth: NDArray | None,
    strain_names: Sequence[str],
    into: Any = None,
    *,
    title: str | None = None,
    modelled: Sequence[bool] | None = None,
    tip: tuple[NDArray, NDArray] | None = None,
) -> Path:
    """Draw a rollout: the tip against a truth with the error over time, else the modelled strains over time.

    Parameters
    ----------
    path : str or Path
        Image file to write.
    t : ndarray, shape (T,)
    q : ndarray, shape (T, 3m)
        Predicted strains.
    poses : ndarray, shape (T, N + 1, 3)
        Predicted poses of the base and the markers.
    truth : ndarray, shape (T, N + 1, 3), or None
        True poses: the end effector against them, with its error panels.
    strain_names : sequence of str
        Names of the columns of ``q``.
    into : FileSet, optional
        The :class:`~pcs_sindy.core.atomic.FileSet` the image joins; default: written atomically on its own.
    title : str, optional
    modelled : sequence of bool, optional
        Which strains the model has (without a truth only these get a panel; default all).
    tip : (measured, predicted) arrays (T, 3), optional
        Tip positions in the capture frame (motion capture; NaN where not measured): drawn instead of
        the poses, with the position error over time.

    Returns
    -------
    Path
    """
    plt = _pyplot()
    from ..plotting.rollout import plot_end_effector, plot_tip_positions

    if tip is not None:
        fig = plot_tip_positions(t, tip[0], tip[1], labels=["model"], title=title)
    elif truth is not None:
        fig = plot_end_effector(t, truth[:, -1], poses[:, -1], labels=["model"], title=title)
    else:
        keep = np.ones(len(strain_names), bool) if modelled is None else np.asarray(modelled, dtype=bool)
        kinds = [(0, "bending [1/m]"), (1, "shear [-]"), (2, "axial [-]")]
        rows = [(c, label) for c, label in kinds if np.any(keep[c::3])]
        if not rows:  # a model that keeps no strain still shows its (zero) bending
            rows, keep = kinds[:1], np.arange(len(strain_names)) % 3 == 0
        fig, axes = plt.subplots(len(rows), 1, figsize=(8, 1.2 + 2.0 * len(rows)), sharex=True, squeeze=False)
        for ax, (c, label) in zip(axes[:, 0], rows):
            for j in range(c, len(strain_names), 3):
                if keep[j]:
                    ax.plot(t, q[:, j], label=strain_names[j])
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            ax.legend(loc="upper right", fontsize="small")
        axes[-1, 0].set_xlabel("time t [s]")
        axes[0, 0].set_title(title or "rollout: predicted strains")
        fig.tight_layout()
    return _save(fig, path, into)


def spatial_rollout_figure(
    path: str | Path,
    t: NDArray,
    q: NDArray,
    positions: NDArray,
    truth: NDArray | None,
    strain_names: Sequence[str],
    modelled: Sequence[bool],
    into: Any = None,
    *,
    title: str | None = None,
) -> Path:
    """Draw the rollout of a spatial model: the tip in 3-D against a truth, else the modelled strains by kind.

    Parameters
    ----------
    path : str or Path
    t : ndarray, shape (T,)
    q : ndarray, shape (T, 6m)
        Predicted strains.
    positions : ndarray, shape (T, N + 1, 3)
        Predicted positions of the base and the markers (base frame).
    truth : ndarray, shape (T, N + 1, 3), or None
        True positions: the tip against them (:func:`pcs_sindy.plotting.plot_positions_3d`).
    strain_names : sequence of str
    modelled : sequence of bool
        Which strains the model has (the panels without a truth).
    into : FileSet, optional
    title : str, optional

    Returns
    -------
    Path
    """
    plt = _pyplot()
    if truth is not None:
        from ..plotting.spatial import plot_positions_3d

        fig = plot_positions_3d(t, truth[:, -1], positions[:, -1], labels=["model"], title=title)
        return _save(fig, path, into)
    keep = np.asarray(modelled, dtype=bool)
    # the spatial strain order per segment: bend_z, bend_x, twist, shear_x, shear_z, axial
    kinds = [((0, 1), "bending [1/m]"), ((2,), "twist [1/m]"), ((3, 4), "shear [-]"), ((5,), "axial [-]")]
    column = np.arange(len(strain_names)) % 6
    rows = [(cols, label) for cols, label in kinds if np.any(keep & np.isin(column, cols))]
    if not rows:
        rows, keep = kinds[:1], np.isin(column, (0, 1))
    fig, axes = plt.subplots(len(rows), 1, figsize=(8, 1.2 + 2.0 * len(rows)), sharex=True, squeeze=False)
    for ax, (cols, label) in zip(axes[:, 0], rows, strict=True):
        for j in np.flatnonzero(keep & np.isin(column, cols)):
            ax.plot(t, q[:, j], label=strain_names[j])
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1, 0].set_xlabel("time t [s]")
    axes[0, 0].set_title(title or "rollout: predicted strains")
    fig.tight_layout()
    return _save(fig, path, into)


def strains_figure(
    path: str | Path,
    t: NDArray,
    q: NDArray,
    q_true: NDArray,
    strain_names: Sequence[str],
    modelled: Sequence[bool],
    *,
    title: str | None = None,
    into: Any = None,
) -> Path:
    """The modelled strains against measured ones, with residual panels (``rollout --truth <strain file>``)."""
    from ..plotting.rollout import plot_rollout

    keep = np.asarray(modelled, dtype=bool)
    if not np.any(keep):
        keep = np.arange(len(strain_names)) % 3 == 0
    names = [nm for nm, k in zip(strain_names, keep) if k]
    fig = plot_rollout(t, q_true[:, keep], q[:, keep], names=names, labels=["model"], title=title)
    return _save(fig, path, into)


def _stills_camera(xy: NDArray) -> Any:
    """A camera of the demo's image size framing the points ``xy`` (N, 2) with a margin."""
    from ..core.camera import Camera

    lo, hi = xy.min(axis=0), xy.max(axis=0)
    margin = 25.0
    ppm = float(
        min(
            (DEMO_SIZE[0] - 2 * margin) / max(hi[0] - lo[0], 1e-6),
            (DEMO_SIZE[1] - 2 * margin) / max(hi[1] - lo[1], 1e-6),
        )
    )
    centre = 0.5 * (lo + hi)
    return Camera(
        pixels_per_metre=ppm,
        image_size=DEMO_SIZE,
        origin=(0.5 * (DEMO_SIZE[0] - 1) - ppm * centre[0], 0.5 * (DEMO_SIZE[1] - 1) - ppm * centre[1]),
    )


def demo_report(
    report_dir: str | Path,
    *,
    fusion: Any,
    model: Any,
    sim: Any,
    poses: NDArray,
    train_files: Sequence[str | Path],
    validation_file: str | Path,
    pose_trajectories: Sequence[Any],
    progress: bool = False,
    tick: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Figures, equations and ``metrics.json`` of a demo run on two_segment.

    Parameters
    ----------
    report_dir : str or Path
        Folder of the report (created).
    fusion : KinematicFusion
        Fitted on ``pose_trajectories``.
    model : EulerLagrangeRegressor
        Identified model.
    sim : StrainTrajectory
        Its rollout under the validation forces; ``poses`` the predicted marker poses.
    train_files, validation_file : path
        Recordings written by ``pcs-sindy simulate`` (``poses_true`` is the truth).
    pose_trajectories : sequence of PoseTrajectory
        The training poses extracted from the videos.
    progress : bool
        Progress bar of the animation.
    tick : callable, optional
        Called with a stage name after each stage (wall-time bookkeeping).

    Returns
    -------
    dict
        ``dir``, ``files`` (figure names by key), ``metrics`` (this run) and ``equations``.
    """
    from ..core.metrics import distributed_errors, end_effector_errors
    from ..core.trajectory import PoseTrajectory
    from ..fusion.kinematic_fusion import KinematicFusion, threshold_sweep
    from ..plotting.animation import animate_rollout
    from ..plotting.fusion import plot_error_vs_segments, plot_strain_distance_profile
    from ..plotting.rollout import plot_end_effector, plot_rollout
    from ..plotting.stills import plot_stills
    from ..simulation.rendering import render_frames
    from ..vision.extractor import MarkerPoseExtractor

    plt = _pyplot()
    tick = tick or (lambda name: None)
    rep = output_dir(report_dir)
    files: dict[str, str] = {}

    def save(fig: Any, name: str, key: str) -> None:
        try:
            atomic.savefig(fig, rep / name, dpi=100)
        finally:
            plt.close(fig)
        files[key] = name

    # kinematic fusion on the training videos against the noise-free simulated poses
    truths = [read_poses(p, "poses_true")[1] for p in train_files]
    rec = fusion.reconstruct(pose_trajectories)
    fd_p, fd_th = distributed_errors(
        np.concatenate([r.poses[:, 1:] for r in rec]), np.concatenate([p[:, 1:] for p in truths])
    )
    h = fusion.threshold_
    save(
        plot_strain_distance_profile(
            fusion.distance_profile_,
            h,
            marker_arc_lengths=fusion.marker_arc_lengths_,
            segment_lengths=fusion.segment_lengths_,
            title=f"strain distance of adjacent segments (h = {h:g})",
        ),
        "fig6_strain_distance.png",
        "fig6",
    )

    # Fig. 8: the seed's Algorithm 1 with end-pose strains, one merge per iteration (every model size
    # appears as h grows), swept on every 10th frame against the noise-free poses
    step = 10
    sub = [PoseTrajectory(tr.poses[::step], tr.t[::step]) for tr in pose_trajectories]
    sub_truth = [PoseTrajectory(p[::step], tr.t[::step]) for p, tr in zip(truths, pose_trajectories)]
    d = np.asarray(fusion.distance_profile_, dtype=float)
    hs = np.unique(np.r_[np.geomspace(0.01, 1.0, 12), 1.0001 * np.quantile(d, np.linspace(0.0, 1.0, 9))])
    template = KinematicFusion(
        min_segment_markers=1, merge="closest_pair", shape_fit="end_pose", total_length=fusion.total_length_
    )
    rows = threshold_sweep(sub, hs[hs > 0], truth=sub_truth, fusion=template)
    tick("report: sweep")
    save(
        plot_error_vs_segments(
            rows, selected=int(fusion.n_segments_), logy=True, title="fusion error against the number of segments"
        ),
        "fig8_error_vs_segments.png",
        "fig8",
    )

    # Fig. 9: rollout of the validation actuation against the simulated truth
    val = read_arrays(validation_file, ["t", "q", "poses_true"], "recording")
    t, truth = val["t"], val["poses_true"]
    save(
        plot_rollout(t, val["q"], sim.q, labels=["model"], title="configuration: model vs truth"),
        "fig9_strains.png",
        "fig9_strains",
    )
    save(
        plot_end_effector(t, truth[:, -1], poses[:, -1], labels=["model"], title="end effector: model vs truth"),
        "fig9_end_effector.png",
        "fig9_ee",
    )

    # Fig. 10: validation stills rendered as the videos are, markers detected, model backbone overlaid;
    # the camera frames the stills (a robot curled over its base can leave the training cameras' view)
    picks = np.linspace(0, t.size - 1, 5).round().astype(int)[1:]
    camera = _stills_camera(truth[picks][..., :2].reshape(-1, 2))
    frames = render_frames(truth[picks], camera, marker_size=DEMO_MARKER_SIZE)
    backbone = sim.poses(np.linspace(0.0, float(np.sum(model.kinematics_.segment_lengths)), 60))
    # each still on its own: they are far apart in time, so no tracking across them; a still whose
    # markers touch (a tight curl) shows no detections rather than invented ones
    det = []
    for frame in frames:
        try:
            det.append(
                MarkerPoseExtractor(truth.shape[1] - 1, camera=camera, dt=1e-3, progress=False)
                .fit_transform([frame[None]])[0]
                .poses[0]
            )
        except ValueError:
            det.append(np.empty((0, 3)))
    save(
        plot_stills(
            frames,
            detected=det,
            backbone=backbone[picks],
            times=list(t[picks]),
            camera=camera,
            title="validation stills: detected markers and the model's backbone",
        ),
        "fig10_stills.png",
        "fig10",
    )
    tick("report: figures")

    from ..core.video import browser_video_format

    animation = "rollout" + browser_video_format()  # H.264 .mp4 if this OpenCV build has it, else VP8 .webm or .gif
    animate_rollout(
        rep / animation,
        t,
        truth,
        backbone,
        truth[:, 1:],
        fps=15.0,
        labels=("truth", "model"),
        size=(400, 400),
        progress=progress,
    )
    files["animation"] = animation
    tick("report: animation")
    equations = model.equations(precision=4)
    atomic.write_text(rep / "equations.txt", "\n".join(equations) + "\n")
    files["equations"] = "equations.txt"

    e_p, e_th = end_effector_errors(poses[:, 1:], truth[:, 1:])
    d_p, d_th = distributed_errors(poses[:, 1:], truth[:, 1:])
    metrics = {
        "segment_lengths": [float(v) for v in fusion.segment_lengths_],
        "e_p_dist_fusion": fd_p,
        "e_theta_dist_fusion": fd_th,
        "e_p_ee": e_p,
        "e_theta_ee": e_th,
        "e_p_dist_rollout": d_p,
        "e_theta_dist_rollout": d_th,
        "stiffness": [float(v) for v in model.stiffness_],
        "damping": [float(v) for v in model.damping_],
        "removed_strains": list(model.removed_strains_),
        "sweep": [list(map(float, r)) for r in rows],
    }
    stored = {"this_run": stored_metrics(metrics, model), "seed": stored_metrics(SEED_TWO_SEGMENT)}
    atomic.write_text(rep / "metrics.json", json.dumps(stored, indent=2, ensure_ascii=False) + "\n")
    files["metrics"] = "metrics.json"
    return {
        "dir": rep,
        "files": files,
        "metrics": metrics,
        "equations": equations,
        "threshold": h,
        "duration": float(t[-1] - t[0]),
        "n_train": len(train_files),
    }


#: how a demo metric is stored in metrics.json: its key there (the unit in the name) and the factor from SI
_STORED = {
    "segment_lengths": ("segment_lengths_m", 1.0),
    "e_p_dist_fusion": ("e_p_dist_fusion_mm", 1e3),
    "e_theta_dist_fusion": ("e_theta_dist_fusion_rad", 1.0),
    "e_p_ee": ("e_p_ee_mm", 1e3),
    "e_theta_ee": ("e_theta_ee_rad", 1.0),
    "e_p_dist_rollout": ("e_p_dist_rollout_mm", 1e3),
    "e_theta_dist_rollout": ("e_theta_dist_rollout_rad", 1.0),
}


def stored_metrics(metrics: dict[str, Any], model: Any = None) -> dict[str, Any]:
    """A demo's metrics as ``metrics.json`` stores them: every number with its unit, as ``report.md`` prints it.

    Parameters
    ----------
    metrics : dict
        In SI units (metres, radians), as :func:`demo_report` returns them (or :data:`SEED_TWO_SEGMENT`).
    model : EulerLagrangeRegressor, optional
        The identified model: names and units of ``stiffness`` and ``damping`` (per modelled strain).

    Returns
    -------
    dict
        Positions in mm, angles in rad, lengths in m, the unit in each key (``e_p_ee_mm``);
        ``stiffness`` and ``damping`` as ``{strain: {"value": ..., "unit": ...}}``; the threshold
        sweep as rows ``{"h", "n_segments", "e_p_dist_mm", "e_theta_dist_rad"}``.
    """
    out: dict[str, Any] = {}
    for key, value in metrics.items():
        if key in _STORED:
            name, factor = _STORED[key]
            out[name] = [factor * float(v) for v in value] if isinstance(value, list) else factor * float(value)
        elif key in ("stiffness", "damping") and model is not None:
            kin = model.kinematics_
            units = {"stiffness": lambda s: generalised_force_unit(s) / strain_unit(s)}
            units["damping"] = lambda s: generalised_force_unit(s) / strain_rate_unit(s)
            out[key] = {
                s: {"value": float(v), "unit": str(units[key](s))}
                for s, v, a in zip(kin.strain_names(), value, kin.active_mask)
                if a and np.isfinite(v)
            }
        elif key == "sweep":
            out[key] = [
                {"h": float(h), "n_segments": int(n), "e_p_dist_mm": 1e3 * float(p), "e_theta_dist_rad": float(t)}
                for h, n, p, t in value
            ]
        else:
            out[key] = value
    return out


def write_report_md(
    report: dict[str, Any],
    clock: dict[str, float],
    *,
    seed: int,
    quick: bool,
    machine: str = "unknown",
    identification: str = "identification",
    integration: str = "",
) -> Path:
    """Write ``report.md`` of a demo run: the metrics table next to the seed's, equations, figures, wall times.

    Parameters
    ----------
    report : dict
        As returned by :func:`demo_report`.
    clock : dict of str to float
        Wall time (s) per stage.
    seed : int
        Random seed of the simulated data.
    quick : bool
        Whether the run used the short ``--quick`` data (numbers not comparable).
    machine : str
        Description of the machine and its load.
    identification : str
        The identification settings, in words.
    integration : str
        The rollout's integration scheme and tolerances, in words.

    Returns
    -------
    Path
    """
    m, s, f = report["metrics"], SEED_TWO_SEGMENT, report["files"]
    lengths = ", ".join(f"{v:.4f}" for v in m["segment_lengths"])
    lines = [
        "# pcs-sindy demo: two_segment from rendered videos",
        "",
        f"Scenario two_segment (true segment lengths [0.07, 0.1] m), seed {seed}, no noise"
        f"{' (--quick: short data, numbers not comparable)' if quick else ''}. "
        f"{report['n_train']} training recordings simulated, rendered to {DEMO_SIZE[0]}x{DEMO_SIZE[1]} MJPG videos, "
        f"markers extracted from the videos, kinematic fusion (h = {report['threshold']:g}, rest length given as "
        f"measured), {identification}, rollout of the {report['duration']:g} s validation actuation from rest "
        f"({integration}). "
        "The validation truth is the simulated noise-free marker poses (the validation video is not rendered; "
        "see the stills).",
        "",
        "| quantity | this run | seed |",
        "|---|---|---|",
        f"| fused segment lengths [m] | [{lengths}] | {s['segment_lengths']} |",
        f"| e_p^dist fusion, training, vs noise-free poses [mm] | {m['e_p_dist_fusion'] * 1e3:.3g} "
        f"| {s['e_p_dist_fusion'] * 1e3:.3g} |",
        f"| e_θ^dist fusion, training, vs noise-free poses [rad] | {m['e_theta_dist_fusion']:.3g} "
        f"| {s['e_theta_dist_fusion']:.3g} |",
        f"| e_p^EE rollout [mm] | {m['e_p_ee'] * 1e3:.3g} | {s['e_p_ee'] * 1e3:.3g} |",
        f"| e_θ^EE rollout [rad] | {m['e_theta_ee']:.3g} | {s['e_theta_ee']:.3g} |",
        f"| e_p^dist rollout [mm] | {m['e_p_dist_rollout'] * 1e3:.3g} | – |",
        f"| e_θ^dist rollout [rad] | {m['e_theta_dist_rollout']:.3g} | – |",
        "",
        "Identified stiffness per strain: "
        + ", ".join(
            f"{name} {v:.4g} {generalised_force_unit(name) / strain_unit(name)}"
            for name, v in ((f"{STRAIN_NAMES[i % 3]}_{i // 3 + 1}", v) for i, v in enumerate(m["stiffness"]))
            if np.isfinite(v)
        )
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
        f"Machine: {machine}. Stages marked 'report:' are part of 'report'.",
        "",
    ]
    path = Path(report["dir"]) / "report.md"
    atomic.write_text(path, "\n".join(lines))
    return path
