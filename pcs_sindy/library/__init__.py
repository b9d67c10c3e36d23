"""Lagrangian libraries for the Euler–Lagrange regression (seed §III-C).

``PCSLagrangianLibrary``: the seed's symbolic basis of the PCS Lagrangian
(closed-form energies, exact Euler–Lagrange images, limit rule).
``PhysicalPCSLibrary``: the same dynamics parameterised by the physical
per-segment unknowns (densities, stiffnesses, damping), computed numerically
for any number of segments; bounded fits keep the model passive.
``StackedEulerLagrangeLibrary``: either of them inside ``pysindy.SINDy`` in
the stacked Euler–Lagrange form (states ``[q, qd, qdd]``, forces as ``x_dot``).
"""

from .pcs_lagrangian import PCSLagrangianLibrary
from .physical import PhysicalPCSLibrary
from .stacked import StackedEulerLagrangeLibrary, stack_forces, unstack_forces

__all__ = [
    "PCSLagrangianLibrary",
    "PhysicalPCSLibrary",
    "StackedEulerLagrangeLibrary",
    "stack_forces",
    "unstack_forces",
]
