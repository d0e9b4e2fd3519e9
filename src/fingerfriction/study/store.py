"""The results store: what ``fingerfriction analyze`` / ``fit`` / ``report`` write, and the
only code that reads and writes it (:class:`ResultsStore`, including ``fit/``; the fit,
the out-of-sample validation, the report and the command line all go through it).

Layout of a results folder (schema version 1)::

    RESULTS/
      run.json                        the run record of the last `analyze`: parameters,
                                      package versions, platform, scheduler, counts,
                                      the study's manifest SHA-256 and, per trial, the
                                      SHA-256 of its video and force files
      trials/<trial-id>/
        frames.parquet                one row per video frame (see FRAME_COLUMNS)
        forces.parquet                one row per position on the 0.01 mm grid
        status.json                   written LAST: {"status": "ok" | "failed", "reason",
                                      "params_sha256", "inputs", "elapsed_s", "info", ...};
                                      info.forces.history: every step of the force
                                      processing with its parameters and fitted values
                                      (the estimated sensor cut-off among them)
      fit/                            written by `fingerfriction fit` (both model variants,
                                      'load' and 'paper'; `model` names the default one)
        fit.json                      default model, per-subject mu (+ 95 % CI), per-model
                                      parameters and CPU time, mu grid, options, flags
                                      (level, code, subject, trial, model, message), counts
        subjects.csv                  subject, model, mu, mu_lo, mu_hi, inset_mm, kappa_per_mm,
                                      transient_mm, n_trials, n_failed, success, message
        trials.csv                    trial, model, subject, surface, speed, mu, p0 (the
                                      load model: the trial's pressure), p1, p1_se, inset_mm,
                                      kappa_per_mm, footing, objective, success, message
        table1.csv                    Table 1 of both models (model, subject, scale, shape,
                                      rho, rho_lo, rho_hi, p, ...)
        loso.csv, loso.png            the out-of-sample validation (leave one surface out),
                                      both models (column model)
        model/<trial-id>.parquet      per position: x_mm; F_T_N and F_hat_N, measured and
                                      model of the default model as compared by its fit
                                      (absolute for 'load', detrended over the flat segment
                                      for 'paper'); F_model_N, F_int_N, F_def_N (Eq. 1-4);
                                      F_N_N (measured normal force, absolute); F_T_raw_N
                                      (the stored paper-footing measurement); the same per
                                      model with a prefix: load_F_T_N, load_F_hat_N,
                                      load_F_int_N, load_F_def_N, load_p0_N_per_mm,
                                      paper_F_T_N, paper_F_hat_N, paper_F_model_N, ...
      report/                         written by `fingerfriction report`
        index.html                    self-contained HTML report (images embedded)
        fig3_occupancy.png/.svg, fig4_forces.png/.svg, fig6_model.png/.svg,
        figS1_lengths.png/.svg, figS3_components.png/.svg
        table1.csv/.md/.tex, blindspots.csv/.md, truth_mu.csv/.md and
        truth_blindspots.csv/.md (simulated studies)

A trial is *finished* when its ``status.json`` says ``"ok"`` and was computed with the
same analysis parameters (``params_sha256``); ``status.json`` is written after both
Parquet files, and every file is written to a temporary name and moved into place with
:func:`os.replace`, so an interrupted run never leaves a trial that looks finished but
is not. A failed trial has a ``status.json`` with ``"failed"`` and a one-line reason,
and no Parquet files.

Per-frame table (``frames.parquet``): ``frame`` (int, index in the video), ``t_s``
(s, common clock), ``x_mm`` (finger position x(t), NaN where unknown), ``n_regions``
(int), ``a1, b1, a2, b2, ...`` (contact regions C_i in mm, NaN-padded; as many pairs
as the trial's largest count, at least one), ``clipped`` (bool, a region ends at the
edge of the camera's field of view, so its length is a lower bound), ``flag`` (str,
empty when the frame is good, else the reason it was flagged), ``x_source`` (str, the
estimator that gave x: ``chord``, ``left-edge``, ``right-edge``, ``cf-centroid``; empty
without a position; absent in results written before it was recorded).

Per-position table (``forces.parquet``): ``x_mm`` (finger position on the 0.01 mm grid),
``F_T_N`` and ``F_N_N`` (tangential and normal force in N, drift-corrected over the flat
segment: the paper's footing), ``F_T_abs_N`` and ``F_N_abs_N`` (the same forces on the
absolute footing: drift removed on the unloaded rests only, flat-ground level ``mu F_N``
kept; NaN when the trial has no absolute level, see ``status.json`` ``info.forces.absolute``),
``n_samples`` (force samples averaged into the bin; 0 = interpolated).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .._atomic import atomic_write, atomic_write_bytes, atomic_write_json, atomic_write_text, jsonable
from .._outputs import write_table
from ..fit import FitOptions, Trial, flat_segment_mask, mu_grid
from ..regions import as_regions, regions_on_grid
from ..surfaces import Surface, surface_from_spec
from .manifest import validate_id

__all__ = [
    "RESULTS_FORMAT",
    "RESULTS_SCHEMA_VERSION",
    "ResultsStore",
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_write_json",
    "atomic_write_parquet",
    "sha256_file",
    "params_digest",
    "now",
    "frames_table",
    "regions_from_table",
    "read_fit_table",
    "write_table",
]

logger = logging.getLogger(__name__)

RESULTS_FORMAT = "fingerfriction-results"
RESULTS_SCHEMA_VERSION = 1
#: Version of a trial's outputs (``status.json`` ``trial_format``): 2 added the absolute
#: forces ``F_T_abs_N``, ``F_N_abs_N`` to ``forces.parquet``. A trial written with another
#: version is not finished: ``analyze`` recomputes it.
TRIAL_FORMAT = 2


# --------------------------------------------------------------------------------------
# writes (atomic, through fingerfriction._atomic) and digests
# --------------------------------------------------------------------------------------


def atomic_write_parquet(path: str | os.PathLike, df: pd.DataFrame) -> None:
    """Write a DataFrame as Parquet (pyarrow) to ``path`` atomically."""
    atomic_write(path, lambda tmp: df.to_parquet(tmp, engine="pyarrow", index=False))


def now() -> str:
    """The current UTC time, ISO 8601 to the second (the clock of the run records)."""
    return datetime.now(UTC).isoformat(timespec="seconds")


def sha256_file(path: str | os.PathLike, *, chunk: int = 1 << 20) -> str:
    """SHA-256 hex digest of a file, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


