"""NSGA-II/III runs of a hisopt problem: library entry points, run directories, resume.

A run drives a pymoo algorithm through its ask/tell interface: ``ask`` proposes a
generation, hisopt evaluates it in one vectorised call, ``tell`` performs survival. Every
:data:`CHECKPOINT_INTERVAL_S` seconds of wall time (after the generation that ends the
interval), at the end, and on Ctrl-C or SIGTERM the run directory receives an atomic
checkpoint (:mod:`hisopt.optim.rundir`) holding everything needed to continue bit for bit: the population with its survival
attributes, NSGA-III's normalisation state, the algorithm's random generator state, the
archive (:mod:`hisopt.optim.archive`), every evaluated design and the statistics. No pymoo
object is pickled; :func:`resume` rebuilds the algorithm from the settings, sets it up with
the same seed and loads that state into it, so an interrupted run (Ctrl-C, ``SIGKILL``)
ends with the same front as an uninterrupted one. A ``SIGKILL`` loses at most the
generations since the last checkpoint, which the resumed run computes again, identically.
The convergence stop (``until = "converged"``, :mod:`hisopt.optim.convergence`) reads only
the progress hypervolume of each generation, which the checkpoint holds, so a resumed run
stops at the same generation.

The run directory's files, the checkpoint format and the resume rule (the problem copy must
be unedited and the original file unchanged) are :mod:`hisopt.optim.rundir`'s; the state a
run directory is in, :mod:`hisopt.optim.runstate`'s.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

import hisopt.interrupt as interrupt
from hisopt.errors import ConfigError, RunError
from hisopt.optim import rundir, runstate
from hisopt.optim.catalogue_cost import catalogue_cost, wants_catalogue_cost
from hisopt.optim.decision import reference_point
from hisopt.optim.engine import Engine
from hisopt.optim.results import CatalogueCost, GenerationStats, OptimizationResult, ProgressFn
from hisopt.optim.settings import AlgorithmChoice, RunSettings, build_algorithm, resolve_settings
from hisopt.optim.thinning import EpsilonInput, epsilon_from_record, resolve_epsilon

if TYPE_CHECKING:
    from hisopt.problem import Problem

CHECKPOINT_INTERVAL_S = 10.0
"""[s] Wall time between checkpoints (also one at the end, and on Ctrl-C or SIGTERM)."""

CHECKPOINT_INTERVAL_ENV = "HISOPT_CHECKPOINT_INTERVAL_S"
"""Environment variable overriding :data:`CHECKPOINT_INTERVAL_S` (seconds; 0: every generation)."""


def checkpoint_interval() -> float:
    """[s] The checkpoint interval: :data:`CHECKPOINT_INTERVAL_ENV` if set, else the default.

    Raises
    ------
    ConfigError
        The variable is not a number of seconds >= 0.
    """
    raw = os.environ.get(CHECKPOINT_INTERVAL_ENV)
    if raw is None or not raw.strip():
        return CHECKPOINT_INTERVAL_S
    try:
        value = float(raw)
    except ValueError:
        value = -1.0
    if not value >= 0.0 or value == float("inf"):
        raise ConfigError(f"expected a number of seconds >= 0, got {raw!r}", key=CHECKPOINT_INTERVAL_ENV)
    return value


def _save(engine: Engine, run: rundir.RunDirectory) -> None:
    """Checkpoint: the evaluations since the last checkpoint as a new history chunk, then the
    checkpoint naming it (a kill between the two leaves a chunk the next checkpoint overwrites)."""
    pending = engine.pending_history()
    if pending is not None:
        engine.history_written(rundir.save_history_chunk(run.path, *pending))
    rundir.save_checkpoint(run.path / rundir.CHECKPOINT, *engine.snapshot())


def _drive(engine: Engine, run: rundir.RunDirectory | None, progress: ProgressFn | None) -> OptimizationResult:
    """Run generations until done; with a run directory, checkpoint each; on Ctrl-C or SIGTERM
    save and re-raise; on an error record ``failed`` in ``run.json`` and re-raise
    (:mod:`hisopt.optim.runstate`)."""
    with interrupt.signals_as_interrupts():
        return _drive_session(engine, run, progress)


def _drive_session(engine: Engine, run: rundir.RunDirectory | None, progress: ProgressFn | None) -> OptimizationResult:
    run_dir = None if run is None else run.path
    session: dict[str, Any] = {"started": rundir.now(), "start_generation": engine.generation} | runstate.process_identity()
    if run is not None:
        run.info.setdefault("sessions", []).append(session)
        run.info["status"], run.info["process"] = runstate.RUNNING, runstate.process_identity()
        run.write_info()
    interval = checkpoint_interval()
    saved_at = time.perf_counter()
    finished = False
    try:
        while not engine.done:
            interrupt.hook_point(f"generation-{engine.generation + 1}")
            stats = engine.step()
            if run is not None and time.perf_counter() - saved_at >= interval:
                with interrupt.deferred():
                    _save(engine, run)
                saved_at = time.perf_counter()
            if stats is not None and progress is not None:
                progress(stats)
        if run is not None:
            with interrupt.deferred():
                _save(engine, run)
        result = engine.result(run_dir)
        if wants_catalogue_cost(engine.problem):
            result.catalogue_cost, result.continuous_front = catalogue_cost(engine, result.hypervolume, progress)
        if run is not None:
            with interrupt.deferred():  # a signal now waits until every file is written
                rundir.write_outputs(run.path, result)
                _record(run, session, runstate.FINISHED, engine, result)
                finished = True
        return result
    except (KeyboardInterrupt, SystemError) as exc:
        signalled = interrupt.as_interrupt(exc)
        if signalled is None:  # a SystemError of its own: a failure, recorded as one
            if run is not None and not finished:
                with interrupt.deferred():
                    runstate.record_failure(run.info, session, exc, engine.generation + 1)
                    run.write_info()
            raise
        if run is not None and not finished:
            session["signal"] = interrupt.signal_name(signalled)
            with interrupt.deferred():  # a second Ctrl-C must not cut the save short
                engine.restore_algorithm(*engine.mark)  # the last complete generation, whatever was cut short
                _save(engine, run)
                result = engine.result(run.path)
                rundir.write_outputs(run.path, result)
                _record(run, session, runstate.INTERRUPTED, engine, result)
        if signalled is exc:
            raise
        raise signalled from None
    except Exception as exc:
        if run is not None and not finished:
            with interrupt.deferred():
                runstate.record_failure(run.info, session, exc, engine.generation + 1)
                run.write_info()
        raise


def _record(run: rundir.RunDirectory, session: dict[str, Any], status: str, engine: Engine, result: OptimizationResult) -> None:
    rundir.update_run_json(run.path, run.info, session, status, result, time.perf_counter() - engine.session_start, engine.evaluation_s)


def optimize(
    problem: Problem | str | Path,
    *,
    out: str | Path | None = None,
    seed: int | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    algorithm: AlgorithmChoice | None = None,
    until: str | None = None,
    progress: ProgressFn | None = None,
    epsilon: EpsilonInput | None = None,
    reference_log: np.ndarray | None = None,
) -> OptimizationResult:
    """Pareto-optimise a problem with NSGA-II/III (settings from its ``[optimizer]`` table).

    Parameters
    ----------
    problem : Problem | str | Path
        [-] a :class:`~hisopt.problem.Problem` or the path of a problem file
    out : str | Path | None, optional
        [-] run directory (created; must not hold a run yet); None keeps the run in
        memory (no files, no checkpoints, not resumable)
    seed : int | None, optional
        [-] random seed; default the problem file's
    pop_size : int | None, optional
        [-] population size; default the problem file's (100)
    generations : int | None, optional
        [-] generations including the initial one; default the file's (200)
    algorithm : AlgorithmChoice | None, optional
        [-] ``"auto"`` (hisopt's SMS-EMOA up to four objectives, NSGA-III above),
        ``"nsga2"``, ``"nsga3"`` or ``"smsemoa"``; default the file's
    until : str | None, optional
        [-] ``"generations"`` or ``"converged"`` (stop when the progress hypervolume gained
        less than the file's ``tolerance`` over its ``window``; ``generations`` is the cap);
        default the file's
    progress : ProgressFn | None, optional
        [-] called with :class:`GenerationStats` after every generation
    epsilon : EpsilonInput | None, optional
        [-] tolerances of the thinned front, each overriding the file's ``[optimizer]
        epsilon``: ``{"sigma_aw": "1 %", "max_roll_psd": "2e-6 rad^2/Hz"}`` or
        ``"sigma_aw=1%,max_roll_psd=2 %"`` (:mod:`hisopt.optim.thinning`); default the file's
    reference_log : np.ndarray | None, optional
        [decades] the hypervolume reference point in ``log10`` objective space, ``(n_obj,)``;
        default the problem's own (:func:`hisopt.optim.decision.reference_point`, a grid over
        the box: a few hundred evaluations). A study gives its runs one (docs/model.md §15.1)

    Returns
    -------
    OptimizationResult
        Front (archive of every feasible non-dominated design evaluated), history,
        hypervolume, knee point and ASF pick; with tolerances also the thinned front, of
        which the knee and the ASF pick are then members; for a problem with choices (and
        ``[optimizer] catalogue_cost`` on) also the continuous relaxation's front and the
        catalogue cost (:mod:`hisopt.optim.catalogue_cost`), after a second run of the
        same budget.

    Raises
    ------
    ConfigError
        A setting is out of range or a tolerance unreadable.
    RunError
        ``out`` cannot be written, already holds a run, or is a folder of another kind or a
        non-empty folder hisopt did not write (:func:`hisopt.folders.claim`; checked before any work).
    KeyboardInterrupt
        After Ctrl-C or SIGTERM (:class:`hisopt.interrupt.Interrupted`, in the main thread),
        once the checkpoint and partial outputs are written and ``run.json`` says
        ``interrupted`` (with ``out``). Any other error marks the run ``failed`` and propagates.
    """
    from hisopt.problem import Problem, load_problem

    if not isinstance(problem, Problem):
        problem = load_problem(problem)
    settings = resolve_settings(problem, algorithm=algorithm, pop_size=pop_size, generations=generations, seed=seed, until=until)
    tolerances = resolve_epsilon(problem, epsilon)
    checkpoint_interval()  # a bad override fails before any work
    if out is not None:
        from hisopt.folders import RUN, check_claim, claim

        check_claim(out, RUN)  # a folder of another kind, or a user's, is refused
        runstate.refuse_occupied(out)
    started = time.perf_counter()
    # the problem's own: a box with no evaluable design is refused before anything is written
    reference = reference_point(problem) if reference_log is None else np.array(reference_log, dtype=float)
    if reference.shape != (len(problem.objective_names),) or not np.all(np.isfinite(reference)):
        raise ConfigError(
            f"expected a finite hypervolume reference of {len(problem.objective_names)} values [decades], got {reference_log!r}", key="reference_log"
        )
    if out is not None:
        claim(out, RUN)  # marked as a run before its run.json
    run_dir = None if out is None else rundir.prepare_run_directory(Path(out), fresh=True)
    run: rundir.RunDirectory | None = None  # None: the run stays in memory
    if run_dir is not None:
        name, raw, record = rundir.problem_copy(problem)
        rundir.atomic_write_bytes(run_dir / name, raw)
        # written by the first session, as running
        run = rundir.RunDirectory(run_dir, {"format": "hisopt-run/1", "status": runstate.STARTING, "created": rundir.now(), "problem": record})
    engine = Engine(problem, settings, reference)
    engine.session_start = started
    engine.epsilon = tolerances
    if run is not None:
        info = run.info
        info["settings"] = asdict(settings) | {
            "objectives": list(problem.objective_names),
            "constraints": [
                {"name": c.name, "limit": c.limit}
                | ({"scenarios": c.scenarios} if c.scenarios else {})
                | ({"probability": c.probability} if c.probability else {})
                for c in problem.spec.constraints
            ],
            "hypervolume_reference_log10": reference.tolist(),
        }
        if tolerances is not None:
            info["settings"]["epsilon"] = tolerances.record()
        if problem.spec.scenarios:  # load cases (docs/model.md §14)
            info["settings"] |= {"scenarios": list(problem.scenario_names), "aggregate": problem.spec.robust.aggregate}
        if problem.spec.uncertain:  # statistics over common random samples (docs/model.md §18.4)
            robust = problem.spec.robust
            info["settings"]["uncertain"] = {
                "inputs": [u.input for u in problem.spec.uncertain],
                "statistic": f"mean + {robust.k:g} sd" if robust.statistic == "mean_plus_k_sigma" else robust.statistic,
                "samples": robust.samples,
                "seed": robust.seed,
            }
        info["versions"] = rundir.versions()
    return _drive(engine, run, progress)


@dataclass
class ResumePlan:
    """A run directory checked and loaded for resuming (:func:`prepare_resume`).

    Attributes
    ----------
    state : runstate.RunState
        [-] the directory's state before resuming
    engine : Engine
        [-] the engine restored from the checkpoint
    info : dict[str, Any]
        [-] the parsed ``run.json``
    """

    state: runstate.RunState
    engine: Engine
    info: dict[str, Any]

    @property
    def finished(self) -> bool:
        """[-] The run had already finished: nothing to do."""
        return self.state.status == runstate.FINISHED

    def run(self, progress: ProgressFn | None = None) -> OptimizationResult:
        """Continue to the end (a finished run: its result, no file touched)."""
        if self.finished:
            result = self.engine.result(self.state.run_dir)
            recorded = self.info.get("result", {}).get("catalogue_cost")
            if recorded is not None:
                result.catalogue_cost = CatalogueCost.from_record(recorded)
                result.continuous_front = rundir.read_front(self.state.run_dir / rundir.CONTINUOUS_FRONT_CSV)
            return result
        return _drive(self.engine, rundir.RunDirectory(self.state.run_dir, self.info), progress)


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
            raise RunError(f"{run_dir / rundir.RUN_JSON}: lacks {key!r}; the run never started, start over with another --out")
    problem = rundir.load_run_problem(run_dir, info["problem"])
    import pymoo

    if info["versions"].get("pymoo") != pymoo.__version__:
        raise RunError(
            f"{run_dir} was run with pymoo {info['versions'].get('pymoo')}, this is pymoo {pymoo.__version__}; an identical continuation needs the same version"
        )
    if state.status != runstate.FINISHED:
        rundir.prepare_run_directory(run_dir, fresh=False)
    s = info["settings"]
    settings = RunSettings(
        s["algorithm"],
        int(s["pop_size"]),
        int(s["generations"]),
        int(s["seed"]),
        s.get("until", "generations"),
        float(s.get("tolerance", RunSettings.tolerance)),
        int(s.get("window", RunSettings.window)),
    )
    engine = Engine(problem, settings, np.asarray(s["hypervolume_reference_log10"], dtype=float))
    engine.epsilon = epsilon_from_record(problem, s.get("epsilon"))
    checkpoint = run_dir / rundir.CHECKPOINT
    if checkpoint.is_file():
        engine.restore(*rundir.load_checkpoint(checkpoint))
    return ResumePlan(state, engine, info)


def resume(run_dir: str | Path, *, progress: ProgressFn | None = None) -> OptimizationResult:
    """Continue an interrupted, killed or failed run from its last checkpoint to the same
    final front (a finished run: its result, files untouched).

    Parameters
    ----------
    run_dir : str | Path
        [-] a directory written by :func:`optimize` with ``out=``
    progress : ProgressFn | None, optional
        [-] called with :class:`GenerationStats` after every generation

    Raises
    ------
    RunError
        As :func:`prepare_resume`.
    """
    return prepare_resume(run_dir).run(progress)


def optimize_or_continue(
    problem: Problem, out: Path, seed: int, pop_size: int | None, generations: int | None, reference_log: np.ndarray | None = None
) -> OptimizationResult:
    """A study's run: a new run in ``out``, or the run already there continued (or only read,
    when it has finished), so that the same study command resumes a study. ``reference_log``
    as :func:`optimize` (a continued run keeps its own).

    Raises
    ------
    RunError
        ``out`` holds a run of another problem or budget, or one that cannot be resumed.
    """
    if not (Path(out) / rundir.RUN_JSON).is_file():
        return optimize(problem, out=out, seed=seed, pop_size=pop_size, generations=generations, reference_log=reference_log)
    plan = prepare_resume(out)
    wanted = resolve_settings(problem, pop_size=pop_size, generations=generations, seed=seed)
    if plan.engine.problem.spec != problem.spec or plan.engine.settings != wanted:
        raise RunError(f"{out} holds a run of another problem or budget than this study's; choose another --out")
    return plan.run()


__all__ = [
    "GenerationStats",
    "OptimizationResult",
    "RunSettings",
    "build_algorithm",
    "optimize",
    "optimize_or_continue",
    "prepare_resume",
    "resolve_settings",
    "resume",
]
