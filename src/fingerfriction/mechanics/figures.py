"""Occupancy figure of a predicted sweep, in the manner of Fig. 3 of the paper."""

from __future__ import annotations

import os

import numpy as np

from .._atomic import atomic_write
from .._style import figure_style
from ..surfaces import Surface
from .sweep import SweepResult

__all__ = ["save_occupancy_figure"]


@figure_style()
def save_occupancy_figure(result: SweepResult, surface: Surface, path, *, kind: str = "geometric") -> str:
    """Write a PNG of the contact occupancy of a sweep over the surface profile.

    The top panel is the normalised occupancy (Fig. 3's grey scale: white = most contacted,
    black = never), the bottom panel the relief with the blind spots shaded.

    Parameters
    ----------
    result : SweepResult
        A sweep (:func:`~fingerfriction.mechanics.sweep`).
    surface : Surface
        Its relief.
    path : str or os.PathLike
        Output PNG path; written atomically (temporary file, then ``os.replace``).
    kind : {'geometric', 'mechanical'}
        Which contact definition to map (default: the paper's 70 um criterion).

    Returns
    -------
    str
        The path written.
    """
    import matplotlib  # heavy, and only needed for this figure

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # heavy, and only needed for this figure

    path = os.fspath(path)
    occ = result.occupancy(kind)
    bs = result.blind_spots(kind)
    x = occ.centers
    fig, (ax0, ax1) = plt.subplots(2, 1, figsize=(7.0, 3.6), sharex=True, height_ratios=[1, 2])
    ax0.imshow(
        occ.normalized[None, :], aspect="auto", cmap="gray", vmin=0, vmax=1,
        extent=(occ.edges[0], occ.edges[-1], 0, 1),
    )
    ax0.set_yticks([])
    ax0.set_title(f"{surface.name}: contact occupancy ({kind}), {result.finger.name or 'finger'}")
    xx = np.linspace(x[0], x[-1], 2000)
    ax1.plot(xx, surface.h(xx), color="k", lw=1.2)
    for a, b in bs.intervals:
        ax1.axvspan(a, b, color="0.2", alpha=0.35, lw=0)
        ax1.annotate(f"{b - a:.2f} mm", ((a + b) / 2, surface.max_height * 1.05), ha="center", fontsize=8)
    ax1.set_xlabel("x (mm)")
    ax1.set_ylabel("h (mm)")
    ax1.set_ylim(-0.1, max(surface.max_height, 0.1) * 1.3)
    fig.tight_layout()
    try:
        atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=150, format="png"))
    finally:
        plt.close(fig)
    return path
