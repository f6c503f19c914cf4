"""Algorithm settings of an optimisation run: the problem file's ``[optimizer]`` table plus
overrides, and the pymoo algorithm they describe (hisopt's SMS-EMOA up to four objectives,
NSGA-III above; NSGA-II on request).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from hisopt.errors import ConfigError

if TYPE_CHECKING:
    from hisopt.problem import Problem

AlgorithmName = Literal["nsga2", "nsga3", "smsemoa"]
Until = Literal["generations", "converged"]
UNTIL_CHOICES = ("generations", "converged")
DEFAULT_TOLERANCE = 1e-3
"""[-] ``until = "converged"``: relative progress-hypervolume gain over the window below which a run stops."""
DEFAULT_WINDOW = 20
"""[generations] ``until = "converged"``: the generations the gain is measured over."""
AlgorithmChoice = Literal["auto", "nsga2", "nsga3", "smsemoa"]
SMSEMOA_MAX_OBJECTIVES = 4
"""``algorithm = "auto"`` picks hisopt's SMS-EMOA up to this many objectives and NSGA-III
above: exact hypervolume contributions cost milliseconds up to four objectives and far more
beyond (``benchmarks/bench_hv_survival.py``)."""


@dataclass(frozen=True)
class RunSettings:
    """Algorithm settings of a run (problem file ``[optimizer]`` plus overrides).

    Attributes
    ----------
    algorithm : AlgorithmName
        [-] ``"nsga2"`` or ``"nsga3"`` (``"auto"`` already resolved)
    pop_size : int
        [-] population size (and offspring per generation)
    generations : int
        [-] generations including the initial one
    seed : int
        [-] random seed of the algorithm
    until : Until
        [-] ``"generations"`` (run them all) or ``"converged"`` (stop when the progress
        hypervolume gained at most ``tolerance`` of itself over ``window`` generations;
        ``generations`` is the cap; :mod:`hisopt.optim.convergence`)
    tolerance : float
        [-] relative gain of the convergence stop
    window : int
        [generations] window of the convergence stop
    """

    algorithm: AlgorithmName
    pop_size: int
    generations: int
    seed: int
    until: Until = "generations"
    tolerance: float = DEFAULT_TOLERANCE
    window: int = DEFAULT_WINDOW

    @property
    def evaluations(self) -> int:
        """[-] Nominal evaluation budget ``pop_size * generations``."""
        return self.pop_size * self.generations


def resolve_settings(
    problem: Problem,
    *,
    algorithm: AlgorithmChoice | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    seed: int | None = None,
    until: str | None = None,
) -> RunSettings:
    """Settings from the problem file, each overridable (``None`` keeps the file's value).

    Raises
    ------
    ConfigError
        An override is out of range or the population is too small for NSGA-III.
    """
    spec = problem.spec.optimizer
    choice = spec.algorithm if algorithm is None else algorithm
    if choice not in ("auto", "nsga2", "nsga3", "smsemoa"):
        raise ConfigError(f"unknown algorithm {choice!r}; expected auto, nsga2, nsga3 or smsemoa", key="--algorithm")
    pop = spec.pop_size if pop_size is None else pop_size
    gens = spec.generations if generations is None else generations
    rng_seed = spec.seed if seed is None else seed
    if not isinstance(pop, int) or pop < 4:
        raise ConfigError(f"expected a population size >= 4, got {pop!r}", key="--pop")
    if not isinstance(gens, int) or gens < 1:
        raise ConfigError(f"expected generations >= 1, got {gens!r}", key="--gens")
    if not isinstance(rng_seed, int) or rng_seed < 0:
        raise ConfigError(f"expected a seed >= 0, got {rng_seed!r}", key="--seed")
    stop = spec.until if until is None else until
    if stop not in UNTIL_CHOICES:
        raise ConfigError(f"unknown stop rule {stop!r}; expected generations or converged", key="--until")
    n_obj = len(problem.objective_names)
    name: AlgorithmName = ("smsemoa" if n_obj <= SMSEMOA_MAX_OBJECTIVES else "nsga3") if choice == "auto" else choice
    if name == "nsga3" and pop < n_obj:
        raise ConfigError(f"NSGA-III needs a population of at least {n_obj} (one per objective), got {pop}", key="--pop")
    return RunSettings(name, pop, gens, rng_seed, stop, spec.tolerance, spec.window)  # type: ignore[arg-type]


def das_dennis_partitions(n_obj: int, pop_size: int) -> int:
    """[-] Most Das-Dennis partitions whose ``C(p + m - 1, m - 1)`` directions fit ``pop_size``."""
    p = 1
    while math.comb(p + 1 + n_obj - 1, n_obj - 1) <= pop_size:
        p += 1
    return p


def searches_in_log(algorithm: AlgorithmName) -> bool:
    """[-] The algorithm is handed ``log10`` of the objectives (:mod:`hisopt.optim.hv_emoa`);
    NSGA-II/III keep the linear objectives they always had, so old runs resume identically."""
    return algorithm == "smsemoa"


def build_algorithm(settings: RunSettings, n_obj: int) -> Any:
    """A fresh pymoo NSGA-II, NSGA-III or hisopt's SMS-EMOA for ``settings`` (not yet set up).

    NSGA-III uses Das-Dennis reference directions, as many as fit the population (84 for
    four objectives and 100 individuals).
    """
    if settings.algorithm == "smsemoa":
        from hisopt.optim.hv_emoa import build_hv_emoa

        return build_hv_emoa(settings.pop_size)
    if settings.algorithm == "nsga2":
        from pymoo.algorithms.moo.nsga2 import NSGA2

        return NSGA2(pop_size=settings.pop_size)
    from pymoo.algorithms.moo.nsga3 import NSGA3
    from pymoo.operators.selection.tournament import TournamentSelection
    from pymoo.util.ref_dirs import get_reference_directions

    ref_dirs = get_reference_directions("das-dennis", n_obj, n_partitions=das_dennis_partitions(n_obj, settings.pop_size))
    return NSGA3(ref_dirs, pop_size=settings.pop_size, selection=TournamentSelection(func_comp=_compare_cv_then_random))


def _compare_cv_then_random(pop: Any, P: np.ndarray, random_state: np.random.Generator, **kwargs: Any) -> np.ndarray:
    """NSGA-III tournament: smaller constraint violation wins, ties drawn from the run's RNG.

    pymoo's own ``comp_by_cv_then_random`` breaks equal violations without passing the
    random state (it fails then); this is the same rule with the state passed.
    """
    winners = np.empty(len(P), dtype=int)
    for i, (a, b) in enumerate(P):
        cv_a, cv_b = pop[a].CV[0], pop[b].CV[0]
        if (cv_a > 0.0 or cv_b > 0.0) and cv_a != cv_b:
            winners[i] = a if cv_a < cv_b else b
        else:
            winners[i] = random_state.choice([a, b])
    return winners[:, None]
