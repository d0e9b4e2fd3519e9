"""The layout of a delimited text file of samples: delimiter, decimal mark, header row.

Lab acquisition software writes force recordings as text in many dialects: ``,`` or ``;``
or tab between columns, ``.`` or ``,`` as the decimal mark, with or without a row of
column names, after a few ``#`` comment lines. :func:`csv_layout` tells which, from the
first lines of the file; :mod:`fingerfriction.forces.readers` then reads the columns with
pandas.
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["CsvLayout", "CsvLayoutError", "csv_layout"]


class CsvLayoutError(ValueError):
    """A text file whose layout cannot be told (empty, no consistent delimiter)."""




@dataclass(frozen=True)
class CsvLayout:
    """How a delimited text file is laid out (:func:`csv_layout`).

    Attributes
    ----------
    delimiter : str
        Column delimiter; ``r'\\s+'`` for runs of blanks.
    decimal : str
        ``'.'`` or ``','``.
    header : tuple of str or None
        Column names from the first row, or None for a headerless file.
    skiprows : int
        Lines before the first data row (comment lines starting with ``#`` and the header).
    n_columns : int
        Columns of the first data row.
    first_row : tuple of str
        The first data row's fields (shown in error messages).
    """

    delimiter: str
    decimal: str
    header: tuple | None
    skiprows: int
    n_columns: int
    first_row: tuple


_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+(?:[eE][+-]?\d+)?$")


def _split(line: str, delimiter: str) -> list[str]:
    if delimiter == r"\s+":
        return line.split()
    return [f.strip().strip('"').strip() for f in next(csv.reader([line], delimiter=delimiter))]


def _is_number(text: str, decimal: str) -> bool:
    t = text.strip().strip('"')
    if decimal == ",":
        t = t.replace(",", ".")
    try:
        float(t)
    except ValueError:
        return t.lower() in ("", "nan")
    return True


def _consistent(lines: list[str], delimiter: str) -> bool:
    """Every line splits into the same number (>= 2) of fields, and the rows after the
    first (a header may have names) are all numbers."""
    rows = [_split(line, delimiter) if delimiter != r"\s+" else line.split() for line in lines]
    if len({len(r) for r in rows}) != 1 or len(rows[0]) < 2:
        return False
    data = rows[1:] or rows
    return any(all(_is_number(f, dec) for r in data for f in r) for dec in (".", ",") if dec != delimiter)


def _first_lines(p: Path, n: int = 50) -> tuple[int, list[str]]:
    """``(skip, lines)``: how many ``#`` comment and blank lines open the file, and its
    first ``n`` non-blank lines after them (from its first 64 KiB)."""
    try:
        with open(p, encoding="utf-8-sig", errors="replace", newline="") as fh:
            head = fh.read(1 << 16)
            more = bool(fh.read(1))
    except OSError as exc:
        raise CsvLayoutError(f"cannot read {str(p)!r} as CSV: {exc.strerror or exc}") from None
    raw = head.splitlines()
    if more and raw:
        raw = raw[:-1]  # the last line of the chunk may be cut
    skip = 0
    lines: list[str] = []
    for line in raw:
        if not lines and (not line.strip() or line.lstrip().startswith("#")):
            skip += 1
            continue
        if line.strip():
            lines.append(line)
        if len(lines) >= n:
            break
    if not lines:
        raise CsvLayoutError(f"{str(p)!r} holds no data rows")
    return skip, lines


def csv_layout(path: str | os.PathLike, *, delimiter: str | None = None) -> CsvLayout:
    """Detect the delimiter, decimal mark and header row of a delimited text file.

    Parameters
    ----------
    path : path-like
    delimiter : str, optional
        The delimiter, when known (skips the detection).

    Returns
    -------
    CsvLayout

    Raises
    ------
    CsvLayoutError
        An empty file, or no consistent delimiter.

    Notes
    -----
    A delimiter is taken when it splits every one of the first 50 lines (after ``#``
    comments and blank lines) into the same number (>= 2) of fields, all numbers after the
    first line, trying tab, ``;``, ``|``, ``,`` and runs of blanks in that order, then
    :class:`csv.Sniffer` (quoted text fields). This rule comes before the Sniffer because
    ``csv.Sniffer`` picks ``,`` for ``0,0001;0,12`` (a ``;`` file with decimal commas, as
    European locales write them): checked on Python 3.11. The decimal
    mark is ``,`` when the delimiter is not and a field reads like ``-0,31``. The first
    line is a header unless every field in it is a number.
    """
    p = Path(path)
    skip, lines = _first_lines(p)
    delim = delimiter
    if delim is None:
        for cand in ("\t", ";", "|", ",", r"\s+"):
            if _consistent(lines, cand):
                delim = cand
                break
    if delim is None:
        try:
            delim = csv.Sniffer().sniff("\n".join(lines), delimiters="\t;|,").delimiter
        except csv.Error:
            pass
    if delim is None:
        raise CsvLayoutError(
            f"cannot tell the column delimiter of {str(p)!r} (tried tab, ';', '|', ',' and blanks; "
            f"first line {lines[0][:80]!r}); give it (manifest force.delimiter)"
        )
    first = _split(lines[0], delim)
    data_line = lines[1] if len(lines) > 1 else lines[0]
    decimal = "."
    if delim != "," and any(_DECIMAL_COMMA.match(f) for ln in lines[:10] for f in _split(ln, delim)):
        decimal = ","
    header = None
    if not all(_is_number(f, decimal) for f in first):
        header = tuple(first)
        skip += 1
    else:
        data_line = lines[0]
    row = tuple(_split(data_line, delim))
    return CsvLayout(delimiter=delim, decimal=decimal, header=header, skiprows=skip, n_columns=len(row),
                     first_row=row)
