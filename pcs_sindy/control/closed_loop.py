"""Closed loops of a controller and a plant: the ground-truth simulator driven at the control rate.

:func:`closed_loop` advances the plant (a :class:`~pcs_sindy.simulation.dynamics.PCSRobot`
with its own segmentation and actuation) one control period at a time with
the held command (``plant.advance``), shows the controller either the exact
state or noisy marker poses at a camera rate (:mod:`.estimation`), and
returns a :class:`ClosedLoopResult` with the plant's strains, marker poses,
tip, commands and the tip error against the task's reference.

This is the one module of :mod:`pcs_sindy.control` that runs the simulator;
the controllers themselves only see a model.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from ..core.kinematics import SEED_Q_MAX
from ..core.simulate_contract import SimulationError
from . import _kinematics
from .base import check_time_grid
from .estimation import PoseEstimator, StateMap

__all__ = [
    "ClosedLoopResult",
    "closed_loop",
    "plant_equilibrium",
    "check_actuation",
    "DIVERGENCE_LIMIT",
    "MAX_PLANT_STEPS",
]

#: default ``divergence_limit`` of :func:`closed_loop`: multiples of the typical strain magnitudes
DIVERGENCE_LIMIT = 20.0
#: default ``max_plant_steps`` of :func:`closed_loop`: integration steps of the plant per control period
MAX_PLANT_STEPS = 10_000


@dataclass
class ClosedLoopResult:
    """A closed-loop run.

    Attributes
    ----------
    t : ndarray (T,)
        Control times.
    q, qd : ndarray (T, 3m_plant)
        The plant's strains and rates at ``t``.
    u : ndarray (T, p)
        Command held on ``[t_k, t_{k+1})``.
    q_model, qd_model : ndarray (T, n)
        What the controller saw (modelled strains of its model).
    poses : ndarray (T, N + 1, 3)
        The plant's true base and marker poses.
    tip : ndarray (T, 2)
        The plant's true tip position.
    tip_reference : ndarray (T, 2)
        The tip the task asked for.
    q_reference : ndarray (T, n)
        The model strains the controller steered to.
    frame_times : ndarray (F,)
        Camera times (observation by poses; empty otherwise).
    frames : ndarray (F, N + 1, 3)
        The noisy poses the controller received.
    step_time : float
        Mean wall time of one controller step [s] (observation excluded).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    u: NDArray[np.float64]
    q_model: NDArray[np.float64]
    qd_model: NDArray[np.float64]
    poses: NDArray[np.float64]
    tip: NDArray[np.float64]
    tip_reference: NDArray[np.float64]
    q_reference: NDArray[np.float64]
    frame_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    frames: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0, 3)))
    step_time: float = float("nan")

    @property
    def tip_error(self) -> NDArray[np.float64]:
        """``|tip - tip_reference|`` (T,) [m]."""
        return np.linalg.norm(self.tip - self.tip_reference, axis=1)

    def final_tip_error(self, window: float = 0.05) -> float:
        """Mean tip error over the last ``window`` seconds [m]."""
        return float(self.tip_error[self.t >= self.t[-1] - window].mean())

    def settling_time(self, band: float = 0.02, window: float = 0.05) -> float:
        """Time [s] after which the tip stays within ``band`` of its travel around its final position.

        The final position is the mean over the last ``window`` seconds and the
        travel its distance from the initial tip; ``inf`` if the tip has not
        settled (the band is left in the last ``window``).
        """
        final = self.tip[self.t >= self.t[-1] - window].mean(axis=0)
        travel = np.linalg.norm(final - self.tip[0])
        if travel == 0.0:
            return 0.0
        dist = np.linalg.norm(self.tip - final, axis=1)
        outside = np.flatnonzero(dist > band * travel)
        if outside.size == 0:
            return 0.0
        last = outside[-1]
        if self.t[last] >= self.t[-1] - window:
            return float("inf")
        return float(self.t[last + 1] - self.t[0])

    def peak_command(self) -> NDArray[np.float64]:
        """Largest ``|u|`` of every input (p,)."""
        return np.abs(self.u).max(axis=0)

    def tip_rmse(self, start: float = 0.0) -> float:
        """Root-mean-square tip error [m] over ``t >= start``."""
        e = self.tip_error[self.t >= start]
        return float(np.sqrt(np.mean(e**2)))


