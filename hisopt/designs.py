"""Design files: a CSV with one column per design variable, one design per row.

Accepted (``hisopt evaluate --designs FILE``):

- UTF-8 text, with or without a byte-order mark; comma-, semicolon- or tab-separated (the
  delimiter that splits the header into the most fields);
- a header naming the variables; other columns are ignored, so a ``front.csv`` or an
  ``evaluate --out`` results file can be read back. A header differing only in case or
  surrounding spaces (``P0``, `` lam ``) is taken when no column has the exact name; two
  columns that could both be a variable are an error;
- an optional second header row of units in square brackets (``[Pa]``, ``[-]``), as
  :func:`hisopt.io.write_csv` writes;
- numbers as Python reads them (``2e6``, ``nan``, ``inf``); an empty cell is NaN.

Values are not judged here: NaN, infinite, rule-breaking and out-of-box rows become rows with
a ``status`` and a ``reason`` (:func:`hisopt.validation.check_designs`). What cannot be read
as designs at all (no header, a missing column, a cell that is not a number, a row with the
wrong number of fields) is a :class:`~hisopt.errors.ConfigError` naming the file, the line
and the column.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError
from hisopt.validation import match_columns, read_text

DELIMITERS = (",", ";", "\t")


def sniff_delimiter(header: str) -> str:
    """The delimiter of the header line: the candidate occurring most often (``,`` on ties)."""
    counts = [header.count(d) for d in DELIMITERS]
    return DELIMITERS[int(np.argmax(counts))] if max(counts) else ","


def _is_units_row(cells: Sequence[str]) -> bool:
    filled = [c.strip() for c in cells if c.strip()]
    return bool(filled) and all(c.startswith("[") and c.endswith("]") for c in filled)


def _cell(text: str, source: str, line: int, name: str) -> float:
    text = text.strip()
    if not text:
        return np.nan
    try:
        return float(text)
    except ValueError:
        hint = "; use a point as the decimal mark" if "," in text else ""
        raise ConfigError(f"expected a number, got {text!r}{hint}", file=source, key=f"line {line}, column {name!r}") from None


def read_designs(path: str | Path, names: Sequence[str]) -> pd.DataFrame:
    """The design columns ``names`` of a design file (module docstring), as floats.

    Parameters
    ----------
    path : [-] the CSV file
    names : [-] the problem's design variable names, in order

    Returns
    -------
    pandas.DataFrame
        One float column per name, one row per design (NaN for empty cells);
        ``attrs["lines"]`` holds each row's line number in the file.

    Raises
    ------
    ConfigError
        The file cannot be read as designs (the message names the file, the line and the
        column where it can).
    """
    source = str(path)
    text = read_text(path, f"a CSV file of designs with the columns {', '.join(names)}")
    lines = text.splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None:
        raise ConfigError(f"empty file; expected a header line with the columns {', '.join(names)} and one design per line", file=source)
    delimiter = sniff_delimiter(lines[first])
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
    try:
        rows = [(reader.line_num, [c.strip() for c in row]) for row in reader]
    except csv.Error as exc:
        raise ConfigError(f"unreadable CSV ({exc})", file=source, key=f"line {reader.line_num}") from None
    rows = [(n, r) for n, r in rows if any(r)]  # blank lines carry nothing
    (header_line, header), body = rows[0], rows[1:]
    if body and _is_units_row(body[0][1]):
        body = body[1:]
    columns = match_columns(header, names, source)
    index = {name: header.index(columns[name]) for name in names}
    if not body:
        raise ConfigError(f"no designs below the header (line {header_line}); expected one design per line", file=source)
    x = np.empty((len(body), len(names)))
    for i, (line, row) in enumerate(body):
        if len(row) != len(header):
            raise ConfigError(
                f"{len(row)} fields, expected {len(header)} like the header (delimiter {delimiter!r})", file=source, key=f"line {line}"
            )
        x[i] = [_cell(row[index[name]], source, line, name) for name in names]
    frame = pd.DataFrame(x, columns=list(names))
    frame.attrs["lines"] = [line for line, _ in body]
    return frame
