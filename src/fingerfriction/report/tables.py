"""The report's tables: Table 1, the blind-spot table, fitted parameters, and the
recovered parameters next to the ground truth of a simulated study."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..model.stats import BOTH, blind_spot_table, correlation_table, shape_label
from ..study.results import FitResult
from ..study.store import ResultsStore
from .data import ReportData

__all__ = ["table1", "blindspot_table", "fit_parameter_table", "truth_tables", "format_p", "P_COLUMNS",
           "with_formatted_p"]

#: Columns that hold p-values (formatted by :func:`format_p` for people to read).
P_COLUMNS = ("p", "p_in_sample", "p_out_of_sample")


def format_p(p) -> str:
    """A p-value as people should read it: never ``0``.

    ``< 1e-300`` below 1e-300 (a computed 0 is an underflow: the true value is below the
    smallest double), scientific notation below 0.001 (``3.2e-12``), else three
    decimals (``0.012``); empty for NaN.

    >>> format_p(0.0), format_p(3.21e-12), format_p(0.01234)
    ('< 1e-300', '3.2e-12', '0.012')
    """
    try:
        p = float(p)
    except (TypeError, ValueError):
        return str(p)
    if p != p:
        return ""
    if p < 1e-300:
        return "< 1e-300"
    if p < 1e-3:
        return f"{p:.1e}"
    return f"{p:.3f}"


def with_formatted_p(df: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``df`` with its p-value columns (:data:`P_COLUMNS`) as :func:`format_p` text."""
    out = df.copy()
    for c in P_COLUMNS:
        if c in out.columns:
            out[c] = [format_p(v) for v in out[c]]
    return out

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class _Series:
    """The minimal TrialFit-like record :func:`fingerfriction.model.stats.correlation_table` reads."""

    measured: np.ndarray
    estimate: np.ndarray
    subject: str
    labels: dict = field(default_factory=dict)


def _condition(data: ReportData, surface: str) -> tuple[str, str]:
    s = data.surfaces.get(surface)
    shape = getattr(s, "shape", None)
    width = getattr(s, "width", None)
    return (shape_label(shape) if shape else surface), (f"{width:g} mm" if width else "")


def table1(data: ReportData) -> pd.DataFrame | None:
    """Table 1 (long format): Pearson rho and p of detrended measured vs model per
    subject x scale x shape, plus both subjects pooled; None before the fit.

    From ``fit/table1.csv`` when the fit wrote it (each model variant, column ``model``,
    the fit's default model first, with bootstrap confidence intervals of rho); else
    computed from the stored model forces of the fit's one model."""
    if data.fit_table1 is not None and not data.fit_table1.empty:
        out = data.fit_table1.copy()
        default = data.fit.model if data.fit is not None else None
        out["_o"] = (out["model"] != default).astype(int)
        out = out.sort_values("_o", kind="stable").drop(columns="_o").reset_index(drop=True)
        if out[out["subject"] != BOTH]["subject"].nunique() < 2:
            out = out[out["subject"] != BOTH].reset_index(drop=True)
        return out[["model", *[c for c in out.columns if c != "model"]]]
    series = []
    for t in data.trials:
        if t.model is None:
            continue
        m = t.model["F_T_N"].to_numpy(float)
        e = t.model["F_hat_N"].to_numpy(float)
        ok = np.isfinite(m) & np.isfinite(e)
        if ok.sum() < 3:
            continue
        shape, scale = _condition(data, t.surface)
        series.append(_Series(m[ok], e[ok], t.subject, {"shape": shape, "scale": scale}))
    if not series:
        return None
    out = correlation_table(series)
    if len({s.subject for s in series}) < 2:  # one subject: "both subjects" would repeat it
        out = out[out["subject"] != BOTH].reset_index(drop=True)
    return out


def blindspot_table(data: ReportData) -> pd.DataFrame:
    """Blind spots per surface (all trials of all subjects pooled, as Fig. 3)."""
    by = {name: [t.regions for t in data.select(surface=name)] for name in data.surface_names}
    df = blind_spot_table(by)
    n = {name: len(v) for name, v in by.items()}
    df.insert(1, "n_trials", df["surface"].map(n))
    return df


