"""The forward contact model swept along a relief: contact regions at every finger position
(:mod:`fingerfriction.mechanics`, geometric 70 um contact by default: the paper's
definition, see ``docs/predict.md``), the slope limit beyond which Eq. (4) is not applied,
and the flat-ground contact length.
"""

from __future__ import annotations

import functools
import logging
import math

import numpy as np

from .._check import check_option
from ..mechanics import GEOMETRIC_TOL, SUBJECTS, FingerParams, sweep
from ..mechanics.fe import FEFingerParams, FEProvider  # scikit-fem only when an FE solver is built
from ..mechanics.sweep import CONTACT_KINDS
from ..regions import as_regions, region_lengths, regions_from_mask
from ..surfaces import SampledProfile, Surface

__all__ = [
    "GEOM_TOL_MM",
    "DEFAULT_LOAD_N",
    "MAX_SLOPE_ANGLE",
    "ProfileTooSteepError",
    "check_profile",
    "sweep_window",
    "forward_regions",
    "flat_contact_length",
    "FE_FORWARD_STEP",
    "FORWARD_STEP_MM",
    "FE_MAX_UNCONVERGED",
]

#: The paper's contact criterion (3 px at about 23 um/px), in mm: the forward model's
#: geometric tolerance, used by every sweep of this module.
GEOM_TOL_MM = GEOMETRIC_TOL


#: The prescribed normal force of the study, in N (Methods "Procedure").
DEFAULT_LOAD_N = 0.3

#: The forward model's finger step in mm by default (a prediction, a validation's sweeps):
#: the 0.01 mm grid the measured forces are binned on.
FORWARD_STEP_MM = 0.01

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

    Solver convergence is not a usable validity test (a linear half-space gives a number far
    beyond where its assumptions hold; ``docs/predict.md``), so the limit is enforced here,
    before solving.

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