def params_digest(params: dict) -> str:
    """SHA-256 of a parameter dict's canonical JSON (sorted keys)."""
    text = json.dumps(jsonable(params), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


# --------------------------------------------------------------------------------------
# table conversions
# --------------------------------------------------------------------------------------


def frames_table(
    t_s: np.ndarray,
    x_mm: np.ndarray,
    regions,
    flags=None,
    *,
    frame: np.ndarray | None = None,
    clipped: np.ndarray | None = None,
    x_source=None,
) -> pd.DataFrame:
    """Build the per-frame table from arrays.

    Parameters
    ----------
    t_s : (n_frames,) ndarray
        Frame times in s on the trial's common clock.
    x_mm : (n_frames,) ndarray
        Finger position x(t) in mm (NaN where unknown).
    regions : (n_frames, n_max, 2) array_like
        Contact regions in mm (:mod:`fingerfriction.regions`).
    flags : (n_frames,) sequence of str, optional
        Empty string for a good frame, else the reason it was flagged.
    frame : (n_frames,) int ndarray, optional
        Frame indices; default ``0..n_frames-1``.
    clipped : (n_frames,) bool ndarray, optional
        A contact region ends at the edge of the field of view (default: none).
    x_source : (n_frames,) sequence of str, optional
        Which estimator gave each frame's x(t) (``chord``, ``left-edge``, ``right-edge``,
        ``cf-centroid``; empty without a position); the column is left out when None.

    Returns
    -------
    pandas.DataFrame
        Columns ``frame, t_s, x_mm, n_regions, a1, b1, ..., clipped, flag`` (and
        ``x_source`` when given).
    """
    t_s = np.asarray(t_s, dtype=float).ravel()
    x_mm = np.asarray(x_mm, dtype=float).ravel()
    n = t_s.size
    if x_mm.size != n:
        raise ValueError(f"x_mm has {x_mm.size} frames but t_s has {n}")
    reg = as_regions(regions) if n else np.full((0, 1, 2), np.nan)
    if reg.shape[0] != n:
        raise ValueError(f"regions has {reg.shape[0]} frames but t_s has {n}")
    if frame is None:
        frame = np.arange(n)
    frame = np.asarray(frame, dtype=np.int64).ravel()
    if frame.size != n:
        raise ValueError(f"frame has {frame.size} entries but t_s has {n}")
    if flags is None:
        flags = [""] * n
    flags = ["" if f is None else str(f) for f in flags]
    if len(flags) != n:
        raise ValueError(f"flags has {len(flags)} entries but t_s has {n}")
    cols: dict[str, Any] = {
        "frame": frame,
        "t_s": t_s,
        "x_mm": x_mm,
        "n_regions": np.sum(~np.isnan(reg[..., 0]), axis=1).astype(np.int64),
    }
    for i in range(reg.shape[1]):
        cols[f"a{i + 1}"] = reg[:, i, 0]
        cols[f"b{i + 1}"] = reg[:, i, 1]
    clipped = np.zeros(n, bool) if clipped is None else np.asarray(clipped, dtype=bool).ravel()
    if clipped.size != n:
        raise ValueError(f"clipped has {clipped.size} entries but t_s has {n}")
    cols["clipped"] = clipped
    cols["flag"] = pd.array(flags, dtype="string")
    if x_source is not None:
        src = ["" if s is None else str(s) for s in x_source]
        if len(src) != n:
            raise ValueError(f"x_source has {len(src)} entries but t_s has {n}")
        cols["x_source"] = pd.array(src, dtype="string")
    return pd.DataFrame(cols)


def regions_from_table(df: pd.DataFrame) -> np.ndarray:
    """Contact regions ``(n_frames, n_max, 2)`` in mm from a per-frame table."""
    k = 0
    while f"a{k + 1}" in df.columns and f"b{k + 1}" in df.columns:
        k += 1
    if k == 0:
        raise ValueError("per-frame table has no region columns a1, b1")
    out = np.empty((len(df), k, 2))
    for i in range(k):
        out[:, i, 0] = df[f"a{i + 1}"].to_numpy(dtype=float)
        out[:, i, 1] = df[f"b{i + 1}"].to_numpy(dtype=float)
    return out


# --------------------------------------------------------------------------------------
# the store
# --------------------------------------------------------------------------------------


class ResultsStore:
    """A results folder (layout in the module docstring).

    Parameters
    ----------
    root : path
        The results folder; created on the first write.
    """

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        if self.root.exists() and not self.root.is_dir():
            raise ValueError(f"results folder {str(self.root)!r} exists and is not a folder")

    # paths ----------------------------------------------------------------------------
    @property
    def run_path(self) -> Path:
        return self.root / "run.json"

    @property
    def fit_dir(self) -> Path:
        return self.root / "fit"

    @property
    def report_dir(self) -> Path:
        return self.root / "report"

    def trial_dir(self, trial_id: str) -> Path:
        """``RESULTS/trials/<trial_id>``; ValueError for an id that could escape the folder."""
        validate_id(trial_id, where=f"results folder {str(self.root)!r}")
        return self.root / "trials" / trial_id

    # run record -----------------------------------------------------------------------
    def write_run(self, record: dict) -> None:
        rec = {"format": RESULTS_FORMAT, "schema_version": RESULTS_SCHEMA_VERSION, **record}
        atomic_write_json(self.run_path, rec)

    def read_run(self) -> dict:
        if not self.run_path.is_file():
            raise ValueError(
                f"{str(self.root)!r} is not a results folder (no run.json); "
                "run `fingerfriction analyze STUDY --out RESULTS` first"
            )
        rec = _read_json(self.run_path)
        if rec.get("format") != RESULTS_FORMAT:
            raise ValueError(f"{self.run_path}: format is {rec.get('format')!r}, expected {RESULTS_FORMAT!r}")
        if rec.get("schema_version") != RESULTS_SCHEMA_VERSION:
            raise ValueError(
                f"{self.run_path}: schema_version {rec.get('schema_version')!r} is not supported "
                f"(this version reads {RESULTS_SCHEMA_VERSION})"
            )
        return rec

    # per trial ------------------------------------------------------------------------
    def status(self, trial_id: str) -> dict | None:
        """The trial's status record, or None if it has none (never run, or interrupted)."""
        p = self.trial_dir(trial_id) / "status.json"
        if not p.is_file():
            return None
        try:
            return _read_json(p)
        except ValueError as exc:
            logger.warning("ignoring unreadable status of trial %s: %s", trial_id, exc)
            return None

    def is_finished(self, trial_id: str, params_sha256: str) -> bool:
        """True if the trial finished OK with these analysis parameters."""
        st = self.status(trial_id)
        if st is None or st.get("status") != "ok" or st.get("params_sha256") != params_sha256:
            return False
        if st.get("trial_format", 1) != TRIAL_FORMAT:
            return False
        d = self.trial_dir(trial_id)
        return (d / "frames.parquet").is_file() and (d / "forces.parquet").is_file()

    def write_trial(
        self, trial_id: str, frames: pd.DataFrame, forces: pd.DataFrame, status: dict
    ) -> None:
        """Write a finished trial: both tables, then its status (the commit marker)."""
        d = self.trial_dir(trial_id)
        # Remove the old status first, so a crash between the writes below leaves the
        # trial unfinished rather than pointing at a mix of old and new tables.
        (d / "status.json").unlink(missing_ok=True)
        atomic_write_parquet(d / "frames.parquet", frames)
        atomic_write_parquet(d / "forces.parquet", forces)
        atomic_write_json(d / "status.json",
                          {"trial": trial_id, "status": "ok", "trial_format": TRIAL_FORMAT, **status})

    def write_failure(self, trial_id: str, reason: str, status: dict) -> None:
        """Record a failed trial with its one-line reason; remove stale tables."""
        d = self.trial_dir(trial_id)
        (d / "status.json").unlink(missing_ok=True)
        for name in ("frames.parquet", "forces.parquet"):
            (d / name).unlink(missing_ok=True)
        one_line = " ".join(str(reason).split()) or "unknown error"
        atomic_write_json(
            d / "status.json", {"trial": trial_id, "status": "failed", "reason": one_line, **status}
        )

    def update_status(self, trial_id: str, changes: dict) -> None:
        """Replace top-level fields of a trial's status record (atomically), e.g. what a
        study-level step measured of a finished trial; a trial without one is left alone."""
        st = self.status(trial_id)
        if st is not None:
            atomic_write_json(self.trial_dir(trial_id) / "status.json", {**st, **changes})

    def trial_ids(self) -> list[str]:
        """Ids of every trial with a status record, sorted."""
        tdir = self.root / "trials"
        if not tdir.is_dir():
            return []
        return sorted(p.name for p in tdir.iterdir() if (p / "status.json").is_file())

    def read_frames(self, trial_id: str) -> pd.DataFrame:
        return pd.read_parquet(self.trial_dir(trial_id) / "frames.parquet")

    def read_forces(self, trial_id: str) -> pd.DataFrame:
        return pd.read_parquet(self.trial_dir(trial_id) / "forces.parquet")

    def summary(self) -> pd.DataFrame:
        """One row per trial with a status: trial, status, reason, elapsed_s."""
        rows = []
        for tid in self.trial_ids():
            st = self.status(tid) or {}
            rows.append(
                {
                    "trial": tid,
                    "status": st.get("status", "unknown"),
                    "reason": st.get("reason") or "",
                    "elapsed_s": st.get("elapsed_s"),
                }
            )
        return pd.DataFrame(rows, columns=["trial", "status", "reason", "elapsed_s"])

    # the analysed trials as the fit sees them ------------------------------------------
    def surfaces(self) -> dict[str, Surface]:
        """The study's surfaces, as recorded in the run record."""
        return {k: surface_from_spec(v) for k, v in (self.read_run().get("surfaces") or {}).items()}

    def analysed_trials(self) -> list[dict]:
        """Run-record entries (``id, subject, surface, speed_mm_s, repetition``) of the trials
        analysed OK, in the study's order."""
        return [m for m in self.read_run().get("trials", [])
                if (self.status(m["id"]) or {}).get("status") == "ok"]

    def read_fit_trial(self, entry: dict, surfaces: dict[str, Surface], *,
                       flat_margin: float = FitOptions().flat_margin) -> tuple[Trial, np.ndarray]:
        """One analysed trial as the fit and the out-of-sample validation use it.

        Forces on the 0.01 mm grid from ``forces.parquet`` (positions with a finite ``F_T``),
        on the paper's footing and, where the trial has them, on the absolute footing
        (``Trial.force_abs``, ``Trial.normal_abs``), the video's contact regions mapped onto
        the grid (:func:`~fingerfriction.regions.regions_on_grid`), the surface from the
        run record.

        Parameters
        ----------
        entry : dict
            The trial's run-record entry (:meth:`analysed_trials`).
        surfaces : dict of str to Surface
            :meth:`surfaces`.
        flat_margin : float
            ``FitOptions.flat_margin`` in mm of the fit that will use the trial.

        Returns
        -------
        trial : fingerfriction.fit.Trial
        translated : (n,) bool ndarray
            Positions whose regions were translated from the nearest tracked frame.

        Raises
        ------
        ValueError, KeyError, OSError
            An unreadable trial, or one without a flat segment (fewer than 2 positions
            where all contact lies before the feature: the fit detrends over it).
        """
        tid = entry["id"]
        fr = self.read_frames(tid)
        fo = self.read_forces(tid)
        x = fo["x_mm"].to_numpy(float)
        F = fo["F_T_N"].to_numpy(float)
        good = np.isfinite(F)
        reg, moved = regions_on_grid(fr["x_mm"].to_numpy(float), regions_from_table(fr), x,
                                     return_translated=True)
        surf = surfaces[entry["surface"]]
        n_flat = int(np.count_nonzero(flat_segment_mask(reg[good], surf, margin=flat_margin)))
        if n_flat < 2:
            raise ValueError(
                f"no flat segment: {n_flat} positions where all contact lies before the feature "
                f"(x(t) tracked over [{np.nanmin(fr['x_mm']):.2f}, {np.nanmax(fr['x_mm']):.2f}] mm)")
        absolute = {}
        if {"F_T_abs_N", "F_N_abs_N"} <= set(fo.columns):
            ft_abs = fo["F_T_abs_N"].to_numpy(float)[good]
            fn_abs = fo["F_N_abs_N"].to_numpy(float)[good]
            if np.all(np.isfinite(ft_abs)) and np.all(np.isfinite(fn_abs)):
                absolute = {"force_abs": ft_abs, "normal_abs": fn_abs}
        clipped = _clipped_on_grid(fr, x)
        trial = Trial(x=x[good], force=F[good], regions=reg[good], surface=surf,
                      subject=str(entry["subject"]),
                      labels={"trial": tid, "surface": entry["surface"],
                              "speed_mm_s": f"{entry['speed_mm_s']:g}"}, **absolute,
                      clipped=None if clipped is None else clipped[good])
        return trial, moved[good]

    # fit/ ------------------------------------------------------------------------------
    def write_model(self, trial_id: str, df: pd.DataFrame) -> None:
        """``fit/model/<trial-id>.parquet``: the fitted model forces of one trial."""
        self.trial_dir(trial_id)  # validates the id
        atomic_write_parquet(self.fit_dir / "model" / f"{trial_id}.parquet", df)

    def read_model(self, trial_id: str) -> pd.DataFrame | None:
        """The fitted model forces of one trial, or None before the fit."""
        self.trial_dir(trial_id)
        p = self.fit_dir / "model" / f"{trial_id}.parquet"
        return pd.read_parquet(p) if p.is_file() else None

    def write_fit_tables(self, trials: pd.DataFrame, subjects: pd.DataFrame) -> None:
        """``fit/trials.csv`` (one row per trial fit) and ``fit/subjects.csv``."""
        atomic_write_text(self.fit_dir / "trials.csv", trials.to_csv(index=False))
        atomic_write_text(self.fit_dir / "subjects.csv", subjects.to_csv(index=False))

    def write_fit_csv(self, name: str, df: pd.DataFrame) -> None:
        """``fit/<name>.csv`` (e.g. ``table1``: Table 1 of both models)."""
        atomic_write_text(self.fit_dir / f"{name}.csv", df.to_csv(index=False))

    def read_fit_csv(self, name: str) -> pd.DataFrame | None:
        """``fit/<name>.csv`` (subjects as text), or None when it was not written."""
        p = self.fit_dir / f"{name}.csv"
        return pd.read_csv(p, dtype={"subject": str}) if p.is_file() else None

    def write_fit_record(self, record: dict) -> None:
        """``fit/fit.json``: the fit's grid, options, per-subject mu, counts."""
        atomic_write_json(self.fit_dir / "fit.json", record)

    def read_fit_record(self) -> dict | None:
        """``fit/fit.json``, or None before the fit."""
        p = self.fit_dir / "fit.json"
        return _read_json(p) if p.is_file() else None

    def read_fit_table(self) -> pd.DataFrame | None:
        """``fit/trials.csv`` (subjects as text), or None before the fit."""
        return read_fit_table(self.fit_dir) if (self.fit_dir / "trials.csv").is_file() else None

    def fit_settings(self) -> tuple[np.ndarray | None, FitOptions | None]:
        """The ``mu`` grid and fit options recorded in ``fit/fit.json`` (None for each that is
        not recorded), so a later computation on the same data can use the fit's own."""
        rec = self.read_fit_record() or {}
        grid = options = None
        g = rec.get("mu_grid") or {}
        if {"start", "stop", "step"} <= set(g):
            grid = mu_grid(g["start"], g["stop"], g["step"])
        o = rec.get("options")
        if isinstance(o, dict):
            known = set(FitOptions.__dataclass_fields__)
            options = FitOptions(**{k: v for k, v in o.items() if k in known})
        return grid, options

    @property
    def loso_path(self) -> Path:
        """``fit/loso.csv``, the out-of-sample validation table (its figure: ``loso.png``)."""
        return self.fit_dir / "loso.csv"

    @property
    def loso_figure_path(self) -> Path:
        """``fit/loso.png``, the figure of the out-of-sample validation."""
        return self.loso_path.with_suffix(".png")

    def clear_loso(self) -> None:
        """Remove ``fit/loso.csv`` and ``fit/loso.png`` (a validation of another fit)."""
        for name in ("loso.csv", "loso.png"):
            (self.fit_dir / name).unlink(missing_ok=True)

    def read_loso(self) -> pd.DataFrame | None:
        """``fit/loso.csv`` (subjects as text), or None when the fit did not validate."""
        p = self.loso_path
        return pd.read_csv(p, dtype={"subject": str}) if p.is_file() else None


def _clipped_on_grid(frames: pd.DataFrame, x: np.ndarray) -> np.ndarray | None:
    """The frames' ``clipped`` flag at each grid position: that of the tracked frame whose
    x(t) is nearest, as :func:`~fingerfriction.regions.regions_on_grid` takes its regions
    (None when the frames have no such column or fewer than two tracked frames)."""
    if "clipped" not in frames.columns:
        return None
    xf = frames["x_mm"].to_numpy(float)
    ok = np.isfinite(xf)
    if ok.sum() < 2:
        return None
    order = np.argsort(xf[ok], kind="stable")
    xs, cl = xf[ok][order], frames["clipped"].to_numpy(bool)[ok][order]
    j = np.clip(np.searchsorted(xs, x), 1, xs.size - 1)
    nearest = np.where(np.abs(x - xs[j - 1]) <= np.abs(xs[j] - x), j - 1, j)
    return cl[nearest]


def read_fit_table(fit_dir: str | os.PathLike) -> pd.DataFrame:
    """``trials.csv`` of a fit folder (one row per trial fit; subjects as text).

    Raises
    ------
    ValueError
        Naming the file when it cannot be read.
    """
    p = os.path.join(os.fspath(fit_dir), "trials.csv")
    try:
        return pd.read_csv(p, dtype={"subject": str})
    except (OSError, ValueError) as exc:
        raise ValueError(f"{p}: cannot read the per-trial fits ({exc})") from None


def _read_json(path: Path) -> dict:
    try:
        with open(path, encoding="utf-8") as fh:
            obj = json.load(fh)
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"cannot read {path}: {exc}") from None
    if not isinstance(obj, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(obj).__name__}")
    return obj
