"""``pcs-sindy inspect`` and ``extract --plot``: a contact sheet of what the extraction found.

:func:`inspect_video` extracts a recording (frames it cannot read are interpolated rather than
fatal, so the sheet is drawn even when ``extract`` would stop), picks a few frames spread over it
(the reference frame among them) and draws on each the marker chain in order, the base and the
marker-shaped components that were not taken as markers
(:func:`~pcs_sindy.plotting.stills.plot_contact_sheet`).  When the extraction fails altogether the
sheet still shows every component found and the error under the frames.

Importing this module loads no stage and no numpy (see :mod:`pcs_sindy.cli.main`).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from .messages import say

__all__ = ["inspect_video", "save_png"]

#: marker-shaped components drawn as rejected: at least this fraction of the typical marker's area
_REJECTED_MIN_AREA = 0.3
#: at most this many rejected components drawn per frame (the largest)
_REJECTED_MAX = 200


def save_png(fig: Any, path: str | Path) -> Path:
    """Write a figure as a PNG atomically (:func:`pcs_sindy.core.atomic.savefig`) and close it.

    An interrupted or failed write (disk full) leaves any previous file at ``path`` as it was.
    """
    import matplotlib.pyplot as plt

    from ..core import atomic

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        return atomic.savefig(fig, path, format="png", dpi=110)
    finally:
        plt.close(fig)


def _components(image: Any, params: dict[str, Any], chosen: str | None) -> Any:
    """Every component (u, v, area) of ``image`` under the binarisation the extraction chose."""
    import numpy as np

    from ..vision.markers import detect_markers, find_components, measure_components
    from ..vision.thresholding import ColourThresholder, LocalThresholder

    polarity = params.get("polarity") or "dark"
    chosen = chosen or ""
    if chosen.startswith(("local", "colour")):
        seg = LocalThresholder(polarity) if chosen.startswith("local") else ColourThresholder()
        try:
            seg = seg.prepare(image)
            work = seg.work(image)
            binary = seg.binary(work)
        except (ValueError, TypeError):
            return np.zeros((0, 7))
        comps = find_components(binary)
        keep = np.flatnonzero(comps.area >= float(params.get("min_area") or 4.0))
        return measure_components(seg, work, comps, keep, binary.shape)
    threshold = params.get("threshold")
    if not isinstance(threshold, (int, float, tuple)) or isinstance(threshold, bool):
        threshold = "otsu"
    kwargs = {k: params[k] for k in ("blur", "roi", "min_area") if params.get(k) is not None}
    return detect_markers(image, threshold=threshold, polarity=polarity, **kwargs)


def inspect_video(
    video: str | Path,
    out: str | Path | None = None,
    *,
    frames: int = 6,
    camera: str | Path | None = None,
    n_markers: int | None = None,
    robot_length: float | None = None,
    quiet: bool = False,
    extracted: tuple[Any, dict[str, Any]] | None = None,
    **options: Any,
) -> Path:
    """Draw a contact sheet (PNG) of a few frames with what the extraction found on them.

    Parameters
    ----------
    video : path
        A video, a folder of image frames, or one image.
    out : path, optional
        PNG to write; default ``<stem>.inspect.png`` beside the video (a folder: ``<stem>`` is its
        name); a path ending in a separator is a folder.
    frames : int
        Frames on the sheet, spread evenly over the recording (the reference frame among them).
    camera, n_markers, robot_length, **options
        :class:`~pcs_sindy.vision.extractor.MarkerPoseExtractor` parameters, as for ``extract``
        (None: the default; ``on_missing`` defaults to ``"interpolate"`` here).
    quiet : bool
        No progress bar or message.
    extracted : (PoseTrajectory, dict), optional
        The extraction already done (``extract --plot``): its trajectory and diagnostics.

    Returns
    -------
    Path
        The PNG written.
    """
    import cv2
    import numpy as np

    from ..core.camera import Camera
    from ..pipeline.pcs_pipeline import make_pcs_pipeline
    from ..plotting.stills import plot_contact_sheet
    from ..vision.frame_source import IMAGE_SUFFIXES, FrameSource, check_frame_size, image_size

    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or not 1 <= frames <= 48:
        raise ValueError(f"frames must be an integer from 1 to 48 (panels on the sheet); got {frames!r}")
    path = Path(video)
    if not path.exists():
        raise FileNotFoundError(f"video {str(video)!r} does not exist")
    recording: Any = str(path)
    if path.is_file() and path.suffix.lower() in IMAGE_SUFFIXES:
        size = image_size(path)
        if size is not None:
            check_frame_size(*size, f"image {str(path)!r}")
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise OSError(f"cannot read image {str(path)!r}")
        recording = image[None, ..., :3] if image.ndim == 3 else image[None]
    src = FrameSource(recording, str(path))
    if out is None:
        target = path.with_name(f"{path.name if path.is_dir() else path.stem}.inspect.png")
    elif str(out).endswith(("/", os.sep)) or Path(out).is_dir():
        target = Path(out) / f"{path.name if path.is_dir() else path.stem}.inspect.png"
    else:
        target = Path(out)
    chosen_params = {
        **options,
        "camera": None if camera is None else str(camera),
        "n_markers": n_markers,
        "robot_length": robot_length,
    }
    given = {k: v for k, v in chosen_params.items() if v is not None}
    given.setdefault("on_missing", "interpolate")
    extractor = make_pcs_pipeline(start="videos").named_steps["poses"]  # as 'extract' builds it
    extractor.set_params(progress=not quiet, **given)
    if isinstance(recording, np.ndarray) and extractor.fps is None and extractor.dt is None:
        extractor.set_params(fps=1.0)  # one image: no time
    extractor.fit()
    traj, diag, error = (None, None, None) if extracted is None else (*extracted, None)
    if extracted is None:
        try:
            traj = extractor.transform([recording])[0]
            diag = extractor.diagnostics_[0]
        except ValueError as err:
            error = " ".join(str(err).split())
    n = src.n_frames if traj is None else traj.n_frames
    ref = int(extractor.reference_frame) if isinstance(extractor.reference_frame, (int, np.integer)) else 0
    picks = np.linspace(0, n - 1, min(frames, n)).round().astype(int)
    if min(ref, n - 1) not in picks:
        picks[np.argmin(np.abs(picks - ref))] = min(ref, n - 1)
    if diag is not None and diag["frames_repaired"] and len(picks) > 2:  # show a frame that was not extracted
        bad = int(diag["frames_repaired"][0])
        if bad not in picks:
            others = [i for i, k in enumerate(picks) if k != min(ref, n - 1)]
            picks[min(others, key=lambda i: abs(picks[i] - bad))] = bad
    if error is not None and len(picks) > 1:  # the frame the error names
        named = re.search(r"frame (\d+)", error)
        if named is not None and 0 <= int(named.group(1)) < n and int(named.group(1)) not in picks:
            picks[-1 if picks[-1] != ref else 0] = int(named.group(1))
    picks = sorted(set(picks.tolist()))
    cam = Camera.from_dict(diag["camera"]) if diag is not None else None
    chosen = diag["binarisation"]["chosen"] if diag is not None else None
    spacing = float(diag["marker_spacing_px"]) if diag is not None else None
    typical = float(diag["marker_area_px"]) if diag is not None else None
    params = extractor.get_params()
    images, chains, rejected, titles, notes = [], [], [], [], []
    for k in picks:
        img = src.frame(k)
        images.append(img if img.ndim == 2 or img.shape[2] == 3 else img[..., :3])
        comps = _components(img, params, chosen)
        chain = None
        note = ""
        if traj is not None and cam is not None:
            chain = np.asarray(cam.to_pixels(traj.poses[k]))[:, :2]
            if k in diag["repair_reasons"]:
                note = f"interpolated: {diag['repair_reasons'][k]}"[:160]
        pts = comps[:, :2] if len(comps) else np.zeros((0, 2))
        if typical is not None and len(comps):
            pts = pts[comps[:, 3] >= _REJECTED_MIN_AREA * typical]
        if chain is not None and len(pts):
            near = np.min(np.linalg.norm(pts[:, None, :] - chain[None, :, :], axis=2), axis=1)
            pts = pts[near > 0.3 * (spacing or 1.0)]
        rejected.append(pts[:_REJECTED_MAX])
        chains.append(chain)
        t = f", t = {traj.t[k]:.4g} s" if traj is not None else ""
        titles.append(f"frame {k}{' (reference)' if k == ref else ''}{t}")
        notes.append(note)
    if error is not None:
        notes = [f"not extracted: {error}"[:200]] + notes[1:]
        head = f"{path.name}: extraction failed (the error is under the first frame)"
    else:
        head = (
            f"{path.name}: {diag['n_frames']} frames, base + {diag['n_markers']} markers "
            f"(base: {diag['base_marker']}), binarisation {chosen}; {len(diag['frames_repaired'])} frames interpolated"
        )
    fig = plot_contact_sheet(
        images,
        chains=chains,
        rejected=rejected,
        titles=titles,
        notes=notes,
        title=head,
        rejected_label="rejected component" if error is None else "component found",
    )
    written = save_png(fig, target)
    say(quiet, f"inspected {path.name} -> {written}" + (f" (extraction failed: {error})" if error else ""))
    return written
