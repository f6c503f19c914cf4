"""What an optimisation run found: per-generation statistics and the result object."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError
from hisopt.optim.decision import asf_index, knee_index
from hisopt.optim.settings import RunSettings
from hisopt.optim.thinning import EpsilonTolerances, thin_front

if TYPE_CHECKING:
    from hisopt.problem import Problem


@dataclass(frozen=True)
class GenerationStats:
    """Progress of a run after one generation (passed to ``progress`` callbacks).

    Attributes
    ----------
    generation : int
        [-] generations completed (1 = initial population)
    generations : int
        [-] generations of the whole run
    evaluations : int
        [-] designs evaluated so far
    feasible_share : float
        [-] share of this generation's designs that are feasible
    front_size : int
        [-] designs in the archive (the non-dominated feasible set)
    hypervolume : float
        [decades^n_obj] progress hypervolume of the archive in log10 space: an estimate
        within about 1 % (:mod:`hisopt.optim.convergence`); the run's final figure,
        :attr:`OptimizationResult.hypervolume`, is exact
    elapsed_s : float
        [s] wall time of the run so far (all sessions)
    """

    generation: int
    generations: int
    evaluations: int
    feasible_share: float
    front_size: int
    hypervolume: float
    elapsed_s: float


@dataclass(frozen=True)
class CatalogueCost:
    """What choosing from lists costs (docs/model.md §17.5): the catalogue front's hypervolume
    against that of the same problem with every choice variable made continuous between its
    first and last value, optimised with the same settings and measured from the same
    reference point.

    Attributes
    ----------
    catalogue : float
        [decades^n_obj] hypervolume of the catalogue run's front (log10 objectives)
    continuous : float
        [decades^n_obj] hypervolume of the continuous relaxation's front
    evaluations : int
        [-] designs the continuous run evaluated
    front_size : int
        [-] designs on the continuous front
    wall_time_s : float
        [s] wall time of the continuous run
    """

    catalogue: float
    continuous: float
    evaluations: int
    front_size: int
    wall_time_s: float

    @property
    def ratio(self) -> float:
        """[-] ``catalogue / continuous`` (below 1: the standard parts cost that share; NaN
        when the continuous front is empty)."""
        return self.catalogue / self.continuous if self.continuous > 0 else float("nan")

    def record(self) -> dict[str, Any]:
        """The ``run.json`` entry."""
        return {
            "hypervolume_catalogue": self.catalogue,
            "hypervolume_continuous": self.continuous,
            "ratio": self.ratio,
            "continuous_evaluations": self.evaluations,
            "continuous_front_size": self.front_size,
            "continuous_wall_time_s": self.wall_time_s,
        }

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> CatalogueCost:
        """From :meth:`record`'s dictionary."""
        return cls(
            float(record["hypervolume_catalogue"]),
            float(record["hypervolume_continuous"]),
            int(record["continuous_evaluations"]),
            int(record["continuous_front_size"]),
            float(record["continuous_wall_time_s"]),
        )

    def line(self, unit: str) -> str:
        """One line for a summary: both hypervolumes and their ratio."""
        return (
            f"{self.catalogue:.6g} of the continuous relaxation's {self.continuous:.6g} {unit} "
            f"({100 * self.ratio:.1f} %; its front of {self.front_size} designs from {self.evaluations} evaluations)"
        )


