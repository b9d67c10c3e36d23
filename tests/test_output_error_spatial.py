"""Output-error refinement of spatial (3-D) fits: the truth is a fixed point, noisy markers move it toward the truth.

Independent truth: the spatial simulator (:class:`~pcs_sindy.simulation.spatial_dynamics.SpatialPCSRobot`, its own
compiled kernels, adaptive Radau), and the true coefficients of its material
(``SpatialPhysicalPCSLibrary.coefficients_from_parameters``).  Markers as a capture places them: two per disc, off
the backbone along body x and z (so torsion is seen), four discs.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcs_sindy.core.spatial import SpatialStrainTrajectory
from pcs_sindy.fusion import fit_spatial_strains
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.identification.library.spatial_physical import SpatialPhysicalPCSLibrary
from pcs_sindy.identification.output_error import refine_output_error
from pcs_sindy.models.actuation import actuation_from_layout
from pcs_sindy.simulation.spatial_dynamics import SpatialPCSRobot

RHO, E, G, R, L = 1070.0, 1e4, 1e3, 0.02, 0.1
DAMP = np.array([3e-5, 3e-5, 2e-5, 0.15, 0.15, 0.15])
SCALE = np.array([1e-3, 1e-3, 3e-4, 0.05, 0.05, 0.1])  # forces on every strain, as the spatial benchmark
DT = 0.01
DISCS = np.linspace(0.0, L, 5)[1:]
OFFSETS = np.tile([[R, 0.0], [0.0, R]], (DISCS.size, 1))  # body x, body z
ARCS = np.repeat(DISCS, 2)


def _inputs(rng, t):
    f = rng.uniform(0.3, 3.0, (3, 6))
    ph = rng.uniform(0.0, 2 * np.pi, (3, 6))
    return SCALE * np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None]).sum(axis=1) / 2


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(7)
    rob = SpatialPCSRobot([L], RHO, E, G, DAMP, radius=R)
    t = np.arange(0.0, 3.0, DT)
    U = [_inputs(rng, t) for _ in range(3)]
    Q = [rob.simulate(np.zeros(6), np.zeros(6), t, u).q for u in U]
    return rob, t, U, Q


def test_the_truth_is_a_fixed_point_of_the_spatial_refinement(data):
    # noise-free markers and the true coefficients as the start: nothing to improve, so the refinement must stay
    # there.  A fixed step of one sample period is 0.1 mm off the exact rollout here: a refinement that fits its own
    # integration error moves the stiffnesses and densities away from the truth (noise-free 0.005 -> 0.18 mm)
    rob, t, U, Q = data
    lib = SpatialPhysicalPCSLibrary([L]).fit(np.zeros((1, 12)))
    truth = lib.coefficients_from_parameters(RHO, R, E, G, DAMP)
    act = actuation_from_layout(None).fit(lib.kinematics)
    # the Savitzky-Golay-like rate of a rest start is not zero: the refinement fits the start states
    recs = [(t, q, (q[1] - q[0]) / DT, u, np.ones(t.size, bool)) for q, u in zip(Q, U, strict=True)]
    arcs = np.r_[0.0, ARCS]
    coef, _, info = refine_output_error(
        lib, truth, act, recs, lib.kinematics, arcs, None, free_density=True, marker_offsets=OFFSETS
    )
    assert info["rmse"] <= info["rmse_start"] < 2e-6  # metres: the markers follow to a few micrometres
    names = lib.coefficient_names()
    physical = [j for j, nm in enumerate(names) if not nm.startswith("f0_")]
    np.testing.assert_allclose(coef[physical], truth[physical], rtol=2e-3)
    f0 = [j for j, nm in enumerate(names) if nm.startswith("f0_")]
    # rest forces: 0 in truth; against the input forces' scale
    assert np.all(np.abs(coef[f0]) < 1e-3 * np.max(np.abs(np.concatenate(U)), axis=0)[: len(f0)])


def test_noisy_markers_move_the_parameters_toward_the_truth(data):
    # 0.5 mm noise on the markers, strains fitted back per frame (the package's spatial fusion fit): the equation-error
    # fit regresses noisy rates (errors in variables); the rollouts compared with the markers are not differentiated
    rob, t, U, Q = data
    rng = np.random.default_rng(3)
    X = []
    for q in Q:
        p, rot = rob.kinematics.forward_kinematics(q, DISCS)
        body = np.stack([[R, 0.0, 0.0], [0.0, 0.0, R]])
        markers = p[:, :, None, :] + np.einsum("tkab,jb->tkja", rot, body)
        markers = markers.reshape(t.size, -1, 3) + rng.normal(0.0, 5e-4, (t.size, ARCS.size, 3))
        est, _ = fit_spatial_strains(
            markers, np.eye(3), np.zeros(3), [L], ARCS, active=np.ones((1, 6), bool), offsets=OFFSETS
        )
        meta = {"marker_arc_lengths": np.r_[0.0, ARCS], "marker_offsets": OFFSETS}
        X.append(SpatialStrainTrajectory(est, t, segment_lengths=[L], metadata=meta))
    fits = {
        refine: EulerLagrangeRegressor(weak_window=45, refine=refine).fit(X, U) for refine in ("none", "output_error")
    }
    ref = fits["output_error"]
    truth = ref.full_library_.coefficients_from_parameters(RHO, R, E, G, DAMP)
    names = ref.full_library_.coefficient_names()
    cols = [j for j, nm in enumerate(names) if nm.startswith(("rhoA", "k_"))]
    err = {k: np.sqrt(np.mean(np.log(np.abs(f.coef_[cols] / truth[cols])) ** 2)) for k, f in fits.items()}
    assert ref.refinement_["kept"] == "refined"
    assert err["output_error"] < 0.5 * err["none"]


def test_noise_detector_tells_per_frame_noise_from_a_smooth_recording(data):
    # refine="auto" refines spatial fits with inputs in physical units only on noisy strains: white noise's third
    # differences are sqrt(10/3) x its second ones, a smooth signal's about omega dt x
    from pcs_sindy.identification.output_error import strains_are_noisy

    _, t, _, Q = data
    assert not strains_are_noisy(Q)
    rng = np.random.default_rng(0)
    # 1 % of each strain's spread per frame: above the second differences of 0.3-3 Hz motion at 100 Hz
    assert strains_are_noisy([q + 1e-2 * q.std(axis=0) * rng.standard_normal(q.shape) for q in Q])
    assert not strains_are_noisy([q + 1e-4 * q.std(axis=0) * rng.standard_normal(q.shape) for q in Q])
    assert strains_are_noisy([rng.standard_normal((50, 3))]) and not strains_are_noisy([np.zeros((3, 2))])
