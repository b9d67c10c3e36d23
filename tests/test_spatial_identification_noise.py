"""Equation weighting of the stiffness-threshold regression (``StiffnessThresholdOptimizer(weight_equations=True)``).

One noisy equation among quiet ones: the weighted fit (one step of feasible generalised least squares)
must keep the coefficient the equations share close to the truth, where ordinary least squares lets the
noisy equation pull it; noise-free rows give the same (exact) coefficients either way.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from pcs_sindy.core import PlanarPCS
from pcs_sindy.identification import StiffnessThresholdOptimizer

TRUE = np.array([2.0, 0.5, 1.5, 3.0])  # a shared coefficient, then one stiffness per strain


def _rows(noise, n_samples=2000, seed=0):
    """Rows of three strain equations ``y_i = a_i c + b_i k_i + noise_i``, stacked sample-major (samples, 3, 4)."""
    rng = np.random.default_rng(seed)
    x = np.zeros((n_samples, 3, 4))
    x[:, :, 0] = rng.normal(size=(n_samples, 3))
    x[:, np.arange(3), 1 + np.arange(3)] = rng.normal(size=(n_samples, 3))
    y = x @ TRUE + rng.normal(size=(n_samples, 3)) * np.asarray(noise)
    return x, y


def _library():
    # what the optimizer reads of a library: the segmentation, the columns and their bounds
    return SimpleNamespace(
        kinematics=PlanarPCS((0.1,)),
        n_coefficients_=4,
        stiffness_factor_=1.0,
        stiffness_index_=np.array([1, 2, 3]),
        lower_bounds_=np.zeros(4),
        euler_lagrange_names=lambda: ["c", "k_1", "k_2", "k_3"],
    )


def _fit(x, y, weighted):
    opt = StiffnessThresholdOptimizer(threshold=np.inf, weight_equations=weighted)
    return opt.fit(x, y, library=_library(), design=lambda lib, keep: x[:, keep]).coef_[0]


def test_weighting_keeps_the_shared_coefficient_from_the_noisy_equation():
    x, y = _rows([0.01, 0.01, 3.0])
    err_ols = np.abs(_fit(x, y, False) - TRUE)
    err_gls = np.abs(_fit(x, y, True) - TRUE)
    # the shared coefficient: OLS error ~ 3 / sqrt(3 * 2000) ~ 0.02, the weighted one ~ 0.01 / sqrt(2 * 2000)
    assert err_gls[0] < 0.1 * err_ols[0]
    assert err_gls[0] < 1e-3
    # the quiet equations' own stiffnesses follow
    assert np.all(err_gls[1:3] < 1e-3)


def test_noise_free_rows_give_the_exact_coefficients_either_way():
    x, y = _rows([0.0, 0.0, 0.0])
    np.testing.assert_allclose(_fit(x, y, False), TRUE, rtol=1e-9)
    np.testing.assert_allclose(_fit(x, y, True), TRUE, rtol=1e-9)


def test_weight_equations_is_validated():
    with pytest.raises(ValueError, match="weight_equations"):
        StiffnessThresholdOptimizer(weight_equations="yes").fit(*_rows([0.0, 0.0, 0.0]), library=_library())
