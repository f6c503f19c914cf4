"""ISO 2631-1:1997 whole-body vibration: frequency weightings and weighted mean squares.

The analytic weightings of Annex A (band limiting x acceleration-velocity transition x upward
step) are evaluated in closed form, vectorised over any array of frequencies. Two ways of forming
the weighted mean square of an acceleration PSD are offered:

- :func:`weighted_mean_square`, the direct (filter) method ``a_w^2 = int |W(f)|^2 S_a(f) df``
  (docs/model.md §5.3, the default);
- :func:`band_weighted_mean_square`, the one-third-octave band method of the paper (Eq. 25-26),
  ``a_w^2 = sum_i w_i^2 sigma_i^2`` with ``w_i`` the weighting at the band's nominal centre.

References
----------
ISO 2631-1:1997, Mechanical vibration and shock -- Evaluation of human exposure to whole-body
vibration -- Part 1: General requirements. Annex A (frequency weightings), Tables 3 and 4
(tabulated band values), clause 8 (comfort: frequency range, axis multiplying factors).
ISO 8041 (instrumentation) repeats the Annex A parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.polynomial import polynomial as P
from numpy.typing import ArrayLike, NDArray

from hisopt.errors import ConfigError

WeightingName = Literal["Wk", "Wd", "We", "Wc", "Wj", "Wf"]
"""Names of the ISO 2631-1 weightings implemented here."""

Q_BAND_LIMIT = 1.0 / math.sqrt(2.0)
"""Resonance quality Q1 = Q2 of the second-order Butterworth band limits (Annex A, Eq. A.1-A.2)."""


@dataclass(frozen=True)
class WeightingParameters:
    """Parameters of one Annex A weighting (ISO 2631-1:1997 Table A.1).

    Attributes
    ----------
    f1_hz
        [Hz] High-pass band-limit corner.
    f2_hz
        [Hz] Low-pass band-limit corner.
    f3_hz
        [Hz] Acceleration-velocity transition numerator corner (``inf``: stage term omitted).
    f4_hz
        [Hz] Acceleration-velocity transition denominator corner (``inf``: stage omitted).
    q4
        [-] Quality factor of the transition denominator (``nan`` when the stage is omitted).
    f5_hz, f6_hz
        [Hz] Upward-step numerator and denominator corners (``inf``: step omitted).
    q5, q6
        [-] Quality factors of the upward step (``nan`` when omitted).
    k
        [-] Gain factor K.
    """

    f1_hz: float
    f2_hz: float
    f3_hz: float
    f4_hz: float
    q4: float
    f5_hz: float
    q5: float
    f6_hz: float
    q6: float
    k: float = 1.0


_INF, _NAN = math.inf, math.nan

WEIGHTINGS: dict[str, WeightingParameters] = {
    "Wk": WeightingParameters(0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91),
    "Wd": WeightingParameters(0.4, 100.0, 2.0, 2.0, 0.63, _INF, _NAN, _INF, _NAN),
    "We": WeightingParameters(0.4, 100.0, 1.0, 1.0, 0.63, _INF, _NAN, _INF, _NAN),
    "Wc": WeightingParameters(0.4, 100.0, 8.0, 8.0, 0.63, _INF, _NAN, _INF, _NAN),
    "Wj": WeightingParameters(0.4, 100.0, _INF, _INF, _NAN, 3.75, 0.91, 5.32, 0.91),
    "Wf": WeightingParameters(0.08, 0.63, _INF, 0.25, 0.86, 0.0625, 0.80, 0.10, 0.80),
}
"""Annex A weighting parameters, ISO 2631-1:1997 Table A.1 (same values in ISO 8041).

