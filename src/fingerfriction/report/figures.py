"""The report's figures, analogous to those of Janko, Wiertlewski & Visell (2018).

Each function takes a :class:`~fingerfriction.report.data.ReportData` and returns a
:class:`matplotlib.figure.Figure` built without pyplot (so it works in any thread and
never opens a window); :func:`save_figure` writes it as PNG and SVG.

* :func:`fig3_occupancy` - Fig. 3: normalised contact occupancy of each surface location
  (all trials of both subjects) with the tactile blind spots marked.
* :func:`fig4_forces` - Fig. 4: measured F_T(x) per surface and subject, mean +- 1 SD per
  speed, speeds offset by 25 mN.
* :func:`fig6_model` - Fig. 6: measured against modelled F_T(x) (as compared by the fit),
  mean +- 1 SD over the trials of each surface and subject.
* :func:`figS1_lengths` - Fig. S1: contact lengths L_i against finger position.
* :func:`figS3_components` - Fig. S3: model interfacial F_int (Eq. 2) and deformation
  F_def (Eq. 3) parts, mean +- 1 SD per surface.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from .._atomic import atomic_write_bytes
from ..blindspots import blind_spots, occupancy
from ..regions import region_lengths
from .data import ReportData, TrialData

__all__ = ["fig3_occupancy", "fig4_forces", "fig6_model", "figS1_lengths", "figS3_components",
           "save_figure", "FIGURES", "pooled_regions"]

#: Speed colours of Fig. 4 (40 mm/s red, 80 blue, 120 orange); other speeds cycle on.
_SPEED_COLOURS = ["#d62728", "#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b"]
_REGION_COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"]
_OFFSET_N = 0.025  # Fig. 4: speeds offset by 25 mN


def save_figure(fig: Figure, stem: str | Path, *, dpi: int = 110) -> dict[str, bytes]:
    """Write ``stem.png`` and ``stem.svg`` atomically; return their bytes by suffix."""
    out = {}
    for fmt in ("png", "svg"):
        buf = io.BytesIO()
        fig.savefig(buf, format=fmt, dpi=dpi, bbox_inches="tight")
        data = buf.getvalue()
        atomic_write_bytes(f"{stem}.{fmt}", data)
        out[fmt] = data
    return out


def _grid(data: ReportData, n_rows: int, n_cols: int, *, w: float = 4.2, h: float = 2.2, **kw):
    fig = Figure(figsize=(w * n_cols, h * n_rows + 0.6), layout="constrained")
    axes = fig.subplots(n_rows, n_cols, squeeze=False, **kw)
    return fig, axes


def _surface_panels(data: ReportData):
    """A figure with one panel per surface (two columns), unused panels hidden.

    Returns the figure and the ``(axes, surface name)`` pairs in surface order.
    """
    names = data.surface_names
    n_cols = 2 if len(names) > 1 else 1
    n_rows = -(-len(names) // n_cols)
    fig, axes = _grid(data, n_rows, n_cols, w=4.6, h=2.4)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    return fig, list(zip(axes.ravel()[: len(names)], names, strict=True))


def _label(data: ReportData, surface: str) -> str:
    s = data.surfaces.get(surface)
    return getattr(s, "name", None) or surface


def _legend(ax) -> None:
    """A legend if anything was drawn (a panel may be empty: every trial failed)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=6, loc="upper left", frameon=False)
    else:
        ax.text(0.5, 0.5, "no trial", transform=ax.transAxes, ha="center", va="center", color="0.5")


def pooled_regions(trials: list[TrialData]) -> np.ndarray:
    """Concatenate the regions of several trials into one ``(n, n_max, 2)`` array."""
    if not trials:
        return np.full((1, 1, 2), np.nan)
    k = max(t.regions.shape[1] for t in trials)
    return np.concatenate([
        np.pad(t.regions, ((0, 0), (0, k - t.regions.shape[1]), (0, 0)), constant_values=np.nan)
        for t in trials
    ])


