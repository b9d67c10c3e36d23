"""The PCS libraries inside ``pysindy.SINDy`` in the stacked Euler–Lagrange form (issue 5).

Truth: ``EulerLagrangeRegressor`` on the same data and library (an independent
route through the regression), the known true parameters of the scenario's robot,
and the simulator's inverse dynamics (forces predicted back).
"""

from __future__ import annotations

import numpy as np
import pysindy as ps
import pytest

from pcs_sindy.core import StrainTrajectory
from pcs_sindy.identification import (
    EulerLagrangeRegressor,
    PCSLagrangianLibrary,
    PhysicalPCSLibrary,
    StackedEulerLagrangeLibrary,
    StiffnessThresholdOptimizer,
    stack_forces,
    unstack_forces,
)


@pytest.fixture(scope="module")
def one_segment():
    from pcs_sindy.simulation import get_scenario

    scenario = get_scenario("one_segment")
    data = scenario.generate(seed=0, validation=False)
    robot = scenario.robot
    recs = data.train[:3]
    # exact rates from the simulator, accelerations from its forward dynamics
    qdd = [robot.forward_dynamics(r.q, r.qd, r.tau) for r in recs]
    return robot, recs, qdd


def _physical(robot):
    return PhysicalPCSLibrary(robot.segment_lengths, radius=robot.radius, gravity=robot.gravity, rest_strain=False)


@pytest.mark.parametrize("kind", ["physical", "lagrangian_physical"])
@pytest.mark.parametrize("optimizer", ["stlsq", "stiffness"])
def test_sindy_stacked_equals_regressor(one_segment, kind, optimizer):
    robot, recs, qdd = one_segment
    if kind == "physical":
        lib = _physical(robot)
    else:
        lib = PCSLagrangianLibrary(robot.segment_lengths, basis="physical")
    L = robot.segment_lengths
    X = [StrainTrajectory(r.q, r.t, segment_lengths=L) for r in recs]
    reg = EulerLagrangeRegressor(feature_library=lib, formulation="strong", check_mass_matrix=False).fit(
        X, [r.tau for r in recs], qd=[r.qd for r in recs], qdd=qdd
    )
    assert reg.removed_strains_ == []
    opt = ps.STLSQ(threshold=0.0, alpha=0.0) if optimizer == "stlsq" else StiffnessThresholdOptimizer()
    model = ps.SINDy(feature_library=StackedEulerLagrangeLibrary(lib), optimizer=opt)
    x = [np.hstack([r.q, r.qd, a]) for r, a in zip(recs, qdd, strict=True)]
    model.fit(x, t=[r.t for r in recs], x_dot=[stack_forces(r.tau) for r in recs])
    coef = model.coefficients()
    assert coef.shape == (1, reg.coef_.size)  # ONE coefficient vector shared by all degrees of freedom
    np.testing.assert_allclose(coef[0], reg.coef_, rtol=1e-8, atol=1e-8 * np.abs(reg.coef_).max())
    if kind == "physical":
        # and both are the robot's true parameters (exact q̇, q̈: the regression is exact)
        truth = lib.coefficients_from_parameters(
            robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
        )
        np.testing.assert_allclose(coef[0], truth, rtol=1e-6)
    # predict gives the forces back, stacked dof-major
    pred = unstack_forces(model.predict(x[0]), robot.n_q)
    np.testing.assert_allclose(pred, recs[0].tau, rtol=0, atol=1e-6 * np.abs(recs[0].tau).max())
    assert model.feature_library.get_feature_names() == list(lib.euler_lagrange_names())


