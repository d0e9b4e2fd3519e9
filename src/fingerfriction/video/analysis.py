"""The per-video analysis: frames in, x(t), contact regions C_i and per-frame flags out.

Pipeline (Methods "Image analysis" of Janko et al. 2018, Fig. 7):

1. :func:`~fingerfriction.video.calibrate.calibrate` on the finger-free calibration frame:
   crop, threshold (given or Otsu), surface profile h-hat, mm per pixel, origin.
2. Every frame, streamed in chunks: threshold the finger zone above the surface, trace
   the finger's contour (``cv2.findContours``), take its lower envelope, refine it to a
   fraction of a pixel from the gray levels.
3. Area-preserving region C_f (:mod:`.tracking`): the area ``A`` below the line 0.4 mm
   above the feature's top in the first usable finger frame; in every frame the line
   enclosing ``A``; ``x(t)`` = centroid of C_f in surface mm.
   Not in the paper, always computed alongside: the chord midpoint (``x_chord``) and the
   hybrid (``x_hybrid``: chord midpoint, else one outline edge shifted by a per-video
   offset, :func:`~fingerfriction.video.tracking.hybrid_positions`), which covers the
   whole 26 mm force window where C_f (|x| < 4-10 mm on the simulated studies) and the
   chord (|x| < 2-8 mm) do not;
   ``AnalysisOptions.position`` chooses which one is ``x``.
4. Contact (:mod:`.contact`): finger outline points within 3 px of the surface outline,
   grouped into regions ``[a_i, b_i]`` in surface mm; beyond the paper, both outlines are
   first smoothed along the columns (``AnalysisOptions.outline_smooth_px``), and frames
   whose regions run into the crop's side are marked (``VideoResult.clipped``).

Frames that cannot give a trustworthy ``x`` are flagged with a reason (:class:`FrameFlag`)
and carry NaN for ``x`` and no contact regions: a flagged frame is never a silently wrong
number.
"""

from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from .._atomic import atomic_write
from ..regions import n_regions, region_lengths
from ..surfaces import Surface
from .calibrate import Calibration, calibrate
from .contact import contact_distance, contact_regions, smooth_outline
from .contours import finger_zone, lower_envelope, trace_finger
from .options import FLAG_REASONS, AnalysisOptions, FrameFlag
from .readers import VideoReader, open_video
from .tracking import (
    PositionSource,
    area_below_line,
    centroid_below_line,
    chord_ends,
    chord_midpoint,
    hybrid_positions,
    line_for_area,
)

__all__ = ["FrameFlag", "FLAG_REASONS", "AnalysisOptions", "FrameAnalyzer", "VideoResult",
           "PositionSource", "analyze_video"]

log = logging.getLogger(__name__)

#: Flags that only say the C_f centroid is unavailable (the finger itself was seen).
_CF_ONLY = int(FrameFlag.OUT_OF_VIEW | FrameFlag.AREA_UNREACHABLE | FrameFlag.NO_REFERENCE)


