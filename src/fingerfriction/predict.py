"""Predict friction on a surface that was never recorded, and validate it out of sample.

The paper's model, Eq. (4) of Janko, Wiertlewski & Visell 2018, needs the contact regions
``C_i`` of every frame, which the paper measured from video. Here the regions come from
the forward finger-contact model (:mod:`fingerfriction.mechanics`) swept across the
surface, so a relief that exists only as a spec or a CSV profile gets a predicted lateral
force ``F_T(x)``, its interfacial and deformation parts (Eq. 2 and 3), the contact
occupancy (Fig. 3) and the tactile blind spots.

Which contact definition
------------------------
By default the prediction uses the forward model's **geometric** contact: the parts of the
surface within 70 um of the deformed finger (the paper's 3-pixel criterion, Methods
"Image analysis"). That is the definition under which the paper measured ``C_i`` and
fitted ``(mu, p0, p1)``, and under which it reported its blind spots; feeding Eq. (4) the
narrower mechanical contact (pressure > 0) would apply fitted parameters to regions of a
different kind. ``contact='mechanical'`` is available for comparison.

Default parameters
------------------
When no fitted parameters are given, :func:`default_params` documents its provenance:

* ``mu`` = 0.55 (subject 1) and 0.60 (subject 2): the paper's grid-search values
  (Methods "Estimating model parameters").
* ``p0`` = ``F_N / L_flat``: the constant pressure (times ``D``) for which the model's
  normal force on flat ground, ``p0 * L_flat``, equals the prescribed 0.3 N
  (``L_flat``: the forward model's geometric flat-ground contact length at that load).
  Eq. (4) on flat ground is then Amontons' law ``F = mu F_N`` (0.165 N and 0.18 N).
* ``p1``: chosen so that the deformation force ``F_def`` alone peaks, on average over
  the paper's four raised surfaces (Bump and Step Up, 2 and 4 mm), at 50 mN: the paper
  reports forces "rising on the order of 50 mN within about 1 mm" at raised features
  (Results) and attributes that rise to ``F_def`` (Discussion, Fig. S3). ``F_def`` is
  linear in ``p1``, so this is closed-form on the forward-model sweeps.

Measured consequence (noted, not hidden): with ``p0 = F_N / L_flat`` the interfacial
term alone varies by tens of mN, and by up to ~150 mN with the calibrated fingers on a
3 mm bump, over a relief (the contact length, hence the model's normal force ``p0 L``,
changes as the finger bridges the feature: Eq. 4 with a constant ``p0`` does not
conserve the normal force), so the predicted variation is larger than 50 mN and
``F_def`` does not dominate as in the paper's Fig. S3. The paper's fits were made
against drift-corrected forces (zero on flat ground), which favours a small ``p0``; a
flat-friction-consistent ``p0`` is kept here because rendering on a display needs the
model's flat-ground level to be ``mu F_N``.

These are anchored on figures the paper reports, not fitted to data: fitted parameters
(``--params``) should be preferred whenever a study is available.

Validity
--------
:func:`check_profile` refuses reliefs steeper than :data:`MAX_SLOPE_ANGLE`; see its notes
for where that limit comes from.
"""

from __future__ import annotations

import functools
import json
import logging
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ._atomic import atomic_write
from .blindspots import BlindSpots, Occupancy, blind_spots, occupancy
from .mechanics import GEOMETRIC_TOL
from .model import FrictionModel, FrictionParams
from .regions import as_regions, n_regions, regions_on_grid
from .surfaces import SURFACE_NAMES, Surface, get_surface, surface_from_spec

__all__ = [
    "GEOM_TOL_MM",
    "DEFAULT_LOAD_N",
    "PAPER_MU",
    "MAX_SLOPE_ANGLE",
    "ProfileTooSteepError",
    "check_profile",
    "sweep_window",
    "default_params",
    "flat_contact_length",
    "forward_regions",
    "load_params",
    "Prediction",
    "predict",
    "predict_from_regions",
    "OutOfSample",
    "leave_one_surface_out",
    "trials_from_results",
    "validate_results",
]

log = logging.getLogger(__name__)

#: The paper's contact criterion (3 px at about 23 um/px), in mm: the forward model's
#: geometric tolerance, used by every sweep of this module.
GEOM_TOL_MM = GEOMETRIC_TOL
#: The prescribed normal force of the study, in N (Methods "Procedure").
DEFAULT_LOAD_N = 0.3
#: Per-subject coefficients of friction found by the paper's grid search.
PAPER_MU = {1: 0.55, 2: 0.60}
#: Rise of F_T at first contact with a raised feature reported by the paper, in N.
PAPER_FORCE_RISE_N = 0.050
#: The raised surfaces over which the default p1 is calibrated.
_P1_CALIBRATION_SURFACES = ("bump-2mm", "bump-4mm", "step-up-2mm", "step-up-4mm")
#: Half-length in mm of the paper's analysis window (26 mm centred on the feature).
_HALF_WINDOW_MM = 13.0

