"""NSGA-II/III runs of a hisopt problem: library entry points, run directories, resume.

A run drives a pymoo algorithm through its ask/tell interface: ``ask`` proposes a
generation, hisopt evaluates it in one vectorised call, ``tell`` performs survival. After
every generation the run directory receives an atomic checkpoint (:mod:`hisopt.optim.runio`)
holding everything needed to continue bit for bit: the population with its survival
attributes, NSGA-III's normalisation state, the algorithm's random generator state, the
archive (:mod:`hisopt.optim.archive`), every evaluated design and the statistics. No pymoo
object is pickled; :func:`resume` rebuilds the algorithm from the settings, sets it up with
the same seed and loads that state into it, so an interrupted run (Ctrl-C, ``SIGKILL``)
ends with the same front as an uninterrupted one.

Run directory files (all written atomically):

- ``run.json``: status, settings, versions, the problem file's SHA-256 and text, sessions
  with timings, and (when finished) a result summary;
- ``problem.toml`` (or ``problem.json`` for a problem not read unchanged from a file): the
  run's own copy of the problem;
- ``checkpoint.npz``: written after every generation;
- ``front.csv``: the archive's non-dominated feasible designs: variables, objectives,
  constraint quantities, physical units, shortest round-trip decimals and a units row
  (:func:`hisopt.io.write_csv`; read it back with :func:`hisopt.io.read_csv`);
- ``evaluations.parquet`` (``evaluations.csv`` without pyarrow): every evaluated design
  with its generation, quantities, ``valid`` and ``feasible``;
- ``generations.csv``: per-generation statistics (evaluations, feasible share, front
  size, hypervolume).

Resume rule for the problem file: :func:`resume` loads the run's own copy. It refuses
(:class:`~hisopt.errors.RunError`) when the copy's SHA-256 differs from the one in
``run.json`` (the copy was edited) or when the original problem file recorded in
``run.json`` still exists and its SHA-256 differs (the problem changed since the run
started: resuming would mix two problems). A moved or deleted original is not an error.
Resume also refuses a checkpoint written by another pymoo version.
"""

from __future__ import annotations

import json
import math
import platform
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd

from hisopt import interrupt
from hisopt.errors import ConfigError, HisoptError, RunError
from hisopt.io import write_csv
from hisopt.optim import runio, runstate
from hisopt.optim.archive import Archive
from hisopt.optim.decision import asf_index, hypervolume, knee_index, reference_point
from hisopt.optim.pymoo_problem import HisoptPymooProblem, feasible_mask
from hisopt.units import attach_units

if TYPE_CHECKING:
    from hisopt.problem import Problem

AlgorithmName = Literal["nsga2", "nsga3"]
AlgorithmChoice = Literal["auto", "nsga2", "nsga3"]
NSGA3_MIN_OBJECTIVES = 4
"""``algorithm = "auto"`` picks NSGA-III from this many objectives on, NSGA-II below."""

SURVIVAL_FIELDS = ("rank", "crowding", "niche", "dist_to_niche")
"""Per-individual attributes set by survival and read by mating (checkpointed)."""

NORM_FIELDS = ("ideal_point", "worst_point", "nadir_point", "extreme_points")
"""NSGA-III hyperplane normalisation state carried between generations (checkpointed)."""


# --- settings --------------------------------------------------------------------------
@dataclass(frozen=True)
class RunSettings:
    """Algorithm settings of a run (problem file ``[optimizer]`` plus overrides).

    Attributes
    ----------
    algorithm : [-] ``"nsga2"`` or ``"nsga3"`` (``"auto"`` already resolved)
    pop_size : [-] population size (and offspring per generation)
    generations : [-] generations including the initial one
    seed : [-] random seed of the algorithm
    """

    algorithm: AlgorithmName
    pop_size: int
    generations: int
    seed: int

    @property
    def evaluations(self) -> int:
        """[-] Nominal evaluation budget ``pop_size * generations``."""
        return self.pop_size * self.generations


def resolve_settings(
    problem: "Problem",
    *,
    algorithm: AlgorithmChoice | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    seed: int | None = None,
) -> RunSettings:
    """Settings from the problem file, each overridable (``None`` keeps the file's value).

    Raises
    ------
    ConfigError
        An override is out of range or the population is too small for NSGA-III.
    """
    spec = problem.spec.optimizer
    choice = spec.algorithm if algorithm is None else algorithm
    if choice not in ("auto", "nsga2", "nsga3"):
        raise ConfigError(f"unknown algorithm {choice!r}; expected auto, nsga2 or nsga3", key="--algorithm")
    pop = spec.pop_size if pop_size is None else pop_size
    gens = spec.generations if generations is None else generations
    rng_seed = spec.seed if seed is None else seed
    if not isinstance(pop, int) or pop < 4:
        raise ConfigError(f"expected a population size >= 4, got {pop!r}", key="--pop")
    if not isinstance(gens, int) or gens < 1:
        raise ConfigError(f"expected generations >= 1, got {gens!r}", key="--gens")
    if not isinstance(rng_seed, int) or rng_seed < 0:
        raise ConfigError(f"expected a seed >= 0, got {rng_seed!r}", key="--seed")
    n_obj = len(problem.objective_names)
    name: AlgorithmName = ("nsga3" if n_obj >= NSGA3_MIN_OBJECTIVES else "nsga2") if choice == "auto" else choice
    if name == "nsga3" and pop < n_obj:
        raise ConfigError(f"NSGA-III needs a population of at least {n_obj} (one per objective), got {pop}", key="--pop")
    return RunSettings(name, pop, gens, rng_seed)


