"""The fit's part of the results store (``RESULTS/fit/``, layout in
:mod:`fingerfriction.study.store`): :class:`FitFolder`, which
:class:`~fingerfriction.study.store.ResultsStore` is, holds the only reader and writer of
``fit/fit.json`` (:meth:`FitFolder.read_fit`, :meth:`FitFolder.write_fit`, a
:class:`~fingerfriction.study.results.FitResult` each way) and of the fit's tables.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from .._atomic import atomic_write_json, atomic_write_text
from .._check import parse_json
from .results import FitResult
from .tables import atomic_write_parquet

__all__ = ["FitFolder", "read_fit_table", "read_json_object"]


class FitFolder:
    """``RESULTS/fit/``: the fit record, its tables, the model forces, the validation.

    A mixin of :class:`~fingerfriction.study.store.ResultsStore` (which gives ``root``,
    ``fit_dir``, ``trial_dir`` and ``analysis_digests``)."""

    root: Path
    fit_dir: Path

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

    def write_fit(self, fit: FitResult) -> None:
        """``fit/fit.json``: the fit's variants, grid, options, per-subject mu, flags, counts."""
        atomic_write_json(self.fit_json, fit.to_dict())

    def read_fit(self) -> FitResult | None:
        """``fit/fit.json`` as a :class:`~fingerfriction.study.results.FitResult`, or None
        before the fit (the only reader of that file).

        Raises
        ------
        ValueError
            Naming the file when it cannot be read or is not a JSON object.
        """
        p = self.fit_json
        return FitResult(read_json_object(p)) if p.is_file() else None

    @property
    def fit_json(self) -> Path:
        """``fit/fit.json``."""
        return self.fit_dir / "fit.json"

    def read_fit_table(self) -> pd.DataFrame | None:
        """``fit/trials.csv`` (subjects as text), or None before the fit."""
        return read_fit_table(self.fit_dir) if (self.fit_dir / "trials.csv").is_file() else None

    def prediction_params(self, subject, *, model: str | None = None):
        """A subject's parameters of a prediction from the fit (its variant, or ``model``):
        :meth:`FitResult.params_for <fingerfriction.study.results.FitResult.params_for>` over
        ``fit/trials.csv``.

        Raises
        ------
        ValueError
            No fit, or the fit lacks the variant, the subject or a successful trial fit.
        """
        fit = self.read_fit()
        if fit is None:
            raise ValueError(f"{self.root}: a folder without fit/fit.json; run 'fingerfriction fit' first")
        return fit.params_for(subject, read_fit_table(self.fit_dir), model=model, where=str(self.fit_json))

    def fit_staleness(self, fit: FitResult | None = None) -> str | None:
        """Why the fit (``fit/fit.json``) no longer describes the analysed trials, or None:
        trials analysed again, newly analysed or gone since the fit (the digests the fit
        recorded, ``analysis_digests``). None also for a fit that recorded none (made by an
        older version: nothing to compare)."""
        fit = self.read_fit() if fit is None else fit
        fitted = fit.analysis if fit is not None else None
        if not isinstance(fitted, dict) or not isinstance(fitted.get("trials"), dict):
            return None
        before, now_ = fitted["trials"], self.analysis_digests()
        again = sorted(t for t in set(before) & set(now_) if before[t] != now_[t])
        new = sorted(set(now_) - set(before))
        gone = sorted(set(before) - set(now_))
        if not (again or new or gone):
            return None
        parts = [f"{len(v)} {what} (e.g. {v[0]})" for v, what in ((again, "analysed again"),
                                                                   (new, "newly analysed"),
                                                                   (gone, "no longer analysed OK")) if v]
        return (f"the fit is older than the analysis: since it was made, trials were {'; '.join(parts)}; "
                f"run `fingerfriction fit {self.root}` again")

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

    def read_loso_figure(self) -> bytes | None:
        """``fit/loso.png``'s bytes, or None when the fit did not draw it."""
        p = self.loso_figure_path
        return p.read_bytes() if p.is_file() else None


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


def read_json_object(path: Path) -> dict:
    """A JSON object from a file of the store; ValueError naming the file otherwise."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from None
    obj = parse_json(data, f"cannot read {path}")
    if not isinstance(obj, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(obj).__name__}")
    return obj
