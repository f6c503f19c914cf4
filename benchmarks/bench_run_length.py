"""Does a run's cost per evaluation stay flat as the run gets longer?

Times a 20,000-evaluation run (population 100 x 200 generations) and a 400,000-evaluation
run (100 x 4,000) of the default problem, one after the other in this process, each in a
fresh run directory (checkpoints, history chunks and the final outputs included), and prints
the cost per evaluation (wall and this process's CPU time), the time in the evaluator and the ratio
``t(400k) / (20 x t(20k))`` (issue 28's target: at most 1.2). The numba kernels are compiled
(and the problem loaded) by a short warm-up run first, so neither run pays for them.

Run: ``python benchmarks/bench_run_length.py [--long-gens 4000]``. It takes minutes; the
figures depend on the machine's load (printed).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from hisopt.optim.run import optimize
from hisopt.problem import load_problem

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "roll_plane_his.toml"


def timed_run(problem: object, out: Path, generations: int) -> dict[str, float]:
    """One run in ``out``: wall time, evaluations, evaluator time, front size."""
    start, cpu = time.perf_counter(), time.process_time()
    result = optimize(problem, out=out, pop_size=100, generations=generations, seed=1)  # type: ignore[arg-type]
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    timings = json.loads((out / "run.json").read_text())["timings"]
    return {"wall_s": wall, "cpu_s": cpu, "evaluations": len(result.history), "evaluation_s": timings["evaluation_s"], "front": len(result.front)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short-gens", type=int, default=200)
    parser.add_argument("--long-gens", type=int, default=4000)
    args = parser.parse_args()
    problem = load_problem(PROBLEM)
    print(f"load average before: {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory() as tmp:
        timed_run(problem, Path(tmp) / "warm-up", 3)
        short = timed_run(problem, Path(tmp) / "short", args.short_gens)
        long = timed_run(problem, Path(tmp) / "long", args.long_gens)
    print(f"load average after: {os.getloadavg()[0]:.2f} (1 min)")
    print(f"{'run':>6} {'evaluations':>12} {'wall [s]':>10} {'evaluator [s]':>14} {'rest [s]':>10} {'per evaluation [us]':>20} {'front':>7}")
    for name, r in (("short", short), ("long", long)):
        per, rest = 1e6 * r["wall_s"] / r["evaluations"], r["wall_s"] - r["evaluation_s"]
        print(f"{name:>6} {r['evaluations']:>12} {r['wall_s']:>10.1f} {r['evaluation_s']:>14.1f} {rest:>10.1f} {per:>20.1f} {r['front']:>7}")
    scale = long["evaluations"] / short["evaluations"]
    ratio = long["wall_s"] / (scale * short["wall_s"])
    print(f"ratio t(long) / ({scale:g} x t(short)) = {ratio:.3f} (target <= 1.2)")
    rest = (long["wall_s"] - long["evaluation_s"]) / (scale * (short["wall_s"] - short["evaluation_s"]))
    print(f"same ratio outside the evaluator = {rest:.3f}")
    cpu_short, cpu_long = (1e6 * r["cpu_s"] / r["evaluations"] for r in (short, long))
    print(
        f"CPU time of this process per evaluation: short {cpu_short:.1f} us, long {cpu_long:.1f} us, "
        f"ratio {cpu_long / cpu_short:.3f} (less sensitive to other processes' load than wall time)"
    )


if __name__ == "__main__":
    main()
