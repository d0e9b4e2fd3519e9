"""A page per trial: what the analysis detected, so that a reader sees in one click why a
trial looks odd.

Each page (``report/trials/<trial-id>.html``, self-contained: images embedded) shows the
trial's flags with their reasons, the overlay animation (the video's frames with the
finger outline, x(t) and the contact regions C_i drawn, as ``fingerfriction overlay``
makes, from the stored results: :func:`fingerfriction.video.overlay.write_results_overlay`; the
video opened through the store's record of the inputs, the manifest not read again),
and three plots: x(t) with the source of each frame's position, F_T(x) measured with the
model, and F_N(x).

Pages are written for every flagged trial (error or warning) and a sample of the others
(:func:`choose_pages`).
"""

from __future__ import annotations

import base64
import io
import logging
from importlib import resources
from pathlib import Path

import jinja2
import numpy as np
from matplotlib.figure import Figure

from .._atomic import atomic_write_text
from .._style import CYCLE, MEASURED, MODEL, OKABE_ITO, figure_style
from ..forces.signals import describe_history
from ..study.results import AnalysedTrial
from ..study.store import ResultsStore
from ..video.overlay import write_results_overlay
from .data import ReportData
from .figures import measured_series, region_events, surface_title
from .flags import position_gaps

__all__ = ["choose_pages", "trial_plots", "write_trial_pages", "PAGE_DIR", "page_href"]

logger = logging.getLogger(__name__)

#: Folder of the trial pages inside ``report/``.
PAGE_DIR = "trials"

_SOURCE_COLOURS = {"chord": OKABE_ITO["blue"], "cf-centroid": OKABE_ITO["blue"],
                   "left-edge": OKABE_ITO["orange"], "right-edge": OKABE_ITO["bluish green"], "": "0.5"}


def page_href(trial_id: str) -> str:
    """Link from ``report/index.html`` to a trial's page."""
    return f"{PAGE_DIR}/{trial_id}.html"


def choose_pages(data: ReportData, flagged: list[str], sample: int | None) -> list[str]:
    """Trials that get a page: every flagged one and ``sample`` of the others (all if None).

    The sample is spread evenly over the manifest order (so it covers the subjects,
    surfaces and speeds), deterministic: the same results give the same pages.
    """
    order = [m["id"] for m in data.run.get("trials", [])]
    flagged_set = set(flagged)
    others = [t for t in order if t not in flagged_set and any(tr.id == t for tr in data.trials)]
    if sample is None:
        pick = others
    else:
        if int(sample) < 0:
            raise ValueError(f"sample must be >= 0 trials (or None for all), got {sample!r}")
        k = min(int(sample), len(others))
        idx = np.unique(np.linspace(0, len(others) - 1, k).round().astype(int)) if k else []
        pick = [others[i] for i in idx]
    chosen = flagged_set | set(pick)
    return [t for t in order if t in chosen]


def _svg(fig: Figure) -> str:
    """The figure as base64 SVG (text kept as text): vector, and faster to write than a
    PNG of these plots (``docs/study.md``)."""
    buf = io.BytesIO()
    with figure_style():
        fig.savefig(buf, format="svg")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _new(h: float = 2.3) -> Figure:
    # fixed margins: constrained layout doubled the time of these small plots (measured:
    # 0.24 -> 0.1 s each), and the labels are always the same
    fig = Figure(figsize=(6.0, h))
    fig.subplots_adjust(left=0.1, right=0.98, bottom=0.19, top=0.9)
    return fig


