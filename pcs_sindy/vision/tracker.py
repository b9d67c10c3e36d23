"""One frame after another: the markers of each frame, ordered base -> tip.

:class:`FrameTracker` holds what a recording's reference frame fixed (the
thresholder and its fallbacks, the typical marker, the base, the spacing)
and what the last frames showed; :meth:`FrameTracker.step` turns one frame
into the pixel poses of the whole chain, tracking the previous frame's
markers when that is unambiguous and chaining from the base otherwise,
measuring a marker the chain lacks from a partial or faint component at its
predicted pose, filling an isolated missing marker, and refusing chains that
cannot be trusted.  Used by the batch extraction and by the streaming extractor.

Knows nothing of dynamics.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from .chain import (
    chain_from_base,
    crossings,
    fill_gaps,
    fillable,
    frame_angles,
    link_chains,
    track,
    wrap_half_pi,
    zigzags,
)
from .markers import AREA, AXIS, LONG, SHORT, find_components, measure_components
from .thresholding import Thresholder

__all__ = ["FrameProblem", "FrameResult", "FrameTracker", "Detector"]

_OPEN = np.ones((3, 3), np.uint8)
_LINK_RATIO = 1.6  # most a link between neighbouring markers may exceed both links beside it
_FILLED_RATIO = 1.8  # ... and, in a frame with a filled marker, the reference frame's spacing


class FrameProblem(ValueError):
    """A frame whose markers could not be extracted."""


class Detector:
    """Per-frame candidates with one thresholder, knowing the typical marker once it is set."""

    def __init__(self, seg: Thresholder, p: dict[str, Any], opened: bool = False) -> None:
        self.seg = seg
        self.p = p
        self.opened = opened
        self.typical: dict[str, float] | None = None

    def __call__(self, frame: NDArray[np.uint8]) -> NDArray[np.float64]:
        roi = self.p["roi"]
        x0 = y0 = 0
        if roi is not None:
            x0, y0, w, h = roi
            frame = frame[y0 : y0 + h, x0 : x0 + w]
        work = self.seg.work(frame)
        binary = self.seg.binary(work)
        if self.opened:
            # strokes of text, cables and outlines thinner than 3 px touching a marker merge with it: cut
            # them off (a marker 5 px thick keeps its shape; its edge is measured on the grey image)
            binary = cv2.morphologyEx(binary, cv2.MORPH_OPEN, _OPEN)
        comps = find_components(binary)
        ok = comps.area >= self.p["min_area"]
        if self.typical is not None:
            t = self.typical
            ok &= (comps.area >= 0.25 * t["pixels"]) & (comps.area <= 4.0 * t["pixels"])
            ok &= comps.box[:, 2:].max(axis=1) <= 1.6 * (t["long"] + t["short"]) + 3
        else:
            ok &= comps.box[:, 2:].max(axis=1) <= 0.5 * max(binary.shape)  # not a floor or a wall
        if not self.p["refine"]:
            from .markers import BinaryCoverage

            return measure_components(BinaryCoverage(binary), None, comps, np.flatnonzero(ok), binary.shape, (x0, y0))
        return measure_components(self.seg, work, comps, np.flatnonzero(ok), binary.shape, (x0, y0))

    def accept(self, cands: NDArray[np.float64]) -> NDArray[np.float64]:
        """The marker-shaped candidates (area and aspect like the typical marker)."""
        t = self.typical
        lo, hi = self.p["area_tolerance"]
        tol = self.p["aspect_tolerance"]
        aspect = cands[:, LONG] / np.maximum(cands[:, SHORT], 1e-9)
        ok = (cands[:, AREA] >= lo * t["area"]) & (cands[:, AREA] <= hi * t["area"])
        ok &= (aspect >= t["aspect"] / tol) & (aspect <= t["aspect"] * tol)
        return cands[ok]


class FrameResult:
    """The outcome of one frame: raw pixel poses of the chain, or a problem."""

    __slots__ = ("pix", "found", "filled", "tracked", "seg", "ignored", "rescued")

    def __init__(
        self,
        pix: NDArray[np.float64],
        found: int,
        filled: list[int],
        tracked: bool,
        seg: str,
        ignored: int,
        rescued: list[int] | None = None,
    ) -> None:
        self.pix, self.found, self.filled, self.tracked, self.seg, self.ignored = (
            pix,
            found,
            filled,
            tracked,
            seg,
            ignored,
        )
        self.rescued = [] if rescued is None else rescued  # measured from a partial or faint component


def _rematch(cands: NDArray[np.float64], match: NDArray[np.intp], spacing: float) -> NDArray[np.intp]:
    """Markers the previous frame could not place, found from their neighbours in this frame.

    A fast marker (the tip) can outrun the prediction from the previous
    frames; its detected neighbours predict it better: halfway between them,
    or, for the tip, the last chord turned by the last turn (constant strain).
    Taken only when a single unclaimed candidate lies near the prediction.
    """
    match = match.copy()
    n = len(match)
    free = np.setdiff1d(np.arange(len(cands)), match[match >= 0])
    for i in np.flatnonzero(match < 0):
        if 0 < i < n - 1 and match[i - 1] >= 0 and match[i + 1] >= 0:
            guess = 0.5 * (cands[match[i - 1], :2] + cands[match[i + 1], :2])
        elif i == n - 1 and n >= 3 and match[i - 1] >= 0 and match[i - 2] >= 0:
            a, b = cands[match[i - 2]], cands[match[i - 1]]
            turn = float(wrap_half_pi(b[AXIS] - a[AXIS]))
            c, s_ = np.cos(turn), np.sin(turn)
            chord = b[:2] - a[:2]
            guess = b[:2] + np.array([c * chord[0] - s_ * chord[1], s_ * chord[0] + c * chord[1]])
        else:
            continue
        if free.size == 0:
            break
        d = np.linalg.norm(cands[free, :2] - guess, axis=1)
        order = np.argsort(d)
        if d[order[0]] <= 0.35 * spacing and (order.size == 1 or d[order[1]] > 0.8 * spacing):
            match[i] = free[order[0]]
            free = np.delete(free, order[0])
    return match


def _order_frame(
    cands: NDArray[np.float64],
    st: dict[str, Any],
    prev: NDArray[np.float64] | None,
    pred: NDArray[np.float64] | None,
    phi0: float | None,
    raw: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], list[int], int, list[int], bool]:
    """Order one frame's marker-shaped candidates into the chain; raises FrameProblem.

    The previous frame's markers are tracked first (cheap); when that is
    ambiguous or leaves a frame that fails the checks, the frame is chained
    from the base.
    """
    if prev is not None and len(cands):
        match = track(prev, pred, cands[:, :2])
        if match is not None and 0 < np.count_nonzero(match < 0) <= 2:
            match = _rematch(cands, match, st["spacing"])
        if match is not None and np.count_nonzero(match < 0) <= 1:
            try:
                return _finish(cands, match, st, phi0, raw) + (True,)
            except FrameProblem:
                pass
    if len(cands) == 0:
        raise FrameProblem("no markers found")
    d = np.linalg.norm(cands[:, :2] - st["base_px"], axis=1)
    b = int(np.argmin(d))
    scale = st.get("px_scale", 1)  # frames decoded at 1/scale of the footage's resolution: report full-size pixels
    if d[b] > 0.5 * st["spacing"]:
        base_full = (st["base_px"] * scale + 0.5 * (scale - 1)).round(1).tolist()
        raise FrameProblem(
            f"the chain breaks at the base: no marker within {0.5 * st['spacing'] * scale:.1f} px of the base "
            f"position {base_full} (nearest {d[b] * scale:.1f} px away)"
        )
    seq, err = chain_from_base(
        cands[:, :2], cands[:, AXIS], b, st["spacing"], st["first_dir"], st["n"], st["fill"], px_scale=scale
    )
    if err is not None:
        raise FrameProblem(err)
    return _finish(cands, np.array([-1 if i is None else i for i in seq]), st, phi0, raw) + (False,)


# How much a marker's area, long side and short side may differ (log ratio) from its chain
# neighbours' medians, in one combined distance: a partly hidden marker loses area, one merged
# with clutter or text grows in length and width, motion blur widens it (short side) the most
_SHAPE_SCALE = np.array([0.25, 0.12, 0.3])


def _neighbour_median(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Median of the three chain neighbours on either side of each marker (NaN: missing)."""
    n = len(values)
    pad = np.concatenate([np.full(3, np.nan), values, np.full(3, np.nan)])
    window = np.stack([pad[j : j + n] for j in (0, 1, 2, 4, 5, 6)])
    srt = np.sort(window, axis=0)  # NaN last
    cnt = np.isfinite(window).sum(axis=0)
    lo, hi = np.maximum(cnt - 1, 0) // 2, np.minimum(cnt // 2, 5)
    return 0.5 * (np.take_along_axis(srt, lo[None], 0)[0] + np.take_along_axis(srt, hi[None], 0)[0])


