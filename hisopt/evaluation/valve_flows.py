"""The damper valves' RMS flows, solved with the road's response (docs/model.md §3.3).

A physical damper valve is linearised at the RMS flow the road drives through it
(:func:`hisopt.hydraulics.laws.damper_valve_equivalent_resistance`), and that flow depends
on the resistance: per design and load case the two are solved together as the fixed point
``s = F(s)``, where ``F`` builds the model at the valves' equivalent resistances for RMS
flows ``s`` and integrates each valve's flow PSD over the band on the case's road, with the
evaluator's own nodes (:class:`~hisopt.evaluation.evaluate.Evaluator`).

The iteration runs on ``y = log s``, vectorised over designs and valves, each valve stepped by
the secant of its own last two iterates (``y + (F(y) - y) / (1 - m)``, ``m`` the slope of
``log F`` in ``log s``, clipped to ``[-20, 0.5]``; :data:`FIRST_SLOPE` before there are two). A design
is converged when every valve's ``|log F(s) - log s|`` is at most :data:`FLOW_TOLERANCE`;
one that is not after :data:`MAX_ITERATIONS`, or whose model fails, gets NaN flows (its
quantities NaN: the design fails with that reason).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Protocol

import numpy as np

from hisopt.errors import ModelError
from hisopt.hydraulics.network import solved_flow_name

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.specification.design_space import DesignSpace, Inputs


class Evaluator(Protocol):
    """What the fixed point needs of :class:`~hisopt.evaluation.evaluate.Evaluator` (named as a
    protocol: the evaluator imports this module)."""

    problem: DesignSpace

    def output_rms(self, model: CoupledModel, outputs: Sequence[str]) -> np.ndarray: ...


FLOW_TOLERANCE = 1e-7
"""Relative change of the RMS flows at which the fixed point stops (a resistance that far
from its fixed point moves the quantities by less than the evaluator's 1e-4 tolerance)."""
MAX_ITERATIONS = 30
INITIAL_FLOW = 1e-4
"""[m^3/s] The first RMS flow tried: 0.1 L/s, a passenger car's damper on a C road."""
FIRST_SLOPE = -0.25
"""The slope of ``log F`` in ``log s`` assumed for the first step (a stiffer valve passes less
flow, but less than in proportion: -0.1 to -0.4 over the valves problem's box)."""


def valve_flow_names_of(problem: DesignSpace) -> list[str]:
    """The ``valve_flow_<j>`` outputs of the valves whose RMS flows are solved, in element order."""
    net = problem.network()
    damper = [k for k, _, _ in net.damper_valves()]
    return [f"valve_flow_{damper.index(k)}" for k, _, _ in net.solved_valves()]


def solve_valve_flows(evaluator: Evaluator, x: np.ndarray, inputs: Inputs) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The solved RMS flows [m^3/s] of ``x``'s designs (admissible rows), as model inputs
    (:func:`~hisopt.hydraulics.network.solved_flow_name`), each ``(n,)``; whether each design
    converged; and the iterations each took.

    ``evaluator``: an evaluator that integrates the valves' flows (``rms_outputs``
    :func:`valve_flow_names_of`) on the load case's road."""
    net = evaluator.problem.network()
    names = [solved_flow_name(k) for k, _, _ in net.solved_valves()]
    outputs = valve_flow_names_of(evaluator.problem)
    n, m = len(x), len(names)
    y = np.full((n, m), np.log(INITIAL_FLOW))
    y_prev, g_prev = np.full((n, m), np.nan), np.full((n, m), np.nan)
    converged = np.zeros(n, dtype=bool)
    failed = np.zeros(n, dtype=bool)
    iterations = np.zeros(n, dtype=np.int64)
    try:  # the static operating point once: the flows change only the valves' resistances
        base = evaluator.problem.model(x, inputs=dict(inputs) | {name: np.exp(y[:, j]) for j, name in enumerate(names)})
    except (ModelError, np.linalg.LinAlgError, ValueError):
        return {name: np.full(n, np.nan) for name in names}, converged, iterations
    active = np.arange(n)
    for _ in range(MAX_ITERATIONS):
        if not len(active):
            break
        g = np.log(_flow_rms(evaluator, _at_flows(base.subset(active), names, np.exp(y[active])), outputs))
        iterations[active] += 1
        bad = ~np.all(np.isfinite(g), axis=1)
        failed[active[bad]] = True
        step = g - y[active]
        done = ~bad & np.all(np.abs(step) <= FLOW_TOLERANCE, axis=1)
        converged[active[done]] = True
        slope = (g - g_prev[active]) / (y[active] - y_prev[active])
        slope = np.where(np.isfinite(slope), np.clip(slope, -20.0, 0.5), FIRST_SLOPE)
        keep = ~bad & ~done
        rows = active[keep]
        y_prev[rows], g_prev[rows] = y[rows], g[keep]
        y[rows] = y[rows] + step[keep] / (1.0 - slope[keep])
        active = rows
    ok = converged & ~failed
    flows = {name: np.where(ok, np.exp(y[:, j]), np.nan) for j, name in enumerate(names)}
    return flows, ok, iterations


def _at_flows(model: CoupledModel, names: list[str], flows: np.ndarray) -> CoupledModel:
    """``model`` with its solved valves linearised at the RMS flows ``flows`` ``(n, len(names))``."""
    assert model.his is not None
    params = dict(model.his.params) | {name: flows[:, j] for j, name in enumerate(names)}
    return replace(model, his=replace(model.his, params=params))


def _flow_rms(evaluator: Evaluator, model: CoupledModel, outputs: list[str]) -> np.ndarray:
    """[m^3/s] The valves' band RMS flows ``(n, len(outputs))`` of a batch of models (NaN for a
    design whose model is unstable, singular or untrusted)."""
    out = np.full((len(np.atleast_1d(model.his.batch_shape and np.empty(model.his.batch_shape))), len(outputs)), np.nan)  # type: ignore[union-attr]
    try:
        groups = model.groups()
    except (ModelError, np.linalg.LinAlgError, ValueError):
        return out
    for rows, group in groups:
        try:
            out[rows] = evaluator.output_rms(group, outputs)
        except (np.linalg.LinAlgError, ModelError):
            continue
    return out