#: Largest surface slope angle (rad) the prediction accepts: acos(3/4) = 0.723 rad
#: (41.4 degrees, dh/dx = 0.882). See :func:`check_profile` for its derivation.
MAX_SLOPE_ANGLE = math.acos(0.75)


class ProfileTooSteepError(ValueError):
    """A relief is steeper than the contact model and Eq. (4) support."""


def check_profile(surface: Surface, *, max_slope_angle: float = MAX_SLOPE_ANGLE) -> float:
    """Check that a relief is within the model's slope limit; return its max angle (rad).

    Parameters
    ----------
    surface : Surface
        The relief.
    max_slope_angle : float, optional
        Limit in rad (default :data:`MAX_SLOPE_ANGLE`, 0.723 rad = 41.4 degrees).

    Returns
    -------
    float
        The largest ``|alpha(x)|`` of the relief in rad.

    Raises
    ------
    ProfileTooSteepError
        Naming the steepest position, its angle and the limit.

    Notes
    -----
    The limit comes from the geometric contact definition that the prediction feeds into
    Eq. (4). The forward model (a plane-strain half-space, a small-slope theory) measures
    the gap between finger and surface vertically, while the paper's 3-pixel criterion is
    a distance between contour points, i.e. along the surface normal: a vertical gap
    ``g`` over a surface inclined at ``alpha`` is a normal distance ``g cos(alpha)``. The
    70 um (3 px) criterion applied to the vertical gap therefore admits points up to
    ``70 / cos(alpha)`` um away along the normal. At ``cos(alpha) = 3/4`` that is 93 um,
    i.e. 4 px instead of 3: the regions are no longer of the kind the parameters were
    fitted on, so predictions there are refused rather than silently biased. The paper's
    steepest surfaces (the bumps, 0.56 rad) stay inside the limit (``cos = 0.85``: 82 um,
    half a pixel off). The same ``cos(alpha)`` factor measures how far the half-space's
    flat-boundary assumption is from the real inclined boundary.

    Solver convergence is *not* a usable validity test: measured on 3 mm raised-cosine
    bumps (subject 1, 0.1 mm steps), the BEM sweep converges at every position up to a
    slope angle of 1.3 rad (H = 3.4 mm) and first fails at 1.45 rad (H = 7.9 mm, where the
    contact reaches the edge of the finger's grid). A linear half-space gives a number far
    beyond where its assumptions hold, so the limit is enforced here, before solving.

    A CSV profile with a vertical or overhanging wall has an unbounded slope and is
    refused here.
    """
    if not isinstance(surface, Surface):
        raise TypeError(f"surface must be a fingerfriction Surface, got {type(surface).__name__}")
    a, b = surface.feature_extent
    if b <= a:
        return 0.0
    # Sample finely enough to see any feature of a sampled profile (>= 20 points per sample).
    n = 20001
    if hasattr(surface, "x"):
        n = max(n, 20 * int(np.asarray(surface.x).size))
    xs = np.linspace(a, b, n)
    s = np.abs(np.asarray(surface.dhdx(xs), dtype=float))
    if not np.all(np.isfinite(s)):
        i = int(np.flatnonzero(~np.isfinite(s))[0])
        raise ProfileTooSteepError(
            f"surface {surface.name!r} has an undefined slope at x = {xs[i]:.3f} mm"
        )
    i = int(np.argmax(s))
    ang = float(np.arctan(s[i]))
    if ang > max_slope_angle:
        raise ProfileTooSteepError(
            f"surface {surface.name!r} has a slope angle of {ang:.3f} rad ({math.degrees(ang):.1f} deg, "
            f"dh/dx = {s[i]:.3g}) at x = {xs[i]:.3f} mm; the contact model and Eq. (4) support at most "
            f"{max_slope_angle:.3f} rad ({math.degrees(max_slope_angle):.1f} deg, dh/dx = "
            f"{math.tan(max_slope_angle):.3g}): beyond it the vertical 70 um gap criterion departs from "
            f"the paper's normal-distance criterion by more than a pixel. Smooth or scale down the profile."
        )
    return ang


def sweep_window(surface: Surface) -> tuple[float, float]:
    """Finger positions (mm) swept for a prediction: the paper's 26 mm window, widened.

    ``(-13, 13)`` for the paper's surfaces (the analysis window of Methods "Force data
    processing"); for a wider relief, 11 mm beyond each end of the feature so the finger
    starts and ends on flat ground.
    """
    a, b = surface.feature_extent
    return (min(-_HALF_WINDOW_MM, a - 11.0), max(_HALF_WINDOW_MM, b + 11.0))


