"""Overlay video: frames with the traced outlines and contact regions drawn on them.

So that a person can check what the analysis detected: the calibrated surface profile
(green), the traced finger contour (light blue), the C_f line (yellow) and centroid x(t)
(red tick), the contact regions C_i (thick red along the surface), the frame number, x
and the flag reasons. Drawing with OpenCV, encoding with PyAV (MP4/H.264 or GIF).

:func:`write_overlay` analyses the video again (every frame, as ``analyze`` did);
:func:`write_results_overlay` draws what ``analyze`` stored (x(t), regions, flags from
``frames.parquet``) on a sample of frames and decodes only those, so that the report can
make one for many trials (about 0.5 s per trial instead of the analysis' seconds).
"""

from __future__ import annotations

import contextlib
import logging
import os
from dataclasses import dataclass
from fractions import Fraction

import cv2
import numpy as np

from .._atomic import AtomicFile
from ..regions import as_regions, regions_from_columns
from ..surfaces import Surface
from .analysis import FLAG_REASONS, AnalysisOptions, FrameAnalyzer, FrameFlag
from .calibrate import calibrate
from .contours import trace_finger
from .readers import AVReader, open_video

__all__ = ["write_overlay", "write_results_overlay", "OverlayInfo"]

log = logging.getLogger(__name__)

_GREEN, _BLUE, _YELLOW, _RED = (0, 170, 0), (255, 200, 0), (0, 200, 255), (0, 0, 255)


@dataclass(frozen=True)
class OverlayInfo:
    """What :func:`write_overlay` wrote.

    Attributes
    ----------
    path : str
        The output file.
    n_frames : int
        Frames written.
    n_flagged : int
        Of which flagged (no position).
    """

    path: str
    n_frames: int
    n_flagged: int


def _trace(an: FrameAnalyzer, frame: np.ndarray):
    crop = an.cal.crop.apply(frame)[: an.zone_rows]
    dark = (crop <= an.cal.level).astype(np.uint8)
    cv2.bitwise_and(dark, an.zone, dst=dark)
    return trace_finger(dark, min_points=an.opt.min_finger_points)


def _draw(an: FrameAnalyzer, frame: np.ndarray, index: int, res: dict, t: int) -> np.ndarray:
    cal = an.cal
    crop = cal.crop.apply(frame)
    if crop.dtype != np.uint8:
        crop = (crop.astype(np.float32) * (255.0 / max(float(crop.max()), 1.0))).astype(np.uint8)
    img = cv2.cvtColor(np.ascontiguousarray(crop), cv2.COLOR_GRAY2BGR)
    w = cal.crop.width
    cols = np.arange(w)
    surf = np.column_stack([cols, cal.surface_row]).round().astype(np.int32)
    cv2.polylines(img, [surf], False, _GREEN, 1)
    fc = _trace(an, frame)
    if fc is not None:
        cv2.polylines(img, [fc.points.astype(np.int32)], True, _BLUE, 1)
    line = res["line_row"][t]
    x = res["x"][t]
    if np.isfinite(line):
        f = res["f"][t]
        inside = np.flatnonzero(np.nan_to_num(f, nan=-np.inf) > line)
        if inside.size:
            y = int(round(line))
            cv2.line(img, (int(inside[0]), y), (int(inside[-1]), y), _YELLOW, 1)
    if np.isfinite(x):
        c = int(round(x / cal.mm_per_px + cal.x0_col))
        y = int(round(line)) if np.isfinite(line) else 10
        cv2.line(img, (c, y - 12), (c, y + 12), _RED, 2)
    for a, b in res["regions"][t]:
        if np.isnan(a):
            continue
        ca = int(np.clip(round(a / cal.mm_per_px + cal.x0_col), 0, w - 1))
        cb = int(np.clip(round(b / cal.mm_per_px + cal.x0_col), 0, w - 1))
        seg = surf[ca:cb + 1]
        if len(seg) > 1:
            cv2.polylines(img, [seg], False, _RED, 3)
        else:
            cv2.circle(img, (ca, int(surf[ca, 1])), 2, _RED, -1)
    flags = FrameFlag(int(res["flags"][t]))
    text = f"frame {index}  x = {x:+.3f} mm" if np.isfinite(x) else f"frame {index}"
    cv2.putText(img, text, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, _RED, 1, cv2.LINE_AA)
    if flags:
        reason = "; ".join(FLAG_REASONS[b].split(":")[0] for b in FrameFlag if b in flags)
        cv2.putText(img, reason, (8, 42), cv2.FONT_HERSHEY_SIMPLEX, 0.5, _RED, 1, cv2.LINE_AA)
    return img


