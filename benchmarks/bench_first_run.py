"""The first run's extra cost: numba compiling the evaluator's kernels (docs/model.md §10.8).

Each case starts from a fresh, empty numba cache (``NUMBA_CACHE_DIR``, so the checkout's own
cache plays no part) and runs the same hisopt command twice, each in a new process:

- ``cold``: the first run compiles every kernel, the second loads them (the baseline: what a
  user who skips the set-up's warm-up step pays);
- ``after warm-up``: README's set-up step ``python -m hisopt.optim.warmup`` first (timed
  apart: it belongs to the install), then the two runs.

It prints, per case, the wall and CPU seconds of each run and the first run's extra over the
second (the target: at most 3 s after the warm-up). It exits non-zero only if a command fails,
never on a time.

    python benchmarks/bench_first_run.py                       # hisopt evaluate (cheap: every kernel)
    python benchmarks/bench_first_run.py --command "optimize problems/roll_plane_his.toml --out {out}"
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import resource
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 3.0


def _timed(args: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds of one subprocess; its output is shown only if it fails."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.stderr.write(done.stdout + done.stderr)
        raise SystemExit(f"bench_first_run: {shlex.join(args)} failed with exit code {done.returncode}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _case(label: str, command: list[str], warmup: bool, scratch: Path) -> float:
    """Runs one case in its own empty cache; returns the first run's extra wall seconds."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(scratch / f"numba-{label}")}
    hisopt = [sys.executable, "-m", "hisopt"]
    if warmup:
        wall, cpu = _timed([sys.executable, "-m", "hisopt.optim.warmup"], env)
        print(f"{label:>14}: warm-up (install step) {wall:6.1f} s wall {cpu:6.1f} s CPU")
    runs = []
    for i in range(2):
        out = scratch / f"out-{label}-{i}"
        runs.append(_timed(hisopt + [part.replace("{out}", str(out)) for part in command], env))
    (w1, c1), (w2, c2) = runs
    print(
        f"{label:>14}: first run {w1:6.1f} s wall {c1:6.1f} s CPU | second {w2:6.1f} s wall {c2:6.1f} s CPU"
        f" | first-run extra {w1 - w2:5.1f} s wall {c1 - c2:5.1f} s CPU"
    )
    return w1 - w2


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--command", default="evaluate problems/roll_plane_his.toml", help="hisopt's arguments; {out} becomes a fresh directory per run")
    parser.add_argument("--no-cold", action="store_true", help="skip the cold case (its first run compiles everything)")
    args = parser.parse_args()
    command = shlex.split(args.command)
    has_warmup = importlib.util.find_spec("hisopt.optim.warmup") is not None
    print(f"hisopt {shlex.join(command)}  (Python {sys.version.split()[0]}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f})")
    with tempfile.TemporaryDirectory(prefix="bench_first_run-") as tmp:
        scratch = Path(tmp)
        cold = None if args.no_cold else _case("cold", command, False, scratch)
        warm = _case("after warm-up", command, True, scratch) if has_warmup else None
    if cold is not None:
        print(f"first-run extra without the warm-up: {cold:.1f} s")
    if warm is not None:
        print(f"first-run extra after the warm-up:   {warm:.1f} s (target <= {TARGET_S:.0f} s)")
    else:
        print("no warm-up step in this hisopt (hisopt.optim.warmup)")


if __name__ == "__main__":
    main()
