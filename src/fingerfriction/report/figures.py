"""The report's figures, analogous to those of Janko, Wiertlewski & Visell (2018).

Each function takes a :class:`~fingerfriction.report.data.ReportData` and returns a
:class:`matplotlib.figure.Figure` built without pyplot (so it works in any thread and
never opens a window), at print size in the package's style (:mod:`fingerfriction._style`: full page
width, no text under 7 pt, Okabe-Ito colours); :func:`save_figure` writes it as PNG and
SVG (text kept as text).

* :func:`fig3_occupancy` - Fig. 3: normalised contact occupancy of each surface location
  (all trials pooled) over the surface profile, with a colour bar; the tactile blind
  spots marked and labelled with their widths.
* :func:`fig4_forces` - Fig. 4: measured F_T(x) per surface and subject, one curve per
  speed (mean, +- 1 SD band where n > 1, n written by each curve), speeds offset by
  25 mN; the footing (absolute or the paper's detrended one) in the title.
* :func:`fig6_model` - Fig. 6: measured against modelled F_T(x) on the footing the fit
  compares them on (named in the title), mean +- 1 SD where n > 1; ticks mark where a
  contact region appears or vanishes, the cause of the model's steps.
* :func:`figS1_lengths` - Fig. S1: contact lengths L_i against finger position.
* :func:`figS3_components` - Fig. S3: model interfacial F_int (Eq. 2) and deformation
  F_def (Eq. 3) parts, mean +- 1 SD per surface.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from .._atomic import atomic_write_bytes
from .._check import check_option
from .._style import (
    BLIND_SPOT,
    CYCLE,
    F_DEF,
    F_INT,
    FULL_WIDTH_IN,
    MEASURED,
    MODEL,
    SPEED_COLOURS,
    figure_style,
    new_figure,
)
from ..model.blindspots import blind_spots, occupancy
from ..model.stats import shape_label
from ..regions import region_lengths
from ..study.results import AnalysedTrial, FitResult
from .data import ReportData

__all__ = ["fig3_occupancy", "fig4_forces", "fig6_model", "figS1_lengths", "figS3_components",
           "save_figure", "FIGURES", "pooled_regions", "measured_footing", "fit_footing",
           "region_events"]

_OFFSET_N = 0.025  # Fig. 4: speeds offset by 25 mN
_BAND_ALPHA = 0.18


def save_figure(fig: Figure, stem: str | Path, *, dpi: int = 150) -> dict[str, bytes]:
    """Write ``stem.png`` and ``stem.svg`` atomically; return their bytes by suffix.

    Drawn in the package style (tick labels are created at draw time), at the figure's
    own size: the saved size is the print size.
    """
    out = {}
    with figure_style():
        for fmt in ("png", "svg"):
            buf = io.BytesIO()
            fig.savefig(buf, format=fmt, dpi=dpi, bbox_inches="tight", pad_inches=0.03)
            data = buf.getvalue()
            atomic_write_bytes(f"{stem}.{fmt}", data)
            out[fmt] = data
    return out


def surface_title(data: ReportData, surface: str) -> str:
    """'Bump 2 mm' (the paper's names) or the surface's own name."""
    s = data.surfaces.get(surface)
    shape, width = getattr(s, "shape", None), getattr(s, "width", None)
    if shape and width:
        return f"{shape_label(shape)} {width:g} mm"
    return getattr(s, "name", None) or surface


def _subject_word(data: ReportData) -> str:
    n = len(data.subjects)
    return "both subjects" if n == 2 else ("one subject" if n == 1 else f"all {n} subjects")


def _empty(ax, text: str = "no trial") -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.45")


def pooled_regions(trials: list[AnalysedTrial], masks: list[np.ndarray] | None = None) -> np.ndarray:
    """Concatenate the regions of several trials into one ``(n, n_max, 2)`` array
    (optionally only the frames selected by one boolean mask per trial)."""
    if not trials:
        return np.full((1, 1, 2), np.nan)
    k = max(t.regions.shape[1] for t in trials)
    parts = []
    for i, t in enumerate(trials):
        r = t.regions if masks is None else t.regions[masks[i]]
        parts.append(np.pad(r, ((0, 0), (0, k - r.shape[1]), (0, 0)), constant_values=np.nan))
    out = np.concatenate(parts)
    return out if out.shape[0] else np.full((1, k, 2), np.nan)


def _mean_sd(series, x_ref: np.ndarray | None = None):
    """Mean, SD and count across trials of series given as (x, y), on a common grid.

    Returns ``(x, mean, sd, n)`` with ``n`` the number of trials, or None.
    """
    series = [(np.asarray(x, float), np.asarray(y, float)) for x, y in series]
    series = [(x, y) for x, y in series if len(x) > 1 and np.isfinite(y).sum() >= 2]
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
        o = np.argsort(x[ok])
        Y[i] = np.interp(x_ref, x[ok][o], y[ok][o], left=np.nan, right=np.nan)
    cnt = np.isfinite(Y).sum(axis=0)
    with np.errstate(all="ignore"):
        mean = np.nansum(Y, axis=0) / np.where(cnt > 0, cnt, np.nan)
        sd = np.sqrt(np.nansum((Y - mean) ** 2, axis=0) / np.where(cnt > 0, cnt, np.nan))
    sd[cnt < 2] = np.nan  # no spread from one trial: no band
    return x_ref, mean, sd, len(series)


def _curve(ax, ms, colour, *, scale: float = 1e3, offset: float = 0.0, ls: str = "-", label=None):
    """Draw a mean curve and, where more than one trial contributes, its +- 1 SD band."""
    x, m, s, n = ms
    if n > 1:
        ax.fill_between(x, scale * (m - s + offset), scale * (m + s + offset), color=colour,
                        alpha=_BAND_ALPHA, lw=0)
    ax.plot(x, scale * (m + offset), color=colour, ls=ls, label=label)


# --------------------------------------------------------------------------------------
# Fig. 3
# --------------------------------------------------------------------------------------


def _profile_with_blind_spots(ax_h, ax_o, surf, bs) -> None:
    """Fig. 3's lower panel: the profile h(x) over the blind-spot span ``bs.span`` (flat
    without a surface), each blind spot shaded and labelled with its width, and outlined
    on the occupancy strip above (``ax_o``)."""
    lo, hi = bs.span
    xs = np.linspace(lo, hi, 1500)
    h = surf.h(xs) if surf is not None else np.zeros_like(xs)
    H = max(float(np.ptp(h)), 0.2)
    base = float(h.min()) - 0.15 * H
    ax_h.fill_between(xs, base, h, color="0.82", lw=0)
    ax_h.plot(xs, h, color="k", lw=0.9)
    n_bs = len(bs)
    for k, (a, b) in enumerate(bs.intervals):
        ax_h.axvspan(a, b, color=BLIND_SPOT, alpha=0.22, lw=0)
        ax_o.plot([a, a, b, b], [0.0, 1.0, 1.0, 0.0], color=BLIND_SPOT, lw=0.9)
        seg = (xs >= a) & (xs <= b)
        ax_h.plot(xs[seg], h[seg], color=BLIND_SPOT, lw=2.2, solid_capstyle="butt")
        # two neighbours (a bump's pair) are labelled away from each other
        ha, xt = "center", 0.5 * (a + b)
        if n_bs == 2:
            ha, xt = ("right", b) if k == 0 else ("left", a)
        ax_h.text(xt, float(h.max()) + 0.12 * H, f"{b - a:.2f} mm", ha=ha, va="bottom",
                  color=BLIND_SPOT, fontsize=7)
    ax_h.set_ylim(base, float(h.max()) + 0.5 * H)
    ax_h.set_xlim(lo, hi)
    ax_h.set_ylabel("h (mm)")
    ax_h.yaxis.set_major_formatter("{x:.1f}")


def fig3_occupancy(data: ReportData) -> Figure:
    """Fig. 3: normalised proportion of time each surface location is in contact.

    Per surface: a strip of the occupancy (grey scale, colour bar on the right: 1, white
    = the most contacted location, 0, black = never contacted) above the surface profile
    h(x) on the same x axis; the blind spots (never contacted in any frame of any trial,
    as the blind-spot table) shaded on the profile and labelled with their widths.

    The occupancy counts the frames in which the finger slides through the analysis
    window (:meth:`AnalysedTrial.sliding`): the rest at touch-down is left out. Counted, it
    added the resting contact's time to every location it covered, a step in every
    panel at the resting contact's leading edge (x = -9.6 mm in the simulated studies:
    touch-down at x = -15.5 mm, the contact reaching 5.9 mm ahead).
    """
    names = data.surface_names
    with figure_style():
        fig = new_figure(FULL_WIDTH_IN, 0.6 + 1.25 * len(names))
        # one grid for all panels (constrained layout then aligns them all): per surface an
        # occupancy strip over its profile, and a narrow column for the colour bar
        gs = fig.add_gridspec(2 * len(names), 2, width_ratios=[1.0, 0.015],
                              height_ratios=[0.38, 1.0] * len(names))
        im = None
        all_axes = []
        for i, name in enumerate(names):
            ax_o = fig.add_subplot(gs[2 * i, 0])
            ax_h = fig.add_subplot(gs[2 * i + 1, 0], sharex=ax_o)
            all_axes += [ax_o, ax_h]
            ts = data.select(surface=name)
            surf = data.surfaces.get(name)
            title = f"{surface_title(data, name)} ({len(ts)} trials)"
            try:
                bs = blind_spots(pooled_regions(ts))
                occ = occupancy(pooled_regions(ts, [t.sliding() for t in ts]), span=bs.span)
            except ValueError:
                ax_o.set_title(f"{title}: no contact detected", loc="left")
                ax_o.set_axis_off()
                ax_h.set_axis_off()
                continue
            lo, hi = bs.span
            im = ax_o.imshow(occ.normalized[None, :], cmap="gray", vmin=0, vmax=1, aspect="auto",
                             extent=(lo, hi, 0, 1), interpolation="nearest")
            ax_o.set_yticks([])
            ax_o.tick_params(axis="x", labelbottom=False, bottom=False)
            for sp in ax_o.spines.values():
                sp.set_visible(True)
            widths = ", ".join(f"{w:.2f}" for w in bs.widths)
            ax_o.set_title(f"{title}: blind spots {widths + ' mm' if widths else 'none'}", loc="left")
            _profile_with_blind_spots(ax_h, ax_o, surf, bs)
            if i < len(names) - 1:
                ax_h.tick_params(axis="x", labelbottom=False)
        if all_axes:
            all_axes[-1].set_xlabel("surface position x (mm)")
        if im is not None:
            rows = slice(0, 2 * len(names)) if len(names) < 3 else slice(2, 2 * len(names) - 2)
            cb = fig.colorbar(im, cax=fig.add_subplot(gs[rows, 1]))
            cb.set_label("normalised time in contact (1 = most, 0 = never)")
        fig.suptitle(
            f"Fig. 3 - Contact occupancy ({_subject_word(data)}, all trials, while the finger slides "
            "through the window)\nover the surface profile; tactile blind spots (never in contact) shaded, "
            "with their widths")
    return fig


# --------------------------------------------------------------------------------------
# Fig. 4
# --------------------------------------------------------------------------------------


def measured_footing(data: ReportData) -> str:
    """``'absolute'`` if every trial has the absolute forces (``F_T_abs_N``), else ``'paper'``."""
    for t in data.trials:
        col = t.forces.get("F_T_abs_N")
        if col is None or not np.isfinite(col.to_numpy(float)).any():
            return "paper"
    return "absolute" if data.trials else "paper"


def _flat_level(t: AnalysedTrial, x: np.ndarray, y: np.ndarray) -> float:
    """Mean of ``y`` over the trial's flat segment (from the force stage, else the first 2 mm)."""
    seg = (t.status.get("info") or {}).get("forces", {}).get("flat_segment_mm")
    if seg and len(seg) == 2 and all(v is not None and math.isfinite(v) for v in seg):
        m = (x >= seg[0]) & (x <= seg[1]) & np.isfinite(y)
    else:
        m = (x <= np.nanmin(x) + 2.0) & np.isfinite(y)
    return float(np.mean(y[m])) if m.any() else float(np.nanmean(y[:50]))


