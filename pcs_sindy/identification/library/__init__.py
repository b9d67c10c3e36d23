"""Lagrangian libraries for the Euler–Lagrange regression (seed §III-C).

``PCSLagrangianLibrary``: the seed's symbolic basis of the PCS Lagrangian
(closed-form energies, exact Euler–Lagrange images, limit rule).
``PhysicalPCSLibrary``: the same dynamics parameterised by the physical
per-segment unknowns (densities, stiffnesses, damping), computed numerically
for any number of segments; bounded fits keep the model passive.
``SpatialPhysicalPCSLibrary``: the physical library of spatial (3-D) PCS robots (six strains per segment).
``StackedEulerLagrangeLibrary``: either of them inside ``pysindy.SINDy`` in
the stacked Euler–Lagrange form (states ``[q, qd, qdd]``, forces as ``x_dot``).
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "base": ["LagrangianLibrary"],
        "pcs_lagrangian": ["PCSLagrangianLibrary"],
        "physical": ["PhysicalPCSLibrary"],
        "spatial_physical": ["SpatialPhysicalPCSLibrary", "spatial_kinematics_of", "spatial_stiffness_bounds"],
        "stacked": ["StackedEulerLagrangeLibrary", "stack_forces", "unstack_forces"],
    },
)
