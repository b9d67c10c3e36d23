"""Kinematic fusion: from marker poses to a few constant-strain segments.

Implements the seed's Algorithm 1 (docs/method.md, "Kinematic fusion") and, beyond the seed,
a least-squares shape fit with continuously refined segment boundaries.

:class:`KinematicFusion` is the scikit-learn transformer; the work is done by
plain functions on numpy arrays in the modules named after what they hold:

* :mod:`pcs_sindy.fusion.chain_geometry` - the marker chain in the base frame
  (:func:`chain_poses`), the rest length from poses
  (:func:`estimate_total_length`) and the closed-form strains of segments
  ending on markers (:func:`segment_strains`, seed eq. 4, 9-10);
* :mod:`pcs_sindy.fusion.merging` - Algorithm 1 (:func:`strain_distances`,
  :func:`merge_runs`, :func:`fuse_segments`);
* :mod:`pcs_sindy.fusion.shape_fit` - the least-squares strains
  (:func:`fit_strains_least_squares`) and boundaries (:func:`refine_boundaries`);
* :mod:`pcs_sindy.fusion.position_fusion`, :mod:`pcs_sindy.fusion.position_fit` - recordings of
  marker positions only (:meth:`PoseTrajectory.from_positions`): base pose, arc lengths, bending strains;
* :mod:`pcs_sindy.fusion.spatial_fusion` - the same for robots that move in 3-D (``space="3d"``):
  a fixed base in SE(3), the two bendings (and torsion, with orientations) of a spatial PCS;
* :mod:`pcs_sindy.fusion.threshold_selection` - the rules that choose the merge
  threshold from a sweep (:func:`select_threshold`, :func:`choose_threshold`, used by
  ``threshold="auto"``).

This module also holds :func:`threshold_sweep`, the seed's Fig. 8 trade-off, which runs
this estimator for several thresholds.

Every public name of those modules is importable from :mod:`pcs_sindy.fusion`.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real
from typing import Any

import numpy as np
from joblib import Parallel, delayed
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, TransformerMixin, clone
from sklearn.utils.validation import check_is_fitted
from tqdm.auto import tqdm

from ..core.kinematics import SEED_Q_MAX, forward_kinematics, se2_compose
from ..core.metrics import distributed_errors
from ..core.saving import PersistenceMixin
from ..core.spatial import SPATIAL_Q_MAX, SpatialStrainTrajectory, se3_from_matrix, se3_matrix
from ..core.trajectory import (
    MarkerPlane,
    PoseTrajectory,
    StrainTrajectory,
    as_pose_trajectories,
    as_strain_trajectories,
)
from ..core.validation import Check, Interval, Options, validate_parameters
from .chain_geometry import (
    chain_poses,
    frame_chain,
    kinematic_rest_length,
    rest_length_factor,
    segment_strains,
)
from .input_checks import check_arc_lengths, check_marker_chain, check_marker_positions
from .merging import MERGE_RULES, check_q_max, data_q_max, fuse_segments
from .position_fusion import (
    base_axis_planes,
    choose_position_threshold,
    fuse_position_segments,
    marker_geometry,
    on_plane,
    position_strain_trajectories,
    positions_in_user_frame,
    recorded_base_position,
    shared_marker_plane,
)
from .shape_fit import fit_frame_strains, fit_strains_least_squares, lengths_from_ends, refine_boundaries
from .spatial_fusion import (
    choose_spatial_threshold,
    fuse_spatial_segments,
    needs_3d,
    spatial_marker_geometry,
    spatial_marker_positions,
    spatial_strain_trajectories,
)
from .threshold_selection import SELECTION_RULES, SweepRow, choose_threshold

__all__ = ["KinematicFusion", "threshold_sweep"]

_SHAPE_FITS = ("end_pose", "least_squares")
#: frames (at most) of the positions-only geometry fits: the base, arc lengths and offsets are a few
#: numbers that 300 evenly spread frames determine to well within their model uncertainty
POSITION_GEOMETRY_FRAMES = 300
_SCALINGS = ("q_max", "data")
_SPACES = ("auto", "plane", "3d")


def _three_scales(value: Any) -> bool:
    return check_q_max(value) is not None  # raises on anything else


def _two_positive(value: Any) -> bool:
    std = np.asarray(value, dtype=float)
    return std.shape == (2,) and bool(np.all(np.isfinite(std)) and np.all(std > 0))


def _whole_at_least_one(value: Any) -> bool:
    return not isinstance(value, (bool, np.bool_)) and int(value) == value and value >= 1


def _finite_vector(value: Any) -> bool:
    if isinstance(value, str):
        return False
    v = np.asarray(value, dtype=float)
    shape_ok = (v.ndim == 1 and v.size >= 1) or (v.ndim == 2 and v.shape[0] >= 1 and v.shape[1] == 2)
    return shape_ok and bool(np.all(np.isfinite(v)))


def _nonzero_int(value: Any) -> bool:
    return not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, np.integer)) and value != 0


class KinematicFusion(PersistenceMixin, TransformerMixin, BaseEstimator):
    """Segment a continuum robot into constant-strain pieces (seed Algorithm 1).

    Parameters
    ----------
    threshold : float or {"auto", "relative_drop", "largest_drop"}, default "auto"
        Merge threshold ``h`` on the average scaled strain distance (seed eq. 11).
        A float fixes it.  A rule name chooses it per robot in :meth:`fit`:
        Algorithm 1 is run for the thresholds of
        :data:`~pcs_sindy.fusion.threshold_selection.AUTO_THRESHOLDS` (on at most
        ``max_refine_frames`` frames), each segmentation scored by the
        distributed position error of its end-pose model, and the rule picks
        one (:func:`~pcs_sindy.fusion.threshold_selection.select_threshold`):
        ``"largest_drop"`` is the seed's (largest error decrease per added
        segment), ``"relative_drop"`` the largest *factor* of decrease per added
        segment.  ``"auto"`` is ``"relative_drop"``, the rule that fuses every
        scenario of :mod:`pcs_sindy.simulation` into its true segment count
        (docs/results.md, "Kinematic fusion"); the seed's rule splits three- and
        five-segment robots into two and three.  The chosen value is
        :attr:`threshold_`, the reason :attr:`threshold_choice_`.
    q_max : sequence of 3 floats, default (60, 0.3, 0.3)
        Strain scales [1/m, -, -] used when ``scaling="q_max"`` (the seed's).
    scaling : {"q_max", "data"}, default "q_max"
        ``"data"`` scales each strain type by the 99th percentile of its
        magnitude over the initial segments and all frames.
    total_length : float, optional
        Rest length of the robot [m].  If None: the length the poses carry
        (``metadata["rest_length"]``, set by ``MarkerPoseExtractor(robot_length=...)``),
        else the median deformed axial length of the marker chain
        (:func:`estimate_total_length`, long by any mean stretch; correct it
        with :meth:`correct_rest_length` or use
        :func:`pcs_sindy.pipeline.rest_length.estimate_rest_length`).
    shape_fit : {"least_squares", "end_pose"}, default "least_squares"
        ``"end_pose"`` computes each segment's strains from its two end poses
        (the seed).  ``"least_squares"`` fits each frame's strains to all
        marker poses (:func:`fit_strains_least_squares`) and, with
        ``refine_boundaries``, moves the boundaries off the markers.
    refine_boundaries : bool, default True
        With ``shape_fit="least_squares"``, refine the boundary arc lengths
        continuously over the recordings (:func:`refine_boundaries`).
    min_segment_markers : int, default 2
        Segments spanning fewer marker spacings are absorbed into their more
        similar neighbour after Algorithm 1 (see :func:`fuse_segments`); 1
        reproduces the seed's algorithm exactly.
    merge : {"runs", "closest_pair"}, default "runs"
        ``"runs"``: every run of pairs within ``threshold`` merges at once
        (the seed); ``"closest_pair"``: one pair per iteration (see
        :func:`fuse_segments`).
    pose_std : (float, float), default (5e-4, 1°)
        Position [m] and angle [rad] noise levels weighting the least-squares
        residuals (only their ratio matters).
    fixed_base : bool, default True
        The base is clamped: use its median pose per recording as the
        reference frame instead of each frame's measured base pose.
    max_refine_frames : int, default 500
        Frames (evenly subsampled over all recordings) used by the boundary
        search and by the threshold sweep of ``threshold="auto"``; the final
        segmentation and strains use every frame.
    n_jobs : int, optional
        Recordings whose strains :meth:`transform` fits in parallel (joblib;
        ``None`` or 1: sequentially).  Under ``joblib.parallel_backend(...)``
        the work goes to that backend (e.g. a Dask or Ray cluster).
    progress : bool, default False
        Show tqdm progress bars.
    shared_plane : bool or "base_axis", default True
        Positions-only recordings: project every recording passed to :meth:`fit` on one plane
        fitted to all of them (recordings of one set-up, e.g. static holds, which have no motion
        of their own to fit a plane to), and recordings passed to :meth:`transform` on it too
        (:attr:`plane_`).  ``"base_axis"``: one plane per recording, all containing one axis
        through the recorded base marker (:func:`~pcs_sindy.fusion.position_fusion.base_axis_planes`;
        a robot whose tendons pull at different angles bends in a plane that turns with the
        loads); :meth:`transform` then keeps each recording's plane.  False: each recording keeps
        the plane ``from_positions`` gave it.
    marker_offsets : "fit", sequence of float or None, default None
        Positions-only recordings: each marker's distance [m] from the backbone along its
        cross-section's in-plane normal (markers on the skin of a thick body), given, or
        ``"fit"`` (one per marker, shared by all frames, :attr:`marker_offsets_`); None: on the backbone.
    n_segments : int, optional
        Positions-only recordings: fuse into this many segments (the closest adjacent segments merge
        one by one) instead of by ``threshold`` - e.g. the count chosen by held-out prediction.
        Then :attr:`threshold_` is None and :attr:`threshold_choice_` ``{"rule": "n_segments", ...}``.
    space : {"auto", "plane", "3d"}, default "auto"
        Positions-only recordings: fuse a planar PCS in the markers' plane (``"plane"``, the path
        above) or a spatial one in the capture frame (``"3d"``, :mod:`pcs_sindy.fusion.spatial_fusion`:
        the two bendings of every segment, and torsion when the recordings carry marker orientations,
        ``from_positions(rotations=...)``).  ``"auto"``: 3-D when a recording carries orientations or
        leaves its best-fit plane by more than 0.2 of its in-plane motion RMS (and 1 mm; the
        criterion of the warning of ``from_positions``), else the plane; with
        ``shared_plane="base_axis"`` always the plane.  Pose recordings are always planar.
        In 3-D, ``q_max``'s bending scale applies to both bendings, the torsion scale is
        :data:`~pcs_sindy.core.spatial.SPATIAL_Q_MAX`'s, ``marker_offsets`` may also give ``(N, 2)``
        offsets along the cross-section's x and z axes (``"fit"`` fits both), ``shared_plane`` does not
        apply (the best-fit plane of all recordings fixes the gauge: the base's z axis is its normal,
        so a planar motion has ``bend_x = 0``) and ``pose_std`` weights positions against orientations.

    Attributes
    ----------
    threshold_ : float or None
        The merge threshold used: ``threshold`` when it is a number, else the chosen one; None
        when ``n_segments`` fixed the segment count.
    threshold_choice_ : dict
        Why: ``{"rule": "given"}`` for a number; for a rule the record of
        :func:`~pcs_sindy.fusion.threshold_selection.choose_threshold`
        (``h``, ``rule``, ``n_segments``, ``candidates`` as
        ``(n_segments, e_p_dist, e_theta_dist, h_min, h_max)``, ``reason``).
    total_length_ : float
    total_length_source_ : str
        Where the rest length came from (given, carried by the poses, estimated, corrected).
    total_length_std_ : float
        Its standard error: 0 when given; for the kinematic estimate the
        jackknife over recordings (over blocks of frames for one recording),
        which does not include the bias of a mean stretch.
    marker_arc_lengths_ : ndarray, shape (N + 1,)
        Rest arc lengths of the base and the markers.
    n_markers_ : int
    q_max_ : ndarray, shape (3,)
        Strain scales used.
    distance_profile_ : ndarray, shape (N - 1,)
        First-iteration distances of adjacent initial segments (seed Fig. 6).
    history_ : list of dict
        Per iteration of Algorithm 1: ``boundaries``, ``distances``, ``groups``.
    boundaries_ : ndarray of int, shape (m,)
        Marker index (base = 0, tip = N) of each fused segment's end.
    segment_lengths_ : ndarray, shape (m,)
        Segment rest lengths (off the marker grid after boundary refinement).
    n_segments_ : int
    base_pose_ : ndarray, shape (3,)
        Median base pose of the fitted recordings (the reference of :meth:`transform_frame`);
        for positions-only recordings the fitted fixed base pose in the marker plane.
    positions_only_ : bool
        Fitted on positions-only recordings (:meth:`PoseTrajectory.from_positions`).  Then the
        base pose and (unless given) the markers' rest arc lengths are fitted to the positions,
        Algorithm 1 runs on the curvatures of bending-only segments between markers
        (:mod:`pcs_sindy.fusion.position_fusion`; ``min_segment_markers``, ``shape_fit``,
        ``refine_boundaries``, ``merge``, ``pose_std`` and ``fixed_base`` do not apply,
        ``scaling="data"`` scales by the 99th percentile of the initial curvatures,
        ``max_refine_frames`` (at most 300) bounds the frames of the geometry fit), the strain trajectories
        have only bending strains active, and :meth:`inverse_transform` returns the markers
        in the user's frame as ``.positions`` (3-D in, 3-D out).
    base_pose_std_, marker_arc_lengths_std_ : ndarray
        Standard errors of the fitted base pose and arc lengths (positions-only fits; for pose
        recordings the arc lengths' follow from :attr:`total_length_std_` and ``base_pose_std_`` is None).
    position_rms_ : float or None
        RMS position residual of the geometry fit [m] (positions-only fits; None for poses).
    marker_offsets_, marker_offsets_std_ : ndarray, shape (N,), or None
        The markers' distances off the backbone (given, fitted or zeros) and their standard
        errors (positions-only fits; None for poses).
    plane_ : MarkerPlane or None
        The plane shared by the recordings (positions-only fits with ``shared_plane=True``); stored as
        ``plane_origin_`` and ``plane_axes_``.
    plane_base_axis_ : ndarray (3, 3) or None
        With ``shared_plane="base_axis"``: the common axis, its point (the base marker) and the side
        the planes' normals point to.
    space_ : {"plane", "3d"}
        The model fitted (see ``space``).  In 3-D: :attr:`base_pose_` is the base's (4, 4) homogeneous
        matrix in the capture frame, :attr:`base_pose_std_` the standard errors of its position (3) and
        of its rest direction (two angles [rad]), :attr:`marker_offsets_` and its std are (N, 2) (body x,
        body z), :attr:`q_max_` holds the six spatial strain scales, :meth:`transform` returns spatial
        strain trajectories (:class:`~pcs_sindy.core.spatial.SpatialStrainTrajectory`; six strains per
        segment, the bendings active, and torsion with orientations) and :meth:`inverse_transform` positions (and the
        markers' orientations, ``.rotations``) in the capture frame.
    marker_rotation_offsets_ : ndarray (N, 3, 3) or None
        3-D fits on recordings with orientations: each rigid body's frame in its cross-section's
        frame (fitted); None otherwise.
    rotation_rms_ : float or None
        3-D fits with orientations: RMS angle [rad] of the orientation residuals.

    Examples
    --------
    >>> fusion = KinematicFusion().fit(poses)                      # doctest: +SKIP
    >>> fusion.threshold_, fusion.threshold_choice_["reason"]       # doctest: +SKIP
    >>> strains = fusion.transform(poses)                          # doctest: +SKIP
    """

    def __init__(
        self,
        threshold: float | str = "auto",
        q_max: Sequence[float] = SEED_Q_MAX,
        scaling: str = "q_max",
        total_length: float | None = None,
        shape_fit: str = "least_squares",
        refine_boundaries: bool = True,
        min_segment_markers: int = 2,
        merge: str = "runs",
        pose_std: Sequence[float] = (5e-4, float(np.deg2rad(1.0))),
        fixed_base: bool = True,
        max_refine_frames: int = 500,
        n_jobs: int | None = None,
        progress: bool = False,
        shared_plane: bool | str = True,
        marker_offsets: str | Sequence[float] | None = None,
        n_segments: int | None = None,
        space: str = "auto",
    ) -> None:
        self.threshold = threshold
        self.q_max = q_max
        self.scaling = scaling
        self.total_length = total_length
        self.shape_fit = shape_fit
        self.refine_boundaries = refine_boundaries
        self.min_segment_markers = min_segment_markers
        self.merge = merge
        self.pose_std = pose_std
        self.fixed_base = fixed_base
        self.max_refine_frames = max_refine_frames
        self.n_jobs = n_jobs
        self.progress = progress
        self.shared_plane = shared_plane
        self.marker_offsets = marker_offsets
        self.n_segments = n_segments
        self.space = space

    # -- validation: the table read by validate_parameters in fit and transform, and by model files
    _parameter_constraints: dict = {
        "threshold": [Interval(Real, 0, None, closed="neither"), Options(("auto", *SELECTION_RULES))],
        "q_max": [Check(_three_scales, "three finite numbers > 0 (bending [1/m], shear and axial scales)")],
        "scaling": [Options(_SCALINGS)],
        "total_length": [None, Interval(Real, 0, None, closed="neither")],
        "shape_fit": [Options(_SHAPE_FITS)],
        "refine_boundaries": "no_validation",
        "min_segment_markers": [Interval(Integral, 1, None, closed="left")],
        "merge": [Options(MERGE_RULES)],
        "pose_std": [Check(_two_positive, "two finite numbers > 0 (position [m], angle [rad])")],
        "fixed_base": "no_validation",
        # integral floats (500.0) have always been accepted here
        "max_refine_frames": [Check(_whole_at_least_one, "an integer >= 1")],
        "n_jobs": [None, Check(_nonzero_int, "a non-zero integer (joblib's convention)")],
        "progress": "no_validation",
        "shared_plane": ["boolean", Options(("base_axis",))],
        "marker_offsets": [
            None,
            Options(("fit",)),
            Check(_finite_vector, "'fit', None or finite distances [m] (N,) or (N, 2)"),
        ],
        "n_segments": [None, Interval(Integral, 1, None, closed="left")],
        "space": [Options(_SPACES)],
    }

    def _chains(self, X: Any, name: str = "X") -> tuple[list[PoseTrajectory], list[NDArray], list[NDArray]]:
        trajs = as_pose_trajectories(X, name=name)
        chains, bases = [], []
        for k, tr in enumerate(trajs):
            try:
                c, b = chain_poses(tr.poses, fixed_base=self.fixed_base)
            except ValueError as err:
                raise ValueError(f"{name}[{k}]: {err}") from None
            check_marker_chain(tr.poses, name=f"{name}[{k}]")
            chains.append(c)
            bases.append(b)
        n = {c.shape[1] for c in chains}
        if len(n) != 1:
            raise ValueError(f"all recordings in {name} must have the same number of markers; got N + 1 in {sorted(n)}")
        return trajs, chains, bases

    # -- fit -------------------------------------------------------------------
    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False  # X is a list of pose recordings
        return tags

    def set_output(self, *, transform: str | None = None) -> KinematicFusion:
        """scikit-learn's output configuration, where it applies: ``"default"`` (or None) only.

        :meth:`transform` returns one :class:`~pcs_sindy.core.StrainTrajectory` per
        recording (strains, times and the segmentation), not a 2-D array, so there is
        no DataFrame to give; ``Pipeline.set_output(transform="default")`` works.

        Raises
        ------
        ValueError
            For ``"pandas"`` or ``"polars"``, with the way to a table of strains.
        """
        if transform not in (None, "default"):
            raise ValueError(
                f"set_output(transform={transform!r}) does not apply to KinematicFusion: transform returns one "
                "StrainTrajectory per recording, not a 2-D array; only 'default' (or None) does. For a table of "
                "one recording's strains: pandas.DataFrame(traj.q, columns=traj.kinematics.strain_names())"
            )
        return self

    def fit(self, X: Any, y: Any = None) -> KinematicFusion:
        """Find the segmentation from pose recordings.

        Parameters
        ----------
        X : PoseTrajectory, array (T, N + 1, 3), or a list of them
        y : ignored
        """
        validate_parameters(self)
        X = as_pose_trajectories(X)  # converted once: every step below gets these recordings
        if self._positions_only(X):
            if self._spatial(X):
                return self._fit_spatial(X)
            return self._fit_positions(X)
        if self.space == "3d":
            raise ValueError(
                "space='3d' applies to positions-only recordings (PoseTrajectory.from_positions with 3-D "
                "positions); pose recordings (T, N + 1, 3) are planar"
            )
        if self.n_segments is not None:
            raise ValueError(
                f"n_segments={self.n_segments!r} applies to positions-only recordings; for pose recordings "
                "give a threshold (threshold_sweep shows the segment count of each)"
            )
        _, chains, bases = self._chains(X)
        n_markers = chains[0].shape[1] - 1
        total, source, std = self._rest_length(X, chains)
        s = np.linspace(0.0, total, n_markers + 1)

        if self.scaling == "data":
            q_init = np.concatenate([segment_strains(c, s, np.arange(1, n_markers + 1)) for c in chains], axis=0)
            q_max = data_q_max(q_init, fallback=self.q_max)
        else:
            q_max = check_q_max(self.q_max)

        if isinstance(self.threshold, str):
            rule = SELECTION_RULES[0] if self.threshold == "auto" else self.threshold
            h, choice = choose_threshold(
                self._subsample(chains),
                s,
                q_max,
                rule=rule,
                min_segment_markers=int(self.min_segment_markers),
                merge=self.merge,
                progress=bool(self.progress),
            )
        else:
            h, choice = float(self.threshold), {"rule": "given", "h": float(self.threshold)}
        boundaries, history = fuse_segments(chains, s, h, q_max, int(self.min_segment_markers), self.merge)
        if choice["rule"] != "given" and boundaries.size != choice["n_segments"]:
            choice["reason"] += (
                f"; on all frames h = {h:.4g} gives {boundaries.size} segment(s) "
                f"(the sweep used at most max_refine_frames = {int(self.max_refine_frames)} of them)"
            )
        self.threshold_ = h
        self.threshold_choice_ = choice
        self.total_length_ = total
        self.total_length_source_ = source
        self.total_length_std_ = std
        self.marker_arc_lengths_ = s
        self.n_markers_ = n_markers
        self.q_max_ = q_max
        self.history_ = history
        self.distance_profile_ = history[0]["distances"] if history else np.zeros(0)
        self.boundaries_ = boundaries
        ends = s[boundaries]
        if self.shape_fit == "least_squares" and self.refine_boundaries and boundaries.size > 1:
            target = np.concatenate([c[:, 1:, :] for c in chains], axis=0)
            q0 = self._end_pose_q(chains)
            if target.shape[0] > self.max_refine_frames:
                pick = np.linspace(0, target.shape[0] - 1, int(self.max_refine_frames)).round().astype(int)
                target, q0 = target[pick], q0[pick]
            ends, _ = refine_boundaries(target, s[1:], ends, q0, self.pose_std)
        self.segment_lengths_ = lengths_from_ends(ends)
        self.n_segments_ = int(boundaries.size)
        all_bases = np.concatenate(bases)
        self.base_pose_ = np.median(all_bases, axis=0)  # the clamped base of the recordings, for single frames
        # the attributes of a positions-only fit exist here too, so both kinds of fit look alike
        self.marker_arc_lengths_std_ = s / max(total, 1e-300) * std  # the markers are spread over the length
        self.base_pose_std_ = None
        self.position_rms_ = None
        self.marker_offsets_ = self.marker_offsets_std_ = None
        self.plane_origin_ = self.plane_axes_ = self.plane_base_axis_ = None
        self.positions_only_ = False
        self.space_ = "plane"
        self.marker_rotation_offsets_ = self.rotation_rms_ = None
        return self

    def _spatial(self, trajs: list[PoseTrajectory]) -> bool:
        """Whether positions-only recordings get the spatial model (``space``)."""
        if self.space == "plane":
            return False
        three_d = all(tr.positions.shape[-1] == 3 for tr in trajs)
        if self.space == "3d":
            if not three_d:
                raise ValueError("space='3d' needs 3-D marker positions; got 2-D positions")
            return True
        return three_d and self.shared_plane != "base_axis" and needs_3d(trajs)

    def _fit_spatial(self, trajs: list[PoseTrajectory]) -> KinematicFusion:
        """Fit on positions-only recordings in 3-D (:mod:`pcs_sindy.fusion.spatial_fusion`)."""
        if self.total_length is not None:
            raise ValueError(
                f"total_length={self.total_length!r} is not used with positions-only recordings: the model spans "
                "the base to the last marker; give the markers' rest arc lengths to "
                "PoseTrajectory.from_positions(arc_lengths=...) instead"
            )
        if len({tr.n_markers for tr in trajs}) != 1:
            raise ValueError(f"all recordings in X must have the same markers; got {[tr.n_markers for tr in trajs]}")
        known_arcs = trajs[0].metadata.get("marker_arc_lengths")
        check_marker_positions([tr.positions for tr in trajs], known_arcs, name="X")
        with_rotations = {getattr(tr, "rotations", None) is not None for tr in trajs}
        if len(with_rotations) > 1:
            raise ValueError("X: give rotations to PoseTrajectory.from_positions for every recording, or none")
        n = trajs[0].n_markers
        q_max = check_q_max(self.q_max)
        offsets = self.marker_offsets
        if offsets is not None and not isinstance(offsets, str):
            offsets = np.asarray(offsets, dtype=float)
            if offsets.shape not in ((n,), (n, 2)):
                raise ValueError(
                    f"marker_offsets must be 'fit', None, {n} distances [m] or ({n}, 2) offsets, one per marker; "
                    f"got {self.marker_offsets!r}"
                )
        normal = shared_marker_plane(trajs).normal  # the gauge: a planar motion has bend_x = 0
        frames = min(int(self.max_refine_frames), POSITION_GEOMETRY_FRAMES)
        std = tuple(float(v) for v in self.pose_std)
        geometry = spatial_marker_geometry(trajs, frames, normal=normal, offsets=offsets, pose_std=std)
        scales = None if self.scaling == "data" else np.array([q_max[0], q_max[0], SPATIAL_Q_MAX[2]])
        if self.n_segments is not None:
            h, choice = None, {"rule": "n_segments", "n_segments": int(self.n_segments), "h": None}
        elif isinstance(self.threshold, str):
            rule = SELECTION_RULES[0] if self.threshold == "auto" else self.threshold
            h, choice = choose_spatial_threshold(geometry, scales, rule=rule)
        else:
            h, choice = float(self.threshold), {"rule": "given", "h": float(self.threshold)}
        fit = fuse_spatial_segments(
            trajs,
            geometry,
            float("inf") if h is None else h,
            scales,
            n_segments=None if self.n_segments is None else int(self.n_segments),
        )
        self._take_marker_fit(fit, trajs, known_arcs, h, choice)
        bend, _, twist = fit["scales"]
        self.q_max_ = np.array([bend, bend, twist, q_max[1], q_max[1], q_max[2]])
        self.history_ = fit["history"]
        self.distance_profile_ = self.history_[0]["distances"] if self.history_ else np.zeros(0)
        self.boundaries_ = fit["boundaries"]
        self.segment_lengths_ = fit["segment_lengths"]
        self.n_segments_ = int(self.boundaries_.size)
        self.base_pose_ = se3_matrix(fit["base_position"], fit["base_rotation"])
        self.base_pose_std_ = fit["base_std"]
        self.position_rms_ = fit["rms"]
        self.rotation_rms_ = fit["rotation_rms"]
        self.marker_offsets_ = fit["offsets"]
        self.marker_offsets_std_ = fit["offsets_std"]
        self.marker_rotation_offsets_ = fit["rotation_offsets"]
        self.plane_origin_ = self.plane_axes_ = self.plane_base_axis_ = None
        self.positions_only_ = True
        self.space_ = "3d"
        return self

    @property
    def plane_(self) -> MarkerPlane | None:
        """The plane shared by positions-only recordings (``shared_plane``), else None."""
        origin = getattr(self, "plane_origin_", None)
        return None if origin is None else MarkerPlane(origin, self.plane_axes_)

    @staticmethod
    def _positions_only(X: Any) -> bool:
        trajs = as_pose_trajectories(X)
        flags = {tr.positions_only for tr in trajs}
        if len(flags) > 1:
            raise ValueError("X mixes positions-only recordings (PoseTrajectory.from_positions) with pose recordings")
        return flags.pop()

    def _take_marker_fit(self, fit: dict, trajs: list, known_arcs: Any, h: float | None, choice: dict) -> None:
        """Threshold, marker arc lengths and total length of a positions-only fit (planar or 3-D)."""
        s = fit["arc_lengths"]
        if known_arcs is None:  # a fit the markers contradict (what the checks above did not see)
            check_arc_lengths([tr.positions for tr in trajs], s[1:], "the fitted marker arc lengths")
        self.threshold_ = h
        self.threshold_choice_ = choice
        self.total_length_ = float(s[-1])
        known = "marker_arc_lengths" in trajs[0].metadata
        self.total_length_source_ = (
            "arc length of the last marker (given)" if known else "arc length of the last marker, fitted to positions"
        )
        self.total_length_std_ = float(fit["arc_lengths_std"][-1])
        self.marker_arc_lengths_ = s
        self.marker_arc_lengths_std_ = np.concatenate([[0.0], fit["arc_lengths_std"]])
        self.n_markers_ = s.size - 1

    def _fit_positions(self, X: Any) -> KinematicFusion:
        """Fit on positions-only recordings (:mod:`pcs_sindy.fusion.position_fusion`)."""
        trajs = as_pose_trajectories(X)
        if self.total_length is not None:
            raise ValueError(
                f"total_length={self.total_length!r} is not used with positions-only recordings: the model spans "
                "the base to the last marker; give the markers' rest arc lengths to "
                "PoseTrajectory.from_positions(arc_lengths=...) instead"
            )
        if len({tr.n_markers for tr in trajs}) != 1:
            raise ValueError(f"all recordings in X must have the same markers; got {[tr.n_markers for tr in trajs]}")
        known_arcs = trajs[0].metadata.get("marker_arc_lengths")
        check_marker_positions([tr.positions for tr in trajs], known_arcs, name="X")
        q_max = check_q_max(self.q_max)
        bend = None if self.scaling == "data" else float(q_max[0])
        offsets = self.marker_offsets
        if offsets is not None and not isinstance(offsets, str):
            offsets = np.asarray(offsets, dtype=float)
            if offsets.shape != (trajs[0].n_markers,):
                raise ValueError(
                    f"marker_offsets must be 'fit', None or {trajs[0].n_markers} distances [m], one per marker; "
                    f"got {self.marker_offsets!r}"
                )
        self.plane_origin_ = self.plane_axes_ = self.plane_base_axis_ = None
        if self.shared_plane == "base_axis":
            planes, axis, origin, side = base_axis_planes(trajs)
            self.plane_base_axis_ = np.stack([axis, origin, side])
            trajs = [on_plane(tr, plane) for tr, plane in zip(trajs, planes)]
        elif self.shared_plane:
            plane = shared_marker_plane(trajs)
            self.plane_origin_, self.plane_axes_ = plane.origin.copy(), plane.axes.copy()
            trajs = [on_plane(tr, plane) for tr in trajs]
        base_position = recorded_base_position(trajs)
        frames = min(int(self.max_refine_frames), POSITION_GEOMETRY_FRAMES)
        geometry = marker_geometry(trajs, frames, offsets=offsets, base_position=base_position)
        if self.n_segments is not None:
            h, choice = None, {"rule": "n_segments", "n_segments": int(self.n_segments), "h": None}
        elif isinstance(self.threshold, str):
            rule = SELECTION_RULES[0] if self.threshold == "auto" else self.threshold
            h, choice = choose_position_threshold(trajs, bend, frames, rule=rule, geometry=geometry)
        else:
            h, choice = float(self.threshold), {"rule": "given", "h": float(self.threshold)}
        fit = fuse_position_segments(
            trajs,
            float("inf") if h is None else h,
            bend,
            frames,
            geometry=geometry,
            n_segments=None if self.n_segments is None else int(self.n_segments),
        )
        self._take_marker_fit(fit, trajs, known_arcs, h, choice)
        self.q_max_ = np.array([fit["bend_scale"], q_max[1], q_max[2]]) if self.scaling == "data" else q_max
        self.history_ = fit["history"]
        self.distance_profile_ = self.history_[0]["distances"] if self.history_ else np.zeros(0)
        self.boundaries_ = fit["boundaries"]
        self.segment_lengths_ = fit["segment_lengths"]
        self.n_segments_ = int(self.boundaries_.size)
        self.base_pose_ = fit["base_pose"]
        self.base_pose_std_ = fit["base_pose_std"]
        self.position_rms_ = fit["rms"]
        self.marker_offsets_ = fit["offsets"]
        self.marker_offsets_std_ = fit["offsets_std"]
        self.positions_only_ = True
        self.space_ = "plane"
        self.marker_rotation_offsets_ = self.rotation_rms_ = None
        return self

    def _subsample(self, chains: list[NDArray]) -> list[NDArray]:
        """At most ``max_refine_frames`` frames, evenly over all recordings, as one chain."""
        frames = np.concatenate(chains, axis=0)
        if frames.shape[0] > self.max_refine_frames:
            frames = frames[np.linspace(0, frames.shape[0] - 1, int(self.max_refine_frames)).round().astype(int)]
        return [frames]

    def _rest_length(self, X: Any, chains: list[NDArray]) -> tuple[float, str, float]:
        """(total rest length, where it comes from, its standard error) for :meth:`fit`."""
        if self.total_length is not None:
            return float(self.total_length), "given (total_length)", 0.0
        trajs = as_pose_trajectories(X)
        given = [tr.metadata.get("rest_length") for tr in trajs]
        if any(g is not None for g in given):
            values = {float(g) for g in given if g is not None}
            if None in given or len(values) > 1:
                raise ValueError(
                    "X: the recordings carry different rest lengths in metadata['rest_length'] "
                    f"({[None if g is None else float(g) for g in given]}); give total_length"
                )
            value = values.pop()
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"X: metadata['rest_length'] must be a length > 0 in metres; got {value!r}")
            return value, "given with the poses (metadata['rest_length'])", 0.0
        total, std = kinematic_rest_length(chains)
        return total, "estimated: median deformed length (biased by any mean stretch)", std

    def correct_rest_length(self, rest_strain: ArrayLike, rest_strain_std: float | None = None) -> KinematicFusion:
        """Rescale the fitted rest lengths by identified axial rest strains; returns self.

        A rest length read ``(1 + e)`` times too long makes an unloaded robot
        look compressed: its identified axial rest strains (the constant force
        per strain of ``EulerLagrangeRegressor(rest_strain=True)`` over the
        stiffness) are ``-e / (1 + e)``.  Every length is scaled by
        ``1 + q̄``, with ``q̄`` the length-weighted mean of the segments'
        axial rest strains (one factor: markers stay equally spaced).

        Parameters
        ----------
        rest_strain : array_like, shape (3m,)
            ``regressor.rest_strain_`` of a model fitted to this fusion's strains.
        rest_strain_std : float, optional
            Standard error of ``q̄``, propagated to :attr:`total_length_std_`.
        """
        check_is_fitted(self, "segment_lengths_")
        factor, mean = rest_length_factor(self.segment_lengths_, rest_strain)
        self.total_length_ *= factor
        self.marker_arc_lengths_ = self.marker_arc_lengths_ * factor
        self.segment_lengths_ = self.segment_lengths_ * factor
        self.total_length_source_ = (
            f"{self.total_length_source_}, corrected by the identified axial rest strain {mean:+.5f}"
        )
        if rest_strain_std is not None:
            self.total_length_std_ = float(
                np.hypot(self.total_length_std_ * factor, self.total_length_ * rest_strain_std)
            )
        return self

    def _end_pose_q(self, chains: list[NDArray]) -> NDArray[np.float64]:
        q = [segment_strains(c, self.marker_arc_lengths_, self.boundaries_) for c in chains]
        return np.concatenate([v.reshape(v.shape[0], -1) for v in q], axis=0)

    # -- transform -------------------------------------------------------------
    def _strains(self, chain: NDArray[np.float64]) -> NDArray[np.float64]:
        q = self._end_pose_q([chain])
        if self.shape_fit == "least_squares":
            q, _ = fit_strains_least_squares(
                chain[:, 1:, :], self.segment_lengths_, self.marker_arc_lengths_[1:], q, self.pose_std
            )
        return q

    def transform(self, X: Any) -> list[StrainTrajectory]:
        """Strain trajectories of the fitted segmentation, one per recording.

        Each carries ``segment_lengths`` and, in ``metadata``, the marker arc
        lengths, the per-frame base poses (``"base_poses"``), the fused marker
        boundaries and the shape fit used, so :meth:`inverse_transform`
        reproduces the poses in the input frame.
        """
        check_is_fitted(self, "segment_lengths_")
        X = as_pose_trajectories(X)
        if getattr(self, "positions_only_", False) or self._positions_only(X):
            trajs = X
            if not getattr(self, "positions_only_", False) or not self._positions_only(trajs):
                raise ValueError(
                    "X and the fit must both be positions-only recordings (PoseTrajectory.from_positions) or both poses"
                )
            if trajs[0].n_markers != self.n_markers_:
                raise ValueError(f"X has {trajs[0].n_markers} markers; the fusion was fitted with {self.n_markers_}")
            check_marker_positions([tr.positions for tr in trajs], name="X")
            if getattr(self, "space_", "plane") == "3d":
                return self._transform_spatial(trajs)
            plane = self.plane_
            if plane is not None:
                trajs = [on_plane(tr, plane) for tr in trajs]
            elif getattr(self, "plane_base_axis_", None) is not None:
                planes = base_axis_planes(trajs, *self.plane_base_axis_)[0]
                trajs = [on_plane(tr, p) for tr, p in zip(trajs, planes)]
            return position_strain_trajectories(
                trajs,
                self.base_pose_,
                self.segment_lengths_,
                self.marker_arc_lengths_,
                self.boundaries_,
                getattr(self, "marker_offsets_", None),
            )
        trajs, chains, bases = self._chains(X)
        if chains[0].shape[1] - 1 != self.n_markers_:
            raise ValueError(f"X has {chains[0].shape[1] - 1} markers; the fusion was fitted with {self.n_markers_}")
        validate_parameters(self)
        if self.n_jobs in (None, 1) or len(chains) == 1:
            qs = [self._strains(c) for c in tqdm(chains, desc="fusion", disable=not self.progress, leave=False)]
        else:
            # one task per recording; the backend (loky, threads, dask, ray) is joblib's choice
            qs = Parallel(n_jobs=self.n_jobs)(delayed(self._strains)(c) for c in chains)
        out = []
        for tr, q, base in zip(trajs, qs, bases):
            meta = dict(tr.metadata)
            meta.update(
                marker_arc_lengths=self.marker_arc_lengths_.copy(),
                base_poses=base,
                boundaries=self.boundaries_.copy(),
                shape_fit=self.shape_fit,
            )
            out.append(
                StrainTrajectory(
                    q, tr.t, segment_lengths=tuple(self.segment_lengths_), base_pose=tuple(base[0]), metadata=meta
                )
            )
        return out

    def _transform_spatial(self, trajs: list[PoseTrajectory]) -> list[SpatialStrainTrajectory]:
        if any(tr.positions.shape[-1] != 3 for tr in trajs):
            raise ValueError("X: this fusion was fitted in 3-D (space_='3d'); give 3-D marker positions")
        C = self.marker_rotation_offsets_
        for k, tr in enumerate(trajs):
            if (getattr(tr, "rotations", None) is None) != (C is None):
                raise ValueError(
                    f"X[{k}]: the fusion was fitted {'with' if C is not None else 'without'} marker orientations; "
                    f"give {'rotations' if C is not None else 'no rotations'} to PoseTrajectory.from_positions"
                )
        out = spatial_strain_trajectories(
            trajs,
            self.base_pose_,
            self.segment_lengths_,
            self.marker_arc_lengths_,
            self.boundaries_,
            offsets=self.marker_offsets_,
            rotation_offsets=C,
            pose_std=tuple(float(v) for v in self.pose_std),
        )
        for st in out:
            st.metadata["base_pose"] = np.array(self.base_pose_, copy=True)
        return out

    def _inverse_spatial(self, k: int, st: Any) -> PoseTrajectory:
        """Markers in the capture frame of a spatial strain trajectory (see :meth:`inverse_transform`)."""
        if not isinstance(st, SpatialStrainTrajectory):
            raise ValueError(
                f"X[{k}] must be a SpatialStrainTrajectory (this fusion was fitted in 3-D, space_='3d'); "
                f"got {type(st).__name__}"
            )
        meta = st.metadata
        s = np.asarray(meta.get("marker_arc_lengths", self.marker_arc_lengths_), dtype=float)
        H = np.asarray(meta.get("base_pose", self.base_pose_), dtype=float)
        se3_from_matrix(H)  # checks the shape
        d = meta.get("marker_offsets", self.marker_offsets_)
        C = meta.get("rotation_offsets", self.marker_rotation_offsets_)
        try:
            positions, rotations = spatial_marker_positions(st, s, H, d, C)
        except ValueError as err:
            raise ValueError(f"X[{k}]: {err}") from None
        rec = PoseTrajectory.__new__(PoseTrajectory)  # positions-only, like from_positions, without cleaning
        rec.poses = None
        rec.positions, rec.rotations = positions, rotations
        rec.plane, rec.plane_positions = None, None
        rec.t = st.t.copy()
        rec.metadata = dict(meta)
        return rec

    def transform_frame(self, poses: ArrayLike, q0: ArrayLike | None = None) -> NDArray[np.float64]:
        """Strains (3m,) of one frame of poses (N + 1, 3): state estimation at camera rate.

        The same estimate as :meth:`transform` for that frame (the base is
        :attr:`base_pose_`, the median of the fitted recordings', when
        ``fixed_base``; the frame's own base otherwise), with the
        least-squares shape fit compiled for one frame (tens of
        microseconds; the first call compiles it, cached on disk).

        Parameters
        ----------
        poses : array_like, shape (N + 1, 3)
            Base and markers, as the extractor returns one frame.
        q0 : array_like, shape (3m,), optional
            Start of the least-squares fit, e.g. the previous frame's strains
            (default: the closed-form strains from the segments' end poses;
            ignored by ``shape_fit="end_pose"``).
        """
        check_is_fitted(self, "segment_lengths_")
        if getattr(self, "positions_only_", False):
            raise ValueError("transform_frame needs marker poses; this fusion was fitted on positions only")
        P = np.array(poses, dtype=float)
        if P.shape != (self.n_markers_ + 1, 3):
            raise ValueError(
                f"poses must have shape ({self.n_markers_ + 1}, 3) (the base and {self.n_markers_} markers); "
                f"got {np.shape(poses)}"
            )
        if not np.all(np.isfinite(P)):
            i, j = (int(v) for v in np.argwhere(~np.isfinite(P))[0])
            raise ValueError(
                f"poses must be finite; poses[{i}, {j}] = {float(P[i, j])!r} (marker {i}, 0 = the base): "
                "a lost marker cannot be fused"
            )
        rel = frame_chain(P, self.base_pose_ if self.fixed_base else None)
        if q0 is not None:
            start = np.asarray(q0, dtype=float).reshape(-1)
            if start.shape != (3 * self.n_segments_,) or not np.all(np.isfinite(start)):
                raise ValueError(f"q0 must be {3 * self.n_segments_} finite strains; got shape {np.shape(q0)}")
        if q0 is None or self.shape_fit == "end_pose":
            q = segment_strains(rel[None], self.marker_arc_lengths_, self.boundaries_)[0].reshape(-1)
        else:
            q = start
        if self.shape_fit == "least_squares":
            q = fit_frame_strains(rel[1:], self.segment_lengths_, self.marker_arc_lengths_[1:], q, self.pose_std)
        return q

    def inverse_transform(self, X: Any) -> list[PoseTrajectory]:
        """Poses of the base and the markers, shape (T, N + 1, 3), from strain trajectories.

        Uses the marker arc lengths and per-frame base poses carried in each
        trajectory's metadata when present, else the fitted marker arc
        lengths and the trajectory's constant ``base_pose``.

        A 3-D fusion (``space_ == "3d"``) takes :class:`~pcs_sindy.core.spatial.SpatialStrainTrajectory`
        objects (its :meth:`transform`'s, or a spatial model's prediction:
        ``SpatialStrainTrajectory(q, t, segment_lengths=fusion.segment_lengths_)``) and returns
        positions-only trajectories whose ``.positions`` (T, N, 3) are the markers in the capture frame
        and ``.rotations`` (T, N, 3, 3) their frames; the marker arc lengths, base pose (``"base_pose"``,
        4 x 4) and offsets come from the metadata when present, else from the fit.
        """
        check_is_fitted(self, "segment_lengths_")
        if getattr(self, "space_", "plane") == "3d":
            items = [X] if isinstance(X, SpatialStrainTrajectory) else X
            if not isinstance(items, (list, tuple)) or len(items) == 0:
                raise ValueError(f"X must be a non-empty list of SpatialStrainTrajectory; got {type(X).__name__}")
            return [self._inverse_spatial(k, st) for k, st in enumerate(items)]
        strains = as_strain_trajectories(X)
        out = []
        for k, st in enumerate(strains):
            s = np.asarray(st.metadata.get("marker_arc_lengths", self.marker_arc_lengths_), dtype=float)
            total = float(np.sum(st.segment_lengths))
            if abs(s[-1] - total) > 1e-9 * total:
                raise ValueError(
                    f"X[{k}]: segment lengths sum to {total:g} m but the marker arc lengths end at {s[-1]:g} m"
                )
            local = forward_kinematics(st.q, st.segment_lengths, np.clip(s, 0.0, total))
            base = st.metadata.get("base_poses")
            if base is None:
                base = np.broadcast_to(np.asarray(st.kinematics.base_pose), (st.n_frames, 3))
            base = np.asarray(base, dtype=float)
            if base.shape != (st.n_frames, 3):
                raise ValueError(f"X[{k}].metadata['base_poses'] must have shape ({st.n_frames}, 3); got {base.shape}")
            rec = PoseTrajectory(se2_compose(base[:, None, :], local), st.t, metadata=dict(st.metadata))
            positions = positions_in_user_frame(st, rec.poses)
            if positions is not None:  # positions-only input: markers back in the user's (3-D) frame
                plane = st.metadata["plane"]
                rec.positions, rec.plane, rec.plane_positions = positions, plane, plane.to_plane(positions)
            out.append(rec)
        return out

    def reconstruct(self, X: Any) -> list[PoseTrajectory]:
        """``inverse_transform(transform(X))``: the fused model's poses of the same markers."""
        return self.inverse_transform(self.transform(X))

    def score(self, X: Any, y: Any = None) -> float:
        """Minus the distributed position error e_p^dist (seed eq. 23) over markers (not the base)."""
        trajs = as_pose_trajectories(X)
        rec = self.reconstruct(trajs)
        if trajs[0].positions_only:  # mean marker position error over the valid samples, in the user's frame
            err = np.concatenate(
                [np.linalg.norm(r.positions - tr.positions, axis=2).ravel() for r, tr in zip(rec, trajs)]
            )
            return -float(np.nanmean(err))
        est = np.concatenate([r.poses[:, 1:, :] for r in rec], axis=0)
        tru = np.concatenate([tr.poses[:, 1:, :] for tr in trajs], axis=0)
        e_p, _ = distributed_errors(est, tru)
        return -e_p


def threshold_sweep(
    X: Any,
    thresholds: ArrayLike,
    *,
    fusion: KinematicFusion | None = None,
    truth: Any = None,
    progress: bool = False,
) -> list[SweepRow]:
    """Fused segmentation and pose errors for several thresholds (seed Fig. 8).

    Parameters
    ----------
    X : pose recordings (see :meth:`KinematicFusion.fit`)
    thresholds : array_like of float
        Values of ``h`` (each > 0).
    fusion : KinematicFusion, optional
        Template whose other parameters are used (default ``KinematicFusion()``).

    See Also
    --------
    pcs_sindy.fusion.threshold_selection.select_threshold : a rule that picks a row.
    truth : pose recordings, optional
        Poses to measure the errors against (default ``X`` itself), markers
        only; must match ``X`` recording by recording.

    Returns
    -------
    list of SweepRow
        ``(h, n_segments, e_p_dist, e_theta_dist)`` in the order of ``thresholds``.
    """
    hs = np.atleast_1d(np.asarray(thresholds, dtype=float))
    if hs.ndim != 1 or hs.size == 0 or not np.all(np.isfinite(hs)) or np.any(hs <= 0):
        raise ValueError(f"thresholds must be a non-empty 1-D array of finite values > 0; got {thresholds!r}")
    if fusion is None:
        fusion = KinematicFusion()
    template = fusion
    trajs = as_pose_trajectories(X)
    truths = trajs if truth is None else as_pose_trajectories(truth, name="truth")
    if len(truths) != len(trajs) or any(a.poses.shape != b.poses.shape for a, b in zip(trajs, truths)):
        raise ValueError("truth must hold one recording of the same shape per recording of X")
    tru = np.concatenate([tr.poses[:, 1:, :] for tr in truths], axis=0)
    cache: dict[tuple[int, ...], tuple[int, float, float]] = {}
    rows = []
    for h in tqdm(hs, desc="threshold sweep", disable=not progress):
        # Algorithm 1 alone is cheap; the shape fit is done once per distinct segmentation
        probe = clone(template).set_params(threshold=float(h), shape_fit="end_pose").fit(trajs)
        key = tuple(int(b) for b in probe.boundaries_)
        if key not in cache:
            est = clone(template).set_params(threshold=float(h)).fit(trajs)
            rec = est.reconstruct(trajs)
            e_p, e_th = distributed_errors(np.concatenate([r.poses[:, 1:, :] for r in rec], axis=0), tru)
            cache[key] = (est.n_segments_, e_p, e_th)
        n, e_p, e_th = cache[key]
        rows.append(SweepRow(float(h), int(n), float(e_p), float(e_th)))
    return rows
