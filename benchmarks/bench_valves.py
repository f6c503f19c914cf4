"""Cost of physical damper valves: the RMS-flow fixed point against linear valves.

A damper valve is linearised at the RMS flow the road drives through it, solved with the
response per design and load case (docs/model.md §3.3): each iteration builds the model at
the valves' equivalent resistances and integrates their flows' PSDs. This benchmark times, in
one process with one BLAS thread (least CPU time of ``--repeats``), on random designs of the
same box, per load case (the shipped problem's city road alone: its one-road variant,
``tests/data/valves_one_road.toml``, with ``--problem`` for another file):

- **linear valves** (the baseline): ``problems/roll_plane_his_valves.toml`` with its damper
  valves replaced by linear valves whose resistance ``Rv`` is a design variable over
  1e8-1e10 Pa s/m^3 (the equivalent resistances the damper valves reach), so the same charged
  model, roads, objectives and number of variables;
- **damper valves**: the shipped problem as it is, the fixed point included;
- the fixed point's iterations per design (mean and spread), and its one-off start per load
  case (a fit over a fixed Sobol' sample of the box, amortised over a run).

It prints designs per second per core for each and their ratio (the goal: the valves problem
at most 3x the linear cost per load case).

    python benchmarks/bench_valves.py [--designs 1024] [--repeats 3] [--batch 100]
"""

from __future__ import annotations

import argparse
import os
import time
import tomllib
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "tests" / "data" / "valves_one_road.toml"
VALVE_KEYS = ("orifice_diameter", "discharge_coefficient", "cracking_pressure", "blowoff_resistance")


def problems(path: Path):  # -> (damper valves, linear valves)
    from hisopt.problem import problem_from_dict

    data = tomllib.loads(path.read_text())
    valves = problem_from_dict(data, path.name)
    linear = {**data, "his": {k: v for k, v in data["his"].items() if k not in VALVE_KEYS} | {"Rv": 2e9}}
    linear["variables"] = {k: v for k, v in data["variables"].items() if k not in VALVE_KEYS} | {"Rv": {"lower": 1e8, "upper": 1e10, "unit": "Pa s m^-3"}}
    # as many variables as the valves problem: the cracking pressure's place is taken by Rv_rear
    linear["variables"]["Rv_rear"] = {"lower": 1e8, "upper": 1e10, "unit": "Pa s m^-3"}
    return valves, problem_from_dict(linear, "linear valves")


def first_steps_residual(problem, flow_evaluator, x: np.ndarray, start: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """[-] Each design's fixed-point residual after :data:`FIRST_STEPS` secant steps from
    ``start``: how many designs the evaluator's first evaluation accepts (docs/model.md §3.3)."""
    from hisopt.evaluation.valve_flows import first_steps, flow_residual
    from hisopt.hydraulics.network import solved_flow_name

    y, _ = first_steps(flow_evaluator, x, {}, start)
    names = [solved_flow_name(k) for k, _, _ in problem.network().solved_valves()]
    model = problem.model(x, inputs={name: np.exp(y[:, j]) for j, name in enumerate(names)})
    measured = np.full(y.shape, np.nan)
    for rows, group in model.groups():
        measured[rows] = flow_evaluator.output_rms(group, flow_evaluator.rms_outputs)
    return flow_residual(y, measured)


def best_time(fn: Callable[[], object], repeats: int) -> float:
    """[s] The least CPU time of this process over ``repeats`` calls (after one to warm up):
    per core, and not lengthened by other processes sharing the machine."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=1024)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--batch", type=int, default=100, help="designs per call, as the optimiser sends a generation")
    parser.add_argument("--problem", type=Path, default=PROBLEM, help="a damper-valve problem file (default: the valves problem's city road)")
    args = parser.parse_args()
    from hisopt.evaluation.valve_flows import FIRST_STEPS, FLOW_TOLERANCE, FlowStart, solve_valve_flows

    valves, linear = problems(args.problem)
    rng = np.random.default_rng(0)
    unit = rng.random((args.designs, len(valves.lower)))
    x_valves = valves.lower + unit * (valves.upper - valves.lower)
    x_linear = linear.lower + unit * (linear.upper - linear.lower)
    ev_valves, ev_linear = valves.evaluator(), linear.evaluator()

    def run(evaluator, x):
        return lambda: [evaluator(x[i : i + args.batch]) for i in range(0, len(x), args.batch)]

    t_linear = best_time(run(ev_linear, x_linear), args.repeats)
    t_valves = best_time(run(ev_valves, x_valves), args.repeats)
    t0 = time.perf_counter()
    flow_evaluator = ev_valves._flow_evaluator if hasattr(ev_valves, "_flow_evaluator") else ev_valves.evaluators[0]._flow_evaluator  # noqa: SLF001
    start = FlowStart(flow_evaluator)
    t_start = time.perf_counter() - t0
    guess, slope = start(x_valves, 4)
    _, ok, iterations = solve_valve_flows(flow_evaluator, x_valves, {}, (guess, slope))
    residual = first_steps_residual(valves, flow_evaluator, x_valves, (guess, slope))
    n = args.designs
    cases = len(valves.scenario_names) or 1
    print(f"{n} random designs of {args.problem.name} ({cases} load case(s)), {args.batch} per call, one BLAS thread, least CPU time of {args.repeats}")
    print(f"  linear valves (Rv over 1e8-1e10): {n / t_linear:8.0f} designs/s per core")
    print(f"  damper valves (fixed point):      {n / t_valves:8.0f} designs/s per core")
    print(f"  cost ratio damper / linear:       {t_valves / t_linear:8.2f}x  (goal <= 3x)")
    mean, low, high = iterations.mean(), iterations.min(), iterations.max()
    print(f"  fixed point run to its end (solve_valve_flows, as Problem.model and the sheet): {mean:.2f} iterations per design ({low}-{high})")
    print(f"  converged: {ok.mean():.1%}")
    print(f"  start per load case (once): {t_start * 1e3:.0f} ms; its first-step slopes of log F in log s: {slope.min():.2f} to {slope.max():.2f}")
    within = ", ".join(f"{np.mean(residual <= tol):.1%} within {tol:g}" for tol in (FLOW_TOLERANCE, 1e-3))
    print(f"  after the evaluator's {FIRST_STEPS} secant steps, the residual measured at the designs: {within}")


if __name__ == "__main__":
    main()
