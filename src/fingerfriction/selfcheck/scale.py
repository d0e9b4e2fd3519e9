"""The force's scale against the contact the video shows: a trial whose normal force is
far from what its finger's other trials press at the same contact length.

Why
---
A sensitivity off by the same factor on both channels (or forces in another unit) scales
every force alike: the loading angle, F_T / F_N and the friction level do not change,
and 10 x 0.3 N is a plausible 3 N press (:mod:`.channels` cannot see it). The video can:
a finger pressed harder shows a longer contact (2-D Hertz: the half-width grows as the
square root of the load), so a trial whose F_N is ten times its finger's others at the
same contact length is not a harder press but a wrong scale.

What is compared
----------------
Per trial (:func:`flat_contact_length`): the median contact length in mm over the frames
where the finger slides on flat ground (every contact region clear of the feature), and
the median F_N while it presses (:class:`~.channels.ForceFigures`, no clock needed). Per
finger (:func:`scale_checks`): ``r_i = ln F_i - 2 ln L_i`` (F ~ L^2, the line contact's
law) against the median of the finger's reference trials; a trial more than
:data:`SCALE_FACTOR` times off is ``force-scale`` (error).

Why not an absolute check (one trial alone): the contact length a finger shows at a load
depends on its radius and stiffness, whose range across people spans more than the
factor 10 to be caught (``docs/selfcheck.md`` measures both readings).
"""

from __future__ import annotations

import math

import numpy as np

from .flags import Check

__all__ = ["flat_contact_length", "scale_checks", "SCALE_FACTOR", "MIN_FLAT_FRAMES"]

#: How far (x) a trial's F_N may be from its finger's others at the same contact length.
SCALE_FACTOR = 3.0
#: Fewest frames of sliding on flat ground for a contact length.
MIN_FLAT_FRAMES = 10
#: Clearance in mm between the contact and the feature for a frame to be on flat ground.
CLEAR_MM = 0.5
#: Distance in mm the finger must have slid from its rest (its press is over).
SLID_MM = 1.0


def flat_contact_length(x_frames, regions, feature_extent) -> float:
    """Median total contact length in mm over the frames where the finger slides on flat
    ground (NaN: fewer than :data:`MIN_FLAT_FRAMES` such frames).

    Parameters
    ----------
    x_frames : (n,) array_like
        Finger position per frame, mm (NaN unknown).
    regions : (n, k, 2) array_like
        Contact regions per frame, mm (:mod:`fingerfriction.regions`).
    feature_extent : (float, float)
        The feature's extent in mm (:attr:`fingerfriction.surfaces.Surface.feature_extent`).
    """
    x = np.asarray(x_frames, float)
    reg = np.asarray(regions, float)
    if reg.ndim != 3 or reg.shape[0] != x.size or not np.isfinite(x).any():
        return math.nan
    lo, hi = float(feature_extent[0]) - CLEAR_MM, float(feature_extent[1]) + CLEAR_MM
    has = np.isfinite(reg[..., 0])
    with np.errstate(invalid="ignore"):
        clear = np.all(~has | (reg[..., 1] < lo) | (reg[..., 0] > hi), axis=1)
        x0 = float(x[np.isfinite(x)][0])
        slid = np.abs(x - x0) > SLID_MM
    length = np.nansum(np.where(has, reg[..., 1] - reg[..., 0], 0.0), axis=1)
    use = has.any(axis=1) & clear & slid & np.isfinite(x)
    if use.sum() < MIN_FLAT_FRAMES:
        return math.nan
    return float(np.median(length[use]))


def scale_checks(items: dict, *, reference=None) -> dict[str, Check]:
    """The ``force-scale`` check of every trial against its finger's other trials.

    Parameters
    ----------
    items : dict
        Trial id -> ``(group, f_n_level_n, contact_mm)``: its finger, its median F_N while
        pressing (N) and its contact length on flat ground (mm; NaN: not measured).
    reference : set of str, optional
        Trials a finger's level is taken from (default all).

    Returns
    -------
    dict
        Trial id -> Check (``info`` when it could not be made).
    """
    r = {}
    for tid, (group, f, length) in items.items():
        ok = math.isfinite(f) and f > 0 and math.isfinite(length) and length > 0
        r[tid] = (group, math.log(f) - 2.0 * math.log(length) if ok else math.nan)
    out: dict[str, Check] = {}
    groups: dict = {}
    for tid, (group, v) in r.items():
        if math.isfinite(v) and (reference is None or tid in reference):
            groups.setdefault(group, []).append(v)
    for tid, (group, v) in r.items():
        ref = groups.get(group, [])
        if not math.isfinite(v):
            out[tid] = Check("force-scale", "info", math.nan, "x",
                             "not measured: no F_N level or no contact on flat ground in the video")
            continue
        if len(ref) < 3:
            out[tid] = Check("force-scale", "info", math.nan, "x",
                             f"not measured: {len(ref)} trials of finger {group!r} to compare with (needs 3)")
            continue
        ratio = math.exp(v - float(np.median(ref)))
        text = (
            f"F_N is {ratio:.2f}x what finger {group!r} presses in its other trials at the same contact "
            f"length (F ~ L^2)"
        )
        if ratio > SCALE_FACTOR or ratio < 1.0 / SCALE_FACTOR:
            out[tid] = Check(
                "force-scale",
                "error",
                ratio,
                "x",
                f"{text}, beyond {SCALE_FACTOR:g}x: the forces' scale looks off "
                "(force.sensitivity_n_per_v or force.units)",
                "force",
            )
        else:
            out[tid] = Check("force-scale", "ok", ratio, "x", text)
    return out
