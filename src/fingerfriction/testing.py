"""Test fixtures: synthetic trials with a known ground truth, for tests and benchmarks.

A trial here is what the paper's processing produces per slide ("Force data processing"):
the finger position sampled on a 0.01 mm grid over a 26 mm window centred on the relief
feature, the contact regions ``C_i`` seen at each position, and the drift-corrected
tangential force ``F_T``. The synthetic contact comes from a deliberately simple finger:
a rigid pad, flat over ``2 a`` with parabolic shoulders of radius ``R``, resting on the
highest points of the relief and pressed ``delta`` further in, with contact wherever the
pad is below the surface, evaluated on a camera-like pixel grid (so region ends
are quantised, as in the video analysis). ``delta`` wanders slowly from frame to frame (a
fluctuating normal force), so contact length and region count change along the slide:
one region on flat ground, a second (and on bumps a third) disconnected region near the
feature, with never-touched gaps at concave corners, as in Fig. 2 of the paper.

Forces are Eq. (4) on those regions with per-trial ``p0, p1``, plus white Gaussian noise,
then drift-corrected exactly like the measured force (best linear fit over the flat
segment subtracted, see :func:`fingerfriction.fit.flat_segment_mask` and
:func:`fingerfriction.fit.flat_detrend`). This is a test fixture,
not a contact mechanics model (the forward contact model lives in ``mechanics/``).
"""

from __future__ import annotations

import math

import numpy as np

from .fit import Trial, flat_detrend, flat_segment_mask
from .model import FrictionModel
from .regions import inset_regions, regions_from_mask
from .surfaces import SURFACE_NAMES, Surface, get_surface, surface_from_spec

__all__ = ["finger_contact_regions", "synthetic_trial", "synthetic_trials", "PAPER_MU"]

#: Per-subject friction coefficients the paper reports ("Estimating model parameters").
PAPER_MU: dict[str, float] = {"S1": 0.55, "S2": 0.60}


def finger_contact_regions(
    surface: Surface,
    centers,
    indentation,
    *,
    radius: float = 8.0,
    pad: float = 3.0,
    pixel: float = 0.02,
    half_window: float = 6.0,
    n_max: int = 4,
) -> np.ndarray:
    """Contact regions of a rigid flat-bottomed finger pad pressed into a relief.

    The pad's underside is ``f(u) = max(|u| - pad, 0)^2 / (2 radius)`` at distance ``u``
    from its centre. With the defaults the contact on flat ground is ~7.8 mm long and the
    paper's surfaces show blind spots of 0.6 mm (2 mm steps) to 2.1 mm (4 mm bump), the
    order of magnitude of Fig. 3 (a fixture, not a calibrated model).

    Parameters
    ----------
    surface : Surface
        Relief ``h(x)`` in mm.
    centers : (n,) array_like
        Finger centre positions in mm.
    indentation : float or (n,) array_like
        How far (mm) the parabola is pushed below the highest touching point, per frame.
    radius : float
        Radius of curvature of the pad's shoulders in mm (default 8 mm).
    pad : float
        Half-length of the flat part of the pad in mm (default 3 mm).
    pixel : float
        Sampling step in mm of the contact test (a camera pixel); region ends are
        quantised to it (default 0.02 mm).
    half_window : float
        Half-width in mm of the strip tested around the finger centre.
    n_max : int
        Region slots; a frame with more regions raises ``ValueError``.

    Returns
    -------
    (n, n_max, 2) ndarray
        Contact regions in mm (see :mod:`fingerfriction.regions`).
    """
    c = np.asarray(centers, dtype=float).reshape(-1)
    d = np.broadcast_to(np.asarray(indentation, dtype=float), c.shape)
    if np.any(~np.isfinite(d)) or np.any(d <= 0):
        raise ValueError(f"indentation must be positive (mm), got min {float(np.min(d))!r}")
    n_half = int(round(half_window / pixel))
    offs = pixel * np.arange(-n_half, n_half + 1)
    # Pixel grid fixed in surface coordinates (the camera does not move with the finger):
    # every frame samples the same lattice, shifted by a whole number of pixels.
    shift = np.round(c / pixel) * pixel
    grid = shift[:, None] + offs[None, :]
    h = surface.h(grid)
    finger = np.maximum(np.abs(grid - c[:, None]) - pad, 0.0) ** 2 / (2.0 * radius)
    # Lowest point of the finger such that it touches the relief, then push it in by delta.
    y0 = np.max(h - finger, axis=1) - d
    mask = (y0[:, None] + finger) <= h
    out = regions_from_mask(offs, mask, n_max=n_max) + shift[:, None, None]
    used = int(np.max(np.sum(~np.isnan(out[..., 0]), axis=1), initial=1))
    return out[:, : max(used, 1)]


def _smooth_walk(rng: np.random.Generator, n: int, sd: float, corr_len: int) -> np.ndarray:
    """A slowly varying zero-mean random signal of standard deviation ``sd``."""
    w = rng.normal(size=n + 4 * corr_len)
    k = np.exp(-0.5 * (np.arange(-2 * corr_len, 2 * corr_len + 1) / corr_len) ** 2)
    s = np.convolve(w, k / np.sqrt(np.sum(k**2)), mode="same")[2 * corr_len : 2 * corr_len + n]
    return sd * s


