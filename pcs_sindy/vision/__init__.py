"""Vision: frames of a video -> marker poses (seed §III-A, docs/method.md "Shape estimation").

Takes in videos, image folders or frame arrays (and optionally a :class:`~pcs_sindy.core.Camera`)
and gives :class:`~pcs_sindy.core.PoseTrajectory` objects: the base and the N markers'
poses ``[x, y, theta]`` in metres in the robot's base frame, ordered base -> tip.

* :mod:`.frame_source` - frames of a video file, a folder of images or an array;
* :mod:`.thresholding` - thresholders that tell marker pixels from the rest;
* :mod:`.markers` - candidate markers of one frame, refined to sub-pixel;
* :mod:`.chain` - which candidates form the marker chain, and in which order;
* :mod:`.tracker` - one frame after another, with rescues of hidden markers;
* :mod:`.extraction` - one recording -> poses, and :class:`MarkerStream` at camera rate;
* :mod:`.extractor` - :class:`MarkerPoseExtractor`, the scikit-learn transformer;
* :mod:`.calibration` - lens distortion and the robot's plane from checkerboard views.

Vision knows no dynamics and no segmentation of the robot.
"""

import lazy_loader as _lazy

from ..core.optional import require_installed

require_installed("cv2", "pcs_sindy.vision (reading videos and images)")  # every module here uses OpenCV

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "extractor": ["MarkerPoseExtractor"],
        "extraction": ["MarkerStream", "extract_recording"],
        "frame_source": ["FrameSource", "read_frames", "check_recordings"],
        "thresholding": [
            "Thresholder",
            "OtsuThresholder",
            "LocalThresholder",
            "ColourThresholder",
            "RangeThresholder",
            "candidate_thresholders",
        ],
        "markers": ["detect_markers"],
        "tracker": ["FrameTracker"],
        "calibration": ["calibrate_camera", "read_views", "find_board"],
    },
)
