"""The high-speed camera: fronto-parallel silhouettes of finger and surface (Fig. 7).

Geometry (:class:`CameraParams`): 1280 x 720 grayscale frames, ``mm_per_px`` = 0.023 mm
(the paper's ~23 um per pixel), surface position ``x = (col - x0_px) * mm_per_px`` and
height ``y = (y0_row - row) * mm_per_px`` (rows grow downwards; pixel centres at integer
indices). The flat ground ``h = 0`` lies on row ``y0_row`` = 500, so the relief (at most
0.8 mm = 35 px high) and the contact zone lie inside the paper's analysis crop, the
central 1260 x 360 pixels (rows 180-539, columns 10-1269).

Each frame is drawn column by column, with exact vertical area coverage (anti-aliasing):

* the surface plate: dark below ``h(x)``;
* the finger: dark above its lower outline, the deformed finger surface from the contact
  table over the table's relative grid (for the BEM provider: the pad out to 1.5 mm above
  its lowest point, rounded into the finger's sides); beyond the grid's ends the sides
  are vertical and leave the frame at the top (a fingertip seen side-on).

Then optics and sensor: the levels (background ``bright`` = 255 DN, a backlight that
saturates the sensor; shadows ``dark`` = 0 DN, no light behind the silhouettes), a
Gaussian blur of ``blur_px`` pixels (point-spread function), then noise, rounding and
clipping to uint8. Noise: shot noise ``N(0, gain * I)`` on the pixels that are neither
saturated (255) nor black (0), i.e. the edge band of the silhouettes where it matters
for edge localisation; with ``read_noise > 0`` every non-saturated pixel also gets
``N(0, read_noise)``.

Noise and file size: FFV1 is lossless, so noise costs bytes. With the defaults noise is
confined to the edge band and a frame costs ~12-15 kB; a read noise of 0.3 DN over a 3 DN
black level costs ~100 kB per frame (``benchmarks/simulate.py`` measures both). Choose
``read_noise`` / ``dark`` knowingly.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import cv2
import numpy as np

from .._check import in_range, integer, nonnegative, positive, validate_type
from ..surfaces import Surface

__all__ = ["CameraParams", "Camera"]


@dataclass(frozen=True)
class CameraParams:
    """Camera geometry, optics and sensor model.

    Parameters
    ----------
    width, height : int
        Frame size in pixels (1280 x 720).
    fps : float
        Frame rate in Hz (1 kHz).
    mm_per_px : float
        Image scale in mm per pixel (0.023).
    x0_px : float
        Column (0-based, pixel centres) of surface position x = 0.
    y0_row : float
        Row of surface height 0.
    blur_px : float
        Standard deviation of the Gaussian point-spread function in pixels.
    bright, dark : float
        Background and shadow intensity in DN before clipping to [0, 255].
    gain : float
        Shot-noise variance per DN of signal (DN).
    read_noise : float
        Read-noise standard deviation in DN.
    """

    width: int = 1280
    height: int = 720
    fps: float = 1000.0
    mm_per_px: float = 0.023
    x0_px: float = 639.5
    y0_row: float = 500.0
    blur_px: float = 1.0
    bright: float = 255.0
    dark: float = 0.0
    gain: float = 0.1
    read_noise: float = 0.0

    def __post_init__(self) -> None:
        own = "CameraParams"
        for k, v in asdict(self).items():
            validate_type(f"{own}.{k}", v, (int, float), "a number")
        for k in ("width", "height"):
            object.__setattr__(self, k, integer(f"{own}.{k}", getattr(self, k), 16, what="pixels"))
        positive(f"{own}.fps", self.fps, "Hz", what="frame rate")
        positive(f"{own}.mm_per_px", self.mm_per_px, "mm per pixel", what="image scale")
        in_range(f"{own}.x0_px", self.x0_px, unit="px")
        in_range(f"{own}.y0_row", self.y0_row, unit="px")
        for k in ("blur_px", "gain", "read_noise"):
            nonnegative(f"{own}.{k}", getattr(self, k), "px" if k == "blur_px" else "DN")
        in_range(f"{own}.bright", self.bright, 0.0, 255.0, unit="DN")
        in_range(f"{own}.dark", self.dark, 0.0, self.bright, unit="DN (below bright)", open_hi=True)

    @property
    def field_mm(self) -> tuple[float, float]:
        """Surface positions (mm) of the left edge of column 0 and right edge of the last."""
        return ((-0.5 - self.x0_px) * self.mm_per_px, (self.width - 0.5 - self.x0_px) * self.mm_per_px)

    def to_dict(self) -> dict:
        return asdict(self)


class Camera:
    """Renders frames of one surface.

    Parameters
    ----------
    surface : Surface
    params : CameraParams, optional

    Notes
    -----
    Coverage is exact along each pixel column (the fraction of the pixel's height below
    or above the outline at the column centre); frames are built in a transposed
    ``(width, height)`` buffer so each column is a contiguous run (faster than full-frame
    floating-point coverage, ``docs/worlds.md``; and unlike ``cv2.fillPoly(..., LINE_AA)``,
    whose edges are only placed to the nearest pixel).
    """

    def __init__(self, surface: Surface, params: CameraParams | None = None):
        self.params = P = params or CameraParams()
        self.surface = surface
        self.x_cols = (np.arange(P.width) - P.x0_px) * P.mm_per_px
        self.surface_rows = P.y0_row - np.asarray(surface.h(self.x_cols), float) / P.mm_per_px
        rows = np.arange(P.height, dtype=float)[None, :]
        self._surf_cov = np.clip(rows + 0.5 - self.surface_rows[:, None], 0.0, 1.0)  # (W, H)
        self._base = self._levels(self._surf_cov)

    def _levels(self, cov):
        P = self.params
        return np.clip(np.rint(P.bright - (P.bright - P.dark) * cov), 0, 255).astype(np.uint8)

    def height_to_row(self, y_mm):
        """Row coordinate of a height in mm."""
        return self.params.y0_row - np.asarray(y_mm, float) / self.params.mm_per_px

    def finger_rows(self, x_c: float, xi: np.ndarray, y_f: np.ndarray) -> np.ndarray:
        """Row of the finger's lower outline per column (``-inf`` where no finger).

        Parameters
        ----------
        x_c : float
            Finger centre in mm.
        xi, y_f : (m,) ndarray
            Outline heights ``y_f`` (mm) at ``x_c + xi``; ``xi`` spans ``[-R, R]``.

        Returns
        -------
        (width,) ndarray
            The finger covers, in each column, the rows above this row coordinate.
        """
        rel = self.x_cols - x_c
        inside = (rel > xi[0]) & (rel < xi[-1])
        rows = np.full(self.params.width, -np.inf)
        if inside.any():
            rows[inside] = self.height_to_row(np.interp(rel[inside], xi, y_f))
        return rows

    def render(self, finger_rows: np.ndarray | None, rng: np.random.Generator) -> np.ndarray:
        """One frame, ``(height, width)`` uint8.

        Parameters
        ----------
        finger_rows : (width,) ndarray or None
            From :meth:`finger_rows`; ``None`` for a frame without the finger.
        rng : numpy.random.Generator
            For the sensor noise.
        """
        P = self.params
        img = self._base.copy()  # (W, H)
        if finger_rows is not None:
            H = P.height
            yb = np.asarray(finger_rows, float)
            cols = np.flatnonzero(yb > -0.5)
            # pixel i covers [i - 0.5, i + 0.5]; the finger covers rows < yb
            i_f = np.floor(yb[cols] + 0.5).astype(int)  # first row not fully covered
            frac = yb[cols] + 0.5 - i_f
            dark = np.uint8(np.clip(round(P.dark), 0, 255))
            full = np.minimum(i_f, H)
            for j, n in zip(cols.tolist(), full.tolist(), strict=True):
                img[j, :n] = dark
            ok = i_f < H
            cj, ci = cols[ok], i_f[ok]
            cov = np.minimum(frac[ok] + self._surf_cov[cj, ci], 1.0)
            img[cj, ci] = self._levels(cov)
        if P.blur_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), P.blur_px, borderType=cv2.BORDER_REPLICATE)
        if P.gain > 0 or P.read_noise > 0:
            # saturated (255) and black (0) pixels carry no noise: see the module docstring
            flat = img.reshape(-1)
            lo = 0 if P.read_noise > 0 else 1
            nz = cv2.findNonZero(cv2.inRange(img, lo, 254))  # (n, 1, 2) of (col, row), 4x
            # faster than np.flatnonzero on the full frame (measured)
            if nz is None:
                return cv2.transpose(img)  # 14x faster than np.ascontiguousarray(img.T) (measured)
            nz = nz.reshape(-1, 2)
            idx = nz[:, 1].astype(np.int64) * img.shape[1] + nz[:, 0]
            v = flat[idx].astype(np.float32)
            sd = np.sqrt(P.read_noise**2 + P.gain * v)
            v += sd * rng.standard_normal(idx.size, dtype=np.float32)
            flat[idx] = np.clip(np.rint(v), 0, 255).astype(np.uint8)
        return cv2.transpose(img)  # 14x faster than np.ascontiguousarray(img.T) (measured)