def _odd_shapes(
    cands: NDArray[np.float64], order: NDArray[np.intp], missing: NDArray[np.bool_]
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Markers whose shape differs from their neighbours' (partly hidden, or merged with something), and
    the neighbours' median area, long and short side of every marker (N + 1, 3)."""
    feats = np.where(missing[:, None], np.nan, cands[order][:, [AREA, LONG, SHORT]])
    with np.errstate(invalid="ignore", divide="ignore"):
        ref = np.stack([_neighbour_median(feats[:, c]) for c in range(3)], axis=1)
        dist = np.sqrt(np.sum((np.log(feats / ref) / _SHAPE_SCALE) ** 2, axis=1))
        return dist > 1.0, ref


# A second look at a marker the chain lacks, among all components of the frame: one at the place the chain
# predicts, turned like the prediction and as thick as its neighbours, may be shorter (partly hidden: the
# occluder cuts one end) or fainter (motion blur thins the fast tip below the threshold) than they are
_RESCUE_TURN = np.deg2rad(12.0)
_RESCUE_SHORT = (0.8, 1.25)  # times the neighbours' short side
_RESCUE_LONG = (0.3, 1.1)  # ... long side
_RESCUE_AREA = (0.2, 1.1)  # ... area
_PARTIAL = 0.8  # shorter than this share of the neighbours' long side: one end is hidden


def _rescue(
    raw: NDArray[np.float64],
    pix: NDArray[np.float64],
    missing: NDArray[np.bool_],
    ref: NDArray[np.float64],
    spacing: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], list[int]]:
    """Missing markers measured after all, from a component at their predicted pose: (pix, missing, rescued).

    ``pix`` holds the chain's pixel poses with the missing ones filled from
    their neighbours (the prediction), ``ref`` the neighbours' median area,
    long and short side.  A partly hidden marker keeps its visible end and its
    thickness: its centre lies half the hidden length beyond the visible
    part's, towards the prediction (a uniform bar's centroid is midway between
    its ends).  Taken only when exactly one component fits and its corrected
    centre lands near the prediction.
    """
    pix, missing = pix.copy(), missing.copy()
    rescued = []
    tol = max(1.5, 0.12 * spacing)
    for i in np.flatnonzero(missing):
        area_nb, long_nb, short_nb = ref[i]
        if not np.all(np.isfinite(ref[i])) or len(raw) == 0:
            continue
        phi = pix[i, 2]
        axis = np.array([np.cos(phi), np.sin(phi)])
        rel = raw[:, :2] - pix[i, :2]
        along = rel @ axis
        across = rel @ np.array([-axis[1], axis[0]])
        ok = (np.abs(wrap_half_pi(raw[:, AXIS] - phi)) <= _RESCUE_TURN) & (np.abs(across) <= tol)
        ok &= np.abs(along) <= 0.5 * long_nb
        for col, ref_value, (lo, hi) in (
            (SHORT, short_nb, _RESCUE_SHORT),
            (LONG, long_nb, _RESCUE_LONG),
            (AREA, area_nb, _RESCUE_AREA),
        ):
            ok &= (raw[:, col] >= lo * ref_value) & (raw[:, col] <= hi * ref_value)
        fit = np.flatnonzero(ok)
        if fit.size != 1:
            continue
        j = fit[0]
        centre = raw[j, :2].copy()
        if raw[j, LONG] < _PARTIAL * long_nb:
            centre -= np.sign(along[j]) * 0.5 * (long_nb - raw[j, LONG]) * axis
        if np.linalg.norm(centre - pix[i, :2]) > tol:
            continue
        pix[i] = (*centre, phi + float(wrap_half_pi(raw[j, AXIS] - phi)))
        missing[i] = False
        rescued.append(int(i))
    return pix, missing, rescued


