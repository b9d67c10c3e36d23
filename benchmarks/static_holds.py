"""Static holds of a soft tentacle: leave-one-load-out shape prediction from equilibria alone.

The rig of issue 19 (second kind): a tapered soft tentacle, 0.36 m, hanging, two tendons on
opposite sides ending at the tip, 7 known tension levels per tendon (one tendon loaded at a time)
plus the unloaded hold; 5 motion-capture markers (the base one included) 2 cm off the backbone,
3-D positions in the capture system's frame (the robot's plane tilted in it, a slight out-of-plane
wobble), 3 s per hold at 200 Hz with 0.3 mm noise.  Large bending: at the highest load the tip
curls back (tip angle beyond 180 deg).

Ground truth: :class:`pcs_sindy.simulation.dynamics.PCSRobot` with 12 segments (a tapered radius,
so the stiffness falls towards the tip), equilibria by :func:`scipy.optimize.root` on the
simulator's own static forces (independent of the identification side).

The user's side (what this benchmark measures):

1. project the 3-D markers on their best-fit plane (SVD), average each hold;
2. the base pose from the unloaded hold (the straight, hanging robot), the strains of each hold by
   a least-squares fit of a 3-segment constant-curvature model to its markers;
3. ``EulerLagrangeRegressor(formulation="static", actuation=TendonActuation(...))`` on all holds but
   one (the tensions in newtons and the tendons' design offsets fix the scale: a bending-only model
   with identified offsets would determine stiffness, density and offsets only up to one common
   factor), then
   ``equilibrium(u)`` of the left-out hold, its tip marker compared with the measured one.

Baselines on the same left-out holds, from the measured marker positions of the same tendon's other
holds: (i) linear interpolation of the tip marker between the neighbouring load levels (linear
extrapolation from the two below at the highest level), (ii) a per-coordinate quadratic fit of the
tip marker in the load.

Run: ``python benchmarks/static_holds.py [--quick]``.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from scipy.optimize import least_squares, root
from tqdm.auto import tqdm

from pcs_sindy.core import StrainTrajectory, forward_kinematics
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.models import TendonActuation
from pcs_sindy.simulation import Tendons
from pcs_sindy.simulation.dynamics import PCSRobot

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
from _results import write_section  # noqa: E402

LENGTH = 0.36
N_TRUE = 12
MARKER_S = np.array([0.0, 0.09, 0.18, 0.27, 0.36])
MARKER_OFFSET = 0.02  # [m] along the cross-section axis
TENDON_OFFSETS = (0.008, -0.007)
YOUNG = 2e5  # [Pa]
LOAD_STEP = 0.6  # [N]
LEVELS = LOAD_STEP * np.arange(1, 8)  # tensions [N] of the 7 load levels
RATE, HOLD_S, NOISE = 200.0, 3.0, 3e-4
MODEL_LENGTHS = np.array([0.15, 0.12, 0.09])  # [m] shorter towards the tip, where the tentacle bends most
MODEL_SEGMENTS = MODEL_LENGTHS.size


def true_robot() -> PCSRobot:
    lengths = np.full(N_TRUE, LENGTH / N_TRUE)
    s_mid = (np.arange(N_TRUE) + 0.5) * LENGTH / N_TRUE
    return PCSRobot(
        lengths,
        density=1100.0,
        youngs_modulus=YOUNG,
        shear_modulus=2e4,
        damping=np.tile([1e-4, 1e-2, 1e-2], N_TRUE),
        radius=0.014 - 0.006 * s_mid / LENGTH,
        stiffness_scaling="length",
        actuation=Tendons([LENGTH, LENGTH], list(TENDON_OFFSETS)),
    )


def true_equilibria(robot: PCSRobot, inputs: np.ndarray) -> np.ndarray:
    """Equilibria of the simulator's static forces, each load reached by continuation from the last."""
    out, q, prev = [], np.zeros(robot.n_q), np.zeros(inputs.shape[1])
    for u in inputs:
        if u @ prev == 0:  # a new tendon: start again from the straight robot
            q, prev = np.zeros(robot.n_q), np.zeros_like(u)
        for lam in np.linspace(0, 1, 5)[1:]:
            target = prev + lam * (u - prev)

            def residual(x, target=target):
                return robot.gravity_forces(x) + robot.elastic_forces(x) - robot.actuation_forces(x, target)

            sol = root(residual, q, tol=1e-12)
            if not sol.success:
                raise RuntimeError(f"no true equilibrium at u = {target}")
            q = sol.x
        out.append(q)
        prev = u
    return np.asarray(out)


