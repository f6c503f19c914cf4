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

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Protocol

import numpy as np

from hisopt.errors import ModelError
from hisopt.hydraulics.network import solved_flow_name

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.specification.design_space import DesignSpace, Inputs


class FlowIntegrator(Protocol):
    """What the fixed point needs of :class:`~hisopt.evaluation.evaluate.Evaluator` (named as a
    protocol: the evaluator imports this module)."""

    problem: DesignSpace

    def output_rms(self, model: CoupledModel, outputs: Sequence[str]) -> np.ndarray: ...


FLOW_TOLERANCE = 1e-4
"""Largest relative residual ``|F(s) / s - 1|`` of the RMS flows a design is evaluated at: a
resistance that far from its fixed point moves a quantity by at most about as much (its
slope in the resistance, in log-log, is below 1 over the valves problem's box), a tenth of
the evaluator's own 1e-3 budget against a converged reference and far below the
linearisation's error (2-20 %, docs/model.md §3.3)."""
FIRST_STEPS = 2
"""Secant steps the evaluator takes from :class:`FlowStart` before it evaluates a design and
measures its residual (four in five random designs of the valves problem's city road are then
within :data:`FLOW_TOLERANCE`, 97 % within 1e-3: ``python benchmarks/bench_valves.py``)."""
MAX_ITERATIONS = 30
INITIAL_FLOW = 1e-4
"""[m^3/s] The first RMS flow tried: 0.1 L/s, a passenger car's damper on a C road."""
FIRST_SLOPE = -0.25
"""The slope of ``log F`` in ``log s`` assumed for the first step where :class:`FlowStart` has
none: a stiffer valve passes less flow, but less than in proportion (a slope in (-1, 0))."""


def valve_flow_names_of(problem: DesignSpace) -> list[str]:
    """The ``valve_flow_<j>`` outputs of the valves whose RMS flows are solved, in element order."""
    net = problem.network()
    flowing = [k for k, _, _ in net.flow_valves()]
    return [f"valve_flow_{flowing.index(k)}" for k, _, _ in net.solved_valves()]


