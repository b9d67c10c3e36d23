"""The seed's scenarios (docs/method.md, "Scenarios and data") and their seeded data generation.

``get_scenario(name)`` (:mod:`pcs_sindy.simulation.catalog`) returns a
:class:`Scenario` holding the ground-truth robot; ``scenario.generate(seed=0)``
simulates the seed's data set: 8 training recordings of 0.5 s at 1 kHz with
random initial conditions and random
actuation held for 10 ms, and one 7 s validation recording under sinusoidal
actuation ``τ = f (a1 sin(ω1 t) + a2 cos(ω2 t))``.  Every recording carries
time stamps, strains, strain rates, actuation and the poses of the base and
the tracked cross-sections, optionally corrupted by Gaussian measurement noise.

Actuation magnitudes are chosen through static equilibria: a random target
configuration ``q*`` is drawn inside the strain ranges of the seed's data
(bending up to ±``bend_amplitude`` 1/m, shear and axial up to ±``strain_amplitude``)
and the actuation that holds the robot there, ``τ = K q* + G(q*)``, is applied.
The robot therefore moves across the intended strain range whatever its
stiffness and weight.

Actuated scenarios (``two_segment_tendon``, ``one_segment_pneumatic``) drive
their robot through tendons or pressure chambers instead: random actuator
inputs (each off or uniform in ``[0, input_max]``) held for 10 ms in training, slow non-negative
sinusoids of different frequencies per actuator in validation.  Their
recordings carry the inputs ``u`` (T, p) and, for checks, the generalised
forces ``τ = A(q) u`` they produced at the samples.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from ..core import atomic
from ..core.progress import ticking
from .pac import PACRobot

__all__ = ["Recording", "ScenarioData", "Scenario", "add_pose_noise"]  # get_scenario, list_scenarios: .catalog

_DATA_VERSION = 2
# the seed's data ranges (bending 1/m, shear, axial): validation actuation is scaled to stay inside
_STRAIN_LIMITS = np.array([60.0, 0.3, 0.3])


@dataclass
class Recording:
    """One simulated recording.

    Attributes
    ----------
    t : ndarray (T,)
        Time stamps [s].
    q, qd : ndarray (T, n) or None
        True strains and strain rates (PAC: ``q`` holds ``[c0, c1, σ_sh, σ_ax]``; ``qd`` is None).
    tau : ndarray (T, n) or None
        Generalised forces: the actuation held constant on ``[t_k, t_{k+1})``
        of a directly driven robot; ``A(q_k) u_k`` at the samples of an
        actuated one (for checks: it is not held between samples).
    poses : ndarray (T, N + 1, 3)
        Tracked poses (base + N cross-sections), noisy if noise was requested.
    poses_true : ndarray (T, N + 1, 3)
        Noise-free poses.
    u : ndarray (T, p) or None
        The inputs given to ``robot.simulate``, held on ``[t_k, t_{k+1})``:
        tendon tensions [N] or chamber pressures [Pa] of an actuated robot,
        the same array as ``tau`` for a directly driven one.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64] | None
    tau: NDArray[np.float64] | None
    poses: NDArray[np.float64]
    poses_true: NDArray[np.float64]
    u: NDArray[np.float64] | None = None

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0]) if self.t.size > 1 else float("nan")


@dataclass
class ScenarioData:
    """Training recordings and the validation recording of one scenario."""

    name: str
    train: list[Recording]
    validation: Recording | None
    noise: tuple[float, float] = (0.0, 0.0)
    seed: int = 0


