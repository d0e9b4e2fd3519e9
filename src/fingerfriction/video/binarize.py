"""Crop and threshold: the first two steps of the paper's image analysis.

Methods, "Image analysis" (Janko et al. 2018): the 1280 x 720 frames "were cropped after
recording to the center 1260 x 360 pixels to remove unwanted background and then were
converted to binary images using a threshold operation". Conventions here: rows grow
downwards, pixel centres have integer coordinates, and *dark* (finger, surface) means a
value ``<= level``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Crop", "central_crop", "otsu_level", "binarize"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Crop:
    """A rectangular window of a frame, in full-frame pixel coordinates.

    Attributes
    ----------
    x0, y0 : int
        Column and row of the window's top-left pixel (0-based).
    width, height : int
        Size in pixels.
    """

    x0: int
    y0: int
    width: int
    height: int

    def __post_init__(self) -> None:
        for name in ("x0", "y0", "width", "height"):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
                raise TypeError(f"Crop.{name} must be an integer number of pixels, got {v!r}")
        if self.x0 < 0 or self.y0 < 0:
            raise ValueError(f"Crop origin must be >= 0 px, got x0={self.x0}, y0={self.y0}")
        if self.width < 8 or self.height < 8:
            raise ValueError(f"Crop must be at least 8 x 8 px, got {self.width} x {self.height}")

    def check_fits(self, shape: tuple[int, int], where: str = "frame") -> None:
        """Raise ValueError if the window does not fit in a ``(height, width)`` frame."""
        h, w = shape
        if self.x0 + self.width > w or self.y0 + self.height > h:
            raise ValueError(
                f"crop {self.width} x {self.height} px at ({self.x0}, {self.y0}) does not fit in "
                f"the {w} x {h} px {where}; pass a smaller crop"
            )

    def apply(self, frames: np.ndarray) -> np.ndarray:
        """The window of ``(..., height, width)`` frames (a view, no copy)."""
        return frames[..., self.y0:self.y0 + self.height, self.x0:self.x0 + self.width]

    def to_dict(self) -> dict:
        return {"x0": int(self.x0), "y0": int(self.y0), "width": int(self.width),
                "height": int(self.height)}


def central_crop(shape: tuple[int, int], width: int = 1260, height: int = 360) -> Crop:
    """The centred ``width x height`` window of a ``(rows, cols)`` frame (paper: 1260 x 360).

    A frame smaller than the window gives the whole frame, with a warning.
    """
    rows, cols = (int(v) for v in shape)
    if width > cols or height > rows:
        log.warning("frame %d x %d px is smaller than the %d x %d crop: using the whole frame",
                    cols, rows, width, height)
        width, height = min(width, cols), min(height, rows)
    return Crop((cols - width) // 2, (rows - height) // 2, int(width), int(height))


def otsu_level(image: np.ndarray) -> float:
    """Otsu's threshold of a gray image (OpenCV), in the image's units.

    Raises
    ------
    ValueError
        If the image is constant (no threshold separates anything).
    """
    img = np.ascontiguousarray(image)
    if img.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"image must be uint8 or uint16, got {img.dtype}")
    lo, hi = int(img.min()), int(img.max())
    if lo == hi:
        raise ValueError(f"image is constant (all pixels = {lo}): no threshold separates dark from bright")
    level, _ = cv2.threshold(img, 0, int(np.iinfo(img.dtype).max), cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return float(level)


def binarize(image: np.ndarray, level: float) -> np.ndarray:
    """Binary image of the dark pixels: ``image <= level`` as a bool array.

    Parameters
    ----------
    image : (..., height, width) uint8 or uint16 ndarray
    level : float
        Threshold in the image's units.
    """
    if not math.isfinite(level):
        raise ValueError(f"threshold level must be finite, got {level!r}")
    return np.asarray(image) <= level
