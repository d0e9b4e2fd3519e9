"""Video-force synchronisation measured from the data: the start of the slide.

Why this event
--------------
Both recordings see the finger start to slide: the video as x(t) leaving its rest, the
force sensor as F_T rising from nothing to friction. Between the two lies the skin's
pre-sliding (partial slip: the tangential force builds up over the first fraction of a
millimetre the finger moves, Mindlin-Cattaneo), whose law is not known. It is taken as a
function of displacement only, the same for every trial of a finger::

    F_T(s) / F_N(s) = a_i G(d_i(s + tau_i))

``s`` the force clock as the manifest states it, ``d_i`` the finger's displacement from
its rest on the video clock, ``G`` the finger's pre-sliding law (free: a piecewise-linear
function of d, fitted), ``a_i`` the trial's friction level and ``tau_i`` what must be
added to the force clock to put it on the video clock (the correction to
``force.t0_s``). Because the finger accelerates, ``d_i(s)`` differs in shape from trial to
trial, so one ``G`` pins every ``tau_i``: a wrong offset shows as a trial whose rise does
not fall on its finger's curve.

What it resolves (figures in ``docs/selfcheck.md``): the trials' offsets relative to
their subject's other trials; a common offset of all of a finger's trials is seen only
through the differences between accelerations, weakly. The features of the relief are not
used: how a relief shapes the force is what the study measures, and an assumed shape
biases the offset.

The ratio of the clock rates is not fitted here: over the 0.1 s of the start it is not
determined. The force clock is read against the mains instead (:mod:`.clock`), the video
clock against its frames' time stamps (:func:`fingerfriction.video.reader_base.frame_rate`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize_scalar

from .._check import check_option
from .estimate import OffsetEstimate
from .onsets import MOTION_MM, WINDOW_S, OnsetData, onset_data
from .touchdown import touch_level

__all__ = ["OnsetData", "OffsetEstimate", "onset_data", "estimate_offsets", "MOTION_MM", "PRIOR_D_MM"]

#: Knots of G in mm of displacement: dense where skin pre-slides.
KNOTS_MM = np.array(
    [
        -0.05,
        0.0,
        0.01,
        0.02,
        0.03,
        0.04,
        0.05,
        0.06,
        0.08,
        0.10,
        0.12,
        0.15,
        0.2,
        0.3,
        0.45,
        0.65,
        0.9,
        1.2,
        1.6,
        2.0,
        3.0,
        4.5,
        6.5,
        9.0,
    ]
)
#: Displacement range in mm within which a finger's friction reaches half its level, the
#: prior of a trial with no other trial of its finger to compare with: its offset's
#: standard error spans it.
PRIOR_D_MM = (0.02, 0.5)
#: Fewest trials of a finger for the relative estimate.
MIN_TRIALS = 3


# --------------------------------------------------------------------------------------
# the model: a_i G(d_i(s + tau_i)), G piecewise linear on KNOTS_MM


def _hat(d: np.ndarray) -> np.ndarray:
    """Piecewise-linear basis on :data:`KNOTS_MM` (values clipped to the knots' range)."""
    k = KNOTS_MM
    d = np.clip(d, k[0], k[-1])
    j = np.clip(np.searchsorted(k, d) - 1, 0, k.size - 2)
    w = (d - k[j]) / (k[j + 1] - k[j])
    B = np.zeros((d.size, k.size))
    rows = np.arange(d.size)
    B[rows, j] = 1.0 - w
    B[rows, j + 1] = w
    return B


def _design(o: OnsetData, tau: float):
    """(basis, ratio) over the window in video time for offset ``tau``."""
    T = o.s + tau
    sel = (T >= o.t_motion - WINDOW_S[0]) & (T <= o.t_motion + WINDOW_S[1]) & np.isfinite(o.ratio)
    if sel.sum() < 10:
        return None, None
    d = np.interp(T[sel], o.t_video, o.d_video)
    return _hat(d), o.ratio[sel]


def _fit_g(data: list[OnsetData], taus, designs=None) -> np.ndarray | None:
    """G (knot values) and the trials' levels a_i by alternating least squares
    (``designs``: the trials' :func:`_design` at ``taus``, when already built)."""
    if designs is None:
        designs = [_design(o, t) for o, t in zip(data, taus, strict=True)]
    designs = [(B, r) for B, r in designs if B is not None]
    if not designs:
        return None
    a = np.ones(len(designs))
    g = None
    grams = [(B.T @ B, B.T @ r) for B, r in designs]
    ridge = 1e-9 * np.eye(KNOTS_MM.size)  # knots no sample reaches stay at 0
    for _ in range(4):
        # normal equations of sum_i |r_i - a_i B_i g|^2 (a 24 x 24 system)
        M = sum(ai * ai * BB for ai, (BB, _) in zip(a, grams, strict=True)) + ridge
        v = sum(ai * Br for ai, (_, Br) in zip(a, grams, strict=True))
        g = np.linalg.solve(M, v)
        for i, (B, r) in enumerate(designs):
            p = B @ g
            pp = float(p @ p)
            a[i] = float(p @ r) / pp if pp > 0 else 1.0
        m = float(np.mean(a))
        if m > 0:
            a /= m
    return g


def _rss(o: OnsetData, g: np.ndarray, tau: float, design=None) -> float:
    """The trial's misfit to ``a G`` at offset ``tau`` (its level ``a`` fitted), relative to
    its own power over the window: a window that misses the rise cannot fit by ``a = 0``
    (``design``: the trial's :func:`_design` at ``tau``, when already built)."""
    B, r = _design(o, tau) if design is None else design
    if B is None:
        return math.inf
    p = B @ g
    pp = float(p @ p)
    rr = float(r @ r)
    if not (pp > 0 and rr > 0):
        return math.inf
    a = max(float(p @ r) / pp, 0.0)
    e = r - a * p
    return float(e @ e) / rr


def _best_tau(o: OnsetData, g: np.ndarray, lo: float, hi: float) -> float:
    """The offset in ``[lo, hi]`` (s) minimising the trial's misfit to G: a 1 ms grid, then
    0.1 ms steps around its best point, then a parabola."""
    coarse = np.arange(lo, hi + 1e-9, 1e-3)
    r = np.array([_rss(o, g, t) for t in coarse])
    if not np.isfinite(r).any():
        return math.nan
    c = float(coarse[int(np.nanargmin(r))])
    fine = c + np.arange(-1.5e-3, 1.5e-3 + 1e-9, 1e-4)
    r = np.array([_rss(o, g, t) for t in fine])
    k = int(np.argmin(r))
    tau = float(fine[k])
    if 0 < k < fine.size - 1 and np.isfinite(r[k - 1 : k + 2]).all():
        y0, y1, y2 = r[k - 1 : k + 2]
        den = y0 - 2 * y1 + y2
        if den > 0:
            tau += 0.5 * (y0 - y2) / den * 1e-4
    return tau


def _half_rise_offset(o: OnsetData, d_half: float) -> float:
    """Offset that puts the force's half rise (F_T / F_N reaching half its level) where the
    finger has moved ``d_half`` mm."""
    r = o.ratio
    fin = np.isfinite(r)
    if fin.sum() < 10:
        return math.nan
    level = float(np.nanpercentile(r, 75))
    if not level > 0:
        return math.nan
    above = np.flatnonzero(fin & (r > 0.5 * level))
    if above.size == 0:
        return math.nan
    s_half = float(o.s[above[0]])
    early = o.t_video <= o.t_motion
    if early.sum() < 2:
        return math.nan
    dv, tv = o.d_video[early], o.t_video[early]
    order = np.argsort(dv)
    t_half = float(np.interp(d_half, dv[order], tv[order]))
    return t_half - s_half


def _prior_estimate(o: OnsetData) -> OffsetEstimate:
    lo = _half_rise_offset(o, PRIOR_D_MM[0])
    hi = _half_rise_offset(o, PRIOR_D_MM[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return OffsetEstimate(
            o.trial_id,
            math.nan,
            math.nan,
            method="none",
            message="the force's rise at the start of the slide was not found",
        )
    mid = _half_rise_offset(o, math.sqrt(PRIOR_D_MM[0] * PRIOR_D_MM[1]))
    se = abs(hi - lo) / 4.0
    return OffsetEstimate(
        o.trial_id,
        mid,
        se,
        method="prior",
        n_reference=1,
        message=f"one trial of its finger: its force's half rise placed {1e3 * mid:+.1f} ms "
        f"from the manifest's clock, within the pre-sliding distance's range "
        f"{PRIOR_D_MM[0]:g}-{PRIOR_D_MM[1]:g} mm (+-{1e3 * 2 * se:.1f} ms)",
    )


#: Fastest over slowest trial of a finger needed to measure the offset its trials share:
#: trials at one speed accelerate alike, and a shift common to all of them then looks like
#: another pre-sliding law.
MIN_SPEED_SPREAD = 1.3

#: Most groups of the common offset's jackknife (one trial per group up to this many).
JACKKNIFE_GROUPS = 20


def _total_misfit(data: list[OnsetData], rel: np.ndarray, c: float) -> float:
    taus = rel + c
    designs = [_design(o, t) for o, t in zip(data, taus, strict=True)]  # built once for both
    g = _fit_g(data, taus, designs)
    if g is None:
        return math.inf
    return float(sum(_rss(o, g, t, d) for o, t, d in zip(data, taus, designs, strict=True)))


def _min_common(data: list[OnsetData], rel: np.ndarray, lo: float, hi: float, step: float) -> float:
    """The common shift in [lo, hi] minimising the total misfit: a grid, then a bounded
    search around its best point."""
    grid = np.arange(lo, hi + 1e-12, step)
    v = np.array([_total_misfit(data, rel, c) for c in grid])
    if not np.isfinite(v).any():
        return math.nan
    k = int(np.nanargmin(v))
    if k in (0, grid.size - 1):
        return math.nan  # no minimum inside the range
    res = minimize_scalar(
        lambda c: _total_misfit(data, rel, c),
        bounds=(grid[k - 1], grid[k + 1]),
        method="bounded",
        options={"xatol": 2e-5},
    )
    return float(res.x)


def _common_offset(data: list[OnsetData], rel: np.ndarray) -> tuple[float, float]:
    """The offset shared by a finger's trials (added to their relative offsets ``rel``) and
    its standard error, by the jackknife over trials (in at most :data:`JACKKNIFE_GROUPS`
    groups); (NaN, NaN) when it cannot be seen: the
    trials' speeds are too alike (:data:`MIN_SPEED_SPREAD`), or the misfit has no minimum
    within +-10 ms."""
    speeds = np.array([_speed(o) for o in data])
    speeds = speeds[np.isfinite(speeds) & (speeds > 0)]
    if speeds.size < MIN_TRIALS or speeds.max() / speeds.min() < MIN_SPEED_SPREAD:
        return math.nan, math.nan
    c = _min_common(data, rel, -0.01, 0.01, 1e-3)
    if not math.isfinite(c):
        return math.nan, math.nan
    # The delete-a-group jackknife (Efron & Tibshirani 1993, sec. 11.5): at most
    # JACKKNIFE_GROUPS groups of trials, each left out in turn. With one trial per group
    # (up to that many trials) it is the delete-one jackknife; beyond, it keeps the cost
    # linear in the trials: each replicate refits the law on every other trial, so the
    # delete-one jackknife grew as n^2 (docs/selfcheck.md). Groups interleave the trials,
    # so that each replicate keeps every speed and surface.
    n = len(data)
    n_groups = min(n, JACKKNIFE_GROUPS)
    groups = [np.arange(g, n, n_groups) for g in range(n_groups)]
    jack = []
    for idx in groups:
        left = set(idx.tolist())
        others = [o for j, o in enumerate(data) if j not in left]
        ck = _min_common(others, np.delete(rel, idx), c - 0.004, c + 0.004, 1e-3)
        if math.isfinite(ck):
            jack.append(ck)
    if len(jack) < len(groups) - 1:
        return c, math.inf
    jack = np.array(jack)
    se = math.sqrt((len(jack) - 1) / len(jack) * float(np.sum((jack - jack.mean()) ** 2)))
    return c, se


def estimate_offsets(
    data, *, mode: str = "check", reference=None, se_floor_s: float = 1e-4, common_floor_s: float = 1e-3
) -> dict[str, OffsetEstimate]:
    """Offsets of every trial: each finger's trials against each other.

    Parameters
    ----------
    data : iterable of OnsetData
    mode : {'check', 'auto'}
        ``'check'``: the manifest's clocks are the hypothesis. Each finger's pre-sliding
        law is fitted on its reference trials at offset 0 (robustly: a trial far from the
        others is left out and the law fitted again), and each trial's offset is measured
        against the law fitted without it. ``'auto'``: nothing is assumed: every trial's
        offset starts from its half rise and is refined jointly with the law.
    reference : set of str, optional
        Trials the law may be fitted on (default all): the others are only measured.
    se_floor_s : float
        Smallest standard error of a relative offset, s.
    common_floor_s : float
        Smallest standard error of the common offset, s (the common part is seen only
        through the differences between the trials' accelerations; the floor is what the
        virtual study needs, ``docs/selfcheck.md``).

    Returns
    -------
    dict
        Trial id -> :class:`OffsetEstimate`. ``offset_s = relative_s + common_s`` in
        ``'auto'``; in ``'check'`` ``offset_s`` is the relative offset (the reference
        trials' manifest clocks being the hypothesis) and the common offset is reported
        beside it.
    """
    check_option("mode", mode, ("check", "auto"))
    groups: dict[str, list[OnsetData]] = {}
    for o in data:
        groups.setdefault(o.group, []).append(o)
    out: dict[str, OffsetEstimate] = {}
    for items in groups.values():
        ref = [o for o in items if reference is None or o.trial_id in reference]
        if len(ref) < MIN_TRIALS:
            for o in items:
                est = _prior_estimate(o)
                out[o.trial_id] = OffsetEstimate(
                    o.trial_id,
                    est.offset_s,
                    est.se_s,
                    est.offset_s,
                    math.nan,
                    math.nan,
                    est.method,
                    len(ref),
                    est.message + f" (the relative estimate needs {MIN_TRIALS} trials of the finger; "
                    f"{len(ref)} here)",
                )
            continue
        if mode == "check":
            out.update(_check_group(items, ref, se_floor_s, common_floor_s))
        else:
            out.update(_auto_group(items, se_floor_s, common_floor_s))
    return out


def _prior_range(o: OnsetData, margin: float) -> tuple[float, float]:
    """The offsets (s) that put the trial's half rise anywhere in the pre-sliding distances
    :data:`PRIOR_D_MM`, widened by ``margin`` on each side ((NaN, NaN): no half rise)."""
    ends = [_half_rise_offset(o, d) for d in PRIOR_D_MM]
    if not all(math.isfinite(e) for e in ends):
        return math.nan, math.nan
    return min(ends) - margin, max(ends) + margin


def _loo_offsets(items, ref, taus_ref, *, centres=None, span: float = 0.012) -> dict[str, float]:
    """Each trial's offset against the law fitted on the reference trials (without itself),
    searched within ``span`` of ``centres``, or by default over every offset that puts the
    trial's half rise within the prior's pre-sliding distances :data:`PRIOR_D_MM`, and
    ``span`` beyond: a finger whose friction rises over 0.4 mm is as likely as one over
    0.1 mm, and a search centred on the prior's middle can miss the first's offset
    (``docs/selfcheck.md``)."""
    ids = [o.trial_id for o in ref]
    g_all = _fit_g(ref, taus_ref)
    res = {}
    for o in items:
        if o.trial_id in ids and len(ref) > MIN_TRIALS - 1:
            k = ids.index(o.trial_id)
            others = [r for j, r in enumerate(ref) if j != k]
            g = _fit_g(others, [t for j, t in enumerate(taus_ref) if j != k])
        else:
            g = g_all
        if centres is None:
            lo, hi = _prior_range(o, span)
        else:
            c = centres[items.index(o)]
            lo, hi = c - span, c + span
        if g is None or not (math.isfinite(lo) and math.isfinite(hi)):
            res[o.trial_id] = math.nan
            continue
        res[o.trial_id] = _best_tau(o, g, lo, hi)
    return res


def _check_group(items, ref, se_floor_s: float, common_floor_s: float) -> dict[str, OffsetEstimate]:
    taus = _loo_offsets(items, ref, [0.0] * len(ref))
    ref_t = np.array([taus[o.trial_id] for o in ref])
    ok = np.isfinite(ref_t)
    med = float(np.median(ref_t[ok])) if ok.any() else 0.0
    mad = float(np.median(np.abs(ref_t[ok] - med))) * 1.4826 if ok.any() else math.inf
    # a reference trial far from the others is measured, not trusted: fit again without it
    keep = [
        o
        for o, t in zip(ref, ref_t, strict=True)
        if np.isfinite(t) and abs(t - med) <= max(5.0 * mad, 2.0 * o.frame_period)
    ]
    if MIN_TRIALS <= len(keep) < len(ref):
        ref = keep
        taus = _loo_offsets(items, ref, [0.0] * len(ref))
        ref_t = np.array([taus[o.trial_id] for o in ref])
        ok = np.isfinite(ref_t)
        med = float(np.median(ref_t[ok]))
        mad = float(np.median(np.abs(ref_t[ok] - med))) * 1.4826
    se = max(mad, se_floor_s)
    level = touch_level(ref, {o.trial_id: taus[o.trial_id] for o in ref})
    if level is not None:  # the touch-downs fix what the trials share
        common, common_se = level.at(1.0)
        how = f"; the offset its trials share from {level.n} touch-downs"
    else:
        common, common_se = _common_offset(ref, np.zeros(len(ref)))
        if math.isfinite(common_se):
            common_se = max(common_se, common_floor_s)
        how = ""
    out = {}
    for o in items:
        t = taus[o.trial_id]
        out[o.trial_id] = OffsetEstimate(
            o.trial_id,
            t,
            se if math.isfinite(t) else math.nan,
            t,
            common,
            common_se,
            "relative",
            len(ref),
            f"against the pre-sliding law of {len(ref)} trials of finger {o.group!r}{how}",
            level_by="touch-down" if level is not None else "starts",
        )
    return out


def _auto_group(items, se_floor_s: float, common_floor_s: float) -> dict[str, OffsetEstimate]:
    """``mode='auto'``: when the manifest's clocks agree among themselves (the trials'
    offsets against each other's law are tight), the trials that disagree are put back on
    the consensus (``mode='check'``'s estimates). Otherwise every trial starts from its
    half rise at the prior's central pre-sliding distance and the trials are aligned on
    each other; what their starts cannot tell apart (a common shift, and a shift growing
    as speed^-1/4: a smooth start accelerates as t^3, along which a time shift and a
    change of the law look alike) stays at the prior, whose range sets the error."""
    checked = _check_group(items, items, se_floor_s, common_floor_s)
    offs = np.array([checked[o.trial_id].offset_s for o in items])
    fin = np.isfinite(offs)
    period = float(np.median([o.frame_period for o in items]))
    tight = fin.sum() >= MIN_TRIALS and np.mean(np.abs(offs[fin]) <= 2 * period) >= 0.7
    if tight:
        return _on_consensus(items, checked)
    return _aligned_from_starts(items, se_floor_s)


def _on_consensus(items, checked: dict) -> dict[str, OffsetEstimate]:
    """``mode='auto'`` when the manifest's clocks agree among themselves: ``mode='check'``'s
    estimates (``checked``), each moved by what the touch-downs measure of the consensus's
    own offset (a common shift, and one as speed^-1/4)."""
    # the consensus's own offset from the touch-downs: a common shift, and one as
    # speed^-1/4 (what the starts cannot tell from a change of the pre-sliding law)
    sp = {o.trial_id: _speed(o) for o in items}
    level = touch_level(items, {k: e.offset_s for k, e in checked.items()}, speeds=sp)
    out = {}
    for o in items:
        e = checked[o.trial_id]
        if level is not None and e.measured and math.isfinite(sp[o.trial_id]):
            c, c_se = level.at(sp[o.trial_id])
            e = replace(
                e,
                offset_s=e.offset_s + c,
                se_s=math.hypot(e.se_s, c_se),
                common_s=c,
                common_se_s=c_se,
                message=e.message + f" ({1e3 * c:+.2f} ms for this trial's speed, applied)",
                level_by="touch-down",
            )
        out[o.trial_id] = replace(
            e,
            message=e.message + "; the manifest's clocks agree among themselves: the others "
            "are put on their consensus",
        )
    return out


def _aligned_from_starts(items, se_floor_s: float) -> dict[str, OffsetEstimate]:
    """``mode='auto'`` when the manifest's clocks disagree: every trial starts from its half
    rise at the prior's central pre-sliding distance and the trials are aligned on each
    other; what their starts cannot tell apart (a common shift, and a shift growing as
    speed^-1/4) is placed by the touch-downs, or stays at the prior, whose range sets the
    error."""
    mid = math.sqrt(PRIOR_D_MM[0] * PRIOR_D_MM[1])
    out = {}
    usable, start, prior_se = [], [], []
    for o in items:
        est = _prior_estimate(o)
        if not est.measured:
            out[o.trial_id] = est
            continue
        usable.append(o)
        start.append(_half_rise_offset(o, mid))
        prior_se.append(est.se_s)
    if len(usable) < MIN_TRIALS:
        for o in usable:
            out[o.trial_id] = _prior_estimate(o)
        return out
    start = np.array(start)
    speeds = np.array([_speed(o) for o in usable])
    drift = np.column_stack([np.ones(len(usable)), speeds**-0.25])
    taus = start.copy()
    for _ in range(3):
        new = np.array(list(_loo_offsets(usable, usable, taus, centres=taus, span=0.005).values()))
        new = np.where(np.isfinite(new), new, taus)
        # keep what the starts cannot tell apart at the prior: remove the drift along
        # 1 and speed^-1/4 from the prior starts
        ok = np.isfinite(speeds)
        if ok.sum() >= 3:
            coef, *_ = np.linalg.lstsq(drift[ok], (new - start)[ok], rcond=None)
            new = new - np.where(ok, drift @ coef, 0.0)
        taus = new
    resid = taus - start
    se_rel = max(float(np.median(np.abs(resid - np.median(resid)))) * 1.4826, se_floor_s)
    # what the starts cannot tell (a common shift and one as speed^-1/4) from the touch-downs
    level = touch_level(
        usable,
        {o.trial_id: float(t) for o, t in zip(usable, taus, strict=True)},
        speeds={o.trial_id: float(v) for o, v in zip(usable, speeds, strict=True)},
    )
    for o, t, pse, v in zip(usable, taus, prior_se, speeds, strict=True):
        text = (
            f"the manifest's clocks disagree among themselves: {len(usable)} trials of finger "
            f"{o.group!r} aligned on each other from their half rise at {mid:.2g} mm of pre-sliding "
        )
        if level is not None and math.isfinite(v):
            c, c_se = level.at(float(v))
            out[o.trial_id] = OffsetEstimate(
                o.trial_id,
                float(t) + c,
                math.hypot(se_rel, c_se),
                float(t - np.median(taus)),
                float(np.median(taus)) + c,
                c_se,
                "joint",
                len(usable),
                text + f"and placed by {level.n} touch-downs",
                level_by="touch-down",
            )
            continue
        out[o.trial_id] = OffsetEstimate(
            o.trial_id,
            float(t),
            math.hypot(se_rel, pse),
            float(t - np.median(taus)),
            float(np.median(taus)),
            float(np.median(prior_se)),
            "joint",
            len(usable),
            text + f"(range {PRIOR_D_MM[0]:g}-{PRIOR_D_MM[1]:g} mm)",
            level_by="starts",
        )
    return out


def _speed(o: OnsetData) -> float:
    """The finger's speed in mm/s over the window's end (from the video)."""
    sel = (o.t_video >= o.t_motion) & (o.t_video <= o.t_motion + WINDOW_S[1])
    if sel.sum() < 3:
        return math.nan
    return float(np.polyfit(o.t_video[sel], o.d_video[sel], 1)[0])
