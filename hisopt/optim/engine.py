"""The state of an optimisation run between generations: the pymoo algorithm driven through
ask/tell, the archive, every evaluated design and the statistics, with an exact checkpoint
round trip (:meth:`Engine.snapshot`, :meth:`Engine.restore`; format in :mod:`hisopt.optim.rundir`).

A generation's cost does not grow with the run: the archive grows in place and is searched
through a spatial index (:class:`hisopt.optim.archive.Archive`), the progress hypervolume is
updated from the entering designs alone (:mod:`hisopt.optim.convergence`), the
evaluations are kept as per-generation blocks (joined once, for the outputs; a checkpoint
writes only the blocks since the previous one) and the algorithm's own state (population,
survival attributes, random generators: :meth:`Engine.algorithm_state`, a fixed size) is
copied after every generation, so that an interrupted generation can be undone without a
checkpoint. The end of :meth:`Engine.step` (archive, evaluations, counters, statistics and
that copy) is committed with signals deferred, all or nothing.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

import hisopt.interrupt as interrupt
from hisopt.errors import RunError
from hisopt.optim import rundir
from hisopt.optim.archive import Archive
from hisopt.optim.convergence import ProgressHypervolume, converged
from hisopt.optim.decision import hypervolume, log_objectives
from hisopt.optim.hv_emoa import search_objectives
from hisopt.optim.pymoo_problem import HisoptPymooProblem, feasible_mask
from hisopt.optim.results import GenerationStats, OptimizationResult
from hisopt.optim.settings import RunSettings, build_algorithm, searches_in_log
from hisopt.optim.thinning import EpsilonTolerances
from hisopt.units import attach_units

if TYPE_CHECKING:
    from hisopt.problem import Problem

SURVIVAL_FIELDS = ("rank", "crowding", "niche", "dist_to_niche")
"""Per-individual attributes set by survival and read by mating (checkpointed)."""

NORM_FIELDS = ("ideal_point", "worst_point", "nadir_point", "extreme_points")
"""NSGA-III hyperplane normalisation state carried between generations (checkpointed)."""


class Engine:
    """The state of a run between generations, with checkpoint round trips."""

    def __init__(self, problem: Problem, settings: RunSettings, reference_log: np.ndarray):
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
        self.epsilon: EpsilonTolerances | None = None  # the thinned front's tolerances (hisopt.optim.thinning)
        self.progress_hv = ProgressHypervolume(self.reference_log)
        self.converged_at: int | None = None  # generation at which the convergence stop fired
        self.saved_blocks = 0  # entries of ``hist`` already written as history chunks
        self.chunks: list[dict[str, Any]] = []  # history chunk records of the run directory
        self.mark = self.algorithm_state()

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
        x = self.pymoo_problem.decode(np.asarray(pop.get("X"), dtype=float))  # choices: their listed values
        t0 = time.perf_counter()
        q = self.pymoo_problem.quantities(x)
        self.evaluation_s += time.perf_counter() - t0
        f, g = self.pymoo_problem.f_and_g(q)
        pop.set("F", search_objectives(f) if searches_in_log(self.settings.algorithm) else f, "G", g)
        with warnings.catch_warnings():
            self.algorithm.tell(infills=pop)
        feasible = feasible_mask(g)
        n = len(x)
        ids = np.arange(self.evaluations, self.evaluations + n, dtype=np.int64)
        qm = np.column_stack([np.asarray(q[name], dtype=float) for name in self.quantity_names])
        offer = self.archive.offer(x, qm[:, : self.n_obj], qm, ids, feasible)
        with interrupt.deferred():  # commit: all of it or none of it
            self.archive.apply(offer)
            self.progress_hv.add(log_objectives(offer.f))
            self.hist.append((x, qm, np.asarray(q["valid"], dtype=bool), np.full(n, self.generation + 1, dtype=np.int64)))
            self.generation += 1
            self.evaluations += n
            stats = GenerationStats(
                self.generation,
                self.settings.generations,
                self.evaluations,
                float(feasible.mean()),
                len(self.archive),
                self.progress_hv.value(),
                self.elapsed(),
            )
            self.stats.append(stats)
            self._check_convergence()
            self.mark = self.algorithm_state()
        return stats

    def _check_convergence(self) -> None:
        s = self.settings
        if s.until == "converged" and self.converged_at is None:
            if converged([st.hypervolume for st in self.stats[-s.window - 1 :]], s.window, s.tolerance):
                self.converged_at = self.generation

    @property
    def done(self) -> bool:
        """[-] The run has reached its generations, its convergence stop or its last offspring."""
        return self.generation >= self.settings.generations or self.exhausted or self.converged_at is not None

    # -- checkpoint round trip --
    def algorithm_state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(meta, arrays)`` of the algorithm alone: population with its survival attributes,
        normalisation state, iteration counter and random generators (a fixed size).

        Generic over pymoo algorithms: every per-individual attribute survival set (any name
        in the individuals' ``data`` with a number) and, when the survival has a ``norm``,
        its :data:`NORM_FIELDS`.
        """
        alg = self.algorithm
        arrays: dict[str, np.ndarray] = {}
        pop: Any = alg.pop if self.generation > 0 and alg.pop is not None else []
        n_var, n_g = self.pymoo_problem.n_var, self.pymoo_problem.n_ieq_constr
        arrays["pop_X"] = np.asarray(pop.get("X"), dtype=float) if len(pop) else np.empty((0, n_var))
        arrays["pop_F"] = np.asarray(pop.get("F"), dtype=float) if len(pop) else np.empty((0, self.n_obj))
        arrays["pop_G"] = np.asarray(pop.get("G"), dtype=float) if len(pop) else np.empty((0, n_g))
        for name in SURVIVAL_FIELDS:
            values = [ind.data.get(name) for ind in pop]
            arrays[f"pop_{name}"] = np.array([np.nan if v is None else float(v) for v in values])
        norm = getattr(getattr(alg, "survival", None), "norm", None)
        if norm is not None:
            for name in NORM_FIELDS:
                value = getattr(norm, name, None)
                if value is not None:
                    arrays[f"norm_{name}"] = np.array(value, dtype=float)
        meta = {
            "n_iter": int(alg.n_iter or 0),
            "rng": rundir.generator_state(alg.random_state),
            "numpy_global_rng": rundir.legacy_state(),
        }
        return meta, arrays

    def snapshot(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(meta, arrays)`` for :func:`hisopt.optim.rundir.save_checkpoint`: the algorithm's
        state after the last complete generation, the archive, the progress hypervolume, the
        statistics and the list of history chunks (the evaluations themselves are in the
        chunks; :meth:`pending_history` gives the ones not yet written)."""
        alg_meta, arrays = self.mark
        arrays = dict(arrays)
        arrays["archive_x"], arrays["archive_q"], arrays["archive_ids"] = self.archive.x, self.archive.q, self.archive.ids
        arrays["progress_rho"] = self.progress_hv.rho.copy()
        arrays["reference_log"] = self.reference_log
        meta = alg_meta | {
            "generation": self.generation,
            "evaluations": self.evaluations,
            "settings": asdict(self.settings),
            "variables": list(self.problem.variable_names),
            "quantities": list(self.quantity_names),
            "stats": [asdict(s) for s in self.stats],
            "elapsed_s": self.elapsed(),
            "evaluation_s": self.evaluation_s,
            "exhausted": self.exhausted,
            "converged_at": self.converged_at,
            "history_chunks": list(self.chunks),
        }
        return meta, arrays

    def pending_history(self) -> tuple[int, tuple[np.ndarray, ...]] | None:
        """``(first evaluation, (x, q, valid, generation))`` of the evaluations not yet in a
        history chunk, or None; :meth:`history_written` records them as written."""
        if self.saved_blocks >= len(self.hist):
            return None
        first = sum(len(block[0]) for block in self.hist[: self.saved_blocks])
        parts = tuple(np.concatenate(p) for p in zip(*self.hist[self.saved_blocks :], strict=True))
        return first, parts

    def history_written(self, record: dict[str, Any]) -> None:
        """Record that :meth:`pending_history` is now the history chunk ``record``."""
        self.chunks.append(record)
        self.saved_blocks = len(self.hist)

    def restore_algorithm(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Load an :meth:`algorithm_state` into the algorithm (the run's counters untouched)."""
        if self.generation == 0:
            return
        from pymoo.core.population import Population

        alg = self.algorithm
        pop = Population.new(X=arrays["pop_X"])
        pop.set("F", arrays["pop_F"], "G", arrays["pop_G"])
        for name in SURVIVAL_FIELDS:
            values = arrays[f"pop_{name}"]
            for ind, v in zip(pop, values, strict=True):
                if not np.isnan(v):
                    ind.set(name, int(v) if name in ("rank", "niche") else float(v))
        norm = getattr(getattr(alg, "survival", None), "norm", None)
        if norm is not None:
            for name in NORM_FIELDS:
                key = f"norm_{name}"
                if key in arrays:
                    setattr(norm, name, arrays[key].copy())
        alg.pop = pop
        alg.off = None
        alg.is_initialized = True
        alg.n_iter = int(meta["n_iter"])
        rundir.set_generator_state(alg.random_state, meta["rng"])
        rundir.set_legacy_state(meta["numpy_global_rng"])

    def restore(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Load a :meth:`snapshot` (with its history, as :func:`hisopt.optim.rundir.load_checkpoint`
        gives it) into this freshly set-up engine.

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
        self.converged_at = meta.get("converged_at")
        self.reference_log = arrays["reference_log"]
        aq = arrays["archive_q"]
        self.archive = Archive(arrays["archive_x"], aq[:, : self.n_obj], aq, arrays["archive_ids"].astype(np.int64))
        self.progress_hv = ProgressHypervolume(self.reference_log)
        if "progress_rho" in arrays:
            self.progress_hv.rho = arrays["progress_rho"].astype(float)
        else:  # a checkpoint of format 1: the estimate from the archive (the same numbers)
            self.progress_hv.add(log_objectives(self.archive.f))
        hx, hq, hvalid, hgen = arrays["hist_x"], arrays["hist_q"], arrays["hist_valid"].astype(bool), arrays["hist_gen"]
        self.hist = [(hx, hq, hvalid, hgen.astype(np.int64))] if len(hx) else []
        self.chunks = list(meta.get("history_chunks", []))
        self.saved_blocks = len(self.hist) if self.chunks else 0
        self.restore_algorithm(meta, arrays)
        self.mark = self.algorithm_state()

    # -- outputs --
    def history_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every evaluated design so far: ``(x, q, valid, generation)``."""
        if not self.hist:
            n_var, n_q = len(self.problem.variable_names), len(self.quantity_names)
            return np.empty((0, n_var)), np.empty((0, n_q)), np.empty(0, dtype=bool), np.empty(0, dtype=np.int64)
        return tuple(np.concatenate(parts) for parts in zip(*self.hist, strict=True))  # type: ignore[return-value]

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
        hv = hypervolume(self.archive.f, self.reference_log)  # exact (the progress figure is an estimate)
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
            epsilon=self.epsilon,
            converged_at=self.converged_at,
        )
