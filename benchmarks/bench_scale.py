"""A 10^6-design feasible-region sweep, serial against a 2-worker local Dask cluster.

The grid spans two design variables over their bounds (default dA x lam, 1000 x 1000 points,
the others at the baseline), as ``hisopt regions`` does, and evaluates the problem's
objectives for every point. Prints designs/s for both runs, the speed-up and whether the
results are identical (they must be, bit for bit).

    python benchmarks/bench_scale.py [--points 1000] [--pair dA,lam] [--workers 2]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import hisopt
from hisopt.evaluation.parallel import Backend, open_backend
from hisopt.evaluation.robust_evaluator import evaluate_designs

ROOT = Path(__file__).resolve().parents[1]


def grid(problem: hisopt.Problem, pair: tuple[str, str], points: int) -> np.ndarray:
    names = problem.variable_names
    i, j = names.index(pair[0]), names.index(pair[1])
    a = np.linspace(problem.lower[i], problem.upper[i], points)
    b = np.linspace(problem.lower[j], problem.upper[j], points)
    x = np.tile(problem.baseline, (points * points, 1))
    x[:, i] = np.repeat(a, points)
    x[:, j] = np.tile(b, points)
    return x


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--points", type=int, default=1000, help="grid points per axis (1000 -> 10^6 designs)")
    parser.add_argument("--pair", default="dA,lam")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--chunk", type=int, default=8192, help="designs per Dask task")
    args = parser.parse_args()

    problem = hisopt.load_problem(args.problem)
    x = grid(problem, tuple(args.pair.split(",")), args.points)  # type: ignore[arg-type]
    print(f"{len(x):,} designs ({args.pair} grid {args.points}x{args.points}), objectives {', '.join(problem.objective_names)}")

    t0 = time.perf_counter()
    serial = evaluate_designs(problem, x, Backend())
    t_serial = time.perf_counter() - t0
    print(f"serial (1 process)        : {t_serial:8.1f} s  {len(x) / t_serial:10.0f} designs/s")

    with open_backend(workers=args.workers) as backend:
        evaluate_designs(problem, x[:1000], backend, chunk_size=500)  # warm the workers
        t0 = time.perf_counter()
        dist = evaluate_designs(problem, x, backend, chunk_size=args.chunk)
        t_dist = time.perf_counter() - t0
    print(f"Dask, {args.workers} local workers     : {t_dist:8.1f} s  {len(x) / t_dist:10.0f} designs/s")
    print(f"speed-up                  : {t_serial / t_dist:8.2f} x")
    same = all(np.array_equal(serial[k], dist[k], equal_nan=True) for k in serial)
    print(f"identical results         : {same}")


if __name__ == "__main__":
    main()
