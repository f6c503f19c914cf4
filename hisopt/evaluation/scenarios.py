"""Evaluation of a scenario problem: every load case, then the aggregates (docs/model.md §14).

Each scenario is evaluated as its single-case problem
(:meth:`hisopt.specification.design_space.DesignSpace.scenario_space`). Scenarios with the same payload
have the same model, so they share its state space, poles and residues
(:meth:`hisopt.evaluation.evaluate.Evaluator.shared`) and differ only in the road's PSD, the wheelbase
delay and the quadrature nodes these call for. Scenarios with different payloads have models
of their own.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.evaluation.evaluate import Evaluator
from hisopt.robust import aggregate, split_column, worst

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace, Inputs


class ScenarioEvaluator:
    """Quantities of a scenario problem by name: ``"<quantity>@<scenario>"`` for every
    scenario column, and under the plain name each objective's aggregate (``[robust]``) and
    each constraint's worst case over the scenarios where it holds; plus ``"valid"`` (every
    scenario's model valid)."""

    def __init__(self, problem: DesignSpace):
        spec = problem.spec
        self.problem = problem
        self.scenarios = problem.scenario_names
        self.weights = [sc.weight for sc in spec.scenarios]
        self.evaluators = [Evaluator(problem.scenario_space(name)) for name in self.scenarios]
        groups: dict[Any, list[int]] = {}
        solved = bool(problem.network().solved_valves())  # the valves' flows, so the models, differ by road
        for i, sc in enumerate(spec.scenarios):
            laden = sc.payload is not None and sc.payload.active  # a 0 kg payload is no payload (§13)
            temperature = sc.temperature if sc.temperature is not None else spec.temperature
            groups.setdefault((sc.payload if laden else None, temperature, i if solved else None), []).append(i)
        self.groups = list(groups.values())
        """Scenarios sharing a model (the same payload and temperature), by index, in file order."""
        for group in self.groups:  # a step steer constrained in the laden case only: not computed empty
            read = set(spec.objectives) | {c.name for c in spec.constraints if set(problem.constraint_scenarios(c.name)) & {self.scenarios[i] for i in group}}
            lead = self.evaluators[group[0]]
            lead.unread = frozenset(m.name for m in lead.metrics if m.kind == "transient" and m.name not in read)
        plain = list(dict.fromkeys(spec.objectives + [c.name for c in spec.constraints]))
        self.names = tuple(plain) + problem.scenario_columns

    def __call__(self, designs: Any, inputs: Inputs | None = None) -> dict[str, np.ndarray]:
        """Every load case's quantities and their aggregates; ``inputs`` as
        :meth:`hisopt.evaluation.evaluate.Evaluator.shared` takes them (the same in every case)."""
        x = self.problem.design_matrix(designs)
        per: list[dict[str, np.ndarray]] = [{} for _ in self.scenarios]
        for group in self.groups:
            lead = self.evaluators[group[0]]
            for i, result in zip(group, lead.shared(x, [self.evaluators[i] for i in group], inputs), strict=True):
                per[i] = result
        return self.combine(per)

    def combine(self, per: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
        """The scenario columns and aggregates from each scenario's quantities."""
        spec = self.problem.spec
        out: dict[str, np.ndarray] = {}
        for q in spec.objectives:
            values = np.stack([r[q] for r in per], axis=1)
            out[q] = aggregate(values, spec.robust.aggregate, self.weights, spec.robust.alpha)
        for c in spec.constraints:
            where = self.problem.constraint_scenarios(c.name)
            values = np.stack([per[self.scenarios.index(s)][c.name] for s in where], axis=1)
            out.setdefault(c.name, worst(values))
        for col in self.problem.scenario_columns:
            q, s = split_column(col)
            out[col] = per[self.scenarios.index(s)][q]
        out["valid"] = np.all([r["valid"] for r in per], axis=0)
        return out


def case_evaluator_for(space: DesignSpace) -> Evaluator | ScenarioEvaluator:
    """The evaluator of ``space`` at its inputs' nominal values (a :class:`ScenarioEvaluator`
    for a problem with ``[[scenarios]]``), built once and kept with it (its cache survives as
    long as the problem object; a pickled problem builds its own). A problem's own evaluator,
    which may take statistics over ``[[uncertain]]`` samples, is
    :func:`hisopt.evaluation.robust_evaluator.evaluator_for`'s."""
    if "case_evaluator" not in space._cache:
        space._cache["case_evaluator"] = ScenarioEvaluator(space) if space.spec.scenarios else Evaluator(space)
    return space._cache["case_evaluator"]
