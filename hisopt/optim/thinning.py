"""The thinned front: the archive kept to designs that differ by more than stated tolerances.

A run's archive (:mod:`hisopt.optim.archive`) holds every non-dominated feasible design it
evaluated, thousands of them, many differing in the fourth significant digit. With epsilon
tolerances (per objective, relative ``"1 %"`` or absolute ``"0.01 m/s^2"``:
:mod:`hisopt.specification.tolerances`) a run also reports the *thinned front*, a pure,
deterministic function of the archive's objectives (:func:`thin_front`).

Two objective vectors ``a`` and ``b`` are **within the tolerances** of each other when, in
every objective ``j``,

- ``|a_j - b_j| <= eps_j`` (absolute tolerance; zero: equal), or
- ``|a_j - b_j| <= eps_j * min(|a_j|, |b_j|)`` (relative tolerance, i.e. the larger is at
  most ``1 + eps_j`` times the smaller: multiplicative epsilon).

Rule: of the input's non-dominated designs, visit them in order of their augmented
achievement scalarising function (the ASF of :func:`hisopt.optim.decision.asf_index`: ideal
point, equal weights, normalised log space; ties by input row), and keep a design unless it
is within the tolerances of a design already kept. The kept designs form a maximal set of
designs pairwise *not* within the tolerances, so that

(a) no two thinned designs are within the tolerances of each other, and
(b) every non-dominated input design is within the tolerances of a thinned design (it was
    skipped only for being within those of a kept one); every dominated input design is
    epsilon-dominated by a thinned design (no worse than it by more than the tolerance in
    any objective).

This replaces Laumanns et al. (2002)'s epsilon boxes, which give (b) but not (a): two
designs just either side of a box edge are kept although they differ by far less than the
tolerance. Visiting in ASF order makes the front's ASF pick (:func:`~hisopt.optim.decision.asf_index`
with its defaults) the first design kept: it is always in the thinned front, and it is the
thinned front's ASF pick too. With all tolerances zero the thinned front is the input's
non-dominated set (identical objective vectors: the first only).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.errors import ConfigError
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.decision import normalised_log
from hisopt.specification.tolerances import Tolerance, parse_tolerance_options, parse_tolerances

if TYPE_CHECKING:
    from hisopt.problem import Problem

BLOCK = 256
"""[-] Candidates tested against the kept designs in one vectorised call (memory ``BLOCK x kept``)."""

EpsilonInput = Mapping[str, Any] | str | Iterable[str]
"""What :func:`hisopt.optimize`'s ``epsilon`` takes: ``{name: tolerance}`` as in the problem
file, or ``"NAME=TOL"`` text as ``--epsilon`` takes it (one string, comma-separated, or several)."""


@dataclass(frozen=True)
class EpsilonTolerances:
    """The tolerances of a run, one per objective column (module rules).

    Attributes
    ----------
    names : tuple[str, ...]
        [-] objective columns, in the problem's order
    relative : np.ndarray
        [-] boolean ``(k,)``: the tolerance is a share of the value
    value : np.ndarray
        [- or objective unit] ``(k,)`` tolerances (0: exact)
    given : dict[str, Tolerance]
        [-] the tolerances as given, by the name they were given for
    """

    names: tuple[str, ...]
    relative: np.ndarray
    value: np.ndarray
    given: dict[str, Tolerance]

    def record(self) -> dict[str, Any]:
        """``run.json``'s record: ``{name: {"relative": share} | {"absolute": SI value}, "text": as given}``."""
        return {name: {("relative" if t.relative else "absolute"): t.value, "text": t.text} for name, t in self.given.items()}

    def describe(self) -> str:
        """One line for people: ``sigma_aw 1 %, max_roll_psd 2 %`` (objectives without one are exact)."""
        return ", ".join(f"{name} {t.text}" for name, t in self.given.items()) or "none"


