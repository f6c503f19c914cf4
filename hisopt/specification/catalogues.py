"""Catalogues of standard parts: the listed values a choice variable takes (docs/model.md §17).

A catalogue is a CSV file whose header names each column's quantity and unit (``bore [mm]``),
with ``#`` comment lines giving its source; its first column holds the sizes, further columns
a size's ratings (the accumulators' pressure columns, :mod:`hisopt.hydraulics.parts_catalogue`).
hisopt ships ISO 3320's bores and rods, common accumulator volumes with their ratings, and hose
bores (``hisopt/data/catalogues``); a problem names one of those, or its own file by path
(relative to the problem file).
``[variables] bore = { catalogue = "iso3320_bores", lower = "40 mm", upper = "100 mm" }``
takes the listed values within the bounds.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from hisopt.errors import ConfigError
from hisopt.hydraulics.parts_catalogue import AccumulatorRatings, accumulator_ratings, catalogue_table, shipped_accumulator_ratings
from hisopt.quantities import unit_factor


def catalogue_names() -> tuple[str, ...]:
    """[-] The shipped catalogues, by name (their file names without ``.csv``)."""
    folder = resources.files("hisopt") / "data" / "catalogues"
    return tuple(sorted(p.name.removesuffix(".csv") for p in folder.iterdir() if p.name.endswith(".csv")))


def catalogue_text(ref: str, base: Path | None, *, file: str | None, key: str) -> tuple[str, str]:
    """``(where, text)`` of the catalogue ``ref``: a shipped name or a CSV path (relative to
    ``base``, the problem file's folder)."""
    if ref in catalogue_names():
        return f"catalogue {ref!r}", (resources.files("hisopt") / "data" / "catalogues" / f"{ref}.csv").read_text(encoding="utf-8")
    path = Path(ref)
    if path.suffix.lower() != ".csv":
        raise ConfigError(f"unknown catalogue {ref!r}; expected one of {', '.join(catalogue_names())} or a CSV file path", file=file, key=key)
    if not path.is_absolute() and base is not None:
        path = base / path
    if not path.is_file():
        raise ConfigError(f"catalogue file {str(path)!r} not found; expected a CSV file of one column such as 'bore [mm]'", file=file, key=key)
    try:
        return str(path), path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"catalogue file {str(path)!r} cannot be read ({exc}); expected a UTF-8 CSV file", file=file, key=key) from None


def parse_catalogue(text: str, unit: str, *, where: str, file: str | None, key: str) -> list[float]:
    """[SI] The values of a catalogue's text in ``unit``, in increasing order.

    Raises
    ------
    ConfigError
        No header ``<quantity> [<unit>]``, a row without a value in every column, a unit of
        another kind, a value that is not a finite positive number, or a list not in increasing
        order (:func:`hisopt.hydraulics.parts_catalogue.catalogue_table`).
    """
    table = catalogue_table(text, where=where, file=file, key=key)
    factor = unit_factor(table.header[0][1], unit, file=file, key=key, text=f"{where}: the column's unit [{table.header[0][1]}]")
    values: list[float] = []
    for row, cells in table.rows:
        cell = cells[0]
        try:
            value = float(cell)
        except ValueError:
            raise ConfigError(f"{where}: row {row}: {cell!r}; expected a number in its first column", file=file, key=key) from None
        if not (value > 0 and value < float("inf")):
            raise ConfigError(f"{where}: row {row}: {cell!r}; expected a positive finite size", file=file, key=key)
        values.append(float(f"{value * factor:.15g}"))  # 36 mm is 0.036 m, not 0.036000000000000004
    if len(values) < 2:
        raise ConfigError(f"{where}: {len(values)} value(s); expected at least two to choose from", file=file, key=key)
    if any(not b > a for a, b in zip(values, values[1:], strict=False)):
        raise ConfigError(f"{where}: values not in increasing order; expected an ordered list (the search moves along it)", file=file, key=key)
    return values


def resolve_catalogue(table: dict[str, Any], unit: str, base: Path | None, *, file: str | None, key: str) -> dict[str, Any]:
    """A ``[variables]`` entry with ``catalogue`` given ``choices``: the catalogue's values
    (SI) within its ``lower`` and ``upper`` (if given), which then become the listed range.
    An entry that already has ``choices`` (a dumped problem) keeps them."""
    if "choices" in table or not isinstance(table.get("catalogue"), str):
        return table
    where, text = catalogue_text(table["catalogue"], base, file=file, key=f"{key}.catalogue")
    values = parse_catalogue(text, unit, where=where, file=file, key=f"{key}.catalogue")
    accumulator_ratings(catalogue_table(text, where=where, file=file, key=f"{key}.catalogue"), file=file, key=f"{key}.catalogue")  # its ratings read
    low, high = table.get("lower", -float("inf")), table.get("upper", float("inf"))
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (low, high)):
        return table  # a bound that is not a number: the strict validation names it
    kept = [v for v in values if low <= v <= high]
    if len(kept) < 2:
        raise ConfigError(f"{len(kept)} value(s) of {where} within [{low:g}, {high:g}] {unit}; expected at least two to choose from", file=file, key=key)
    return table | {"choices": kept, "lower": kept[0], "upper": kept[-1]}


LISTED_RTOL = 1e-12
"""[-] How near a value must be to a listed choice to be it: a catalogue's value read back
from a CSV file or converted from another unit moves by a few eps."""


def listed(values: np.ndarray, choices: np.ndarray) -> np.ndarray:
    """[-] Which ``values`` are one of the ``choices`` (increasing), within :data:`LISTED_RTOL`."""
    at = np.clip(np.searchsorted(choices, values), 1, len(choices) - 1)
    nearest = np.where(np.abs(values - choices[at - 1]) <= np.abs(values - choices[at]), choices[at - 1], choices[at])
    with np.errstate(invalid="ignore"):
        return np.abs(values - nearest) <= LISTED_RTOL * np.abs(nearest)


def catalogue_accumulator_ratings(ref: str | None, base: Path | None, *, file: str | None = None, key: str = "catalogue") -> AccumulatorRatings:
    """The accumulators' ratings by size of catalogue ``ref`` (a shipped name or a CSV path
    relative to ``base``, as a ``[variables]`` entry names it): its pressure columns, or, for
    None or a catalogue of volumes alone, the shipped ``accumulator_volumes``'
    (:func:`hisopt.hydraulics.parts_catalogue.accumulator_rating` takes them)."""
    if ref is None:
        return shipped_accumulator_ratings()
    where, text = catalogue_text(ref, base, file=file, key=key)
    return accumulator_ratings(catalogue_table(text, where=where, file=file, key=key), file=file, key=key) or shipped_accumulator_ratings()
