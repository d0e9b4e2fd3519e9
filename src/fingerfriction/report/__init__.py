"""Figures, tables and a self-contained HTML report of an analysed (and fitted) study.

:func:`make_report` reads a results folder (:mod:`fingerfriction.study.store`) and writes,
into ``RESULTS/report/``: each figure as PNG and SVG (:mod:`.figures`), Table 1, the
blind-spot table, the out-of-sample validation (``loso``, computed by
``fit``) and, for a simulated study, the recovered parameters next to the ground
truth (:mod:`.tables`) as CSV and Markdown (Table 1 also LaTeX), and ``index.html``, a
single file with every figure embedded (base64 PNG) that opens anywhere on its own.
"""

from __future__ import annotations

import base64
import html
import logging
import math
import os
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import resources
from pathlib import Path

import jinja2
import pandas as pd
from markupsafe import Markup

from .._atomic import atomic_write_text
from .._progress import ProgressBar
from ..forces.signals import describe_history
from ..study.results import FitResult
from ..study.store import write_table
from .data import ReportData, load_report_data
from .figures import FIGURES, save_figure
from .flags import collect_flags, comparison_notes, flagged_trials, group_flags
from .tables import (
    blindspot_table,
    fit_parameter_table,
    loso_table,
    run_record,
    table1,
    table1_display,
    truth_tables,
    with_formatted_p,
)
from .trial_pages import choose_pages, page_href, write_trial_pages

__all__ = ["make_report", "ReportResult", "load_report_data", "ReportData", "comparison_frame"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ReportResult:
    """What :func:`make_report` wrote.

    Attributes
    ----------
    html : Path
        The self-contained report.
    files : tuple of Path
        Every file written (figures, tables, the report).
    table1 : pandas.DataFrame or None
        Table 1 in long format (None before the fit).
    loso : pandas.DataFrame or None
        Out-of-sample validation, rho per held-out surface (computed by ``fit``,
        :func:`fingerfriction.pipeline.fitting.fit`; None if the fit did not validate).
    blindspots : pandas.DataFrame
        One row per blind spot per surface.
    truth : dict of str to pandas.DataFrame
        Recovered against true parameters (simulated studies).
    n_trials, n_failed : int
    flags : tuple of dict
        Everything flagged (:func:`fingerfriction.report.flags.collect_flags`): ``level``,
        ``code``, ``subject``, ``trial``, ``model``, ``message``.
    pages : dict of str to Path
        The trial pages written, by trial id.
    fitted : bool
        Whether the results were fitted (Fig. 6, Fig. S3 and Table 1 need the fit).
    notices : tuple of str
        What the top of the page says before anything else (e.g. the model is not
        fitted); the CLI prints them too.
    stale_fit : str or None
        Why the fit was left out: the trials were analysed again since it was made.
    model : str or None
        The model variant the fit used (None before the fit).
    rejection : str
        The fit's reason when it rejected every model variant (the error at the top of the
        page), else ''.
    comparison : pandas.DataFrame or None
        The fit's comparison of the variants (``fit.json`` ``selection``).
    """

    html: Path
    files: tuple[Path, ...]
    table1: pd.DataFrame | None
    blindspots: pd.DataFrame
    truth: dict
    n_trials: int
    n_failed: int
    loso: pd.DataFrame | None = None
    fitted: bool = False
    notices: tuple[str, ...] = ()
    flags: tuple[dict, ...] = ()
    pages: dict = field(default_factory=dict)
    stale_fit: str | None = None
    model: str | None = None
    rejection: str = ""
    comparison: pd.DataFrame | None = None
    notes: tuple[dict, ...] = ()


#: Captions of the figures in the HTML report (the figure titles carry the essentials).
CAPTIONS = {
    "fig3_occupancy": (
        "Normalised proportion of time each surface location was in contact (Fig. 3 of the paper), "
        "counted over the frames in which the finger slides through the analysis window: the rest at "
        "touch-down is left out (counted, it added a step at the resting contact's leading edge, near "
        "x = -9.6 mm in the simulated studies). The occupancy tapers towards the ends of the swept span, "
        "which the contact covers for a shorter time inside the window. Blind spots: never in contact in "
        "any frame of any trial (the blind-spot table)."),
    "fig4_forces": (
        "Measured tangential force per surface and subject, one curve per speed (mean; band +- 1 SD where "
        "more than one trial; n written by each curve), offset by 25 mN per speed as in the paper. The "
        "footing is named in the title: the absolute one avoids the paper's flat-segment line extrapolated "
        "over the 26 mm window, which makes curves drift at the far end."),
    "fig6_model": (
        "Measured and modelled force on the footing the fit compares them on (title). Ticks: where a "
        "contact region appears or vanishes in a trial; the model, an integral over the detected regions, "
        "steps there (at contact onset the video finds a region of finite length on the slope at once), "
        "while the measured force changes continuously."),
    "figS1_lengths": "Contact lengths L_i of the regions C_i against finger position, every frame of every "
                     "trial.",
    "figS3_components": "Interfacial (Eq. 2) and deformation (Eq. 3) parts of the fitted model.",
}


def _html_table(df: pd.DataFrame, float_format: str = "{:.3g}", links: dict | None = None) -> str:
    """An HTML table; cells of a ``trial`` column with a page in ``links`` link to it."""
    links = links or {}

    def fmt(col, v):
        if isinstance(v, float):
            return "" if v != v else float_format.format(v)
        if col == "trial" and v in links:
            return f'<a class="trial-link" href="{html.escape(links[v])}">{html.escape(str(v))}</a>'
        return html.escape(str(v))

    cols = list(df.columns)
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in cols)
    body = "".join("<tr>" + "".join(f"<td>{fmt(c, v)}</td>" for c, v in zip(cols, row, strict=True)) + "</tr>"
                   for row in df.itertuples(index=False))
    return f"<table><tr>{head}</tr>{body}</table>"


