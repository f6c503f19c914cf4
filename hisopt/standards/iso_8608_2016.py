"""ISO 8608:2016 road-surface profiles: displacement PSD, road classes A-H.

Single-track displacement PSD ``G_d(n) = G_d(n0) (n/n0)^-w`` in spatial frequency ``n``
[cycle/m]; at constant speed ``v`` the one-sided temporal PSD is
``G(f) = G_d(f/v) / v = G_d(n0) (f/(n0 v))^-w / v`` [m^2/Hz] (docs/model.md §4.2).

References
----------
ISO 8608:2016, Mechanical vibration -- Road surface profiles -- Reporting of measured data.
Fitted displacement PSD ``G_d(n) = G_d(n0)(n/n0)^-w`` with ``n0 = 0.1`` cycle/m, and Annex C,
Table C.2 (degree of roughness, classes A-H, ``w = 2``).
"""

from __future__ import annotations

import csv
import math
from functools import lru_cache
from importlib import resources
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hisopt.errors import ConfigError

RoadClass = Literal["A", "B", "C", "D", "E", "F", "G", "H"]
"""ISO 8608 road roughness classes, A (very good) to H."""

N0_CYCLES_PER_M = 0.1
"""[cycle/m] Reference spatial frequency n0 (ISO 8608:2016)."""

WAVINESS = 2.0
"""[-] Waviness exponent w of the class spectra (ISO 8608:2016, Annex C)."""

_CLASS_FILE = "iso8608_classes.csv"
"""Packaged table ``hisopt/data/iso8608_classes.csv`` (Table C.2; provenance in its header)."""


@lru_cache(maxsize=1)
def road_classes() -> dict[str, tuple[float, float, float]]:
    """Road classes of ISO 8608:2016 Table C.2, read from the packaged table.

    Returns
    -------
    dict
        ``{class: (lower, geometric_mean, upper)}`` of ``G_d(n0)`` [m^3]; the lower limit of A
        is 0 and the upper limit of H is ``inf``.
    """
    text = (resources.files("hisopt") / "data" / _CLASS_FILE).read_text(encoding="utf-8")
    rows = csv.DictReader(line for line in text.splitlines() if not line.startswith("#"))

    def m3(cell: str, missing: float) -> float:
        return float(cell) * 1e-6 if cell.strip() else missing

    return {
        r["class"]: (
            m3(r["Gd_n0_lower"], 0.0),
            m3(r["Gd_n0_geometric_mean"], math.nan),
            m3(r["Gd_n0_upper"], math.inf),
        )
        for r in rows
    }


def class_gd_n0(road_class: RoadClass) -> float:
    """Geometric-mean ``G_d(n0)`` of a road class.

    Parameters
    ----------
    road_class
        ISO 8608 class letter ``"A"`` to ``"H"`` (upper case).

    Returns
    -------
    float
        [m^3] ``G_d(n0)`` at ``n0 = 0.1`` cycle/m, e.g. 256e-6 for class C.
    """
    classes = road_classes()
    if road_class not in classes:
        raise ConfigError(f"unknown ISO 8608 road class {road_class!r}; expected one of {sorted(classes)}")
    return classes[road_class][1]


def _check_positive(**values: ArrayLike) -> None:
    for key, value in values.items():
        array = np.asarray(value, dtype=float)
        if not np.all(array > 0.0):
            raise ConfigError(f"expected {key} > 0 everywhere, got minimum {np.min(array)!r}")


def spatial_psd(n_cyc_per_m: ArrayLike, gd_n0: ArrayLike, waviness: ArrayLike = WAVINESS) -> NDArray[np.float64]:
    """Single-track displacement PSD ``G_d(n) = G_d(n0) (n/n0)^-w`` (ISO 8608:2016).

    Parameters
    ----------
    n_cyc_per_m
        [cycle/m] Spatial frequencies, ``> 0``.
    gd_n0
        [m^3] ``G_d(n0)``, e.g. from :func:`class_gd_n0`; broadcast with ``n_cyc_per_m``.
    waviness
        [-] Exponent w; broadcast with ``n_cyc_per_m``.

    Returns
    -------
    ndarray
        [m^3 = m^2/(cycle/m)] One-sided spatial PSD, broadcast shape of the inputs.
    """
    _check_positive(n_cyc_per_m=n_cyc_per_m, gd_n0=gd_n0)
    n = np.asarray(n_cyc_per_m, dtype=float)
    return np.asarray(gd_n0, dtype=float) * (n / N0_CYCLES_PER_M) ** -np.asarray(waviness, float)