def _checked_output(out, fps: float, scale: float, *, count_name: str, count: int,
                    unit: str = "") -> tuple[str, str]:
    """The output path and its extension, after the checks both overlays make (the
    extension, ``count_name`` >= 1, the playback rate in Hz, the resize factor)."""
    out = os.fspath(out)
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".mp4", ".gif"):
        raise ValueError(f"overlay output must end in .mp4 or .gif, got {out!r}")
    if int(count) < 1:
        raise ValueError(f"{count_name} must be >= 1{unit}, got {count!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive frame rate in Hz, got {fps!r}")
    if not (np.isfinite(scale) and 0.1 <= scale <= 4):
        raise ValueError(f"scale must be in [0.1, 4], got {scale!r}")
    return out, ext


def _output_size(cal, scale: float) -> tuple[int, int]:
    """Width and height in px of the drawn crop resized by ``scale`` (even, as H.264 needs)."""
    return int(round(cal.crop.width * scale)) // 2 * 2, int(round(cal.crop.height * scale)) // 2 * 2


def _resized(img: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    if size != (img.shape[1], img.shape[0]):
        img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    return img


@contextlib.contextmanager
def _encoder(path, ext: str, fps: float, size: tuple[int, int], crf: str):
    """Yield ``put(img)``, which encodes one BGR image of ``size`` (px) into the MP4 (H.264
    at quality ``crf``) or GIF at ``path``; the stream is flushed on a normal exit."""
    import av  # heavy (FFmpeg bindings), only to encode an overlay

    with av.open(str(path), "w") as container:
        if ext == ".mp4":
            st = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
            st.pix_fmt = "yuv420p"
            st.options = {"crf": crf, "preset": "veryfast"}
        else:
            st = container.add_stream("gif", rate=Fraction(fps).limit_denominator(1000))
            st.pix_fmt = "rgb8"
        st.width, st.height = size

        def put(img: np.ndarray) -> None:
            vf = av.VideoFrame.from_ndarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB), format="rgb24")
            for pkt in st.encode(vf.reformat(format=st.pix_fmt)):
                container.mux(pkt)

        yield put
        for pkt in st.encode():
            container.mux(pkt)


def write_overlay(video, surface_height_mm: float, out: str | os.PathLike, *,
                  surface: Surface | None = None, options: AnalysisOptions | None = None,
                  start: int = 0, stop: int | None = None, step: int = 1, fps: float = 30.0,
                  scale: float = 1.0) -> OverlayInfo:
    """Write an MP4 (or GIF) of analysed frames with outlines and contact regions drawn.

    Parameters
    ----------
    video : path-like
        The trial's video.
    surface_height_mm : float
        Known feature height H in mm (calibration).
    out : path-like
        Output file, ``.mp4`` (H.264) or ``.gif``.
    surface : Surface, optional
        The surface shape (raised-cosine calibration fit).
    options : AnalysisOptions, optional
    start, stop, step : int
        Frames ``start, start + step, ... < stop`` are drawn (all frames are analysed from
        ``start`` so that the reference area is the same as in the analysis only when
        ``start`` is 0).
    fps : float
        Playback frame rate of the output in Hz.
    scale : float
        Resize factor of the drawn crop.

    Returns
    -------
    OverlayInfo

    Raises
    ------
    ValueError
        For an unknown output extension, bad frame range, or an unusable video.
    """
    out, ext = _checked_output(out, fps, scale, count_name="step", count=step, unit=" frame")
    opt = options or AnalysisOptions()
    reader = open_video(video)
    target = None
    n_written = n_flagged = 0
    try:
        target = AtomicFile(out)
        cal = calibrate(reader.read_frame(opt.calibration_frame), surface_height_mm, crop=opt.crop,
                        level=opt.level, surface=surface)
        an = FrameAnalyzer(cal, opt, reader.shape)
        size = _output_size(cal, scale)
        with _encoder(target.tmp, ext, fps, size, crf="20") as put:
            for i0, frames in reader.iter_chunks(opt.chunk_size, start=start, stop=stop):
                res = an.analyze_chunk(i0, frames)
                for t in range(frames.shape[0]):
                    if (i0 + t - start) % step:
                        continue
                    put(_resized(_draw(an, frames[t], i0 + t, res, t), size))
                    n_written += 1
                    n_flagged += int(res["flags"][t] != 0)
        if n_written == 0:
            raise ValueError(f"{reader.path}: no frame in the range start={start}, stop={stop}")
        target.commit()
    finally:
        reader.close()
        if target is not None:
            target.discard()
    log.info("overlay: %d frames written to %s", n_written, out)
    return OverlayInfo(path=out, n_frames=n_written, n_flagged=n_flagged)