# ---------------------------------------------------------------------------- contact
def _resolve_finger(subject):
    """``(label, FingerParams)`` for a subject number or a FingerParams."""
    from .mechanics import SUBJECTS, FingerParams

    if isinstance(subject, FingerParams):
        return (subject.name or "custom"), subject
    try:
        key = int(subject)
    except (TypeError, ValueError):
        key = None
    if key is None or key not in SUBJECTS or isinstance(subject, bool):
        raise ValueError(
            f"unknown subject {subject!r}; known subjects: {sorted(SUBJECTS)} (or a FingerParams)"
        )
    return key, SUBJECTS[key]


def forward_regions(surface: Surface, finger, positions, *, load: float = DEFAULT_LOAD_N,
                    contact: str = "geometric") -> np.ndarray:
    """Contact regions of the forward model at each finger position.

    Parameters
    ----------
    surface : Surface
        The relief.
    finger : FingerParams
        The finger (:mod:`fingerfriction.mechanics`).
    positions : (n,) array_like
        Finger-centre positions in mm, increasing (the sweep warm-starts each from the
        previous one).
    load : float
        Normal force in N.
    contact : {'geometric', 'mechanical'}
        Geometric: within :data:`GEOM_TOL_MM` of the deformed finger (the paper's
        definition); mechanical: pressure > 0.

    Returns
    -------
    (n, n_max, 2) ndarray
        Regions in mm (:mod:`fingerfriction.regions` format).

    Raises
    ------
    RuntimeError
        When the contact solver did not converge at some position (named).
    """
    if contact not in ("geometric", "mechanical"):
        raise ValueError(f"contact must be 'geometric' or 'mechanical', got {contact!r}")
    from .mechanics import sweep

    res = sweep(surface, finger, np.asarray(positions, dtype=float), load=load)
    return _sweep_regions(res, contact)


def _sweep_regions(res, contact: str) -> np.ndarray:
    """Extract the regions array of one kind from a mechanics SweepResult."""
    ok = np.asarray(res.success, dtype=bool)
    if not ok.all():
        bad = np.flatnonzero(~ok)
        first = res.messages[0] if res.messages else ""
        raise RuntimeError(
            f"the contact solver failed at {bad.size} of {ok.size} finger positions, first at "
            f"x = {float(res.positions[bad[0]]):.3f} mm ({first}); no prediction is made from a "
            "partly failed sweep"
        )
    return as_regions(res.regions(contact), name=f"{contact} regions")


# ---------------------------------------------------------------------------- params
@functools.lru_cache(maxsize=8)
def _flat_length(finger, load: float) -> float:
    """Geometric contact length (mm) of the finger on flat ground at ``load`` (N)."""
    flat = _flat_surface()
    r = forward_regions(flat, finger, np.array([0.0]), load=load)
    from .regions import region_lengths

    L = float(np.nansum(region_lengths(r)))
    if not L > 0:
        raise RuntimeError(f"the forward model gave no contact on flat ground at {load} N")
    return L


def _flat_surface() -> Surface:
    from .surfaces import SampledProfile

    x = np.linspace(-40.0, 40.0, 9)
    return SampledProfile(x, np.zeros_like(x), name="flat")


def flat_contact_length(subject, *, load: float = DEFAULT_LOAD_N) -> float:
    """The forward model's geometric contact length on flat ground, in mm.

    Parameters
    ----------
    subject : int or FingerParams
    load : float
        Normal force in N.
    """
    _, finger = _resolve_finger(subject)
    return _flat_length(finger, float(load))


