"""Catalogue files of hydraulic parts, and the accumulators' pressure ratings by size
(docs/model.md §16.8, §17).

A catalogue is a CSV file whose header names each column's quantity and unit
(``volume [L], max_pressure_ratio [-], max_working_pressure [bar]``), with ``#`` comment lines
giving its sources; the first column holds the sizes a choice variable takes
(:func:`hisopt.specification.catalogues.parse_catalogue`), further columns a size's ratings.
Every row gives every column: a size without its rating is refused where the file is read.

:func:`accumulator_rating` is the rating of the part you would buy for a volume: the smallest
catalogue size at or above it (``hisopt/data/catalogues/accumulator_volumes.csv``, or a
problem's own catalogue with the two pressure columns).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.errors import ConfigError
from hisopt.quantities import unit_factor

if TYPE_CHECKING:
    from hisopt.hydraulics.roll_plane import RollPlaneHIS

_HEADER = re.compile(r"\s*(?P<label>[^\[\]]*?)\s*\[(?P<unit>[^\[\]]*)\]\s*")

RATIO_COLUMN = "max_pressure_ratio"
"""[-] Catalogue column: the largest ratio of maximum working pressure to precharge (gauge)."""

PRESSURE_COLUMN = "max_working_pressure"
"""Catalogue column: the largest working pressure (gauge), in the unit its header names."""

BLADDER_RATIO = 4.0
"""[-] A bladder accumulator's largest pressure ratio at every size: the bladder folds and
wears beyond it (HST Hydrospeichertechnik, "Speicherberechnung"; Parker's selection guide, 4:1)."""

SIZE_RTOL = 1e-12
"""[-] A volume within this of a catalogue size is that size (read back from a CSV file or
converted from litres, a size moves by a few eps)."""


@dataclass(frozen=True)
class CatalogueTable:
    """A catalogue file's columns as written: ``header`` the ``(label, unit)`` of each column,
    ``rows`` each data row's line number and cells (text, one per column)."""

    where: str
    header: tuple[tuple[str, str], ...]
    rows: tuple[tuple[int, tuple[str, ...]], ...]

    def column(self, label: str) -> int | None:
        """[-] The index of the column named ``label``, or None."""
        return next((i for i, (name, _) in enumerate(self.header) if name == label), None)


def catalogue_table(text: str, *, where: str, file: str | None, key: str) -> CatalogueTable:
    """The columns of a catalogue's ``text`` (module docstring), each row checked to give every
    column and, beyond the first (the sizes, checked by their reader), a positive finite number.

    Raises
    ------
    ConfigError
        An empty file, a header column not named with its unit, a row with a column missing or
        too many, or a rating that is not a positive finite number: one line naming the file
        (``where``) and the row.
    """
    lines = [(i + 1, line.strip()) for i, line in enumerate(text.splitlines()) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ConfigError(f"{where}: empty; expected a header such as 'bore [mm]' and one value per row", file=file, key=key)
    row, line = lines[0]
    matches = [_HEADER.fullmatch(cell) for cell in line.split(",")]
    if not all(matches):
        raise ConfigError(
            f"{where}: row {row}: header {line!r}; expected columns named with their units, such as 'bore [mm]' (the first the sizes to choose from)",
            file=file,
            key=key,
        )
    header = tuple((m["label"], m["unit"]) for m in matches if m is not None)
    rows = []
    for row, line in lines[1:]:
        cells = tuple(cell.strip() for cell in line.split(","))
        if len(cells) != len(header):
            names = ", ".join(f"{label} [{unit}]" for label, unit in header)
            raise ConfigError(
                f"{where}: row {row}: {line!r} has {len(cells)} value(s); expected one in each of the {len(header)} columns ({names})", file=file, key=key
            )
        for (label, unit), cell in list(zip(header, cells, strict=True))[1:]:
            if not _positive_number(cell):
                raise ConfigError(f"{where}: row {row}: {label} {cell!r}; expected a positive finite number [{unit}]", file=file, key=key)
        rows.append((row, cells))
    return CatalogueTable(where, header, tuple(rows))


def _positive_number(cell: str) -> bool:
    try:
        value = float(cell)
    except ValueError:
        return False
    return 0.0 < value < math.inf


@dataclass(frozen=True)
class AccumulatorRatings:
    """The accumulators' pressure ratings by size, each array increasing in ``volumes``."""

    volumes: np.ndarray
    """[m^3] the catalogue's nominal volumes"""
    ratios: np.ndarray
    """[-] each size's largest ratio of working pressure to precharge (diaphragm, gauge)"""
    pressures: np.ndarray
    """[Pa] each size's largest working pressure (gauge)"""
    source: str
    """[-] the catalogue they come from"""


def accumulator_ratings(table: CatalogueTable, *, file: str | None, key: str) -> AccumulatorRatings | None:
    """The ratings of an accumulator catalogue (its first column the volumes), or None for a
    catalogue of sizes alone (neither pressure column).

    Raises
    ------
    ConfigError
        One pressure column without the other, a column in a unit of another kind, or a ratio
        not above 1: one line naming the file.
    """
    ratio_at, pressure_at = table.column(RATIO_COLUMN), table.column(PRESSURE_COLUMN)
    if ratio_at is None and pressure_at is None:
        return None
    if ratio_at is None or pressure_at is None:
        given, missing = (RATIO_COLUMN, PRESSURE_COLUMN) if pressure_at is None else (PRESSURE_COLUMN, RATIO_COLUMN)
        raise ConfigError(f"{table.where}: a {given} column without {missing}; expected both (an accumulator's rating) or neither", file=file, key=key)
    factors = [
        unit_factor(table.header[i][1], unit, file=file, key=key, text=f"{table.where}: the {table.header[i][0]} column's unit [{table.header[i][1]}]")
        for i, unit in ((0, "m^3"), (ratio_at, "-"), (pressure_at, "Pa"))
    ]
    values = np.array([[float(cells[i]) for i in (0, ratio_at, pressure_at)] for _, cells in table.rows]).reshape(-1, 3) * factors
    low = [row for (row, _), ratio in zip(table.rows, values[:, 1], strict=True) if not ratio > 1.0]
    if low:
        raise ConfigError(f"{table.where}: row {low[0]}: {RATIO_COLUMN} at or below 1; expected a working pressure above the precharge", file=file, key=key)
    return AccumulatorRatings(values[:, 0], values[:, 1], values[:, 2], table.where)


@lru_cache(maxsize=1)
def shipped_accumulator_ratings() -> AccumulatorRatings:
    """The ratings of the shipped ``accumulator_volumes`` catalogue (read once)."""
    text = (resources.files("hisopt") / "data" / "catalogues" / "accumulator_volumes.csv").read_text(encoding="utf-8")
    where = "catalogue 'accumulator_volumes'"
    ratings = accumulator_ratings(catalogue_table(text, where=where, file=None, key="accumulator_volumes"), file=None, key="accumulator_volumes")
    assert ratings is not None  # the shipped file has both columns (tests/test_accumulator_rating.py)
    return ratings


def accumulator_rating(
    volume_m3: Any,
    separator: str = "diaphragm",
    ratings: AccumulatorRatings | None = None,
    *,
    pressure_rating: float | None = None,
    max_working_pressure: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """[-], [Pa] The largest ratio of working pressure to precharge (gauge) and the largest
    working pressure (gauge) of the accumulator you would buy for ``volume_m3`` [m^3] (a float
    or a numpy array of any shape; arrays of its shape come back).

    The part is the smallest size of ``ratings`` (None: the shipped catalogue's,
    :func:`shipped_accumulator_ratings`) at or above the volume (within :data:`SIZE_RTOL`); a
    volume above the largest size, or not a positive finite number, gets NaN for both. A
    ``"bladder"`` separator's ratio is :data:`BLADDER_RATIO` at every size (the catalogue's
    ratios are a diaphragm's). ``pressure_rating`` and ``max_working_pressure`` (a problem's
    ``[his]`` values, from the part's data sheet) replace the catalogue's where given, at
    every volume.
    """
    if separator not in ("diaphragm", "bladder"):
        raise ValueError(f"separator: {separator!r}; expected 'diaphragm' or 'bladder'")
    ratings = ratings or shipped_accumulator_ratings()
    volume = np.asarray(volume_m3, dtype=float)
    with np.errstate(invalid="ignore"):
        at = np.searchsorted(ratings.volumes, volume * (1.0 - SIZE_RTOL), side="left")
        bought = (at < len(ratings.volumes)) & (volume > 0.0)  # NaN and inf volumes: no part
    at = np.minimum(at, len(ratings.volumes) - 1)
    sized = ratings.ratios[at] if separator == "diaphragm" else BLADDER_RATIO
    ratio = np.where(bought, sized, np.nan) if pressure_rating is None else np.full(volume.shape, float(pressure_rating))
    pressure = np.where(bought, ratings.pressures[at], np.nan) if max_working_pressure is None else np.full(volume.shape, float(max_working_pressure))
    return ratio, pressure


def his_accumulator_rating(his: RollPlaneHIS, volume_m3: Any, ratings: AccumulatorRatings | None = None) -> tuple[np.ndarray, np.ndarray]:
    """[-], [Pa] :func:`accumulator_rating` of a ``[his]`` table: its ``separator``, and its
    ``pressure_rating`` and ``max_working_pressure`` where given."""
    return accumulator_rating(volume_m3, his.separator, ratings, pressure_rating=his.pressure_rating, max_working_pressure=his.max_working_pressure)