def markers(q: np.ndarray, lengths: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
    """Marker positions (5, 2): the backbone at ``MARKER_S`` plus the offset along the cross-section axis."""
    pose = forward_kinematics(q, lengths, MARKER_S, np.zeros(3) if base is None else base)
    return pose[:, :2] + MARKER_OFFSET * np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])], axis=1)


def record(planar: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """3-D capture (H, T, 5, 3): the plane tilted in the capture frame, wobble and noise."""
    n = int(RATE * HOLD_S)
    rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    offset = np.array([0.4, -0.2, 1.1])
    t = np.arange(n) / RATE
    out = []
    for h, pts in enumerate(planar):
        wobble = 1e-3 * np.sin(2 * np.pi * 0.7 * t + h)[:, None] * (MARKER_S / LENGTH)[None, :]  # (T, 5)
        local = np.concatenate([np.broadcast_to(pts, (n, 5, 2)), wobble[..., None]], axis=2)
        out.append(local @ rot.T + offset + NOISE * rng.normal(size=(n, 5, 3)))
    return np.asarray(out)


def to_plane(cloud: np.ndarray) -> tuple[np.ndarray, float]:
    """Hold means of the markers in their best-fit plane (H, 5, 2), and the out-of-plane RMS [m]."""
    flat = cloud.reshape(-1, 3)
    centre = flat.mean(axis=0)
    _, _, vt = np.linalg.svd(flat - centre, full_matrices=False)
    planar = (cloud - centre) @ vt[:2].T
    rms = float(np.sqrt(np.mean(((cloud - centre) @ vt[2]) ** 2)))
    return planar.mean(axis=1), rms


def fit_base(points: np.ndarray) -> np.ndarray:
    """Base pose from the unloaded hold: the straight, hanging robot (with a uniform axial strain)."""
    pts = points

    def residual(b):
        return (markers(np.array([0.0, 0.0, b[3]]), np.array([LENGTH]), b[:3]) - pts).ravel()

    guess = np.r_[pts[0], np.arctan2(-(pts[-1, 0] - pts[0, 0]), pts[-1, 1] - pts[0, 1]), 0.0]
    return least_squares(residual, guess).x[:3]


def handedness(means: np.ndarray, loaded: int) -> np.ndarray:
    """The plane's axes flipped if needed so that tendon 1 (known to the user: on the markers' side of the
    backbone) pulls the tip towards the markers' side.  A straight robot cannot tell (its markers are
    collinear), a loaded one can."""
    for flip in (np.array([1.0, 1.0]), np.array([1.0, -1.0])):
        pts = means * flip
        base = fit_base(pts[0])
        c, s = np.cos(base[2]), np.sin(base[2])
        tip = np.array([[c, s], [-s, c]]) @ (pts[loaded, -1] - base[:2])
        if tip[0] > MARKER_OFFSET:
            return flip
    raise RuntimeError("tendon 1 does not bend the robot towards the markers' side in either handedness")


def shape_fit(points: np.ndarray, base: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """Bending strains of the model's segments whose markers best match ``points`` (5, 2).

    Bending only: with 4 markers beyond the base, free axial strains too would absorb the misfit of
    constant curvatures to the continuum (a segment's axial strain bent into a length change).
    """

    def full(x):
        q = np.zeros(3 * MODEL_SEGMENTS)
        q[0::3] = x
        return q

    sol = least_squares(lambda x: (markers(full(x), MODEL_LENGTHS, base) - points).ravel(), q0)
    return full(sol.x)


def tip_in_base(q: np.ndarray) -> np.ndarray:
    return markers(q, MODEL_LENGTHS)[-1]


def main(quick: bool = False) -> None:
    start = time.perf_counter()
    rng = np.random.default_rng(0)
    robot = true_robot()
    inputs = [np.zeros(2)] + [np.array([f, 0.0]) for f in LEVELS] + [np.array([0.0, f]) for f in LEVELS]
    inputs = np.asarray(inputs)  # (15, 2): unloaded, tendon 1 sweep, tendon 2 sweep
    q_true = true_equilibria(robot, inputs)
    tip_angle = np.rad2deg(q_true[:, 0::3] @ robot.segment_lengths)
    planar_true = np.array([markers(q, robot.segment_lengths) for q in q_true])
    cloud = record(planar_true, rng)
    means, out_of_plane = to_plane(cloud)

    # the user's frame: base pose from the unloaded hold, then each hold's strains
    flip = handedness(means, len(LEVELS))
    means = means * flip
    base = fit_base(means[0])
    c, s = np.cos(base[2]), np.sin(base[2])
    to_base = np.array([[c, s], [-s, c]])  # rotate the plane into the base frame
    local = (means - base[:2]) @ to_base.T
    q_fit, x = [], np.zeros(MODEL_SEGMENTS)
    for h in range(len(inputs)):
        if h in (1, 8):
            x = np.zeros(MODEL_SEGMENTS)
        q = shape_fit(local[h], np.zeros(3), x)
        x = q[0::3]
        q_fit.append(q)
    q_fit = np.asarray(q_fit)
    fit_rms = np.sqrt(np.mean([(tip_in_base(q) - local[h][-1]) ** 2 for h, q in enumerate(q_fit)]))
    lengths = MODEL_LENGTHS
    active = np.tile([True, False, False], (MODEL_SEGMENTS, 1))

    def fit(train: np.ndarray) -> EulerLagrangeRegressor:
        X = StrainTrajectory(
            q_fit[train], np.arange(train.size, dtype=float), segment_lengths=lengths, active_strains=active
        )
        act = TendonActuation([LENGTH, LENGTH], [1, -1], offset=np.abs(TENDON_OFFSETS))
        return EulerLagrangeRegressor(formulation="static", actuation=act).fit([X], [inputs[train]])

    held_out = np.arange(1, len(inputs)) if not quick else np.array([1, 4, 7, 8, 11, 14])
    errors = {"PCS static model": [], "interpolate neighbours": [], "quadratic in load": []}
    truth_errors = []
    measured_tip = local[:, -1]
    true_tip = np.array([markers(q, robot.segment_lengths) for q in q_true])[:, -1]
    for h in tqdm(held_out, desc="leave one load out"):
        train = np.setdiff1d(np.arange(len(inputs)), [h])
        model = fit(train)
        start_q = q_fit[h - 1] if h not in (1, 8) else np.zeros(3 * MODEL_SEGMENTS)
        q_pred = model.equilibrium(inputs[h], start_q)
        tip = tip_in_base(q_pred)
        errors["PCS static model"].append(np.linalg.norm(tip - measured_tip[h]))
        truth_errors.append(np.linalg.norm(tip - true_tip[h]))
        # the same tendon's sweep: loads and measured tips, the unloaded hold as level 0
        sweep = np.r_[0, np.arange(1, 8)] if h <= 7 else np.r_[0, np.arange(8, 15)]
        loads = inputs[sweep].sum(axis=1)
        others = sweep[sweep != h]
        f = inputs[h].sum()
        k = int(np.flatnonzero(sweep == h)[0])
        if k < len(sweep) - 1:
            lo, hi = sweep[k - 1], sweep[k + 1]
        else:
            lo, hi = sweep[k - 2], sweep[k - 1]
        w = (f - loads[sweep == lo][0]) / (loads[sweep == hi][0] - loads[sweep == lo][0])
        interp = (1 - w) * measured_tip[lo] + w * measured_tip[hi]
        errors["interpolate neighbours"].append(np.linalg.norm(interp - measured_tip[h]))
        coef = np.polyfit(inputs[others].sum(axis=1), measured_tip[others], 2)
        quad = np.array([np.polyval(coef[:, j], f) for j in range(2)])
        errors["quadratic in load"].append(np.linalg.norm(quad - measured_tip[h]))

    full_model = fit(np.arange(len(inputs)))
    k_fit = full_model.stiffness_[full_model.kinematics_.active_mask]
    rows = "\n".join(
        f"| {name} | {1e3 * np.mean(v):.2f} | {1e3 * np.median(v):.2f} | {1e3 * np.max(v):.2f} |"
        for name, v in errors.items()
    )
    per_hold = "\n".join(
        f"| {int(h)} | {inputs[h][0]:.1f}, {inputs[h][1]:.1f} | {tip_angle[h]:.0f} | "
        + " | ".join(f"{1e3 * errors[n][i]:.1f}" for n in errors)
        + " |"
        for i, h in enumerate(held_out)
    )
    pcs, best = (
        np.mean(errors["PCS static model"]),
        min(np.mean(errors["interpolate neighbours"]), np.mean(errors["quadratic in load"])),
    )
    verdict = (
        f"PCS mean tip error {1e3 * pcs:.2f} mm vs the best baseline {1e3 * best:.2f} mm "
        f"({'no worse' if pcs <= best else f'worse by {1e3 * (pcs - best):.2f} mm'}); goal < 8 mm: "
        f"{'met' if pcs < 8e-3 else f'missed by {1e3 * (pcs - 8e-3):.2f} mm'}."
    )
    model_lengths = ", ".join(f"{v:.2f}" for v in MODEL_LENGTHS)
    body = f"""Leave-one-load-out tip-marker error [mm] over {len(held_out)} held-out holds (the tip marker 2 cm off the
backbone, against its measured mean position).  Truth: a 12-segment tapered tentacle (radius 14 -> 8 mm,
E = {YOUNG / 1e3:.0f} kPa, stiffness scaled by length), tendons at +8 / -7 mm ending at the tip, loads
{", ".join(f"{v:.1f}" for v in LEVELS)} N per tendon; tip angles up to {np.abs(tip_angle).max():.0f} deg.  Capture:
{RATE:.0f} Hz, {HOLD_S:.0f} s per hold, {1e3 * NOISE:.1f} mm noise, 1 mm out-of-plane wobble (measured out-of-plane RMS
{1e3 * out_of_plane:.2f} mm).  Model: {MODEL_SEGMENTS} constant-curvature segments of {model_lengths} m
(bending only), shape-fit tip-marker RMS {1e3 * fit_rms:.2f} mm; `formulation="static"`, tendon offsets given
(8 and 7 mm, the design);
identified bending stiffness {", ".join(f"{v:.3g}" for v in k_fit)} N m^2 (the truth's E I falls from
{YOUNG * np.pi / 4 * 0.014**4:.3g} at the base to {YOUNG * np.pi / 4 * 0.008**4:.3g} N m^2 at the tip; the model's
stiffness is per unit curvature of its segment, f_L = 1).

| method | mean | median | max |
|---|---|---|---|
{rows}

{verdict}  The PCS model's tip against the true tip (not the measured mean): mean
{1e3 * np.mean(truth_errors):.2f} mm.

Per held-out hold:

| hold | tensions [N] | true tip angle [deg] | {" | ".join(errors)} |
|---|---|---|{"---|" * len(errors)}
{per_hold}

Wall time {time.perf_counter() - start:.1f} s.
"""
    print(body)
    if not quick:
        write_section(
            "static_holds",
            "Static holds: leave-one-load-out shape prediction",
            body,
            "python benchmarks/static_holds.py",
        )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer held-out holds, no docs/results.md update")
    main(parser.parse_args().quick)
