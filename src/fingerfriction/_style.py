"""The package's figure style: print-size figures, fonts of at least 7 pt, a colour-blind
safe colour cycle, vector SVG with editable text.

Every figure of the package is drawn inside :func:`figure_style` (a context manager, or a
decorator of the function that draws and saves it); the report's are created with
:func:`new_figure`, so that they look the same
everywhere and reads at print size: figures are made at the width they are printed at
(:data:`FULL_WIDTH_IN`, a journal's double column, 180 mm) and no text is smaller than
:data:`MIN_FONT_PT`.

Colours are the Okabe-Ito palette (Okabe & Ito 2008, "Color Universal Design"), which
stays distinguishable under the common colour-vision deficiencies and in greyscale
print when paired with line styles. The speeds of Fig. 4 keep the paper's hues (40 mm/s
red, 80 blue, 120 orange) within it.

References
----------
.. [1] M. Okabe and K. Ito, "Color Universal Design (CUD): how to make figures and
   presentations that are friendly to colorblind people", 2008.
   https://jfly.uni-koeln.de/color/
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING

from cycler import cycler

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["OKABE_ITO", "CYCLE", "SPEED_COLOURS", "MEASURED", "MODEL", "F_INT", "F_DEF", "BLIND_SPOT",
           "FULL_WIDTH_IN", "MIN_FONT_PT", "RC", "figure_style", "new_figure"]

#: The Okabe-Ito palette by name.
OKABE_ITO = {
    "black": "#000000", "orange": "#E69F00", "sky blue": "#56B4E9", "bluish green": "#009E73",
    "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00", "reddish purple": "#CC79A7",
}
#: The colour cycle of every axes (yellow left out: too light on white).
CYCLE = [OKABE_ITO[k] for k in ("blue", "vermillion", "bluish green", "orange", "reddish purple",
                                 "sky blue", "black")]
#: Fig. 4: the paper's 40 mm/s red, 80 blue, 120 orange; further speeds continue the cycle.
SPEED_COLOURS = [OKABE_ITO[k] for k in ("vermillion", "blue", "orange", "bluish green", "reddish purple",
                                        "sky blue")]
#: Fig. 6: measured black, model blue (as the paper).
MEASURED, MODEL = OKABE_ITO["black"], OKABE_ITO["blue"]
#: Fig. S3: interfacial (Eq. 2) and deformation (Eq. 3) parts.
F_INT, F_DEF = OKABE_ITO["bluish green"], OKABE_ITO["reddish purple"]
#: Fig. 3: blind spots.
BLIND_SPOT = OKABE_ITO["vermillion"]

#: Width of a full-width (double-column) figure at print size, in inches (180 mm).
FULL_WIDTH_IN = 180 / 25.4
#: Smallest font size of any text in a figure, in points at the saved size.
MIN_FONT_PT = 7.0

#: Matplotlib settings of the style.
RC = {
    "font.size": 8.0,
    "axes.titlesize": 8.0,
    "axes.labelsize": 8.0,
    "xtick.labelsize": 7.0,
    "ytick.labelsize": 7.0,
    "legend.fontsize": 7.0,
    "legend.title_fontsize": 7.0,
    "figure.titlesize": 9.0,
    "figure.labelsize": 8.0,
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans"],  # ships with matplotlib: the same glyphs everywhere
    "axes.prop_cycle": cycler(color=CYCLE),
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.linewidth": 0.6,
    "axes.titlepad": 3.0,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "xtick.major.size": 2.5,
    "ytick.major.size": 2.5,
    "lines.linewidth": 1.0,
    "legend.frameon": False,
    "legend.handlelength": 1.6,
    "image.cmap": "gray",
    "savefig.dpi": 150,
    "svg.fonttype": "none",  # text stays text in the SVG: editable, searchable, crisp
    "pdf.fonttype": 42,
}


@contextlib.contextmanager
def figure_style() -> Iterator[None]:
    """Context in which figures are built *and saved* (tick labels are made at draw time);
    also a decorator (``@figure_style()``) of a function that draws and saves a figure."""
    import matplotlib as mpl  # heavy: only when a figure is drawn

    with mpl.rc_context(RC):
        yield


def new_figure(width_in: float = FULL_WIDTH_IN, height_in: float = 3.0, **kw) -> Figure:
    """A :class:`~matplotlib.figure.Figure` (no pyplot) of the given print size in inches,
    with constrained layout; call inside :func:`figure_style`."""
    from matplotlib.figure import Figure  # heavy: only when a figure is drawn

    if not (0 < width_in <= 20 and 0 < height_in <= 30):
        raise ValueError(f"figure size must be within 20 x 30 in, got {width_in!r} x {height_in!r}")
    return Figure(figsize=(width_in, height_in), layout=kw.pop("layout", "constrained"), **kw)
