"""Numbers with units where people type them: ``"2.5 MPa"`` is read as 2.5e6 Pa.

SI inside, units at the edges (docs/input.md, "Units"). Wherever a person types or pastes a
number (problem files, ``--set``, numeric command-line options, the units row of a designs
file) a value may carry a unit: ``"2.5 MPa"``, ``"12 cm^2"``, ``"1.5 deg"``, ``"72 km/h"``,
``"1.8 deg/g"``. A bare number is SI, as it always was. A unit of the wrong kind (a length
where a pressure is expected) is refused with one line naming the expected kind.

Every field's SI unit is declared once, as structured metadata on the field
(``Field(..., json_schema_extra={"unit": "Pa"})`` on pydantic models,
``field(metadata={"unit": "Pa"})`` on dataclasses), and read by :func:`field_unit`.
Unit strings are those hisopt writes (:mod:`hisopt.units`): ``-`` is dimensionless.

``g`` is two units: the gram and, in a roll gradient (``deg/g``) or an acceleration
(``[handling] step_g``, ``"0.05 g"`` for ``sigma_aw``), the gravitational acceleration
:data:`hisopt.constants.G_MPS2` the model itself uses for "1 g". It is read as the gram
where that fits the expected quantity and as gravity otherwise, so ``"5 g"`` is a mass in
``[payload] mass`` and an acceleration in ``step_g``.

pint (the units library) is imported only when a unit other than the expected SI one is
actually met: ``hisopt --help`` and files in SI never load it.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import re
from decimal import Decimal, localcontext
from typing import TYPE_CHECKING, Any

from hisopt.constants import G_MPS2
from hisopt.errors import ConfigError

if TYPE_CHECKING:
    import pint

NO_UNIT = "-"
"""Unit of dimensionless quantities (ratios, counts)."""

UNIT_KEY = "unit"
"""Key of a field's SI unit in its metadata (``json_schema_extra`` or dataclass ``metadata``)."""

_NUMBER = re.compile(r"\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*", re.DOTALL)
_G_TOKEN = re.compile(r"(?<![\w.])g(?!\w)")  # a lone "g" (not the g of "kg" or "deg")
_GRAVITY = "hisopt_g"  # the pint name of hisopt's "1 g"

# What each SI unit measures, for messages: (kind, example with a unit, the same in SI).
KINDS: dict[str, tuple[str, str, str]] = {
    "Pa": ("a pressure", "2.5 MPa", "2.5e6"),
    "Pa s m^-3": ("a valve coefficient (pressure per flow)", "0.8 MPa s/m^3", "8e5"),
    "Pa s^2 m^-6": ("an orifice coefficient (pressure per flow squared)", "1e10 Pa s^2/m^6", "1e10"),
    "Pa s": ("a dynamic viscosity", "30 mPa s", "0.03"),
    "m": ("a length", "25 mm", "0.025"),
    "m^2": ("an area", "10 cm^2", "1e-3"),
    "m^3": ("a volume", "1 L", "1e-3"),
    "m^3/s": ("a flow", "0.5 L/s", "5e-4"),
    "kg": ("a mass", "1210 kg", "1210"),
    "kg m^2": ("a moment of inertia", "390 kg m^2", "390"),
    "kg/m^3": ("a density", "870 kg/m^3", "870"),
    "N": ("a force", "2 kN", "2000"),
    "N/m": ("a stiffness", "18 kN/m", "1.8e4"),
    "N s/m": ("a damping coefficient", "1.5 kN s/m", "1500"),
    "m/s": ("a speed", "72 km/h", "20"),
    "m/s^2": ("an acceleration", "0.5 m/s^2", "0.5"),
    "g": ("an acceleration in g", "0.4 g", "0.4"),
    "s": ("a time", "0.5 s", "0.5"),
    "Hz": ("a frequency", "80 Hz", "80"),
    "K": ("a temperature", "-20 degC", "253.15"),
    "1/K": ("a thermal expansion coefficient", "7e-4 1/K", "7e-4"),
    "m^2/s": ("a kinematic viscosity", "32 cSt", "3.2e-5"),
    "rad": ("an angle", "1.5 deg", "0.02618"),
    "rad/s": ("an angular rate", "10 deg/s", "0.1745"),
    "rad/g": ("a roll gradient (angle per g)", "1.8 deg/g", "0.03142"),
    "rad/(m/s^2)": ("an angle per acceleration", "0.2 deg/(m/s^2)", "0.003491"),
    "rad^2/Hz": ("a PSD of an angle", "8e-5 rad^2/Hz", "8e-5"),
    "m^2/Hz": ("a PSD of a length", "4e-5 m^2/Hz", "4e-5"),
    "N^2/Hz": ("a PSD of a force", "5e4 N^2/Hz", "5e4"),
    "(m/s^2)^2/Hz": ("a PSD of an acceleration", "0.1 (m/s^2)^2/Hz", "0.1"),
    NO_UNIT: ("a dimensionless number", "50 %", "0.5"),
}


