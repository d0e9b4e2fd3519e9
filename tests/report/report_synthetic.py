"""A synthetic results folder (no video, no Dask): what `analyze` would write for trials
whose contact regions and forces come from Eq. (4) with known parameters."""

from __future__ import annotations

import json

import numpy as np

from fingerfriction.model import FrictionModel, FrictionParams, friction_force
from fingerfriction.study.results import AnalysedTrial
from fingerfriction.study.store import ResultsStore, frames_table
from fingerfriction.surfaces import get_surface

SUBJECTS = {"1": 0.55, "2": 0.60}
SURFACES = ("bump-2mm", "step-down-4mm")
SPEEDS = (40.0, 120.0)
REPS = 2


def _regions(x: np.ndarray, gap: tuple[float, float]) -> np.ndarray:
    """Contact [x - 4, x + 4] mm with the interval ``gap`` never touched."""
    reg = np.full((x.size, 2, 2), np.nan)
    for k, xc in enumerate(x):
        lo, hi = xc - 4.0, xc + 4.0
        segs = []
        if lo < gap[0]:
            segs.append((lo, min(hi, gap[0])))
        if hi > gap[1]:
            segs.append((max(lo, gap[1]), hi))
        for i, s in enumerate(segs):
            reg[k, i] = s
    return reg


def _forward(sname: str, subj: str, xg: np.ndarray) -> np.ndarray:
    """The forward model's geometric regions of the subject's default finger on the grid."""
    from fingerfriction.mechanics import SUBJECTS as FINGERS
    from fingerfriction.predict import forward_regions

    key = (sname, subj)
    if key not in _FORWARD:
        _FORWARD[key] = forward_regions(get_surface(sname), FINGERS[int(subj)], xg)
    return _FORWARD[key]


_FORWARD: dict = {}


def write_synthetic_results(root, *, truth_dir=None, seed: int = 0, subjects: dict | None = None,
                            transient_mm: float | None = None, regions: str = "toy",
                            force_law: str = "eq4", speeds: tuple = SPEEDS) -> dict:
    """Write a results folder; return the true per-trial parameters and blind spots.

    ``subjects`` (subject -> mu) defaults to :data:`SUBJECTS`, ``speeds`` (mm/s) to
    :data:`SPEEDS`. ``transient_mm``: add to the
    absolute tangential force the start transient real slides show (a friction ratio 0.15
    higher at the window's start, decaying over this length in mm). ``regions``: ``'toy'``
    (contact [x - 4, x + 4] mm with a gap never touched: the blind spots of ``truth``) or
    ``'forward'`` (the forward contact model's, with the subject's default finger, so that
    the leave-one-surface-out prediction from geometry sees the same contact as the fit:
    a study whose model passes the fit's bars). ``force_law``: ``'eq4'`` (Eq. 4 with known
    parameters) or ``'unrelated'`` (the flat-ground level of Eq. 4 plus a slow random
    force that has nothing to do with the surface: no variant explains it).
    """
    rng = np.random.default_rng(seed)
    rng_abs = np.random.default_rng(seed + 1000)  # the absolute footing's own draws
    store = ResultsStore(root)
    trials, truth = [], {"gaps": {}, "p": {}}
    subjects = SUBJECTS if subjects is None else subjects
    for subj, mu in subjects.items():
        for sname in SURFACES:
            surf = get_surface(sname)
            a, _ = surf.feature_extent
            gap = (a - 0.5, a + 0.2)
            truth["gaps"][sname] = gap
            for v in speeds:
                for r in range(1, REPS + 1):
                    tid = f"s{subj}-{sname}-v{int(v):03d}-r{r}"
                    t = np.arange(0.0, 34.0 / v, 1e-3)
                    x = -17.0 + v * t
                    x[0] = np.nan  # calibration frame: no finger
                    xg = np.round(np.arange(-13.0, 13.0 + 1e-9, 0.01), 2)
                    if regions == "forward":
                        near = np.clip(np.rint((np.nan_to_num(x, nan=-17.0) + 13.0) / 0.01).astype(int), 0,
                                       xg.size - 1)
                        reg = _forward(sname, subj, xg)[near]
                    else:
                        reg = _regions(np.nan_to_num(x, nan=-17.0), gap)
                    reg[0] = np.nan
                    flags = ["no finger"] + [""] * (t.size - 1)
                    frames = frames_table(t, x, reg, flags)
                    p = FrictionParams(mu, 0.05 * (1 + 0.1 * rng.standard_normal()), 0.3)
                    truth["p"][tid] = p
                    xv, rv = x[1:], reg[1:]
                    idx = np.clip(np.searchsorted(xv, xg), 0, xv.size - 1)
                    F_abs = friction_force(surf, rv[idx], p).total
                    if force_law == "unrelated":
                        walk = np.convolve(rng.standard_normal(xg.size + 400), np.hanning(401), "valid")
                        F_abs = F_abs[:200].mean() + 0.02 * walk / walk.std()
                    F = F_abs - F_abs[:200].mean() + 0.002 * rng.standard_normal(xg.size)
                    import pandas as pd

                    # the absolute footing: the same force with its flat level, and the normal
                    # force of the same constant pressure (the vertical resultant of Eq. 2)
                    S, K, _ = FrictionModel(surf).integrals(rv[idx]).T
                    F_N = p.p0 * (K - mu * S) + 0.001 * rng_abs.standard_normal(xg.size)
                    F_T_abs = F + F_abs[:200].mean()
                    if transient_mm:
                        F_T_abs = F_T_abs + 0.15 * F_N * np.exp(-(xg - xg[0]) / transient_mm)
                    forces = pd.DataFrame({"x_mm": xg, "F_T_N": F, "F_N_N": np.full(xg.size, 0.0),
                                           "F_T_abs_N": F_T_abs, "F_N_abs_N": F_N,
                                           "n_samples": np.ones(xg.size, dtype=np.int64)})
                    store.write_trial(AnalysedTrial.from_tables(
                        tid, frames, forces, {"params_sha256": "synthetic", "inputs": {}, "elapsed_s": 0.0}))
                    trials.append({"id": tid, "subject": subj, "surface": sname, "speed_mm_s": v,
                                   "repetition": r})
    if truth_dir is not None:
        truth_dir.mkdir(parents=True, exist_ok=True)
        (truth_dir / "study.json").write_text(json.dumps(
            {"subjects": {s: {"mu": mu} for s, mu in subjects.items()}}))
    store.write_run({
        "study": str(truth_dir.parent) if truth_dir is not None else "synthetic",
        "parameters": {"video": {"contact_tol_px": 3.0, "position": "hybrid"},
                       "forces": {"notch_hz": [50.0, 150.0, 300.0], "flat_segment_mm": None}},
        "params_sha256": "synthetic",
        "versions": {"fingerfriction": "test"},
        "surfaces": {s: get_surface(s).to_dict() for s in SURFACES},
        "trials": trials,
        "truth": str(truth_dir) if truth_dir is not None else None,
    })
    return truth
