"""Cost of the buildability rules (docs/model.md §21) against the objectives alone.

Every rule in every load case adds the road's swing of each chamber's and accumulator's
pressure and of each strut's stroke rate (more outputs through the same poles and residues),
a static cornering solve, and the wheel modes (one more eigendecomposition with vectors).
This benchmark times, in one process with one BLAS thread (least CPU time of ``--repeats``),
on the same random designs of the flagship problem's box (``problems/his_buildable.toml``,
seven load cases, damper valves solved per case):

- **objectives alone** (the baseline): the problem without its constraints;
- **with every rule**: the problem as shipped (ten rules and two accumulator constraints);
- **the verdict** of :func:`hisopt.studies.buildability.buildability`, as the views compute it
  for a front (every rule's value and limit in every load case).

It prints designs per second per core for each and their ratios.

    python benchmarks/bench_buildability.py [--designs 512] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import time
import tomllib
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "his_buildable.toml"


def least_cpu(run, repeats: int) -> float:
    """[s] Least CPU time of ``repeats`` calls of ``run``."""
    best = np.inf
    for _ in range(repeats):
        t = time.process_time()
        run()
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=512)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--problem", type=Path, default=PROBLEM)
    args = parser.parse_args()

    import warnings

    from scipy.stats import qmc

    from hisopt.problem import problem_from_dict
    from hisopt.studies.buildability import buildability

    warnings.simplefilter("ignore")
    data = tomllib.loads(args.problem.read_text())
    ruled = problem_from_dict(data, args.problem.name, warn_implausible=False)
    bare = problem_from_dict({**data, "constraints": []}, "objectives alone", warn_implausible=False)
    x = ruled.lower + qmc.Sobol(len(ruled.lower), seed=0).random(args.designs) * (ruled.upper - ruled.lower)
    x = ruled.design_matrix(x)
    for p in (bare, ruled):  # compile, and fit each load case's start of the valves' fixed point
        p.evaluate(x[:8], log=False)
    buildability(ruled, x[:8])
    times = {
        "objectives alone": least_cpu(lambda: bare.evaluate(x, log=False), args.repeats),
        "with every rule": least_cpu(lambda: ruled.evaluate(x, log=False), args.repeats),
        "the verdict (views)": least_cpu(lambda: buildability(ruled, x), args.repeats),
    }
    base = times["objectives alone"]
    print(f"{args.problem.name}: {args.designs} designs, {len(ruled.scenario_names) or 1} load cases, one core")
    for name, t in times.items():
        print(f"  {name:22s} {args.designs / t:8.0f} designs/s   {t:7.2f} s CPU   {t / base:5.2f} x the objectives alone")


if __name__ == "__main__":
    main()
