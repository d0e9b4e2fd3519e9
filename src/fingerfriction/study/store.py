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

The columns of the trial's tables (``frames.parquet``, ``forces.parquet``) are described in
:mod:`fingerfriction.study.tables`; the digests that decide what ``analyze`` recomputes are in
:mod:`fingerfriction.study.digests`.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import logging
import math
import os
import shutil
import stat
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd

from .._atomic import atomic_write, atomic_write_json
from .._check import parse_json
from .._outputs import write_table
from ..fit import FitOptions, Trial, flat_segment_mask
from ..regions import regions_on_grid
from ..surfaces import Surface, surface_from_spec
from ..video import AnalysisOptions
from .digests import input_fingerprint, params_digest, sha256_file, sha256_input
from .fitstore import FitFolder, read_fit_table, read_json_object
from .manifest import resolve_path, validate_id
from .results import AnalysedTrial, VideoInput
from .tables import atomic_write_parquet, clipped_on_grid, frames_table, regions_from_table, with_regions

__all__ = [
    "RESULTS_FORMAT",
    "RESULTS_SCHEMA_VERSION",
    "ResultsStore",
    "atomic_write_parquet",
    "sha256_file",
    "sha256_input",
    "input_fingerprint",
    "params_digest",
    "ResultsInUseError",
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


#: The fields of a finished trial's ``status.json`` the store writes itself (a status read from
#: the store and written again keeps none of its old ones).
_STORE_KEYS = ("trial", "status", "trial_format", "reason", "tables")


def now() -> str:
    """The current UTC time, ISO 8601 to the second (the clock of the run records)."""
    return datetime.now(UTC).isoformat(timespec="seconds")


#: The text of status records by (path, inode, size, modification time), each checked once
#: (:meth:`ResultsStore.status`).
_STATUS_CACHE: dict = {}


class ResultsInUseError(ValueError):
    """Another command holds the results folder (:meth:`ResultsStore.lock`)."""


class ResultsStore(FitFolder):
    """A results folder (layout in the module docstring); its ``fit/`` part is
    :class:`~fingerfriction.study.fitstore.FitFolder`'s.

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
        rec = read_json_object(self.run_path)
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
        """The trial's status record, or None if it has none (never run, or interrupted).

        A status read again while its file is the same (inode, size, modification time: it
        is only ever replaced whole) is not read and checked again (``analyze`` reads each
        several times): its text, checked once, is parsed again into a new dict."""
        p = self.trial_dir(trial_id) / "status.json"
        try:
            st = p.stat()
        except OSError:
            return None
        if not stat.S_ISREG(st.st_mode):
            return None
        key = (str(p), st.st_ino, st.st_size, st.st_mtime_ns)
        text = _STATUS_CACHE.get(key)
        if text is not None:
            return json.loads(text)
        try:
            text = p.read_text(encoding="utf-8")
            obj = parse_json(text, f"cannot read {p}")
            if not isinstance(obj, dict):
                raise ValueError(f"{p}: expected a JSON object, got {type(obj).__name__}")
        except (OSError, ValueError) as exc:  # (UnicodeDecodeError is a ValueError)
            logger.warning("ignoring unreadable status of trial %s: %s", trial_id, exc)
            return None
        if len(_STATUS_CACHE) > 20_000:
            _STATUS_CACHE.clear()
        _STATUS_CACHE[key] = text
        return obj

    def is_finished(self, trial_id: str, params_sha256: str) -> bool:
        """True if the trial finished OK with these analysis parameters."""
        st = self.status(trial_id)
        if st is None or st.get("status") != "ok" or st.get("params_sha256") != params_sha256:
            return False
        if st.get("trial_format", 1) != TRIAL_FORMAT:
            return False
        d = self.trial_dir(trial_id)
        return (d / "frames.parquet").is_file() and (d / "forces.parquet").is_file()

    def write_trial(self, trial: AnalysedTrial) -> None:
        """Write a finished trial: its per-frame table (its regions flattened into the
        ``a1, b1, ...`` columns, :func:`~.tables.with_regions`), its per-position table, then
        its status (the commit marker): ``trial.status`` with the store's ``trial``,
        ``status: "ok"``, ``trial_format`` and ``tables``."""
        if not isinstance(trial, AnalysedTrial):
            raise TypeError(f"write_trial takes an AnalysedTrial, got {type(trial).__name__}")
        d = self.trial_dir(trial.id)
        frames = with_regions(trial.frames, trial.regions)
        # Remove the old status first, so a crash between the writes below leaves the
        # trial unfinished rather than pointing at a mix of old and new tables.
        (d / "status.json").unlink(missing_ok=True)
        tables = {}
        for name, df in (("frames.parquet", frames), ("forces.parquet", trial.forces)):
            buf = io.BytesIO()
            df.to_parquet(buf, engine="pyarrow", index=False)
            data = buf.getvalue()
            atomic_write(d / name, lambda tmp, data=data: tmp.write_bytes(data))
            # what resume checks before it trusts the table again (verify_tables)
            tables[name] = {"rows": len(df), "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
        status = {k: v for k, v in trial.status.items() if k not in _STORE_KEYS}
        atomic_write_json(d / "status.json", {"trial": trial.id, "status": "ok", "trial_format": TRIAL_FORMAT,
                                              **status, "tables": tables})

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

    def verify_tables(self, trial_id: str, status: dict | None = None) -> str | None:
        """Why a finished trial's stored tables cannot be trusted, or None when they are
        intact: each must exist with the size and SHA-256 recorded when it was written
        (``status.json`` ``tables``); for results written before those were recorded, it
        must be a readable Parquet file (its footer) with the recorded row count where
        there is one."""
        import pyarrow.parquet as pq  # pyarrow is pandas' Parquet engine here

        status = self.status(trial_id) if status is None else status
        d = self.trial_dir(trial_id)
        recorded = (status or {}).get("tables") or {}
        for name in ("frames.parquet", "forces.parquet"):
            p = d / name
            rec = recorded.get(name) or {}
            try:
                size = p.stat().st_size
                if rec.get("sha256"):
                    if size != rec.get("bytes"):
                        return f"{name} has {size} bytes, {rec.get('bytes')} were written"
                    if sha256_file(p) != rec["sha256"]:
                        return f"{name} changed since it was written (SHA-256)"
                    continue
                rows = pq.read_metadata(p).num_rows
            except FileNotFoundError:
                return f"{name} is missing"
            except Exception as exc:  # noqa: BLE001 - a damaged Parquet file raises many types
                return f"{name} cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())[:120]})"
            if rec.get("rows") is not None and rows != rec["rows"]:
                return f"{name} has {rows} rows, {rec['rows']} were written"
        return None

    def mark_input_missing(self, trial_id: str, reason: str | None) -> None:
        """Mark a finished trial whose input files are missing or unreadable (``reason``),
        keeping its tables: ``status.json`` gains ``input_missing`` (what and since when);
        ``reason=None`` removes the mark (the inputs are back, unchanged)."""
        st = self.status(trial_id)
        if st is None or st.get("status") != "ok":
            return
        if reason is None:
            if "input_missing" not in st:
                return
            st.pop("input_missing")
        else:
            since = (st.get("input_missing") or {}).get("since") or now()
            st["input_missing"] = {"reason": " ".join(str(reason).split()), "since": since}
        atomic_write_json(self.trial_dir(trial_id) / "status.json", st)

    @contextlib.contextmanager
    def lock(self, command: str) -> Iterator[None]:
        """Hold the results folder for one command (``RESULTS/.lock``, an exclusive
        ``flock`` the system releases when the process ends, however it ends).

        Raises
        ------
        ResultsInUseError
            Another command holds it (the message names it, with its process id).
        ValueError
            The folder cannot be written (read-only, no permission).
        """
        import fcntl  # POSIX; the package's commands run on Linux and macOS

        try:
            self.root.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.root / ".lock", os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            raise ValueError(f"results folder {str(self.root)!r} cannot be written ({exc.strerror or exc}); "
                             "give a folder you can write with --out") from None
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 200, 0).decode("utf-8", "replace").strip() or "another command"
                raise ResultsInUseError(
                    f"results folder {str(self.root)!r} is in use by {holder}; wait for it to finish "
                    "(two commands writing one results folder would mix their results)") from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"`fingerfriction {command}` (process {os.getpid()}, since {now()})".encode(), 0)
            yield
        finally:
            os.close(fd)  # releases the lock

    def purge(self, keep: set) -> list[str]:
        """Remove what the package wrote for trials not in ``keep`` (``trials/<id>/``), and
        ``fit/`` and ``report/``; returns the trial ids removed. For a results folder taken
        over by another study (``analyze --force``)."""
        gone = []
        tdir = self.root / "trials"
        if tdir.is_dir():
            for p in sorted(tdir.iterdir()):
                if p.is_dir() and not p.is_symlink() and p.name not in keep:
                    shutil.rmtree(p)
                    gone.append(p.name)
        for sub in (self.fit_dir, self.report_dir):
            if sub.is_dir() and not sub.is_symlink():
                shutil.rmtree(sub)
        return gone
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

    def read_trial(self, entry: dict | str, *, status: dict | None = None,
                   model: bool = False) -> AnalysedTrial:
        """One trial analysed OK, as the analysis stored it: its tables, its regions as an
        array (the only reader of the ``a1, b1, ...`` columns), its status record and, with
        ``model``, the fit's model forces (None before the fit).

        Parameters
        ----------
        entry : dict or str
            The trial's run-record entry (:meth:`analysed_trials`) or its id.
        status : dict, optional
            Its status record when the caller has read it.
        model : bool
            Also read ``fit/model/<trial-id>.parquet``.

        Raises
        ------
        ValueError, KeyError, OSError
            An unknown trial, unreadable tables.
        """
        if isinstance(entry, str):
            entry = next((m for m in self.read_run().get("trials", []) if m.get("id") == entry), None) or \
                {"id": entry}
        tid = entry["id"]
        return AnalysedTrial.from_tables(
            tid, self.read_frames(tid), self.read_forces(tid),
            (self.status(tid) or {}) if status is None else status,
            subject=str(entry.get("subject")), surface=str(entry.get("surface")),
            speed_mm_s=float(entry.get("speed_mm_s") or math.nan), repetition=entry.get("repetition"),
            model=self.read_model(tid) if model else None)

    def trial_video(self, trial_id: str) -> VideoInput:
        """A trial's video as the store recorded its inputs (the run record's study folder,
        the trial's entry and input paths, the video options of the analysis): what an
        overlay of the stored results on the video needs, without reading the manifest.

        Raises
        ------
        ValueError
            The results do not record the trial's video, or the study is not reachable.
        """
        run = self.read_run()
        st = self.status(trial_id) or {}
        entry = st.get("entry")
        rel = ((st.get("inputs") or {}).get("video") or {}).get("path") or \
            ((entry or {}).get("video") or {}).get("path")
        study = run.get("study")
        if not study:
            raise ValueError("the run record names no study")
        root = Path(study)
        if not (root / "manifest.json").is_file():
            raise ValueError(f"the study's manifest is not reachable from here ({root}), nor are its videos")
        if not isinstance(entry, dict) or not rel:
            raise ValueError("the results do not record this trial's video inputs (analysed by an earlier "
                             "version; run analyze again)")
        spec = entry.get("surface_spec") or (run.get("surfaces") or {}).get(entry.get("surface"))
        surface = surface_from_spec(spec)
        height = (entry.get("calibration") or {}).get("surface_height_mm")
        video = dict((run.get("parameters") or {}).get("video") or {})
        video.setdefault("calibration_frame", int((entry.get("video") or {}).get("calibration_frame", 0)))
        try:
            options = AnalysisOptions(**video)
        except TypeError as exc:  # an option of another version
            raise ValueError(f"video option: {exc}") from None
        return VideoInput(path=resolve_path(root, rel, where="video.path"), surface=surface,
                          height_mm=float(surface.max_height if height is None else height), options=options)

    def read_truth(self) -> tuple[dict | None, Path | None, list[str]]:
        """``(truth, truth_dir, notes)``: the ground truth of a simulated study that the run
        record names (``truth/study.json``), its folder, and why it is left out when it
        cannot be read (``(None, None, [])`` for a study without one)."""
        truth_dir = self.read_run().get("truth")
        if not truth_dir:
            return None, None, []
        truth_dir = Path(truth_dir)
        try:
            return json.loads((truth_dir / "study.json").read_text(encoding="utf-8")), truth_dir, []
        except (OSError, json.JSONDecodeError) as exc:
            return None, None, [f"ground truth not readable ({exc}); the comparison with the truth is "
                                "left out"]

    def trial_truth(self, truth_dir: Path | None, trial_id: str,
                    keys: tuple[str, ...]) -> dict[str, np.ndarray]:
        """The arrays ``keys`` of a simulated trial's truth (``truth/<trial-id>.npz``) that it
        has; {} without a truth file."""
        self.trial_dir(trial_id)  # validates the id
        p = None if truth_dir is None else Path(truth_dir) / f"{trial_id}.npz"
        if p is None or not p.is_file():
            return {}
        with np.load(p, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in keys if k in z.files}

    def read_fit_trial(self, entry: dict, surfaces: dict[str, Surface], *,
                       flat_margin: float = FitOptions().flat_margin) -> Trial:
        """One analysed trial as the fit and the out-of-sample validation use it.

        Forces on the 0.01 mm grid from ``forces.parquet`` (positions with a finite ``F_T``),
        on the paper's footing and, where the trial has them, on the absolute footing
        (``Trial.force_abs``, ``Trial.normal_abs``), the video's contact regions mapped onto
        the grid (:func:`~fingerfriction.regions.regions_on_grid`; ``Trial.translated``: the
        positions whose regions were translated from the nearest tracked frame), the surface
        from the run record.

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
        fingerfriction.fit.Trial

        Raises
        ------
        ValueError, KeyError, OSError
            An unreadable trial, or one without a flat segment (fewer than 2 positions
            where all contact lies before the feature: the fit detrends over it).
        """
        at = self.read_trial(entry)
        fr, fo = at.frames, at.forces
        x = fo["x_mm"].to_numpy(float)
        F = fo["F_T_N"].to_numpy(float)
        good = np.isfinite(F)
        reg, moved = regions_on_grid(fr["x_mm"].to_numpy(float), at.regions, x, return_translated=True)
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
        clipped = clipped_on_grid(fr, x)
        labels = {"trial": at.id, "surface": entry["surface"], "speed_mm_s": f"{entry['speed_mm_s']:g}"}
        return Trial(x=x[good], force=F[good], regions=reg[good], surface=surf, subject=str(entry["subject"]),
                     labels=labels,
                     **absolute, clipped=None if clipped is None else clipped[good], translated=moved[good])

    # the analysis a fit used ----------------------------------------------------------
    def analysis_digests(self) -> dict[str, str]:
        """``{trial_id: SHA-256}`` of every trial analysed OK (in the run record), over its
        stored tables' digests (``status.json`` ``tables``; the files themselves for results
        written before those were recorded): what a fit records, and what tells that a
        trial was analysed again since (:meth:`fit_staleness`)."""
        out = {}
        for m in self.read_run().get("trials", []):
            tid = m.get("id") if isinstance(m, dict) else None
            if not isinstance(tid, str):
                continue
            st = self.status(tid) or {}
            if st.get("status") != "ok":
                continue
            tables = st.get("tables") or {}
            parts = []
            for name in ("frames.parquet", "forces.parquet"):
                digest = (tables.get(name) or {}).get("sha256")
                if digest is None:
                    try:
                        digest = sha256_file(self.trial_dir(tid) / name)
                    except OSError:
                        digest = "missing"
                parts.append(f"{name}={digest}")
            out[tid] = hashlib.sha256(";".join(parts).encode()).hexdigest()
        return out