def _check_budget(
    q: NDArray[np.float64],
    qd: NDArray[np.float64],
    bound: NDArray[np.float64],
    now: float,
    start_time: float,
    max_wall_time: float | None,
    divergence_limit: float,
) -> None:
    """SimulationError when the plant's strains left ``bound`` or the loop overran its wall-time budget."""
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd)) and np.all(np.abs(q) <= bound)):
        i = int(np.argmax(~np.isfinite(q) | (np.abs(q) > bound)))
        raise SimulationError(
            f"closed loop diverged at t = {now:.6g} s: plant strain {i} = {q[i]:.6g} beyond "
            f"{bound[i]:.6g} (divergence_limit = {divergence_limit:g} times its typical magnitude); the "
            "gains or the model do not stabilise the plant",
            now,
            np.concatenate([q, qd]),
        )
    if max_wall_time is not None and time.perf_counter() - start_time > max_wall_time:
        raise SimulationError(
            f"closed loop overran max_wall_time = {max_wall_time:g} s at t = {now:.6g} s of the control times",
            now,
            np.concatenate([q, qd]),
        )


def _fd_jacobian(fun: Any, q: NDArray[np.float64], h: float = 1e-7) -> NDArray[np.float64]:
    return np.stack([(fun(q + h * e) - fun(q - h * e)) / (2 * h) for e in np.eye(q.size)], axis=1)


def plant_equilibrium(
    plant: Any, u: ArrayLike, q0: ArrayLike | None = None, *, tol: float = 1e-12, max_iter: int = 50
) -> NDArray[np.float64]:
    """The plant's static equilibrium under held inputs ``u`` (Newton on ``G + K q - A(q) u``), (3m,)."""
    u = np.asarray(u, dtype=float)

    def residual(q):
        return plant.gravity_forces(q) + plant.elastic_forces(q) - plant.actuation_forces(q, u)

    q = np.zeros(plant.n_q) if q0 is None else np.array(q0, dtype=float)
    for _ in range(max_iter):
        dq = -np.linalg.solve(_fd_jacobian(residual, q), residual(q))
        q = q + dq
        if np.max(np.abs(dq)) < tol * (1.0 + np.max(np.abs(q))):
            return q
    raise RuntimeError(f"the plant has no static equilibrium near q0 under inputs {u.tolist()}")


def _zero_input(plant: Any) -> NDArray[np.float64]:
    return np.zeros(plant.n_inputs)


def check_actuation(plant: Any, fm: Any) -> None:
    """Raise ValueError unless the controller's model is driven like the plant.

    A model driven by generalised forces (no ``actuation_layout``) matches a
    plant without actuators with as many segments (its forces go to the plant's
    strains one to one, as they did in identification); an actuated model
    matches a plant with the same number of inputs and, when both describe
    it, the same actuator layout.
    """
    p_model, p_plant = int(fm.n_inputs), int(plant.n_inputs)
    layout = getattr(fm, "actuation_layout", None)
    plant_layout = None if plant.actuation is None else plant.actuation.layout()
    plant_desc = "generalised forces" if plant.actuation is None else repr(plant.actuation)
    if layout is None:
        if plant.actuation is not None or fm.kinematics.n_segments != plant.n_segments or p_model != p_plant:
            raise ValueError(
                f"plant: driven by {plant_desc} ({p_plant} inputs, {plant.n_segments} segments) but the controller's "
                f"model is driven by {p_model} generalised forces on {fm.kinematics.n_segments} segments; the "
                "actuation does not match"
            )
        return
    if p_model != p_plant or (plant_layout is not None and layout != plant_layout):
        raise ValueError(
            f"plant: actuation {plant_layout} ({p_plant} inputs) does not match the controller's model "
            f"{layout} ({p_model} inputs)"
        )


