"""The rollout integrators against closed forms (matrix exponential of linear systems).

A one-segment model with only the axial strain modelled and no gravity is a
linear oscillator ``m sdd + d sd + k s = tau`` with ``m = rhoA L^3 / 3``: its
zero-order-hold solution is exact by the matrix exponential, which checks the
compiled Dormand–Prince and Rosenbrock-W loops (orders, tolerances, stiffness)
and the solve_ivp path.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from pcs_sindy.core import PlanarPCS, SimulationError, canonical_method
from pcs_sindy.models import DOPRI5, ROS34PW2, LumpedPCSModel, solve_held

W, ZETA, L = 20.0, 0.1, 0.1
A_OSC = np.array([[0.0, 1.0], [-(W**2), -2 * ZETA * W]])


def _oscillator(k: float = W**2, d: float = 2 * ZETA * W) -> LumpedPCSModel:
    """``sdd + d sd + k s = tau`` (unit mass) as an axial-only PCS model."""
    kin = PlanarPCS((L,), active_strains=[[False, False, True]])
    return LumpedPCSModel(kin, [3.0 / L**3], [0.0], [[0.0, 0.0]], [k], [d])


def _exact_zoh(A, y0, t, u):
    aug = np.zeros((3, 3))
    aug[:2, :2] = A
    aug[1, 2] = 1.0
    y = np.asarray(y0, float)
    out = [y]
    for k in range(t.size - 1):
        y = (expm(aug * (t[k + 1] - t[k])) @ np.r_[y, u[k, 0]])[:2]
        out.append(y)
    return np.array(out)


def _problem():
    rng = np.random.default_rng(0)
    t = np.arange(101) * 0.01
    u = rng.normal(size=(t.size, 1)) * 50.0
    return t, u, _exact_zoh(A_OSC, [1.0, 0.0], t, u)


def _run(model, t, u, y0=(1.0, 0.0), **kw):
    sim = model.simulate([0.0, 0.0, y0[0]], [0.0, 0.0, y0[1]], t, u, **kw)
    return np.stack([sim.q[:, 2], sim.qd[:, 2]], axis=1)


def test_tableau_order_conditions():
    # the 5th-order weights satisfy the order conditions up to order 5 (a sample),
    # the embedded 4th-order weights up to order 4; rows of A sum to c
    a, b, c = DOPRI5.a, DOPRI5.b, DOPRI5.c
    b_hat = b - DOPRI5.e
    np.testing.assert_allclose(a.sum(axis=1), c, atol=1e-15)
    for w, order in ((b, 5), (b_hat, 4)):
        for p in range(1, order + 1):
            assert w @ c ** (p - 1) == pytest.approx(1.0 / p, abs=1e-14)
        assert w @ (a @ c) == pytest.approx(1 / 6, abs=1e-14)
        assert w @ (c * (a @ c)) == pytest.approx(1 / 8, abs=1e-14)
    assert b @ (a @ (a @ (a @ c))) == pytest.approx(1 / 120, abs=1e-14)


def test_rosenbrock_tableau_order_conditions():
    # Rosenbrock order conditions (Hairer & Wanner II, Table IV.7.1) up to order 3 for b,
    # up to order 2 for the embedded b_hat; beta = alpha + Gamma off the diagonal
    a, g, b, b_hat = ROS34PW2.alpha, ROS34PW2.Gamma, ROS34PW2.b, ROS34PW2.b_hat
    gam = ROS34PW2.gamma
    beta = a + g - np.diag(np.diag(g))
    al, bp = a.sum(axis=1), beta.sum(axis=1)
    for w, order in ((b, 3), (b_hat, 2)):
        assert w.sum() == pytest.approx(1.0, abs=1e-14)
        assert w @ bp == pytest.approx(0.5 - gam, abs=1e-14)
        if order >= 3:
            assert w @ al**2 == pytest.approx(1 / 3, abs=1e-14)
            assert w @ (beta @ bp) == pytest.approx(1 / 6 - gam + gam**2, abs=1e-14)
    # stiffly accurate: the solution is the last stage (L-stability with A-stability)
    np.testing.assert_allclose((a + g)[-1], b, atol=1e-15)


@pytest.mark.parametrize("method,order", [("dopri5", 5), ("rosenbrock", 3)])
def test_fixed_steps_have_the_scheme_order_on_held_forcing(method, order):
    t, u, exact = _problem()
    model = _oscillator()
    errors = [np.abs(_run(model, t, u, method=method, step=h) - exact).max() for h in (0.005, 0.0025, 0.00125)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    # halving the step divides the error by ~2^order
    assert np.all(ratios > 0.75 * 2**order) and np.all(ratios < 1.3 * 2**order), ratios


@pytest.mark.parametrize("method", ["dopri5", "rosenbrock", "radau", "dop853", "bdf", "lsoda"])
def test_adaptive_schemes_meet_their_tolerance(method):
    t, u, exact = _problem()
    out = _run(_oscillator(), t, u, method=method, rtol=1e-8, atol=1e-10)
    scale = np.abs(exact).max(axis=0)
    assert np.all(np.abs(out - exact).max(axis=0) <= 1e-5 * scale), np.abs(out - exact).max(axis=0) / scale


def test_callable_input_through_solve_ivp():
    wf = 7.0
    t = np.linspace(0.0, 1.0, 201)
    out = _run(
        _oscillator(), t, lambda s: [0.0, 0.0, np.cos(wf * s)], y0=(0.5, 0.0), method="radau", rtol=1e-10, atol=1e-12
    )
    # the steady-state and the transient of a cosine-forced oscillator, in closed form
    from scipy.integrate import solve_ivp

    ref = solve_ivp(
        lambda s, y: A_OSC @ y + [0.0, np.cos(wf * s)],
        (0, 1),
        [0.5, 0.0],
        method="DOP853",
        t_eval=t,
        rtol=1e-12,
        atol=1e-14,
    ).y.T
    assert np.abs(out - ref).max() < 1e-7
    with pytest.raises(ValueError, match="tabulated inputs"):
        _run(_oscillator(), t, lambda s: [0.0, 0.0, 1.0], method="rosenbrock")


def test_rosenbrock_is_not_stability_limited_on_a_stiff_oscillator():
    # overdamped with a 1e-5 s time constant: explicit steps must stay below ~3e-5 s
    k, d = 1e5, 1e5 + 1.0
    model = _oscillator(k, d)
    t = np.linspace(0.0, 0.3, 31)
    u = np.cos(t)[:, None] * k
    exact = _exact_zoh(np.array([[0.0, 1.0], [-k, -d]]), [1.0, 0.0], t, u)
    st_r, st_d = {}, {}
    out = _run(model, t, u, method="rosenbrock", rtol=1e-4, atol=1e-7, stats=st_r)
    _run(model, t, u, method="dopri5", rtol=1e-4, atol=1e-7, stats=st_d)
    assert np.abs(out[:, 0] - exact[:, 0]).max() < 1e-5
    assert st_r["n_steps"] < 0.1 * st_d["n_steps"], (st_r, st_d)


@pytest.mark.parametrize("method", ["dopri5", "rosenbrock", "radau"])
def test_divergence_raises_with_time_and_state(method):
    t = np.arange(200) * 0.01
    unstable = _oscillator(k=-2500.0, d=0.0)
    with pytest.raises(SimulationError, match=r"t = .* s.*ax_1="):
        _run(unstable, t, np.zeros((t.size, 1)), method=method, max_abs_state=1e3)
    singular = LumpedPCSModel(PlanarPCS((L,)), [0.0], [0.0], [[0.0, 0.0]], [1.0] * 3, [0.0] * 3)
    with pytest.raises(SimulationError, match="singular") as err:
        singular.simulate(np.ones(3), np.zeros(3), t[:5], np.zeros((5, 3)), method=method)
    assert err.value.y.size == 6


def test_bad_input_is_named():
    t = np.arange(10) * 0.01
    model = _oscillator()
    with pytest.raises(ValueError, match="does not divide"):
        _run(model, t, np.zeros((10, 1)), step=0.003)
    with pytest.raises(ValueError, match=r"u must have shape \(10, 3\)"):
        _run(model, t, np.zeros((9, 1)))
    with pytest.raises(ValueError, match="q0 contains NaN"):
        model.simulate([0.0, 0.0, np.nan], np.zeros(3), t, np.zeros((10, 1)))
    with pytest.raises(ValueError, match="strictly increasing"):
        _run(model, t[::-1], np.zeros((10, 1)))
    with pytest.raises(ValueError, match=r"method must be one of \['rosenbrock'"):
        _run(model, t, np.zeros((10, 1)), method="euler")
    with pytest.raises(ValueError, match="rtol must be finite"):
        _run(model, t, np.zeros((10, 1)), rtol=-1.0)


def test_former_method_names_warn_and_map():
    with pytest.warns(FutureWarning, match="method='radau'"):
        assert canonical_method("Radau", ("radau", "dopri5")) == "radau"
    with pytest.warns(FutureWarning, match="method='dopri5'"):
        assert canonical_method("RK45", ("radau", "dopri5")) == "dopri5"
    with pytest.raises(ValueError, match="must be one of"):
        canonical_method("rosenbrock", ("radau",))


def test_solve_held_on_a_plain_function():
    t, u, exact = _problem()
    out = solve_held(
        lambda y, uk: A_OSC @ y + np.array([0.0, uk[0]]), [1.0, 0.0], t, u, method="dop853", rtol=1e-10, atol=1e-12
    )
    assert np.abs(out - exact).max() < 1e-8
    with pytest.raises(SimulationError, match="a="):
        solve_held(lambda y, uk: 50.0 * y, [1.0, 1.0], t, u, method="radau", max_abs_state=1e3, state_names=["a", "b"])
    with pytest.raises(ValueError, match="for solve_ivp"):
        solve_held(lambda y, uk: y, [1.0], t, u, method="rosenbrock")


def test_solve_held_reports_where_solve_ivp_gives_up_inside_a_sample():
    # y' = y^2 from y(0) = 1 blows up at t = 1, inside the sample [0.5, 2]; solve_ivp fails there
    with pytest.raises(SimulationError, match="solve_ivp") as err:
        solve_held(lambda y, uk: y**2, [1.0], [0.0, 0.5, 2.0], np.zeros((3, 1)), method="dopri5", max_abs_state=1e300)
    assert err.value.t == pytest.approx(1.0, abs=1e-3)  # the last step reached (numerically at the pole), not 0.5
    assert err.value.y[0] > 1e6