def measured_series(t: AnalysedTrial, footing: str):
    """A trial's measured ``(x mm, F_T N)``: 'absolute' less its mean on the flat, else the paper's."""
    x = t.forces["x_mm"].to_numpy(float)
    if footing == "absolute":
        y = t.forces["F_T_abs_N"].to_numpy(float)
        return x, y - _flat_level(t, x, y)
    return x, t.forces["F_T_N"].to_numpy(float)


_FOOTING_TEXT = {
    "absolute": "absolute (drift removed on the unloaded rests), less each trial's mean on the flat "
                "before the feature",
    "paper": "the paper's (a line fitted on the flat before the feature, subtracted over the window)",
}


def _surface_subject_grid(data: ReportData, *, top_in: float):
    """Fig. 4's and Fig. 6's layout: a panel per surface (row) and subject (column), x
    shared; the axes labelled (F_T in mN, finger position in mm). ``top_in``: the height
    in inches above the rows (titles, legend). Returns ``(fig, axes)``, axes
    ``(n_surfaces, max(n_subjects, 1))``."""
    names, n_cols = data.surface_names, max(len(data.subjects), 1)
    fig = new_figure(FULL_WIDTH_IN if n_cols > 1 else FULL_WIDTH_IN / 2 + 0.3, top_in + 1.55 * len(names))
    axes = fig.subplots(len(names), n_cols, squeeze=False, sharex=True)
    if data.subjects:
        for ax in axes[:, 0]:
            ax.set_ylabel("F_T (mN)")
    for ax in axes[-1]:
        ax.set_xlabel("finger position x (mm)")
    return fig, axes