def _finish(
    cands: NDArray[np.float64],
    order: NDArray[np.intp],
    st: dict[str, Any],
    phi0: float | None,
    raw: NDArray[np.float64] | None = None,
) -> tuple:
    """Angles, filled gaps and checks of an ordered chain (-1: missing): (pixel poses, filled, ignored, rescued).

    ``raw`` are all components of the frame (before the marker-shape test),
    searched for the missing markers at their predicted poses (:func:`_rescue`).
    """
    missing = order < 0
    # a marker much smaller or larger than its chain neighbours is partly hidden or merged: treat it as missing
    odd, ref = _odd_shapes(cands, order, missing)
    missing = missing | odd
    if missing.any() and (not st["fill"] or not fillable(missing, st["base_pose"] is not None)):
        raise FrameProblem(f"marker(s) {np.flatnonzero(missing).tolist()} missing, merged or partly hidden")
    idx = order[~missing]
    pts = cands[idx, :2]
    phi_det, conflicts = frame_angles(pts, cands[idx, AXIS], phi0)
    pix = np.zeros((len(order), 3))
    pix[~missing, :2], pix[~missing, 2] = pts, phi_det
    pix = fill_gaps(pix, missing, st["base_pose"])
    rescued: list[int] = []
    if missing.any() and raw is not None:
        pix, missing, rescued = _rescue(raw, pix, missing, ref, st["spacing"])
    links = np.linalg.norm(np.diff(pix[:, :2], axis=0), axis=1)
    # markers are evenly spaced in arc length: one link much longer than the links on both sides of it skips a
    # marker (a chain tracked off by one); the spacing may change at a segment boundary, but for good
    nb = np.maximum(np.concatenate([links[1:2], links[:-1]]), np.concatenate([links[1:], links[-2:-1]]))
    # (a marker the tracking skipped near the tip also leaves the filled tip one link further: both links are
    # then about twice the recording's spacing; only checked with a marker filled, since segments may stretch)
    if missing.any():
        nb = np.minimum(nb, _FILLED_RATIO / _LINK_RATIO * st["spacing"])
    jump = np.flatnonzero(links > _LINK_RATIO * nb) if links.size >= 3 else np.zeros(0, int)
    if jump.size:
        i = int(jump[0])
        scale = st.get("px_scale", 1)
        raise FrameProblem(
            f"the marker spacing jumps between markers {i} and {i + 1} ({links[i] * scale:.1f} px against "
            f"{nb[i] * scale:.1f} px beside it or in the reference frame): a marker skipped (ordering not "
            "trustworthy)"
        )
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
    return pix, np.flatnonzero(missing).tolist(), others.size, rescued


