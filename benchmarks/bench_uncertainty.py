"""Cost of the uncertainty studies: hisopt's batched uncertain evaluator against a per-design loop.

On ``problems/roll_plane_his_uncertain.toml`` (eight ``[[uncertain]]`` inputs: car masses,
spring and damper, precharge, gas volume, valve, temperature), around the baseline design, in
one process with one BLAS thread:

- **sensitivity**: ``hisopt.studies.uncertainty.sensitivity`` (Saltelli sample, SALib's
  estimators, 250 bootstrap resamples, hisopt's default) at ``n_base`` = 256, 512, ... until every total
  index's 95 % half-width ``ST_conf`` is at most ``--target``; the last call is timed on its
  own, and so are its evaluations alone (``UncertainEvaluator.paired`` on as many rows), which
  splits the call into the model and SALib's bootstrap;
- **tolerance**: ``hisopt.studies.uncertainty.tolerance`` at ``--samples`` Monte Carlo samples;
- **the per-design loop** (the straightforward baseline): per sample, a ``Problem`` with that
  sample's input values set in its specification (``vehicle.<field>``, ``temperature``, a
  ``[his]`` value; a design variable in the design row), its ``evaluator()`` on the one design.
  It is timed on the first ``--loop-samples`` samples of the tolerance's sample set and
  extrapolated (labelled so) to the studies' evaluations; its values are checked against the
  batched evaluator's on those samples (largest relative difference, expected 0 or rounding).

- **the default ``hisopt sensitivity PROBLEM``** (no ``--design``: over the whole box of the
  design variables and the uncertain inputs), before and after it converged by itself:
  *before*, the fixed default it had (``n_base`` 1024, the quantities as they are); *after*,
  today's default (base samples doubled from 1024 until every S1 and ST half-width is at most
  0.05, a quantity spanning more than a decade taken as log10). Each: base samples,
  evaluations, wall seconds, the widest half-width and where.

Prints the search, then a table: evaluations, wall seconds, evaluations per second, and the
loop's (extrapolated) time for as many evaluations over the method's time; then the default
sensitivity before and after.

    python benchmarks/bench_uncertainty.py [--target 0.02] [--samples 100000] [--loop-samples 300]
    python benchmarks/bench_uncertainty.py --quick          # a smoke run: seconds (the default sensitivity too: minutes)
    python benchmarks/bench_uncertainty.py --default-only   # the default sensitivity before and after only
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

import hisopt  # noqa: E402
from hisopt.evaluation.uncertain import UncertainEvaluator, monte_carlo_variates  # noqa: E402
from hisopt.problem import Problem  # noqa: E402
from hisopt.studies.uncertainty import sensitivity, tolerance  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "roll_plane_his_uncertain.toml"
VEHICLE = "vehicle."


def per_design_loop(problem: Problem, ev: UncertainEvaluator, design: np.ndarray, u: np.ndarray) -> dict[str, np.ndarray]:
    """Quantities of ``design`` (one row) at each sample ``u[j]``: one problem per sample."""
    spec, names = problem.spec, problem.variable_names
    values = ev.values(np.repeat(design, len(u), axis=0), u)
    out = {k: np.empty(len(u)) for k in ev.names}
    for j in range(len(u)):
        row, car, his, update = design[0].copy(), {}, {}, {}
        for name, v in values.items():
            if name.startswith(VEHICLE):
                car[name.removeprefix(VEHICLE)] = float(v[j])
            elif name == "temperature":
                update["temperature"] = float(v[j])  # [K]
            elif name in names:
                row[names.index(name)] = v[j]
            else:
                his[name] = float(v[j])
        if car:
            update["vehicle"] = spec.vehicle.model_copy(update=car)
        if his:
            update["his"] = spec.his.model_copy(update=his)
        got = Problem(spec.model_copy(update=update), None).evaluator()(row[None, :])
        for k in ev.names:
            out[k][j] = got[k][0]
    return out


def timed(fn):
    """[s] Wall time of one call, and its result."""
    started = time.perf_counter()
    out = fn()
    return time.perf_counter() - started, out


def widest(indices) -> tuple[float, str]:  # noqa: ANN001 - a SensitivityResult's indices
    """[-] The widest S1 or ST half-width and where (index, input, quantity)."""
    parts = [indices.assign(index=k, w=indices[f"{k}_conf"]) for k in ("S1", "ST")]
    table = pd.concat(parts, ignore_index=True)
    row = table.loc[table["w"].idxmax()]
    return float(row["w"]), f"{row['index']} of {row['input']} on {row['quantity']}"


def default_sensitivity(problem: Problem) -> None:
    """The default ``hisopt sensitivity`` (over the whole box) before and after it converged by
    itself, and the log10 alone at the old count (which of the two narrows the intervals)."""
    print("\ndefault sensitivity (no --design: over the whole box), before and after it converged by itself")
    print("(wall and CPU seconds of this process: on a loaded machine the CPU time is the steadier figure)")
    runs = [
        ("before: fixed 1024, linear", lambda: sensitivity(problem, None, n_base=1024, log=False)),
        ("log10 alone: fixed 1024", lambda: sensitivity(problem, None, n_base=1024)),
        ("after: doubled to <= 0.05, log10", lambda: sensitivity(problem, None)),
    ]
    print(f"{'':34s} | {'n_base':>6s} | {'evaluations':>11s} | {'wall [s]':>8s} | {'CPU [s]':>8s} | {'widest half-width':>17s} | at")
    measured = []
    for label, run in runs:
        cpu = time.process_time()
        wall, result = timed(run)
        cpu = time.process_time() - cpu
        w, where = widest(result.indices)
        measured.append((wall, cpu, w, result))
        print(f"{label:34s} | {result.n_base:6d} | {result.evaluations:11d} | {wall:8.1f} | {cpu:8.1f} | {w:17.3f} | {where}", flush=True)
    (before_wall, before_cpu, before_w, _), (after_wall, after_cpu, after_w, after) = measured[0], measured[-1]
    print(f"after: stop {after.stop!r}; log10 of {', '.join(after.logged) or 'none'}; widest half-width before / after {before_w / after_w:.1f}")
    print(f"after / before: wall {after_wall / before_wall:.1f}, CPU {after_cpu / before_cpu:.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--target", type=float, default=0.02, help="[-] largest total-index half-width to reach")
    parser.add_argument("--start", type=int, default=256, help="first n_base of the search (doubled)")
    parser.add_argument("--samples", type=int, default=100_000, help="Monte Carlo samples of the tolerance study")
    parser.add_argument("--loop-samples", type=int, default=300, help="samples the per-design loop is timed on")
    parser.add_argument("--resamples", type=int, default=250, help="SALib's bootstrap resamples (hisopt's default)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: target 0.1, 5000 samples, a 30-sample loop")
    parser.add_argument("--default-only", action="store_true", help="only the default sensitivity before and after")
    args = parser.parse_args()
    if args.quick:
        args.target, args.samples, args.loop_samples = 0.1, 5000, 30

    problem = hisopt.load_problem(PROBLEM)
    design = problem.baseline[None, :]
    ev = UncertainEvaluator(problem)
    k = len(ev.inputs)
    load = os.getloadavg()
    print(f"{problem.name}: {k} uncertain inputs ({', '.join(u.name for u in ev.inputs)}), baseline design, one BLAS thread")
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores")
    if args.default_only:
        sensitivity(problem, design, n_base=8, seed=0, resamples=10)  # untimed: compiled kernels, SALib's imports
        default_sensitivity(problem)
        load = os.getloadavg()
        print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} after")
        return

    # untimed first calls: compiled kernels, SALib's imports, the models' caches
    u_all = monte_carlo_variates(args.samples, k, 0)  # the tolerance study's sample set
    sensitivity(problem, design, n_base=8, seed=0, resamples=10)
    per_design_loop(problem, ev, design, u_all[:2])

    print(f"\nsensitivity search: smallest n_base (from {args.start}, doubling) with every ST_conf <= {args.target}")
    print("(ST_conf is SALib's bootstrap half-width at 95 %, seeded: the same in every run)")
    print(f"{'n_base':>7s} {'evaluations':>12s} {'wall [s]':>9s} {'max ST_conf':>12s}  at (quantity, input)")
    n = args.start
    while True:
        t_sens, result = timed(lambda n=n: sensitivity(problem, design, n_base=n, seed=0, resamples=args.resamples, log=False))
        ix = result.indices
        worst = ix.loc[ix["ST_conf"].idxmax()]
        print(f"{n:7d} {result.evaluations:12d} {t_sens:9.2f} {worst['ST_conf']:12.4f}  ({worst['quantity']}, {worst['input']})", flush=True)
        if ix["ST_conf"].max() <= args.target:  # NaN never passes
            break
        n *= 2
    n_sens = result.evaluations
    if result.dropped:
        print(f"  {result.dropped} blocks dropped (failed model)")
    t_paired, _ = timed(lambda: ev.paired(np.repeat(design, n_sens, axis=0), monte_carlo_variates(n_sens, k, 0)))

    t_tol, _ = timed(lambda: tolerance(problem, design, n_samples=args.samples, seed=0))

    m = args.loop_samples
    t_loop, looped = timed(lambda: per_design_loop(problem, ev, design, u_all[:m]))
    per_sample = t_loop / m
    batched = ev(design, u_all[:m])
    diff, nan_mismatch = 0.0, 0
    for q in ev.names:
        a, b = looped[q], batched[q][0]
        nan_mismatch += int(np.sum(np.isnan(a) != np.isnan(b)))
        both = np.isfinite(a) & np.isfinite(b)
        if both.any():
            diff = max(diff, float(np.max(np.abs(a[both] / b[both] - 1.0))))
    print(f"\nper-design loop on {m} samples: {1e3 * per_sample:.2f} ms per sample")
    print(f"loop against batched on those samples: largest relative difference {diff:.1e} [-], NaN in one only: {nan_mismatch}")

    rows = [
        (f"sensitivity (n_base {n})", "hisopt sensitivity (evaluations + SALib)", n_sens, t_sens),
        ("", "  its evaluations alone (batched)", n_sens, t_paired),
        ("", "per-design loop (extrapolated)", n_sens, per_sample * n_sens),
        (f"tolerance ({args.samples} samples)", "hisopt tolerance", args.samples, t_tol),
        ("", "per-design loop (extrapolated)", args.samples, per_sample * args.samples),
        (f"loop ({m} samples)", "per-design loop (measured)", m, t_loop),
    ]
    print(f"\n{'task':28s} | {'method':42s} | {'evaluations':>11s} | {'wall [s]':>9s} | {'evaluations/s':>13s} | {'loop / this':>11s}")
    for task, method, evaluations, wall in rows:
        print(f"{task:28s} | {method:42s} | {evaluations:11d} | {wall:9.2f} | {evaluations / wall:13.0f} | {per_sample * evaluations / wall:11.1f}")
    print(f"(sensitivity: max ST_conf {ix['ST_conf'].max():.4f} at n_base {n}; extrapolated rows: {1e3 * per_sample:.2f} ms per sample x evaluations)")
    default_sensitivity(problem)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} after")


if __name__ == "__main__":
    main()
