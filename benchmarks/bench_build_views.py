"""What the run's views pay for the buildability verdict (docs/model.md §21.3).

On the same designs of a run's front (``--run RUN_DIR``) or, without one, of a Sobol' sample
of a problem's box, in one process with one BLAS thread, CPU time:

- **computed** (the baseline): :func:`hisopt.studies.build_verdicts.write_run_verdicts`, what
  ``hisopt optimize`` does once when the run finishes (every rule in every load case, then
  ``buildability.csv`` written);
- **read back**: :func:`hisopt.studies.build_verdicts.run_verdicts` from that file, what the
  report and the decision room do;
- **box check**: :func:`hisopt.studies.buildable_box.box_verdict` of the problem constrained on
  ``build_usage`` (1,024 designs), what ``hisopt optimize`` pays before a run of a problem
  that enforces rules.

It prints each time and its ratio to the computed verdicts.

    python benchmarks/bench_build_views.py [--designs 2048] [--problem problems/roll_plane_his_valves.toml]
    python benchmarks/bench_build_views.py --run runs/valves    # a real front (writes its buildability.csv)
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
import tomllib
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pandas as pd  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "roll_plane_his_valves.toml"


def cpu(run) -> tuple[float, object]:
    """[s] CPU time of ``run()`` and its result."""
    t = time.process_time()
    out = run()
    return time.process_time() - t, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2048)
    parser.add_argument("--problem", type=Path, default=PROBLEM)
    parser.add_argument("--run", type=Path, default=None, help="a finished run directory: its front (its buildability.csv is rewritten)")
    args = parser.parse_args()

    import warnings

    from hisopt.optim.rundir import FRONT_CSV, read_front, run_problem
    from hisopt.problem import load_problem, problem_from_dict
    from hisopt.studies.build_verdicts import buildable_line, run_verdicts, write_run_verdicts
    from hisopt.studies.buildable_box import box_sample, box_verdict

    warnings.simplefilter("ignore")
    scratch = None
    if args.run is not None:
        problem, folder = run_problem(args.run)[0], args.run
        front = read_front(args.run / FRONT_CSV)
    else:
        problem = load_problem(args.problem, warn_implausible=False)
        folder = scratch = Path(tempfile.mkdtemp(prefix="bench_build_views-"))
        front = pd.DataFrame(box_sample(problem, args.designs, seed=1), columns=list(problem.variable_names))
    names = list(problem.variable_names)
    x = front[names].to_numpy(dtype=float)
    write_run_verdicts(folder, problem, front.iloc[:8])  # compile, and fit each load case's start of the valves' fixed point
    (folder / "buildability.csv").unlink()
    computed, verdicts = cpu(lambda: write_run_verdicts(folder, problem, front))
    read, again = cpu(lambda: run_verdicts(folder, problem, x))
    assert again.equals(verdicts)
    source = args.problem if args.run is None else args.run / "problem.toml"
    data = tomllib.loads(source.read_text())
    data["constraints"] = [*data.get("constraints", []), {"name": "build_usage", "limit": 1.0}]
    ruled = problem_from_dict(data, str(source), warn_implausible=False)
    box, verdict = cpu(lambda: box_verdict(ruled))
    print(f"{problem.name}: {len(x)} designs, {len(problem.scenario_names) or 1} load cases, one core; {buildable_line(verdicts, 'designs')}")
    print(f"  computed (at the run's end)  {computed:7.2f} s CPU   1.00 x")
    print(f"  read back (report, room)     {read:7.2f} s CPU   {read / computed:.4f} x")
    print(f"  box check (1024 designs)     {box:7.2f} s CPU   {box / computed:.4f} x   ({verdict.buildable} buildable)")  # type: ignore[union-attr]
    if scratch is not None:
        shutil.rmtree(scratch)


if __name__ == "__main__":
    main()
