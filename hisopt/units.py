"""Units of the quantities hisopt reports, and how people read them.

SI inside, engineering units at the edges. Every DataFrame hisopt returns names the unit of
each column in ``frame.attrs["units"]`` (:func:`with_units`), which
:func:`hisopt.io.write_csv` writes as a second header row. Unit strings are plain ASCII
(``m/s^2``, ``Pa s m^-3``, ``rad^2/Hz``); ``-`` marks a column without a physical unit:
ratios, counts, flags and labels.

Human tables and figures show numbers in engineering units (:func:`display_for`): one unit
per column, chosen from the column's largest magnitude, 4 significant figures.

========================  ===================================================================
SI unit                   shown as
========================  ===================================================================
``Pa``                    Pa, kPa from 1 kPa, MPa from 0.1 MPa (``0.1 MPa``, ``2.5 MPa``)
``Pa s m^-3``             the same prefixes: ``0.8 MPa s/m^3``
``m``                     µm, mm from 0.1 mm, m from 1 m
``m^2``                   mm^2, cm^2 from 1 cm^2, m^2 from 1 m^2 (``12.8 cm^2``)
``m^3``                   cm^3, L from 0.1 L, m^3 from 1 m^3
``m^3/s``                 L/s (a valve's RMS flow: ``0.12 L/s``)
``N``                     N, kN from 10 kN
``N/m``, ``N s/m``        N/m, kN/m from 10 kN/m (and N s/m, kN s/m likewise)
``rad``, ``rad/g``        deg, deg/g: roll angles and roll gradients as vehicle engineers
                          quote them; the number shown is in the unit shown (180/pi x rad);
                          likewise ``rad/s`` and ``rad/(m/s^2)`` (deg/s, deg/(m/s^2))
PSDs (``<u>^2/Hz``)       scientific notation in the SI unit (``8.468e-5 rad^2/Hz``)
anything else             4 significant figures in the SI unit (``1.795 Hz``, ``0.3082 -``)
========================  ===================================================================

Only the display changes: files and DataFrames keep SI values at full precision.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from hisopt.arguments import integer, of_type
from hisopt.errors import ConfigError

NO_UNIT = "-"
"""Unit of ratios, counts, flags and labels."""

DIGITS = 4
"""Significant figures of displayed numbers."""

# SI unit -> ((smallest magnitude in SI, display unit, display value per SI value), ...),
# ascending; the last step whose magnitude the value reaches is used.
_STEPS: dict[str, tuple[tuple[float, str, float], ...]] = {
    "Pa": ((0.0, "Pa", 1.0), (1e3, "kPa", 1e-3), (1e5, "MPa", 1e-6), (1e8, "GPa", 1e-9)),
    "Pa s m^-3": ((0.0, "Pa s/m^3", 1.0), (1e3, "kPa s/m^3", 1e-3), (1e5, "MPa s/m^3", 1e-6), (1e8, "GPa s/m^3", 1e-9)),
    "m": ((0.0, "µm", 1e6), (1e-4, "mm", 1e3), (1.0, "m", 1.0)),
    "m^2": ((0.0, "mm^2", 1e6), (1e-4, "cm^2", 1e4), (1.0, "m^2", 1.0)),
    "m^3": ((0.0, "cm^3", 1e6), (1e-4, "L", 1e3), (1.0, "m^3", 1.0)),
    "m^3/s": ((0.0, "L/s", 1e3),),
    "N": ((0.0, "N", 1.0), (1e4, "kN", 1e-3)),
    "N/m": ((0.0, "N/m", 1.0), (1e4, "kN/m", 1e-3)),
    "N s/m": ((0.0, "N s/m", 1.0), (1e4, "kN s/m", 1e-3)),
    "rad": ((0.0, "deg", 180.0 / math.pi),),
    "rad/g": ((0.0, "deg/g", 180.0 / math.pi),),
    "rad/s": ((0.0, "deg/s", 180.0 / math.pi),),
    "rad/(m/s^2)": ((0.0, "deg/(m/s^2)", 180.0 / math.pi),),
}

_FIXED: dict[str, str] = {
    # labels and flags
    "mode": NO_UNIT,
    "motion": NO_UNIT,
    "dominant": NO_UNIT,
    "case": NO_UNIT,
    "source": NO_UNIT,
    "status": NO_UNIT,
    "design": NO_UNIT,
    "feasible": NO_UNIT,
    "valid": NO_UNIT,
    "accepted": NO_UNIT,
    # counts and indices
    "generation": NO_UNIT,
    "generations": NO_UNIT,
    "evaluation": NO_UNIT,
    "evaluations": NO_UNIT,
    "front_size": NO_UNIT,
    "seed": NO_UNIT,
    "source_index": NO_UNIT,
    "rounds": NO_UNIT,
    "iterations": NO_UNIT,
    # ratios
    "feasible_share": NO_UNIT,
    "mechanical_share": NO_UNIT,
    "damping": NO_UNIT,
    "asf": NO_UNIT,
    "merit": NO_UNIT,
    # times
    "seconds": "s",
    "f_hz": "Hz",
}
_SUFFIXES = (("_hz", "Hz"), ("_s", "s"), ("_pct", "%"), ("_ratio", NO_UNIT), ("_share", NO_UNIT))
_PREFIXES = (("shape_", NO_UNIT),)  # mode shapes, normalised to a largest entry of +1


# --- units of columns ------------------------------------------------------------------------
class VariableSpace(Protocol):
    """What the unit helpers read of a problem (:class:`hisopt.specification.design_space.DesignSpace`):
    its variables' units and its objectives; a protocol, so this leaf imports nothing above it."""

    @property
    def variable_units(self) -> Mapping[str, str]: ...

    @property
    def objective_names(self) -> tuple[str, ...]: ...


