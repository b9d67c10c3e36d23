"""make_pcs_pipeline: videos/poses + forces -> PCS model, cross-validated by recording.

Truth used here: the two_segment robot of the seed's Table I (segment lengths
70 and 100 mm, E = 1e4 / 9e3 Pa, G = 1e3 / 3e3 Pa, r = 20 mm, K = diag(E I,
4/3 G A, E A)) and the simulated poses of its recordings.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from sklearn.exceptions import FitFailedWarning
from sklearn.metrics import r2_score
from sklearn.model_selection import GridSearchCV, GroupKFold, LeaveOneGroupOut

from pcs_sindy.core import Camera, PoseTrajectory, StrainTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import EulerLagrangeRegressor, StiffnessThresholdOptimizer
from pcs_sindy.pipeline import PCSPipeline, make_pcs_pipeline, recording_groups
from pcs_sindy.simulation import get_scenario
from pcs_sindy.simulation.rendering import render_frames
from pcs_sindy.vision import MarkerPoseExtractor

TRUE_LENGTHS = np.array([0.07, 0.10])
_R = 0.02
_A, _I = np.pi * _R**2, np.pi * _R**4 / 4
# Table I stiffness [EI, c_sh G A, E A] per segment (c_sh = 4/3, f_L = 1)
TRUE_K = np.array([_I * 1e4, 4 / 3 * _A * 1e3, _A * 1e4, _I * 9e3, 4 / 3 * _A * 3e3, _A * 9e3])


@pytest.fixture(scope="module")
def data():
    return get_scenario("two_segment").generate(seed=0)


def _poses(data, n_rec: int, n_frames: int):
    recs = data.train[:n_rec]
    X = [PoseTrajectory(r.poses[:n_frames], t=r.t[:n_frames]) for r in recs]
    return X, [r.tau[:n_frames] for r in recs], recs


@pytest.fixture(scope="module")
def video_fit(data):
    """3 recordings x 60 frames rendered at 320x240 (markers 12 x 4 mm, ~10 x 3 px)."""
    recs = data.train[:3]
    n = 60
    cam = Camera.fit_poses(np.concatenate([r.poses[:n] for r in recs]), image_size=(320, 240))
    frames = [render_frames(r.poses[:n], cam, marker_size=(0.012, 0.004)) for r in recs]
    taus = [r.tau[:n] for r in recs]
    # 60-frame recordings hold only two of the default 40-sample weak-form windows: use shorter, overlapping ones
    reg = EulerLagrangeRegressor(weak_window=20, weak_stride=5)
    pipe = make_pcs_pipeline(extractor=MarkerPoseExtractor(camera=cam, fps=1000.0, progress=False), regressor=reg)
    pipe.fit(frames, taus)
    return pipe, frames, taus, cam


def test_video_pipeline_recovers_the_robot(video_fit) -> None:
    pipe, frames, taus, _ = video_fit
    assert isinstance(pipe, PCSPipeline)
    assert [name for name, _ in pipe.steps] == ["poses", "segments", "dynamics"]
    assert pipe.n_segments_ == 2
    np.testing.assert_allclose(pipe.segment_lengths_, TRUE_LENGTHS, atol=2e-3)
    # bending and axial stiffness of both segments and shear of the second within 10 %
    # (shear of segment 1 is barely excited by 60 ms of data, even from exact poses)
    k = pipe.model_.stiffness_
    for j in (0, 2, 3, 4, 5):
        assert abs(k[j] - TRUE_K[j]) < 0.1 * TRUE_K[j], (j, k[j], TRUE_K[j])


def test_video_pipeline_predict_and_score(video_fit) -> None:
    pipe, frames, taus, _ = video_fit
    pred = pipe.predict(frames)
    assert len(pred) == 3 and all(p.shape == (60, 6) and np.all(np.isfinite(p)) for p in pred)
    strains = pipe.transform_strains(frames)
    for a, b in zip(pred, pipe.model_.predict(strains), strict=True):
        np.testing.assert_array_equal(a, b)
    # the pipeline's score is the dynamics step's on the fitted transformers' strains
    assert pipe.score(frames, taus) == pipe.model_.score(strains, taus)
    # scikit-learn's rule: score is the R^2 of what predict returns, recordings stacked
    assert pipe.score(frames, taus) == pytest.approx(r2_score(np.concatenate(taus), np.vstack(list(pred))), rel=1e-12)
    assert pipe.score(frames, taus) > 0.7  # measured 0.78: the held forces' jumps are not explained sample by sample
    assert pipe.rollout_score(frames, taus) > 0.8  # the tip paths of rollouts of the training recordings


def test_video_pipeline_takes_pose_trajectories_for_strains(video_fit, data) -> None:
    pipe, *_ = video_fit
    truth = [PoseTrajectory(r.poses[:60], t=r.t[:60]) for r in data.train[:2]]
    direct = pipe.named_steps["segments"].transform(truth)
    for a, b in zip(pipe.transform_strains(truth), direct, strict=True):
        np.testing.assert_array_equal(a.q, b.q)
    # exact poses give strains within the fused segmentation's accuracy of the simulator's
    q0, _ = pipe.initial_state(truth, recording=1)
    assert np.all(np.abs(q0 - data.train[1].q[0]) < np.array([1.0, 0.02, 0.02] * 2)), q0


@pytest.fixture(scope="module")
def pose_fit(data):
    X, y, recs = _poses(data, 4, 200)
    pipe = make_pcs_pipeline(start="poses", fusion=KinematicFusion(shape_fit="end_pose")).fit(X, y)
    return pipe, X, y, recs


def test_pose_start_and_rollout_follow_the_truth(pose_fit) -> None:
    pipe, X, y, recs = pose_fit
    assert [name for name, _ in pipe.steps] == ["segments", "dynamics"]
    q0, qd0 = pipe.initial_state(X, recording=1)
    # the fused segmentation is close to the true one (68/102 mm), so its strains are near the simulator's
    assert np.all(np.abs(q0 - recs[1].q[0]) < np.array([1.0, 0.02, 0.02] * 2)), (q0, recs[1].q[0])
    sim = pipe.simulate(q0, qd0, recs[1].t[:200], y[1])
    assert isinstance(sim, StrainTrajectory) and sim.q.shape == (200, 6)
    poses = pipe.simulate_poses(q0, qd0, recs[1].t[:200], y[1], base_pose=(0.0, 0.0, 0.0))
    assert poses.poses.shape == recs[1].poses[:200].shape
    tip = np.linalg.norm(poses.poses[:, -1, :2] - recs[1].poses[:200, -1, :2], axis=-1)
    assert tip.mean() < 3e-3, tip.mean()  # 0.2 s open-loop rollout, robot 170 mm long
    moved = pipe.simulate_poses(q0, qd0, recs[1].t[:200], y[1], base_pose=(0.01, -0.02, 0.0))
    shift = moved.poses[..., :2] - poses.poses[..., :2]
    np.testing.assert_allclose(shift, np.broadcast_to([0.01, -0.02], shift.shape), atol=1e-12)


def test_pipeline_is_the_composition_of_its_steps(pose_fit) -> None:
    pipe, X, y, _ = pose_fit
    fusion = KinematicFusion(shape_fit="end_pose").fit(X)
    np.testing.assert_array_equal(pipe.fusion_.boundaries_, fusion.boundaries_)
    np.testing.assert_array_equal(pipe.segment_lengths_, fusion.segment_lengths_)
    strains = fusion.transform(X)
    for a, b in zip(pipe.transform_strains(X), strains, strict=True):
        np.testing.assert_array_equal(a.q, b.q)
    reg = EulerLagrangeRegressor(optimizer=StiffnessThresholdOptimizer()).fit(strains, y)
    np.testing.assert_array_equal(pipe.model_.coef_, reg.coef_)
    for a, b in zip(pipe.predict(X), reg.predict(strains), strict=True):
        np.testing.assert_array_equal(a, b)


def test_defaults_and_argument_errors() -> None:
    pipe = make_pcs_pipeline()
    reg = pipe.named_steps["dynamics"]
    # the regressor's own defaults, with the default optimizer made explicit for grid searches
    assert reg.get_params(deep=False) == {**EulerLagrangeRegressor().get_params(deep=False), "optimizer": reg.optimizer}
    assert isinstance(reg.optimizer, StiffnessThresholdOptimizer)
    assert reg.optimizer.get_params() == StiffnessThresholdOptimizer().get_params()
    assert isinstance(pipe.named_steps["poses"], MarkerPoseExtractor)
    mine = EulerLagrangeRegressor(window_length=9)
    assert make_pcs_pipeline(regressor=mine, start="poses").named_steps["dynamics"] is mine
    pipe = make_pcs_pipeline(start="poses", n_jobs=2)
    assert pipe.named_steps["segments"].n_jobs == 2
    with pytest.raises(ValueError, match="start"):
        make_pcs_pipeline(start="strains")
    with pytest.raises(ValueError, match="extractor"):
        make_pcs_pipeline(extractor=MarkerPoseExtractor(), start="poses")
    with pytest.raises(ValueError, match="regressor"):
        make_pcs_pipeline(regressor=KinematicFusion())
    with pytest.raises(ValueError, match="n_jobs"):
        make_pcs_pipeline(n_jobs=0)
    with pytest.raises(AttributeError):
        _ = make_pcs_pipeline().n_segments_  # not fitted


def test_segmentation_that_does_not_match_the_forces_is_named(data) -> None:
    X, y, _ = _poses(data, 2, 100)
    pipe = make_pcs_pipeline(start="poses", fusion=KinematicFusion(threshold=1.0, shape_fit="end_pose"))
    with pytest.raises(ValueError, match=r"1 segment\(s\) = 3 strains, but y has 6 force columns"):
        pipe.fit(X, y)
    # after a good fit, other errors keep their own message (the old segmentation is not blamed)
    pipe.set_params(segments__threshold=0.2).fit(X, y)
    bad = X[0].poses.copy()
    bad[3, 2, 0] = np.nan
    with pytest.raises(ValueError, match="NaN") as err:
        pipe.fit([bad, X[1]], [y[0][:, :3], y[1][:, :3]])
    assert "force columns" not in str(err.value)


def test_grid_search_by_recording_picks_two_segments(data) -> None:
    X, y, _ = _poses(data, 4, 200)
    pipe = make_pcs_pipeline(start="poses", fusion=KinematicFusion(shape_fit="end_pose"))
    grid = {
        "segments__threshold": [0.2, 1.0],  # 2 segments / 1 segment
        # E_max = 1 kPa declares the true bending and axial stiffness over-stiff: they get removed
        "dynamics__optimizer__youngs_modulus_max": [1e3, 1e8],
    }
    search = GridSearchCV(pipe, grid, cv=GroupKFold(n_splits=2), error_score=np.nan)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        search.fit(X, y, groups=recording_groups(X))
    failed = [w for w in caught if issubclass(w.category, FitFailedWarning)]
    assert failed and "force columns" in str(failed[0].message)  # exclusion is announced, with the reason
    scores = search.cv_results_["mean_test_score"]
    params = search.cv_results_["params"]
    for p, s in zip(params, scores, strict=True):
        # NaN exactly for the candidates that cannot be fitted (1 segment for 6 forces)
        assert np.isnan(s) == (p["segments__threshold"] == 1.0), (p, s)
    assert search.best_params_ == {"segments__threshold": 0.2, "dynamics__optimizer__youngs_modulus_max": 1e8}
    best = search.best_estimator_
    assert best.n_segments_ == 2 and best.active_strains_.all()


@pytest.mark.slow
def test_loky_n_jobs_2_matches_sequential(data) -> None:
    X, y, _ = _poses(data, 3, 60)
    reg = EulerLagrangeRegressor(weak_window=20, weak_stride=5)
    pipe = make_pcs_pipeline(start="poses", fusion=KinematicFusion(shape_fit="end_pose"), regressor=reg)
    grid = {"segments__threshold": [0.2, 1.0]}
    runs = []
    for n_jobs in (1, 2):  # 2: the whole pipeline pickled to loky worker processes
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitFailedWarning)
            warnings.simplefilter("ignore", UserWarning)
            s = GridSearchCV(pipe, grid, cv=LeaveOneGroupOut(), n_jobs=n_jobs).fit(X, y, groups=recording_groups(X))
        runs.append(s.cv_results_["mean_test_score"])
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.isfinite(runs[0][0]) and np.isnan(runs[0][1])
    # per-recording strain fits of the fusion (reuses the warm loky workers)
    f1 = KinematicFusion(n_jobs=1).fit(X)
    f2 = KinematicFusion(n_jobs=2).fit(X)
    for a, b in zip(f1.transform(X), f2.transform(X), strict=True):
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.metadata["base_poses"], b.metadata["base_poses"])


def test_recording_groups() -> None:
    X = [None] * 5
    np.testing.assert_array_equal(recording_groups(X), np.arange(5))
    g = recording_groups(X, ["a", "b", "a", "c", "b"])
    assert g[0] == g[2] and g[1] == g[4] and len(set(g.tolist())) == 3
    with pytest.raises(ValueError, match="recording_ids"):
        recording_groups(X, ["a"])
    with pytest.raises(ValueError, match="X must be a list"):
        recording_groups(np.zeros(3))


def test_pipeline_fits_actuator_inputs_from_poses() -> None:
    scenario = get_scenario("one_segment_pneumatic")
    data = scenario.generate(seed=0, n_train=3, validation=False)
    poses = [PoseTrajectory(r.poses, t=r.t) for r in data.train]
    mass = float(1070 * np.pi * 0.02**2 * 0.1)  # Table I: rho A L, as a user weighs it
    from pcs_sindy.identification import PhysicalPCSLibrary

    pipe = make_pcs_pipeline(
        start="poses",
        fusion=KinematicFusion(total_length=0.1),
        regressor=EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(mass=mass), actuation=scenario.actuation),
    )
    pipe.fit(poses, [r.u for r in data.train])
    true = scenario.robot.actuation
    np.testing.assert_allclose(pipe.model_.actuation_.gains_, np.r_[true.bending_gain, true.axial_gain], rtol=0.02)
    with pytest.raises(ValueError, match="actuation was given with regressor"):
        make_pcs_pipeline(regressor=EulerLagrangeRegressor(), actuation=scenario.actuation)
    default = make_pcs_pipeline(start="poses", actuation=scenario.actuation)
    assert default.named_steps["dynamics"].actuation == scenario.actuation


def test_initial_state_indices_must_be_integers(pose_fit) -> None:
    pipe, X, _, _ = pose_fit
    with pytest.raises(ValueError, match=r"sample must be an integer index; got 1.5"):
        pipe.initial_state(X, recording=1, sample=1.5)  # before: numpy's IndexError on st.q[1.5]
    with pytest.raises(ValueError, match=r"recording must be an integer index; got True"):
        pipe.initial_state(X, recording=True)
