"""Successive halving of a synthesis's screened-in candidates with the layout study
(docs/model.md §20.4; the plan: :mod:`hisopt.studies.halving`).

Each rung is a layout study (:func:`hisopt.studies.layout_study.run_layout_study`: one task
per candidate and seed on the backend, roll_plane at the same budget as the reference) of the
rung's candidates at the rung's budget, in ``DIR/rung-<r>`` (``DIR/study`` for the last rung),
resumable as any study. The measure, higher is better: the study's comfort gain over roll_plane
at equal handling (``gain_vs_roll_plane_pct``; in the early rungs from the sampled designs,
unrefined, in the last refined as in any study); a candidate without a design at the limit
ranks below every candidate with one, by its normalised hypervolume (``hv_mean``); where no
layout has a gain (roll_plane itself misses the limit), all rank by the hypervolume.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.studies.halving import HalvingResult, Rung, successive_halving
from hisopt.studies.layout_tables import NO_REFINEMENT

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.problem import Problem
    from hisopt.studies.layout_study import LayoutStudyResult

STUDY_DIR = "study"
TOP = 10
"""[-] The old rule's count (``--optimise 10``) and the final top ten it is checked against."""


def rung_directory(out: Path | None, rung: Rung, rungs: int) -> Path | None:
    """``DIR/rung-<r>`` of an early rung, ``DIR/study`` of the last (None: nothing written)."""
    if out is None:
        return None
    return out / (STUDY_DIR if rung.number == rungs else f"rung-{rung.number}")


def measure(row: Any) -> tuple[int, float]:
    """The halving measure of a ``layouts.csv`` row (module docstring), higher is better:
    ``(1, gain_vs_roll_plane_pct)`` with a design at the limit, else ``(0, hv_mean)``."""
    gain = float(row["gain_vs_roll_plane_pct"])
    if math.isfinite(gain):
        return (1, gain)
    hv = float(row["hv_mean"])
    return (0, hv if math.isfinite(hv) else -math.inf)


@dataclass
class HalvingRun:
    """Successive halving in a synthesis.

    Attributes
    ----------
    result : HalvingResult
        the rungs, their entrants and measures, and the final ranking
    studies : list[LayoutStudyResult]
        each rung's layout study (the last at the full budget)
    """

    result: HalvingResult
    studies: list[LayoutStudyResult]


def run_halving(
    problem: Problem,
    files: dict[str, Path],
    plan: list[Rung],
    *,
    out: Path | None,
    pop_size: int | None,
    handling: str | None,
    backend: Backend | None,
    say: Callable[[str], None],
    references: Sequence[str] = (),
) -> HalvingRun:
    """Successive halving over the candidates ``files`` (name -> problem file, in the screen's
    order) with ``plan`` (module docstring); ``references`` (layout names, e.g.
    ``conventional``) join the last rung's study only."""
    from hisopt.studies.layout_study import run_layout_study

    studies: list[LayoutStudyResult] = []

    def score(names: list[Hashable], rung: Rung) -> list[tuple[int, float]]:
        say(
            f"rung {rung.number} of {len(plan)}: {len(names):,} candidates and roll_plane, "
            f"{rung.generations} generation{'s' if rung.generations != 1 else ''}, "
            f"seed{'s' if len(rung.seeds) > 1 else ''} {', '.join(str(s) for s in rung.seeds)}"
        )
        last = rung.number == len(plan)
        study = run_layout_study(
            problem,
            [*(str(files[str(n)]) for n in names), *(references if last else ())],
            rung.seeds,
            out=rung_directory(out, rung, len(plan)),
            pop_size=pop_size,
            generations=rung.generations,
            handling=handling,
            backend=backend,
            # early rungs rank by the sampled designs: an NLP per candidate would cost more
            # than its short run; the last rung refines, as any study
            refine_method="ipopt" if last else NO_REFINEMENT,
        )
        studies.append(study)
        table = study.table.set_index("layout")
        return [measure(table.loc[str(n)]) for n in names]

    return HalvingRun(successive_halving(list(files), plan, score), studies)


