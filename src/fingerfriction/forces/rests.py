"""The sensor's steps of the force chain (:func:`sensor_chain`): the rests before the touch
and after the lift-off, the baseline, notch and low-pass filters, and the compensation of the
piezo chain's high-pass (at a given, estimated or measured response), with the residual
drift fitted on both rests. :func:`fingerfriction.forces.chain.process_forces` runs it first,
then maps the forces onto the positions; ``docs/forces.md`` explains the order and the
choices beyond the paper.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..flags import Flag
from .filters import lowpass_filter
from .params import ForceProcessingParams
from .response import estimate_response
from .sensor import compose, detect_baseline, detect_post_baseline
from .signals import ForceSignals

__all__ = ["sensor_chain"]


def sensor_chain(sig: ForceSignals, params: ForceProcessingParams, flags: list):
    """The sensor's steps on the decomposed forces: baseline (drift line and mains on the rest
    before the touch), notch, low-pass, high-pass compensation (at the estimated cut-off
    with ``estimate_highpass``), residual drift on both rests.

    Returns
    -------
    (signals, base, post) : the processed :class:`ForceSignals`, the rest before the touch
    (mask or None) and the rest after the lift-off (``(mask, description)`` or None).
    """
    fit_mains = params.mains in ("fit", "both") and bool(params.notch_hz)
    notch = params.mains in ("notch", "both") and bool(params.notch_hz)
    base = None
    if params.sensor_highpass_hz is not None or fit_mains:
        base = _baseline_mask(sig, params, flags)
        if base is not None:
            sig = sig.remove_baseline(base, mains_hz=params.notch_hz, subtract_mains=fit_mains)
        elif fit_mains:
            notch = True
            flags.append(
                Flag(
                    "warning",
                    "mains-notch",
                    "mains='fit' needs an unloaded baseline; the interference was removed by notch "
                    f"filters at {list(params.notch_hz)} Hz instead (they also remove the force's "
                    "own content there)",
                )
            )
    if notch:
        sig = sig.notch(params.notch_hz, q=params.notch_q)
    if params.lowpass_hz is not None:
        sig = sig.lowpass(params.lowpass_hz, order=params.lowpass_order)
    post = None
    if params.sensor_highpass_hz is not None and params.highpass_model == "second-order":
        sig, post = _response_compensation(sig, base, params, flags)
    elif params.sensor_highpass_hz is not None:
        if params.estimate_highpass:
            fc, sig, post = _estimated_compensation(sig, base, params, flags)
        else:
            fc = params.sensor_highpass_hz
            sig = sig.compensate_highpass(fc)
            post = _post_baseline_mask(sig, params, flags)
        if post is not None:
            rests = post[0] if base is None else post[0] | base
            sig = sig.remove_rest_drift(rests, fc, rests=_rests_text(base, post))
    return sig, base, post


def _baseline_mask(sig: ForceSignals, params: ForceProcessingParams, flags: list) -> np.ndarray | None:
    """The unloaded-rest samples before the high-pass compensation, or None (flagged)."""
    t = sig.times()
    fs = sig.fs_hz
    consequence = (
        "; the drift is not removed before the high-pass compensation (it becomes quadratic in time: "
        "only a rest after the lift-off, post_baseline, can remove it then; the flat-segment fit removes "
        "only its linear part)"
        if params.sensor_highpass_hz is not None
        else ""
    )
    if params.baseline is None:
        flags.append(Flag("warning", "no-baseline", "baseline=None" + consequence))
        return None
    if params.baseline == "auto":
        quick = lowpass_filter(np.vstack([sig.f_n, sig.f_t]), fs, min(50.0, 0.4 * fs))
        n = detect_baseline(
            quick[0], quick[1], fs, threshold=params.contact_threshold_n, guard_s=params.baseline_guard_s
        )
        mask = np.arange(t.size) < n
        how = (
            f"the record starts with {n / fs:.4f} s of rest before the force departs by "
            f"contact_threshold_n={params.contact_threshold_n:g} N"
        )
    else:
        lo, hi = params.baseline
        mask = (t >= lo) & (t <= hi)
        how = f"baseline=({lo:g}, {hi:g}) s holds {int(mask.sum())} samples"
    if mask.sum() < params.min_baseline_s * fs:
        flags.append(
            Flag(
                "warning",
                "no-baseline",
                f"no usable unloaded baseline: {how}, less than min_baseline_s={params.min_baseline_s:g} s"
                + consequence
                + ". Record a rest before the touch, or set baseline=(t_lo, t_hi)",
            )
        )
        return None
    return mask


def _post_baseline_mask(sig: ForceSignals, params: ForceProcessingParams, flags: list):
    """The unloaded rest after the lift-off, as (mask, description), or None (flagged)."""
    if params.post_baseline is None:
        return None
    t = sig.times()
    fs = sig.fs_hz
    if params.post_baseline == "auto":
        k = detect_post_baseline(
            sig.f_n, sig.f_t, fs, max_rate=params.rest_rate_n_per_s, guard_s=params.baseline_guard_s
        )
        mask = np.arange(t.size) >= k
        how = (
            f"the record ends with {(t.size - k) / fs:.4f} s of rest after the lift-off (forces changing "
            f"slower than rest_rate_n_per_s={params.rest_rate_n_per_s:g} N/s, F_N below a quarter of its "
            "maximum)"
        )
    else:
        lo, hi = params.post_baseline
        mask = (t >= lo) & (t <= hi)
        how = f"post_baseline=({lo:g}, {hi:g}) s holds {int(mask.sum())} samples"
    if mask.sum() < max(params.min_baseline_s * fs, 4):
        flags.append(
            Flag(
                "warning",
                "no-post-baseline",
                f"no usable unloaded rest after the lift-off: {how}, less than "
                f"min_baseline_s={params.min_baseline_s:g} s (the record ends in contact or too soon); the "
                "drift line under the high-pass compensation rests on the baseline before the touch alone, "
                "whose slope error grows quadratically through the compensation (up to 5.5 % of the "
                "peak-to-peak at 40 mm/s on simulated trials, against 1 % with both rests). Record a rest "
                "after the lift-off, or set post_baseline=(t_lo, t_hi)",
            )
        )
        return None
    return mask, how


def _rests_text(base, post) -> str:
    which = "after the lift-off" if base is None else "before the touch and after the lift-off"
    return f"{which}; {post[1]}"


def _post_rest_near_prior(raw: ForceSignals, params: ForceProcessingParams, tried: list):
    """The rest after the lift-off detected on ``raw`` compensated at the prior cut-off and,
    with ``post_baseline='auto'``, at 0.9, 1.1, 0.8, 1.2, 0.7, 1.3 times it (a wrong cut-off
    leaves a decaying error that can delay or hide the rest); the prior's flags go to
    ``tried``. ``(mask, description)`` or None."""
    prior = params.sensor_highpass_hz
    post = _post_baseline_mask(raw.compensate_highpass(prior), params, tried)
    if post is None and params.post_baseline == "auto":
        for s in (0.9, 1.1, 0.8, 1.2, 0.7, 1.3):
            post = _post_baseline_mask(raw.compensate_highpass(s * prior), params, [])
            if post is not None:
                break
    return post


def _estimated_compensation(raw: ForceSignals, base, params: ForceProcessingParams, flags: list):
    """Compensate the high-pass at the cut-off estimated on the rests (:func:`estimate_highpass`).

    The rest after the lift-off is detected on the forces compensated at the prior. A wrong
    cut-off leaves there a decaying error (a fraction ``fc / prior - 1`` of the high-pass
    tail, time constant ``1 / (2 pi fc)``) that can delay or hide the rest: when none is
    found at the prior, the detection is tried at the prior times 0.9, 1.1, 0.8, 1.2, 0.7,
    1.3. After the estimate the rest is detected again at the estimate, and the estimate
    repeated (at most twice) while the rest changes. Falls back on the prior, with a flag,
    when no rest after the lift-off is found or the rests do not determine the cut-off.

    Returns
    -------
    (cutoff_hz, signals, post) : the cut-off used, ``raw`` compensated at it (with the
    estimate in its history), and the rest after the lift-off as for
    :func:`_post_baseline_mask` (or None).
    """
    prior = params.sensor_highpass_hz
    tried: list[Flag] = []
    post = _post_rest_near_prior(raw, params, tried)
    if post is None:
        flags.extend(tried)
        flags.append(
            Flag(
                "warning",
                "highpass-estimate",
                "estimate_highpass=True but there is no usable rest after the lift-off (see the "
                "no-post-baseline flag), so the cut-off is not determined; the prior "
                f"sensor_highpass_hz={prior:g} Hz was used",
            )
        )
        return prior, raw.compensate_highpass(prior), None
    for _ in range(3):
        rests = post[0] if base is None else post[0] | base
        sig, est = raw.estimate_highpass(rests, prior, rests=_rests_text(base, post))
        if not est.success:
            flags.append(
                Flag(
                    "warning",
                    "highpass-estimate",
                    f"estimate_highpass=True but {est.message}; the prior sensor_highpass_hz={prior:g} Hz "
                    "was used",
                )
            )
            return prior, sig.compensate_highpass(prior), post
        again = sig.compensate_highpass(est.fc_hz)
        if params.post_baseline != "auto":
            break
        new = _post_baseline_mask(again, params, [])
        if new is None or np.array_equal(new[0], post[0]):
            break
        post = new
    if abs(est.rel_change) > params.highpass_max_change:
        flags.append(
            Flag(
                "warning",
                "highpass-estimate",
                f"the sensor cut-off estimated on the rests, {est.fc_hz:.4g} +- {est.se_hz:.2g} Hz, is "
                f"{100 * est.rel_change:+.0f} % from the prior sensor_highpass_hz={prior:g} Hz (allowed "
                f"highpass_max_change={params.highpass_max_change:g}); it was used: check the sensor's "
                "specification, and that the rests are free of contact",
            )
        )
    return est.fc_hz, again, post


def _rough_post_rest(sig: ForceSignals, params: ForceProcessingParams):
    """A first guess of the rest after the lift-off when the forces compensated at the prior
    do not settle (a second pole left uninverted decays slowly, so neither their level nor
    their rate marks the rest): the unloading is the fastest fall of ``F_N`` (its
    derivative, smoothed by an 8 ms Gaussian, at its minimum); the rest starts
    ``baseline_guard_s`` after that derivative is back above a tenth of its minimum.
    ``(mask, description)`` or None."""
    fs = sig.fs_hz
    rate = ndimage.gaussian_filter1d(sig.f_n, 0.008 * fs, order=1, mode="nearest") * fs
    k_min = int(np.argmin(rate))
    back = np.flatnonzero(rate[k_min:] > 0.1 * rate[k_min])
    if not back.size or not rate[k_min] < 0:
        return None
    k = k_min + int(back[0]) + int(round(params.baseline_guard_s * fs))
    mask = np.arange(sig.f_n.size) >= k
    if mask.sum() < max(params.min_baseline_s * fs, 8):
        return None
    return mask, (f"first guess: from {params.baseline_guard_s:g} s after the unloading (the fastest fall "
                  f"of F_N) to the end ({mask.sum() / fs:.4f} s)")


def _response_compensation(raw: ForceSignals, base, params: ForceProcessingParams, flags: list):
    """``highpass_model='second-order'``: each transducer's response estimated on the rests
    (:func:`~fingerfriction.forces.response.estimate_response`) and inverted, its drift
    removed through it (:meth:`ForceSignals.compensate_response`).

    The rest after the lift-off is detected on the forces compensated at the prior (first
    order, tried at 0.7-1.3 times it), else guessed (:func:`_rough_post_rest`); after the
    estimate it is detected again on the compensated forces and the estimate repeated (at
    most twice) while it changes. Without any rest after the lift-off the response is not
    determined: the prior's first order is used, with a flag.

    Returns
    -------
    (signals, post) : compensated and drift-corrected signals, and the rest after the
    lift-off ``(mask, description)`` or None.
    """
    prior = params.sensor_highpass_hz
    tried: list = []
    post = _post_rest_near_prior(raw, params, tried)
    if post is None and params.post_baseline == "auto":
        post = _rough_post_rest(raw.compensate_highpass(prior), params)
    if post is None:
        flags.extend(tried)
        flags.append(Flag("warning", "highpass-estimate",
                          "highpass_model='second-order' but there is no usable rest "
                          "after the lift-off, so the response is not determined; the prior "
                          f"sensor_highpass_hz={prior:g} Hz (first order) was used"))
        sig = raw.compensate_highpass(prior)
        if base is not None:
            sig = sig.remove_rest_drift(base, prior, rests="before the touch")
        return sig, None
    chans = compose(raw.f_n, raw.f_t)
    for _ in range(3):
        rests = post[0] if base is None else post[0] | base
        ests = [estimate_response(y, rests, raw.fs_hz, prior) for y in chans]
        sig = raw.compensate_response([e.response for e in ests], rests,
                                      rests_text=_rests_text(base, post), estimates=ests)
        if params.post_baseline != "auto":
            break
        new = _post_baseline_mask(sig, params, [])
        if new is None or np.array_equal(new[0], post[0]):
            break
        post = new
    for c, e in enumerate(ests):
        if not e.success:
            flags.append(Flag("warning", "highpass-estimate", f"transducer F{c + 1}: {e.message}; the prior "
                              f"sensor_highpass_hz={prior:g} Hz (first order) was used for it"))
        elif abs(e.cutoff_hz / prior - 1.0) > params.highpass_max_change:
            change = 100 * (e.cutoff_hz / prior - 1)
            flags.append(Flag("warning", "highpass-estimate",
                              f"transducer F{c + 1}: the high-pass estimated on the "
                              f"rests has its -3 dB cut-off at {e.cutoff_hz:.4g} Hz, {change:+.0f} % from "
                              "the "
                              f"prior sensor_highpass_hz={prior:g} Hz (allowed highpass_max_change="
                              f"{params.highpass_max_change:g}); it was used: check the sensor's "
                              "specification, and that the rests are free of contact"))
    return sig, post
