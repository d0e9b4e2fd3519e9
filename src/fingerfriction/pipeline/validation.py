"""Out-of-sample validation: leave one surface out, fit on the others, predict the held-out
surface from its geometry alone (no video), rho next to the in-sample Table 1.

:func:`leave_one_surface_out` works on per-trial data; :func:`validate_results` on an
analysed study's results store (the trials read as the fit reads them).
"""

from __future__ import annotations

import logging
import math
import os
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .._atomic import atomic_write
from .._style import figure_style
from ..fit import FitOptions, LoadFitOptions, Trial
from ..fit.load import load_estimate
from ..fit.select import DEFAULT_MODEL
from ..fit.variants import MODELS as VARIANT_NAMES
from ..fit.variants import FitSettings, HeldOut, get, variant_of_params
from ..model import FrictionModel, LoadParams
from ..model.stats import BOTH, correlation_table, ensemble_correlation
from ..predict.forward import (
    DEFAULT_LOAD_N,
    FORWARD_STEP_MM,
    check_profile,
    finger_for_label,
    flat_length_of_kind,
    forward_regions,
)
from ..study.store import ResultsStore
from ..surfaces import Surface

__all__ = [
    "OutOfSample", "leave_one_surface_out", "trials_from_results", "validate_results", "validate_models",
    "write_validation", "load_prediction",
]

log = logging.getLogger(__name__)


