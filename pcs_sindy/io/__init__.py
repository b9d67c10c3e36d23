"""Files: fitted estimators as safe model files, and the command line's data files.

Takes in fitted estimators, trajectories and arrays, and gives files (and back):

* :mod:`.model_files` - :func:`save` / :func:`load`: JSON + ``.npz``, never pickle; classes
  come from a fixed :data:`REGISTRY`;
* :mod:`.data_files` - recordings, poses, forces, strains and models of ``pcs-sindy``.

Every file is written atomically, and files that belong together as one set
(:mod:`pcs_sindy.core.atomic`): a failure or crash leaves the old files or the new ones.

Sits on top of the stages: nothing below imports it (the estimators' ``save``/``load`` methods
reach :func:`save` and :func:`load` through :mod:`pcs_sindy.core.saving`).
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "model_files": [
            "save",
            "load",
            "REGISTRY",
            "FORMAT_NAME",
            "FORMAT_VERSION",
            "INLINE_ARRAY_SIZE",
            "PARAMETER_RANGES",
            "MAX_SEGMENTS",
            "MAX_MONOMIAL_SEGMENTS",
        ],
        "marker_csv": ["MarkerData", "read_marker_csv", "InputLog", "read_input_log", "align_inputs"],
        "data_files": [
            "DataFileError",
            "FILE_FORMATS",
            "output_dir",
            "read_arrays",
            "read_poses",
            "write_poses",
            "read_strains",
            "write_strains",
            "read_tau",
            "write_tau",
            "write_recording",
            "read_training_files",
            "model_file_arrays",
            "pair_files",
            "read_model_file",
            "write_model_file",
        ],
    },
)