# --- the SI unit of a field ----------------------------------------------------------------------
def field_unit(owner: type, name: str) -> str | None:
    """The SI unit declared on field ``name`` (or its alias) of a pydantic model or a dataclass.

    None for a field without a unit (a name, a count, a table) or no such field.
    """
    fields = getattr(owner, "model_fields", None)
    if fields is not None:
        info = fields.get(name) or next((f for f in fields.values() if f.alias == name), None)
        extra = getattr(info, "json_schema_extra", None)
        unit = extra.get(UNIT_KEY) if isinstance(extra, dict) else None
        return unit if isinstance(unit, str) else None
    if dataclasses.is_dataclass(owner):
        found = next((f for f in dataclasses.fields(owner) if f.name == name), None)
        return None if found is None else found.metadata.get(UNIT_KEY)
    return None


def si(unit: str) -> dict[str, Any]:
    """The metadata declaring a field's SI unit: ``Field(..., json_schema_extra=si("Pa"))``."""
    return {UNIT_KEY: unit}


# --- reading a value -------------------------------------------------------------------------------
def split_quantity(text: str) -> tuple[str, str] | None:
    """``"2.5 MPa"`` -> ``("2.5", "MPa")``, ``"3e6"`` -> ``("3e6", "")``: the number's text and
    the unit's; None when the text does not start with a number (a name, a word)."""
    match = _NUMBER.fullmatch(text)
    if match is None:
        return None
    return match.group(1), match.group(2)


def scaled(number: str, factor: float) -> float:
    """[SI] The number written ``number`` times ``factor`` (:func:`unit_factor`), rounded once.

    The product is taken in decimal, so ``"12.5"`` cm^2 is the float nearest 12.5e-4, the
    same float as the SI literal ``12.5e-4``: a file in engineering units runs bit for bit as
    its SI twin whenever the factor is a power of ten (or any decimal: 9.81, 1e-3).
    """
    if factor == 1.0:
        return float(number)
    try:
        with localcontext(prec=60):  # exact: no rounding before the one to float
            return float(Decimal(number.strip()) * Decimal(repr(factor)))
    except ArithmeticError:  # a text float() reads and Decimal does not: one more rounding
        return float(number) * factor


def has_unit(value: Any) -> bool:
    """Whether ``value`` is a string holding a number followed by a unit (``"2.5 MPa"``)."""
    if not isinstance(value, str):
        return False
    parts = split_quantity(value)
    return parts is not None and parts[1] != ""


def to_si(value: Any, unit: str, *, file: str | None = None, key: str | None = None) -> float:
    """``value`` in the SI unit ``unit``: a number as it is, a string ``"<number> [<unit>]"``
    converted (``to_si("2.5 MPa", "Pa") == 2.5e6``; a string without a unit is SI).

    Raises
    ------
    ConfigError
        Not a number, an unknown unit or a unit of another kind (naming ``file`` and ``key``).
    """
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    text = str(value)
    parts = split_quantity(text)
    if parts is None:
        try:
            return float(text)  # "inf", "nan": the caller's own check names the rule
        except ValueError:
            pass
        raise ConfigError(f"expected a number (SI) or a number with a unit, e.g. {_example(unit)}; got {text.strip()!r}", file=file, key=key)
    number, given = parts
    if _is_scale(given):  # "20 degC": a point on a temperature scale, not a multiple of a unit
        return _scale_point(number, given, unit, file=file, key=key, text=text.strip())
    value = scaled(number, unit_factor(given, unit, file=file, key=key, text=text.strip()))
    if unit == "K" and given:  # "-5 K", "-5 mK": named as written, never with a Celsius hint
        problem = absolute_zero_problem(value, f"{number} {' '.join(given.split())}")
        if problem:
            raise ConfigError(problem, file=file, key=key)
    return value


_SCALES = {
    **dict.fromkeys(("degc", "°c", "celsius", "degree_celsius"), "degC"),
    **dict.fromkeys(("degf", "°f", "fahrenheit", "degree_fahrenheit"), "degF"),
}
"""Temperature scales with an offset from absolute zero, by their written (lower-case) names."""


