"""Evaluator throughput on one core: the new evaluator, today's, and a plain baseline, side by side.

Three ways to the same quantities, timed in one run on the same designs (interleaved, best of
``--repeats``, one BLAS thread), with each one's largest relative error against a converged
reference (a direct solve on a fine pole-clustered grid, :mod:`hisopt.reference`) on random
designs and box corners:

- **new**: :class:`hisopt.evaluate.Evaluator` (symmetric halves, compiled pole-residue
  kernel, error-controlled panels, parabolic peak search);
- **today's**: ``benchmarks/legacy_evaluate.py``, the evaluator before this work, kept as the
  reference path;
- **plain baseline**: the batched direct solve on a 1000-point log grid with trapezoid
  integrals and sample maxima (:func:`hisopt.reference.grid_quantities`).

Then the distributed-pipe problem (no exact state space: the direct solve on the nodes the
lumped twin's poles place), new against today's.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_evaluate.py [--designs 2000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import hisopt
from hisopt.evaluate import Evaluator
from hisopt.linalg import one_blas_thread
from hisopt.reference import converged_grid, grid_quantities

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import legacy_evaluate  # noqa: E402

Method = Callable[[np.ndarray], dict[str, np.ndarray]]


def methods(problem: hisopt.Problem) -> dict[str, Method]:
    band = problem.spec.band
    grid = np.geomspace(band.f_min_hz, band.f_max_hz, 1000)
    new, legacy = Evaluator(problem), legacy_evaluate.Evaluator(problem)

    def baseline(x: np.ndarray) -> dict[str, np.ndarray]:
        with one_blas_thread():
            return grid_quantities(problem, x, grid)

    return {"new": new, "today's": legacy, "plain baseline": baseline}


def rates(named: dict[str, Method], designs: dict[str, np.ndarray], repeats: int) -> dict[str, float]:
    """[designs/s] Best of ``repeats`` interleaved runs of each method on its designs."""
    for name, fn in named.items():
        fn(designs[name][:8])  # warm-up (compiled kernels load from their cache)
    best = dict.fromkeys(named, np.inf)
    for _ in range(repeats):
        for name, fn in named.items():
            t0 = time.perf_counter()
            fn(designs[name])
            best[name] = min(best[name], time.perf_counter() - t0)
    return {name: len(designs[name]) / best[name] for name in named}


def errors(problem: hisopt.Problem, named: dict[str, Method], check: np.ndarray) -> dict[str, float]:
    """Largest relative error of any quantity against the converged reference, per method."""
    names = list(dict.fromkeys(problem.objective_names + problem.constraint_names))
    parts = [grid_quantities(problem, c[None], converged_grid(problem, c), chunk_size=1) for c in check]
    ref = {k: np.array([p[k][0] for p in parts]) for k in names}
    return {m: max(float(np.max(np.abs(fn(check)[k] / ref[k] - 1))) for k in names) for m, fn in named.items()}


def check_designs(problem: hisopt.Problem, x: np.ndarray) -> np.ndarray:
    corners = np.array(np.meshgrid(*[[0, 1]] * x.shape[1], indexing="ij")).reshape(x.shape[1], -1).T
    return np.vstack([x[:4], problem.lower + (problem.upper - problem.lower) * corners[[0, 3, 5, 10, 12, 15]]])


def report(title: str, rate: dict[str, float], error: dict[str, float]) -> None:
    print(title)
    print(f"  {'method':16s} {'designs/s':>11s} {'new is':>8s} {'max rel. error':>15s}")
    for name, r in rate.items():
        print(f"  {name:16s} {r:11.0f} {rate['new'] / r:7.2f}x {error.get(name, float('nan')):15.1e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    args = parser.parse_args()

    problem = hisopt.load_problem(args.problem)
    rng = np.random.default_rng(0)
    x = problem.lower + (problem.upper - problem.lower) * rng.random((args.designs, len(problem.lower)))
    named = methods(problem)
    n_base = min(args.designs, 200)  # the baseline is slow; timed on fewer designs
    rate = rates(named, {"new": x, "today's": x, "plain baseline": x[:n_base]}, args.repeats)
    print(f"problem: {problem.name} ({', '.join(problem.objective_names)}), {args.designs} random designs in the box")
    report("lumped HIS (exact state space):", rate, errors(problem, named, check_designs(problem, x)))

    pipes = problem.with_values(pipes={"diameter": 0.01, "length_front": 1.0, "length_rear": 2.5}, pipe_model="distributed")
    named = {k: v for k, v in methods(pipes).items() if k != "plain baseline"}
    n_pipes = min(args.designs, 300)
    rate = rates(named, {"new": x[:n_pipes], "today's": x[:n_pipes]}, max(1, args.repeats // 2))
    report(f"distributed pipes (direct solve on the nodes), {n_pipes} designs:", rate, errors(pipes, named, check_designs(pipes, x)[:5]))


if __name__ == "__main__":
    main()
