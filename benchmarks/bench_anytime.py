"""Anytime quality: hypervolume ratio per evaluation and per second, every method, many seeds.

COCO's anytime method (Brockhoff et al., Evolutionary Computation 30(2), 2022) applied to
hisopt's problems: each method runs with several seeds on the same evaluator; a run is judged
at every point of its life by the hypervolume of its archive (every feasible design it has
evaluated, reduced to the non-dominated ones: hisopt's front is that archive, and every peer
gets the same count) relative to a reference front. The runtime to reach a target ratio
(0.9, 0.95, 0.99, 0.999) is the first evaluation count (and CPU time) at which the
archive's ratio reaches it; their distribution over seeds is the empirical runtime
distribution.

Hypervolume ratio: objectives in log10, scaled so that the reference front's ideal is 0 and
its nadir 1 in each objective, reference point 1.1 in each (designs beyond it add nothing);
ratio = hypervolume of the run's archive / hypervolume of the reference front.

Reference front: the non-dominated union of long runs (``reference`` step: hisopt's default
and pymoo's SMS-EMOA and AGE-MOEA2 at many evaluations) and of every benchmark run's archive,
stored with how it was made (``reference.json``). A run can then not exceed 1.

Three steps, each resumable (a finished run is not repeated)::

    python benchmarks/bench_anytime.py runs --problem problems/roll_plane_his.toml --seeds 11
    python benchmarks/bench_anytime.py reference --problem problems/roll_plane_his.toml
    python benchmarks/bench_anytime.py analyse --problem problems/roll_plane_his.toml

``runs`` stores every evaluation of every run (objectives, feasibility, CPU time) under
``--work`` (default ``benchmarks/anytime/work``, not committed); ``analyse`` writes
``benchmarks/anytime/<problem>/anytime.csv`` (ratio per method, seed and budget),
``runtimes.csv`` (evaluations and seconds to each target), ``table.md`` and ``anytime.html``
(median and worst per method over evaluations and over CPU seconds).

Methods: ``hisopt`` (the default run, through ``hisopt.optimize`` with a run directory, as a
user runs it: checkpoints, reference grid and all), ``hisopt-nsga3`` (hisopt's NSGA-III, the
default before issue 28), pymoo's ``nsga3``, ``unsga3``, ``agemoea2`` and ``smsemoa`` (their
default operators, population 100, on hisopt's vectorised evaluator, one generation per
call), Optuna's default sampler ``optuna-tpe`` and its ``optuna-gp`` sampler (one design per
trial; constraints passed to the sampler). Optuna's samplers cost far more per trial than
the evaluator, so they run to ``--optuna-evaluations`` (default 1,000) only.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import hisopt
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.decision import hypervolume
from hisopt.optim.pymoo_problem import HisoptPymooProblem, feasible_mask
from hisopt.optim.settings import das_dennis_partitions

ROOT = Path(__file__).resolve().parents[1]
TARGETS = (0.9, 0.95, 0.99, 0.999)
BUDGETS = (1000, 5000, 20000)
PEERS = ("hisopt", "hisopt-smsemoa", "hisopt-nsga3", "nsga3", "unsga3", "agemoea2", "smsemoa", "optuna-tpe", "optuna-gp")
OPTUNA = ("optuna-tpe", "optuna-gp")
REFERENCE_MARGIN = 0.1
"""[-] Reference point beyond the reference front's nadir, in units of its range."""


# -- recording runs -------------------------------------------------------------------------
class Log:
    """Every evaluation of one run: objectives (inf when infeasible) and the CPU time of this
    process when it was evaluated [s] (not wall time: the figures then hold on a shared
    machine; every method runs in this one process, its threads counted)."""

    def __init__(self, problem: hisopt.Problem):
        self.adapter = HisoptPymooProblem(problem)
        self.evaluator = problem.evaluator()
        self.f: list[np.ndarray] = []
        self.t: list[np.ndarray] = []
        self.start = time.process_time()

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        f, g = self.adapter.f_and_g(self.evaluator(x))
        self.record(f, feasible_mask(g))
        return f, g

    def record(self, f: np.ndarray, feasible: np.ndarray, at: float | None = None) -> None:
        self.f.append(np.where(feasible[:, None], f, np.inf))
        self.t.append(np.full(len(f), time.process_time() - self.start if at is None else at))

    @property
    def count(self) -> int:
        return sum(len(f) for f in self.f)

    def save(self, path: Path, meta: dict[str, Any]) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez_compressed(tmp, f=np.concatenate(self.f), t=np.concatenate(self.t), meta=json.dumps(meta))
        tmp.replace(path)


