"""Readable parameter types in the command line's ``--help`` (a typer 0.2x detail)."""

from __future__ import annotations

import typer

from ._common import FieldDefault

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
    _plain_field_defaults()


def _plain_field_defaults() -> None:
    """Show an option's default taken from its dataclass (``cli._common.FieldDefault``, a
    ``show_default`` text) as the value, ``[default: 11]``, not as click shows a described
    default, ``[default: (11)]``; other typer versions keep the parentheses."""
    option = getattr(getattr(typer, "core", None), "TyperOption", None)
    original = getattr(option, "_get_default_string", None)
    if original is None or getattr(original, "_plain", False):
        return

    def _get_default_string(self, *args, **kwargs):
        if isinstance(self.show_default, FieldDefault):
            return str(self.show_default)
        return original(self, *args, **kwargs)

    _get_default_string._plain = True
    option._get_default_string = _get_default_string
