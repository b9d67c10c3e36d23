"""Real robots: every recording of the real-data folder through the PCS path, against black boxes (issue 25).

Data (read at run time from the real-data folder, see ``_real_data.py``; never copied into the repository):

* Trunk (StanfordASL trunk-stack): a hanging tendon robot, 3 tracked disks, 6 servo angles, 100 Hz.
  The two step-test files: the first half trains, the second half is predicted open loop from the
  recorded angles ``phi1..phi6``; 3-D tip (disk 3) RMSE [mm] in the capture frame, over the samples
  where the tracker did not hold its last value (exact repeats are not measurements; they are skipped
  in fitting and scoring alike).  Models: the PCS path (:func:`pcs_trunk`), a cubic map of
  first-order-lagged angles (:class:`~pcs_sindy.identification.LaggedPolynomialMap`, lag chosen on the
  training half) and ARX(2,2) (:class:`~pcs_sindy.identification.ARX`, started from the two measured
  samples at the split).  Also: the out-of-plane RMS of the disks about their best-fit plane, whether the
  PCS rollout stays bounded (finite, and within twice the measured tip's largest excursion from its
  mean) and whether the PCS model released from its most bent training state with the angles at 0
  comes to rest.  ``observations_controlled_1`` (all motors, 3-D motion, commanded angles in a second
  file): the baselines on both the measured and the commanded angles, and with ``--pcs-3d`` the spatial
  PCS path (:func:`pcs_trunk_3d`, issue 26).  ``observations_zeros_0g`` (rest): noise level and frozen samples.
* Tentacle (tud-phi soromox): 8 static holds under two tendon loads, 5 unlabelled markers (base included)
  in a per-file column order, ordered here from the base along the body.  Leave one hold out, predict its
  marker positions from the other seven: the PCS static path (:func:`pcs_tentacle`), linear interpolation
  between neighbouring loads (:class:`~pcs_sindy.identification.LinearLoadInterpolator`) and a quadratic
  in the loads (:class:`~pcs_sindy.identification.PolynomialLoadMap`); tip-marker error [mm] per hold.

PCS failures (exceptions, divergence) are rows of the table, never a crash of the benchmark.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/real_robots.py [--quick] [--write] [--plots DIR]``
(``--quick``: 20 s of each Trunk file, a smoke run; ``--write``: the
"Real robots" section of docs/results.md).  The 3-D file alone with the spatial PCS path:
``--only trunk3d --pcs-3d [--write]`` (``--write``: its own section, "Real robots: the Trunk in 3-D").
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _real_data import (  # noqa: E402
    TRUNK_3D_FILE,
    TRUNK_3D_INPUTS,
    TRUNK_REST_FILE,
    TRUNK_STEP_FILES,
    read_commanded,
    read_tentacle,
    read_trunk,
    real_data_dir,
)

from pcs_sindy.identification import ARX, LaggedPolynomialMap, LinearLoadInterpolator, PolynomialLoadMap  # noqa: E402

from _results import write_section  # noqa: E402

# ================================================================================ PCS recipes
# The coordinator swaps these two functions when the new API lands; everything else only calls them.
#: the disk spacing a user of the Trunk may give (3 disks, equally spaced; the base is not tracked)
TRUNK_DISK_SPACING = 0.105


def pcs_trunk(
    train_positions: np.ndarray,
    train_inputs: np.ndarray,
    test_positions: np.ndarray,
    test_inputs: np.ndarray,
    dt: float,
    details: dict | None = None,
) -> np.ndarray:
    """The documented positions-only path at defaults (docs/mocap.md, "Inputs of unknown units").

    The user gives the rate, the marker order from the base, the servo angles and the disk spacing
    (arc lengths 1, 2, 3 spacings).  ``select_segmentation`` chooses the segment count by held-out
    open-loop prediction on the training half -> ``KinematicFusion`` at that threshold ->
    ``EulerLagrangeRegressor(actuation=LearnedActuation(6))`` (no mass: the scale convention; the
    output-error refinement by default) -> ``simulate`` from the fused strains at the split (at rest
    rates) -> ``fusion.inverse_transform``; returns the predicted tip (T_test, 3) in the capture frame.
    ``details`` (if given) receives ``"release"``: a function of a duration [s] returning the strain
    rates of the model released from its most bent training state with the inputs at 0, and a
    description of the fit.
    """
    from pcs_sindy.core import PoseTrajectory
    from pcs_sindy.fusion import KinematicFusion
    from pcs_sindy.identification import EulerLagrangeRegressor
    from pcs_sindy.models import LearnedActuation
    from pcs_sindy.pipeline import select_segmentation

    arcs = TRUNK_DISK_SPACING * np.arange(1, train_positions.shape[1] + 1)
    choice = select_segmentation(train_positions, train_inputs, dt=dt, arc_lengths=arcs)
    train = PoseTrajectory.from_positions(train_positions, dt=dt, arc_lengths=arcs)
    test = PoseTrajectory.from_positions(test_positions, dt=dt, arc_lengths=arcs, plane=train.plane)
    fusion = KinematicFusion(threshold=choice.threshold).fit(train)
    (strains,), (st_test,) = fusion.transform(train), fusion.transform(test)
    model = EulerLagrangeRegressor(actuation=LearnedActuation(train_inputs.shape[1])).fit([strains], [train_inputs])
    if details is not None:
        q_bent = strains.q[np.argmax(np.abs(strains.q).sum(axis=1))]
        lengths = np.round(1e3 * np.asarray(fusion.segment_lengths_)).astype(int).tolist()
        details["fit"] = (
            f"{fusion.n_segments_} segment(s) {lengths} mm (held-out errors by count: "
            + ", ".join(f"{k}: {1e3 * e:.1f} mm" for k, e in sorted(choice.errors.items()))
            + ")"
        )

        def release(duration: float) -> np.ndarray:
            t = np.arange(int(round(duration / dt)) + 1) * dt
            sim = model.simulate(q_bent, np.zeros(q_bent.size), t, np.zeros((t.size, train_inputs.shape[1])))
            return np.gradient(sim.q, t, axis=0) if sim.qd is None else sim.qd

        details["release"] = release
    sim = model.simulate(st_test.q[0], np.zeros(st_test.q.shape[1]), st_test.t, test_inputs)
    sim.metadata.update({k: st_test.metadata[k] for k in ("plane", "marker_arc_lengths", "base_poses")})
    (pred,) = fusion.inverse_transform([sim])
    return pred.positions[:, -1, :]


def pcs_trunk_3d(
    train_positions: np.ndarray,
    train_inputs: np.ndarray,
    test_positions: np.ndarray,
    test_inputs: np.ndarray,
    dt: float,
    details: dict | None = None,
    space: str = "auto",
) -> np.ndarray:
    """The documented spatial path (issue 26) on a recording that moves in 3-D.

    ``KinematicFusion()`` at its defaults (``space="auto"`` goes 3-D on such a recording; arc lengths
    1, 2, 3 disk spacings as in :func:`pcs_trunk`) -> ``EulerLagrangeRegressor(actuation=LearnedActuation(6))``
    at its defaults (the spatial physical library, chosen for 3-D strains: from positions alone one line
    density and one weight vector ``rhoA g`` of unknown direction; no mass: the scale convention; the
    output-error refinement) -> ``simulate`` of the test inputs from the fused first test state at rest
    rates -> ``fusion.inverse_transform``; returns the predicted tip (T_test, 3) in the capture frame.
    ``space="3d"`` forces the spatial path on a recording that stays near a plane (the step files: a check
    that the 3-D path is not tuned to the one 3-D file).  ``details`` receives ``"fit"``, and ``"release"``
    as in :func:`pcs_trunk`.
    """
    from pcs_sindy.core import PoseTrajectory
    from pcs_sindy.fusion import KinematicFusion
    from pcs_sindy.identification import EulerLagrangeRegressor
    from pcs_sindy.models import LearnedActuation

    arcs = TRUNK_DISK_SPACING * np.arange(1, train_positions.shape[1] + 1)
    train = PoseTrajectory.from_positions(train_positions, dt=dt, arc_lengths=arcs)
    test = PoseTrajectory.from_positions(test_positions, dt=dt, arc_lengths=arcs)
    fusion = KinematicFusion(space=space).fit(train)
    (strains,), (st_test,) = fusion.transform(train), fusion.transform(test)
    if details is not None:
        lengths = np.round(1e3 * np.asarray(fusion.segment_lengths_)).astype(int).tolist()
        details["fit"] = f"space {fusion.space_}, {fusion.n_segments_} segment(s) {lengths} mm"
    model = EulerLagrangeRegressor(actuation=LearnedActuation(train_inputs.shape[1]))
    model.fit([strains], [train_inputs])
    if details is not None:
        details["model"] = model
        details["fit"] += f", strains {', '.join(model.kinematics_.strain_names(active_only=True))}"
        ref = model.refinement_
        if ref is not None:
            details["fit"] += (
                ", output-error refinement: training marker RMSE "
                + (f"{1e3 * ref['rmse_start']:.1f}" if np.isfinite(ref["rmse_start"]) else "(diverged)")
                + f" -> {1e3 * ref['rmse']:.1f} mm in {ref['nfev']} evaluations"
            )
        else:
            details["fit"] += ", not refined"
        q_bent = strains.q[np.argmax(np.abs(strains.q).sum(axis=1))]

        def release(duration: float) -> np.ndarray:
            t = np.arange(int(round(duration / dt)) + 1) * dt
            sim = model.simulate(q_bent, np.zeros(q_bent.size), t, np.zeros((t.size, train_inputs.shape[1])))
            return np.gradient(sim.q, t, axis=0) if sim.qd is None else sim.qd

        details["release"] = release
    sim = model.simulate(st_test.q[0], np.zeros(st_test.q.shape[1]), st_test.t, test_inputs)
    sim.metadata.update({k: v for k, v in st_test.metadata.items() if k not in sim.metadata})
    (pred,) = fusion.inverse_transform([sim])
    return pred.positions[:, -1, :]


def pcs_tentacle(train_holds: list[np.ndarray], train_loads: np.ndarray, test_load: np.ndarray) -> np.ndarray:
    """The documented static path (docs/mocap.md, "Static holds in 3-D"); the predicted markers (5, 3).

    Each training hold (T, 5, 3) ordered base first (``pcs_sindy.core.order_markers``), loads (H, 2) as
    the file names give them.  ``StaticShapeRegressor()`` at its defaults: constant-curvature segments
    bending in 3-D with the base at the recorded base marker standing along +y, markers off the
    backbone, per-segment equilibria (tendon compliance, rest curvature, weight) with the terms chosen
    by leave-one-hold-out error on the training holds only.
    """
    from pcs_sindy.identification import StaticShapeRegressor

    positions = np.array([h.mean(axis=0) for h in train_holds])
    model = StaticShapeRegressor().fit(positions, np.asarray(train_loads, dtype=float))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a held-out load outside the training range warns: the table says so
        return model.predict(np.atleast_2d(test_load))[0]


# ================================================================================ helpers
def frozen(positions: np.ndarray) -> np.ndarray:
    """Samples where the tracker held its last value: an exact repeat of the previous 3-D position."""
    out = np.zeros(positions.shape[0], dtype=bool)
    out[1:] = np.all(positions[1:] == positions[:-1], axis=-1)
    return out


def out_of_plane_rms(points: np.ndarray) -> float:
    """RMS distance [m] of the points (..., 3) from their best-fit plane (SVD)."""
    flat = points.reshape(-1, 3)
    flat = flat[np.all(np.isfinite(flat), axis=1)]
    centred = flat - flat.mean(axis=0)
    return float(np.linalg.svd(centred, full_matrices=False)[1][-1] / np.sqrt(flat.shape[0]))


def rmse_mm(pred: np.ndarray, ref: np.ndarray, ok: np.ndarray) -> float:
    """3-D RMSE [mm] over the rows ``ok``."""
    d = pred[ok] - ref[ok]
    return float(1e3 * np.sqrt(np.mean(np.sum(d**2, axis=1))))


def attempt(fn: Callable[[], Any]) -> tuple[Any, str | None, float]:
    """(result, failure or None, seconds): a PCS failure is a result, never a crash."""
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn(), None, time.perf_counter() - t0
    except Exception as err:  # noqa: BLE001 -- reported as a row
        first = str(err).splitlines()[0] if str(err) else ""
        where = traceback.extract_tb(err.__traceback__)[-1]
        return (
            None,
            f"{type(err).__name__}: {first[:160]} ({Path(where.filename).name}:{where.lineno})",
            (time.perf_counter() - t0),
        )


def baselines_trunk(u: np.ndarray, tip: np.ndarray, ok: np.ndarray, half: int, dt: float) -> dict[str, Any]:
    """Cubic lagged map and ARX(2,2) fitted on ``[:half]``, predicted on ``[half:]`` open loop."""
    y = np.where(ok[:, None], tip, np.nan)
    cubic = LaggedPolynomialMap(degree=3).fit(u[:half], y[:half], dt)
    quadratic = LaggedPolynomialMap(degree=2).fit(u[:half], y[:half], dt)
    arx = ARX(2, 2).fit(u[:half], y[:half])
    k0 = half + int(np.argmax(ok[half:-1] & ok[half + 1 :]))  # two measured samples to start from
    arx_tip = np.full((u.shape[0] - half, 3), np.nan)
    arx_tip[k0 - half :] = arx.predict(u[k0:], tip[k0 : k0 + 2])
    return {
        f"cubic map of lagged angles (lag {cubic.lag_:.3g} s)": cubic.predict(u)[half:],
        f"quadratic map of lagged angles (lag {quadratic.lag_:.3g} s)": quadratic.predict(u)[half:],
        "ARX(2,2)": arx_tip,
        "_arx": arx,
    }


# ================================================================================ Trunk
def run_trunk_file(
    path: Path,
    n_rows: int | None,
    pcs: bool = True,
    commanded: Path | None = None,
    pcs_fn: Callable[..., np.ndarray] | None = None,
    pcs_label: str = "PCS, documented path at defaults",
) -> dict:
    pcs_fn = pcs_trunk if pcs_fn is None else pcs_fn
    rec = read_trunk(path, n_rows)
    P, u, dt = rec.positions, rec.inputs, rec.dt
    tip = P[:, -1]
    ok = ~frozen(tip) & np.all(np.isfinite(tip), axis=1)
    T = P.shape[0]
    half = T // 2
    out: dict[str, Any] = {
        "name": path.name,
        "reader": rec.reader,
        "samples": T,
        "duration": T * dt,
        "frozen": int(np.sum(~ok)),
        "out_of_plane_mm": 1e3 * out_of_plane_rms(P),
        "tip": tip,
        "half": half,
        "dt": dt,
        "rows": [],
        "predictions": {},
    }
    test_ok = ok[half:]
    base = baselines_trunk(u, tip, ok, half, dt)
    arx = base.pop("_arx")
    out["arx_radius"] = arx.spectral_radius_
    for name, pred in base.items():
        out["predictions"][name] = pred
        out["rows"].append((name, rmse_mm(pred, tip[half:], test_ok & np.all(np.isfinite(pred), axis=1)), ""))
    if commanded is not None:
        uc = read_commanded(commanded)
        n = min(uc.shape[0], T)
        for name, pred in baselines_trunk(uc[:n], tip[:n], ok[:n], n // 2, dt).items():
            if name == "_arx":
                continue
            ref_ok = ok[n // 2 : n] & np.all(np.isfinite(pred), axis=1)
            out["rows"].append((f"{name}, commanded angles", rmse_mm(pred, tip[n // 2 : n], ref_ok), ""))
    if pcs:
        details: dict = {}
        pred, failure, secs = attempt(lambda: pcs_fn(P[:half], u[:half], P[half:], u[half:], dt, details))
        out["pcs_seconds"] = secs
        out["pcs_fit"] = details.get("fit", "")
        label = pcs_label
        if failure is not None:
            out["rows"].append((label, float("nan"), f"failed: {failure}"))
            out["pcs_bounded"], out["pcs_rest"] = "no prediction", "no model" if "release" not in details else ""
        else:
            out["predictions"][label] = pred
            finite = np.all(np.isfinite(pred), axis=1)
            reach = 2 * np.max(np.linalg.norm(tip[ok] - tip[ok].mean(axis=0), axis=1))
            far = np.linalg.norm(np.where(finite[:, None], pred, 0) - tip[ok].mean(axis=0), axis=1) > reach
            bounded = bool(finite.all() and not far.any())
            out["pcs_bounded"] = "yes" if bounded else f"no ({int(np.sum(~finite | far))} samples non-finite or beyond)"
            note = "" if bounded else "unbounded rollout"
            out["rows"].append((label, rmse_mm(pred, tip[half:], test_ok & finite), note))
        if "release" in details:
            rates, failure_r, _ = attempt(lambda: details["release"](20.0))
            if failure_r is not None:
                out["pcs_rest"] = f"failed: {failure_r}"
            else:
                tail = np.max(np.abs(rates[-int(round(1 / dt)) :]))
                rest = bool(np.isfinite(tail) and tail < 1e-2)
                out["pcs_rest"] = f"{'yes' if rest else 'no'} (last-second max strain rate {tail:.2g} /s)"
    return out


def rest_file(path: Path) -> dict:
    rec = read_trunk(path)
    P = rec.positions
    fro = np.stack([frozen(P[:, i]) for i in range(P.shape[1])], axis=1)
    noise = []
    for i in range(P.shape[1]):
        d = np.diff(P[~fro[:, i], i], axis=0)  # sample-to-sample change of a resting disk: noise * sqrt(2)
        noise.append(1e3 * np.sqrt(np.mean(np.sum(d**2, axis=1)) / 2 / 3))
    return {
        "name": path.name,
        "samples": P.shape[0],
        "frozen": fro.sum(axis=0).tolist(),
        "noise_mm": noise,
        "std_mm": (1e3 * np.linalg.norm(P.std(axis=0), axis=1)).tolist(),
        "angles": (np.abs(rec.inputs).max(axis=0)).tolist(),
    }


# ================================================================================ Tentacle
def run_tentacle(folder: Path, frames: int | None, pcs: bool = True) -> dict:
    holds, notes = read_tentacle(folder)
    if frames is not None:
        for h in holds:
            h.positions = h.positions[np.linspace(0, h.positions.shape[0] - 1, frames).astype(int)]
    loads = np.array([h.loads for h in holds])
    means = np.array([h.mean for h in holds])
    spread = max(float(np.max(np.linalg.norm(h.positions - h.mean, axis=-1))) for h in holds)
    methods = ("PCS static path", "interpolate neighbouring loads", "quadratic in the loads")
    errors = {m: [] for m in methods}
    preds = {m: [] for m in methods}
    failures = []
    t0 = time.perf_counter()
    for i in range(len(holds)):
        rest = [j for j in range(len(holds)) if j != i]
        interp = LinearLoadInterpolator().fit(loads[rest], means[rest]).predict(loads[i])[0]
        quad = PolynomialLoadMap(2).fit(loads[rest], means[rest]).predict(loads[i])[0]
        failure = None
        if pcs:
            pcs_pred, failure, _ = attempt(
                lambda i=i, rest=rest: pcs_tentacle([holds[j].positions for j in rest], loads[rest], loads[i])
            )
        else:
            pcs_pred = np.full((5, 3), np.nan)
        if failure is not None:
            failures.append(f"hold {holds[i].name}: {failure}")
            pcs_pred = np.full((5, 3), np.nan)
        for m, p in zip(methods, (pcs_pred, interp, quad), strict=True):
            preds[m].append(p)
            errors[m].append(1e3 * float(np.linalg.norm(p[-1] - means[i][-1])))
    return {
        "holds": holds,
        "notes": notes,
        "loads": loads,
        "means": means,
        "spread_mm": 1e3 * spread,
        "out_of_plane_mm": 1e3 * out_of_plane_rms(means),
        "errors": errors,
        "preds": preds,
        "failures": failures,
        "seconds": time.perf_counter() - t0,
    }


# ================================================================================ plots
def save_small_png(fig: Any, path: Path) -> None:
    """A PNG of few colours (the plots are line art): committed plots stay well under 150 KB."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, dpi=72, format="png")
    buf.seek(0)
    Image.open(buf).convert("RGB").quantize(colors=128).save(path, optimize=True)


