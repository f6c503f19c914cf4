"""SMS-EMOA's survival (200 -> 100 points by least hypervolume contribution): hisopt's against pymoo's loop.

pymoo's ``LeastHypervolumeContributionSurvival`` removes ``argmin(moocore.hv_contributions)``
one point at a time; :func:`hisopt.optim.hv_survival.least_contributor_removal_order` removes the
same points (exact contributions, local and lazy updates). Both are timed in the same run on

- a real front: ``hisopt.optimize`` on the paper's problem (``--gens`` generations), ``log10``
  of the front's objectives normalised to [0, 1] per objective, ``--points`` of its designs drawn
  at random, reference point 1.1 in every objective;
- random points on the unit sphere's positive part (all mutually non-dominated), reference 1.1.

Prints, per case, the best of ``--repeats`` for hisopt and of ``--naive-repeats`` for the loop,
their ratio, how many of the removals agree and the hypervolume of both survivor sets. The
naive loop's moocore sets contributions below sqrt(eps) = 1.5e-8 to 0 (its ``hvc_1point_diff``)
and removes the first of those: where the two differ, the survivors' hypervolume says which kept
more. ``--compile`` also times the first call in a fresh process with an empty numba cache
(compilation) and with the cache filled (loading). The machine's load average is printed: on a
shared machine the figures move with it.

    python benchmarks/bench_hv_survival.py [--points 200] [--gens 20] [--repeats 20] [--naive-repeats 2] [--compile]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import moocore
import numpy as np

import hisopt
from hisopt.optim.decision import log_objectives
from hisopt.optim.hv_survival import least_contributor_removal_order

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = 1.1
"""[-] reference point in every normalised objective."""


def naive_removal_order(f: np.ndarray, ref: np.ndarray, n_remove: int) -> np.ndarray:
    """pymoo's loop: ``argmin(moocore.hv_contributions)``, delete, repeat."""
    ids = np.arange(len(f))
    removed = []
    for _ in range(n_remove):
        j = int(np.argmin(moocore.hv_contributions(f, ref=ref)))
        removed.append(int(ids[j]))
        f, ids = np.delete(f, j, axis=0), np.delete(ids, j)
    return np.array(removed, dtype=np.int64)


def best_time(fn: Callable[[], np.ndarray], repeats: int) -> tuple[float, np.ndarray]:
    """[s] Least wall time of ``repeats`` calls, and the last result."""
    best = np.inf
    for _ in range(repeats):
        started = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - started)
    return best, out


def real_front(points: int, gens: int, seed: int) -> np.ndarray:
    """``points`` designs of a short run's front, log10 objectives normalised to [0, 1]."""
    run = hisopt.optimize(ROOT / "problems" / "roll_plane_his.toml", generations=gens, seed=seed)
    z = log_objectives(run.objectives.to_numpy(dtype=float))
    rng = np.random.default_rng(seed)
    z = z[rng.choice(len(z), size=min(points, len(z)), replace=False)]
    return (z - z.min(axis=0)) / np.where(np.ptp(z, axis=0) > 0, np.ptp(z, axis=0), 1.0)


def sphere(points: int, k: int, seed: int) -> np.ndarray:
    """Points on the unit sphere's positive part (mutually non-dominated)."""
    x = np.abs(np.random.default_rng(seed).normal(size=(points, k)))
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def compare(name: str, f: np.ndarray, repeats: int, naive_repeats: int) -> None:
    n, k = f.shape
    ref = np.full(k, REFERENCE)
    n_remove = n // 2
    least_contributor_removal_order(f[:8], ref, 4)  # compiled or loaded before timing
    mine_s, mine = best_time(lambda: least_contributor_removal_order(f, ref, n_remove), repeats)
    naive_s, naive = best_time(lambda: naive_removal_order(f, ref, n_remove), naive_repeats)
    same = int(np.sum(mine == naive))
    first = int(np.argmax(mine != naive)) if same < n_remove else n_remove

    def survivors_hv(removed: np.ndarray) -> float:
        return float(moocore.hypervolume(np.delete(f, removed, axis=0), ref=ref))

    print(
        f"{name:<28} {n:>4} -> {n - n_remove:<4} k={k}: hisopt {1e3 * mine_s:8.2f} ms, pymoo loop {1e3 * naive_s:8.1f} ms, "
        f"ratio {naive_s / mine_s:6.0f}x; removals equal {same}/{n_remove} (first difference at step {first}); "
        f"same survivors: {'yes' if set(mine.tolist()) == set(naive.tolist()) else 'no'}; "
        f"survivors' hypervolume hisopt {survivors_hv(mine):.9f}, hisopt - loop {survivors_hv(mine) - survivors_hv(naive):+.1e}"
    )


FIRST_CALL = """
import time
t = time.perf_counter()
import numpy as np
from hisopt.optim.hv_survival import hv_contributions, least_contributor_removal_order
t_import = time.perf_counter() - t
x = np.abs(np.random.default_rng(0).normal(size=(30, 4)))
x /= np.linalg.norm(x, axis=1, keepdims=True)
t = time.perf_counter()
hv_contributions(x, np.full(4, 1.1))
least_contributor_removal_order(x, np.full(4, 1.1), 15)
first = time.perf_counter() - t
t = time.perf_counter()
hv_contributions(x, np.full(4, 1.1))
least_contributor_removal_order(x, np.full(4, 1.1), 15)
print(t_import, first, time.perf_counter() - t)
"""


def first_calls() -> None:
    """Compile time (empty cache) and cache-load time of the kernels, each in a fresh process."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("empty numba cache (compiles)", "filled numba cache (loads)"):
            out = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, cwd=ROOT, capture_output=True, text=True, check=True)
            t_import, first, again = (float(v) for v in out.stdout.split())
            print(f"first call, {label}: {first:.2f} s (the call again: {1e3 * again:.2f} ms; import {t_import:.2f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=200)
    parser.add_argument("--gens", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--naive-repeats", type=int, default=2)
    parser.add_argument("--compile", action="store_true", help="also time the first call with an empty and a filled numba cache")
    args = parser.parse_args()

    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores")
    if args.compile:
        first_calls()
    compare(f"real front ({args.gens} gens)", real_front(args.points, args.gens, args.seed), args.repeats, args.naive_repeats)
    for k in (4, 3, 2):
        compare("sphere", sphere(args.points, k, args.seed), args.repeats, args.naive_repeats)
    compare("sphere", sphere(args.points // 2, 5, args.seed), max(args.repeats // 10, 1), 1)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} after")


if __name__ == "__main__":
    main()
