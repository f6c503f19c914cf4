"""pymoo adapter: a hisopt :class:`~hisopt.problem.Problem` as a vectorised pymoo ``Problem``.

Objectives and constraints are the ones the problem file names (default: the paper's four
indicators, docs/model.md §6). Following pymoo's contract (``pymoo/core/problem.py``):

- ``F`` (n, n_obj): the objectives in physical units (all are minimised);
- ``G`` (n, n_con + 1), feasible when ``G <= 0``: each constraint normalised as
  ``value / limit - 1`` (as pymoo's ``problems/multi/carside.py``), plus a last column that is
  0 for a valid design and 1 for a design the model cannot evaluate (unstable or singular:
  the evaluator returns NaN). Invalid designs get ``F = inf`` and every constraint violated,
  so survival ranks them last by constraint violation and they never enter a front.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from pymoo.core.problem import Problem as PymooProblem

if TYPE_CHECKING:
    from hisopt.problem import Problem

INVALID_VIOLATION = 1.0
"""[-] normalised violation given to every constraint of an invalid design."""


def objective_matrix(quantities: dict[str, np.ndarray], names: tuple[str, ...]) -> np.ndarray:
    """Objectives ``F`` (n, n_obj) from evaluator output; invalid designs get ``inf``.

    Parameters
    ----------
    quantities : dict[str, np.ndarray]
        [physical units] evaluator output, each ``(n,)``, with boolean ``"valid"``
    names : tuple[str, ...]
        [-] objective names, in column order
    """
    valid = np.asarray(quantities["valid"], dtype=bool)
    f = np.column_stack([np.asarray(quantities[name], dtype=float) for name in names])
    return np.where(valid[:, None] & np.isfinite(f), f, np.inf)


def constraint_matrix(quantities: dict[str, np.ndarray], names: tuple[str, ...], limits: tuple[float, ...]) -> np.ndarray:
    """Normalised constraints ``G`` (n, n_con + 1), ``value / limit - 1 <= 0`` when met.

    The last column flags invalid designs (0 valid, 1 invalid); invalid designs violate
    every constraint by :data:`INVALID_VIOLATION`.

    Parameters
    ----------
    quantities : dict[str, np.ndarray]
        [physical units] evaluator output, each ``(n,)``, with boolean ``"valid"``
    names : tuple[str, ...]
        [-] constraint quantity names
    limits : tuple[float, ...]
        [physical units] upper limits, one per name (all > 0)
    """
    valid = np.asarray(quantities["valid"], dtype=bool)
    n = valid.size
    g = np.empty((n, len(names) + 1))
    for j, (name, limit) in enumerate(zip(names, limits, strict=True)):
        g[:, j] = np.asarray(quantities[name], dtype=float) / limit - 1.0
    g[:, -1] = 0.0
    bad = ~valid | ~np.all(np.isfinite(g), axis=1)
    g[bad, :] = INVALID_VIOLATION
    return g


def feasible_mask(g: np.ndarray) -> np.ndarray:
    """[-] Designs meeting every constraint (and valid), shape ``(n,)``, from ``G``."""
    return np.all(g <= 0.0, axis=1)


class HisoptPymooProblem(PymooProblem):
    """A hisopt problem seen by pymoo: box bounds, ``F`` and ``G`` in one vectorised call.

    Parameters
    ----------
    problem : Problem
        [-] the hisopt problem (variables, objectives, constraints)
    """

    def __init__(self, problem: Problem):
        self.hisopt_problem = problem
        self.objective_names = problem.objective_names
        self.constraint_names = problem.constraint_names
        self.constraint_limits = tuple(float(c.limit) for c in problem.spec.constraints)
        self.choices = problem.choices
        xl, xu = problem.lower.astype(float), problem.upper.astype(float)
        for j, values in self.choices.items():  # a choice is searched by its place in the list
            xl[j], xu[j] = -0.5, len(values) - 0.5
        super().__init__(
            n_var=len(problem.variable_names),
            n_obj=len(self.objective_names),
            n_ieq_constr=len(self.constraint_names) + 1,
            xl=xl,
            xu=xu,
            vtype=float,
        )

    def decode(self, u: np.ndarray) -> np.ndarray:
        """[SI] The designs of search coordinates ``u`` (n, n_var): a choice variable's
        coordinate is a place in its list, rounded to the nearest listed value, so that the
        operators (SBX, polynomial mutation, the box's faces) move along the list in order and
        the whole population is still one batch (docs/model.md §17); the others are values."""
        x = np.array(u, dtype=float)
        for j, values in self.choices.items():
            x[:, j] = values[np.clip(np.rint(x[:, j]), 0, len(values) - 1).astype(np.int64)]
        return x

    def encode(self, x: np.ndarray) -> np.ndarray:
        """Search coordinates of designs ``x`` (n, n_var) [SI]: a listed value's place in its list
        (the nearest one's), the others as they are; ``decode(encode(x)) == x`` for listed designs."""
        u = np.array(x, dtype=float)
        for j, values in self.choices.items():
            u[:, j] = np.argmin(np.abs(u[:, j, None] - values[None, :]), axis=1)
        return u

    def quantities(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """[physical units] Evaluator output for designs ``x`` (n, n_var) [SI, decoded]."""
        return self.hisopt_problem.evaluator()(x)

    def f_and_g(self, quantities: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """``(F, G)`` from evaluator output (see the module docstring)."""
        return (
            objective_matrix(quantities, self.objective_names),
            constraint_matrix(quantities, self.constraint_names, self.constraint_limits),
        )

    def _evaluate(self, x: np.ndarray, out: dict[str, Any], *args: Any, **kwargs: Any) -> None:
        out["F"], out["G"] = self.f_and_g(self.quantities(self.decode(x)))