def resolve_epsilon(problem: Problem, given: EpsilonInput | None = None, *, option: str = "epsilon") -> EpsilonTolerances | None:
    """The run's tolerances: the problem file's ``[optimizer] epsilon``, each overridden by ``given``.

    Parameters
    ----------
    problem : Problem
        [-] the problem (its objectives, their units and its file's tolerances)
    given : EpsilonInput | None, optional
        [-] tolerances by objective name (:data:`EpsilonInput`); None: the file's only
    option : str, optional
        [-] what a message names for ``given``: ``--epsilon`` or ``epsilon``

    Returns
    -------
    EpsilonTolerances | None
        None when neither the file nor ``given`` names a tolerance (no thinned front).

    Raises
    ------
    ConfigError
        An unknown objective name or an unreadable tolerance, naming ``option`` and the name.
    """
    from hisopt.metrics import METRICS
    from hisopt.robust import quantity_of

    units = {q: METRICS[q].unit for q in problem.spec.objectives}
    tolerances = parse_tolerances(
        problem.spec.optimizer.epsilon, units, file=None if problem.path is None else str(problem.path), key=lambda n: f"optimizer.epsilon.{n}"
    )
    if given is not None:
        if isinstance(given, Mapping):
            texts = dict(given)
            tolerances |= parse_tolerances(texts, units, key=lambda n: f"{option}.{n}")
        else:
            if not isinstance(given, str) and not all(isinstance(item, str) for item in given):
                raise ConfigError('expected {name: tolerance}, "NAME=TOL" text or a list of such texts', key=option)
            texts = parse_tolerance_options(given, option)
            tolerances |= parse_tolerances(texts, units, key=lambda n: f"{option} {n}={texts[n]}")
    if not tolerances:
        return None
    names = tuple(problem.objective_names)
    per_column = [tolerances.get(quantity_of(name)) for name in names]  # a scenario column takes its quantity's
    return EpsilonTolerances(
        names,
        np.array([t is not None and t.relative for t in per_column], dtype=bool),
        np.array([0.0 if t is None else t.value for t in per_column], dtype=float),
        {name: tolerances[name] for name in problem.spec.objectives if name in tolerances},
    )


def within_tolerances(a: np.ndarray, b: np.ndarray, relative: np.ndarray, value: np.ndarray) -> np.ndarray:
    """``out[i, j]``: ``a[i]`` and ``b[j]`` are within the tolerances of each other (module rule).

    Parameters
    ----------
    a : np.ndarray
        [objective units] shape ``(m, k)``
    b : np.ndarray
        [objective units] shape ``(n, k)``
    relative : np.ndarray
        [-] boolean ``(k,)``, True where the tolerance is relative
    value : np.ndarray
        [- or objective units] tolerances ``(k,)``

    Returns
    -------
    np.ndarray
        Boolean array of shape ``(m, n)``.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    out = np.ones((len(a), len(b)), dtype=bool)
    for j in range(np.shape(a)[1]):  # one objective at a time: no (m, n, k) temporary
        gap = np.abs(a[:, None, j] - b[None, :, j])
        bound = value[j] * np.minimum(np.abs(a[:, None, j]), np.abs(b[None, :, j])) if relative[j] else value[j]
        out &= gap <= bound
    return out


def thin_front(f: np.ndarray, relative: np.ndarray, value: np.ndarray) -> np.ndarray:
    """[-] Rows of ``f`` that form its thinned front (module rule), ascending.

    Parameters
    ----------
    f : np.ndarray
        [objective units] objective vectors ``(n, k)`` (normally the archive: non-dominated)
    relative : np.ndarray
        [-] boolean ``(k,)``, True where the tolerance is relative
    value : np.ndarray
        [- or objective units] tolerances ``(k,)``, finite and >= 0

    Returns
    -------
    np.ndarray
        [-] integer row indices into ``f``.
    """
    f = np.asarray(f, dtype=float)
    rows = np.flatnonzero(non_dominated_mask(f)) if len(f) else np.zeros(0, dtype=np.int64)
    relative, value = np.asarray(relative, dtype=bool), np.asarray(value, dtype=float)
    if len(rows) <= 1 or not np.any(value > 0):
        return rows  # exact everywhere: nothing is within the tolerances of another design
    z, _ = normalised_log(f[rows])
    d = z  # ASF with the ideal point (0 in normalised space) and equal weights
    asf = d.max(axis=1) + 1e-6 * d.sum(axis=1)  # rho as decision.asf_index's default
    order = rows[np.lexsort((rows, asf))]
    kept = np.empty((0, f.shape[1]))
    kept_rows: list[np.ndarray] = []
    for start in range(0, len(order), BLOCK):  # the greedy rule, a block of candidates at a time
        block = order[start : start + BLOCK]
        fb = f[block]
        free = np.flatnonzero(~within_tolerances(fb, kept, relative, value).any(axis=1))  # clear of every design kept so far
        near = within_tolerances(fb[free], fb[free], relative, value)
        taken = np.zeros(len(free), dtype=bool)
        for i in range(len(free)):  # in visiting order: clear of those of this block kept before it
            taken[i] = not (near[i] & taken).any()
        kept_rows.append(block[free[taken]])
        kept = np.concatenate([kept, fb[free[taken]]])
    return np.sort(np.concatenate(kept_rows))


def epsilon_from_record(problem: Problem, record: Mapping[str, Any] | None) -> EpsilonTolerances | None:
    """The tolerances :meth:`EpsilonTolerances.record` wrote to ``run.json`` (for resuming);
    None for a run without any."""
    if not record:
        return None
    return resolve_epsilon(problem, {name: entry["text"] for name, entry in record.items()})
