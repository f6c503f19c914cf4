"""Designs under uncertain inputs: every design at every sample of the ``[[uncertain]]``
inputs (docs/model.md §18).

A sample is a row of standard uniform variates ``u`` (one column per input); each input's
distribution maps it to a value around that design's nominal
(:meth:`hisopt.specification.uncertain.Uncertain.values`), so every design meets the same
samples (common random numbers). The evaluator takes the values the fastest exact way their
input allows:

- a design variable: its column of the design matrix, moved;
- a ``[his]`` or layout parameter, the temperature and the car's masses, inertias, springs,
  dampers and rear tyre: model inputs of the batched evaluator, one per row
  (:meth:`hisopt.specification.design_space.DesignSpace.model`);
- the road's roughness ``G_d(n0)``: a pure factor on every road PSD, so each quantity scales
  by the factor to its metric's power (:data:`hisopt.metrics.ROAD_POWER`), exactly;
- the rest (the speed, the payload, the car's geometry and front tyre, and every car field of
  a charged or laden problem or one with transient quantities): one problem per distinct
  value, its rows batched.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from hisopt.coupled.payload import laden_problem
from hisopt.errors import ConfigError
from hisopt.evaluation.parallel import Backend, chunks
from hisopt.evaluation.scenarios import case_evaluator_for
from hisopt.metrics import METRICS, ROAD_POWER
from hisopt.robust import quantity_of
from hisopt.specification.design_space import TEMPERATURE_OFFSET, VEHICLE_PREFIX
from hisopt.specification.uncertain import PAYLOAD, ROAD_CLASS, ROAD_ROUGHNESS, ROAD_SPEED, TEMPERATURE, Uncertain, input_rule, nominal_value, resolve_uncertain

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

Route = Literal["design", "batched", "road", "problem"]

BATCHED_VEHICLE = frozenset({"m_s", "I_x", "I_y", "m_uf", "m_ur", "k_sf", "k_sr", "c_sf", "c_sr", "k_arb_f", "k_arb_r", "k_tr", "c_tr"})
"""Car fields a batch of cars carries through the frequency-domain evaluator: those no
output, road delay or coherence reads (the roll gradient takes each car's ``m_s``)."""

ROWS_PER_TASK = 8192
"""(design, sample) rows per task of a parallel backend."""


def monte_carlo_variates(n_samples: int, n_inputs: int, seed: int) -> np.ndarray:
    """[-] ``(N, K)`` independent standard uniform variates in (0, 1) from ``seed`` (numpy's
    PCG64): the fixed sample set every design meets."""
    return np.random.default_rng(seed).random((n_samples, n_inputs))


def route(item: Uncertain, space: DesignSpace) -> Route:
    """How the evaluator takes input ``item`` (module docstring)."""
    spec = space.spec
    name = item.name
    if name in spec.variables:
        return "design"
    if name in (ROAD_ROUGHNESS, ROAD_CLASS):
        return "road"
    if name == ROAD_SPEED or name.startswith(PAYLOAD):
        return "problem"
    if name.startswith(VEHICLE_PREFIX):
        laden = (spec.payload is not None and spec.payload.active) or any(sc.payload is not None and sc.payload.active for sc in spec.scenarios)
        transient = any(METRICS[q].kind == "transient" for q in spec.objectives + [c.name for c in spec.constraints])
        plain = spec.his.charge is None and not laden and not transient
        return "batched" if plain and name.removeprefix(VEHICLE_PREFIX) in BATCHED_VEHICLE else "problem"
    return "batched"  # a [his] or layout parameter, the temperature


@dataclass(frozen=True)
class Rows:
    """Every (design, sample) pair as one row, design-major (row ``i * N + j``)."""

    x: np.ndarray  # (R, n_var) design matrix, design-variable inputs moved
    batched: dict[str, np.ndarray]  # model inputs by the name DesignSpace.model takes, (R,)
    fixed: np.ndarray  # (R, P) values of the "problem" inputs
    road: np.ndarray  # (R,) factor on the road PSD
    possible: np.ndarray  # (R,) every input value obeys its rule
    fixed_names: tuple[str, ...]  # the "problem" inputs, the columns of fixed

    def part(self, rows: slice) -> Rows:
        return Rows(self.x[rows], {k: v[rows] for k, v in self.batched.items()}, self.fixed[rows], self.road[rows], self.possible[rows], self.fixed_names)


class UncertainEvaluator:
    """Quantities of designs at every sample of the uncertain inputs.

    Parameters
    ----------
    space : DesignSpace
        the problem; its ``[[uncertain]]`` entries unless ``inputs`` are given
    inputs : Sequence[Uncertain] | None
        the uncertain inputs (:func:`hisopt.specification.uncertain.resolve_uncertain`)
    """

    def __init__(self, space: DesignSpace, inputs: Sequence[Uncertain] | None = None):
        self.space = space
        self.inputs = tuple(resolve_uncertain(space.spec) if inputs is None else inputs)
        self.routes = tuple(route(u, space) for u in self.inputs)
        self.names = case_evaluator_for(space).names
        self.nominal = {u.name: nominal_value(u.name, space.spec) for u in self.inputs}
        self.fixed_names = tuple(u.name for u, r in zip(self.inputs, self.routes, strict=True) if r == "problem")

    def values(self, x: np.ndarray, u: np.ndarray) -> dict[str, np.ndarray]:
        """[SI] Each input's value at design ``x[i]`` and sample ``u[i]`` (paired rows),
        ``(R,)`` each: around the design's value for a design variable, else the file's."""
        names = self.space.variable_names
        out = {}
        for k, item in enumerate(self.inputs):
            nominal = x[:, names.index(item.name)] if item.name in names else np.full(len(x), self.nominal[item.name])
            out[item.name] = item.values(np.clip(u[:, k], 1e-12, 1.0 - 1e-12), nominal)
        return out

    def rows(self, x: np.ndarray, u: np.ndarray) -> Rows:
        """The rows of designs ``x`` ``(R, n_var)`` each at its sample ``u`` ``(R, K)``."""
        values = self.values(x, u)
        rows_x = np.array(x, dtype=float)
        batched: dict[str, np.ndarray] = {}
        fixed = np.empty((len(x), len(self.fixed_names)))
        road = np.ones(len(x))
        possible = np.ones(len(x), dtype=bool)
        names = self.space.variable_names
        for item, how in zip(self.inputs, self.routes, strict=True):
            v = values[item.name]
            possible &= input_rule(item.name, self.space.spec).holds(v)
            if how == "design":
                rows_x[:, names.index(item.name)] = v
            elif how == "road":
                road = v / self.nominal[item.name]
            elif how == "problem":
                fixed[:, self.fixed_names.index(item.name)] = v
            elif item.name == TEMPERATURE:
                batched[TEMPERATURE_OFFSET] = v - self.nominal[item.name]
            else:
                batched[item.name] = v
        return Rows(rows_x, batched, fixed, road, possible, self.fixed_names)

    def __call__(self, designs: Any, u: np.ndarray, backend: Backend | None = None) -> dict[str, np.ndarray]:
        """Quantities by name, each ``(n, N)`` for ``n`` designs at every one of ``N``
        samples ``u`` ``(N, K)`` in (0, 1), plus ``"valid"``; a sample whose input breaks its
        rule (a negative mass drawn) gives NaN and ``valid`` False there."""
        x = self.space.design_matrix(designs)
        u = self._variates(u)
        n, m = len(x), len(u)
        out = self.paired(np.repeat(x, m, axis=0), np.tile(u, (n, 1)), backend)
        return {k: v.reshape(n, m) for k, v in out.items()}

    def paired(self, designs: Any, u: np.ndarray, backend: Backend | None = None) -> dict[str, np.ndarray]:
        """Quantities of design ``i`` at sample ``u[i]``, ``(R,)`` each, plus ``"valid"``."""
        rows = self.rows(self.space.design_matrix(designs), self._variates(u))
        backend = backend or Backend()
        total = len(rows.x)
        parts = [rows.part(s) for s in chunks(total, ROWS_PER_TASK if backend.is_distributed else max(total, 1))]
        results = backend.map(_evaluate_rows, parts, self.space)
        return {k: np.concatenate([r[k] for r in results]) for k in results[0]}

    def _variates(self, u: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if u.shape[1] != len(self.inputs):
            raise ValueError(f"expected {len(self.inputs)} columns of variates, one per uncertain input; got {u.shape[1]}")
        return u


def _evaluate_rows(rows: Rows, space: DesignSpace) -> dict[str, np.ndarray]:
    """Quantities of ``rows``: one problem per distinct value of their "problem" inputs."""
    fixed_names = rows.fixed_names
    names = case_evaluator_for(space).names
    out = {k: np.full(len(rows.x), np.nan) for k in names}
    valid = np.zeros(len(rows.x), dtype=bool)
    if fixed_names:
        groups, which = np.unique(rows.fixed, axis=0, return_inverse=True)
        which = which.ravel()
    else:
        groups, which = np.empty((1, 0)), np.zeros(len(rows.x), dtype=np.int64)
    for g, values in enumerate(groups):
        take = np.flatnonzero((which == g) & rows.possible)
        if take.size == 0:
            continue
        try:  # a sample the problem file would refuse (a payload off the body, a CG outside the track)
            sub = with_inputs(space, dict(zip(fixed_names, map(float, values), strict=True)))
        except ValueError:
            continue  # not evaluated: NaN, not valid
        got = case_evaluator_for(sub)(rows.x[take], inputs={k: v[take] for k, v in rows.batched.items()})
        for k in names:
            out[k][take] = got[k] * rows.road[take] ** ROAD_POWER[METRICS[quantity_of(k)].kind]
        valid[take] = got["valid"]
    return out | {"valid": valid}


def sample_space(space: DesignSpace, values: dict[str, float]) -> DesignSpace:
    """``space`` at one sample as a plain problem: every input that is not a design variable
    (nor the road's roughness) set in its specification, no ``[[uncertain]]`` entries, no
    statistic, no chance constraints (the engines that take one problem per sample, e.g. the
    CasADi refinement's sample average)."""
    spec = space.spec
    his_names = {k: v for k, v in values.items() if not k.startswith((VEHICLE_PREFIX, PAYLOAD)) and k not in (ROAD_SPEED, TEMPERATURE)}
    extra = {k: v for k, v in his_names.items() if k not in type(spec.his).model_fields and not k.startswith("pipe_")}  # a layout's own
    pipes = {k.removeprefix("pipe_"): v for k, v in his_names.items() if k.startswith("pipe_")}
    fields = {k: v for k, v in his_names.items() if k not in extra and not k.startswith("pipe_")}
    his = spec.his.model_copy(update=fields | ({"parameters": spec.his.parameters | extra} if extra else {}))
    if pipes:
        assert his.pipes is not None
        his = his.model_copy(update={"pipes": his.pipes.model_copy(update=pipes)})
    update: dict[str, Any] = {
        "his": his,
        "uncertain": [],
        "robust": type(spec.robust)(),
        "constraints": [c.model_copy(update={"probability": None}) for c in spec.constraints],
    }
    if TEMPERATURE in values:
        update["temperature"] = values[TEMPERATURE]
    plain = type(space)(spec.model_copy(update=update), space.path)
    rest = {k: v for k, v in values.items() if k.startswith((VEHICLE_PREFIX, PAYLOAD)) or k == ROAD_SPEED}
    return with_inputs(plain, rest)


def with_inputs(space: DesignSpace, values: dict[str, float]) -> DesignSpace:
    """``space`` with problem-level inputs set: ``vehicle.<field>``, ``road.speed``,
    ``payload.<field>``, each table validated again with its new values.

    Raises
    ------
    ValueError
        The values make a car, road or payload the problem file would refuse (pydantic's
        ``ValidationError``, or :class:`~hisopt.errors.ConfigError` for a payload the car
        cannot carry).
    """
    if not values:
        return space
    spec = space.spec
    car = {k.removeprefix(VEHICLE_PREFIX): v for k, v in values.items() if k.startswith(VEHICLE_PREFIX)}
    load = {k.removeprefix(PAYLOAD): v for k, v in values.items() if k.startswith(PAYLOAD)}
    vehicle = type(spec.vehicle).model_validate(spec.vehicle.model_dump() | car) if car else spec.vehicle
    update: dict[str, Any] = {"vehicle": vehicle}
    if ROAD_SPEED in values:
        update["road"] = type(spec.road).model_validate(spec.road.model_dump() | {"speed": values[ROAD_SPEED]})
    payload = spec.payload
    if load:
        assert payload is not None
        payload = type(payload).model_validate(payload.model_dump() | load)
        update["payload"] = payload
    problem = laden_problem(vehicle, payload) if payload is not None and payload.active and (car or load) else None
    if problem:
        raise ConfigError(problem)
    return type(space)(spec.model_copy(update=update), space.path, space.sha256)