Wk: vertical z (seat, feet, recumbent pelvis), health and comfort. Wd: horizontal x, y.
We: rotational (roll, pitch, yaw). Wc: seat-back x. Wj: recumbent head vertical.
Wf: motion sickness, vertical. Provenance of the values: ``tests/data/README.md``.
"""

AXIS_FACTORS_COMFORT: dict[str, float] = {"x": 1.0, "y": 1.0, "z": 1.0}
"""Comfort multiplying factors k for seated translational axes (ISO 2631-1:1997, clause 8);
``sigma_aw = sqrt(sum_axis k^2 a_w,axis^2)`` (docs/model.md §5.3)."""

_NOMINAL_MANTISSA = (1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0)
"""Nominal one-third-octave centre mantissas (ISO 266 R10 series, as used in Tables 3 and 4)."""

_BAND_TOLERANCE = 0.05
"""[band number] Tolerance when selecting bands by centre, so that nominal limits such as
80 Hz (exact centre 79.43 Hz) select the same bands whether nominal or exact values are given."""


def _params(name: str) -> WeightingParameters:
    try:
        return WEIGHTINGS[name]
    except KeyError:
        raise ConfigError(f"unknown ISO 2631-1 weighting {name!r}; expected one of {sorted(WEIGHTINGS)}") from None


def _inv(f_hz: float) -> float:
    """Reciprocal of a corner frequency, 0 for an omitted (infinite) corner."""
    return 0.0 if math.isinf(f_hz) else 1.0 / f_hz


def weighting_response(f_hz: ArrayLike, name: WeightingName) -> NDArray[np.complex128]:
    """Complex frequency response ``H(j 2 pi f)`` of an Annex A weighting, including K.

    Parameters
    ----------
    f_hz
        [Hz] Frequencies, any shape, ``>= 0``.
    name
        Weighting name, one of :data:`WeightingName`.

    Returns
    -------
    ndarray of complex, same shape as ``f_hz``
        [-] ``K Hh Hl Ht Hs``; its modulus is the weighting factor of Tables 3 and 4.

    References
    ----------
    ISO 2631-1:1997 Annex A, Eq. (A.1) to (A.4) and Table A.1.
    """
    p = _params(name)
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)
    w1, w2 = 2 * np.pi * p.f1_hz, 2 * np.pi * p.f2_hz
    r3, r4 = _inv(2 * np.pi * p.f3_hz), _inv(2 * np.pi * p.f4_hz)
    r5, r6 = _inv(2 * np.pi * p.f5_hz), _inv(2 * np.pi * p.f6_hz)
    h = s**2 / (s**2 + math.sqrt(2.0) * w1 * s + w1**2)  # high-pass, written to allow f = 0
    h = h * w2**2 / (s**2 + math.sqrt(2.0) * w2 * s + w2**2)
    if r4:
        h = h * (1 + s * r3) / (1 + s * r4 / p.q4 + (s * r4) ** 2)
    if r5:
        h = h * (1 + s * r5 / p.q5 + (s * r5) ** 2) / (1 + s * r6 / p.q6 + (s * r6) ** 2)
        h = h * (r6 / r5) ** 2
    return p.k * h


def _quadratic_gain2(inv_f_hz: float, q: float) -> NDArray[np.float64]:
    """Coefficients in ``x = f^2`` of ``|1 + s/(Q w) + (s/w)^2|^2`` (ascending powers)."""
    if inv_f_hz == 0.0:
        return np.array([1.0])
    r2 = inv_f_hz**2
    return np.array([1.0, r2 / q**2 - 2 * r2, r2**2])


def _gain2_polynomials(p: WeightingParameters) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Numerator and denominator coefficients of ``|W|^2`` as polynomials in ``x = f^2`` [Hz^2]."""
    num = np.array([0.0, 0.0, 1.0])  # |Hh|^2 = x^2 / (x^2 + f1^4)
    den = np.array([p.f1_hz**4, 0.0, 1.0])
    den = P.polymul(den, [1.0, 0.0, p.f2_hz**-4])  # |Hl|^2 = 1 / (1 + x^2 / f2^4)
    if not math.isinf(p.f4_hz):
        num = P.polymul(num, [1.0, _inv(p.f3_hz) ** 2])
        den = P.polymul(den, _quadratic_gain2(_inv(p.f4_hz), p.q4))
    if not math.isinf(p.f5_hz):
        num = P.polymul(num, _quadratic_gain2(_inv(p.f5_hz), p.q5) * (p.f5_hz / p.f6_hz) ** 4)
        den = P.polymul(den, _quadratic_gain2(_inv(p.f6_hz), p.q6))
    return p.k**2 * num, den


