"""Layout study: which HIS layout gives the best ride at equal handling (docs/model.md §15).

``hisopt compare-layouts PROBLEM --layouts ... --seeds 1-3 --out DIR`` and
:func:`compare_layouts` optimise every layout (:mod:`hisopt.studies.layout_cases`) on the same
objectives and constraints with the same budget per layout and seed, then compare them:

1. **Spread across seeds**: each seed's front's hypervolume in one shared normalisation
   (:mod:`hisopt.studies.layout_metrics`), their mean, standard deviation, minimum and maximum,
   the merged front's, and the attainment of the comfort-handling trade-off across seeds
   (EAF, Vorob'ev expectation and deviation).
2. **Equal handling**: for a handling limit (default: the handling quantity of the study
   problem's baseline design on the roll-plane layout), per layout the best comfort
   (``sigma_aw``) among every feasible design its runs evaluated that meets the limit, and
   the epsilon-constraint NLP (:func:`hisopt.optim.gradient.refine.refine_constrained`: minimise
   ``sigma_aw`` subject to the constraints and ``handling <= limit``, by IPOPT on CasADi's
   virtual machine, no C compilation; the batched SLP with ``refine_method="slp"``) started from each
   seed's best such design (kept only if the evaluator confirms it; not for a layout with
   damper valves whose RMS flows are solved per design, which IPOPT's model cannot hold:
   its sampled designs stand); the best of these, and
   its gain over the roll-plane
   layout at the same limit, ``gain_vs_roll_plane_pct = 100 (1 - sigma_layout / sigma_roll_plane)``
   (positive: better comfort). The trade-off curve of best comfort against the limit is the
   staircase of the non-dominated (handling, comfort) pairs of all those designs, plus a few
   refined points.

Study directory ``DIR``::

    study.json          problem (SHA-256 of its specification), budget, normalisation, layouts
    <layout>/seed-<n>/  an ordinary run directory of each layout and seed (hisopt resume works)
    layouts.csv         one row per layout (:data:`TABLE_DOC`)
    runs.csv            one row per layout and seed: hypervolume, front size, evaluations
    fronts.csv          each seed's front per layout: objectives, normalised objectives
    handling_curve.csv  best comfort against the handling limit per layout (the staircase)
    attainment.csv      attainment surfaces and Vorob'ev expectation per layout
    report.html         :mod:`hisopt.report.layout_report`

Re-running the same command on ``DIR`` resumes interrupted runs (killed, Ctrl-C) and reuses
finished ones, with results identical to an uninterrupted study; a study of another problem
or budget in ``DIR`` is refused. Layouts and seeds may be added on a re-run.
"""

from __future__ import annotations

import hashlib
import json
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import problem_argument
from hisopt.errors import ConfigError, RunError
from hisopt.optim.rundir import LAYOUT_STUDY_JSON
from hisopt.plausibility import seed_count_problem
from hisopt.studies.layout_cases import LayoutCase, layout_cases, wants_conventional
from hisopt.studies.layout_metrics import (
    COMFORT,
    Normalisation,
    check_handling,
    default_handling_quantity,
    evaluate_quantities,
    shared_normalisation,
)
from hisopt.studies.layout_tables import NO_REFINEMENT

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.problem import Problem

STUDY_JSON = LAYOUT_STUDY_JSON
STUDY_FORMAT = "hisopt-layout-study/1"
LAYOUTS_CSV, RUNS_CSV, FRONTS_CSV, CURVE_CSV, ATTAINMENT_CSV = ("layouts.csv", "runs.csv", "fronts.csv", "handling_curve.csv", "attainment.csv")
CURVE_REFINED = 4
"""Limits per layout at which the trade-off curve is refined (spread over its staircase)."""

