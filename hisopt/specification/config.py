"""Problem files: TOML, validated with pydantic; every mistake becomes one clear line.

A problem file holds the vehicle, the fixed HIS parameters (their values are the baseline
design), the design variables with bounds, the road, the frequency band, comfort settings,
objectives, constraints and optimiser settings. See ``problems/roll_plane_his.toml``.
"""

from __future__ import annotations

import difflib
import hashlib
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    StrictBool,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)

from hisopt.coupled.buildability import BuildLimits
from hisopt.coupled.payload import Payload, laden_problem
from hisopt.errors import ConfigError, ProblemFileNotFoundError
from hisopt.hydraulics.catalogue import PIPE_PARAMETERS, his_layout, layout_defaults, layout_problem, used_parameters
from hisopt.hydraulics.layout import Accumulator, parameter_uses
from hisopt.hydraulics.roll_plane import RollPlaneHIS
from hisopt.metrics import METRICS
from hisopt.plausibility import cylinder_box_problem, given_warnings, rule_reason, speed_problem, warn
from hisopt.quantities import field_unit, has_unit, si
from hisopt.specification.build_settings import Build
from hisopt.specification.problem_units import convert_problem_units
from hisopt.specification.text_files import read_file
from hisopt.specification.tolerances import parse_tolerances
from hisopt.specification.uncertain import ROAD_CLASS, ROAD_ROUGHNESS, UncertainInput, resolve_uncertain
from hisopt.specification.validation import bounds_problem, design_parameters, implausible_number, switched_off
from hisopt.specification.valve_checks import damper_valve_problem
from hisopt.units import format_quantity
from hisopt.vehicle import VehicleParams

OBJECTIVE_NAMES = tuple(METRICS)
"""Names of every objective/constraint quantity (docs/model.md §6)."""

ROAD_CLASSES = ("A", "B", "C", "D", "E", "F", "G", "H")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Variable(_Strict):
    """A design variable: a HIS parameter with its bounds [SI units], or a choice among
    listed values (``choices``, or a ``catalogue``'s, docs/model.md §17), whose bounds are
    the first and the last."""

    lower: float
    upper: float
    choices: list[float] | None = Field(None, description="[SI] the values it takes, in increasing order")
    catalogue: str | None = Field(None, description="[-] the catalogue the choices come from (a shipped name or a CSV path)")
    unit: str = ""
    description: str = ""

    @model_validator(mode="before")
    @classmethod
    def _bounds_of_choices(cls, data: Any) -> Any:
        choices = data.get("choices") if isinstance(data, dict) else None
        if not isinstance(choices, list) or not choices or "catalogue" in data:
            return data
        if (data.get("lower", choices[0]), data.get("upper", choices[-1])) != (choices[0], choices[-1]):  # a dump repeats them
            raise ValueError("choices: given with lower or upper; expected one or the other (the choices' first and last are the bounds)")
        return data | {"lower": choices[0], "upper": choices[-1]}

    @model_validator(mode="after")
    def _ordered(self) -> Variable:
        if self.choices is not None:
            if len(self.choices) < 2:
                raise ValueError(f"choices: {len(self.choices)} value(s); expected at least two to choose from (a single value belongs in [his])")
            if any(not b > a for a, b in zip(self.choices, self.choices[1:], strict=False)):
                raise ValueError(f"choices: {self.choices} are not in increasing order; expected an ordered list (the search moves along it)")
            if (self.lower, self.upper) != (self.choices[0], self.choices[-1]):
                raise ValueError(f"choices: the bounds {self.lower:g} and {self.upper:g} are not the first and last choice")
        if not self.lower < self.upper:
            raise ValueError(f"expected lower < upper, got lower={self.lower}, upper={self.upper}")
        return self