_GAIN2_POLYNOMIALS = {name: _gain2_polynomials(p) for name, p in WEIGHTINGS.items()}
"""Precomputed ``(num, den)`` of ``|W|^2`` in ``x = f^2`` for :func:`weighting_gain_squared`."""


def weighting_gain_polynomials(name: WeightingName) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(num, den)``: ``|W|^2 = num(f^2) / den(f^2)``, ascending coefficients (what
    :func:`weighting_gain_squared` evaluates, for loops that evaluate it themselves)."""
    _params(name)
    return _GAIN2_POLYNOMIALS[name]


def weighting_gain_squared(f_hz: ArrayLike, name: WeightingName) -> NDArray[np.float64]:
    """Squared weighting factor ``|W(f)|^2``, real arithmetic only (fast path for hot loops).

    Equal to ``abs(weighting_response(f_hz, name))**2`` to rounding; evaluated as a precomputed
    rational function of ``f^2``.

    Parameters
    ----------
    f_hz
        [Hz] Frequencies, any shape, ``>= 0``.
    name
        Weighting name, one of :data:`WeightingName`.

    Returns
    -------
    ndarray, same shape as ``f_hz``
        [-] ``|W(f)|^2``.
    """
    _params(name)
    num, den = _GAIN2_POLYNOMIALS[name]
    x = np.square(np.asarray(f_hz, dtype=float))
    return _horner(x, num) / _horner(x, den)


def _horner(x: NDArray[np.float64], coefficients: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_k c_k x^k`` by Horner's rule, in place on one array (hot loops call this)."""
    out = np.full(x.shape, coefficients[-1])
    for c in coefficients[-2::-1]:
        out *= x
        out += c
    return out


class ThirdOctaveBands(NamedTuple):
    """One-third-octave bands (base-10 system, IEC 61260), each field of shape ``(n_bands,)``."""

    band_n: NDArray[np.int64]
    """[-] Band number n, exact centre ``10^(n/10)`` Hz."""
    nominal_hz: NDArray[np.float64]
    """[Hz] Nominal centre (ISO 266 R10 series), as labelled in ISO 2631-1 Tables 3 and 4."""
    exact_hz: NDArray[np.float64]
    """[Hz] Exact centre ``10^(n/10)``."""
    lower_hz: NDArray[np.float64]
    """[Hz] Lower edge ``exact * 10^(-1/20)``."""
    upper_hz: NDArray[np.float64]
    """[Hz] Upper edge ``exact * 10^(1/20)``."""


def third_octave_bands(f_lo_hz: float = 0.5, f_hi_hz: float = 80.0) -> ThirdOctaveBands:
    """One-third-octave bands whose centre lies in ``[f_lo_hz, f_hi_hz]``.

    Parameters
    ----------
    f_lo_hz
        [Hz] Lowest band centre (nominal or exact), ``> 0``.
    f_hi_hz
        [Hz] Highest band centre (nominal or exact), ``>= f_lo_hz``.

    Returns
    -------
    ThirdOctaveBands
        Band numbers, nominal and exact centres and edges; the default range is the
        0.5-80 Hz comfort band of ISO 2631-1 (clause 8): 23 bands.
    """
    if not (0.0 < f_lo_hz <= f_hi_hz and math.isfinite(f_hi_hz)):
        raise ConfigError(f"expected 0 < f_lo_hz <= f_hi_hz < inf, got f_lo_hz={f_lo_hz}, f_hi_hz={f_hi_hz}")
    n_lo = math.ceil(10.0 * math.log10(f_lo_hz) - _BAND_TOLERANCE)
    n_hi = math.floor(10.0 * math.log10(f_hi_hz) + _BAND_TOLERANCE)
    n = np.arange(n_lo, n_hi + 1)
    nominal = np.array([float(f"{_NOMINAL_MANTISSA[k % 10]}e{k // 10}") for k in n.tolist()])
    exact = 10.0 ** (n / 10.0)
    return ThirdOctaveBands(n, nominal, exact, exact * 10.0**-0.05, exact * 10.0**0.05)