def _calibration_sweep(surface: Surface, finger, load: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Finger positions (mm) and forward-model regions of a calibration sweep."""
    lo, hi = sweep_window(surface)
    x = np.arange(lo, hi + 0.5 * step, step)
    regions = forward_regions(surface, finger, x, load=load)
    return x, regions


@functools.lru_cache(maxsize=8)
def _default_params_cached(key, finger, load: float, step: float) -> FrictionParams:
    mu = PAPER_MU[key]
    L = _flat_length(finger, load)
    p0 = load / L
    peaks = []
    for name in _P1_CALIBRATION_SURFACES:
        s = get_surface(name)
        x, regions = _calibration_sweep(s, finger, load, step)
        peaks.append(float(np.max(FrictionModel(s).basis(regions, mu)[:, 1])))
    m = float(np.mean(peaks))
    if not m > 0:
        raise RuntimeError("could not calibrate the default p1: the deformation basis is zero")
    # F_def = p1 * basis: linear, so the calibration is closed-form.
    return FrictionParams(mu, p0, PAPER_FORCE_RISE_N / m)


def default_params(subject, *, load: float = DEFAULT_LOAD_N, step: float = 0.05) -> FrictionParams:
    """Documented default Eq. (4) parameters of subject 1 or 2 (see the module notes).

    ``mu`` from the paper; ``p0 = F_N / L_flat`` (flat-ground friction ``mu F_N``);
    ``p1`` such that the mean peak of ``F_def`` over the paper's four raised surfaces is
    50 mN. Computed from forward-model sweeps at ``step`` mm (cached per finger).

    Parameters
    ----------
    subject : int
        1 or 2 (a custom FingerParams has no paper mu: give parameters instead).
    load : float
        Normal force in N (default 0.3).
    step : float
        Finger step in mm of the calibration sweeps (default 0.05).
    """
    key, finger = _resolve_finger(subject)
    if key not in PAPER_MU:
        raise ValueError(
            f"no default friction parameters for subject {subject!r}: give params "
            f"(FrictionParams or a JSON file); defaults exist for subjects {sorted(PAPER_MU)}"
        )
    return _default_params_cached(key, finger, float(load), float(step))


def _subject_keys(subject) -> list:
    """Keys a subject may have in a parameters file: '1', 1, 'S1', 's1'."""
    keys = [str(subject), subject]
    digits = "".join(c for c in str(subject) if c.isdigit())
    if digits:
        keys += [digits, f"S{digits}", f"s{digits}"]
    return [k for k in keys if isinstance(k, (str, int))]


def _params_from_mapping(d: dict, subject, where: str) -> FrictionParams:
    """FrictionParams from a JSON object (see :func:`load_params` for the accepted forms)."""
    if {"mu", "p0", "p1"} <= set(d):
        return FrictionParams(mu=d["mu"], p0=d["p0"], p1=d["p1"])
    subjects = d.get("subjects", d)
    if not isinstance(subjects, dict):
        raise ValueError(f"{where}: 'subjects' must be an object keyed by subject")
    entry = next((subjects[k] for k in _subject_keys(subject) if k in subjects), None)
    if entry is None:
        raise ValueError(
            f"{where}: no parameters for subject {subject!r}; the file has {sorted(map(str, subjects))}. "
            "Expected {'mu','p0','p1'} or {'subjects': {'<subject>': {...}}}"
        )
    if not isinstance(entry, dict) or "mu" not in entry:
        raise ValueError(f"{where}: subject {subject!r} entry must be an object with 'mu'")
    if "p0" in entry and "p1" in entry:
        return FrictionParams(mu=entry["mu"], p0=entry["p0"], p1=entry["p1"])
    trials = entry.get("trials")
    if isinstance(trials, list) and trials:
        try:
            p0 = float(np.median([float(t["p0"]) for t in trials]))
            p1 = float(np.median([float(t["p1"]) for t in trials]))
        except (KeyError, TypeError, ValueError):
            raise ValueError(
                f"{where}: subject {subject!r} trials must each have numbers p0 and p1"
            ) from None
        return FrictionParams(mu=entry["mu"], p0=p0, p1=p1)
    raise ValueError(f"{where}: subject {subject!r} entry needs 'p0' and 'p1' or a non-empty 'trials' list")


def _params_from_pipeline_fit(d: dict, subject, path: str) -> FrictionParams:
    """``fingerfriction fit`` output: mu per subject in fit.json, p0/p1 per trial in the
    trials.csv beside it; the subject's medians over its successful trials are used."""
    import pandas as pd

    mus = d["mu"]
    key = next((k for k in _subject_keys(subject) if k in mus), None)
    if key is None:
        raise ValueError(f"{path}: no fitted mu for subject {subject!r}; the fit has subjects {sorted(mus)}")
    tcsv = os.path.join(os.path.dirname(path), "trials.csv")
    try:
        t = pd.read_csv(tcsv, dtype={"subject": str})
    except (OSError, ValueError) as exc:
        raise ValueError(f"{tcsv}: cannot read the per-trial fits ({exc})") from None
    missing = {"subject", "p0", "p1"} - set(t.columns)
    if missing:
        raise ValueError(f"{tcsv}: missing column(s) {sorted(missing)}")
    sel = t[t["subject"] == key]
    if "success" in sel.columns:
        sel = sel[sel["success"].astype(str).str.lower() == "true"]
    if sel.empty:
        raise ValueError(f"{tcsv}: no successful trial fit for subject {subject!r}")
    return FrictionParams(mu=float(mus[key]), p0=float(sel["p0"].median()), p1=float(sel["p1"].median()))


def load_params(path: str | os.PathLike, subject=None) -> FrictionParams:
    """Read Eq. (4) parameters from a JSON file.

    Accepted forms: ``FrictionParams.to_json()`` (``{"mu", "p0", "p1"}``); a per-subject
    object ``{"subjects": {"1": {"mu", "p0", "p1"}}}`` (or without the ``subjects``
    level); or a fit output with per-trial values ``{"subjects": {"1": {"mu": ...,
    "trials": [{"p0": ..., "p1": ...}, ...]}}}``, whose subject-level ``p0, p1`` are the
    medians over trials (a prediction has no trial of its own to fit); or the output of
    ``fingerfriction fit`` (``RESULTS``, ``RESULTS/fit`` or ``RESULTS/fit/fit.json``: mu
    per subject, p0 and p1 medians over the subject's successful trials in ``trials.csv``).

    Raises
    ------
    ValueError
        Naming the file and what is missing or malformed.
    """
    path = os.fspath(path)
    if os.path.isdir(path):  # a results folder or its fit/ folder
        for cand in (os.path.join(path, "fit", "fit.json"), os.path.join(path, "fit.json")):
            if os.path.exists(cand):
                path = cand
                break
        else:
            raise ValueError(f"{path}: a folder without fit/fit.json; run 'fingerfriction fit' first")
    try:
        with open(path, encoding="utf-8") as fh:
            d = json.load(fh)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read parameters ({exc.strerror})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(d).__name__}")
    if isinstance(d.get("mu"), dict):
        return _params_from_pipeline_fit(d, subject, path)
    try:
        return _params_from_mapping(d, subject, path)
    except (TypeError, KeyError) as exc:
        raise ValueError(f"{path}: malformed parameters ({exc})") from None


