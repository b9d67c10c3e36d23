"""Marker poses from videos: :class:`MarkerPoseExtractor` (docs/method.md, shape estimation).

Per recording (:mod:`pcs_sindy.vision.extraction` does the work): the reference
frame is checked first and chooses, among candidate thresholders (global
Otsu, a local threshold relative to the lit background, the distance to the
dominant marker colour; :mod:`pcs_sindy.vision.thresholding`), the one whose
components form a chain of similar markers (:mod:`pcs_sindy.vision.chain`);
clutter, printed text and floors that are not part of the chain do not
count.  Every frame is then segmented, its components refined to sub-pixel
centres and axes from coverage-weighted moments (:mod:`pcs_sindy.vision.markers`),
the markers tracked from the previous frame or chained from the base, the
90°/180° ambiguity of each axis resolved along the chain and in time, and
pixels mapped through the camera's lens model to metres in the robot's base
frame (:class:`pcs_sindy.core.camera.Camera`).

Knows nothing of dynamics.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import BaseEstimator, TransformerMixin

from ..core.camera import Camera
from ..core.saving import PersistenceMixin
from ..core.trajectory import PoseTrajectory
from .extraction import MarkerStream, extract_recording
from .frame_source import check_recordings, describe, read_frames
from .markers import detect_markers

__all__ = ["MarkerPoseExtractor", "MarkerStream", "detect_markers", "read_frames"]

_THRESHOLDS = ("auto", "otsu", "local", "colour")


class MarkerPoseExtractor(PersistenceMixin, TransformerMixin, BaseEstimator, auto_wrap_output_keys=None):
    """Videos of a marker-carrying planar robot -> pose trajectories (base + N markers).

    Parameters
    ----------
    n_markers : int, optional
        Number N of tracked cross-sections (the base marker not counted).
        Default: inferred from the reference frame of each recording.
    threshold : "auto", "otsu", "local", "colour", float or (lower, upper)
        Binarisation.  ``"auto"`` (default): of global Otsu, ``"local"``
        (markers darker than a fraction of the local background, which
        divides out uneven light and vignetting and turns floors and trays
        into background) and, for colour footage, ``"colour"`` (the
        projection on the chroma of the dominant marker colour), the one
        whose components form the chain of markers in the reference frame;
        the others are tried on frames it cannot complete.  The choice and
        why are in :attr:`diagnostics_`.  A float is a fixed grey level, a
        pair a colour range for ``cv2.inRange`` (bounds as grey levels or BGR triples).
    polarity : {"dark", "bright"}
        Markers darker (default) or brighter than the background.
    blur : int
        Odd Gaussian kernel applied before thresholding, 0 for none.
    roi : (x, y, width, height), optional
        Region of interest in pixels; components outside are ignored.
    marker_area : float, optional
        Typical marker area in pixels; default: the median area of the
        markers chained in the reference frame.
    area_tolerance : (float, float)
        Components whose area lies outside ``marker_area * [low, high]`` are
        not markers (clutter, noise, or two markers merged).  Within a frame's
        chain, a marker whose area differs by more than about 25 % from its
        neighbours' is treated as partly hidden or merged (missing).
    aspect_tolerance : float
        Components whose long/short ratio differs from the typical marker's by
        more than this factor are not markers.
    camera : "auto", None, Camera, dict or path
        Calibration.  ``"auto"``: read ``<video>.camera.json`` (written by
        :func:`pcs_sindy.simulation.rendering.render_video` or ``pcs-sindy calibrate``)
        when it exists, otherwise calibrate from the reference frame.
        ``None``: always calibrate from the reference frame.  A
        :class:`~pcs_sindy.core.camera.Camera`, its dict or the path of its JSON:
        use it for every recording.  A camera with a lens model (distortion,
        plane homography) maps marker centres and axes, not whole frames; one
        that leaves its base frame open (``pcs-sindy calibrate``) gets it
        from the footage (the base marker and the rest direction).
    pixels_per_metre : float, optional
        Scale when no camera is used.
    robot_length : float, optional
        Total rest length (m); with no camera and no ``pixels_per_metre`` the
        scale is the length of the marker chain in the reference frame (the
        robot straight and unstretched there) divided by this.  When given,
        it travels with the poses (``metadata["rest_length"]``) to
        :class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion`.
    base_position : (u, v), optional
        Pixel position of the base marker; default: the camera's origin, or
        the marker that stays put over the recording.
    rest_direction : float, optional
        Image angle (radians, ``atan2(dv, du)``) of the robot's rest direction
        (+y of the base frame) when no camera is used; default: from the base
        marker to the next one in the reference frame.
    reference_frame : int
        Frame used for the typical marker, N, and the calibration.
    fps, dt : float, optional
        Frame rate or period overriding the video's (required for arrays and
        image folders without a camera JSON holding ``fps``).
    refine : bool
        Sub-pixel centres and axes from intensity-weighted moments (default);
        ``False`` uses ``minAreaRect`` directly.
    on_missing : {"raise", "interpolate", "predict"}
        A frame whose markers cannot be extracted (missing or merged markers
        that cannot be filled, a chain that cannot be ordered) either raises
        (naming recording and frame) or is interpolated in time from its
        valid neighbours (listed in :attr:`diagnostics_`).  ``"predict"`` is
        for :meth:`stream` only (a live camera has no later frames to
        interpolate from): a few lost markers are predicted from the last
        two frames.
    fill_missing : bool
        An isolated missing (or partly hidden) marker between two detected
        neighbours gets the pose halfway along the constant-strain arc
        between them, and the frame counts as extracted (listed in
        ``diagnostics_["markers_filled"]``); False makes such a frame a
        problem for ``on_missing``.
    min_area : float
        Components smaller than this many pixels are noise.
    n_jobs : int, optional
        Recordings processed in parallel (joblib).
    progress : bool
        tqdm progress bar over frames.

    Attributes
    ----------
    diagnostics_ : list of dict
        After :meth:`transform`, one per recording: ``recording``,
        ``n_frames``, ``n_markers``, ``binarisation`` (``chosen``,
        ``reason`` and what each candidate found in the reference frame),
        ``markers_found`` (marker-shaped components per frame),
        ``frames_repaired`` and ``repair_reasons``, ``markers_filled``
        (frame -> filled marker indices), ``frames_complete`` (every marker
        detected), ``frames_tracked``, ``fallback_frames`` (frames done by
        another candidate thresholder), ``ignored_components`` (marker-shaped
        components off the chain per frame: clutter), ``max_theta_step``,
        ``base_marker``, ``calibration`` and the camera used.

    Notes
    -----
    Accuracy on rendered frames (``tests/test_vision.py``, markers 24×6 px):
    about 0.05 px rms in position and 0.2° rms in angle; it degrades for
    markers thinner than about 4 px.  On degraded footage (uneven light,
    vignetting, noise, motion blur, JPEG, clutter, a floor, a hidden marker)
    see ``benchmarks/degraded_footage.py``.  Frames are not silently
    misordered: the chain from the base refuses steps that do not fit or are
    ambiguous (a missing, merged or crossing marker), and a finished chain is
    rejected when it crosses itself, when a marker faces against it, or when
    the marker angles zigzag along it (two interleaved stretches of a robot
    curled over itself).  Rejected frames raise or are interpolated per
    ``on_missing``; ``tests/test_vision.py`` checks this on robots curled
    beyond a full turn.

    Examples
    --------
    >>> from pcs_sindy.simulation import render_video
    >>> paths = render_video(poses, "clip.avi", fps=1000.0)       # doctest: +SKIP
    >>> trajs = MarkerPoseExtractor().fit_transform([str(paths.video)])  # doctest: +SKIP
    >>> trajs[0].poses.shape                                       # doctest: +SKIP
    (500, 21, 3)
    """

    def __init__(
        self,
        n_markers: int | None = None,
        *,
        threshold: str | float | tuple = "auto",
        polarity: str = "dark",
        blur: int = 0,
        roi: tuple[int, int, int, int] | None = None,
        marker_area: float | None = None,
        area_tolerance: tuple[float, float] = (0.5, 1.6),
        aspect_tolerance: float = 1.8,
        camera: Any = "auto",
        pixels_per_metre: float | None = None,
        robot_length: float | None = None,
        base_position: tuple[float, float] | None = None,
        rest_direction: float | None = None,
        reference_frame: int = 0,
        fps: float | None = None,
        dt: float | None = None,
        refine: bool = True,
        on_missing: str = "raise",
        fill_missing: bool = True,
        min_area: float = 4.0,
        n_jobs: int | None = None,
        progress: bool = True,
    ) -> None:
        self.n_markers = n_markers
        self.threshold = threshold
        self.polarity = polarity
        self.blur = blur
        self.roi = roi
        self.marker_area = marker_area
        self.area_tolerance = area_tolerance
        self.aspect_tolerance = aspect_tolerance
        self.camera = camera
        self.pixels_per_metre = pixels_per_metre
        self.robot_length = robot_length
        self.base_position = base_position
        self.rest_direction = rest_direction
        self.reference_frame = reference_frame
        self.fps = fps
        self.dt = dt
        self.refine = refine
        self.on_missing = on_missing
        self.fill_missing = fill_missing
        self.min_area = min_area
        self.n_jobs = n_jobs
        self.progress = progress

    # -- validation ---------------------------------------------------------
    def _validate(self) -> dict[str, Any]:
        def positive(name: str, value: Any, allow_none: bool = True) -> None:
            if value is None and allow_none:
                return
            if isinstance(value, bool) or not np.isscalar(value) or not np.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a finite number > 0; got {value!r}")

        if self.n_markers is not None and (
            isinstance(self.n_markers, bool) or not isinstance(self.n_markers, (int, np.integer)) or self.n_markers < 1
        ):
            raise ValueError(f"n_markers must be a positive integer or None; got {self.n_markers!r}")
        thr = self.threshold
        if isinstance(thr, str):
            if thr not in _THRESHOLDS:
                raise ValueError(
                    f"threshold must be one of {_THRESHOLDS}, a grey level or a (lower, upper) colour range; "
                    f"got {thr!r}"
                )
        elif isinstance(thr, tuple):
            if len(thr) != 2:
                raise ValueError(f"threshold as a colour range must be (lower, upper); got {thr!r}")
            lo, hi = (np.atleast_1d(np.asarray(b, dtype=float)) for b in thr)
            if lo.shape != hi.shape or lo.size not in (1, 3) or np.any(lo > hi) or np.any(lo < 0) or np.any(hi > 255):
                raise ValueError(
                    "threshold colour range must be two grey levels or BGR triples with lower <= upper in [0, 255]; "
                    f"got {thr!r}"
                )
        elif not np.isscalar(thr) or isinstance(thr, bool) or not 0 <= float(thr) <= 255:
            raise ValueError(
                f"threshold must be one of {_THRESHOLDS}, a grey level in [0, 255] or a (lower, upper) colour "
                f"range; got {thr!r}"
            )
        if self.polarity not in ("dark", "bright"):
            raise ValueError(f"polarity must be 'dark' or 'bright'; got {self.polarity!r}")
        if not isinstance(self.blur, (int, np.integer)) or self.blur < 0 or (self.blur and self.blur % 2 == 0):
            raise ValueError(f"blur must be 0 or an odd positive integer; got {self.blur!r}")
        roi = self.roi
        if roi is not None:
            r = np.asarray(roi)
            if r.shape != (4,) or np.any(r != np.round(r)) or np.any(r[:2] < 0) or np.any(r[2:] < 1):
                raise ValueError(f"roi must be (x, y, width, height) integers with width, height >= 1; got {roi!r}")
            roi = tuple(int(v) for v in r)
        positive("marker_area", self.marker_area)
        tol = np.asarray(self.area_tolerance, dtype=float)
        if tol.shape != (2,) or not (0 < tol[0] < 1 < tol[1]) or not np.all(np.isfinite(tol)):
            raise ValueError(f"area_tolerance must be (low < 1, high > 1), both > 0; got {self.area_tolerance!r}")
        positive("aspect_tolerance", self.aspect_tolerance, allow_none=False)
        if self.aspect_tolerance < 1:
            raise ValueError(f"aspect_tolerance must be >= 1; got {self.aspect_tolerance!r}")
        cam = self.camera
        if isinstance(cam, str) and cam == "auto":
            pass
        elif cam is None or isinstance(cam, Camera):
            pass
        elif isinstance(cam, dict):
            cam = Camera.from_dict(cam)
        elif isinstance(cam, (str, os.PathLike)):
            cam = Camera.from_json(cam)
        else:
            raise ValueError(f"camera must be 'auto', None, a Camera, a dict or a JSON path; got {type(cam).__name__}")
        positive("pixels_per_metre", self.pixels_per_metre)
        positive("robot_length", self.robot_length)
        if self.base_position is not None:
            bp = np.asarray(self.base_position, dtype=float)
            if bp.shape != (2,) or not np.all(np.isfinite(bp)):
                raise ValueError(f"base_position must be (u, v) pixels; got {self.base_position!r}")
        if self.rest_direction is not None and (
            not np.isscalar(self.rest_direction) or not np.isfinite(self.rest_direction)
        ):
            raise ValueError(f"rest_direction must be a finite angle in radians; got {self.rest_direction!r}")
        if (
            isinstance(self.reference_frame, bool)
            or not isinstance(self.reference_frame, (int, np.integer))
            or self.reference_frame < 0
        ):
            raise ValueError(f"reference_frame must be a non-negative integer; got {self.reference_frame!r}")
        positive("fps", self.fps)
        positive("dt", self.dt)
        if self.fps is not None and self.dt is not None:
            raise ValueError(f"give fps or dt, not both; got fps={self.fps!r}, dt={self.dt!r}")
        if self.on_missing not in ("raise", "interpolate", "predict"):
            raise ValueError(f"on_missing must be 'raise', 'interpolate' or 'predict'; got {self.on_missing!r}")
        if not isinstance(self.fill_missing, (bool, np.bool_)):
            raise ValueError(f"fill_missing must be True or False; got {self.fill_missing!r}")
        positive("min_area", self.min_area, allow_none=False)
        params = self.get_params()
        params.update(camera=cam, roi=roi)
        return params

    # -- sklearn API -----------------------------------------------------------
    def fit(self, X: Any = None, y: Any = None) -> MarkerPoseExtractor:
        """Validate the parameters and, if given, the form of ``X`` (extraction is stateless); returns self."""
        self._validate()
        if X is not None:
            check_recordings(X)
        return self

    def transform(self, X: Any) -> list[PoseTrajectory]:
        """Extract the pose trajectory of every recording.

        Parameters
        ----------
        X : list of recordings
            Each a video path, a folder of image files, or a uint8 array of
            frames (T, H, W) / (T, H, W, 3).  A single path or array is one
            recording.

        Returns
        -------
        list of PoseTrajectory
            Poses (T, N + 1, 3) in metres/radians in the robot's base frame;
            ``metadata`` holds the source, the camera and the diagnostics.
        """
        params = self._validate()
        if params["on_missing"] == "predict":
            raise ValueError(
                "on_missing='predict' is for stream(); recordings take 'raise' or 'interpolate' (which uses the "
                "frames on both sides)"
            )
        X = check_recordings(X)
        names = [describe(rec, k) for k, rec in enumerate(X)]
        jobs = (delayed(extract_recording)(rec, name, params) for rec, name in zip(X, names))
        if self.n_jobs in (None, 1) or len(X) == 1:
            results = [extract_recording(rec, name, params) for rec, name in zip(X, names)]
        else:
            results = Parallel(n_jobs=self.n_jobs)(jobs)
        self.diagnostics_ = [diag for _, diag in results]
        return [traj for traj, _ in results]

    def stream(self, reference: Any, *, max_predicted: int = 2, max_run: int = 3) -> MarkerStream:
        """A streaming extractor for a live camera, set up on its first frame.

        ``stream(first_frame).update(frame)`` returns the poses (N + 1, 3) of
        one frame at a time (about a millisecond at 640x480), tracking the
        markers from frame to frame; with :meth:`KinematicFusion.transform_frame
        <pcs_sindy.fusion.kinematic_fusion.KinematicFusion.transform_frame>` it gives the
        strains of a robot under control at camera rate.  The base must be
        known from the first frame: give ``base_position`` or a camera with an
        origin; the scale comes from the camera, ``pixels_per_metre`` or
        ``robot_length`` (the first frame straight).  ``n_jobs``, ``fps`` and
        ``dt`` do not apply.

        ``on_missing`` decides what ``update`` does with a frame it cannot
        extract.  ``"raise"`` (the default) and ``"interpolate"`` (which
        would need the frames after) raise ``ValueError`` naming the frame.
        ``"predict"`` first matches the frame's marker-shaped components to
        where the last two frames put the markers (constant velocity in the
        image); when at most ``max_predicted`` markers have no component
        there, they are placed at that constant-velocity pose, the others
        are measured, and the frame returns poses with
        ``stream.last_predicted`` naming the predicted markers
        (``stream.diagnostics`` counts ``frames_predicted`` and
        ``markers_predicted``).  It still raises when more markers are lost,
        when none is (the frame failed the chain's checks: a chain crossing
        itself, say), when either of the two frames before raised, or after ``max_run``
        frames in a row with predicted markers (a prediction drifts: at 1 kHz
        a few frames of constant velocity stay within a fraction of a
        millimetre, see ``tests/test_streaming.py``).

        Parameters
        ----------
        reference : uint8 image, (H, W) or (H, W, 3)
        max_predicted : int
            With ``on_missing="predict"``, the most markers of a frame that
            may be predicted.
        max_run : int
            With ``on_missing="predict"``, the most consecutive frames with
            predicted markers.

        Returns
        -------
        MarkerStream
            ``update(frame)``, plus ``camera``, ``n_markers``, ``last``,
            ``last_predicted``, ``diagnostics``.
        """
        params = self._validate()
        for name, value in (("max_predicted", max_predicted), ("max_run", max_run)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be a positive integer; got {value!r}")
        return MarkerStream(reference, params, int(max_predicted), int(max_run))

    def __sklearn_tags__(self):  # stateless: transform needs no fit
        tags = super().__sklearn_tags__()
        tags.requires_fit = False
        tags.input_tags.two_d_array = False  # X is a list of videos
        return tags
