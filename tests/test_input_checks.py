"""Input checks at the public entry points (issue 20 items 1, 5 and 6): no silent wrong answers, no hangs.

Every case here was reproduced on the code before these checks: a short input
table read past its end by the compiled integrators, force files paired by
argument order, shuffled/duplicated/reversed markers or angles in
milliradians fused into many segments, negative gains accepted, NaN
measurements turned into NaN commands, a diverging closed loop running for
minutes.  Truths: the forward kinematics of known strains (marker chains),
file names (pairing), the sign of a gain, a closed-form linear plant.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_control import LinearPlant, linear_model, true_model

from pcs_sindy.cli.main import main
from pcs_sindy.control import ComputedTorqueController, SetpointRegulator, StrainReference, closed_loop
from pcs_sindy.control.closed_loop import plant_equilibrium
from pcs_sindy.core import PlanarPCS, SimulationError, StrainTrajectory, forward_kinematics
from pcs_sindy.fusion import KinematicFusion, check_marker_chain
from pcs_sindy.io.data_files import DataFileError, pair_files, read_training_files, write_strains, write_tau
from pcs_sindy.models import LumpedPCSModel, TendonActuation
from pcs_sindy.models.integrators import solve_held
from pcs_sindy.simulation import get_scenario


# --------------------------------------------------------------------------- 1. inputs of a rollout
def _actuated_model():
    kin = PlanarPCS((0.1,))
    act = TendonActuation([0.1], [1], offset=[0.01]).fit(kin)
    return LumpedPCSModel(kin, [0.3], [1e-5], [[0.0, -3.0]], [1e-3, 10.0, 10.0], [1e-5, 1e-3, 1e-3], actuation=act)


@pytest.mark.parametrize("method", ["rosenbrock", "dopri5", "radau"])
def test_an_actuated_rollout_needs_one_input_row_per_time(method):
    # before: rosenbrock and dopri5 read past the end of u (no error), radau raised a bare IndexError
    model = _actuated_model()
    t = np.linspace(0.0, 0.5, 51)
    u = np.full((51, 1), 0.1)
    for rows in (45, 1, 52):
        with pytest.raises(ValueError, match=rf"u must have shape \(51, 1\).*got shape \({rows}, 1\)"):
            bad = u[:rows] if rows <= 51 else np.vstack([u, u[:1]])
            model.simulate(np.zeros(3), np.zeros(3), t, bad, method=method)
    with pytest.raises(ValueError, match="NaN"):
        model.simulate(np.zeros(3), np.zeros(3), t, np.where(t[:, None] > 0.2, np.nan, u), method=method)
    # the full table still runs: the tendon pulls the robot to one side (curvature of the tension's sign)
    q = model.simulate(np.zeros(3), np.zeros(3), t, u, method=method).q
    assert np.all(np.isfinite(q))


def test_solve_held_checks_its_inputs():
    def fun(y, u):
        return np.array([y[1], u[0] - y[0]])

    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(ValueError, match=r"u must have shape \(11, p\).*got shape \(10, 1\)"):
        solve_held(fun, [0.0, 0.0], t, np.zeros((10, 1)))
    with pytest.raises(ValueError, match="y0 must be finite"):
        solve_held(fun, [np.nan, 0.0], t, np.zeros((11, 1)))
    with pytest.raises(ValueError, match="strictly increasing"):
        solve_held(fun, [0.0, 0.0], t[::-1], np.zeros((11, 1)))
    # the check keeps the answer: u = 1 held from rest, y = 1 - cos(t)
    y = solve_held(fun, [0.0, 0.0], t, np.ones((11, 1)), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(y[:, 0], 1.0 - np.cos(t), atol=1e-8)


def test_a_callable_force_returning_nan_is_named():
    lib_model = _actuated_model()
    kin = lib_model.kinematics
    model = LumpedPCSModel(kin, [0.3], [1e-5], [[0.0, -3.0]], [1e-3, 10.0, 10.0], [1e-5, 1e-3, 1e-3])
    with pytest.raises(ValueError, match=r"u\(t\) returned NaN or inf at t ="):
        model.simulate(np.zeros(3), np.zeros(3), np.linspace(0, 0.1, 5), lambda s: [np.nan, 0.0, 0.0], method="radau")


def test_forward_dynamics_name_a_bad_force():
    model = _actuated_model()
    q = np.zeros((2, 3))
    with pytest.raises(ValueError, match=r"tau must hold one force per modelled strain and state, shape \(2, 3\)"):
        model.accelerations(q, q, np.zeros(5))  # before: numpy's "cannot reshape array of size 5"
    with pytest.raises(ValueError, match="tau contains NaN"):
        model.accelerations(q, q, np.full((2, 3), np.nan))  # before: NaN accelerations
    # the check keeps the answer: at rest, straight, qdd = M^-1 (tau - G)
    tau = np.array([[1e-4, 0.0, 0.0], [0.0, 0.0, 1e-3]])
    M, bias = model.mass_and_bias(q, q)
    np.testing.assert_allclose(model.accelerations(q, q, tau), np.linalg.solve(M, (tau - bias)[..., None])[..., 0])


# --------------------------------------------------------------------------- 3. force files and strain files
def _strains(n_frames=20):
    t = 1e-2 * np.arange(n_frames)
    return StrainTrajectory(np.zeros((n_frames, 3)), t, segment_lengths=(0.1,))


def test_force_files_are_paired_by_name_or_refused(tmp_path):
    st = _strains()
    strains = [write_strains(tmp_path / f"strain_{side}.npz", st) for side in ("left", "right")]
    forces = {side: np.full((20, 3), value) for side, value in (("left", 1.0), ("right", 2.0))}
    taus = [write_tau(tmp_path / f"tau_{side}.npz", st.t, forces[side]) for side in ("right", "left")]
    # the names differ by a prefix each side shares: matched by the rest (before: by order, left <- right)
    _, got = read_training_files(strains, taus)
    np.testing.assert_array_equal(got[0], forces["left"])
    np.testing.assert_array_equal(got[1], forces["right"])
    # names that say nothing: refused, showing the pairing by order
    other = [write_tau(tmp_path / name, st.t, forces["left"]) for name in ("x.npz", "second.npz")]
    with pytest.raises(DataFileError, match=r"do not match.*strain_left.npz' <- '.*x.npz'.*pairing='order'"):
        read_training_files(strains, other)
    assert [b for _, b in pair_files(strains, other, "order")] == other
    # one file each: nothing to confuse
    assert pair_files(strains[:1], other[:1]) == [(strains[0], other[0])]
    with pytest.raises(DataFileError, match="2 strain file.*1 tau file"):
        pair_files(strains, other[:1], "order")
    with pytest.raises(ValueError, match="pairing must be 'name' or 'order'"):
        pair_files(strains, other, "size")


def test_numbers_are_never_cut_to_pair_files(tmp_path):
    """run_10..12 share the prefix "run_1" but are not run_0..2 (issue 27): refused, not paired."""
    st = _strains()
    strains = [write_strains(tmp_path / f"run_{k}.npz", st) for k in range(3)]
    (tmp_path / "f").mkdir()
    (tmp_path / "g").mkdir()
    taus = [write_tau(tmp_path / "f" / f"run_{k}.npz", st.t, np.zeros((20, 3))) for k in (10, 11, 12)]
    with pytest.raises(DataFileError, match="do not match"):
        pair_files(strains, taus)
    # whole name parts still pair: strain_a <- tau_a, and suffixes: a_q <- a_tau
    named = [write_tau(tmp_path / "g" / f"run_{k}_tau.npz", st.t, np.full((20, 3), k)) for k in (2, 0, 1)]
    assert [Path(b).name for _, b in pair_files(strains, named)] == ["run_0_tau.npz", "run_1_tau.npz", "run_2_tau.npz"]


def test_fit_skips_the_segmentation_arrays_a_glob_catches(tmp_path, capsys):
    """The quickstart's ``fit strains/*.npz`` catches segmentation.npz: skipped with a warning naming it."""
    from pcs_sindy.fusion import KinematicFusion
    from pcs_sindy.io.data_files import model_file_arrays, write_model_file
    from pcs_sindy.simulation import get_scenario

    data = get_scenario("one_segment").generate(seed=0, n_train=2, train_duration=0.05, validation=False)
    fusion = KinematicFusion(threshold=0.2, total_length=0.1).fit([r.poses for r in data.train])
    folder = tmp_path / "strains"
    folder.mkdir()
    write_model_file(fusion, folder / "segmentation.json")
    strains, taus = [], []
    fused = fusion.transform([r.poses for r in data.train])
    for k, (rec, st) in enumerate(zip(data.train, fused, strict=True)):
        st = StrainTrajectory(st.q, rec.t, segment_lengths=(0.1,))
        strains.append(str(write_strains(folder / f"train_{k}.npz", st)))
        (tmp_path / "taus").mkdir(exist_ok=True)
        taus.append(str(write_tau(tmp_path / "taus" / f"train_{k}.npz", rec.t, rec.tau)))
    globbed = sorted(str(p) for p in folder.glob("*.npz"))
    assert model_file_arrays(globbed) == [folder / "segmentation.npz"]
    capsys.readouterr()
    assert main(["fit", *globbed, "--tau", *taus, "--out", str(tmp_path / "m.json"), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "skipping" in err and "segmentation.npz" in err


def test_cli_fit_refuses_unmatched_force_files(tmp_path, capsys):
    st = _strains()
    strains = [str(write_strains(tmp_path / f"rec{k}.npz", st)) for k in range(2)]
    taus = [str(write_tau(tmp_path / name, st.t, np.zeros((20, 3)))) for name in ("a.npz", "b.npz")]
    assert main(["fit", *strains, "--tau", *taus, "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "do not match" in err and "--pair-by order" in err
    assert not (tmp_path / "m.json").exists()


# --------------------------------------------------------------------------- 4. marker chains
N = 20


def _chain(n_frames=300, noise=(5e-4, 0.0175), seed=0):
    """Poses (T, N + 1, 3) of one constant-strain segment of 0.1 m whose strains vary smoothly."""
    rng = np.random.default_rng(seed)
    tt = np.linspace(0.0, 1.0, n_frames)
    q = np.stack([25 * np.sin(2 * np.pi * tt), 0.05 * np.cos(3 * tt), 0.02 * np.sin(5 * tt)], axis=1)
    poses = forward_kinematics(q, [0.1], np.linspace(0.0, 0.1, N + 1))
    poses[:, 1:, :2] += noise[0] * rng.standard_normal(poses[:, 1:, :2].shape)
    poses[:, 1:, 2] += noise[1] * rng.standard_normal(poses[:, 1:, 2].shape)
    return poses


def test_plausible_chains_pass_even_noisy_ones():
    check_marker_chain(_chain())
    check_marker_chain(_chain(noise=(1.5e-3, np.deg2rad(5.0))))  # 1.5 mm noise on a 5 mm spacing
    check_marker_chain(_chain()[..., :2])  # positions only
    # three markers on a robot bent to the seed's largest curvature (60 1/m): chords turn by 115 degrees
    bent = forward_kinematics(np.tile([60.0, 0.0, 0.0], (5, 1)), [0.1], np.linspace(0.0, 0.1, 4))
    check_marker_chain(bent)
    check_marker_chain(bent[..., :2])
    assert KinematicFusion(total_length=0.1).fit(_chain()).n_segments_ == 1


@pytest.mark.parametrize(
    "case, match",
    [
        ("shuffled", "not in order"),
        ("swapped", r"turns back between markers 5 and 6, 6 and 7"),
        ("duplicated", r"markers 9 and 10 coincide"),
        ("reversed", "from the tip to the base"),
        ("milliradians", r"look like milliradians \(times 0.001"),
        ("degrees", "look like degrees"),
        ("millimetres", r"positions look like millimetres"),
    ],
)
def test_implausible_chains_are_refused_quickly(case, match):
    # before: 7, 2, 2 segments (shuffled after 20 s), 9 segments after 80 s (milliradians), LinAlgError (degrees)
    poses = _chain()
    rng = np.random.default_rng(1)
    bad = {
        "shuffled": lambda P: P[:, np.r_[0, 1 + rng.permutation(N)]],
        "swapped": lambda P: P[:, np.r_[0:5, 6, 5, 7 : N + 1]],
        "duplicated": lambda P: P[:, np.r_[0:10, 9, 11 : N + 1]],
        "reversed": lambda P: P[:, ::-1],
        "milliradians": lambda P: np.concatenate([P[..., :2], 1e3 * P[..., 2:]], axis=-1),
        "degrees": lambda P: np.concatenate([P[..., :2], np.rad2deg(P[..., 2:])], axis=-1),
        "millimetres": lambda P: np.concatenate([1e3 * P[..., :2], P[..., 2:]], axis=-1),
    }[case](poses)
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"X\[0\]: .*" + match):
        KinematicFusion(total_length=None if case == "millimetres" else 0.1).fit(bad)
    assert time.perf_counter() - start < 5.0
    if case in ("shuffled", "swapped", "duplicated", "millimetres"):
        with pytest.raises(ValueError, match=match):
            check_marker_chain(bad[..., :2], name="positions")


# --------------------------------------------------------------------------- 5. controllers
def test_gain_signs_and_gains_that_cannot_regulate():
    fm = linear_model(2e-6, 1e-5, 1.3e-3)
    t = np.arange(20) * 1e-3
    with pytest.raises(ValueError, match=r"kp must be >= 0 .*got -0.001"):
        SetpointRegulator(fm, kp=-1e-3, ki=0.0, kd=1e-4).start([1.0], t)
    with pytest.raises(ValueError, match=r"kd must be >= 0"):
        ComputedTorqueController(fm, kd=[-1.0]).start(StrainReference(np.linspace(0, 1, 8), np.zeros((8, 1))), t)
    with pytest.warns(UserWarning, match="cannot regulate any strain"):
        SetpointRegulator(fm, kp=0.0, ki=0.0, kd=1e-4).start([1.0], t)
    with pytest.warns(UserWarning, match=r"kp\[0, 0\] = -0.001 < 0"):
        SetpointRegulator(fm, kp=[[-1e-3]], ki=1e-2, kd=1e-4).start([1.0], t)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the rule's gains and sensible given ones say nothing
        SetpointRegulator(fm, kp=4e-3, ki=2e-2, kd=1e-4).start([1.0], t)


def test_a_nan_measurement_raises_or_holds_the_last_command():
    fm = linear_model(2e-6, 1e-5, 1.3e-3)
    t = np.arange(10) * 1e-3
    ctrl = SetpointRegulator(fm, kp=4e-3, ki=0.0, kd=1e-4).start([12.0], t)
    u0 = ctrl.command(0, np.array([1.0]), np.array([0.0]))
    # independent: the feed-forward k q* plus kp (q* - q) - kd qd
    np.testing.assert_allclose(u0[0], 1.3e-3 * 12.0 + 4e-3 * 11.0, rtol=1e-12)
    with pytest.raises(ValueError, match=r"control step 1 \(t = 0.001 s\) holds NaN or inf in q.*on_nan='hold'"):
        ctrl.command(1, np.array([np.nan]), np.array([0.0]))
    hold = SetpointRegulator(fm, kp=4e-3, ki=0.0, kd=1e-4, on_nan="hold").start([12.0], t)
    with pytest.raises(ValueError, match="no earlier command to hold"):
        hold.command(0, np.array([np.nan]), np.array([0.0]))
    u0 = hold.command(0, np.array([1.0]), np.array([0.0]))
    np.testing.assert_array_equal(hold.command(1, np.array([1.0]), np.array([np.inf])), u0)
    with pytest.raises(ValueError, match="on_nan must be one of"):
        SetpointRegulator(fm, on_nan="zero").start([12.0], t)
    with pytest.raises(ValueError, match=r"k must be a control step index in \[0, 9\]"):
        hold.command(10, np.array([1.0]), np.array([0.0]))


@pytest.mark.filterwarnings("ignore:the gains do not stabilise")
def test_a_diverging_closed_loop_stops_within_its_budget():
    # before: kp = -0.1 on the diagonal ran for minutes inside the plant's Radau loop
    robot = get_scenario("two_segment").robot
    fm = true_model(robot)
    q_star = plant_equilibrium(robot, np.zeros(6)) + np.array([5.0, 0, 0, -5.0, 0, 0])
    t = np.arange(301) * 1e-3
    robot.advance(q_star, np.zeros(6), np.zeros(6), 1e-3)  # compiled (or loaded) before the clock starts
    start = time.perf_counter()
    with pytest.warns(UserWarning, match="negative gain"), pytest.raises(SimulationError, match="diverged at t ="):
        closed_loop(robot, SetpointRegulator(fm, kp=-0.1 * np.eye(6), kd=1e-4, ki=0.0), q_star, t)
    assert time.perf_counter() - start < 10.0
    plant = LinearPlant(2e-6, 1e-5, 1.3e-3)
    ctrl = SetpointRegulator(linear_model(2e-6, 1e-5, 1.3e-3), kp=4e-3, ki=2e-2, kd=1e-4)
    with pytest.raises(SimulationError, match="overran max_wall_time"):
        closed_loop(plant, ctrl, [12.0], t, q0=np.zeros(3), qd0=np.zeros(3), max_wall_time=1e-9)
    with pytest.raises(ValueError, match="divergence_limit must be"):
        closed_loop(plant, ctrl, [12.0], t, q0=np.zeros(3), qd0=np.zeros(3), divergence_limit=-1)


def test_a_lost_marker_in_one_frame_is_named():
    fusion = KinematicFusion(total_length=0.1).fit(_chain())
    frame = _chain(n_frames=2)[1]
    frame[7, 1] = np.nan
    with pytest.raises(ValueError, match=r"poses\[7, 1\] = nan \(marker 7"):
        fusion.transform_frame(frame)


@pytest.mark.filterwarnings("ignore:the gains do not stabilise")
def test_the_plant_step_budget():
    robot = get_scenario("two_segment").robot
    q = plant_equilibrium(robot, np.zeros(6))
    u = robot.stiffness * np.array([5.0, 0.0, 0.0, -5.0, 0.0, 0.0])
    free = robot.advance(q, np.zeros(6), u, 1e-3, step=5e-4)
    # two fixed steps of 0.5 ms make the period: a budget of 2 gives the same state, 1 stops
    np.testing.assert_array_equal(robot.advance(q, np.zeros(6), u, 1e-3, step=5e-4, max_steps=2)[0], free[0])
    with pytest.raises(SimulationError, match=r"step budget \(max_steps = 1\) ran out"):
        robot.advance(q, np.zeros(6), u, 1e-3, step=5e-4, max_steps=1)
    with pytest.raises(ValueError, match="max_steps must be an integer >= 1"):
        robot.advance(q, np.zeros(6), u, 1e-3, max_steps=0)
    # a diverging loop with no strain limit still ends: within the step budget of its plant
    fm = true_model(robot)
    t = np.arange(301) * 1e-3
    start = time.perf_counter()
    with (
        pytest.warns(UserWarning, match="negative gain"),
        pytest.raises(SimulationError, match=r"step budget \(max_steps = 50\)"),
    ):
        ctrl = SetpointRegulator(fm, kp=-0.1 * np.eye(6), kd=1e-4, ki=0.0)
        closed_loop(robot, ctrl, q + np.array([5.0, 0, 0, -5, 0, 0]), t, divergence_limit=np.inf, max_plant_steps=50)
    assert time.perf_counter() - start < 30.0
