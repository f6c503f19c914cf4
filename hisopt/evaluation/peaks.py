"""Continuous maxima of a PSD off any grid (docs/model.md §10.4).

A PSD's maxima are resonance peaks (or a band limit). From samples that resolve every
resonance (the evaluator's pole-aware nodes and its samples at the damped frequencies), the
highest local maxima are followed by successive parabolic interpolation of ``1/y``, which is
exact for a Lorentzian peak ``y = k / ((f - f0)^2 + b^2)``; the evaluator, the sweeps and the
refinement's node plan all find their maxima here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hisopt.evaluation.kernels import local_maxima

GOLDEN = (3.0 - np.sqrt(5.0)) / 2.0
"""[-] The golden-section share: where a safeguarded step samples the larger half-bracket."""


def _vertex(a: np.ndarray, m: np.ndarray, c: np.ndarray, ya: np.ndarray, ym: np.ndarray, yc: np.ndarray) -> np.ndarray:
    """Abscissa of the vertex of the parabola through ``1/y`` at ``a < m < c`` (exact for a
    Lorentzian peak ``y = k / ((f - f0)^2 + b^2)``), safeguarded to a golden-section point."""
    with np.errstate(all="ignore"):
        ra, rm, rc = 1.0 / ya, 1.0 / ym, 1.0 / yc
        p, q = (m - a) * (rm - rc), (m - c) * (rm - ra)
        x = m - 0.5 * ((m - a) * p - (m - c) * q) / (p - q)
    golden = np.where(c - m > m - a, m + GOLDEN * (c - m), m - GOLDEN * (m - a))
    span = c - a
    ok = np.isfinite(x) & (x > a + 1e-3 * span) & (x < c - 1e-3 * span) & (np.abs(x - m) > 1e-9 * span)
    return np.where(ok, x, golden)


def refine_maximum(
    values_at: Callable[[np.ndarray], np.ndarray],
    f_hz: np.ndarray,
    values: np.ndarray,
    steps: int,
    candidates: int = 2,
    starts: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """[Hz], [value] Continuous maximum of a positive function sampled at sorted nodes, per row.

    The ``candidates`` highest local maxima among the samples (two resonances of nearly equal
    height are both followed) are each refined from the sample and its two neighbours by
    successive parabolic interpolation of ``1/y`` (exact for a resonance's Lorentzian peak;
    a step that would leave the bracket samples it by golden section instead), ``steps`` new
    samples each; the best value found, samples included, is returned.

    Parameters
    ----------
    values_at : Callable[[np.ndarray], np.ndarray]
        the function at frequencies ``(n, m)`` [Hz] -> ``(n, m)``
    f_hz, values : np.ndarray
        nodes ``(r, F)`` and values ``(n, F)``, ``n`` a multiple of ``r`` (row
        ``i`` of the values sampled at the nodes of row ``i % r``); a node of value ``-inf``
        is never chosen
    steps : int
        new samples per candidate
    candidates : int, optional
        local maxima followed per row (1 or 2)
    starts : np.ndarray | None, optional
        ``(n, 2)`` those maxima's columns (:func:`hisopt.evaluation.kernels.local_maxima`), if
        found already
    """
    n, size = values.shape
    row = np.arange(n)
    f_row = row % f_hz.shape[0]
    if starts is None:
        starts = np.empty((n, 2), dtype=np.int64)
        local_maxima(np.ascontiguousarray(values, dtype=float), 0.1, starts)
    idx = starts[:, :candidates]
    first = idx[:, 0]
    rows = row[:, None]
    best, f_best = values[row, first], f_hz[f_row, first]
    lo, hi = np.maximum(idx - 1, 0), np.minimum(idx + 1, size - 1)
    a, m, c = f_hz[f_row[:, None], lo], f_hz[f_row[:, None], idx], f_hz[f_row[:, None], hi]
    ya, ym, yc = values[rows, lo], values[rows, idx], values[rows, hi]
    # A maximum at the first or last sample has a == m or m == c: its first step samples the
    # other side by golden section (the parabola is degenerate).
    for _ in range(steps):
        x = _vertex(a, m, c, ya, ym, yc)
        y = values_at(x)
        better = y >= ym
        left_of = x < m
        a, ya = np.where(better & ~left_of, m, np.where(~better & left_of, x, a)), np.where(better & ~left_of, ym, np.where(~better & left_of, y, ya))
        c, yc = np.where(better & left_of, m, np.where(~better & ~left_of, x, c)), np.where(better & left_of, ym, np.where(~better & ~left_of, y, yc))
        m, ym = np.where(better, x, m), np.where(better, y, ym)
    j = np.argmax(ym, axis=1)
    found, f_found = ym[row, j], m[row, j]
    improved = found > best
    return np.where(improved, f_found, f_best), np.where(improved, found, best)