def _band_index(f_hz: NDArray[np.float64], bands: ThirdOctaveBands) -> NDArray[np.int64]:
    """Index into ``bands`` of the band holding each frequency, -1 outside all bands."""
    positive = f_hz > 0.0
    n = np.floor(10.0 * np.log10(np.where(positive, f_hz, 1.0)) + 0.5).astype(np.int64)
    idx = n - int(bands.band_n[0])
    return np.where(positive & (idx >= 0) & (idx < bands.band_n.size), idx, -1)


def band_mean_squares(
    f_hz: ArrayLike,
    quad_weights_hz: ArrayLike,
    psd: ArrayLike,
    f_lo_hz: float = 0.5,
    f_hi_hz: float = 80.0,
) -> NDArray[np.float64]:
    """Unweighted mean square ``sigma_i^2`` in each one-third-octave band (paper Eq. 25).

    Each quadrature node contributes ``psd * weight`` to the band holding it (edges
    ``10^((n -+ 1/2)/10)`` Hz); node weights are not split at band edges, so the node spacing
    should be fine compared with the band width (23 % of the centre).

    Parameters
    ----------
    f_hz
        [Hz] Quadrature nodes, shape ``(..., n_nodes)``; may differ between batch rows.
    quad_weights_hz
        [Hz] Quadrature weights, broadcastable with ``f_hz``.
    psd
        [u^2/Hz] One-sided PSD at the nodes, broadcastable with ``f_hz``.
    f_lo_hz, f_hi_hz
        [Hz] Range of band centres, see :func:`third_octave_bands`.

    Returns
    -------
    ndarray, shape ``(..., n_bands)``
        [u^2] Band mean squares, bands as in ``third_octave_bands(f_lo_hz, f_hi_hz)``.
    """
    bands = third_octave_bands(f_lo_hz, f_hi_hz)
    f = np.asarray(f_hz, dtype=float)
    power = np.asarray(psd, dtype=float) * np.asarray(quad_weights_hz, dtype=float)
    f, power = np.broadcast_arrays(f, power)
    one_hot = _band_index(f, bands)[..., None, :] == np.arange(bands.band_n.size)[:, None]
    return np.einsum("...bk,...k->...b", one_hot, power)


def band_weighted_mean_square(
    f_hz: ArrayLike,
    quad_weights_hz: ArrayLike,
    psd: ArrayLike,
    name: WeightingName,
    f_lo_hz: float = 0.5,
    f_hi_hz: float = 80.0,
) -> NDArray[np.float64]:
    """Weighted mean square by the one-third-octave band method (paper Eq. 25-26).

    ``a_w^2 = sum_i w_i^2 sigma_i^2``, with ``sigma_i^2`` the PSD integrated over band i
    (see :func:`band_mean_squares`) and ``w_i = |W|`` at the band's nominal centre.

    Parameters
    ----------
    f_hz
        [Hz] Quadrature nodes, shape ``(..., n_nodes)``; may differ between batch rows.
    quad_weights_hz
        [Hz] Quadrature weights, broadcastable with ``f_hz``.
    psd
        [(m/s^2)^2/Hz] One-sided acceleration PSD at the nodes, broadcastable with ``f_hz``.
    name
        Weighting name, one of :data:`WeightingName`.
    f_lo_hz, f_hi_hz
        [Hz] Range of band centres, default the 0.5-80 Hz band of ISO 2631-1 (clause 8).

    Returns
    -------
    ndarray, shape ``(...,)``
        [(m/s^2)^2] Weighted mean square ``a_w^2``.

    References
    ----------
    ISO 2631-1:1997 clause 6 (summation of one-third-octave band values) and Tables 3
    and 4; paper Eq. (25)-(26).
    """
    power = np.asarray(psd, dtype=float) * np.asarray(quad_weights_hz, dtype=float)
    return np.sum(band_gain_squared(f_hz, name, f_lo_hz, f_hi_hz) * power, axis=-1)


