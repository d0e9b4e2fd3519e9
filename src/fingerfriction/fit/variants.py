"""The model variants as objects, in one registry (:data:`VARIANTS`).

Each variant of Eq. (4) of Janko, Wiertlewski & Visell 2018 knows how to fit itself to
trials, what its flags are, how its per-trial and per-subject results read as table rows
and in ``fit/fit.json``, which parameters a prediction takes from a fit, and how a
held-out trial is predicted from those parameters. Code outside this module asks a
variant (:func:`get`) instead of branching on its name; a new variant is a subclass of
:class:`Variant` added to :data:`VARIANTS`.

========== ======================================================= ========== ==========
name       what                                                    mu         selectable
========== ======================================================= ========== ==========
load       the pressure carries the measured F_N (load-sharing)    flat, CI   yes
pressure   one constant pressure per trial, Eq. (4) as printed,    flat, CI   yes
           on the absolute footing
interlock  load-sharing, the slope push weighed by slope           flat, CI   yes
           direction (interlocking on rising features)
paper      Eq. (4) as printed on the paper's detrended footing,    grid, none no
           mu by grid search (kept to reproduce the paper)
========== ======================================================= ========== ==========

``fit --model auto`` (:mod:`fingerfriction.fit.select`) chooses among the selectable
variants; the paper's variant is fitted and shown beside them, but its ``mu`` has no
confidence interval and is not identifiable on its footing (:func:`paper_flags`), so it is
never chosen.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .._check import check_option, validate_type
from ..model import FrictionModel, FrictionParams, LoadParams, T_matrix
from .common import FitFlag, Trial, flat_detrend, flat_segment_mask, median_filter
from .load import LoadFitOptions, fit_load_trials, load_estimate
from .paper import METHODS, FitOptions, fit_trials, mu_grid, paper_flags
from .pressure import fit_pressure_trials

__all__ = ["FitSettings", "HeldOut", "Variant", "VARIANTS", "MODELS", "SELECTABLE", "get",
           "variant_of_params"]


@dataclass(frozen=True)
class FitSettings:
    """Everything the variants' fits take, passed in memory from the fit to its validation.

    Parameters
    ----------
    paper : FitOptions
        Options of the paper's variant.
    load : LoadFitOptions
        Options of the variants on the absolute footing (load, pressure, interlock).
    grid : (m,) ndarray
        ``mu`` grid of the paper's variant.
    method : {'lstsq', 'nelder-mead'}
        How the paper's variant fits ``p0, p1``.
    """

    paper: FitOptions = field(default_factory=FitOptions)
    load: LoadFitOptions = field(default_factory=LoadFitOptions)
    grid: np.ndarray = field(default_factory=mu_grid)
    method: str = "lstsq"

    def __post_init__(self) -> None:
        validate_type("FitSettings.paper", self.paper, FitOptions, "a FitOptions")
        validate_type("FitSettings.load", self.load, LoadFitOptions, "a LoadFitOptions")
        check_option("FitSettings.method", self.method, METHODS)


@dataclass(frozen=True)
class HeldOut:
    """How a held-out trial is predicted (:meth:`Variant.heldout_series`).

    Parameters
    ----------
    load : float
        Nominal normal force in N (the prescribed load).
    paper : FitOptions
        The paper variant's processing (median filter mode, detrend).
    kernel : int
        Median filter window of the variants on the absolute footing.
    flat_length : callable
        Returns the forward model's flat-ground contact length in mm (the paper variant's
        flat level ``mu p0 L_flat``); called only when needed.
    min_load : float
        Positions with a measured normal force below this (N) do not count in a trial's
        own flat-ground pressure.
    """

    load: float
    paper: FitOptions
    kernel: int
    flat_length: Callable[[], float]
    min_load: float = 0.05


def _median(v) -> float:
    v = [float(a) for a in v if math.isfinite(float(a))]
    return float(np.median(v)) if v else math.nan


class Variant:
    """One variant of Eq. (4): how it is fitted, reported and used for prediction.

    Attributes
    ----------
    name : str
        Its name on the command line and in the outputs.
    title : str
        A heading for people.
    family : str
        The kind of physics it assumes (``'load-sharing'``, ``'constant-pressure'``,
        ``'interlocking'``): a world of the simulator of the same name is this family's.
    note : str
        One sentence: what it assumes and what it is for.
    footing : str
        How measurement and model are put on one footing.
    complexity : int
        Free weights per trial; of two variants that the data support equally, the one
        with fewer is chosen (:mod:`fingerfriction.fit.select`).
    selectable : bool
        Whether ``--model auto`` may choose it (it gives ``mu`` with a confidence interval).
    params_type : type
        The parameters of its predictions: :class:`~fingerfriction.model.LoadParams` (the
        pressure carries a normal force) or :class:`~fingerfriction.model.FrictionParams`
        (a constant pressure).
    """

    name = ""
    title = ""
    family = ""
    note = ""
    footing = "absolute (drift removed on the unloaded rests only; no detrend of either)"
    complexity = 1
    selectable = True
    params_type: type = LoadParams

    # -- fitting -------------------------------------------------------------------------
    def fit(self, trials: Sequence[Trial], settings: FitSettings) -> dict:
        """Fit every subject of ``trials``: subject -> subject fit (with ``.trials``)."""
        raise NotImplementedError

    def flags(self, fits: dict) -> list[FitFlag]:
        """Every flag of the fit (subject and trial level)."""
        return [f for sf in fits.values() for f in sf.flags]

    @staticmethod
    def mu_ci(sf) -> tuple[float, float]:
        """Confidence interval of a subject's ``mu`` (NaN when the variant has none)."""
        return tuple(getattr(sf, "mu_ci", (math.nan, math.nan)))

    # -- outputs -------------------------------------------------------------------------
    def trial_row(self, tf) -> dict:
        """The parameters of one trial fit for ``fit/trials.csv``."""
        return {"mu": tf.mu, "p0": tf.p0_mean, "p1": tf.p1, "p1_se": tf.p1_se,
                "push_up": tf.push_up, "push_up_se": tf.push_up_se, "push_down": tf.push_down,
                "push_down_se": tf.push_down_se, "inset_mm": tf.inset,
                "kappa_per_mm": tf.kappa, "footing": tf.footing, "objective": tf.objective}

    def subject_row(self, sf) -> dict:
        """The parameters of one subject fit for ``fit/subjects.csv``."""
        lo, hi = self.mu_ci(sf)
        return {"mu": sf.mu, "mu_lo": lo, "mu_hi": hi, "inset_mm": sf.inset, "kappa_per_mm": sf.kappa,
                "transient_mm": sf.flat.transient_mm if sf.flat is not None else math.nan}

    def record(self, fits: dict) -> dict:
        """This variant's part of ``fit/fit.json`` (besides its note, CPU time, mu, success)."""
        return {"mu_ci": {s: list(self.mu_ci(sf)) for s, sf in fits.items()},
                "mu_trials": {s: (sf.flat.mu_trials if sf.flat else {}) for s, sf in fits.items()},
                "transient_mm": {s: (sf.flat.transient_mm if sf.flat else math.nan)
                                 for s, sf in fits.items()},
                "inset_mm": {s: sf.inset for s, sf in fits.items()},
                "kappa_per_mm": {s: sf.kappa for s, sf in fits.items()},
                "fitted": {s: list(sf.fitted) for s, sf in fits.items()},
                "p1_median": {s: _median([t.p1 for t in sf.trials if t.success]) for s, sf in fits.items()}}

    def columns(self, tf, trial: Trial, model: FrictionModel) -> dict:
        """Per-position series of one trial fit for ``fit/model/<trial>.parquet`` (N, N/mm):
        ``F_T_N`` and ``F_hat_N`` as compared, ``F_model_N``, ``F_int_N``, ``F_def_N``."""
        return {"F_T_N": tf.measured, "F_hat_N": tf.estimate, "F_model_N": tf.estimate,
                "F_int_N": tf.interfacial, "F_def_N": tf.deformation, "p0_N_per_mm": tf.pressure}

    def summary(self, sf) -> str:
        """A subject's parameters in one line (the console)."""
        lo, hi = self.mu_ci(sf)
        p1 = _median([t.p1 for t in sf.trials if t.success])
        return (f"mu = {sf.mu:.4f} (95 % CI {lo:.4f}-{hi:.4f}), load-bearing inset {sf.inset:.2f} mm, "
                f"pressure rise {sf.kappa:.2f}/mm, p1 median {p1:.3g} N/mm")

    # -- prediction ----------------------------------------------------------------------
    def params_for(self, sf, ok: list):
        """A subject's parameters for a trial it has no fit of (a held-out surface, a
        prediction): its own ``mu`` and contact, the medians of its trials' weights."""
        raise NotImplementedError

    def params_from_record(self, rec: dict, rows, key: str):
        """The same from ``fit/fit.json`` (``rec``: this variant's part) and this variant's
        successful rows of ``fit/trials.csv`` for subject ``key`` (a DataFrame)."""
        raise NotImplementedError

    def heldout_series(self, t: Trial, fwd: np.ndarray, params, model: FrictionModel, ctx: HeldOut) -> dict:
        """Measured and predicted series of one held-out trial (N): ``m, g`` the prediction
        from the forward model's regions ``fwd`` at the nominal load; ``vm, vg`` the same
        parameters on the trial's video regions (and measured load); ``lm, lg`` the
        forward regions with the trial's measured load (NaN where the variant has no load)."""
        raise NotImplementedError

    @staticmethod
    def row_params(params) -> dict:
        """The parameters of a prediction as columns of the out-of-sample table."""
        d = dataclasses.asdict(params)
        return {"mu": d["mu"], "p0": d.get("p0", math.nan), "p1": d["p1"],
                "push_up": d["push_up"] if d.get("push_up") is not None else math.nan,
                "push_down": d["push_down"] if d.get("push_down") is not None else math.nan,
                "inset_mm": d.get("inset", math.nan), "kappa_per_mm": d.get("kappa", math.nan)}