def _caption(img: np.ndarray, lines: list[str]) -> None:
    """Write ``lines`` in red on a white band across the top of ``img`` (in place)."""
    cv2.rectangle(img, (0, 0), (img.shape[1] - 1, 8 + 18 * len(lines)), (255, 255, 255), -1)
    for j, text in enumerate(lines):
        cv2.putText(img, text, (6, 18 + 18 * j), cv2.FONT_HERSHEY_SIMPLEX, 0.5, _RED, 1, cv2.LINE_AA)


def _stored_caption(frame: int, x: float, source: str | None, flag: str) -> list[str]:
    """The caption of a frame of stored results: its number, x in mm and the estimator that
    gave it; the first reason of its flag, if any."""
    lines = [f"frame {frame}" + (f"  x = {x:+.2f} mm" if np.isfinite(x) else "  no x")]
    if source and np.isfinite(x):
        lines[0] += f" ({source})"
    if flag:
        lines.append(flag.split(";")[0].split(":")[0][:70])
    return lines


def _sample_frames(reader, candidates: np.ndarray, max_frames: int) -> list[tuple[int, np.ndarray]]:
    """Up to ``max_frames`` of the ``candidates`` frame indices, evenly spread, decoded.

    For a compressed video (PyAV) only key frames are decoded, each on its own: the
    others would need every frame since the last key frame (the cost of each:
    ``docs/video.md``). Random-access formats (TIFF, cine) read the chosen frames
    directly.
    """
    candidates = np.unique(np.asarray(candidates, dtype=np.int64))
    if candidates.size == 0:
        return []
    idx = candidates[np.unique(np.linspace(0, candidates.size - 1, min(max_frames, candidates.size)).round()
                               .astype(int))]
    if isinstance(reader, AVReader):
        import av  # heavy (FFmpeg bindings): only for compressed videos

        with av.open(reader.path, format=reader.demuxer) as c:
            st = c.streams.video[0]
            keys = np.asarray([i for i, pk in enumerate(p for p in c.demux(st) if p.size) if pk.is_keyframe],
                              dtype=np.int64)
        inside = keys[(keys >= candidates[0]) & (keys <= candidates[-1])]
        if inside.size >= min(10, idx.size):  # enough key frames: decode those alone
            pick = inside[np.unique(np.linspace(0, inside.size - 1, min(max_frames, inside.size)).round()
                                    .astype(int))]
            want = set(pick.tolist())
            fmt = "gray16le" if reader.dtype == np.uint16 else "gray"
            out = []
            with av.open(reader.path, format=reader.demuxer) as c:
                st = c.streams.video[0]
                for i, pk in enumerate(p for p in c.demux(st) if p.size):
                    if i in want:
                        out += [(i, fr.to_ndarray(format=fmt)) for fr in st.codec_context.decode(pk)]
                    if i >= pick[-1]:
                        break
            # an intra key frame decodes on its own; a codec with a decoding delay gives
            # fewer (or misnumbered) frames: then decode in order below
            if len(out) == len(want) and all(i in want for i, _ in out):
                return out
        # few key frames (a long GOP): decode in order, keep the chosen frames
        want = set(idx.tolist())
        out = []
        for i0, block in reader.iter_chunks(64, start=int(idx[0]), stop=int(idx[-1]) + 1):
            out += [(i0 + k, block[k].copy()) for k in range(block.shape[0]) if i0 + k in want]
        return out
    return [(int(i), reader.read_frame(int(i))) for i in idx]


