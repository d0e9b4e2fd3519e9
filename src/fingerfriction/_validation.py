"""Small input validators shared by the stages (one message style everywhere)."""

from __future__ import annotations

import math

__all__ = ["positive", "interval"]


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
    TypeError
        If ``value`` is not a number.
    ValueError
        If it is NaN, infinite, zero or negative: "<name> must be a finite positive
        <what> in <unit>, got <value>".
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a {what} in {unit}, got {value!r}") from None
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
