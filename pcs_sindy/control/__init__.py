"""Model-based control with identified models (docs/control.md).

Controllers take an identified model (anything with ``forward_model()``, or a
:class:`~pcs_sindy.models.forward.ForwardModel`) and run at the control rate on the
model's strains:

* :class:`SetpointRegulator` — P-satI-D with the model's static forces as feed-forward;
* :class:`ComputedTorqueController` — tracking of strain or tip trajectories;
* :class:`TipRegulator` — equilibrium inputs for a tip target, then feedback, within input bounds;
* :class:`ShapeTarget` — a set-point stated as a shape (marker poses, or strains of another
  segmentation such as the plant's), mapped to the model's strains by :func:`shape_strains`.

:func:`closed_loop` runs one against a plant (the ground-truth simulator), observing
its state or its noisy marker poses at a camera rate; :mod:`.plots` draws the results.

Takes in identified models (and targets), gives inputs: generalised forces or actuator
commands.  Imports only :mod:`pcs_sindy.core` and :mod:`pcs_sindy.models`; the plant and the
fusion that observes it are passed in, never imported.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "base": ["Controller"],
        "regulators": ["SetpointRegulator", "TipRegulator"],
        "tracking": ["ComputedTorqueController", "StrainReference", "TipReference", "tip_circle"],
        "closed_loop": ["closed_loop", "ClosedLoopResult"],
        "statics": ["equilibrium_inputs", "tip_inverse_kinematics"],
        "targets": ["ShapeTarget", "shape_strains"],
    },
)
