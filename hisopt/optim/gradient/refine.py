"""Gradient refinement of a Pareto front: one NLP per design, by batched SLP or by IPOPT.

An evolutionary front (:mod:`hisopt.optim.run`) is close to the Pareto front but not on
it. From each of up to ``max_points`` designs spread evenly over the front, an
achievement-scalarising NLP moves the design towards the Pareto front; the standard
evaluator then decides what to keep. Two solvers of the NLP:

- ``method="slp"`` (default): trust-region SLP on the evaluator itself, every design at once
  and from several starts each (:mod:`hisopt.optim.gradient.asf_slp`), about 0.05 s per design;
- ``method="ipopt"``: IPOPT on the CasADi model with exact gradients
  (:mod:`hisopt.optim.gradient.casadi_model`), one design at a time, described below.

The NLP of one start design (reference ``r`` = the start's objectives; ``z = log10`` of the
objectives; ``w`` = 1 / the front's log10 range per objective, so every objective counts in
units of the front's spread; decision variables ``u`` = the design scaled to [0, 1] over its
bounds, the ASF level ``s`` and a log10 epigraph level ``t_j`` per band-maximum quantity)::

    minimise    s + rho * sum_i w_i (z_i(u) - r_i)
    subject to  w_i (z_i(u) - r_i) <= s                  every objective i   (ASF epigraph)
                w_i (z_i(u) - r_i) <= -m_i               every objective i   (none worse)
                log10 S_j(f_k; u) <= t_j                 maxima j, their nodes k
                z_c(u) <= log10(limit_c)                 every problem constraint c
                max(0, u_c - Delta) <= u <= min(1, u_c + Delta)

``z`` of a band maximum is its level ``t_j``; integrals (``sigma_aw``, ``rms_*``) are sums
over Gauss-Legendre nodes. The nodes are the evaluator's pole-aware nodes at the current
design ``u_c`` (:meth:`hisopt.evaluation.evaluate.Evaluator.nodes`), fixed during a solve, plus a
cluster around every local PSD peak within ``peak_share`` of a maximum (offsets
``cluster_offsets`` in half-power half-widths of the nearest mode; the continuous peak itself
is a node, so the model equals the evaluator at ``u_c``). A maximum's epigraph uses its
clusters and the nodes where the PSD is at least ``node_share`` of the maximum. The margins
``m`` start tiny (IPOPT's tolerance) and grow when the evaluator finds an objective worse
than the model promised.

Trust region: the NLP is solved in rounds. Each solution is re-evaluated with the standard
evaluator (continuous maxima, its own nodes); if it weakly dominates the start and lowers the
NLP's objective it becomes the new centre ``u_c`` (nodes rebuilt there), otherwise ``Delta``
shrinks. A refined design is kept only if, re-evaluated, it weakly dominates its start and
is strictly better in at least one objective (in fact the rounds demand a lower ASF merit).

Starting points: the best design in each objective, then farthest-point sampling in the
front's normalised log10 objective space (deterministic).

Output: the refined front, i.e. the kept refined designs plus every original design none of
them dominates, with the columns of ``front.csv`` plus ``source_index`` (the ``front.csv``
row a design started from; an unrefined design's own row). Hypervolumes are those of
:func:`hisopt.optim.decision.hypervolume` (log10 objectives, the problem's fixed reference
point, or the one a run directory recorded).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import integer, of_type, problem_argument
from hisopt.errors import ConfigError, RunError
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.gradient.asf_nlp import Part, RefineSettings, node_plan, solve_asf
from hisopt.optim.gradient.asf_slp import SlpSettings, asf_merit, refine_designs

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.problem import Problem


@dataclass(frozen=True)
class PointResult:
    """Outcome of refining one front design.

    Attributes
    ----------
    source_index : int
        [-] row of the front the refinement started from
    x : np.ndarray
        [variable units] final design (the start when nothing better was found), ``(n_var,)``
    quantities : dict[str, float]
        [physical units] the final design's objectives and constraints (evaluator)
    accepted : bool
        [-] the final design weakly dominates the start and is better somewhere
    asf : float
        [-] worst weighted log10 change of an objective against the start (<= 0)
    merit : float
        [-] the NLP objective of the final design (0 for the start)
    rounds : int
        [-] NLP solves performed (IPOPT), or SLP steps taken on the way to the result (SLP)
    iterations : int
        [-] IPOPT iterations over all rounds, or linear programmes over all starts (SLP)
    seconds : float
        [s] wall time of this point (SLP: its share of its batch's)
    status : str
        [-] IPOPT return status of the last solve, or why the chosen SLP start stopped
    """

    source_index: int
    x: np.ndarray
    quantities: dict[str, float]
    accepted: bool
    asf: float
    merit: float
    rounds: int
    iterations: int
    seconds: float
    status: str


@dataclass
class RefineResult:
    """Refined front and per-point records.

    Attributes
    ----------
    front : pd.DataFrame
        [physical units] the refined front (module docstring)
    points : pd.DataFrame
        one row per start design: ``source_index``, ``accepted``, ``asf``, ``merit``,
        ``rounds``, ``iterations``, ``seconds``, ``status``, the final variables and quantities
    hypervolume_before, hypervolume_after : float
        [decades^n_obj] of the input and refined fronts
    reference_point : np.ndarray
        [decades] hypervolume reference point (log10 of the objectives)
    wall_time_s : float
        [s] wall time of the whole refinement (worker start-up included)
    """

    front: pd.DataFrame
    points: pd.DataFrame
    hypervolume_before: float
    hypervolume_after: float
    reference_point: np.ndarray
    wall_time_s: float

    @property
    def hypervolume_gain(self) -> float:
        """[-] Relative hypervolume gain ``after / before - 1``."""
        if self.hypervolume_before <= 0:
            return 0.0 if self.hypervolume_after <= 0 else np.inf
        return self.hypervolume_after / self.hypervolume_before - 1.0

    @property
    def seconds_per_point(self) -> float:
        """[s] Wall time per start design."""
        return self.wall_time_s / max(len(self.points), 1)

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (what ``refine.json`` holds besides the settings)."""
        return {
            "points": int(len(self.points)),
            "accepted": int(self.points["accepted"].sum()) if len(self.points) else 0,
            "front_size": int(len(self.front)),
            "hypervolume_before": self.hypervolume_before,
            "hypervolume_after": self.hypervolume_after,
            "hypervolume_gain": self.hypervolume_gain,
            "hypervolume_reference_log10": self.reference_point.tolist(),
            "wall_time_s": self.wall_time_s,
            "seconds_per_point": self.seconds_per_point,
        }


# --- choosing the starting points ------------------------------------------------------------
def check_max_points(max_points: int) -> int:
    """``max_points`` as an int, refused (``--max-points``, as the command names it) unless
    a whole number >= 1; ``hisopt refine`` and the library call this one check."""
    return integer(max_points, "--max-points", minimum=1, what="point to refine")


def select_points(f: np.ndarray, max_points: int) -> np.ndarray:
    """[-] Rows of front ``f`` (n, k) spread evenly over it, at most ``max_points``, sorted.

    The best design in each objective first, then repeatedly the design farthest (Euclidean,
    normalised log10 objectives) from those chosen.

    Raises
    ------
    ConfigError
        ``max_points`` is below 1.
    """
    from hisopt.optim.decision import normalised_log

    max_points = check_max_points(max_points)
    n = len(f)
    if n <= max_points:
        return np.arange(n)
    z, _ = normalised_log(f)
    chosen = list(dict.fromkeys(int(i) for i in np.argmin(z, axis=0)))[:max_points]
    dist = np.min(np.linalg.norm(z[:, None, :] - z[None, chosen, :], axis=2), axis=1)
    while len(chosen) < max_points:
        i = int(np.argmax(dist))
        chosen.append(i)
        dist = np.minimum(dist, np.linalg.norm(z - z[i], axis=1))
    return np.sort(np.array(chosen))


def asf_weights(f: np.ndarray) -> np.ndarray:
    """[1/decade] ASF weights: reciprocal log10 range of each objective over the front ``f``.

    An objective with no spread gets the largest other weight (1 when none spreads).
    """
    from hisopt.optim.decision import log_objectives

    z = log_objectives(f)
    span = z.max(axis=0) - z.min(axis=0)
    spread = span > 0
    w = np.where(spread, 1.0 / np.where(spread, span, 1.0), 0.0)
    return np.where(spread, w, w.max() if spread.any() else 1.0)


# --- one start design: trust-region rounds -----------------------------------------------------
def _merit(gap: np.ndarray, rho: float) -> float:
    """[-] The NLP objective at a design whose weighted log10 changes are ``gap``."""
    return float(asf_merit(gap, rho))


def _evaluate(problem: Problem, x: np.ndarray) -> dict[str, float]:
    q = problem.evaluator()(np.asarray(x, dtype=float)[None, :])
    return {k: float(v[0]) for k, v in q.items()}


def _feasible(problem: Problem, q: dict[str, float]) -> bool:
    return bool(q["valid"]) and all(q[c.name] <= c.limit for c in problem.spec.constraints)


def refine_point(
    problem: Problem,
    parts: list[Part],
    source_index: int,
    x0: np.ndarray,
    f0: np.ndarray,
    weights: np.ndarray,
    settings: RefineSettings,
) -> PointResult:
    """Refine one front design by trust-region rounds of the ASF NLP (module docstring).

    Parameters
    ----------
    source_index : int
        [-] the design's row in the front (recorded only)
    x0 : np.ndarray
        [variable units] start design, ``(n_var,)``
    f0 : np.ndarray
        [objective units] the start's objectives as the front records them, ``(n_obj,)``
    weights : np.ndarray
        [1/decade] ASF weights, ``(n_obj,)``
    """
    from hisopt.optim.decision import log_objectives

    started = time.perf_counter()
    lower, span = problem.lower, problem.upper - problem.lower
    names = problem.objective_names
    ref = log_objectives(np.asarray(f0, dtype=float)[None, :])[0]
    u_c = np.clip((np.asarray(x0, dtype=float) - lower) / span, 0.0, 1.0)
    best_x, best_q, best_merit, best_asf = np.asarray(x0, dtype=float), None, 0.0, 0.0
    margin = np.full(len(names), settings.margin)
    radius, rounds, iterations, status = settings.trust_radius, 0, 0, "not_started"
    while rounds < settings.rounds and radius >= settings.min_radius:
        planned = [replace(p, plan=node_plan(p.problem, p.model, p.design(lower + span * u_c), settings)) for p in parts]
        outcome = solve_asf(problem, planned, u_c, ref, weights, radius, settings, margin)
        rounds, iterations, status = rounds + 1, iterations + outcome.iterations, outcome.status
        x_new = lower + span * outcome.u
        q = _evaluate(problem, x_new)
        gap = weights * (log_objectives(np.array([[q[n] for n in names]]))[0] - ref)
        merit = _merit(gap, settings.rho)
        if _feasible(problem, q) and np.all(gap <= 0.0) and merit < best_merit:
            gain = best_merit - merit
            u_c, best_x, best_q, best_merit, best_asf = outcome.u, x_new, q, merit, float(np.max(gap))
            if gain < settings.min_gain:  # converged: the model offers nothing more here
                break
        elif np.all(outcome.gap <= -margin + 1e-12) and np.any(gap > 0.0):
            # The model promised no loss but the evaluator sees one: demand that much more.
            margin = margin + 2.0 * np.maximum(gap - outcome.gap, 0.0)
            radius /= 2.0
        else:
            radius /= 4.0
    if best_q is None:
        best_q = _evaluate(problem, best_x)
    return PointResult(
        source_index=int(source_index),
        x=best_x,
        quantities={k: v for k, v in best_q.items() if k != "valid"},
        accepted=best_merit < 0.0,
        asf=best_asf,
        merit=best_merit,
        rounds=rounds,
        iterations=iterations,
        seconds=time.perf_counter() - started,
        status=status,
    )


# --- one quantity under limits (epsilon-constraint) -------------------------------------------
def constrained_problem(problem: Problem, objective: str, limits: dict[str, float]) -> Problem:
    """``problem`` with the single objective ``objective`` and ``limits`` as constraints
    (a limit on an already constrained quantity keeps the tighter of the two).

    Parameters
    ----------
    objective : str
        [-] quantity to minimise, e.g. ``"sigma_aw"``
    limits : dict[str, float]
        [quantity units] upper limit per quantity, e.g. ``{"roll_gradient": 0.03}``
    """
    from hisopt.problem import problem_from_dict

    data = problem.spec.model_dump(by_alias=True)
    constraints = {c["name"]: dict(c) for c in data["constraints"]}
    for name, limit in limits.items():
        old = constraints.get(name, {}).get("limit", np.inf)
        # a constraint keeps the scenarios it holds in (docs/model.md §14.1)
        constraints[name] = constraints.get(name, {"name": name}) | {"limit": float(min(limit, old))}
    data["objectives"] = [objective]
    data["constraints"] = list(constraints.values())
    if data["scenarios"] and data["robust"]["aggregate"] == "per_scenario":  # one objective: its worst case
        data["robust"]["aggregate"] = "worst"
    return problem_from_dict(data, f"{problem.name} ({objective} under limits)", warn_implausible=False)  # checked when read


def refine_constrained(
    problem: Problem,
    x0: np.ndarray,
    objective: str,
    limits: dict[str, float],
    settings: RefineSettings | SlpSettings | None = None,
    *,
    method: str = "ipopt",
    compile: bool = False,
) -> PointResult:
    """Minimise ``objective`` subject to the problem's constraints and ``limits`` from ``x0``.

    The epsilon-constraint form of the refinement, the NLP of :func:`constrained_problem` (one
    objective, so the ASF NLP minimises ``log10`` of it with every limit as a constraint):
    by batched SLP on the evaluator (``method="slp"``,
    :func:`~hisopt.optim.gradient.asf_slp.refine_designs` with :data:`CONSTRAINED_SLP`: no
    compilation, every quantity the evaluator computes) or by IPOPT on the CasADi model
    (``"ipopt"``: :func:`refine_point`, inside the trust region). The result is kept
    (``accepted``) only if the evaluator finds it feasible, every limit met exactly, and
    strictly better than ``x0``; otherwise ``x`` is ``x0``.

    Parameters
    ----------
    x0 : np.ndarray
        [variable units] a start design meeting every limit, ``(n_var,)``
    objective, limits
        as :func:`constrained_problem`
    settings : RefineSettings | SlpSettings | None, optional
        the method's settings (default :class:`RefineSettings`, or :data:`CONSTRAINED_SLP`)
    method : str, optional
        [-] ``"ipopt"`` or ``"slp"`` (:data:`METHODS`)
    compile : bool, optional
        compile the CasADi model's node functions to C (:func:`~hisopt.optim.gradient.casadi_model.compiled`)
        instead of evaluating them on CasADi's virtual machine. Off by default: a compilation
        costs seconds to minutes per model (every layout and load case has its own), a few
        such NLPs far less; both give the same numbers (docs/model.md §15.4). IPOPT only.
    """
    settings = CONSTRAINED_SLP if method == "slp" and settings is None else method_settings(method, settings)
    sub = constrained_problem(problem, objective, limits)
    x0 = np.asarray(x0, dtype=float)
    start = _evaluate(sub, x0)
    if isinstance(settings, SlpSettings):
        return _slp_task([(0, x0, np.array([start[objective]]))], sub, np.ones(1), settings)[0]
    # The CasADi model does not depend on the limits (they enter the NLP's bounds): one per
    # problem and set of constrained quantities, whatever their limits.
    parts = _worker_parts(_limits_one(sub), compile)
    return refine_point(sub, parts, 0, x0, np.array([start[objective]]), np.ones(1), settings)


CONSTRAINED_SLP = SlpSettings(iterations=60, correction=True)
"""The SLP settings of :func:`refine_constrained`: steps corrected back onto a binding limit,
and more iterations than a front's refinement, since sliding along that limit takes short
steps (on the six catalogue layouts of the paper's problem 25 iterations left one 0.8 %
short of IPOPT, 60 reach it: docs/model.md §15.4)."""


def _limits_one(problem: Problem) -> Problem:
    """``problem`` with every constraint limit 1 (a cache key that ignores the limits)."""
    from hisopt.problem import problem_from_dict

    data = problem.spec.model_dump(by_alias=True)
    data["constraints"] = [c | {"limit": 1.0} for c in data["constraints"]]
    return problem_from_dict(data, problem.name, warn_implausible=False)  # a cache key, not a problem to warn about


# --- many start designs, in parallel --------------------------------------------------------
_WORKER: dict[str, Any] = {}
"""Per-process cache: the problem and its CasADi model (built once per worker)."""


def model_parts(problem: Problem, compile: bool = True) -> list[Part]:
    """The load cases of ``problem`` with their CasADi models (one part without scenarios),
    their node functions compiled to C unless ``compile`` is false (:class:`~hisopt.optim.gradient.casadi_model.CasadiModel`)."""
    from hisopt.optim.gradient.casadi_model import CasadiModel
    from hisopt.optim.gradient.sample_parts import sample_cases, uses_samples

    if uses_samples(problem):  # one part per common random sample (docs/model.md §18.4)
        return [Part(c.name, c.space, CasadiModel(c.space, compile), None, c.shift, c.scale, c.road) for c in sample_cases(problem)]
    if not problem.spec.scenarios:
        return [Part(None, problem, CasadiModel(problem, compile))]
    spaces = [(name, problem.scenario_space(name)) for name in problem.scenario_names]
    return [Part(name, space, CasadiModel(space, compile)) for name, space in spaces]  # type: ignore[arg-type]


def _worker_parts(problem: Problem, compile: bool = True) -> list[Part]:
    key = (problem.spec.model_dump_json(), compile)
    if _WORKER.get("key") != key:
        _WORKER.update(key=key, problem=problem, parts=model_parts(problem, compile))
    return _WORKER["parts"]


def _refine_task(task: tuple[int, np.ndarray, np.ndarray], problem: Problem, weights: np.ndarray, settings: RefineSettings) -> PointResult:
    """Refine one ``(source_index, x0, f0)`` by IPOPT in whichever process runs it."""
    parts = _worker_parts(problem)
    return refine_point(_WORKER["problem"], parts, task[0], task[1], task[2], weights, settings)


def _slp_task(chunk: list[tuple[int, np.ndarray, np.ndarray]], problem: Problem, weights: np.ndarray, settings: SlpSettings) -> list[PointResult]:
    """Refine a chunk of ``(source_index, x0, f0)`` together by SLP in whichever process runs it."""
    started = time.perf_counter()
    keys = np.array([t[0] for t in chunk])
    result = refine_designs(problem, np.array([t[1] for t in chunk]), np.array([t[2] for t in chunk]), keys, weights, settings)
    share = (time.perf_counter() - started) / len(chunk)
    quantities = {k: v for k, v in result.quantities.items() if k != "valid"}
    return [
        PointResult(
            source_index=int(keys[i]),
            x=result.x[i],
            quantities={k: float(v[i]) for k, v in quantities.items()},
            accepted=bool(result.merit[i] < 0.0),
            asf=float(result.asf[i]),
            merit=float(result.merit[i]),
            rounds=int(result.steps[i]),
            iterations=int(result.iterations[i]),
            seconds=share,
            status=result.status[i],
        )
        for i in range(len(chunk))
    ]


METHODS = ("slp", "ipopt")
"""[-] Solvers of the refinement NLP (module docstring)."""


def refine_front(
    problem: Problem,
    front: pd.DataFrame,
    max_points: int = 40,
    *,
    method: str = "slp",
    settings: RefineSettings | SlpSettings | None = None,
    backend: Backend | None = None,
    reference_log: np.ndarray | None = None,
    progress: Callable[[PointResult], None] | None = None,
    source: str = "front",
) -> RefineResult:
    """Refine up to ``max_points`` designs spread over ``front`` (module docstring).

    Parameters
    ----------
    problem : Problem
        the problem the front belongs to
    front : pd.DataFrame
        [physical units] the front: the variable columns and objective columns (and any
        constraint columns), one row per design, as ``front.csv``
    max_points : int, optional
        [-] most start designs
    method : str, optional
        [-] ``"slp"`` (batched trust-region SLP on the evaluator) or ``"ipopt"`` (CasADi and
        IPOPT, one design at a time); see the module docstring
    settings : RefineSettings | SlpSettings | None, optional
        the method's settings (default :class:`~hisopt.optim.gradient.asf_slp.SlpSettings`
        for SLP, :class:`RefineSettings` for IPOPT)
    backend : Backend | None, optional
        where the NLPs run: this process (default) or a Dask cluster
        (:func:`hisopt.evaluation.parallel.open_backend`), one task per start design (IPOPT) or
        per fixed-size chunk of them (SLP: the same chunks whatever the workers, so the
        same result)
    reference_log : np.ndarray | None, optional
        [decades] hypervolume reference point; default the problem's
        (:func:`hisopt.optim.decision.reference_point`)
    progress : Callable[[PointResult], None] | None, optional
        called with each finished :class:`PointResult` (in completion order)
    source : str, optional
        [-] where the front comes from (named in errors), e.g. its file

    Raises
    ------
    ConfigError
        ``max_points < 1``, an unknown method or settings of another method, the front lacks a
        variable or objective column, or a row is not a valid start (:func:`start_designs`).
    RunError
        ``method="ipopt"`` on damper valves whose RMS flows are solved
        (:func:`~hisopt.optim.gradient.casadi_model.check_valve_flows_given`).
    """
    from hisopt.evaluation.parallel import Backend
    from hisopt.optim.decision import hypervolume, reference_point

    started = time.perf_counter()
    problem_argument(problem)
    of_type(front, pd.DataFrame, "front", "a DataFrame of the front (hisopt.read_csv of front.csv)")
    check_max_points(max_points)
    settings = method_settings(method, settings)
    if method == "ipopt":  # before any task, not once per worker
        from hisopt.optim.gradient.casadi_model import check_valve_flows_given

        check_valve_flows_given(problem)
    names = list(problem.objective_names)
    var_names = list(problem.variable_names)
    missing = [c for c in var_names + names if c not in front.columns]
    if missing:
        raise ConfigError(f"the front lacks the column {missing[0]!r}; expected columns {', '.join(var_names + names)}")
    front = front.reset_index(drop=True)
    x, f = start_designs(problem, front, source)
    reference = reference_point(problem) if reference_log is None else np.asarray(reference_log, dtype=float)
    chosen = select_points(f, max_points) if len(front) else np.zeros(0, dtype=int)
    weights = asf_weights(f) if len(front) else np.ones(len(names))
    tasks = [(int(i), x[i], f[i]) for i in chosen]
    backend = backend or Backend()
    if isinstance(settings, SlpSettings):
        chunks = [tasks[i : i + settings.chunk] for i in range(0, len(tasks), settings.chunk)]

        def report_chunk(_: int, chunk: list[PointResult]) -> None:
            for point in chunk:
                if progress is not None:
                    progress(point)

        results = [r for chunk in backend.map(_slp_task, chunks, problem, weights, settings, on_result=report_chunk) for r in chunk]
    else:
        report = None if progress is None else (lambda _, result: progress(result))
        results = backend.map(_refine_task, tasks, problem, weights, settings, on_result=report)

    from hisopt.units import attach_units

    points = attach_units(_points_frame(problem, results), problem)
    refined = attach_units(_refined_front(problem, front, results), problem)
    return RefineResult(
        front=refined,
        points=points,
        hypervolume_before=hypervolume(f, reference),
        hypervolume_after=hypervolume(refined[names].to_numpy(dtype=float), reference),
        reference_point=reference,
        wall_time_s=time.perf_counter() - started,
    )


def method_settings(method: str, settings: RefineSettings | SlpSettings | None) -> RefineSettings | SlpSettings:
    """The settings of refinement ``method`` (its defaults when ``settings`` is None).

    Raises
    ------
    ConfigError
        ``method`` is not one of :data:`METHODS`, or ``settings`` belong to the other method.
    """
    if method not in METHODS:
        raise ConfigError(f"expected a refinement method of {', '.join(METHODS)}, got {method!r}", key="--method")
    expected = SlpSettings if method == "slp" else RefineSettings
    if settings is None:
        return expected()
    if not isinstance(settings, expected):
        raise ConfigError(f"expected {expected.__name__} for method {method!r}, got {type(settings).__name__}", key="--method")
    return settings


def start_designs(problem: Problem, front: pd.DataFrame, source: str = "front") -> tuple[np.ndarray, np.ndarray]:
    """Start designs ``x`` (n, n_var) and their objectives ``f`` (n, n_obj) from a front, checked
    by the same rules as every design (:mod:`hisopt.specification.validation`).

    Raises
    ------
    ConfigError
        A row breaks a parameter's rule, lies outside the box, or has a non-finite objective
        (the row, counted from 1, is named).
    """
    from hisopt.specification.validation import check_designs, design_matrix

    x = design_matrix(problem, front[list(problem.variable_names)], source)
    f = front[list(problem.objective_names)].to_numpy(dtype=float)
    check = check_designs(problem, x)
    bad = np.flatnonzero(~check.ok)
    if len(bad):
        i = int(bad[0])
        raise ConfigError(f"row {i + 1}: {check.detail[i]}; expected start designs inside the box", file=source)
    bad = np.flatnonzero(~np.all(np.isfinite(f), axis=1))
    if len(bad):
        i = int(bad[0])
        raise ConfigError(f"row {i + 1}: expected finite objective values, got {dict(zip(problem.objective_names, f[i].tolist(), strict=True))}", file=source)
    return x, f


def _points_frame(problem: Problem, results: list[PointResult]) -> pd.DataFrame:
    rows = []
    for r in results:
        row = {
            "source_index": r.source_index,
            "accepted": r.accepted,
            "asf": r.asf,
            "merit": r.merit,
            "rounds": r.rounds,
            "iterations": r.iterations,
            "seconds": r.seconds,
            "status": r.status,
        }
        row |= dict(zip(problem.variable_names, r.x.tolist(), strict=True))
        row |= r.quantities
        rows.append(row)
    return pd.DataFrame(rows)


def _refined_front(problem: Problem, front: pd.DataFrame, results: list[PointResult]) -> pd.DataFrame:
    """The kept refined designs plus the original designs none of them dominates."""
    original = front.copy()
    original["source_index"] = np.arange(len(front))
    rows = []
    for r in results:
        if not r.accepted:
            continue
        row = {c: np.nan for c in front.columns}
        row |= dict(zip(problem.variable_names, r.x.tolist(), strict=True))
        row |= {k: v for k, v in r.quantities.items() if k in front.columns}
        row["source_index"] = r.source_index
        rows.append(row)
    merged = pd.concat([original, pd.DataFrame(rows, columns=original.columns)], ignore_index=True) if rows else original
    f = merged[list(problem.objective_names)].to_numpy(dtype=float)
    keep = non_dominated_mask(f) if len(f) else np.zeros(0, dtype=bool)
    out = merged[keep].sort_values("source_index", kind="stable").reset_index(drop=True)
    out["source_index"] = out["source_index"].astype(np.int64)
    return out


# --- run directories -------------------------------------------------------------------------
def refine_run(
    run_dir: str | Path,
    max_points: int = 40,
    *,
    method: str = "slp",
    settings: RefineSettings | SlpSettings | None = None,
    backend: Backend | None = None,
    progress: Callable[[PointResult], None] | None = None,
) -> RefineResult:
    """Refine a run directory's ``front.csv``; write ``front_refined.csv`` and ``refine.json``
    (``method="ipopt"``: ``front_refined_ipopt.csv`` and ``refine_ipopt.json``, beside SLP's).

    Parameters
    ----------
    run_dir : str | Path
        [-] a directory written by :func:`hisopt.optim.run.optimize` (``out=``)
    max_points, method, settings, backend, progress
        as :func:`refine_front`

    Raises
    ------
    RunError
        Not a run directory, no or unreadable ``front.csv``, or the problem copy was edited.
    ConfigError
        A front row is not a valid start design.
    """
    from hisopt.io import ensure_writable_dir, write_csv
    from hisopt.optim import rundir
    from hisopt.plausibility import with_bound_column

    check_max_points(max_points)
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunError(f"{run_dir}: run directory not found; expected the --out directory of `hisopt optimize`")
    problem, reference = rundir.run_problem(run_dir)
    front = rundir.read_front(run_dir / rundir.FRONT_CSV)
    ensure_writable_dir(run_dir)
    settings = method_settings(method, settings)
    result = refine_front(
        problem,
        front,
        max_points,
        method=method,
        settings=settings,
        backend=backend,
        reference_log=reference,
        progress=progress,
        source=str(run_dir / rundir.FRONT_CSV),
    )
    front_file, summary_file = rundir.refined_files(method)  # each method its own files
    write_csv(with_bound_column(result.front, problem), run_dir / front_file)
    summary = result.summary() | {"max_points": max_points, "method": method, "settings": asdict(settings)}
    summary["per_point"] = json.loads(result.points.to_json(orient="records"))
    rundir.atomic_write_json(run_dir / summary_file, summary)
    return result