# ----------------------------------------------------------------------------- the variants


class LoadVariant(Variant):
    name = "load"
    title = "Load-consistent Eq. 4"
    family = "load-sharing"
    note = ("load-consistent Eq. (4): the pressure at each position carries the measured normal force, "
            "mu is measured on flat ground (where Eq. 4 is Amontons' law), the load-bearing contact and "
            "the deformation weight p1 are fitted on absolute forces.")
    complexity = 1
    law = "deformation"

    def fit(self, trials, settings):
        return fit_load_trials(trials, settings.load, law=self.law, name=self.name)

    def params_for(self, sf, ok):
        return LoadParams(sf.mu, _median([f.p1 for f in ok]), sf.inset, sf.kappa)

    def params_from_record(self, rec, rows, key):
        return LoadParams(mu=float(rec["mu"][key]), p1=float(rows["p1"].median()),
                          inset=float(rec["inset_mm"][key]), kappa=float(rec["kappa_per_mm"][key]))

    def heldout_series(self, t, fwd, params, model, ctx):
        meas = t.force_abs if t.has_absolute else t.force
        fn = t.normal_abs if t.has_absolute else ctx.load
        g = load_estimate(model, fwd, ctx.load, params, median_kernel=ctx.kernel)[0]
        lg = load_estimate(model, fwd, fn, params, median_kernel=ctx.kernel)[0]
        vg = load_estimate(model, t.regions, fn, params, median_kernel=ctx.kernel)[0]
        if not t.has_absolute:  # the paper's footing: compare shapes only (rho detrends)
            g, lg, vg = g - np.nanmean(g), lg - np.nanmean(lg), vg - np.nanmean(vg)
        return {"m": meas, "g": g, "vm": meas, "vg": vg, "lm": meas, "lg": lg}