def fit_parameter_table(data: ReportData) -> pd.DataFrame | None:
    """Mean and SD of the fitted p0, p1 (N/mm) and the mean objective per subject and surface."""
    ft = data.fit_trials
    if ft is None or ft.empty:
        return None
    keys = ["model", "subject", "surface"] if "model" in ft.columns else ["subject", "surface"]
    g = ft.groupby(keys, sort=False)
    out = g.agg(n_trials=("trial", "size"), mu=("mu", "first"), p0_mean=("p0", "mean"), p0_sd=("p0", "std"),
                p1_mean=("p1", "mean"), p1_sd=("p1", "std"), objective_mean=("objective", "mean"),
                n_failed=("success", lambda s: int((~s.astype(bool)).sum())))
    return out.reset_index()


def _mu_of(v) -> float | None:
    if not isinstance(v, dict):
        return None
    if "mu" in v:
        return float(v["mu"])
    for key in ("force_law", "friction"):  # the simulator's truth: subjects.<s>.force_law.mu
        if isinstance(v.get(key), dict) and "mu" in v[key]:
            return float(v[key]["mu"])
    return None


def _truth_mu(truth: dict) -> dict[str, float]:
    """Per-subject true mu from truth/study.json (``subjects`` as a dict or a list)."""
    subs = truth.get("subjects")
    out = {}
    if isinstance(subs, dict):
        items = [(str(k), v) for k, v in subs.items()]
    elif isinstance(subs, list):
        items = [(str(v.get("subject", v.get("id", v.get("name")))), v) for v in subs if isinstance(v, dict)]
    else:
        items = []
    for k, v in items:
        mu = _mu_of(v)
        if mu is not None:
            out[k] = mu
    return out


def realised_mu(data: ReportData) -> dict[str, float]:
    """Per subject, the mean of the friction coefficients the simulator drew for the trials
    in the report (``truth/<trial>.npz`` ``mu_trial``): the value a fit of these trials
    should recover (a study with per-trial scatter of ``mu`` does not realise its nominal
    mean exactly). Empty when the truth files are not there."""
    if data.truth_dir is None:
        return {}
    by: dict[str, list[float]] = {}
    store = ResultsStore(data.root)
    for t in data.trials:
        z = store.trial_truth(data.truth_dir, t.id, ("mu_trial",))
        if "mu_trial" in z:
            by.setdefault(t.subject, []).append(float(z["mu_trial"]))
    return {s: float(np.mean(v)) for s, v in by.items() if v}


