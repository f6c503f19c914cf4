"""Synthesis at scale: the K = 10 full-car robust search, measured per task and projected.

Enumerates and screens every mirror-symmetric layout of the eight chambers with at most K
parts on the robust problem (``problems/roll_plane_his_robust.toml``), builds the default
successive-halving plan over the screened-in candidates (:mod:`hisopt.studies.halving`), then
times, for each rung, a layout study of a few sampled candidates at that rung's budget and
seeds and one of roll_plane alone (serial, this process): the study's own cost, and per
candidate the difference the sample makes. The projected time of the whole search is the
sum over rungs of its candidates times that cost, on one core and on N workers: a rung's
runs divided among the workers (they are independent tasks), an early rung's tables (each
candidate's stiffness table and buildability verdict) in the driver, the last rung's (mostly
its refinements, tasks too) divided, each study's own cost and the enumeration and screening
once. The straightforward
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
from dataclasses import replace
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

    def timed(files: list[str], rung) -> tuple[float, float]:
        """[s] A layout study of ``files`` and roll_plane at ``rung``'s budget: its runs, then its
        tables (the driver's stiffness tables and verdicts, the last rung's refinements)."""
        ended: list[float] = []
        start = time.perf_counter()
        run_layout_study(
            problem,
            files,
            rung.seeds,
            pop_size=budget["pop_size"],
            generations=rung.generations,
            refine_method="ipopt" if rung.number == len(plan) else "none",  # as hisopt synthesize does
            progress=lambda _: ended.append(time.perf_counter()),
        )
        return ended[-1] - start, time.perf_counter() - ended[-1]

    # per rung [s]: the study's own cost (roll_plane, the normalisation) once, and per candidate
    # the difference a study of the sample makes, split into its runs (parallel) and tables (serial)
    fixed, runs_cost, tables_cost = {}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        picks = [int(i) for i in screened[: args.sample]]
        files = _candidate_files(problem, enumeration, picks, Path(tmp))
        timed(["roll_plane"], plan[0])  # warm: imports, roll_plane's reference point and normalisation (cached)
        for rung in plan:
            alone, sample = timed(["roll_plane"], rung), timed(files, rung)
            fixed[rung.number] = alone
            runs_cost[rung.number] = max(sample[0] - alone[0], 0.0) / len(files)
            tables_cost[rung.number] = max(sample[1] - alone[1], 0.0) / len(files)
            seeds = f"{len(rung.seeds)} seed{'s' if len(rung.seeds) > 1 else ' '}"
            runs = f"{rung.candidates:>5,} candidates x {seeds} at {rung.generations:>3} generation{'s' if rung.generations != 1 else ' '}"
            print(
                f"  rung {rung.number}: {runs}: {runs_cost[rung.number]:6.2f} s of runs + {tables_cost[rung.number]:5.2f} s of tables per candidate "
                f"(the study itself {sum(alone):5.1f} s)"
            )

    def projected(workers: int, rungs: list) -> float:
        """[s] The rungs on ``workers``: each study's own cost once, the candidates' runs divided
        among the workers, their tables in the driver; the last rung's tables are mostly its
        refinements, tasks on the workers too."""

        def per_candidate(g) -> float:
            if g.number == len(plan):
                return (runs_cost[g.number] + tables_cost[g.number]) / workers
            return runs_cost[g.number] / workers + tables_cost[g.number]

        return sum(sum(fixed[g.number]) + g.candidates * per_candidate(g) for g in rungs)

    last = plan[-1]
    baseline = [replace(last, candidates=len(screened))]  # every candidate at the full budget, every seed
    halving_s, everyone_s = projected(1, plan), projected(1, baseline)
    print(f"projected, halving: {halving_s / 60:.1f} min of CPU;")
    print(f"  every candidate at the full budget (the baseline): {everyone_s / 3600:.1f} h ({everyone_s / halving_s:.0f}x)")
    for n in WORKERS:
        halving_n, everyone_n = screening_s + projected(n, plan), screening_s + projected(n, baseline)
        print(f"  on {n:>2} worker(s): halving {halving_n / 60:7.1f} min, baseline {everyone_n / 3600:6.2f} h")

    if args.run is not None:
        command = [sys.executable, "-m", "hisopt", "synthesize", str(PROBLEM), "--max-elements", str(args.max_elements), "--out", str(args.run)]
        if args.workers:
            command += ["--workers", str(args.workers)]
        start = time.perf_counter()
        subprocess.run(command, check=True)
        print(f"the whole search: {(time.perf_counter() - start) / 60:.1f} min wall")


if __name__ == "__main__":
    main()