TABLE_DOC = """layout, source (catalogue or file), variables; hv_mean, hv_std, hv_min, hv_max
(normalised hypervolume of the seeds' fronts), hv_merged (of their merged front),
vorobev_threshold_pct, vorobev_deviation (comfort-handling plane); handling (the quantity's
name), handling_limit, sigma_aw_at_limit (best comfort meeting it), handling_at_best,
refined (the NLP improved the best sampled design), gain_vs_roll_plane_pct,
gain_vs_conventional_pct (with conventional in --layouts: against the car without circuits
whose anti-roll bars are sized at the limit, its own row, docs/model.md §15.6); handling_least
(the least handling of the layout's feasible designs), at_limit ("met", or why the layout has
no design at the limit: its sigma_aw_at_limit and gain are then empty); buildable,
binding_rule, build_margin (docs/model.md §21.3: the verdict of every buildability rule,
constrained or not, on the design of sigma_aw_at_limit; not buildable and empty without
one; the ranking does not use them); k_bounce ...
c_warp, stiffness_coupling (hisopt layouts, at the layout's baseline); damper_valves (a
layout with physical damper valves: their orifice, cracking pressure and equivalent
resistance on the baseline road, as hisopt layouts says); best_<variable>: the
design of sigma_aw_at_limit (empty where a layout lacks the variable)."""


def parse_seed_list(text: str | Sequence[int]) -> list[int]:
    """Seeds from ``"1-3"``/``"1,3,5"`` or a sequence (:func:`hisopt.optim.study.parse_seeds`)."""
    from hisopt.optim.study import parse_seeds

    if isinstance(text, str):
        return parse_seeds(text)
    seeds = sorted({int(s) for s in text})
    if not seeds or seeds[0] < 0:
        raise ConfigError(f"expected non-negative seeds, got {list(text)!r}", key="--seeds")
    too_many = seed_count_problem(len(seeds))
    if too_many:
        raise ConfigError(too_many, key="--seeds")
    return seeds


# --- one (layout, seed) run, in whichever process runs it ---------------------------------------
def _run(problem: Problem, run_dir: Path | None, seed: int, pop: int | None, gens: int | None, reference: np.ndarray | None) -> Any:
    """A new run, or the run already in ``run_dir`` continued (or just read when finished)."""
    from hisopt.optim.run import optimize, optimize_or_continue

    if run_dir is None:
        return optimize(problem, seed=seed, pop_size=pop, generations=gens, reference_log=reference)
    return optimize_or_continue(problem, run_dir, seed, pop, gens, reference)


def _run_task(
    task: tuple[str, int], cases: dict[str, Problem], out: str | None, pop: int | None, gens: int | None, handling: str, reference: np.ndarray | None
) -> dict[str, Any]:
    name, seed = task
    problem = cases[name]
    result = _run(problem, None if out is None else Path(out) / name / f"seed-{seed}", seed, pop, gens, reference)
    names = list(problem.variable_names)
    history = result.history[result.history["feasible"]].reset_index(drop=True)
    designs = history[["evaluation", *names]].copy()
    have = [q for q in (COMFORT, handling) if q in history.columns]
    for q in have:
        designs[q] = history[q].to_numpy()
    need = tuple(q for q in (COMFORT, handling) if q not in have)
    if need and len(designs):
        values = evaluate_quantities(problem, designs[names].to_numpy(), need)
        for q in need:
            designs[q] = values[q]
    elif need:
        for q in need:
            designs[q] = np.zeros(0)
    front = result.front[[*names, *problem.objective_names]].reset_index(drop=True)
    return {"layout": name, "seed": seed, "front": front, "designs": designs, "evaluations": len(result.history)}


# --- the study record ----------------------------------------------------------------------------
def problem_digest(problem: Problem) -> str:
    """[-] SHA-256 of the problem's specification (its content, not its file's bytes)."""
    return hashlib.sha256(problem.spec.model_dump_json(by_alias=True).encode()).hexdigest()


def study_budget(problem: Problem, pop_size: int | None, generations: int | None) -> dict[str, int]:
    """[-] ``{"pop_size", "generations"}`` of every run (overrides or the problem's ``[optimizer]``).

    Raises
    ------
    ConfigError
        An override is out of range.
    """
    from hisopt.optim.settings import resolve_settings

    settings = resolve_settings(problem, pop_size=pop_size, generations=generations)
    return {"pop_size": settings.pop_size, "generations": settings.generations}


