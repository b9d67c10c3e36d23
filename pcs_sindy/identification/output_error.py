"""Output-error refinement of an identified model: its few physical parameters fitted to rollouts.

The equation-error fit (:mod:`.formulations`) regresses differentiated strains,
and on a lightly damped robot driven by steps its damping, its stiffness and
its input gains come out biased (noise in the rates, a rate-dependent input
map): rolled out open loop it drifts.  :func:`refine_output_error` starts from
that fit and adjusts stiffness, damping, rotary inertia, rest forces and the
input gains so that the rollouts of the training recordings from their first
sample follow the recorded markers (``scipy.optimize.least_squares``; the
compiled rollouts make each one a few tens of ms for 50 s at 100 Hz).

The refined model is stable by construction:

* **mass matrix** positive definite: the line densities are fixed (uniform over
  the segments, at the fit's total mass: under the scale convention of
  :class:`~pcs_sindy.identification.EulerLagrangeRegressor` 1 kg) or, for inputs
  in physical units (``free_density``), refined from that start with each
  ``>= 0``; rotary inertia ``>= 0``;
* **damping** and **stiffness** ``>= 0`` (bounds);
* **input map from a potential**: a learned map's ``u * q`` terms are tied
  symmetric (``tau = -d/dq sum_k u_k (a_k^T q + 1/2 q^T B_k q)``), so a held
  input adds a conservative force and the model stays passive;
* **stiffness under input** ``K - sum_k u_k B_k`` positive definite (smallest
  eigenvalue at least :data:`STIFFNESS_MARGIN` of the smallest stiffness) at
  every vertex of the training input box, a penalty in the fit and enforced
  afterwards by shrinking the ``B_k`` (gravity's stiffness is left out: it is
  positive about the hanging pose, so the condition is conservative there).

A spatial fit (:class:`~pcs_sindy.core.SpatialPCS`) from positions alone carries one weight vector
``rhoA g`` of unknown direction (``identify_gravity="shared"``): its magnitude is set to the line density
times the library's ``|g|`` and its direction refined (two angles); the fit also starts from rest forces
that balance the recordings' mean shape under their mean input when that rollout is better, refines its
``u*q`` gains along :data:`SPATIAL_SLOPE_DIRECTIONS` leading input direction(s) and stops after about
:data:`SPATIAL_ROLLOUT_BUDGET` rollouts (spatial models have many more strain pairs than planar ones).  A spatial
refinement compares the markers themselves (off the backbone they see torsion; orientations too when measured),
rolls out with a step fine enough that the fit does not absorb the integrator's error, starts each recording from
the better of its first frame's rate and rest, and returns the equation-error fit when that follows the training
markers better at the forward model's own tolerances.

Internal to :class:`~pcs_sindy.identification.EulerLagrangeRegressor`
(``refine="output_error"``).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..core.simulate_contract import DivergenceError
from ..core.spatial import SpatialPCS

__all__ = [
    "refine_output_error",
    "input_stiffness",
    "input_directions",
    "STIFFNESS_MARGIN",
    "INPUT_RANK_TOL",
    "MAX_VERTICES",
    "SPATIAL_SLOPE_DIRECTIONS",
    "SPATIAL_ROLLOUT_BUDGET",
    "STEP_TOLERANCE",
    "ORIENTATION_LENGTH",
    "NOISE_DIFFERENCE_RATIO",
    "strains_are_noisy",
]

#: smallest eigenvalue of ``K - sum_k u_k B_k`` required at the training input box's vertices,
#: relative to the smallest stiffness: a held input may soften the robot, never to a buckling point
STIFFNESS_MARGIN = 0.1
#: input directions with a singular value below this fraction of the largest are not excited: their gains
#: keep the equation-error value (steps of all servos together excite one direction and the servos' noise)
INPUT_RANK_TOL = 0.02
#: a spatial model's learned ``u*q`` gains (21 symmetric pairs of strains on 3 bending segments, against 6 in the
#: plane) are refined along this many leading input directions; the constant gains along all excited ones.  Each
#: refined parameter costs one rollout of every training recording per step of the fit
SPATIAL_SLOPE_DIRECTIONS = 1
#: a spatial refinement stops after about this many rollouts of the training recordings (finite-difference Jacobians
#: included: one per refined parameter and step), at least 10 steps: a compiled spatial rollout of 75 s at 100 Hz
#: takes about 0.3 s, so this is minutes where the planar model's 60 steps are
SPATIAL_ROLLOUT_BUDGET = 1500
#: spatial rollouts use a fixed step, halved from the sample period while halving it moves the markers by more than
#: this fraction of the start model's marker RMS misfit ...
STEP_TOLERANCE = 0.01
#: ... and more than this fraction of the robot's length [m / m] (noise-free data: a misfit near zero) ...
STEP_FLOOR = 1e-5
#: ... at most this many times (an eighth of the sample period)
MAX_STEP_HALVINGS = 3
#: ... after the first solve, only while the budget left pays for this many iterations at the halved step
MIN_RESOLVE_ITERATIONS = 3
#: a rotation compared (``orientations``) counts like markers at this distance [m] from the backbone: the spatial
#: fusion's default weighting of positions against orientations (0.5 mm against 1 degree)
ORIENTATION_LENGTH = 5e-4 / float(np.deg2rad(1.0))
#: ``refine="auto"`` refines a spatial fit with inputs in physical units when its strains carry per-frame noise: the
#: median over strains of ``median|third differences| / median|second differences|`` exceeds this.  White noise gives
#: ``sqrt(10/3) = 1.83``, a smooth signal about ``omega dt`` (spatial benchmark, 100 Hz: 0.16 noise-free, 1.8-1.9 with
#: 0.5 mm marker noise); on noise-free data the equation-error fit is already exact and a refinement only costs time
NOISE_DIFFERENCE_RATIO = 1.0
#: above this many inputs the box's vertices (2^p) are replaced by its training samples' extremes
MAX_VERTICES = 256
#: a stiffness margin missed by the whole smallest stiffness costs like this marker RMS [m] over the recordings
_PENALTY_SCALE = 0.1


def strains_are_noisy(strains: Sequence[NDArray[np.float64]]) -> bool:
    """Whether the recordings' strains (each (T, n)) carry per-frame noise (:data:`NOISE_DIFFERENCE_RATIO`)."""
    ratios = []
    for q in strains:
        q = np.asarray(q, dtype=float)
        if q.shape[0] < 4:
            continue
        d2 = np.median(np.abs(np.diff(q, 2, axis=0)), axis=0)
        d3 = np.median(np.abs(np.diff(q, 3, axis=0)), axis=0)
        ratios.append(np.where(d2 > 0, d3 / np.where(d2 > 0, d2, 1.0), 0.0))
    return bool(ratios) and float(np.median(np.median(ratios, axis=0))) > NOISE_DIFFERENCE_RATIO