def add_pose_noise(
    poses: NDArray[np.float64], sigma_p: float, sigma_theta: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Gaussian noise on the tracked cross-sections (not the base, which defines the frame).

    Parameters
    ----------
    poses : ndarray (T, N + 1, 3)
    sigma_p : float
        Standard deviation on x and y [m].
    sigma_theta : float
        Standard deviation on θ [rad].
    rng : numpy Generator
    """
    if sigma_p < 0 or sigma_theta < 0 or not np.isfinite(sigma_p) or not np.isfinite(sigma_theta):
        raise ValueError(f"noise standard deviations must be finite and >= 0; got ({sigma_p!r}, {sigma_theta!r})")
    out = np.array(poses, dtype=float, copy=True)
    shape = out[:, 1:, :2].shape
    out[:, 1:, :2] += sigma_p * rng.standard_normal(shape)
    out[:, 1:, 2] += sigma_theta * rng.standard_normal(shape[:2])
    return out


def _default_cache_dir() -> Path:
    root = os.environ.get("PCS_SINDY_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "pcs_sindy")
    return Path(root) / "scenarios"


@dataclass
class Scenario:
    """A named robot and the recipe that generates its data.

    Attributes
    ----------
    name : str
    robot : PCSRobot or PACRobot
        Ground-truth model (``.kinematics`` gives the segmentation of a PCS robot).
    parameters : dict
        The physical parameters the robot was built from (docs/method.md).
    seed_noise : (float, float)
        The seed's measurement noise ``(σ_p [m], σ_θ [rad])`` for this scenario.
    n_markers : int
        Tracked cross-sections (equally spaced, the last at the tip).
    input_max : tuple of float or None
        Actuated scenarios: the largest training input of each actuator.
    actuation_reference : str or None
        Stiffened variants: the name of the nominal scenario whose robot sets the
        training forces (the same forces move a stiff strain very little, which is
        what sparsification has to detect, seed Case 4).
    actuation_robot : PCSRobot or None
        That nominal robot (given with ``actuation_reference``).
    """

    name: str
    robot: Any
    parameters: dict = field(default_factory=dict)
    seed_noise: tuple[float, float] = (0.0, 0.0)
    n_markers: int = 20
    dt: float = 1e-3
    n_train: int = 8
    train_duration: float = 0.5
    hold: float = 0.01
    validation_duration: float = 7.0
    bend_amplitude: float = 40.0
    strain_amplitude: float = 0.2
    description: str = ""
    actuation_reference: str | None = None
    input_max: tuple[float, ...] | None = None
    actuation_robot: Any = field(default=None, repr=False)

    @property
    def actuation(self) -> dict[str, Any] | None:
        """The actuation layout as a user knows it from the design (JSON-able), or None.

        Tendons: ``{"type": "tendon", "end": [...], "side": [...]}`` (termination
        arc lengths [m] and sides ±1 of the backbone); pressure chambers:
        ``{"type": "pressure", "start": [...], "end": [...], "side": [...]}``.
        Not the offsets or gains, which stay on ``robot.actuation`` for checks.
        None for a robot driven directly by generalised forces (``u`` is τ).
        """
        act = None if self.is_kinematic else self.robot.actuation
        return None if act is None else act.layout()

    @property
    def is_kinematic(self) -> bool:
        """True for the PAC robot, which has no dynamics."""
        return isinstance(self.robot, PACRobot)

    @property
    def marker_arc_lengths(self) -> NDArray[np.float64]:
        """Arc lengths of the base and the tracked cross-sections."""
        total = self.robot.total_length if self.is_kinematic else self.robot.kinematics.total_length
        return np.linspace(0.0, total, self.n_markers + 1)

    def marker_poses(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """True poses (T, N + 1, 3) of the base and the tracked cross-sections."""
        if self.is_kinematic:
            return self.robot.forward_kinematics(q, self.marker_arc_lengths)
        return self.robot.kinematics.forward_kinematics(q, self.marker_arc_lengths)

    # ------------------------------------------------------------------
    def _amplitudes(self) -> NDArray[np.float64]:
        m = self.robot.kinematics.n_segments
        return np.tile([self.bend_amplitude, self.strain_amplitude, self.strain_amplitude], m)

    def _actuation_robot(self) -> Any:
        if self.actuation_reference is None:
            return self.robot
        if self.actuation_robot is None:
            raise ValueError(
                f"scenario {self.name!r}: actuation_reference={self.actuation_reference!r} needs the nominal "
                "robot as actuation_robot (get_scenario sets both)"
            )
        return self.actuation_robot

    def _holding_force(self, q_target: NDArray[np.float64]) -> NDArray[np.float64]:
        robot = self._actuation_robot()
        return robot.elastic_forces(q_target) + robot.gravity_forces(q_target)

    def _simulate(self, q0, qd0, t, u) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """States (T, n) or, for a batch, (T, B, n)."""
        runs = self.robot.simulate(q0, qd0, t, u)
        if isinstance(runs, list):
            return np.stack([r.q for r in runs], axis=1), np.stack([r.qd for r in runs], axis=1)
        return runs.q, runs.qd

    def _training_recordings(self, rng: np.random.Generator) -> list[tuple]:
        if self.input_max is not None:
            return self._actuated_training_recordings(rng)
        n = self.robot.n_q
        amp = self._amplitudes()
        n_samples = int(round(self.train_duration / self.dt))
        t = np.arange(n_samples) * self.dt
        per_hold = max(1, int(round(self.hold / self.dt)))
        n_holds = -(-n_samples // per_hold)
        targets = rng.uniform(-1.0, 1.0, (n_holds, self.n_train, n)) * amp
        tau = np.repeat(self._holding_force(targets), per_hold, axis=0)[:n_samples]  # (T, B, n)
        # initial strains of a stiffened strain shrink with it, as its actuated range does
        ref = self._actuation_robot().stiffness
        q0 = rng.uniform(-0.5, 0.5, (self.n_train, n)) * amp * np.minimum(1.0, ref / self.robot.stiffness)
        qd0 = np.zeros((self.n_train, n))
        # all training recordings share the time grid: one batched integration
        q, qd = self._simulate(q0, qd0, t, tau)
        # u is τ itself (one array object: stored once, recognised as such)
        return [(t, q[:, b], qd[:, b], tau_b, tau_b) for b, tau_b in enumerate(np.moveaxis(tau, 1, 0))]

    def _actuated_training_recordings(self, rng: np.random.Generator) -> list[tuple]:
        n, p = self.robot.n_q, self.robot.n_inputs
        n_samples = int(round(self.train_duration / self.dt))
        t = np.arange(n_samples) * self.dt
        per_hold = max(1, int(round(self.hold / self.dt)))
        n_holds = -(-n_samples // per_hold)
        # every actuator independently off or uniform in [0, input_max] (probability 1/2 each): single pulls
        # bend the robot further than co-contraction, which mostly compresses it
        level = rng.uniform(0.0, 1.0, (n_holds, self.n_train, p)) * (rng.uniform(size=(n_holds, self.n_train, p)) < 0.5)
        u = np.repeat(level * np.asarray(self.input_max), per_hold, axis=0)[:n_samples]  # (T, B, p)
        q0 = rng.uniform(-0.5, 0.5, (self.n_train, n)) * self._amplitudes()
        q, qd = self._simulate(q0, np.zeros((self.n_train, n)), t, u)
        tau = self.robot.actuation_forces(q, u)
        return [(t, q[:, b], qd[:, b], tau[:, b], u[:, b]) for b in range(self.n_train)]

    def _actuated_validation_recording(self, rng: np.random.Generator) -> tuple:
        n, p = self.robot.n_q, self.robot.n_inputs
        t = np.arange(int(round(self.validation_duration / self.dt))) * self.dt
        # slow sinusoids around half the training range, one frequency per actuator, all different
        # (stratified over 0.5-3 Hz), never negative: u = mid (1 + a sin(w t + phase)) with a <= 1
        mid = 0.5 * np.asarray(self.input_max)
        amp = rng.uniform(0.6, 1.0, p)
        omega = 2 * np.pi * (0.5 + 2.5 * (rng.permutation(p) + rng.uniform(0.0, 1.0, p)) / p)
        phase = rng.uniform(0.0, 2 * np.pi, p)
        shape = 1.0 + amp * np.sin(omega * t[:, None] + phase)
        limits = np.tile(_STRAIN_LIMITS, self.robot.kinematics.n_segments)
        for _ in range(4):
            u = mid * shape
            q, qd = self._simulate(np.zeros(n), np.zeros(n), t, u)
            excess = np.max(np.abs(q) / limits)
            if excess <= 1.0:
                break
            mid = mid * (0.9 / excess)
        return t, q, qd, self.robot.actuation_forces(q, u), u

    def _validation_recording(self, rng: np.random.Generator) -> tuple:
        if self.input_max is not None:
            return self._actuated_validation_recording(rng)
        n = self.robot.n_q
        n_samples = int(round(self.validation_duration / self.dt))
        t = np.arange(n_samples) * self.dt
        # f: the holding force of a random configuration of the intended amplitude, so each strain is excited
        direction = rng.choice([-1.0, 1.0], n) * rng.uniform(0.5, 1.0, n) * self._amplitudes()
        f = self._holding_force(direction) - self._holding_force(np.zeros(n))
        a1, a2 = rng.uniform(0.3, 0.7, 2)
        w1, w2 = 2 * np.pi * rng.uniform(0.5, 3.0, 2)
        signal = a1 * np.sin(w1 * t) + a2 * np.cos(w2 * t)
        q0 = np.zeros(n)
        qd0 = np.zeros(n)
        limits = np.tile(_STRAIN_LIMITS, self.robot.kinematics.n_segments)
        for _ in range(4):
            tau = np.outer(signal, f)
            q, qd = self._simulate(q0, qd0, t, tau)
            # a sinusoid near a resonance can curl the robot into loops no camera could track:
            # shrink the actuation until every strain stays inside the seed's data ranges
            excess = np.max(np.abs(q) / limits)
            if excess <= 1.0:
                break
            f = f * (0.9 / excess)
        return t, q, qd, tau, tau

    def _pac_recording(self, rng: np.random.Generator, n_configurations: int = 500) -> tuple:
        c0 = rng.uniform(-20.0, 20.0, n_configurations)
        c1 = rng.uniform(-250.0, 250.0, n_configurations)
        shear = rng.uniform(-1.0, 1.0, (n_configurations, 2)) * self.strain_amplitude
        config = np.column_stack([c0, c1, shear])
        t = np.arange(n_configurations) * self.dt
        return t, config, None, None, None

    # ------------------------------------------------------------------
    def generate(
        self,
        seed: int = 0,
        *,
        noise: tuple[float, float] | str | None = None,
        n_train: int | None = None,
        train_duration: float | None = None,
        validation: bool = True,
        validation_duration: float | None = None,
        cache: bool = True,
        progress: bool = False,
    ) -> ScenarioData:
        """Simulate the scenario's data set.

        Parameters
        ----------
        seed : int
            Seed of every random draw (initial conditions, actuation, noise).
        noise : (sigma_p, sigma_theta), "seed" or None
            Measurement noise added to the tracked poses; ``"seed"`` uses
            :attr:`seed_noise`.  The noise-free poses stay in ``poses_true``.
        n_train, train_duration, validation_duration : optional
            Override the seed's 8 recordings of 0.5 s and the 7 s validation.
        validation : bool
            Whether to simulate the validation recording.
        cache : bool
            Reuse simulations stored (as ``.npz``) under ``$PCS_SINDY_CACHE`` or
            ``~/.cache/pcs_sindy``; noise is added after loading.
        progress : bool
            Show a progress bar over recordings.
        """
        if int(seed) != seed:
            raise ValueError(f"seed must be an integer; got {seed!r}")
        if isinstance(noise, str):
            if noise != "seed":
                raise ValueError(f"noise must be None, 'seed' or (sigma_p, sigma_theta); got {noise!r}")
            noise = self.seed_noise
        noise = (0.0, 0.0) if noise is None else tuple(float(v) for v in noise)
        if len(noise) != 2 or min(noise) < 0 or not all(np.isfinite(noise)):
            raise ValueError(f"noise must be (sigma_p >= 0, sigma_theta >= 0); got {noise!r}")
        spec = replace(
            self,
            n_train=self.n_train if n_train is None else int(n_train),
            train_duration=self.train_duration if train_duration is None else float(train_duration),
            validation_duration=self.validation_duration if validation_duration is None else float(validation_duration),
        )
        if spec.n_train < 1 or spec.train_duration <= 0 or spec.validation_duration <= 0:
            raise ValueError(
                f"n_train, train_duration and validation_duration must be positive; got "
                f"{spec.n_train}, {spec.train_duration}, {spec.validation_duration}"
            )
        raw = spec._load_or_simulate(int(seed), validation and not self.is_kinematic, cache, progress)
        noise_rng = np.random.default_rng([int(seed), 7919])
        recordings = []
        for t, q, qd, tau, u in raw:
            truth = spec.marker_poses(q)
            noisy = add_pose_noise(truth, *noise, noise_rng) if max(noise) > 0 else truth.copy()
            recordings.append(Recording(t=t, q=q, qd=qd, tau=tau, poses=noisy, poses_true=truth, u=u))
        n_val = 1 if (validation and not self.is_kinematic) else 0
        train = recordings[: len(recordings) - n_val]
        val = recordings[-1] if n_val else None
        return ScenarioData(name=self.name, train=train, validation=val, noise=noise, seed=int(seed))

    def _cache_key(self, seed: int, validation: bool) -> str:
        spec = {
            "version": _DATA_VERSION,
            "name": self.name,
            "parameters": self.parameters,
            "seed": seed,
            "validation": validation,
            "n_train": self.n_train,
            "train_duration": self.train_duration,
            "validation_duration": self.validation_duration,
            "dt": self.dt,
            "hold": self.hold,
            "amplitudes": [self.bend_amplitude, self.strain_amplitude],
            "actuation_reference": self.actuation_reference,
        }
        if self.input_max is not None:  # keeps the keys (and cached data) of the other scenarios as they were
            spec["input_max"] = list(self.input_max)
        return hashlib.sha256(json.dumps(spec, sort_keys=True, default=str).encode()).hexdigest()[:20]

    def _load_or_simulate(self, seed: int, validation: bool, cache: bool, progress: bool) -> list[tuple]:
        path = _default_cache_dir() / f"{self.name}-{self._cache_key(seed, validation)}.npz"
        if cache and path.exists():
            try:
                with np.load(path, allow_pickle=False) as data:
                    count = int(data["count"])
                    out = []
                    for k in range(count):
                        get = lambda key, k=k: data[f"{key}{k}"] if f"{key}{k}" in data.files else None  # noqa: E731
                        tau, u = get("tau"), get("u")
                        out.append((get("t"), get("q"), get("qd"), tau, tau if u is None else u))
                    return out
            except (OSError, ValueError, KeyError):
                pass  # a damaged cache entry is simply recomputed
        rng = np.random.default_rng(seed)
        if self.is_kinematic:
            out = [self._pac_recording(rng)]
        else:
            steps = 2 if validation else 1
            with tqdm(total=steps, desc=f"simulating {self.name}", unit="step", disable=not progress) as bar:
                with ticking(bar):  # one batched integration per step: the elapsed time keeps moving
                    bar.set_postfix_str(f"{self.n_train} training recording(s)")
                    out = self._training_recordings(rng)
                    bar.update()
                    if validation:
                        bar.set_postfix_str("validation recording")
                        out.append(self._validation_recording(rng))
                        bar.update()
        if cache:
            arrays: dict[str, NDArray] = {"count": np.array(len(out))}
            for k, rec in enumerate(out):
                for key, value in zip(("t", "q", "qd", "tau", "u"), rec):
                    # u is stored only where it differs from tau (actuated robots)
                    if value is not None and not (key == "u" and value is rec[3]):
                        arrays[f"{key}{k}"] = value
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                atomic.savez(path, **arrays)  # two processes filling the cache leave one complete file
            except OSError:
                pass  # caching is an optimisation; an unwritable cache is not an error
        return out
