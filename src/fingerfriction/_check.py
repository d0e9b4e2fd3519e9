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

Where the checks run: once, at the boundary. An options dataclass checks its fields in
``__post_init__`` with these functions, and code that receives the dataclass trusts it
(it does not check a field again). A record of data checks its own invariants the same way
(a :class:`~fingerfriction.forces.ForceRecord` its ``fs_hz``), and the stage that takes it
passes its checked values on. A public function that takes a bare number from a user
checks it, as ``scipy.signal`` does with ``fs``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable

__all__ = ["positive", "nonnegative", "integer", "in_range", "interval", "SamplingRate", "check_fs",
           "check_freq", "check_option", "choices_text", "option_message", "validate_type", "check_bool",
           "parse_json", "MAX_JSON_DEPTH", "lookup"]


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


def nonnegative(name: str, value, unit: str, *, what: str = "number") -> float:
    """``value`` as a finite float >= 0, or a ValueError naming it ("<name> must be a finite
    <what> >= 0 in <unit>, got <value>")."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a {what} in {unit}, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a finite {what} >= 0 in {unit}, got {value!r}")
    return v


def integer(name: str, value, lo: int | None = None, hi: int | None = None, *, what: str = "") -> int:
    """``value`` as an int in ``[lo, hi]`` (either end may be open), or a ValueError naming it.

    A float with an integer value (``3.0``) is accepted; ``True``/``False`` and ``2.5`` are
    not. ``what`` is appended to the allowed range in the message (``'samples'``).

    Raises
    ------
    ValueError
        "lowpass_order must be an integer in [1, 12], got 13".
    """
    span = ("" if lo is None and hi is None else f" >= {lo}" if hi is None else f" <= {hi}" if lo is None
            else f" in [{lo}, {hi}]")
    allowed = f"an integer{span}{' ' + what if what else ''}"
    try:
        ok = not isinstance(value, bool) and float(value) == int(value)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or (lo is not None and int(value) < lo) or (hi is not None and int(value) > hi):
        raise ValueError(f"{name} must be {allowed}, got {value!r}")
    return int(value)


def in_range(name: str, value, lo: float | None = None, hi: float | None = None, *, unit: str = "",
             what: str = "", open_lo: bool = False, open_hi: bool = False) -> float:
    """``value`` as a finite float between ``lo`` and ``hi`` (either may be None: no bound;
    each end closed unless ``open_lo`` / ``open_hi``), or a ValueError naming it.

    ``True``/``False`` are not numbers here. The message says the range as it is asked
    for: "friction must be a friction coefficient in [0, 5], got -0.1", "poisson must be in
    (0, 0.499], got 0.5", "mu_sd must be <= 0.3 (relative), got 0.5".

    Parameters
    ----------
    name : str
        Argument name used in the message.
    value : object
        The value received.
    lo, hi : float or None
        The bounds.
    unit : str
        Its unit (``'mm'``, ``'DN'``; ``'(relative)'``), after the range in the message.
    what : str
        What kind of quantity it is (``'friction coefficient'``), before the range.
    open_lo, open_hi : bool
        Exclude the bound itself.
    """
    if lo is not None and hi is not None:
        span = f"in {'(' if open_lo else '['}{lo:g}, {hi:g}{')' if open_hi else ']'}"
    elif lo is not None:
        span = f"{'>' if open_lo else '>='} {lo:g}"
    elif hi is not None:
        span = f"{'<' if open_hi else '<='} {hi:g}"
    else:
        span = ""
    noun = f"a {what}" if what else "" if span else "a finite number"
    allowed = " ".join(t for t in (noun, span, unit if span or not unit else f"in {unit}") if t)
    try:
        v = float(value) if not isinstance(value, bool) else math.nan
    except (TypeError, ValueError):
        v = math.nan
    ok = math.isfinite(v) and not (lo is not None and (v < lo or (open_lo and v == lo))) \
        and not (hi is not None and (v > hi or (open_hi and v == hi)))
    if not ok:
        raise ValueError(f"{name} must be {allowed}, got {value!r}")
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


class SamplingRate(float):
    """A sampling frequency in Hz that :func:`check_fs` has checked: a float in every other
    respect (arithmetic on it gives plain floats, JSON writes it as a number).

    :func:`check_fs` returns one and passes one through without checking it again, so a
    rate is checked once, where it enters (a manifest's ``force.fs_hz``, a force file's own
    rate, a number a user passes), however many functions it then goes through.
    """

    __slots__ = ()


def check_fs(fs, name: str = "fs") -> SamplingRate:
    """A sampling frequency in Hz as a finite positive float (a :class:`SamplingRate`).

    Parameters
    ----------
    fs : object
        The value received; a :class:`SamplingRate` (checked already) is returned as is.
    name : str
        Argument name used in the message (``'fs'``, ``'fs_hz'``).

    Raises
    ------
    ValueError
        If it is not a number, or NaN, infinite, zero or negative.
    """
    if type(fs) is SamplingRate:
        return fs
    return SamplingRate(positive(name, fs, "Hz", what="sampling frequency"))


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


def choices_text(allowed: Iterable) -> str:
    """The allowed values as a message lists them: names bare, anything else as its repr
    (``'hybrid, cf-centroid, chord'``, ``'1, 2'``, ``'None'``)."""
    return ", ".join(a if isinstance(a, str) else repr(a) for a in allowed)


def lookup(mapping, key, what: str):
    """``mapping[str(key)]``, or a ValueError "unknown <what> 'key'; known: a, b" (the keys of a
    mapping of named things: a provider's subjects' fingers)."""
    try:
        return mapping[str(key)]
    except KeyError:
        raise ValueError(f"unknown {what} {key!r}; known: {', '.join(mapping)}") from None


def check_option(name: str, value, allowed: Iterable) -> object:
    """``value`` if it is one of ``allowed``, else a ValueError listing them (after
    ``mne.utils._check_option``).

    Parameters
    ----------
    name : str
        Argument name used in the message (``'position'``, ``'--sync'``, ``'force.format'``).
    value : object
        The value received.
    allowed : iterable
        The values allowed, in the order the message lists them.

    Raises
    ------
    ValueError
        "position must be one of hybrid, cf-centroid, chord, got 'x'".
    """
    allowed = tuple(allowed)
    try:
        ok = value in allowed
    except TypeError:  # an unhashable value against a set or dict of names
        ok = False
    if not ok:
        raise ValueError(f"{name} {option_message(value, allowed)}")
    return value


def option_message(value, allowed: Iterable) -> str:
    """What :func:`check_option` says of a value that is not one of ``allowed``, without the
    name: "must be one of hybrid, cf-centroid, chord, got 'x'" (a reader whose messages put
    the field first, ``"trials[3].force.format: ..."``, raises its own error with it)."""
    return f"must be one of {choices_text(allowed)}, got {value!r}"


def validate_type(name: str, value, types, what: str):
    """``value`` if it is an instance of ``types``, else a TypeError naming it (after
    ``mne.utils._validate_type``).

    Parameters
    ----------
    name : str
        Argument name used in the message.
    value : object
        The value received.
    types : type or tuple of types
        What :func:`isinstance` must accept. ``bool`` is never taken for a number: pass
        ``int`` and a ``True`` is refused.
    what : str
        What is allowed, for the message (``'a ForceProcessingParams'``, ``'a dict of options'``).

    Raises
    ------
    TypeError
        "params must be a ForceProcessingParams, got dict".
    """
    types = types if isinstance(types, tuple) else (types,)
    bool_as_number = isinstance(value, bool) and bool not in types
    if bool_as_number or not isinstance(value, types):
        raise TypeError(f"{name} must be {what}, got {type(value).__name__}")
    return value


def check_bool(name: str, value) -> bool:
    """``value`` as a bool when it is ``True``/``False`` (numpy's included), else a
    TypeError: "estimate_highpass must be True or False, got 'yes'"."""
    import numpy as np  # numpy's bool is accepted; numpy is imported by every stage anyway

    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


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
