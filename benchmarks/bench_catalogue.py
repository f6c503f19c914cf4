"""What choosing from catalogues costs and how well hisopt searches them (docs/model.md §17.5).

On problems/roll_plane_his_parts.toml (bores, rods, accumulator volumes and hose bores from
the catalogues; precharge and valve continuous), per seed at the same budget:

- hisopt's catalogue run (the default algorithm, choices encoded as places in their lists);
- its continuous relaxation (§17.5: every choice variable continuous over its list's span), run
  with the same settings and measured from the catalogue run's reference point;
- (i) that continuous front snapped to the nearest listed parts and evaluated again:
  "optimise continuously, round afterwards";
- (ii) pymoo's ``MixedVariableGA`` (rank-and-crowding survival, as pymoo's docs pose a
  multi-objective mixed problem; ``Choice`` variables for the lists), each generation
  evaluated as one batch by hisopt's evaluator, every evaluated design archived as hisopt's
  are.

Every front is measured as hisopt's are: the feasible non-dominated designs of all evaluations,
log10 objectives, the catalogue run's reference point. Also designs per CPU second of whole
runs (evaluation, survival, archive): the catalogue run against its continuous relaxation, in
the same process, in turns. Prints the per-seed figures, the medians and the worst.

    python benchmarks/bench_catalogue.py [--seeds 11] [--evaluations 20000] [--pop 100]
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hisopt.optim.catalogue_cost import continuous_relaxation
from hisopt.optim.decision import hypervolume, reference_point
from hisopt.optim.hv_emoa import search_objectives
from hisopt.optim.pymoo_problem import HisoptPymooProblem, feasible_mask
from hisopt.optim.results import OptimizationResult
from hisopt.optim.run import optimize
from hisopt.problem import Problem, load_problem

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "roll_plane_his_parts.toml"


@dataclass
class SeedResult:
    seed: int
    catalogue: float  # [decades^4] hypervolume of hisopt's catalogue run
    continuous: float  # of its continuous relaxation
    snapped: float  # of the relaxation's front snapped to parts and evaluated again
    snapped_feasible: float  # [-] share of the snapped designs still feasible
    mixed: float  # of pymoo's MixedVariableGA
    mixed_evaluations: int
    catalogue_rate: float  # [designs per CPU s] of the catalogue run
    continuous_rate: float  # of its relaxation
    mixed_rate: float  # of the MixedVariableGA run


def front_hypervolume(problem: Problem, x: np.ndarray, reference: np.ndarray) -> tuple[float, np.ndarray]:
    """[decades^n_obj] Hypervolume of the feasible designs among ``x`` (evaluated in one batch)
    and their feasibility mask."""
    pymoo_problem = HisoptPymooProblem(problem)
    f, g = pymoo_problem.f_and_g(pymoo_problem.quantities(x))
    feasible = feasible_mask(g)
    return hypervolume(f[feasible], reference), feasible


def snapped(problem: Problem, x: np.ndarray) -> np.ndarray:
    """[SI] ``x`` with each choice variable at its nearest listed value."""
    out = x.copy()
    for column, listed in problem.choices.items():
        out[:, column] = listed[np.abs(x[:, column, None] - listed[None, :]).argmin(axis=1)]
    return out


def mixed_variable_ga(problem: Problem, seed: int, pop: int, evaluations: int, reference: np.ndarray) -> tuple[float, int, float]:
    """pymoo's ``MixedVariableGA`` on ``problem``: hypervolume of every feasible design it
    evaluated, evaluations, designs per second."""
    from pymoo.algorithms.soo.nonconvex.ga import GA  # noqa: F401 (pymoo's import order)
    from pymoo.core.mixed import MixedVariableGA
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.core.variable import Choice, Real
    from pymoo.operators.survival.rank_and_crowding import RankAndCrowding
    from pymoo.optimize import minimize
    from pymoo.util.display.multi import MultiObjectiveOutput

    names = problem.variable_names
    choices = problem.choices
    variables = {
        name: Choice(options=list(map(float, choices[k]))) if k in choices else Real(bounds=(float(problem.lower[k]), float(problem.upper[k])))
        for k, name in enumerate(names)
    }
    hisopt_problem = HisoptPymooProblem(problem)
    seen: list[tuple[np.ndarray, np.ndarray]] = []

    class Mixed(PymooProblem):
        def __init__(self) -> None:
            super().__init__(vars=variables, n_obj=len(problem.objective_names), n_ieq_constr=hisopt_problem.n_ieq_constr)

        def _evaluate(self, X, out, *args, **kwargs):  # one batch per generation
            x = np.array([[float(d[name]) for name in names] for d in X])
            f, g = hisopt_problem.f_and_g(hisopt_problem.quantities(x))
            seen.append((f, g))
            out["F"], out["G"] = search_objectives(f), g  # log10 objectives, as hisopt's search

    algorithm = MixedVariableGA(pop_size=pop, survival=RankAndCrowding(), output=MultiObjectiveOutput())
    start = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        minimize(Mixed(), algorithm, ("n_evals", evaluations), seed=seed, verbose=False)
    elapsed = time.process_time() - start
    f = np.concatenate([s[0] for s in seen])
    g = np.concatenate([s[1] for s in seen])
    return hypervolume(f[feasible_mask(g)], reference), len(f), len(f) / elapsed


def timed_run(problem: Problem, seed: int, pop: int, generations: int) -> tuple[OptimizationResult, float]:
    """A run in memory and its [s] CPU time (CPU, not wall: other load on the machine moves it less)."""
    start = time.process_time()
    result = optimize(problem, seed=seed, pop_size=pop, generations=generations)
    return result, time.process_time() - start


def one_seed(problem: Problem, seed: int, pop: int, evaluations: int, reference: np.ndarray) -> SeedResult:
    generations = evaluations // pop
    optimizer = problem.spec.optimizer.model_copy(update={"catalogue_cost": False})  # the relaxation is timed on its own
    catalogue_only = type(problem)(problem.spec.model_copy(update={"optimizer": optimizer}), problem.path)
    relaxed = continuous_relaxation(problem)
    # the two runs in turns (odd seeds the catalogue first): a drifting machine moves both alike
    order = (catalogue_only, relaxed) if seed % 2 else (relaxed, catalogue_only)
    runs = {id(p): timed_run(p, seed, pop, generations) for p in order}
    (catalogue, t_catalogue), (continuous, t_continuous) = runs[id(catalogue_only)], runs[id(relaxed)]
    names = list(problem.objective_names)
    hv_continuous = hypervolume(continuous.front[names].to_numpy(dtype=float), reference)  # from the catalogue run's reference
    x = continuous.front[list(problem.variable_names)].to_numpy(dtype=float)
    hv_snapped, feasible = front_hypervolume(problem, snapped(problem, x), reference)
    hv_mixed, n_mixed, mixed_rate = mixed_variable_ga(problem, seed, pop, evaluations, reference)
    return SeedResult(
        seed,
        hypervolume(catalogue.front[names].to_numpy(dtype=float), reference),
        hv_continuous,
        hv_snapped,
        float(feasible.mean()),
        hv_mixed,
        n_mixed,
        len(catalogue.history) / t_catalogue,
        len(continuous.history) / t_continuous,
        mixed_rate,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=11)
    parser.add_argument("--evaluations", type=int, default=20000)
    parser.add_argument("--pop", type=int, default=100)
    args = parser.parse_args()
    problem = load_problem(PROBLEM)
    reference = reference_point(problem)  # computed once, before any run is timed
    optimize(problem, seed=0, pop_size=8, generations=2)  # the compiled kernels and models' first calls, untimed
    print(f"{problem.name}: {args.seeds} seeds x {args.evaluations} evaluations, population {args.pop}")
    print("seed | catalogue | continuous | snapped (feasible) | MixedVariableGA | catalogue / snapped | catalogue / mixed | per CPU s cat / cont / mixed")
    rows = []
    for seed in range(1, args.seeds + 1):
        r = one_seed(problem, seed, args.pop, args.evaluations, reference)
        rows.append(r)
        print(
            f"{seed:4d} | {r.catalogue:.5f} | {r.continuous:.5f} | {r.snapped:.5f} ({100 * r.snapped_feasible:.0f} %) | {r.mixed:.5f} | "
            f"{r.catalogue / r.snapped:.3f} | {r.catalogue / r.mixed:.3f} | {r.catalogue_rate:.0f} / {r.continuous_rate:.0f} / {r.mixed_rate:.0f}",
            flush=True,
        )

    def column(name: str) -> np.ndarray:
        return np.array([getattr(r, name) for r in rows])

    cat, cont, snap, mixed = column("catalogue"), column("continuous"), column("snapped"), column("mixed")
    rate = column("catalogue_rate") / column("continuous_rate")
    print()
    print(f"hypervolume [decades^4], median (worst) over {len(rows)} seeds at {args.evaluations} evaluations:")
    print(f"  hisopt catalogue run               {np.median(cat):.5f} ({cat.min():.5f})")
    print(f"  continuous relaxation              {np.median(cont):.5f} ({cont.min():.5f})   catalogue / continuous {np.median(cat / cont):.3f}")
    print(
        f"  (i) continuous, snapped to parts   {np.median(snap):.5f} ({snap.min():.5f})   catalogue / snapped {np.median(cat / snap):.3f} "
        f"(worst {np.min(cat / snap):.3f})"
    )
    print(
        f"  (ii) pymoo MixedVariableGA         {np.median(mixed):.5f} ({mixed.min():.5f})   catalogue / MixedVariableGA {np.median(cat / mixed):.3f} "
        f"(worst {np.min(cat / mixed):.3f})"
    )
    print(
        f"designs per CPU s, median: catalogue run {np.median(column('catalogue_rate')):.0f}, continuous run {np.median(column('continuous_rate')):.0f} "
        f"(ratio {np.median(rate):.3f}, worst {rate.min():.3f}; goal >= 0.90), MixedVariableGA {np.median(column('mixed_rate')):.0f}"
    )


if __name__ == "__main__":
    main()
