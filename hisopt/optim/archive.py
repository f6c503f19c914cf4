"""Archive of the non-dominated feasible designs a run has evaluated.

With four objectives most Pareto-optimal designs are found on the way and later lost from
the population (survival keeps only ``pop_size`` of them), so the front a run reports is this
archive of every feasible design ever evaluated, not the last population.

Rules (deterministic, independent of timing):

- only feasible, valid designs enter;
- a candidate is rejected when an archived design weakly dominates it (no worse in every
  objective, which includes an identical objective vector: the first design found keeps
  its place) or when an earlier candidate of the same batch does;
- archived designs dominated by an accepted candidate leave;
- members are kept in order of evaluation (their evaluation ids ascend).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import moocore
import numpy as np


def weakly_dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``out[i, j]``: ``a[i]`` is no worse than ``b[j]`` in every objective (minimisation).

    Parameters
    ----------
    a : np.ndarray
        [objective units] shape ``(m, k)``
    b : np.ndarray
        [objective units] shape ``(n, k)``

    Returns
    -------
    np.ndarray
        Boolean array of shape ``(m, n)``.
    """
    out = np.ones((len(a), len(b)), dtype=bool)
    for j in range(np.shape(a)[1]):  # one objective at a time: no (m, n, k) temporary
        out &= a[:, None, j] <= b[None, :, j]
    return out


def dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``out[i, j]``: ``a[i]`` Pareto-dominates ``b[j]`` (no worse everywhere, better somewhere)."""
    return weakly_dominates(a, b) & ~weakly_dominates(b, a).T


def non_dominated_mask(f: np.ndarray) -> np.ndarray:
    """[-] Rows of ``f`` (n, k) that no other row dominates; of equal rows only the first.

    Kung's dimension sweep (moocore, ``O(n log^(k-2) n)`` time, ``O(n k)`` memory), so a
    study can merge fronts of any size. A row with a NaN compares with no other row: it is
    kept, and never removes another.
    """
    f = np.asarray(f, dtype=float)
    n = len(f)
    if n == 0 or f.shape[1] == 0:
        return np.arange(n) == 0
    comparable = ~np.isnan(f).any(axis=1)
    out = np.ones(n, dtype=bool)
    out[comparable] = moocore.is_nondominated(f[comparable], keep_weakly=False)
    return out


def pareto_update(archive_f: np.ndarray, new_f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which archived designs stay and which new designs enter (module rules).

    The batch is filtered first (:func:`non_dominated_mask`); each survivor is then checked
    against the archive by a compiled loop that stops at the first archived design weakly
    dominating it, scanning the newest designs first (a candidate's dominators are mostly
    recent: they come from the population that bred it). Only accepted candidates scan the
    whole archive, to find the designs they remove; a generation's cost therefore grows with
    the archive only through the few candidates that enter.

    Parameters
    ----------
    archive_f : np.ndarray
        [objective units] archived objectives, shape ``(m, k)``
    new_f : np.ndarray
        [objective units] candidate objectives (feasible designs only), shape ``(n, k)``

    Returns
    -------
    keep : np.ndarray
        boolean ``(m,)``, archived designs that stay
    accept : np.ndarray
        boolean ``(n,)``, candidates that enter
    """
    accept = non_dominated_mask(new_f)
    keep = np.ones(len(archive_f), dtype=bool)
    if len(archive_f) and accept.any():
        a = np.ascontiguousarray(archive_f, dtype=float)
        c = np.ascontiguousarray(np.asarray(new_f, dtype=float)[accept])
        if np.isnan(a).any() or np.isnan(c).any():  # NaN compares with nothing: the plain rule
            accept[accept] = ~weakly_dominates(a, c).any(axis=0)
            if accept.any():
                keep = np.asarray(~weakly_dominates(np.asarray(new_f, dtype=float)[accept], a).any(axis=0), dtype=bool)
            return keep, accept
        entered = np.empty(len(c), dtype=np.bool_)
        _archive_kernel()(a, c, entered, keep)
        accept[accept] = entered
    return keep, accept


