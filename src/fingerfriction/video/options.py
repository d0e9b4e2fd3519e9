"""What the video stage is asked to do (:class:`AnalysisOptions`) and why a frame has no
position (:class:`FrameFlag`, with one line per reason in :data:`FLAG_REASONS`). The stage
itself is :func:`fingerfriction.video.analysis.analyze_video`.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from .._check import check_option, integer, nonnegative, positive
from .binarize import Crop
from .contact import CONTACT_METRICS

__all__ = ["FrameFlag", "FLAG_REASONS", "AnalysisOptions", "POSITIONS"]

#: The x(t) estimators (``AnalysisOptions.position``).
POSITIONS = ("hybrid", "cf-centroid", "chord")


class FrameFlag(enum.IntFlag):
    """Why a frame has no position (bit flags; 0 = a good frame)."""

    CALIBRATION = 1
    FINGER_MISSING = 2
    OUT_OF_VIEW = 4
    NO_CONTOUR = 8
    CORRUPT = 16
    AREA_UNREACHABLE = 32
    NO_REFERENCE = 64
    NO_HYBRID = 128
    #: Alias of NO_CONTOUR (the uint8 flags have no free bit): the outline found touches
    #: the surface in more than ``AnalysisOptions.n_max_regions`` separate regions even
    #: after the pixel-scale cleanup, so the contour is not a usable one.
    TOO_MANY_REGIONS = 8


#: Human-readable reason of each flag.
FLAG_REASONS = {
    FrameFlag.CALIBRATION: "calibration frame (finger-free by definition)",
    FrameFlag.FINGER_MISSING: "finger missing: no dark region entering from the top",
    FrameFlag.OUT_OF_VIEW: "finger leaves the field of view: C_f is cut by the crop's side",
    FrameFlag.NO_CONTOUR: ("threshold leaves no usable contour: the finger zone is (almost) all dark, "
                           "or the outline touches the surface in more than n_max_regions separate "
                           "contact regions"),
    FrameFlag.CORRUPT: "corrupt or missing frame: the video could not be decoded here",
    FrameFlag.AREA_UNREACHABLE: "finger lifted: no line encloses the reference area A",
    FrameFlag.NO_REFERENCE: "no reference area A yet (no usable finger frame before this one)",
    FrameFlag.NO_HYBRID: ("no hybrid position: the chord is cut by the crop and no outline edge can "
                          "stand in (edge out of view, finger not on the surface, inside the chord's "
                          "range, or no frames to calibrate the edge's offset)"),
}


@dataclass(frozen=True)
class AnalysisOptions:
    """Options of the video analysis.

    Parameters
    ----------
    crop : Crop, optional
        Window analysed; default the central 1260 x 360 px of the frame (the paper's).
    level : float, optional
        Threshold in gray units (dark = ``<= level``); default Otsu on the calibration
        frame.
    contact_tol_px : float
        Contact distance in px (paper: 3 px, about 70 um).
    contact_metric : {'euclidean', 'vertical'}
        Distance between outline points (paper: euclidean) or vertical gap.
    line_offset_mm : float
        Height of the C_f line above the feature's top in the reference frame (0.4 mm).
    chunk_size : int
        Frames decoded and analysed together (memory: ~1 MB per frame of 1280 x 720 uint8).
    calibration_frame : int
        Index of the finger-free frame.
    min_finger_points : int
        Shortest finger contour (pixels) accepted; shorter ones are noise.
    n_max_regions : int
        Most contact regions expected in a frame; a frame with more (after the cleanup
        below) is flagged ``TOO_MANY_REGIONS`` (= NO_CONTOUR), never an error.
    min_gap_px : float
        Contact regions separated by a gap shorter than this (px, between interpolated
        end points) are merged into one (5 px, 0.115 mm at 23 um/px). See Notes.
    min_region_px : float
        Contact regions shorter than this (px), after merging, are dropped (3 px). See
        Notes.
    outline_smooth_px : int
        Odd number of columns of the Savitzky-Golay fit (order ``outline_smooth_order``)
        applied, for the contact test only, to the finger's lower outline in every frame
        and to the calibration's surface edge (:func:`~fingerfriction.video.contact.smooth_outline`;
        not in the paper, which compares the raw contour points). Default 41 (0.94 mm at
        23 um/px); 0 or 1 disables it. See Notes.
    outline_smooth_order : int
        Polynomial order of that fit (default 2).
    chord_height_mm : float
        Height above the feature's top of the chord whose midpoint gives the alternative
        position ``x_chord`` (not in the paper; 2 mm: higher is less affected by the
        deformation near the contact but leaves the field of view sooner).
    position : {'cf-centroid', 'chord', 'hybrid'}
        What :attr:`VideoResult.x` holds: the paper's centroid of C_f (default); the
        chord midpoint (frames whose chord is cut by the crop are then flagged
        OUT_OF_VIEW); or the hybrid of :func:`~fingerfriction.video.tracking.hybrid_positions`
        (chord midpoint where the chord is in view, else one outline edge at
        ``edge_height_mm`` shifted by a per-video offset; frames with a hybrid position
        are unflagged even where C_f is out of view, frames without get NO_HYBRID, and
        :attr:`VideoResult.x_source` says which estimator each frame used). All three are
        always returned as ``x_cf``, ``x_chord`` and ``x_hybrid``.
    edge_height_mm : float
        Height above the feature's top of the row where the hybrid's single outline edge
        is taken (4 mm: far from the contact, where the skin barely deforms and the
        silhouette is steep, so a small change of the finger's indentation moves the edge
        little; ``docs/video.md``).
    edge_calibration_mm : float
        Chord travel (mm) at each end of the chord's range whose frames give the edges'
        offsets (1 mm).

    Notes
    -----
    Contact-region cleanup (``min_gap_px``, ``min_region_px``; in image pixels, the
    scale of the artefact, applied per frame by
    :func:`~fingerfriction.video.contact.contact_regions`): with a soft, flat-bottomed
    finger the gap near a contact edge stays within a fraction of a pixel of the 3 px
    criterion over many columns, and a region flickers into fragments separated by short
    gaps; the defaults bridge those gaps and drop the specks, far below any real blind
    spot. Set both to 0 for the raw runs. No hysteresis in time is applied: frames stay
    independent (chunking-invariant).

    Outline smoothing for the contact test (``outline_smooth_px``): where the gap opens
    slowly, a contact end point is ill-conditioned (a gap error of 0.1 px moves it by
    5-20 px), and the sub-pixel outlines carry about 0.04 px of noise per column; a
    quadratic Savitzky-Golay fit along the columns removes most of it. The C_f area,
    chord and edge positions use the raw outline. The measurements behind both defaults
    are in ``docs/video.md``.
    """

    crop: Crop | None = None
    level: float | None = None
    contact_tol_px: float = 3.0
    contact_metric: str = "euclidean"
    line_offset_mm: float = 0.4
    chunk_size: int = 128
    calibration_frame: int = 0
    min_finger_points: int = 20
    n_max_regions: int = 8
    min_gap_px: float = 5.0
    min_region_px: float = 3.0
    outline_smooth_px: int = 41
    outline_smooth_order: int = 2
    chord_height_mm: float = 2.0
    position: str = "cf-centroid"
    edge_height_mm: float = 4.0
    edge_calibration_mm: float = 1.0

    def __post_init__(self) -> None:
        positive("contact_tol_px", self.contact_tol_px, "px")
        check_option("contact_metric", self.contact_metric, CONTACT_METRICS)
        positive("line_offset_mm", self.line_offset_mm, "mm", what="length")
        integer("chunk_size", self.chunk_size, 1, what="frames")
        integer("calibration_frame", self.calibration_frame, 0, what="(a frame index)")
        integer("n_max_regions", self.n_max_regions, 1, what="regions")
        for name in ("min_gap_px", "min_region_px"):
            nonnegative(name, getattr(self, name), "px")
        w, o = self.outline_smooth_px, self.outline_smooth_order
        if isinstance(w, bool) or not isinstance(w, (int, np.integer)) or w < 0 or (w > 1 and w % 2 == 0):
            raise ValueError(f"outline_smooth_px must be 0, 1 or an odd number of columns, got {w!r}")
        if isinstance(o, bool) or not isinstance(o, (int, np.integer)) or o < 0 or (w > 1 and o >= w):
            raise ValueError(
                f"outline_smooth_order must be an integer >= 0 and < outline_smooth_px ({w}), got {o!r}"
            )
        check_option("position", self.position, POSITIONS)
        for name in ("edge_height_mm", "edge_calibration_mm", "chord_height_mm"):
            positive(name, getattr(self, name), "mm", what="length")
        if self.level is not None and not math.isfinite(float(self.level)):
            raise ValueError(f"level must be a finite gray level, got {self.level!r}")
