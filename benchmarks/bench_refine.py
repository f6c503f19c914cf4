"""Gradient refinement of an NSGA-II front: seconds per refined design against the previous
path, and the hypervolume gain.

The issue's acceptance run: a 40-generation, population-40 NSGA-II on the paper's problem,
then 40 designs spread over its front refined with CasADi/IPOPT. The refinement runs twice
on the same front in the same process, one design at a time (``--workers 1``, the fairest
figure on a shared machine; pin it with ``taskset -c 0``):

- **baseline**: the previous path, rebuilt here by patching: the node plan searches each PSD
  peak with its own :func:`hisopt.evaluation.peaks.refine_maximum` call (one FRF call per
  peak and step), and the spectra callback converts CasADi ``DM`` results to numpy;
- **current**: one peak search for all peaks of a node plan, zero-copy CasADi buffers.

Both must give the same refined designs (the changes only reorder work); the script checks it
and prints wall and CPU seconds per design for each, their ratio, the hypervolume (log10
objectives, the run's reference point) before and after, and the IPOPT work per design. The
first run on a machine also compiles the CasADi model (a few seconds, then cached; see
``hisopt.optim.gradient.casadi_model.compiled``): it is timed separately, before the refinement.

    python benchmarks/bench_refine.py [--pop 40] [--gens 40] [--points 40] [--workers 1] [--seed 1]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

import hisopt
from hisopt.optim.gradient import asf_nlp, casadi_model
from hisopt.optim.gradient.casadi_model import CasadiModel
from hisopt.optim.gradient.refine import RefineResult, refine_front
from hisopt.optim.run import optimize

ROOT = Path(__file__).resolve().parents[1]


def _peak_locations_one_by_one(frf: Any, ev: Any, outputs: np.ndarray, lo_hz: np.ndarray, hi_hz: np.ndarray, steps: int = 12, points: int = 9) -> np.ndarray:
    """The previous peak search: one ``refine_maximum`` (and one FRF call per step) per peak."""
    from hisopt.evaluation.peaks import refine_maximum

    found = []
    for j, lo, hi in zip(np.asarray(outputs).tolist(), np.asarray(lo_hz).tolist(), np.asarray(hi_hz).tolist(), strict=True):

        def values_at(pts: np.ndarray, j: int = j) -> np.ndarray:
            return ev.spectra(pts, frf(2 * np.pi * pts, j))[..., 0]

        f = np.linspace(lo, hi, points)[None, :]
        found.append(float(refine_maximum(values_at, f, values_at(f), steps)[0][0]))
    return np.array(found)


def _evaluate_through_dm(self: Any, u: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """The previous spectra callback: mapped node functions called with and returning ``DM``."""
    import casadi as ca

    if not hasattr(self, "_dm"):
        self._dm = (
            self.model.fast_node_function().map(self.nodes_count, "serial"),
            self.model.fast_node_function(jacobian=True).map(self.nodes_count, "serial"),
            ca.DM(self.params),
        )
    value, value_jac, params = self._dm
    key = np.asarray(u, dtype=float).tobytes()
    hit = self._cache.get(key)
    if hit is not None and (hit[1] is not None or not jacobian):
        return hit
    x = self.lower + self.span * u
    if jacobian:
        psd, jac = value_jac(x, params)
        jac = np.array(jac).reshape(self.outputs_count, self.nodes_count, -1, order="C")
        jac = np.transpose(jac, (1, 0, 2)).reshape(self.nodes_count * self.outputs_count, -1) * self.span
        result = (np.array(psd), jac)
    else:
        result = (np.array(value(x, params)), None)
    self._cache[key] = result
    while len(self._cache) > 8:
        self._cache.pop(next(iter(self._cache)))
    return result


@contextlib.contextmanager
def baseline_path() -> Iterator[None]:
    """The previous refinement path (module docstring), for this process only."""
    saved = asf_nlp.peak_locations, casadi_model.SpectraCallback.evaluate
    asf_nlp.peak_locations = _peak_locations_one_by_one
    casadi_model.SpectraCallback.evaluate = _evaluate_through_dm  # type: ignore[method-assign]
    try:
        yield
    finally:
        asf_nlp.peak_locations, casadi_model.SpectraCallback.evaluate = saved  # type: ignore[method-assign]


def timed(label: str, problem: hisopt.Problem, front: Any, points: int, reference: np.ndarray, backend: Any) -> tuple[RefineResult, float]:
    cpu = time.process_time()
    result = refine_front(problem, front, points, backend=backend, reference_log=reference)
    cpu = (time.process_time() - cpu) / max(len(result.points), 1)
    p = result.points
    print(
        f"{label:>8}: {result.seconds_per_point:.3f} s per design wall, {cpu:.3f} s CPU in this process; "
        f"refined {int(p['accepted'].sum())} of {len(p)}; hypervolume {result.hypervolume_before:.6g} -> "
        f"{result.hypervolume_after:.6g} ({100 * result.hypervolume_gain:+.2f} %); IPOPT iterations median "
        f"{p['iterations'].median():.0f}, NLP rounds mean {p['rounds'].mean():.1f}"
    )
    return result, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--pop", type=int, default=40)
    parser.add_argument("--gens", type=int, default=40)
    parser.add_argument("--points", type=int, default=40)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    print(f"load average {', '.join(f'{v:.2f}' for v in os.getloadavg())} on {os.cpu_count()} CPUs")
    problem = hisopt.load_problem(args.problem)
    started = time.perf_counter()
    run = optimize(problem, seed=args.seed, pop_size=args.pop, generations=args.gens, algorithm="nsga2")
    print(f"NSGA-II {args.pop} x {args.gens}: {len(run.front)} front designs in {time.perf_counter() - started:.1f} s")

    started = time.perf_counter()
    model = CasadiModel(problem)
    model.fast_node_function(), model.fast_node_function(jacobian=True)
    print(f"CasADi model built and compiled (or loaded from the cache) in {time.perf_counter() - started:.1f} s")

    from hisopt.evaluation.parallel import open_backend

    with open_backend(args.workers if args.workers > 1 else None) as backend:
        refine_front(problem, run.front, 1, backend=backend, reference_log=run.reference_point)  # warm: caches, imports
        with baseline_path():
            old, old_cpu = timed("baseline", problem, run.front, args.points, run.reference_point, backend)
        new, new_cpu = timed("current", problem, run.front, args.points, run.reference_point, backend)
    names = list(problem.variable_names) + list(problem.objective_names)
    same = np.array_equal(old.front[names].to_numpy(), new.front[names].to_numpy())
    print(f"same refined front as the baseline: {same}")
    if args.workers > 1:
        print("(CPU seconds count this process only: with workers, compare the wall figures)")
    print(
        f"speed-up: {old.seconds_per_point / new.seconds_per_point:.2f}x wall, {old_cpu / new_cpu:.2f}x CPU; "
        f"hypervolume gain per refined design {100 * new.hypervolume_gain / max(len(new.points), 1):.3f} % "
        f"(baseline {100 * old.hypervolume_gain / max(len(old.points), 1):.3f} %)"
    )


if __name__ == "__main__":
    main()