_KERNEL: list[Any] = []


def _archive_kernel() -> Any:
    """The compiled archive check (compiled on first use, cached on disk)."""
    if not _KERNEL:
        import importlib

        importlib.import_module("hisopt.evaluation.kernels")  # numba imported the evaluator's way first
        from numba import njit

        _KERNEL.append(njit(cache=True)(_offer))
    return _KERNEL[0]


def _offer(a: np.ndarray, c: np.ndarray, entered: np.ndarray, keep: np.ndarray) -> None:
    """Compiled by numba: ``entered[j]`` no row of ``a`` weakly dominates ``c[j]``; clear
    ``keep[i]`` for each row of ``a`` an entering candidate dominates (no NaN in ``a``, ``c``)."""
    m, k = a.shape
    for j in range(c.shape[0]):
        entered[j] = True
        for i in range(m - 1, -1, -1):  # newest first: early exit for most rejected candidates
            below = True
            for t in range(k):
                if a[i, t] > c[j, t]:
                    below = False
                    break
            if below:
                entered[j] = False
                break
        if entered[j]:
            # no archived design weakly dominates c[j], so "c[j] weakly dominates" is strict domination
            for i in range(m):
                if keep[i]:
                    above = True
                    for t in range(k):
                        if c[j, t] > a[i, t]:
                            above = False
                            break
                    if above:
                        keep[i] = False


@dataclass(frozen=True)
class Archive:
    """Non-dominated feasible designs (immutable; :meth:`update` returns a new archive).

    Attributes
    ----------
    x : np.ndarray
        [variable units] designs, shape ``(m, n_var)``
    f : np.ndarray
        [objective units] objectives, shape ``(m, n_obj)``
    q : np.ndarray
        [physical units] every evaluated quantity (objectives, then constraint-only
        quantities), shape ``(m, n_q)``
    ids : np.ndarray
        [-] evaluation ids (position in the run's evaluation history), ascending, ``(m,)``
    """

    x: np.ndarray
    f: np.ndarray
    q: np.ndarray
    ids: np.ndarray

    @classmethod
    def empty(cls, n_var: int, n_obj: int, n_q: int) -> Archive:
        """An archive with no designs."""
        return cls(np.empty((0, n_var)), np.empty((0, n_obj)), np.empty((0, n_q)), np.empty(0, dtype=np.int64))

    def __len__(self) -> int:
        return len(self.ids)

    def update(self, x: np.ndarray, f: np.ndarray, q: np.ndarray, ids: np.ndarray, feasible: np.ndarray) -> Archive:
        """The archive after offering a batch of evaluated designs.

        Parameters
        ----------
        x, f, q : np.ndarray
            [physical units] the batch, shapes ``(n, n_var)``, ``(n, n_obj)``, ``(n, n_q)``
        ids : np.ndarray
            [-] evaluation ids of the batch, all greater than the archived ones, ``(n,)``
        feasible : np.ndarray
            [-] designs eligible for the archive (valid and meeting all constraints)
        """
        sel = np.asarray(feasible, dtype=bool)
        keep, accept = pareto_update(self.f, f[sel])
        return Archive(
            np.concatenate([self.x[keep], x[sel][accept]]),
            np.concatenate([self.f[keep], f[sel][accept]]),
            np.concatenate([self.q[keep], q[sel][accept]]),
            np.concatenate([self.ids[keep], np.asarray(ids, dtype=np.int64)[sel][accept]]),
        )

    def order(self) -> np.ndarray:
        """[-] Presentation order: by the first objective, then the next ones, then id."""
        keys = [self.ids] + [self.f[:, j] for j in range(self.f.shape[1] - 1, -1, -1)]
        return np.lexsort(keys)
