"""Readable parameter types in the command line's ``--help`` (a typer 0.2x detail)."""

from __future__ import annotations

import typer

__all__ = ["readable_help_types"]


def readable_help_types() -> None:
    """Show parameter types in ``--help`` as words (TEXT, INTEGER, FLOAT; nothing for a flag).

    typer 0.2x prints them as Python annotations, ``<str>``, ``<bool>``, ``<int range>``,
    ``<list[str]>``; this wraps its one formatting method (``_TyperParameter.display_type``)
    and leaves every other typer version untouched. An option's own ``metavar`` still wins.
    """
    base = getattr(getattr(typer, "core", None), "_TyperParameter", None)
    original = getattr(base, "display_type", None)
    if original is None or getattr(original, "_readable", False):
        return
    names = {"str": "TEXT", "int": "INTEGER", "float": "FLOAT", "bool": "BOOLEAN", "Path": "PATH"}

    def display_type(self, ctx):
        if getattr(self, "is_flag", False):
            return ""
        text = original(self, ctx)
        if not (isinstance(text, str) and text.startswith("<") and text.endswith(">")):
            return text
        inner = text[1:-1].replace(" range", "")
        repeat = inner.startswith("list[") and inner.endswith("]")
        inner = inner[5:-1] if repeat else inner
        word = inner if "|" in inner else names.get(inner, inner.upper())
        return f"{word} (repeatable)" if repeat else word

    display_type._readable = True
    base.display_type = display_type