@dataclass
class OptimizationResult:
    """What a run found: the front, every evaluation, quality and decision support.

    Attributes
    ----------
    problem : Problem
        the optimised problem
    settings : RunSettings
        algorithm settings of the run
    front : pd.DataFrame
        [physical units] non-dominated feasible designs of all evaluations: variable
        columns, objective columns, constraint-only quantity columns (sorted by the first
        objective)
    history : pd.DataFrame
        [physical units] every evaluated design: ``evaluation``, ``generation``,
        variables, quantities, ``valid``, ``feasible``
    generations : pd.DataFrame
        per-generation statistics (:class:`GenerationStats` fields)
    hypervolume : float
        [decades^n_obj] hypervolume of the front in log10 space
    reference_point : np.ndarray
        [decades] the fixed hypervolume reference point (log10 of objectives)
    wall_time_s : float
        [s] wall time of the run (all sessions)
    run_dir : Path | None
        the run directory (None for a run without one)
    completed : bool
        [-] False when the algorithm stopped early (no new offspring possible)
    epsilon : EpsilonTolerances | None
        [-] the run's tolerances (:mod:`hisopt.optim.thinning`); None: no thinned front
    converged_at : int | None
        [-] generation at which the convergence stop fired (None: it did not, or the run
        does not use it)
    catalogue_cost : CatalogueCost | None
        [-] a problem with choices: its front against the continuous relaxation's
        (:mod:`hisopt.optim.catalogue_cost`); None otherwise or when switched off
    continuous_front : pd.DataFrame | None
        [physical units] the continuous relaxation's front (with ``catalogue_cost``)
    """

    problem: Problem
    settings: RunSettings
    front: pd.DataFrame
    history: pd.DataFrame
    generations: pd.DataFrame
    hypervolume: float
    reference_point: np.ndarray
    wall_time_s: float
    run_dir: Path | None = None
    completed: bool = True
    epsilon: EpsilonTolerances | None = None
    converged_at: int | None = None
    catalogue_cost: CatalogueCost | None = None
    continuous_front: pd.DataFrame | None = None

    def stop_record(self) -> dict[str, Any]:
        """[-] The run's stop rule and whether and where it fired (for ``run.json`` and the summary)."""
        s = self.settings
        out: dict[str, Any] = {"until": s.until, "generations": s.generations}
        if s.until == "converged":
            out |= {
                "tolerance": s.tolerance,
                "window_generations": s.window,
                "converged": self.converged_at is not None,
                "converged_at_generation": self.converged_at,
            }
        return out

    def hypervolume_history(self, rows: int = 6) -> list[tuple[int, float]]:
        """[-, decades^k] A few ``(evaluations, progress hypervolume)`` points of the run, evenly
        spaced in generations and ending with the last, to show whether it still improves."""
        g = self.generations
        if len(g) == 0:
            return []
        picks = np.unique(np.linspace(0, len(g) - 1, min(rows, len(g))).round().astype(int))
        return [(int(g["evaluations"].iloc[i]), float(g["hypervolume"].iloc[i])) for i in picks]

    @property
    def objectives(self) -> pd.DataFrame:
        """[objective units] The front's objective columns."""
        return self.front[list(self.problem.objective_names)]

    @cached_property
    def thinned(self) -> pd.DataFrame | None:
        """[physical units] The thinned front (:func:`hisopt.optim.thinning.thin_front` of
        :attr:`front`, same columns and order), or None for a run without tolerances."""
        if self.epsilon is None:
            return None
        rows = thin_front(self.objectives.to_numpy(dtype=float), self.epsilon.relative, self.epsilon.value)
        out = self.front.iloc[rows].reset_index(drop=True)
        out.attrs = dict(self.front.attrs)
        return out

    @property
    def shown(self) -> pd.DataFrame:
        """[physical units] The front decisions are made on: :attr:`thinned` when the run has
        tolerances, else :attr:`front`. The knee and the ASF pick are its members."""
        return self.front if self.thinned is None else self.thinned

    @property
    def knee(self) -> pd.Series:
        """The knee design of :attr:`shown` (:func:`hisopt.optim.decision.knee_index`)."""
        shown = self.shown
        return shown.iloc[knee_index(shown[list(self.problem.objective_names)].to_numpy())]

    def plot_front(self, refined: pd.DataFrame | None = None) -> Any:
        """Scatter matrix of :attr:`shown`'s objectives, knee and ASF pick highlighted (plotly)."""
        from hisopt.plotting.figures import front_scatter_matrix

        highlights = {"knee": self.knee, "ASF pick": self.asf_pick()} if len(self.front) else {}
        return front_scatter_matrix(self.shown, self.problem.objective_names, self.problem.variable_names, highlights, refined)

    def plot_parallel(self, color_by: str | None = None) -> Any:
        """Parallel coordinates of :attr:`shown`'s variables and objectives (plotly)."""
        from hisopt.plotting.figures import parallel_coordinates

        names = self.problem.objective_names
        return parallel_coordinates(self.shown, self.problem.variable_names, names, color_by or names[0])

    def plot_convergence(self) -> Any:
        """Hypervolume, front size and feasible share per generation (plotly)."""
        from hisopt.plotting.figures import convergence

        return convergence(self.generations)

    def asf_pick(
        self,
        reference: Mapping[str, float] | Sequence[float] | None = None,
        weights: Mapping[str, float] | Sequence[float] | None = None,
    ) -> pd.Series:
        """The design of :attr:`shown` closest to an aspiration point (augmented ASF, log space).

        Parameters
        ----------
        reference : Mapping[str, float] | Sequence[float] | None, optional
            [objective units] aspiration value per objective (by name or in
            objective order); default the front's ideal point; names left out take it too
        weights : Mapping[str, float] | Sequence[float] | None, optional
            [-] positive weight per objective (by name or in order); default 1 each;
            a larger weight pulls that objective closer to the reference
        """
        shown = self.shown
        names = self.problem.objective_names
        f = shown[list(names)].to_numpy()
        ref = None
        if reference is not None:
            ideal = f.min(axis=0)
            ref = _by_objective(reference, names, "reference", default=ideal)
        w = None if weights is None else _by_objective(weights, names, "weights", default=np.ones(len(names)))
        return shown.iloc[asf_index(f, ref, w)]


def _by_objective(values: Mapping[str, float] | Sequence[float], names: tuple[str, ...], what: str, default: np.ndarray) -> np.ndarray:
    if isinstance(values, Mapping):
        unknown = [k for k in values if k not in names]
        if unknown:
            raise ConfigError(f"unknown objective {unknown[0]!r} in the ASF {what}; expected names from {', '.join(names)}")
        return np.array([float(values.get(n, d)) for n, d in zip(names, default, strict=True)])
    out = np.asarray(values, dtype=float)
    if out.shape != (len(names),):
        raise ConfigError(f"expected {len(names)} ASF {what} values (order {', '.join(names)}), got {out.shape[0] if out.ndim else 1}")
    return out


ProgressFn = Callable[[GenerationStats], None]
"""Called with each generation's statistics."""
