"""Cost of the wheel modes of a batch: ``wheel_modes`` against the per-design tables.

``hisopt.coupled.mode_energy.wheel_modes`` names the modes of every design of a batch at once
(one batched eigen-decomposition, the naming on arrays; docs/model.md §8.2). The baseline is
what a rule would do without it: ``modal_analysis`` design by design, reading the four wheel
modes off each table. Both run in one process with one BLAS thread (least CPU time of
``--repeats``) on the same admissible random designs of the problem's box (rods thinner than
70 % of their bores); the baseline on the first ``--loop`` designs, extrapolated per design.
It prints designs per second per core for each, their ratio, and the largest difference
between the two (they must agree).

    python benchmarks/bench_wheel_modes.py [--problem problems/roll_plane_his_parts.toml] [--designs 2000] [--loop 100] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def admissible(problem, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` random designs of the box whose rods are thinner than 70 % of their bores."""
    lo, hi = problem.lower, problem.upper
    x = lo + (hi - lo) * rng.random((8 * n, lo.size))
    if "rod" in problem.variable_names:
        x = x[x[:, problem.variable_names.index("rod")] < 0.7 * x[:, problem.variable_names.index("bore")]]
    return x[:n]


def least_cpu(run, repeats: int) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeats):
        start = time.process_time()
        out = run()
        best = min(best, time.process_time() - start)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his_parts.toml"))
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--loop", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    import hisopt
    from hisopt.coupled.mode_energy import MODE_NAMES, WHEEL_MODE_SLOTS, wheel_modes

    problem = hisopt.load_problem(args.problem)
    x = admissible(problem, args.designs, np.random.default_rng(1))
    names = [MODE_NAMES[k] for k in WHEEL_MODE_SLOTS]

    def batched():
        return wheel_modes(problem.model(x))

    def loop():
        rows = [hisopt.modal_analysis(problem, row).set_index("mode").loc[names, "frequency_hz"].to_numpy(float) for row in x[: args.loop]]
        return np.array(rows)

    t_batch, (frequency, _) = least_cpu(batched, args.repeats)
    t_loop, looped = least_cpu(loop, args.repeats)
    rate_batch, rate_loop = len(x) / t_batch, len(looped) / t_loop
    diff = float(np.max(np.abs(frequency[: len(looped)] / looped - 1)))
    print(f"problem {Path(args.problem).name}: {len(x)} designs (loop on {len(looped)}), one BLAS thread, least CPU of {args.repeats}")
    print(f"  wheel_modes (batched)         {rate_batch:10.0f} designs/s   ({t_batch:.3f} s)")
    print(f"  modal_analysis per design     {rate_loop:10.0f} designs/s   ({t_loop:.3f} s)")
    print(f"  ratio batched / per design    {rate_batch / rate_loop:10.1f}")
    print(f"  largest relative difference   {diff:10.2e}")
    print(f"  wheel-mode frequencies [Hz]: min {frequency.min():.2f}, median {np.median(frequency):.2f}, max {frequency.max():.2f}")


if __name__ == "__main__":
    main()
