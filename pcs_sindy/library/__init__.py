"""Lagrangian libraries for the Euler–Lagrange regression (seed §III-C).

``PCSLagrangianLibrary``: the seed's symbolic basis of the PCS Lagrangian
(closed-form energies, exact Euler–Lagrange images, limit rule).
``PhysicalPCSLibrary``: the same dynamics parameterised by the physical
per-segment unknowns (densities, stiffnesses, damping), computed numerically
for any number of segments; bounded fits keep the model passive.
"""

from .pcs_lagrangian import PCSLagrangianLibrary
from .physical import PhysicalPCSLibrary

__all__ = ["PCSLagrangianLibrary", "PhysicalPCSLibrary"]
