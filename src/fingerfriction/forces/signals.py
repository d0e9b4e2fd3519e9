"""The provenance object of the force stage: :class:`ForceSignals`, the two forces of a
trial in time with every step applied to them (``history``, in the manner of MNE-Python's
``Raw``: a thin method over each pure function of :mod:`.filters` and :mod:`.sensor`).

:func:`describe_step` turns one history entry into a line a person reads (the report's
run record shows it).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from .filters import design_lowpass, design_notch, zero_phase
from .params import MAINS_HZ, ForceProcessingParams
from .readers import ForceRecord
from .response import rest_drift_image
from .sensor import (
    HighpassEstimate,
    compensate_highpass,
    compose,
    decompose,
    estimate_highpass,
    fit_baseline,
    fit_rest_drift,
    remove_linear_drift,
)

#: The force stage's default options: their values are the steps' defaults.
_OPTS = ForceProcessingParams()

__all__ = ["ForceSignals", "describe_step", "describe_history"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ForceSignals:
    """Normal and tangential force of one trial in time, with the steps applied to them.

    Every method returns a new object whose ``history`` has one more entry (the step's
    name and parameters), in the spirit of MNE-Python's ``Raw`` objects.

    Attributes
    ----------
    f_n, f_t : (n,) ndarray
        Normal and tangential force in N.
    fs_hz : float
        Sampling frequency in Hz.
    t0_s : float
        Time in s of sample 0 on the trial's common clock.
    history : tuple of dict
        Steps applied, oldest first.
    """

    f_n: np.ndarray
    f_t: np.ndarray
    fs_hz: float
    t0_s: float = 0.0
    history: tuple = ()

    @classmethod
    def from_record(cls, record: ForceRecord) -> ForceSignals:
        """Decompose a :class:`~fingerfriction.forces.readers.ForceRecord` (Fig. 1C)."""
        f_n, f_t = decompose(record.f1, record.f2)
        step = {"step": "decompose", "formula": "F_N=(F1+F2)/sqrt2, F_T=(F1-F2)/sqrt2", "source": record.path}
        return cls(f_n, f_t, record.fs_hz, record.t0_s, (step,))

    @property
    def n_samples(self) -> int:
        return int(self.f_t.shape[0])

    def times(self) -> np.ndarray:
        """``(n,)`` sample times in s on the common clock."""
        return self.t0_s + np.arange(self.n_samples) / self.fs_hz

    def _with(self, step: dict, **changes) -> ForceSignals:
        logger.info("forces: %s", step)
        return replace(self, history=self.history + (step,), **changes)

    def notch(self, freqs: Sequence[float] = MAINS_HZ, *, q: float = _OPTS.notch_q) -> ForceSignals:
        """Zero-phase notch filters at ``freqs`` Hz (:func:`notch_filter`)."""
        if len(freqs) == 0:
            return self
        sos = design_notch(self.fs_hz, freqs, q)
        both = zero_phase(sos, np.vstack([self.f_n, self.f_t]), -1)
        step = {"step": "notch", "freqs_hz": [float(f) for f in freqs], "q": float(q), "zero_phase": True}
        return self._with(step, f_n=both[0], f_t=both[1])

    def lowpass(self, cutoff: float = _OPTS.lowpass_hz, *, order: int = _OPTS.lowpass_order) -> ForceSignals:
        """Zero-phase Butterworth low-pass at ``cutoff`` Hz (:func:`lowpass_filter`)."""
        sos = design_lowpass(self.fs_hz, cutoff, order)
        both = zero_phase(sos, np.vstack([self.f_n, self.f_t]), -1)
        step = {"step": "lowpass", "cutoff_hz": float(cutoff), "order": int(order), "zero_phase": True}
        return self._with(step, f_n=both[0], f_t=both[1])

    def remove_baseline(
        self, mask, *, mains_hz: Sequence[float] = MAINS_HZ, subtract_mains: bool = False
    ) -> ForceSignals:
        """Subtract the drift line fitted on an unloaded baseline (:func:`fit_baseline`), and
        with ``subtract_mains`` the mains sinusoids fitted with it, from the whole record."""
        t = self.times()
        out = {}
        sel = np.flatnonzero(mask)
        step: dict = {
            "step": "remove_baseline",
            "n_samples": int(sel.size),
            "t_s": [float(t[sel[0]]), float(t[sel[-1]])],
            "mains_subtracted_hz": [float(f) for f in mains_hz] if subtract_mains else [],
        }
        for name in ("f_n", "f_t"):
            fit = fit_baseline(t, getattr(self, name), mask, mains_hz=mains_hz)
            model = fit.line(t) + (fit.mains(t) if subtract_mains else 0.0)
            out[name] = getattr(self, name) - model
            key = "F_" + name[2:].upper()
            step[f"{key}_slope_N_per_s"] = fit.slope
            step[f"{key}_intercept_N"] = fit.intercept
            step[f"{key}_mains_amplitude_N"] = [float(a) for a in fit.amplitudes()]
        return self._with(step, **out)

    def compensate_highpass(self, cutoff: float) -> ForceSignals:
        """Invert the sensor's first-order high-pass at ``cutoff`` Hz (:func:`compensate_highpass`)."""
        both = compensate_highpass(np.vstack([self.f_n, self.f_t]), self.fs_hz, cutoff)
        step = {"step": "compensate_highpass", "cutoff_hz": float(cutoff), "order": 1, "from_rest": True}
        return self._with(step, f_n=both[0], f_t=both[1])

    def estimate_highpass(
        self, mask, prior: float, *, rests: str = "", max_rel_se: float = 0.1
    ) -> tuple[ForceSignals, HighpassEstimate]:
        """Estimate the sensor's cut-off from the unloaded rests ``mask`` (:func:`estimate_highpass`,
        ``F_N`` and ``F_T`` jointly, before the compensation). The data are unchanged; the
        returned object's history records the estimate."""
        both = np.vstack([self.f_n, self.f_t])
        est = estimate_highpass(both, mask, self.fs_hz, prior, max_rel_se=max_rel_se)
        step = {
            "step": "estimate_highpass",
            "rests": rests,
            "prior_hz": est.prior_hz,
            "cutoff_hz": est.fc_hz,
            "se_hz": est.se_hz,
            "n_samples": est.n_samples,
            "iterations": est.iterations,
            "rms_residual_N": est.rms_residual_n,
            "success": est.success,
            "message": est.message,
        }
        return self._with(step), est

    def remove_rest_drift(self, mask, cutoff: float, *, rests: str = "") -> ForceSignals:
        """Subtract the residual drift fitted through the high-pass inverse on the unloaded
        rests ``mask`` (:func:`fit_rest_drift`) from both compensated forces."""
        out = {}
        sel = np.flatnonzero(mask)
        step: dict = {
            "step": "remove_rest_drift",
            "rests": rests,
            "cutoff_hz": float(cutoff),
            "n_samples": int(sel.size),
            "t_s": [float(self.t0_s + sel[0] / self.fs_hz), float(self.t0_s + sel[-1] / self.fs_hz)],
        }
        for name in ("f_n", "f_t"):
            fit = fit_rest_drift(getattr(self, name), mask, self.fs_hz, cutoff)
            out[name] = getattr(self, name) - fit.image
            key = "F_" + name[2:].upper()
            step[f"{key}_offset_N"] = fit.offset
            step[f"{key}_slope_N_per_s"] = fit.slope
            step[f"{key}_rest_rms_N"] = [fit.rms_before, fit.rms_after]
        return self._with(step, **out)

    def compensate_response(self, responses, rests, *, rests_text: str = "", estimates=()) -> ForceSignals:
        """Invert each transducer channel's high-pass and remove its residual drift.

        ``F1, F2`` are composed from ``F_N, F_T`` (:func:`compose`), each is inverted with
        its :class:`~fingerfriction.forces.response.HighpassResponse` and the image of its
        drift line fitted on the rests ``rests`` (:func:`~fingerfriction.forces.response.
        rest_drift_image`) is subtracted, and the channels are decomposed back.
        ``estimates`` (the :class:`~fingerfriction.forces.response.ResponseEstimate` per
        channel, optional) are recorded in the history.
        """
        fs = self.fs_hz
        chans = compose(self.f_n, self.f_t)
        out, step = [], {"step": "compensate_response", "rests": rests_text, "n_samples": int(np.sum(rests))}
        for c, (y, resp) in enumerate(zip(chans, responses, strict=True)):
            comp = resp.invert(y, fs)
            image, coef = rest_drift_image(comp, rests, fs, resp)
            out.append(comp - image)
            key = f"F{c + 1}"
            step[f"{key}_a1_rad_s"] = resp.a1
            step[f"{key}_a0_rad2_s2"] = resp.a0
            step[f"{key}_cutoff_hz"] = resp.cutoff_hz(fs)
            step[f"{key}_poles_hz"] = [str(p) if isinstance(p, complex) else float(p)
                                       for p in resp.poles_hz(fs)]
            step[f"{key}_drift_N"] = [float(v) for v in coef]
            if estimates:
                est = estimates[c]
                step[f"{key}_estimated"] = bool(est.success)
                step[f"{key}_message"] = est.message
                step[f"{key}_rest_rms_N"] = est.rms_residual_n
        f_n, f_t = decompose(out[0], out[1])
        return self._with(step, f_n=f_n, f_t=f_t)

    def remove_drift(self, mask, *, segment: str = "") -> ForceSignals:
        """Subtract a line in time fitted over ``mask`` (the flat segment) from both forces."""
        t = self.times()
        f_t, (a_t, b_t) = remove_linear_drift(t, self.f_t, mask)
        f_n, (a_n, b_n) = remove_linear_drift(t, self.f_n, mask)
        step = {
            "step": "remove_drift",
            "segment": segment,
            "n_samples": int(np.count_nonzero(mask)),
            "F_T_slope_N_per_s": a_t,
            "F_T_intercept_N": b_t,
            "F_N_slope_N_per_s": a_n,
            "F_N_intercept_N": b_n,
        }
        return self._with(step, f_n=f_n, f_t=f_t)


