"""The typed boundary of the results store: what the analysis made of one trial
(:class:`AnalysedTrial`) and what the fit made of a study (:class:`FitResult`).

Both are written and read by :class:`fingerfriction.study.store.ResultsStore` only: the
fit, the out-of-sample validation, the prediction and the report take them from the store
instead of parsing its files. Provenance travels with the data: a trial carries its status
record (inputs, the force stage's history and flags), a fit its options and flags.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..fit import FitOptions, LoadFitOptions, mu_grid
from ..fit.variants import MODELS, FitSettings, get
from ..flags import LEVELS, Flag
from ..surfaces import Surface
from ..video import AnalysisOptions
from .tables import regions_from_table

__all__ = ["AnalysedTrial", "FitResult", "VideoInput", "UNRECORDED_MODEL", "subject_keys"]

#: The variant of a ``fit.json`` that does not name one: written before the fit recorded its
#: variants, it fitted the paper's Eq. 4 only.
UNRECORDED_MODEL = "paper"


@dataclass(eq=False)
class AnalysedTrial:
    """One analysed trial as the store holds it: the video stage's per-frame table, its
    contact regions as an array, the force stage's per-position table, the status record,
    and the fit's per-position model forces once the study is fitted.

    Attributes
    ----------
    id, subject, surface : str
    speed_mm_s : float
    repetition : int or None
    frames : pandas.DataFrame
        Per-frame table (``frame, t_s, x_mm, n_regions, a1, b1, ..., clipped, flag``,
        :mod:`fingerfriction.study.tables`).
    regions : (n_frames, n_max, 2) ndarray
        Contact regions C_i in mm per frame: read from the table's ``a1, b1, ...`` columns,
        and what the store writes into them (:func:`~fingerfriction.study.tables.with_regions`).
    forces : pandas.DataFrame
        Per-position table (``x_mm, F_T_N, F_N_N, F_T_abs_N, F_N_abs_N, n_samples``).
    model : pandas.DataFrame or None
        The fit's model forces per position (``fit/model/<trial-id>.parquet``: ``x_mm,
        F_T_N, F_hat_N, F_model_N, F_int_N, F_def_N``, per variant with a prefix), None
        before the fit.
    status : dict
        The trial's ``status.json`` (inputs, stage diagnostics under ``info``: the force
        stage's flags with their level and its history, :attr:`flags`,
        :attr:`force_history`); what the analysis hands the store to write
        (:meth:`~fingerfriction.study.store.ResultsStore.write_trial`) without the fields
        the store adds (``trial``, ``status``, ``trial_format``, ``tables``).
    """

    id: str
    subject: str
    surface: str
    speed_mm_s: float
    repetition: int | None
    frames: pd.DataFrame
    regions: np.ndarray
    forces: pd.DataFrame
    model: pd.DataFrame | None = None
    status: dict = field(default_factory=dict)

    @classmethod
    def from_tables(cls, trial_id: str, frames: pd.DataFrame, forces: pd.DataFrame,
                    status: dict | None = None, *, subject: str = "", surface: str = "",
                    speed_mm_s: float = math.nan, repetition: int | None = None,
                    model: pd.DataFrame | None = None) -> AnalysedTrial:
        """An analysed trial from its tables, its regions read from the per-frame table's
        ``a1, b1, ...`` columns (:func:`~fingerfriction.study.tables.regions_from_table`).

        Raises
        ------
        ValueError
            A per-frame table without region columns.
        """
        return cls(id=trial_id, subject=subject, surface=surface, speed_mm_s=speed_mm_s,
                   repetition=repetition, frames=frames, regions=regions_from_table(frames), forces=forces,
                   model=model, status={} if status is None else status)

    @property
    def info(self) -> dict:
        """The stages' diagnostics (``status.json`` ``info``)."""
        return self.status.get("info") or {}

    @property
    def force_history(self) -> list | None:
        """Every step of the trial's force processing with its parameters and fitted values
        (``status.json``, ``info.forces.history``); None for a trial analysed before the
        history was stored."""
        return (self.info.get("forces") or {}).get("history")

    @property
    def flags(self) -> list[Flag]:
        """The flags the force and consistency stages stored for this trial, their level
        kept (results written before: ``'code: message'`` strings, read as warnings),
        placed at the trial and its subject."""
        return [Flag.from_dict(s if isinstance(s, dict) else str(s)).at(trial=self.id, subject=self.subject)
                for s in (self.info.get("forces") or {}).get("flags") or []]

    def sliding(self, *, min_speed_fraction: float = 0.2, half_span: int = 10) -> np.ndarray:
        """Frames in which the finger slides through the analysis window, ``(n_frames,)`` bool.

        The frames whose position x(t) lies inside the span of the force grid (the
        paper's 26 mm window, "Force data processing") and whose speed, a central
        difference over ``2 * half_span`` frames, is at least ``min_speed_fraction`` of
        the median speed of those frames. This leaves out the rest at touch-down (and
        any pause), in which a recording can spend a tenth of its frames with the
        finger still: counted as contact time, it lights up the resting contact's span
        in the occupancy map (Fig. 3) with a step at its edge.
        """
        fr = self.frames
        x = fr["x_mm"].to_numpy(float)
        t = fr["t_s"].to_numpy(float)
        xg = self.forces["x_mm"].to_numpy(float) if len(self.forces) else np.array([np.nan])
        lo, hi = (np.nanmin(xg), np.nanmax(xg)) if np.isfinite(xg).any() else (-np.inf, np.inf)
        with np.errstate(invalid="ignore"):
            inside = np.isfinite(x) & (x >= lo) & (x <= hi)
        k = int(half_span)
        v = np.full(x.size, np.nan)
        if x.size > 2 * k:
            v[k:-k] = (x[2 * k:] - x[:-2 * k]) / (t[2 * k:] - t[:-2 * k])
        ok = inside & np.isfinite(v)
        if not ok.any():
            return inside
        v_ref = float(np.median(np.abs(v[ok])))
        with np.errstate(invalid="ignore"):
            return inside & (np.abs(v) >= min_speed_fraction * v_ref)


