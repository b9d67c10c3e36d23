"""The ground floor: conventions every stage shares, and nothing that belongs to one stage.

Takes in nothing of the package and gives every other stage:

* planar PCS kinematics and SE(2) pose algebra (:mod:`.kinematics`: :class:`PlanarPCS`);
* spatial (3-D) PCS kinematics and SE(3) pose algebra, six strains per segment (:mod:`.spatial`:
  :class:`SpatialPCS`);
* the trajectory containers that flow through every estimator (:mod:`.trajectory`:
  :class:`PoseTrajectory`, :class:`StrainTrajectory`);
* the seed's task-space error metrics (:mod:`.metrics`);
* unlabelled markers put in order along the body from the base (:mod:`.marker_order`), for fusion and
  for the static identification alike;
* per-recording arrays that scikit-learn's metrics read stacked (:mod:`.recording_list`: :class:`RecordingList`);
* the units of what is printed and stored (:mod:`.units`: :class:`Unit`, the strains' and generalised
  forces' units);
* the camera model between the base frame and image pixels (:mod:`.camera`: :class:`Camera`);
* the video formats this OpenCV build writes and the browser-playable one (:mod:`.video`);
* the optional dependencies (OpenCV, matplotlib, sympy) and the error naming the pip extra that
  installs a missing one (:mod:`.optional`);
* the simulate contract shared by the ground truth and identified models
  (:mod:`.simulate_contract`: :class:`SimulationError`, the method names);
* infrastructure with no domain knowledge: a compiled dense LU (:mod:`.linalg`), parameter
  constraints checked the scikit-learn way (:mod:`.validation`), the estimators'
  ``save``/``load`` methods (:mod:`.saving`) and atomic, recoverable file outputs that every
  writer of the package uses (:mod:`.atomic`: :class:`FileSet`).

Nothing here imports another stage, the file formats, the command line or plotting.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "kinematics": [
            "PlanarPCS",
            "SEED_Q_MAX",
            "STRAIN_NAMES",
            "forward_kinematics",
            "forward_kinematics_jacobian",
            "segment_pose",
            "segment_inverse_kinematics",
            "se2_compose",
            "se2_inverse",
            "se2_relative",
            "se2_matrix",
            "se2_from_matrix",
            "wrap_angle",
        ],
        "spatial": [
            "SpatialPCS",
            "SpatialStrainTrajectory",
            "SPATIAL_STRAIN_NAMES",
            "SPATIAL_Q_MAX",
            "tangent_coefficients",
            "strains_to_twist",
            "twist_to_strains",
            "se3_exp",
            "se3_log",
            "se3_compose",
            "se3_inverse",
            "se3_relative",
            "se3_matrix",
            "se3_from_matrix",
            "quaternion_to_rotation",
            "rotation_to_quaternion",
            "planar_to_spatial_strains",
            "spatial_to_planar_strains",
            "planar_to_spatial_pose",
        ],
        "trajectory": [
            "PoseTrajectory",
            "StrainTrajectory",
            "as_pose_trajectories",
            "as_strain_trajectories",
            "kinematics_of",
            "MarkerPlane",
            "clean_marker_tracks",
        ],
        "marker_order": ["order_markers", "find_base_marker"],
        "camera": ["Camera", "camera_extras", "read_camera_json"],
        "progress": ["ticking"],
        "video": ["VIDEO_CODECS", "browser_video_format", "codec_works", "open_video_writer", "video_codec"],
        "optional": ["EXTRAS", "MissingDependencyError", "require", "require_installed"],
        "atomic": ["FileSet", "recover"],
        "simulate_contract": ["SimulationError", "METHODS", "canonical_method"],
        "recording_list": ["RecordingList"],
        "units": ["Unit", "strain_unit", "generalised_force_unit"],
        "metrics": [
            "distributed_errors",
            "end_effector_errors",
            "pose_errors",
            "rollout_scorer",
            "rollout_r2_scorer",
            "noise_level",
            "motion_to_noise",
        ],
        "validation": [
            "validate_parameters",
            "InvalidParameterError",
            "Interval",
            "Options",
            "InstanceOf",
            "HasMethods",
            "Check",
            "Constraint",
        ],
    },
)