def read_study_record(out: Path | None, problem: Problem, budget: dict[str, int]) -> dict[str, Any]:
    """``out/study.json`` if it is a study of ``problem`` with ``budget`` ({} when there is none).

    Raises
    ------
    RunError
        ``out`` holds a study of another problem or budget, or an unreadable record.
    """
    path = None if out is None else Path(out) / STUDY_JSON
    if path is None or not path.is_file():
        return {}
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RunError(f"{path}: unreadable ({exc}); choose another --out") from None
    if not isinstance(record, dict) or record.get("format") != STUDY_FORMAT:
        raise RunError(f"{path}: not a hisopt layout study; choose another --out")
    digest = problem_digest(problem)
    if record["problem"]["sha256"] != digest:
        raise RunError(
            f"{out} holds a layout study of another problem (sha256 {record['problem']['sha256'][:12]} -> {digest[:12]}); choose another --out or delete {out}"
        )
    if record["budget"] != budget:
        raise RunError(f"{out} holds a layout study with budget {record['budget']}, not {budget}; use the same --pop and --gens, or another --out")
    return record


def _study_record(out: Path | None, problem: Problem, budget: dict[str, int], handling: str, cases: list[LayoutCase]) -> tuple[dict[str, Any], Normalisation]:
    """The stored record (checked against this study) or a new one, with its normalisation."""
    digest = problem_digest(problem)
    record = read_study_record(out, problem, budget)
    norms = record.get("normalisation", {})
    if handling in norms:
        norm = Normalisation.from_json(norms[handling])
    else:
        norm = shared_normalisation(cases[0].problem, handling)
    record = {
        "format": STUDY_FORMAT,
        "problem": {"name": problem.name, "sha256": digest, "path": None if problem.path is None else str(problem.path)},
        "budget": budget,
        "normalisation": norms | {handling: norm.to_json()},
        "layouts": {c.name: c.source for c in cases} | record.get("layouts", {}),
    }
    return record, norm


# --- results ------------------------------------------------------------------------------------
@dataclass
class LayoutStudyResult:
    """Everything a layout study found (module docstring); frames carry ``attrs["units"]``.

    Attributes
    ----------
    table : pd.DataFrame
        one row per layout (``layouts.csv``, :data:`TABLE_DOC`)
    runs : pd.DataFrame
        one row per layout and seed: ``layout``, ``seed``, ``hypervolume`` [-],
        ``front_size``, ``evaluations``, ``feasible_designs``
    fronts : pd.DataFrame
        each seed's front: ``layout``, ``seed``, objectives [physical units] and
        ``<objective>_norm`` [-]
    curve : pd.DataFrame
        the trade-off staircase: ``layout``, ``source`` (sampled or refined), ``seed``,
        the handling quantity and ``sigma_aw`` [physical units]
    attainment : pd.DataFrame
        ``layout``, ``kind`` (``eaf`` or ``vorobev``), ``percentile`` [%],
        ``sigma_aw`` and the handling quantity [physical units]
    cases : list[LayoutCase]
        the layouts
    normalisation : Normalisation
        the shared normalisation
    handling : str
        [-] the handling quantity
    handling_limit : float
        [quantity unit] the limit of the equal-handling comparison
    out : Path | None
        the study directory (None: nothing written)
    """

    table: pd.DataFrame
    runs: pd.DataFrame
    fronts: pd.DataFrame
    curve: pd.DataFrame
    attainment: pd.DataFrame
    cases: list[LayoutCase]
    normalisation: Normalisation
    handling: str
    handling_limit: float
    out: Path | None

    def limit_notes(self) -> list[str]:
        """One sentence per layout without a design at the handling limit (``at_limit`` not
        ``met``): why, and the least limit that would compare it; the gains' absence when the
        reference is one of them."""
        from hisopt.studies.layout_cases import REFERENCE_LAYOUT
        from hisopt.units import format_quantity

        if "at_limit" not in self.table:  # a table written before hisopt said why
            return []
        unit = self.table.attrs["units"]["handling_limit"]
        notes = []
        for row in self.table.itertuples(index=False):
            if row.at_limit == "met":
                continue
            text = f"{row.layout}: {row.at_limit}, so it has no sigma_aw_at_limit"
            if np.isfinite(row.handling_least):
                text += f"; a handling limit of at least {format_quantity(row.handling_least, unit)} (--handling-limit) compares it"
            if row.layout == REFERENCE_LAYOUT:
                text += "; without the reference, no layout has a gain_vs_roll_plane_pct"
            notes.append(text)
        return notes


