"""One recording -> marker poses: the work behind :class:`pcs_sindy.vision.MarkerPoseExtractor`.

1. **Reference frame first.**  Before anything else is decoded, every
   candidate segmentation (:mod:`pcs_sindy.binarisation`) is tried on the
   reference frame; the one whose components form the longest chain of
   similar markers (:func:`~pcs_sindy.marker_chain.link_chains`) wins, and
   its reasons go to the diagnostics.  No chain, a chain of the wrong length
   or two chains (two robots) stop here with a message naming what was found
   and what to try.
2. **The base.**  Given, the camera's origin, or the end of the reference
   chain that stays put in a few frames sampled over the recording.
3. **Every frame, in one pass.**  Markers are tracked from the previous frame
   when that is unambiguous, otherwise chained from the base; a frame the
   chosen segmentation cannot complete is tried with the other candidates; an
   isolated missing or partly hidden marker is filled from its neighbours.
   A frame that still fails raises (naming recording and frame) or is
   interpolated in time, per ``on_missing``.
4. **Metres.**  Marker centres and axes go through the camera's lens model
   (points, not frames) and its similarity to the robot's base frame.

Knows nothing of dynamics.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from .binarisation import ColourSegmentation, LocalSegmentation, OtsuSegmentation, RangeSegmentation, Segmentation
from .binarisation import candidate_segmentations
from .camera import Camera, camera_json_path, read_camera_json
from .frame_source import FrameSource
from .marker_chain import chain_from_base, crossings, fill_gaps, fillable, frame_angles, link_chains, track, zigzags
from .markers import AREA, AXIS, LONG, PIXELS, SHORT, find_components, refine
from .trajectory import PoseTrajectory

__all__ = ["extract_recording"]

_N_BASE_SAMPLES = 8
_HINTS = (
    "check that the robot is in view and its markers contrast with their surroundings; give n_markers=N; exclude "
    "clutter with roi=(x, y, width, height); try threshold='local' (uneven light), threshold='colour' (coloured "
    "markers), a fixed grey level threshold=<0-255> or a colour range threshold=((b0, g0, r0), (b1, g1, r1)); "
    "polarity='bright' for markers lighter than the background"
)


class FrameProblem(ValueError):
    """A frame whose markers could not be extracted."""


def _segmentations(p: dict[str, Any], ref_img: NDArray[np.uint8]) -> list[Segmentation]:
    thr = p["threshold"]
    if isinstance(thr, tuple):
        return [RangeSegmentation(*thr)]
    if thr == "auto":
        return candidate_segmentations(ref_img, p["polarity"], p["blur"])
    if thr == "otsu":
        return [OtsuSegmentation(None, p["polarity"], p["blur"])]
    if thr == "local":
        return [LocalSegmentation(p["polarity"]).prepare(ref_img)]
    if thr == "colour":
        try:
            return [ColourSegmentation().prepare(ref_img)]
        except ValueError as err:
            raise ValueError(f"threshold='colour': {err}") from None
    return [OtsuSegmentation(float(thr), p["polarity"], p["blur"])]


class _Detector:
    """Per-frame candidates with one segmentation, knowing the typical marker once it is set."""

    def __init__(self, seg: Segmentation, p: dict[str, Any]) -> None:
        self.seg = seg
        self.p = p
        self.typical: dict[str, float] | None = None

    def __call__(self, frame: NDArray[np.uint8]) -> NDArray[np.float64]:
        roi = self.p["roi"]
        x0 = y0 = 0
        if roi is not None:
            x0, y0, w, h = roi
            frame = frame[y0 : y0 + h, x0 : x0 + w]
        work = self.seg.work(frame)
        binary = self.seg.binary(work)
        comps = find_components(binary)
        ok = comps.area >= self.p["min_area"]
        if self.typical is not None:
            t = self.typical
            ok &= (comps.area >= 0.25 * t["pixels"]) & (comps.area <= 4.0 * t["pixels"])
            ok &= comps.box[:, 2:].max(axis=1) <= 1.6 * (t["long"] + t["short"]) + 3
        else:
            ok &= comps.box[:, 2:].max(axis=1) <= 0.5 * max(binary.shape)  # not a floor or a wall
        if not self.p["refine"]:
            from .markers import _BinaryCoverage

            return refine(_BinaryCoverage(binary), None, comps, np.flatnonzero(ok), binary.shape, (x0, y0))
        return refine(self.seg, work, comps, np.flatnonzero(ok), binary.shape, (x0, y0))

    def accept(self, cands: NDArray[np.float64]) -> NDArray[np.float64]:
        """The marker-shaped candidates (area and aspect like the typical marker)."""
        t = self.typical
        lo, hi = self.p["area_tolerance"]
        tol = self.p["aspect_tolerance"]
        aspect = cands[:, LONG] / np.maximum(cands[:, SHORT], 1e-9)
        ok = (cands[:, AREA] >= lo * t["area"]) & (cands[:, AREA] <= hi * t["area"])
        ok &= (aspect >= t["aspect"] / tol) & (aspect <= t["aspect"] * tol)
        return cands[ok]


def _pick_chain(chains: list[NDArray[np.intp]], n_expected: int | None) -> NDArray[np.intp] | None:
    if not chains:
        return None
    if n_expected is not None:
        exact = [c for c in chains if len(c) == n_expected]
        if exact:
            return exact[0]
    return chains[0]


def _reference(p: dict[str, Any], segs: list[Segmentation], ref_img: NDArray[np.uint8], name: str, ref: int) -> tuple:
    """Choose the segmentation on the reference frame: (detector, candidates, chain, report)."""
    n_expected = None if p["n_markers"] is None else p["n_markers"] + 1
    results = []
    for seg in segs:
        det = _Detector(seg, p)
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
        raise ValueError(f"recording {name!r}, frame {ref} (reference frame): expected a chain of {want}; {what}. Try: {_HINTS}")
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


def _find_base(src: FrameSource, det: _Detector, ends: NDArray[np.float64], spacing: float, ref: int, grey: bool, reduce: int) -> int:
    """Which end of the reference chain (0 or 1) stays put over frames sampled across the recording."""
    name = src.name
    picks = [k for k in np.linspace(0, src.n_frames - 1, _N_BASE_SAMPLES + 1).round().astype(int) if k != ref]
    picks = sorted(set(picks))
    if not picks:
        raise ValueError(f"recording {name!r}: cannot tell the base marker from a single frame; give base_position or a camera")
    worst = np.zeros(2)
    for k in picks:
        try:
            cands = det.accept(det(src.frame(int(k), grey=grey, reduce=reduce)))
        except OSError:
            continue  # a frame the container cannot seek to: the pass over all frames will report it
        if len(cands) == 0:
            continue
        d = np.linalg.norm(ends[:, None] - cands[None, :, :2], axis=-1).min(axis=1)
        worst = np.maximum(worst, d)
    b = int(np.argmin(worst))
    # the base moves by detection noise only; the tip must move clearly more somewhere
    if worst[1 - b] < max(4.0 * worst[b], 1.0, 0.1 * spacing):
        raise ValueError(
            f"recording {name!r}: both ends of the marker chain stay put (the robot hardly moves), so the base marker is "
            "ambiguous; give base_position or a camera"
        )
    return b


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


def _resolve_camera(recording: Any, p: dict[str, Any]) -> tuple[Camera | None, str | None, float | None]:
    camera, json_fps = p["camera"], None
    if isinstance(camera, str):  # "auto"
        if isinstance(recording, (str, os.PathLike)):
            jpath = camera_json_path(recording)
            if jpath.exists():
                data = read_camera_json(jpath)
                try:
                    camera = Camera.from_dict(data)
                except ValueError as err:
                    raise ValueError(f"camera JSON {str(jpath)!r}: {err}") from None
                return camera, f"camera JSON {str(jpath)!r}", data.get("fps")
        return None, None, None
    return camera, (None if camera is None else "given camera"), json_fps


class _Frame:
    """The outcome of one frame: raw pixel poses of the chain, or a problem."""

    __slots__ = ("pix", "found", "filled", "tracked", "seg", "ignored")

    def __init__(self, pix: NDArray[np.float64], found: int, filled: list[int], tracked: bool, seg: str, ignored: int) -> None:
        self.pix, self.found, self.filled, self.tracked, self.seg, self.ignored = pix, found, filled, tracked, seg, ignored


def _order_frame(
    cands: NDArray[np.float64], st: dict[str, Any], prev: NDArray[np.float64] | None, pred: NDArray[np.float64] | None, phi0: float | None
) -> tuple[NDArray[np.float64], list[int], int, bool]:
    """Order one frame's marker-shaped candidates into the chain; raises FrameProblem.

    The previous frame's markers are tracked first (cheap); when that is
    ambiguous or leaves a frame that fails the checks, the frame is chained
    from the base.
    """
    if prev is not None and len(cands):
        match = track(prev, pred, cands[:, :2])
        if match is not None and np.count_nonzero(match < 0) <= 1:
            try:
                return _finish(cands, match, st, phi0) + (True,)
            except FrameProblem:
                pass
    if len(cands) == 0:
        raise FrameProblem("no markers found")
    d = np.linalg.norm(cands[:, :2] - st["base_px"], axis=1)
    b = int(np.argmin(d))
    if d[b] > 0.5 * st["spacing"]:
        raise FrameProblem(f"no marker within {0.5 * st['spacing']:.1f} px of the base position {st['base_px'].round(1).tolist()}")
    seq, err = chain_from_base(cands[:, :2], cands[:, AXIS], b, st["spacing"], st["first_dir"], st["n"], st["fill"])
    if err is not None:
        raise FrameProblem(err)
    return _finish(cands, np.array([-1 if i is None else i for i in seq]), st, phi0) + (False,)


def _finish(cands: NDArray[np.float64], order: NDArray[np.intp], st: dict[str, Any], phi0: float | None) -> tuple:
    """Angles, filled gaps and checks of an ordered chain (-1: missing): (pixel poses, filled, ignored)."""
    missing = order < 0
    # a marker much smaller or larger than its chain neighbours is partly hidden or merged: treat it as missing
    area = np.where(missing, np.nan, cands[order, AREA])
    # the median of the three markers on either side: one odd marker does not make its neighbours odd
    pad = np.concatenate([np.full(3, np.nan), area, np.full(3, np.nan)])
    window = np.stack([pad[j : j + len(area)] for j in (0, 1, 2, 4, 5, 6)])
    srt = np.sort(window, axis=0)  # NaN last
    cnt = np.isfinite(window).sum(axis=0)
    lo, hi = np.maximum(cnt - 1, 0) // 2, cnt // 2
    ref = 0.5 * (np.take_along_axis(srt, lo[None], 0)[0] + np.take_along_axis(srt, np.minimum(hi, 5)[None], 0)[0])
    with np.errstate(invalid="ignore"):
        missing = missing | (area < 0.78 * ref) | (area > 1.28 * ref)
    if missing.any() and (not st["fill"] or not fillable(missing, st["base_pose"] is not None)):
        raise FrameProblem(f"marker(s) {np.flatnonzero(missing).tolist()} missing, merged or partly hidden")
    idx = order[~missing]
    pts = cands[idx, :2]
    phi_det, conflicts = frame_angles(pts, cands[idx, AXIS], phi0)
    pix = np.zeros((len(order), 3))
    pix[~missing, :2], pix[~missing, 2] = pts, phi_det
    pix = fill_gaps(pix, missing, st["base_pose"])
    if crossings(pix[:, :2]):
        raise FrameProblem("the ordered marker chain crosses itself (ordering not trustworthy)")
    if zigzags(pix[:, 2]) >= 3:
        raise FrameProblem("marker angles zigzag along the chain (interleaved markers; ordering not trustworthy)")
    if conflicts:
        raise FrameProblem(f"{conflicts} marker(s) face against the chain direction (ordering not trustworthy)")
    others = np.setdiff1d(np.arange(len(cands)), idx)
    if others.size >= 5:
        # marker-shaped components off the chain are clutter, unless they form a chain of their own
        second = link_chains(cands[others])
        if second and len(second[0]) >= max(5, len(order) // 2):
            raise FrameProblem(
                f"a second chain of {len(second[0])} markers besides the robot's (another robot in view? restrict "
                "the view with roi=(x, y, width, height))"
            )
    return pix, np.flatnonzero(missing).tolist(), others.size


def _analyse(p: dict[str, Any], ref_img: NDArray[np.uint8], name: str, ref: int) -> tuple:
    """Segmentation, fallbacks, chained markers, their spacing and the report, from the reference frame."""
    roi = p["roi"]
    segs = _segmentations(p, ref_img if roi is None else ref_img[roi[1] : roi[1] + roi[3], roi[0] : roi[0] + roi[2]])
    det, cands, chain, choice = _reference(p, segs, ref_img, name, ref)
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
    fallbacks = [_Detector(s, p) for s in segs if s is not det.seg and (not grey or not s.needs_colour)]
    for f in fallbacks:
        f.typical = det.typical
    return det, fallbacks, members, spacing, choice


def _reduced_params(p: dict[str, Any], red: int) -> dict[str, Any]:
    """Pixel-valued parameters for frames decoded at 1/red of the resolution."""
    q = dict(p, min_area=p["min_area"] / red**2)
    if p["marker_area"] is not None:
        q["marker_area"] = p["marker_area"] / red**2
    if p["roi"] is not None:
        x, y, w, h = p["roi"]
        q["roi"] = (x // red, y // red, max(1, -(-w // red)), max(1, -(-h // red)))
    return q


def extract_recording(recording: Any, name: str, p: dict[str, Any]) -> tuple[PoseTrajectory, dict[str, Any]]:
    """Pose trajectory and diagnostics of one recording (module level so joblib can pickle it)."""
    src = FrameSource(recording, name)
    camera, calibration, json_fps = _resolve_camera(recording, p)
    if p["dt"] is not None:
        dt = float(p["dt"])
    elif p["fps"] is not None:
        dt = 1.0 / float(p["fps"])
    elif src.fps is not None:
        dt = 1.0 / src.fps
    elif json_fps is not None:
        dt = 1.0 / float(json_fps)
    else:
        raise ValueError(f"recording {name!r}: the frame rate is unknown; give fps or dt")
    ref = p["reference_frame"]
    if ref >= src.n_frames:
        raise ValueError(f"reference_frame={ref} but recording {name!r} has only {src.n_frames} frames")
    ref_img = src.frame(ref)
    size = (int(ref_img.shape[1]), int(ref_img.shape[0]))
    if camera is not None and tuple(camera.image_size) != size:
        raise ValueError(
            f"recording {name!r}, frame {ref}: frames are {size[0]}x{size[1]} pixels but the camera ({calibration}) "
            f"expects {camera.image_size[0]}x{camera.image_size[1]} (a camera JSON from another resolution?)"
        )

    # 1. the reference frame chooses the segmentation and fixes the markers
    det, fallbacks, members, spacing, choice = _analyse(p, ref_img, name, ref)
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
                choice = {**choice, "decoding": f"1/{red} resolution (markers {det.typical['short'] * red:.0f} px thick)"}
            else:
                red = 1
    to_red = (lambda px: (np.asarray(px, dtype=float) - 0.5 * (red - 1)) / red)

    # 2. the base: given, the camera's origin, or the chain end that stays put
    ends = members[[0, -1], :2]
    if p["base_position"] is not None:
        base_px, base_source = to_red(p["base_position"]), "given"
    elif camera is not None and camera.origin is not None:
        base_px, base_source = to_red(camera.unrectify(np.asarray(camera.origin))), "camera origin"
    else:
        base_px, base_source = ends[_find_base(src, det, ends, spacing, ref, grey, red)], "stays put"
    gap = np.linalg.norm(ends - base_px, axis=1)
    if gap.min() > 0.5 * spacing:
        raise ValueError(
            f"recording {name!r}, frame {ref} (reference frame): neither end of the marker chain lies within "
            f"{0.5 * spacing:.1f} px of the base position {base_px.round(1).tolist()} ({base_source})"
        )
    if np.argmin(gap) == 1:
        members = members[::-1]
    if camera is not None and camera.angle is not None:
        o = camera.unrectify(np.asarray(camera.origin if camera.origin is not None else (0.0, 0.0)))
        tip = camera.unrectify(o + 10.0 * np.array([-np.sin(camera.angle), np.cos(camera.angle)]))
        first_dir = (tip - o) / np.linalg.norm(tip - o)
    elif p["rest_direction"] is not None:
        first_dir = np.array([np.cos(p["rest_direction"]), np.sin(p["rest_direction"])])
    else:
        first_dir = np.array([np.cos(_rest_direction(members[:, :2])), np.sin(_rest_direction(members[:, :2]))])

    # 3. every frame
    st = {"n": n, "base_px": base_px, "spacing": spacing, "first_dir": first_dir, "fill": p["fill_missing"], "base_pose": None}
    T_hint = src.n_frames
    pix_all: list[NDArray[np.float64] | None] = []
    outcomes: list[_Frame | None] = []
    problems: dict[int, str] = {}
    found = []
    prev = prev2 = None
    phi0 = None
    expected = (-(-size[0] // red), -(-size[1] // red))
    for k, frame in enumerate(tqdm(src.frames(grey=grey, reduce=red), total=T_hint, desc=f"extract {Path(name).name}",
                                   unit="frame", disable=not p["progress"])):
        if (frame.shape[1], frame.shape[0]) != expected:
            raise ValueError(
                f"recording {name!r}, frame {k}: size {frame.shape[1] * red}x{frame.shape[0] * red} differs from frame "
                f"{ref} ({size[0]}x{size[1]})"
            )
        pred = None if prev is None else (prev if prev2 is None else 2.0 * prev - prev2)
        out = None
        err = None
        n_found = 0
        for d in [det] + fallbacks:
            shaped = d.accept(d(frame))
            if d is det:
                n_found = len(shaped)
            try:
                pix, filled, ignored, tracked = _order_frame(shaped, st, prev, pred, phi0)
            except FrameProblem as e:
                if err is None:
                    err = str(e)
                continue
            out = _Frame(pix, len(shaped) - ignored, filled, tracked, d.seg.describe(), ignored)
            break
        found.append(n_found)
        if out is None:
            what = "no markers found" if n_found == 0 else f"found {n_found} marker-shaped components"
            msg = f"{what}, expected {n} (base + {n - 1} markers): {err}"
            if p["on_missing"] == "raise":
                raise ValueError(f"recording {name!r}, frame {k}: {msg}")
            problems[k] = msg
            prev = prev2 = None
            outcomes.append(None)
            pix_all.append(None)
            continue
        prev2, prev = prev, out.pix[:, :2]
        phi0 = out.pix[0, 2]
        if 0 not in out.filled:
            st["base_pose"] = out.pix[0]
        outcomes.append(out)
        pix_all.append(out.pix)
    T = len(outcomes)
    if T == 0:
        raise ValueError(f"recording {name!r}: no frames")
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
        origin = np.median(rect[valid, 0, :2], axis=0) if camera is None or camera.origin is None else np.asarray(camera.origin)
        if camera is not None and camera.angle is not None:
            angle = camera.angle
        elif p["rest_direction"] is not None and (camera is None or not camera.has_lens):
            angle = float(p["rest_direction"]) - 0.5 * np.pi
        else:
            angle = _rest_direction(rect[ref, :, :2]) - 0.5 * np.pi
        if camera is not None:
            ppm, calibration = camera.pixels_per_metre, f"{calibration} (base frame found in the footage)"
        elif p["pixels_per_metre"] is not None:
            ppm, calibration = float(p["pixels_per_metre"]), "given pixels_per_metre"
        elif p["robot_length"] is not None:
            ppm = float(np.sum(np.linalg.norm(np.diff(rect[ref, :, :2], axis=0), axis=1))) / float(p["robot_length"])
            calibration = f"straight reference frame {ref} with robot_length={p['robot_length']!r}"
        else:
            raise ValueError(
                f"recording {name!r}: no calibration; give camera, pixels_per_metre, or robot_length "
                "(with a straight reference frame)"
            )
        if p["base_position"] is not None:
            origin = lens.rectify(np.asarray(p["base_position"], dtype=float))
        camera = replace(lens, pixels_per_metre=ppm, origin=tuple(origin), angle=angle)
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
        "frames_complete": int(sum(1 for o in ok if not o.filled)),
        "frames_tracked": int(sum(o.tracked for o in ok)),
        "fallback_frames": {k: o.seg for k, o in enumerate(outcomes) if o is not None and o.seg != choice["chosen"]},
        "ignored_components": np.array([o.ignored if o is not None else -1 for o in outcomes]),
        "max_theta_step": float(jumps.max()) if jumps.size else 0.0,
        "marker_area_px": det.typical["area"] * red**2,
        "marker_aspect": det.typical["aspect"],
        "marker_spacing_px": spacing * red,
        "base_marker": base_source,
        "calibration": calibration,
        "camera": camera.to_dict(),
    }
    meta = {"source": name, "camera": camera.to_dict(), "diagnostics": diag}
    if p["robot_length"] is not None:
        meta["rest_length"] = float(p["robot_length"])
    return PoseTrajectory(poses, dt=dt, metadata=meta), diag
