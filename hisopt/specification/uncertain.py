"""``[[uncertain]]``: model inputs that vary around their nominal values (docs/model.md §18).

An entry names an input and its distribution in the units a person writes::

    [[uncertain]]
    input = "vehicle.m_s"         # a [vehicle] field
    distribution = "normal"
    sd = "5 %"                    # of the nominal (the file's value, or a design's)

    [[uncertain]]
    input = "p0"                  # a [his] or layout parameter, design variable or not
    tolerance = "±4 %"            # uniform; with distribution = "normal": 3 sd

Inputs: a ``[vehicle]`` field (``vehicle.<field>``), a ``[his]`` or layout parameter by its
name, ``temperature``, ``road.speed``, ``road.gd_n0`` (the ISO 8608 roughness; or
``road.class`` with a ``band`` of classes, log-uniform over them) and a ``[payload]`` field
(``payload.<field>``). Every distribution maps a standard uniform variate ``u`` to a value
(:meth:`Uncertain.values`), so one sample set of ``u`` serves every design: common random
numbers. This module reads and checks the entries (:func:`resolve_uncertain`); sampling and
evaluation are :mod:`hisopt.evaluation.uncertain`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict
from scipy import stats

from hisopt.coupled.payload import Payload
from hisopt.errors import ConfigError
from hisopt.hydraulics.catalogue import PIPE_PARAMETERS, his_layout, his_parameter_values, layout_defaults, parameter_unit
from hisopt.hydraulics.layout import parameter_uses
from hisopt.hydraulics.roll_plane import RollPlaneHIS, reference_temperature
from hisopt.quantities import field_unit, split_quantity, to_si, unit_factor
from hisopt.specification.validation import Rule, parameter_rule
from hisopt.standards.iso_8608_2016 import class_gd_n0, road_classes
from hisopt.vehicle import VehicleParams

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

Kind = Literal["normal", "uniform", "triangular", "loguniform"]

IMPOSSIBLE_MASS = 1e-9
"""Largest probability an untruncated distribution may put where its input is physically
impossible: a normal's tail 6 sd out. Beyond it the entry must be truncated or narrowed."""

ROAD_CLASS = "road.class"
ROAD_ROUGHNESS = "road.gd_n0"
ROAD_SPEED = "road.speed"
TEMPERATURE = "temperature"
VEHICLE = "vehicle."
PAYLOAD = "payload."


class ProblemParts(Protocol):
    """What the entries are read against: the parts of a problem specification
    (:class:`hisopt.specification.config.ProblemSpec`, which holds the entries, so a structural
    type here and no import back)."""

    @property
    def vehicle(self) -> VehicleParams: ...
    @property
    def his(self) -> RollPlaneHIS: ...
    @property
    def payload(self) -> Payload | None: ...
    @property
    def variables(self) -> Mapping[str, Any]: ...
    @property
    def road(self) -> Any: ...
    @property
    def temperature(self) -> float | None: ...
    @property
    def scenarios(self) -> Sequence[Any]: ...
    @property
    def uncertain(self) -> Sequence[UncertainInput]: ...


