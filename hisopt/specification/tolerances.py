"""Epsilon tolerances of the thinned front, as people write them (docs/input.md, "Epsilon").

A tolerance says how much an objective must differ for two designs to count as different
(the thinned front of a run, :mod:`hisopt.optim.thinning`). Per objective it is either

- **relative**, written with a percent sign: ``"1 %"`` (or ``"1%"``, ``"1 percent"``): two
  values are within it when they differ by at most 1 % of the smaller one in magnitude
  (multiplicative: natural for PSDs that span decades); or
- **absolute**, in the objective's unit: ``"0.01 m/s^2"``, ``"2e-6 rad^2/Hz"``, read with
  :func:`hisopt.quantities.to_si`, so any unit of the right kind is accepted; a bare number
  is SI.

A percent sign always means relative, also for a dimensionless objective. A tolerance is
finite and not negative; zero means exact (the objective never thins the front), as does an
objective without a tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from hisopt.errors import ConfigError
from hisopt.quantities import split_quantity, to_si

PERCENT_UNITS = ("%", "percent")
"""Unit texts that make a tolerance relative (a share of the value)."""


@dataclass(frozen=True)
class Tolerance:
    """One objective's tolerance.

    Attributes
    ----------
    relative : bool
        [-] True: ``value`` is a share of the smaller value (``"1 %"`` is 0.01); False:
        ``value`` is in the objective's SI unit
    value : float
        [- or objective unit] the tolerance, finite and >= 0
    text : str
        [-] the tolerance as written (for records and messages)
    """

    relative: bool
    value: float
    text: str


def parse_tolerance(value: Any, unit: str, *, file: str | None = None, key: str | None = None) -> Tolerance:
    """A tolerance from its written form (module rules) for an objective in SI unit ``unit``.

    Parameters
    ----------
    value : Any
        [-] a number (absolute, SI) or a string: ``"1 %"``, ``"0.01 m/s^2"``, ``"0.01"``
    unit : str
        [-] the objective's SI unit (:data:`hisopt.metrics.METRICS`)
    file : str | None, optional
        [-] the file (or None for an option) named by a message
    key : str | None, optional
        [-] the key (or option) named by a message

    Raises
    ------
    ConfigError
        Not a number or a number with a unit, a unit of another kind, negative or not finite.
    """
    example = '"1 %" (relative) or a number in the objective\'s unit'
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        shown = str(value).lower() if isinstance(value, bool) else repr(value)
        raise ConfigError(f"expected a tolerance such as {example} ({unit}), got {shown}", file=file, key=key)
    text = str(value).strip()
    parts = split_quantity(text) if isinstance(value, str) else None
    if parts is not None and " ".join(parts[1].split()) in PERCENT_UNITS:
        relative, number = True, float(parts[0]) / 100.0
    else:
        relative = False
        try:
            number = to_si(value, unit, file=file, key=key)
        except ConfigError as exc:
            raise ConfigError(f'{exc.detail}; a tolerance may also be relative, e.g. "1 %"', file=file, key=key) from None
    if not math.isfinite(number) or number < 0.0:
        raise ConfigError(f"expected a finite tolerance >= 0 such as {example} ({unit}), got {text!r}", file=file, key=key)
    return Tolerance(relative, number, text)


def parse_tolerances(given: Mapping[str, Any], units: Mapping[str, str], *, file: str | None = None, key: Callable[[str], str] = str) -> dict[str, Tolerance]:
    """Tolerances by objective name from ``{name: written tolerance}``.

    Parameters
    ----------
    given : Mapping[str, Any]
        [-] written tolerances by objective name
    units : Mapping[str, str]
        [-] the SI unit of each objective that may have a tolerance, in objective order
    file : str | None, optional
        [-] the file named by a message (None for an option or a library call)
    key : Callable[[str], str], optional
        [-] the key a message names for an objective name (e.g. ``optimizer.epsilon.NAME``)

    Raises
    ------
    ConfigError
        An unknown objective name, or a tolerance :func:`parse_tolerance` refuses.
    """
    out = {}
    for name, value in given.items():
        if name not in units:
            raise ConfigError(f"{name!r} is not an objective of this problem; expected names from {', '.join(units)}", file=file, key=key(name))
        out[name] = parse_tolerance(value, units[name], file=file, key=key(name))
    return out


def parse_tolerance_options(items: str | Iterable[str] | None, option: str = "--epsilon") -> dict[str, str]:
    """``{name: text}`` from command-line items ``NAME=TOL`` (each may hold several, comma-separated).

    Raises
    ------
    ConfigError
        An item without ``=`` or without a name (naming ``option`` and the item).
    """
    if items is None:
        return {}
    out: dict[str, str] = {}
    for item in [items] if isinstance(items, str) else items:
        for part in str(item).split(","):
            name, sep, text = part.partition("=")
            if not sep or not name.strip() or not text.strip():
                raise ConfigError(f'expected NAME=TOLERANCE, e.g. {option} sigma_aw=1% or {option} "sigma_aw=0.01 m/s^2"', key=f"{option} {part.strip()}")
            out[name.strip()] = text.strip()
    return out
