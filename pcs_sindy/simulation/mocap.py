"""A simulated motion-capture recording of a hanging tendon-driven robot, as a lab would export it.

:class:`MocapScenario` is the analogue of the recordings of issue 19: a
0.3 m robot of three constant-strain segments hangs from its base and is
bent by two antagonistic tendons ending at the tip; three markers (rigid
bodies) at 0.1, 0.2 and 0.3 m are tracked by their 3-D positions only, in the
capture system's frame (rotated and offset from the robot's), at a nominal
100 Hz, with

* Gaussian noise on every coordinate;
* an out-of-plane wobble of a few mm (the robot does not move exactly in a plane);
* a few percent of frozen samples (the tracker repeats the last value) and
  occasional jumps of a few cm lasting one or two samples;
* step inputs (fast rises: overshoot and ringing) through a backlash (play)
  on the input, a hysteresis: the robot does not return exactly to where it
  started.

The inputs are tendon tensions [N] by default (``actuation=None``).  Any
actuation object :class:`~pcs_sindy.simulation.PCSRobot` accepts can be given
instead; the step levels are then drawn in ``[0, input_max]`` of its units.
:meth:`MocapScenario.servo` is the kind the issue's recordings are: servo
angles [deg] winding elastic tendons (``Tendons(..., drive="displacement")``)
that go slack when the body bends towards them or the servo lets go, with
the play on the servo angles.

:meth:`MocapRecording.to_csv` writes the recording like a motion-capture
export: a sample index, no time stamps, the inputs, and the marker
coordinates in millimetres.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .actuation import Tendons
from .dynamics import PCSRobot

__all__ = ["MocapScenario", "MocapRecording", "play_operator"]


def play_operator(u: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    """Backlash (play) hysteresis of each column of ``u`` (T, p): the output follows the input
    once it is more than ``width / 2`` away, and holds otherwise; the output starts at ``u[0]``."""
    u = np.asarray(u, dtype=float)
    out = np.empty_like(u)
    y = u[0].copy()
    h = 0.5 * float(width)
    for k in range(u.shape[0]):
        y = np.clip(y, u[k] - h, u[k] + h)
        out[k] = y
    return np.maximum(out, 0.0)


@dataclass
class MocapRecording:
    """One simulated capture.

    Attributes
    ----------
    dt : float
        Nominal sample period [s] (the file carries only a sample index).
    u : ndarray (T, p)
        Commanded inputs (what the user logs), held on each sample.
    positions : ndarray (T, N, 3)
        Measured marker positions [m] in the capture frame: noise, wobble, frozen samples, jumps.
    positions_true : ndarray (T, N, 3)
        Noise-free positions [m] in the capture frame (with the wobble: the robot does it).
    q : ndarray (T, 3m)
        True strains.
    rotation : ndarray (3, 3), offset : ndarray (3,)
        Capture frame from the robot frame: ``x_capture = rotation @ [x, y, z] + offset``.
    frozen, jumps : ndarray of bool (T, N)
        Where the samples were frozen or jumped (for checks).
    """

    dt: float
    u: NDArray[np.float64]
    positions: NDArray[np.float64]
    positions_true: NDArray[np.float64]
    q: NDArray[np.float64]
    rotation: NDArray[np.float64]
    offset: NDArray[np.float64]
    frozen: NDArray[np.bool_]
    jumps: NDArray[np.bool_]
    input_names: tuple[str, ...] = ()

    @property
    def t(self) -> NDArray[np.float64]:
        """Nominal time stamps ``k * dt``."""
        return np.arange(self.u.shape[0]) * self.dt

    def split(self, fraction: float = 0.5) -> tuple[slice, slice]:
        """Slices of the first ``fraction`` of the samples and of the rest."""
        k = int(round(fraction * self.u.shape[0]))
        return slice(0, k), slice(k, self.u.shape[0])

    def to_csv(self, path: str | Path) -> Path:
        """Write ``frame, <inputs>, M1_X, M1_Y, M1_Z, ...`` (positions in mm), one row per sample."""
        path = Path(path)
        n = self.positions.shape[1]
        names = list(self.input_names) or [f"u{k + 1}" for k in range(self.u.shape[1])]
        header = ["frame", *names] + [f"M{i + 1}_{c}" for i in range(n) for c in "XYZ"]
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            flat = 1e3 * self.positions.reshape(self.positions.shape[0], -1)
            for k in range(self.u.shape[0]):
                w.writerow([k, *(f"{v:.6g}" for v in self.u[k]), *(f"{v:.4f}" for v in flat[k])])
        return path


@dataclass
class MocapScenario:
    """A hanging tendon-driven robot tracked by 3 position-only markers (the issue-19 analogue).

    Parameters
    ----------
    segment_lengths : tuple of float
        The true segments [m] (0.3 m in all).
    radius, density, youngs_modulus, shear_modulus : float
        Material of every segment (SI units).
    damping : tuple of 3 float
        Damping per strain (bending, shear, axial) of every segment.
    marker_arc_lengths : tuple of float
        Where the markers sit [m].
    tendon_offset : float
        Distance of the two tendons from the backbone [m]; both end at the tip.
    actuation : object, optional
        An actuation for :class:`PCSRobot` (default: ``Tendons`` at ``±tendon_offset``, inputs tensions).
    input_max : float
        Largest step level per input (N for tensions, deg for servo angles).
    pretension : float
        Input level of a tendon that is off (N, or deg for servo angles).
    hold : tuple of float
        Range of the step durations [s].
    play : float
        Width of the backlash on the inputs (hysteresis), in input units.
    rate : float
        Nominal capture rate [Hz].
    duration : float
        Length of the recording [s].
    noise : float
        Standard deviation of every measured coordinate [m].
    wobble : float
        Amplitude of the out-of-plane motion at the tip [m].
    frozen_fraction : float
        Fraction of samples frozen (in runs of 1-6 samples).
    jump_rate : float
        Probability per marker-sample that a jump of 2-5 cm starts (1-2 samples).
    """

    segment_lengths: tuple[float, ...] = (0.1, 0.1, 0.1)
    radius: float = 0.01
    density: float = 1100.0
    youngs_modulus: float = 3e5
    shear_modulus: float = 1e5
    damping: tuple[float, float, float] = (1e-4, 2e-2, 2e-2)
    marker_arc_lengths: tuple[float, ...] = (0.1, 0.2, 0.3)
    tendon_offset: float = 0.012
    actuation: Any = None
    input_max: float = 3.0
    pretension: float = 0.1
    hold: tuple[float, float] = (1.0, 3.0)
    play: float = 0.15
    rate: float = 100.0
    duration: float = 60.0
    noise: float = 2e-4
    wobble: float = 3e-3
    frozen_fraction: float = 0.03
    jump_rate: float = 5e-4
    input_names: tuple[str, ...] = field(default=())

    @classmethod
    def servo(
        cls,
        *,
        stiffness: float = 150.0,
        pulley_radius: float = 0.012,
        slack: float = 0.002,
        **kwargs: Any,
    ) -> MocapScenario:
        """The servo-driven capture: inputs are servo angles [deg] winding two elastic tendons.

        Each servo winds its tendon (at ``±tendon_offset`` to the tip) on a pulley:
        ``Tendons(..., drive="displacement")`` with the tension
        ``stiffness * max(0, pulley_radius * u * pi/180 + l(q) - l(0) - slack)``.
        Steps go to 18-90 deg (``input_max=90``); a servo that is off rests at
        ``pretension=5`` deg, where its tendon is still slack on the straight
        robot (``0.012 m * 5 deg = 1.05 mm < 2 mm``) and it goes taut only when the
        other tendon bends the robot away from it; the play (hysteresis) is 4 deg.

        Parameters
        ----------
        stiffness : float, default 150.0
            Tendon stiffness [N/m] of both tendons.
        pulley_radius : float, default 0.012
            Servo pulley radius [m].
        slack : float, default 0.002
            Slack [m] of the straight robot's tendons at 0 deg.
        **kwargs
            Other fields of the scenario (``duration``, ``noise``, ``input_max``, ...).

        Returns
        -------
        MocapScenario
        """
        kwargs = {"input_max": 90.0, "pretension": 5.0, "play": 4.0, **kwargs}
        if "actuation" in kwargs:
            raise TypeError("MocapScenario.servo() builds its own actuation; give stiffness/pulley_radius/slack")
        d = float(kwargs.get("tendon_offset", cls.tendon_offset))
        total = float(np.sum(kwargs.get("segment_lengths", cls.segment_lengths)))
        actuation = Tendons(
            end=[total, total],
            offset=[d, -d],
            drive="displacement",
            stiffness=[stiffness] * 2,
            pulley_radius=[pulley_radius] * 2,
            slack=[slack] * 2,
        )
        return cls(actuation=actuation, **kwargs)

    @property
    def robot(self) -> PCSRobot:
        """The ground-truth robot."""
        m = len(self.segment_lengths)
        act = self.actuation
        if act is None:
            total = float(np.sum(self.segment_lengths))
            act = Tendons(end=[total, total], offset=[self.tendon_offset, -self.tendon_offset])
        return PCSRobot(
            self.segment_lengths,
            density=self.density,
            youngs_modulus=self.youngs_modulus,
            shear_modulus=self.shear_modulus,
            damping=list(self.damping) * m,
            radius=self.radius,
            actuation=act,
        )

    def inputs(self, rng: np.random.Generator, n: int, p: int) -> NDArray[np.float64]:
        """Step inputs (n, p): each hold, one input (or none) is on at a random level, the others at pretension."""
        u = np.full((n, p), float(self.pretension))
        k = 0
        while k < n:
            length = int(round(rng.uniform(*self.hold) * self.rate))
            on = rng.integers(-1, p)  # -1: all off
            if on >= 0:
                u[k : k + length, on] = rng.uniform(0.2, 1.0) * self.input_max
            k += length
        return u

    def generate(self, seed: int = 0) -> MocapRecording:
        """Simulate the capture (seeded)."""
        rng = np.random.default_rng(seed)
        robot = self.robot
        n = int(round(self.duration * self.rate))
        dt = 1.0 / self.rate
        t = np.arange(n) * dt
        u_cmd = self.inputs(rng, n, robot.n_inputs)
        u_applied = play_operator(u_cmd, self.play)
        sim = robot.simulate(np.zeros(robot.n_q), np.zeros(robot.n_q), t, u_applied)
        s = np.asarray(self.marker_arc_lengths, dtype=float)
        planar = robot.kinematics.forward_kinematics(sim.q, s)[..., :2]  # (T, N, 2)
        # out-of-plane wobble: a slow sway growing along the body
        phase = rng.uniform(0, 2 * np.pi, 2)
        sway = np.sin(2 * np.pi * 0.23 * t + phase[0]) + 0.5 * np.sin(2 * np.pi * 0.61 * t + phase[1])
        z = self.wobble / 1.5 * sway[:, None] * (s / s[-1])[None, :]
        robot_frame = np.concatenate([planar, z[..., None]], axis=2)
        rotation = _rotation(rng)
        offset = rng.uniform(-1.0, 1.0, 3) + np.array([0.0, 0.0, 1.2])
        true = robot_frame @ rotation.T + offset
        meas = true + self.noise * rng.standard_normal(true.shape)
        frozen = np.zeros(meas.shape[:2], dtype=bool)
        jumps = np.zeros_like(frozen)
        n_runs = int(round(self.frozen_fraction * n / 3.5))
        for i in range(meas.shape[1]):
            for start in rng.integers(1, n - 7, n_runs):
                frozen[start : start + rng.integers(1, 7), i] = True
            for start in np.flatnonzero(rng.random(n) < self.jump_rate):
                if start > 0 and not frozen[start, i]:
                    width = int(rng.integers(1, 3))
                    jumps[start : start + width, i] = True
                    meas[start : start + width, i] += rng.uniform(0.02, 0.05) * _unit(rng)
        jumps &= ~frozen
        for k in range(1, n):
            meas[k, frozen[k]] = meas[k - 1, frozen[k]]
        names = self.input_names or tuple(f"u{k + 1}" for k in range(robot.n_inputs))
        return MocapRecording(
            dt=dt,
            u=u_cmd,
            positions=meas,
            positions_true=true,
            q=sim.q,
            rotation=rotation,
            offset=offset,
            frozen=frozen,
            jumps=jumps,
            input_names=names,
        )


def _unit(rng: np.random.Generator) -> NDArray[np.float64]:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def _rotation(rng: np.random.Generator) -> NDArray[np.float64]:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q