def fig4_forces(data: ReportData, *, footing: str = "auto") -> Figure:
    """Fig. 4: measured F_T(x) per surface and subject, one curve per speed.

    Parameters
    ----------
    data : ReportData
    footing : {'auto', 'absolute', 'paper'}
        ``'absolute'``: the absolute forces (drift removed on the unloaded rests only)
        less each trial's mean over its flat segment, so that curves start at zero as in
        the paper without its extrapolated drift line; ``'paper'``: the paper's
        flat-segment detrend; ``'auto'`` (default): absolute when every trial has it.
        The title says which.
    """
    check_option("footing", footing, ("auto", "absolute", "paper"))
    if footing == "auto":
        footing = measured_footing(data)
    names, subjects, speeds = data.surface_names, data.subjects, data.speeds
    with figure_style():
        fig, axes = _surface_subject_grid(data, top_in=0.9)
        for i, name in enumerate(names):
            for j, subj in enumerate(subjects):
                ax = axes[i, j]
                drawn = False
                for k, v in enumerate(speeds):
                    ts = data.select(surface=name, subject=subj, speed=v)
                    ms = _mean_sd([measured_series(t, footing) for t in ts])
                    if ms is None:
                        continue
                    c = SPEED_COLOURS[k % len(SPEED_COLOURS)]
                    _curve(ax, ms, c, offset=k * _OFFSET_N)
                    x, m, _, n = ms
                    first = int(np.flatnonzero(np.isfinite(m))[0])
                    ax.annotate(f"n = {n}", (x[first], 1e3 * (m[first] + k * _OFFSET_N)), xytext=(1, 2.5),
                                textcoords="offset points", ha="left", va="bottom", color=c, fontsize=7)
                    drawn = True
                if not drawn:
                    _empty(ax)
                ax.set_title(f"{surface_title(data, name)}, subject {subj}")
        handles = [Line2D([], [], color=SPEED_COLOURS[k % len(SPEED_COLOURS)],
                          label=f"{v:g} mm/s (+{k * 25} mN)") for k, v in enumerate(speeds)]
        handles.append(Patch(color="0.5", alpha=0.35, label="+- 1 SD (only where n > 1)"))
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles))
        fig.suptitle(f"Fig. 4 - Measured F_T(x) per surface and subject: mean per speed, offset by 25 mN\n"
                     f"Footing: {_FOOTING_TEXT[footing]}")
    return fig