def temporal_psd(f_hz: ArrayLike, gd_n0: ArrayLike, speed_mps: ArrayLike, waviness: ArrayLike = WAVINESS) -> NDArray[np.float64]:
    """One-sided temporal displacement PSD seen by a wheel at constant speed.

    ``G(f) = G_d(f/v) / v = G_d(n0) (f/(n0 v))^-w / v``; for ``w = 2``,
    ``G(f) = G_d(n0) n0^2 v / f^2`` (docs/model.md §4.2).

    Parameters
    ----------
    f_hz
        [Hz] Temporal frequencies, ``> 0``.
    gd_n0
        [m^3] ``G_d(n0)``; broadcast elementwise with ``f_hz``.
    speed_mps
        [m/s] Vehicle speed, ``> 0``; broadcast elementwise with ``f_hz``.
    waviness
        [-] Exponent w; broadcast elementwise with ``f_hz``.

    Returns
    -------
    ndarray
        [m^2/Hz] ``G(f)``, broadcast shape of the inputs.
    """
    _check_positive(f_hz=f_hz, speed_mps=speed_mps)
    v = np.asarray(speed_mps, dtype=float)
    return spatial_psd(np.asarray(f_hz, dtype=float) / v, gd_n0, waviness) / v


def temporal_power_law(gd_n0: float, speed_mps: float, waviness: float = WAVINESS) -> tuple[float, float]:
    """``(G_1, w)`` with :func:`temporal_psd` ``G(f) = G_1 f^-w`` [m^2/Hz, f in Hz]:
    ``G_1 = G_d(n0) (n0 v)^w / v`` (the form a compiled loop evaluates per frequency)."""
    _check_positive(speed_mps=speed_mps)
    return float(gd_n0 * (N0_CYCLES_PER_M * speed_mps) ** waviness / speed_mps), float(waviness)


def temporal_variance(
    f1_hz: ArrayLike,
    f2_hz: ArrayLike,
    gd_n0: ArrayLike,
    speed_mps: ArrayLike,
    waviness: ArrayLike = WAVINESS,
) -> NDArray[np.float64]:
    """Displacement variance in ``[f1, f2]``: the integral of :func:`temporal_psd`, analytic.

    ``int_f1^f2 G df = G_d(n0) n0^w v^(w-1) (f2^(1-w) - f1^(1-w)) / (1-w)``
    (``G_d(n0) n0 ln(f2/f1)`` for ``w = 1``).

    Parameters
    ----------
    f1_hz, f2_hz
        [Hz] Band limits, ``0 < f1 < f2``.
    gd_n0
        [m^3] ``G_d(n0)``.
    speed_mps
        [m/s] Vehicle speed, ``> 0``.
    waviness
        [-] Exponent w.

    Returns
    -------
    ndarray
        [m^2] Variance, broadcast shape of the inputs.
    """
    _check_positive(f1_hz=f1_hz, speed_mps=speed_mps, gd_n0=gd_n0)
    f1, f2 = np.asarray(f1_hz, dtype=float), np.asarray(f2_hz, dtype=float)
    if not np.all(f2 > f1):
        raise ConfigError(f"expected f2_hz > f1_hz, got f1_hz={f1_hz!r}, f2_hz={f2_hz!r}")
    v, w = np.asarray(speed_mps, dtype=float), np.asarray(waviness, dtype=float)
    e = 1.0 - w
    unit = np.abs(e) < 1e-12
    e_safe = np.where(unit, 1.0, e)
    integral = np.where(unit, np.log(f2 / f1), (f2**e_safe - f1**e_safe) / e_safe)
    return np.asarray(gd_n0, dtype=float) * N0_CYCLES_PER_M**w * v ** (w - 1.0) * integral


__all__ = [
    "N0_CYCLES_PER_M",
    "WAVINESS",
    "RoadClass",
    "class_gd_n0",
    "road_classes",
    "spatial_psd",
    "temporal_psd",
    "temporal_variance",
]
