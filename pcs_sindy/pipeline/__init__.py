"""The stages composed: videos (or poses) and inputs -> a PCS model, in one scikit-learn Pipeline.

Takes in videos or pose trajectories and the recorded forces or actuator inputs, and gives a
fitted :class:`PCSPipeline` (extractor -> fusion -> regressor) or, from poses and the
identified dynamics, the robot's rest length when nobody measured it.

* :mod:`.pcs_pipeline` - :func:`make_pcs_pipeline`, :class:`PCSPipeline`, :func:`recording_groups`;
* :mod:`.rest_length` - :func:`estimate_rest_length`: kinematics corrected by identified dynamics;
* :mod:`.segmentation` - :func:`select_segmentation`: the segment count of position data by held-out prediction.

The only stage that imports vision, fusion and identification together.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "pcs_pipeline": ["PCSPipeline", "make_pcs_pipeline", "recording_groups"],
        "rest_length": ["RestLengthEstimate", "estimate_rest_length"],
        "segmentation": ["SegmentationChoice", "select_segmentation", "SEGMENTATION_THRESHOLDS"],
    },
)
