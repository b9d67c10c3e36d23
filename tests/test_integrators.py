"""Explicit RK rollout against closed forms (matrix exponential of linear systems)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from pcs_sindy.integrators import DOPRI5, ROS34PW2, DivergenceError, integrate_zoh

W, ZETA = 20.0, 0.1
A_OSC = np.array([[0.0, 1.0], [-(W**2), -2 * ZETA * W]])


def _osc(y, u):
    return A_OSC @ y + np.array([0.0, u[0]])


def _exact_zoh(y0, t, u):
    """Damped oscillator under a zero-order-hold force: exact by the matrix exponential."""
    aug = np.zeros((3, 3))
    aug[:2, :2] = A_OSC
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
    return t, u, _exact_zoh([1.0, 0.0], t, u)


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


def test_fixed_step_is_fifth_order_on_piecewise_constant_forcing():
    t, u, exact = _problem()
    errors = [np.abs(integrate_zoh(_osc, [1.0, 0.0], t, u, step=h) - exact).max() for h in (0.005, 0.0025, 0.00125)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    # halving the step divides the error by ~2^5 = 32
    assert np.all(ratios > 25) and np.all(ratios < 40), ratios
    assert errors[-1] < 1e-9


def test_adaptive_step_meets_tolerance_and_callable_input():
    t, u, exact = _problem()
    out = integrate_zoh(_osc, [1.0, 0.0], t, u, rtol=1e-9, atol=1e-12)
    assert np.abs(out - exact).max() < 1e-7
    # callable input: a smooth forcing, reference from the forced response
    # of y' = A y + [0, cos(w_f t)] written as an autonomous 4-state linear system
    wf = 7.0
    big = np.zeros((4, 4))
    big[:2, :2] = A_OSC
    big[1, 2] = 1.0
    big[2, 3] = 1.0
    big[3, 2] = -(wf**2)  # [c, c'] with c = cos(wf t)
    ref = np.array([(expm(big * tk) @ np.array([0.5, 0.0, 1.0, 0.0]))[:2] for tk in t])
    out_c = integrate_zoh(_osc, [0.5, 0.0], t, lambda tk: [np.cos(wf * tk)], rtol=1e-10, atol=1e-12)
    assert np.abs(out_c - ref).max() < 1e-8


def test_divergence_raises_with_time_and_state():
    t = np.arange(200) * 0.01
    grow = lambda y, u: 50.0 * y  # noqa: E731  e^(50 t) passes 1e6 well before t = 2 s
    with pytest.raises(DivergenceError, match=r"t = .* s.*a=") as info:
        integrate_zoh(grow, [1.0, 1.0], t, np.zeros((t.size, 1)), step=0.001, state_names=["a", "b"])
    assert 0.2 < info.value.t < 0.35 and np.all(np.isfinite(info.value.y))

    def singular(y, u):
        return np.linalg.solve(np.zeros((2, 2)), y)

    with pytest.raises(DivergenceError, match="right-hand side failed"):
        integrate_zoh(singular, [1.0, 1.0], t, np.zeros((t.size, 1)))


def test_bad_input():
    t = np.arange(10) * 0.01
    with pytest.raises(ValueError, match="does not divide"):
        integrate_zoh(_osc, [1.0, 0.0], t, np.zeros((10, 1)), step=0.003)
    with pytest.raises(ValueError, match="u must have shape"):
        integrate_zoh(_osc, [1.0, 0.0], t, np.zeros((9, 1)))
    with pytest.raises(ValueError, match="NaN"):
        integrate_zoh(_osc, [np.nan, 0.0], t, np.zeros((10, 1)))
    with pytest.raises(ValueError, match="increasing"):
        integrate_zoh(_osc, [1.0, 0.0], t[::-1], np.zeros((10, 1)))


# ---------------------------------------------------------------------------
# Rosenbrock-W (ROS34PW2)
# ---------------------------------------------------------------------------
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


@pytest.mark.parametrize("jac_scale", [1.0, 0.5, 0.0])
def test_rosenbrock_w_is_third_order_whatever_the_jacobian(jac_scale):
    # a W-method keeps order 3 with any approximation of J, even J = 0 (then it is explicit)
    t, u, exact = _problem()
    jac = lambda y, uk: jac_scale * A_OSC  # noqa: E731
    errors = [np.abs(integrate_zoh(_osc, [1.0, 0.0], t, u, step=h, method="rosenbrock", jac=jac) - exact).max()
              for h in (0.005, 0.0025)]
    assert 7 < errors[0] / errors[1] < 9, errors  # 2^3 = 8
    assert errors[-1] < 1e-3


def test_rosenbrock_finite_difference_jacobian_and_callable_input():
    t, u, exact = _problem()
    out = integrate_zoh(_osc, [1.0, 0.0], t, u, step=0.00125, method="rosenbrock")  # jac by differences
    exact_jac = integrate_zoh(_osc, [1.0, 0.0], t, u, step=0.00125, method="rosenbrock", jac=lambda y, uk: A_OSC)
    assert np.abs(out - exact_jac).max() < 1e-9
    # smooth callable forcing: the time derivative of u is not in J, order 3 all the same
    wf = 7.0
    big = np.zeros((4, 4))
    big[:2, :2] = A_OSC
    big[1, 2] = 1.0
    big[2, 3] = 1.0
    big[3, 2] = -(wf**2)
    ref = np.array([(expm(big * tk) @ np.array([0.5, 0.0, 1.0, 0.0]))[:2] for tk in t])
    errs = [np.abs(integrate_zoh(_osc, [0.5, 0.0], t, lambda tk: [np.cos(wf * tk)], step=h, method="rosenbrock",
                                 jac=lambda y, uk: A_OSC) - ref).max() for h in (0.005, 0.0025)]
    assert 6.5 < errs[0] / errs[1] < 9.5, errs


def test_rosenbrock_is_not_stability_limited_on_a_stiff_problem():
    # y1' = -1e5 (y1 - cos t) (stiff, follows cos t), y2' = y1: explicit steps need h < 3.3e-5
    lam = 1e5

    def f(y, uk):
        return np.array([-lam * (y[0] - uk[0]), y[0]])

    t = np.linspace(0.0, 0.3, 31)
    u = np.cos(t)[:, None]
    # exact zero-order-hold solution, interval by interval
    h, decay = 0.01, np.exp(-lam * 0.01)
    ref = [np.array([1.0, 0.0])]
    for k in range(t.size - 1):
        y1, y2 = ref[-1]
        uk = u[k, 0]
        ref.append(np.array([uk + (y1 - uk) * decay, y2 + uk * h + (y1 - uk) * (1 - decay) / lam]))
    ref = np.array(ref)
    st_r, st_d = {}, {}
    out = integrate_zoh(f, [1.0, 0.0], t, u, method="rosenbrock", rtol=1e-6, atol=1e-9, stats=st_r)
    integrate_zoh(f, [1.0, 0.0], t, u, rtol=1e-6, atol=1e-9, stats=st_d)
    assert np.abs(out - ref).max() < 1e-8
    assert st_r["n_steps"] < 0.1 * st_d["n_steps"], (st_r, st_d)


def test_rosenbrock_divergence_and_bad_method():
    t = np.arange(200) * 0.01
    grow = lambda y, u: 50.0 * y  # noqa: E731
    with pytest.raises(DivergenceError, match=r"t = .* s.*a="):
        integrate_zoh(grow, [1.0, 1.0], t, np.zeros((t.size, 1)), method="rosenbrock", state_names=["a", "b"])
    with pytest.raises(ValueError, match="method must be one of.*'rk45'"):
        integrate_zoh(_osc, [1.0, 0.0], t, np.zeros((t.size, 1)), method="rk45")
    with pytest.raises(ValueError, match="jac is only used"):
        integrate_zoh(_osc, [1.0, 0.0], t, np.zeros((t.size, 1)), jac=lambda y, u: A_OSC)
    with pytest.raises(ValueError, match=r"jac must return shape \(2, 2\)"):
        integrate_zoh(_osc, [1.0, 0.0], t, np.zeros((t.size, 1)), method="rosenbrock", jac=lambda y, u: np.eye(3))