def check_arguments(
    problem: Problem, layouts: str | Sequence[str] | None, seeds: str | Sequence[int], handling: str | None, handling_limit: float | None
) -> tuple[list[int], list[LayoutCase], str]:
    """The seeds, the layouts and the handling quantity of a study, checked (before any work).

    Raises
    ------
    ConfigError
        As :func:`run_layout_study`.
    """
    problem_argument(problem)
    seed_list = parse_seed_list(seeds)
    cases = layout_cases(problem, layouts)
    name = check_handling(problem, handling or default_handling_quantity(problem))
    is_number = isinstance(handling_limit, numbers.Real) and not isinstance(handling_limit, bool)
    if handling_limit is not None and not (is_number and np.isfinite(handling_limit) and handling_limit > 0):
        raise ConfigError(f"expected a finite limit > 0 of {name} [SI], got {handling_limit!r}", key="--handling-limit")
    return seed_list, cases, name


def _shared_reference(cases: list[LayoutCase], pop_size: int | None, generations: int | None) -> np.ndarray | None:
    """[decades] The hypervolume reference point every run of the study records its progress
    against: roll_plane's (the first case), so that runs' figures compare across layouts and a
    candidate's run costs no grid of its own (a few hundred evaluations, more than a short
    rung's run). None (each run its own) where a run stops on its progress (``until =
    "converged"``), which must not hinge on another layout's reference."""
    from hisopt.optim.decision import reference_point
    from hisopt.optim.settings import resolve_settings

    if any(resolve_settings(c.problem, pop_size=pop_size, generations=generations).until != "generations" for c in cases):
        return None
    return reference_point(cases[0].problem)