def truth_tables(data: ReportData) -> dict[str, pd.DataFrame]:
    """For a simulated study: recovered against true parameters.

    Returns a dict with (when available) ``'mu'``: model, subject, the true mu (the mean of
    the trials' drawn coefficients, :func:`realised_mu`, else the nominal one), the nominal
    one, the fitted one with its CI, error, whether the CI covers the truth; and
    ``'blindspots'``: surface, blind-spot widths from the analysed video against those of
    the simulator's geometric (3 px) contact regions of the same trials.
    """
    out: dict[str, pd.DataFrame] = {}
    if data.truth is None:
        return out
    nominal = _truth_mu(data.truth)
    true_mu = {**nominal, **realised_mu(data)}
    fit = data.fit if data.fit is not None else FitResult({})  # no fit: no fitted mu
    if true_mu:
        rows = []
        for m in fit.order:
            fitted = fit.mu(m)
            ci = fit.mu_ci(m)
            for s in sorted(set(true_mu) | set(fitted)):
                t, f = true_mu.get(s, math.nan), fitted.get(s, math.nan)
                lo, hi = (ci.get(s) or [math.nan, math.nan])
                lo = math.nan if lo is None else lo
                hi = math.nan if hi is None else hi
                rows.append({"model": m, "subject": s, "mu_true": t, "mu_nominal": nominal.get(s, math.nan),
                             "mu_fitted": f, "ci95_lo": lo, "ci95_hi": hi, "error": f - t,
                             "truth_in_ci": bool(lo <= t <= hi) if math.isfinite(lo) else None})
        out["mu"] = pd.DataFrame(rows)
    if data.truth_dir is not None:
        store = ResultsStore(data.root)
        rows, track = [], []
        for name in data.surface_names:
            regs, rms = [], []
            for t in data.select(surface=name):
                z = store.trial_truth(data.truth_dir, t.id, ("regions_geom", "x_finger_video"))
                if "regions_geom" in z:
                    regs.append(np.asarray(z["regions_geom"], float))
                if "x_finger_video" in z:
                    x_true = np.asarray(z["x_finger_video"], float)
                    rms.append(_x_rms(t.frames["x_mm"].to_numpy(float), x_true))
            rms = [r for r in rms if np.isfinite(r)]
            if rms:
                track.append({"surface": name, "n_trials": len(rms), "x_rms_median_mm": float(np.median(rms)),
                              "x_rms_max_mm": float(np.max(rms))})
            if not regs:
                continue
            true_bs = blind_spot_table({name: regs})
            meas_bs = blind_spot_table({name: [t.regions for t in data.select(surface=name)]})
            tw = true_bs["width_mm"].to_numpy()
            mw = meas_bs["width_mm"].to_numpy()
            for i in range(max(tw.size, mw.size)):
                a = float(tw[i]) if i < tw.size else math.nan
                b = float(mw[i]) if i < mw.size else math.nan
                rows.append({"surface": name, "blind_spot": i + 1, "width_true_mm": a,
                             "width_measured_mm": b, "error_mm": b - a})
        if rows:
            out["blindspots"] = pd.DataFrame(rows)
        if track:
            out["tracking"] = pd.DataFrame(track)
    return out


def _x_rms(x: np.ndarray, x_true: np.ndarray) -> float:
    """RMS in mm of the tracked x(t) against the true finger centre, over the frames where
    both exist, after removing one constant offset (the centroid of C_f need not be the
    finger's centre)."""
    if x.shape != x_true.shape:
        return math.nan
    ok = np.isfinite(x) & np.isfinite(x_true)
    if ok.sum() < 2:
        return math.nan
    d = x[ok] - x_true[ok]
    return float(np.sqrt(np.mean((d - d.mean()) ** 2)))


def table1_display(table: pd.DataFrame) -> pd.DataFrame:
    """Table 1 in a compact wide form for HTML: one row per (subject, scale), shapes as columns
    with ``rho``, its 95 % confidence interval when known and a star where p < 0.01 (one
    model: select its rows first)."""
    rows = []
    for (subj, scale), g in table.groupby(["subject", "scale"], sort=False):
        row = {"subject": subj, "scale": scale}
        for _, r in g.iterrows():
            star = "*" if r["significant"] else ""
            ci = ""
            if "rho_lo" in r and np.isfinite(r["rho_lo"]) and np.isfinite(r["rho_hi"]):
                ci = f" [{r['rho_lo']:.2f}, {r['rho_hi']:.2f}]"
            row[r["shape"]] = "" if not np.isfinite(r["rho"]) else f"{r['rho']:.2f}{star}{ci}"
        rows.append(row)
    df = pd.DataFrame(rows).fillna("")
    order = {s: i for i, s in enumerate([*sorted(set(df["subject"]) - {BOTH}), BOTH])}
    return df.sort_values("subject", key=lambda c: c.map(order), kind="stable").reset_index(drop=True)


#: Columns of the out-of-sample table in the report, in order (from ``fit/loso.csv``).
LOSO_COLUMNS = ("subject", "surface", "n_trials", "rho_in_sample", "rho_out_of_sample", "p_out_of_sample",
                "rho_heldout_params_video")


