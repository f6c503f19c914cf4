"""Multi-seed studies: independent NSGA runs (in parallel on the backend), fronts merged.

Each seed is a full, resumable run in ``OUT/seed-<n>``; the merged front is the
non-dominated set of the union of the runs' fronts. Runs are deterministic, so a study gives
the same merged front serially or on any Dask cluster.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError
from hisopt.plausibility import seed_count_problem, with_bound_column

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.problem import Problem


@dataclass(frozen=True)
class StudyResult:
    """Merged front (with a ``seed`` column), per-seed summary and merged hypervolume.

    ``front`` and ``runs`` carry their columns' units in ``attrs["units"]``.
    """

    front: pd.DataFrame
    runs: pd.DataFrame
    hypervolume: float
    out: Path | None


def parse_seeds(text: str) -> list[int]:
    """``"1-8"`` or ``"1,3,5"`` (or a mix, ``"1-3,7"``) -> sorted unique seeds, at most
    :data:`hisopt.plausibility.MAX_SEEDS` of them (a larger range is refused before it is built)."""
    seeds: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        lo, sep, hi = part.partition("-")
        try:
            values = range(int(lo), int(hi) + 1) if sep else range(int(part), int(part) + 1)
        except ValueError:
            raise ConfigError(f"expected seeds like 1-8 or 1,3,5, got {text!r}", key="--seeds") from None
        if sep and int(hi) < int(lo):
            raise ConfigError(f"expected an increasing seed range, got {part!r}", key="--seeds")
        too_many = seed_count_problem(len(seeds) + len(values))  # an upper bound of the count: nothing built yet
        if too_many:
            raise ConfigError(too_many, key="--seeds")
        seeds.update(values)
    if not seeds or min(seeds) < 0:
        raise ConfigError(f"expected non-negative seeds, got {text!r}", key="--seeds")
    return sorted(seeds)


SUMMARY_COLUMNS = ("seed", "evaluations", "hypervolume", "wall_time_s", "front_size")
"""Columns of :attr:`StudyResult.runs` (and of each progress report)."""


def _run_seed(seed: int, problem: Problem, out: str | None, pop_size: int | None, generations: int | None) -> dict[str, Any]:
    from hisopt.optim.run import optimize, optimize_or_continue

    if out is None:
        result = optimize(problem, seed=seed, pop_size=pop_size, generations=generations)
    else:  # the same study again continues its runs (a finished one is only read)
        result = optimize_or_continue(problem, Path(out) / f"seed-{seed}", seed, pop_size, generations)
    # only the front leaves the task: the run's history stays in its run directory
    return {
        "seed": seed,
        "front": result.front,
        "hypervolume": result.hypervolume,
        "wall_time_s": result.wall_time_s,
        "evaluations": len(result.history),
        "front_size": len(result.front),
    }


def study(
    problem: Problem,
    seeds: list[int],
    *,
    out: str | Path | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    backend: Backend | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> StudyResult:
    """Run one optimisation per seed (one task each on ``backend``) and merge the fronts.

    Parameters
    ----------
    problem : Problem
        the problem
    seeds : list[int]
        [-] one run per seed
    out : str | Path | None, optional
        study directory (``seed-<n>/`` run directories, merged ``front.csv``, ``runs.csv``);
        the same study again continues its runs (a finished one is only read); a folder of
        another kind, or one with files hisopt did not write, is refused (:func:`hisopt.folders.claim`)
    pop_size, generations : int | None, optional
        [-] overrides of the problem file's optimizer settings
    backend : Backend | None, optional
        where to run (default in-process, one seed after the other)
    progress : Callable[[dict[str, Any]], None] | None, optional
        called as each run finishes with its summary (:data:`SUMMARY_COLUMNS`: seed,
        evaluations, hypervolume [decades^k], wall_time_s [s], front_size)

    Notes
    -----
    The merged front is the non-dominated set of the union of the runs' fronts (of equal
    objective vectors the one of the lowest seed), by :func:`hisopt.optim.archive.non_dominated_mask`
    in ``O(n log^2 n)`` time and ``O(n)`` memory for ``n`` designs in the union.
    """
    from hisopt.evaluation.parallel import Backend
    from hisopt.folders import SEED_STUDY, claim
    from hisopt.io import write_csv
    from hisopt.optim.archive import non_dominated_mask
    from hisopt.optim.decision import hypervolume, reference_point
    from hisopt.units import attach_units

    too_many = seed_count_problem(len(seeds))
    if too_many:
        raise ConfigError(too_many, key="--seeds")
    backend = backend or Backend()
    reference_point(problem)  # a box with no evaluable design says why before OUT is made (cached for the runs here)
    if out is not None:
        claim(out, SEED_STUDY)  # refuses a folder of another kind, or a user's

    def report(_: int, run: dict[str, Any]) -> None:
        if progress is not None:
            progress({k: run[k] for k in SUMMARY_COLUMNS})

    runs = backend.map(_run_seed, seeds, problem, None if out is None else str(out), pop_size, generations, on_result=report)
    summary = pd.DataFrame([{k: r[k] for k in SUMMARY_COLUMNS} for r in runs], columns=list(SUMMARY_COLUMNS))
    union = pd.concat([r.pop("front").assign(seed=r["seed"]) for r in runs], ignore_index=True)
    objectives = list(problem.objective_names)
    merged = union[non_dominated_mask(union[objectives].to_numpy())]
    del union
    merged = merged.sort_values(objectives + ["seed"], kind="stable").reset_index(drop=True)
    hv = hypervolume(merged[objectives].to_numpy(), reference_point(problem))
    attach_units(merged, problem)
    attach_units(summary, problem)
    if out is not None:
        write_csv(with_bound_column(merged, problem), Path(out) / "front.csv")
        write_csv(summary, Path(out) / "runs.csv")
    return StudyResult(merged, summary, hv, None if out is None else Path(out))


def merged_front_equal(a: StudyResult, b: StudyResult) -> bool:
    """Exact equality of two studies' merged fronts (values and order)."""
    return a.front.shape == b.front.shape and bool(np.all(a.front.to_numpy() == b.front.to_numpy()))
