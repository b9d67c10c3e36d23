"""One scikit-learn Pipeline from videos (or poses) and forces to a PCS model.

:func:`make_pcs_pipeline` chains the three estimators of the package::

    Pipeline([("poses", MarkerPoseExtractor),      # videos -> PoseTrajectory
              ("segments", KinematicFusion),        # poses  -> StrainTrajectory
              ("dynamics", EulerLagrangeRegressor)])  # strains + tau -> model

``pipeline.fit(videos, taus)`` fits it; ``predict``/``score`` are the
regressor's (forces by inverse dynamics; R^2 of those forces, scikit-learn's rule);
:meth:`PCSPipeline.simulate` and :meth:`PCSPipeline.simulate_poses` roll the
identified model out, :meth:`PCSPipeline.rollout_error` and :meth:`PCSPipeline.rollout_score` score rollouts (see
:func:`pcs_sindy.core.metrics.rollout_scorer` and :func:`pcs_sindy.core.metrics.rollout_r2_scorer`).

The sample unit is a recording: ``X`` is a list with one entry per recording
and ``y`` the list of their force arrays, so scikit-learn's model selection
splits by recording (``KFold`` over the list, or ``GroupKFold`` /
``LeaveOneGroupOut`` with ``groups`` when several entries come from one
physical recording).  See :func:`recording_groups` and the example in
:func:`make_pcs_pipeline`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import savgol_filter
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from ..core.saving import PersistenceMixin
from ..core.simulate_contract import simulate_inputs
from ..core.trajectory import PoseTrajectory, StrainTrajectory

__all__ = ["PCSPipeline", "make_pcs_pipeline", "recording_groups"]

_STARTS = ("videos", "poses")


def _holds_poses(X: Any) -> bool:
    """Whether every item of X is a pose trajectory rather than a video."""
    items = X if isinstance(X, (list, tuple)) else [X]

    def is_pose(item: Any) -> bool:
        if isinstance(item, PoseTrajectory):
            return True
        return isinstance(item, np.ndarray) and item.dtype.kind == "f" and item.ndim == 3 and item.shape[-1] == 3

    return len(items) > 0 and all(is_pose(item) for item in items)


class PCSPipeline(PersistenceMixin, Pipeline):
    """A :class:`sklearn.pipeline.Pipeline` ending in a ``segments`` and a ``dynamics`` step.

    Everything of ``Pipeline`` works unchanged (``fit``, ``predict``,
    ``score``, ``set_params(segments__threshold=...)``, slicing, ``memory``);
    this class adds rollouts of the identified model, shortcuts to the fitted
    segmentation and a clear error when the segmentation does not match the
    forces.  Build it with :func:`make_pcs_pipeline`.

    Attributes
    ----------
    All read-only, set by ``fit``.

    fusion_ : KinematicFusion
        The fitted ``segments`` step.
    model_ : EulerLagrangeRegressor
        The fitted ``dynamics`` step.
    n_segments_ : int
    segment_lengths_ : ndarray, shape (m,)
    active_strains_ : ndarray of bool, shape (m, 3)
        Strains kept by the dynamics step's sparsification.
    """

    # -- fitting ---------------------------------------------------------------
    def fit(self, X: Any, y: Any = None, **params: Any) -> PCSPipeline:
        """Fit every step; ``X`` a list of recordings, ``y`` the list of their forces.

        Raises
        ------
        ValueError
            Besides the steps' own errors: when the fitted segmentation has a
            different number of strains (3 per segment) than ``y`` has force
            columns, naming the segmentation and the ``segments`` parameters
            to change.  Inside ``GridSearchCV(error_score=np.nan)`` such a
            candidate is excluded with a ``FitFailedWarning`` carrying this
            message (its score is NaN and it ranks last).
        """
        # a segmentation left over from an earlier fit must not be blamed for this one's error
        before = getattr(self.named_steps.get("segments"), "boundaries_", None)
        try:
            super().fit(X, y, **params)
        except ValueError as err:
            mismatch = self._strain_mismatch(y, before)
            if mismatch is None:
                raise
            raise ValueError(mismatch) from err
        return self

    def _strain_mismatch(self, y: Any, before: Any) -> str | None:
        """A message when the ``segments`` step fitted in this call disagrees with the width of ``y``."""
        fusion = self.named_steps.get("segments")
        n = getattr(fusion, "n_segments_", None)
        if n is None or y is None or getattr(fusion, "boundaries_", None) is before:
            return None
        if getattr(self.steps[-1][1], "actuation", None) is not None:
            return None  # actuator inputs: their width does not depend on the segmentation
        try:
            first = y[0] if isinstance(y, (list, tuple)) else y
            width = int(np.shape(first)[-1])
        except (IndexError, TypeError):
            return None
        if width == 3 * n:
            return None
        return (
            f"the 'segments' step (threshold={getattr(fusion, 'threshold', None)!r}) fused the robot into {n} "
            f"segment(s) = {3 * n} strains, but y has {width} force columns per sample (one per strain): "
            f"choose segments__threshold (or min_segment_markers) so that the segmentation has {width // 3} "
            "segment(s), or give forces for the fused strains"
        )

    # -- shortcuts -------------------------------------------------------------
    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False  # X is a list of videos or pose recordings
        return tags

    def _fitted_step(self, name: str) -> Any:
        if name not in self.named_steps:
            raise AttributeError(f"this pipeline has no {name!r} step (steps: {list(self.named_steps)})")
        est = self.named_steps[name]
        check_is_fitted(est)
        return est

    @property
    def fusion_(self) -> Any:
        """The fitted ``segments`` step (:class:`~pcs_sindy.fusion.kinematic_fusion.KinematicFusion`)."""
        return self._fitted_step("segments")

    @property
    def model_(self) -> Any:
        """The fitted ``dynamics`` step (:class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`)."""
        return self._fitted_step("dynamics")

    @property
    def n_segments_(self) -> int:
        """Number of fused segments."""
        return int(self.fusion_.n_segments_)

    @property
    def segment_lengths_(self) -> NDArray[np.float64]:
        """Rest lengths of the fused segments (m)."""
        return np.asarray(self.fusion_.segment_lengths_, dtype=float)

    @property
    def active_strains_(self) -> NDArray[np.bool_]:
        """Strains kept by the dynamics step, shape (m, 3)."""
        return np.asarray(self.model_.active_strains_, dtype=bool)

    # -- data through the fitted transformers ----------------------------------
    def transform_strains(self, X: Any) -> list[StrainTrajectory]:
        """Strain trajectories of recordings ``X`` through every step but the last.

        ``X`` may also hold pose trajectories (``PoseTrajectory`` or float
        arrays (T, N + 1, 3)) when the pipeline starts from videos: they skip
        the ``poses`` step (e.g. a ground-truth validation recording).
        """
        check_is_fitted(self)
        if "poses" in self.named_steps and _holds_poses(X):
            return self.named_steps["segments"].transform(X)
        return self[:-1].transform(X)

    def initial_state(
        self, X: Any, recording: int = 0, sample: int = 0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Strains and strain rates of one sample of a recording, to start a rollout from.

        The rates are the dynamics step's Savitzky–Golay derivative
        (``window_length``, ``polyorder``) of the strains that the fitted
        transformers give for ``X[recording]``.

        Returns
        -------
        q0, qd0 : ndarray, shape (3m,)
        """
        check_is_fitted(self)
        for name, val in (("recording", recording), ("sample", sample)):
            if isinstance(val, bool) or not isinstance(val, (int, np.integer)):
                raise ValueError(f"{name} must be an integer index; got {val!r}")
        if isinstance(X, (list, tuple)):
            if not -len(X) <= recording < len(X):
                raise ValueError(f"recording must index one of the {len(X)} recordings of X; got {recording!r}")
            X = [X[recording]]
        elif recording != 0:
            raise ValueError(f"X is a single recording, so recording must be 0; got {recording!r}")
        (st,) = self.transform_strains(X)
        if not -st.n_frames <= sample < st.n_frames:
            raise ValueError(f"sample must index one of the {st.n_frames} frames; got {sample!r}")
        reg = self.model_
        wl, po = int(reg.window_length), int(reg.polyorder)
        if st.n_frames < wl:
            raise ValueError(
                f"the recording has {st.n_frames} frames, fewer than the window_length {wl} of the dynamics step"
            )
        dt = float(np.median(np.diff(st.t)))
        rate = savgol_filter(st.q, wl, po, deriv=1, delta=dt, axis=0)
        return st.q[sample].copy(), rate[sample].copy()

    # -- rollouts --------------------------------------------------------------
    def simulate(self, q0: ArrayLike, qd0: ArrayLike, t: Any = None, u: Any = None, **kw: Any) -> StrainTrajectory:
        """Roll out the identified model: the ``dynamics`` step's ``simulate(q0, qd0, t, u, **kw)``."""
        t, u = simulate_inputs(t, u, kw.pop("tau", None))
        return self.model_.simulate(q0, qd0, t, u, **kw)

    def rollout_error(self, X: Any, y: Sequence[ArrayLike], **kw: Any) -> NDArray[np.float64]:
        """Tip position error (m) of rolling each recording of ``X`` out under ``y``.

        ``X`` goes through the fitted transformers (videos or poses), then the
        ``dynamics`` step's :meth:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor.rollout_error`.
        """
        return self.model_.rollout_error(self.transform_strains(X), y, **kw)

    def rollout_score(self, X: Any, y: Sequence[ArrayLike]) -> float:
        """R^2 of the tip path of rollouts of ``X`` under ``y`` (the regressor's :meth:`rollout_score`).

        ``score`` is scikit-learn's: the R^2 of the forces ``predict`` returns.
        """
        return float(self.model_.rollout_score(self.transform_strains(X), y))

    def simulate_poses(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        t: Any = None,
        u: Any = None,
        *,
        base_pose: ArrayLike | None = None,
        **kw: Any,
    ) -> PoseTrajectory:
        """Roll out the model and return the poses of the base and the tracked markers.

        Parameters
        ----------
        q0, qd0, t, u, **kw
            As :meth:`simulate`.
        base_pose : array_like, shape (3,), optional
            Pose of the robot's base (x, y, θ) in the frame of the extracted
            poses; default: the base of the first training recording.

        Returns
        -------
        PoseTrajectory
            Poses (T, N + 1, 3) of the base and the N markers at the fitted
            marker arc lengths, via the ``segments`` step's ``inverse_transform``.
        """
        fusion = self.fusion_
        t, u = simulate_inputs(t, u, kw.pop("tau", None))
        sim = self.simulate(q0, qd0, t, u, **kw)
        if base_pose is not None:
            bp = np.asarray(base_pose, dtype=float)
            if bp.shape != (3,) or not np.all(np.isfinite(bp)):
                raise ValueError(f"base_pose must be a finite (x, y, theta); got {base_pose!r}")
            sim.metadata["base_poses"] = np.broadcast_to(bp, (sim.n_frames, 3)).copy()
        return fusion.inverse_transform([sim])[0]


def recording_groups(X: Sequence[Any], recording_ids: Sequence[Any] | None = None) -> NDArray[np.int64]:
    """Group labels for ``GroupKFold`` / ``LeaveOneGroupOut`` over a list of recordings.

    Parameters
    ----------
    X : list
        Entries passed as ``X`` (videos, pose or strain trajectories).
    recording_ids : sequence, optional
        Physical recording of each entry (e.g. several clips cut from one
        video share an id); default: every entry is its own recording.

    Returns
    -------
    ndarray of int, shape (len(X),)
    """
    if not isinstance(X, (list, tuple)):
        raise ValueError(f"X must be a list with one entry per recording; got {type(X).__name__}")
    if recording_ids is None:
        return np.arange(len(X))
    ids = list(recording_ids)
    if len(ids) != len(X):
        raise ValueError(f"recording_ids must hold one id per entry of X ({len(X)}); got {len(ids)}")
    _, codes = np.unique(np.asarray(ids, dtype=object).astype(str), return_inverse=True)
    return codes.astype(np.int64)


def make_pcs_pipeline(
    *,
    extractor: Any = None,
    fusion: Any = None,
    regressor: Any = None,
    start: str = "videos",
    memory: Any = None,
    verbose: bool = False,
    n_jobs: int | None = None,
    actuation: Any = None,
) -> PCSPipeline:
    """Videos (or pose trajectories) and forces to a PCS model, as one Pipeline.

    Parameters
    ----------
    extractor : MarkerPoseExtractor, optional
        The ``poses`` step; default ``MarkerPoseExtractor()``.  Not allowed
        with ``start="poses"``.
    fusion : KinematicFusion, optional
        The ``segments`` step; default ``KinematicFusion()`` (h = 0.2).
    regressor : EulerLagrangeRegressor, optional
        The ``dynamics`` step; default ``EulerLagrangeRegressor()`` (its
        defaults are the recommended settings) with an explicit
        ``StiffnessThresholdOptimizer()`` so that grid searches can reach
        ``dynamics__optimizer__threshold`` etc.
    start : {"videos", "poses"}
        ``"videos"``: X holds videos (paths, image folders, frame arrays);
        ``"poses"``: X holds pose trajectories (``PoseTrajectory`` or arrays
        (T, N + 1, 3)) and the ``poses`` step is omitted.
    memory : str, joblib.Memory or None
        Cache of the fitted transformers (``Pipeline(memory=...)``): a grid
        search over the dynamics step then extracts and fuses once.
    verbose : bool
        Print the time of each step.
    n_jobs : int, optional
        If given, set on the steps that have ``n_jobs`` (the extractor and the
        fusion: recordings processed in parallel by joblib).
    actuation : Actuation or dict, optional
        How the inputs ``y`` act (:mod:`pcs_sindy.models.actuation`; e.g. a tendon
        layout): given to the default regressor, so ``pipe.fit(videos, u_list)``
        takes actuator inputs.  Not allowed with ``regressor`` (set it there).

    Returns
    -------
    PCSPipeline

    Notes
    -----
    Work over recordings (extraction, per-recording strain fits) and over
    grid-search candidates (``GridSearchCV(n_jobs=...)``) goes through joblib,
    so the same code runs on a cluster by switching joblib's backend::

        from dask.distributed import Client
        from joblib import parallel_config
        client = Client()                       # or Client("scheduler-address:8786")
        with parallel_config(backend="dask"):
            search.fit(videos, taus, groups=groups)

    (``"ray"`` after ``ray.util.joblib.register_ray()``; the default is
    ``"loky"``, processes on this machine.)

    Cross-validation by recording, e.g. over the fusion threshold h and the
    sparsification threshold (a factor on the material bound)::

        from sklearn.model_selection import GridSearchCV, GroupKFold
        pipe = make_pcs_pipeline(start="poses")
        search = GridSearchCV(
            pipe,
            {"segments__threshold": [0.1, 0.2, 0.5],
             "dynamics__optimizer__threshold": [1.0, 0.1, 0.01]},
            cv=GroupKFold(4), scoring=rollout_r2_scorer, error_score=np.nan)
        search.fit(poses, taus, groups=recording_groups(poses))

    A candidate whose segmentation does not match the width of the forces
    cannot be fitted: ``PCSPipeline.fit`` raises a ``ValueError`` saying so,
    which ``error_score=np.nan`` (GridSearchCV's default) turns into a
    ``FitFailedWarning`` with that message and a last rank for that
    candidate; ``error_score="raise"`` stops the search instead.  Scores of
    fitted candidates are never NaN: the regressor's ``rollout_score`` raises on an
    undefined R^2 instead of returning NaN.
    """
    from ..fusion.kinematic_fusion import KinematicFusion
    from ..identification.optimizers import StiffnessThresholdOptimizer
    from ..identification.regressor import EulerLagrangeRegressor

    if start not in _STARTS:
        raise ValueError(f"start must be one of {_STARTS}; got {start!r}")
    if start == "poses" and extractor is not None:
        raise ValueError("extractor was given with start='poses'; the poses step is omitted, pass start='videos'")
    if n_jobs is not None and (isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0):
        raise ValueError(f"n_jobs must be None or a non-zero integer (joblib's convention); got {n_jobs!r}")
    for name, est, needed in (
        ("extractor", extractor, ("fit", "transform")),
        ("fusion", fusion, ("fit", "transform", "inverse_transform")),
        ("regressor", regressor, ("fit", "predict", "simulate")),
    ):
        if est is not None and not all(hasattr(est, m) for m in needed):
            raise ValueError(f"{name} must implement {', '.join(needed)}; got {type(est).__name__}")

    if fusion is None:
        fusion = KinematicFusion()
    if regressor is None:
        regressor = EulerLagrangeRegressor(optimizer=StiffnessThresholdOptimizer(), actuation=actuation)
    elif actuation is not None:
        raise ValueError(
            "actuation was given with regressor; set it on the regressor: EulerLagrangeRegressor(actuation=...)"
        )
    steps: list[tuple[str, Any]] = []
    if start == "videos":
        if extractor is None:  # vision (OpenCV) only for a pipeline that reads videos
            from ..vision.extractor import MarkerPoseExtractor

            extractor = MarkerPoseExtractor()
        steps.append(("poses", extractor))
    steps += [("segments", fusion), ("dynamics", regressor)]
    if n_jobs is not None:
        for _, est in steps:
            if "n_jobs" in est.get_params(deep=False):
                est.set_params(n_jobs=n_jobs)
    return PCSPipeline(steps, memory=memory, verbose=verbose)
