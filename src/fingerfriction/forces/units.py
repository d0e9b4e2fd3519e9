"""Units of the force channels: newtons, or the volts of a charge amplifier.

Piezoelectric force transducers feed charge amplifiers whose output is a voltage; the
amplifier is set to a sensitivity in N/V (or, in the other convention, a gain in V/N).
:func:`channel_scale` turns the manifest's ``force.units`` and either setting into the
newtons per file unit of each channel.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .._check import check_option

__all__ = ["FORCE_UNITS", "channel_scale"]

#: Units accepted in the manifest's ``force.units`` field: newtons, or the volts of a
#: charge amplifier (then with a sensitivity in N/V or a gain in V/N).
FORCE_UNITS = ("N", "V", "mV")


def _scale_arg(value, name: str) -> dict:
    """A number or ``{'F1': a, 'F2': b}`` -> ``{'F1': a, 'F2': b}`` of finite non-zero floats."""
    if isinstance(value, Mapping):
        if set(value) != {"F1", "F2"}:
            raise ValueError(f"{name} must be a number or map exactly 'F1' and 'F2', got {dict(value)!r}")
        items = {k: value[k] for k in ("F1", "F2")}
    else:
        items = {"F1": value, "F2": value}
    out = {}
    for k, v in items.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise ValueError(f"{name} for {k} must be a number, got {str(v)[:40]!r}")
        if isinstance(v, int) and abs(v) > 1e9:  # before float(): an integer of 400 digits has none
            raise ValueError(f"{name} for {k} must be within 1e-9 and 1e9 in magnitude, got a number of "
                             f"{len(str(abs(v)))} digits")
        v = float(v)
        if not math.isfinite(v) or v == 0:
            raise ValueError(
                f"{name} for {k} must be finite and non-zero (negative flips the channel), got {v!r}"
            )
        if not 1e-9 <= abs(v) <= 1e9:  # beyond any amplifier; products would overflow
            raise ValueError(f"{name} for {k} must be within 1e-9 and 1e9 in magnitude, got {v!r}")
        out[k] = v
    return out


def channel_scale(units: str = "N", sensitivity_n_per_v=None, gain_v_per_n=None) -> dict:
    """Newtons per unit of the file, per channel.

    Parameters
    ----------
    units : {'N', 'V', 'mV'}
        Units of the channels in the file.
    sensitivity_n_per_v : float or {'F1': float, 'F2': float}, optional
        For volts: N per V, one number for both channels or one per channel (a charge
        amplifier set to 10 N/V: ``10``). A negative value flips the channel's sign.
    gain_v_per_n : float or {'F1': float, 'F2': float}, optional
        For volts, instead of the sensitivity: V per N (its reciprocal).

    Returns
    -------
    dict
        ``{'F1': s1, 'F2': s2}`` in N per file unit.

    Raises
    ------
    ValueError
        Unknown units; volts without exactly one of the two; a scale given for newtons.
    """
    check_option("units", units, FORCE_UNITS)
    given = [n for n, v in (("sensitivity_n_per_v", sensitivity_n_per_v), ("gain_v_per_n", gain_v_per_n))
             if v is not None]
    if units == "N":
        if given:
            raise ValueError(f"{given[0]} is for channels in volts, but units is 'N'; "
                             "give units='V' (or 'mV') or drop it")
        return {"F1": 1.0, "F2": 1.0}
    if len(given) != 1:
        raise ValueError(
            f"units {units!r} needs exactly one of sensitivity_n_per_v (N/V) or gain_v_per_n (V/N), got "
            + ("both" if given else "neither")
        )
    per_volt = 1e-3 if units == "mV" else 1.0
    if sensitivity_n_per_v is not None:
        s = _scale_arg(sensitivity_n_per_v, "sensitivity_n_per_v")
        return {k: v * per_volt for k, v in s.items()}
    g = _scale_arg(gain_v_per_n, "gain_v_per_n")
    return {k: per_volt / v for k, v in g.items()}
