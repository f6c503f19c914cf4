"""``hisopt verify``'s cost: one design over the robust problem's four load cases on one core.

Times :func:`hisopt.simulation.verification.verify_design` (every load case's road pairs in
both models, causes, manoeuvres) at the default R and T (the issue's budget: 60 s on one
core), and, as the straightforward baseline of the same run, the first load case's roads
simulated one at a time (:func:`hisopt.simulation.timedomain.simulate`) against the same roads
in one batch (:func:`~hisopt.simulation.timedomain.simulate_batch`)::

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_verify.py [--problem problems/roll_plane_his_robust.toml]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the budget says
os.environ.setdefault("OMP_NUM_THREADS", "1")

from hisopt.problem import load_problem  # noqa: E402
from hisopt.simulation.timedomain import Nonlinearities, simulate, simulate_batch  # noqa: E402
from hisopt.simulation.verification import load_cases, road_grid, road_pairs, verify_design  # noqa: E402
from hisopt.simulation.verification_rows import VerifySettings  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default="problems/roll_plane_his_robust.toml")
    args = parser.parse_args()
    problem = load_problem(args.problem)
    x = problem.design_matrix(problem.baseline)
    settings = VerifySettings()

    start, cpu = time.perf_counter(), time.process_time()
    verification = verify_design(problem, x, "baseline", settings)
    wall, used = time.perf_counter() - start, time.process_time() - cpu
    chosen = ", ".join(f"{c.traces.case} R={c.realisations}" for c in verification.cases)
    print(f"verify_design, {len(verification.cases)} load cases ({chosen}), T = {settings.duration_s:g} s + {settings.settle_s:g} s settling:")
    print(f"  {wall:.1f} s wall, {used:.1f} s CPU (budget 60 s on one core); verdict {verification.verdict}")

    name, case = load_cases(problem)[0]
    model = case.model(x)
    t = road_grid(case, settings)
    roads = road_pairs(case, t, settings, 0, 0, settings.first_realisations)
    switches = Nonlinearities(tyre_liftoff=True)
    start = time.process_time()
    simulate_batch(model, t, roads, "nonlinear", interpolation="cubic", method="RK45", rtol=settings.rtol, nonlinearities=switches)
    batched = time.process_time() - start
    start = time.process_time()
    for road in roads:
        simulate(model, t, road, "nonlinear", tyre_liftoff=True, interpolation="cubic", method="RK45", rtol=settings.rtol)
    one_by_one = time.process_time() - start
    print(f"{name}: {len(roads)} nonlinear records of {t[-1]:.0f} s: one at a time {one_by_one:.1f} s CPU,")
    print(f"  in one batch {batched:.1f} s ({one_by_one / batched:.1f}x)")


if __name__ == "__main__":
    main()