def average_ranks(values: Sequence[Any]) -> np.ndarray:
    """[-] Rank of each value, 1 the highest, equal values sharing their mean rank (ordered
    values of any kind, e.g. the tuples of :func:`measure`)."""
    order = sorted(range(len(values)), key=lambda i: values[i], reverse=True)
    ranks = np.zeros(len(values))
    start = 0
    while start < len(order):
        end = start
        while end + 1 < len(order) and values[order[end + 1]] == values[order[start]]:
            end += 1
        ranks[order[start : end + 1]] = (start + end) / 2 + 1
        start = end + 1
    return ranks


def spearman(screen_rank: Sequence[float], measures: Sequence[Any]) -> dict[str, Any]:
    """``{"rho", "p_value", "candidates"}``: Spearman's rank correlation of the screen's rank
    (1 the screen's first) and the rank by the measure (1 the best): +1 where the screen's
    order is the measured one (None, JSON's null, for fewer than three candidates or a
    constant rank)."""
    import warnings

    from scipy.stats import spearmanr

    n = len(measures)
    if n < 3:
        return {"rho": None, "p_value": None, "candidates": n}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a constant input: NaN, said by None
        found = spearmanr(np.asarray(screen_rank, dtype=float), average_ranks(measures))
    rho, p = float(found.statistic), float(found.pvalue)
    return {"rho": rho if math.isfinite(rho) else None, "p_value": p if math.isfinite(p) else None, "candidates": n}


def halving_summary(run: HalvingRun, screen_order: Sequence[str], old_top: Sequence[str]) -> dict[str, Any]:
    """What ``halving.json`` records: the plan, the Spearman correlation of the screen's order
    and the measured one over the last rung's candidates (``final``) and over every candidate's
    first-rung measure (``first``), the final top ten and those of them the old rule
    (``--optimise 10``: the screen's first ten, ``old_top``) would not have optimised."""
    result = run.result
    rank = {name: i + 1 for i, name in enumerate(screen_order)}

    def correlation(r: int) -> dict[str, Any]:
        names = result.entrants[r]
        return spearman([rank[str(n)] for n in names], [result.measures[r][n] for n in names])

    top = [str(n) for n in result.ranking[:TOP]]
    return {
        "plan": [{"rung": g.number, "candidates": g.candidates, "generations": g.generations, "seeds": list(g.seeds)} for g in result.plan],
        "spearman_final": correlation(len(result.plan) - 1),
        "spearman_first": correlation(0),
        "top_ten": top,
        "top_ten_missed_by_old_rule": [n for n in top if n not in set(old_top)],
    }


def rung_columns(run: HalvingRun, names: Sequence[str], screen_order: Sequence[str]) -> pd.DataFrame:
    """Per candidate of ``names`` (``candidates.csv``'s order): ``screen_rank`` (1 the
    screen's first; empty where screened out), ``rung`` (the last rung it ran, 0 none),
    ``final_rank`` (1 the best of the halving), and per rung ``gain_rung_<r>`` [%] and
    ``hv_rung_<r>`` [-] from that rung's study (empty where it did not run)."""
    result = run.result
    rank = {name: i + 1 for i, name in enumerate(screen_order)}
    final = {str(n): i + 1 for i, n in enumerate(result.ranking)}
    reached = {str(n): rung.number for rung, entrants in zip(result.plan, result.entrants, strict=True) for n in entrants}
    frame = pd.DataFrame(
        {
            "screen_rank": pd.array([rank.get(n) for n in names], dtype="Int64"),
            "rung": [reached.get(n, 0) for n in names],
            "final_rank": pd.array([final.get(n) for n in names], dtype="Int64"),
        }
    )
    for rung, study in zip(result.plan, run.studies, strict=True):
        table = study.table.set_index("layout")
        for column, source in ((f"gain_rung_{rung.number}", "gain_vs_roll_plane_pct"), (f"hv_rung_{rung.number}", "hv_mean")):
            values = table[source]
            frame[column] = [float(values[n]) if n in values.index else np.nan for n in names]
    return frame


def rung_units(rungs: int) -> dict[str, str]:
    """The units of :func:`rung_columns`."""
    units = {"screen_rank": "-", "rung": "-", "final_rank": "-"}
    for r in range(1, rungs + 1):
        units |= {f"gain_rung_{r}": "%", f"hv_rung_{r}": "-"}
    return units
