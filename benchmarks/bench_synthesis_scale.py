"""Synthesis at scale: the K = 10 full-car robust search, measured per task and projected.

Enumerates and screens every mirror-symmetric layout of the eight chambers with at most K
parts on the robust problem (``problems/roll_plane_his_robust.toml``), builds the default
successive-halving plan over the screened-in candidates (:mod:`hisopt.studies.halving`), then
times, for each rung, a layout study of a few sampled candidates at that rung's budget and
seeds (serial, this process: the per-candidate cost of a rung's tasks, roll_plane's included
as one more candidate). The projected time of the whole search is the sum over rungs of its
candidates times that cost, on one core and on N workers (ideal division: the tasks are
independent; the driver's enumeration and screening are added once). The straightforward
baseline, in the same run: the old rule's cost, every screened-in candidate at the full budget
with every seed (what ranking them all without halving would take). ``--run`` also runs the
whole search with ``hisopt synthesize`` and reports its wall time::

    python benchmarks/bench_synthesis_scale.py [--max-elements 10] [--sample 2] [--run OUT --workers 2]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from hisopt.hydraulics import topology
from hisopt.problem import load_problem
from hisopt.studies.halving import default_first_generations, default_rungs, halving_plan
from hisopt.studies.layout_study import run_layout_study, study_budget
from hisopt.studies.synthesis import STATUS_SCREENED_IN, candidate_problem_data, screening_frame

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "roll_plane_his_robust.toml"
WORKERS = (1, 2, 8, 32)


def _candidate_files(problem, enumeration: topology.Enumeration, picks: list[int], folder: Path) -> list[str]:
    import tomli_w

    files = []
    for i in picks:
        path = folder / f"c{i}.toml"
        path.write_bytes(tomli_w.dumps(candidate_problem_data(problem, enumeration, i)).encode())
        files.append(str(path))
    return files


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-elements", type=int, default=10)
    parser.add_argument("--sample", type=int, default=2, help="candidates timed per rung")
    parser.add_argument("--run", type=Path, default=None, help="also run the whole search into this folder")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args()
    problem = load_problem(PROBLEM)

    start = time.perf_counter()
    enumeration = topology.enumerate_layouts(args.max_elements, "all", True)
    frame = screening_frame(problem, enumeration)
    screening_s = time.perf_counter() - start
    screened = frame.index[frame["status"] == STATUS_SCREENED_IN].tolist()
    budget = study_budget(problem, None, None)
    seeds = (1, 2, 3)
    rungs = default_rungs(len(screened), budget["generations"])
    plan = halving_plan(len(screened), rungs, default_first_generations(rungs, budget["generations"]), budget["generations"], seeds)
    print(f"K = {args.max_elements}: {len(enumeration.candidates)} candidates, {len(screened)} screened in; enumerate and screen {screening_s:.1f} s")
    print(f"population {budget['pop_size']}, full budget {budget['generations']} generations, seeds {seeds}; {rungs} rungs")

    cost = {}
    with tempfile.TemporaryDirectory() as tmp:
        picks = [int(i) for i in screened[: args.sample]]
        files = _candidate_files(problem, enumeration, picks, Path(tmp))
        for rung in plan:
            start = time.perf_counter()
            last = rung.number == len(plan)  # early rungs rank the sampled designs, as hisopt synthesize does
            run_layout_study(problem, files, rung.seeds, pop_size=budget["pop_size"], generations=rung.generations, refine_method="ipopt" if last else "none")
            cost[rung.number] = (time.perf_counter() - start) / (len(files) + 1)  # roll_plane is one more candidate
            runs = f"{rung.candidates:>5} candidates x {len(rung.seeds)} seed(s) at {rung.generations:>3} generations"
            print(f"  rung {rung.number}: {runs}: {cost[rung.number]:6.1f} s per candidate")
    halving_s = sum((rung.candidates + 1) * cost[rung.number] for rung in plan)
    last = plan[-1]
    everyone_s = (len(screened) + 1) * cost[last.number]
    print(f"projected, halving: {halving_s / 60:.1f} min of CPU;")
    print(f"  every candidate at the full budget (the baseline): {everyone_s / 3600:.1f} h ({everyone_s / halving_s:.0f}x)")
    for n in WORKERS:
        print(f"  on {n:>2} worker(s): halving {(screening_s + halving_s / n) / 60:7.1f} min, baseline {(screening_s + everyone_s / n) / 3600:6.2f} h")

    if args.run is not None:
        command = [sys.executable, "-m", "hisopt", "synthesize", str(PROBLEM), "--max-elements", str(args.max_elements), "--out", str(args.run)]
        if args.workers:
            command += ["--workers", str(args.workers)]
        start = time.perf_counter()
        subprocess.run(command, check=True)
        print(f"the whole search: {(time.perf_counter() - start) / 60:.1f} min wall")


if __name__ == "__main__":
    main()