def _trial_table(data: ReportData, flags: list[dict]) -> pd.DataFrame:
    """One row per trial of the run: labels, status, counts of its flags by level."""
    status = dict(data.failed)
    rows = []
    for m in data.run.get("trials", []):
        own = [f for f in flags if f["trial"] == m["id"]]
        rows.append({"trial": m["id"], "subject": str(m.get("subject", "")), "surface": m.get("surface", ""),
                     "speed_mm_s": m.get("speed_mm_s"), "status": "failed" if m["id"] in status else "ok",
                     "errors": sum(f["level"] == "error" for f in own),
                     "warnings": sum(f["level"] == "warning" for f in own),
                     "notes": sum(f["level"] == "info" for f in own)})
    return pd.DataFrame(rows)


def _force_history(data: ReportData) -> list[tuple[str, list[str]]]:
    """Per trial, the steps of its force processing as lines a person reads."""
    return [(t.id, describe_history(t.force_history) if t.force_history is not None
             else ["not recorded (the trial was analysed by an earlier version)"]) for t in data.trials]


def _write_tables(data: ReportData, out: Path, has_fit: bool, files: list[Path]):
    """Write Table 1, the out-of-sample table, the blind spots and the truth tables (CSV,
    Markdown, Table 1 also LaTeX) into ``out``, appending to ``files``; returns
    ``(table1, loso, blindspots, truth, fitted parameters)``."""
    t1 = table1(data) if has_fit else None
    if t1 is not None:
        for ext in ("csv", "md", "tex"):  # the CSV keeps the numbers, the others read as text
            write_table(t1 if ext == "csv" else with_formatted_p(t1), out / f"table1.{ext}")
            files.append(out / f"table1.{ext}")
    loso = loso_table(data) if has_fit else None
    if loso is not None:
        for ext in ("csv", "md"):
            write_table(loso if ext == "csv" else with_formatted_p(loso), out / f"loso.{ext}")
            files.append(out / f"loso.{ext}")
    bs = blindspot_table(data)
    for ext in ("csv", "md"):
        write_table(bs, out / f"blindspots.{ext}")
        files.append(out / f"blindspots.{ext}")
    truth = truth_tables(data)
    for key, df in truth.items():
        for ext in ("csv", "md"):
            write_table(df, out / f"truth_{key}.{ext}")
            files.append(out / f"truth_{key}.{ext}")
    return t1, loso, bs, truth, fit_parameter_table(data)


