"""Throughput of the fast evaluator against a straightforward one, side by side.

Baseline: batched ``numpy.linalg.solve`` of the 7-DOF dynamic stiffness on a plain 1000-point
log grid (0.5-80 Hz), trapezoid integrals and sample maxima, same objectives
(``hisopt.evaluate.grid_quantities``). Fast: ``problem.evaluate`` (pole-residue evaluation on
a pole-aware Gauss-Legendre grid with refined maxima). Also prints each method's largest
relative error against a converged reference on a few designs, so speed is never bought with
accuracy.

    python benchmarks/bench_evaluate.py [--designs 2000] [--problem problems/roll_plane_his.toml]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import hisopt
from hisopt.evaluate import Evaluator, grid_quantities
from hisopt.quadrature import base_edges

ROOT = Path(__file__).resolve().parents[1]


def converged_grid(problem: hisopt.Problem, x: np.ndarray) -> np.ndarray:
    """[Hz] a very fine grid: dense log spacing plus tan-clustered points around every mode."""
    band = problem.spec.band
    lam = np.linalg.eigvals(problem.model(x[None]).state_space().a[0])
    parts = [np.geomspace(band.f_min_hz, band.f_max_hz, 100_001)]
    theta = np.linspace(-np.pi / 2, np.pi / 2, 8001)[1:-1]
    for pole in lam[lam.imag > 1e-6]:
        f_d, b = pole.imag / (2 * np.pi), max(-pole.real / (2 * np.pi), 1e-9)
        parts.append(f_d + b * np.tan(theta))
    f = np.concatenate(parts)
    return np.unique(f[(f >= band.f_min_hz) & (f <= band.f_max_hz)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    problem = hisopt.load_problem(args.problem)
    rng = np.random.default_rng(0)
    x = problem.lower + (problem.upper - problem.lower) * rng.random((args.designs, len(problem.lower)))
    band = problem.spec.band
    grid = np.geomspace(band.f_min_hz, band.f_max_hz, 1000)
    evaluator = Evaluator(problem)
    evaluator(x[:8])  # warm-up

    def best_of(fn) -> float:
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times)

    n_base = min(args.designs, 400)  # the baseline is slow; time it on a subset
    t_fast = best_of(lambda: evaluator(x))
    t_base = best_of(lambda: grid_quantities(problem, x[:n_base], grid))
    fast_rate, base_rate = args.designs / t_fast, n_base / t_base
    print(f"problem: {problem.name}, objectives: {', '.join(evaluator.names)}")
    print(f"fast evaluator     : {fast_rate:10.0f} designs/s  ({args.designs} designs, best of {args.repeats})")
    print(f"baseline (1000-pt) : {base_rate:10.0f} designs/s  ({n_base} designs, best of {args.repeats})")
    print(f"speed-up           : {fast_rate / base_rate:10.1f} x")

    # Accuracy against a converged reference, including the box corners.
    corners = np.array(np.meshgrid(*[[0, 1]] * x.shape[1], indexing="ij")).reshape(x.shape[1], -1).T
    check = np.vstack([x[:4], problem.lower + (problem.upper - problem.lower) * corners[[0, 5, 10, 15]]])
    ref = {k: np.concatenate([grid_quantities(problem, c[None], converged_grid(problem, c))[k] for c in check]) for k in evaluator.names}
    fast = evaluator(check)
    base = grid_quantities(problem, check, grid)
    for name in evaluator.names:
        e_fast = np.max(np.abs(fast[name] / ref[name] - 1))
        e_base = np.max(np.abs(base[name] / ref[name] - 1))
        print(f"max rel. error {name:18s}: fast {e_fast:8.1e}   baseline {e_base:8.1e}")
    print(f"nodes per design (fast): {base_edges(band.f_min_hz, band.f_max_hz).size} base edges + pole panels")


if __name__ == "__main__":
    main()