def _is_scale(given: str) -> bool:
    return " ".join(given.split()).lower() in _SCALES


def _scale_point(number: str, given: str, unit: str, *, file: str | None, key: str | None, text: str) -> float:
    """[K] A temperature written on a scale with an offset (``"20 degC"`` is 293.15 K, not
    20 times the size of a degree); only where a temperature is expected."""
    if unit != "K":
        raise ConfigError(f"{json.dumps(text, ensure_ascii=False)} is a temperature; expected {_kind(unit)} (e.g. {_example(unit)})", file=file, key=key)
    scale = _SCALES[" ".join(given.split()).lower()]
    value = float(_registry().Quantity(float(number), scale).to("K").magnitude)
    problem = absolute_zero_problem(float(number), f"{number} {' '.join(given.split())}", scale)  # compared as written: -459.67 degF is 0 K exactly
    if problem:
        raise ConfigError(problem, file=file, key=key)
    return float(f"{value:.15g}")  # 20 degC is 293.15 K exactly as written, not 293.15000000000003


ABSOLUTE_ZERO = {"K": 0.0, "degC": -273.15, "degF": -459.67}
"""Absolute zero on each temperature scale hisopt reads, in that scale's own degrees."""


def absolute_zero_problem(value: float, shown: str, scale: str = "K") -> str | None:
    """Why the temperature ``value`` on ``scale`` (a key of :data:`ABSOLUTE_ZERO`), written
    ``shown``, cannot be: ``-300 degC is below absolute zero (-273.15 degC)``; None above
    absolute zero. The message names the value as the person wrote it, in their scale."""
    zero_value = ABSOLUTE_ZERO[scale]
    if value > zero_value:
        return None
    zero = f"{zero_value:g} {scale}"
    if value < zero_value:
        return f"{shown} is below absolute zero ({zero})"
    return f"{shown} is absolute zero ({zero}), which no oil or gas reaches; expected a temperature above it"


def unit_factor(given: str, unit: str, *, file: str | None = None, key: str | None = None, text: str | None = None) -> float:
    """SI units (``unit``) per ``given`` unit: ``unit_factor("MPa", "Pa") == 1e6``.

    ``given`` may be empty (SI) or ``-`` (dimensionless). ``text`` is the value as written,
    for messages (default ``given`` in brackets). The factor is rounded to 16 significant
    digits: a decimal one comes out exact (pint's ``L`` is ``0.1 m`` cubed, 1.0000000000000002e-3;
    this is 1e-3), an irrational one (``deg``: pi/180) moves by at most 5e-16 relative.

    Raises
    ------
    ConfigError
        ``given`` is unknown or of another kind than ``unit`` (naming ``file`` and ``key``).
    """
    given = " ".join(given.split())
    if _is_scale(given):  # 0 degC is not 0 K: no factor turns one into the other
        shown = json.dumps(text if text is not None else given, ensure_ascii=False)
        raise ConfigError(f"{shown}: a temperature scale with an offset is not a factor; expected K (absolute)", file=file, key=key)
    if given in ("", unit):  # SI already: no units library needed
        return 1.0
    # the text as written, its line breaks and control characters escaped: a message is one line
    shown = json.dumps(text, ensure_ascii=False) if text is not None else f"[{given}]"
    expected = f"expected {_kind(unit)} (e.g. {_example(unit)})"
    ureg = _registry()
    try:
        target = _parse(unit, gravity=True)
    except Exception as exc:  # a unit string of hisopt itself: a bug, named as such
        raise ValueError(f"hisopt declares the unknown unit {unit!r}") from exc
    readings = []
    for gravity in (False, True) if _G_TOKEN.search(given) else (False,):
        try:
            readings.append(_parse(given, gravity))
        except Exception as exc:  # pint raises several types for unreadable text
            names = getattr(exc, "unit_names", None)
            names = [names] if isinstance(names, str) else list(names or [])
            what = f"unknown unit {names[0]!r}" if names else f"cannot read the unit {given!r}"
            raise ConfigError(f"{shown}: {what}; {expected}", file=file, key=key) from None
    try:
        for reading in readings:
            if _fits(reading, target):
                factor = float(ureg.Quantity(1.0, reading).to(target).magnitude)
                if not (math.isfinite(factor) and factor > 0):
                    raise OverflowError
                return float(f"{factor:.16g}")
    except ArithmeticError:  # km^999 / Mm^999 m: a factor beyond floats
        raise ConfigError(f"{shown}: the unit {given!r} is out of range; {expected}", file=file, key=key) from None
    kinds = [_kind_of(r) for r in readings]  # the gram's reading first, then gravity's
    is_what = next((k for k in kinds if k.startswith("a")), kinds[0])
    raise ConfigError(f"{shown} is {is_what}; {expected}", file=file, key=key)


