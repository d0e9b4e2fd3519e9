"""The package's figure style, for the report's figures (implemented in
:mod:`fingerfriction._style`, the base layer, so that every figure of the package can use it)."""

from .._style import (
    BLIND_SPOT,
    CYCLE,
    F_DEF,
    F_INT,
    FULL_WIDTH_IN,
    MEASURED,
    MIN_FONT_PT,
    MODEL,
    OKABE_ITO,
    RC,
    SPEED_COLOURS,
    figure_style,
    new_figure,
)

__all__ = ["OKABE_ITO", "CYCLE", "SPEED_COLOURS", "MEASURED", "MODEL", "F_INT", "F_DEF", "BLIND_SPOT",
           "FULL_WIDTH_IN", "MIN_FONT_PT", "RC", "figure_style", "new_figure"]
