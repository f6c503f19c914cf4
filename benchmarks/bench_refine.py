"""Gradient refinement of an NSGA-II front: hypervolume gain and seconds per refined design.

The issue's acceptance run: a 40-generation, population-40 NSGA-II on the paper's problem,
then 40 designs spread over its front refined with CasADi/IPOPT on the available cores.
Prints the hypervolume (log10 objectives, the run's reference point) before and after, the
refinement's wall time per design (target: at most 2 s) and the IPOPT work per design. The
first run on a machine also compiles the CasADi model (a few seconds, then cached; see
``hisopt.optim.gradient.casadi_model.compiled``): it is timed separately, before the refinement.

    python benchmarks/bench_refine.py [--pop 40] [--gens 40] [--points 40] [--workers 2] [--seed 1]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import hisopt
from hisopt.optim.gradient.casadi_model import CasadiModel
from hisopt.optim.gradient.refine import refine_front
from hisopt.optim.run import optimize

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--pop", type=int, default=40)
    parser.add_argument("--gens", type=int, default=40)
    parser.add_argument("--points", type=int, default=40)
    parser.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    problem = hisopt.load_problem(args.problem)
    started = time.perf_counter()
    run = optimize(problem, seed=args.seed, pop_size=args.pop, generations=args.gens, algorithm="nsga2")
    print(f"NSGA-II {args.pop} x {args.gens}: {len(run.front)} front designs in {time.perf_counter() - started:.1f} s")

    started = time.perf_counter()
    model = CasadiModel(problem)
    model.fast_node_function(), model.fast_node_function(jacobian=True)
    print(f"CasADi model built and compiled (or loaded from the cache) in {time.perf_counter() - started:.1f} s")

    from hisopt.evaluation.parallel import open_backend

    with open_backend(args.workers if args.workers > 1 else None) as backend:
        result = refine_front(problem, run.front, args.points, backend=backend, reference_log=run.reference_point)
    points = result.points
    print(f"refined {int(points['accepted'].sum())} of {len(points)} designs on {args.workers} worker(s)")
    print(f"hypervolume {result.hypervolume_before:.6g} -> {result.hypervolume_after:.6g} ({100 * result.hypervolume_gain:+.2f} %)")
    print(
        f"wall time {result.wall_time_s:.1f} s: {result.seconds_per_point:.2f} s per design "
        f"(per design in its worker: median {points['seconds'].median():.2f} s, max {points['seconds'].max():.2f} s; "
        f"IPOPT iterations: median {points['iterations'].median():.0f}; NLP rounds: mean {points['rounds'].mean():.1f})"
    )


if __name__ == "__main__":
    main()
