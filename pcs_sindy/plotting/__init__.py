"""Figures of the seed: strain-distance profile, error trade-off, rollouts, stills, animation; 3-D figures.

Plain functions on numpy arrays (the fitted estimators expose everything they
need: e.g. ``KinematicFusion.distance_profile_``, ``boundaries_``,
``marker_arc_lengths_``; ``StrainTrajectory.poses(s)`` gives backbones).
Every plotting function returns the :class:`matplotlib.figure.Figure` and
accepts an ``ax``/``axes`` argument to draw into existing axes; none calls
``plt.show()``.  :func:`animate_rollout` writes a video file with OpenCV and
uses its own Agg canvas, so it works without a display.

Conventions (docs/method.md, "Configuration"): positions in metres, angles in radians, strains
``[kappa_be 1/m, sigma_sh -, sigma_ax -]`` per segment (spatial robots: the six strains of
docs/spatial.md).  Drawings of the robot
follow the renderer: the base at the top and image-down = +y, so the y axis of
robot drawings in metres is inverted.

The figures live in modules named after what they show, and every public name
is importable from here:

* :mod:`pcs_sindy.plotting.fusion` - kinematic fusion
  (:func:`plot_strain_distance_profile`, seed Fig. 6; :func:`plot_error_vs_segments`, Fig. 8);
* :mod:`pcs_sindy.plotting.rollout` - rollouts against time
  (:func:`plot_rollout`, Fig. 9a / 11a; :func:`plot_end_effector`, Fig. 9b; :func:`plot_tip_positions`,
  a measured tip against predictions), each with residual panels;
* :mod:`pcs_sindy.plotting.stills` - images with overlays (:func:`plot_stills`, Fig. 3 / 10; the
  extraction's :func:`plot_contact_sheet`);
* :mod:`pcs_sindy.plotting.animation` - a rollout video (:func:`animate_rollout`);
* :mod:`pcs_sindy.plotting.spatial` - spatial (3-D) robots: measured positions against predicted ones
  in 3-D, per coordinate and as an error over time (:func:`plot_positions_3d`), backbone shapes with
  markers (:func:`plot_shapes_3d`).

Takes in arrays and fitted estimators' attributes, gives :class:`matplotlib.figure.Figure` objects.
Imports only :mod:`pcs_sindy.core`; nothing but the command line imports it.
"""

import lazy_loader as _lazy

from ..core.optional import require_installed

require_installed("matplotlib", "pcs_sindy.plotting (figures)")  # every module here draws with matplotlib

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "animation": ["animate_rollout"],
        "rollout": ["plot_end_effector", "plot_rollout", "plot_tip_positions"],
        "fusion": ["plot_error_vs_segments", "plot_strain_distance_profile"],
        "stills": ["plot_contact_sheet", "plot_stills"],
        "spatial": ["plot_positions_3d", "plot_shapes_3d"],
    },
)
