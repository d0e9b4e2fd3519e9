"""The one set of argument checks of the package (in the manner of ``mne.utils.check`` and
``scipy.signal._arraytools._validate_fs``).

Exception policy, the same for every check: a number or an option that is malformed or
outside what is allowed raises :class:`ValueError`, whether it is negative, NaN, above
Nyquist or text that is not a number at all (numbers often arrive as text from a file or
the command line: ``float(value)`` decides, as in ``scipy.signal``); :class:`TypeError` is
kept for an argument that is not the kind of object asked for (a dict where a
``FrictionParams`` is expected, a string for a True/False flag). Every message names the
argument, the value received and what is allowed: "fs must be a finite positive sampling
frequency in Hz, got -1.0".
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable

__all__ = ["positive", "interval", "check_fs", "check_freq", "check_option"]


def positive(name: str, value, unit: str, *, what: str = "number") -> float:
    """``value`` as a finite positive float, or a ValueError naming it.

    Parameters
    ----------
    name : str
        Argument name used in the message.
    value : object
        The value received.
    unit : str
        Its unit, e.g. ``'mm'``, ``'N/mm'``, ``'Hz'``.
    what : str
        What kind of quantity it is (``'number'``, ``'length'``...), for the message.

    Raises
    ------
    ValueError
        If it is not a number, or NaN, infinite, zero or negative: "<name> must be a
        finite positive <what> in <unit>, got <value>".
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a {what} in {unit}, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite positive {what} in {unit}, got {value!r}")
    return v


def interval(name: str, value, unit: str, *, labels: tuple[str, str] = ("lo", "hi")) -> tuple[float, float]:
    """``value`` as a finite increasing pair ``(lo, hi)`` of floats, or a ValueError naming it.

    Parameters
    ----------
    name : str
        Argument name used in the message.
    value : object
        The value received (any 2-iterable of numbers).
    unit : str
        Unit of both ends, e.g. ``'mm'`` or ``'s'``.
    labels : (str, str)
        How the two ends are called in the message, e.g. ``('x_lo', 'x_hi')``.
    """
    a, b = labels
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be ({a}, {b}) in {unit}, got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise ValueError(f"{name} must be ({a}, {b}) in {unit} with {a} < {b}, got {(lo, hi)!r}")
    return lo, hi


def check_fs(fs, name: str = "fs") -> float:
    """A sampling frequency in Hz as a finite positive float.

    Parameters
    ----------
    fs : object
        The value received.
    name : str
        Argument name used in the message (``'fs'``, ``'fs_hz'``).

    Raises
    ------
    ValueError
        If it is not a number, or NaN, infinite, zero or negative.
    """
    return positive(name, fs, "Hz", what="sampling frequency")


def check_freq(name: str, value, fs: float) -> float:
    """A frequency in Hz strictly between 0 and the Nyquist frequency ``fs / 2``.

    A frequency within 10 % of Nyquist is accepted with a :class:`RuntimeWarning` (the
    filter designed from it is poorly conditioned).

    Raises
    ------
    ValueError
        If it is not a finite positive number, or not below Nyquist: "cutoff (600 Hz) must be
        below the Nyquist frequency (500 Hz) of fs=1000 Hz".
    """
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a frequency in Hz, got {value!r}") from None
    nyq = fs / 2.0
    if not (math.isfinite(f) and f > 0):
        raise ValueError(f"{name} must be a finite positive frequency in Hz, got {value!r}")
    if f >= nyq:
        raise ValueError(
            f"{name} ({f:g} Hz) must be below the Nyquist frequency ({nyq:g} Hz) of fs={fs:g} Hz"
        )
    if f > 0.9 * nyq:
        warnings.warn(
            f"{name} ({f:g} Hz) is within 10 % of the Nyquist frequency ({nyq:g} Hz); "
            "the filter will be poorly conditioned",
            RuntimeWarning,
            stacklevel=3,
        )
    return f


def check_option(name: str, value, allowed: Iterable) -> object:
    """``value`` if it is one of ``allowed``, else a ValueError listing them.

    Raises
    ------
    ValueError
        "position must be one of 'hybrid', 'cf-centroid', 'chord', got 'x'".
    """
    allowed = tuple(allowed)
    if value not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {value!r}")
    return value
