"""Gradient refinement of a front: seconds per refined design and hypervolume gain, the batched
SLP (the default) against CasADi/IPOPT (the previous default) on the same front.

The issue's acceptance run: a 40-generation, population-40 NSGA-II on the paper's problem,
then 40 designs spread over its front refined by each method in the same process, in this
process (no workers; pin it with ``taskset -c 0`` on a shared machine). The script prints
wall and CPU seconds per design for each, their ratio, the hypervolume (log10 objectives, the
run's reference point) before and after, how many designs each improved, and checks that
no refined design is worse than its start in any objective. The first IPOPT refinement on a
machine also compiles the CasADi model (a few seconds, then cached; see
``hisopt.optim.gradient.casadi_model.compiled``): it is done, and timed, before the runs.

    python benchmarks/bench_refine.py [--pop 40] [--gens 40] [--points 40] [--seed 1]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

import hisopt
from hisopt.optim.gradient.refine import RefineResult, refine_front
from hisopt.optim.run import optimize

ROOT = Path(__file__).resolve().parents[1]


def timed(method: str, problem: hisopt.Problem, front: Any, points: int, reference: np.ndarray) -> tuple[RefineResult, float, float]:
    """[-, s, s] The refinement by ``method`` with its wall and CPU time."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = refine_front(problem, front, max_points=points, method=method, reference_log=reference)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def never_worse(problem: hisopt.Problem, front: Any, result: RefineResult) -> bool:
    """Every refined design is no worse than its start in any objective."""
    names = list(problem.objective_names)
    start = front[names].to_numpy(dtype=float)[result.front["source_index"].to_numpy()]
    return bool(np.all(result.front[names].to_numpy(dtype=float) <= start))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--pop", type=int, default=40)
    parser.add_argument("--gens", type=int, default=40)
    parser.add_argument("--points", type=int, default=40)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    problem = hisopt.load_problem(args.problem)
    run = optimize(problem, seed=args.seed, pop_size=args.pop, generations=args.gens, algorithm="nsga2")
    print(f"{problem.name}: NSGA-II {args.pop} x {args.gens}, front of {len(run.front)} designs; refining {min(args.points, len(run.front))}")
    started = time.perf_counter()
    for method in ("slp", "ipopt"):  # compile and warm both before any clock
        refine_front(problem, run.front, max_points=1, method=method, reference_log=run.reference_point)
    print(f"warm-up (CasADi compile on a first run, numba kernels): {time.perf_counter() - started:.1f} s")
    rows = {}
    for method in ("ipopt", "slp"):
        result, wall, cpu = timed(method, problem, run.front, args.points, run.reference_point)
        n = len(result.points)
        rows[method] = (wall / n, cpu / n)
        print(
            f"{method:5s}: {wall / n:.3f} s wall, {cpu / n:.3f} s CPU per design; hypervolume {result.hypervolume_before:.6g} -> "
            f"{result.hypervolume_after:.6g} ({100 * result.hypervolume_gain:+.2f} %), {int(result.points['accepted'].sum())} of {n} "
            f"designs improved, none worse than its start: {never_worse(problem, run.front, result)}"
        )
    print(f"SLP against IPOPT: {rows['ipopt'][0] / rows['slp'][0]:.1f}x less wall time, {rows['ipopt'][1] / rows['slp'][1]:.1f}x less CPU per design")


if __name__ == "__main__":
    main()