def _mean_sd(trials: list[TrialData], get, x_ref: np.ndarray | None = None):
    """Mean and SD across trials of a series given per trial as (x, y), on a common grid."""
    series = [get(t) for t in trials]
    series = [(np.asarray(x, float), np.asarray(y, float)) for x, y in series if len(x) > 1]
    if not series:
        return None
    if x_ref is None:
        x_ref = series[0][0]
        # At most ~1000 points per curve (0.026 mm on the paper's 26 mm window): the same
        # picture as 0.01 mm, a third of the drawing time and SVG size.
        x_ref = x_ref[:: max(1, -(-x_ref.size // 1000))]
    Y = np.full((len(series), x_ref.size), np.nan)
    for i, (x, y) in enumerate(series):
        ok = np.isfinite(x) & np.isfinite(y)
        if ok.sum() < 2:
            continue
        o = np.argsort(x[ok])
        Y[i] = np.interp(x_ref, x[ok][o], y[ok][o], left=np.nan, right=np.nan)
    with np.errstate(all="ignore"), _quiet():
        mean = np.nanmean(Y, axis=0)
        sd = np.nanstd(Y, axis=0)
    return x_ref, mean, sd, len(series)


class _quiet:
    def __enter__(self):
        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        self._w.__exit__(*exc)


def fig3_occupancy(data: ReportData) -> Figure:
    """Fig. 3: normalised proportion of time each surface location is in contact."""
    names = data.surface_names
    fig, axes = _grid(data, len(names), 1, w=9.0, h=1.9)
    for ax, name in zip(axes[:, 0], names, strict=True):
        ts = data.select(surface=name)
        reg = pooled_regions(ts)
        surf = data.surfaces.get(name)
        try:
            occ = occupancy(reg)
            bs = blind_spots(reg)
        except ValueError:
            ax.set_title(f"{_label(data, name)}: no contact detected")
            continue
        lo, hi = occ.span
        H = max(getattr(surf, "max_height", 1.0) if surf is not None else 1.0, 0.2)
        ax.imshow(occ.normalized[None, :], cmap="gray", vmin=0, vmax=1, aspect="auto",
                  extent=(lo, hi, -0.35 * H, -0.05 * H), interpolation="nearest")
        if surf is not None:
            xs = np.linspace(lo, hi, 2000)
            ax.fill_between(xs, -0.02 * H, surf.h(xs), color="0.75", lw=0)
            ax.plot(xs, surf.h(xs), color="k", lw=1)
        for a, b in bs.intervals:
            ax.axvspan(a, b, color="#d62728", alpha=0.35, lw=0)
        widths = ", ".join(f"{w:.2f}" for w in bs.widths)
        widths = f"{widths} mm" if widths else "none"
        ax.set_title(f"{_label(data, name)} ({len(ts)} trials): blind spots {widths}", fontsize=9)
        ax.set_ylim(-0.4 * H, 1.25 * H)
        ax.set_yticks([])
        ax.set_xlim(lo, hi)
    axes[-1, 0].set_xlabel("surface position x (mm)")
    fig.suptitle("Contact occupancy (grey: 1 = most contacted, black = never) and tactile blind spots (red)",
                 fontsize=10)
    return fig


def fig4_forces(data: ReportData) -> Figure:
    """Fig. 4: measured F_T(x), mean +- 1 SD per speed, per surface and subject."""
    names, subjects, speeds = data.surface_names, data.subjects, data.speeds
    fig, axes = _grid(data, len(names), len(subjects), sharex=True)
    for i, name in enumerate(names):
        for j, subj in enumerate(subjects):
            ax = axes[i, j]
            for k, v in enumerate(speeds):
                ts = data.select(surface=name, subject=subj, speed=v)
                ms = _mean_sd(ts, lambda t: (t.forces["x_mm"], t.forces["F_T_N"]))
                if ms is None:
                    continue
                x, m, s, n = ms
                c = _SPEED_COLOURS[k % len(_SPEED_COLOURS)]
                off = k * _OFFSET_N
                ax.fill_between(x, 1e3 * (m - s + off), 1e3 * (m + s + off), color=c, alpha=0.25, lw=0)
                ax.plot(x, 1e3 * (m + off), color=c, lw=1, label=f"{v:g} mm/s (n={n})")
            ax.set_title(f"{_label(data, name)}, subject {subj}", fontsize=9)
            if j == 0:
                ax.set_ylabel("F_T (mN)")
            _legend(ax)
    for ax in axes[-1]:
        ax.set_xlabel("finger position x (mm)")
    fig.suptitle("Measured F_T(x): mean +- 1 SD per speed (speeds offset by 25 mN)", fontsize=10)
    return fig


def fig6_model(data: ReportData) -> Figure:
    """Fig. 6: measured (black) and model (blue) F_T(x), mean +- 1 SD per condition."""
    names, subjects = data.surface_names, data.subjects
    fig, axes = _grid(data, len(names), len(subjects), sharex=True)
    for i, name in enumerate(names):
        for j, subj in enumerate(subjects):
            ax = axes[i, j]
            ts = [t for t in data.select(surface=name, subject=subj) if t.model is not None]
            for col, c, lab in (("F_T_N", "k", "measured"), ("F_hat_N", "#1f77b4", "model")):
                ms = _mean_sd(ts, lambda t, col=col: (t.model["x_mm"], t.model[col]))
                if ms is None:
                    continue
                x, m, s, n = ms
                ax.fill_between(x, 1e3 * (m - s), 1e3 * (m + s), color=c, alpha=0.2, lw=0)
                ax.plot(x, 1e3 * m, color=c, lw=1, label=f"{lab} (n={n})")
            ax.set_title(f"{_label(data, name)}, subject {subj}", fontsize=9)
            if j == 0:
                ax.set_ylabel("F_T (mN)")
            _legend(ax)
    for ax in axes[-1]:
        ax.set_xlabel("finger position x (mm)")
    fig.suptitle("Measured (black) and model (blue) F_T(x), mean +- 1 SD, detrended over the flat segment",
                 fontsize=10)
    return fig


def figS1_lengths(data: ReportData) -> Figure:
    """Fig. S1: contact lengths L_i of each region C_i against finger position."""
    fig, panels = _surface_panels(data)
    for ax, name in panels:
        ts = data.select(surface=name)
        for t in ts:
            x = t.frames["x_mm"].to_numpy(float)
            L = region_lengths(t.regions)
            for i in range(L.shape[1]):
                ok = np.isfinite(x) & np.isfinite(L[:, i])
                ax.plot(x[ok], L[ok, i], ".", ms=1.0, color=_REGION_COLOURS[i % len(_REGION_COLOURS)],
                        alpha=0.5, rasterized=True)
        for i in range(max((t.regions.shape[1] for t in ts), default=0)):
            ax.plot([], [], "o", ms=3, color=_REGION_COLOURS[i % len(_REGION_COLOURS)], label=f"L{i + 1}")
        ax.legend(fontsize=6, loc="upper right", frameon=False)
        ax.set_title(f"{_label(data, name)} ({len(ts)} trials)", fontsize=9)
        ax.set_xlabel("finger position x (mm)")
        ax.set_ylabel("L_i (mm)")
    fig.suptitle("Contact lengths L_i of the regions C_i (left to right) against finger position",
                 fontsize=10)
    return fig


def figS3_components(data: ReportData) -> Figure:
    """Fig. S3: model F_int (Eq. 2) and F_def (Eq. 3), mean +- 1 SD over all trials."""
    fig, panels = _surface_panels(data)
    for ax, name in panels:
        ts = [t for t in data.select(surface=name) if t.model is not None]
        for col, c, lab in (("F_int_N", "#2ca02c", "F_int (Eq. 2)"), ("F_def_N", "#9467bd", "F_def (Eq. 3)")):
            ms = _mean_sd(ts, lambda t, col=col: (t.model["x_mm"], t.model[col]))
            if ms is None:
                continue
            x, m, s, n = ms
            ax.fill_between(x, 1e3 * (m - s), 1e3 * (m + s), color=c, alpha=0.2, lw=0)
            ax.plot(x, 1e3 * m, color=c, lw=1, label=lab)
        _legend(ax)
        ax.set_title(f"{_label(data, name)} ({len(ts)} trials)", fontsize=9)
        ax.set_xlabel("finger position x (mm)")
        ax.set_ylabel("force (mN)")
    fig.suptitle("Model components: interfacial F_int and deformation F_def (fitted p0, p1, mu)", fontsize=10)
    return fig


#: (file stem, title, function, needs the fit)
FIGURES = (
    ("fig3_occupancy", "Fig. 3 - contact occupancy and tactile blind spots", fig3_occupancy, False),
    ("fig4_forces", "Fig. 4 - measured tangential force F_T(x)", fig4_forces, False),
    ("fig6_model", "Fig. 6 - measured against modelled force", fig6_model, True),
    ("figS1_lengths", "Fig. S1 - contact lengths against position", figS1_lengths, False),
    ("figS3_components", "Fig. S3 - interfacial against deformation force", figS3_components, True),
)
