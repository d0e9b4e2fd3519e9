"""The touch-down in both recordings: when the finger's lowest point reaches the surface
in the video, and when the normal force leaves zero in the force record.

Why this event
--------------
A finger lands on the surface at a finite speed: in the video its gap above the surface
closes at that speed, and the moment it reaches zero the pad starts to indent, so the
normal force leaves zero with a slope (the pad's initial stiffness times the landing
speed). Both are instants, not shapes: the offset between the two clocks is the
difference of the two instants, with no law in between (the start of the slide needs a
pre-sliding law, :mod:`.sync`).

How each instant is measured
----------------------------
* **Video** (:func:`touch_video`): the gap per frame (the finger's lowest point above the
  surface, :attr:`fingerfriction.video.VideoResult.gap_px`) over the last millimetre of
  the approach, from :data:`GAP_MM` ``[0]`` (the paper's 3-pixel contact criterion: below
  it the blurred edges of finger and surface merge) up to :data:`GAP_MM` ``[1]``, its
  last :data:`N_FRAMES` frames: the gap is ``v tau + a tau^2 + j tau^3`` of the time to the
  touch ``tau`` (the start of its Taylor series about the touch: a smooth approach, landing
  at the speed ``v``), fitted by least squares with the touch's instant (the coefficients
  linear, the instant by a search between the last frame of the approach and the frame
  after the first one with the finger on the surface). A finger that rests already in the
  first frames, or lands out of view, gives no touch.
* **Force** (:func:`touch_force`): the normal force ``(F1 + F2) / sqrt 2`` as recorded
  (before any filter, whose smear would move the instant), less the rest before the touch
  (a line and the mains with its harmonics 2-6, fitted over :data:`REST_S` before it), is
  ``k1 tau + k2 tau^2`` for ``tau = t - t0 > 0`` and 0 before: fitted by least squares from
  the rest up to :data:`FORCE_TOP` of the press's level. Its ``t0`` is the touch.

Standard errors are those of the least-squares fits (the residuals' scatter through the
fit's Jacobian). What neither sees: a delay between the finger's load and the recorded
force (a sensor's resonance, an anti-alias filter), which adds to the offset as it is.
Figures: ``docs/selfcheck.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from .flags import SelfCheckParams

__all__ = [
    "TouchDown",
    "TouchLevel",
    "touch_video",
    "touch_force",
    "touch_level",
    "GAP_MM",
    "FORCE_TOP",
    "REST_S",
    "TOUCH_SE_FLOOR_S",
]

#: The part of the approach the video's touch is fitted on: the finger's gap above the
#: surface in mm, from the paper's contact criterion (3 pixels of 23 um: below it the video
#: stage calls the finger in contact, and the blurred edges of finger and surface merge)
#: to a millimetre.
GAP_MM = (0.069, 1.0)
#: Frames of that part of the approach the touch is fitted on (the last ones before it,
#: at most): the gap ``v tau + a tau^2 + j tau^3`` of ``tau`` = time to the touch has four
#: unknowns with the touch; the others measure their scatter.
N_FRAMES = 8
#: Fewest such frames.
MIN_FRAMES = 5
#: The force's touch is fitted up to this fraction of the press's level.
FORCE_TOP = 0.1
#: The rest before the touch the force's baseline is fitted on: from ``REST_S[0]`` to
#: ``REST_S[1]`` s before the force first reaches :data:`FORCE_TOP` of the press.
REST_S = (0.12, 0.02)


@dataclass(frozen=True)
class TouchDown:
    """The instant of the touch-down on one recording's clock.

    Attributes
    ----------
    t_s : float
        The instant in s on the recording's clock as the manifest states it (NaN: not
        measured).
    se_s : float
        Its standard error in s.
    message : str
        How it was measured, or why it could not be.
    """

    t_s: float
    se_s: float
    message: str = ""

    @property
    def measured(self) -> bool:
        return math.isfinite(self.t_s) and math.isfinite(self.se_s)


def _none(why: str) -> TouchDown:
    return TouchDown(math.nan, math.nan, why)


def touch_video(t_frames, gap_mm) -> TouchDown:
    """The instant the finger's lowest point reaches the surface, on the video clock.

    Parameters
    ----------
    t_frames : (n,) array_like
        Frame times in s (the manifest's video clock).
    gap_mm : (n,) array_like
        The finger's lowest point above the surface per frame in mm (NaN: no outline).

    Returns
    -------
    TouchDown
    """
    t = np.asarray(t_frames, float)
    g = np.asarray(gap_mm, float)
    if g.shape != t.shape:
        return _none(f"{g.size} gaps for {t.size} frames")
    fin = np.isfinite(g)
    closed = np.flatnonzero(fin & (g < GAP_MM[0]))
    if closed.size == 0:
        return _none("the finger never comes within the gap's lower bound of the surface in the video")
    k_c = int(closed[0])
    rests = np.flatnonzero(fin & (g <= 0.0) & (np.arange(g.size) >= k_c))
    k_0 = int(rests[0]) if rests.size else k_c
    # the approach: the frames just before the first closed one, back while the gap is
    # within GAP_MM and grows (going back in time)
    ks = []
    k = k_c - 1
    while k >= 0 and fin[k] and g[k] <= GAP_MM[1] and (not ks or g[k] > g[ks[-1]]):
        ks.append(k)
        k -= 1
    if len(ks) < MIN_FRAMES:
        return _none(
            f"{len(ks)} frames of the finger's approach within {GAP_MM[0]:g}-{GAP_MM[1]:g} mm of the "
            f"surface (needs {MIN_FRAMES}): it lands too fast for the frame rate, rests in the first "
            "frames, or lands out of view"
        )
    ks = np.array(ks[::-1])[-N_FRAMES:]
    tt, gg = t[ks], g[ks]
    k_last = min(k_0 + 1, t.size - 1)
    t_lo, t_hi = float(tt[-1]), float(t[k_last])
    if not t_hi > t_lo:
        return _none("the finger rests in the frame after its approach: no time left for the touch")

    def ssr(tc: float):
        tau = tc - tt
        V = np.column_stack([tau, tau**2, tau**3])
        c, *_ = np.linalg.lstsq(V, gg, rcond=None)
        r = gg - V @ c
        return float(r @ r), c

    grid = np.linspace(t_lo, t_hi, 101)
    vals = np.array([ssr(tc)[0] for tc in grid])
    k = int(np.argmin(vals))
    step = float(grid[1] - grid[0])
    t0 = float(grid[k])
    curv = math.nan
    if 0 < k < grid.size - 1:
        y0, y1, y2 = vals[k - 1 : k + 2]
        den = y0 - 2 * y1 + y2
        if den > 0:
            t0 += 0.5 * (y0 - y2) / den * step
            curv = den / step**2
    best, coef = ssr(t0)
    if coef[0] <= 0:
        return _none("the finger's approach does not extrapolate to the surface before it rests")
    # the fit's own error, and at least that of an instant known only to lie between two
    # frames (the extrapolation's model error is of that order, docs/selfcheck.md)
    dof = max(len(ks) - 4, 1)
    se_fit = math.sqrt(2.0 * best / dof / curv) if curv > 0 else math.inf
    period = float(np.median(np.diff(tt)))
    se = min(math.hypot(se_fit, period / math.sqrt(12.0)), t_hi - t_lo)
    return TouchDown(t0, se, f"the gap closes at {coef[0]:.0f} mm/s ({len(ks)} frames of the approach)")


def _rest_model(s: np.ndarray, mains_hz: float) -> np.ndarray:
    cols = [np.ones_like(s), s - s.mean()]
    if math.isfinite(mains_hz) and mains_hz > 0:
        for h in range(1, 7):
            w = 2 * math.pi * h * mains_hz * s
            cols += [np.cos(w), np.sin(w)]
    return np.column_stack(cols)


def touch_force(f1, f2, fs_hz: float, t0_s: float = 0.0, *,
                mains_hz: float = SelfCheckParams().mains_hz[0]) -> TouchDown:
    """The instant the normal force leaves zero, on the force clock.

    Parameters
    ----------
    f1, f2 : (n,) array_like
        The two channels as recorded, N (``F_N = (F1 + F2) / sqrt 2``).
    fs_hz, t0_s : float
        The force clock as the manifest states it: sample ``k`` at ``t0_s + k / fs_hz``.
    mains_hz : float
        The mains frequency on that clock (removed from the rest with its harmonics 2-6;
        NaN: none); default the first nominal one of
        :attr:`SelfCheckParams.mains_hz <fingerfriction.selfcheck.flags.SelfCheckParams>` (50 Hz).

    Returns
    -------
    TouchDown
    """
    fn = (np.asarray(f1, float) + np.asarray(f2, float)) / math.sqrt(2.0)
    if fn.size < 100 or not np.isfinite(fn).all():
        return _none("the force record is too short or holds NaN")
    s = t0_s + np.arange(fn.size) / fs_hz
    level = float(np.percentile(fn, 95) - np.percentile(fn, 5))
    if not level > 0:
        return _none("the normal force never rises")
    base0 = float(np.median(fn[: max(int(0.02 * fs_hz), 10)]))
    up = np.flatnonzero(fn - base0 > 0.5 * level)
    if up.size == 0:
        return _none("the normal force never rises to half its level")
    k50 = int(up[0])
    below = np.flatnonzero(fn[:k50] - base0 < FORCE_TOP * level)
    if below.size == 0:
        return _none("the force record starts during the press: no touch-down in it")
    k_top = int(below[-1]) + 1
    lo = k_top - int(round(REST_S[0] * fs_hz))
    hi = k_top - int(round(REST_S[1] * fs_hz))
    if hi - max(lo, 0) < int(0.02 * fs_hz):
        return _none(
            f"less than 20 ms of rest before the press in the force record (needs its {1e3 * REST_S[1]:g} ms "
            "before the touch free)"
        )
    lo = max(lo, 0)
    A = _rest_model(s[lo:hi], mains_hz)
    coef, *_ = np.linalg.lstsq(A, fn[lo:hi], rcond=None)
    noise = float(np.std(fn[lo:hi] - A @ coef))
    seg = slice(hi, k_top + 1)
    ss = s[seg]
    # the rest's model evaluated over the onset (its line centred on the rest's mean time)
    B = _rest_model(np.concatenate([s[lo:hi], ss]), mains_hz)[hi - lo :]
    y = fn[seg] - B @ coef
    top = float(y[-1])
    if not top > 10 * noise:
        return _none("the force's onset is lost in the rest's noise")
    # the start: the line through the last crossings of 20 % and 100 % of the window's top
    k20 = int(np.flatnonzero(y < 0.2 * top)[-1])
    k1 = 0.8 * top / max(float(ss[-1] - ss[k20]), 1.0 / fs_hz)
    t_guess = float(ss[k20]) - 0.2 * top / k1

    def model(p):
        tau = np.clip(ss - p[0], 0.0, None)
        return p[1] * tau + p[2] * tau * tau

    def resid(p):
        return model(p) - y

    res = least_squares(
        resid,
        [min(max(t_guess, float(ss[0])), float(ss[-1])), k1, 0.0],
        bounds=([float(ss[0]), 0.0, -np.inf], [float(ss[-1]), np.inf, np.inf]),
        x_scale=[1e-3, k1, k1 / 1e-3],
    )
    t0 = float(res.x[0])
    J = res.jac
    r = res.fun
    dof = max(r.size - 3, 1)
    try:
        cov = np.linalg.inv(J.T @ J) * float(r @ r) / dof
        se = math.sqrt(max(float(cov[0, 0]), 0.0))
    except np.linalg.LinAlgError:
        se = math.inf
    if not (float(ss[0]) < t0 < float(ss[-1])) or not math.isfinite(se):
        return _none("the force's onset did not fit a finger landing (a slope from zero)")
    return TouchDown(
        t0,
        se,
        f"F_N leaves 0 at {res.x[1]:.3g} N/s ({r.size} samples up to {100 * FORCE_TOP:g} % of the press)",
    )


#: Smallest standard error of one trial's touch-down offset, s: what the video's gap
#: reading near the surface (a tenth of a pixel, 2 um) makes of the instant at the
#: slowest landings (about 20 mm/s), and the force's onset at its noise.
TOUCH_SE_FLOOR_S = 1e-4


@dataclass(frozen=True)
class TouchLevel:
    """The part of a finger's offsets that its trials share, from their touch-downs.

    Attributes
    ----------
    coef : (k,) ndarray
        ``(c,)`` or ``(c, k)``: the level ``c`` (s), and with the speed term the
        coefficient ``k`` of ``v^-1/4`` (s (mm/s)^1/4).
    cov : (k, k) ndarray
        Their covariance.
    n : int
        Trials it rests on.
    """

    coef: np.ndarray
    cov: np.ndarray
    n: int

    def at(self, speed: float) -> tuple[float, float]:
        """The level (s) and its standard error for a trial of speed ``speed`` (mm/s)."""
        x = np.array([1.0, speed**-0.25])[: self.coef.size]
        return float(x @ self.coef), math.sqrt(max(float(x @ self.cov @ x), 0.0))


def touch_level(items, rel: dict, *, speeds: dict | None = None) -> TouchLevel | None:
    """What the touch-downs say a finger's trials share beyond their relative offsets.

    Each trial's touch-down offset ``d_i`` (:attr:`OnsetData.touch_offset_s`) less its
    offset relative to the finger's other trials ``rel_i`` measures the same level ``c``;
    with ``speeds`` also a term ``k v_i^-1/4`` (what the starts of the slides cannot tell
    from a common shift, :mod:`.sync`). Weighted least squares (weights ``1 / (se_i^2 +``
    :data:`TOUCH_SE_FLOOR_S` ``^2)``), after dropping a trial more than 5 robust standard
    deviations from the weighted median; the covariance is scaled up by the residuals'
    reduced chi-square when it exceeds 1.

    Parameters
    ----------
    items : iterable of OnsetData
    rel : dict
        Trial id -> its relative offset, s.
    speeds : dict, optional
        Trial id -> its sliding speed, mm/s.

    Returns
    -------
    TouchLevel, or None with fewer than 3 trials measured.
    """
    d, se, v = [], [], []
    for o in items:
        r = rel.get(o.trial_id, math.nan)
        if not (math.isfinite(o.touch_offset_s) and math.isfinite(o.touch_se_s) and math.isfinite(r)):
            continue
        sp = math.nan if speeds is None else speeds.get(o.trial_id, math.nan)
        if speeds is not None and not (math.isfinite(sp) and sp > 0):
            continue
        d.append(o.touch_offset_s - r)
        se.append(o.touch_se_s)
        v.append(sp)
    if len(d) < 3:
        return None
    d, se, v = np.array(d), np.array(se), np.array(v)
    w = 1.0 / (se**2 + TOUCH_SE_FLOOR_S**2)
    order = np.argsort(d)
    cw = np.cumsum(w[order])
    med = float(d[order][np.searchsorted(cw, 0.5 * cw[-1])])
    mad = 1.4826 * float(np.median(np.abs(d - med)))
    keep = np.abs(d - med) <= max(5.0 * mad, 5.0 * TOUCH_SE_FLOOR_S)
    d, w, v = d[keep], w[keep], v[keep]
    X = np.ones((d.size, 1)) if speeds is None else np.column_stack([np.ones(d.size), v**-0.25])
    if X.shape[1] == 2 and (d.size < 4 or v.max() / v.min() < 1.3):
        X = X[:, :1]
    A = X.T @ (w[:, None] * X)
    cov = np.linalg.inv(A)
    coef = cov @ (X.T @ (w * d))
    r = d - X @ coef
    dof = d.size - X.shape[1]
    if dof > 0:
        chi2 = float(np.sum(w * r * r)) / dof
        cov = cov * max(chi2, 1.0)
    return TouchLevel(coef, cov, int(d.size))
