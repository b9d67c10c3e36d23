"""Dynamic identification: strain trajectories and inputs -> a PCS model (seed §III-C).

Takes in :class:`~pcs_sindy.core.StrainTrajectory` objects (carrying their segmentation) and
generalised forces or actuator inputs, and gives a fitted :class:`EulerLagrangeRegressor`
whose ``forward_model()`` is a :class:`~pcs_sindy.models.ForwardModel`.

* :mod:`.regressor` - :class:`EulerLagrangeRegressor`: library x formulation x optimizer x actuation;
* :mod:`.library` - Lagrangian libraries (physical, the seed's monomial basis, pysindy's stacked form);
* :mod:`.weak_sindy` - :class:`WeakEulerLagrangeSINDy`: the weak form as a ``pysindy.SINDy`` (forces as ``u``);
* :mod:`.formulations` - the strong (samples) and weak (window integrals) regression rows;
* :mod:`.recordings` - recordings checked, differentiated and cut for a formulation;
* :mod:`.optimizers` - least squares with the seed's stiffness-threshold sparsification;
* :mod:`.least_squares` - column-scaled least squares and the material stiffness bounds;
* :mod:`.variable_projection` - nonlinear actuation parameters (tendon offsets) around the linear fit;
* :mod:`.identifiability` - standard errors: what the recordings determined;
* :mod:`.baselines` - black boxes a PCS model must beat (lagged polynomial, ARX, load interpolation).
* :mod:`.static_shape` - :class:`StaticShapeRegressor`: static holds of a tendon rod in 3-D, markers to equilibria.

Identification never imports the simulator: the simulator is what checks it.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submodules=["library"],
    submod_attrs={
        "regressor": ["EulerLagrangeRegressor", "PoorFitWarning"],
        "weak_sindy": ["WeakEulerLagrangeSINDy"],
        "optimizers": ["StiffnessThresholdOptimizer"],
        "library": [
            "LagrangianLibrary",
            "PCSLagrangianLibrary",
            "PhysicalPCSLibrary",
            "SpatialPhysicalPCSLibrary",
            "StackedEulerLagrangeLibrary",
            "stack_forces",
            "unstack_forces",
        ],
        "least_squares": ["scaled_lstsq", "stiffness_bounds"],
        "variable_projection": ["fit_offsets"],
        "formulations": ["FORMULATIONS", "PreparedRecording"],
        "identifiability": ["strain_excitation"],
        "baselines": ["LaggedPolynomialMap", "ARX", "LinearLoadInterpolator", "PolynomialLoadMap", "first_order_lag"],
        "static_shape": ["StaticShapeRegressor", "cc_points"],
    },
)
