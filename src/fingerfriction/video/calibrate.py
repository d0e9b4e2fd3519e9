"""Calibration from the first, finger-free frame (Fig. 7A of Janko et al. 2018).

From the calibration frame this module extracts the surface profile h-hat (the top edge
of the dark surface silhouette, to a fraction of a pixel), the image scale in mm per
pixel from the known feature height ``H`` ("the maximum height h-hat_0, in pixels, of the
observed shape h-hat and the known height of the surface H expressed in mm"), and the
column of the surface origin ``x = 0`` (bump: its top; steps: where the height is H/2).

Sub-pixel edges
---------------
Along each column, the edge is where the gray level, linearly interpolated between the
last bright and first dark pixel, crosses the threshold level. With a symmetric blur and
a threshold halfway between the two gray levels (Otsu) this is the silhouette's edge.

Scale and origin
----------------
For a raised-cosine surface (:class:`~fingerfriction.surfaces.RaisedCosine`) the edge
rows are fitted with the known shape ``row(c) = base - A g((c - c0) / w)`` (scipy least
squares), which uses every column of the feature instead of the noisiest one: then
``h-hat_0 = A`` px, ``mm_per_px = H / A`` and ``c0`` is the origin. The fitted width
``w`` gives an independent scale ``W / w`` that is reported (and warned about when it
disagrees). For any other surface the profile's robust maximum and its half-height
crossings are used.
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import least_squares

from ..surfaces import RaisedCosine, Surface
from .binarize import Crop, binarize, central_crop, otsu_level

__all__ = ["Calibration", "calibrate", "surface_edge_rows"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Calibration:
    """Image geometry recovered from the calibration frame.

    Attributes
    ----------
    crop : Crop
        The analysed window of the full frame.
    level : float
        Threshold level (gray units); dark means ``<= level``.
    level_method : str
        ``'given'`` or ``'otsu'``.
    mm_per_px : float
        Image scale in mm per pixel (``H / h-hat_0``).
    h0_px : float
        h-hat_0: the feature's height in pixels.
    x0_col : float
        Crop column (pixel centres, 0-based) of the surface origin ``x = 0``.
    surface_row : (width,) ndarray
        Sub-pixel row (crop coordinates, pixel centres) of the surface's top edge in each
        column: the measured profile h-hat.
    surface_first_dark : (width,) int ndarray
        First dark row of the surface in each column (integer).
    base_row : float
        Row of the lower flat level (h = 0).
    top_row : float
        Row of the feature's highest point (smallest surface row).
    mm_per_px_width : float or None
        Independent scale from the fitted feature width (raised-cosine fit only).
    method : str
        ``'raised-cosine fit'`` or ``'profile'``.
    fit_rms_px : float
        RMS residual of the profile fit in px (NaN for the ``'profile'`` method).
    """

    crop: Crop
    level: float
    level_method: str
    mm_per_px: float
    h0_px: float
    x0_col: float
    surface_row: np.ndarray = field(repr=False)
    surface_first_dark: np.ndarray = field(repr=False)
    base_row: float
    top_row: float
    mm_per_px_width: float | None = None
    method: str = "profile"
    fit_rms_px: float = float("nan")

    @property
    def x_mm(self) -> np.ndarray:
        """Surface position in mm of every crop column, ``(width,)``."""
        return (np.arange(self.crop.width) - self.x0_col) * self.mm_per_px

    @property
    def h_hat_mm(self) -> np.ndarray:
        """The measured surface profile h-hat in mm at :attr:`x_mm`, ``(width,)``."""
        return (self.base_row - self.surface_row) * self.mm_per_px

    @property
    def x0_px(self) -> float:
        """Full-frame column of ``x = 0`` (comparable to the simulator's truth ``x0_px``)."""
        return self.x0_col + self.crop.x0

    def col_to_mm(self, col):
        """Crop column(s) -> surface position in mm."""
        return (np.asarray(col, dtype=float) - self.x0_col) * self.mm_per_px

    def to_dict(self) -> dict:
        return {
            "crop": self.crop.to_dict(), "level": self.level, "level_method": self.level_method,
            "mm_per_px": self.mm_per_px, "h0_px": self.h0_px, "x0_col": self.x0_col,
            "x0_px": self.x0_px, "base_row": self.base_row, "top_row": self.top_row,
            "mm_per_px_width": self.mm_per_px_width, "method": self.method,
            "fit_rms_px": self.fit_rms_px,
        }


def surface_edge_rows(image: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """Top edge of the dark region touching the bottom of the image, per column.

    Parameters
    ----------
    image : (height, width) uint8 or uint16 ndarray
        A (cropped) finger-free frame: bright background, dark surface at the bottom.
    level : float
        Threshold; dark is ``<= level``.

    Returns
    -------
    rows : (width,) float ndarray
        Sub-pixel row of the bright -> dark transition (pixel centres).
    first_dark : (width,) int ndarray
        First row of the bottom dark run.

    Raises
    ------
    ValueError
        If some column's bottom pixel is bright (no surface there) or a column is dark
        to the top (no background above the surface).
    """
    img = np.asarray(image)
    dark = binarize(img, level).astype(np.uint8)
    # Remove isolated noise pixels before locating the edge (3x3 opening then closing).
    k = np.ones((3, 3), np.uint8)
    dark = cv2.morphologyEx(cv2.morphologyEx(dark, cv2.MORPH_CLOSE, k), cv2.MORPH_OPEN, k)
    h, w = dark.shape
    bright = dark == 0
    if not dark[-1].all():
        bad = np.flatnonzero(dark[-1] == 0)
        raise ValueError(
            f"no surface at the bottom of the crop in {bad.size} columns (first: column {bad[0]}) "
            f"at threshold {level:g}: the surface silhouette must cover the crop's bottom row; "
            "check the crop and the threshold"
        )
    if not bright.any(axis=0).all():
        bad = np.flatnonzero(~bright.any(axis=0))
        raise ValueError(
            f"{bad.size} columns are dark from top to bottom at threshold {level:g} "
            f"(first: column {bad[0]}): no bright background above the surface"
        )
    last_bright = h - 1 - np.argmax(bright[::-1], axis=0)
    first_dark = last_bright + 1
    cols = np.arange(w)
    g0 = img[last_bright, cols].astype(float)  # bright (> level)
    g1 = img[first_dark, cols].astype(float)  # dark (<= level)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(g0 > g1, (g0 - level) / (g0 - g1), 0.5)
    rows = last_bright + np.clip(frac, 0.0, 1.0)
    return rows, first_dark


def _shape_fn(surface: RaisedCosine):
    unit = RaisedCosine(surface.shape, 1.0, 1.0)
    return unit.h  # g(u) with u in feature widths, centred at 0, heights 0..1


def _threshold(img: np.ndarray, level: float | None) -> tuple[float, str]:
    """The threshold gray level and how it was chosen: Otsu's of ``img``, or ``level``
    checked to leave a contour."""
    if level is None:
        return otsu_level(img), "otsu"
    level_v = float(level)
    lo, hi = float(img.min()), float(img.max())
    if not lo <= level_v < hi:
        raise ValueError(
            f"threshold level {level_v:g} leaves no contour in the calibration frame "
            f"(gray levels span {lo:g}..{hi:g}); choose a level between them or omit it (Otsu)"
        )
    return level_v, "given"


@dataclass(frozen=True)
class _Guess:
    """A robust first reading of the surface profile (rows and columns in px): the base
    row left and right of the feature, the lower of the two (``base``, the larger row),
    the feature's height ``h0``, its centre (a bump's) or half-height crossing (a step's)
    ``x0`` and, for a bump, twice its width above half height."""

    left: float
    right: float
    base: float
    h0: float
    x0: float
    width_px: float | None


def _first_guess(rows: np.ndarray) -> _Guess:
    """:class:`_Guess` from the surface edge rows (px) of the crop's columns."""
    w = rows.size
    sm = cv2.medianBlur(rows.astype(np.float32)[None], 5)[0].astype(float)
    n_edge = max(w // 10, 3)
    left, right = float(np.median(sm[:n_edge])), float(np.median(sm[-n_edge:]))
    base = max(left, right)
    top = float(sm.min())
    h0 = base - top
    if h0 < 2.0:
        raise ValueError(
            f"no surface feature found in the calibration frame: the profile's height range is "
            f"{h0:.2f} px (< 2 px); check the crop, the threshold and calibration_frame"
        )
    if abs(left - right) > 0.5 * h0:  # a step
        half = 0.5 * (left + right)
        s = np.sign(sm - half)
        cross = np.flatnonzero(s[:-1] != s[1:])
        if cross.size == 0:
            raise ValueError("cannot locate the step's half-height crossing in the calibration frame")
        i = int(cross[np.argmin(np.abs(cross - w / 2))])
        x0 = i + (sm[i] - half) / (sm[i] - sm[i + 1]) if sm[i] != sm[i + 1] else i + 0.5
        return _Guess(left, right, base, h0, float(x0), None)
    above = np.flatnonzero(base - sm > 0.5 * h0)
    return _Guess(left, right, base, h0, float(0.5 * (above[0] + above[-1])),
                  (above[-1] - above[0] + 1) * 2.0)


def _raised_cosine_fit(rows: np.ndarray, surface: RaisedCosine, H: float, guess: _Guess):
    """Least-squares fit of the surface's raised-cosine shape to the edge rows:
    ``(base_row, h0_px, x0_col, mm_per_px_from_width, rms_px)``, or None (logged) when it
    fails."""
    g = _shape_fn(surface)
    b0 = guess.right if surface.shape == "step-down" else guess.left
    width_px_guess = guess.width_px if guess.width_px is not None else surface.width / (H / guess.h0)
    cols = np.arange(rows.size, dtype=float)

    def resid(p):
        b, a, c0, wpx = p
        return b - a * g((cols - c0) / wpx) - rows

    p0 = [b0, guess.h0, guess.x0, width_px_guess]
    sol = least_squares(resid, p0, method="lm", x_scale=[1.0, 1.0, 1.0, 10.0])
    if sol.success and sol.x[1] > 0 and sol.x[3] > 0:
        b, a, c0, wpx = sol.x
        return float(b), float(a), float(c0), float(surface.width / wpx), float(np.sqrt(np.mean(sol.fun**2)))
    log.warning("raised-cosine fit of the calibration profile failed (%s); using the "
                "profile's maximum", sol.message)
    return None


def calibrate(frame: np.ndarray, surface_height_mm: float, *, crop: Crop | None = None,
              level: float | None = None, surface: Surface | None = None,
              width_tolerance: float = 0.05) -> Calibration:
    """Calibrate scale, origin and surface profile from a finger-free frame (Fig. 7A).

    Parameters
    ----------
    frame : (rows, cols) uint8 or uint16 ndarray
        The full calibration frame (finger-free).
    surface_height_mm : float
        Known feature height ``H`` in mm (manifest ``calibration.surface_height_mm``).
    crop : Crop, optional
        Window to analyse; default the central 1260 x 360 px (the paper's).
    level : float, optional
        Threshold level in gray units; default Otsu's level of the cropped frame
        (reported in the result as ``level_method='otsu'``).
    surface : Surface, optional
        The surface's shape. A :class:`~fingerfriction.surfaces.RaisedCosine` enables the
        shape fit (recommended); otherwise the profile's maximum is used.
    width_tolerance : float
        Relative disagreement between the height-based and width-based scales above
        which a warning is issued (raised-cosine fit only).

    Returns
    -------
    Calibration

    Raises
    ------
    ValueError
        If ``H`` is not a positive length, the crop does not fit, the frame is constant,
        or no surface feature can be found in the crop.
    """

    H = float(surface_height_mm)
    if not (math.isfinite(H) and H > 0):
        raise ValueError(f"surface_height_mm must be a positive height in mm, got {surface_height_mm!r}")
    frame = np.asarray(frame)
    if frame.ndim != 2:
        raise ValueError(f"calibration frame must be 2-D (rows, cols), got shape {frame.shape}")
    crop = central_crop(frame.shape) if crop is None else crop
    crop.check_fits(frame.shape, "calibration frame")
    img = crop.apply(frame)
    level_v, method = _threshold(img, level)
    rows, first_dark = surface_edge_rows(img, level_v)
    guess = _first_guess(rows)
    x0, h0_px, base_row = guess.x0, guess.h0, guess.base
    mm_w, fit_rms, fit_method = None, float("nan"), "profile"
    if isinstance(surface, RaisedCosine):
        fitted = _raised_cosine_fit(rows, surface, H, guess)
        if fitted is not None:
            base_row, h0_px, x0, mm_w, fit_rms = fitted
            fit_method = "raised-cosine fit"
    mm_per_px = H / h0_px
    if mm_w is not None and abs(mm_w / mm_per_px - 1) > width_tolerance:
        warnings.warn(
            f"scale from the feature height ({mm_per_px * 1000:.2f} um/px) and from its width "
            f"({mm_w * 1000:.2f} um/px) differ by more than {width_tolerance:.0%}: check "
            "surface_height_mm and the surface spec",
            stacklevel=2,
        )
    top_row = base_row - h0_px
    log.info("calibration: %s, level %.1f (%s), h0 = %.3f px, %.5f mm/px, x0 at column %.2f",
             fit_method, level_v, method, h0_px, mm_per_px, x0)
    return Calibration(crop=crop, level=level_v, level_method=method, mm_per_px=mm_per_px,
                       h0_px=h0_px, x0_col=x0, surface_row=rows, surface_first_dark=first_dark,
                       base_row=base_row, top_row=top_row, mm_per_px_width=mm_w,
                       method=fit_method, fit_rms_px=fit_rms)