def solve_valve_flows(
    evaluator: FlowIntegrator, x: np.ndarray, inputs: Inputs, start: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The solved RMS flows [m^3/s] of ``x``'s designs (admissible rows), as model inputs
    (:func:`~hisopt.hydraulics.network.solved_flow_name`), each ``(n,)``; whether each design
    converged; and the iterations each took.

    ``evaluator``: an evaluator that integrates the valves' flows (``rms_outputs``
    :func:`valve_flow_names_of`) on the load case's road; ``start``: ``log`` of the first
    flows tried and the slope of ``log F`` to take the first step with, each ``(n, n_valves)``
    (None: :data:`INITIAL_FLOW` and :data:`FIRST_SLOPE` for all; :class:`FlowStart`). Once a design's
    residual is within :data:`FLOW_TOLERANCE` it takes one more step (no new evaluation): the
    secant's superlinear convergence puts that step's error orders of magnitude below the
    tolerance, so the result does not hinge on the path the iteration took."""
    net = evaluator.problem.network()
    names = [solved_flow_name(k) for k, _, _ in net.solved_valves()]
    outputs = valve_flow_names_of(evaluator.problem)
    n, m = len(x), len(names)
    y = np.full((n, m), np.log(INITIAL_FLOW)) if start is None else np.array(start[0], dtype=float)
    first = np.full((n, m), FIRST_SLOPE) if start is None else np.clip(start[1], -20.0, 0.5)
    try:  # the static operating point once: the flows change only the valves' resistances
        base = evaluator.problem.model(x, inputs=dict(inputs) | {name: np.exp(y[:, j]) for j, name in enumerate(names)})
    except (ModelError, np.linalg.LinAlgError, ValueError):
        return {name: np.full(n, np.nan) for name in names}, np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64)
    y, ok, iterations, _ = log_fixed_point(
        lambda rows, y_rows: np.log(_flow_rms(evaluator, _at_flows(base.subset(rows), names, np.exp(y_rows)), outputs)), y, first
    )
    flows = {name: np.where(ok, np.exp(y[:, j]), np.nan) for j, name in enumerate(names)}
    return flows, ok, iterations


def first_steps(
    evaluator: FlowIntegrator, x: np.ndarray, inputs: Inputs, start: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """``log`` of the RMS flows [m^3/s] after :data:`FIRST_STEPS` secant steps from ``start``,
    ``(n, n_valves)`` (NaN rows where a model fails), and the last ``(y, log F(y))`` pair the
    steps evaluated (for :func:`secant_step`): where the evaluator evaluates the designs,
    measuring their flows as it goes (:func:`flow_residual`)."""
    net = evaluator.problem.network()
    names = [solved_flow_name(k) for k, _, _ in net.solved_valves()]
    outputs = valve_flow_names_of(evaluator.problem)
    y = np.array(start[0], dtype=float)
    last = (np.full(y.shape, np.nan), np.full(y.shape, np.nan))
    try:
        base = evaluator.problem.model(x, inputs=dict(inputs) | {name: np.exp(y[:, j]) for j, name in enumerate(names)})
    except (ModelError, np.linalg.LinAlgError, ValueError):
        return np.full(y.shape, np.nan), last
    response = lambda rows, y_rows: np.log(_flow_rms(evaluator, _at_flows(base.subset(rows), names, np.exp(y_rows)), outputs))  # noqa: E731
    y, _, iterations, last = log_fixed_point(response, y, start[1], tolerance=0.0, max_iterations=FIRST_STEPS)
    return np.where((iterations == FIRST_STEPS)[:, None], y, np.nan), last  # a row that failed on the way: NaN


def secant_step(y: np.ndarray, g: np.ndarray, last: tuple[np.ndarray, np.ndarray], first: np.ndarray) -> np.ndarray:
    """The next iterate from ``y`` where ``log F`` is ``g``, each valve by the secant through
    ``last`` (:func:`first_steps`'s pair; ``first``, the start's slope, where it gives none)."""
    with np.errstate(all="ignore"):
        slope = (g - last[1]) / (y - last[0])
    slope = np.where(np.isfinite(slope), slope, first)
    return y + (g - y) / (1.0 - np.clip(slope, -20.0, 0.5))


def flow_residual(y: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """[-] The largest ``|log F(s) - log s|`` over each design's valves, ``(n,)`` (NaN where
    either is not finite): how far the flows ``exp(y)`` are from the fixed point, ``measured``
    being the RMS flows [m^3/s] of the model built at them."""
    with np.errstate(all="ignore"):
        r = np.max(np.abs(np.log(measured) - y), axis=1, initial=0.0)
    return np.where(np.all(np.isfinite(y), axis=1) & np.all(np.isfinite(measured), axis=1), r, np.nan)


def log_fixed_point(
    response: Callable[[np.ndarray, np.ndarray], np.ndarray],
    y: np.ndarray,
    first: np.ndarray,
    tolerance: float = FLOW_TOLERANCE,
    max_iterations: int = MAX_ITERATIONS,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Solve ``y = G(y)`` per row (design) by each column's secant (module docstring).

    Parameters
    ----------
    response : Callable
        ``response(rows, y[rows])`` -> ``G`` at those rows, ``(len(rows), m)`` (NaN: no answer)
    y, first : np.ndarray
        the start and the slope of ``G`` to take the first step with, each ``(n, m)``
    tolerance : float
        [-] the largest ``|G(y) - y|`` accepted (0: take ``max_iterations`` steps)
    max_iterations : int
        [-] evaluations of ``G`` at most

    Returns
    -------
    y, converged, iterations : np.ndarray
        ``(n, m)`` the solution (one more step past the accepted iterate), ``(n,)`` whether it
        converged, ``(n,)`` the evaluations of ``G`` it took
    last : tuple[np.ndarray, np.ndarray]
        the last ``(y, G(y))`` pair evaluated per row, each ``(n, m)``
    """
    y = np.array(y, dtype=float)
    n = len(y)
    y_prev, g_prev = np.full(y.shape, np.nan), np.full(y.shape, np.nan)
    converged, failed = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    iterations = np.zeros(n, dtype=np.int64)
    active = np.arange(n)
    for _ in range(max_iterations):
        if not len(active):
            break
        g = response(active, y[active])
        iterations[active] += 1
        bad = ~np.all(np.isfinite(g), axis=1)
        failed[active[bad]] = True
        residual = g - y[active]
        slope = (g - g_prev[active]) / (y[active] - y_prev[active])  # each column's own secant
        slope = np.where(np.isfinite(slope), np.clip(slope, -20.0, 0.5), np.clip(first[active], -20.0, 0.5))
        keep = ~bad
        rows = active[keep]
        y_prev[rows], g_prev[rows] = y[rows], g[keep]
        y[rows] = y[rows] + residual[keep] / (1.0 - slope[keep])
        done = keep & np.all(np.abs(residual) <= tolerance, axis=1)
        converged[active[done]] = True
        active = active[keep & ~done]
    return y, converged & ~failed, iterations, (y_prev, g_prev)


def _slopes(evaluator: FlowIntegrator, x: np.ndarray, inputs: Inputs, y: np.ndarray, step: float = 0.05) -> np.ndarray:
    """The slope of each valve's ``log F`` at ``y`` along all valves' ``log s`` stepped together
    by ``step`` (a forward difference; the cross terms are small, so it is close to each
    valve's own slope): ``(n, n_valves)``."""
    net = evaluator.problem.network()
    names = [solved_flow_name(k) for k, _, _ in net.solved_valves()]
    outputs = valve_flow_names_of(evaluator.problem)
    base = evaluator.problem.model(x, inputs=dict(inputs) | {name: np.exp(y[:, j]) for j, name in enumerate(names)})
    g0 = np.log(_flow_rms(evaluator, _at_flows(base, names, np.exp(y)), outputs))
    g1 = np.log(_flow_rms(evaluator, _at_flows(base, names, np.exp(y + step)), outputs))
    return (g1 - g0) / step