class Road(_Strict):
    """ISO 8608 road at constant speed (docs/model.md §4)."""

    road_class: Literal["A", "B", "C", "D", "E", "F", "G", "H"] = Field("C", alias="class")
    speed: float = Field(10.0, gt=0, description="vehicle speed", json_schema_extra=si("m/s"))
    coherence: Literal["independent", "isotropic"] = "independent"

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True, allow_inf_nan=False)

    @field_validator("speed")
    @classmethod
    def _road_vehicle(cls, v: float) -> float:
        problem = speed_problem(v)  # hisopt.plausibility: the cap and its reason
        if problem:
            raise ValueError(problem)
        return v


class Band(_Strict):
    """Frequency band of every response integral and maximum [Hz]."""

    f_min_hz: float = Field(0.5, gt=0, json_schema_extra=si("Hz"))
    f_max_hz: float = Field(80.0, gt=0, json_schema_extra=si("Hz"))

    @model_validator(mode="after")
    def _ordered(self) -> Band:
        if not self.f_min_hz < self.f_max_hz:
            raise ValueError(f"expected f_min_hz < f_max_hz, got {self.f_min_hz} and {self.f_max_hz}")
        return self


class Comfort(_Strict):
    """ISO 2631-1 comfort evaluation (docs/model.md §5)."""

    k_x: float = Field(1.0, ge=0, json_schema_extra=si("-"))
    k_y: float = Field(1.0, ge=0, json_schema_extra=si("-"))
    k_z: float = Field(1.0, ge=0, json_schema_extra=si("-"))
    method: Literal["filter", "band"] = "filter"


class Constraint(_Strict):
    """``value <= limit``, normalised for optimisers as ``value / limit - 1 <= 0``.

    In a scenario problem the limit holds in every scenario, or in those ``scenarios`` names.
    """

    name: str
    limit: float = Field(gt=0)
    scenarios: list[str] | None = Field(None, min_length=1)
    probability: float | None = Field(
        None, gt=0, lt=1, description="a chance constraint: P(value > limit) <= probability over the [[uncertain]] samples", json_schema_extra=si("-")
    )

    @field_validator("name")
    @classmethod
    def _known(cls, v: str) -> str:
        if v not in OBJECTIVE_NAMES:
            raise ValueError(f"unknown constraint {v!r}; expected one of {', '.join(OBJECTIVE_NAMES)}")
        return v


class Scenario(_Strict):
    """A load case: a road at a speed, an optional payload and temperature, and its weight
    (docs/model.md §14, §16).

    ``road`` defaults to the problem's ``[road]``; the weight is relative (normalised over the
    problem's scenarios) and enters ``expected`` and ``cvar`` aggregation.
    """

    name: str = Field(min_length=1, max_length=40)
    road: Road | None = None
    payload: Payload | None = None
    temperature: float | None = Field(None, description="oil and gas temperature (default: the problem's)", json_schema_extra=si("K"))
    weight: float = Field(1.0, gt=0, json_schema_extra=si("-"))

    @field_validator("name")
    @classmethod
    def _plain(cls, v: str) -> str:
        if not all(ch.isalnum() or ch in "_-" for ch in v):
            raise ValueError(f"expected letters, digits, '_' or '-' (the name becomes part of column names like sigma_aw@{v!s}), got {v!r}")
        return v


class Robust(_Strict):
    """How a scenario problem's objectives combine its scenarios (docs/model.md §14.3), and a
    problem with ``[[uncertain]]`` inputs its samples (§18.4)."""

    aggregate: Literal["worst", "expected", "cvar", "per_scenario"] = "worst"
    alpha: float = Field(0.8, ge=0, lt=1, description="CVaR level: the mean of the worst 1 - alpha of the weight", json_schema_extra=si("-"))
    statistic: Literal["nominal", "mean", "mean_plus_k_sigma"] = "nominal"
    k: float = Field(2.0, ge=0, le=10, description="sigmas added to the mean by mean_plus_k_sigma", json_schema_extra=si("-"))
    samples: int = Field(64, ge=2, le=100_000, description="common random samples of the uncertain inputs every design meets")
    seed: int = Field(0, ge=0, description="seed of the common random samples")

    @field_validator("k")
    @classmethod
    def _k_of_its_statistic(cls, v: float, info: ValidationInfo) -> float:
        how = info.data.get("statistic", "nominal")
        if how != "mean_plus_k_sigma":
            raise ValueError(f'k is read by statistic = "mean_plus_k_sigma" only; expected no k with statistic = "{how}"')
        return v

    @field_validator("alpha")
    @classmethod
    def _cvar_only(cls, v: float, info: ValidationInfo) -> float:
        # runs only for an alpha written in the file: a default is never validated
        how = info.data.get("aggregate", "worst")
        if how != "cvar":
            raise ValueError(f'alpha is the CVaR level, which only aggregate = "cvar" reads; expected no alpha with aggregate = "{how}", or aggregate = "cvar"')
        return v

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        data = handler(self)
        if self.aggregate != "cvar":  # a dump reads back: alpha only where the file may hold it
            data.pop("alpha", None)
        if self.statistic != "mean_plus_k_sigma":
            data.pop("k", None)
        return data