class InterlockVariant(LoadVariant):
    name = "interlock"
    title = "Load-consistent Eq. 4, slope push by direction"
    family = "interlocking"
    note = ("the load-consistent Eq. (4) with the interfacial slope push of Eq. (2) weighed separately on "
            "ascending slopes (push_up: the finger's leading side pressing against rising ground) and "
            "descending ones (push_down: what a viscoelastic finger gives back on falling ground), per "
            "trial, in place of Eq. (3)'s deformation term; both weights 1 is the load variant with p1 = 0.")
    complexity = 2
    law = "push"

    @staticmethod
    def _medians(tfs) -> tuple[float, float]:
        """The median weights of the trials that identify each (a finite standard error);
        1 (Eq. 2's symmetric push) for a direction no trial meets."""
        up = _median([f.push_up for f in tfs if math.isfinite(f.push_up_se)])
        down = _median([f.push_down for f in tfs if math.isfinite(f.push_down_se)])
        return 1.0 if math.isnan(up) else up, 1.0 if math.isnan(down) else down

    def params_for(self, sf, ok):
        up, down = self._medians(ok)
        return LoadParams(sf.mu, 0.0, sf.inset, sf.kappa, push_up=up, push_down=down)

    def params_from_record(self, rec, rows, key):
        def med(col):
            if col not in rows or col + "_se" not in rows:
                raise ValueError(f"fit/trials.csv has no column {col!r} for the {self.name} variant: the fit "
                                 "was made by another version; run fingerfriction fit again")
            v = rows.loc[np.isfinite(rows[col + "_se"].astype(float)), col].astype(float)
            return float(v.median()) if len(v) else 1.0

        return LoadParams(mu=float(rec["mu"][key]), p1=0.0, inset=float(rec["inset_mm"][key]),
                          kappa=float(rec["kappa_per_mm"][key]), push_up=med("push_up"),
                          push_down=med("push_down"))

    def record(self, fits):
        rec = super().record(fits)
        for name in ("push_up", "push_down"):
            rec[f"{name}_median"] = {s: _median([getattr(t, name) for t in sf.trials
                                                 if t.success and math.isfinite(getattr(t, name + "_se"))])
                                     for s, sf in fits.items()}
        return rec

    def summary(self, sf):
        up, down = self._medians([t for t in sf.trials if t.success])
        lo, hi = self.mu_ci(sf)
        return (f"mu = {sf.mu:.4f} (95 % CI {lo:.4f}-{hi:.4f}), load-bearing inset {sf.inset:.2f} mm, "
                f"pressure rise {sf.kappa:.2f}/mm, slope push medians {up:.3g} (ascending), {down:.3g} "
                "(descending)")


