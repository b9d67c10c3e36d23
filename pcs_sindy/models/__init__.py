"""Forward models: identified dynamics ``M(q) qdd + bias(q, qd) = A(q) u``, and their rollouts.

Takes in coefficients and structure from the identification stage (or true parameters) and
gives :class:`ForwardModel` objects: batched mass matrices and bias forces for controllers,
and ``simulate`` with the contract of :mod:`pcs_sindy.core.simulate_contract`.

* :mod:`.forward` - :class:`ForwardModel`, :class:`LumpedPCSModel`, :class:`CallableModel`;
* :mod:`.actuation` - input maps ``tau = A(q) u`` (tendons of force or servo drive, pressure chambers, linear,
  learned), one kind per module, each registered by its class (:func:`actuation_kinds`);
* :mod:`.integrators` - the one place for integration schemes of identified models
  (tableaus, ``solve_ivp`` over held inputs) with their compiled loops (``_jit_rollout``)
  and compiled dynamics (``_jit_dynamics``);
* :mod:`.pcs_numeric` - closed-form Jacobians and quadrature of planar PCS backbones;
* :mod:`.spatial_forward` - :class:`SpatialPCSModel`, spatial (3-D) PCS dynamics from lumped parameters.

Models never import the identification stage (it builds them) nor the simulator.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "forward": ["ForwardModel", "CallableModel", "LumpedPCSModel", "reduce_strains"],
        "actuation": [
            "Actuation",
            "IdentityActuation",
            "TendonActuation",
            "SpatialTendonActuation",
            "PressureActuation",
            "LinearActuation",
            "LearnedActuation",
            "actuation_from_layout",
            "actuation_kinds",
        ],
        "spatial_forward": ["SpatialPCSModel"],
        "integrators": ["solve_held", "DOPRI5", "ROS34PW2", "COMPILED_METHODS"],
    },
)
