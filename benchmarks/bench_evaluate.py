"""Evaluator throughput on one core: the new evaluator, today's, and a plain baseline, side by side.

Three ways to the same quantities, timed in one run on the same designs, each in a fresh
process of its own as a user would run it (one BLAS thread, best of ``--repeats``), with each
one's largest relative error against a converged reference (a direct solve on a fine
pole-clustered grid, :mod:`hisopt.evaluation.reference`) on random designs and box corners:

- **new**: :class:`hisopt.evaluation.evaluate.Evaluator` (symmetric halves, compiled pole-residue
  kernel, error-controlled panels, parabolic peak search);
- **today's**: ``benchmarks/legacy_evaluate.py``, the evaluator before this work, frozen (it
  imports nothing from hisopt; benchmarks/README.md says what it shares with the new one);
  also shown with the memory allocator primed as the new evaluator primes it (one 16 MB block
  freed at start, :func:`hisopt.evaluation.evaluate._prime_allocator`), to show how much of the
  difference that alone makes;
- **plain baseline**: the batched direct solve on a 1000-point log grid with trapezoid
  integrals and sample maxima (:func:`hisopt.evaluation.reference.grid_quantities`).

Then the distributed-pipe problem (no exact state space: the direct solve on the nodes the
lumped twin's poles place), new against today's.

    python benchmarks/bench_evaluate.py [--designs 2000] [--repeats 7]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PIPES = {"diameter": 0.01, "length_front": 1.0, "length_rear": 2.5}
Method = Callable[[np.ndarray], dict[str, np.ndarray]]


def problem_for(path: str, distributed: bool):  # -> hisopt.Problem
    import hisopt

    problem = hisopt.load_problem(path)
    return problem.with_values(pipes=PIPES, pipe_model="distributed") if distributed else problem


def method(name: str, problem) -> Method:  # noqa: ANN001
    """The method ``name`` on ``problem``, ready to evaluate design matrices."""
    if name == "new":
        from hisopt.evaluation.evaluate import Evaluator

        return Evaluator(problem)
    if name.startswith("today's"):
        sys.path.insert(0, str(ROOT / "benchmarks"))
        import legacy_evaluate

        if name.endswith("primed"):
            from hisopt.evaluation.evaluate import _prime_allocator

            _prime_allocator()
        return legacy_evaluate.Evaluator(problem)
    from hisopt.evaluation.reference import grid_quantities
    from hisopt.linalg import one_blas_thread

    band = problem.spec.band
    grid = np.geomspace(band.f_min_hz, band.f_max_hz, 1000)

    def baseline(x: np.ndarray) -> dict[str, np.ndarray]:
        with one_blas_thread():
            return grid_quantities(problem, x, grid)

    return baseline


def designs(problem, n: int) -> np.ndarray:  # noqa: ANN001
    rng = np.random.default_rng(0)
    return problem.lower + (problem.upper - problem.lower) * rng.random((n, len(problem.lower)))


def worker(args: argparse.Namespace) -> None:
    """Time one method in this process and print its rate as JSON."""
    problem = problem_for(args.problem, args.distributed)
    fn = method(args.worker, problem)
    x = designs(problem, args.designs)
    fn(x[:8])  # warm-up: compiled kernels load from their cache
    best = np.inf
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        fn(x)
        best = min(best, time.perf_counter() - t0)
    print(json.dumps({"rate": args.designs / best}))


def rate(name: str, args: argparse.Namespace, n: int, distributed: bool = False) -> float:
    """[designs/s] ``name`` timed in a fresh process."""
    cmd = [sys.executable, __file__, "--worker", name, "--problem", args.problem, "--designs", str(n), "--repeats", str(args.repeats)]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    out = subprocess.run(cmd + (["--distributed"] if distributed else []), capture_output=True, text=True, env=env, check=True)
    return float(json.loads(out.stdout.strip().splitlines()[-1])["rate"])


def errors(problem, names: list[str], check: np.ndarray) -> dict[str, float]:  # noqa: ANN001
    """Largest relative error of any quantity against the converged reference, per method."""
    from hisopt.evaluation.reference import converged_grid, grid_quantities

    quantities = list(dict.fromkeys(problem.objective_names + problem.constraint_names))
    parts = [grid_quantities(problem, c[None], converged_grid(problem, c), chunk_size=1) for c in check]
    ref = {k: np.array([p[k][0] for p in parts]) for k in quantities}
    out = {}
    for name in names:
        values = method(name, problem)(check)
        out[name] = max(float(np.max(np.abs(values[k] / ref[k] - 1))) for k in quantities)
    return out


def check_designs(problem, x: np.ndarray) -> np.ndarray:  # noqa: ANN001
    corners = np.array(np.meshgrid(*[[0, 1]] * x.shape[1], indexing="ij")).reshape(x.shape[1], -1).T
    return np.vstack([x[:4], problem.lower + (problem.upper - problem.lower) * corners[[0, 3, 5, 10, 12, 15]]])


def report(title: str, rates: dict[str, float], error: dict[str, float]) -> None:
    print(title)
    print(f"  {'method':24s} {'designs/s':>10s} {'new is':>8s} {'max rel. error':>15s}")
    for name, r in rates.items():
        e = error.get(name.removesuffix(", allocator primed"), float("nan"))
        print(f"  {name:24s} {r:10.0f} {rates['new'] / r:7.2f}x {e:15.1e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--distributed", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args)

    problem = problem_for(args.problem, False)
    names = ["new", "today's", "today's, allocator primed", "plain baseline"]
    sizes = {"plain baseline": min(args.designs, 200)}  # the baseline is slow: timed on fewer designs
    rates = {name: rate(name, args, sizes.get(name, args.designs)) for name in names}
    print(f"problem: {problem.name} ({', '.join(problem.objective_names)}), {args.designs} random designs in the box, one core")
    x = designs(problem, args.designs)
    report("lumped HIS (exact state space):", rates, errors(problem, ["new", "today's", "plain baseline"], check_designs(problem, x)))

    pipes = problem_for(args.problem, True)
    n_pipes = min(args.designs, 300)
    rates = {name: rate(name, args, n_pipes, distributed=True) for name in ("new", "today's")}
    report(f"distributed pipes (direct solve on the nodes), {n_pipes} designs:", rates, errors(pipes, ["new", "today's"], check_designs(pipes, x)[:5]))


if __name__ == "__main__":
    main()