class Handling(_Strict):
    """Handling manoeuvre of the transient roll quantities (docs/model.md §6.6) and the
    convention of the roll quantities (docs/model.md §6.4)."""

    step_g: float = Field(0.4, gt=0, description="lateral-acceleration step of roll_step_peak and roll_rate_peak", json_schema_extra=si("g"))
    gravity_moment: StrictBool = Field(
        True,
        description=(
            "the body's weight adds m_s g h_0s phi when it rolls by phi about the roll axis: in roll_gradient and the transient roll quantities "
            "(docs/model.md §6.4); false: the paper's convention, the lateral force's moment alone"
        ),
    )


class Optimizer(_Strict):
    """Evolutionary search settings (overridable on the command line)."""

    algorithm: Literal["auto", "nsga2", "nsga3", "smsemoa"] = "auto"
    pop_size: int = Field(100, ge=4)
    generations: int = Field(200, ge=1)
    seed: int = Field(1, ge=0)
    epsilon: dict[str, Any] = Field(default_factory=dict, description='tolerance per objective of the thinned front: "1 %" or a value in its unit')
    until: Literal["generations", "converged"] = Field(
        "generations", description="stop after all generations, or when converged (tolerance, window; generations is the cap)"
    )
    tolerance: float = Field(1e-3, gt=0, lt=1, description='until = "converged": relative hypervolume gain over the window', json_schema_extra=si("-"))
    window: int = Field(20, ge=1, description='until = "converged": generations the gain is measured over')
    catalogue_cost: bool = Field(
        True, description="a problem with choices: also optimise it with those variables continuous and report the hypervolume ratio (docs/model.md §17.5)"
    )


SCREEN_UNITS: dict[str, str] = {
    **{f"k_{m}": "N/m" for m in ("bounce", "roll", "pitch", "warp")},
    **{f"c_{m}": "N s/m" for m in ("bounce", "roll", "pitch", "warp")},
    "stiffness_coupling": "-",
}
"""The quantities a synthesis screen may bound (the columns of ``hisopt layouts``) and their
SI units (docs/model.md §20)."""


class Synthesis(_Strict):
    """``[synthesis]``: the screen of ``hisopt synthesize`` (docs/model.md §20), e.g.
    ``screen = { k_roll = { min = "40 kN/m" }, k_warp = { max = "20 kN/m" } }``: a bare
    number is SI."""

    screen: dict[str, dict[str, float]] = Field(default_factory=dict, description="bounds (min, max) on the mode-stiffness table of a candidate")

    @field_validator("screen", mode="before")
    @classmethod
    def _known_bounds(cls, v: Any) -> Any:
        from hisopt.errors import ConfigError
        from hisopt.quantities import to_si

        if not isinstance(v, dict):
            return v
        out: dict[str, dict[str, float]] = {}
        for name, bounds in v.items():
            if name not in SCREEN_UNITS:
                raise ValueError(f"unknown quantity {name!r}; expected one of {', '.join(SCREEN_UNITS)}")
            if not isinstance(bounds, dict) or not bounds or set(bounds) - {"min", "max"}:
                raise ValueError(f"{name}: expected a table with min and/or max, e.g. {name} = {{ min = 1 }}")
            out[name] = {}
            for key, value in bounds.items():
                try:
                    out[name][key] = to_si(value, SCREEN_UNITS[name])
                except ConfigError as exc:
                    raise ValueError(f"{name}.{key}: {exc.detail}") from None
            if "min" in out[name] and "max" in out[name] and not out[name]["min"] <= out[name]["max"]:
                raise ValueError(f"{name}: expected min <= max, got {out[name]['min']:g} > {out[name]['max']:g} [{SCREEN_UNITS[name]}]")
        return out