def load_prediction(model: FrictionModel, regions: np.ndarray, f_n, params: LoadParams, *,
                    median_kernel: int = 11) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The load-consistent Eq. (4) along a sweep, processed as the fit processes its model
    (:func:`fingerfriction.fit.load.load_estimate`): ``(total, interfacial, deformation)``
    in N, NaN where the load-bearing contact is empty."""
    return load_estimate(model, regions, f_n, params, median_kernel=median_kernel)


def _finite_pairs(meas: list, pred: list) -> tuple[list, list]:
    """Drop the positions where a prediction is undefined (no load-bearing contact)."""
    out_m, out_p = [], []
    for m, g in zip(meas, pred, strict=True):
        ok = np.isfinite(g) & np.isfinite(m)
        out_m.append(np.asarray(m)[ok])
        out_p.append(np.asarray(g)[ok])
    return out_m, out_p


@dataclass(frozen=True)
class OutOfSample:
    """Result of :func:`leave_one_surface_out`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (subject or "Both subjects", held-out surface): ``subject, surface,
        scale, shape, n_trials, rho_in_sample, p_in_sample, rho_heldout_params_video,
        rho_out_of_sample, p_out_of_sample, mu, p0, p1``. ``rho_in_sample`` is Table 1
        (fit on all six surfaces, per-trial p0 and p1, video regions);
        ``rho_out_of_sample`` is the prediction (fit on the other surfaces, subject-level
        median p0 and p1, forward-model regions, no video); ``rho_heldout_params_video``
        separates the two losses (held-out parameters on the video regions).
        ``mu, p0, p1`` are the subject's training parameters (NaN on the pooled rows).
    estimates : dict
        ``(subject, surface) -> list of (x, measured, predicted)`` per held-out trial, as
        compared (N).
    """

    table: object
    estimates: dict = field(repr=False)

    def write_csv(self, path: str | os.PathLike) -> str:
        """Write :attr:`table` as CSV, atomically; returns the path."""
        p = os.fspath(path)
        atomic_write(p, lambda tmp: self.table.to_csv(tmp, index=False, float_format="%.6g"))
        return p

    @figure_style()
    def write_figure(self, path: str | os.PathLike) -> str:
        """PNG: per held-out surface and subject, measured (grey) and predicted (blue)
        forces of every held-out trial as compared (N), with rho in and out of sample."""
        import matplotlib  # heavy, and only needed for the figure

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt  # heavy, and only needed for the figure

        keys = sorted(self.estimates, key=lambda k: (str(k[1]), str(k[0])))
        surfaces = list(dict.fromkeys(k[1] for k in keys))
        subjects = sorted({k[0] for k in keys})
        if not keys:  # no held-out surface could be predicted: say so instead of an empty grid
            fig, ax = plt.subplots(figsize=(5.2, 1.6))
            ax.axis("off")
            ax.text(0.5, 0.5, "no held-out surface could be predicted\n(no successful training fit; "
                    "see the table's notes)", ha="center", va="center", fontsize=9)
            p = os.fspath(path)
            atomic_write(p, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
            plt.close(fig)
            return p
        size = (2.6 * len(surfaces), 2.2 * len(subjects))
        fig, axes = plt.subplots(len(subjects), len(surfaces), figsize=size, squeeze=False, sharex=True)
        rows = {(r.subject, r.surface): r for r in self.table.itertuples()}
        for i, subj in enumerate(subjects):
            for j, surf in enumerate(surfaces):
                ax = axes[i][j]
                for x, m, g in self.estimates.get((subj, surf), []):
                    ax.plot(x, 1e3 * m, color="0.6", lw=0.6)
                    ax.plot(x, 1e3 * g, color="C0", lw=0.9)
                r = rows.get((subj, surf))
                if r is not None:
                    ax.set_title(f"subject {subj}, {surf}\nrho in {r.rho_in_sample:.2f} / "
                                 f"out {r.rho_out_of_sample:.2f}", fontsize=8)
                ax.tick_params(labelsize=7)
                if j == 0:
                    ax.set_ylabel("F (mN)", fontsize=8)
                if i == len(subjects) - 1:
                    ax.set_xlabel("x (mm)", fontsize=8)
        fig.suptitle("held-out surfaces: measured (grey) vs predicted from geometry alone (blue)", fontsize=9)
        fig.tight_layout()
        p = os.fspath(path)
        atomic_write(p, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
        plt.close(fig)
        return p


def leave_one_surface_out(trials, *, model: str = DEFAULT_MODEL, fingers=None, grid=None, options=None,
                          load_options: LoadFitOptions | None = None, load: float = DEFAULT_LOAD_N,
                          forward_step: float = FORWARD_STEP_MM, contact: str = "geometric",
                          forward_cache: dict | None = None, in_sample=None,
                          heldout_fingers: dict | None = None,
                          settings: FitSettings | None = None) -> OutOfSample:
    """Out-of-sample validation: fit on all surfaces but one, predict the held-out one.

    For each surface ``s`` of the study the model is fitted on the trials of the *other*
    surfaces, then the held-out trials are predicted from the geometry of ``s`` alone:
    forward-model contact regions along the trial's finger positions (no video) with the
    subject's parameters. A held-out trial cannot have its own per-trial parameter (that
    would need its contact, i.e. its video), so the subject's **median** over its training
    trials is used. Measured and predicted forces are correlated per condition as in
    Table 1 (:func:`fingerfriction.model.stats.ensemble_correlation`, which detrends every trial).

    ``model='load'`` (default): the load-consistent Eq. (4) (:mod:`fingerfriction.model`)
    with the subject's flat-ground ``mu``, load-bearing inset and pressure rise with height, and the
    median ``p1``; the pressure comes from the **nominal load** (``load``, the prescribed
    0.3 N), as for any surface never recorded. Measured and predicted forces are both on
    the absolute footing. Two more columns separate the losses: the same prediction with
    the trial's measured normal force (``rho_out_of_sample_measured_load``), and the
    training parameters on the trial's own video regions with its measured normal force
    (``rho_heldout_params_video``).

    ``model='interlock'``: the same with the median slope-push weights of the ascending
    and the descending slopes. ``model='pressure'``: Eq. (4) with the constant pressure, on the
    absolute footing, with the subject's flat-ground ``mu`` and the median ``p0, p1``.

    ``model='paper'``: Eq. (4) as printed, ``mu`` by grid search and the median ``p0, p1``
    (:func:`fingerfriction.fit.fit_trials`). The measured force is taken on the paper's
    footing (drift-corrected, near zero on flat ground) and the prediction minus its exact
    flat-ground level ``mu p0 L_flat`` (forward model on flat ground): the fit's own footing,
    a line over the positions where all contact lies before the feature, can be empty or a
    fraction of a millimetre with the forward finger, whose 70 um contact reaches a raised
    feature several mm ahead (rho itself does not depend on any linear footing).

    Parameters
    ----------
    trials : sequence of fingerfriction.fit.Trial
        Per-trial data: finger positions ``x`` (mm), measured ``F_T`` (N) on the paper's
        footing and, for the load-consistent model, on the absolute one with ``F_N``;
        video contact regions (used for fitting only), surface, subject.
    model : str
        The model variant (:data:`fingerfriction.fit.variants.MODELS`).
    fingers : dict, optional
        Subject label -> FingerParams (or 1/2) of the forward model. Default: the digits
        of the label ('S1', '1') select :data:`fingerfriction.mechanics.SUBJECTS`.
    grid : array_like, optional
        ``mu`` grid of the paper variant (default :func:`fingerfriction.fit.mu_grid`).
    options : fingerfriction.fit.FitOptions, optional
        Options of the paper variant.
    load_options : fingerfriction.fit.LoadFitOptions, optional
        Options of the load-consistent variant.
    load : float
        Normal force in N of the forward model and of the load-consistent prediction.
    forward_step : float
        Finger step in mm of the forward sweeps; trial positions take the regions of the
        nearest sweep position (exact when trials are on the same 0.01 mm grid).
    contact : {'geometric', 'mechanical'}
        Forward-model contact definition (default geometric, as the fitted regions).
    forward_cache : dict, optional
        Forward sweeps already computed (shared between calls for the two variants).
    in_sample : pandas.DataFrame, optional
        The Table 1 of the same model on all trials (:func:`fingerfriction.model.stats.correlation_table`)
        when the caller has it; computed otherwise.
    heldout_fingers : dict, optional
        Held-out surface name -> {subject label: FingerParams}: the forward-model finger
        that predicts that surface (e.g. calibrated on the other five,
        :func:`fingerfriction.pipeline.finger_calibration.calibrate_held_out`); subjects not
        in it use ``fingers``.
    settings : fingerfriction.fit.variants.FitSettings, optional
        All the fit's settings at once (a fit passes its own); replaces ``grid``,
        ``options`` and ``load_options``.

    Returns
    -------
    OutOfSample
        A subject and surface that cannot be predicted (no successful training fit, or the
        forward model's contact solver failed on the held-out surface) is a row with NaN
        rho and a ``note`` saying why, and its pooled row likewise; the others go on.

    Notes
    -----
    Eq. (4) is exactly invariant under ``(mu, p0, p1) -> (p0/p1, p1 mu, p1)``: expanding
    ``p0 (S + mu K) + p1 (Q + mu S)`` gives the coefficients ``(p0 + p1 mu, p0 mu, p1)``
    of ``(S, K, Q)``, which both parameter sets share. When ``p0/p1`` falls inside the
    ``mu`` grid the paper variant's grid search has two equally good minima; its ``mu``
    (and with it ``p0``) is then not identifiable from forces alone, although the predicted
    forces are the same either way. The load-consistent variant measures ``mu`` on flat
    ground instead, where it is identified.
    """
    variant = get(model)
    trials, surfaces, subjects = _loso_inputs(trials, fingers)
    if settings is None:
        settings = FitSettings(paper=options or FitOptions(), load=load_options or LoadFitOptions(),
                               **({} if grid is None else {"grid": np.asarray(grid, dtype=float)}))

    def fit_all(ts):
        return variant.fit(ts, settings)

    if in_sample is None:
        in_sample = correlation_table(fit_all(trials), n_boot=None)
    ins = {(r.subject, r.scale, r.shape): (r.rho, r.p) for r in in_sample.itertuples()}
    cache = {} if forward_cache is None else forward_cache

    rows = []
    estimates: dict = {}
    for name, surf in surfaces.items():
        train = [t for t in trials if t.surface.name != name]
        test = [t for t in trials if t.surface.name == name]
        train_subjects = {t.subject for t in train}
        fits = fit_all(train)
        fmodel = FrictionModel(surf)
        pooled: dict[str, list] = {"m": [], "g": [], "vm": [], "vg": [], "lm": [], "lg": []}
        unpredicted: list = []
        for subj in sorted({t.subject for t in test}):
            ttest = [t for t in test if t.subject == subj]
            if subj not in train_subjects:
                raise ValueError(f"subject {subj!r} has trials only on {name!r}: nothing to train on")
            sf = fits[subj]
            ok = [f for f in sf.trials if f.success]
            if not ok:  # nothing to predict with: said in the row, the other surfaces go on
                note = f"no successful training fit for subject {subj} without {name}: {sf.message}"
                log.warning("leave-one-surface-out (%s model): %s", model, note)
                rows.append({**_loso_row(model, subj, surf, ttest, ins, {k: [] for k in pooled}, None),
                             "note": note})
                continue
            params = variant.params_for(sf, ok)
            finger = _heldout_finger(subj, name, fingers, heldout_fingers)
            try:
                lo, xs, fwd = _forward_sweep(cache, surf, finger, ttest, load=load, contact=contact,
                                             step=forward_step)
            except RuntimeError as exc:  # the contact solver failed: said in the row, the others go on
                note = f"no prediction for subject {subj} on {name}: {exc}"
                log.warning("leave-one-surface-out (%s model): %s", model, note)
                rows.append({**_loso_row(model, subj, surf, ttest, ins, {k: [] for k in pooled}, params),
                             "note": note})
                unpredicted.append(subj)
                continue
            ctx = HeldOut(load=float(load), paper=settings.paper, kernel=settings.load.median_kernel,
                          flat_length=lambda f=finger: flat_length_of_kind(f, float(load), contact),
                          min_load=settings.load.min_load)
            per, got = [], {k: [] for k in pooled}
            for t in ttest:
                idx = np.clip(np.rint((t.x - lo) / forward_step).astype(int), 0, xs.size - 1)
                series = variant.heldout_series(t, fwd[idx], params, fmodel, ctx)
                for k, v in series.items():
                    got[k].append(v)
                per.append((t.x, series["m"], series["g"]))
            estimates[(subj, name)] = per
            for k in pooled:
                pooled[k] += got[k]
            rows.append(_loso_row(model, subj, surf, ttest, ins, got, params))
        if unpredicted:  # a pooled rho of the other subjects alone would not be the surface's
            rows.append({**_loso_row(model, BOTH, surf, test, ins, {k: [] for k in pooled}, None),
                         "note": f"no pooled prediction: subject {', '.join(unpredicted)} could not be "
                                 "predicted on this surface"})
        else:
            rows.append(_loso_row(model, BOTH, surf, test, ins, pooled, None))
    return OutOfSample(table=_in_table1_order(pd.DataFrame(rows), subjects), estimates=estimates)


def _loso_inputs(trials, fingers) -> tuple[list[Trial], dict[str, Surface], list]:
    """The trials as a list, their surfaces by name (at least two, each a profile the
    forward model takes) and their subjects (each with a finger), checked."""
    trials = list(trials)
    for i, t in enumerate(trials):
        if not isinstance(t, Trial):
            raise TypeError(f"trials[{i}] must be a fingerfriction.fit.Trial, got {type(t).__name__}")
    surfaces: dict[str, Surface] = {}
    for t in trials:
        surfaces.setdefault(t.surface.name, t.surface)
    if len(surfaces) < 2:
        raise ValueError(f"leave-one-surface-out needs trials on at least 2 surfaces, got {sorted(surfaces)}")
    subjects = sorted({t.subject for t in trials})
    for s in subjects:
        finger_for_label(s, fingers)  # fail early on an unmappable subject
    for surf in surfaces.values():
        check_profile(surf)
    return trials, surfaces, subjects


#: Forward sweeps kept in this process across calls (the least recently used dropped beyond
#: this many; each is a few hundred kB): a fit and a later validation of the same trials in
#: one session, or several fits of one study, solve each sweep once.
SWEEP_MEMO_SIZE = 32
_sweep_memo: OrderedDict = OrderedDict()


def _forward_sweep(cache: dict, surf: Surface, finger, trials, *, load: float, contact: str, step: float):
    """``(lo, xs, regions)``: the forward model's sweep over the positions of ``trials``
    (from ``lo`` by ``step`` mm), computed once per surface, finger, load, contact and
    span (kept in ``cache``, and in this process's memo of the last
    :data:`SWEEP_MEMO_SIZE` sweeps; the arrays are read-only). A sweep the contact solver
    failed raises its ``RuntimeError``, kept in ``cache`` and raised again without solving."""
    lo = min(float(t.x[0]) for t in trials)
    hi = max(float(t.x[-1]) for t in trials)
    key = (surf, finger, float(load), contact, round(lo, 9), round(hi, 9), float(step))
    if isinstance(cache.get(key), RuntimeError):  # failed before: the other variants are told at once
        raise cache[key]
    if key not in cache:
        entry = _sweep_memo.get(key)
        if entry is None:
            xs = lo + step * np.arange(int(math.ceil((hi - lo) / step - 1e-9)) + 1)
            try:
                regions = forward_regions(surf, finger, xs, load=load, contact=contact)
            except RuntimeError as exc:
                cache[key] = exc
                raise
            xs.setflags(write=False)
            regions.setflags(write=False)
            entry = _sweep_memo[key] = (xs, regions)
            while len(_sweep_memo) > SWEEP_MEMO_SIZE:
                _sweep_memo.popitem(last=False)
        else:
            _sweep_memo.move_to_end(key)
        cache[key] = entry
    return (lo, *cache[key])


def _heldout_finger(subject, surface: str, fingers, heldout_fingers):
    """``heldout_fingers[surface][subject]`` when given, else the subject's finger."""
    per = (heldout_fingers or {}).get(surface) or {}
    return per[subject] if subject in per else finger_for_label(subject, fingers)


def _in_table1_order(table: pd.DataFrame, subjects: list) -> pd.DataFrame:
    """Table 1's order: subjects then both pooled; scale; Bump, Step Up, Step Down."""
    sub_order = {s: i for i, s in enumerate(subjects + [BOTH])}
    shape_order = {"Bump": 0, "Step Up": 1, "Step Down": 2}
    key = table.apply(lambda r: (sub_order[r.subject], r.scale_mm, shape_order.get(r["shape"], 9), r.surface),
                      axis=1)
    return table.iloc[sorted(range(len(table)), key=lambda i: key.iloc[i])].reset_index(drop=True)


def _rho(meas: list, pred: list) -> tuple[float, float]:
    """Ensemble rho and p over the positions where the prediction is defined (NaN when the
    series are all undefined, e.g. the paper variant has no measured-load prediction)."""
    m, g = _finite_pairs(meas, pred)
    if not m or any(v.size < 3 for v in m):
        return math.nan, math.nan
    return ensemble_correlation(m, g)[:2]


def _loso_row(model: str, subject, surf: Surface, trials, ins, got: dict, params) -> dict:
    t0 = trials[0]
    scale, shape = t0.scale, t0.shape
    rho_in, p_in = ins.get((subject, scale, shape), (math.nan, math.nan))
    out = _rho(got["m"], got["g"])
    nan = math.nan
    return {
        "model": model,
        "subject": subject,
        "surface": surf.name,
        "scale": scale,
        "scale_mm": float(getattr(surf, "width", math.nan)),
        "shape": shape,
        "n_trials": len(trials),
        "rho_in_sample": rho_in,
        "p_in_sample": p_in,
        "rho_heldout_params_video": _rho(got["vm"], got["vg"])[0],
        "rho_out_of_sample": out[0],
        "p_out_of_sample": out[1],
        "rho_out_of_sample_measured_load": _rho(got["lm"], got["lg"])[0],
        **(variant_of_params(params).row_params(params) if params is not None else
           dict.fromkeys(("mu", "p0", "p1", "push_up", "push_down", "inset_mm", "kappa_per_mm"), nan)),
        "note": "",
    }


def trials_from_results(results: str | os.PathLike) -> list:
    """Per-trial data of an analysed study (``fingerfriction analyze`` results folder).

    One :class:`fingerfriction.fit.Trial` per successfully analysed trial, read exactly as
    ``fingerfriction fit`` reads them (:meth:`fingerfriction.study.store.ResultsStore.read_fit_trial`:
    forces on the 0.01 mm grid, video regions mapped onto it, surface from the run record;
    a trial without a flat segment is left out, as by the fit). Trials that cannot be read
    are logged and left out.

    Raises
    ------
    ValueError
        If the folder has no analysed trial.
    """
    store = ResultsStore(results)
    surfaces = store.surfaces()
    fitted = store.read_fit()
    margin = (fitted.settings.paper if fitted is not None else FitOptions()).flat_margin
    trials, skipped = [], []
    for m in store.analysed_trials():
        try:
            trials.append(store.read_fit_trial(m, surfaces, flat_margin=margin))
        except (ValueError, KeyError, OSError) as exc:
            skipped.append((m["id"], str(exc)))
    for tid, why in skipped:
        log.warning("trial %s skipped: %s", tid, why)
    if not trials:
        raise ValueError(f"{os.fspath(results)!r} has no analysed trial to validate")
    return trials


def validate_results(results: str | os.PathLike, *, out: str | os.PathLike | None = None,
                     forward_step: float = FORWARD_STEP_MM, models: tuple[str, ...] | None = None,
                     trials: list | None = None, fingers: dict | None = None,
                     calibrated_fingers: dict | None = None, settings: FitSettings | None = None,
                     in_sample: dict | None = None) -> OutOfSample:
    """Leave-one-surface-out validation of an analysed study; writes ``loso.csv``.

    Validates each model variant of ``models`` (default: the fit's model first, then the
    other variants it fitted; all share the forward-model sweeps), with ``settings`` (the
    fit passes its own, and ``in_sample``, model -> its Table 1) or else the ``mu`` grid
    and the options of the fit the store holds (:meth:`~fingerfriction.study.store.ResultsStore.read_fit`)
    when there is one (so ``rho_in_sample`` is the study's Table 1), else the defaults. The
    table, one block of
    rows per model (column ``model``), goes to ``out`` (default ``RESULTS/fit/loso.csv``)
    and a figure of the first model's held-out trials beside it (``loso.png``). This is
    the function the fit stage and ``fingerfriction validate`` call. ``fingers``
    (subject label -> FingerParams, e.g. from ``calibrate-finger``) replaces the default
    finger of those subjects. ``calibrated_fingers`` (held-out surface -> {subject:
    FingerParams}, each calibrated on the other surfaces) adds the columns
    ``rho_out_of_sample_calibrated_finger`` and ``p_out_of_sample_calibrated_finger``: the
    same validation with those fingers (NaN where a subject has no calibrated finger for
    that surface, e.g. its calibration failed).

    Returns
    -------
    OutOfSample
        ``table`` with the rows of every model; ``estimates`` of the first model.
    """
    root = os.fspath(results)
    store = ResultsStore(root)
    if settings is None:  # a later validation of a fit: the fit's own settings and variants
        fitted = store.read_fit()
        settings = fitted.settings if fitted is not None else FitSettings()
        if models is None and fitted is not None:
            models = fitted.fitted_models
    if models is None:
        models = VARIANT_NAMES
    for m in models:
        get(m)  # an unknown name: ValueError naming the known ones
    trials = trials_from_results(root) if trials is None else trials
    if fingers is not None:  # the other subjects keep their default finger
        fingers = {**{t.subject: finger_for_label(t.subject, None) for t in trials
                      if t.subject not in fingers}, **fingers}
    cache: dict = {}
    by_model = validate_models(trials, models, settings, in_sample=in_sample, fingers=fingers,
                               forward_step=forward_step, forward_cache=cache)
    res = OutOfSample(table=pd.concat([r.table for r in by_model.values()], ignore_index=True),
                      estimates=by_model[models[0]].estimates)
    if calibrated_fingers:
        cal = validate_models(trials, models, settings, in_sample=in_sample, fingers=fingers,
                              forward_step=forward_step, forward_cache=cache,
                              heldout_fingers=calibrated_fingers)
        cal_table = pd.concat([r.table for r in cal.values()], ignore_index=True)
        res = OutOfSample(table=_with_calibrated(res.table, cal_table, calibrated_fingers),
                          estimates=res.estimates)
    write_validation(res, out if out is not None else store.loso_path)
    return res


def validate_models(trials: list, models, settings: FitSettings, *, in_sample: dict | None = None,
                    fingers: dict | None = None, forward_step: float = FORWARD_STEP_MM,
                    forward_cache: dict | None = None,
                    heldout_fingers: dict | None = None) -> dict:
    """:func:`leave_one_surface_out` of each variant of ``models`` on the same trials, sharing
    the forward model's sweeps: variant name -> OutOfSample (in the order of ``models``).
    ``in_sample``: variant name -> its Table 1, when the caller has it."""
    in_sample = in_sample or {}
    cache = {} if forward_cache is None else forward_cache
    return {m: leave_one_surface_out(trials, model=m, fingers=fingers, settings=settings,
                                     forward_step=forward_step,
                                     forward_cache=cache, in_sample=in_sample.get(m),
                                     heldout_fingers=heldout_fingers) for m in models}


def write_validation(res: OutOfSample, path: str | os.PathLike) -> None:
    """``res.table`` as CSV at ``path`` and the figure of ``res.estimates`` beside it (``.png``)."""
    target = os.fspath(path)
    os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
    res.write_csv(target)
    first = res.table["model"].iloc[0] if len(res.table) else None
    OutOfSample(table=res.table[res.table["model"] == first], estimates=res.estimates).write_figure(
        os.path.splitext(target)[0] + ".png")


def _with_calibrated(table: pd.DataFrame, cal: pd.DataFrame, calibrated_fingers: dict) -> pd.DataFrame:
    """``table`` with the out-of-sample rho and p of ``cal`` (the calibrated-finger run) as
    two more columns, and its notes (``note_calibrated_finger``: why a cell has no
    prediction); NaN where a subject (or, pooled, any subject) kept its default finger."""
    key = ["model", "subject", "surface"]
    got = cal.loc[:, key + ["rho_out_of_sample", "p_out_of_sample", "note"]].rename(columns={
        "rho_out_of_sample": "rho_out_of_sample_calibrated_finger",
        "p_out_of_sample": "p_out_of_sample_calibrated_finger", "note": "note_calibrated_finger"})
    out = table.merge(got, on=key, how="left")
    subjects = sorted(set(out["subject"]) - {BOTH})
    cols = ["rho_out_of_sample_calibrated_finger", "p_out_of_sample_calibrated_finger"]
    for i, r in out.iterrows():
        have = calibrated_fingers.get(r["surface"]) or {}
        needed = subjects if r["subject"] == BOTH else [r["subject"]]
        if not all(s in have for s in needed):
            out.loc[i, cols] = math.nan
    return out

