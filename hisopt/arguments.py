"""Checks of the arguments a person hands to a public function or a command, written once.

Each check raises :class:`hisopt.errors.ConfigError` with ``key`` the argument's name as the
caller knows it: the library passes its parameter (``n_samples``), the command line its
option (``--samples``), so both say the same one line (docs/model.md §8). A leaf: it imports
only :mod:`hisopt.errors`, so every layer may call it.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Collection
from typing import Any

from hisopt.errors import ConfigError


def _shown(value: Any, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def integer(value: Any, key: str, minimum: int | None = None, what: str = "") -> int:
    """``value`` as an int, refused unless it is a whole number (not a bool) at least ``minimum``.

    ``what`` names the count in the message (``samples``: "expected at least 2 samples").
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if not (isinstance(value, numbers.Real) and math.isfinite(value) and float(value).is_integer() and not isinstance(value, bool)):
            raise ConfigError(f"expected a whole number{f' of {what}' if what else ''}, got {_shown(value)}", key=key)
    number = int(value)
    if minimum is not None and number < minimum:
        raise ConfigError(f"expected at least {minimum}{f' {what}' if what else ''}, got {number}", key=key)
    return number


def number(value: Any, key: str, *, positive: bool = False, low: float | None = None, high: float | None = None, unit: str = "") -> float:
    """``value`` as a finite float, refused when it is not a number (or a bool), NaN or
    infinite, not ``> 0`` with ``positive``, or outside ``[low, high]``; ``unit`` is the
    unit the number is in (said in the message)."""
    shown = f"{_shown(value)}{f' {unit}' if unit and isinstance(value, numbers.Real) else ''}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigError(f"expected a number{f' [{unit}]' if unit else ''}, got {shown}", key=key)
    x = float(value)
    if not math.isfinite(x):
        raise ConfigError(f"expected a finite number{f' [{unit}]' if unit else ''}, got {shown}", key=key)
    if positive and x <= 0:
        raise ConfigError(f"expected a number > 0{f' [{unit}]' if unit else ''}, got {shown}", key=key)
    if (low is not None and x < low) or (high is not None and x > high):
        span = f"between {low} and {high}" if low is not None and high is not None else f">= {low}" if low is not None else f"<= {high}"
        raise ConfigError(f"expected a number {span}{f' [{unit}]' if unit else ''}, got {shown}", key=key)
    return x


def one_of(value: Any, choices: Collection[str], key: str) -> str:
    """``value`` when it is one of ``choices``, else the one line listing them."""
    if not isinstance(value, str) or value not in choices:
        raise ConfigError(f"expected one of {', '.join(choices)}, got {_shown(value)}", key=key)
    return value


def of_type(value: Any, kind: type | tuple[type, ...], key: str, expected: str) -> None:
    """Refuse ``value`` unless it is a ``kind``; ``expected`` says what in words ("a Problem
    (hisopt.load_problem)")."""
    if not isinstance(value, kind):
        raise ConfigError(f"expected {expected}, got {type(value).__name__} {_shown(value)}", key=key)


def problem_argument(value: Any, key: str = "problem") -> None:
    """Refuse ``value`` unless it is a loaded problem (a :class:`hisopt.DesignSpace`, told by
    what it has, since this leaf does not import the specification)."""
    if not (hasattr(value, "spec") and hasattr(value, "variable_names") and hasattr(value, "design_matrix")):
        raise ConfigError(f"expected a problem (hisopt.load_problem), got {type(value).__name__} {_shown(value)}", key=key)


def not_empty(values: Collection[Any], key: str, what: str) -> None:
    """Refuse an empty collection: ``what`` names one of its items ("a drop test")."""
    if len(values) == 0:
        raise ConfigError(f"expected at least one {what}, got none", key=key)


def columns(frame: Any, names: Collection[str], key: str) -> None:
    """Refuse ``frame`` unless it is a DataFrame holding every column of ``names``; ``key``
    names the argument that asked for the column (``objectives``, ``color_by``)."""
    import pandas as pd

    if not isinstance(frame, pd.DataFrame):
        raise ConfigError(f"expected a pandas DataFrame, got {type(frame).__name__}", key="frame")
    missing = [n for n in names if n not in frame.columns]
    if missing:
        shown = ", ".join(map(str, frame.columns[:12])) + (", ..." if len(frame.columns) > 12 else "")
        raise ConfigError(f"no column {missing[0]!r} in the table; its columns are {shown}", key=key)
