"""Axis ticks that a person reads at a glance, for plotly figures.

Plotly's own log axes label a range narrower than a decade with digits of the mantissa
(``1, 4, 1.089826, 3``); :func:`log_ticks` gives decades, 1-2-5 steps or, for a narrow
range, evenly spaced round values, each labelled in full.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from hisopt.units import format_number


def _finite_positive(values: ArrayLike) -> np.ndarray:
    x = np.asarray(values, dtype=float).ravel()
    return x[np.isfinite(x) & (x > 0)]


def _linear_ticks(lo: float, hi: float, least: int = 3) -> list[float]:
    """Round, evenly spaced ticks in ``[lo, hi]``: the largest step of 1, 2, 2.5 or 5 times a
    power of ten giving at least ``least`` of them."""
    top = math.floor(math.log10(hi - lo)) if hi > lo else math.floor(math.log10(hi))
    for power in range(top, top - 15, -1):
        for m in (5.0, 2.5, 2.0, 1.0):
            step = m * 10.0**power
            first = math.ceil(lo / step - 1e-9) * step
            ticks = [float(f"{v:.12g}") for v in np.arange(first, hi + step * 1e-6, step) if v > 0]
            if len(ticks) >= least:
                return ticks
    return [lo, hi]


def log_ticks(lo: float, hi: float, max_ticks: int = 7) -> list[float]:
    """Tick values for a log axis spanning ``[lo, hi]`` (both > 0), ascending.

    The densest of 1-2-5, 1-3 and decade steps with at most ``max_ticks`` ticks inside (every
    k-th decade for very wide ranges); when fewer than two of those fall inside (a range
    narrower than a factor of about 3), round linear steps.
    """
    if not (lo > 0 and hi > 0):
        raise ValueError(f"log axis needs positive limits, got {lo!r}, {hi!r}")
    lo, hi = min(lo, hi), max(lo, hi)
    d_lo, d_hi = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    inside = lambda ticks: [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]  # noqa: E731
    for mantissas in ((1, 2, 5), (1, 3), (1,)):
        ticks = inside([float(f"{m * 10.0**d:.12g}") for d in range(d_lo, d_hi + 1) for m in mantissas])
        if 2 <= len(ticks) <= max_ticks:
            return ticks
        if len(ticks) > max_ticks and mantissas == (1,):
            every = math.ceil(len(ticks) / max_ticks)
            return [t for t in ticks if round(math.log10(t)) % every == 0]
    return _linear_ticks(lo, hi)


def tick_label(value: float, scientific: bool, digits: int = 3) -> str:
    """``0.02``; or ``2×10<sup>-5</sup>``, ``10<sup>4</sup>`` (plotly's superscript markup)."""
    if not scientific:
        return format_number(value, digits)
    mantissa, exponent = format_number(value, digits, scientific=True).split("e")
    power = f"10<sup>{int(exponent)}</sup>"
    return power if mantissa == "1" else f"{mantissa}×{power}"


def log_axis(values: ArrayLike, pad: float = 0.05, digits: int = 3, max_ticks: int = 5) -> dict[str, Any]:
    """Plotly axis settings for a log axis showing ``values``: range, ticks and labels.

    Parameters
    ----------
    values : ArrayLike
        [axis unit] the data on the axis (non-positive and non-finite values ignored)
    pad : float, optional
        [-] margin beyond the data at each end, as a share of the span in decades
        (at least 0.02 decade)
    digits : int, optional
        [-] significant figures of the tick labels
    max_ticks : int, optional
        [-] most ticks of 1-2-5, 1-3 or decade steps
    """
    x = _finite_positive(values)
    if x.size == 0:
        return {"type": "log"}
    lo, hi = float(x.min()), float(x.max())
    if hi / lo < 1.0 + 1e-9:  # a constant: half a decade's view around it
        lo, hi = lo / 1.5, hi * 1.5
    margin = max(pad * (math.log10(hi) - math.log10(lo)), 0.02)
    ticks = log_ticks(lo, hi, max_ticks)
    scientific = not all(1e-2 <= t < 1e4 for t in ticks)  # one style per axis
    labels = [tick_label(t, scientific, digits) for t in ticks]
    return {
        "type": "log",
        "range": [math.log10(lo) - margin, math.log10(hi) + margin],
        "tickvals": ticks,
        "ticktext": labels,
    }