class FlowStart:
    """A first guess of the valves' log RMS flows from the design alone: a least-squares
    quadratic in the scaled variables (log-scaled where positive) through the fixed points of a fixed 64-point Sobol' sample of the
    box (solved once per load case). A better start saves iterations; the answer is the fixed
    point whatever the start (to far below :data:`FLOW_TOLERANCE`)."""

    def __init__(self, evaluator: FlowIntegrator, inputs: Inputs | None = None):
        from scipy.stats import qmc

        space = evaluator.problem
        self.lower, self.upper = space.lower, space.upper
        unit = qmc.Sobol(len(self.lower), scramble=False).random(64)
        x = self.lower + unit * (self.upper - self.lower)
        given = dict(inputs or {})
        y = np.log(np.array(list(solve_valve_flows(evaluator, x, given)[0].values())).T)
        good = np.all(np.isfinite(y), axis=1)
        self.coefficients = self.slope_coefficients = None
        self.fallback = np.log(INITIAL_FLOW)
        features = self._features(x[good])
        if good.sum() > features.shape[1]:
            slopes = _slopes(evaluator, x[good], given, y[good])
            fit = np.all(np.isfinite(slopes), axis=1)
            self.coefficients = np.linalg.lstsq(features, y[good], rcond=None)[0]
            if fit.sum() > features.shape[1]:
                self.slope_coefficients = np.linalg.lstsq(features[fit], slopes[fit], rcond=None)[0]

    def _features(self, x: np.ndarray) -> np.ndarray:
        positive = (self.lower > 0) & (self.upper > self.lower)  # sizes and pressures act through powers: log scale
        lo = np.where(positive, np.log(np.where(positive, self.lower, 1.0)), self.lower)
        hi = np.where(positive, np.log(np.where(positive, self.upper, 1.0)), self.upper)
        with np.errstate(divide="ignore", invalid="ignore"):
            v = np.where(positive, np.log(np.where(positive, x, 1.0)), x)
        u = (v - lo) / np.where(hi > lo, hi - lo, 1.0)
        pairs = [u[:, i] * u[:, j] for i in range(u.shape[1]) for j in range(i, u.shape[1])]
        return np.column_stack([np.ones(len(x)), u, *pairs])

    def __call__(self, x: np.ndarray, n_valves: int) -> tuple[np.ndarray, np.ndarray]:
        """``log`` of the first flows to try and the slopes to step with, each ``(n, n_valves)``."""
        shape = (len(x), n_valves)
        if self.coefficients is None:
            return np.full(shape, self.fallback), np.full(shape, FIRST_SLOPE)
        features = self._features(x)
        guess = features @ self.coefficients
        slope = features @ self.slope_coefficients if self.slope_coefficients is not None else np.full(shape, FIRST_SLOPE)
        return np.where(np.isfinite(guess), guess, self.fallback), np.where(np.isfinite(slope), slope, FIRST_SLOPE)


def _at_flows(model: CoupledModel, names: list[str], flows: np.ndarray) -> CoupledModel:
    """``model`` with its solved valves linearised at the RMS flows ``flows`` ``(n, len(names))``."""
    assert model.his is not None
    params = dict(model.his.params) | {name: flows[:, j] for j, name in enumerate(names)}
    return replace(model, his=replace(model.his, params=params))


def _flow_rms(evaluator: FlowIntegrator, model: CoupledModel, outputs: list[str]) -> np.ndarray:
    """[m^3/s] The valves' band RMS flows ``(n, len(outputs))`` of a batch of models
    (:func:`band_rms`)."""
    return band_rms(evaluator, model, outputs)


def band_rms(evaluator: FlowIntegrator, model: CoupledModel, outputs: Sequence[str]) -> np.ndarray:
    """The band RMS of ``outputs`` ``(n, len(outputs))`` of a batch of models, NaN for a design
    whose model is unstable, singular, untrusted or not built (an accumulator without oil at
    rest): a batch the linear algebra refuses as a whole (one design's NaN matrix) is done
    design by design, so that one design does not blank the others."""
    assert model.his is not None
    n = int(np.prod(model.his.batch_shape))
    out = np.full((n, len(outputs)), np.nan)
    try:
        groups = model.groups()
    except (ModelError, np.linalg.LinAlgError, ValueError):
        groups = None
    if groups is None:
        if n == 1:
            return out
        for i in range(n):
            out[i] = band_rms(evaluator, model.subset(np.array([i])), outputs)[0]
        return out
    for rows, group in groups:
        try:
            out[rows] = evaluator.output_rms(group, outputs)
        except (np.linalg.LinAlgError, ModelError):
            if len(rows) > 1:
                for j, i in enumerate(np.asarray(rows)):
                    out[i] = band_rms(evaluator, group.subset(np.array([j])), outputs)[0]
    return out