def band_gain_squared(f_hz: ArrayLike, name: WeightingName, f_lo_hz: float = 0.5, f_hi_hz: float = 80.0) -> NDArray[np.float64]:
    """Piecewise-constant ``w_i^2`` of the band method at each frequency (0 outside the bands).

    Parameters
    ----------
    f_hz
        [Hz] Frequencies, any shape.
    name
        Weighting name, one of :data:`WeightingName`.
    f_lo_hz, f_hi_hz
        [Hz] Range of band centres, see :func:`third_octave_bands`.
    """
    bands = third_octave_bands(f_lo_hz, f_hi_hz)
    w2 = weighting_gain_squared(bands.nominal_hz, name)
    idx = _band_index(np.asarray(f_hz, dtype=float), bands)
    return np.where(idx >= 0, w2[np.maximum(idx, 0)], 0.0)


def weighted_mean_square(f_hz: ArrayLike, quad_weights_hz: ArrayLike, psd: ArrayLike, name: WeightingName) -> NDArray[np.float64]:
    """Weighted mean square by the direct (filter) method, ``sum |W(f)|^2 psd w``.

    The frequency range is that of the nodes; docs/model.md §5.3 integrates over 0.5-80 Hz.

    Parameters
    ----------
    f_hz
        [Hz] Quadrature nodes, shape ``(..., n_nodes)``.
    quad_weights_hz
        [Hz] Quadrature weights, broadcastable with ``f_hz``.
    psd
        [(m/s^2)^2/Hz] One-sided acceleration PSD at the nodes, broadcastable with ``f_hz``.
    name
        Weighting name, one of :data:`WeightingName`.

    Returns
    -------
    ndarray, shape ``(...,)``
        [(m/s^2)^2] ``a_w^2 = int |W(f)|^2 S_a(f) df``.

    References
    ----------
    ISO 2631-1:1997 clause 6 (weighted r.m.s. acceleration) with the Annex A weightings.
    """
    w2 = weighting_gain_squared(f_hz, name)
    return np.sum(w2 * np.asarray(psd, dtype=float) * np.asarray(quad_weights_hz, dtype=float), -1)


__all__ = [
    "AXIS_FACTORS_COMFORT",
    "WEIGHTINGS",
    "ThirdOctaveBands",
    "WeightingName",
    "WeightingParameters",
    "band_mean_squares",
    "band_weighted_mean_square",
    "third_octave_bands",
    "weighted_mean_square",
    "weighting_gain_squared",
    "weighting_response",
]


def weighting_poles_hz(name: WeightingName) -> NDArray[np.complex128]:
    """[Hz] Singularities of ``|W(f)|^2`` in the complex frequency plane (upper half plane
    and the real axis), the roots of its denominator in ``f``: where a quadrature of a
    weighted spectrum must keep its distance (:mod:`hisopt.evaluation.quadrature`)."""
    _params(name)
    x = P.polyroots(_GAIN2_DEN[name])
    f = np.sqrt(x.astype(complex))
    return np.concatenate([f, -f])


_GAIN2_DEN = {name: den for name, (_, den) in _GAIN2_POLYNOMIALS.items()}