def _box_vertices(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vertices of the box ``[lo, hi]`` (inputs that never vary give one value, not two)."""
    axes = [np.unique([a, b]) for a, b in zip(lo, hi, strict=True)]
    n = int(np.prod([a.size for a in axes]))
    if n > MAX_VERTICES:  # pragma: no cover - robots with more than 8 varying inputs
        return np.stack([lo, hi])
    return np.asarray(list(itertools.product(*axes)), dtype=float)


def _slope_blocks(act: Any, gains: NDArray[np.float64], n: int) -> tuple[NDArray, NDArray] | None:
    """``B_k`` of a learned map (n, n) per input, for the input itself and its positive part; None if no ``u*q``."""
    idx = getattr(act, "_arrays", {}).get("index")
    if idx is None or act.kind != "learned":
        return None
    p = act.n_inputs_
    blocks = np.zeros((2, p, n, n))
    for (a, k, b, part), g in zip(idx, gains, strict=True):
        if b >= 0:
            blocks[part, k, a, b] += g
    return blocks[0], blocks[1]


def input_stiffness(
    stiffness: NDArray[np.float64], act: Any, gains: NDArray[np.float64], u: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Smallest eigenvalue of ``K - sum_k (u_k B_k + max(0, u_k) P_k)`` for each row of ``u`` (B,).

    ``B_k``, ``P_k``: the ``u*q`` and ``pull*q`` blocks of a learned input map
    (``tau = ... + B_k q u_k``, so the input stiffens by ``-B_k u_k``).
    """
    k = np.asarray(stiffness, dtype=float)
    n = k.size
    blocks = _slope_blocks(act, gains, n)
    u = np.atleast_2d(np.asarray(u, dtype=float))
    if blocks is None:
        return np.full(u.shape[0], float(k.min()))
    b_lin, b_pull = blocks
    mats = np.diag(k)[None] - np.einsum("bk,kij->bij", u, b_lin) - np.einsum("bk,kij->bij", np.maximum(u, 0.0), b_pull)
    mats = 0.5 * (mats + np.swapaxes(mats, 1, 2))
    return np.linalg.eigvalsh(mats)[:, 0]


class _Layout:
    """Which coefficients and gains the refinement moves, and how they map to the free vector.

    A learned map's gains are refined only along the input directions the
    training data excited (``directions``, p x r: the inputs' principal
    directions down to :data:`INPUT_RANK_TOL` of the largest); the gains'
    components outside them keep their starting value (the data do not
    determine them).  Its ``u*q`` gains are tied symmetric.
    """

    def __init__(
        self,
        lib: Any,
        coef: NDArray[np.float64],
        act: Any,
        gains: NDArray[np.float64],
        directions: NDArray | None,
        free_density: bool = False,
    ) -> None:
        names = list(lib.coefficient_names())
        self.coef0 = np.asarray(coef, dtype=float).copy()
        lengths = np.asarray(lib.kinematics.segment_lengths, dtype=float)
        rho = [j for j, nm in enumerate(names) if nm.startswith("rhoA_")]
        if "rhoA" in names:  # one line density for the whole robot (a uniform library): already what is wanted
            rho = [names.index("rhoA")]
            if not self.coef0[rho[0]] > 0:
                self.coef0[rho[0]] = 1.0 / lengths.sum()
        elif len(rho) == lengths.size and not (
            free_density and isinstance(lib.kinematics, SpatialPCS) and np.all(self.coef0[rho] > 0)
        ):
            # uniform line density at the fit's total mass: positive, and what the convention states (a spatial fit
            # with free densities starts where the equation-error fit put them when they are positive)
            total = float(np.sum(self.coef0[rho] * lengths))
            if not total > 0:
                total = 1.0
            self.coef0[rho] = total / lengths.sum()
        self.rho = float(self.coef0[rho].mean()) if rho else 1.0
        g0 = np.asarray(gains, dtype=float).copy()
        # one weight vector rhoA g shared by all segments (a spatial fit from positions alone): its direction is
        # refined (two angles about the equation-error direction), its magnitude is the line density times the
        # library's |g|.  The equation-error fit leaves the magnitude loose; all its static forces are scaled with it
        # (stiffness, rest forces, gains; damping by the square root: the same motion, only faster or slower), so
        # the start keeps the fit's equilibria
        self.gcols = [names.index(f"rhoAg{a}") for a in "xyz"] if all(f"rhoAg{a}" in names for a in "xyz") else []
        if self.gcols:
            g_fit = self.coef0[self.gcols]
            g_lib = np.asarray(getattr(lib, "gravity", (0.0, 9.81, 0.0)), dtype=float)
            weight = self.rho * float(np.linalg.norm(g_lib))
            norm = float(np.linalg.norm(g_fit))
            self.n0 = g_fit / norm if norm > 0 else g_lib / np.linalg.norm(g_lib)
            scale = weight / norm if norm > 0 else 1.0
            rest = np.asarray(getattr(lib, "rest_force_index_", []), dtype=int)
            self.coef0[np.r_[lib.stiffness_index_, rest].astype(int)] *= scale
            self.coef0[np.asarray(lib.damping_index_, dtype=int)] *= np.sqrt(scale)
            g0 *= scale
            self.coef0[self.gcols] = weight * self.n0
            self.weight = weight
            # an orthonormal pair perpendicular to the start direction
            e = np.linalg.svd(self.n0[None, :])[2][1:]
            self.e1, self.e2 = e[0], e[1]
        # inputs in physical units (no scale convention, no given mass): the line densities are determined by the
        # data and refined, each bounded below by 0 (they start uniform at the fit's total mass, positive)
        free_rho = free_density and not self.gcols
        self.free = [
            j
            for j, nm in enumerate(names)
            if not (nm.startswith("rhoAg") or (not free_rho and (nm == "rhoA" or nm.startswith("rhoA_"))))
        ]
        lower = [0.0 if names[j].startswith(("rhoI_", "k_", "d_", "rhoA")) else -np.inf for j in self.free]
        self.stiff = np.asarray(lib.stiffness_index_, dtype=int)
        self.damp = np.asarray(lib.damping_index_, dtype=int)
        self.n_coef = len(self.free)
        idx = getattr(act, "_arrays", {}).get("index") if act.kind == "learned" else None
        p = int(act.n_inputs_)
        # types: per (row kind) one vector over the inputs of index lists; symmetric u*q entries share one
        types: dict = {}
        own = []
        for j in range(g0.size):
            if idx is None:
                own.append(j)
                continue
            a, k, b, part = (int(v) for v in idx[j])
            key = ("c", a, part) if b < 0 else ("s", min(a, b), max(a, b), part)
            types.setdefault(key, [[] for _ in range(p)])[k].append(j)
        self.own = own
        self.types = list(types.values())
        self.dirs = np.eye(p) if directions is None else np.asarray(directions, dtype=float)
        spatial = isinstance(lib.kinematics, SpatialPCS)
        self.type_dirs = [
            self.dirs[:, :SPATIAL_SLOPE_DIRECTIONS] if spatial and key[0] == "s" else self.dirs for key in types
        ]
        # start: symmetric pairs averaged; the part outside the refined directions is kept as it is
        self.base, z0 = [], []
        for lists, dirs in zip(self.types, self.type_dirs, strict=True):
            vec = np.array([g0[lst].mean() if lst else 0.0 for lst in lists])
            z = dirs.T @ vec
            self.base.append(vec - dirs @ z)
            z0.append(z)
        self.gains0 = g0
        self.n_angles = 2 if self.gcols else 0
        self.x0 = np.r_[
            self.coef0[self.free], g0[own], np.concatenate(z0) if z0 else np.zeros(0), np.zeros(self.n_angles)
        ]
        self.lower = np.r_[lower, np.full(self.x0.size - self.n_coef, -np.inf)]

    def unpack(self, x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        coef = self.coef0.copy()
        coef[self.free] = x[: self.n_coef]
        gains = self.gains0.copy()
        pos = self.n_coef
        gains[self.own] = x[pos : pos + len(self.own)]
        pos += len(self.own)
        for lists, base, dirs in zip(self.types, self.base, self.type_dirs, strict=True):
            vec = base + dirs @ x[pos : pos + dirs.shape[1]]
            pos += dirs.shape[1]
            for k, lst in enumerate(lists):
                gains[lst] = vec[k]
        if self.n_angles:
            n = self.n0 + x[pos] * self.e1 + x[pos + 1] * self.e2
            coef[self.gcols] = self.weight * n / np.linalg.norm(n)
        return coef, gains

    def pack(self, coef: NDArray[np.float64], gains: NDArray[np.float64]) -> NDArray[np.float64]:
        z = [
            dirs.T @ np.array([gains[lst].mean() if lst else 0.0 for lst in lists])
            for lists, dirs in zip(self.types, self.type_dirs, strict=True)
        ]
        angles = np.zeros(self.n_angles)
        if self.n_angles:
            n = coef[self.gcols] / np.linalg.norm(coef[self.gcols])
            n = n / (n @ self.n0)
            angles = np.array([n @ self.e1, n @ self.e2])
        return np.r_[coef[self.free], gains[self.own], np.concatenate(z) if z else np.zeros(0), angles]


def input_directions(u: NDArray[np.float64], tol: float | None = None) -> NDArray[np.float64]:
    """Directions (p, r) in which the inputs ``u`` (T, p) vary: principal directions of the centred inputs
    down to ``tol`` of the largest singular value.  A constant input (or combination) acts like the
    model's constant force ``f0`` and cannot be told from it."""
    tol = INPUT_RANK_TOL if tol is None else tol
    u = np.asarray(u, dtype=float)
    _, sv, vt = np.linalg.svd(u - u.mean(axis=0), full_matrices=False)
    if not sv.size or not sv[0] > 0:
        return np.zeros((u.shape[1], 0))
    return vt[sv > tol * sv[0]].T


def _enforce_margin(
    lib: Any, coef: NDArray, act: Any, gains: NDArray, vertices: NDArray, layout: _Layout
) -> tuple[NDArray, NDArray, float]:
    """Shrink the ``u*q`` gains until the stiffness margin holds at every vertex; returns the factor used."""
    k = np.asarray(lib.stiffness_from_coef(coef), dtype=float)
    need = STIFFNESS_MARGIN * max(float(k.min()), 0.0)
    blocks = _slope_blocks(act, gains, k.size)
    if blocks is None or np.all(input_stiffness(k, act, gains, vertices) >= need):
        return coef, gains, 1.0
    idx = act._arrays["index"]
    slope = idx[:, 2] >= 0
    lo, hi = 0.0, 1.0
    for _ in range(40):  # bisection on the factor: the margin is monotone along the segment to B = 0
        mid = 0.5 * (lo + hi)
        g = gains.copy()
        g[slope] *= mid
        if np.all(input_stiffness(k, act, g, vertices) >= need):
            lo = mid
        else:
            hi = mid
    g = gains.copy()
    g[slope] *= lo
    return coef, g, lo


def _model_forces(
    act: Any, kin: Any, q: NDArray[np.float64], u: NDArray[np.float64], gains: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The input forces on the model's strains at one state ``q`` (1, n) of them: the actuation may be fitted to more
    strains than the model keeps (strains removed as not excited are held at 0), so ``q`` is spread over its strains
    and the forces are read back on the model's."""
    k_act = getattr(act, "kinematics_", kin)
    if k_act.n_active == kin.n_active:
        return np.asarray(act.forces(q, u, gains), dtype=float)[0]
    full = np.zeros((1, kin.n_q))
    full[:, kin.active_mask] = q
    forces = np.zeros(kin.n_q)
    forces[k_act.active_mask] = np.asarray(act.forces(full[:, k_act.active_mask], u, gains), dtype=float)[0]
    return forces[kin.active_mask]


def _balanced_start(
    lib: Any, layout: _Layout, act: Any, x: NDArray[np.float64], recordings: Sequence[tuple]
) -> NDArray[np.float64] | None:
    """``x`` with the rest forces ``f0`` that make the recordings' mean strain an equilibrium under their mean input
    (None when some modelled strain has no rest force)."""
    rest = np.asarray(getattr(lib, "rest_force_index_", []), dtype=int)
    rows = np.asarray(getattr(lib, "rest_force_rows_", []), dtype=int)
    q = np.concatenate([r[1] for r in recordings])
    n = q.shape[1]
    if rest.size != n or not np.array_equal(np.sort(rows), np.arange(n)):
        return None
    u = np.concatenate([r[3] for r in recordings])
    q_mean, u_mean = q.mean(axis=0)[None], u.mean(axis=0)[None]
    coef, gains = layout.unpack(x)
    static = np.asarray(lib.bias_forces(q_mean, np.zeros_like(q_mean), coef), dtype=float)[0]  # G + K q - f0
    f0 = np.zeros(n)
    f0[rows] = coef[rest]
    need = static + f0 - _model_forces(act, lib.kinematics, q_mean, u_mean, gains)
    coef = coef.copy()
    coef[rest] = need[rows]
    return layout.pack(coef, gains)


def _spatial_starts(
    fm: Any, recordings: Sequence[tuple], shapes: Any, targets: list, mask: NDArray
) -> list[tuple[NDArray, NDArray]]:
    """Initial states (q0, qd0) of the recordings: the first frame's strains, at its Savitzky-Golay rate or at rest,
    whichever the start model's rollout of the whole recording at its default tolerances follows better.

    The rate at the edge is biased (a rest start reads as 5-16 1/s on the spatial benchmark's noise-free force data).
    States fitted to the first half second of markers were tried and dropped: they absorb the start model's errors in
    its stiff modes, which a fixed-step rollout damps and an accurate one rings (noisy forces: 0.30 -> 0.65 mm)."""
    starts = []
    for (t, q, qd0, u, valid), tg in zip(recordings, targets, strict=True):
        n = q.shape[1]

        def cost(v: NDArray, t=t, q=q, u=u, valid=valid, tg=tg) -> float:
            try:
                sim = fm.simulate(q[0], v, t, u, max_abs_state=1e4)
                r = shapes(sim.q[:, mask])[valid] - tg
            except (DivergenceError, np.linalg.LinAlgError, ValueError):
                return np.inf
            return float(np.sum(r**2)) if np.all(np.isfinite(r)) else np.inf

        starts.append((q[0], min([np.asarray(qd0, dtype=float), np.zeros(n)], key=cost)))
    return starts


def refine_output_error(
    lib: Any,
    coef: NDArray[np.float64],
    act: Any,
    recordings: Sequence[tuple[NDArray, NDArray, NDArray, NDArray, NDArray]],
    kinematics: Any,
    arc_lengths: NDArray[np.float64],
    input_box: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    *,
    max_nfev: int = 60,
    free_density: bool = False,
    marker_offsets: NDArray[np.float64] | None = None,
    orientations: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict]:
    """Fit the physical parameters to open-loop rollouts of the training recordings.

    Spatial fits (:class:`~pcs_sindy.core.SpatialPCS`) also choose each recording's initial state
    (:func:`_spatial_starts`), roll out with a fixed step halved from the sample period while halving it moves the
    markers by more than :data:`STEP_TOLERANCE` of the start's misfit (and :data:`STEP_FLOOR` of the robot's length),
    and keep the equation-error fit unless the refined model's rollouts of the training recordings at the forward
    model's default tolerances follow the markers better (a refinement never makes a fit worse on its own objective).

    Parameters
    ----------
    lib : LagrangianLibrary
        The fitted (physical) library of the model's strains.
    coef : ndarray
        The equation-error coefficients (the start).
    act : Actuation
        The fitted input map; its gains are refined (the instance is left with the refined ones).
    recordings : sequence of (t, q, qd0, u, valid)
        Per recording: times (T,), modelled strains (T, n), the initial rate (n,),
        inputs (T, p) and which samples to compare (T,) bool.
    kinematics : PlanarPCS or SpatialPCS
        The model's segmentation (marker positions of strains).
    arc_lengths : ndarray
        Arc lengths at which rolled-out and recorded shapes are compared (the markers').
    input_box : (lower, upper) or None
        The training inputs' range: the stiffness margin holds at its vertices.
    max_nfev : int
        Function evaluations of ``least_squares`` (each one a rollout of every recording).
    free_density : bool
        Refine the line densities too (each ``>= 0``, from the uniform start): for inputs in physical units,
        where the data determine the mass.  False (under the scale convention or a given mass) keeps them
        uniform at the fit's total mass.
    marker_offsets : ndarray, shape (K, 2) or (K - 1, 2), optional
        Spatial: the markers' offsets from the backbone along body x and z (the fusion's ``marker_offsets``;
        one row fewer than ``arc_lengths`` when those start with the base): a marker off the backbone sees torsion.
    orientations : bool
        Spatial: also compare the frames at ``arc_lengths`` (the capture measured orientations), their axes
        scaled by :data:`ORIENTATION_LENGTH`.

    Returns
    -------
    coef, gains : ndarray
    info : dict
        ``rmse_start``, ``rmse`` [m] of the compared markers (spatial: both at the forward model's default
        tolerances, ``rmse_start`` of the equation-error fit, ``inf`` when its rollouts diverge), ``nfev`` (over
        all solves), ``slope_factor``
        (1 unless the ``u*q`` gains were shrunk to hold the margin) and ``n_vertices``; spatial also ``step``
        [s] of the rollouts, ``kept`` (``"refined"`` or ``"equation_error"``), ``starts``, the recordings'
        initial states (modelled strains, rates) of those rollouts, ``solves``, (step [s], function
        evaluations) of each ``least_squares`` run (one more per halving of the step after the first).
    """
    u_all = np.concatenate([u for (_, _, _, u, _) in recordings])
    layout = _Layout(
        lib, coef, act, act.gains_, input_directions(u_all) if act.kind == "learned" else None, free_density
    )
    gains_given = np.asarray(act.gains_, dtype=float).copy()
    mask = kinematics.active_mask
    s = np.asarray(arc_lengths, dtype=float)
    vertices = np.zeros((0, act.n_inputs_)) if input_box is None else _box_vertices(*input_box)
    spatial = isinstance(kinematics, SpatialPCS)
    offsets = None if marker_offsets is None else np.asarray(marker_offsets, dtype=float).reshape(-1, 2)
    if offsets is not None and offsets.shape[0] == s.size - 1:  # the fusion's arc lengths start with the base
        offsets = np.vstack([np.zeros((1, 2)), offsets])
    if offsets is not None and offsets.shape[0] != s.size:
        raise ValueError(f"marker_offsets must hold one row per arc length ({s.size}); got shape {offsets.shape}")

    def shapes(q: NDArray) -> NDArray:
        full = np.zeros((q.shape[0], kinematics.n_q))
        full[:, mask] = q
        poses = kinematics.forward_kinematics(full, s)
        if not isinstance(poses, tuple):  # planar: (T, K, 3) poses (x, y, theta), the positions compared
            return poses[:, :, :2]
        pos, rot = poses
        if offsets is not None:  # the markers themselves: off the backbone they turn with the cross-section
            pos = pos + rot[..., 0] * offsets[:, :1] + rot[..., 2] * offsets[:, 1:]
        if orientations:
            pos = np.concatenate([pos, ORIENTATION_LENGTH * rot.reshape(q.shape[0], -1, 3)], axis=1)
        return pos

    targets = [shapes(q)[valid] for (_, q, _, _, valid) in recordings]
    n_res = sum(tg.size for tg in targets)
    dt = float(min(np.min(np.diff(t)) for (t, *_) in recordings))
    starts = [(q[0], qd0) for (_, q, qd0, _, _) in recordings]

    def rollouts(c: NDArray, g: NDArray, step: float | None, at: list) -> list[NDArray]:
        """Marker residuals per recording (1 m everywhere where a rollout diverges); ``step`` None: adaptive."""
        fm = lib.forward_model(c, actuation=act.set_identified(g, act.offsets_))
        out = []
        for (t, _, _, u, valid), tg, (q0, v0) in zip(recordings, targets, at, strict=True):
            try:
                kw = {} if step is None else {"step": step}
                sim = fm.simulate(q0, v0, t, u, max_abs_state=1e4, **kw)
                r = (shapes(sim.q[:, mask])[valid] - tg).ravel()
                if not np.all(np.isfinite(r)):
                    raise DivergenceError("non-finite rollout")
            except (DivergenceError, np.linalg.LinAlgError, ValueError):
                r = np.full(tg.size, 1.0)  # 1 m everywhere: far worse than any bounded rollout
            out.append(r)
        return out

    def residual(x: NDArray, step: float = dt) -> NDArray:
        c, g = layout.unpack(x)
        out = rollouts(c, g, step, starts)
        if vertices.size:
            k = np.asarray(lib.stiffness_from_coef(c), dtype=float)
            lam = input_stiffness(k, act, g, vertices)
            short = np.maximum(0.0, STIFFNESS_MARGIN * max(float(k.min()), 0.0) - lam)
            scale = _PENALTY_SCALE * np.sqrt(n_res) / max(float(np.abs(k).max()), 1e-12)
            out.append(scale * short)
        return np.concatenate(out)

    x0 = np.maximum(layout.x0, np.where(np.isfinite(layout.lower), layout.lower, -np.inf))
    # a bound at exactly zero starts the trust region on its edge; a small damping lets rollouts settle
    pos = np.isfinite(layout.lower)
    x0[pos] = np.maximum(x0[pos], 1e-6 * max(float(np.abs(x0[pos]).max()), 1e-9))
    # start feasible: the equation-error fit's input-stiffness terms shrunk to hold the margin
    c0, g0, _ = _enforce_margin(lib, *layout.unpack(x0)[:1], act, layout.unpack(x0)[1], vertices, layout)
    x0 = layout.pack(c0, g0)
    step = dt
    if spatial:
        # the start states, then the rollout step: fixed steps keep the finite-difference Jacobian smooth, but a step
        # of one sample period on the benchmark's force-driven robot is 0.12 mm off the exact rollout, and the fit
        # then bends the parameters to reproduce that error (noise-free 0.005 -> 0.18 mm held out)
        fm0 = lib.forward_model(c0, actuation=act.set_identified(g0, act.offsets_))
        starts = _spatial_starts(fm0, recordings, shapes, targets, mask)
        base = np.concatenate(rollouts(c0, g0, step, starts))
        floor = STEP_FLOOR * float(np.sum(lib.kinematics.segment_lengths))
        for _ in range(MAX_STEP_HALVINGS):
            finer = np.concatenate(rollouts(c0, g0, step / 2, starts))
            if np.sqrt(np.mean((finer - base) ** 2)) <= max(STEP_TOLERANCE * np.sqrt(np.mean(finer**2)), floor):
                break
            step, base = step / 2, finer
    r0 = residual(x0, step)
    n_markers = n_res
    if not np.all(np.abs(r0[:n_markers]) < 1.0):
        # the equation-error start diverges (a stiffness at its bound 0 under a bent rest pose): start each
        # strain at the stiffness of gravity on the whole robot about its base (m g L), the scale of a hanging body
        c_start, g_start = layout.unpack(x0)
        lengths = np.asarray(lib.kinematics.segment_lengths, dtype=float)
        k_g = layout.rho * lengths.sum() * 9.81 * lengths.sum()
        c_start[layout.stiff] = np.maximum(c_start[layout.stiff], k_g)
        c_start[layout.damp] = np.maximum(c_start[layout.damp], 0.05 * k_g)
        x1 = layout.pack(c_start, g_start)
        r1 = residual(x1, step)
        if np.sum(r1**2) < np.sum(r0**2):
            x0, r0 = x1, r1
    if spatial:
        # a spatial fit from positions alone hangs from a fitted base under a gravity of loose direction: its rest
        # forces may hold a pose far from the recorded ones.  Also try them set so that the recordings' mean shape
        # is the equilibrium under their mean input; the better rollout starts the fit
        x2 = _balanced_start(lib, layout, act, x0, recordings)
        if x2 is not None:
            r2 = residual(x2, step)
            if np.sum(r2**2) < np.sum(r0**2):
                x0, r0 = x2, r2

    # the budget counts rollouts at the sample period (finer steps cost proportionally more), over all the solves
    budget = float(SPATIAL_ROLLOUT_BUDGET)
    solves: list[tuple[float, int]] = []

    def iteration_cost(step: float) -> float:
        """Rollouts at the sample period of one iteration's finite-difference Jacobian."""
        return max(x0.size, 1) * dt / step

    def solve(x: NDArray, step: float, n_fev: int) -> Any:
        nonlocal budget
        res = least_squares(
            lambda x: residual(x, step), x, bounds=(layout.lower, np.inf), x_scale="jac", max_nfev=n_fev, diff_step=1e-4
        )
        budget -= (res.nfev + x0.size * res.njev) * dt / step
        solves.append((step, int(res.nfev)))
        return res

    first = int(min(max_nfev, max(10, budget // iteration_cost(step)))) if spatial else max_nfev
    res = solve(x0, step, first)
    halvings = MAX_STEP_HALVINGS - round(np.log2(dt / step)) if spatial else 0
    while halvings > 0 and budget // iteration_cost(step / 2) >= MIN_RESOLVE_ITERATIONS:
        # the step was checked on the start model; the refined one may be stiffer.  Where its rollouts at that step
        # are off its rollouts at the default tolerances by more than the tolerance, halve and continue from it, on
        # what is left of the budget (a fresh one per halving made real 3-D fits 2-4x slower for no gain)
        exact = np.concatenate(rollouts(*layout.unpack(res.x), None, starts))
        if np.sqrt(np.mean((exact - res.fun[:n_res]) ** 2)) <= max(STEP_TOLERANCE * np.sqrt(np.mean(exact**2)), floor):
            break
        step, halvings = step / 2, halvings - 1
        r0 = residual(x0, step)
        res = solve(res.x, step, int(min(max_nfev, budget // iteration_cost(step))))
    best = res.x if np.sum(res.fun**2) <= np.sum(r0**2) else x0
    coef_out, gains_out = layout.unpack(best)
    coef_out, gains_out, factor = _enforce_margin(lib, coef_out, act, gains_out, vertices, layout)
    kept = "refined"
    if spatial:
        # the training objective at the forward model's own tolerances: the refined model against the equation-error
        # fit (both from the fitted start states); the better one is returned
        r_given = np.concatenate(rollouts(np.asarray(coef, dtype=float), gains_given, None, starts))
        r_end = np.concatenate(rollouts(coef_out, gains_out, None, starts))
        r0 = r_given
        if not np.sum(r_end**2) < np.sum(r_given**2):
            coef_out, gains_out, factor, kept, r_end = (
                np.asarray(coef, dtype=float).copy(),
                gains_given,
                1.0,
                "equation_error",
                r_given,
            )
        act.set_identified(gains_out, act.offsets_)
    else:
        act.set_identified(gains_out, act.offsets_)
        r_end = residual(layout.pack(coef_out, gains_out))
    if not np.all(np.abs(r_end[:n_markers]) < 1.0):
        import warnings

        warnings.warn(
            "the output-error refinement found no model whose rollout of the training recordings stays bounded "
            "(from the equation-error fit nor from a gravity-scale stiffness): fewer segments or more data",
            UserWarning,
            stacklevel=3,
        )
    rmse_start = float(np.sqrt(np.mean(r0[:n_markers] ** 2)))
    if spatial and not np.all(np.abs(r0[:n_markers]) < 1.0):
        rmse_start = np.inf  # the equation-error fit's rollout diverges: no misfit to report (1 m stood in)
    info = {
        "rmse_start": rmse_start,
        "rmse": float(np.sqrt(np.mean(r_end[:n_markers] ** 2))),
        "nfev": int(sum(n for _, n in solves)),
        "slope_factor": float(factor),
        "n_vertices": int(vertices.shape[0]),
    }
    if spatial:
        info.update(
            step=step,
            kept=kept,
            starts=[(a.tolist(), b.tolist()) for a, b in starts],
            solves=solves,
        )
    return coef_out, gains_out, info