class PressureVariant(Variant):
    name = "pressure"
    title = "Constant-pressure Eq. 4, absolute"
    family = "constant-pressure"
    note = ("Eq. (4) as printed with one constant pressure p0 per trial, on the absolute forces: mu measured "
            "on flat ground (with its CI), p0 from the trial's flat-ground load, p1 per trial; the pressure "
            "stays at its flat-ground value over the feature whatever the measured normal force does.")
    complexity = 1
    params_type = FrictionParams

    def fit(self, trials, settings):
        return fit_pressure_trials(trials, settings.load)

    def record(self, fits):
        rec = super().record(fits)
        rec["p0_median"] = {s: _median([t.p0_mean for t in sf.trials if t.success]) for s, sf in fits.items()}
        return rec

    def summary(self, sf):
        lo, hi = self.mu_ci(sf)
        p0 = _median([t.p0_mean for t in sf.trials if t.success])
        p1 = _median([t.p1 for t in sf.trials if t.success])
        return (f"mu = {sf.mu:.4f} (95 % CI {lo:.4f}-{hi:.4f}), p0 median {p0:.3g} N/mm, "
                f"p1 median {p1:.3g} N/mm")

    def params_for(self, sf, ok):
        return FrictionParams(sf.mu, _median([f.p0_mean for f in ok]), _median([f.p1 for f in ok]))

    def params_from_record(self, rec, rows, key):
        return FrictionParams(mu=float(rec["mu"][key]), p0=float(rows["p0"].median()),
                              p1=float(rows["p1"].median()))

    def heldout_series(self, t, fwd, params, model, ctx):
        def est(regions, p0):
            coef = T_matrix(params.mu) @ np.array([p0, params.p1])
            return median_filter(model.integrals(regions), ctx.kernel) @ coef

        own = self._own_p0(t, model, ctx.min_load)  # the trial's load: its flat-ground pressure
        own = own if math.isfinite(own) else params.p0  # no flat ground seen whole: the training's
        g = est(fwd, params.p0)
        if not t.has_absolute:  # the paper's footing: compare shapes only (rho detrends)
            vg = est(t.regions, params.p0)
            return {"m": t.force, "g": g - g.mean(), "vm": t.force, "vg": vg - vg.mean(), "lm": t.force,
                    "lg": np.full(t.n, np.nan)}
        vg = est(t.regions, own)
        if t.clipped is not None:  # the camera cut the contact: the video regions are not the contact
            vg = np.where(t.clipped, np.nan, vg)
        return {"m": t.force_abs, "g": g, "vm": t.force_abs, "vg": vg, "lm": t.force_abs, "lg": est(fwd, own)}

    @staticmethod
    def _own_p0(t: Trial, model: FrictionModel, min_load: float) -> float:
        """A trial's flat-ground pressure in N/mm (as the fit measures it), NaN without one."""
        if not t.has_absolute:
            return math.nan
        flat = flat_segment_mask(t.regions, t.surface) & (t.normal_abs >= min_load)
        if t.clipped is not None:
            flat &= ~t.clipped
        K = model.integrals(t.regions[flat])[:, 1]
        ok = flat.sum() >= 2 and np.sum(K) > 0
        return float(np.sum(t.normal_abs[flat]) / np.sum(K)) if ok else math.nan


