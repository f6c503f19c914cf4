"""``DesignSpace``: a validated problem file and the mapping from designs to models.

What every engine needs of a problem: the validated specification, the design variables
(names, bounds, baseline), the design matrix of any input form, and the coupled model of a
batch of designs (numpy) or of symbolic ones (CasADi). The evaluator sits on top of it;
:class:`hisopt.problem.Problem` (the facade users load) adds the evaluator and ``evaluate``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Self

import numpy as np

from hisopt.coupled.model import CoupledModel
from hisopt.coupled.operating_point import charged_static_pressure
from hisopt.coupled.payload import laden_vehicle, static_pressure_rise
from hisopt.errors import ConfigError
from hisopt.hydraulics.catalogue import PIPE_PARAMETERS, his_layout, his_parameter_values, layout_defaults
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.network import compile_network
from hisopt.hydraulics.roll_plane import reference_temperature
from hisopt.plausibility import warn
from hisopt.robust import scenario_column
from hisopt.specification.config import ProblemSpec, implausible_values, parse_problem
from hisopt.specification.validation import (
    Rule,
    assignment_text,
    design_matrix,
    parameter_rule,
    require_admissible,
    variable_si_units,
)
from hisopt.vehicle.batch import VehicleBatch

if TYPE_CHECKING:
    from hisopt.hydraulics.layout import Layout
    from hisopt.hydraulics.network import Network
    from hisopt.vehicle import VehicleParams

Inputs = Mapping[str, np.ndarray]
"""Model inputs per design that the problem file fixes (:meth:`DesignSpace.model`)."""

VEHICLE_PREFIX = "vehicle."
TEMPERATURE_OFFSET = "temperature_offset"


def his_value_path(data: Mapping[str, Any], extra: Mapping[str, float], key: str) -> tuple[str, ...] | None:
    """Where the value of ``[his]`` parameter ``key`` lives in a problem file's data ``data``:
    ``("his", "parameters", key)`` for a layout's extra parameter (``extra``, its defaults),
    ``("his", "pipes", "diameter")`` for ``pipe_diameter`` (with ``[his.pipes]``), else
    ``("his", key)``; None for a name that is none of them."""
    if key in extra:
        return ("his", "parameters", key)
    if key in PIPE_PARAMETERS and data["his"].get("pipes") is not None:
        return ("his", "pipes", key.removeprefix("pipe_"))
    if key not in data["his"] or key in ("parameters", "circuits"):
        return None
    return ("his", key)


def nested(path: Sequence[str], value: Any) -> dict[str, Any]:
    """``{"a": {"b": value}}`` of the path ``("a", "b")``."""
    out: Any = value
    for part in reversed(path):
        out = {part: out}
    return dict(out)


@dataclass(frozen=True)
class DesignSpace:
    """A design problem below the evaluator: vehicle, HIS, variables with bounds, road, band,
    objectives and constraints, and the models of designs."""

    spec: ProblemSpec
    path: Path | None = None
    sha256: str | None = None
    _cache: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickle (e.g. to Dask workers) without the caches; they are rebuilt there.
        return (type(self), (self.spec, self.path, self.sha256))

    # --- variables -------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def variable_names(self) -> tuple[str, ...]:
        return tuple(self.spec.variables)

    @property
    def variable_units(self) -> dict[str, str]:
        """[-] Unit of each design variable: the SI unit its ``[his]`` field declares, else that
        of the element field the layout reads it as (a layout's extra parameter;
        :func:`hisopt.specification.validation.variable_si_units`), else the problem file's
        ``unit`` label."""
        if "variable_units" not in self._cache:
            declared = variable_si_units(self)
            self._cache["variable_units"] = {name: declared[name] or self.spec.variables[name].unit for name in self.variable_names}
        return dict(self._cache["variable_units"])

    @property
    def lower(self) -> np.ndarray:
        return np.array([v.lower for v in self.spec.variables.values()])

    @property
    def upper(self) -> np.ndarray:
        return np.array([v.upper for v in self.spec.variables.values()])

    @property
    def choices(self) -> dict[int, np.ndarray]:
        """[SI] The listed values of each choice variable, by its column (docs/model.md §17)."""
        return {j: np.array(v.choices) for j, v in enumerate(self.spec.variables.values()) if v.choices is not None}

    @property
    def baseline(self) -> np.ndarray:
        """The fixed ``[his]`` values of the design variables (the baseline design)."""
        his = self.spec.his
        extra = layout_defaults(his)
        if his.pipes is not None:  # a hose's bore and lengths as design variables
            extra |= {"pipe_diameter": his.pipes.diameter, "pipe_length_front": his.pipes.length_front, "pipe_length_rear": his.pipes.length_rear}

        def value(name: str) -> Any:  # a rear value not given follows the front's
            given = extra[name] if name in extra else getattr(his, name)
            return getattr(his, name.removesuffix("_rear")) if given is None and name.endswith("_rear") else given

        return np.array([value(n) for n in self.variable_names], dtype=float)

    @property
    def objective_names(self) -> tuple[str, ...]:
        """What the optimiser minimises: the ``objectives`` (aggregated over the scenarios), or
        with ``[robust] aggregate = "per_scenario"`` every ``"<objective>@<scenario>"`` pair."""
        if self.spec.scenarios and self.spec.robust.aggregate == "per_scenario":
            return tuple(scenario_column(q, s) for q in self.spec.objectives for s in self.scenario_names)
        return tuple(self.spec.objectives)

    @property
    def result_columns(self) -> tuple[str, ...]:
        """The quantity columns of :meth:`hisopt.problem.Problem.evaluate`: each objective and
        constrained quantity once (aggregated in a scenario problem), then the scenario columns."""
        plain = tuple(self.spec.objectives) if self.spec.scenarios else self.objective_names
        return tuple(dict.fromkeys(plain + self.constraint_names + self.scenario_columns))

    # --- scenarios (docs/model.md §14) ---------------------------------------------------
    @property
    def scenario_names(self) -> tuple[str, ...]:
        """The ``[[scenarios]]`` names, in file order (empty for a single-case problem)."""
        return tuple(sc.name for sc in self.spec.scenarios)

    def constraint_scenarios(self, name: str) -> tuple[str, ...]:
        """The scenarios in which the constraint on ``name`` holds (all unless it names some)."""
        c = next(c for c in self.spec.constraints if c.name == name)
        return tuple(c.scenarios) if c.scenarios else self.scenario_names

    @property
    def scenario_columns(self) -> tuple[str, ...]:
        """Every ``"<quantity>@<scenario>"`` column a scenario problem reports: each objective in
        every scenario, each constraint in the scenarios where it holds."""
        cols = [scenario_column(q, s) for q in self.spec.objectives for s in self.scenario_names]
        cols += [scenario_column(c.name, s) for c in self.spec.constraints for s in self.constraint_scenarios(c.name)]
        return tuple(dict.fromkeys(cols))

    def scenario_space(self, name: str) -> DesignSpace:
        """Scenario ``name`` as a single-case problem: its road and payload, every objective and
        constrained quantity as an objective, no constraints (cached)."""
        key = f"scenario:{name}"
        if key not in self._cache:
            sc = next(s for s in self.spec.scenarios if s.name == name)
            quantities = list(dict.fromkeys(self.spec.objectives + [c.name for c in self.spec.constraints]))
            spec = self.spec.model_copy(
                update={
                    "road": sc.road or self.spec.road,
                    "payload": sc.payload,
                    "temperature": sc.temperature if sc.temperature is not None else self.spec.temperature,
                    "scenarios": [],
                    "objectives": quantities,
                    "constraints": [],
                }
            )
            self._cache[key] = type(self)(spec, self.path)
        return self._cache[key]

    @property
    def constraint_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.spec.constraints)

    def design_matrix(self, designs: Any) -> np.ndarray:
        """Designs as an ``(n, n_var)`` float array (:func:`hisopt.specification.validation.design_matrix`).

        Accepts an array (columns in variable order), a DataFrame or a dict with the
        variable names (missing names take the baseline value), a list of such dicts, or a
        single design. Values are not checked against the rules here: see
        :func:`hisopt.specification.validation.check_designs`.
        """
        return design_matrix(self, designs)

    def with_values(self, **values: Any) -> Self:
        """A copy with fixed ``[his]`` values replaced (``--set p0=3e6``), validated like the file.

        A name of the layout's extra parameters (``Rv_acc``, ...) sets ``[his.parameters]``.
        An implausible value (a precharge under 0.1 MPa) issues a
        :class:`~hisopt.errors.PlausibilityWarning` naming ``his.<name>``.
        """
        return self.replace_values(values)

    def replace_values(self, values: Mapping[str, Any], option: str | None = None) -> Self:
        """:meth:`with_values` with ``values`` from the command-line ``option`` (``--set``),
        which its warnings name (``--set p0=50000.0: ...``); None: they name ``his.<name>``."""
        data = self.spec.model_dump(by_alias=True)
        extra = layout_defaults(self.spec.his)
        given: dict[str, dict[str, Any]] = {}
        for key, value in values.items():
            value = value.item() if isinstance(value, np.generic) else value
            path = his_value_path(data, extra, key)
            if path is None:
                known = [k for k in data["his"] if k not in ("parameters", "circuits")] + list(extra)
                raise ConfigError(f"unknown HIS parameter {key!r}; expected one of {', '.join(known)}", key=key)
            place = data
            for step in path[:-1]:
                place = place[step]
            place[path[-1]] = value
            given[key] = nested(path, value)
        # the rest of the problem was checked when it was read: only the given values may warn
        spec = parse_problem(data, str(self.path or "<problem>"), warn_implausible=False)
        for key, part in given.items():
            label = f"{option} {key}={assignment_text(values[key])}" if option else None
            warn([(label or found, message) for found, message in implausible_values(spec, part)])
        return type(self)(spec, self.path, self.sha256)

    # --- models ----------------------------------------------------------------------
    def his_parameters(self, designs: Any) -> dict[str, np.ndarray]:
        """Design matrix as a dict of per-design arrays, shape ``(n,)`` each."""
        x = self.design_matrix(designs)
        return {n: x[:, i] for i, n in enumerate(self.variable_names)}

    def model(self, designs: Any = None, his: bool = True, inputs: Inputs | None = None) -> CoupledModel:
        """The coupled model for a batch of designs (batch shape ``(n,)``).

        ``designs=None`` is the baseline design; ``his=False`` the reference vehicle. A design
        that is not finite or breaks a parameter's rule raises :class:`ConfigError` naming
        the row and the rule. ``inputs`` vary what the file fixes, per design (``(n,)``
        arrays, SI, checked by the caller; docs/model.md §18): ``"vehicle.<field>"`` a field of
        the car, a ``[his]`` or layout parameter's name its value, ``"temperature_offset"`` [K]
        a shift of the problem's temperature.
        """
        if not his:
            return CoupledModel(self.vehicle, None)
        x = self.design_matrix(self.baseline if designs is None else designs)
        require_admissible(self, x)  # never build a model from a rule-breaking design
        params = {n: x[:, i] for i, n in enumerate(self.variable_names)}
        given = dict(inputs or {})
        offset = given.pop(TEMPERATURE_OFFSET, None)
        cars = {k.removeprefix(VEHICLE_PREFIX): v for k, v in given.items() if k.startswith(VEHICLE_PREFIX)}
        params |= {k: v for k, v in given.items() if not k.startswith(VEHICLE_PREFIX)}
        temperature = None if offset is None else self.temperature + np.asarray(offset, dtype=float)
        if cars and (self.spec.his.charge is not None or (self.spec.payload is not None and self.spec.payload.active)):
            raise ValueError("a batch of cars with a charged HIS or a payload is evaluated one car at a time (a problem per car)")
        vehicle = VehicleBatch.of(self.vehicle, cars) if cars else self.vehicle
        return CoupledModel(vehicle, self.hydraulic_system(params, temperature))

    @property
    def temperature(self) -> float:
        """[K] The problem's operating temperature: ``temperature``, else the reference one the
        ``[his]`` values are given at."""
        return self.spec.temperature if self.spec.temperature is not None else reference_temperature(self.spec.his)

    def hydraulic_system(self, overrides: Mapping[str, Any], temperature: np.ndarray | None = None) -> HydraulicSystem:
        """The HIS with design variables set from ``overrides`` (numpy arrays of one batch
        shape, or CasADi expressions for the refinement), the rest at the ``[his]`` values.
        The fluid and the gas are at the problem's ``temperature`` (or at ``temperature`` [K],
        one per design). With a ``[payload]`` the
        accumulators are linearised at the laden static pressures
        (:func:`hisopt.coupled.payload.static_pressure_rise`); a charged HIS (``[his.charge]``)
        at its static pressures at that temperature and payload
        (:func:`hisopt.coupled.operating_point.charged_static_pressure`)."""
        at = self.spec.temperature if temperature is None else temperature
        return at_operating_point(self.spec, HydraulicSystem(self.network(), his_parameter_values(self.spec.his, overrides, at)))

    @property
    def vehicle(self) -> VehicleParams:
        """The car the models use: laden with ``[payload]`` (:func:`hisopt.coupled.payload.laden_vehicle`),
        else ``[vehicle]``."""
        payload = self.spec.payload
        if payload is None or not payload.active:
            return self.spec.vehicle
        if "vehicle" not in self._cache:
            self._cache["vehicle"] = laden_vehicle(self.spec.vehicle, payload)
        return self._cache["vehicle"]

    def layout(self) -> Layout:
        """The HIS layout (``[his] layout`` or ``[[his.circuits]]``, with pipes and chamber
        volumes; docs/model.md §12)."""
        if "layout" not in self._cache:
            self._cache["layout"] = his_layout(self.spec.his)
        return self._cache["layout"]

    def network(self) -> Network:
        """The compiled HIS network (structure only; computed once per problem)."""
        if "network" not in self._cache:
            self._cache["network"] = compile_network(self.layout(), self.spec.his.pipe_model)
        return self._cache["network"]

    def parameter_rule(self, name: str) -> Rule:
        """The physical rule of parameter ``name`` (its ``[his]`` field and every element field
        of the layout that reads it; :func:`hisopt.specification.validation.parameter_rule`)."""
        return parameter_rule(name, layout=self.layout())


def at_operating_point(spec: ProblemSpec, his: HydraulicSystem) -> HydraulicSystem:
    """``his`` (parameter values at the problem's temperature) linearised at the static
    operating point of ``spec``'s own load case, as :meth:`DesignSpace.hydraulic_system`
    builds it: a charged HIS (``[his.charge]``) at its static pressures
    (:func:`hisopt.coupled.operating_point.charged_static_pressure`), else with an active
    ``[payload]`` at the laden static pressures (:func:`hisopt.coupled.payload.static_pressure_rise`),
    else unchanged (the accumulators at their precharge). The synthesis's screening solves
    each circuit alone with it (:func:`hisopt.studies.synthesis.circuit_matrices`)."""
    payload = spec.payload
    if spec.his.charge is not None:
        return HydraulicSystem(his.network, his.params, static_pressure=charged_static_pressure(spec.vehicle, payload, his))
    if payload is None or not payload.active:
        return his
    return HydraulicSystem(his.network, his.params, static_pressure_rise(spec.vehicle, payload, his))