class ProblemSpec(_Strict):
    """The whole problem file."""

    name: str = "problem"
    description: str = ""
    vehicle: VehicleParams = Field(default_factory=VehicleParams)
    his: RollPlaneHIS = Field(default_factory=RollPlaneHIS)
    variables: dict[str, Variable] = Field(default_factory=dict)
    road: Road = Field(default_factory=Road)
    band: Band = Field(default_factory=Band)
    comfort: Comfort = Field(default_factory=Comfort)
    handling: Handling = Field(default_factory=Handling)
    build: Build = Field(default_factory=Build)
    objectives: list[str] = Field(default_factory=lambda: ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd"])
    constraints: list[Constraint] = Field(default_factory=list)
    optimizer: Optimizer = Field(default_factory=Optimizer)
    payload: Payload | None = None
    temperature: float | None = Field(
        None, description="oil and gas temperature of every load case that names none (None: the reference temperature)", json_schema_extra=si("K")
    )
    scenarios: list[Scenario] = Field(default_factory=list)
    robust: Robust = Field(default_factory=Robust)
    uncertain: list[UncertainInput] = Field(default_factory=list)
    synthesis: Synthesis | None = None

    @property
    def build_limits(self) -> BuildLimits:
        """``[build]`` as the buildability rules take it, with ``[handling] gravity_moment``."""
        return self.build.limits(self.handling.gravity_moment)

    @field_validator("objectives")
    @classmethod
    def _known_objectives(cls, v: list[str]) -> list[str]:
        unknown = [o for o in v if o not in OBJECTIVE_NAMES]
        if unknown:
            raise ValueError(f"unknown objective {unknown[0]!r}; expected names from {', '.join(OBJECTIVE_NAMES)}")
        if not v:
            raise ValueError("expected at least one objective")
        ranked = [o for o in v if not METRICS[o].objective]
        if ranked:
            raise ValueError(f"{ranked[0]!r} cannot be minimised (lower is not better); constrain it in [[constraints]] instead")
        twice = [o for i, o in enumerate(v) if o in v[:i]]
        if twice:
            raise ValueError(f"{twice[0]!r} is listed twice; expected each objective once")
        return v

    @field_validator("constraints")
    @classmethod
    def _constraints_once(cls, v: list[Constraint]) -> list[Constraint]:
        names = [c.name for c in v]
        twice = [n for i, n in enumerate(names) if n in names[:i]]
        if twice:
            raise ValueError(f"{twice[0]!r} is constrained twice; expected one [[constraints]] table per quantity")
        return v

    @model_validator(mode="after")
    def _scenarios_consistent(self, info: ValidationInfo) -> ProblemSpec:
        names = [sc.name for sc in self.scenarios]
        twice = [n for i, n in enumerate(names) if n in names[:i]]
        if twice:
            raise ValueError(f"scenarios: {twice[0]!r} is named twice; expected each scenario name once")
        if self.scenarios and self.payload is not None:
            raise ValueError("payload: a problem with [[scenarios]] gives each scenario its payload; expected no top-level [payload]")
        for sc in self.scenarios:
            problem = None if sc.payload is None else laden_problem(self.vehicle, sc.payload)
            if problem:
                raise ValueError(f"scenario {sc.name!r}: {problem}")
        written = info.context.get(WRITTEN) if isinstance(info.context, Mapping) else None  # the data as written: no kelvin hint for a unit
        charge = self.his.charge
        charged = [("his.charge.temperature", charge.temperature)] if charge is not None else []  # its default too: a dump re-read names it
        for key, temperature in self.temperatures() + charged:
            as_written = written_value(written, key)
            problem = self.his.oil.temperature_problem(temperature, written=" ".join(as_written.split()) if has_unit(as_written) else None)
            if problem:
                raise ValueError(f"{key}: {problem}")
        for c in self.constraints:
            unknown = [n for n in c.scenarios or [] if n not in names]
            if unknown:
                known = f"one of {', '.join(names)}" if names else "[[scenarios]] tables for it to name, or no scenarios on the constraint"
                raise ValueError(f"constraints: {c.name} names scenario {unknown[0]!r}; expected {known}")
        for c in self.constraints if self.scenarios else []:
            worst_everywhere = self.robust.aggregate in ("worst", "per_scenario") and c.scenarios is None
            if c.name in self.objectives and not worst_everywhere:
                raise ValueError(
                    f"constraints: {c.name} is also an objective; in a scenario problem its column is then the objective's "
                    f'aggregate, so expected [robust] aggregate = "worst" and the limit in every scenario, or one role only'
                )
        robust_set = self.robust.model_fields_set
        if "robust" in self.model_fields_set and not self.scenarios and not (self.uncertain and not robust_set & {"aggregate", "alpha"}):
            raise ValueError(
                "robust: [robust] combines the results of [[scenarios]] (or, with statistic, of [[uncertain]] samples) and this problem has none; "
                "expected at least one [[scenarios]] table, or no [robust] table"
            )
        if self.robust.statistic != "nominal" and not self.uncertain:
            raise ValueError("robust.statistic: a statistic over the samples needs [[uncertain]] inputs to draw them from; add them, or no statistic")
        for c in self.constraints:
            if c.probability is not None and not self.uncertain:
                raise ValueError(
                    f"constraints: {c.name} has a probability, a chance over [[uncertain]] inputs, and this problem has none; add them, or no probability"
                )
            if c.probability is not None and c.name in self.objectives:
                raise ValueError(f"constraints: {c.name} is an objective too and its column holds one value; expected no probability on it, or not both roles")
        return self

    def temperatures(self) -> list[tuple[str, float]]:
        """[K] Every operating temperature the problem names, by key (the problem's, then each
        scenario's)."""
        out = [("temperature", self.temperature)] if self.temperature is not None else []
        return out + [(f"scenarios.{i}.temperature", sc.temperature) for i, sc in enumerate(self.scenarios) if sc.temperature is not None]

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        data = handler(self)
        if not self.scenarios and not self.uncertain:  # a dump reads back: [robust] only where the file may hold it
            data.pop("robust", None)
        elif not self.scenarios:  # the samples' settings, without load cases to aggregate
            data["robust"] = {k: v for k, v in data["robust"].items() if k not in ("aggregate", "alpha")}
        return data

    @model_validator(mode="after")
    def _variables_are_his_fields(self) -> ProblemSpec:
        # The layout first: the variables may name its parameters (docs/model.md §12).
        problem = layout_problem(self.his)
        if problem:
            raise ValueError(problem)
        layout = his_layout(self.his)
        # The rules come from RollPlaneHIS's fields and the layout's element fields
        # (hisopt.specification.validation), not from a list here.
        pipes = PIPE_PARAMETERS if self.his.pipes is not None else ()  # a hose's bore and length, over [his.pipes]
        allowed = design_parameters() + tuple(layout_defaults(self.his)) + pipes
        used = used_parameters(layout)
        if not self.variables:  # also for a file without [variables] (defaults are not validated)
            raise ValueError(
                "variables: expected at least one design variable, e.g. [variables] p0 = { lower = 0.0, upper = 4.0e6 } (see problems/roll_plane_his.toml)"
            )
        problem = damper_valve_problem(self.his, self.variables, layout)  # before "not read": it says why
        if problem:
            raise ValueError(problem)
        for name, var in self.variables.items():
            if name not in allowed:
                raise ValueError(f"variables.{name}: not a design parameter of [his]; expected one of {', '.join(allowed)}")
            problem = bounds_problem(name, var.lower, var.upper, layout) or switched_off(name, self.his)
            if not problem and name not in used:
                read = ", ".join(n for n in allowed if n in used)
                problem = f"not read by layout {self.his.layout!r}, so it would do nothing; " + (
                    f"expected one of {read}" if read else "its elements read only numbers, so it has no design variable"
                )
            if problem:
                raise ValueError(f"variables.{name}: {problem}")
        return self

    @model_validator(mode="after")
    def _tolerances_readable(self) -> ProblemSpec:
        try:
            parse_tolerances(self.optimizer.epsilon, {o: METRICS[o].unit for o in self.objectives}, key=lambda n: f"optimizer.epsilon.{n}")
        except ConfigError as exc:
            raise ValueError(f"{exc.key}: {exc.detail}") from None
        return self

    @model_validator(mode="after")
    def _cylinder_sizes_in_pairs(self) -> ProblemSpec:
        given = {n for n in ("bore", "rod", "bore_rear", "rod_rear") if n in self.variables or getattr(self.his, n) is not None}
        for axle in ("", "_rear"):
            pair = {f"bore{axle}", f"rod{axle}"}
            if axle and given & pair and not {"bore", "rod"} <= given:
                raise ValueError(f"his.{sorted(given & pair)[0]}: a rear size needs the front's bore and rod (the rear follows them where not given)")
            if not axle and len(given & pair) == 1:
                (one,) = given & pair
                other = (pair - {one}).pop()
                raise ValueError(f"his.{other}: missing; {one} sizes the cylinder with {other} (expected both, in [his] or [variables])")
        for name in ("bore", "rod"):
            if name in self.variables and getattr(self.his, name) is None:
                raise ValueError(
                    f'his.{name}: missing; expected the baseline value of design variable {name} (e.g. {name} = "{50 if name == "bore" else 28} mm")'
                )
        sized = {a for a in ("", "_rear") if {"bore", "rod"} <= given}
        for axle in sized:  # bore and rod set dA and lam: a value of those would be ignored
            for name in (f"dA{axle}", f"lam{axle}"):
                if name in self.variables:
                    raise ValueError(f"variables.{name}: the cylinder is sized by bore and rod, which set dA and lam; expected one or the other")
                if name in self.his.model_fields_set and getattr(self.his, name) is not None:
                    raise ValueError(f"his.{name}: the cylinder is sized by bore and rod, which set dA and lam; expected one or the other")
        problem = cylinder_box_problem(self)
        if problem:
            raise ValueError(problem)
        return self

    @model_validator(mode="after")
    def _swing_needs_oil(self) -> ProblemSpec:
        keys = [f"objectives.{i}" for i, o in enumerate(self.objectives) if o == "accumulator_swing"]
        keys += [f"constraints.{i}.name" for i, c in enumerate(self.constraints) if c.name == "accumulator_swing"]
        if keys and self.his.charge is None:
            raise ValueError(
                f"{keys[0]}: accumulator_swing measures the oil swing against the oil an accumulator holds, and the paper's idealisation "
                "([his] without [his.charge]) holds none; expected a [his.charge] table (see problems/roll_plane_his_envelope.toml)"
            )
        return self

    @model_validator(mode="after")
    def _build_rules_see_the_road_as_it_is(self) -> ProblemSpec:
        build = [f"objectives.{i}" for i, o in enumerate(self.objectives) if METRICS[o].kind == "build"]
        build += [f"constraints.{i}.name" for i, c in enumerate(self.constraints) if METRICS[c.name].kind == "build"]
        rough = [u.input for u in self.uncertain if u.input in (ROAD_ROUGHNESS, ROAD_CLASS)]
        if build and rough:
            raise ValueError(
                f"{build[0]}: a buildability rule adds the road's swing to a static value, so no factor of an uncertain {rough[0]} scales it; "
                "expected the road's roughness fixed (a scenario per road class) or no buildability rule"
            )
        return self

    @model_validator(mode="after")
    def _payload_fits(self) -> ProblemSpec:
        problem = None if self.payload is None else laden_problem(self.vehicle, self.payload)
        if problem:
            raise ValueError(problem)
        return self


WRITTEN = "written"
"""Key of the validation context holding the problem data as written (before the units were
converted): a temperature written with its unit gets no hint that a bare number is kelvin."""


def written_value(data: Any, key: str) -> Any:
    """The value at the dotted ``key`` (``scenarios.0.temperature``) of ``data`` as written,
    or None."""
    node = data
    for part in key.split("."):
        if isinstance(node, Mapping):
            node = node.get(part)
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return None
    return node


def _key_part(part: Any) -> str:
    text = str(part)
    return text if text.isprintable() and text.strip() == text and text else repr(text)


def _short(value: Any, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _unwrap(annotation: Any) -> Any:
    """``PipeLayout | None`` -> ``PipeLayout``; containers (``dict[str, Variable]``) unchanged."""
    args = [a for a in getattr(annotation, "__args__", ()) if a is not type(None)]
    container = getattr(annotation, "__origin__", None) in (dict, list)
    return args[0] if len(args) == 1 and not container else annotation


def _allowed_keys(loc: tuple[Any, ...]) -> list[str]:
    """The keys the table at ``loc`` (a pydantic error location) may hold."""
    model: Any = ProblemSpec
    for part in loc:
        fields = getattr(model, "model_fields", {})
        field = fields.get(part) or next((f for f in fields.values() if f.alias == part), None)
        if field is not None:
            model = _unwrap(field.annotation)
        else:  # a variable's name or a list index: step into the item type
            model = (getattr(model, "__args__", None) or (None,))[-1]
    fields = getattr(model, "model_fields", None)
    return [f.alias or name for name, f in fields.items()] if fields else []


MAX_LISTED_KEYS = 20
"""An unknown key's message lists the table's keys up to this many; a longer table's message
names the closest ones instead (it stays one readable line)."""


def _format_error(err: Mapping[str, Any]) -> tuple[str, str]:
    key = ".".join(_key_part(p) for p in err["loc"] if not str(p).startswith("function-"))
    msg = " ".join(err["msg"].removeprefix("Value error, ").split())
    value = err.get("input")
    head, colon, rest = msg.partition(": ")
    if err["type"] == "value_error" and colon and key and head.split(".")[0] in _allowed_keys(err["loc"]):  # a table's validator naming its key
        return f"{key}.{head}", rest
    if err["type"] == "extra_forbidden":
        allowed = _allowed_keys(err["loc"][:-1])
        if len(allowed) > MAX_LISTED_KEYS:  # a long table: the keys closest to the one written
            given = str(err["loc"][-1])
            close = difflib.get_close_matches(given, allowed, n=5, cutoff=0.5)
            hint = f"did you mean {', '.join(close)}? " if close else ""
            return key, f"unknown key; {hint}expected one of the table's {len(allowed)} keys (check the spelling)"
        return key, f"unknown key; expected one of {', '.join(allowed)} (check the spelling)" if allowed else "unknown key"
    elif isinstance(value, bool) and err["type"] in ("float_type", "int_type", "float_parsing", "int_parsing"):
        kind = "an integer" if err["type"].startswith("int") else "a number"
        return key, f"expected {kind}, got the boolean {str(value).lower()} (booleans are not numbers)"
    elif err["type"] == "finite_number":
        return key, f"expected a finite number, got {value!r}"
    elif err["type"] in ("float_type", "float_parsing", "int_type", "int_parsing", "int_from_float"):
        kind = "an integer" if err["type"].startswith("int") else "a valid number"
        return key, f"expected {kind}, got {_short(value)}"
    elif err["type"] in ("model_type", "dict_type", "model_attributes_type"):
        return key, f"expected a table (e.g. [{key}] or {{ key = value }}), got {_short(value)}"
    elif err["type"] == "list_type":
        return key, f'expected a list (e.g. ["a", "b"]), got {_short(value)}'
    elif err["type"] == "missing":
        return key, "missing; expected a value (see problems/roll_plane_his.toml)"
    msg = msg.replace("Input should be ", "expected ", 1)
    if err["type"] in ("greater_than", "greater_than_equal", "less_than", "less_than_equal") and err["loc"]:
        msg += rule_reason(str(err["loc"][-1]))  # a rule with a physical reason says it (hisopt.plausibility)
        unit = field_unit(RollPlaneHIS, str(err["loc"][-1])) if tuple(err["loc"][:1]) == ("his",) and len(err["loc"]) == 2 else None
        if unit and unit != "-" and isinstance(value, (int, float)) and not isinstance(value, bool):
            msg += f", got {format_quantity(value, unit) if value else f'0 {unit}'}"  # in the unit the user thinks in, as written
    if "input" in err and not isinstance(err["input"], dict) and not any(g in msg for g in (", got ", "; got ")):  # a validator may name it
        msg = f"{msg}, got {_short(err['input'])}"
    return key, msg


def parse_problem(data: dict[str, Any], source: str = "<problem>", *, warn_implausible: bool = True) -> ProblemSpec:
    """Validate a problem dictionary; raise :class:`ConfigError` naming the key on failure.

    Validation is strict: a number must be a TOML integer or float, or a string of a number
    and its unit (``"2.5 MPa"``, read in that unit: :mod:`hisopt.specification.problem_units`; a boolean or
    other text is not a number; an integer field takes no float) and finite (no ``inf``, ``nan``, ``1e309``),
    and every number is zero or of a magnitude within
    :data:`hisopt.specification.validation.MAGNITUDE_RANGE` (1e-15 to 1e15). Physically impossible values
    are refused and, with ``warn_implausible``, each implausible value ``data`` gives issues a
    :class:`~hisopt.errors.PlausibilityWarning` (:mod:`hisopt.plausibility`); problems derived
    from a checked one (a dump with one change) pass False, so that nothing warns twice.
    """
    written = data  # as the user wrote it: a roll limit warns only when written as a bare number
    data = convert_problem_units(data, source, ProblemSpec)  # "2.5 MPa" -> 2.5e6: SI before the strict validation
    try:
        spec = ProblemSpec.model_validate(data, strict=True, context={WRITTEN: written})
    except ValidationError as exc:
        key, msg = _format_error(exc.errors()[0])
        raise ConfigError(msg, file=source, key=key or None) from None
    found = implausible_number(data)
    if found:
        raise ConfigError(found[1], file=source, key=found[0])
    resolve_uncertain(spec, source)  # checks [[uncertain]], whose units depend on the input each names
    if warn_implausible:
        warn(implausible_values(spec, written), source)
    return spec


def implausible_values(spec: ProblemSpec, given: Mapping[str, Any]) -> list[tuple[str, str]]:
    """``(key, message)`` of each implausible value of ``spec`` that ``given`` (the raw data,
    or the part given, e.g. ``{"his": {"p0": 5e4}}``) holds (:func:`hisopt.plausibility.given_warnings`)."""
    uses = parameter_uses(his_layout(spec.his))
    precharges = {name for name, fields in uses.items() if (Accumulator, "precharge") in fields}
    return given_warnings(spec, given, precharges)


def read_problem_file(path: str | Path, *, warn_implausible: bool = True) -> tuple[ProblemSpec, str]:
    """Read and validate a TOML problem file; returns the spec and the file's SHA-256
    (``warn_implausible``: as :func:`parse_problem`)."""
    path = Path(path)
    raw, text = read_file(path, "a TOML problem file", ProblemFileNotFoundError)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"invalid TOML: {exc}; expected a TOML problem file like problems/roll_plane_his.toml", file=str(path)) from None
    return parse_problem(data, str(path), warn_implausible=warn_implausible), hashlib.sha256(raw).hexdigest()