class PaperVariant(Variant):
    name = "paper"
    title = "The paper's Eq. 4"
    family = "constant-pressure"
    note = ("Eq. (4) as printed: one constant pressure p0 per trial and mu by grid search on the paper's "
            "flat-segment footing; kept to reproduce the paper, never chosen by --model auto: its mu has no "
            "confidence interval and is not identifiable there ((mu, p0, p1) and (p0/p1, p1 mu, p1) give the "
            "same forces), and p0 can turn negative.")
    footing = "detrended (a line fitted on the flat before the feature, subtracted from both)"
    complexity = 2
    selectable = False
    params_type = FrictionParams

    def fit(self, trials, settings):
        return fit_trials(trials, grid=settings.grid, method=settings.method, options=settings.paper)

    def flags(self, fits):
        return [f for sf in fits.values() for f in paper_flags(sf)]

    def trial_row(self, tf):
        nan = math.nan
        return {"mu": tf.mu, "p0": tf.p0, "p1": tf.p1, "p1_se": nan, "push_up": nan, "push_up_se": nan,
                "push_down": nan, "push_down_se": nan, "inset_mm": nan, "kappa_per_mm": nan,
                "footing": "flat", "objective": tf.objective}

    def subject_row(self, sf):
        nan = math.nan
        return {"mu": sf.mu, "mu_lo": nan, "mu_hi": nan, "inset_mm": nan, "kappa_per_mm": nan,
                "transient_mm": nan}

    def record(self, fits):
        return {"p0_median": {s: _median([t.p0 for t in sf.trials if t.success]) for s, sf in fits.items()},
                "p1_median": {s: _median([t.p1 for t in sf.trials if t.success]) for s, sf in fits.items()},
                "curves": {s: {"grid": sf.grid, "objective": sf.curve} for s, sf in fits.items()}}

    def columns(self, tf, trial, model):
        # Eq. (2)-(4) with the fitted p0, p1 as they are (FrictionParams would refuse the
        # unphysical p0 < 0 of a failed fit; its row in trials.csv says it failed).
        B = model.basis(trial.regions, tf.mu)
        return {"F_T_N": tf.measured, "F_hat_N": tf.estimate, "F_model_N": tf.p0 * B[:, 0] + tf.p1 * B[:, 1],
                "F_int_N": tf.p0 * B[:, 0], "F_def_N": tf.p1 * B[:, 1]}

    def summary(self, sf):
        return f"mu = {sf.mu:.3f} (grid search), p0 median {_median([t.p0 for t in sf.trials]):.3g} N/mm"

    def params_for(self, sf, ok):
        return FrictionParams(sf.mu, float(np.median([f.p0 for f in ok])),
                              float(np.median([f.p1 for f in ok])))

    def params_from_record(self, rec, rows, key):
        return FrictionParams(mu=float(rec["mu"][key]), p0=float(rows["p0"].median()),
                              p1=float(rows["p1"].median()))

    def heldout_series(self, t, fwd, params, model, ctx):
        # The measured force on the paper's footing (drift-corrected, near zero on flat
        # ground) and the prediction minus its exact flat-ground level mu p0 L_flat (module
        # notes of fingerfriction.pipeline.validation).
        opts = ctx.paper
        flat_level = params.mu * params.p0 * ctx.flat_length() if opts.detrend else 0.0
        m = np.asarray(t.force, dtype=float)
        g = _paper_estimate(model, fwd, params, opts) - flat_level
        mask = flat_segment_mask(t.regions, t.surface, margin=opts.flat_margin)

        def footing(y):
            return flat_detrend(t.x, y, mask) if opts.detrend else np.asarray(y, dtype=float)

        vm, vg = footing(t.force), _paper_estimate(model, t.regions, params, opts, footing)
        return {"m": m, "g": g, "vm": vm, "vg": vg, "lm": m, "lg": np.full(m.shape, np.nan)}