def psd_unit(unit: str) -> str:
    """Unit of the PSD of a signal in ``unit``: ``m`` -> ``m^2/Hz``, ``m/s^2`` -> ``(m/s^2)^2/Hz``."""
    simple = re.fullmatch(r"[A-Za-zµ]+", unit) is not None
    return f"{unit}^2/Hz" if simple else f"({unit})^2/Hz"


def is_psd(unit: str) -> bool:
    """Whether ``unit`` is a power spectral density unit (``...^2/Hz``)."""
    return unit.endswith("^2/Hz")


def hypervolume_unit(n_objectives: int) -> str:
    """Hypervolume in log10 objective space: one decade per objective axis."""
    return f"decades^{n_objectives}"


def variable_units(problem: VariableSpace) -> dict[str, str]:
    """Unit of each design variable of ``problem``: its ``variable_units``
    (:attr:`hisopt.specification.design_space.DesignSpace.variable_units`)."""
    return dict(problem.variable_units)


def column_unit(name: str) -> str:
    """Unit of a column hisopt writes, from its name alone ('' when unknown).

    Objective and constraint quantities (:data:`hisopt.metrics.METRICS`, also as a scenario's
    ``"<quantity>@<scenario>"``), fixed names
    (``feasible``, ``generation``, ...) and suffixes (``_hz``, ``_s``, ``_pct``, ``_ratio``).
    Design variables need the problem: :func:`column_units`.
    """
    from hisopt.metrics import METRICS
    from hisopt.robust import quantity_of

    if quantity_of(name) in METRICS:  # "sigma_aw" or a scenario's "sigma_aw@city"
        return METRICS[quantity_of(name)].unit
    if name in _FIXED:
        return _FIXED[name]
    for prefix, unit in _PREFIXES:
        if name.startswith(prefix):
            return unit
    for suffix, unit in _SUFFIXES:
        if name.endswith(suffix):
            return unit
    return ""