def run_hisopt(problem: hisopt.Problem, seed: int, evaluations: int, algorithm: str | None) -> Log:
    log = Log(problem)
    pop = problem.spec.optimizer.pop_size
    with tempfile.TemporaryDirectory() as tmp:
        stamps: list[float] = []
        result = hisopt.optimize(
            problem,
            out=Path(tmp) / "run",
            seed=seed,
            generations=evaluations // pop,
            algorithm=algorithm,  # type: ignore[arg-type]
            progress=lambda stats: stamps.append(time.process_time() - log.start),
        )
    history = result.history
    f = history[list(problem.objective_names)].to_numpy(dtype=float)
    generation = history["generation"].to_numpy()
    log.record(f, history["feasible"].to_numpy(dtype=bool))
    log.t = [np.asarray(stamps)[generation - 1]]
    return log


def run_pymoo(problem: hisopt.Problem, name: str, seed: int, evaluations: int) -> Log:
    from pymoo.core.termination import NoTermination
    from pymoo.util.ref_dirs import get_reference_directions

    n_obj = len(problem.objective_names)
    pop = 100
    if name in ("nsga3", "unsga3"):
        from pymoo.algorithms.moo.nsga3 import NSGA3
        from pymoo.algorithms.moo.unsga3 import UNSGA3

        ref_dirs = get_reference_directions("das-dennis", n_obj, n_partitions=das_dennis_partitions(n_obj, pop))
        algorithm: Any = (NSGA3 if name == "nsga3" else UNSGA3)(ref_dirs, pop_size=pop)
    elif name == "agemoea2":
        from pymoo.algorithms.moo.age2 import AGEMOEA2

        algorithm = AGEMOEA2(pop_size=pop)
    else:
        from pymoo.algorithms.moo.sms import SMSEMOA

        algorithm = SMSEMOA(pop_size=pop)
    log = Log(problem)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        algorithm.setup(log.adapter, termination=NoTermination(), seed=seed)
        while log.count < evaluations:
            offspring = algorithm.ask()
            offspring = offspring[: evaluations - log.count]
            f, g = log.evaluate(np.asarray(offspring.get("X"), dtype=float))
            offspring.set("F", f, "G", g)
            algorithm.tell(infills=offspring)
    return log


def run_optuna(problem: hisopt.Problem, name: str, seed: int, evaluations: int) -> Log:
    import optuna

    optuna.logging.set_verbosity(optuna.logging.ERROR)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    log = Log(problem)
    names, lower, upper = problem.variable_names, problem.lower, problem.upper

    sampler: Any = optuna.samplers.GPSampler(seed=seed) if name == "optuna-gp" else optuna.samplers.TPESampler(seed=seed)
    study = optuna.create_study(directions=["minimize"] * len(problem.objective_names), sampler=sampler)
    for _ in range(evaluations):
        trial = study.ask()
        x = np.array([[trial.suggest_float(n, lo, hi) for n, lo, hi in zip(names, lower, upper, strict=True)]])
        f, g = log.evaluate(x)
        for j, value in enumerate(g[0]):  # Optuna 5: feasible when every value <= 0
            trial.set_constraint(f"g{j}", float(value))
        if np.all(np.isfinite(f)):
            study.tell(trial, [float(v) for v in f[0]])
        else:
            study.tell(trial, state=optuna.trial.TrialState.FAIL)
    return log


