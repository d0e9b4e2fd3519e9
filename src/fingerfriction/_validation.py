"""Small input validators shared by the stages (one message style everywhere)."""

from __future__ import annotations

import math

__all__ = ["positive"]


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