def check_si_label(label: str, unit: str, *, file: str | None = None, key: str | None = None) -> None:
    """Refuse a unit label (``[variables] p0 = {..., unit = "MPa"}``) that is not ``unit``
    itself: the bare numbers beside it are SI, so any other scale would lie."""
    if " ".join(label.split()) in ("", unit):
        return
    factor = unit_factor(label, unit, file=file, key=key, text=label)
    if abs(factor - 1.0) > 1e-12:
        shown = KINDS[unit][1] if unit in KINDS else f"1 {unit}"
        raise ConfigError(
            f"{label!r} is not the SI unit {unit!r}, and bare numbers are SI; expected unit = {unit!r}, "
            f'or values written with their unit (e.g. upper = "{shown}")',
            file=file,
            key=key,
        )


# --- messages ----------------------------------------------------------------------------------
def _kind(unit: str) -> str:
    return KINDS[unit][0] if unit in KINDS else f"a quantity in {unit}"


def _example(unit: str) -> str:
    if unit in KINDS:
        _, shown, bare = KINDS[unit]
        return f'"{shown}" or {bare} [{unit}]'
    return f'"1 {unit}"'


def _kind_of(units: Any) -> str:
    """What a parsed unit measures (``a length``), else its dimension."""
    for unit in KINDS:
        try:
            if _fits(units, _parse(unit, gravity=True)):
                return KINDS[unit][0]
        except ArithmeticError:  # a factor beyond floats: not this kind, whatever it is
            continue
    ureg = _registry()
    dimension = str(ureg.Quantity(1.0, units).dimensionality)
    return "dimensionless" if dimension == "dimensionless" else f"of dimension {dimension}"


# --- pint, loaded on first use ---------------------------------------------------------------------
@functools.cache
def _registry() -> pint.UnitRegistry:
    import pint

    ureg: pint.UnitRegistry = pint.UnitRegistry()
    ureg.define(f"{_GRAVITY} = {G_MPS2!r} * meter / second ** 2")
    return ureg


@functools.cache
def _parse(text: str, gravity: bool) -> Any:
    """pint units of ``text`` (``-`` dimensionless; with ``gravity`` a lone ``g`` is 1 g)."""
    ureg = _registry()
    if text == NO_UNIT:
        return ureg.dimensionless
    if not _plain(text):
        raise ValueError(f"not a unit: {text!r}")
    return ureg.parse_units(_G_TOKEN.sub(_GRAVITY, text) if gravity else text)


_NUMERAL = re.compile(r"(?<![\w.])\d+(?:\.\d+)?")  # a number, not the digit of a name (g_0)
_AFTER_POWER = re.compile(r"(?:\^|\*\*)\s*\(?\s*-?\s*$")
_POWER_OF_POWER = re.compile(r"(?:\^|\*\*)\s*-?\s*\d[\d.]*\s*(?:\^|\*\*)")


def _plain(text: str) -> bool:
    """Whether pint may evaluate ``text`` safely: numbers only as exponents of up to three
    characters (``m^-3``, ``s^2``) and the 1 of ``1/s``, no power of a power. pint evaluates
    numbers in a unit expression exactly: ``10^10^10`` would never return."""
    if len(text) > 80 or _POWER_OF_POWER.search(text):
        return False
    for match in _NUMERAL.finditer(text):
        exponent = _AFTER_POWER.search(text[: match.start()]) is not None and len(match.group()) <= 3
        one = match.group() == "1" and text[match.end() :].lstrip().startswith("/")
        if not (exponent or one):
            return False
    return True


def _angle_power(units: Any) -> float:
    """Power of the radian in ``units`` (pint counts angles as dimensionless; hisopt does not)."""
    root = _registry().Quantity(1.0, units).to_root_units()
    return float(dict(root.unit_items()).get("radian", 0))  # type: ignore[arg-type]


def _fits(given: Any, target: Any) -> bool:
    """Same dimension, angles counted (a degree is not a ratio)."""
    ureg = _registry()
    same = ureg.Quantity(1.0, given).dimensionality == ureg.Quantity(1.0, target).dimensionality
    return bool(same and _angle_power(given) == _angle_power(target))