@dataclass(frozen=True)
class VideoResult:
    """Result of :func:`analyze_video` for one video.

    Attributes
    ----------
    path : str
        The video.
    x : (n_frames,) ndarray
        Finger position x(t) in mm, surface coordinates: ``x_cf``, ``x_chord`` or
        ``x_hybrid`` as chosen by ``AnalysisOptions.position``; NaN where flagged.
    x_cf : (n_frames,) ndarray
        Centroid of C_f in mm (the paper's definition); NaN where flagged or (with
        ``position='hybrid'``) where C_f is not available.
    x_chord : (n_frames,) ndarray
        Alternative position (not in the paper): midpoint of the finger's chord
        ``chord_height_mm`` above the feature's top, in mm; NaN where flagged or where
        the chord is cut by the crop.
    regions : (n_frames, n_max, 2) ndarray
        Contact regions C_i in mm (:mod:`fingerfriction.regions`); no regions (all NaN)
        in flagged frames.
    flags : (n_frames,) uint8 ndarray
        :class:`FrameFlag` bits; 0 for a good frame.
    line_row : (n_frames,) ndarray
        Row of the C_f line (crop coordinates, px); NaN where flagged.
    area_px : float
        Reference area A in px^2 (NaN if no usable finger frame).
    reference_frame : int
        Frame where A was measured (-1 if none).
    calibration : Calibration
        Scale, origin, threshold, surface profile.
    fps : float or None
        Frame rate in Hz.
    contact_tol_px, contact_metric : float, str
        The contact criterion used.
    timings : dict
        ``decode_s``, ``analysis_s`` (s) and ``frames_per_s`` of the analysis alone.
    truncated : bool
        The video ended or broke before its announced frame count.
    success : bool
        At least one frame gave a position.
    message : str
        Summary.
    x_hybrid : (n_frames,) ndarray or None
        Hybrid position in mm (:func:`~fingerfriction.video.tracking.hybrid_positions`),
        computed in every mode; NaN where no estimator applies or the finger is missing.
    x_source : (n_frames,) uint8 ndarray or None
        :class:`~fingerfriction.video.tracking.PositionSource` of each frame's ``x_hybrid``
        (0 none, 1 chord, 2 left edge, 3 right edge).
    hybrid : dict
        The hybrid's per-video edge offsets (mm), calibration frame counts and ranges.
    clipped : (n_frames,) bool ndarray or None
        Frames where a contact region reaches the left or right edge of the crop: that
        end is the edge of the field of view, not of the contact, so the region's length
        is a lower bound (the frame's position and its other regions are unaffected).
        Happens near the ends of the 26 mm window, where the pad's contact extends beyond
        the paper's 29 mm field of view (``position='hybrid'``).
    gap_px : (n_frames,) ndarray or None
        The finger's lowest point above the surface, px (0: touching; NaN: no outline).
    """

    path: str
    x: np.ndarray = field(repr=False)
    x_cf: np.ndarray = field(repr=False)
    x_chord: np.ndarray = field(repr=False)
    regions: np.ndarray = field(repr=False)
    flags: np.ndarray = field(repr=False)
    line_row: np.ndarray = field(repr=False)
    area_px: float
    reference_frame: int
    calibration: Calibration = field(repr=False)
    fps: float | None
    contact_tol_px: float
    contact_metric: str
    timings: dict
    truncated: bool
    success: bool
    message: str
    x_hybrid: np.ndarray | None = field(default=None, repr=False)
    x_source: np.ndarray | None = field(default=None, repr=False)
    hybrid: dict = field(default_factory=dict)
    clipped: np.ndarray | None = field(default=None, repr=False)
    gap_px: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_frames(self) -> int:
        return int(self.x.size)

    @property
    def threshold(self) -> float:
        """Threshold level used (gray units)."""
        return self.calibration.level

    @property
    def mm_per_px(self) -> float:
        return self.calibration.mm_per_px

    @property
    def lengths(self) -> np.ndarray:
        """Contact lengths L_i in mm, ``(n_frames, n_max)``."""
        return region_lengths(self.regions)

    @property
    def n_regions(self) -> np.ndarray:
        """Number of contact regions per frame (0 in flagged frames)."""
        return n_regions(self.regions)

    @property
    def valid(self) -> np.ndarray:
        """Frames with a position, ``(n_frames,)`` bool."""
        return self.flags == 0

    def reasons(self, frame: int) -> list[str]:
        """Reasons a frame is flagged (empty for a good frame)."""
        f = FrameFlag(int(self.flags[frame]))
        return [FLAG_REASONS[b] for b in FrameFlag if b in f]

    def flag_counts(self) -> dict[str, int]:
        """Number of frames carrying each flag, by flag name."""
        return {b.name: int(np.count_nonzero(self.flags & b)) for b in FrameFlag
                if np.any(self.flags & b)}

    def save(self, path: str | os.PathLike) -> None:
        """Write the result to a ``.npz`` file (atomic: temp file + rename)."""
        cal = self.calibration
        extra = {} if self.x_hybrid is None else {"x_hybrid": self.x_hybrid, "x_source": self.x_source}
        if self.clipped is not None:
            extra["clipped"] = self.clipped
        arrays = dict(x=self.x, x_cf=self.x_cf, x_chord=self.x_chord, regions=self.regions, flags=self.flags,
                      line_row=self.line_row, area_px=self.area_px, reference_frame=self.reference_frame,
                      mm_per_px=cal.mm_per_px, x0_px=cal.x0_px, level=cal.level,
                      surface_x_mm=cal.x_mm, surface_h_mm=cal.h_hat_mm,
                      contact_tol_px=self.contact_tol_px, **extra)

        def write(tmp) -> None:
            with open(tmp, "wb") as fh:  # a file object: savez adds no '.npz' to the name
                np.savez(fh, **arrays)

        atomic_write(path, write)


