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

__all__ = ["positive", "interval", "check_fs", "check_freq", "check_option", "parse_json", "MAX_JSON_DEPTH"]


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


#: The deepest nesting accepted in a JSON file the package reads (a manifest is 4 deep).
MAX_JSON_DEPTH = 64
#: The largest JSON file the package reads, in bytes (a manifest of 100 000 trials is ~60 MB).
MAX_JSON_BYTES = 256 * 2**20


def parse_json(text: str | bytes, what: str):
    """JSON text parsed, or a one-line ValueError naming ``what`` (a file).

    Beyond :func:`json.loads`' own errors: text over :data:`MAX_JSON_BYTES`, nesting deeper
    than :data:`MAX_JSON_DEPTH` (Python's parser would raise RecursionError), an integer
    of thousands of digits (Python refuses to convert it) are all refused with a message.
    """
    import json  # small; kept beside its one use

    if len(text) > MAX_JSON_BYTES:
        raise ValueError(f"{what}: {len(text)} bytes, more than the {MAX_JSON_BYTES} a JSON file may have")
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") \
            from None
    except RecursionError:
        raise ValueError(f"{what}: nested too deeply (more than {MAX_JSON_DEPTH} levels are not read)") \
            from None
    except ValueError as exc:  # e.g. "Exceeds the limit (4300 digits) for integer string conversion"
        raise ValueError(f"{what}: not valid JSON ({' '.join(str(exc).split())})") from None
    stack = [(obj, 1)]
    while stack:  # the nesting of what was read: code that walks it recursively stays safe
        node, depth = stack.pop()
        if depth > MAX_JSON_DEPTH:
            raise ValueError(f"{what}: nested more than {MAX_JSON_DEPTH} levels deep")
        if isinstance(node, dict):
            stack.extend((v, depth + 1) for v in node.values() if isinstance(v, (dict, list)))
        elif isinstance(node, list):
            stack.extend((v, depth + 1) for v in node if isinstance(v, (dict, list)))
    return obj
