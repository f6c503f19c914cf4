"""What standard parts cost (docs/model.md §17.5): a problem whose variables choose from lists
is optimised a second time with every such variable continuous between its first and last
listed value (its *continuous relaxation*), with the same settings, and both fronts are
measured from the catalogue run's hypervolume reference point.

The relaxation runs after the catalogue run, in memory: it is deterministic (same seed, same
settings), so a run interrupted during it resumes by running it again.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING

import hisopt.interrupt as interrupt
from hisopt.optim.decision import hypervolume
from hisopt.optim.engine import Engine
from hisopt.optim.results import CatalogueCost, ProgressFn
from hisopt.specification.config import Variable

if TYPE_CHECKING:
    import pandas as pd

    from hisopt.problem import Problem


def has_choices(problem: Problem) -> bool:
    """[-] Some variable of ``problem`` chooses from a list."""
    return any(v.choices is not None for v in problem.spec.variables.values())


def wants_catalogue_cost(problem: Problem) -> bool:
    """[-] A run of ``problem`` also runs its continuous relaxation: it has choices and its
    ``[optimizer] catalogue_cost`` is on."""
    return has_choices(problem) and problem.spec.optimizer.catalogue_cost


def continuous_relaxation(problem: Problem) -> Problem:
    """``problem`` with every choice variable continuous between its first and last value
    (its unit and description kept); the other variables and the whole model unchanged."""
    variables = {
        name: v if v.choices is None else Variable(lower=v.lower, upper=v.upper, unit=v.unit, description=v.description)
        for name, v in problem.spec.variables.items()
    }
    return type(problem)(problem.spec.model_copy(update={"variables": variables}), problem.path)


def catalogue_cost(engine: Engine, catalogue: float, progress: ProgressFn | None = None) -> tuple[CatalogueCost, pd.DataFrame]:
    """The catalogue run ``engine``'s front (hypervolume ``catalogue`` [decades^n_obj], the
    run's result) against its continuous relaxation's, and that front.

    The relaxation is run with ``engine``'s settings and reference point; ``progress``
    receives its generations counted on from the catalogue run's.
    """
    started = time.perf_counter()
    relaxed = Engine(continuous_relaxation(engine.problem), engine.settings, engine.reference_log)
    offset = engine.generation
    while not relaxed.done:
        interrupt.hook_point(f"relaxation-{relaxed.generation + 1}")
        stats = relaxed.step()
        if stats is not None and progress is not None:
            progress(replace(stats, generation=offset + stats.generation, generations=offset + stats.generations))
    cost = CatalogueCost(
        catalogue=catalogue,
        continuous=hypervolume(relaxed.archive.f, relaxed.reference_log),
        evaluations=relaxed.evaluations,
        front_size=len(relaxed.archive),
        wall_time_s=time.perf_counter() - started,
    )
    return cost, relaxed.front()
