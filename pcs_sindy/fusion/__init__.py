"""Kinematic fusion: marker poses -> a few constant-strain segments and their strains (seed §III-B).

Takes in :class:`~pcs_sindy.core.PoseTrajectory` objects (base + N markers) and gives the
fused segmentation (``KinematicFusion.segment_lengths_``) and
:class:`~pcs_sindy.core.StrainTrajectory` objects that carry it downstream.

* :mod:`.kinematic_fusion` - :class:`KinematicFusion`, the scikit-learn transformer, and the
  threshold sweep (seed Fig. 8);
* :mod:`.chain_geometry` - the marker chain in the base frame, rest length, segment strains;
* :mod:`.merging` - the seed's Algorithm 1 (strain distances, merging runs of segments);
* :mod:`.threshold_selection` - the rules that choose the merge threshold (``threshold="auto"``);
* :mod:`.input_checks` - marker order, duplicates and angle units checked before fusion;
* :mod:`.shape_fit` - least-squares strains and continuously refined segment boundaries;
* :mod:`.position_fit`, :mod:`.position_fusion` - positions-only markers (motion capture): base pose,
  marker arc lengths, bending strains and Algorithm 1 on them;
* :mod:`.spatial_fusion` - the same in 3-D (``KinematicFusion(space="3d")``): a base in SE(3), the two
  bendings (and torsion, from orientations) of a spatial PCS.

Fusion knows no images and no dynamics.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "kinematic_fusion": ["KinematicFusion", "threshold_sweep"],
        "threshold_selection": [
            "SweepRow",
            "SELECTION_RULES",
            "AUTO_THRESHOLDS",
            "select_threshold",
            "segmentation_sweep",
            "choose_threshold",
            "choice_from_sweep",
        ],
        "merging": ["MERGE_RULES", "fuse_segments", "merge_runs", "strain_distances", "data_q_max", "check_q_max"],
        "chain_geometry": [
            "chain_poses",
            "frame_chain",
            "segment_strains",
            "deformed_lengths",
            "estimate_total_length",
            "kinematic_rest_length",
            "jackknife_std",
            "rest_length_factor",
        ],
        "input_checks": ["check_marker_chain", "check_marker_positions", "check_arc_lengths"],
        "shape_fit": ["fit_strains_least_squares", "fit_frame_strains", "refine_boundaries"],
        "position_fit": ["fit_marker_geometry", "fit_position_strains", "bending_strains"],
        "position_fusion": [
            "fuse_position_segments",
            "marker_geometry",
            "shared_marker_plane",
            "base_axis_planes",
            "on_plane",
            "recorded_base_position",
            "choose_position_threshold",
            "position_strain_trajectories",
            "positions_in_user_frame",
            "tendon_sides",
        ],
        "spatial_fusion": [
            "SPATIAL_BENDING",
            "SPATIAL_BENDING_TWIST",
            "DIRECTION_PRIOR",
            "needs_3d",
            "base_rotation",
            "spatial_marker_model",
            "fit_spatial_strains",
            "fit_spatial_geometry",
            "spatial_marker_geometry",
            "fuse_spatial_segments",
            "choose_spatial_threshold",
            "spatial_strain_trajectories",
            "spatial_marker_positions",
        ],
    },
)