class FrameAnalyzer:
    """Analyses decoded frames chunk by chunk, given a calibration.

    Stateful only in the reference area ``A`` (set from the first usable finger frame),
    so chunks must be passed in frame order.

    Parameters
    ----------
    calibration : Calibration
    options : AnalysisOptions
    frame_shape : (int, int)
        ``(rows, cols)`` of the full frames.
    """

    def __init__(self, calibration: Calibration, options: AnalysisOptions,
                 frame_shape: tuple[int, int]) -> None:
        self.cal = calibration
        self.opt = options
        calibration.crop.check_fits(frame_shape, "video frame")
        h, w = calibration.crop.height, calibration.crop.width
        self.width = w
        fd = calibration.surface_first_dark
        self.zone_rows = int(max(int(fd.max()) - 1, 1))
        self.zone = finger_zone(fd, h)[: self.zone_rows].copy()
        self.zone_bool = self.zone > 0
        self.zone_count = int(np.count_nonzero(self.zone))
        self.zone_last = fd - 2
        self.s = calibration.surface_row.astype(float)
        # the surface edge as the contact test sees it (smoothed like the finger's outline)
        self.s_contact = smooth_outline(self.s, options.outline_smooth_px, options.outline_smooth_order)
        self.buf = np.empty((self.zone_rows, w), np.uint8)
        # rows from which the zone mask differs from "all rows": only there is it applied
        self.band_start = int(max(int(fd.min()) - 2, 0))
        self.line0 = calibration.top_row - options.line_offset_mm / calibration.mm_per_px
        self.chord_row = calibration.top_row - options.chord_height_mm / calibration.mm_per_px
        self.edge_row = calibration.top_row - options.edge_height_mm / calibration.mm_per_px
        self.area: float | None = None
        self.reference_frame = -1
        self.n_frames_seen = 0

    def outlines(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Finger lower outlines of a chunk.

        Parameters
        ----------
        frames : (k, rows, cols) uint8 or uint16 ndarray
            Full frames.

        Returns
        -------
        f : (k, width) float ndarray
            Sub-pixel lower-outline row per crop column, NaN where no finger.
        flags : (k,) uint8 ndarray
            FINGER_MISSING / NO_CONTOUR where no outline was found.
        """
        crop = self.cal.crop.apply(frames)
        k = crop.shape[0]
        w = self.width
        zr = self.zone_rows
        level = self.cal.level
        flags = np.zeros(k, np.uint8)
        eight = crop.dtype == np.uint8
        lvl8 = int(math.floor(level))
        # Each frame's finger zone is copied to a small contiguous buffer first: OpenCV
        # copies strided inputs internally, and the gathers below stay in cache.
        gray = np.empty((zr + 1, w), crop.dtype)
        gflat = gray.reshape(-1)
        boolbuf = np.empty((zr, w), bool)
        b0 = self.band_start
        zone_band = self.zone[b0:]
        min_pts = self.opt.min_finger_points
        env = np.full((k, w), -1, np.int64)
        g0 = np.zeros((k, w), crop.dtype)
        g1 = np.zeros((k, w), crop.dtype)
        colidx = np.arange(w)
        for t in range(k):
            np.copyto(gray, crop[t, : zr + 1])
            if eight:
                binimg = self.buf
                cv2.threshold(gray[:zr], lvl8, 255, cv2.THRESH_BINARY_INV, dst=binimg)
                band = binimg[b0:]
                cv2.bitwise_and(band, zone_band, dst=band)
            else:
                np.less_equal(gray[:zr], level, out=boolbuf)
                np.logical_and(boolbuf[b0:], self.zone_bool[b0:], out=boolbuf[b0:])
                binimg = boolbuf.view(np.uint8)
            fc = trace_finger(binimg, min_points=min_pts)
            if fc is None:
                flags[t] = int(FrameFlag.FINGER_MISSING)
                continue
            e = lower_envelope(fc.points, w)
            env[t] = e
            idx = np.maximum(e, 0) * w + colidx
            np.take(gflat, idx, out=g0[t])
            np.take(gflat, idx + w, out=g1[t])
        # Sub-pixel outline, vectorised over the chunk: where the gray level crosses the
        # threshold between the last finger pixel and the bright pixel below it.
        has = env >= 0
        a0 = g0.astype(np.float32)
        a1 = g1.astype(np.float32)
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(a1 > a0, (level - a0) / (a1 - a0), 0.5)
        s = self.s[None, :]
        f = np.minimum(env + np.clip(frac, 0.0, 1.0), s)
        touch = has & (env >= self.zone_last[None, :]) & (a1 <= level)
        f = np.where(touch, s, f)
        f[~has] = np.nan
        # Dark down to the surface in nearly every column: the threshold leaves no finger
        # contour to speak of (frame too dark or level too high).
        nocont = (flags == 0) & (np.count_nonzero(touch, axis=1) > 0.98 * w)
        flags[nocont] = int(FrameFlag.NO_CONTOUR)
        f[nocont] = np.nan
        return f, flags

    def contact_distance(self, f: np.ndarray) -> np.ndarray:
        """Finger-surface distance in px per column, for the contact test.

        Parameters
        ----------
        f : (k, width) float ndarray
            Raw sub-pixel lower-outline rows, NaN where not analysed.

        Returns
        -------
        (k, width) float ndarray
            :func:`~fingerfriction.video.contact.contact_distance` of the outline and the
            surface edge, both smoothed by ``outline_smooth_px`` (see AnalysisOptions).
        """
        opt = self.opt
        fs = np.minimum(smooth_outline(f, opt.outline_smooth_px, opt.outline_smooth_order),
                        self.s_contact[None, :])  # NaN stays NaN
        return contact_distance(fs, self.s_contact, metric=opt.contact_metric, tol_px=opt.contact_tol_px)

    def analyze_chunk(self, start: int, frames: np.ndarray) -> dict:
        """Outlines, C_f tracking and contact for one chunk of full frames.

        Returns
        -------
        dict
            ``x``, ``x_cf``, ``x_chord`` (k,) mm, ``regions`` (k, n_max, 2) mm, ``flags`` (k,) uint8,
            ``line_row`` (k,) px, ``f`` (k, width) outline rows; for the hybrid position
            (combined over the whole video by :func:`analyze_video`): ``h_chord`` the chord
            midpoint wherever the finger's outline was found (whatever C_f's state),
            ``h_left``, ``h_right`` the outline's edges at the edge row (mm; NaN unless the
            finger touches the surface). With ``position='hybrid'``, ``x`` is NaN (only
            known for the whole video) and ``regions`` are filled for every frame that may
            get a hybrid position. ``gap`` (k,) px: :attr:`VideoResult.gap_px`.
        """
        opt, cal = self.opt, self.cal
        f, flags = self.outlines(frames)
        k = f.shape[0]
        idx = start + np.arange(k)
        flags[idx == opt.calibration_frame] |= int(FrameFlag.CALIBRATION)
        w = self.width
        if self.area is None:
            cand = np.flatnonzero(flags == 0)
            for t in cand:
                ft = f[t]
                if ft[0] > self.line0 or ft[w - 1] > self.line0:
                    continue  # C_f cut by the crop: not a usable reference
                a = float(area_below_line(ft, self.line0))
                if a >= 1.0:
                    self.area = a
                    self.reference_frame = int(start + t)
                    log.info("reference area A = %.1f px^2 in frame %d", a, self.reference_frame)
                    break
        line = np.full(k, np.nan)
        pre = (flags == 0) & ((self.area is None) | (idx < self.reference_frame))
        if pre.any():
            # Before the reference frame: C_f (at the initial line) cut by the crop's side
            # is "out of view"; anything else has no reference area yet.
            cut0 = ((np.nan_to_num(f[:, 0], nan=-np.inf) > self.line0)
                    | (np.nan_to_num(f[:, w - 1], nan=-np.inf) > self.line0))
            flags[pre & cut0] |= int(FrameFlag.OUT_OF_VIEW)
            flags[pre & ~cut0] |= int(FrameFlag.NO_REFERENCE)
        if self.area is not None:
            ok = flags == 0
            if ok.any():
                line[ok] = line_for_area(f[ok], self.area)
            unreachable = ok & np.isnan(line)
            flags[unreachable] |= int(FrameFlag.AREA_UNREACHABLE)
            cut = (flags == 0) & ((np.nan_to_num(f[:, 0], nan=-np.inf) > line)
                                  | (np.nan_to_num(f[:, w - 1], nan=-np.inf) > line))
            flags[cut] |= int(FrameFlag.OUT_OF_VIEW)
        good = flags == 0
        xcol = centroid_below_line(f, np.where(good, line, np.inf))
        x_cf = np.where(good, cal.col_to_mm(xcol), np.nan)
        seen = (flags & ~np.uint8(_CF_ONLY)) == 0  # the finger's outline was found
        chord_all = np.where(seen, cal.col_to_mm(chord_midpoint(f, self.chord_row)), np.nan)
        x_chord = np.where(good, chord_all, np.nan)
        # an edge is a position only while the finger rests on the surface (vertical gap
        # within the contact tolerance somewhere): a lifted finger moves its edges
        with np.errstate(invalid="ignore"):
            gap = np.min(np.where(np.isnan(f), np.inf, self.s[None, :] - f), axis=1)
            touch = seen & (gap <= opt.contact_tol_px)
        gap = np.where(seen & np.isfinite(gap), np.maximum(gap, 0.0), np.nan)
        el, er = chord_ends(f, self.edge_row)
        h_left = np.where(touch, cal.col_to_mm(el), np.nan)
        h_right = np.where(touch, cal.col_to_mm(er), np.nan)
        if opt.position == "hybrid":
            # the hybrid needs the whole video (offsets): fill the regions of every frame
            # that may get a position; analyze_video settles x, flags and regions
            cand = seen & (np.isfinite(chord_all) | np.isfinite(h_left) | np.isfinite(h_right))
            line[~good] = np.nan  # the C_f line only where C_f is valid
            good = good | cand
            x = np.full(k, np.nan)
        elif opt.position == "chord":
            cut = good & np.isnan(x_chord)
            flags[cut] |= int(FrameFlag.OUT_OF_VIEW)
            good = flags == 0
            x_cf[~good] = np.nan
            x = x_chord
        else:
            x = x_cf
        line[~good] = np.nan
        d = self.contact_distance(np.where(good[:, None], f, np.nan))
        regions, too_many = contact_regions(d, opt.contact_tol_px, cal.col_to_mm, n_max=opt.n_max_regions,
                                            min_gap_px=opt.min_gap_px, min_region_px=opt.min_region_px,
                                            on_overflow="mask")
        if too_many.any():
            log.warning("frames %s: more than n_max_regions=%d contact regions; flagged TOO_MANY_REGIONS",
                        (start + np.flatnonzero(too_many)).tolist(), opt.n_max_regions)
            flags[too_many] |= int(FrameFlag.TOO_MANY_REGIONS)
            x = np.where(too_many, np.nan, x)
            x_cf = np.where(too_many, np.nan, x_cf)
            x_chord = np.where(too_many, np.nan, x_chord)
            line[too_many] = np.nan
        self.n_frames_seen += k
        return {"x": x, "x_cf": x_cf, "x_chord": x_chord, "regions": regions, "flags": flags,
                "line_row": line, "f": f, "h_chord": chord_all, "h_left": h_left, "h_right": h_right,
                "too_many": too_many, "gap": gap}


def analyze_video(video, surface_height_mm: float, *, surface: Surface | None = None,
                  options: AnalysisOptions | None = None, calibration: Calibration | None = None,
                  start: int = 0, stop: int | None = None,
                  n_frames: int | None = None) -> VideoResult:
    """Analyse one video: x(t), contact regions and per-frame flags.

    Parameters
    ----------
    video : path-like or VideoReader
        The video (any format of :func:`~fingerfriction.video.readers.open_video`).
    surface_height_mm : float
        Known feature height ``H`` in mm, for the scale.
    surface : Surface, optional
        The surface shape (enables the exact raised-cosine calibration fit).
    options : AnalysisOptions, optional
    calibration : Calibration, optional
        Reuse a calibration instead of computing it from ``options.calibration_frame``.
    start, stop : int
        Frame range to analyse (default: all).
    n_frames : int, optional
        Frame count the video should have (the manifest's ``video.n_frames``); frames
        the file does not hold are flagged CORRUPT and the result marked truncated.

    Returns
    -------
    VideoResult

    Raises
    ------
    ValueError
        For an unreadable file, a calibration frame that cannot be read or calibrated.
    """
    opt = options or AnalysisOptions()
    reader = video if isinstance(video, VideoReader) else open_video(video)
    own = not isinstance(video, VideoReader)
    try:
        n, expected, stop = _frame_range(reader, n_frames, start, stop)
        if calibration is None:
            calibration = _calibrate_reader(reader, opt, surface_height_mm, surface)
        an = FrameAnalyzer(calibration, opt, reader.shape)
        a, timings = _analyze_frames(reader, an, opt, start, stop)
        truncated = reader.truncated or stop > n
        if stop > n and not reader.truncated:
            reader.error = f"the file holds {n} frames, {expected} expected"
            reader.n_read = n
    finally:
        if own:
            reader.close()
    hyb = hybrid_positions(a["h_chord"], a["h_left"], a["h_right"], calibration_mm=opt.edge_calibration_mm)
    hinfo = {"offsets_mm": hyb.offsets_mm, "calibration_frames": hyb.calibration_frames,
             "calibration_range_mm": hyb.calibration_range_mm, "counts": hyb.counts()}
    if opt.position == "hybrid":
        _use_hybrid(a, hyb)
        log.info("%s: hybrid position %s; edge offsets %s mm", reader.path, hinfo["counts"],
                 hinfo["offsets_mm"])
    flags, too_many = a["flags"], a["too_many"]
    kmax = max(int(n_regions(a["regions"]).max(initial=0)), 1)
    regions = a["regions"][:, :kmax]
    clipped = _clipped(regions, calibration)
    if clipped.any():
        log.info("%s: %d frames have a contact region cut by the crop's edge (VideoResult.clipped)",
                 reader.path, int(clipped.sum()))
    n_good = int(np.count_nonzero(flags == 0))
    msg = f"{n_good} of {flags.size} frames tracked"
    if truncated:
        msg += f"; video truncated after frame {reader.n_read - 1}: {reader.error}"
    return VideoResult(path=reader.path, x=a["x"], x_cf=a["x_cf"], x_chord=a["x_chord"], regions=regions,
                       flags=flags, line_row=a["line_row"],
                       area_px=float(an.area) if an.area is not None else float("nan"),
                       reference_frame=an.reference_frame, calibration=calibration, fps=reader.fps,
                       contact_tol_px=opt.contact_tol_px, contact_metric=opt.contact_metric,
                       timings=timings, truncated=bool(truncated), success=n_good > 0, message=msg,
                       x_hybrid=np.where(too_many, np.nan, hyb.x),
                       x_source=np.where(too_many, PositionSource.NONE, hyb.source).astype(np.uint8),
                       hybrid=hinfo, clipped=clipped, gap_px=a["gap"])


def _frame_range(reader: VideoReader, n_frames: int | None, start: int, stop: int | None):
    """``(n, expected, stop)``: the frames the file holds, the frames it should hold (the
    manifest's count, else ``n``) and the end of the range to analyse, checked."""
    n = reader.n_frames
    if n == 0:
        raise ValueError(f"{reader.path}: the video has no frames")
    expected = n if n_frames is None else int(n_frames)
    if n_frames is not None and expected < n:
        log.warning("%s holds %d frames, more than the %d expected; analysing %d",
                    reader.path, n, expected, expected)
    stop = expected if stop is None else min(int(stop), expected)
    if not 0 <= start < stop:
        raise ValueError(f"{reader.path}: frame range [{start}, {stop}) is empty or outside "
                         f"the video's {expected} frames")
    return n, expected, stop


def _calibrate_reader(reader: VideoReader, opt: AnalysisOptions, surface_height_mm: float,
                      surface: Surface | None) -> Calibration:
    """The calibration (Fig. 7A) from the video's finger-free frame ``opt.calibration_frame``."""
    if opt.calibration_frame >= reader.n_frames:
        raise ValueError(f"{reader.path}: calibration_frame {opt.calibration_frame} is beyond "
                         f"the last frame ({reader.n_frames - 1})")
    frame0 = reader.read_frame(opt.calibration_frame)
    try:
        return calibrate(frame0, surface_height_mm, crop=opt.crop, level=opt.level, surface=surface)
    except ValueError as exc:
        raise ValueError(f"{reader.path}, calibration frame {opt.calibration_frame}: {exc}") from None


def _analyze_frames(reader: VideoReader, an: FrameAnalyzer, opt: AnalysisOptions, start: int,
                    stop: int) -> tuple[dict, dict]:
    """Frames ``start..stop-1`` through :meth:`FrameAnalyzer.analyze_chunk`, chunk by chunk:
    the per-frame arrays (frames the file does not hold stay flagged CORRUPT) and the time
    spent decoding and analysing."""
    m = stop - start
    a = {k: np.full(m, np.nan) for k in "x x_cf x_chord h_chord h_left h_right line_row gap".split()}
    a["flags"] = np.full(m, int(FrameFlag.CORRUPT), dtype=np.uint8)
    a["regions"] = np.full((m, opt.n_max_regions, 2), np.nan)
    a["too_many"] = np.zeros(m, bool)
    t_dec = t_an = 0.0
    n_an = 0
    t0 = time.perf_counter()
    for i0, frames in reader.iter_chunks(opt.chunk_size, start=start, stop=stop):
        t1 = time.perf_counter()
        t_dec += t1 - t0
        r = an.analyze_chunk(i0, frames)
        s = slice(i0 - start, i0 - start + frames.shape[0])
        for k, v in a.items():
            v[s] = r[k]
        t0 = time.perf_counter()
        t_an += t0 - t1
        n_an += frames.shape[0]
    rate = n_an / t_an if t_an > 0 else float("nan")
    return a, {"decode_s": t_dec, "analysis_s": t_an, "frames_per_s": rate}


def _use_hybrid(a: dict, hyb) -> None:
    """Make the hybrid position x(t) (:func:`hybrid_positions`) the frames' position, in
    place: a frame is tracked where it has one, and keeps C_f, the line and the regions
    only then; a frame with too many regions stays flagged."""
    flags, too_many = a["flags"], a["too_many"]
    has = np.isfinite(hyb.x)
    a["x"] = hyb.x.copy()
    seen = (flags & ~np.uint8(_CF_ONLY)) == 0
    flags[has] = 0
    flags[seen & ~has] |= int(FrameFlag.NO_HYBRID)
    flags[too_many] |= int(FrameFlag.TOO_MANY_REGIONS)  # stays flagged: no position
    has &= ~too_many
    a["x"][too_many] = np.nan
    a["x_cf"][~has] = np.nan
    a["line_row"][~has] = np.nan
    a["regions"][~has] = np.nan


def _clipped(regions: np.ndarray, calibration: Calibration) -> np.ndarray:
    """Frames with a contact region cut by the crop's side, ``(n,)`` bool: a run of contact
    columns that reaches the crop's first or last column ends there because the field of
    view does (its interpolated end is half a column outside)."""
    lo_mm, hi_mm = (float(v) for v in calibration.col_to_mm(np.array([0.0, calibration.crop.width - 1.0])))
    with np.errstate(invalid="ignore"):
        return np.any(regions[..., 0] <= lo_mm, axis=1) | np.any(regions[..., 1] >= hi_mm, axis=1)