class UncertainInput(BaseModel):
    """One ``[[uncertain]]`` table as written: numbers SI, or strings with a unit (spreads
    also in ``%`` of the nominal); :func:`resolve_uncertain` reads it."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    input: str
    distribution: Kind | None = None
    mean: float | str | None = None
    sd: float | str | None = None
    lower: float | str | None = None
    upper: float | str | None = None
    mode: float | str | None = None
    half_width: float | str | None = None
    tolerance: float | str | None = None
    truncate: list[float | str] | None = None
    band: list[str] | None = None


@dataclass(frozen=True)
class Uncertain:
    """A checked uncertain input in SI.

    Attributes
    ----------
    name : str
        [-] the input as written (``vehicle.m_s``, ``p0``, ``temperature``, ...)
    unit : str
        [-] its SI unit
    kind : Kind
        [-] the distribution
    center : float | None
        [unit] the normal's mean or the triangle's mode; None: the nominal value
    spread : float | None
        [unit, or - when relative] the normal's sd or the half width of a uniform or triangle
        around the center; None: ``lower`` and ``upper`` bound it
    relative : bool
        [-] ``spread`` is a fraction of the nominal value
    lower, upper : float | None
        [unit] absolute ends of a uniform, triangle or log-uniform, or the normal's truncation
    """

    name: str
    unit: str
    kind: Kind
    center: float | None = None
    spread: float | None = None
    relative: bool = False
    lower: float | None = None
    upper: float | None = None

    def values(self, u: np.ndarray, nominal: Any) -> np.ndarray:
        """[unit] The value at standard uniform variates ``u`` in (0, 1) around ``nominal``
        (broadcast together: designs ``(n, 1)`` against samples ``(N,)`` give ``(n, N)``)."""
        u = np.asarray(u, dtype=float)
        nominal = np.asarray(nominal, dtype=float)
        width = None if self.spread is None else self.spread * (np.abs(nominal) if self.relative else 1.0)
        center = nominal if self.center is None else np.full_like(nominal, self.center)
        if self.kind == "normal":
            assert width is not None
            if self.lower is None and self.upper is None:
                return center + width * stats.norm.ppf(u)
            a = -np.inf if self.lower is None else (self.lower - center) / width
            b = np.inf if self.upper is None else (self.upper - center) / width
            return center + width * stats.truncnorm.ppf(u, a, b)
        lo, hi = self.ends(nominal)
        if self.kind == "uniform":
            return lo + u * (hi - lo)
        if self.kind == "loguniform":
            return np.exp(np.log(lo) + u * (np.log(hi) - np.log(lo)))
        return stats.triang.ppf(u, (center - lo) / (hi - lo), lo, hi - lo)

    def ends(self, nominal: Any) -> tuple[Any, Any]:
        """[unit] Lowest and highest value at ``nominal`` (a normal's truncation, else +-inf)."""
        nominal = np.asarray(nominal, dtype=float)
        if self.kind == "normal" or self.spread is None:
            lo = -np.inf if self.lower is None else self.lower
            hi = np.inf if self.upper is None else self.upper
            return np.broadcast_to(lo, nominal.shape) + 0.0, np.broadcast_to(hi, nominal.shape) + 0.0
        width = self.spread * (np.abs(nominal) if self.relative else 1.0)
        center = nominal if self.center is None else self.center
        return center - width, center + width

    def outside(self, rule: Rule, nominal: float) -> float:
        """[-] Probability at ``nominal`` of a value that breaks ``rule`` (a normal's tails;
        0 or 1 for a bounded distribution, whose ends are checked instead)."""
        if self.kind != "normal":
            lo, hi = self.ends(nominal)
            return 0.0 if bool(np.all(rule.holds(np.array([lo, hi])))) else 1.0
        width = float(self.spread or 0.0) * (abs(nominal) if self.relative else 1.0)
        center = nominal if self.center is None else self.center
        if width == 0.0:  # a spread in % of a design's bound at 0: a point
            return 0.0 if bool(rule.holds(center)) else 1.0
        cut = stats.norm(center, width)
        lo_end = -np.inf if self.lower is None else self.lower
        hi_end = np.inf if self.upper is None else self.upper
        mass = cut.cdf(hi_end) - cut.cdf(lo_end)
        low = 0.0 if rule.lower is None else max(0.0, cut.cdf(min(rule.lower, hi_end)) - cut.cdf(lo_end))
        high = 0.0 if rule.upper is None else max(0.0, cut.cdf(hi_end) - cut.cdf(max(rule.upper, lo_end)))
        return float((low + high) / mass)

    @property
    def text(self) -> str:
        """The distribution as a person writes it: ``normal, mean nominal, sd 5 %``,
        ``triangular -10 degC to 50 degC, mode 20 degC`` (temperatures on the Celsius scale)."""
        point = lambda v: f"{v - 273.15:.4g} degC" if self.unit == "K" else f"{v:.4g} {self.unit}"  # noqa: E731
        if self.kind == "loguniform":
            return f"log-uniform {point(self.lower)} to {point(self.upper)}"
        spread = None if self.spread is None else (f"{self.spread * 100:.4g} %" if self.relative else f"{self.spread:.4g} {self.unit}")
        at = "nominal" if self.center is None else point(self.center)
        if self.kind == "normal":
            cut = "" if self.lower is None and self.upper is None else f", truncated to {_end(self.lower, point, '-inf')} to {_end(self.upper, point, 'inf')}"
            return f"normal, mean {at}, sd {spread}{cut}"
        if spread is None:
            middle = f", mode {at}" if self.kind == "triangular" else ""
            return f"{self.kind} {point(self.lower)} to {point(self.upper)}{middle}"
        return f"{self.kind}, {at} ± {spread}"


def _end(value: float | None, point: Any, missing: str) -> str:
    return missing if value is None else point(value)


# --- reading the entries -------------------------------------------------------------------------
def input_unit(name: str, spec: ProblemParts) -> str | None:
    """[-] SI unit of the input ``name`` of ``spec``, None if it names nothing in the model."""
    if name.startswith(VEHICLE):
        return field_unit(VehicleParams, name.removeprefix(VEHICLE))
    if name.startswith(PAYLOAD):
        return field_unit(Payload, name.removeprefix(PAYLOAD))
    fixed = {TEMPERATURE: "K", ROAD_SPEED: "m/s", ROAD_ROUGHNESS: "m^3", ROAD_CLASS: "m^3"}
    if name in fixed:
        return fixed[name]
    if name in ("parameters", "circuits") or not (name in RollPlaneHIS.model_fields or name in layout_defaults(spec.his) or name in PIPE_PARAMETERS):
        return None
    if name in PIPE_PARAMETERS and spec.his.pipes is None:
        return None
    return parameter_unit(name, parameter_uses(his_layout(spec.his)))


def nominal_value(name: str, spec: ProblemParts) -> float:
    """[SI] The value the file gives the input ``name`` (a design variable's baseline)."""
    if name.startswith(VEHICLE):
        return float(getattr(spec.vehicle, name.removeprefix(VEHICLE)))
    if name.startswith(PAYLOAD):
        return float(getattr(spec.payload, name.removeprefix(PAYLOAD)))
    if name == TEMPERATURE:
        return spec.temperature if spec.temperature is not None else reference_temperature(spec.his)
    if name == ROAD_SPEED:
        return spec.road.speed
    if name in (ROAD_ROUGHNESS, ROAD_CLASS):
        return class_gd_n0(spec.road.road_class)
    given = his_parameter_values(spec.his).get(name)  # rear values follow the front's, a rating its separator's
    if given is None:
        raise ConfigError(f"{name} has no value in [his] to vary; give it one, or vary what sets it", key="uncertain")
    return float(given)


def input_rule(name: str, spec: ProblemParts) -> Rule:
    """The physical rule of input ``name``: its field's (and the layout elements') bounds, the
    oil's temperature range, a positive roughness."""
    if name.startswith(VEHICLE):
        return parameter_rule(name.removeprefix(VEHICLE), VehicleParams)
    if name.startswith(PAYLOAD):
        return parameter_rule(name.removeprefix(PAYLOAD), Payload)
    if name == TEMPERATURE:
        return Rule("temperature", spec.his.oil.lowest, True, spec.his.oil.highest, True)
    if name == ROAD_SPEED:
        return Rule("road.speed", 0.0, False)
    if name in (ROAD_ROUGHNESS, ROAD_CLASS):
        return Rule(name, 0.0, False)
    if name in PIPE_PARAMETERS:  # a hose's bore and lengths
        return Rule(name, 0.0, False)
    return parameter_rule(name, layout=his_layout(spec.his))


def _spread(value: Any, unit: str, file: str, key: str) -> tuple[float, bool]:
    """A spread as written: ``"5 %"`` (relative), ``"0.1 MPa"``, ``"±3 K"``, ``"5 degC"`` (a
    difference: kelvin), or a bare number (SI)."""
    text = str(value).strip().removeprefix("±").removeprefix("+-").strip() if isinstance(value, str) else value
    parts = split_quantity(text) if isinstance(text, str) else None
    if parts is not None and parts[1].strip() == "%":
        number = float(parts[0]) / 100.0
        relative = True
    elif parts is not None and parts[1].strip().lower() in ("degc", "°c", "celsius"):
        number, relative = float(parts[0]), False
    elif parts is not None and parts[1].strip().lower() in ("degf", "°f", "fahrenheit"):
        number, relative = float(parts[0]) * 5.0 / 9.0, False
    elif parts is not None and parts[1]:
        number, relative = float(parts[0]) * unit_factor(parts[1], unit, file=file, key=key, text=str(value)), False
    else:
        number, relative = to_si(text, unit, file=file, key=key), False
    if not number > 0 or not math.isfinite(number):
        raise ConfigError(f"expected a spread above 0; got {value!r}", file=file, key=key)
    return number, relative


def resolve_uncertain(spec: ProblemParts, source: str = "<problem>") -> tuple[Uncertain, ...]:
    """The checked, SI form of every ``[[uncertain]]`` entry of ``spec``.

    Raises
    ------
    ConfigError
        One line naming ``source`` and ``uncertain.<i>.<key>``: an input that names nothing in
        the model (or twice), a spread not above 0, ends in the wrong order, a log-uniform
        lower end not above 0, a distribution
        missing what defines it, or one that puts more than :data:`IMPOSSIBLE_MASS` where the
        input is physically impossible (a negative mass, a temperature outside the oil's range)
        without truncation.
    """
    out = []
    seen: set[str] = set()
    for i, entry in enumerate(spec.uncertain):
        key = f"uncertain.{i}"
        item = _resolve(entry, spec, source, key)
        if item.name in seen or {item.name, *seen} >= {ROAD_CLASS, ROAD_ROUGHNESS}:
            raise ConfigError(f"{item.name} varies twice; expected one [[uncertain]] table per input", file=source, key=f"{key}.input")
        seen.add(item.name)
        _check_possible(item, spec, source, key)
        out.append(item)
    return tuple(out)


def _resolve(entry: UncertainInput, spec: ProblemParts, source: str, key: str) -> Uncertain:
    name = entry.input
    unit = input_unit(name, spec)
    if unit is None:
        raise ConfigError(
            f"{name!r} names nothing in the model; expected vehicle.<field>, a [his] or layout parameter, temperature, "
            "road.speed, road.gd_n0, road.class or payload.<field>",
            file=source,
            key=f"{key}.input",
        )
    if name.startswith(PAYLOAD) and (spec.payload is None or spec.scenarios):
        raise ConfigError(f"{name} varies the problem's [payload], which this problem has not; give a [payload] table", file=source, key=f"{key}.input")
    if name in (ROAD_CLASS, ROAD_ROUGHNESS, ROAD_SPEED) and spec.scenarios:
        raise ConfigError(
            f"{name}: a problem with [[scenarios]] has a road per load case; vary the road in a single-case problem", file=source, key=f"{key}.input"
        )
    variable = name in spec.variables
    if name == ROAD_CLASS:
        return _class_band(entry, source, key)
    given = {k for k in ("mean", "sd", "lower", "upper", "mode", "half_width", "tolerance", "truncate", "band") if getattr(entry, k) is not None}
    if "band" in given:
        raise ConfigError("band is for road.class; expected lower and upper for other inputs", file=source, key=f"{key}.band")
    point = lambda k: None if getattr(entry, k) is None else to_si(getattr(entry, k), unit, file=source, key=f"{key}.{k}")  # noqa: E731
    absolute = sorted(given & {"mean", "lower", "upper", "mode"})
    if variable and absolute:
        raise ConfigError(
            f"{name} is a design variable: give its spread around each design (sd, half_width or tolerance), not absolute {absolute[0]}",
            file=source,
            key=f"{key}.{absolute[0]}",
        )
    kind: Kind = entry.distribution or ("normal" if "sd" in given else "uniform")
    allowed = {
        "normal": {"mean", "sd", "tolerance", "truncate"},
        "uniform": {"lower", "upper", "half_width", "tolerance"},
        "triangular": {"lower", "upper", "mode", "half_width", "tolerance"},
        "loguniform": {"lower", "upper"},
    }[kind]
    extra = sorted(given - allowed)
    if extra:
        raise ConfigError(f"{extra[0]} does not define a {kind} distribution; expected {', '.join(sorted(allowed))}", file=source, key=f"{key}.{extra[0]}")
    spreads = sorted(given & {"sd", "half_width", "tolerance"})
    if len(spreads) > 1:
        raise ConfigError(f"{spreads[0]} and {spreads[1]} both give the spread; expected one", file=source, key=f"{key}.{spreads[1]}")
    spread, relative = (None, False) if not spreads else _spread(getattr(entry, spreads[0]), unit, source, f"{key}.{spreads[0]}")
    if spreads == ["tolerance"] and kind == "normal":
        assert spread is not None
        spread = spread / 3.0  # a tolerance band is +-3 sd
    if kind == "normal":
        if spread is None:
            raise ConfigError("a normal distribution needs its sd (or a tolerance, read as 3 sd)", file=source, key=f"{key}.sd")
        lo, hi = (None, None)
        if entry.truncate is not None:
            if len(entry.truncate) != 2:
                raise ConfigError("expected truncate = [lower, upper]", file=source, key=f"{key}.truncate")
            lo, hi = (to_si(v, unit, file=source, key=f"{key}.truncate") for v in entry.truncate)
            if not lo < hi:
                raise ConfigError(f"truncation [{lo:g}, {hi:g}] {unit} is empty; expected lower < upper", file=source, key=f"{key}.truncate")
        return Uncertain(name, unit, "normal", point("mean"), spread, relative, lo, hi)
    lower, upper = point("lower"), point("upper")
    if spread is None:
        if lower is None or upper is None:
            raise ConfigError(f"a {kind} distribution needs lower and upper, or a half_width or tolerance", file=source, key=f"{key}.lower")
        if kind == "loguniform" and not lower > 0:  # its logarithm is uniform: log(0) is -inf, log(-1) no number
            raise ConfigError(
                f"a log-uniform distribution spreads over orders of magnitude and needs lower above 0; got {entry.lower!r}",
                file=source,
                key=f"{key}.lower",
            )
        if not lower < upper:
            raise ConfigError(f"lower {lower:g} {unit} is not below upper {upper:g} {unit}", file=source, key=f"{key}.upper")
        mode = point("mode") if kind == "triangular" else None
        if kind == "triangular":
            mode = nominal_value(name, spec) if mode is None else mode
            if not lower <= mode <= upper:
                raise ConfigError(f"mode {mode:g} {unit} is outside [{lower:g}, {upper:g}] {unit}", file=source, key=f"{key}.mode")
        return Uncertain(name, unit, kind, mode, None, False, lower, upper)
    if lower is not None or upper is not None:
        raise ConfigError(f"give either lower and upper or a {spreads[0]}, not both", file=source, key=f"{key}.{spreads[0]}")
    return Uncertain(name, unit, kind, point("mode"), spread, relative)


def _class_band(entry: UncertainInput, source: str, key: str) -> Uncertain:
    """``road.class`` with ``band = ["B", "C"]``: the roughness log-uniform from the lower
    limit of the first class to the upper limit of the last (ISO 8608 Table C.2)."""
    classes = road_classes()
    band = entry.band or []
    others = [k for k in ("distribution", "mean", "sd", "lower", "upper", "mode", "half_width", "tolerance", "truncate") if getattr(entry, k) is not None]
    if others:
        raise ConfigError(f"road.class takes a band of classes only; use road.gd_n0 for a {others[0]}", file=source, key=f"{key}.{others[0]}")
    if len(band) != 2 or any(c not in classes for c in band) or band[0] > band[1]:
        raise ConfigError(f'expected band = [first, last] ISO 8608 classes A to H in order, e.g. ["B", "C"]; got {band!r}', file=source, key=f"{key}.band")
    lower, upper = classes[band[0]][0], classes[band[1]][2]
    if not (lower > 0 and math.isfinite(upper)):
        raise ConfigError(
            "classes A (no lower limit) and H (no upper limit) cannot end a band; use road.gd_n0 with lower and upper", file=source, key=f"{key}.band"
        )
    return Uncertain(ROAD_CLASS, "m^3", "loguniform", None, None, False, lower, upper)


def _check_possible(item: Uncertain, spec: ProblemParts, source: str, key: str) -> None:
    """Refuse a distribution that puts more than :data:`IMPOSSIBLE_MASS` where the input is
    physically impossible, at the nominal value (each end of a design variable's bounds)."""
    rule = input_rule(item.name, spec)
    variable = spec.variables.get(item.name)
    nominals = [variable.lower, variable.upper] if variable is not None else [nominal_value(item.name, spec)]
    if item.name == TEMPERATURE and item.kind != "normal":  # the oil's own words, in degC
        for end in item.ends(nominals[0]):
            problem = spec.his.oil.temperature_problem(float(end), written=f"{float(end) - 273.15:.4g} degC")  # as item.text shows it
            if problem:
                raise ConfigError(f"{item.text} reaches {problem}; narrow it", file=source, key=key)
    for nominal in nominals:
        if item.relative and nominal == 0.0 and variable is None:
            raise ConfigError(f"{item.name} is 0 {item.unit} here, so a spread in % of it is none; give the spread in {item.unit}", file=source, key=key)
        mass = item.outside(rule, nominal)
        if mass > IMPOSSIBLE_MASS:
            at = f" at its bound {nominal:g} {item.unit}" if variable is not None else ""
            what = f"puts {mass:.2g} of its probability" if item.kind == "normal" else "reaches"
            hint = "truncate it (truncate = [lower, upper]) or narrow it" if item.kind == "normal" else "narrow it"
            raise ConfigError(f"{item.text}{at} {what} outside {rule.text} ({item.unit}), where it is physically impossible; {hint}", file=source, key=key)
