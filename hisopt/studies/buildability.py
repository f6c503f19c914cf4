"""Whether designs can be built: every buildability rule in every load case, one verdict per
design, and the sheet of one design's rules (docs/model.md §21).

A problem's constraints enforce the rules it names; this module computes all of them for any
designs, so every view shows the verdict: ``buildable`` (every rule's usage at most 1 in every
load case), the ``binding_rule`` (the largest usage) and the ``build_margin`` (1 minus it).
The numbers are the evaluator's: each load case's model at its operating point (with the
damper valves at that case's fixed point) and the road's swing from its band integrals.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.coupled.buildability import RULES, RuleValue
from hisopt.evaluation.build_rules import catalogue_rating, road_outputs, rule_values
from hisopt.studies.damper_valves import load_cases
from hisopt.units import NO_UNIT

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

BUILDABLE = "buildable"
BINDING_RULE = "binding_rule"
BUILD_MARGIN = "build_margin"
VERDICT_COLUMNS = (BUILDABLE, BINDING_RULE, BUILD_MARGIN)
"""The verdict's columns: every rule's usage at most 1 in every load case; the rule with the
largest usage; 1 minus that usage (NaN, and not buildable, where a design was not evaluated)."""


@dataclass(frozen=True)
class CaseRules:
    """Every rule of designs ``(n,)`` in load case ``name``."""

    name: str
    rules: dict[str, RuleValue]


def case_rules(space: DesignSpace, x: np.ndarray) -> dict[str, RuleValue]:
    """Every rule of the rows of ``x`` [SI] in the single-case problem ``space``: NaN for a
    row breaking a parameter's rule, whose valves have no fixed point or whose model is
    unstable."""
    from hisopt.evaluation.evaluate import Evaluator
    from hisopt.evaluation.valve_states import valve_states
    from hisopt.specification.validation import STATUS_INVALID, check_designs

    n = len(x)
    out = {name: RuleValue(np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)) for name in RULES}
    rows = np.flatnonzero(check_designs(space, x).status != STATUS_INVALID)
    inputs: dict[str, np.ndarray] = {}
    if space.network().solved_valves() and len(rows):
        states = valve_states(space, x[rows])
        rows, inputs = rows[states.converged], {k: v[states.converged] for k, v in states.inputs.items()}
    if not len(rows):
        return out
    model = space.model(x[rows], inputs=inputs or None)
    outputs = road_outputs(space.network(), tuple(RULES))
    evaluator = Evaluator(space, names=(), rms_outputs=outputs)
    limits = space.spec.build_limits
    rating = catalogue_rating(space)
    for group, sub in model.groups():
        rms = evaluator.output_rms(sub, outputs)
        got = rule_values(sub, limits, tuple(RULES), lambda o, rms=rms: rms[:, outputs.index(o)], rating)  # type: ignore[misc]
        target = rows[np.asarray(group)]
        for name, value in got.items():
            for part in ("value", "limit", "usage"):
                getattr(out[name], part)[target] = np.broadcast_to(getattr(value, part), (len(target),))
    return out


def load_case_rules(problem: DesignSpace, designs: Any) -> list[CaseRules]:
    """:func:`case_rules` of ``designs`` (any form ``design_matrix`` takes) in every load case."""
    x = problem.design_matrix(designs)
    return [CaseRules(name, case_rules(space, x)) for name, space in load_cases(problem)]


def verdicts(cases: list[CaseRules]) -> pd.DataFrame:
    """One row per design: each rule's largest usage over the load cases (named as its
    quantity) and :data:`VERDICT_COLUMNS`."""
    usage = {name: np.max(np.stack([c.rules[name].usage for c in cases]), axis=0) for name in RULES}
    table = np.stack(list(usage.values()), axis=-1)
    evaluated = ~np.any(np.isnan(table), axis=-1)  # +inf: beyond a rating of zero, judged
    worst = np.where(evaluated, np.max(np.where(evaluated[:, None], table, 0.0), axis=-1), np.nan)
    binding = np.array(list(RULES), dtype=object)[np.argmax(np.where(evaluated[:, None], table, -np.inf), axis=-1)]
    frame = pd.DataFrame(usage)
    frame[BUILDABLE] = evaluated & (worst <= 1.0)
    frame[BINDING_RULE] = np.where(evaluated, binding, "")
    frame[BUILD_MARGIN] = 1.0 - worst
    frame.attrs["units"] = dict.fromkeys(frame.columns, NO_UNIT)
    return frame


def buildability(problem: DesignSpace, designs: Any) -> pd.DataFrame:
    """:func:`verdicts` of ``designs`` over every load case of ``problem``."""
    return verdicts(load_case_rules(problem, designs))


def rule_sheet(cases: list[CaseRules], design: int = 0) -> pd.DataFrame:
    """[SI] One row per rule of design row ``design``: ``rule``, what it checks (``check``),
    the load case where it binds, its ``value`` and ``limit`` there (``unit``), ``usage`` and
    ``margin`` (``1 - usage``), and ``holds``."""
    rows = []
    for name, rule in RULES.items():
        usage = np.array([c.rules[name].usage[design] for c in cases])
        k = int(np.nanargmax(usage)) if np.isfinite(usage).any() else 0
        value = cases[k].rules[name]
        rows.append(
            {
                "rule": name,
                "check": rule.label,
                "load_case": cases[k].name,
                "value": float(value.value[design]),
                "limit": float(value.limit[design]),
                "unit": rule.unit,
                "usage": float(usage[k]),
                "margin": float(1.0 - usage[k]),
                "holds": bool(usage[k] <= 1.0),
            }
        )
    frame = pd.DataFrame(rows)
    frame.attrs["units"] = {c: NO_UNIT for c in frame.columns}
    return frame
