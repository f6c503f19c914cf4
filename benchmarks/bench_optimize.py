"""hisopt's NSGA run against Optuna's NSGA-II sampler on the same problem and budget.

Both methods get the same evaluation budget (default 10,000 designs) on the same problem and
call the same hisopt evaluator: hisopt evaluates a generation in one vectorised call, Optuna
evaluates one design per trial (its ask/tell loop proposes one trial at a time). Both are
judged the same way: the archive of every feasible design evaluated, reduced to its
non-dominated set (Optuna's Pareto set is its archive of all trials, so archive is compared
with archive), and its hypervolume with log10-scaled objectives and the problem's fixed
reference point (:func:`hisopt.optim.decision.reference_point`). Wall times are in-process
(imports excluded); hisopt's includes its reference-point grid (625 extra evaluations that
only serve reporting) since that is part of every ``hisopt.optimize`` call.

    python benchmarks/bench_optimize.py [--problem problems/roll_plane_his.toml]
        [--evaluations 10000] [--pop 100] [--seed 1] [--seeds 1]

Hypervolume varies by a few per cent from seed to seed for either method; ``--seeds 3``
compares means.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

import hisopt
from hisopt.optim import decision
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.pymoo_problem import HisoptPymooProblem, feasible_mask
from hisopt.optim.run import optimize
from hisopt.optim.settings import resolve_settings

ROOT = Path(__file__).resolve().parents[1]


def archive_front(f: np.ndarray, feasible: np.ndarray) -> np.ndarray:
    """[objective units] Non-dominated set of the feasible rows of ``f`` (n, k)."""
    f = f[feasible & np.all(np.isfinite(f), axis=1)]
    return f[non_dominated_mask(f)]


def run_hisopt(problem: hisopt.Problem, pop: int, generations: int, seed: int) -> tuple[float, np.ndarray, int]:
    """Wall time [s], archive front and evaluation count of ``hisopt.optimize``."""
    t0 = time.perf_counter()
    result = optimize(problem, pop_size=pop, generations=generations, seed=seed)
    wall = time.perf_counter() - t0
    return wall, result.front[list(problem.objective_names)].to_numpy(), len(result.history)


def run_optuna(problem: hisopt.Problem, pop: int, trials: int, seed: int) -> tuple[float, np.ndarray, int]:
    """Wall time [s], archive front and evaluation count of Optuna's NSGA-II sampler."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.ERROR)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    adapter = HisoptPymooProblem(problem)
    evaluator = problem.evaluator()
    names, lower, upper = problem.variable_names, problem.lower, problem.upper
    constraint_keys = (*problem.constraint_names, "invalid") if problem.constraint_names else ()
    records: list[tuple[np.ndarray, bool]] = []

    def objective(trial: optuna.Trial) -> tuple[float, ...]:
        x = np.array([[trial.suggest_float(n, lo, hi) for n, lo, hi in zip(names, lower, upper, strict=True)]])
        f, g = adapter.f_and_g(evaluator(x))
        records.append((f[0], bool(feasible_mask(g)[0])))
        for key, value in zip(constraint_keys, g[0], strict=True):  # value / limit - 1 <= 0, as for hisopt
            trial.set_constraint(key, float(value))
        if not np.all(np.isfinite(f)):
            return tuple(float("nan") for _ in f[0])  # Optuna marks the trial failed
        return tuple(float(v) for v in f[0])

    sampler = optuna.samplers.NSGAIISampler(population_size=pop, seed=seed)
    t0 = time.perf_counter()
    study = optuna.create_study(directions=["minimize"] * len(problem.objective_names), sampler=sampler)
    study.optimize(objective, n_trials=trials)
    wall = time.perf_counter() - t0
    f = np.array([r[0] for r in records])
    feasible = np.array([r[1] for r in records])
    return wall, archive_front(f, feasible), len(study.trials)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--problem", type=Path, default=ROOT / "problems" / "roll_plane_his.toml")
    parser.add_argument("--evaluations", type=int, default=10_000)
    parser.add_argument("--pop", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1, help="first seed")
    parser.add_argument("--seeds", type=int, default=1, help="seeds seed, seed+1, ...: hypervolume varies with the seed")
    args = parser.parse_args()
    if args.seeds < 1 or args.evaluations < args.pop:
        parser.error("expected --seeds >= 1 and --evaluations >= --pop")
    problem = hisopt.load_problem(args.problem)
    generations = args.evaluations // args.pop
    algorithm = resolve_settings(problem, pop_size=args.pop, generations=generations).algorithm.upper()
    print(f"problem {problem.name}: {len(problem.objective_names)} objectives, {len(problem.constraint_names)} constraints")
    print(f"budget {generations * args.pop} evaluations, population {args.pop}")
    print()
    print(f"{'method':<24}{'seed':>5}{'evaluations':>12}{'wall time [s]':>15}{'evals/s':>10}{'front size':>12}{'hypervolume':>14}")
    totals = {"hisopt": [0.0, 0.0], "optuna": [0.0, 0.0]}  # wall time, hypervolume
    for seed in range(args.seed, args.seed + args.seeds):
        h_wall, h_front, h_evals = run_hisopt(problem, args.pop, generations, seed)
        reference = decision.reference_point(problem)  # cached by hisopt's run (the first one paid for it)
        o_wall, o_front, o_evals = run_optuna(problem, args.pop, generations * args.pop, seed)
        rows = (
            ("hisopt", f"hisopt {algorithm}", h_evals, h_wall, h_front),
            ("optuna", "optuna NSGAIISampler", o_evals, o_wall, o_front),
        )
        for key, name, evals, wall, front in rows:
            hv = decision.hypervolume(front, reference)
            totals[key][0] += wall
            totals[key][1] += hv
            print(f"{name:<24}{seed:>5}{evals:>12}{wall:>15.2f}{evals / wall:>10.0f}{len(front):>12}{hv:>14.6f}", flush=True)
    (h_wall, h_hv), (o_wall, o_hv) = totals["hisopt"], totals["optuna"]
    print()
    print(f"hypervolume reference point (log10 of {', '.join(problem.objective_names)}): {np.round(reference, 4).tolist()}")
    print(
        f"over {args.seeds} seed(s): speed-up (optuna wall / hisopt wall) {o_wall / h_wall:.1f}x, "
        f"mean hypervolume hisopt {h_hv / args.seeds:.6f}, optuna {o_hv / args.seeds:.6f}, "
        f"ratio {h_hv / o_hv if o_hv > 0 else float('inf'):.4f}"
    )


if __name__ == "__main__":
    main()