def _stored(frames, regions=None):
    """Frame indices, x(t) (mm), regions ``(n, k, 2)`` (mm; ``regions`` when given), flag texts
    and position sources (None when not recorded) from a per-frame table."""
    idx = frames["frame"].to_numpy(np.int64)
    x = frames["x_mm"].to_numpy(float)
    regions = as_regions(regions_from_columns(frames, empty_ok=True) if regions is None else regions)
    flags = frames["flag"].astype(str).to_numpy() if "flag" in frames.columns else np.full(len(frames), "")
    source = frames["x_source"].astype(str).to_numpy() if "x_source" in frames.columns else None
    return idx, x, regions, flags, source


def write_results_overlay(video, frames, surface_height_mm: float, out: str | os.PathLike, *,
                          surface: Surface | None = None, options: AnalysisOptions | None = None,
                          max_frames: int = 60, fps: float = 10.0, scale: float = 0.5,
                          regions: np.ndarray | None = None) -> OverlayInfo:
    """Write a short GIF or MP4 of a trial with what ``analyze`` stored drawn on its frames.

    The surface profile (green), the finger outline traced at the analysis' threshold
    (light blue), the finger position x(t) (red tick) and the contact regions C_i (thick
    red along the surface) as stored in the trial's per-frame table, the frame number,
    x, the position's source and the frame's flag. Only the drawn frames are decoded.

    Parameters
    ----------
    video : path-like
        The trial's video.
    frames : pandas.DataFrame
        The trial's per-frame table (``frames.parquet``: ``frame, x_mm, a1, b1, ...,
        flag`` and, when recorded, ``x_source``).
    surface_height_mm : float
        Known feature height H in mm (calibration, as the analysis).
    out : path-like
        ``.gif`` or ``.mp4``.
    surface : Surface, optional
        The surface shape (raised-cosine calibration fit, as the analysis).
    options : AnalysisOptions, optional
        The analysis options (crop, threshold level, calibration frame) used by ``analyze``.
    max_frames : int
        At most this many frames, spread evenly over the frames where the finger is seen.
    fps : float
        Playback rate in Hz.
    scale : float
        Resize factor of the drawn crop (0.5: 630 x 180 px for the paper's crop).
    regions : (n_frames, n_max, 2) ndarray, optional
        The frames' contact regions in mm when the caller has them (the results store's
        :class:`~fingerfriction.study.results.AnalysedTrial`); else read from the table's
        columns ``a1, b1, ...``.

    Returns
    -------
    OverlayInfo

    Raises
    ------
    ValueError
        Unknown extension, bad options, an unusable video, or no frame to draw.
    """
    out, ext = _checked_output(out, fps, scale, count_name="max_frames", count=max_frames)
    opt = options or AnalysisOptions()
    idx, x_all, regions, flags, source = _stored(frames, regions)
    row_of = {int(f): r for r, f in enumerate(idx)}
    seen = idx[np.isfinite(x_all) | ~np.isnan(regions[..., 0]).all(axis=1)]
    reader = open_video(video)
    target = None
    n_written = n_flagged = 0
    try:
        cal = calibrate(reader.read_frame(opt.calibration_frame), surface_height_mm, crop=opt.crop,
                        level=opt.level, surface=surface)
        an = FrameAnalyzer(cal, opt, reader.shape)
        sample = _sample_frames(reader, seen, int(max_frames))
        if not sample:
            raise ValueError(f"{reader.path}: no frame with the finger in view to draw")
        target = AtomicFile(out)
        size = _output_size(cal, scale)
        with _encoder(target.tmp, ext, fps, size, crf="26") as put:
            for i, frame in sample:
                r = row_of.get(i)
                if r is None:
                    continue
                res = {"line_row": [np.nan], "x": [x_all[r]], "regions": [regions[r]], "flags": [0]}
                img = _resized(_draw(an, frame, i, res, 0), size)
                # the text is written at the output size (readable), over _draw's own
                _caption(img, _stored_caption(i, x_all[r], None if source is None else source[r], flags[r]))
                n_flagged += bool(flags[r])
                put(img)
                n_written += 1
        target.commit()
    finally:
        reader.close()
        if target is not None:
            target.discard()
    log.info("overlay: %d frames of stored results written to %s", n_written, out)
    return OverlayInfo(path=out, n_frames=n_written, n_flagged=n_flagged)