class FrameTracker:
    """The per-frame work of one recording, given what its reference frame fixed.

    Parameters
    ----------
    detectors : list of Detector
        The chosen thresholder first, then the fallbacks tried on frames it cannot complete.
    state : dict
        ``n`` (markers incl. the base), ``base_px``, ``spacing``, ``first_dir``
        (rest direction in the image), ``fill`` (fill isolated missing markers),
        optionally ``px_scale`` (frames decoded at 1/px_scale of the footage's
        resolution: messages quote full-resolution pixels).
    """

    def __init__(self, detectors: list[Detector], state: dict[str, Any]) -> None:
        self.detectors = detectors
        self.st = dict(state, base_pose=None)
        self.phi0 = None  # the base angle's branch, kept across failed frames so angles stay continuous
        self.candidates: NDArray[np.float64] | None = None  # marker-shaped components of the last frame
        first = detectors[0]
        # markers thick enough to survive a 3 x 3 opening: frames with a marker that looks merged are tried
        # again with thin strokes cut off the binary mask
        self.opened = None
        if first.typical is not None and first.typical["short"] >= 5.0:
            self.opened = Detector(first.seg, first.p, opened=True)
            self.opened.typical = first.typical
        self.reset()

    def resume(self, last: NDArray[np.float64], before: NDArray[np.float64] | None = None) -> None:
        """Track on from the pixel poses ``last`` (N + 1, 3) of a frame extracted before (and ``before``, of
        the frame before that, for a constant-velocity prediction): used to run backwards in time from the
        reference frame."""
        self.prev2 = None if before is None else np.asarray(before)[:, :2]
        self.prev = np.asarray(last)[:, :2]
        self.phi0 = float(last[0, 2])
        self.st["base_pose"] = np.asarray(last[0], dtype=float)

    def reset(self) -> None:
        """Forget the previous frames' positions (after a frame that could not be extracted)."""
        self.prev = self.prev2 = None

    def step(self, frame: NDArray[np.uint8]) -> tuple[FrameResult | None, int, str | None]:
        """(result or None, marker-shaped components found, the first problem met) for one frame."""
        pred = None if self.prev is None else (self.prev if self.prev2 is None else 2.0 * self.prev - self.prev2)
        err = None
        n_found = 0
        best = None
        order = [self.detectors[0]] + ([self.opened] if self.opened is not None else []) + self.detectors[1:]
        for d in order:
            if best is not None and (d is not self.opened or not (best[0][1] or best[0][3])):
                # done, unless the result filled a marker, or took one from a partial component, that the
                # opened mask might show whole (cut off a cable or a line of text it merged with)
                break
            raw = d(frame)
            shaped = d.accept(raw)
            if d is self.detectors[0]:
                n_found = len(shaped)
                self.candidates = shaped  # kept for a caller that looks at a failed frame again
            try:
                result = _order_frame(shaped, self.st, self.prev, pred, self.phi0, raw)
            except FrameProblem as e:
                err = err or str(e)
                continue
            if best is None or (len(result[1]), len(result[3])) < (len(best[0][1]), len(best[0][3])):
                best = (result, d, len(shaped))
        if best is not None:
            (pix, filled, ignored, rescued, tracked), d, n_shaped = best
            out = FrameResult(pix, n_shaped - ignored, filled, tracked, d.seg.describe(), ignored, rescued)
            self.prev2, self.prev = self.prev, pix[:, :2]
            self.phi0 = pix[0, 2]
            if 0 not in filled:
                self.st["base_pose"] = pix[0]
            return out, n_found, None
        self.reset()
        return None, n_found, err