def synthetic_trial(
    surface,
    *,
    mu: float,
    p0: float,
    p1: float,
    rng: np.random.Generator,
    noise: float = 0.1,
    window: float = 26.0,
    step: float = 0.01,
    indentation: float = 0.05,
    indentation_sd: float = 0.05,
    subject: str = "S1",
    labels: dict | None = None,
    absolute: bool = False,
    inset: float = 0.0,
    noise_normal: float | None = None,
):
    """One synthetic trial (see module docstring) as a :class:`fingerfriction.fit.Trial`.

    Parameters
    ----------
    surface : Surface or str
        Relief (anything :func:`fingerfriction.surfaces.surface_from_spec` accepts).
    mu, p0, p1 : float
        True Eq. (4) parameters (p0, p1 in N/mm).
    rng : numpy.random.Generator
        Source of every random draw.
    noise : float
        Standard deviation of the additive white noise as a fraction of the standard
        deviation of the noiseless Eq. (4) force over the trial (0.1 = "10 % noise").
    window : float
        Span of finger positions in mm, centred on the feature (paper: 26 mm).
    step : float
        Position grid step in mm (paper: 0.01 mm).
    indentation, indentation_sd : float
        Mean and frame-to-frame standard deviation (slowly varying) of the finger
        indentation in mm.
    subject : str
        Subject label.
    labels : dict, optional
        Extra condition labels (e.g. speed, repetition).
    absolute : bool
        Also give the trial forces on the absolute footing: ``force_abs`` is the noisy
        Eq. (4) force before the detrend, and ``normal_abs`` the normal force of the same
        constant pressure, ``F_N = p0 sum int (cos alpha - mu sin alpha) dx`` (the vertical
        resultant of Eq. 2's stresses), with noise of ``noise_normal`` (default ``noise``)
        times its own standard deviation.
    inset : float
        The forces come from the contact regions inset by this many mm at each end (the
        load-bearing contact), while the trial carries the regions as seen (default 0).
    """
    surf = surface_from_spec(surface)
    lo, hi = surf.feature_extent
    mid = 0.5 * (lo + hi)
    n = int(round(window / step)) + 1
    x = mid - window / 2 + step * np.arange(n)
    walk = _smooth_walk(rng, n, indentation_sd, corr_len=max(n // 40, 1))
    delta = np.clip(indentation + walk, 0.2 * indentation, None)
    regions = finger_contact_regions(surf, x, delta)
    model = FrictionModel(surf)
    S, K, Q = model.integrals(inset_regions(regions, inset)).T
    clean = p0 * (S + mu * K) + p1 * (Q + mu * S)
    sd = float(np.std(clean))
    f_abs = clean + rng.normal(scale=noise * sd if sd > 0 else noise, size=n)
    # Drift-correct like the measurement: subtract the best line over the flat segment.
    flat = flat_segment_mask(regions, surf)
    f = flat_detrend(x, f_abs, flat)
    extra = {}
    if absolute:
        fn = p0 * (K - mu * S)
        sd_n = float(np.std(fn))
        rel = noise if noise_normal is None else noise_normal
        extra = {"force_abs": f_abs, "normal_abs": fn + rng.normal(scale=rel * sd_n if sd_n > 0 else rel,
                                                                     size=n)}
    return Trial(x=x, force=f, regions=regions, surface=surf, subject=subject,
                 labels=dict(labels or {}), **extra)


def synthetic_trials(
    *,
    subjects=None,
    surfaces=SURFACE_NAMES,
    speeds=(40, 80, 120),
    reps: int = 5,
    seed: int = 0,
    noise: float = 0.1,
    p0: float = 0.1,
    p1: float = 0.3,
    param_sd: float = 0.15,
    step: float = 0.01,
) -> tuple[list, dict]:
    """A synthetic study: every subject x surface x speed x repetition, with ground truth.

    Parameters
    ----------
    subjects : dict of str to float, optional
        Subject label -> true mu (default :data:`PAPER_MU`, the paper's 0.55 and 0.60).
    surfaces : sequence of str
        Surface names or specs (default the paper's six).
    speeds : sequence of float
        Sliding speeds in mm/s; only a label here (the model has no speed dependence).
    reps : int
        Repetitions per condition. The paper's 180 trials are 2 x 6 x 3 x 5.
    seed : int
        Seed of the ``numpy.random.Generator`` behind every draw.
    noise : float
        Relative noise level (see :func:`synthetic_trial`).
    p0, p1 : float
        Median true ``p0``, ``p1`` in N/mm; each trial draws its own from a log-normal of
        log-standard deviation ``param_sd``.
    step : float
        Position grid step in mm.

    Returns
    -------
    trials : list of Trial
    truth : dict
        ``{'mu': {subject: mu}, 'p0': (n_trials,), 'p1': (n_trials,)}``.
    """
    subjects = dict(PAPER_MU if subjects is None else subjects)
    if reps < 1 or int(reps) != reps:
        raise ValueError(f"reps must be a positive integer, got {reps!r}")
    rng = np.random.default_rng(seed)
    trials, tp0, tp1 = [], [], []
    surfs = [get_surface(s) if s in SURFACE_NAMES else surface_from_spec(s) for s in surfaces]
    for subj, mu in subjects.items():
        for surf in surfs:
            for speed in speeds:
                for rep in range(int(reps)):
                    q0 = p0 * math.exp(param_sd * rng.normal())
                    q1 = p1 * math.exp(param_sd * rng.normal())
                    trials.append(synthetic_trial(
                        surf, mu=mu, p0=q0, p1=q1, rng=rng, noise=noise, step=step, subject=subj,
                        labels={"speed": f"{speed:g}", "rep": str(rep + 1)},
                    ))
                    tp0.append(q0)
                    tp1.append(q1)
    return trials, {"mu": subjects, "p0": np.array(tp0), "p1": np.array(tp1)}