def run_one(problem: hisopt.Problem, method: str, seed: int, evaluations: int) -> Log:
    if method == "hisopt":
        return run_hisopt(problem, seed, evaluations, None)
    if method.startswith("hisopt-"):
        return run_hisopt(problem, seed, evaluations, method.removeprefix("hisopt-"))
    if method in OPTUNA:
        return run_optuna(problem, method, seed, evaluations)
    return run_pymoo(problem, method, seed, evaluations)


def run_path(work: Path, problem: hisopt.Problem, method: str, seed: int, evaluations: int) -> Path:
    return work / problem.name / f"{method}_s{seed}_n{evaluations}.npz"


def cmd_runs(args: argparse.Namespace) -> None:
    problem = hisopt.load_problem(args.problem)
    problem.evaluator()(problem.lower[None, :])  # compile before any clock starts
    for method in args.methods.split(","):
        budget = min(args.evaluations, args.optuna_evaluations) if method in OPTUNA else args.evaluations
        for seed in range(1, args.seeds + 1):
            path = run_path(Path(args.work), problem, method, seed, budget)
            if path.exists():
                continue
            log = run_one(problem, method, seed, budget)
            log.save(path, {"method": method, "seed": seed, "evaluations": budget, "problem": problem.name})
            print(f"{problem.name} {method} seed {seed}: {log.count} evaluations in {log.t[-1][-1]:.1f} s", flush=True)


# -- the reference front and ratios ---------------------------------------------------------
def archive_front(f: np.ndarray) -> np.ndarray:
    """[objective units] Non-dominated feasible rows of ``f`` (infeasible rows are inf)."""
    f = f[np.all(np.isfinite(f), axis=1)]
    return f[non_dominated_mask(f)]


class Ratio:
    """Hypervolume ratio against a reference front (module docstring).

    Scaling each log10 objective by the reference front's range multiplies every hypervolume
    by the same factor, so the ratio is that of :func:`hisopt.optim.decision.hypervolume` (log10
    objectives, exact, by slabs for large fronts) with the reference point at the front's
    nadir plus :data:`REFERENCE_MARGIN` of its range.
    """

    def __init__(self, reference_f: np.ndarray):
        z = np.log10(reference_f)
        ideal, nadir = z.min(axis=0), z.max(axis=0)
        self.point = nadir + REFERENCE_MARGIN * (nadir - ideal)  # [decades]
        self.reference = hypervolume(reference_f, self.point)

    def __call__(self, f: np.ndarray) -> float:
        return hypervolume(archive_front(f), self.point) / self.reference


def load_runs(work: Path, problem_name: str) -> list[dict[str, Any]]:
    runs = []
    for path in sorted((work / problem_name).glob("*.npz")):
        with np.load(path) as data:
            runs.append(json.loads(str(data["meta"])) | {"f": data["f"], "t": data["t"], "path": path})
    return runs


def cmd_reference(args: argparse.Namespace) -> None:
    problem = hisopt.load_problem(args.problem)
    problem.evaluator()(problem.lower[None, :])
    for item in args.long.split(","):
        method, budget = item.split(":")[0], int(item.split(":")[1])
        path = run_path(Path(args.work) / "reference", problem, method, 1, budget)
        if not path.exists():
            log = run_one(problem, method, 1, budget)
            log.save(path, {"method": method, "seed": 1, "evaluations": budget, "problem": problem.name})
            print(f"reference run {method}: {budget} evaluations in {log.t[-1][-1]:.1f} s", flush=True)
    sources = load_runs(Path(args.work) / "reference", problem.name) + load_runs(Path(args.work), problem.name)
    front = archive_front(np.concatenate([archive_front(r["f"]) for r in sources]))
    out = ROOT / "benchmarks" / "anytime" / problem.name
    out.mkdir(parents=True, exist_ok=True)
    # 6 digits: 3.5 MB for a quarter-million designs; the rounding (5e-7 of a value) moves a
    # hypervolume ratio by about 1e-6, far below the 4 digits reported
    np.savetxt(out / "reference_front.csv.gz", front, fmt="%.6g", delimiter=",", header=",".join(problem.objective_names), comments="")
    made_of = sorted({(r["method"], int(r["evaluations"])) for r in sources})
    (out / "reference.json").write_text(
        json.dumps(
            {
                "problem": problem.name,
                "objectives": list(problem.objective_names),
                "designs": len(front),
                "made_of": [f"{m} x {sum(1 for r in sources if r['method'] == m and r['evaluations'] == n)} seeds at {n} evaluations" for m, n in made_of],
                "rule": "non-dominated union of the archives of every listed run",
                "hypervolume": "log10 objectives scaled to the front's ideal (0) and nadir (1); reference point 1.1 in each",
                "values": "6 significant digits",
            },
            indent=1,
        )
        + "\n"
    )
    print(f"reference front of {problem.name}: {len(front)} designs from {len(sources)} runs")


