"""Kinematic fusion: marker poses -> a few constant-strain segments and their strains (seed §III-B).

Takes in :class:`~pcs_sindy.core.PoseTrajectory` objects (base + N markers) and gives the
fused segmentation (``KinematicFusion.segment_lengths_``) and
:class:`~pcs_sindy.core.StrainTrajectory` objects that carry it downstream.

* :mod:`.kinematic_fusion` - :class:`KinematicFusion`, the scikit-learn transformer;
* :mod:`.chain_geometry` - the marker chain in the base frame, rest length, segment strains;
* :mod:`.merging` - the seed's Algorithm 1 (strain distances, merging runs of segments);
* :mod:`.threshold_selection` - the seed's Fig. 8 trade-off and its selection rule;
* :mod:`.input_checks` - marker order, duplicates and angle units checked before fusion;
* :mod:`.shape_fit` - least-squares strains and continuously refined segment boundaries.

Fusion knows no images and no dynamics.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "kinematic_fusion": ["KinematicFusion"],
        "threshold_selection": ["SweepRow", "threshold_sweep", "select_threshold"],
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
        "input_checks": ["check_marker_chain"],
        "shape_fit": ["fit_strains_least_squares", "fit_frame_strains", "refine_boundaries"],
    },
)