def das_dennis_partitions(n_obj: int, pop_size: int) -> int:
    """[-] Most Das-Dennis partitions whose ``C(p + m - 1, m - 1)`` directions fit ``pop_size``."""
    p = 1
    while math.comb(p + 1 + n_obj - 1, n_obj - 1) <= pop_size:
        p += 1
    return p


def build_algorithm(settings: RunSettings, n_obj: int) -> Any:
    """A fresh pymoo NSGA-II or NSGA-III for ``settings`` (not yet set up).

    NSGA-III uses Das-Dennis reference directions, as many as fit the population (84 for
    four objectives and 100 individuals).
    """
    if settings.algorithm == "nsga2":
        from pymoo.algorithms.moo.nsga2 import NSGA2

        return NSGA2(pop_size=settings.pop_size)
    from pymoo.algorithms.moo.nsga3 import NSGA3
    from pymoo.operators.selection.tournament import TournamentSelection
    from pymoo.util.ref_dirs import get_reference_directions

    ref_dirs = get_reference_directions("das-dennis", n_obj, n_partitions=das_dennis_partitions(n_obj, settings.pop_size))
    return NSGA3(ref_dirs, pop_size=settings.pop_size, selection=TournamentSelection(func_comp=_compare_cv_then_random))


def _compare_cv_then_random(pop: Any, P: np.ndarray, random_state: np.random.Generator, **kwargs: Any) -> np.ndarray:
    """NSGA-III tournament: smaller constraint violation wins, ties drawn from the run's RNG.

    pymoo's own ``comp_by_cv_then_random`` breaks equal violations without passing the
    random state (it fails then); this is the same rule with the state passed.
    """
    winners = np.empty(len(P), dtype=int)
    for i, (a, b) in enumerate(P):
        cv_a, cv_b = pop[a].CV[0], pop[b].CV[0]
        if (cv_a > 0.0 or cv_b > 0.0) and cv_a != cv_b:
            winners[i] = a if cv_a < cv_b else b
        else:
            winners[i] = random_state.choice([a, b])
    return winners[:, None]


# --- statistics and result -------------------------------------------------------------
@dataclass(frozen=True)
class GenerationStats:
    """Progress of a run after one generation (passed to ``progress`` callbacks).

    Attributes
    ----------
    generation : [-] generations completed (1 = initial population)
    generations : [-] generations of the whole run
    evaluations : [-] designs evaluated so far
    feasible_share : [-] share of this generation's designs that are feasible
    front_size : [-] designs in the archive (the non-dominated feasible set)
    hypervolume : [decades^n_obj] hypervolume of the archive in log10 space
    elapsed_s : [s] wall time of the run so far (all sessions)
    """

    generation: int
    generations: int
    evaluations: int
    feasible_share: float
    front_size: int
    hypervolume: float
    elapsed_s: float


@dataclass
class OptimizationResult:
    """What a run found: the front, every evaluation, quality and decision support.

    Attributes
    ----------
    problem : the optimised problem
    settings : algorithm settings of the run
    front : [physical units] non-dominated feasible designs of all evaluations: variable
        columns, objective columns, constraint-only quantity columns (sorted by the first
        objective)
    history : [physical units] every evaluated design: ``evaluation``, ``generation``,
        variables, quantities, ``valid``, ``feasible``
    generations : per-generation statistics (:class:`GenerationStats` fields)
    hypervolume : [decades^n_obj] hypervolume of the front in log10 space
    reference_point : [decades] the fixed hypervolume reference point (log10 of objectives)
    wall_time_s : [s] wall time of the run (all sessions)
    run_dir : the run directory (None for a run without one)
    completed : [-] False when the algorithm stopped early (no new offspring possible)
    """

    problem: "Problem"
    settings: RunSettings
    front: pd.DataFrame
    history: pd.DataFrame
    generations: pd.DataFrame
    hypervolume: float
    reference_point: np.ndarray
    wall_time_s: float
    run_dir: Path | None = None
    completed: bool = True

    @property
    def objectives(self) -> pd.DataFrame:
        """[objective units] The front's objective columns."""
        return self.front[list(self.problem.objective_names)]

    @property
    def knee(self) -> pd.Series:
        """The knee design of the front (:func:`hisopt.optim.decision.knee_index`)."""
        return self.front.iloc[knee_index(self.objectives.to_numpy())]

    def plot_front(self, refined: pd.DataFrame | None = None) -> Any:
        """Scatter matrix of the front's objectives, knee and ASF pick highlighted (plotly)."""
        from hisopt.report.figures import front_scatter_matrix

        highlights = {"knee": self.knee, "ASF pick": self.asf_pick()} if len(self.front) else {}
        return front_scatter_matrix(self.front, self.problem.objective_names, self.problem.variable_names, highlights, refined)

    def plot_parallel(self, color_by: str | None = None) -> Any:
        """Parallel coordinates of the front's variables and objectives (plotly)."""
        from hisopt.report.figures import parallel_coordinates

        names = self.problem.objective_names
        return parallel_coordinates(self.front, self.problem.variable_names, names, color_by or names[0])

    def plot_convergence(self) -> Any:
        """Hypervolume, front size and feasible share per generation (plotly)."""
        from hisopt.report.figures import convergence

        return convergence(self.generations)

    def asf_pick(
        self,
        reference: Mapping[str, float] | Sequence[float] | None = None,
        weights: Mapping[str, float] | Sequence[float] | None = None,
    ) -> pd.Series:
        """The front design closest to an aspiration point (augmented ASF, log space).

        Parameters
        ----------
        reference : [objective units] aspiration value per objective (by name or in
            objective order); default the front's ideal point; names left out take it too
        weights : [-] positive weight per objective (by name or in order); default 1 each;
            a larger weight pulls that objective closer to the reference
        """
        f = self.objectives.to_numpy()
        names = self.problem.objective_names
        ref = None
        if reference is not None:
            ideal = f.min(axis=0)
            ref = _by_objective(reference, names, "reference", default=ideal)
        w = None if weights is None else _by_objective(weights, names, "weights", default=np.ones(len(names)))
        return self.front.iloc[asf_index(f, ref, w)]