def first_reaching(run: dict[str, Any], ratio: Ratio, target: float) -> tuple[int, float] | None:
    """[-, s] First evaluation count (and CPU time) at which the archive's ratio reaches
    ``target``: bisection, since an archive's hypervolume never falls."""
    f, t = run["f"], run["t"]
    if ratio(f) < target:
        return None
    lo, hi = 0, len(f)  # ratio(f[:lo]) < target <= ratio(f[:hi])
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if ratio(f[:mid]) < target else (lo, mid)
    return hi, float(t[hi - 1])


def cmd_analyse(args: argparse.Namespace) -> None:
    import pandas as pd

    problem = hisopt.load_problem(args.problem)
    out = ROOT / "benchmarks" / "anytime" / problem.name
    reference = np.loadtxt(out / "reference_front.csv.gz", delimiter=",", skiprows=1, ndmin=2)
    ratio = Ratio(reference)
    rows, times = [], []
    grid = np.unique(np.concatenate([np.round(np.logspace(2, np.log10(args.evaluations), 25)).astype(int), BUDGETS]))
    for run in load_runs(Path(args.work), problem.name):
        # the archive after at most n evaluations: a run may end a few short of its budget
        # (pymoo drops duplicate offspring), and is judged at the budget by its final archive
        for n in grid[grid <= int(run["evaluations"])]:
            used = min(int(n), len(run["f"]))
            row = {"method": run["method"], "seed": run["seed"], "evaluations": int(n), "cpu_time_s": float(run["t"][used - 1])}
            rows.append(row | {"ratio": ratio(run["f"][:used])})
        for target in TARGETS:
            hit = first_reaching(run, ratio, target)
            evaluations, seconds = (None, None) if hit is None else hit
            times.append({"method": run["method"], "seed": run["seed"], "target": target, "evaluations": evaluations, "cpu_time_s": seconds})
        print(f"analysed {run['path'].name}", flush=True)
    anytime, runtimes = pd.DataFrame(rows), pd.DataFrame(times)
    anytime.to_csv(out / "anytime.csv", index=False, float_format="%.6g")
    runtimes.to_csv(out / "runtimes.csv", index=False, float_format="%.6g")
    table = summary_table(anytime, runtimes)
    (out / "table.md").write_text(f"{problem.name}: hypervolume ratio against the reference front (median / worst over seeds)\n\n{table}\n")
    print(table)
    plot(anytime, runtimes, problem.name, out / "anytime.html")


def summary_table(anytime: Any, runtimes: Any) -> str:
    lines = ["| method | seeds | 1,000 | 5,000 | 20,000 | evaluations to 0.99 (median) | CPU time to 0.99 [s] (median) |", "|---|---|---|---|---|---|---|"]
    for method in [m for m in PEERS if m in set(anytime["method"])]:
        a = anytime[anytime["method"] == method]
        cells = []
        for budget in BUDGETS:
            r = a[a["evaluations"] == budget]["ratio"]
            cells.append(f"{r.median():.4f} / {r.min():.4f}" if len(r) else "-")
        hit = runtimes[(runtimes["method"] == method) & (runtimes["target"] == 0.99)]
        seeds = a["seed"].nunique()
        reached = hit["evaluations"].notna().sum()
        evals = f"{hit['evaluations'].median():,.0f}" if reached * 2 > seeds else f"not reached ({reached}/{seeds})"
        secs = f"{hit['cpu_time_s'].median():.1f}" if reached * 2 > seeds else "-"
        lines.append(f"| {method} | {seeds} | {' | '.join(cells)} | {evals} | {secs} |")
    return "\n".join(lines)


