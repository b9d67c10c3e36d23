"""The PCS Euler–Lagrange regression run by ``pysindy.SINDy`` (stacked form).

The one-segment scenario's training data with exact rates and accelerations
(from the simulator's forward dynamics) are fitted twice with the same
``PhysicalPCSLibrary``: by ``pysindy.SINDy`` with the library wrapped in
``StackedEulerLagrangeLibrary`` (states ``[q, qd, qdd]``, forces passed as
``x_dot`` stacked per degree of freedom) and by ``EulerLagrangeRegressor``.
Both find one coefficient vector shared by the three strains: the robot's
lumped physical parameters.

Run: ``.venv/bin/python examples/pysindy_interop.py`` (well under a minute).
"""

from __future__ import annotations

import numpy as np
import pysindy as ps

from pcs_sindy.core import StrainTrajectory
from pcs_sindy.identification import (
    EulerLagrangeRegressor,
    PhysicalPCSLibrary,
    StackedEulerLagrangeLibrary,
    stack_forces,
    unstack_forces,
)
from pcs_sindy.simulation import get_scenario


def main() -> None:
    scenario = get_scenario("one_segment")
    robot = scenario.robot
    data = scenario.generate(seed=0, validation=False)
    recs = data.train
    qdd = [robot.forward_dynamics(r.q, r.qd, r.tau) for r in recs]
    # the simulated robot is straight at rest: no constant forces (rest strains) to identify
    lib = PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity, rest_strain=False)

    names = lib.kinematics.strain_names(active_only=True)
    states = names + [f"d{n}" for n in names] + [f"dd{n}" for n in names]  # x = [q, qd, qdd]
    # pysindy: one output coordinate (tau), degrees of freedom on a spatial axis
    model = ps.SINDy(feature_library=StackedEulerLagrangeLibrary(lib), optimizer=ps.STLSQ(threshold=0.0, alpha=0.0))
    model.fit(
        [np.hstack([r.q, r.qd, a]) for r, a in zip(recs, qdd, strict=True)],
        t=[r.t for r in recs],
        x_dot=[stack_forces(r.tau) for r in recs],
        feature_names=states,
    )
    print("pysindy.SINDy (stacked Euler-Lagrange form, tau = Psi(q, qd, qdd) pi):")
    model.print(lhs=["tau"], precision=6)

    # the package's own estimator on the same data and library, in the same (strong) form: tau = Psi pi per sample
    strains = [StrainTrajectory(r.q, r.t, segment_lengths=robot.segment_lengths) for r in recs]
    reg = EulerLagrangeRegressor(library=lib, formulation="strong")
    reg.fit(strains, [r.tau for r in recs], qd=[r.qd for r in recs], qdd=qdd)
    print("\nEulerLagrangeRegressor:")
    reg.print(precision=6)

    coef = model.coefficients()[0]
    truth = lib.coefficients_from_parameters(
        robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
    )
    print("\n" + "parameter".ljust(12) + "SINDy".rjust(14) + "regressor".rjust(14) + "true".rjust(14))
    for name, a, b, c in zip(lib.euler_lagrange_names(), coef, reg.coef_, truth, strict=True):
        print(f"{name:<12}{a:14.6g}{b:14.6g}{c:14.6g}")
    print(f"max relative difference SINDy vs regressor: {np.max(np.abs(coef - reg.coef_) / np.abs(reg.coef_)):.1e}")
    tau_hat = unstack_forces(model.predict(np.hstack([recs[0].q, recs[0].qd, qdd[0]])), robot.n_q)
    print(f"max |tau_hat - tau| on recording 0: {np.abs(tau_hat - recs[0].tau).max():.1e} N")


if __name__ == "__main__":
    main()
