"""Cost of load cases: six road/speed scenarios against one, shared model against separate ones.

Scenarios that differ only in the road and the speed share the model, its poles and its
residues (docs/model.md §14.4); only the road's PSD, the wheelbase delay and the quadrature
nodes differ. This benchmark times, in one process with one BLAS thread (best of
``--repeats``), on the same random designs of the default problem:

- **one scenario**: city, class C at 10 m/s;
- **six scenarios, shared**: classes A-D at 10-33 m/s in one scenario problem;
- **six scenarios, separately**: the six single-case problems one after another (the
  straightforward baseline: six models, six eigendecompositions);
- **two payload states**: an empty and a laden scenario (each with its own model), both in
  one scenario problem;
- **the shipped robust problem** (``problems/roll_plane_his_robust.toml``: four load cases, two
  models, a step steer constrained in the laden case), as evaluated, and with the step steer
  computed for the empty car's model too (what a model does when a scenario it serves asks
  for it), to show what skipping it saves.

    python benchmarks/bench_scenarios.py [--designs 2000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import copy
import os
import time
import tomllib
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SIX = [
    ("city", "C", 10.0),
    ("suburb", "C", 15.0),
    ("rural", "B", 20.0),
    ("rough", "D", 8.0),
    ("country", "B", 25.0),
    ("motorway", "A", 33.0),
]


def problem_with(scenarios: list[dict]):  # -> hisopt.Problem
    from hisopt.problem import problem_from_dict

    data = tomllib.loads((ROOT / "problems" / "roll_plane_his.toml").read_text())
    data = copy.deepcopy(data)
    if scenarios:
        data["scenarios"] = scenarios
    return problem_from_dict(data)


def best_time(fn: Callable[[], object], repeats: int) -> float:
    fn()  # warm up: compiled kernels, caches
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        fn()
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    roads = [{"name": n, "road": {"class": c, "speed": v}} for n, c, v in SIX]
    one = problem_with(roads[:1])
    six = problem_with(roads)
    separate = [problem_with([r]) for r in roads]
    laden = problem_with([roads[0], {"name": "laden", "road": roads[0]["road"], "payload": {"mass": 300.0, "x": -0.6, "z": 0.2}}])
    import hisopt

    robust = hisopt.load_problem(ROOT / "problems" / "roll_plane_his_robust.toml")
    robust_all = hisopt.load_problem(ROOT / "problems" / "roll_plane_his_robust.toml")
    for ev in robust_all.evaluator().evaluators:  # type: ignore[union-attr]
        ev.unread = frozenset()
    rng = np.random.default_rng(2026)
    x = one.lower + rng.random((args.designs, len(one.lower))) * (one.upper - one.lower)

    rows = [
        ("one scenario (city C, 10 m/s)", lambda: one.evaluator()(x)),
        ("six road/speed scenarios, shared model", lambda: six.evaluator()(x)),
        ("six single-case problems, separately", lambda: [p.evaluator()(x) for p in separate]),
        ("empty + laden (two models)", lambda: laden.evaluator()(x)),
        ("robust problem (4 load cases, 2 models)", lambda: robust.evaluator()(x)),
        ("robust, step steer for both models", lambda: robust_all.evaluator()(x)),
    ]
    base = None
    print(f"{args.designs} random designs of the default problem, one BLAS thread, best of {args.repeats}")
    print(f"{'method':42s} {'time [s]':>9s} {'designs/s':>10s} {'cost vs one [-]':>16s}")
    for label, fn in rows:
        t = best_time(fn, args.repeats)
        base = base or t
        print(f"{label:42s} {t:9.3f} {args.designs / t:10.0f} {t / base:16.2f}")

    shared, alone = six.evaluator()(x), [p.evaluator()(x) for p in separate]
    err = max(float(np.nanmax(np.abs(shared[f"{q}@{name}"] / alone[k][q] - 1))) for k, (name, _, _) in enumerate(SIX) for q in six.spec.objectives)
    print(f"largest relative difference, shared against separate: {err:.1e} [-]")


if __name__ == "__main__":
    main()
