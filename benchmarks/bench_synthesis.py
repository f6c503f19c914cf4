"""Topology synthesis: enumeration and screening time per K on one core (docs/model.md §20).

For each budget K up to the one that holds the whole catalogue (10), mirror-symmetric
layouts of all eight chambers and of the front axle's four, and every layout (asymmetric
too) of the front axle: the number of candidates, the circuit structures examined, the time
to enumerate them (hub structures, networkx isomorphism, composition) and the time to screen
them all (each distinct circuit solved once by the network code, candidates' tables summed
over their circuits). The straightforward baseline of the screening, in the same run: each
candidate's whole layout compiled and solved on its own, as ``hisopt layouts`` does one
layout, timed on a sample of candidates and given per candidate; the ratio is per candidate.
Also checks the counts known up front (``candidate_count``) against the enumeration.

    python benchmarks/bench_synthesis.py [--max-elements 10] [--sample 300]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from hisopt.hydraulics import topology
from hisopt.problem import load_problem
from hisopt.studies.screening import layout_system, pattern_properties
from hisopt.studies.synthesis import screening_frame

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "roll_plane_his_robust.toml"


def baseline_seconds(problem, enumeration: topology.Enumeration, sample: int) -> float:
    """[s per candidate] Screening by compiling each sampled candidate's layout whole."""
    from hisopt.hydraulics.roll_plane import RollPlaneHIS
    from hisopt.studies.synthesis import candidate_problem_data

    rng = np.random.default_rng(0)
    picks = rng.choice(len(enumeration.candidates), size=min(sample, len(enumeration.candidates)), replace=False)
    his_tables = [RollPlaneHIS.model_validate(candidate_problem_data(problem, enumeration, int(i))["his"]) for i in picks]
    start = time.process_time()
    for his in his_tables:
        pattern_properties(layout_system(his))
    return (time.process_time() - start) / len(picks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-elements", type=int, default=10)
    parser.add_argument("--sample", type=int, default=300)
    args = parser.parse_args()
    problem = load_problem(PROBLEM)
    print(f"{'search':<22}{'K':>3}{'candidates':>12}{'structures':>12}{'enumerate':>11}{'screen':>9}{'per cand.':>11}{'baseline':>11}{'ratio':>8}")
    for chambers, symmetric, top in (("all", True, args.max_elements), ("front", True, args.max_elements), ("front", False, min(args.max_elements, 8))):
        for k in range(1, top + 1):
            structures = topology.search_structure_count(k, chambers, symmetric)
            start = time.process_time()
            enumeration = topology.enumerate_layouts(k, chambers, symmetric)
            enumerate_s = time.process_time() - start
            assert topology.candidate_count(k, chambers, symmetric) == len(enumeration.candidates)
            start = time.process_time()
            screening_frame(problem, enumeration)
            screen_s = time.process_time() - start
            n = len(enumeration.candidates)
            per = screen_s / n
            base = baseline_seconds(problem, enumeration, args.sample) if k in (top - 2, top) else float("nan")
            measured = base == base
            shown = f"{base * 1e6:>9.0f}us" if measured else f"{'-':>11}"
            ratio = f"{base / per:7.1f}x" if measured else ""
            name = f"{chambers}, {'mirror' if symmetric else 'any'}"
            print(f"{name:<22}{k:>3}{n:>12,}{structures:>12,}{enumerate_s:>10.2f}s{screen_s:>8.2f}s{per * 1e6:>9.0f}us{shown} {ratio}", flush=True)


if __name__ == "__main__":
    main()