def resolve_finger(subject):
    """``(label, finger)`` for a subject number, a FingerParams or an FEFingerParams."""
    if isinstance(subject, (FingerParams, FEFingerParams)):
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
    finger : FingerParams or FEFingerParams
        The finger: the half-space finger (:mod:`fingerfriction.mechanics`) or the layered
        finite-element finger (:mod:`fingerfriction.mechanics.fe`; with its own sliding
        friction :attr:`~fingerfriction.mechanics.fe.FEFingerParams.friction`, solved every
        :data:`FE_FORWARD_STEP` mm, cached on disk, see ``docs/mechanics-fe.md``).
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
        When the contact solver did not converge at some position (named); for the FE
        finger, at more than :data:`FE_MAX_UNCONVERGED` of its solved positions (fewer are
        logged as a warning, and take the regions of the nearest converged position).
    """
    check_option("contact", contact, CONTACT_KINDS)
    if isinstance(finger, FEFingerParams):
        return _fe_regions(surface, finger, np.asarray(positions, dtype=float), load, contact)
    res = sweep(surface, finger, np.asarray(positions, dtype=float), load=load)
    return _sweep_regions(res, contact)


#: Finger step (mm) at which an FE finger is solved: finer requested positions take the
#: regions of the nearest solved one (0.4 s or more a position at the default mesh).
FE_FORWARD_STEP = 0.1

#: Largest fraction of an FE sweep's solved positions that may be unconverged: each takes the
#: regions of the nearest converged position, with a warning; beyond it no prediction is made.
#: (A stiff skin over a sharp feature is the penalty contact's hard case: about 2 % of the
#: positions of a drawn finger's tables, ``docs/mechanics-fe.md``.)
FE_MAX_UNCONVERGED = 0.05

log = logging.getLogger(__name__)


def _fe_regions(surface: Surface, finger, x: np.ndarray, load: float, contact: str) -> np.ndarray:
    """Regions of the layered FE finger (:class:`fingerfriction.mechanics.fe.FEProvider`,
    its tables cached on disk) at positions ``x``: solved every :data:`FE_FORWARD_STEP` mm
    over the span of ``x`` (an FE sweep is warm-started), each position taking the nearest
    solved one's regions, and an unconverged solved position those of the nearest converged
    one (at most :data:`FE_MAX_UNCONVERGED` of them)."""
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
        raise ValueError("positions must be a non-empty 1-D array of finite finger positions in mm")
    lo, hi = float(x.min()), float(x.max())
    xs = lo + FE_FORWARD_STEP * np.arange(int(math.ceil((hi - lo) / FE_FORWARD_STEP - 1e-9)) + 1)
    prov = FEProvider(fingers={"fe": finger})
    y, p = prov.solve(surface, "fe", xs, float(load))
    ok = prov.last_ok if prov.last_ok is not None else np.ones(xs.size, dtype=bool)
    name = getattr(surface, "name", "the surface")
    bad = int((~ok).sum())
    if bad > FE_MAX_UNCONVERGED * xs.size or not ok.any():
        raise RuntimeError(f"the FE contact solver failed at {bad} of {xs.size} finger positions on {name} "
                           f"(more than {FE_MAX_UNCONVERGED:.0%}); no prediction is made from it")
    if bad:
        first = float(xs[np.flatnonzero(~ok)[0]])
        log.warning("the FE contact solver did not converge at %d of %d finger positions on %s (first at "
                    "x = %.2f mm, %g N): they take the regions of the nearest converged position",
                    bad, xs.size, name, first, load)
    xi = prov.grid("fe")
    rows = []
    for i, xc in enumerate(xs):
        xg = xc + xi
        m = (y[i] - np.asarray(surface.h(xg), float) <= GEOM_TOL_MM) if contact == "geometric" else p[i] > 0
        rows.append(regions_from_mask(xg, m)[0] if m.any() else np.full((1, 2), np.nan))
    k = max(r.shape[0] for r in rows)
    solved = np.full((xs.size, k, 2), np.nan)
    for i, r in enumerate(rows):
        solved[i, : r.shape[0]] = r
    good = np.flatnonzero(ok)
    nearest_ok = good[np.abs(np.arange(xs.size)[:, None] - good[None, :]).argmin(axis=1)]
    idx = np.clip(np.rint((x - lo) / FE_FORWARD_STEP).astype(int), 0, xs.size - 1)
    return as_regions(solved[nearest_ok[idx]], name=f"{contact} regions")


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


@functools.lru_cache(maxsize=8)
def flat_length(finger, load: float) -> float:
    """Geometric contact length (mm) of the finger on flat ground at ``load`` (N)."""
    flat = _flat_surface()
    r = forward_regions(flat, finger, np.array([0.0]), load=load)
    L = float(np.nansum(region_lengths(r)))
    if not L > 0:
        raise RuntimeError(f"the forward model gave no contact on flat ground at {load} N")
    return L


def _flat_surface() -> Surface:
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
    _, finger = resolve_finger(subject)
    return flat_length(finger, float(load))


@functools.lru_cache(maxsize=16)
def flat_length_of_kind(finger, load: float, contact: str) -> float:
    """Flat-ground contact length (mm) of the given kind."""
    if contact == "geometric":
        return flat_length(finger, load)
    r = forward_regions(_flat_surface(), finger, np.array([0.0]), load=load, contact=contact)
    return float(np.nansum(region_lengths(r)))


def finger_for_label(label: str, fingers):
    """The forward-model finger of a trial's subject label ('1', 'S1', ...)."""
    if fingers is not None:
        if label not in fingers:
            raise ValueError(f"no finger given for subject {label!r}; fingers has {sorted(fingers)}")
        f = fingers[label]
        return f if isinstance(f, (FingerParams, FEFingerParams)) else resolve_finger(f)[1]
    digits = "".join(c for c in str(label) if c.isdigit())
    if digits and int(digits) in SUBJECTS:
        return SUBJECTS[int(digits)]
    raise ValueError(
        f"cannot map subject {label!r} to a forward-model finger; pass fingers={{label: FingerParams or 1/2}}"
    )