# --------------------------------------------------------------------------------------
# Fig. 6
# --------------------------------------------------------------------------------------


def fit_footing(data: ReportData) -> str:
    """How the fit put measurement and model on one footing, in words (from ``fit.json``)."""
    return (data.fit if data.fit is not None else FitResult({})).footing


def region_events(t: AnalysedTrial, *, min_jump_mm: float = 0.2) -> np.ndarray:
    """Finger positions (mm) at which a contact region appears or vanishes, ``(n,)``.

    Consecutive tracked frames whose number of regions differs and whose total contact
    length changes by at least ``min_jump_mm``: there the model of Eq. (4), an integral
    over the detected regions, steps, while the measured force changes continuously.
    """
    fr = t.frames
    x = fr["x_mm"].to_numpy(float)
    n = fr["n_regions"].to_numpy()
    L = np.nansum(region_lengths(t.regions), axis=1)
    ok = np.isfinite(x)
    idx = np.flatnonzero(ok)
    if idx.size < 2:
        return np.empty(0)
    a, b = idx[:-1], idx[1:]
    jump = (n[a] != n[b]) & (np.abs(L[b] - L[a]) >= min_jump_mm)
    return 0.5 * (x[a][jump] + x[b][jump])


def fig6_model(data: ReportData) -> Figure:
    """Fig. 6: measured (black) and model (blue) F_T(x), mean +- 1 SD per condition.

    On the footing the fit compares them on (title). Ticks along the bottom of each panel
    mark, per trial, where a contact region appears or vanishes: the model, an integral
    over the detected regions (Eq. 4), steps there (at contact onset a region appears on
    the slope with a finite length: the video's 3-px proximity criterion closes a gap at
    once), while the measured force changes continuously.
    """
    names, subjects = data.surface_names, data.subjects
    with figure_style():
        fig, axes = _surface_subject_grid(data, top_in=1.0)
        for i, name in enumerate(names):
            for j, subj in enumerate(subjects):
                ax = axes[i, j]
                ts = [t for t in data.select(surface=name, subject=subj) if t.model is not None]
                n = 0
                for col, c in (("F_T_N", MEASURED), ("F_hat_N", MODEL)):
                    ms = _mean_sd([(t.model["x_mm"], t.model[col]) for t in ts])
                    if ms is None:
                        continue
                    _curve(ax, ms, c)
                    n = ms[3]
                if n == 0:
                    _empty(ax)
                else:
                    xr = (min(float(np.nanmin(t.model["x_mm"])) for t in ts),
                          max(float(np.nanmax(t.model["x_mm"])) for t in ts))
                    for t in ts:
                        ev = region_events(t)
                        ev = ev[(ev >= xr[0]) & (ev <= xr[1])]
                        ax.plot(ev, np.zeros_like(ev), ls="none", marker="|", ms=5, mew=0.8, color=MODEL,
                                alpha=0.6, transform=ax.get_xaxis_transform())
                ax.set_title(f"{surface_title(data, name)}, subject {subj}" + (f" (n = {n})" if n else ""))
        handles = [Line2D([], [], color=MEASURED, label="measured F_T (mean)"),
                   Line2D([], [], color=MODEL, label="model F_hat_T (mean)"),
                   Patch(color="0.5", alpha=0.35, label="+- 1 SD (where n > 1)"),
                   Line2D([], [], color=MODEL, ls="none", marker="|", ms=6,
                          label="a contact region appears or vanishes (a tick per trial)")]
        fig.legend(handles=handles, loc="outside lower center", ncols=2)
        fig.suptitle("Fig. 6 - Measured and modelled F_T(x) per surface and subject, all speeds pooled\n"
                     f"Footing: {fit_footing(data)}\n"
                     "The model integrates over the detected contact regions (Eq. 4): it steps where one "
                     "appears\nor vanishes (ticks); at contact onset the video's 3-px criterion finds one "
                     "on the slope at once")
    return fig


