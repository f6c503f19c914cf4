"""Navigation over a stored front: reference points and E-NAUTILUS steps (docs/model.md §19.3).

The decision room (``hisopt report``, :mod:`hisopt.report.decision_page`) runs the same rules
in the page; this module is their reference, which the page's test compares against. Both
work in the normalised log space of :func:`hisopt.optim.decision.normalised_log` (``0`` the
ideal and ``1`` the nadir of the designs at hand in each objective), minimisation.

- **Reference point**: the pick is :func:`hisopt.optim.decision.asf_index`; the *reachable
  ranges* (:func:`reachable_ranges`) are, per objective, the least and largest value among
  the designs at least as good as the reference point in every objective (none: the
  aspiration is out of reach and the pick is the closest design).
- **E-NAUTILUS** (Ruiz, Sindhya, Miettinen, Ruiz and Luque, EJOR 2015): a walk from the nadir
  to a Pareto design in ``steps`` steps. At each step the designs still reachable (those at
  least as good as the current point in every objective) are summarised by ``k``
  representatives, each giving the intermediate point ``c + (q - c) / h`` (``c`` the current
  point, ``q`` the representative, ``h`` the steps left): every objective improves and no
  Pareto design is lost until the designer picks one. Its reachable designs are those at
  least as good as it; their least values are the best each objective can still become. At
  the last step the point is the representative itself, a design of the front (``c + (q - c)``
  could round below ``q`` and leave nothing reachable). DESDEO picks the
  representatives by k-means clustering; here they are the greedy farthest-point sample
  (:func:`representatives`), which is deterministic, so the page and this module show the
  same designs.

Sums over objectives run in objective order, one objective at a time, as the page's
JavaScript adds them: the two agree to the last bit whatever numpy's summation order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _ordered_sum(terms: np.ndarray) -> np.ndarray:
    """Sum over the last axis one term at a time (the page's order)."""
    total = np.zeros(terms.shape[:-1])
    for j in range(terms.shape[-1]):
        total = total + terms[..., j]
    return total


def dominating(z: np.ndarray, point: np.ndarray) -> np.ndarray:
    """[-] Rows of ``z`` (n, k) at least as good as ``point`` (k,) in every objective."""
    return np.all(z <= point, axis=1)


def reachable_ranges(z: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(least, largest)`` (k,) of each objective over the rows of ``z`` at least as good as
    ``point`` in every objective; None when no row is."""
    rows = z[dominating(z, point)]
    if not len(rows):
        return None
    return rows.min(axis=0), rows.max(axis=0)


def representatives(z: np.ndarray, k: int) -> np.ndarray:
    """[-] Rows of ``z`` (n, k_obj) that summarise it: the row of least objective sum, then
    repeatedly the row farthest (Euclidean) from those chosen; ties go to the lower row.
    All rows when there are at most ``k``."""
    n = len(z)
    if n <= k:
        return np.arange(n)
    chosen = [int(np.argmin(_ordered_sum(z)))]
    nearest = _ordered_sum(np.square(z - z[chosen[0]]))
    for _ in range(k - 1):
        nxt = int(np.argmax(nearest))
        chosen.append(nxt)
        nearest = np.minimum(nearest, _ordered_sum(np.square(z - z[nxt])))
    return np.array(chosen)


@dataclass(frozen=True)
class Option:
    """One choice of an E-NAUTILUS step: the intermediate ``point`` (k,), the representative
    row it heads for, the rows still reachable from it and their least values (k,)."""

    point: np.ndarray
    representative: int
    reachable: np.ndarray
    best: np.ndarray


def enautilus_options(z: np.ndarray, current: np.ndarray, reachable: np.ndarray, steps_left: int, k: int) -> list[Option]:
    """The options of one E-NAUTILUS step (module docstring).

    Parameters
    ----------
    z : np.ndarray
        [-] the front in normalised log space (n, k_obj)
    current : np.ndarray
        [-] the current point (k_obj,) (the nadir, all ones, at the start)
    reachable : np.ndarray
        [-] rows of ``z`` reachable from ``current``, ascending
    steps_left : int
        [-] steps left, this one included (1: the options are designs of the front)
    k : int
        [-] options per step
    """
    if steps_left < 1 or k < 1:
        raise ValueError(f"expected at least one step left and one option per step, got {steps_left} and {k}")
    reachable = np.asarray(reachable, dtype=int)
    options = []
    for r in representatives(z[reachable], k):
        q = z[reachable[r]]
        point = q.copy() if steps_left == 1 else current + (q - current) / steps_left  # the last step: the design itself, not c + (q - c) rounded
        rows = reachable[dominating(z[reachable], point)]
        options.append(Option(point, int(reachable[r]), rows, z[rows].min(axis=0)))
    return options


def enautilus_walk(z: np.ndarray, picks: list[int], steps: int, k: int) -> list[list[Option]]:
    """The options of each step of a walk that takes option ``picks[i]`` at step ``i``: one
    list per step taken plus the next step's (``len(picks) + 1`` lists, fewer when the walk
    reaches a design)."""
    current = np.ones(z.shape[1])
    reachable = np.arange(len(z))
    shown = []
    for step in range(steps):
        options = enautilus_options(z, current, reachable, steps - step, k)
        shown.append(options)
        if step >= len(picks):
            break
        chosen = options[picks[step]]
        current, reachable = chosen.point, chosen.reachable
    return shown