def _mu_rows(fit: FitResult) -> list[dict]:
    """Per subject: mu of the variant the fit used, with its confidence interval, and the
    fit's own warning about that subject's mu when it has one (e.g. mu at an end of the
    paper variant's search grid)."""
    used = fit.model
    subject_flags = {}
    for f in fit.flags or []:
        if not f.trial and f.subject and f.model == used and f.level in ("error", "warning"):
            subject_flags.setdefault(f.subject, f.message)
    rows = []
    for s, mu in fit.mu(used).items():
        text = f"subject {s}: &mu; = {mu:.4g}"
        lo, hi = (fit.mu_ci(used).get(s) or [None, None])
        if lo is not None and hi is not None and math.isfinite(lo):
            text += f" (95 % CI {lo:.4f}-{hi:.4f})"
        rows.append({"model": f"{fit.title(used)} ({used})", "text": Markup(text),
                     "warn": subject_flags.get(str(s), "")})
    return rows


def _by_model(df: pd.DataFrame | None, fit: FitResult, render) -> list[dict]:
    """One block per model of a table with a ``model`` column (the variant used first)."""
    if df is None:
        return []
    if "model" not in df.columns:
        return [{"title": "", "note": "", "html": render(df)}]
    out = []
    for m in fit.order:
        sel = df[df["model"] == m].drop(columns="model")
        if sel.empty:
            continue
        title = f"{fit.title(m)} ({m})" + (" - the model used" if m == fit.model else " - comparison")
        out.append({"title": title, "note": fit.note(m), "html": render(sel)})
    return out


#: Columns of the comparison of the variants in the report (from ``fit.json`` ``selection``).
_COMPARISON = (("model", "model"), ("title", "variant"), ("verdict", "verdict"),
               ("n_unphysical", "unphysical fits"), ("table1_cells_ok", "Table 1 cells >= bar"),
               ("loso_cells_ok", "held-out cells >= bar"), ("cv_rho_mean", "mean held-out rho"),
               ("cv_rho_min", "min held-out rho"), ("residual_structure", "systematic misfit"),
               ("why", "bars missed"))


#: Text columns of the comparison; every other one is a number (None in JSON where unknown).
_COMPARISON_TEXT = ("model", "title", "family", "verdict", "why", "selectable", "passes")


def comparison_frame(records) -> pd.DataFrame:
    """The comparison of the variants (``fit.json`` ``selection.comparison``) as a table whose
    number columns are numbers: JSON writes NaN as null, and a column of nulls alone (the
    residual structure of a study without two trials per surface) would be read as objects."""
    rows = pd.DataFrame(records or [])
    for c in rows.columns:
        if c not in _COMPARISON_TEXT:
            rows[c] = pd.to_numeric(rows[c], errors="coerce")
    return rows


def _selection(fit: FitResult, notes: list[dict]) -> dict | None:
    """The model choice for the page: how it was made, its reason, the comparison table and
    the comparison variants' flags as notes (grouped by variant and kind)."""
    sel = fit.selection
    if sel is None:
        return None
    rows = comparison_frame(sel.get("comparison"))
    table = None
    if not rows.empty:
        cols = [(c, h) for c, h in _COMPARISON if c in rows.columns]
        table = rows[[c for c, _ in cols]].rename(columns=dict(cols))
        for c, k, n in (("unphysical fits", "n_unphysical", "n_trials"),
                        ("Table 1 cells >= bar", "table1_cells_ok", "table1_cells"),
                        ("held-out cells >= bar", "loso_cells_ok", "loso_cells")):
            if c in table.columns:  # "k of n"; NaN (None in JSON) where not computed
                table[c] = [f"{int(a)} of {int(b)}" if a is not None and a == a else ""
                            for a, b in zip(rows[k], rows[n], strict=True)]
    grouped = []
    for g in group_flags(notes):
        grouped.append({"model": g["example"]["model"], "level": g["level"], "code": g["code"],
                        "n_trials": g["n_trials"], "count": g["count"], "example": g["example"]})
    bars = sel.get("bars") or {}
    return {"rejected": bool(sel.get("rejected")), "reason": sel.get("reason", ""),
            "requested": fit.requested,
            "used": fit.model, "auto": sel.get("model"), "bars": bars,
            "cross_validated": sel.get("cross_validated", True),
            "table": Markup(_html_table(table, float_format="{:.3f}")) if table is not None else None,
            "notes": grouped}


