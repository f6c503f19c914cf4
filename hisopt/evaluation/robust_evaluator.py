"""A problem's own evaluator: at the nominal inputs, or, with ``[robust] statistic`` or a
chance constraint, statistics over the ``[[uncertain]]`` samples (docs/model.md §18.4).

Every design meets the same ``[robust] samples`` draws from ``[robust] seed`` (common random
numbers), so a design's value is a deterministic, piecewise smooth function of it and an
optimiser compares designs on equal terms. Per column (an objective, a constraint, a
scenario's ``"<quantity>@<scenario>"``):

- ``statistic = "nominal"``: the value at the nominal inputs;
- ``"mean"``: the mean over the samples; ``"mean_plus_k_sigma"``: mean plus ``k`` standard
  deviations (``ddof = 1``). A design the model fails at in any sample is not rated (NaN),
  as in any one load case (docs/model.md §14.3);
- a constraint with a ``probability`` p (a chance constraint, ``P(value > limit) <= p``):
  the order statistic ``q_(N - floor(p N))`` of its samples, which is at most the limit
  exactly when at most ``floor(p N)`` samples exceed it; a failed sample exceeds any limit.

Mean and variance are taken about the first sample (shifted data): exact for samples that
are all equal, so inputs of zero width give the nominal values to the last bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.evaluation.evaluate import Evaluator
from hisopt.evaluation.parallel import DEFAULT_CHUNK, Backend, chunks
from hisopt.evaluation.scenarios import ScenarioEvaluator, case_evaluator_for
from hisopt.evaluation.uncertain import UncertainEvaluator, monte_carlo_variates
from hisopt.robust import quantity_of

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace
    from hisopt.specification.uncertain import Uncertain


def sample_statistic(values: np.ndarray, statistic: str, k: float = 2.0) -> np.ndarray:
    """Per design (row) over its samples (columns): ``mean`` or ``mean_plus_k_sigma``; NaN where
    any sample is NaN."""
    shift = values[:, :1]
    d = values - shift
    mean = shift[:, 0] + np.mean(d, axis=1)
    if statistic == "mean":
        return mean
    spread = np.sqrt(np.sum((d - np.mean(d, axis=1, keepdims=True)) ** 2, axis=1) / max(values.shape[1] - 1, 1))
    return mean + k * spread


def chance_value(values: np.ndarray, probability: float) -> np.ndarray:
    """The order statistic ``q_(N - floor(p N))`` of each row's ``N`` samples (1-based; NaN, a
    failed sample, ranks above every number): at most a limit exactly when at most
    ``floor(p N)`` samples exceed it."""
    n = values.shape[1]
    allowed = int(np.floor(probability * n + 1e-9))  # p N = 3.0000000000000004 allows 3
    ranked = np.sort(np.where(np.isnan(values), np.inf, values), axis=1)
    return ranked[:, n - allowed - 1]


class RobustEvaluator:
    """Columns of a problem with ``[[uncertain]]`` inputs as statistics over its samples
    (module docstring); same call and keys as :class:`~hisopt.evaluation.evaluate.Evaluator`.

    Parameters
    ----------
    space : DesignSpace
        the problem (its ``[robust]`` statistic, samples and seed; its constraints' probabilities)
    inputs : Sequence[Uncertain] | None
        the uncertain inputs (default the problem's ``[[uncertain]]``; a study may pass others,
        e.g. of zero width)
    """

    def __init__(self, space: DesignSpace, inputs: Sequence[Uncertain] | None = None):
        self.space = space
        self.samples = UncertainEvaluator(space, inputs)
        self.case = case_evaluator_for(space)
        self.names = self.case.names
        robust = space.spec.robust
        self.statistic, self.k = robust.statistic, robust.k
        self.variates = monte_carlo_variates(robust.samples, len(self.samples.inputs), robust.seed)
        self.chance = {c.name: c.probability for c in space.spec.constraints if c.probability is not None}

    def __call__(self, designs: Any) -> dict[str, np.ndarray]:
        """Quantities by name, each ``(n,)``, plus ``"valid"`` (every sample evaluated, or with
        ``statistic = "nominal"`` the nominal design)."""
        x = self.space.design_matrix(designs)
        per = self.samples(x, self.variates)
        nominal = self.case(x) if self.statistic == "nominal" else None
        out: dict[str, np.ndarray] = {}
        for name in self.names:
            probability = self.chance.get(name) if quantity_of(name) == name else None
            if probability is not None:
                out[name] = chance_value(per[name], probability)
            elif nominal is not None:
                out[name] = nominal[name]
            else:
                out[name] = sample_statistic(per[name], self.statistic, self.k)
        out["valid"] = nominal["valid"] if nominal is not None else np.all(per["valid"], axis=1)
        return out


def needs_samples(space: DesignSpace) -> bool:
    """Whether ``space``'s columns are statistics over samples (``[robust] statistic`` other
    than nominal, or a chance constraint)."""
    spec = space.spec
    return bool(spec.uncertain) and (spec.robust.statistic != "nominal" or any(c.probability is not None for c in spec.constraints))


def evaluator_for(space: DesignSpace) -> Evaluator | ScenarioEvaluator | RobustEvaluator:
    """The evaluator of ``space``: a :class:`RobustEvaluator` when its columns are statistics
    over samples (:func:`needs_samples`), else the nominal one
    (:func:`hisopt.evaluation.scenarios.case_evaluator_for`); built once and kept with it."""
    if not needs_samples(space):
        return case_evaluator_for(space)
    if "evaluator" not in space._cache:
        space._cache["evaluator"] = RobustEvaluator(space)
    return space._cache["evaluator"]


def _evaluate_chunk(x: np.ndarray, problem: DesignSpace) -> dict[str, np.ndarray]:
    return evaluator_for(problem)(x)


def evaluate_designs(problem: DesignSpace, designs: Any, backend: Backend | None = None, chunk_size: int = DEFAULT_CHUNK) -> dict[str, np.ndarray]:
    """Objectives/constraints of many designs through ``backend`` (same keys as the evaluator
    of :func:`evaluator_for`)."""
    backend = backend or Backend()
    x = problem.design_matrix(designs)
    if not backend.is_distributed:
        return _evaluate_chunk(x, problem)
    parts = backend.map(_evaluate_chunk, [x[s] for s in chunks(len(x), chunk_size)], problem)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