# --------------------------------------------------------------------------------------
# supplementary figures
# --------------------------------------------------------------------------------------


def _surface_panels(data: ReportData, *, row_h: float = 1.75):
    """A figure with one panel per surface (two columns), unused panels hidden."""
    names = data.surface_names
    n_cols = 2 if len(names) > 1 else 1
    n_rows = -(-len(names) // n_cols)
    fig = new_figure(FULL_WIDTH_IN if n_cols > 1 else FULL_WIDTH_IN / 2 + 0.3, 0.6 + row_h * n_rows)
    axes = fig.subplots(n_rows, n_cols, squeeze=False)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    return fig, list(zip(axes.ravel()[: len(names)], names, strict=True))


def figS1_lengths(data: ReportData) -> Figure:
    """Fig. S1: contact lengths L_i of each region C_i against finger position."""
    with figure_style():
        fig, panels = _surface_panels(data)
        n_max = 0
        for ax, name in panels:
            ts = data.select(surface=name)
            for t in ts:
                x = t.frames["x_mm"].to_numpy(float)
                L = region_lengths(t.regions)
                for i in range(L.shape[1]):
                    ok = np.isfinite(x) & np.isfinite(L[:, i])
                    ax.plot(x[ok], L[ok, i], ".", ms=1.0, color=CYCLE[i % len(CYCLE)], alpha=0.5,
                            rasterized=True)
            n_max = max(n_max, max((t.regions.shape[1] for t in ts), default=0))
            if not ts:
                _empty(ax)
            ax.set_title(f"{surface_title(data, name)} ({len(ts)} trials)")
            ax.set_xlabel("finger position x (mm)")
            ax.set_ylabel("L_i (mm)")
        handles = [Line2D([], [], ls="none", marker="o", ms=4, color=CYCLE[i % len(CYCLE)], label=f"L{i + 1}")
                   for i in range(n_max)]
        if handles:
            fig.legend(handles=handles, loc="outside lower center", ncols=len(handles))
        fig.suptitle("Fig. S1 - Contact lengths L_i of the regions C_i (numbered left to right) against "
                     "finger position")
    return fig


def figS3_components(data: ReportData) -> Figure:
    """Fig. S3: model F_int (Eq. 2) and F_def (Eq. 3), mean +- 1 SD over all trials, for
    the model variant the fit used and, beside it, each variant it fitted only to compare
    with the paper (not selectable: the paper's Eq. 4 as printed)."""
    fit = data.fit if data.fit is not None else FitResult({})
    default = fit.model
    recorded = fit.record.get("models") or {}
    models = [default] + [m for m, rec in recorded.items()
                          if m != default and isinstance(rec, dict) and rec.get("selectable") is False]
    if not any("selectable" in (rec or {}) for rec in recorded.values()):  # a fit of the two variants
        models = [default] + [m for m in recorded if m != default]
    models = [m for m in models
              if any(t.model is not None and f"{m}_F_int_N" in t.model for t in data.trials)]
    if not models:  # a fit written before the two variants: its own columns
        models = [None]
    names = data.surface_names
    with figure_style():
        width = FULL_WIDTH_IN if len(models) > 1 else FULL_WIDTH_IN / 2 + 0.3
        fig = new_figure(width, 0.9 + 1.45 * len(names))
        axes = fig.subplots(len(names), len(models), squeeze=False, sharex=True)
        for i, name in enumerate(names):
            ts = [t for t in data.select(surface=name) if t.model is not None]
            for j, m in enumerate(models):
                ax = axes[i, j]
                drawn = False
                for col, c in (("F_int_N", F_INT), ("F_def_N", F_DEF)):
                    key = col if m is None else f"{m}_{col}"
                    ms = _mean_sd([(t.model["x_mm"], t.model[key]) for t in ts if key in t.model])
                    if ms is None:
                        continue
                    _curve(ax, ms, c)
                    drawn = True
                if not drawn:
                    _empty(ax)
                what = "" if m is None else f" - {fit.title(m)}"
                ax.set_title(f"{surface_title(data, name)}{what}"
                             + (" (default)" if m == default and len(models) > 1 else ""))
                if j == 0:
                    ax.set_ylabel("force (mN)")
        for ax in axes[-1]:
            ax.set_xlabel("finger position x (mm)")
        handles = [Line2D([], [], color=F_INT, label="interfacial F_int (Eq. 2)"),
                   Line2D([], [], color=F_DEF, label="deformation F_def (Eq. 3)"),
                   Patch(color="0.5", alpha=0.35, label="+- 1 SD (where n > 1)")]
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles))
        fig.suptitle("Fig. S3 - Model components with the fitted parameters: mean over all trials of a "
                     "surface" + (", each model variant" if len(models) > 1 else ""))
    return fig


#: (file stem, title, function, needs the fit)
FIGURES = (
    ("fig3_occupancy", "Fig. 3 - contact occupancy and tactile blind spots", fig3_occupancy, False),
    ("fig4_forces", "Fig. 4 - measured tangential force F_T(x)", fig4_forces, False),
    ("fig6_model", "Fig. 6 - measured against modelled force", fig6_model, True),
    ("figS1_lengths", "Fig. S1 - contact lengths against position", figS1_lengths, False),
    ("figS3_components", "Fig. S3 - interfacial against deformation force", figS3_components, True),
)