def _by_objective(values: Mapping[str, float] | Sequence[float], names: tuple[str, ...], what: str, default: np.ndarray) -> np.ndarray:
    if isinstance(values, Mapping):
        unknown = [k for k in values if k not in names]
        if unknown:
            raise ConfigError(f"unknown objective {unknown[0]!r} in the ASF {what}; expected names from {', '.join(names)}")
        return np.array([float(values.get(n, d)) for n, d in zip(names, default)])
    out = np.asarray(values, dtype=float)
    if out.shape != (len(names),):
        raise ConfigError(f"expected {len(names)} ASF {what} values (order {', '.join(names)}), got {out.shape[0] if out.ndim else 1}")
    return out


# --- the engine: algorithm, archive, history -------------------------------------------
class _Engine:
    """The state of a run between generations, with checkpoint round trips."""

    def __init__(self, problem: "Problem", settings: RunSettings, reference_log: np.ndarray):
        from pymoo.core.termination import NoTermination

        self.problem = problem
        self.settings = settings
        self.reference_log = np.asarray(reference_log, dtype=float)
        self.pymoo_problem: HisoptPymooProblem = HisoptPymooProblem(problem)
        self.quantity_names = tuple(dict.fromkeys(problem.objective_names + problem.constraint_names))
        self.n_obj = len(problem.objective_names)
        self.algorithm = build_algorithm(settings, self.n_obj)
        with warnings.catch_warnings():
            self.algorithm.setup(self.pymoo_problem, termination=NoTermination(), seed=settings.seed)
        n_var = len(problem.variable_names)
        self.archive = Archive.empty(n_var, self.n_obj, len(self.quantity_names))
        self.hist: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.stats: list[GenerationStats] = []
        self.generation = 0
        self.evaluations = 0
        self.elapsed_before = 0.0  # [s] wall time of earlier sessions
        self.session_start = time.perf_counter()
        self.evaluation_s = 0.0  # [s] time spent in the evaluator (all sessions)
        self.exhausted = False

    # -- stepping --
    def elapsed(self) -> float:
        """[s] Wall time of the run so far."""
        return self.elapsed_before + time.perf_counter() - self.session_start

    def step(self) -> GenerationStats | None:
        """Run one generation; None when pymoo cannot produce new offspring."""
        with warnings.catch_warnings():
            pop = self.algorithm.ask()
        if pop is None or len(pop) == 0:
            self.exhausted = True
            return None
        x = np.asarray(pop.get("X"), dtype=float)
        t0 = time.perf_counter()
        q = self.pymoo_problem.quantities(x)
        self.evaluation_s += time.perf_counter() - t0
        f, g = self.pymoo_problem.f_and_g(q)
        pop.set("F", f, "G", g)
        with warnings.catch_warnings():
            self.algorithm.tell(infills=pop)
        feasible = feasible_mask(g)
        n = len(x)
        ids = np.arange(self.evaluations, self.evaluations + n, dtype=np.int64)
        qm = np.column_stack([np.asarray(q[name], dtype=float) for name in self.quantity_names])
        archive = self.archive.update(x, qm[:, : self.n_obj], qm, ids, feasible)
        hv = hypervolume(archive.f, self.reference_log)
        # commit
        self.archive = archive
        self.hist.append((x, qm, np.asarray(q["valid"], dtype=bool), np.full(n, self.generation + 1, dtype=np.int64)))
        self.generation += 1
        self.evaluations += n
        stats = GenerationStats(
            self.generation, self.settings.generations, self.evaluations, float(feasible.mean()), len(archive), hv, self.elapsed()
        )
        self.stats.append(stats)
        return stats

    # -- checkpoint round trip --
    def snapshot(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(meta, arrays)`` for :func:`hisopt.optim.runio.save_checkpoint`."""
        alg = self.algorithm
        arrays: dict[str, np.ndarray] = {}
        pop = alg.pop if self.generation > 0 else []
        n_var, n_g = self.pymoo_problem.n_var, self.pymoo_problem.n_ieq_constr
        arrays["pop_X"] = np.asarray(pop.get("X"), dtype=float) if len(pop) else np.empty((0, n_var))
        arrays["pop_F"] = np.asarray(pop.get("F"), dtype=float) if len(pop) else np.empty((0, self.n_obj))
        arrays["pop_G"] = np.asarray(pop.get("G"), dtype=float) if len(pop) else np.empty((0, n_g))
        for name in SURVIVAL_FIELDS:
            values = [ind.data.get(name) for ind in pop]
            arrays[f"pop_{name}"] = np.array([np.nan if v is None else float(v) for v in values])
        norm = getattr(alg.survival, "norm", None)
        if norm is not None:
            for name in NORM_FIELDS:
                value = getattr(norm, name)
                if value is not None:
                    arrays[f"norm_{name}"] = np.asarray(value, dtype=float)
        arrays["archive_x"], arrays["archive_q"], arrays["archive_ids"] = self.archive.x, self.archive.q, self.archive.ids
        hx, hq, hv, hg = self.history_arrays()
        arrays["hist_x"], arrays["hist_q"], arrays["hist_valid"], arrays["hist_gen"] = hx, hq, hv, hg
        arrays["reference_log"] = self.reference_log
        meta = {
            "generation": self.generation,
            "evaluations": self.evaluations,
            "n_iter": int(alg.n_iter or 0),
            "settings": asdict(self.settings),
            "variables": list(self.problem.variable_names),
            "quantities": list(self.quantity_names),
            "rng": runio.generator_state(alg.random_state),
            "numpy_global_rng": runio.legacy_state(),
            "stats": [asdict(s) for s in self.stats],
            "elapsed_s": self.elapsed(),
            "evaluation_s": self.evaluation_s,
            "exhausted": self.exhausted,
        }
        return meta, arrays

    def restore(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Load a :meth:`snapshot` into this freshly set-up engine.

        Raises
        ------
        RunError
            The checkpoint belongs to other settings or another problem layout.
        """
        if meta["settings"] != asdict(self.settings):
            raise RunError(f"checkpoint settings {meta['settings']} differ from the run's {asdict(self.settings)}")
        if meta["variables"] != list(self.problem.variable_names) or meta["quantities"] != list(self.quantity_names):
            raise RunError("checkpoint variables or quantities differ from the run's problem")
        self.generation = int(meta["generation"])
        self.evaluations = int(meta["evaluations"])
        self.stats = [GenerationStats(**s) for s in meta["stats"]]
        self.elapsed_before = float(meta["elapsed_s"])
        self.evaluation_s = float(meta.get("evaluation_s", 0.0))
        self.session_start = time.perf_counter()
        self.exhausted = bool(meta.get("exhausted", False))
        self.reference_log = arrays["reference_log"]
        aq = arrays["archive_q"]
        self.archive = Archive(arrays["archive_x"], aq[:, : self.n_obj], aq, arrays["archive_ids"].astype(np.int64))
        hx, hq, hvalid, hgen = arrays["hist_x"], arrays["hist_q"], arrays["hist_valid"].astype(bool), arrays["hist_gen"]
        self.hist = [(hx, hq, hvalid, hgen.astype(np.int64))] if len(hx) else []
        if self.generation == 0:
            return
        from pymoo.core.population import Population

        alg = self.algorithm
        pop = Population.new(X=arrays["pop_X"])
        pop.set("F", arrays["pop_F"], "G", arrays["pop_G"])
        for name in SURVIVAL_FIELDS:
            values = arrays[f"pop_{name}"]
            for ind, v in zip(pop, values):
                if not np.isnan(v):
                    ind.set(name, int(v) if name in ("rank", "niche") else float(v))
        norm = getattr(alg.survival, "norm", None)
        if norm is not None:
            for name in NORM_FIELDS:
                key = f"norm_{name}"
                if key in arrays:
                    setattr(norm, name, arrays[key].copy())
        alg.pop = pop
        alg.off = None
        alg.is_initialized = True
        alg.n_iter = int(meta["n_iter"])
        runio.set_generator_state(alg.random_state, meta["rng"])
        runio.set_legacy_state(meta["numpy_global_rng"])

    # -- outputs --
    def history_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every evaluated design so far: ``(x, q, valid, generation)``."""
        if not self.hist:
            n_var, n_q = len(self.problem.variable_names), len(self.quantity_names)
            return np.empty((0, n_var)), np.empty((0, n_q)), np.empty(0, dtype=bool), np.empty(0, dtype=np.int64)
        return tuple(np.concatenate(parts) for parts in zip(*self.hist))  # type: ignore[return-value]

    def front(self) -> pd.DataFrame:
        """[physical units] The archive as the front table (variables, quantities)."""
        order = self.archive.order()
        df = pd.DataFrame(self.archive.x[order], columns=list(self.problem.variable_names))
        for j, name in enumerate(self.quantity_names):
            df[name] = self.archive.q[order, j]
        return attach_units(df, self.problem)

    def history(self) -> pd.DataFrame:
        """Every evaluated design with its generation, quantities, validity and feasibility."""
        x, q, valid, gen = self.history_arrays()
        df = pd.DataFrame({"evaluation": np.arange(len(x), dtype=np.int64), "generation": gen})
        for j, name in enumerate(self.problem.variable_names):
            df[name] = x[:, j]
        for j, name in enumerate(self.quantity_names):
            df[name] = q[:, j]
        df["valid"] = valid
        if len(x):
            _, g = self.pymoo_problem.f_and_g({name: q[:, j] for j, name in enumerate(self.quantity_names)} | {"valid": valid})
            df["feasible"] = feasible_mask(g)
        else:
            df["feasible"] = np.zeros(0, dtype=bool)
        return attach_units(df, self.problem)

    def generations_table(self) -> pd.DataFrame:
        """Per-generation statistics as a table."""
        columns = [f.name for f in GenerationStats.__dataclass_fields__.values()]
        return attach_units(pd.DataFrame([asdict(s) for s in self.stats], columns=columns), self.problem)

    def result(self, run_dir: Path | None) -> OptimizationResult:
        """The result so far."""
        hv = self.stats[-1].hypervolume if self.stats else 0.0
        return OptimizationResult(
            problem=self.problem,
            settings=self.settings,
            front=self.front(),
            history=self.history(),
            generations=self.generations_table(),
            hypervolume=hv,
            reference_point=self.reference_log.copy(),
            wall_time_s=self.elapsed(),
            run_dir=run_dir,
            completed=not self.exhausted,
        )


# --- run directory bookkeeping ---------------------------------------------------------
def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def versions() -> dict[str, str]:
    """Versions of hisopt, Python and the numerical stack (recorded in ``run.json``)."""
    import pymoo
    import scipy

    import hisopt

    return {
        "hisopt": hisopt.__version__,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
        "pymoo": pymoo.__version__,
        "platform": platform.platform(),
    }


def problem_copy(problem: "Problem") -> tuple[str, bytes, dict[str, Any]]:
    """The run's copy of the problem: ``(file name, bytes, run.json record)``.

    The problem file itself (``problem.toml``) when the problem was loaded from a file that
    is unchanged and unmodified since (``Problem.sha256`` matches and the file parses to the
    same specification); otherwise the specification as JSON (``problem.json``), e.g. for
    :func:`~hisopt.problem.problem_from_dict` or ``Problem.with_values``.
    """
    from hisopt.config import parse_problem

    path = problem.path
    if path is not None and problem.sha256 is not None and Path(path).is_file():
        raw = Path(path).read_bytes()
        if runio.sha256_bytes(raw) == problem.sha256:
            import tomllib

            try:
                same = parse_problem(tomllib.loads(raw.decode("utf-8")), str(path)) == problem.spec
            except (ConfigError, tomllib.TOMLDecodeError, UnicodeDecodeError):
                same = False
            if same:
                record = {
                    "name": problem.name,
                    "path": str(Path(path).resolve()),
                    "sha256": problem.sha256,
                    "copy": runio.PROBLEM_TOML,
                    "text": raw.decode("utf-8"),
                }
                return runio.PROBLEM_TOML, raw, record
    text = json.dumps(problem.spec.model_dump(mode="json", by_alias=True), indent=2) + "\n"
    raw = text.encode("utf-8")
    record = {
        "name": problem.name,
        "path": None,
        "derived_from": None if path is None else str(Path(path).resolve()),
        "sha256": runio.sha256_bytes(raw),
        "copy": runio.PROBLEM_JSON,
        "text": text,
    }
    return runio.PROBLEM_JSON, raw, record


def load_run_problem(run_dir: Path, record: dict[str, Any]) -> "Problem":
    """The problem of a run from its own copy, after the checks of the module's resume rule.

    Raises
    ------
    RunError
        The copy is missing or edited, or the original problem file has changed.
    """
    from hisopt.problem import load_problem, problem_from_dict

    copy = run_dir / str(record.get("copy", ""))
    if not copy.is_file():
        raise RunError(f"{copy}: the run's copy of its problem is missing")
    digest = runio.sha256_bytes(copy.read_bytes())
    if digest != record["sha256"]:
        raise RunError(
            f"{copy} was edited since the run started (sha256 {record['sha256'][:12]} -> {digest[:12]}); "
            "restore it or start a new run with `hisopt optimize`"
        )
    original = record.get("path")
    if original and Path(original).is_file():
        now = runio.sha256_bytes(Path(original).read_bytes())
        if now != record["sha256"]:
            raise RunError(
                f"{original} changed since the run started (sha256 {record['sha256'][:12]} -> {now[:12]}); "
                "resuming would mix two problems: restore the file or start a new run with `hisopt optimize`"
            )
    if copy.suffix == ".toml":
        return load_problem(copy)
    return problem_from_dict(json.loads(copy.read_text(encoding="utf-8")), str(copy))


def _summary(result: OptimizationResult) -> dict[str, Any]:
    out: dict[str, Any] = {
        "generations": int(len(result.generations)),
        "evaluations": int(len(result.history)),
        "front_size": int(len(result.front)),
        "hypervolume": result.hypervolume,
        "completed": result.completed,
    }
    if len(result.front):
        out["knee"] = {k: float(v) for k, v in result.knee.items()}
        out["asf_pick"] = {k: float(v) for k, v in result.asf_pick().items()}
    return out


def write_outputs(run_dir: Path, result: OptimizationResult) -> None:
    """``front.csv``, the evaluations and ``generations.csv`` (each atomically)."""
    write_csv(result.front, run_dir / runio.FRONT_CSV)
    interrupt.hook_point("final-write")
    write_csv(result.generations, run_dir / runio.GENERATIONS_CSV)
    try:
        import io

        buffer = io.BytesIO()
        result.history.to_parquet(buffer, index=False)
        runio.atomic_write_bytes(run_dir / runio.EVALUATIONS, buffer.getvalue())
    except ImportError:
        write_csv(result.history, run_dir / runio.EVALUATIONS_CSV)


def _update_run_json(
    run_dir: Path, info: dict[str, Any], session: dict[str, Any], status: str, engine: _Engine, result: OptimizationResult
) -> None:
    info["status"] = status
    if status == runstate.FINISHED:
        info.pop("failure", None)
    session |= {
        "ended": _now(),
        "status": status,
        "end_generation": int(len(result.generations)),
        "wall_time_s": time.perf_counter() - engine.session_start,
    }
    info["timings"] = {"wall_time_s": result.wall_time_s, "evaluation_s": engine.evaluation_s}
    info["result"] = _summary(result)
    runio.atomic_write_json(run_dir / runio.RUN_JSON, info)


# --- the driver --------------------------------------------------------------------------
ProgressFn = Callable[[GenerationStats], None]


def _drive(engine: _Engine, run_dir: Path | None, info: dict[str, Any] | None, progress: ProgressFn | None) -> OptimizationResult:
    """Run generations until done; checkpoint each; on Ctrl-C or SIGTERM save and re-raise;
    on an error record ``failed`` in ``run.json`` and re-raise (:mod:`hisopt.optim.runstate`)."""
    with interrupt.signals_as_interrupts():
        return _drive_session(engine, run_dir, info, progress)


def _drive_session(engine: _Engine, run_dir: Path | None, info: dict[str, Any] | None, progress: ProgressFn | None) -> OptimizationResult:
    keep = run_dir is not None and info is not None
    session: dict[str, Any] = {"started": _now(), "start_generation": engine.generation} | runstate.process_identity()
    if keep:
        info.setdefault("sessions", []).append(session)  # type: ignore[union-attr]
        info["status"], info["process"] = runstate.RUNNING, runstate.process_identity()  # type: ignore[index]
        runio.atomic_write_json(run_dir / runio.RUN_JSON, info)  # type: ignore[operator, arg-type]
    last = engine.snapshot() if run_dir is not None else None
    finished = False
    try:
        while engine.generation < engine.settings.generations and not engine.exhausted:
            interrupt.hook_point(f"generation-{engine.generation + 1}")
            stats = engine.step()
            if run_dir is not None:
                last = engine.snapshot()
                runio.save_checkpoint(run_dir / runio.CHECKPOINT, *last)
            if stats is not None and progress is not None:
                progress(stats)
        result = engine.result(run_dir)
        if keep:
            with interrupt.deferred():  # a signal now waits until every file is written
                write_outputs(run_dir, result)  # type: ignore[arg-type]
                _update_run_json(run_dir, info, session, runstate.FINISHED, engine, result)  # type: ignore[arg-type]
                finished = True
        return result
    except KeyboardInterrupt as exc:
        if keep and last is not None and not finished:
            session["signal"] = interrupt.signal_name(exc)
            with interrupt.deferred():  # a second Ctrl-C must not cut the save short
                clock = engine.session_start, engine.elapsed_before
                engine.restore(*last)  # the last complete generation, whatever was cut short
                engine.session_start, engine.elapsed_before = clock
                runio.save_checkpoint(run_dir / runio.CHECKPOINT, *last)  # type: ignore[operator]
                result = engine.result(run_dir)
                write_outputs(run_dir, result)  # type: ignore[arg-type]
                _update_run_json(run_dir, info, session, runstate.INTERRUPTED, engine, result)  # type: ignore[arg-type]
        raise
    except Exception as exc:
        if keep and not finished:
            with interrupt.deferred():
                runstate.record_failure(info, session, exc, engine.generation + 1)  # type: ignore[arg-type]
                runio.atomic_write_json(run_dir / runio.RUN_JSON, info)  # type: ignore[operator, arg-type]
        raise


def optimize(
    problem: "Problem | str | Path",
    *,
    out: str | Path | None = None,
    seed: int | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    algorithm: AlgorithmChoice | None = None,
    progress: ProgressFn | None = None,
) -> OptimizationResult:
    """Pareto-optimise a problem with NSGA-II/III (settings from its ``[optimizer]`` table).

    Parameters
    ----------
    problem : [-] a :class:`~hisopt.problem.Problem` or the path of a problem file
    out : [-] run directory (created; must not hold a run yet); None keeps the run in
        memory (no files, no checkpoints, not resumable)
    seed : [-] random seed; default the problem file's
    pop_size : [-] population size; default the problem file's (100)
    generations : [-] generations including the initial one; default the file's (200)
    algorithm : [-] ``"auto"`` (NSGA-III from four objectives on, else NSGA-II),
        ``"nsga2"`` or ``"nsga3"``; default the file's
    progress : [-] called with :class:`GenerationStats` after every generation

    Returns
    -------
    OptimizationResult
        Front (archive of every feasible non-dominated design evaluated), history,
        hypervolume, knee point and ASF pick.

    Raises
    ------
    ConfigError
        A setting is out of range.
    RunError
        ``out`` cannot be written or already holds a run (checked before any work).
    KeyboardInterrupt
        After Ctrl-C or SIGTERM (:class:`hisopt.interrupt.Interrupted`, in the main thread),
        once the checkpoint and partial outputs are written and ``run.json`` says
        ``interrupted`` (with ``out``). Any other error marks the run ``failed`` and propagates.
    """
    from hisopt.problem import Problem, load_problem

    if not isinstance(problem, Problem):
        problem = load_problem(problem)
    settings = resolve_settings(problem, algorithm=algorithm, pop_size=pop_size, generations=generations, seed=seed)
    if out is not None:
        runstate.refuse_occupied(out)
    run_dir = None if out is None else runio.prepare_run_directory(Path(out), fresh=True)
    started = time.perf_counter()
    info: dict[str, Any] | None = None
    if run_dir is not None:
        name, raw, record = problem_copy(problem)
        runio.atomic_write_bytes(run_dir / name, raw)
        info = {"format": "hisopt-run/1", "status": runstate.STARTING, "created": _now(), "problem": record}  # written as running
    reference = reference_point(problem)
    engine = _Engine(problem, settings, reference)
    engine.session_start = started
    if info is not None:
        info["settings"] = asdict(settings) | {
            "objectives": list(problem.objective_names),
            "constraints": [{"name": c.name, "limit": c.limit} for c in problem.spec.constraints],
            "hypervolume_reference_log10": reference.tolist(),
        }
        info["versions"] = versions()
    return _drive(engine, run_dir, info, progress)


@dataclass
class ResumePlan:
    """A run directory checked and loaded for resuming (:func:`prepare_resume`).

    Attributes
    ----------
    state : [-] the directory's state before resuming
    engine : [-] the engine restored from the checkpoint
    info : [-] the parsed ``run.json``
    """

    state: runstate.RunState
    engine: _Engine
    info: dict[str, Any]

    @property
    def finished(self) -> bool:
        """[-] The run had already finished: nothing to do."""
        return self.state.status == runstate.FINISHED

    def run(self, progress: ProgressFn | None = None) -> OptimizationResult:
        """Continue to the end (a finished run: its result, no file touched)."""
        if self.finished:
            return self.engine.result(self.state.run_dir)
        return _drive(self.engine, self.state.run_dir, self.info, progress)


def prepare_resume(run_dir: str | Path) -> ResumePlan:
    """Every check of :func:`resume`, and the restored engine, before any output.

    Raises
    ------
    RunError
        Not a run directory, a live process still runs it, the problem file changed (see the
        module's resume rule), or the checkpoint belongs to another pymoo version.
    """
    run_dir = Path(run_dir)
    state = runstate.read_state(run_dir)
    if state.status in (runstate.STARTING, runstate.RUNNING) and state.alive:
        pid = (state.info.get("process") or {}).get("pid")
        raise RunError(f"{state.line()}; wait for it to end, or stop it with `kill -TERM {pid}` and resume then")
    info = state.info
    for key in ("problem", "settings", "versions"):
        if key not in info:
            raise RunError(f"{run_dir / runio.RUN_JSON}: lacks {key!r}; the run never started, start over with another --out")
    problem = load_run_problem(run_dir, info["problem"])
    import pymoo

    if info["versions"].get("pymoo") != pymoo.__version__:
        raise RunError(
            f"{run_dir} was run with pymoo {info['versions'].get('pymoo')}, this is pymoo {pymoo.__version__}; "
            "an identical continuation needs the same version"
        )
    if state.status != runstate.FINISHED:
        runio.prepare_run_directory(run_dir, fresh=False)
    s = info["settings"]
    settings = RunSettings(s["algorithm"], int(s["pop_size"]), int(s["generations"]), int(s["seed"]))
    engine = _Engine(problem, settings, np.asarray(s["hypervolume_reference_log10"], dtype=float))
    checkpoint = run_dir / runio.CHECKPOINT
    if checkpoint.is_file():
        engine.restore(*runio.load_checkpoint(checkpoint))
    return ResumePlan(state, engine, info)


def resume(run_dir: str | Path, *, progress: ProgressFn | None = None) -> OptimizationResult:
    """Continue an interrupted, killed or failed run from its last checkpoint to the same
    final front (a finished run: its result, files untouched).

    Parameters
    ----------
    run_dir : [-] a directory written by :func:`optimize` with ``out=``
    progress : [-] called with :class:`GenerationStats` after every generation

    Raises
    ------
    RunError
        As :func:`prepare_resume`.
    """
    return prepare_resume(run_dir).run(progress)


# --- console presentation (the CLI's progress bar and summary) --------------------------
def console_progress(total: int, start: int = 0) -> tuple[Any, ProgressFn]:
    """A rich progress display (on stderr) and its callback: ``(progress, callback)``.

    Use the display as a context manager around the run.
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    progress = Progress(
        TextColumn("[bold]optimising"),
        BarColumn(),
        TextColumn("gen {task.completed:>4.0f}/{task.total:.0f}"),
        TextColumn("evals {task.fields[evals]:>6}"),
        TextColumn("feasible {task.fields[feasible]:>5}"),
        TextColumn("front {task.fields[front]:>5}"),
        TextColumn("HV {task.fields[hv]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=False,
    )
    task = progress.add_task("optimise", total=total, completed=start, evals="-", feasible="-", front="-", hv="-")

    def update(stats: GenerationStats) -> None:
        progress.update(
            task,
            completed=stats.generation,
            evals=stats.evaluations,
            feasible=f"{100 * stats.feasible_share:.0f}%",
            front=stats.front_size,
            hv=f"{stats.hypervolume:.5g}",
        )

    return progress, update


def run_with_console(
    start: Callable[[ProgressFn], OptimizationResult], *, total: int, done: int, run_dir: Path, debug: bool = False
) -> int:
    """Run ``start(progress_callback)`` under a live progress bar, then print the summary.

    Parameters
    ----------
    start : [-] starts or resumes the run with the given progress callback
    total : [-] generations of the run
    done : [-] generations already completed
    run_dir : [-] the run directory (for the resume hint)
    debug : [-] re-raise an internal error (for its traceback) instead of reporting it

    Returns
    -------
    int
        Exit code: 0; ``128 + signal`` after Ctrl-C (130) or SIGTERM (143), the checkpoint
        saved and the resume command printed on stderr; 1 after an internal error, with one
        line on stderr saying what ``run.json`` now records and what to do.
    """
    from rich.console import Console

    display, update = console_progress(total, done)
    try:
        with display:
            result = start(update)
    except KeyboardInterrupt as exc:
        print(runstate.interrupted_line(run_dir, exc), file=sys.stderr)
        return interrupt.exit_code(exc)
    except HisoptError:
        raise
    except Exception as exc:
        if debug:
            raise
        line = runstate.state_line(run_dir)
        if type(exc).__name__ not in line:  # the state line names a recorded failure itself
            line = f"{type(exc).__name__}: {exc}; {line}"
        print(f"internal error: {line} (--debug shows a traceback)", file=sys.stderr)
        return 1
    console = Console(width=120)
    for table in summary_tables(result):
        console.print(table)
    return 0


def summary_tables(result: OptimizationResult) -> list[Any]:
    """Rich tables summarising a run: totals, then the knee design and the ASF pick (with units)."""
    from rich.table import Table
    from rich.text import Text

    from hisopt.units import display_for, hypervolume_unit

    totals = Table(title=f"{result.problem.name}: {result.settings.algorithm.upper()} run summary", show_header=False)
    totals.add_column("item")
    totals.add_column("value", justify="right")
    rows = [
        ("front size", f"{len(result.front)} designs"),
        ("evaluations", f"{len(result.history)}"),
        ("generations", f"{len(result.generations)} of {result.settings.generations}"),
        ("population / seed", f"{result.settings.pop_size} / {result.settings.seed}"),
        ("wall time", f"{result.wall_time_s:.1f} s"),
        ("hypervolume (log10 objectives)", f"{result.hypervolume:.6g} {hypervolume_unit(len(result.problem.objective_names))}"),
        ("run directory", str(result.run_dir) if result.run_dir else "-"),
    ]
    for item, value in rows:
        totals.add_row(item, Text(value))
    tables: list[Any] = [totals]
    if len(result.front):
        picks = Table(title="Knee and ASF pick (closest to the ideal)")
        picks.add_column(Text("quantity [unit]"))  # Text: brackets are not rich markup
        picks.add_column("knee", justify="right")
        picks.add_column("ASF pick", justify="right")
        knee, asf = result.knee, result.asf_pick()
        units = result.front.attrs.get("units", {})
        for name in result.front.columns:
            shown = display_for(units.get(name, ""), [knee[name], asf[name]], trim=False)
            picks.add_row(Text(shown.label(name)), shown.number(knee[name]), shown.number(asf[name]))
        tables.append(picks)
    return tables


__all__ = [
    "GenerationStats",
    "OptimizationResult",
    "RunSettings",
    "build_algorithm",
    "optimize",
    "prepare_resume",
    "resolve_settings",
    "resume",
]