def _paper_estimate(model: FrictionModel, regions: np.ndarray, params: FrictionParams, options,
                    footing=np.asarray) -> np.ndarray:
    """The paper model's Eq. (4) in N for fixed parameters, processed as its fit processes
    it (``fit.paper._Design.estimate``): the median filter on the per-frame integrals S, K,
    Q ('basis' mode) or on the force ('estimate' mode), and ``footing`` (a linear map of a
    series, e.g. the flat detrend) where the fit applies it."""
    raw = model.integrals(regions)  # S, K, Q (mm)
    coef = T_matrix(params.mu) @ np.array([params.p0, params.p1])
    if options.median_on == "basis":
        return footing(median_filter(raw, options.median_kernel)) @ coef
    return footing(median_filter(raw @ coef, options.median_kernel))


#: The registry: name -> variant, in the order tables show them.
VARIANTS: dict[str, Variant] = {v.name: v for v in (LoadVariant(), PressureVariant(), InterlockVariant(),
                                                   PaperVariant())}
#: Every variant's name.
MODELS: tuple[str, ...] = tuple(VARIANTS)
#: The variants ``--model auto`` may choose.
SELECTABLE: tuple[str, ...] = tuple(n for n, v in VARIANTS.items() if v.selectable)


def get(name: str) -> Variant:
    """The variant called ``name``; ``ValueError`` naming the known ones otherwise."""
    return VARIANTS[check_option("model", name, MODELS)]


def variant_of_params(params) -> Variant:
    """The variant a set of prediction parameters belongs to (LoadParams: load or
    interlock; FrictionParams: the constant pressure of the paper's Eq. 4)."""
    if isinstance(params, LoadParams):
        return VARIANTS["interlock" if params.split_push else "load"]
    if isinstance(params, FrictionParams):
        return VARIANTS["paper"]
    raise TypeError(f"params must be LoadParams or FrictionParams, got {type(params).__name__}")
