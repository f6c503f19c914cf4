"""Manoeuvres' cost and figures: the paper's robust problem's baseline over its load cases.

For each load case, :func:`hisopt.simulation.manoeuvres.manoeuvre_table` (the step steer, the
sine with dwell and the half-sine bump, each linear and nonlinear) is timed on one core
(CPU time) with the linear runs alone as the baseline of the same run; the table's main
figures are printed, linear against nonlinear (docs/model.md §22.4)::

    python benchmarks/bench_manoeuvres.py [--problem problems/roll_plane_his_robust.toml]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hisopt.problem import load_problem
from hisopt.simulation.manoeuvres import manoeuvre_table, manoeuvres_of, simulate_manoeuvre

SHOWN = ("peak_roll", "roll_overshoot", "peak_roll_rate", "max_chamber_pressure", "peak_strut_force", "peak_stroke", "roll_ratio_1s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default="problems/roll_plane_his_robust.toml")
    args = parser.parse_args()
    problem = load_problem(args.problem)
    manoeuvre_table(problem.scenario_space(problem.scenario_names[0]) if problem.scenario_names else problem)  # warm the caches
    for name in problem.scenario_names or ("",):
        case = problem.scenario_space(name) if name else problem
        model = case.model(case.design_matrix(case.baseline))
        gravity = bool(case.spec.handling.gravity_moment)
        start = time.process_time()
        for manoeuvre in manoeuvres_of(case):
            simulate_manoeuvre(model, manoeuvre, "linear", gravity)
        linear = time.process_time() - start
        start = time.process_time()
        table = manoeuvre_table(case)
        total = time.process_time() - start
        print(f"\n{name or case.spec.name}: {total:.2f} s CPU for the table, linear runs alone {linear:.2f} s ({total / linear:.1f}x)")
        for row in table[table.figure.isin(SHOWN)].itertuples():
            gap = row.nonlinear / row.linear - 1.0
            transient = "" if np.isnan(row.transient) else f"  transient {row.transient:.6g}"
            print(f"  {row.manoeuvre:16s} {row.figure:22s} [{row.unit:5s}] linear {row.linear:11.6g}  nonlinear {row.nonlinear:11.6g}  ({gap:+.2%}){transient}")


if __name__ == "__main__":
    main()