@dataclass(frozen=True)
class VideoInput:
    """A trial's video as the results store recorded the analysis' inputs
    (:meth:`~fingerfriction.study.store.ResultsStore.trial_video`).

    Attributes
    ----------
    path : Path
        The video (a file or a folder of TIFF frames), inside the study folder.
    surface : Surface
        The trial's relief.
    height_mm : float
        The feature height H in mm that calibrated the image scale.
    options : AnalysisOptions
        The video stage's options of the analysis, with the trial's calibration frame.
    """

    path: Path
    surface: Surface
    height_mm: float
    options: AnalysisOptions


def _flag(d: Mapping) -> Flag:
    """A flag recorded in ``fit.json`` (an unknown level read as a warning, as always)."""
    level = d.get("level", "warning") if d.get("level") in LEVELS else "warning"
    return Flag(level, str(d.get("code") or "fit"), str(d.get("message", "")),
                trial=str(d.get("trial") or ""), subject=str(d.get("subject") or ""),
                model=str(d.get("model") or ""))


@dataclass(frozen=True, eq=False)
class FitResult:
    """A study's fit (``fit/fit.json``), as the store writes and reads it.

    The record is the JSON object the fit wrote (its layout in
    :mod:`fingerfriction.study.store`); the properties read it, with the defaults of a
    record written by an earlier version (no ``model``: the paper's variant only).

    Parameters
    ----------
    record : dict
        The JSON object of ``fit.json``.
    """

    record: Mapping

    def __post_init__(self) -> None:
        if not isinstance(self.record, Mapping):
            raise TypeError(f"FitResult.record must be a JSON object (dict), got "
                            f"{type(self.record).__name__}")

    @classmethod
    def from_dict(cls, d: Mapping | FitResult) -> FitResult:
        """A FitResult from its JSON object (or itself)."""
        return d if isinstance(d, FitResult) else cls(dict(d))

    def to_dict(self) -> dict:
        """The JSON object the store writes."""
        return dict(self.record)

    # -- the variants ------------------------------------------------------------------
    @property
    def model(self) -> str:
        """The variant the fit used (the chosen or forced one): the one a prediction, the
        report and the console use first."""
        return str(self.record.get("model") or UNRECORDED_MODEL)

    @property
    def requested(self) -> str:
        """``'auto'`` or the variant the caller forced."""
        return str(self.record.get("requested", "auto"))

    @property
    def models(self) -> dict:
        """Variant name -> its part of the record (``mu``, ``mu_ci``, ``title``, ...); for a
        record of one variant, that variant's ``mu`` and ``mu_ci``."""
        rec = self.record.get("models")
        if isinstance(rec, Mapping) and rec:
            return {str(k): (v if isinstance(v, Mapping) else {}) for k, v in rec.items()}
        return {self.model: {"mu": self.record.get("mu") or {}, "mu_ci": self.record.get("mu_ci") or {}}}

    @property
    def order(self) -> list[str]:
        """The fitted variants, the one used first."""
        return [self.model, *[m for m in (self.record.get("models") or {}) if m != self.model]]

    def title(self, m: str) -> str:
        """A variant's title as the fit recorded it (its name for a fit that did not)."""
        return (self.models.get(m) or {}).get("title") or m

    def note(self, m: str) -> str:
        """A variant's one-sentence note as the fit recorded it ('' when it did not)."""
        return (self.record.get("model_notes") or {}).get(m, "")

    def _per_subject(self, key: str, m: str | None) -> dict:
        m = self.model if m is None else m
        recorded = self.record.get("models") or {}
        if m in recorded:
            return dict((recorded[m] or {}).get(key) or {})
        return dict(self.record.get(key) or {}) if m == self.model else {}

    def mu(self, m: str | None = None) -> dict:
        """Per subject, ``mu`` of variant ``m`` (default: the one used)."""
        return self._per_subject("mu", m)

    def mu_ci(self, m: str | None = None) -> dict:
        """Per subject, the 95 % confidence interval ``[lo, hi]`` of ``mu`` of variant ``m``
        (default: the one used; absent where the variant has none)."""
        return self._per_subject("mu_ci", m)

    # -- flags -------------------------------------------------------------------------
    @property
    def flags(self) -> list[Flag] | None:
        """The study's flags as the fit recorded them (those of the variant used), None for
        a record written before the fit recorded its flags."""
        recorded = self.record.get("flags")
        if not isinstance(recorded, list):
            return None
        used = self.record.get("model")
        return [_flag(f) for f in recorded
                if isinstance(f, Mapping) and not (f.get("model") and used and f.get("model") != used)
                and f.get("message")]

    @property
    def notes(self) -> list[Flag]:
        """The flags of the variants fitted for comparison (not the one the fit used)."""
        used = self.record.get("model")
        if isinstance(self.record.get("notes"), list):
            recorded = self.record["notes"]
        else:  # a record written before "notes": the other variants' flags were among "flags"
            recorded = [f for f in self.record.get("flags") or [] if isinstance(f, Mapping) and f.get("model")
                        and f.get("model") != used]
        return [_flag(f) for f in recorded if isinstance(f, Mapping)]

    @property
    def failures(self) -> list[dict]:
        """``{"trial", "reason"}`` of the trials the fit could not prepare or fit."""
        return [f for f in self.record.get("failures") or [] if isinstance(f, Mapping)]

    # -- how it was made ---------------------------------------------------------------
    @property
    def selection(self) -> dict | None:
        """The comparison of the variants and the choice (:mod:`fingerfriction.fit.select`)."""
        sel = self.record.get("selection")
        return sel if isinstance(sel, Mapping) else None

    @property
    def footing(self) -> str:
        """How the fit put measurement and model on one footing, in words."""
        if isinstance(self.record.get("footing"), str):
            return self.record["footing"]
        if (self.record.get("options") or {}).get("detrend", True):
            return "detrended (a line fitted on the flat before the feature, subtracted from both)"
        return "absolute (no detrend)"

    @property
    def mu_grid(self) -> dict:
        """``{"start", "stop", "step", "n"}`` of the paper variant's grid ({} when not recorded)."""
        return dict(self.record.get("mu_grid") or {})

    @property
    def method(self) -> str | None:
        return self.record.get("method")

    @property
    def options(self) -> dict:
        """The paper variant's options as recorded."""
        return dict(self.record.get("options") or {})

    @property
    def settings(self) -> FitSettings:
        """The fit's settings (grid, options, method), for a later computation on the same
        data (e.g. ``fingerfriction validate``); defaults for what is not recorded."""
        g = self.mu_grid
        grid = mu_grid(g["start"], g["stop"], g["step"]) if {"start", "stop", "step"} <= set(g) else None
        return FitSettings(paper=_options(FitOptions, self.record.get("options")),
                           load=_options(LoadFitOptions, self.record.get("load_options")),
                           **({} if grid is None else {"grid": grid}),
                           **({"method": self.method} if self.method else {}))

    @property
    def fitted_models(self) -> tuple[str, ...]:
        """The variants to validate again: the one used, then the others it fitted (every
        variant of the registry when the record names none)."""
        fitted = [m for m in (self.record.get("models") or {}) if m in MODELS] or list(MODELS)
        first = self.record.get("model") or MODELS[0]
        return (first, *[m for m in fitted if m != first])

    @property
    def loso(self) -> dict:
        """How the out-of-sample validation went (``computed``, ``message``, ``csv``)."""
        return dict(self.record.get("loso") or {})

    @property
    def analysis(self) -> dict | None:
        """The digests of the analysed trials the fit used (None for an older record)."""
        a = self.record.get("analysis")
        return a if isinstance(a, Mapping) else None

    @property
    def n_trials(self):
        return self.record.get("n_trials")

    @property
    def finished(self):
        return self.record.get("finished")

    # -- prediction --------------------------------------------------------------------
    def params_for(self, subject, rows: pd.DataFrame, *, model: str | None = None, where: str = "fit.json"):
        """A subject's parameters of a prediction from this fit: ``mu`` (and the variant's
        per-subject contact) recorded here, the medians of the subject's successful trial
        fits in ``rows`` (``fit/trials.csv``).

        Parameters
        ----------
        subject : str or int
            As the fit labels it (``'1'``; ``1``, ``'S1'`` and ``'s1'`` find it too).
        rows : pandas.DataFrame
            ``fit/trials.csv``.
        model : str, optional
            The variant (default: the one the fit used).
        where : str
            The file named in error messages.

        Returns
        -------
        LoadParams or FrictionParams
            As the variant predicts (:attr:`fingerfriction.fit.variants.Variant.params_type`).
        """
        model = self.model if model is None else model
        variant = get(model)
        recorded = self.record.get("models")
        per_model = (recorded or {}).get(model)
        if per_model is None and model != self.model:
            raise ValueError(f"{where}: the fit has no {model!r} model (it has {self.model!r})")
        mus = self.mu(model)
        key = next((k for k in subject_keys(subject) if k in mus), None)
        if key is None:
            raise ValueError(f"{where}: no fitted mu for subject {subject!r}; the fit has subjects "
                             f"{sorted(mus)}")
        missing = {"subject", "p0", "p1"} - set(rows.columns)
        if missing:
            raise ValueError(f"trials.csv beside {where}: missing column(s) {sorted(missing)}")
        sel = rows[rows["subject"] == key]
        if "model" in sel.columns:
            sel = sel[sel["model"] == model]
        if "success" in sel.columns:
            sel = sel[sel["success"].astype(str).str.lower() == "true"]
        if sel.empty:
            raise ValueError(f"trials.csv beside {where}: no successful {model!r} trial fit for subject "
                             f"{subject!r}")
        return variant.params_from_record({**(per_model or {}), "mu": mus}, sel, key)


def subject_keys(subject) -> list:
    """The labels a subject may have in a fit or a parameters file: ``'1'``, ``1``, ``'S1'``,
    ``'s1'``."""
    keys = [str(subject), subject]
    digits = "".join(c for c in str(subject) if c.isdigit())
    if digits:
        keys += [digits, f"S{digits}", f"s{digits}"]
    return [k for k in keys if isinstance(k, (str, int))]


def _options(cls, d):
    """Options recorded as a dict (their known fields), else the defaults."""
    if not isinstance(d, Mapping):
        return cls()
    known = set(cls.__dataclass_fields__)
    return cls(**{k: v for k, v in d.items() if k in known})

