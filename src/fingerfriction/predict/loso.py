"""Out-of-sample validation: leave one surface out, fit on the others, predict the held-out
surface from its geometry alone (no video), rho next to the in-sample Table 1.

:func:`leave_one_surface_out` works on per-trial data; :func:`validate_results` on an
analysed study's results store (the trials read as the fit reads them).
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .._atomic import atomic_write
from ..fit import FitOptions, Trial, fit_trials, flat_detrend, flat_segment_mask, median_filter
from ..model import FrictionModel, FrictionParams
from ..stats import BOTH, correlation_table, ensemble_correlation
from ..study.store import ResultsStore
from ..surfaces import Surface
from .forward import DEFAULT_LOAD_N, _finger_for_label, _flat_length_kind, check_profile, forward_regions

__all__ = ["OutOfSample", "leave_one_surface_out", "trials_from_results", "validate_results"]

log = logging.getLogger(__name__)


def _compared_estimate(surface: Surface, x: np.ndarray, force: np.ndarray, regions: np.ndarray,
                       params: FrictionParams, options, model: FrictionModel | None = None):
    """Measured and model series as the fit compares them (fit.py's processing), for fixed
    parameters: median filter on the per-frame integrals S, K, Q, then the same linear
    detrend over the flat segment defined by ``regions`` applied to both."""
    model = model or FrictionModel(surface)
    b0 = model.basis(regions, 0.0)
    b1 = model.basis(regions, 1.0)
    raw = np.column_stack([b0[:, 0], b1[:, 0] - b0[:, 0], b0[:, 1]])  # S, K, Q (mm)
    if getattr(options, "detrend", True):
        mask = flat_segment_mask(regions, surface, margin=options.flat_margin)

        def footing(y):
            return flat_detrend(x, y, mask)
    else:  # absolute forces (FitOptions.detrend=False)
        def footing(y):
            return np.asarray(y, dtype=float)
    mu = params.mu
    T = np.array([[1.0, mu], [mu, 0.0], [0.0, 1.0]])
    p = np.array([params.p0, params.p1])
    if options.median_on == "basis":
        est = footing(median_filter(raw, options.median_kernel)) @ (T @ p)
    else:
        est = footing(median_filter(raw @ (T @ p), options.median_kernel))
    return footing(force), est


def _predicted_estimate(surface: Surface, force: np.ndarray, regions: np.ndarray, params: FrictionParams,
                        options, flat_level: float, model: FrictionModel):
    """Measured force as given and the prediction minus its flat-ground level (N); the
    model is median-filtered like the fit's (per-frame integrals S, K, Q in 'basis' mode)."""
    b0 = model.basis(regions, 0.0)
    b1 = model.basis(regions, 1.0)
    raw = np.column_stack([b0[:, 0], b1[:, 0] - b0[:, 0], b0[:, 1]])  # S, K, Q (mm)
    mu = params.mu
    T = np.array([[1.0, mu], [mu, 0.0], [0.0, 1.0]])
    p = np.array([params.p0, params.p1])
    if options.median_on == "basis":
        est = median_filter(raw, options.median_kernel) @ (T @ p)
    else:
        est = median_filter(raw @ (T @ p), options.median_kernel)
    if not getattr(options, "detrend", True):  # absolute forces: keep the flat level
        flat_level = 0.0
    return np.asarray(force, dtype=float), est - flat_level


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

    def write_figure(self, path: str | os.PathLike) -> str:
        """PNG: per held-out surface and subject, measured (grey) and predicted (blue)
        forces of every held-out trial as compared (N), with rho in and out of sample."""
        import matplotlib  # heavy, and only needed for the figure

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt  # heavy, and only needed for the figure

        keys = sorted(self.estimates, key=lambda k: (str(k[1]), str(k[0])))
        surfaces = list(dict.fromkeys(k[1] for k in keys))
        subjects = sorted({k[0] for k in keys})
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


def leave_one_surface_out(trials, *, fingers=None, grid=None, options=None, load: float = DEFAULT_LOAD_N,
                          forward_step: float = 0.01, contact: str = "geometric") -> OutOfSample:
    """Out-of-sample validation: fit on all surfaces but one, predict the held-out one.

    For each surface ``s`` of the study: ``mu`` per subject (grid search) and ``p0, p1``
    per trial are fitted on the trials of the *other* surfaces
    (:func:`fingerfriction.fit.fit_trials`); the held-out trials are then predicted from
    the geometry of ``s`` alone: forward-model contact regions along the trial's finger
    positions (no video) into Eq. (4) with the subject's ``mu`` and the **median** of its
    training trials' ``p0`` and ``p1`` (a held-out trial cannot have its own ``p0, p1``:
    fitting them would need its contact, i.e. its video). Measured and predicted forces
    are correlated per condition as in Table 1
    (:func:`fingerfriction.stats.ensemble_correlation`, which detrends every trial).

    How the two are put on the same footing: the measured force is taken as the
    analysis delivers it (drift-corrected, near zero on flat ground); the prediction is
    Eq. (4) on the forward regions, median-filtered like the fit's basis, minus its exact
    flat-ground level ``mu p0 L_flat`` (forward model on flat ground). The fit's own
    footing, a line fitted over the positions where all contact lies before the feature,
    is not used for the prediction: with the forward finger that stretch can be empty or a
    fraction of a millimetre (the 70 um contact reaches a raised feature several mm ahead
    of the finger), which either fails or extrapolates a meaningless line into the
    predicted series. (rho itself does not depend on any linear footing: the Table 1
    correlation detrends every trial linearly; the footing matters for the series that
    are stored and plotted.) The ``rho_heldout_params_video`` column keeps the fit's
    footing (video regions and their flat segment).

    Parameters
    ----------
    trials : sequence of fingerfriction.fit.Trial
        Per-trial data: finger positions ``x`` (mm), measured drift-corrected ``F_T``
        (N), video contact regions (used for fitting only), surface, subject.
    fingers : dict, optional
        Subject label -> FingerParams (or 1/2) of the forward model. Default: the digits
        of the label ('S1', '1') select :data:`fingerfriction.mechanics.SUBJECTS`.
    grid : array_like, optional
        ``mu`` grid (default :func:`fingerfriction.fit.mu_grid`).
    options : fingerfriction.fit.FitOptions, optional
    load : float
        Normal force in N of the forward model.
    forward_step : float
        Finger step in mm of the forward sweeps; trial positions take the regions of the
        nearest sweep position (exact when trials are on the same 0.01 mm grid).
    contact : {'geometric', 'mechanical'}
        Forward-model contact definition (default geometric, as the fitted regions).

    Returns
    -------
    OutOfSample

    Notes
    -----
    Eq. (4) is exactly invariant under ``(mu, p0, p1) -> (p0/p1, p1 mu, p1)``: expanding
    ``p0 (S + mu K) + p1 (Q + mu S)`` gives the coefficients ``(p0 + p1 mu, p0 mu, p1)``
    of ``(S, K, Q)``, which both parameter sets share. When ``p0/p1`` falls inside the
    ``mu`` grid the grid search has two equally good minima; the subject's ``mu`` (and
    with it ``p0``) is then not identifiable from forces alone, although the predicted
    forces are the same either way.
    """
    trials = list(trials)
    for i, t in enumerate(trials):
        if not isinstance(t, Trial):
            raise TypeError(f"trials[{i}] must be a fingerfriction.fit.Trial, got {type(t).__name__}")
    options = options or FitOptions()
    surfaces: dict[str, Surface] = {}
    for t in trials:
        surfaces.setdefault(t.surface.name, t.surface)
    if len(surfaces) < 2:
        raise ValueError(f"leave-one-surface-out needs trials on at least 2 surfaces, got {sorted(surfaces)}")
    subjects = sorted({t.subject for t in trials})
    for s in subjects:
        _finger_for_label(s, fingers)  # fail early on an unmappable subject
    for surf in surfaces.values():
        check_profile(surf)

    in_sample = correlation_table(fit_trials(trials, grid=grid, options=options))
    ins = {(r.subject, r.scale, r.shape): (r.rho, r.p) for r in in_sample.itertuples()}

    rows = []
    estimates: dict = {}
    for name, surf in surfaces.items():
        train = [t for t in trials if t.surface.name != name]
        test = [t for t in trials if t.surface.name == name]
        train_subjects = {t.subject for t in train}
        fits = fit_trials(train, grid=grid, options=options)
        model = FrictionModel(surf)
        pooled_m, pooled_g, pooled_v, pooled_vm = [], [], [], []
        for subj in sorted({t.subject for t in test}):
            ttest = [t for t in test if t.subject == subj]
            if subj not in train_subjects:
                raise ValueError(f"subject {subj!r} has trials only on {name!r}: nothing to train on")
            sf = fits[subj]
            ok = [f for f in sf.trials if f.success]
            if not ok:
                raise RuntimeError(f"no successful training fit for subject {subj!r} without {name!r}")
            params = FrictionParams(sf.mu, float(np.median([f.p0 for f in ok])),
                                    float(np.median([f.p1 for f in ok])))
            finger = _finger_for_label(subj, fingers)
            lo = min(float(t.x[0]) for t in ttest)
            hi = max(float(t.x[-1]) for t in ttest)
            xs = lo + forward_step * np.arange(int(math.ceil((hi - lo) / forward_step - 1e-9)) + 1)
            fwd = forward_regions(surf, finger, xs, load=load, contact=contact)
            flat_level = params.mu * params.p0 * _flat_length_kind(finger, float(load), contact)
            meas, pred, vmeas, vpred, per = [], [], [], [], []
            for t in ttest:
                idx = np.clip(np.rint((t.x - lo) / forward_step).astype(int), 0, xs.size - 1)
                m, g = _predicted_estimate(surf, t.force, fwd[idx], params, options, flat_level, model)
                vm, vg = _compared_estimate(surf, t.x, t.force, t.regions, params, options, model)
                meas.append(m)
                pred.append(g)
                vmeas.append(vm)
                vpred.append(vg)
                per.append((t.x, m, g))
            estimates[(subj, name)] = per
            pooled_m += meas
            pooled_g += pred
            pooled_v += vpred
            pooled_vm += vmeas
            rows.append(_loso_row(subj, surf, ttest, ins, ensemble_correlation(meas, pred),
                                  ensemble_correlation(vmeas, vpred), params))
        rows.append(_loso_row(BOTH, surf, test, ins, ensemble_correlation(pooled_m, pooled_g),
                              ensemble_correlation(pooled_vm, pooled_v), None))
    table = pd.DataFrame(rows)
    # Table 1's order: subjects then both pooled; scale; Bump, Step Up, Step Down.
    sub_order = {s: i for i, s in enumerate(subjects + [BOTH])}
    shape_order = {"Bump": 0, "Step Up": 1, "Step Down": 2}
    key = table.apply(lambda r: (sub_order[r.subject], r.scale_mm, shape_order.get(r["shape"], 9), r.surface),
                      axis=1)
    table = table.iloc[sorted(range(len(table)), key=lambda i: key.iloc[i])].reset_index(drop=True)
    return OutOfSample(table=table, estimates=estimates)


def _loso_row(subject, surf: Surface, trials, ins, out, video, params) -> dict:
    t0 = trials[0]
    scale, shape = t0.scale, t0.shape
    rho_in, p_in = ins.get((subject, scale, shape), (math.nan, math.nan))
    return {
        "subject": subject,
        "surface": surf.name,
        "scale": scale,
        "scale_mm": float(getattr(surf, "width", math.nan)),
        "shape": shape,
        "n_trials": len(trials),
        "rho_in_sample": rho_in,
        "p_in_sample": p_in,
        "rho_heldout_params_video": video[0],
        "rho_out_of_sample": out[0],
        "p_out_of_sample": out[1],
        "mu": params.mu if params else math.nan,
        "p0": params.p0 if params else math.nan,
        "p1": params.p1 if params else math.nan,
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
    _, options = store.fit_settings()
    margin = (options or FitOptions()).flat_margin
    trials, skipped = [], []
    for m in store.analysed_trials():
        try:
            trials.append(store.read_fit_trial(m, surfaces, flat_margin=margin)[0])
        except (ValueError, KeyError, OSError) as exc:
            skipped.append((m["id"], str(exc)))
    for tid, why in skipped:
        log.warning("trial %s skipped: %s", tid, why)
    if not trials:
        raise ValueError(f"{os.fspath(results)!r} has no analysed trial to validate")
    return trials


def validate_results(results: str | os.PathLike, *, out: str | os.PathLike | None = None,
                     forward_step: float = 0.01) -> OutOfSample:
    """Leave-one-surface-out validation of an analysed study; writes ``loso.csv``.

    Uses the ``mu`` grid and fit options recorded by ``fingerfriction fit`` in
    ``RESULTS/fit/fit.json`` when present (so ``rho_in_sample`` is the study's Table 1),
    else the defaults. The table goes to ``out`` (default ``RESULTS/fit/loso.csv``) and a
    figure of the held-out trials beside it (``loso.png``).
    This is the function the report calls.
    """
    root = os.fspath(results)
    grid, options = ResultsStore(root).fit_settings()
    res = leave_one_surface_out(trials_from_results(root), grid=grid, options=options,
                                forward_step=forward_step)
    target = os.fspath(out) if out is not None else os.fspath(ResultsStore(root).loso_path)
    os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
    res.write_csv(target)
    res.write_figure(os.path.splitext(target)[0] + ".png")
    return res