def test_stacked_layout_and_errors(one_segment):
    robot, recs, qdd = one_segment
    lib = _physical(robot)
    st = StackedEulerLagrangeLibrary(lib)
    x = np.hstack([recs[0].q, recs[0].qd, qdd[0]])[:50]
    out = st.fit(x).transform(x)
    psi = lib.euler_lagrange_matrix(x[:, :3], x[:, 3:6], x[:, 6:])
    assert out.shape == (3, 50, psi.shape[-1])
    np.testing.assert_array_equal(out[1], psi[:, 1, :])
    assert (np.atleast_1d(out.ax_spatial).tolist(), out.ax_time, out.ax_coord) == ([0], 1, 2)
    tau = recs[0].tau[:50]
    np.testing.assert_array_equal(stack_forces(tau)[2, :, 0], tau[:, 2])
    np.testing.assert_array_equal(unstack_forces(stack_forces(tau).reshape(-1, 1), 3), tau)
    with pytest.raises(ValueError, match=r"x must have 3n = 9 columns"):
        st.fit(x[:, :6])
    with pytest.raises(ValueError, match="NaN"):
        st.transform(np.full((4, 9), np.nan))
    with pytest.raises(ValueError, match="library must provide euler_lagrange_matrix"):
        StackedEulerLagrangeLibrary(object()).fit(x)
    with pytest.raises(ValueError, match=r"tau must have shape \(n_time, n\)"):
        stack_forces(tau[:, 0])
    with pytest.raises(ValueError, match="not a multiple of n = 4"):
        unstack_forces(np.zeros(6), 4)


def _strong_fit(one_segment, optimizer):
    robot, recs, qdd = one_segment
    X = [StrainTrajectory(r.q, r.t, segment_lengths=robot.segment_lengths) for r in recs]
    reg = EulerLagrangeRegressor(feature_library=_physical(robot), formulation="strong", optimizer=optimizer)
    return reg.fit(X, [r.tau for r in recs], qd=[r.qd for r in recs], qdd=qdd)


@pytest.mark.parametrize("optimizer", [ps.STLSQ(threshold=0.0, alpha=0.0), ps.SR3(reg_weight_lam=0.0)])
def test_any_pysindy_optimizer_drives_the_regressor(one_segment, optimizer):
    robot = one_segment[0]
    ref = _strong_fit(one_segment, StiffnessThresholdOptimizer(threshold=np.inf))
    reg = _strong_fit(one_segment, optimizer)
    truth = reg.library_.coefficients_from_parameters(
        robot.density, robot.radius, robot.youngs_modulus, robot.shear_modulus, robot.damping
    )
    # exact rates and accelerations: every optimizer without a penalty lands on the truth
    np.testing.assert_allclose(reg.coef_, ref.coef_, rtol=1e-5, atol=1e-6 * np.abs(truth).max())
    np.testing.assert_allclose(ref.coef_, truth, rtol=1e-6)
    assert reg.removed_strains_ == [] and type(reg.optimizer_) is type(optimizer)


def test_from_sindy_rolls_out_like_the_regressor(one_segment):
    robot, recs, qdd = one_segment
    lib = _physical(robot)
    model = ps.SINDy(feature_library=StackedEulerLagrangeLibrary(lib), optimizer=ps.STLSQ(threshold=0.0, alpha=0.0))
    model.fit(
        [np.hstack([r.q, r.qd, a]) for r, a in zip(recs, qdd, strict=True)],
        t=[r.t for r in recs],
        x_dot=[stack_forces(r.tau) for r in recs],
    )
    from_sindy = EulerLagrangeRegressor.from_sindy(model)
    reg = _strong_fit(one_segment, ps.STLSQ(threshold=0.0, alpha=0.0))
    np.testing.assert_array_equal(from_sindy.coef_, model.coefficients()[0])
    np.testing.assert_allclose(from_sindy.stiffness_, robot.stiffness, rtol=1e-6)
    t = recs[1].t[:200]
    a = from_sindy.simulate(recs[1].q[0], recs[1].qd[0], t, recs[1].tau[:200])
    b = reg.simulate(recs[1].q[0], recs[1].qd[0], t, recs[1].tau[:200])
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-6 * np.abs(b.q).max())
    # and both follow the recording (exact model): the rollout is the recorded motion
    err = np.abs(a.q - recs[1].q[:200]).max(axis=0) / np.abs(recs[1].q[:200]).max(axis=0)
    assert np.all(err < 1e-3), err
    assert from_sindy.equations() == reg.library_.equations(from_sindy.coef_)
    with pytest.raises(ValueError, match="StackedEulerLagrangeLibrary"):
        EulerLagrangeRegressor.from_sindy(ps.SINDy())
