"""The layout study's equal-handling NLP: the batched SLP (now) against IPOPT on CasADi's
virtual machine and IPOPT on compiled C (before), on the six catalogue layouts.

Each layout of the paper's problem starts at its baseline design, the limit at that design's
own roll gradient (docs/model.md §15.4, ``tests/test_equal_handling_nlp.py``). For each
method the script prints the refined ``sigma_aw``, its difference from IPOPT's in decades and
the wall and CPU seconds (the compiled path's CPU includes the C compiler, a child process:
it compiles into a fresh cache folder, as a new machine or a new layout would), then the
totals and the ratios against the compiled path. Pin it with ``taskset -c 0`` on a shared
machine.

    python benchmarks/bench_equal_handling.py [--problem problems/roll_plane_his.toml]
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import hisopt
from hisopt.evaluation.evaluate import roll_gradient
from hisopt.hydraulics.catalogue import CATALOGUE_NAMES
from hisopt.optim.gradient.asf_nlp import RefineSettings
from hisopt.optim.gradient.refine import refine_constrained
from hisopt.studies.layout_cases import catalogue_case

ROOT = Path(__file__).resolve().parents[1]
METHODS = (("ipopt_vm", {"method": "ipopt"}), ("ipopt_compiled", {"method": "ipopt", "compile": True}), ("slp", {"method": "slp"}))


def cpu_seconds() -> float:
    """[s] CPU time of this process and its finished children (the C compiler)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    args = parser.parse_args()
    os.environ["HISOPT_CACHE_DIR"] = tempfile.mkdtemp(prefix="hisopt-bench-cache-")
    problem = hisopt.load_problem(args.problem)
    totals = {name: [0.0, 0.0] for name, _ in METHODS}
    print(f"{'layout':30s} {'method':15s} {'sigma_aw':>12s} {'vs IPOPT dec':>12s} {'wall s':>8s} {'CPU s':>8s}")
    for layout in CATALOGUE_NAMES:
        case = catalogue_case(problem, layout).problem
        x0 = case.baseline.copy()
        limit = float(roll_gradient(case.model(x0[None, :]), case.spec.handling.gravity_moment)[0])
        sigma = {}
        for name, options in METHODS:
            settings = RefineSettings(rounds=8) if options["method"] == "ipopt" else None
            wall, cpu = time.perf_counter(), cpu_seconds()
            point = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, settings, **options)
            wall, cpu = time.perf_counter() - wall, cpu_seconds() - cpu
            totals[name][0] += wall
            totals[name][1] += cpu
            sigma[name] = point.quantities["sigma_aw"]
            diff = np.log10(sigma[name] / sigma["ipopt_vm"])  # [decades]
            print(f"{layout:30s} {name:15s} {sigma[name]:12.9f} {diff:+12.2e} {wall:8.2f} {cpu:8.2f}", flush=True)
    base_wall, base_cpu = totals["ipopt_compiled"]
    for name, (wall, cpu) in totals.items():
        print(f"total {name:15s} wall {wall:8.1f} s  CPU {cpu:8.1f} s  (compiled/this: wall {base_wall / wall:5.1f}x, CPU {base_cpu / cpu:5.1f}x)")


if __name__ == "__main__":
    main()
