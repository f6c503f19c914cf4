"""Measures of a layout study: the shared normalisation, hypervolumes, attainment and the
comfort-against-handling staircase (docs/model.md §15).

**Shared normalisation.** Objectives are compared in ``z = log10(F)`` (as everywhere in hisopt,
:mod:`hisopt.optim.decision`), scaled so that 0 is an ideal and 1 a reference point in every
objective. Both come from the *study problem on the paper's roll-plane layout* only, never from
the fronts found, so the same front gets the same hypervolume whichever other layouts (or
seeds, or budgets) a study holds: a full-factorial grid over the roll-plane problem's box
(:func:`hisopt.optim.decision.grid_designs`, about 1000 designs) is evaluated; of its feasible
designs (all valid ones if none is feasible) the non-dominated set gives the ideal (its
minimum) and the reference (its nadir plus 10 % of its range, at least 0.01 decade: the
problem's hypervolume reference point, :func:`hisopt.optim.decision.reference_from_sample`).
A normalised hypervolume of 1 is the box between that ideal and reference; a layout that
beats the roll-plane grid's ideal can exceed 1; points beyond the reference add nothing. The
comfort-handling plane (``sigma_aw`` against the handling quantity) is normalised the same
way from the same grid. A study stores its normalisation in ``study.json`` and reuses it.

**Attainment.** Per layout and seed, the non-dominated set in the normalised
comfort-handling plane of every feasible design the run evaluated; across seeds, the
empirical attainment function (moocore ``eaf``: the share of seeds whose set weakly dominates
a point) and the Vorob'ev expectation and deviation (moocore ``vorob_t``/``vorob_dev``; the
deviation is the expected hypervolume of the symmetric difference between a seed's attained
set and the expectation, in the normalised unit square: 0 when every seed attains the same).
moocore computes these in two and three dimensions only, hence the plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import moocore
import numpy as np

from hisopt.errors import ConfigError
from hisopt.metrics import METRICS
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.decision import grid_designs, grid_sample_rows, log_objectives, reference_from_sample

if TYPE_CHECKING:
    from hisopt.problem import Problem

COMFORT = "sigma_aw"
"""The comfort quantity of the equal-handling comparison."""


def default_handling_quantity(problem: Problem) -> str:
    """[-] The handling quantity a layout study holds equal unless told otherwise.

    The static roll gradient (rad/g) of the paper's problem; for a problem with load cases
    (docs/model.md §14) the peak roll of the step steer, ``roll_step_peak`` (rad), the
    handling quantity such problems are signed off on. The one place that chooses it.
    """
    return "roll_step_peak" if problem.spec.scenarios else "roll_gradient"


def known_quantities(problem: Problem) -> tuple[str, ...]:
    """[-] Quantity names a study may use: the registry's and the problem's own columns."""
    return tuple(dict.fromkeys((*METRICS, *problem.objective_names, *problem.constraint_names)))


def check_handling(problem: Problem, name: str) -> str:
    """``name`` if it is a known quantity other than the comfort one.

    Raises
    ------
    ConfigError
        Unknown, or the comfort quantity itself.
    """
    known = known_quantities(problem)
    if name not in known:
        raise ConfigError(f"unknown quantity {name!r}; expected one of {', '.join(known)}", key="--handling")
    if name == COMFORT:
        raise ConfigError(f"the handling quantity must differ from the comfort one ({COMFORT}); expected e.g. roll_gradient", key="--handling")
    return name


def quantity_problem(problem: Problem, names: tuple[str, ...]) -> Problem:
    """``problem`` evaluating ``names``: as objectives, the comfort one first, but a quantity
    that is a constraint only (``static_gas_fraction``: lower is not better) as a constraint
    whose limit plays no part (only its value is read)."""
    from hisopt.metrics import METRICS
    from hisopt.problem import problem_from_dict

    wanted = list(dict.fromkeys((COMFORT, *names)))  # a frequency quantity always: see the report
    only_constraints = [n for n in wanted if n in METRICS and not METRICS[n].objective]
    data = problem.spec.model_dump(by_alias=True)
    data["objectives"] = [n for n in wanted if n not in only_constraints]
    data["constraints"] = [{"name": n, "limit": 1.0} for n in only_constraints]
    return problem_from_dict(data, f"{problem.name} (quantities)", warn_implausible=False)  # checked when read


def evaluate_quantities(problem: Problem, x: np.ndarray, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """[quantity units] ``names`` at designs ``x`` (n, n_var), each ``(n,)``, plus ``valid``."""
    missing = tuple(n for n in names if n not in problem.objective_names + problem.constraint_names)
    probe = quantity_problem(problem, names) if missing else problem
    q = probe.evaluator()(np.asarray(x, dtype=float).reshape(-1, len(problem.variable_names)))
    return {n: np.asarray(q[n], dtype=float) for n in (*names, "valid")}


# --- the shared normalisation ----------------------------------------------------------------
@dataclass(frozen=True)
class Normalisation:
    """Ideal and reference points (log10) of a study (module docstring).

    Attributes
    ----------
    objectives : tuple[str, ...]
        [-] objective names, in order
    ideal_log, reference_log : np.ndarray
        [decades] ``(n_obj,)``
    handling : str
        [-] the handling quantity
    plane_ideal_log, plane_reference_log : np.ndarray
        [decades] of ``(sigma_aw, handling)``, ``(2,)``
    """

    objectives: tuple[str, ...]
    ideal_log: np.ndarray
    reference_log: np.ndarray
    handling: str
    plane_ideal_log: np.ndarray
    plane_reference_log: np.ndarray

    def objective_space(self, f: np.ndarray) -> np.ndarray:
        """[-] Objectives ``f`` (n, n_obj) in the normalised space."""
        return (log_objectives(f) - self.ideal_log) / (self.reference_log - self.ideal_log)

    def plane(self, comfort: np.ndarray, handling: np.ndarray) -> np.ndarray:
        """[-] ``(sigma_aw, handling)`` pairs, each ``(n,)``, in the normalised plane, ``(n, 2)``."""
        z = log_objectives(np.column_stack([comfort, handling]))
        return (z - self.plane_ideal_log) / (self.plane_reference_log - self.plane_ideal_log)

    def from_plane(self, z: np.ndarray) -> np.ndarray:
        """[quantity units] Normalised plane points ``(n, 2)`` back to ``(sigma_aw, handling)``."""
        return 10.0 ** (self.plane_ideal_log + np.asarray(z, dtype=float) * (self.plane_reference_log - self.plane_ideal_log))

    def to_json(self) -> dict[str, Any]:
        """JSON-ready record (``study.json``)."""
        return {
            "objectives": list(self.objectives),
            "ideal_log10": self.ideal_log.tolist(),
            "reference_log10": self.reference_log.tolist(),
            "handling": self.handling,
            "plane_ideal_log10": self.plane_ideal_log.tolist(),
            "plane_reference_log10": self.plane_reference_log.tolist(),
        }

    @classmethod
    def from_json(cls, record: dict[str, Any]) -> Normalisation:
        """The inverse of :meth:`to_json`."""
        return cls(
            tuple(record["objectives"]),
            np.asarray(record["ideal_log10"], dtype=float),
            np.asarray(record["reference_log10"], dtype=float),
            str(record["handling"]),
            np.asarray(record["plane_ideal_log10"], dtype=float),
            np.asarray(record["plane_reference_log10"], dtype=float),
        )


def _ideal_and_reference(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    z = log_objectives(f)
    return z[non_dominated_mask(z)].min(axis=0), reference_from_sample(f)


def shared_normalisation(reference_problem: Problem, handling: str) -> Normalisation:
    """The study's normalisation from the roll-plane problem alone (module docstring).

    Raises
    ------
    RunError
        No design of the grid can be evaluated.
    """
    x = grid_designs(reference_problem.lower, reference_problem.upper)
    objectives = reference_problem.objective_names
    q = evaluate_quantities(reference_problem, x, (*objectives, *reference_problem.constraint_names, COMFORT, handling))
    chosen = grid_sample_rows(reference_problem, q, x)
    ideal, reference = _ideal_and_reference(np.column_stack([q[n][chosen] for n in objectives]))
    plane_ideal, plane_reference = _ideal_and_reference(np.column_stack([q[COMFORT][chosen], q[handling][chosen]]))
    return Normalisation(tuple(objectives), ideal, reference, handling, plane_ideal, plane_reference)


def normalised_hypervolume(f: np.ndarray, norm: Normalisation) -> float:
    """[-] Hypervolume of objectives ``f`` (n, n_obj) in the normalised space, reference 1."""
    z = norm.objective_space(np.asarray(f, dtype=float).reshape(-1, len(norm.objectives)))
    z = z[np.all(z < 1.0, axis=1)]
    return float(moocore.hypervolume(z, ref=np.ones(z.shape[1]))) if len(z) else 0.0


# --- the comfort-handling plane ----------------------------------------------------------------
def plane_front(comfort: np.ndarray, handling: np.ndarray) -> np.ndarray:
    """[-] Indices of the non-dominated ``(handling, sigma_aw)`` pairs, by ascending handling.

    Read as a staircase: from each point's handling on, its comfort is the best there is
    (first of equal pairs kept).
    """
    pairs = np.column_stack([handling, comfort])
    keep = np.flatnonzero(non_dominated_mask(pairs)) if len(pairs) else np.zeros(0, dtype=int)
    return keep[np.lexsort((comfort[keep], handling[keep]))]


def best_at_limit(comfort: np.ndarray, handling: np.ndarray, limit: float) -> int | None:
    """[-] Index of the best comfort among designs with ``handling <= limit`` (the first
    of equals), None if none meets the limit."""
    meeting = np.flatnonzero(handling <= limit)
    if not len(meeting):
        return None
    return int(meeting[np.argmin(comfort[meeting])])


@dataclass(frozen=True)
class Attainment:
    """Attainment across seeds in the normalised comfort-handling plane (module docstring).

    Attributes
    ----------
    surfaces : np.ndarray
        [-] rows ``(sigma_aw_norm, handling_norm, percentile)``: the EAF's attainment
        surfaces at :data:`ATTAINMENT_LEVELS` (the best, median and worst seed)
    vorobev_threshold_pct : float
        [%] Vorob'ev threshold
    vorobev_expectation : np.ndarray
        [-] the expectation's points, ``(m, 2)``
    vorobev_deviation : float
        [-] Vorob'ev deviation (unit square)
    """

    surfaces: np.ndarray
    vorobev_threshold_pct: float
    vorobev_expectation: np.ndarray
    vorobev_deviation: float


def attainment(sets: list[np.ndarray]) -> Attainment:
    """EAF surfaces and Vorob'ev expectation and deviation of per-seed point sets.

    Parameters
    ----------
    sets : list[np.ndarray]
        [-] per seed, its normalised plane points ``(n_i, 2)``; points not below the
        reference ``(1, 1)`` are dropped, and a seed left with none attains only the reference
        corner (so it still counts as a seed)
    """
    parts, labels = [], []
    for i, z in enumerate(sets):
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        z = z[np.all(z < 1.0, axis=1)]
        z = z[moocore.is_nondominated(z)] if len(z) else np.ones((1, 2))
        parts.append(z)
        labels.append(np.full(len(z), i + 1))
    points, sets_id = np.concatenate(parts), np.concatenate(labels)
    n = len(sets)
    levels = sorted({100.0 / n, 50.0, 100.0}) if n > 1 else [100.0]
    surfaces = moocore.eaf(points, sets_id, percentiles=levels)
    if n < 2:
        return Attainment(surfaces, float("nan"), points, float("nan"))
    vorob = moocore.vorob_t(points, sets_id, ref=np.ones(2))
    deviation = float(moocore.vorob_dev(points, sets_id, ref=np.ones(2), ve=vorob["ve"]))
    return Attainment(surfaces, float(vorob["threshold"]), np.asarray(vorob["ve"]), deviation)