def trial_plots(t: AnalysedTrial, data: ReportData) -> dict[str, str]:
    """The page's three plots as base64 SVG: ``x_t``, ``f_t``, ``f_n``."""
    out = {}
    fr = t.frames
    with figure_style():
        # 1. x(t), coloured by the estimator that gave each frame's position
        fig = _new()
        ax = fig.add_subplot()
        tt = fr["t_s"].to_numpy(float)
        x = fr["x_mm"].to_numpy(float)
        src = fr["x_source"].astype(str).to_numpy() if "x_source" in fr.columns else None
        if src is None:
            ax.plot(tt, x, ".", ms=1.5, color=CYCLE[0], label="x(t) (source not recorded by this analysis)")
        else:
            for name in dict.fromkeys(s for s in src if s):
                m = src == name
                ax.plot(tt[m], x[m], ".", ms=1.5, color=_SOURCE_COLOURS.get(name, CYCLE[4]),
                        label=f"{name} ({int(m.sum())} frames)")
        flagged = (fr["flag"].astype(str).str.len().to_numpy() > 0 if "flag" in fr.columns
                   else np.zeros(len(fr), bool))
        if flagged.any():
            ax.plot(tt[flagged], np.zeros(int(flagged.sum())), ls="none", marker="|", ms=5,
                    color=OKABE_ITO["vermillion"], transform=ax.get_xaxis_transform(),
                    label=f"flagged frame ({int(flagged.sum())})")
        for g in position_gaps(t):
            r0, r1 = g["row"], g["row"] + g["n"] - 1
            ax.axvspan(tt[r0], tt[r1], color=OKABE_ITO["vermillion"], alpha=0.15, lw=0)
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("finger position x (mm)")
        ax.set_title("x(t) per video frame, by the estimator that gave it")
        ax.legend(loc="lower right", markerscale=4)
        out["x_t"] = _svg(fig)
        xf = t.forces["x_mm"].to_numpy(float)
        has_abs = "F_T_abs_N" in t.forces.columns and np.isfinite(t.forces["F_T_abs_N"]).any()

        # 2. F_T(x) measured with the model (as the fit compares them), or measured only
        fig = _new()
        ax = fig.add_subplot()
        if t.model is not None:
            xm = t.model["x_mm"].to_numpy(float)
            ax.plot(xm, 1e3 * t.model["F_T_N"].to_numpy(float), color=MEASURED, label="measured (as fitted)")
            ax.plot(xm, 1e3 * t.model["F_hat_N"].to_numpy(float), color=MODEL, label="model F_hat_T")
            ev = region_events(t)
            ev = ev[(ev >= xm.min()) & (ev <= xm.max())] if xm.size else ev
            ax.plot(ev, np.zeros_like(ev), ls="none", marker="|", ms=6, color=MODEL,
                    transform=ax.get_xaxis_transform(), label="a contact region appears or vanishes")
            footing = (data.fit.footing if data.fit is not None else "the fit's").split(" (")[0]
            ax.set_title(f"F_T(x): measured and the fit's default model, {footing} footing")
        else:  # not fitted: the measurement on its footings (one scale: the flat level taken off)
            ax.set_title("F_T(x) measured (not fitted)")
            ax.plot(xf, 1e3 * t.forces["F_T_N"].to_numpy(float), color=OKABE_ITO["vermillion"], lw=0.7,
                    label="paper's footing")
            if has_abs:
                xa, ya = measured_series(t, "absolute")
                ax.plot(xa, 1e3 * ya, color=OKABE_ITO["bluish green"], lw=0.7,
                        label="absolute, less its flat level")
        ax.set_xlabel("finger position x (mm)")
        ax.set_ylabel("F_T (mN)")
        ax.legend(loc="best")
        out["f_t"] = _svg(fig)

        # 3. F_N(x)
        fig = _new()
        ax = fig.add_subplot()
        if "F_N_abs_N" in t.forces.columns and np.isfinite(t.forces["F_N_abs_N"]).any():
            ax.plot(xf, 1e3 * t.forces["F_N_abs_N"].to_numpy(float), color=OKABE_ITO["bluish green"],
                    label="absolute footing")
            ax.set_title("F_N(x): normal force")
        elif "F_N_N" in t.forces.columns:
            ax.plot(xf, 1e3 * t.forces["F_N_N"].to_numpy(float), color=OKABE_ITO["vermillion"],
                    label="paper's footing (flat-segment line removed)")
            ax.set_title("F_N(x): normal force (no absolute level for this trial)")
        ax.set_xlabel("finger position x (mm)")
        ax.set_ylabel("F_N (mN)")
        ax.legend(loc="lower right")
        out["f_n"] = _svg(fig)
    return out


def _animation(t: AnalysedTrial, store: ResultsStore, tmp_dir: Path, max_frames: int):
    """(base64 GIF, None) or (None, why there is none): the stored results drawn on the
    trial's video, opened through the store's record of the analysis' inputs."""
    try:
        video = store.trial_video(t.id)
    except (KeyError, ValueError, TypeError, OSError) as exc:
        return None, str(exc)
    try:
        out = tmp_dir / f".{t.id}.overlay.gif"
        write_results_overlay(video.path, t.frames, video.height_mm, out, surface=video.surface,
                              options=video.options, max_frames=max_frames, regions=t.regions)
        blob = out.read_bytes()
        out.unlink()
    except (KeyError, ValueError, TypeError, OSError) as exc:
        return None, f"overlay failed: {exc}"
    return base64.b64encode(blob).decode("ascii"), None


