"""Combining a quantity over load cases: worst case, expected value, CVaR (docs/model.md §14.3).

Pure functions on ``(n designs, S scenarios)`` arrays and the naming of the per-scenario
columns, ``"<quantity>@<scenario>"``. A NaN in any scenario makes the aggregate NaN: a design
whose model fails in one load case is not rated on the others.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

Aggregate = Literal["worst", "expected", "cvar", "per_scenario"]

SEPARATOR = "@"


def scenario_column(quantity: str, scenario: str) -> str:
    """The column of ``quantity`` in ``scenario``: ``"sigma_aw@city"``."""
    return f"{quantity}{SEPARATOR}{scenario}"


def split_column(column: str) -> tuple[str, str]:
    """``"sigma_aw@city"`` -> ``("sigma_aw", "city")`` (the inverse of :func:`scenario_column`)."""
    quantity, scenario = column.split(SEPARATOR, 1)
    return quantity, scenario


def quantity_of(column: str) -> str:
    """The quantity a column holds: ``"sigma_aw@city"`` -> ``"sigma_aw"`` (plain names unchanged)."""
    return column.split(SEPARATOR, 1)[0]


def normalised(weights: Sequence[float]) -> np.ndarray:
    """[-] Weights scaled to sum to 1."""
    w = np.asarray(weights, dtype=float)
    return w / w.sum()


def worst(values: np.ndarray) -> np.ndarray:
    """Largest value over the scenarios (axis 1)."""
    return np.max(values, axis=1)


def expected(values: np.ndarray, weights: Sequence[float]) -> np.ndarray:
    """Weighted mean over the scenarios, ``sum_s w_s v_s`` with normalised weights."""
    if values.shape[1] == 1:
        return values[:, 0].copy()
    return values @ normalised(weights)


def cvar(values: np.ndarray, weights: Sequence[float], alpha: float) -> np.ndarray:
    """Conditional value at risk at level ``alpha``: the mean of the worst ``1 - alpha`` of the
    probability mass, the scenarios' weights being their probabilities.

    Equals ``min_t t + E[(v - t)+] / (1 - alpha)`` (Rockafellar and Uryasev 2000): sort the
    scenarios from worst to best and average them with weights ``min(w_s, mass left)`` until
    ``1 - alpha`` of the mass is taken (a scenario on the boundary counts in part). ``alpha =
    0`` is the expected value; as ``alpha -> 1`` it tends to the worst case.

    Parameters
    ----------
    values : np.ndarray
        [quantity unit] shape ``(n, S)``
    weights : Sequence[float]
        [-] relative weight of each scenario, ``(S,)``
    alpha : float
        [-] level in ``[0, 1)``
    """
    if values.shape[1] == 1:
        return values[:, 0].copy()
    w = normalised(weights)
    order = np.argsort(-values, axis=1, kind="stable")
    ranked = np.take_along_axis(values, order, axis=1)
    w_ranked = w[order]
    tail = 1.0 - alpha
    before = np.cumsum(w_ranked, axis=1) - w_ranked  # mass of the worse scenarios
    taken = np.clip(tail - before, 0.0, w_ranked)
    out = np.sum(np.where(taken > 0, taken * ranked, 0.0), axis=1) / tail
    return np.where(np.isnan(values).any(axis=1), np.nan, out)


def aggregate(values: np.ndarray, how: Aggregate, weights: Sequence[float], alpha: float = 0.8) -> np.ndarray:
    """One value per design from its scenarios' ``values`` ``(n, S)``.

    ``per_scenario`` keeps the scenarios as objectives of their own; its plain column is the
    worst case, reported for reading, never optimised.
    """
    if how in ("worst", "per_scenario"):
        return worst(values)
    if how == "expected":
        return expected(values, weights)
    return cvar(values, weights, alpha)
