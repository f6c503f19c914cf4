"""Design files: a CSV with one column per design variable, one design per row.

Accepted (``hisopt evaluate --designs FILE``):

- UTF-8 text, with or without a byte-order mark; comma-, semicolon- or tab-separated (the
  delimiter that splits the header into the most fields);
- a header naming the variables; other columns are ignored, so a ``front.csv`` or an
  ``evaluate --out`` results file can be read back. A header differing only in case or
  surrounding spaces (``P0``, `` lam ``) is taken when no column has the exact name; two
  columns that could both be a variable are an error;
- an optional second header row of units in square brackets, as :func:`hisopt.io.write_csv`
  writes (``[Pa]``, ``[-]``) or as people write them (``[MPa]``, ``[cm^2]``, ``[MPa s/m^3]``):
  a design column is read in the unit its row names (:mod:`hisopt.quantities`) and converted
  to SI; an empty ``[]`` is SI;
- numbers as Python reads them (``2e6``, ``nan``, ``inf``); an empty cell is NaN.

Values are not judged here: NaN, infinite, rule-breaking and out-of-box rows become rows with
a ``status`` and a ``reason`` (:func:`hisopt.specification.validation.check_designs`). What cannot be read
as designs at all (no header, a missing column, a cell that is not a number, a row with the
wrong number of fields) is a :class:`~hisopt.errors.ConfigError` naming the file, the line
and the column.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError
from hisopt.quantities import has_unit, scaled, unit_factor
from hisopt.specification.text_files import read_text
from hisopt.specification.validation import match_columns

DELIMITERS = (",", ";", "\t")


def sniff_delimiter(header: str) -> str:
    """The delimiter of the header line: the candidate occurring most often (``,`` on ties)."""
    counts = [header.count(d) for d in DELIMITERS]
    return DELIMITERS[int(np.argmax(counts))] if max(counts) else ","


def _is_units_row(cells: Sequence[str]) -> bool:
    filled = [c.strip() for c in cells if c.strip()]
    return bool(filled) and all(c.startswith("[") and c.endswith("]") for c in filled)


def _cell(text: str, source: str, line: int, name: str, factor: float = 1.0) -> float:
    """[SI] A cell's number times its column's unit ``factor`` (:func:`hisopt.quantities.scaled`)."""
    text = text.strip()
    if not text:
        return np.nan
    try:
        float(text)
        return scaled(text, factor)
    except ValueError:
        hint = "; use a point as the decimal mark" if "," in text else ""
        if has_unit(text) and not hint:
            hint = "; give a column's unit once, in a units row below the header (e.g. [MPa])"
        raise ConfigError(f"expected a number, got {text!r}{hint}", file=source, key=f"line {line}, column {name!r}") from None


def read_designs(path: str | Path, names: Sequence[str], units: Mapping[str, str] | None = None) -> pd.DataFrame:
    """The design columns ``names`` of a design file (module docstring), as floats.

    Parameters
    ----------
    path : str | Path
        [-] the CSV file
    names : Sequence[str]
        [-] the problem's design variable names, in order
    units : Mapping[str, str] | None, optional
        [-] the SI unit of each name (:func:`hisopt.units.variable_units`); a units row
        converts the columns to them. None: a units row is not read

    Returns
    -------
    pandas.DataFrame
        [SI] One float column per name, one row per design (NaN for empty cells);
        ``attrs["lines"]`` holds each row's line number in the file and ``attrs["units"]``
        the SI unit of each column (with ``units``).

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
    unit_row = None
    if body and _is_units_row(body[0][1]):
        unit_row, body = body[0], body[1:]
    columns = match_columns(header, names, source)
    index = {name: header.index(columns[name]) for name in names}
    if not body:
        raise ConfigError(f"no designs below the header (line {header_line}); expected one design per line", file=source)
    factors = dict.fromkeys(names, 1.0)
    if units is not None and unit_row is not None:  # [MPa] under p0: Pa per MPa
        line, cells = unit_row
        for name in names:
            given = cells[index[name]].strip()[1:-1] if index[name] < len(cells) else ""
            factors[name] = unit_factor(given, units[name], file=source, key=f"line {line}, column {name!r}")
    x = np.empty((len(body), len(names)))
    for i, (line, row) in enumerate(body):
        if len(row) != len(header):
            raise ConfigError(f"{len(row)} fields, expected {len(header)} like the header (delimiter {delimiter!r})", file=source, key=f"line {line}")
        x[i] = [_cell(row[index[name]], source, line, name, factors[name]) for name in names]
    frame = pd.DataFrame(x, columns=list(names))
    frame.attrs["lines"] = [line for line, _ in body]
    if units is not None:
        frame.attrs["units"] = {name: units[name] for name in names}
    return frame