def _camera_noise(
    poses: NDArray[np.float64], sigma_p: float, sigma_theta: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Gaussian noise on the tracked cross-sections of one frame's poses (not the base, which defines the frame)."""
    out = np.array(poses, dtype=float, copy=True)
    out[..., 1:, :2] += sigma_p * rng.standard_normal(out[..., 1:, :2].shape)
    out[..., 1:, 2] += sigma_theta * rng.standard_normal(out[..., 1:, 2].shape)
    return out


def closed_loop(
    plant: Any,
    controller: Any,
    reference: Any,
    t: ArrayLike,
    *,
    observe: str = "state",
    q0: ArrayLike | None = None,
    qd0: ArrayLike | None = None,
    camera_rate: float = 100.0,
    pose_noise: tuple[float, float] = (0.0, 0.0),
    fusion: Any = None,
    marker_arc_lengths: ArrayLike | None = None,
    velocity_cutoff: float = 15.0,
    plant_step: float | None = 5e-4,
    seed: int | None = 0,
    divergence_limit: float = DIVERGENCE_LIMIT,
    max_plant_steps: int | None = MAX_PLANT_STEPS,
    max_wall_time: float | None = None,
    progress: bool = False,
) -> ClosedLoopResult:
    """Run ``controller`` on ``plant`` for the task ``reference`` over the control times ``t``.

    Parameters
    ----------
    plant : PCSRobot
        Ground truth with its own segmentation and actuation (``advance``,
        ``kinematics``, ``n_inputs``, ``actuation``).
    controller : Controller
        Not started: :meth:`~.base.Controller.start` is called here with
        ``reference`` and ``t``.
    reference : any
        The controller's task (strain set-point, tip target, trajectory).
    t : array_like (T,)
        Uniform control times; the period is the control period.
    observe : {"state", "poses"}
        ``"state"``: the exact state, in the model's strains (:class:`~.estimation.StateMap`).
        ``"poses"``: the plant's marker poses every ``1 / camera_rate`` s with
        Gaussian noise, through ``fusion`` (:class:`~.estimation.PoseEstimator`).
        Either way the controller also gets the measured tip (the last
        marker's position: exact, or of the latest noisy frame).
    q0, qd0 : array_like (3m_plant,), optional
        Initial plant state; default its equilibrium without input, at rest.
    camera_rate : float
        Frames per second (observe="poses"); the control rate must be a multiple.
    pose_noise : (float, float)
        Standard deviations of the position [m] and angle [rad] noise on each
        marker (not the base, which defines the frame).
    fusion : KinematicFusion, optional
        Fitted on the plant's recordings; needed for ``observe="poses"``, and
        gives the model's marker arc lengths for a state map between different segmentations.
    marker_arc_lengths : array_like (N + 1,), optional
        Arc lengths of the base and markers on the plant; default ``N`` =
        the fusion's markers (else 20) equally spaced, the last at the tip.
    velocity_cutoff : float
        Cut-off [Hz] of the rate filter of pose observation.
    plant_step : float or None
        Fixed Radau step of the plant's integration (``plant.advance``), or None
        for error control (tolerances 1e-9 / 1e-12: the integration error out of the way).
    seed : int, optional
        Of the pose noise.
    divergence_limit : float, default 20
        The loop counts as diverged, and stops with a SimulationError, when a
        plant strain exceeds this many times its typical magnitude (60 1/m
        bending, 0.3 shear and axial: 1200 1/m and 6 by default), or is not
        finite.  An unstable loop (e.g. negative gains) otherwise drives the
        plant's integration into ever smaller steps for minutes.
    max_plant_steps : int or None, default 10000
        Most integration steps of the plant in one control period
        (``plant.advance(..., max_steps=)``; 2 with the default fixed step);
        exceeded: a SimulationError.  None: no bound.
    max_wall_time : float, optional
        Budget [s] of wall time for the whole loop, checked after every
        control period; exceeded: a SimulationError naming the control time
        reached.  Default: none.
    progress : bool
        tqdm progress bar over the control steps.

    Returns
    -------
    ClosedLoopResult

    Raises
    ------
    ValueError
        Bad arguments (naming them), or a plant whose actuation does not match the controller's model.
    SimulationError
        If the plant's integration fails, the plant's strains leave
        ``divergence_limit`` (the loop went unstable) or the loop overruns ``max_wall_time``.
    """
    t, dt = check_time_grid(t)
    if isinstance(divergence_limit, bool) or not (
        isinstance(divergence_limit, (int, float, np.integer, np.floating)) and divergence_limit > 0
    ):
        raise ValueError(f"divergence_limit must be a number > 0 (np.inf: no limit); got {divergence_limit!r}")
    if max_wall_time is not None and (
        isinstance(max_wall_time, bool)
        or not isinstance(max_wall_time, (int, float, np.integer, np.floating))
        or not max_wall_time > 0
    ):
        raise ValueError(f"max_wall_time must be a number of seconds > 0, or None; got {max_wall_time!r}")
    if max_plant_steps is not None and (
        isinstance(max_plant_steps, bool) or not isinstance(max_plant_steps, (int, np.integer)) or max_plant_steps < 1
    ):
        raise ValueError(f"max_plant_steps must be an integer >= 1 or None; got {max_plant_steps!r}")
    if observe not in ("state", "poses"):
        raise ValueError(f"observe must be 'state' or 'poses'; got {observe!r}")
    for attr in ("advance", "kinematics", "n_inputs", "actuation"):
        if not hasattr(plant, attr):
            raise ValueError(
                f"plant must be a PCSRobot (ground-truth simulator); {type(plant).__name__} has no {attr!r}"
            )
    q = plant_equilibrium(plant, _zero_input(plant)) if q0 is None else np.array(q0, dtype=float)
    qd = np.zeros(plant.n_q) if qd0 is None else np.array(qd0, dtype=float)
    for name, val in (("q0", q), ("qd0", qd)):
        if val.shape != (plant.n_q,) or not np.all(np.isfinite(val)):
            raise ValueError(f"{name} must be finite with shape ({plant.n_q},) (the plant's strains); got {val.shape}")
    sig = np.asarray(pose_noise, dtype=float)
    if sig.shape != (2,) or not np.all(np.isfinite(sig)) or np.any(sig < 0):
        raise ValueError(f"pose_noise must be (position [m], angle [rad]) standard deviations >= 0; got {pose_noise!r}")
    if fusion is not None and not hasattr(fusion, "segment_lengths_"):
        raise ValueError("fusion must be a fitted KinematicFusion")
    n_markers = fusion.n_markers_ if fusion is not None else 20
    s_plant = (
        plant.kinematics.marker_arc_lengths(n_markers)
        if marker_arc_lengths is None
        else np.asarray(marker_arc_lengths, dtype=float)
    )
    if (
        s_plant.shape != (n_markers + 1,)
        or s_plant[0] != 0.0
        or np.any(np.diff(s_plant) <= 0)
        or s_plant[-1] > plant.kinematics.total_length * (1 + 1e-12)
    ):
        raise ValueError(
            f"marker_arc_lengths must be {n_markers + 1} increasing arc lengths from 0 (the base) "
            f"within the plant's {plant.kinematics.total_length:g} m; got {s_plant.tolist()}"
        )

    controller.start(reference, t)
    fm = controller.forward_model_
    check_actuation(plant, fm)
    kin = fm.kinematics
    s_model = (
        fusion.marker_arc_lengths_
        if fusion is not None
        else s_plant * (kin.total_length / plant.kinematics.total_length)
    )
    rng = np.random.default_rng(seed)
    if observe == "poses":
        if fusion is None:
            raise ValueError("observe='poses' needs fusion, a KinematicFusion fitted on the plant's recordings")
        if not np.allclose(kin.segment_lengths, fusion.segment_lengths_, rtol=1e-9, atol=0.0):
            raise ValueError(
                f"fusion segments the robot as {list(fusion.segment_lengths_)} but the controller's model "
                f"has segments {list(kin.segment_lengths)}"
            )
        if not (np.isfinite(camera_rate) and camera_rate > 0):
            raise ValueError(f"camera_rate must be finite and > 0; got {camera_rate!r}")
        n_sub = int(round(1.0 / (camera_rate * dt)))
        if n_sub < 1 or abs(n_sub * dt * camera_rate - 1.0) > 1e-9:
            raise ValueError(f"camera_rate = {camera_rate!r} Hz must divide the control rate {1.0 / dt:g} Hz")
        if not (np.isfinite(velocity_cutoff) and velocity_cutoff > 0):
            raise ValueError(f"velocity_cutoff must be finite and > 0; got {velocity_cutoff!r}")
        estimator = PoseEstimator(fusion, kin.active_mask, n_sub * dt, velocity_cutoff)
    else:
        n_sub = 0
        state_map = StateMap(kin, plant.kinematics, s_model, s_plant)

    advance_kw = {"step": plant_step} if plant_step is not None else {"step": None, "rtol": 1e-9, "atol": 1e-12}
    if max_plant_steps is not None:
        advance_kw["max_steps"] = int(max_plant_steps)
    T = t.size
    Q, QD = np.empty((T, plant.n_q)), np.empty((T, plant.n_q))
    U = np.empty((T, controller.n_inputs_))
    QM, QDM = np.empty((T, kin.n_active)), np.empty((T, kin.n_active))
    frame_times, frames = [], []
    spent = 0.0
    # the measured tip given to the controller: the last marker (the tip unless marker_arc_lengths say otherwise)
    geo_plant = (
        np.asarray(plant.kinematics.segment_lengths, dtype=float),
        np.asarray(plant.kinematics.base_pose, dtype=float),
        np.array([s_plant[-1]]),
    )
    last_marker = np.empty((1, 3))
    tip_seen = np.empty(2)
    bound = float(divergence_limit) * np.tile(np.asarray(SEED_Q_MAX, dtype=float), plant.n_segments)
    start_time = time.perf_counter()
    for k in tqdm(range(T), desc="closed loop", disable=not progress, leave=False):
        Q[k], QD[k] = q, qd
        if observe == "poses":
            if k % n_sub == 0:
                frame = _camera_noise(plant.kinematics.forward_kinematics(q, s_plant)[None], sig[0], sig[1], rng)[0]
                estimator.update(t[k], frame)
                tip_seen[:] = frame[-1, :2]
                frame_times.append(t[k])
                frames.append(frame)
            qm, qdm = estimator(t[k])
        else:
            qm, qdm = state_map(q, qd)
            _kinematics.marker_poses(q, *geo_plant, last_marker)
            tip_seen[:] = last_marker[0, :2]
        QM[k], QDM[k] = qm, qdm
        tic = time.perf_counter()
        u = controller.command(k, qm, qdm, tip_seen)
        spent += time.perf_counter() - tic
        U[k] = u
        if k < T - 1:
            q, qd = plant.advance(q, qd, u, dt, **advance_kw)
            _check_budget(q, qd, bound, float(t[k + 1]), start_time, max_wall_time, divergence_limit)
    poses = plant.kinematics.forward_kinematics(Q, s_plant)
    tip = plant.kinematics.forward_kinematics(Q, [plant.kinematics.total_length])[:, 0, :2]
    return ClosedLoopResult(
        t=t,
        q=Q,
        qd=QD,
        u=U,
        q_model=QM,
        qd_model=QDM,
        poses=poses,
        tip=tip,
        tip_reference=np.asarray(controller.reference_tip_, dtype=float),
        q_reference=np.asarray(controller.reference_strains_, dtype=float),
        frame_times=np.asarray(frame_times),
        frames=np.asarray(frames) if frames else np.zeros((0, n_markers + 1, 3)),
        step_time=spent / T,
    )
