"""One recording -> marker poses: the work behind :class:`pcs_sindy.vision.extractor.MarkerPoseExtractor`.

1. **Reference frame first.**  Before anything else is decoded, every
   candidate thresholder (:mod:`pcs_sindy.vision.thresholding`) is tried on the
   reference frame; the one whose components form the longest chain of
   similar markers (:func:`~pcs_sindy.vision.chain.link_chains`) wins, and
   its reasons go to the diagnostics.  No chain, a chain of the wrong length
   or two chains (two robots) stop here with a message naming what was found
   and what to try.
2. **The base.**  Given, the camera's origin, or the end of the reference
   chain that stays put in a few frames sampled over the recording.
3. **Every frame, in one pass.**  Markers are tracked from the previous frame
   when that is unambiguous, otherwise chained from the base; a frame the
   chosen thresholder cannot complete is tried with the other candidates; a
   marker the chain lacks is looked for at its predicted pose among all
   components (a partly hidden or motion-blurred one is measured there, see
   ``diagnostics["markers_partial"]``), else an isolated missing marker is
   filled from its neighbours.
   A frame that still fails raises (naming recording and frame) or is
   interpolated in time, per ``on_missing``.
4. **Metres.**  Marker centres and axes go through the camera's lens model
   (points, not frames) and its similarity to the robot's base frame.

Knows nothing of dynamics.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter
from tqdm.auto import tqdm

from ..core.camera import Camera, camera_extras, camera_json_path, read_camera_json
from ..core.metrics import noise_level
from ..core.trajectory import PoseTrajectory
from .chain import link_chains, track, wrap_half_pi
from .frame_source import FrameSource
from .markers import AREA, AXIS, LONG, PIXELS, SHORT
from .thresholding import (
    ColourThresholder,
    LocalThresholder,
    OtsuThresholder,
    RangeThresholder,
    Thresholder,
    candidate_thresholders,
)
from .tracker import Detector, FrameResult, FrameTracker

__all__ = ["extract_recording", "MarkerStream", "MAX_AUTO_GAP"]

_N_BASE_SAMPLES = 16
_N_REFERENCE_SAMPLES = 12  # frames tried as the reference with reference_frame="auto"
_BUFFER_BYTES = 512 * 2**20  # decoded frames before the reference kept in memory for the pass back to frame 0
_HINTS = (
    "check that the robot is in view and its markers contrast with their surroundings; give n_markers=N; exclude "
    "clutter with roi=(x, y, width, height); try threshold='local' (uneven light), threshold='colour' (coloured "
    "markers), a fixed grey level threshold=<0-255> or a colour range threshold=((b0, g0, r0), (b1, g1, r1)); "
    "polarity='bright' for markers lighter than the background"
)


def _thresholders(p: dict[str, Any], ref_img: NDArray[np.uint8]) -> list[Thresholder]:
    thr = p["threshold"]
    if isinstance(thr, tuple):
        return [RangeThresholder(*thr)]
    if thr == "auto":
        return candidate_thresholders(ref_img, p["polarity"], p["blur"])
    if thr == "otsu":
        return [OtsuThresholder(None, p["polarity"], p["blur"])]
    if thr == "local":
        return [LocalThresholder(p["polarity"]).prepare(ref_img)]
    if thr == "colour":
        try:
            return [ColourThresholder().prepare(ref_img)]
        except ValueError as err:
            raise ValueError(f"threshold='colour': {err}") from None
    return [OtsuThresholder(float(thr), p["polarity"], p["blur"])]


def _pick_chain(chains: list[NDArray[np.intp]], n_expected: int | None) -> NDArray[np.intp] | None:
    if not chains:
        return None
    if n_expected is not None:
        exact = [c for c in chains if len(c) == n_expected]
        if exact:
            return exact[0]
    return chains[0]


def _reference(p: dict[str, Any], segs: list[Thresholder], ref_img: NDArray[np.uint8], name: str, ref: int) -> tuple:
    """Choose the thresholder on the reference frame: (detector, candidates, chain, report)."""
    n_expected = None if p["n_markers"] is None else p["n_markers"] + 1
    results = []
    for seg in segs:
        det = Detector(seg, p)
        cands = det(ref_img)
        chains = link_chains(cands)
        chain = _pick_chain(chains, n_expected)
        length = 0 if chain is None else len(chain)
        exact = n_expected is not None and length == n_expected
        spread = float(np.std(np.log(cands[chain, AREA]))) if length > 1 else np.inf
        results.append(((exact, length, -spread), det, cands, chains, chain))
    report = {
        r[1].seg.describe(): f"a chain of {r[0][1]} similar markers among {len(r[2])} components" for r in results
    }
    best = max(results, key=lambda r: r[0])
    (_, length, _), det, cands, chains, chain = best
    found = "; ".join(f"{k}: {v}" for k, v in report.items())
    if length < 3 or (n_expected is not None and length != n_expected):
        want = f"{n_expected} markers (base + {n_expected - 1})" if n_expected else "at least 3 markers"
        what = "no markers found" if all(len(r[2]) == 0 for r in results) else f"found {found}"
        raise ValueError(
            f"recording {name!r}, frame {ref} (reference frame): expected a chain of {want}; {what}. Try: {_HINTS}"
        )
    others = [c for c in chains if c is not chain and len(c) >= max(5, 0.5 * length)]
    if others:
        raise ValueError(
            f"recording {name!r}, frame {ref} (reference frame): two chains of markers ({length} and {len(others[0])} "
            f"markers): two robots in view, or one robot whose chain is broken by a missing marker; restrict the view "
            f"with roi=(x, y, width, height) or give n_markers"
        )
    why = f"{det.seg.describe()}: the longest chain of similar markers ({length})"
    if len(results) > 1:
        why += " of the candidates"
    return det, cands, chain, {"chosen": det.seg.describe(), "reason": why, "candidates": report}


def _find_base(
    src: FrameSource, det: Detector, ends: NDArray[np.float64], spacing: float, ref: int, grey: bool, reduce: int
) -> tuple[int, str]:
    """Which end of the reference chain (0 or 1) stays put over frames sampled across the recording, and why.

    The clamped base moves by detection noise only, the tip somewhere by far
    more: for each end, the largest distance over the sampled frames from its
    place in the reference frame to the nearest marker-shaped component
    (pixels reported at the footage's full resolution).
    """
    name = src.name
    picks = [k for k in np.linspace(0, src.n_frames - 1, _N_BASE_SAMPLES + 1).round().astype(int) if k != ref]
    picks = sorted(set(picks))
    if not picks:
        raise ValueError(
            f"recording {name!r}: cannot tell the base marker from a single frame; give base_position or a camera"
        )
    worst = np.zeros(2)
    used = 0
    for k in picks:
        try:
            cands = det.accept(det(src.frame(int(k), grey=grey, reduce=reduce)))
        except OSError:
            continue  # a frame the container cannot seek to: the pass over all frames will report it
        if len(cands) == 0:
            continue
        used += 1
        d = np.linalg.norm(ends[:, None] - cands[None, :, :2], axis=-1).min(axis=1)
        worst = np.maximum(worst, d)
    b = int(np.argmin(worst))
    full = [((ends[e] + 0.5 * (reduce - 1) / reduce) * reduce).round(1).tolist() for e in (0, 1)]
    evidence = (
        f"motion over {used} frames sampled across the recording: the chain end at {full[b]} px (frame {ref}) moved "
        f"at most {worst[b] * reduce:.1f} px, the other end at {full[1 - b]} px up to {worst[1 - b] * reduce:.1f} px; "
        "the clamped base is the end that moves least"
    )
    # the base moves by detection noise only; the tip must move clearly more somewhere
    if worst[1 - b] < max(4.0 * worst[b], 1.0, 0.1 * spacing):
        raise ValueError(
            f"recording {name!r}: both ends of the marker chain stay put (the robot hardly moves), so the base "
            f"marker is ambiguous ({evidence}); give base_position=(u, v) or a camera"
        )
    return b, evidence


def _is_straight(pts: NDArray[np.float64]) -> bool:
    """Whether the chain's centres lie on one line (within half a pixel, or 2 % of their spacing for large markers)."""
    centred = pts - pts.mean(axis=0)
    dvec = np.linalg.svd(centred, full_matrices=False)[2][0]
    off = np.abs(centred @ np.array([-dvec[1], dvec[0]]))
    spacing = float(np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    return bool(off.max() <= max(0.5, 0.02 * spacing))


def _base_axis_angle(phi: NDArray[np.float64]) -> float:
    """Circular mean of the base marker's angle over frames: its tangent is the rest direction (clamped base)."""
    return float(np.arctan2(np.mean(np.sin(phi)), np.mean(np.cos(phi))))


def _rest_direction(pts: NDArray[np.float64]) -> float:
    """Image angle of the least-squares line through the first markers, pointing along the chain.

    One pair of centres would carry their detection noise into every angle:
    the line runs through as many markers from the base as lie on it (within
    half a pixel; all of them in a straight reference frame), at least five.
    """
    for k in range(len(pts), 1, -1):
        near = pts[:k]
        centred = near - near.mean(axis=0)
        dvec = np.linalg.svd(centred, full_matrices=False)[2][0]
        off = np.abs(centred @ np.array([-dvec[1], dvec[0]]))
        if k <= 5 or off.max() <= 0.5:
            break
    if dvec @ (near[-1] - near[0]) < 0:
        dvec = -dvec
    return float(np.arctan2(dvec[1], dvec[0]))


def _resolve_camera(
    recording: Any, p: dict[str, Any], size: tuple[int, int]
) -> tuple[Camera | None, str | None, dict[str, Any]]:
    """The camera, what gave it, and the recording facts its JSON holds (``fps``, ``n_frames``).

    ``camera="auto"`` reads ``<video>.camera.json`` when it exists; a camera dict (a JSON given by
    path arrives read) is honoured in full; ``size``, the footage's, completes one without ``image_size``.
    """
    camera, source = p["camera"], p.get("camera_source", "given camera")
    if isinstance(camera, str):  # "auto"
        jpath = camera_json_path(recording) if isinstance(recording, (str, os.PathLike)) else None
        if jpath is None or not jpath.exists():
            return None, None, {}
        camera, source = read_camera_json(jpath), f"camera JSON {str(jpath)!r}"
    if isinstance(camera, dict):
        extras = camera_extras(camera, source)
        try:
            return Camera.from_dict(camera, image_size=size), source, extras
        except ValueError as err:
            raise ValueError(f"{source}: {err}") from None
    return camera, (None if camera is None else source), {}


def _frame_period(
    p: dict[str, Any], src: FrameSource, facts: dict[str, Any], calibration: str | None, name: str
) -> tuple[float, str]:
    """The frame period and what gave it: ``dt``, ``fps``, the camera JSON's ``fps``, the container's.

    A camera JSON's frame rate is the capture rate the user wrote down; a container's is often a
    playback rate (high-speed cameras save 1000 fps footage as 30 fps video): the JSON wins, with a
    warning when the two differ by more than 1 %.
    """
    given = (
        ("dt", float(p["dt"])) if p["dt"] is not None else ("fps", float(p["fps"])) if p["fps"] is not None else None
    )
    if given is not None:
        period = given[1] if given[0] == "dt" else 1.0 / given[1]
        if "fps" in facts and abs(period * facts["fps"] - 1.0) > 0.01:
            # the user's word wins, but a capture rate written down in the camera JSON is not overridden silently
            warnings.warn(
                f"recording {name!r}: {given[0]}={given[1]:g} overrides the {calibration}'s {facts['fps']:g} fps "
                f"(a frame period of {period:g} s instead of {1.0 / facts['fps']:g} s); leave {given[0]} out to use "
                "the camera JSON's",
                UserWarning,
                stacklevel=3,
            )
        elif "fps" not in facts and src.fps is not None and abs(period * src.fps - 1.0) > 0.01:
            # legitimate for high-speed footage saved at a playback rate, but never silent
            warnings.warn(
                f"recording {name!r}: {given[0]}={given[1]:g} overrides the video container's {src.fps:g} fps "
                f"(a frame period of {period:g} s instead of {1.0 / src.fps:g} s); leave {given[0]} out to use the "
                "container's",
                UserWarning,
                stacklevel=3,
            )
        return period, given[0]
    if "fps" in facts:
        if src.fps is not None and abs(src.fps - facts["fps"]) > 0.01 * facts["fps"]:
            warnings.warn(
                f"recording {name!r}: the {calibration} says {facts['fps']:g} fps, the video container "
                f"{src.fps:g} fps; using {facts['fps']:g} fps (give fps to choose)",
                UserWarning,
                stacklevel=3,
            )
        return 1.0 / facts["fps"], f"{calibration}"
    if src.fps is not None:
        return 1.0 / src.fps, "video container"
    raise ValueError(
        f"recording {name!r}: the frame rate is unknown; give fps or dt (--fps), or an 'fps' field in its camera JSON"
    )


def _first_direction(camera: Camera | None, p: dict[str, Any], members: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rest direction (+y of the base frame) in the recorded image, for the first step of the chain."""
    if camera is not None and camera.angle is not None:
        o = camera.unrectify(np.asarray(camera.origin if camera.origin is not None else (0.0, 0.0)))
        tip = camera.unrectify(o + 10.0 * np.array([-np.sin(camera.angle), np.cos(camera.angle)]))
        return (tip - o) / np.linalg.norm(tip - o)
    rest = float(p["rest_direction"]) if p["rest_direction"] is not None else _rest_direction(members[:, :2])
    return np.array([np.cos(rest), np.sin(rest)])


def _complete_camera(
    camera: Camera | None,
    lens: Camera,
    p: dict[str, Any],
    rect_ref: NDArray[np.float64],
    origin: NDArray[np.float64],
    calibration: str | None,
    what: str,
    ref: int,
    base_phi: NDArray[np.float64] | None = None,
) -> tuple[Camera, str]:
    """The camera with its base frame: origin, angle and scale from the parameters or the reference frame.

    ``rect_ref`` are the reference frame's markers in rectified pixels, ``origin``
    the base marker's rectified position (used unless the camera or ``base_position`` gives one),
    ``base_phi`` the base marker's rectified angles over the recording (the rest direction when the
    reference frame is not straight).
    """
    if camera is not None and camera.origin is not None:
        origin = np.asarray(camera.origin)
    elif p["base_position"] is not None:
        origin = lens.rectify(np.asarray(p["base_position"], dtype=float))
    bent = ""
    if camera is not None and camera.angle is not None:
        angle = camera.angle
    elif p["rest_direction"] is not None and (camera is None or not camera.has_lens):
        angle = float(p["rest_direction"]) - 0.5 * np.pi
    elif base_phi is not None and not _is_straight(rect_ref[:, :2]):
        # no straight frame to read the rest direction from: the clamped base marker's axis gives it
        angle = _base_axis_angle(base_phi)
        bent = f", rest direction from the base marker's axis (frame {ref} is not straight)"
    else:
        angle = _rest_direction(rect_ref[:, :2]) - 0.5 * np.pi
    if camera is not None:
        ppm, calibration = camera.pixels_per_metre, f"{calibration} (base frame found in the footage)"
    elif p["pixels_per_metre"] is not None:
        ppm, calibration = float(p["pixels_per_metre"]), "given pixels_per_metre"
    elif p["robot_length"] is not None:
        ppm = float(np.sum(np.linalg.norm(np.diff(rect_ref[:, :2], axis=0), axis=1))) / float(p["robot_length"])
        calibration = f"straight reference frame {ref} with robot_length={p['robot_length']!r}"
        if not _is_straight(rect_ref[:, :2]):
            calibration = f"reference frame {ref} (the straightest found) with robot_length={p['robot_length']!r}"
    else:
        raise ValueError(
            f"{what}: no calibration; give camera, pixels_per_metre, or robot_length (with a straight reference frame)"
        )
    return replace(lens, pixels_per_metre=ppm, origin=tuple(origin), angle=angle), calibration + bent


def _analyse(
    p: dict[str, Any], ref_img: NDArray[np.uint8], name: str, ref: int, segs: list[Thresholder] | None = None
) -> tuple:
    """Thresholder, fallbacks, chained markers, their spacing and the report, from the reference frame.

    ``segs``: thresholders prepared on another frame of the recording, the one chosen there first; only it
    is tried here (the others stay fallbacks).  Default: every candidate, prepared on this frame.
    """
    roi = p["roi"]
    if segs is None:
        segs = _thresholders(p, ref_img if roi is None else ref_img[roi[1] : roi[1] + roi[3], roi[0] : roi[0] + roi[2]])
        det, cands, chain, choice = _reference(p, segs, ref_img, name, ref)
    else:
        det, cands, chain, choice = _reference(p, segs[:1], ref_img, name, ref)
    members = cands[chain]
    det.typical = {
        "area": float(np.median(members[:, AREA])) if p["marker_area"] is None else float(p["marker_area"]),
        "pixels": float(np.median(members[:, PIXELS])),
        "long": float(np.median(members[:, LONG])),
        "short": float(np.median(members[:, SHORT])),
        "aspect": float(np.median(members[:, LONG] / np.maximum(members[:, SHORT], 1e-9))),
    }
    spacing = float(np.median(np.linalg.norm(np.diff(members[:, :2], axis=0), axis=1)))
    grey = not det.seg.needs_colour
    fallbacks = [Detector(s, p) for s in segs if s is not det.seg and (not grey or not s.needs_colour)]
    for f in fallbacks:
        f.typical = det.typical
    return det, fallbacks, members, spacing, choice


def _choose_reference(src: FrameSource, p: dict[str, Any], name: str) -> tuple:
    """The frame to start from: (index, its analysis, its image, why).

    Of frames sampled evenly over the recording (frame 0 included; a dozen,
    one per 25 frames in shorter recordings but at least 4), those
    whose chain of markers is the longest found (all markers in view and
    linked; with ``n_markers``, of that length) compete; the straightest
    (end-to-end distance over chain length) wins, the earliest among equals,
    so a recording that starts straight starts at frame 0 (taken at once,
    without sampling others) and one whose first frames are curled starts
    where the robot is plain.  Once one frame has been analysed (every
    candidate thresholder tried), the others are screened with the
    thresholder it chose; only the winner is analysed in full.
    """
    T = src.n_frames
    # a dozen samples, fewer in short recordings (one per 25 frames, at least 4): the screening stays a few % of
    # the work
    n_samples = min(T, _N_REFERENCE_SAMPLES, max(4, T // 25))
    picks = sorted(set(np.linspace(0, T - 1, n_samples).round().astype(int).tolist()))
    n_expected = None if p["n_markers"] is None else p["n_markers"] + 1
    screened, failed, analysed = [], {}, {}
    det = None
    for k in picks:
        try:
            img = src.frame(k)
        except (OSError, ValueError) as err:
            failed[k] = str(err)
            continue
        if det is None:
            try:
                analysis = _analyse(p, img, name, k)
            except ValueError as err:
                failed[k] = str(err)
                continue
            det, pts = analysis[0], analysis[2][:, :2]
            analysed[k] = (analysis, img)
            if k == picks[0] and _is_straight(pts) and (n_expected is None or len(pts) == n_expected):
                # a recording that starts straight with its whole chain in view: nothing can be straighter
                return k, analysis, img, f"frame {k}: the first frame, straight, with a chain of {len(pts)} markers"
        else:
            cands = det(img)
            chain = _pick_chain(link_chains(cands), n_expected)
            if chain is None or len(chain) < 3:
                failed[k] = "no chain of markers"
                continue
            pts = cands[chain, :2]
        arc = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        screened.append((k, len(pts), float(np.linalg.norm(pts[-1] - pts[0])) / max(arc, 1e-9)))
    if not screened:
        k0 = picks[0]
        raise ValueError(
            f"recording {name!r}: none of the {len(picks)} frames sampled across it ({picks}) shows a chain of "
            f"markers to start from; in frame {k0}: {failed[k0]}"
        )
    longest = max(u[1] for u in screened)
    if n_expected is not None and any(u[1] == n_expected for u in screened):
        longest = n_expected
    whole = [u for u in screened if u[1] == longest]
    # the straightest first (the earliest among equals); the full analysis may still refuse one (two chains)
    top = max(u[2] for u in whole)
    ranked = [u for u in whole if u[2] >= top - 0.002] + sorted(
        (u for u in whole if u[2] < top - 0.002), key=lambda u: -u[2]
    )
    last_err = None
    for k, _, straight in ranked:
        if k in analysed:
            analysis, img = analysed[k]
        else:
            img = src.frame(k)
            first = next(iter(analysed.values()))[0]
            try:  # with the thresholder the first analysed frame chose (preparing every candidate costs more)
                analysis = _analyse(p, img, name, k, [first[0].seg] + [f.seg for f in first[1]])
            except ValueError:
                try:
                    analysis = _analyse(p, img, name, k)
                except ValueError as err:
                    last_err = str(err)
                    continue
        why = (
            f"frame {k}: the straightest (end-to-end / chain length {straight:.3f}) of {len(whole)} frames showing a "
            f"chain of {longest} markers among {len(picks)} sampled"
        )
        if failed:
            k1 = min(failed)
            why += f"; no usable chain in frame(s) {sorted(failed)} (frame {k1}: {failed[k1].split(': ', 1)[-1][:160]})"
        return k, analysis, img, why
    raise ValueError(f"recording {name!r}: no sampled frame could serve as the reference frame; {last_err}")


def _reduced_params(p: dict[str, Any], red: int) -> dict[str, Any]:
    """Pixel-valued parameters for frames decoded at 1/red of the resolution."""
    q = dict(p, min_area=p["min_area"] / red**2)
    if p["marker_area"] is not None:
        q["marker_area"] = p["marker_area"] / red**2
    if p["roi"] is not None:
        x, y, w, h = p["roi"]
        q["roi"] = (x // red, y // red, max(1, -(-w // red)), max(1, -(-h // red)))
    return q


#: A marker whose offset from its neighbours' chain jumps by more than this many noise levels (and at
#: least :data:`OUTLIER_MIN` metres) from its running median is flagged as off its track.
OUTLIER_FACTOR = 10.0
OUTLIER_MIN = 1e-3


def _track_outliers(poses: NDArray[np.float64], valid: NDArray[np.bool_]) -> dict[int, list[int]]:
    """Frames whose markers lie far off their own track: ``{frame: [markers, 1-based]}``.

    A marker detected at the wrong place (a merged blob split wrongly, a reflection) still makes a
    complete frame.  Judged on each marker's offset from its chain neighbours (its position minus the
    mean of the two beside it; the tip against the line through the two before it), which the whole
    body's motion, however fast, barely changes from frame to frame: a sample of that offset farther
    than ``OUTLIER_FACTOR`` noise levels (at least ``OUTLIER_MIN``) from its running median over 9
    frames, and farther than its neighbours', flags the marker.  Only extracted frames are judged.
    """
    xy = np.array(poses[:, :, :2], dtype=float)  # base first
    T, n = xy.shape[:2]
    if T < 9 or n < 3:
        return {}
    offset = np.empty((T, n - 1, 2))
    offset[:, :-1] = xy[:, 1:-1] - 0.5 * (xy[:, :-2] + xy[:, 2:])
    offset[:, -1] = xy[:, -1] - 2.0 * xy[:, -2] + xy[:, -3]
    good = np.flatnonzero(valid)
    if good.size < 9:
        return {}
    med = median_filter(offset[good], size=(9, 1, 1), mode="nearest")
    dev = np.linalg.norm(offset[good] - med, axis=2)  # (frames, markers)
    sigma = noise_level(offset[good], axis=(0, 2))  # per marker, robust to the outliers
    limit = np.maximum(OUTLIER_FACTOR * sigma * np.sqrt(2.0), OUTLIER_MIN)
    padded = np.pad(dev, ((0, 0), (1, 1)))
    largest = (dev >= padded[:, :-2]) & (dev >= padded[:, 2:])  # a marker off moves its neighbours' offsets by half
    off = (dev > limit) & largest
    return {int(good[k]): [int(i) + 1 for i in np.flatnonzero(off[k])] for k in np.flatnonzero(off.any(axis=1))}


#: With ``on_missing="auto"``, runs of at most this many consecutive frames that cannot be
#: extracted are interpolated (with a warning); a longer run is an error.
MAX_AUTO_GAP = 5


def _runs(frames: list[int]) -> list[tuple[int, int]]:
    """Consecutive runs ``(first, last)`` of sorted frame indices."""
    runs: list[tuple[int, int]] = []
    for k in frames:
        if runs and k == runs[-1][1] + 1:
            runs[-1] = (runs[-1][0], k)
        else:
            runs.append((k, k))
    return runs


def _check_gaps(missing: list[int], problems: dict[int, str], name: str) -> None:
    """``on_missing="auto"``: a warning naming short gaps, an error naming the first gap that is too long."""
    runs = _runs(missing)
    for a, b in runs:
        if b - a + 1 > MAX_AUTO_GAP:
            raise ValueError(
                f"recording {name!r}, frames {a}-{b}: {b - a + 1} consecutive frames cannot be extracted (frame {a}: "
                f"{problems[a]}); on_missing='auto' interpolates at most {MAX_AUTO_GAP} in a row. Look at them with "
                "'pcs-sindy inspect', or interpolate anyway with on_missing='interpolate' (--on-missing interpolate)"
            )
    shown = ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs[:8]) + (" ..." if len(runs) > 8 else "")
    warnings.warn(
        f"recording {name!r}: {len(missing)} frame(s) could not be extracted and were interpolated in time "
        f"(frames {shown}; frame {missing[0]}: {problems[missing[0]]}); on_missing='raise' refuses them",
        UserWarning,
        stacklevel=4,
    )


def extract_recording(recording: Any, name: str, p: dict[str, Any]) -> tuple[PoseTrajectory, dict[str, Any]]:
    """Pose trajectory and diagnostics of one recording (module level so joblib can pickle it)."""
    src = FrameSource(recording, name)
    analysis = None
    if isinstance(p["reference_frame"], str):  # "auto"
        ref, analysis, ref_img, ref_reason = _choose_reference(src, p, name)
    else:
        ref = int(p["reference_frame"])
        if ref >= src.n_frames:
            raise ValueError(f"reference_frame={ref} but recording {name!r} has only {src.n_frames} frames")
        ref_img = src.frame(ref)
        ref_reason = f"frame {ref}: given (reference_frame={ref})"
    size = (int(ref_img.shape[1]), int(ref_img.shape[0]))
    camera, calibration, facts = _resolve_camera(recording, p, size)
    dt, rate_source = _frame_period(p, src, facts, calibration, name)
    if camera is not None and tuple(camera.image_size) != size:
        raise ValueError(
            f"recording {name!r}, frame {ref}: frames are {size[0]}x{size[1]} pixels but the camera ({calibration}) "
            f"expects {camera.image_size[0]}x{camera.image_size[1]} (a camera JSON from another resolution?)"
        )

    # 1. the reference frame chooses the thresholder and fixes the markers
    det, fallbacks, members, spacing, choice = analysis if analysis is not None else _analyse(p, ref_img, name, ref)
    grey = not det.seg.needs_colour
    n = len(members)
    # large markers in JPEG data: decode at a fraction of the resolution (the decoder skips the fine
    # DCT coefficients), keeping markers at least 6 px thick; coordinates are scaled back at the end
    red = 1
    if grey and src.jpeg:
        red = 4 if det.typical["short"] >= 24 else 2 if det.typical["short"] >= 12 else 1
    if red > 1:
        try:
            reduced = _analyse(_reduced_params(p, red), src.frame(ref, grey=True, reduce=red), name, ref)
        except ValueError:
            red = 1  # the markers do not survive the reduction: full resolution
        else:
            if len(reduced[2]) == n and not reduced[0].seg.needs_colour:
                det, fallbacks, members, spacing, choice = reduced
                choice = {
                    **choice,
                    "decoding": f"1/{red} resolution (markers {det.typical['short'] * red:.0f} px thick)",
                }
            else:
                red = 1

    def to_red(px: Any) -> NDArray[np.float64]:
        return (np.asarray(px, dtype=float) - 0.5 * (red - 1)) / red

    # 2. the base: given, the camera's origin, or the chain end that stays put
    ends = members[[0, -1], :2]
    if p["base_position"] is not None:
        base_px, base_source = to_red(p["base_position"]), "given"
        evidence = f"given: base_position={tuple(float(v) for v in p['base_position'])}"
    elif camera is not None and camera.origin is not None:
        base_px, base_source = to_red(camera.unrectify(np.asarray(camera.origin))), "camera origin"
        evidence = f"the camera's origin ({calibration})"
    else:
        b, evidence = _find_base(src, det, ends, spacing, ref, grey, red)
        base_px, base_source = ends[b], "stays put"
    gap = np.linalg.norm(ends - base_px, axis=1)
    if gap.min() > 0.5 * spacing:
        full_ends = (ends * red + 0.5 * (red - 1)).round(1).tolist()
        raise ValueError(
            f"recording {name!r}, frame {ref} (reference frame): neither end of the marker chain ({full_ends} px) lies "
            f"within {0.5 * spacing * red:.1f} px of the base position "
            f"{(base_px * red + 0.5 * (red - 1)).round(1).tolist()} ({base_source})"
        )
    if np.argmin(gap) == 1:
        members = members[::-1]
    first_dir = _first_direction(camera, p, members)

    # 3. every frame: on from the reference frame, then back from it to frame 0 (a robot that starts curled
    # is followed back into its curl from a frame where its chain is plain)
    st = {
        "n": n,
        "base_px": base_px,
        "spacing": spacing,
        "first_dir": first_dir,
        "fill": p["fill_missing"],
        "px_scale": red,
    }
    tracker = FrameTracker([det] + fallbacks, st)
    results: dict[int, FrameResult | None] = {}
    problems: dict[int, str] = {}
    counts: dict[int, int] = {}
    expected = (-(-size[0] // red), -(-size[1] // red))
    damaged = "raise" if p["on_missing"] == "raise" else "none"
    bar = tqdm(total=src.n_frames, desc=f"extract {Path(name).name}", unit="frame", disable=not p["progress"])

    def run(k: int, frame: NDArray[np.uint8] | None) -> None:
        if frame is None:  # undecodable (on_missing allows it): missing, at its own time
            problems[k] = "the frame's data cannot be decoded (damaged, or no file in a numbered folder)"
            counts[k] = 0
            results[k] = None
            bar.update(1)
            return
        if (frame.shape[1], frame.shape[0]) != expected:
            raise ValueError(
                f"recording {name!r}, frame {k}: size {frame.shape[1] * red}x{frame.shape[0] * red} differs from frame "
                f"{ref} ({size[0]}x{size[1]})"
            )
        out, n_found, err = tracker.step(frame)
        counts[k] = n_found
        bar.update(1)
        if out is None:
            if n_found == n:  # every marker is there, but they could not be put in order
                msg = f"found all {n} marker-shaped components (base + {n - 1} markers), but {err}"
            else:
                what = "no markers found" if n_found == 0 else f"found {n_found} marker-shaped components"
                msg = f"{what}, expected {n} (base + {n - 1} markers): {err}"
            if p["on_missing"] == "raise":
                bar.close()
                raise ValueError(f"recording {name!r}, frame {k}: {msg}")
            problems[k] = msg
        results[k] = out

    # frames before the reference are kept in memory when they fit, else read again one by one
    frame_bytes = expected[0] * expected[1] * (1 if grey else 3)
    keep = ref * frame_bytes <= _BUFFER_BYTES
    before: list[NDArray[np.uint8]] = []
    for k, frame in enumerate(src.frames(grey=grey, reduce=red, damaged=damaged)):
        if k < ref:
            if keep:
                before.append(frame)
            continue
        run(k, frame)
    if ref not in results:
        bar.close()
        raise ValueError(
            f"recording {name!r}: decoding stopped after {len(results) + ref} frames, before the reference frame {ref}"
        )
    start = results[ref]
    if start is not None and ref > 0:
        nxt = results.get(ref + 1)
        tracker.resume(start.pix, None if nxt is None else nxt.pix)
        for k in range(ref - 1, -1, -1):
            run(k, before[k] if keep else src.frame(k, grey=grey, reduce=red))
    bar.close()
    outcomes = [results.get(k) for k in range(max(results) + 1)]
    found = [counts.get(k, 0) for k in range(len(outcomes))]
    T = len(outcomes)
    src.check_count(facts.get("n_frames"), calibration or "", allow=p["on_missing"] == "interpolate")
    if T == 0:
        raise ValueError(f"recording {name!r}: no frames")
    if p["on_missing"] == "auto" and problems:
        _check_gaps(sorted(problems), problems, name)
    valid = np.array([o is not None for o in outcomes])
    if not valid.any():
        raise ValueError(f"recording {name!r}: no frame could be extracted")
    if not valid[ref] and ref < T:
        raise ValueError(f"recording {name!r}, frame {ref} (reference frame): {problems.get(ref)}")

    # 4. metres: through the lens (points, not frames), then the base frame
    raw = np.stack([o.pix if o is not None else np.zeros((n, 3)) for o in outcomes])
    raw[..., :2] = raw[..., :2] * red + 0.5 * (red - 1)  # back to full-resolution pixels
    lens = camera if camera is not None else Camera(1.0, None, size, None)
    rect = raw.copy()
    rect[valid] = lens.rectify(raw[valid])
    if camera is None or camera.origin is None or camera.angle is None:
        origin = np.median(rect[valid, 0, :2], axis=0)
        camera, calibration = _complete_camera(
            camera, lens, p, rect[ref], origin, calibration, f"recording {name!r}", ref, rect[valid, 0, 2]
        )
    poses = camera.from_rectified(rect)
    # the base is clamped: pick the 2pi branch that puts its first valid angle nearest 0
    first = int(np.argmax(valid))
    poses[..., 2] -= 2 * np.pi * np.round(poses[first, 0, 2] / (2 * np.pi))
    repaired = sorted(problems)
    if repaired:
        good = np.flatnonzero(valid)
        for i in range(n):
            for c in range(3):
                poses[~valid, i, c] = np.interp(np.flatnonzero(~valid), good, poses[good, i, c])
    jumps = np.abs(np.diff(poses[valid][..., 2], axis=0)) if valid.sum() > 1 else np.zeros((0, n))
    ok = [o for o in outcomes if o is not None]
    diag = {
        "recording": name,
        "n_frames": T,
        "n_markers": n - 1,
        "binarisation": choice,
        "markers_found": np.asarray(found),
        "frames_repaired": repaired,
        "repair_reasons": {k: problems[k] for k in repaired},
        "markers_filled": {k: o.filled for k, o in enumerate(outcomes) if o is not None and o.filled},
        "markers_partial": {k: o.rescued for k, o in enumerate(outcomes) if o is not None and o.rescued},
        "frames_complete": int(sum(1 for o in ok if not o.filled)),
        "frames_tracked": int(sum(o.tracked for o in ok)),
        "fallback_frames": {k: o.seg for k, o in enumerate(outcomes) if o is not None and o.seg != choice["chosen"]},
        "ignored_components": np.array([o.ignored if o is not None else -1 for o in outcomes]),
        "max_theta_step": float(jumps.max()) if jumps.size else 0.0,
        "marker_area_px": det.typical["area"] * red**2,
        "marker_aspect": det.typical["aspect"],
        "marker_spacing_px": spacing * red,
        "base_marker": base_source,
        "frames_listed": {"container": src.n_listed, "camera JSON": facts.get("n_frames")},
        "frame_rate": {"fps": 1.0 / dt, "source": rate_source},
        "base_evidence": evidence,
        "reference_frame": ref,
        "reference_reason": ref_reason,
        "calibration": calibration,
        "camera": camera.to_dict(),
    }
    diag["outlier_frames"] = _track_outliers(poses, valid)
    if "robot_length=" in calibration:  # the scale came from this recording's own reference frame
        chain = rect[ref, :, :2]
        length = float(np.sum(np.linalg.norm(np.diff(chain, axis=0), axis=1)))
        diag["scale_reference"] = {
            "pixels_per_metre": float(camera.pixels_per_metre),
            "straightness": float(np.linalg.norm(chain[-1] - chain[0]) / length) if length > 0 else 0.0,
        }
    meta = {"source": name, "camera": camera.to_dict(), "diagnostics": diag}
    if p["robot_length"] is not None:
        meta["rest_length"] = float(p["robot_length"])
    return PoseTrajectory(poses, dt=dt, metadata=meta), diag


class MarkerStream:
    """Marker poses of one frame after another, from a live camera: see :meth:`MarkerPoseExtractor.stream`.

    Parameters
    ----------
    reference : uint8 image
        The first frame (the robot in view; straight and at rest when the
        scale comes from ``robot_length``).
    p : dict
        The extractor's validated parameters.
    max_predicted : int
        With ``on_missing="predict"``: the most markers of one frame that may
        be predicted (see :meth:`MarkerPoseExtractor.stream`).
    max_run : int
        ... and the most consecutive frames with predicted markers.

    Attributes
    ----------
    last : (N + 1, 3) array
        The poses returned last.
    last_predicted : list of int
        Markers of the last frame predicted rather than measured (empty when
        every marker was measured, filled or rescued).
    diagnostics : dict
        ``binarisation``, ``calibration`` (when the first frame set it),
        ``frames_predicted`` and ``markers_predicted`` (counts so far).

    Notes
    -----
    A frame costs one thresholding and a few small numpy operations (about
    a millisecond at 640x480); one the chosen thresholder cannot complete is
    tried with the other candidates too, so costs about twice that.  The
    per-frame path creates almost no objects that Python's garbage collector
    tracks, but a full collection triggered by the set-up's garbage (or by
    the caller's) traverses every object of the process, numba's compiled
    code included: tens of milliseconds.  A control loop calls
    ``gc.collect(); gc.freeze()`` once its set-up is done, so those objects
    are never traversed again.
    """

    def __init__(
        self, reference: NDArray[np.uint8], p: dict[str, Any], max_predicted: int = 2, max_run: int = 3
    ) -> None:
        ref_img = np.asarray(reference)
        if ref_img.dtype != np.uint8 or ref_img.ndim not in (2, 3):
            raise ValueError(
                f"reference must be a uint8 image (H, W) or (H, W, 3); got {ref_img.dtype} {ref_img.shape}"
            )
        self.size = (int(ref_img.shape[1]), int(ref_img.shape[0]))
        camera = None if isinstance(p["camera"], str) else p["camera"]
        if isinstance(camera, dict):  # a camera JSON or dict, checked by the extractor
            camera = Camera.from_dict(camera, image_size=self.size)
        if camera is not None and tuple(camera.image_size) != self.size:
            raise ValueError(
                f"stream, reference frame: frames are {self.size[0]}x{self.size[1]} pixels but the camera expects "
                f"{camera.image_size[0]}x{camera.image_size[1]}"
            )
        det, fallbacks, members, spacing, choice = _analyse(p, ref_img, "stream", 0)
        ends = members[[0, -1], :2]
        if p["base_position"] is not None:
            base_px = np.asarray(p["base_position"], dtype=float)
        elif camera is not None and camera.origin is not None:
            base_px = camera.unrectify(np.asarray(camera.origin))
        else:
            raise ValueError(
                "stream: the base cannot be told from one frame; give base_position or a camera with an origin"
            )
        gap = np.linalg.norm(ends - base_px, axis=1)
        if gap.min() > 0.5 * spacing:
            raise ValueError(
                "stream, reference frame: neither end of the marker chain lies near the base "
                f"{base_px.round(1).tolist()}"
            )
        if np.argmin(gap) == 1:
            members = members[::-1]
        self.grey = not det.seg.needs_colour
        self.n_markers = len(members) - 1
        st = {
            "n": len(members),
            "base_px": base_px,
            "spacing": spacing,
            "first_dir": _first_direction(camera, p, members),
            "fill": p["fill_missing"],
        }
        self.tracker = FrameTracker([det] + fallbacks, st)
        self.diagnostics: dict[str, Any] = {"binarisation": choice, "frames_predicted": 0, "markers_predicted": 0}
        self.on_missing = p["on_missing"]
        self.max_predicted, self.max_run = max_predicted, max_run
        self.last_predicted: list[int] = []
        self._run = 0  # consecutive frames with predicted markers
        out, _, err = self.tracker.step(self._prepare(ref_img))
        if out is None:
            raise ValueError(f"stream, reference frame: {err}")
        lens = camera if camera is not None else Camera(1.0, None, self.size, None)
        rect = lens.rectify(out.pix)
        if camera is None or not camera.has_base_frame:
            camera, calibration = _complete_camera(camera, lens, p, rect, rect[0, :2], "given camera", "stream", 0)
            self.diagnostics["calibration"] = calibration
        self.camera = camera
        first = camera.from_rectified(rect)
        self._branch = 2 * np.pi * np.round(first[0, 2] / (2 * np.pi))  # the base angle nearest 0, kept from now on
        self.n_frames = 1
        self.last = first - np.array([0.0, 0.0, self._branch])
        self._history = [out.pix]  # pixel poses of the last two frames returned, oldest first

    def _prepare(self, frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
        img = np.asarray(frame)
        if (img.shape[1], img.shape[0]) != self.size or img.dtype != np.uint8:
            raise ValueError(
                f"stream, frame {getattr(self, 'n_frames', 0)}: expected a uint8 image of "
                f"{self.size[0]}x{self.size[1]} "
                f"pixels; got {img.dtype} {img.shape[1::-1] if img.ndim >= 2 else img.shape}"
            )
        if self.grey and img.ndim == 3:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        return img

    def update(self, frame: NDArray[np.uint8]) -> NDArray[np.float64]:
        """Poses (N + 1, 3) of the base and the markers in this frame, metres/radians in the base frame.

        With ``on_missing="predict"``, a frame that cannot be extracted but
        whose lost markers are few gets them predicted
        (:attr:`last_predicted` names them).

        Raises
        ------
        ValueError
            When the frame's markers cannot be extracted (the message says
            why) and cannot be predicted; the next frame is then chained from
            the base again.
        """
        img = self._prepare(frame)
        out, n_found, err = self.tracker.step(img)
        k = self.n_frames
        self.n_frames += 1
        self.last_predicted = []
        if out is None:
            what = f"found {n_found} marker-shaped components" + (" (a blank frame?)" if n_found == 0 else "")
            msg = f"stream, frame {k}: {what}, expected {self.n_markers + 1}: {err}"
            if self.on_missing != "predict":
                self._history = []
                raise ValueError(msg)
            pix = self._predict(msg)
        else:
            pix = out.pix
            self._run = 0
        self._history = [self._history[-1], pix] if self._history else [pix]
        poses = self.camera.from_rectified(self.camera.rectify(pix))
        poses[:, 2] -= self._branch
        self.last = poses
        return poses

    def _predict(self, msg: str) -> NDArray[np.float64]:
        """Pixel poses of a frame the tracker could not extract: the markers found where the last two frames
        put them, the lost ones continued at constant velocity; raises ValueError (``msg`` and why) otherwise."""
        hist, self._history = self._history, []  # a raise below leaves no history
        if len(hist) < 2:
            raise ValueError(f"{msg}; no markers predicted: the two frames before were not both extracted")
        if len(self.tracker.candidates) == 0:
            raise ValueError(f"{msg}; no markers predicted: nothing in view to anchor a prediction")
        if self._run >= self.max_run:
            raise ValueError(f"{msg}; no markers predicted: already {self._run} frames in a row predicted")
        # constant velocity in pixels: at camera rate a marker moves a fraction of the spacing per frame
        pred = 2.0 * hist[1] - hist[0]
        cands = self.tracker.candidates  # of the chosen thresholder, as tracker.step found them
        match = track(hist[1][:, :2], pred[:, :2], cands[:, :2])
        if match is None:
            raise ValueError(f"{msg}; no markers predicted: the markers found do not match the prediction one to one")
        lost = np.flatnonzero(match < 0)
        if lost.size == 0:
            # every marker is where it was expected, yet the tracker refused the frame (a chain that crosses
            # itself, zigzags or faces against itself): its measurements are not to be trusted either
            raise ValueError(f"{msg}; no markers predicted: none is lost, the frame failed the chain's checks")
        if lost.size > self.max_predicted:
            raise ValueError(
                f"{msg}; no markers predicted: {lost.size} markers lost ({lost.tolist()}), at most "
                f"{self.max_predicted} are predicted"
            )
        pix = pred.copy()
        seen = match >= 0
        pix[seen, :2] = cands[match[seen], :2]
        # a marker's axis is known up to a half turn: take the branch nearest the prediction
        pix[seen, 2] = pred[seen, 2] + wrap_half_pi(cands[match[seen], AXIS] - pred[seen, 2])
        # the tracker follows the markers on from here instead of chaining the next frame from the base
        self.tracker.prev2, self.tracker.prev = hist[1][:, :2], pix[:, :2]
        self._run += 1
        self._history = hist
        self.last_predicted = lost.tolist()
        self.diagnostics["frames_predicted"] += 1
        self.diagnostics["markers_predicted"] += int(lost.size)
        return pix