def make_report(results: str | os.PathLike, *, progress: bool = False, sample: int | None = 6,
                animations: bool = True) -> ReportResult:
    """Write the figures, tables and the HTML report of a results folder.

    Parameters
    ----------
    results : path
        A results folder after ``analyze`` (and, for Fig. 6, Fig. S3 and Table 1,
        ``fit``).
    progress : bool
        Show a progress bar on stderr.
    sample : int or None
        Trial pages (``report/trials/<trial-id>.html``) are written for every flagged
        trial and for this many of the others, spread over the manifest's order (None:
        every trial).
    animations : bool
        Put the overlay animation on each trial page (needs the study's videos; about
        0.4 s of CPU per page).

    Returns
    -------
    ReportResult

    Raises
    ------
    ValueError
        Not a results folder, or no trial finished OK.
    """
    data = load_report_data(results)
    out = Path(data.root) / "report"
    out.mkdir(parents=True, exist_ok=True)
    has_fit = data.fit is not None and any(t.model is not None for t in data.trials)
    files: list[Path] = []
    flags = collect_flags(data)
    flagged = flagged_trials(flags)
    page_ids = choose_pages(data, flagged, sample)
    bar = ProgressBar(progress, len(FIGURES) + 2 + len(page_ids), "report")
    figures = []
    try:
        for stem, title, fn, needs_fit in FIGURES:
            if needs_fit and not has_fit:
                bar.advance(f"{stem} (needs fit)")
                continue
            fig = fn(data)
            blobs = save_figure(fig, out / stem)
            files += [out / f"{stem}.png", out / f"{stem}.svg"]
            figures.append({"stem": stem, "title": title,
                            "png_b64": base64.b64encode(blobs["png"]).decode("ascii")})
            bar.advance(stem)

        t1, loso, bs, truth, params = _write_tables(data, out, has_fit, files)
        loso_img = (base64.b64encode(data.loso_figure).decode("ascii")
                    if loso is not None and data.loso_figure is not None else None)
        bar.advance("tables")

        pages = write_trial_pages(data, flags, page_ids, out / "trials", animations=animations,
                                  progress=lambda tid: bar.advance(tid))
        files += list(pages.values())
        links = {tid: page_href(tid) for tid in pages}
        notices = []
        if data.stale_fit:
            notices.append(f"The fit is out of date and left out (Fig. 6, Fig. S3, Table 1): "
                           f"{data.stale_fit}, and then this report again.")
        elif not has_fit:
            notices.append(f"The model is not fitted: Fig. 6, Fig. S3 and Table 1 are left out; run "
                           f"`fingerfriction fit {data.root}` and then this report again.")
        page = _render_index(
            data, has_fit=has_fit, figures=figures, tables=(t1, loso, bs, truth, params), loso_img=loso_img,
            flags=flags, flagged=flagged, links=links, n_pages=len(pages), notices=notices)
        atomic_write_text(out / "index.html", page)
        files.append(out / "index.html")
        bar.advance("index.html")
    finally:
        bar.close()
    sel = (data.fit.selection if has_fit else None) or {}
    return ReportResult(html=out / "index.html", files=tuple(files), table1=t1, blindspots=bs, truth=truth,
                        n_trials=len(data.trials), n_failed=len(data.failed), loso=loso, fitted=has_fit,
                        notices=tuple(notices), flags=tuple(flags), pages=pages, stale_fit=data.stale_fit,
                        model=data.fit.model if has_fit else None,
                        rejection=sel.get("reason", "") if sel.get("rejected") else "",
                        comparison=comparison_frame(sel["comparison"]) if sel.get("comparison") else None,
                        notes=tuple(comparison_notes(data)) if has_fit else ())