def run_layout_study(
    problem: Problem,
    layouts: str | Sequence[str] | None = None,
    seeds: str | Sequence[int] = (1, 2, 3),
    *,
    out: str | Path | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    handling: str | None = None,
    handling_limit: float | None = None,
    backend: Backend | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
    refine_method: str = "ipopt",
) -> LayoutStudyResult:
    """Optimise every layout with every seed and compare them (module docstring).

    Parameters
    ----------
    problem : Problem
        the study problem (its layout is replaced by each layout's)
    layouts : str | Sequence[str] | None, optional
        [-] catalogue names and custom layouts' problem files, as a list or
        comma-separated; default the whole catalogue; ``roll_plane`` is always included
    seeds : str | Sequence[int], optional
        [-] one run per layout and seed, e.g. ``"1-3"``
    out : str | Path | None, optional
        study directory (module docstring); None keeps everything in memory
    pop_size, generations : int | None, optional
        [-] the budget of every run (default the problem's ``[optimizer]``)
    handling : str | None, optional
        [-] the quantity held equal (default :func:`default_handling_quantity`)
    handling_limit : float | None, optional
        [quantity unit] its limit (default its value at the baseline design on
        the roll-plane layout)
    backend : Backend | None, optional
        where runs and refinements go (default this process; Dask: one task per run)
    progress : Callable[[dict[str, Any]], None] | None, optional
        called with ``{"layout", "seed", "evaluations", "feasible_designs"}`` as each run ends
    refine_method : str, optional
        [-] the solver of the equal-handling NLP: ``"ipopt"`` (IPOPT on the CasADi model, on
        CasADi's virtual machine) or ``"slp"`` (the batched SLP on the evaluator; the
        trade-off curve's points always; docs/model.md §15.4); ``"none"``: nothing refined,
        each layout's best sampled design at the limit (successive halving's early rungs)

    Raises
    ------
    ConfigError
        An unknown layout, bad seeds, an unknown handling quantity, a non-positive limit or an
        unknown ``refine_method``.
    RunError
        ``out`` holds a study of another problem or budget, a run that cannot be resumed, a
        folder of another kind or files hisopt did not write (:func:`hisopt.folders.claim`).
    """
    from hisopt.evaluation.parallel import Backend
    from hisopt.folders import LAYOUT_STUDY, check_claim, claim
    from hisopt.optim.gradient.refine import method_settings

    seed_list, cases, handling = check_arguments(problem, layouts, seeds, handling, handling_limit)
    if refine_method != NO_REFINEMENT:
        method_settings(refine_method, None)  # an unknown method fails before any work
    budget = study_budget(problem, pop_size, generations)  # bad budgets fail before any work
    out_dir = None if out is None else Path(out)
    if out_dir is not None:
        check_claim(out_dir, LAYOUT_STUDY)  # a folder of another kind, or a user's, is refused
        read_study_record(out_dir, problem, budget)  # so is a study of another problem or budget
        claim(out_dir, LAYOUT_STUDY)
    record, norm = _study_record(out_dir, problem, budget, handling, cases)
    if out_dir is not None:
        from hisopt.io import atomic_write_json

        atomic_write_json(out_dir / STUDY_JSON, record)
    if handling_limit is None:
        base = cases[0].problem
        handling_limit = float(evaluate_quantities(base, base.baseline[None, :], (handling,))[handling][0])
    backend = backend or Backend()
    problems = {c.name: c.problem for c in cases}
    tasks = [(c.name, s) for c in cases for s in seed_list]

    def report(_: int, r: dict[str, Any]) -> None:
        if progress is not None:
            progress({"layout": r["layout"], "seed": r["seed"], "evaluations": r["evaluations"], "feasible_designs": len(r["designs"])})

    reference = _shared_reference(cases, pop_size, generations)
    runs = backend.map(_run_task, tasks, problems, None if out_dir is None else str(out_dir), pop_size, generations, handling, reference, on_result=report)
    from hisopt.studies.layout_tables import assemble

    frames = assemble(cases, runs, norm, handling, handling_limit, backend, method=refine_method)
    if wants_conventional(layouts):  # sized at the same limit: a second, no runs
        from hisopt.studies.conventional import size_conventional, with_conventional

        frames["table"] = with_conventional(frames["table"], size_conventional(problem, handling, handling_limit), handling, handling_limit)
    result = LayoutStudyResult(**frames, cases=cases, normalisation=norm, handling=handling, handling_limit=handling_limit, out=out_dir)
    if out_dir is not None:
        from hisopt.io import write_csv

        for frame, name in (
            (result.table, LAYOUTS_CSV),
            (result.runs, RUNS_CSV),
            (result.fronts, FRONTS_CSV),
            (result.curve, CURVE_CSV),
            (result.attainment, ATTAINMENT_CSV),
        ):
            write_csv(frame, out_dir / name)
    return result


def compare_layouts(
    problem: Problem,
    layouts: str | Sequence[str] | None = None,
    seeds: str | Sequence[int] = (1, 2, 3),
    *,
    out: str | Path | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    handling: str | None = None,
    handling_limit: float | None = None,
    backend: Backend | None = None,
) -> pd.DataFrame:
    """The table of :func:`run_layout_study` (``layouts.csv``; units in ``attrs["units"]``).

    Parameters and errors as :func:`run_layout_study`.
    """
    return run_layout_study(
        problem, layouts, seeds, out=out, pop_size=pop_size, generations=generations, handling=handling, handling_limit=handling_limit, backend=backend
    ).table
