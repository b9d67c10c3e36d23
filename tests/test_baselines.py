"""Black-box baselines recover systems of their own class exactly (truth written independently here)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pcs_sindy.core.validation import InvalidParameterError
from pcs_sindy.identification import ARX, LaggedPolynomialMap, LinearLoadInterpolator, PolynomialLoadMap


def steps(rng, n, n_u, hold=37):
    """Piecewise-constant random inputs (held ``hold`` samples)."""
    levels = rng.uniform(-1, 1, size=(n // hold + 1, n_u))
    return np.repeat(levels, hold, axis=0)[:n]


# ---------------------------------------------------------------------------- ARX
A1 = np.diag([1.5, 1.2, 0.9])
A2 = np.diag([-0.7, -0.5, -0.2])
B1 = np.array([[0.3, -0.1], [0.0, 0.2], [0.1, 0.1]])
B2 = np.array([[0.05, 0.0], [-0.1, 0.1], [0.0, 0.3]])
C = np.array([0.01, -0.02, 0.5])


def arx_truth(u, y0, y1):
    y = np.zeros((u.shape[0], 3))
    y[0], y[1] = y0, y1
    for k in range(2, u.shape[0]):
        y[k] = A1 @ y[k - 1] + A2 @ y[k - 2] + B1 @ u[k - 1] + B2 @ u[k - 2] + C
    return y


def test_arx_recovers_an_exact_system_and_its_open_loop_rollout():
    rng = np.random.default_rng(0)
    u = steps(rng, 600, 2)
    y = arx_truth(u, np.array([0.1, 0.0, 1.0]), np.array([0.1, 0.05, 1.0]))
    model = ARX(2, 2).fit(u, y)
    np.testing.assert_allclose(model.ar_coef_, [A1, A2], atol=1e-8)
    np.testing.assert_allclose(model.input_coef_, [B1, B2], atol=1e-8)
    np.testing.assert_allclose(model.intercept_, C, atol=1e-8)
    # the eigenvalues of a diagonal ARX(2): the roots of z^2 - a1 z - a2 per output
    radius = max(np.max(np.abs(np.roots([1, -a1, -a2]))) for a1, a2 in zip(np.diag(A1), np.diag(A2), strict=True))
    assert model.spectral_radius_ == pytest.approx(radius, rel=1e-7)
    # open loop on new inputs, from two measured outputs only
    u_new = steps(np.random.default_rng(1), 400, 2, hold=23)
    truth = arx_truth(u_new, y[10], y[11])
    np.testing.assert_allclose(model.predict(u_new, truth[:2]), truth, atol=1e-7)


def test_arx_skips_the_rows_that_need_a_missing_output():
    rng = np.random.default_rng(2)
    u = steps(rng, 500, 2)
    y = arx_truth(u, np.zeros(3), np.zeros(3))
    y_missing = y.copy()
    y_missing[[50, 51, 300]] = np.nan  # rows 50..53 and 300..302 cannot be regressed
    model = ARX().fit(u, y_missing)
    assert model.n_rows_ == 498 - 4 - 3
    np.testing.assert_allclose(model.ar_coef_, [A1, A2], atol=1e-8)


def test_arx_refuses_missing_inputs_and_bad_initial_outputs():
    u = np.zeros((100, 2))
    u[40, 1] = np.nan
    with pytest.raises(ValueError, match="row 40"):
        ARX().fit(u, np.zeros((100, 3)))
    model = ARX().fit(steps(np.random.default_rng(3), 200, 2), np.random.default_rng(3).normal(size=(200, 3)))
    with pytest.raises(ValueError, match="y_initial"):
        model.predict(np.zeros((10, 2)), np.zeros((1, 3)))
    with pytest.raises(InvalidParameterError, match="na must be"):
        ARX(na=0).fit(np.zeros((100, 2)), np.zeros((100, 3)))


# ---------------------------------------------------------------------------- lagged polynomial
def lag_truth(u, dt, tau):
    """Exact first-order lag of held inputs, written out sample by sample."""
    a = np.exp(-dt / tau)
    x = np.empty_like(u)
    x[0] = u[0]
    for k in range(1, u.shape[0]):
        x[k] = a * x[k - 1] + (1 - a) * u[k - 1]
    return x


def cubic(x):
    """A cubic of two inputs with cross terms, two outputs."""
    a, b = x[:, 0], x[:, 1]
    return np.stack(
        [0.2 + a - 0.5 * b + 0.3 * a * b + 0.4 * a**3 - 0.2 * a * b**2, -0.1 + 2 * b**2 + 0.7 * a**2 * b], 1
    )


def test_lagged_cubic_is_recovered_with_its_lag():
    dt, tau = 0.01, 0.15
    u = steps(np.random.default_rng(4), 3000, 2, hold=41)
    y = cubic(lag_truth(u, dt, tau))
    model = LaggedPolynomialMap(degree=3, lags=[0.0, 0.05, 0.1, 0.15, 0.3]).fit(u, y, dt)
    assert model.lag_ == 0.15
    assert model.training_rmse_ < 1e-9
    u_new = steps(np.random.default_rng(5), 800, 2, hold=29)
    np.testing.assert_allclose(model.predict(u_new), cubic(lag_truth(u_new, dt, tau)), atol=1e-8)
    # the automatic grid (log spacing 10^(1/12)) brackets the true lag
    auto = LaggedPolynomialMap(degree=3).fit(u, y, dt)
    assert tau / 10 ** (1 / 12) <= auto.lag_ <= tau * 10 ** (1 / 12)


def test_lagged_map_skips_missing_outputs_and_checks_its_data():
    dt, tau = 0.01, 0.1
    u = steps(np.random.default_rng(6), 1500, 2)
    y = cubic(lag_truth(u, dt, tau))
    y[100:140] = np.nan
    model = LaggedPolynomialMap(lags=[0.05, 0.1, 0.2]).fit(u, y, dt)
    assert model.lag_ == 0.1 and np.isfinite(model.coef_).all()
    with pytest.raises(ValueError, match="dt must be"):
        LaggedPolynomialMap().fit(u, y, -1.0)
    with pytest.raises(InvalidParameterError, match="lags must be"):
        LaggedPolynomialMap(lags=[-1.0]).fit(u, y, dt)
    with pytest.raises(ValueError, match="3 valid"):
        LaggedPolynomialMap().fit(u[:3], y[:3], dt)


# ---------------------------------------------------------------------------- static holds
def affine(loads):
    """An affine map of two loads to a shape of 5 markers x 3 coordinates."""
    rng = np.random.default_rng(7)
    M, c = rng.normal(size=(2, 15)), rng.normal(size=15)
    return (np.atleast_2d(loads) @ M + c).reshape(-1, 5, 3)


# the tentacle's load grid: from some holds the nearest three are collinear
GRID = np.array([[0.05, 0.1], [0.1, 0.05], [0.1, 0.1], [0.1, 0.2], [0.2, 0.1], [0.15, 0.2], [0.2, 0.15], [0.2, 0.2]])


def test_interpolation_is_exact_on_an_affine_map_inside_and_outside_the_hull():
    for h in range(len(GRID)):  # leave each hold out: inside or outside the others' hull
        train = np.delete(np.arange(len(GRID)), h)
        model = LinearLoadInterpolator().fit(GRID[train], affine(GRID[train]))
        np.testing.assert_allclose(model.predict(GRID[h]), affine(GRID[h]), atol=1e-12)
    queries = np.array([[0.0, 0.0], [0.3, 0.1], [0.12, 0.13], [0.5, 0.5]])
    model = LinearLoadInterpolator().fit(GRID, affine(GRID))
    np.testing.assert_allclose(model.predict(queries), affine(queries), atol=1e-12)


def test_interpolation_in_one_load_is_piecewise_linear():
    loads = np.array([0.0, 1.0, 2.0, 4.0])
    values = np.array([0.0, 1.0, 3.0, 2.0])
    model = LinearLoadInterpolator().fit(loads, values)
    # between neighbours; beyond the ends, the line through the two nearest
    np.testing.assert_allclose(model.predict([0.5, 1.5, 3.0, 5.0, -1.0]), [0.5, 2.0, 2.5, 1.5, -1.0])


def test_quadratic_load_map_is_exact_on_a_quadratic_and_holds_with_nan_are_skipped():
    rng = np.random.default_rng(8)
    loads = rng.uniform(0, 1, size=(9, 2))

    def quad(L):
        a, b = L[:, 0], L[:, 1]
        return np.stack([1 + a - 2 * b + a * b, a**2 - b**2 + 0.5], axis=1)

    targets = quad(loads)
    targets[3] = np.nan
    model = PolynomialLoadMap().fit(loads, targets)
    q = np.array(list(itertools.product([0.2, 0.9], [0.1, 0.6])))
    np.testing.assert_allclose(model.predict(q), quad(q), atol=1e-10)
    interp = LinearLoadInterpolator().fit(loads, targets)
    assert interp.loads_.shape == (8, 2)
