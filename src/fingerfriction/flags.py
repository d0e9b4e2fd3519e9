"""One flag type, from the stage that raises it to the report.

A :class:`Flag` is one finding about a result: its level, a short machine-readable code, a
one-line message, and where it belongs (trial, subject, model variant; ``''`` when it is
about something wider). The force stage raises them while processing a trial, the fit for
each trial and subject, the consistency stage for each check that finds something; the
results store writes them as dicts (:meth:`Flag.to_dict`) and the report reads them back
(:meth:`Flag.from_dict`) with their level kept.

Levels, most serious first (:data:`LEVELS`): ``'error'`` (no usable result), ``'warning'``
(a result to look at before trusting it), ``'info'`` (a known limit, said once).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from ._check import check_option

__all__ = ["LEVELS", "Flag"]

#: Levels of a :class:`Flag`, most serious first.
LEVELS = ("error", "warning", "info")


@dataclass(frozen=True)
class Flag:
    """One finding about a result.

    Attributes
    ----------
    level : {'error', 'warning', 'info'}
    code : str
        Short machine-readable kind, e.g. ``'extrapolated'``, ``'mu-at-grid-edge'``.
    message : str
        One line saying what and why.
    trial : str
        Trial id; ``''`` for a flag about a whole subject or study.
    subject : str
        Subject label; ``''`` when not known or not relevant.
    model : str
        Model variant of a fit flag (``'load'``, ``'paper'``); ``''`` otherwise.
    """

    level: str
    code: str
    message: str
    trial: str = ""
    subject: str = ""
    model: str = ""

    def __post_init__(self) -> None:
        check_option("Flag.level", self.level, LEVELS)
        if not isinstance(self.code, str) or not self.code:
            raise ValueError(f"Flag.code must be a non-empty string, got {self.code!r}")
        for name in ("message", "trial", "subject", "model"):
            if not isinstance(getattr(self, name), str):
                raise TypeError(f"Flag.{name} must be a string, got {getattr(self, name)!r}")

    @property
    def severity(self) -> str:
        """The level (the force stage's former name for it)."""
        return self.level

    def line(self) -> str:
        """``'code: message'``."""
        return f"{self.code}: {self.message}"

    def at(self, *, trial: str | None = None, subject: str | None = None, model: str | None = None) -> Flag:
        """The same flag placed: the fields given (not None) replaced."""
        given = (("trial", trial), ("subject", subject), ("model", model))
        kw = {k: str(v) for k, v in given if v is not None}
        return replace(self, **kw) if kw else self

    def __getitem__(self, name: str):
        """Field by name (``flag["level"]``), for tables and templates that index records."""
        if name not in _FIELDS:
            raise KeyError(name)
        return getattr(self, name)

    def to_dict(self) -> dict:
        """The JSON form the results store writes."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d) -> Flag:
        """A flag from :meth:`to_dict`'s form, or from the ``'code: message'`` string that
        results written before flags kept their level hold (read as a warning, as then).

        Raises
        ------
        ValueError
            Not a mapping with a known level and a code, nor a string.
        """
        if isinstance(d, str):
            code, sep, msg = d.partition(": ")
            return cls("warning", code.strip() or "forces", msg if sep else d)
        if not isinstance(d, dict):
            raise ValueError(f"a flag must be a dict or a 'code: message' string, got {type(d).__name__}")
        return cls(level=str(d.get("level", "")), code=str(d.get("code", "")),
                   message=str(d.get("message", "")), trial=str(d.get("trial") or ""),
                   subject=str(d.get("subject") or ""), model=str(d.get("model") or ""))


_FIELDS = ("level", "code", "message", "trial", "subject", "model")
