"""What the hardware quantities cost the evaluator, each against its baseline in the same run.

1. The accumulators' swing (docs/model.md §16.9): the charged envelope problem on one road,
   without and with an ``accumulator_swing`` constraint (its outputs ride on the same poles
   and residues).
2. Catalogue choices (docs/model.md §17.3): decoding a population's search coordinates to
   listed parts, against evaluating it, on problems/roll_plane_his_parts.toml.

CPU seconds (one core), best of ``--repeats``.

    python benchmarks/bench_hardware_costs.py [--designs 3000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np

from hisopt.optim.pymoo_problem import HisoptPymooProblem
from hisopt.problem import load_problem, problem_from_dict

ROOT = Path(__file__).resolve().parents[1]


def best_cpu(call, repeats: int, *args) -> float:
    """[s] The least CPU time of ``repeats`` calls ``call(*args)``."""
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        call(*args)
        best = min(best, time.process_time() - start)
    return best


def envelope_on_one_road(swing: bool):
    data = tomllib.loads((ROOT / "problems" / "roll_plane_his_envelope.toml").read_text())
    for key in ("scenarios", "robust"):
        data.pop(key)
    data["constraints"] = [{"name": "accumulator_swing", "limit": 0.5}] if swing else []
    with warnings.catch_warnings():  # the file's -20 C case extrapolates the oil (gone with the scenarios)
        warnings.simplefilter("ignore")
        return problem_from_dict(data)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(0)

    # the same designs for both, timed in turns (a drifting machine moves both alike)
    problems = {swing: envelope_on_one_road(swing) for swing in (False, True)}
    box = problems[False]
    x = box.lower + rng.random((args.designs, len(box.lower))) * (box.upper - box.lower)
    evaluators = {swing: p.evaluator() for swing, p in problems.items()}
    for evaluator in evaluators.values():
        evaluator(x[:50])  # compile and warm up
    best = dict.fromkeys(evaluators, np.inf)
    for _ in range(args.repeats):
        for swing, evaluator in evaluators.items():
            best[swing] = min(best[swing], best_cpu(evaluator, 1, x))
    rates = {swing: args.designs / seconds for swing, seconds in best.items()}
    print(
        f"envelope problem, one road, {args.designs} designs: {rates[False]:,.0f} designs/s without the swing, "
        f"{rates[True]:,.0f} with it (ratio {rates[True] / rates[False]:.3f})"
    )

    problem = load_problem(ROOT / "problems" / "roll_plane_his_parts.toml")
    adapter = HisoptPymooProblem(problem)
    u = adapter.xl + (adapter.xu - adapter.xl) * rng.random((100, len(adapter.xl)))
    x = adapter.decode(u)
    evaluator = problem.evaluator()
    evaluator(x)
    decode = best_cpu(lambda: [adapter.decode(u) for _ in range(1000)], args.repeats) / 1000
    evaluate = best_cpu(lambda: evaluator(x), args.repeats)
    print(f"parts problem, 100 designs: decoding {decode * 1e6:.1f} us, evaluating {evaluate * 1e3:.1f} ms CPU (share {decode / evaluate:.1e})")


if __name__ == "__main__":
    main()
