"""hisopt's default search: SMS-EMOA in log10 objectives, with designs put on the box's faces.

Why this algorithm (issue 28's anytime benchmark, ``benchmarks/bench_anytime.py``): a run is
judged by the hypervolume of its archive in log10 objectives, and SMS-EMOA's survival keeps
exactly the designs that add most hypervolume. Three choices make it reach a converged front
in a few thousand evaluations on HIS problems:

- the search sees ``log10`` of the objectives (PSD maxima span decades; in linear units the
  largest values would dominate the normalisation and the small ones would be crowded out),
  the measure the front is judged by;
- :class:`~hisopt.optim.operators.BoxSampling` and :class:`~hisopt.optim.operators.FaceMutation`
  put designs on the bounds where a third to a half of the front lies;
- survival removes the least hypervolume contributor one at a time
  (:func:`hisopt.optim.hv_survival.greedy_least_contributor_removal`, exact and fast), as
  pymoo's SMS-EMOA does (Beume et al. 2007), with pymoo's normalisation: the splitting front
  is scaled by the parent population's ideal and nadir, and the reference point lies
  :data:`REFERENCE_OFFSET` beyond the nadir so the extremes are always kept.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pymoo.core.survival import Survival
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from hisopt.optim.decision import log_objectives
from hisopt.optim.hv_survival import greedy_least_contributor_removal
from hisopt.optim.operators import BoxSampling, FaceMutation

REFERENCE_OFFSET = 10.0
"""[-] Reference point of the survival: ``1 + REFERENCE_OFFSET`` in every normalised objective
(pymoo's SMS-EMOA default), far enough that the extreme designs are never removed."""


def search_objectives(f: np.ndarray) -> np.ndarray:
    """[decades] What the search minimises: ``log10`` of the objectives ``f`` (inf stays inf)."""
    f = np.asarray(f, dtype=float)
    return np.where(np.isfinite(f), log_objectives(np.where(np.isfinite(f), f, 1.0)), np.inf)


def normalised(f: np.ndarray, ideal: np.ndarray, nadir: np.ndarray) -> np.ndarray:
    """[-] ``f`` scaled so that ``ideal`` maps to 0 and ``nadir`` to 1 (no spread: span 1)."""
    span = np.where(nadir > ideal, nadir - ideal, 1.0)
    return (f - ideal) / span


class LeastContributorSurvival(Survival):
    """Non-dominated sorting, then the splitting front loses its least hypervolume
    contributors one at a time (infeasible designs: by constraint violation, pymoo's rule)."""

    def __init__(self) -> None:
        super().__init__(filter_infeasible=True)

    def _do(
        self,
        problem: Any,
        pop: Any,
        *args: Any,
        n_survive: int,
        ideal: np.ndarray | None = None,
        nadir: np.ndarray | None = None,
        **kwargs: Any,
    ) -> Any:
        F = np.asarray(pop.get("F"), dtype=float)
        # the parents' ideal and nadir (pymoo's rule), where finite: an invalid parent has inf
        ideal = F.min(axis=0) if ideal is None else np.where(np.isfinite(ideal), ideal, F.min(axis=0))
        nadir = F.max(axis=0) if nadir is None else np.where(np.isfinite(nadir), nadir, F.max(axis=0))
        survivors: list[int] = []
        for rank, front in enumerate(NonDominatedSorting().do(F, n_stop_if_ranked=n_survive)):
            pop[front].set("rank", rank)
            excess = len(survivors) + len(front) - n_survive
            if excess > 0:
                reference = np.full(F.shape[1], 1.0 + REFERENCE_OFFSET)
                front = front[greedy_least_contributor_removal(normalised(F[front], ideal, nadir), reference, excess)]
            survivors.extend(int(i) for i in front)
        return pop[survivors]


def build_hv_emoa(pop_size: int) -> Any:
    """A fresh pymoo SMS-EMOA with hisopt's sampling, mutation and survival (not set up)."""
    from pymoo.algorithms.moo.sms import SMSEMOA

    return SMSEMOA(pop_size=pop_size, sampling=BoxSampling(), mutation=FaceMutation(), survival=LeastContributorSurvival())