def loso_table(data: ReportData) -> pd.DataFrame | None:
    """Out-of-sample validation next to Table 1: rho per held-out surface.

    From ``fit/loso.csv`` (:func:`fingerfriction.pipeline.validation.validate_results`, run by
    :func:`fingerfriction.pipeline.fitting.fit`): per subject (and both subjects) and held-out
    surface, the in-sample rho (Table 1), the out-of-sample rho (fitted on the other
    surfaces, predicted from the surface's geometry alone) with its p-value, and rho with
    the held-out parameters on the video regions. None when the fit did not validate.
    """
    if data.loso is None:
        return None
    missing = [c for c in LOSO_COLUMNS if c not in data.loso.columns]
    if missing:
        raise ValueError(f"{data.root / 'fit' / 'loso.csv'}: missing columns {missing}")
    cols = [c for c in ("model", *LOSO_COLUMNS, "rho_out_of_sample_measured_load",
                        "rho_out_of_sample_calibrated_finger") if c in data.loso.columns]
    out = data.loso.loc[:, cols].reset_index(drop=True)
    if out["subject"].nunique() == 2 and BOTH in set(out["subject"]):  # one subject + its copy
        out = out[out["subject"] != BOTH].reset_index(drop=True)
    return out


def _value(v) -> str:
    """A parameter value as people read it: lists joined, None as 'default', floats short."""
    if v is None:
        return "default"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return ", ".join(_value(x) for x in v)
    if isinstance(v, dict):
        return "; ".join(f"{k} = {_value(x)}" for k, x in v.items())
    return str(v)


def run_record(data: ReportData) -> dict[str, pd.DataFrame]:
    """The run record (``run.json``, ``fit/fit.json``) as readable tables.

    Returns ``{"study", "parameters", "fit", "versions", "runs", "inputs"}`` (those that
    exist): the study and its manifest hash; every analysis parameter by stage; the fit's
    settings; package versions and platform; the history of ``analyze`` runs; each
    trial's input files with their SHA-256.
    """
    run = data.run
    out: dict[str, pd.DataFrame] = {}
    rows = [("study", run.get("study")), ("manifest SHA-256", run.get("manifest_sha256")),
            ("parameters SHA-256", run.get("params_sha256")), ("x(t) estimator", run.get("x_estimator")),
            ("state", run.get("state")), ("started", run.get("started")), ("finished", run.get("finished")),
            ("ground truth", run.get("truth"))]
    out["study"] = pd.DataFrame([{"item": k, "value": _value(v)} for k, v in rows if v is not None])
    prm = []
    for stage, d in (run.get("parameters") or {}).items():
        if isinstance(d, dict):
            prm += [{"stage": stage, "parameter": k, "value": _value(v)} for k, v in d.items()]
        else:
            prm.append({"stage": stage, "parameter": "", "value": _value(d)})
    if prm:
        out["parameters"] = pd.DataFrame(prm)
    if data.fit is not None:
        f = data.fit
        grid = f.mu_grid
        frows = [("method", f.method),
                 ("mu grid", f"{grid.get('start'):g} to {grid.get('stop'):g} by {grid.get('step'):g} "
                             f"({grid.get('n')} values)" if grid else None),
                 *[(f"option: {k}", v) for k, v in f.options.items()],
                 ("trials fitted", f.n_trials), ("finished", f.finished)]
        out["fit"] = pd.DataFrame([{"item": k, "value": _value(v)} for k, v in frows if v is not None])
    ver = [{"package": k, "version": str(v)} for k, v in (run.get("versions") or {}).items()]
    ver += [{"package": f"platform: {k}", "version": str(v)} for k, v in (run.get("platform") or {}).items()]
    if ver:
        out["versions"] = pd.DataFrame(ver)
    runs = run.get("runs") or []
    if runs:
        out["runs"] = pd.DataFrame([{k: _value(v) for k, v in r.items()} for r in runs])
    inp = []
    for tid, files in (run.get("inputs") or {}).items():
        for kind, d in (files or {}).items():
            if isinstance(d, dict):
                inp.append({"trial": tid, "file": kind, "path": d.get("path", ""),
                            "sha256": d.get("sha256", ""), "bytes": d.get("bytes", "")})
    if inp:
        out["inputs"] = pd.DataFrame(inp)
    return out
