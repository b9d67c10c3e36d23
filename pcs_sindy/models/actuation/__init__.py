"""Actuation terms of the identification: ``tau = A(q) u`` from actuator inputs ``u``.

Real robots are driven by tendons, chambers and motors, not by generalised
forces.  An :class:`Actuation` maps the inputs ``u`` (T, p) of a recording to
generalised forces on the modelled strains of a segmentation,

    A(q) u = known(q, u) + sum_j theta_j B_j(q, u),

with ``theta`` the gains the regression identifies (linear, solved with the
Lagrangian coefficients) and, for tendons, offsets that enter nonlinearly
(solved by variable projection around the linear fit).  Layouts are given by
arc length along the robot, so they hold for any fused segmentation.

One kind per module, each registered by its class attribute ``kind``:

* :class:`IdentityActuation` (:mod:`.identity`) — the inputs are the generalised forces (3m columns).
* :class:`TendonActuation` (:mod:`.tendons`) — tendons from the base to termination arc lengths
  at offsets from the backbone along the cross-section axis; ``A = -dl/dq``.
* :class:`SpatialTendonActuation` (:mod:`.spatial_tendons`) — tendons of a spatial (3-D) robot at
  offsets ``(d_x, d_z)`` in the cross-section, known or identified along known directions; ``A = -dl/dq``.
* :class:`PressureActuation` (:mod:`.pressure`) — pressure chambers spanning arc-length intervals
  on either side of the backbone; constant columns with unknown gains.
* :class:`LinearActuation` (:mod:`.linear`) — any constant ``A`` with a sparsity pattern over
  the strains of a known segmentation; one unknown gain per entry.
* :class:`LearnedActuation` (:mod:`.learned`) — a mechanism of unknown layout: ``A(q)`` affine
  in the strains (terms ``u`` and ``u`` times strains), every term a gain.

:mod:`.base` holds the contract and the registry, :mod:`.constant` the base of the
constant maps, :mod:`.layouts` :func:`actuation_from_layout` and :func:`actuation_kinds`.

Scale.  When every actuator gain is identified (chambers, linear layouts), the
equations are homogeneous: scaling every density, stiffness, damping and gain
by one factor leaves the motion unchanged, with or without known gravity
(gravity forces scale with the density).  The regression then needs one
absolute quantity — the robot's mass (``PhysicalPCSLibrary(mass=...)``) — and
raises otherwise.  Tendons carry their own scale: their tensions are in newtons
and ``A(q)`` is geometry.

A new kind subclasses :class:`Actuation`, declares ``kind = "<name>"`` and
implements ``_structure``, :meth:`Actuation.parts` and :meth:`Actuation.describe`
(and, to run on the compiled rollouts, :meth:`Actuation.compiled` giving one of
the :data:`COMPILED_FORMS`).  Defining the class registers it: layouts
(``{"type": "<name>", ...}``), model files (:func:`pcs_sindy.io.save`,
:func:`pcs_sindy.io.load`) and forward models take it with no other change (without
a compiled form, forward models evaluate its forces in Python).
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "base": ["Actuation", "COMPILED_FORMS", "registered_kinds"],
        "identity": ["IdentityActuation"],
        "tendons": ["TendonActuation"],
        "spatial_tendons": ["SpatialTendonActuation"],
        "pressure": ["PressureActuation"],
        "linear": ["LinearActuation"],
        "learned": ["LearnedActuation"],
        "layouts": ["actuation_from_layout", "actuation_kinds"],
    },
)