def _hz_list(v) -> str:
    return ", ".join(f"{float(f):g}" for f in v) + " Hz" if v else "none"


def _t_range(step: dict) -> str:
    t = step.get("t_s") or []
    return f"t = {t[0]:.3f} to {t[1]:.3f} s, " if len(t) == 2 else ""


def describe_step(step: dict) -> str:
    """One line a person reads for one entry of :attr:`ForceSignals.history`.

    Parameters
    ----------
    step : dict
        A history entry (``{'step': name, ...parameters and fitted values...}``), as
        recorded by :class:`ForceSignals` or read back from a results store.

    Returns
    -------
    str
        E.g. ``"sensor high-pass inverted at 5 Hz (first order)"``; an unknown step is
        shown as its name and its fields.
    """
    name = step.get("step", "?")
    if name == "decompose":
        return "F1, F2 decomposed into F_N, F_T (Fig. 1C)"
    if name == "remove_baseline":
        mains = step.get("mains_subtracted_hz") or []
        what = "drift line and mains at " + _hz_list(mains) if mains else "drift line"
        return (f"{what} fitted on the rest before the touch ({_t_range(step)}{step.get('n_samples', '?')} "
                "samples), subtracted")
    if name == "notch":
        q = step.get("q", float("nan"))
        return f"notch filters at {_hz_list(step.get('freqs_hz'))} (Q {q:g}, zero phase)"
    if name == "lowpass":
        return (f"low-pass at {step.get('cutoff_hz', float('nan')):g} Hz (Butterworth order "
                f"{step.get('order', '?')}, zero phase)")
    if name == "compensate_highpass":
        return f"sensor high-pass inverted at {step.get('cutoff_hz', float('nan')):.4g} Hz (first order)"
    if name == "estimate_highpass":
        prior = step.get("prior_hz")
        if step.get("success"):
            return (f"sensor cut-off estimated on the rests: {step.get('cutoff_hz', float('nan')):.4f} "
                    f"+- {step.get('se_hz', float('nan')):.4f} Hz (prior {prior:g} Hz)")
        return f"sensor cut-off not estimated ({step.get('message', '')}); the prior {prior:g} Hz is used"
    if name == "remove_rest_drift":
        rms = step.get("F_T_rest_rms_N") or []
        rms_text = (f"; F_T on the rests {1e3 * rms[0]:.2f} -> {1e3 * rms[1]:.2f} mN RMS"
                    if len(rms) == 2 and None not in rms else "")
        rests = step.get("rests", "").split(";")[0]
        return (f"residual drift fitted through the compensation on the rests {rests} "
                f"({step.get('n_samples', '?')} samples), subtracted{rms_text}")
    if name == "remove_drift":
        return f"flat-segment line removed (the paper's footing): {step.get('segment', '')}"
    if name == "compensate_response":
        cuts = ", ".join(f"F{c} {step.get(f'F{c}_cutoff_hz', float('nan')):.3f} Hz" for c in (1, 2))
        how = "estimated on the rests" if all(step.get(f"F{c}_estimated", False) for c in (1, 2)) else \
            "not all estimated (see the flags)"
        return (f"sensor high-pass inverted per transducer as a second-order response ({cuts}, {how}), "
                f"residual drift fitted through it on the rests ({step.get('n_samples', '?')} samples), "
                "subtracted")
    fields = ", ".join(f"{k}={v}" for k, v in step.items() if k != "step")
    return f"{name}: {fields}" if fields else str(name)


def describe_history(history) -> list[str]:
    """:func:`describe_step` of every entry of a history, oldest first."""
    return [describe_step(dict(h)) for h in history or ()]
