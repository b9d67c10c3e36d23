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
import warnings
from numbers import Integral, Real
from typing import Any

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import BaseEstimator, TransformerMixin

from ..core.camera import Camera, camera_extras, read_camera_json
from ..core.saving import PersistenceMixin
from ..core.trajectory import PoseTrajectory
from ..core.validation import Check, InstanceOf, Interval, InvalidParameterError, Options, validate_parameters
from .extraction import MarkerStream, extract_recording
from .frame_source import check_recordings, describe, read_frames
from .markers import detect_markers

__all__ = ["MarkerPoseExtractor", "MarkerStream", "detect_markers", "read_frames"]

_THRESHOLDS = ("auto", "otsu", "local", "colour")
_POSITIVE = Interval(Real, 0, None, closed="neither")


def _colour_range(value: Any) -> bool:
    if not (isinstance(value, tuple) and len(value) == 2):
        return False
    lo, hi = (np.atleast_1d(np.asarray(b, dtype=float)) for b in value)
    return (
        lo.shape == hi.shape
        and lo.size in (1, 3)
        and bool(np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)))
        and bool(np.all(lo <= hi) and np.all(lo >= 0) and np.all(hi <= 255))
    )


def _blur_kernel(value: Any) -> bool:
    return (
        isinstance(value, (int, np.integer))
        and not isinstance(value, bool)
        and (value == 0 or (value > 0 and value % 2 == 1))
    )


def _roi(value: Any) -> bool:
    r = np.asarray(value)  # not dtype=float: strings of digits are no pixel counts
    return (
        r.shape == (4,)
        and bool(np.all(np.isfinite(r)) and np.all(r == np.round(r)))
        and bool(np.all(r[:2] >= 0) and np.all(r[2:] >= 1))
    )


def _area_tolerance(value: Any) -> bool:
    tol = np.asarray(value, dtype=float)
    return tol.shape == (2,) and bool(np.all(np.isfinite(tol))) and bool(0 < tol[0] < 1 < tol[1])


def _pixel(value: Any) -> bool:
    bp = np.asarray(value, dtype=float)
    return bp.shape == (2,) and bool(np.all(np.isfinite(bp)))


#: Recordings of one set-up calibrated each from its own reference frame whose scales differ by
#: more than this (relative) get a warning naming every scale.
SCALE_SPREAD_WARNING = 0.02


