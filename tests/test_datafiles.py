"""The data files of the command line (pcs_sindy.io.data_files): round trips, older files, clear errors.

Files "written before" are made with plain ``np.savez`` and the keys documented
in FILE_FORMATS, independently of the writers under test.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core import PlanarPCS, StrainTrajectory
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.io import (
    FILE_FORMATS,
    DataFileError,
    output_dir,
    read_arrays,
    read_model_file,
    read_poses,
    read_strains,
    read_tau,
    read_training_files,
    write_model_file,
    write_poses,
    write_recording,
    write_strains,
    write_tau,
)

RNG = np.random.default_rng(0)


def _strains(n_frames: int = 30) -> StrainTrajectory:
    t = 0.5 + 1e-3 * np.arange(n_frames)
    q = RNG.normal(size=(n_frames, 6)) * [5.0, 0.05, 0.02, 5.0, 0.05, 0.02]
    active = np.array([[True, True, False], [True, False, True]])
    q[:, ~active.reshape(-1)] = 0.0
    meta = {
        "base_poses": RNG.normal(size=(n_frames, 3)),
        "marker_arc_lengths": np.linspace(0, 0.17, 6),
        "boundaries": np.array([0, 2, 5]),
    }
    return StrainTrajectory(
        q, t, segment_lengths=(0.07, 0.1), active_strains=active, base_pose=(0.01, -0.02, 0.3), metadata=meta
    )


def test_strain_file_round_trip(tmp_path):
    st = _strains()
    back = read_strains(write_strains(tmp_path / "s.npz", st))
    np.testing.assert_array_equal(back.q, st.q)
    np.testing.assert_array_equal(back.t, st.t)
    assert back.segment_lengths == st.segment_lengths
    np.testing.assert_array_equal(back.active_strains, st.active_strains)
    assert back.kinematics.base_pose == pytest.approx(st.kinematics.base_pose)
    for key in ("base_poses", "marker_arc_lengths", "boundaries"):
        np.testing.assert_array_equal(back.metadata[key], st.metadata[key])
    assert back.metadata["source"] == str(tmp_path / "s.npz")
    # the poses the file describes are the trajectory's (closed-form forward kinematics of both)
    s = np.array([0.0, 0.05, 0.17])
    np.testing.assert_allclose(
        back.poses(s),
        PlanarPCS((0.07, 0.1), st.active_strains, (0.01, -0.02, 0.3)).forward_kinematics(st.q, s),
        atol=1e-12,
    )


def test_minimal_older_strain_file_loads(tmp_path):
    """A strain file with only the required keys (and unknown extra keys) still loads, with the documented defaults."""
    q = RNG.normal(size=(20, 3))
    np.savez(tmp_path / "old.npz", t=np.arange(20) * 1e-3, q=q, segment_lengths=np.float64(0.1), comment=np.array(1))
    st = read_strains(tmp_path / "old.npz")
    np.testing.assert_array_equal(st.q, q)
    assert st.segment_lengths == (0.1,) and st.active_strains.all()
    assert st.kinematics.base_pose == (0.0, 0.0, 0.0)


def test_pose_tau_and_recording_round_trips(tmp_path):
    t = np.arange(12) * 1e-3
    poses = RNG.normal(size=(12, 4, 3))
    t_back, poses_back = read_poses(write_poses(tmp_path / "p.npz", t, poses))
    np.testing.assert_array_equal(t_back, t)
    np.testing.assert_array_equal(poses_back, poses)
    tau = RNG.normal(size=(12, 6))
    t_back, tau_back = read_tau(write_tau(tmp_path / "tau.npz", t, tau))
    np.testing.assert_array_equal(tau_back, tau)

    class Rec:  # only the attributes a recording has; qd absent counts as None
        pass

    rec = Rec()
    rec.t, rec.q, rec.tau, rec.poses, rec.poses_true = t, RNG.normal(size=(12, 6)), tau, poses, poses + 1.0
    path = write_recording(tmp_path / "rec.npz", rec)
    with np.load(path) as data:
        assert sorted(data.files) == ["poses", "poses_true", "q", "t", "tau"]
    # a recording is a pose file, a tau file and a truth file at once
    np.testing.assert_array_equal(read_poses(path, "poses_true")[1], poses + 1.0)
    np.testing.assert_array_equal(read_tau(path)[1], tau)
    for key in ("t (T,), poses (T, N+1, 3)", "t (T,), tau (T, 3m)", "segment_lengths (m,)"):
        assert key in FILE_FORMATS


def test_pose_file_without_time_stamps(tmp_path):
    np.savez(tmp_path / "p.npz", poses=np.zeros((5, 3, 3)))
    t, poses = read_poses(tmp_path / "p.npz")
    assert t is None and poses.shape == (5, 3, 3)


def test_training_files_pair_by_stem_then_by_order(tmp_path):
    st = [_strains(), _strains()]
    names = [write_strains(tmp_path / f"rec{k}.npz", s) for k, s in enumerate(st)]
    taus = [RNG.normal(size=(30, 6)) for _ in st]
    (tmp_path / "tau").mkdir()
    by_stem = [
        write_tau(tmp_path / "tau" / f"rec{k}.npz", s.t, u) for k, (s, u) in enumerate(zip(st, taus, strict=True))
    ]
    _, got = read_training_files(names, by_stem[::-1])  # reversed, matched by name
    for a, b in zip(got, taus, strict=True):
        np.testing.assert_array_equal(a, b)
    by_order = [
        write_tau(tmp_path / "tau" / f"other{k}.npz", s.t, u) for k, (s, u) in enumerate(zip(st, taus, strict=True))
    ]
    _, got = read_training_files(names, by_order)
    for a, b in zip(got, taus, strict=True):
        np.testing.assert_array_equal(a, b)


def test_training_files_that_do_not_belong_together(tmp_path):
    st = _strains()
    name = write_strains(tmp_path / "s.npz", st)
    with pytest.raises(DataFileError, match="5 force columns"):
        read_training_files([name], [write_tau(tmp_path / "a.npz", st.t, np.zeros((30, 5)))])
    with pytest.raises(DataFileError, match="29 samples"):
        read_training_files([name], [write_tau(tmp_path / "b.npz", st.t[:29], np.zeros((29, 6)))])
    rate = 1.0 / float(np.median(np.diff(st.t)))
    with pytest.raises(DataFileError, match=rf"half a sample: .* at {rate:.6g} Hz, the tau at {rate / 1.5:.6g} Hz"):
        read_training_files([name], [write_tau(tmp_path / "c.npz", st.t * 1.5, np.zeros((30, 6)))])
    with pytest.raises(DataFileError, match="1 strain file.*2 tau file"):
        read_training_files([name], [tmp_path / "a.npz", tmp_path / "b.npz"])


def test_unreadable_files_name_the_file_and_the_problem(tmp_path):
    with pytest.raises(FileNotFoundError, match="pose file .*nope.npz' does not exist"):
        read_poses(tmp_path / "nope.npz")
    np.savez(tmp_path / "x.npz", x=np.zeros(3))
    with pytest.raises(DataFileError, match=r"lacks \['t', 'tau'\] \(found \['x'\]\)"):
        read_tau(tmp_path / "x.npz")
    np.save(tmp_path / "single.npy", np.zeros(3))
    with pytest.raises(DataFileError, match="single .npy array"):
        read_arrays(tmp_path / "single.npy", ["t"], "tau file")
    (tmp_path / "text.npz").write_text("not an npz")
    with pytest.raises(DataFileError, match="cannot read strain file"):
        read_strains(tmp_path / "text.npz")
    np.savez(tmp_path / "bad.npz", poses=np.zeros((5, 3)))
    with pytest.raises(DataFileError, match=r"\(T, N \+ 1, 3\)"):
        read_poses(tmp_path / "bad.npz")
    np.savez(tmp_path / "badq.npz", t=np.arange(4.0), q=np.zeros((4, 5)), segment_lengths=[0.1])
    with pytest.raises(DataFileError, match="strain file .*badq.npz"):
        read_strains(tmp_path / "badq.npz")
    np.savez(tmp_path / "objects.npz", t=np.array([None, 1], dtype=object), tau=np.zeros((2, 3)))
    with pytest.raises(DataFileError, match="cannot read tau file"):  # object arrays need pickle: refused
        read_tau(tmp_path / "objects.npz")
    (tmp_path / "file").write_text("")
    with pytest.raises(DataFileError, match="not writable"):
        output_dir(tmp_path / "file" / "sub")


def test_model_files_are_checked_for_their_class(tmp_path):
    from pcs_sindy.identification import EulerLagrangeRegressor

    fusion = KinematicFusion(threshold=0.3)
    path = write_model_file(fusion, tmp_path / "segmentation.json")
    assert read_model_file(path, KinematicFusion, "segmentation file").get_params() == fusion.get_params()
    with pytest.raises(DataFileError, match="holds a KinematicFusion, not a EulerLagrangeRegressor"):
        read_model_file(path, EulerLagrangeRegressor)
    with pytest.raises(FileNotFoundError, match="model file"):
        read_model_file(tmp_path / "none.json", EulerLagrangeRegressor)


def test_folders_fifos_and_devices_are_named_for_what_they_are(tmp_path):
    """Not "does not exist" for what exists (issue 27): a folder, a FIFO (whose read would hang), /dev/zero."""
    import os

    from pcs_sindy.io import read_poses

    (tmp_path / "poses.npz").mkdir()
    with pytest.raises(DataFileError, match="is a folder, not a file"):
        read_poses(tmp_path / "poses.npz")
    fifo = tmp_path / "pipe.npz"
    os.mkfifo(fifo)
    with pytest.raises(DataFileError, match="FIFO"):
        read_poses(fifo)  # returns at once: a read would wait for a writer forever
    if os.path.exists("/dev/zero"):
        with pytest.raises(DataFileError, match="a device"):
            read_poses("/dev/zero")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_poses(tmp_path / "missing.npz")