def _resolve_params(params, subject, load: float) -> tuple[FrictionParams, str]:
    if params is None:
        return default_params(subject, load=load), "default (paper mu; p0 = F_N/L_flat; p1: 50 mN peak F_def)"
    if isinstance(params, FrictionParams):
        return params, "given"
    if isinstance(params, (str, os.PathLike)):
        return load_params(params, subject), f"file {os.fspath(params)}"
    raise TypeError(f"params must be None, FrictionParams or a JSON path, got {type(params).__name__}")


# ---------------------------------------------------------------------------- prediction
@dataclass(frozen=True)
class Prediction:
    """A predicted sweep of a finger over a relief.

    Attributes
    ----------
    surface : Surface
    subject : int or str
        Subject label.
    params : FrictionParams
        Eq. (4) parameters used.
    params_source : str
        Where they came from.
    load : float
        Normal force in N.
    contact : str
        'geometric' (70 um, default) or 'mechanical'.
    positions : (n,) ndarray
        Finger-centre positions in mm.
    regions : (n, n_max, 2) ndarray
        Contact regions in mm at each position.
    F_T, F_int, F_def : (n,) ndarray
        Eq. (4), (2), (3) in N.
    occupancy : Occupancy
        Contact occupancy over the sweep (Fig. 3).
    blind_spots : BlindSpots
        Never-contacted intervals.
    """

    surface: Surface
    subject: object
    params: FrictionParams
    params_source: str
    load: float
    contact: str
    positions: np.ndarray
    regions: np.ndarray
    F_T: np.ndarray
    F_int: np.ndarray
    F_def: np.ndarray
    occupancy: Occupancy = field(repr=False)
    blind_spots: BlindSpots = field(repr=False)
    finger: object = field(default=None, repr=False)

    @property
    def max_contacts(self) -> int:
        """Largest number of simultaneous contact regions over the sweep."""
        return int(n_regions(self.regions).max(initial=0))

    @property
    def flat_level(self) -> float:
        """F_T (N) at the first position (finger on flat ground before the feature)."""
        return float(self.F_T[0])

    def summary(self) -> dict:
        """JSON-serialisable summary: parameters, blind spots, force extremes."""
        return {
            "surface": self.surface.name,
            "surface_spec": _surface_dict(self.surface),
            "subject": str(self.subject),
            "params": {"mu": self.params.mu, "p0": self.params.p0, "p1": self.params.p1},
            "params_source": self.params_source,
            "load_N": self.load,
            "contact": self.contact,
            "geom_tol_mm": GEOM_TOL_MM if self.contact == "geometric" else None,
            "n_positions": int(self.positions.size),
            "step_mm": float(np.median(np.diff(self.positions))) if self.positions.size > 1 else None,
            "max_slope_angle_rad": self.surface.max_slope_angle(),
            "max_contacts": self.max_contacts,
            "blind_spots": self.blind_spots.as_table(),
            "F_T_flat_N": self.flat_level,
            "F_T_max_N": float(np.max(self.F_T)),
            "F_T_min_N": float(np.min(self.F_T)),
        }

    def table(self):
        """Per-position table (pandas DataFrame): x_mm, F_T_N, F_int_N, F_def_N, n_contacts,
        contact_length_mm."""
        import pandas as pd

        from .regions import region_lengths

        return pd.DataFrame(
            {
                "x_mm": self.positions,
                "F_T_N": self.F_T,
                "F_int_N": self.F_int,
                "F_def_N": self.F_def,
                "n_contacts": n_regions(self.regions),
                "contact_length_mm": np.nansum(region_lengths(self.regions), axis=1),
            }
        )

    def write(self, out_dir: str | os.PathLike, *, figures: bool = True) -> dict[str, str]:
        """Write CSV tables, a JSON summary and (optionally) PNG figures into ``out_dir``.

        Files: ``forces.csv`` (per position), ``regions.csv`` (one row per region:
        x_mm, a_mm, b_mm), ``occupancy.csv`` (bin centre, fraction, normalised),
        ``blind_spots.csv``, ``prediction.json``; figures ``forces.png``,
        ``occupancy.png``. Every write is atomic.

        Returns
        -------
        dict
            File kind -> path.
        """
        import pandas as pd

        out = os.fspath(out_dir)
        os.makedirs(out, exist_ok=True)
        paths: dict[str, str] = {}

        def put(kind: str, name: str, writer: Callable[[str], None]) -> None:
            p = os.path.join(out, name)
            atomic_write(p, writer)
            paths[kind] = p

        put("forces", "forces.csv", lambda tmp: self.table().to_csv(tmp, index=False, float_format="%.9g"))
        valid = ~np.isnan(self.regions[..., 0])
        t_idx, _ = np.nonzero(valid)
        reg = pd.DataFrame(
            {
                "x_mm": self.positions[t_idx],
                "a_mm": self.regions[..., 0][valid],
                "b_mm": self.regions[..., 1][valid],
            }
        )
        put("regions", "regions.csv", lambda tmp: reg.to_csv(tmp, index=False, float_format="%.6f"))
        occ = pd.DataFrame(
            {
                "x_mm": self.occupancy.centers,
                "fraction": self.occupancy.fraction,
                "normalized": self.occupancy.normalized,
            }
        )
        put("occupancy", "occupancy.csv", lambda tmp: occ.to_csv(tmp, index=False, float_format="%.6g"))
        bs = pd.DataFrame(self.blind_spots.as_table(), columns=["start_mm", "end_mm", "width_mm"])
        put("blind_spots", "blind_spots.csv", lambda tmp: bs.to_csv(tmp, index=False, float_format="%.4f"))

        def wjson(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(self.summary(), fh, indent=2)

        put("summary", "prediction.json", wjson)
        if figures:
            put("forces_png", "forces.png", self._plot_forces)
            put("occupancy_png", "occupancy.png", self._plot_occupancy)
        return paths

    def _plot_forces(self, path: str) -> None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, (ax0, ax1) = plt.subplots(2, 1, figsize=(7, 5), sharex=True, height_ratios=[3, 1])
        x = self.positions
        ax0.plot(x, 1e3 * self.F_T, "k", lw=1.5, label="$F_T$ (Eq. 4)")
        ax0.plot(x, 1e3 * self.F_int, "C0", lw=1, label="$F_{int}$ (Eq. 2)")
        ax0.plot(x, 1e3 * self.F_def, "C3", lw=1, label="$F_{def}$ (Eq. 3)")
        ax0.set_ylabel("force (mN)")
        ax0.legend(loc="upper right", fontsize=8)
        p = self.params
        ax0.set_title(
            f"{self.surface.name}, subject {self.subject}: mu={p.mu:.3g}, p0={p.p0:.3g} N/mm, "
            f"p1={p.p1:.3g} N/mm", fontsize=9,
        )
        xs = np.linspace(x[0], x[-1], 2000)
        ax1.fill_between(xs, 0, self.surface.h(xs), color="0.6")
        for a, b in self.blind_spots.intervals:
            ax1.axvspan(a, b, color="k", alpha=0.8, lw=0)
        ax1.set_xlabel("finger position x (mm)  /  surface position (mm)")
        ax1.set_ylabel("h (mm)")
        fig.tight_layout()
        fig.savefig(path, format="png", dpi=120)
        plt.close(fig)

    def _plot_occupancy(self, path: str) -> None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        occ = self.occupancy
        fig, ax = plt.subplots(figsize=(7, 2.8))
        xs = occ.centers
        h = self.surface.h(xs)
        ax.fill_between(xs, h.min() - 0.2, h, color="0.85")
        sc = ax.scatter(xs, h, c=occ.normalized, cmap="gray", s=4, vmin=0, vmax=1)
        for a, b in self.blind_spots.intervals:
            ax.axvspan(a, b, color="r", alpha=0.15, lw=0)
        fig.colorbar(sc, ax=ax, label="normalised contact time")
        ax.set_xlabel("surface position (mm)")
        ax.set_ylabel("h (mm)")
        widths = ", ".join(f"{w:.2f}" for w in self.blind_spots.widths) or "none"
        ax.set_title(f"{self.surface.name}, subject {self.subject}: blind spots (mm): {widths}", fontsize=9)
        fig.tight_layout()
        fig.savefig(path, format="png", dpi=120)
        plt.close(fig)


def _surface_dict(surface: Surface):
    to_dict = getattr(surface, "to_dict", None)
    return to_dict() if callable(to_dict) else {"name": surface.name}


def predict_from_regions(surface: Surface, positions, regions, params: FrictionParams, *,
                         subject="?", params_source: str = "given", load: float = DEFAULT_LOAD_N,
                         contact: str = "geometric", finger=None) -> Prediction:
    """Eq. (4) and the blind spots for given contact regions along a sweep.

    Parameters
    ----------
    surface : Surface
    positions : (n,) array_like
        Finger positions in mm.
    regions : (n, n_max, 2) array_like
        Contact regions in mm at each position.
    params : FrictionParams
    """
    if not isinstance(params, FrictionParams):
        raise TypeError(f"params must be FrictionParams, got {type(params).__name__}")
    x = np.asarray(positions, dtype=float)
    reg = as_regions(regions)
    if x.ndim != 1 or x.size != reg.shape[0]:
        raise ValueError(
            f"positions must be 1-D with one entry per frame of regions; got {x.shape} "
            f"and {reg.shape[0]} frames"
        )
    if not np.all(np.isfinite(x)):
        raise ValueError("positions must be finite (mm)")
    f = FrictionModel(surface).forces(reg, params)
    occ = occupancy(reg)
    bs = blind_spots(reg)
    return Prediction(
        surface=surface, subject=subject, params=params, params_source=params_source, load=float(load),
        contact=contact, positions=x, regions=reg, F_T=f.total, F_int=f.interfacial, F_def=f.deformation,
        occupancy=occ, blind_spots=bs, finger=finger,
    )


def predict(surface_spec, subject, params=None, *, load: float = DEFAULT_LOAD_N, step: float = 0.01,
            contact: str = "geometric", window: Sequence[float] | None = None,
            max_slope_angle: float = MAX_SLOPE_ANGLE) -> Prediction:
    """Predict F_T(x), F_int, F_def, occupancy and blind spots on any relief.

    The forward contact model (:mod:`fingerfriction.mechanics`) is swept over the surface
    at ``step`` mm; its contact regions (geometric, 70 um, by default: see the module
    notes) go into Eq. (4) of Janko et al. 2018 with ``params``.

    Parameters
    ----------
    surface_spec : str, path or Surface
        A paper surface name (``'bump-4mm'``), a parametric spec (``'bump:W=3,H=0.5'``),
        a CSV profile of x, h in mm, or a Surface (:func:`surface_from_spec`).
    subject : int or FingerParams
        Subject 1 or 2 (the calibrated fingers of :mod:`fingerfriction.mechanics`), or a
        custom finger (then ``params`` is required).
    params : None, FrictionParams or path, optional
        Eq. (4) parameters; ``None`` uses :func:`default_params`; a path is read by
        :func:`load_params`.
    load : float, optional
        Normal force in N (default 0.3, the paper's).
    step : float, optional
        Finger step in mm (default 0.01, the paper's spatial resolution).
    contact : {'geometric', 'mechanical'}, optional
    window : (float, float), optional
        First and last finger positions in mm (default :func:`sweep_window`).
    max_slope_angle : float, optional
        Slope limit in rad (:func:`check_profile`).

    Returns
    -------
    Prediction

    Raises
    ------
    ValueError
        Unknown surface, malformed CSV, unknown subject, bad parameters file;
        :class:`ProfileTooSteepError` for a relief beyond the slope limit.
    RuntimeError
        If the contact solver fails at some position.
    """
    surface = surface_from_spec(surface_spec)
    check_profile(surface, max_slope_angle=max_slope_angle)
    if not (isinstance(step, (int, float)) and math.isfinite(step) and 0 < step <= 1.0):
        raise ValueError(f"step must be a finger step in mm in (0, 1], got {step!r}")
    if not (isinstance(load, (int, float)) and math.isfinite(load) and load > 0):
        raise ValueError(f"load must be a positive normal force in N, got {load!r}")
    label, finger = _resolve_finger(subject)
    p, source = _resolve_params(params, label, float(load))
    lo, hi = sweep_window(surface) if window is None else (float(window[0]), float(window[1]))
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(
            f"window must be (first, last) finger positions in mm with first < last, got {window!r}"
        )
    x = lo + step * np.arange(int(math.floor((hi - lo) / step + 1e-9)) + 1)
    log.info("predict: %s, subject %s, %d positions, %s contact", surface.name, label, x.size, contact)
    reg = forward_regions(surface, finger, x, load=load, contact=contact)
    return predict_from_regions(surface, x, reg, p, subject=label, params_source=source, load=load,
                                contact=contact, finger=finger)


def known_surface_names() -> tuple[str, ...]:
    """The paper's surface names (for error messages and the CLI)."""
    return SURFACE_NAMES


# ---------------------------------------------------------------------------- out of sample
def _finger_for_label(label: str, fingers):
    """The forward-model finger of a trial's subject label ('1', 'S1', ...)."""
    from .mechanics import SUBJECTS, FingerParams

    if fingers is not None:
        if label not in fingers:
            raise ValueError(f"no finger given for subject {label!r}; fingers has {sorted(fingers)}")
        f = fingers[label]
        return f if isinstance(f, FingerParams) else _resolve_finger(f)[1]
    digits = "".join(c for c in str(label) if c.isdigit())
    if digits and int(digits) in SUBJECTS:
        return SUBJECTS[int(digits)]
    raise ValueError(
        f"cannot map subject {label!r} to a forward-model finger; pass fingers={{label: FingerParams or 1/2}}"
    )


def _compared_estimate(surface: Surface, x: np.ndarray, force: np.ndarray, regions: np.ndarray,
                       params: FrictionParams, options, model: FrictionModel | None = None):
    """Measured and model series as the fit compares them (fit.py's processing), for fixed
    parameters: median filter on the per-frame integrals S, K, Q, then the same linear
    detrend over the flat segment defined by ``regions`` applied to both."""
    from .fit import flat_detrend, flat_segment_mask, median_filter

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
    from .fit import median_filter

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


@functools.lru_cache(maxsize=16)
def _flat_length_kind(finger, load: float, contact: str) -> float:
    """Flat-ground contact length (mm) of the given kind."""
    if contact == "geometric":
        return _flat_length(finger, load)
    from .regions import region_lengths

    r = forward_regions(_flat_surface(), finger, np.array([0.0]), load=load, contact=contact)
    return float(np.nansum(region_lengths(r)))


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
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

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
    import pandas as pd

    from .fit import FitOptions, Trial, fit_trials
    from .stats import BOTH, correlation_table, ensemble_correlation

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


# ---------------------------------------------------------------------------- results store
def trials_from_results(results: str | os.PathLike) -> list:
    """Per-trial data of an analysed study (``fingerfriction analyze`` results folder).

    Builds one :class:`fingerfriction.fit.Trial` per successfully analysed trial exactly
    as ``fingerfriction fit`` does (:func:`fingerfriction.pipeline.fit`): forces on the
    0.01 mm grid from ``forces.parquet``, video regions mapped onto the grid with
    :func:`fingerfriction.pipeline.regions_on_grid`, surface from the run record.

    Raises
    ------
    ValueError
        If the folder has no analysed trial.
    """
    from .fit import Trial
    from .results import ResultsStore, regions_from_table

    store = ResultsStore(results)
    run = store.read_run()
    surfaces = {k: surface_from_spec(v) for k, v in run.get("surfaces", {}).items()}
    trials, skipped = [], []
    for m in run.get("trials", []):
        tid = m["id"]
        if (store.status(tid) or {}).get("status") != "ok":
            continue
        try:
            fr = store.read_frames(tid)
            fo = store.read_forces(tid)
            x = fo["x_mm"].to_numpy(float)
            F = fo["F_T_N"].to_numpy(float)
            good = np.isfinite(F)
            reg = regions_on_grid(fr["x_mm"].to_numpy(float), regions_from_table(fr), x)
            trials.append(Trial(x=x[good], force=F[good], regions=reg[good], surface=surfaces[m["surface"]],
                                subject=str(m["subject"]), labels={"trial": tid, "surface": m["surface"]}))
        except (ValueError, KeyError, OSError) as exc:
            skipped.append((tid, str(exc)))
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
    from .fit import FitOptions, mu_grid

    root = os.fspath(results)
    grid, options = None, None
    fj = os.path.join(root, "fit", "fit.json")
    if os.path.exists(fj):
        with open(fj, encoding="utf-8") as fh:
            rec = json.load(fh)
        g = rec.get("mu_grid") or {}
        if {"start", "stop", "step"} <= set(g):
            grid = mu_grid(g["start"], g["stop"], g["step"])
        o = rec.get("options")
        if isinstance(o, dict):
            known = set(FitOptions.__dataclass_fields__)
            options = FitOptions(**{k: v for k, v in o.items() if k in known})
    res = leave_one_surface_out(trials_from_results(root), grid=grid, options=options,
                                forward_step=forward_step)
    target = os.fspath(out) if out is not None else os.path.join(root, "fit", "loso.csv")
    os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
    res.write_csv(target)
    res.write_figure(os.path.splitext(target)[0] + ".png")
    return res