#: Titles of the ground-truth tables (simulated studies).
_TRUTH_TITLES = {"mu": "Friction coefficient per subject",
                 "blindspots": "Blind-spot widths: video analysis against the simulator's 3-px contact",
                 "tracking": "Finger position x(t): RMS error against the true finger centre "
                             "(one constant offset per trial removed)"}

#: Sections of the run record: (key of :func:`.tables.run_record`, title).
_RECORD = (("study", "Study"), ("parameters", "Analysis parameters"), ("fit", "Fit"),
           ("runs", "History of analyze runs"), ("versions", "Versions and platform"),
           ("inputs", "Input files (SHA-256)"))


def _render_index(data: ReportData, *, has_fit, figures, tables, loso_img, flags, flagged, links, n_pages,
                  notices) -> str:
    """The text of ``index.html``."""
    t1, loso, bs, truth, params = tables
    env = jinja2.Environment(autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined)
    template = env.from_string(
        resources.files("fingerfriction.report").joinpath("templates/report.html.j2").read_text("utf-8"))
    run = data.run
    record = run_record(data)
    fit = data.fit if data.fit is not None else FitResult({})
    ft = data.fit_trials
    n_neg_p0 = 0
    if ft is not None:  # the variant used: a constant pressure p0 < 0 is unphysical
        used_rows = ft[ft["model"] == data.fit.model] if "model" in ft.columns else ft
        n_neg_p0 = int((used_rows["p0"] < 0).sum())
    return template.render(
        flag_groups=group_flags(flags), n_flagged=len(flagged), links=links, all_flags=flags,
        trials_table=Markup(_html_table(_trial_table(data, flags), links=links)),
        n_pages=n_pages,
        notices=notices, mu_rows=_mu_rows(fit), n_neg_p0=n_neg_p0,
        selection=_selection(fit, comparison_notes(data)) if has_fit else None,
        table1_models=_by_model(t1, fit, lambda d: Markup(_html_table(table1_display(d)))),
        loso_models=_by_model(loso, fit, lambda d: Markup(_html_table(with_formatted_p(d)))),
        subject_word=("all subjects" if len(data.subjects) > 1 else "one subject"),
        table1_long=(Markup(_html_table(with_formatted_p(t1.drop(columns=["significant"]))))
                     if t1 is not None else None),
        loso_img=loso_img, captions=CAPTIONS,
        study_name=Path(run.get("study", "study")).name, study=run.get("study", ""),
        results=str(data.root),
        generated=datetime.now(UTC).isoformat(timespec="seconds"),
        version=(run.get("versions") or {}).get("fingerfriction", "?"),
        n_ok=len(data.trials), n_trials=len(data.trials) + len(data.failed),
        subjects=data.subjects, surfaces=data.surface_names,
        speeds=", ".join(f"{v:g}" for v in data.speeds),
        has_fit=has_fit, failed=data.failed, notes=data.notes,
        table1=t1 is not None, loso=loso is not None,
        loso_calibrated=loso is not None and "rho_out_of_sample_calibrated_finger" in loso.columns,
        loso_message=fit.loso.get("message", "not computed by this fit"),
        blindspots=Markup(_html_table(bs)),
        truth=[(_TRUTH_TITLES.get(k, k), Markup(_html_table(df))) for k, df in truth.items()],
        params=Markup(_html_table(params)) if params is not None else None,
        figures=figures,
        record=[(title, key, Markup(_html_table(record[key], links=links))) for key, title in _RECORD
                if key in record],
        force_history=_force_history(data),
    )