def share_scale(trajs: list[PoseTrajectory], diags: list[dict[str, Any]]) -> list[PoseTrajectory]:
    """One scale for a set of recordings that were each scaled from their own reference frame.

    With ``robot_length`` and no camera, every recording's scale is its reference frame's chain
    length divided by the robot's length: right only when the robot is straight *and unstretched*
    there.  The videos of one set-up share one camera, so all take one scale: the median chain
    length over every frame of every recording (the median deformed length, which stretches and
    compressions of the single reference frames do not move) divided by ``robot_length``.  The
    positions are rescaled, ``diagnostics_`` say so, and a warning names every recording's own scale
    when they differed by more than :data:`SCALE_SPREAD_WARNING`.  Recordings with a camera or a given
    ``pixels_per_metre`` are returned unchanged.
    """
    own = [d.get("scale_reference") for d in diags]
    if len(trajs) < 2 or any(o is None for o in own):
        return trajs
    lengths = []  # chain lengths in pixels of every frame (metres times the recording's own scale)
    for traj, o in zip(trajs, own):
        xy = np.asarray(traj.poses, dtype=float)[..., :2]
        lengths.append(o["pixels_per_metre"] * np.linalg.norm(np.diff(xy, axis=1), axis=-1).sum(axis=1))
    rest = float(trajs[0].metadata["rest_length"])
    common = float(np.median(np.concatenate(lengths))) / rest
    ratios = np.array([o["pixels_per_metre"] / common for o in own])
    if np.ptp(ratios) > SCALE_SPREAD_WARNING:
        listed = ", ".join(f"{d['recording']}: {o['pixels_per_metre']:.1f} px/m" for d, o in zip(diags, own))
        warnings.warn(
            f"the recordings' own scales (each from its reference frame and robot_length) differ by up to "
            f"{100 * np.ptp(ratios):.0f} %: {listed}; all use {common:.1f} px/m, from the median chain length of "
            "all their frames. A camera JSON per set-up (pcs-sindy calibrate) or pixels_per_metre avoids the guess",
            UserWarning,
            stacklevel=3,
        )
    out = []
    for traj, diag, ratio in zip(trajs, diags, ratios):
        poses = np.array(traj.poses, dtype=float)
        poses[..., :2] *= ratio  # metres = pixels / scale, measured from the base marker
        camera = {**diag["camera"], "pixels_per_metre": common}
        diag["camera"] = camera
        diag["calibration"] += f"; rescaled by {ratio:.4f} to the set's scale (median chain length of all recordings)"
        meta = {**traj.metadata, "camera": camera, "diagnostics": diag}
        out.append(PoseTrajectory(poses, t=traj.t, metadata=meta))
    return out


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
        the end of the chain that moves least over the recording (a clamped
        base moves by detection noise only; the evidence is in
        :attr:`base_evidence_`).
    rest_direction : float, optional
        Image angle (radians, ``atan2(dv, du)``) of the robot's rest direction
        (+y of the base frame) when no camera is used; default: from the base
        marker to the next one in the reference frame.
    reference_frame : "auto" or int
        Frame used for the typical marker, N, the base and the calibration;
        extraction runs on from it and then back from it to frame 0, so a
        robot that starts curled (into a ring, or with its tip next to its
        own body) is followed into the curl from a frame where its chain is
        plain.  ``"auto"`` (default): of up to a dozen frames sampled across the
        recording (frame 0 included), the straightest of those showing the
        longest chain of markers (the earliest among equals: frame 0 when the
        robot starts straight); the choice and why are in
        ``diagnostics_["reference_reason"]``.  With ``robot_length`` and no
        camera, the scale comes from this frame (straight and unstretched
        at best); when it is not straight the rest direction comes from the
        clamped base marker's axis.
    fps, dt : float, optional
        Frame rate or period overriding the video's (required for arrays and
        image folders without a camera JSON holding ``fps``).
    refine : bool
        Sub-pixel centres and axes from intensity-weighted moments (default);
        ``False`` uses ``minAreaRect`` directly.
    on_missing : {"auto", "raise", "interpolate", "predict"}
        A frame whose markers cannot be extracted (missing or merged markers
        that cannot be filled, a chain that cannot be ordered, undecodable
        data) either raises (``"raise"``, naming recording and frame) or is
        interpolated in time from its valid neighbours (``"interpolate"``,
        listed in :attr:`diagnostics_`).  ``"auto"`` (default) interpolates
        gaps of at most :data:`~pcs_sindy.vision.extraction.MAX_AUTO_GAP`
        consecutive frames with a warning naming them, and raises on a longer
        gap (naming it, ``on_missing="interpolate"`` and ``pcs-sindy
        inspect``): a few frames where markers touch do not stop a recording,
        a robot out of view for a while does.  ``"predict"`` is for
        :meth:`stream` only (a live camera has no later frames to interpolate
        from): a few lost markers are predicted from the last two frames;
        there ``"auto"`` raises like ``"raise"``.
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
        ``base_marker`` and ``base_evidence`` (how the base was told from
        the tip), ``reference_frame`` and ``reference_reason``,
        ``calibration`` and the camera used.
    base_evidence_ : list of str
        After :meth:`transform`, per recording: what decided which end of the
        chain is the base (given, the camera's origin, or the motion of both
        ends over frames sampled across the recording).

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
        reference_frame: int | str = "auto",
        fps: float | None = None,
        dt: float | None = None,
        refine: bool = True,
        on_missing: str = "auto",
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
    #: read by validate_parameters in fit, transform and stream, and by model files
    _parameter_constraints: dict = {
        "n_markers": [None, Interval(Integral, 1, None, closed="left")],
        "threshold": [
            Options(_THRESHOLDS),
            Interval(Real, 0, 255, closed="both"),
            Check(
                _colour_range,
                "a (lower, upper) colour range of grey levels or BGR triples with lower <= upper in [0, 255]",
            ),
        ],
        "polarity": [Options(("dark", "bright"))],
        "blur": [Check(_blur_kernel, "0 or an odd integer >= 1")],
        "roi": [None, Check(_roi, "(x, y, width, height) integers with x, y >= 0 and width, height >= 1")],
        "marker_area": [None, _POSITIVE],
        "area_tolerance": [Check(_area_tolerance, "(low, high) with 0 < low < 1 < high, both finite")],
        "aspect_tolerance": [Interval(Real, 1, None, closed="left")],
        "camera": [
            Options(("auto",)),
            None,
            InstanceOf(Camera, "a Camera"),
            InstanceOf(dict, "a camera dict"),
            InstanceOf((str, os.PathLike), "the path of a camera JSON"),
        ],
        "pixels_per_metre": [None, _POSITIVE],
        "robot_length": [None, _POSITIVE],
        "base_position": [None, Check(_pixel, "(u, v) pixels: two finite numbers")],
        "rest_direction": [None, Interval(Real, None, None, closed="neither")],
        "reference_frame": [Options(("auto",)), Interval(Integral, 0, None, closed="left")],
        "fps": [None, _POSITIVE],
        "dt": [None, _POSITIVE],
        "refine": "no_validation",
        "on_missing": [Options(("auto", "raise", "interpolate", "predict"))],
        "fill_missing": ["boolean"],
        "min_area": [_POSITIVE],
        "n_jobs": "no_validation",
        "progress": "no_validation",
    }

    def _check_frame_rate(self) -> None:
        """What the table cannot say: a frame rate or a period, not both."""
        if self.fps is not None and self.dt is not None:
            want = f"None when fps is given (fps = {self.fps!r}; give fps or dt, not both)"
            raise InvalidParameterError.of(self, "dt", want, self.dt)

    def _extraction_params(self) -> dict[str, Any]:
        """The (checked) parameters as the extraction takes them: a camera JSON read, the roi in ints.

        A camera dict or JSON is checked now (the frame rate and frame count it may hold included) and
        handed on as its dict, with ``camera_source`` naming it: the extraction takes its ``fps`` and
        ``n_frames`` and completes a missing ``image_size`` from the footage.
        """
        cam, source = self.camera, "given camera"
        if isinstance(cam, (str, os.PathLike)) and not (isinstance(cam, str) and cam == "auto"):
            source = f"camera JSON {str(cam)!r}"
            cam = read_camera_json(cam)
        if isinstance(cam, dict):
            camera_extras(cam, source)
            try:
                Camera.from_dict(cam, image_size=(1, 1))  # the camera itself, checked (the size may come later)
            except (ValueError, TypeError) as err:
                raise ValueError(f"{source}: {err}") from None
        params = self.get_params()
        params.update(
            camera=cam,
            camera_source=source,
            roi=None if self.roi is None else tuple(int(v) for v in np.asarray(self.roi)),
        )
        return params

    # -- sklearn API -----------------------------------------------------------
    def fit(self, X: Any = None, y: Any = None) -> MarkerPoseExtractor:
        """Validate the parameters and, if given, the form of ``X`` (extraction is stateless); returns self."""
        validate_parameters(self)
        self._check_frame_rate()
        self._extraction_params()  # reads a camera dict or JSON: refuses an invalid one now
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
        validate_parameters(self)
        self._check_frame_rate()
        params = self._extraction_params()
        if params["on_missing"] == "predict":
            raise ValueError(
                "on_missing='predict' is for stream(); recordings take 'auto', 'raise' or 'interpolate' (which uses "
                "the frames on both sides)"
            )
        X = check_recordings(X)
        names = [describe(rec, k) for k, rec in enumerate(X)]
        jobs = (delayed(extract_recording)(rec, name, params) for rec, name in zip(X, names))
        if self.n_jobs in (None, 1) or len(X) == 1:
            results = [extract_recording(rec, name, params) for rec, name in zip(X, names)]
        else:
            results = Parallel(n_jobs=self.n_jobs)(jobs)
        trajs = share_scale([traj for traj, _ in results], [diag for _, diag in results])
        self.diagnostics_ = [diag for _, diag in results]
        self.base_evidence_ = [diag["base_evidence"] for _, diag in results]
        return trajs

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
        validate_parameters(self)
        self._check_frame_rate()
        params = self._extraction_params()
        for name, value in (("max_predicted", max_predicted), ("max_run", max_run)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be a positive integer; got {value!r}")
        return MarkerStream(reference, params, int(max_predicted), int(max_run))

    def __sklearn_tags__(self):  # stateless: transform needs no fit
        tags = super().__sklearn_tags__()
        tags.requires_fit = False
        tags.input_tags.two_d_array = False  # X is a list of videos
        return tags