def column_units(columns: Iterable[Any], problem: VariableSpace | None = None, extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """Unit of every column: ``extra`` first, then the problem's variables, then :func:`column_unit`.

    With a problem, ``hypervolume`` is in ``decades^n_obj``.
    """
    known: dict[str, str] = {}
    if problem is not None:
        known |= problem.variable_units
        known["hypervolume"] = hypervolume_unit(len(problem.objective_names))
    known |= dict(extra or {})
    return {str(c): known[str(c)] if str(c) in known else column_unit(str(c)) for c in columns}


def with_units(frame: pd.DataFrame, units: Mapping[str, str]) -> pd.DataFrame:
    """Set ``frame.attrs["units"]`` to the unit of each of its columns (in place); returns ``frame``."""
    frame.attrs["units"] = {str(c): units.get(str(c), "") for c in frame.columns}
    return frame


def attach_units(frame: pd.DataFrame, problem: VariableSpace | None = None, extra: Mapping[str, str] | None = None) -> pd.DataFrame:
    """:func:`with_units` with :func:`column_units` of the frame's columns (in place); returns ``frame``."""
    return with_units(frame, column_units(frame.columns, problem, extra))


# --- display -----------------------------------------------------------------------------------
def _compact(text: str) -> str:
    """``8.468e-05`` -> ``8.468e-5``, ``1e+06`` -> ``1e6``."""
    if "e" not in text:
        return text
    mantissa, exponent = text.split("e")
    return f"{mantissa}e{int(exponent)}"


def format_number(value: Any, digits: int = DIGITS, scientific: bool = False, trim: bool = True) -> str:
    """A number for people: ``digits`` significant figures, compact exponents, ints as ints.

    ``trim=False`` keeps trailing zeros (``1.400``), so that a table column reads evenly.
    """
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if not isinstance(value, (float, np.floating)):
        return str(value)
    x = float(value)
    if not math.isfinite(x):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if x == 0.0:
        return "0"
    if scientific:
        mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
        mantissa = mantissa.rstrip("0").rstrip(".") if trim and "." in mantissa else mantissa
        return f"{mantissa}e{int(exponent)}"
    return _compact(f"{x:.{digits}g}" if trim else f"{x:#.{digits}g}".rstrip("."))


@dataclass(frozen=True)
class Display:
    """How a quantity is shown: in ``unit``, ``scale`` display units per SI unit."""

    unit: str
    scale: float = 1.0
    scientific: bool = False
    digits: int = DIGITS
    trim: bool = True

    def number(self, value: Any) -> str:
        """The number alone, in :attr:`unit` (labels and flags as text)."""
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            return format_number(value)
        if isinstance(value, (int, np.integer)) and self.scale == 1.0 and not self.scientific:
            return str(int(value))
        return format_number(float(value) * self.scale, self.digits, self.scientific, self.trim)

    def __call__(self, value: Any) -> str:
        """Number and unit: ``0.1 MPa`` (no unit after text, flags and ``-``)."""
        text = self.number(value)
        numeric = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
        return f"{text} {self.unit}" if numeric and self.unit not in ("", NO_UNIT) else text

    def values(self, values: ArrayLike) -> np.ndarray:
        """[display unit] Values scaled for plotting."""
        return np.asarray(values, dtype=float) * self.scale

    def label(self, name: str) -> str:
        """Axis or column title with the unit in brackets: ``p0 [MPa]``."""
        return f"{name} [{self.unit}]" if self.unit else name


def _magnitude(values: ArrayLike) -> float:
    try:
        x = np.abs(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        return 0.0
    x = x[np.isfinite(x)]
    return float(x.max()) if x.size else 0.0


def display_for(unit: str, values: ArrayLike | float = 0.0, digits: int = DIGITS, trim: bool = True) -> Display:
    """The engineering display of quantities in ``unit`` with these values (one unit for all).

    The unit follows the largest finite magnitude (module docstring table); PSDs are shown
    in scientific notation. ``trim=False`` keeps trailing zeros (table columns).
    """
    if is_psd(unit):
        return Display(unit, 1.0, True, digits, trim)
    steps = _STEPS.get(unit)
    if steps is None:
        return Display(unit, 1.0, False, digits, trim)
    size = _magnitude(values)
    chosen = steps[0]
    for step in steps:
        if size >= step[0] * (1 - 1e-12):
            chosen = step
    return Display(chosen[1], chosen[2], False, digits, trim)


def format_quantity(value: float, unit: str, digits: int = DIGITS) -> str:
    """One value in engineering units: ``format_quantity(1e5, "Pa") == "0.1 MPa"``."""
    if isinstance(value, (str, bytes, bool)):
        raise ConfigError(f"expected a number, got {value!r}", key="value")
    try:
        float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"expected a number, got {type(value).__name__}", key="value") from None
    of_type(unit, str, "unit", "a unit (str), e.g. 'Pa'")
    integer(digits, "digits", minimum=1, what="significant figures")
    return display_for(unit, value, digits)(value)


def format_design(values: Mapping[str, float], units: Mapping[str, str]) -> str:
    """``p0 = 2 MPa, dA = 10 cm^2, lam = 0.5`` for titles and captions."""
    return ", ".join(f"{k} = {format_quantity(float(v), units.get(k, ''))}" for k, v in values.items())


def display_frame(frame: pd.DataFrame, units: Mapping[str, str] | None = None, digits: int = DIGITS) -> pd.DataFrame:
    """Strings for a human table: headers ``name [unit]``, values in each column's display unit.

    Parameters
    ----------
    frame : pd.DataFrame
        [SI] the table; ``units`` default ``frame.attrs["units"]``
    digits : int, optional
        [-] significant figures
    """
    of_type(frame, pd.DataFrame, "frame", "a pandas DataFrame")
    if units is not None:
        of_type(units, Mapping, "units", "a dict of column names to units")
    integer(digits, "digits", minimum=1, what="significant figures")
    units = dict(frame.attrs.get("units", {}) if units is None else units)
    out = {}
    for col in frame.columns:
        unit = units.get(str(col), "")
        data = frame[col]
        numeric = pd.api.types.is_numeric_dtype(data.dtype) and not pd.api.types.is_bool_dtype(data.dtype)
        shown = display_for(unit, data.to_numpy() if numeric else 0.0, digits, trim=False)
        out[shown.label(str(col))] = [shown.number(v) for v in data]
    return pd.DataFrame(out, index=frame.index)