#: Columns of ``fit/trials.csv`` shown on a trial page (those present), in order.
_FIT_COLUMNS = ("model", "mu", "p0", "p1", "p1_se", "inset_mm", "kappa_per_mm", "footing", "objective",
                "success", "message")


def _cell(v) -> str:
    if isinstance(v, float):
        return "" if v != v else f"{v:.4g}"
    return "" if v is None else str(v)


def readable(v) -> str:
    """A record value as a reader wants it: counts as ``NAME n, ...``, numbers to 6
    significant digits, an empty list as ``none`` (not Python's repr).

    >>> readable({"CALIBRATION": 1, "OUT_OF_VIEW": 5})
    'CALIBRATION 1, OUT_OF_VIEW 5'
    >>> readable([-12.998532789218679, -8.807356476971798])
    '-12.9985, -8.80736'
    >>> readable([])
    'none'
    """
    if isinstance(v, dict):
        return ", ".join(f"{k} {readable(x)}" for k, x in v.items()) or "none"
    if isinstance(v, (list, tuple)):
        return ", ".join(readable(x) for x in v) or "none"
    if isinstance(v, float):
        return f"{v:.6g}"
    return "" if v is None else str(v)


def write_trial_pages(data: ReportData, flags: list[dict], trial_ids: list[str], out_dir: Path, *,
                      animations: bool = True, max_frames: int = 40, progress=None) -> dict[str, Path]:
    """Write the pages of ``trial_ids`` into ``out_dir`` (``report/trials``).

    Returns ``{trial id: page path}``. ``progress`` (optional) is called once per page.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    env = jinja2.Environment(autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined)
    env.filters["readable"] = readable
    template = env.from_string(
        resources.files("fingerfriction.report").joinpath("templates/trial.html.j2").read_text("utf-8"))
    store = ResultsStore(data.root) if animations else None
    by_id = {t.id: t for t in data.trials}
    failed = dict(data.failed)
    labels = {m["id"]: m for m in data.run.get("trials", [])}
    fit_rows: dict = {}
    if data.fit_trials is not None:
        cols = [c for c in _FIT_COLUMNS if c in data.fit_trials.columns]
        for r in data.fit_trials.to_dict("records"):
            fit_rows.setdefault(r["trial"], []).append({c: _cell(r.get(c)) for c in cols})
    written = {}
    order = list(trial_ids)
    for i, tid in enumerate(order):
        t = by_id.get(tid)
        lab = labels.get(tid, {})
        own = [f for f in flags if f["trial"] == tid]
        ctx = {"trial": tid, "subject": lab.get("subject", ""), "surface": lab.get("surface", ""),
               "surface_label": surface_title(data, lab.get("surface", "")) if lab.get("surface") else "",
               "speed": lab.get("speed_mm_s", ""), "repetition": lab.get("repetition", ""),
               "flags": own, "failed": failed.get(tid), "plots": None, "animation": None,
               "animation_note": None, "fit": fit_rows.get(tid), "info": None,
               "prev": order[i - 1] if i > 0 else None, "next": order[i + 1] if i + 1 < len(order) else None,
               "history": None, "inputs": (data.run.get("inputs") or {}).get(tid)}
        if t is not None:
            ctx["plots"] = trial_plots(t, data)
            info = t.status.get("info") or {}
            ctx["info"] = {"video": info.get("video") or {}, "forces": info.get("forces") or {},
                           "n_frames": info.get("n_frames"), "n_flagged_frames": info.get("n_flagged_frames")}
            hist = t.force_history
            ctx["history"] = describe_history(hist) if hist is not None else None
            if store is not None:
                ctx["animation"], ctx["animation_note"] = _animation(t, store, out_dir, max_frames)
            else:
                ctx["animation_note"] = "animations switched off for this report"
        path = out_dir / f"{tid}.html"
        atomic_write_text(path, template.render(**ctx))
        written[tid] = path
        if progress is not None:
            progress(tid)
    return written