def plot_trunk(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tip, half, dt = res["tip"], res["half"], res["dt"]
    t = np.arange(tip.shape[0] - half) * dt + half * dt
    step = max(1, int(np.ceil(t.size / 1200)))  # small PNGs: >= 16 Hz still shows the ~1.5 Hz ringing
    t, tip = t[::step], tip[half::step]
    half = 0
    res = {**res, "predictions": {k: v[::step] for k, v in res["predictions"].items()}}
    fig, axes = plt.subplots(4, 1, figsize=(8, 7.5), sharex=True, gridspec_kw={"height_ratios": [1, 1, 1, 1.2]})
    styles = {"PCS": "tab:red", "cubic": "tab:blue", "quadratic": "tab:purple", "ARX": "tab:green"}
    for c, ax in enumerate(axes[:3]):
        ax.plot(t, 1e3 * tip[half:, c], color="k", lw=1.2, label="measured")
        for name, pred in res["predictions"].items():
            colour = next(v for k, v in styles.items() if name.startswith(k))
            shown = np.clip(1e3 * pred[:, c], *(1e3 * np.array([tip[:, c].min(), tip[:, c].max()]) + [-50, 50]))
            ax.plot(t, shown, color=colour, lw=0.8, label=name.split(" (")[0])
        ax.set_ylabel(f"tip {'xyz'[c]} [mm]")
    for name, pred in res["predictions"].items():
        colour = next(v for k, v in styles.items() if name.startswith(k))
        err = np.minimum(1e3 * np.linalg.norm(pred - tip[half:], axis=1), 200)
        axes[3].plot(t, err, color=colour, lw=0.7)
    axes[3].set_ylabel("|error| [mm]\n(clipped 200)")
    axes[3].set_xlabel("time [s] (second half: predicted open loop)")
    axes[0].legend(fontsize=7, ncol=4, loc="upper right")
    axes[0].set_title(f"Trunk, {res['name']}", fontsize=9)
    fig.tight_layout()
    save_small_png(fig, path)
    plt.close(fig)


def plot_tentacle(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    means = res["means"]
    flat = means.reshape(-1, 3)
    centre = flat.mean(axis=0)
    axes2 = np.linalg.svd(flat - centre, full_matrices=False)[2][:2]

    def xy(p):
        return 1e3 * (np.asarray(p) - centre) @ axes2.T

    n = len(means)
    fig, axes = plt.subplots(2, (n + 1) // 2, figsize=(10, 5.5), sharex=True, sharey=True)
    colours = {
        "PCS static path": "tab:red",
        "interpolate neighbouring loads": "tab:blue",
        "quadratic in the loads": "tab:green",
    }
    for i, ax in enumerate(axes.ravel()[:n]):
        m = xy(means[i])
        ax.plot(m[:, 0], m[:, 1], "ko-", lw=1.5, ms=4, label="measured")
        for name, c in colours.items():
            p = res["preds"][name][i]
            if np.all(np.isfinite(p)):
                q = xy(p)
                ax.plot(q[:, 0], q[:, 1], "o--", color=c, lw=0.9, ms=3, label=name)
        ax.set_title(f"{res['holds'][i].name}\nloads {res['loads'][i].tolist()}", fontsize=8)
        ax.set_aspect("equal")
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    axes.ravel()[0].legend(fontsize=6)
    fig.suptitle("Tentacle: held-out hold, predicted vs measured markers (plane of all holds) [mm]", fontsize=9)
    fig.tight_layout()
    save_small_png(fig, path)
    plt.close(fig)


# ================================================================================ report
def table(trunk: list[dict], three_d: list[dict], rest: dict | None, tent: dict | None) -> str:
    lines = []
    if trunk:
        lines += [
            "Trunk step tests: first half trains, second half predicted open loop from the recorded angles; "
            "3-D tip (disk 3) RMSE in the capture frame over the samples the tracker did not freeze.\n",
            "| file | model | tip RMSE [mm] | note |",
            "|---|---|---|---|",
        ]
        for r in trunk:
            for name, err, note in r["rows"]:
                lines.append(f"| {r['name']} | {name} | {'—' if not np.isfinite(err) else f'{err:.2f}'} | {note} |")
        lines += [
            "",
            "| file | samples | frozen tip samples | out-of-plane RMS [mm] | ARX spectral radius | PCS rollout bounded "
            "| PCS released at 0 comes to rest | PCS fit | PCS time [s] |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in trunk:
            pcs = f"{r.get('pcs_bounded', '—')} | {r.get('pcs_rest', '—')} | {r.get('pcs_fit', '')}"
            lines.append(
                f"| {r['name']} | {r['samples']} ({r['duration']:.0f} s) | {r['frozen']} | "
                f"{r['out_of_plane_mm']:.1f} | {r['arx_radius']:.4f} | {pcs} | "
                f"{r.get('pcs_seconds', float('nan')):.0f} |"
            )
        lines.append(f"\nRead with: {trunk[0]['reader']}.\n")
    for k, r in enumerate(three_d):
        pcs_run = any(name.startswith("PCS") for name, _, _ in r["rows"])
        what = (
            "all six motors, the robot moves in 3-D"
            if k == 0
            else "a step file, near a plane: the spatial path forced (`space='3d'`), a check on another recording"
        )
        lines += [
            f"`{r['name']}` ({what}: out-of-plane RMS {r['out_of_plane_mm']:.1f} mm): "
            + (
                "the spatial PCS path (issue 26) beside the black boxes; same split and score.\n"
                if pcs_run
                else "baselines only (`--pcs-3d` adds the spatial PCS path); same split and score.\n"
            ),
            "| model | tip RMSE [mm] | note |",
            "|---|---|---|",
        ]
        for name, err, note in r["rows"]:
            lines.append(f"| {name} | {'—' if not np.isfinite(err) else f'{err:.2f}'} | {note} |")
        if pcs_run:
            lines.append(
                f"\nSpatial PCS: {r.get('pcs_fit', '')}; rollout bounded: {r.get('pcs_bounded', '—')}; released at 0 "
                f"comes to rest: {r.get('pcs_rest', '—')}; time {r.get('pcs_seconds', float('nan')):.0f} s."
            )
        lines.append("")
    if rest is not None:
        lines += [
            f"`{rest['name']}` (rest, all motors at 0, {rest['samples']} samples): per disk, noise "
            f"{', '.join(f'{v:.3f}' for v in rest['noise_mm'])} mm (per axis, from sample-to-sample changes), "
            f"total std {', '.join(f'{v:.3f}' for v in rest['std_mm'])} mm, frozen samples "
            f"{', '.join(str(v) for v in rest['frozen'])}; largest |angle| {max(rest['angles']):.2f} deg.\n"
        ]
    if tent is not None:
        e = tent["errors"]
        lines += [
            f"Tentacle, {len(tent['holds'])} static holds, leave one hold out: tip-marker error [mm] (against the "
            f"hold's mean; within-hold spread up to {tent['spread_mm']:.2f} mm; out-of-plane RMS of the hold means "
            f"{tent['out_of_plane_mm']:.1f} mm).\n",
            "| hold | loads | " + " | ".join(e) + " |",
            "|---|---|" + "---|" * len(e),
        ]
        for i, h in enumerate(tent["holds"]):
            vals = " | ".join("—" if not np.isfinite(e[m][i]) else f"{e[m][i]:.1f}" for m in e)
            lines.append(f"| {h.name} | {h.loads[0]:.2f}, {h.loads[1]:.2f} | {vals} |")
        means = " | ".join(
            f"**{np.mean(e[m]):.1f}**"
            if np.all(np.isfinite(e[m]))
            else f"{np.mean(np.asarray(e[m])[np.isfinite(e[m])]):.1f} over the {int(np.sum(np.isfinite(e[m])))} "
            f"predicted ({int(np.sum(~np.isfinite(e[m])))} failed)"
            if np.any(np.isfinite(e[m]))
            else f"— ({len(e[m])} failed)"
            for m in e
        )
        lines.append(f"| mean | | {means} |")
        if tent["failures"]:
            lines += ["", "PCS static path failures:", *(f"- {f}" for f in tent["failures"])]
        lines += [f"- note: {n}" for n in tent["notes"]]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="20 s per Trunk file (smoke run)")
    ap.add_argument("--write", action="store_true", help='write the "Real robots" section of docs/results.md')
    ap.add_argument("--plots", type=Path, default=None, help="write PNG plots into this folder")
    ap.add_argument("--no-pcs", action="store_true", help="baselines only (fast)")
    ap.add_argument(
        "--only",
        choices=("trunk", "tentacle", "trunk3d"),
        help="one robot only (no --write); trunk3d: the 3-D Trunk file alone (--write: its own section)",
    )
    ap.add_argument("--pcs-3d", action="store_true", help="also run the spatial (3-D) PCS path on the 3-D recording")
    args = ap.parse_args(argv)
    root = real_data_dir()
    if root is None:
        print("no real-data folder (set PCS_SINDY_REAL_DATA); nothing to do")
        return {}
    start = time.perf_counter()
    n_rows = 2000 if args.quick else None
    trunk, three_d, rest, tent = [], [], None, None
    tdir = root / "trunk"
    for name in TRUNK_STEP_FILES if args.only not in ("tentacle", "trunk3d") else ():
        if (tdir / name).is_file():
            trunk.append(run_trunk_file(tdir / name, n_rows, pcs=not args.no_pcs))
            print(f"{name}: " + "; ".join(f"{n} {e:.2f} mm {x}" for n, e, x in trunk[-1]["rows"]), flush=True)
    if (tdir / TRUNK_3D_FILE).is_file() and args.only != "tentacle":
        commanded = tdir / TRUNK_3D_INPUTS if (tdir / TRUNK_3D_INPUTS).is_file() else None
        # the planar PCS model is out of scope on the 3-D recording; --pcs-3d runs the spatial path (issue 26)
        three_d.append(
            run_trunk_file(
                tdir / TRUNK_3D_FILE,
                n_rows,
                pcs=args.pcs_3d and not args.no_pcs,
                commanded=commanded,
                pcs_fn=pcs_trunk_3d,
                pcs_label="PCS 3-D, documented spatial path at defaults",
            )
        )
        print(f"{TRUNK_3D_FILE}: " + "; ".join(f"{n} {e:.2f} mm {x}" for n, e, x in three_d[-1]["rows"]), flush=True)
    for name in TRUNK_STEP_FILES if args.only == "trunk3d" and args.pcs_3d and not args.no_pcs else ():
        # the same spatial path on the step files (fused in 3-D): acceptance runs on other recordings too
        if (tdir / name).is_file():
            three_d.append(
                run_trunk_file(
                    tdir / name,
                    n_rows,
                    pcs_fn=lambda *a, **k: pcs_trunk_3d(*a, **k, space="3d"),
                    pcs_label="PCS 3-D, documented spatial path at defaults (space='3d')",
                )
            )
            print(f"{name}: " + "; ".join(f"{n} {e:.2f} mm {x}" for n, e, x in three_d[-1]["rows"]), flush=True)
    if (tdir / TRUNK_REST_FILE).is_file() and args.only not in ("tentacle", "trunk3d"):
        rest = rest_file(tdir / TRUNK_REST_FILE)
    if (root / "tentacle").is_dir() and args.only not in ("trunk", "trunk3d"):
        # static holds: the frames of a hold differ by noise only (< 0.4 mm), 30 of them say what all do
        tent = run_tentacle(root / "tentacle", 30, pcs=not args.no_pcs)
        if args.no_pcs:
            tent["errors"].pop("PCS static path")
    body = table(trunk, three_d, rest, tent)
    seconds = time.perf_counter() - start
    print(body)
    print(f"wall time {seconds:.0f} s")
    if args.plots is not None:
        args.plots.mkdir(parents=True, exist_ok=True)
        for r in trunk + three_d:
            plot_trunk(r, args.plots / f"real_trunk_{Path(r['name']).stem}.png")
        if tent is not None and tent["holds"]:
            plot_tentacle(tent, args.plots / "real_tentacle_holds.png")
    if args.write and not args.quick and args.only == "trunk3d" and three_d:
        write_section(
            "real_robots_3d",
            "Real robots: the Trunk in 3-D (issue 26)",
            body + f"\nWall time {seconds:.0f} s.\n",
            "OMP_NUM_THREADS=1 .venv/bin/python benchmarks/real_robots.py --only trunk3d --pcs-3d --write",
        )
    if args.write and not args.quick and args.only is None:
        write_section(
            "real_robots",
            "Real robots (issue 25)",
            body + f"\nWall time {seconds:.0f} s.\n",
            "OMP_NUM_THREADS=1 .venv/bin/python benchmarks/real_robots.py --write --plots docs/img",
        )
    return {"trunk": trunk, "three_d": three_d, "rest": rest, "tentacle": tent, "seconds": seconds}


if __name__ == "__main__":
    main()