def plot(anytime: Any, runtimes: Any, name: str, path: Path) -> None:
    """Three panels: the hypervolume gap ``1 - ratio`` (log scale, so that 0.99 and 0.999 are
    apart) per evaluation and per CPU second, median solid and worst dotted; and COCO's
    empirical runtime distribution, the share of (seed, target) pairs reached by each
    evaluation count, over the targets :data:`TARGETS`."""
    import plotly.graph_objects as go
    from plotly.colors import qualitative
    from plotly.subplots import make_subplots

    fig = make_subplots(rows=1, cols=3, subplot_titles=("per evaluation", "per CPU second", "runtime distribution, targets 0.9-0.999"))
    for k, method in enumerate(m for m in PEERS if m in set(anytime["method"])):
        a = anytime[anytime["method"] == method].groupby("evaluations")
        median, worst, seconds = 1.0 - a["ratio"].median(), 1.0 - a["ratio"].min(), a["cpu_time_s"].median()
        colour = qualitative.D3[k % len(qualitative.D3)]
        for col, x in ((1, median.index), (2, seconds.to_numpy())):
            fig.add_trace(
                go.Scatter(x=x, y=median.to_numpy(), mode="lines", name=method, legendgroup=method, showlegend=col == 1, line={"color": colour}), row=1, col=col
            )
            dotted = {"color": colour, "dash": "dot", "width": 1}
            fig.add_trace(
                go.Scatter(x=x, y=worst.to_numpy(), mode="lines", name=f"{method} worst", legendgroup=method, showlegend=False, line=dotted), row=1, col=col
            )
        hits = runtimes[runtimes["method"] == method]["evaluations"]
        reached = np.sort(hits.dropna().to_numpy(dtype=float))
        share = np.arange(1, len(reached) + 1) / max(len(hits), 1)
        fig.add_trace(
            go.Scatter(x=reached, y=share, mode="lines", name=method, legendgroup=method, showlegend=False, line={"color": colour, "shape": "hv"}), row=1, col=3
        )
    for col in (1, 2):
        fig.update_yaxes(type="log", range=[-4, np.log10(0.3)], exponentformat="e", row=1, col=col)
    fig.update_xaxes(type="log", title_text="evaluations [-]", row=1, col=1)
    fig.update_xaxes(type="log", title_text="CPU time [s]", row=1, col=2)
    fig.update_xaxes(type="log", title_text="evaluations [-]", row=1, col=3)
    fig.update_yaxes(title_text="1 - hypervolume ratio [-] (median solid, worst dotted)", row=1, col=1)
    fig.update_yaxes(title_text="share of (seed, target) pairs reached [-]", range=[0, 1], row=1, col=3)
    fig.update_layout(title=f"Anytime quality on {name} (lower gap is better)", width=1500, height=500, template="plotly_white")
    fig.write_html(path, include_plotlyjs=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("step", choices=("runs", "reference", "analyse"))
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--methods", default=",".join(PEERS))
    parser.add_argument("--seeds", type=int, default=11)
    parser.add_argument("--evaluations", type=int, default=20_000)
    parser.add_argument("--optuna-evaluations", type=int, default=1_000)
    parser.add_argument("--long", default="hisopt:200000,smsemoa:40000,agemoea2:100000", help="the reference's long runs, METHOD:EVALUATIONS,...")
    parser.add_argument("--work", default=str(ROOT / "benchmarks" / "anytime" / "work"))
    args = parser.parse_args()
    {"runs": cmd_runs, "reference": cmd_reference, "analyse": cmd_analyse}[args.step](args)


if __name__ == "__main__":
    main()
