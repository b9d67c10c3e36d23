"""pysindy routes to a PCS model, side by side with ``EulerLagrangeRegressor``.

1. From videos (two_segment, rendered in memory): marker poses
   (``MarkerPoseExtractor``) -> segments and strains (``KinematicFusion``), then
   the same weak-form regression twice, with the same pysindy optimizer at its
   defaults (``ps.STLSQ()``):

   * ``WeakEulerLagrangeSINDy`` — a ``pysindy.SINDy``: strains as ``x``, forces
     as ``u``, no accelerations (window integrals against a test function);
     ``print()`` shows ``tau_<strain> = ...``, ``simulate(x0, t, u)`` rolls out;
   * ``EulerLagrangeRegressor(optimizer=ps.STLSQ())`` on the same strains;

   the coefficients agree, and both roll out the 7 s validation.
2. A plain ``ps.SINDy(feature_library=PhysicalPCSLibrary(...))`` (first-order
   ``x_dot = Theta(x) Xi``) is refused with the routes that work.
3. With exact accelerations (a simulator), the strong form inside a plain
   ``SINDy``: ``StackedEulerLagrangeLibrary`` (states ``[q, qd, qdd]``, forces
   stacked per strain as ``x_dot``).
4. A pysindy user's script, unchanged, on ``EulerLagrangeRegressor``: arrays in
   (``fit(q, t=dt, u=u, segment_lengths=...)``), ``print(lhs=...)``,
   ``coefficients()`` per strain equation, ``simulate(x0, t, u)``.

Run: ``.venv/bin/python examples/pysindy_interop.py`` (about a minute).
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pysindy as ps

from pcs_sindy.core import Camera, StrainTrajectory, end_effector_errors
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import (
    EulerLagrangeRegressor,
    PhysicalPCSLibrary,
    StackedEulerLagrangeLibrary,
    WeakEulerLagrangeSINDy,
    stack_forces,
)
from pcs_sindy.simulation import get_scenario
from pcs_sindy.simulation.rendering import render_frames
from pcs_sindy.vision import MarkerPoseExtractor


def from_videos() -> None:
    scenario = get_scenario("two_segment")
    data = scenario.generate(seed=0)
    total_length = scenario.robot.kinematics.total_length
    camera = Camera.fit_robot(total_length)
    start = time.perf_counter()
    videos = [render_frames(rec.poses_true, camera) for rec in data.train]
    poses = MarkerPoseExtractor(camera=camera, fps=1000.0, progress=False).fit_transform(videos)
    # sub-pixel extraction: a few hundredths of a millimetre, a few tenths of a degree
    fusion = KinematicFusion(threshold=0.2, total_length=total_length, pose_std=(2.5e-5, 6e-3)).fit(poses)
    strains = fusion.transform(poses)
    taus = [rec.tau for rec in data.train]
    lengths = tuple(fusion.segment_lengths_)
    print(
        f"{len(videos)} videos -> {fusion.n_segments_} segments {np.round(lengths, 4)} m "
        f"in {time.perf_counter() - start:.1f} s"
    )

    # the pysindy route: strains as x, forces as u; the weak form needs no accelerations
    lib = PhysicalPCSLibrary(lengths)
    sindy = WeakEulerLagrangeSINDy(feature_library=lib, optimizer=ps.STLSQ())
    sindy.fit([s.q for s in strains], t=[s.t for s in strains], u=taus)
    print("\nWeakEulerLagrangeSINDy (pysindy.SINDy, weak Euler-Lagrange form):")
    sindy.print(precision=4)

    # the package's estimator on the same strains, same library and optimizer
    reg = EulerLagrangeRegressor(feature_library=lib, optimizer=ps.STLSQ()).fit(strains, taus)
    # coefficients(): one row per strain equation (the terms acting on it); the physical values are coef_
    assert sindy.coefficients().shape == reg.coefficients().shape == (lib.kinematics.n_active, reg.coef_.size)
    a, b = sindy.regressor_.coef_, reg.coef_
    print("\n" + "coefficient".ljust(12) + "SINDy".rjust(14) + "regressor".rjust(14))
    for name, x, y in zip(sindy.get_feature_names(), a, b, strict=True):
        print(f"{name:<12}{x:14.6g}{y:14.6g}")
    print(f"max |SINDy - regressor| / max |coef|: {np.abs(a - b).max() / np.abs(b).max():.1e}")

    # both roll out the 7 s validation from rest under its forces: x0 = [q0, qd0]
    val = data.validation
    n = lib.kinematics.n_active
    s_end = np.array([float(np.sum(lengths))])
    kin = reg.kinematics_
    x = np.asarray(sindy.simulate(np.zeros(2 * n), val.t, val.tau))  # a StrainTrajectory; as an array [q, qd]
    tips = {
        "WeakEulerLagrangeSINDy": kin.forward_kinematics(x[:, :n], s_end)[:, 0],
        "EulerLagrangeRegressor": kin.forward_kinematics(reg.simulate(np.zeros(2 * n), val.t, val.tau).q, s_end)[:, 0],
    }
    for label, tip in tips.items():
        e_p, e_th = end_effector_errors(tip[:, None], val.poses_true[:, -1:])
        print(f"{label}: 7 s validation rollout e_p^EE = {1e3 * e_p:.3f} mm, e_theta^EE = {e_th:.4f} rad")


def plain_sindy_is_refused() -> None:
    lib = PhysicalPCSLibrary([0.1])
    t = np.arange(100) * 1e-3
    try:
        ps.SINDy(feature_library=lib).fit(np.zeros((100, 6)), t=t)
    except TypeError as err:
        print(f"\nplain SINDy with a PCS library: TypeError: {str(err)[:160]}...")


def stacked_with_exact_accelerations() -> None:
    scenario = get_scenario("one_segment")
    robot = scenario.robot
    recs = scenario.generate(seed=0, validation=False).train
    qdd = [robot.forward_dynamics(r.q, r.qd, r.tau) for r in recs]
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity, rest_strain=False)
    names = lib.kinematics.strain_names(active_only=True)
    model = ps.SINDy(feature_library=StackedEulerLagrangeLibrary(lib), optimizer=ps.STLSQ(threshold=0.0, alpha=0.0))
    model.fit(
        [np.hstack([r.q, r.qd, a]) for r, a in zip(recs, qdd, strict=True)],
        t=[r.t for r in recs],
        x_dot=[stack_forces(r.tau) for r in recs],
        feature_names=names + [f"d{n}" for n in names] + [f"dd{n}" for n in names],
    )
    strains = [StrainTrajectory(r.q, r.t, segment_lengths=robot.segment_lengths) for r in recs]
    reg = EulerLagrangeRegressor(feature_library=lib, formulation="strong")
    reg.fit(strains, [r.tau for r in recs], qd=[r.qd for r in recs], qdd=qdd)
    coef = model.coefficients()[0]
    print("\npysindy.SINDy, stacked strong form with the simulator's accelerations (one_segment):")
    model.print(lhs=["tau"], precision=6)
    print(f"max relative difference SINDy vs regressor: {np.max(np.abs(coef - reg.coef_) / np.abs(reg.coef_)):.1e}")


def pysindy_script() -> None:
    scenario = get_scenario("one_segment")
    data = scenario.generate(seed=0)
    q, u = [r.q for r in data.train], [r.tau for r in data.train]  # strains (T, 3) and forces (T, 3)
    model = EulerLagrangeRegressor()
    model.fit(q, t=0.001, u=u, segment_lengths=[0.1])
    print("\npysindy's idioms on EulerLagrangeRegressor (one_segment):")
    model.print(lhs=["M_be", "F_sh", "F_ax"])
    print("coefficients():", model.coefficients().shape, "columns", list(model.get_feature_names_out()[:4]), "...")
    val = data.validation
    x = np.asarray(model.simulate(np.r_[val.q[0], val.qd[0]], val.t, val.tau))  # (T, 6): [q, qd]
    print(f"7 s validation: max |q - q_true| = {np.abs(x[:, :3] - val.q).max():.2e}")


def main() -> None:
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # identifiability notes of weakly excited parameters
        from_videos()
    plain_sindy_is_refused()
    stacked_with_exact_accelerations()
    pysindy_script()
    print(f"total {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
