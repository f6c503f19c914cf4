"""Successive halving over candidates: a small budget for all, the full budget for the best
(docs/model.md §20.4; Li et al., Hyperband, JMLR 2018).

A pure module: the rung plan (:func:`halving_plan`) and its application to any scoring
function (:func:`successive_halving`); :func:`hisopt.studies.synthesis.run_synthesis` scores
with the layout study. With ``n`` candidates, ``R`` rungs, a first budget of ``G``
generations and a full budget of ``F`` generations, rung ``r = 1 .. R`` (1-based):

- takes ``n_r = ceil(n / 3**(r - 1))`` candidates: rung 1 every candidate, each later rung
  the best third of the one before, rounded up (so never fewer than one; iterated rounding
  up of a division by 3 equals this closed form), except that the last rung keeps at least
  the best ``min(N, n_(R-1))`` of the rung before (``N`` finalists, default
  :data:`DEFAULT_FINALISTS`: a top ten at the full budget);
- runs each for ``G * 3**(r - 1)`` generations with one seed (the study's first), except
  the last rung, which runs the full budget ``F`` with every seed of the study.

A plan is refused (:class:`hisopt.errors.ConfigError` naming the option) when its last rung
would have no candidate to choose among (the rung before it holds a single candidate:
``n <= 3**(R - 2)``), when the first budget is below one generation, or when a rung before
the last would run the full budget or more (``G * 3**(R - 2) >= F``: it would cost as much as
the last rung and choose less).

The measure is higher-is-better and any ordered value (a float, or a tuple compared
element by element); ties keep the candidates' given order (the screen's).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any

from hisopt.arguments import integer
from hisopt.errors import ConfigError

REDUCTION = 3
"""[-] Each rung keeps ``ceil(1 / REDUCTION)`` of the candidates and multiplies the budget by it."""
DEFAULT_FINALISTS = 10
"""[-] The last rung keeps at least this many candidates (all of the rung before, if fewer)
when no other count is asked for (``--finalists``): the old rule's ten, ranked at the full
budget with their seed spread. Rungs when none are asked for: as many as leave the rung
before the last more finalists than this to choose from (one rung, all at the full budget,
for up to ten candidates)."""
DEFAULT_FIRST_GENERATIONS = 1
"""[generations] The first rung's budget when none is asked for: the first generation, the
population sampled over the box (the same sample for every candidate of one box and seed,
so the first rung compares them on common designs)."""


@dataclass(frozen=True)
class Rung:
    """One rung of a plan.

    Attributes
    ----------
    number : int
        [-] 1-based
    candidates : int
        [-] candidates it runs
    generations : int
        [generations] each run's budget
    seeds : tuple[int, ...]
        [-] the seeds each candidate runs with
    """

    number: int
    candidates: int
    generations: int
    seeds: tuple[int, ...]


def ceil_div(n: int, d: int) -> int:
    """[-] ``ceil(n / d)`` of whole numbers, exactly."""
    return -(-n // d)


def max_rungs(n_candidates: int) -> int:
    """[-] The most rungs ``n_candidates`` allow: the rung before the last must hold at least
    two candidates (``n > 3**(R - 2)``); one rung for one candidate (or none)."""
    rungs = 1
    while n_candidates > REDUCTION ** (rungs - 1):
        rungs += 1
    return rungs


def check_halving_arguments(rungs: int, first_generations: int, full_generations: int) -> None:
    """The plan's own arguments, before any candidate is counted: ``--rungs`` and
    ``--first-gens`` whole numbers >= 1 and every rung before the last below the full budget.

    Raises
    ------
    ConfigError
        As the module docstring says, naming ``--rungs`` or ``--first-gens``.
    """
    integer(rungs, "--rungs", minimum=1, what="rung")
    integer(first_generations, "--first-gens", minimum=1, what="generation")
    if rungs >= 2:
        before_last = first_generations * REDUCTION ** (rungs - 2)
        if before_last >= full_generations:
            raise ConfigError(
                f"--first-gens {first_generations} with --rungs {rungs}: rung {rungs - 1} would run {before_last} generations, "
                f"not below the full budget of {full_generations} (--gens); choose a smaller first budget, fewer rungs or more --gens",
                key="--first-gens",
            )


def halving_plan(
    n_candidates: int, rungs: int, first_generations: int, full_generations: int, seeds: Sequence[int], finalists: int = DEFAULT_FINALISTS
) -> list[Rung]:
    """The rungs of successive halving over ``n_candidates`` (module docstring).

    Parameters
    ----------
    n_candidates : int
        [-] candidates entering the first rung (at least 1)
    rungs : int
        [-] R
    first_generations : int
        [generations] G, the first rung's budget
    full_generations : int
        [generations] F, the last rung's
    seeds : Sequence[int]
        [-] the last rung's seeds; the earlier rungs run the first of them
    finalists : int, optional
        [-] the least the last rung keeps (all of the rung before, if fewer)

    Raises
    ------
    ConfigError
        ``--rungs`` leaving no candidate for the last rung to choose among, a first budget
        below one generation, a rung before the last at the full budget, or fewer than one
        finalist.
    """
    integer(n_candidates, "candidates", minimum=1, what="candidate")
    integer(finalists, "--finalists", minimum=1, what="finalist")
    check_halving_arguments(rungs, first_generations, full_generations)
    if rungs > max_rungs(n_candidates):
        raise ConfigError(
            f"--rungs {rungs} with {n_candidates} candidate{'s' if n_candidates != 1 else ''}: rung {rungs - 1} would hold a single candidate, "
            f"leaving none for rung {rungs} to choose among; at most {max_rungs(n_candidates)} rung{'s' if max_rungs(n_candidates) != 1 else ''}",
            key="--rungs",
        )
    seed_list = tuple(int(s) for s in seeds)
    if not seed_list:
        raise ConfigError("expected at least one seed", key="--seeds")
    plan: list[Rung] = []
    for r in range(1, rungs + 1):
        last = r == rungs
        candidates = ceil_div(n_candidates, REDUCTION ** (r - 1))
        if last and r > 1:
            candidates = max(candidates, min(finalists, plan[-1].candidates))
        plan.append(
            Rung(
                number=r,
                candidates=candidates,
                generations=full_generations if last else first_generations * REDUCTION ** (r - 1),
                seeds=seed_list if last else seed_list[:1],
            )
        )
    return plan


def default_rungs(
    n_candidates: int, full_generations: int | None = None, first_generations: int = DEFAULT_FIRST_GENERATIONS, finalists: int = DEFAULT_FINALISTS
) -> int:
    """[-] The most rungs that leave the rung before the last more than ``finalists``
    candidates (one rung for up to that many): 6 for 2,039 candidates and ten finalists
    (2,039, 680, 227, 76, 26, then the best ten); fewer where a rung before the last would
    reach ``full_generations`` from ``first_generations``."""
    rungs = 1
    while ceil_div(n_candidates, REDUCTION ** (rungs - 1)) > finalists:
        rungs += 1
    while full_generations is not None and rungs >= 2 and first_generations * REDUCTION ** (rungs - 2) >= full_generations:
        rungs -= 1
    return rungs


def default_first_generations(rungs: int, full_generations: int) -> int:
    """[generations] :data:`DEFAULT_FIRST_GENERATIONS`, or less when a rung before the last
    would reach the full budget with it (at least 1: :func:`check_halving_arguments` then
    says what to change)."""
    if rungs < 2:
        return DEFAULT_FIRST_GENERATIONS
    return max(1, min(DEFAULT_FIRST_GENERATIONS, (full_generations - 1) // REDUCTION ** (rungs - 2)))


@dataclass
class HalvingResult:
    """What successive halving did.

    Attributes
    ----------
    plan : list[Rung]
        the rungs
    entrants : list[list[Hashable]]
        per rung, the candidates it ran (in the given order)
    measures : list[dict[Hashable, Any]]
        per rung, each entrant's measure (higher is better)
    ranking : list[Hashable]
        every candidate, best first: those of the last rung by their last measure, then
        those that stopped at each earlier rung, later rungs first, by their measure there
    """

    plan: list[Rung]
    entrants: list[list[Hashable]]
    measures: list[dict[Hashable, Any]]
    ranking: list[Hashable]

    def reached(self, candidate: Hashable) -> int:
        """[-] The last rung ``candidate`` ran in (1-based)."""
        return max(rung.number for rung, names in zip(self.plan, self.entrants, strict=True) if candidate in names)


def best_first(candidates: Sequence[Hashable], measures: dict[Hashable, Any]) -> list[Hashable]:
    """``candidates`` by their measure, highest first; equal measures keep the given order."""
    order = sorted(range(len(candidates)), key=lambda i: measures[candidates[i]], reverse=True)
    # sorted(reverse=True) keeps equal keys in their given order (it is stable)
    return [candidates[i] for i in order]


def successive_halving(candidates: Sequence[Hashable], plan: Sequence[Rung], score: Callable[[list[Hashable], Rung], Sequence[Any]]) -> HalvingResult:
    """Run ``plan`` over ``candidates`` (module docstring).

    Parameters
    ----------
    candidates : Sequence[Hashable]
        distinct candidates, as many as the first rung takes; their order breaks ties
    plan : Sequence[Rung]
        :func:`halving_plan` of ``len(candidates)``
    score : Callable[[list[Hashable], Rung], Sequence[Any]]
        the measure of each of a rung's candidates at its budget and seeds, in their order
        (higher is better); called once per rung, so it may run them all at once

    Raises
    ------
    ValueError
        ``plan`` is not a plan of ``len(candidates)`` distinct candidates, or ``score``
        returns a measure count other than its candidates'.
    """
    names = list(candidates)
    if len(set(names)) != len(names) or not plan or plan[0].candidates != len(names):
        raise ValueError(f"a plan for {plan[0].candidates if plan else 0} candidates given {len(names)} (distinct: {len(set(names))})")
    entrants: list[list[Hashable]] = []
    measures: list[dict[Hashable, Any]] = []
    current = names
    for rung in plan:
        if len(current) != rung.candidates:
            raise ValueError(f"rung {rung.number} expects {rung.candidates} candidates, has {len(current)}")
        values = list(score(list(current), rung))
        if len(values) != len(current):
            raise ValueError(f"score returned {len(values)} measures for {len(current)} candidates")
        measured = dict(zip(current, values, strict=True))
        entrants.append(list(current))
        measures.append(measured)
        if rung.number < len(plan):
            kept = set(best_first(current, measured)[: plan[rung.number].candidates])
            current = [c for c in current if c in kept]  # the given order: ties stay the screen's
    ranking: list[Hashable] = []
    for r in range(len(plan) - 1, -1, -1):
        later = set(entrants[r + 1]) if r + 1 < len(plan) else set()
        ranking += best_first([c for c in entrants[r] if c not in later], measures[r])
    return HalvingResult(list(plan), entrants, measures, ranking)
