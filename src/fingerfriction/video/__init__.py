"""Video analysis (Methods "Image analysis", Fig. 7 of Janko et al. 2018).

From high-speed silhouette frames to the finger position x(t) and the contact regions C_i:
:mod:`.readers` (TIFF, AVI/MP4/MKV via PyAV, Phantom cine) -> :mod:`.binarize` (crop,
threshold) -> :mod:`.calibrate` (mm per pixel, surface profile, origin) ->
:mod:`.contours` (finger outline, ``cv2.findContours``) -> :mod:`.tracking` (area-preserving
region C_f, x(t)) -> :mod:`.contact` (regions within 3 px). :func:`analyze_video` runs it
all on a video, streaming frames in chunks.
"""

from .analysis import FLAG_REASONS, AnalysisOptions, FrameAnalyzer, FrameFlag, VideoResult, analyze_video
from .binarize import Crop, central_crop, otsu_level
from .calibrate import Calibration, calibrate
from .readers import VideoReader, open_video
from .tracking import PositionSource

__all__ = [
    "AnalysisOptions", "Calibration", "Crop", "FLAG_REASONS", "FrameAnalyzer", "FrameFlag",
    "VideoReader", "VideoResult", "analyze_video", "calibrate", "central_crop", "open_video",
    "otsu_level", "PositionSource",
]
