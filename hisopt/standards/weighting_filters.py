"""ISO 2631-1:1997 weightings in the time domain: the realisable filters on sampled records.

The Annex A weighting ``W(s) = K Hh Hl Ht Hs`` is a causal rational filter. Here it is built
in zero-pole-gain form, each stage in closed form from the same :data:`WEIGHTINGS` parameters
as :func:`~hisopt.standards.iso_2631_1_1997.weighting_response`, and applied to uniformly
sampled records (docs/model.md §22.1):

- the record is read as its not-a-knot cubic spline (the continuous signal it samples; its
  slopes at the samples from one tridiagonal solve for all records);
- the continuous filter, started at rest at the first sample, is integrated exactly on that
  piecewise cubic, through its partial fractions ``W(s) = sum_i r_i / (s - p_i) + D``: each
  first-order term advances over one step as ``z <- exp(p T) z + sum_m c_m I_m(p)`` with the
  interval's cubic coefficients ``c_m`` and ``I_m(p) = int_0^T exp(p (T - tau)) (tau/T)^m dtau``
  (one 5 x 5 matrix exponential per pole). Written on the samples and slopes, a conjugate
  pair of such terms is a real second-order IIR section on each, run by
  :func:`scipy.signal.lfilter` in C over any number of records at once.

The only error is the spline's: for a sinusoid of angular frequency ``w`` (infinite record)
the spline's amplitude is ``S(w) = sinc^4(w T/2) 3 / (2 + cos w T)`` times the sinusoid's,
``1 - S`` = 0.49 % at 5 samples per period and ``(w T)^4 / 720`` well inside the band
(2e-6 at 12 Hz with ``T`` = 2.5 ms); :func:`sampled_response` is the exact response of the
whole discretisation, the spline's images included.

References
----------
ISO 2631-1:1997, Annex A (Eq. A.1-A.4, Table A.1): the weightings as realisable filters.
ISO 8041 (instrumentation) repeats the Annex A parameters.
M. Unser, "Splines: a perfect fit for signal and image processing", IEEE Signal Processing
Magazine 16(6), 1999: the cardinal cubic spline's spectrum ``sinc^4 3/(2 + cos)``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import expm, solve_banded
from scipy.signal import lfilter

from hisopt.errors import ConfigError
from hisopt.standards.iso_2631_1_1997 import WEIGHTINGS, WeightingName, WeightingParameters, weighting_response

SETTLING_DECAY = 1e-6
"""[-] Default decay of the slowest pole's transient, ``exp(-sigma t)``, before a weighted
record is trusted (:func:`settling_time_s`)."""

MIN_SAMPLES = 4
"""Fewest samples of a record (the not-a-knot spline needs four)."""


class WeightingZpk(NamedTuple):
    """Zero-pole-gain form ``W(s) = gain prod(s - z) / prod(s - p)`` of a weighting."""

    zeros_rad_s: NDArray[np.complex128]
    """[rad/s] Zeros (conjugate pairs adjacent)."""
    poles_rad_s: NDArray[np.complex128]
    """[rad/s] Poles, all in the left half plane (conjugate pairs adjacent)."""
    gain: float
    """[rad/s^(n_poles - n_zeros)] Gain, ``K`` included."""


class PartialFractions(NamedTuple):
    """``W(s) = D + sum_i r_i / (s - p_i)``, listed by the poles with ``Im p >= 0``.

    A complex pole stands for itself and its conjugate, whose residue is ``conj(r)``
    (``weight`` 2: in the time domain the pair adds ``2 Re(r z)``, ``z`` the pole's state); a
    real pole stands for itself (``weight`` 1).
    """

    residues: NDArray[np.complex128]
    """[rad/s] Residues ``r_i`` at :attr:`poles_rad_s`."""
    poles_rad_s: NDArray[np.complex128]
    """[rad/s] Poles with ``Im p >= 0``."""
    weights: NDArray[np.float64]
    """[-] 2 for a complex pole (its conjugate's term folded in), 1 for a real pole."""
    direct: float
    """[-] ``D``, the limit of ``W(s)`` as ``s -> inf`` (0: every weighting is strictly proper)."""


def _parameters(name: str) -> WeightingParameters:
    try:
        return WEIGHTINGS[name]
    except KeyError:
        raise ConfigError(f"unknown ISO 2631-1 weighting {name!r}; expected one of {sorted(WEIGHTINGS)}", key="name") from None


def _quadratic_roots(w_rad_s: float, q: float) -> NDArray[np.complex128]:
    """Roots of ``s^2 + (w/Q) s + w^2`` in closed form, the one with ``Im >= 0`` first.

    Complex for ``Q > 1/2`` (every Annex A stage): ``w (-1/(2Q) +- j sqrt(1 - 1/(4Q^2)))``;
    real otherwise, the smaller one from the product ``w^2`` (no cancellation).
    """
    half = 1.0 / (2.0 * q)
    if half < 1.0:
        root = w_rad_s * complex(-half, math.sqrt(1.0 - half * half))
        return np.array([root, root.conjugate()])
    big = -w_rad_s * (half + math.sqrt(half * half - 1.0))
    return np.array([big, w_rad_s**2 / big], dtype=complex)


def weighting_zpk(name: WeightingName) -> WeightingZpk:
    """Zeros, poles and gain of an Annex A weighting, each stage in closed form.

    From :data:`~hisopt.standards.iso_2631_1_1997.WEIGHTINGS`, the same parameters as
    :func:`~hisopt.standards.iso_2631_1_1997.weighting_response` (``w_i = 2 pi f_i``):

    - high-pass ``Hh = s^2 / (s^2 + sqrt2 w1 s + w1^2)``: zeros 0, 0; poles
      ``w1 (-1 +- j) / sqrt2`` (Butterworth, ``Q = 1/sqrt2``);
    - low-pass ``Hl = w2^2 / (s^2 + sqrt2 w2 s + w2^2)``: poles ``w2 (-1 +- j) / sqrt2``;
    - transition ``Ht = (1 + s/w3) / (1 + s/(Q4 w4) + (s/w4)^2)``: zero ``-w3`` (no zero when
      ``f3`` is infinite), poles the roots of ``s^2 + (w4/Q4) s + w4^2``, gain ``w4^2 / w3``;
      omitted when ``f4`` is infinite;
    - upward step ``Hs = (w5/w6)^2 (1 + s/(Q5 w5) + (s/w5)^2) / (1 + s/(Q6 w6) + (s/w6)^2)``:
      zeros the roots of ``s^2 + (w5/Q5) s + w5^2``, poles those of ``s^2 + (w6/Q6) s + w6^2``,
      gain 1; omitted when ``f5`` is infinite.

    Parameters
    ----------
    name
        Weighting name, one of :data:`~hisopt.standards.iso_2631_1_1997.WeightingName`.

    Returns
    -------
    WeightingZpk
        ``(zeros_rad_s, poles_rad_s, gain)``.
    """
    p = _parameters(name)
    w1, w2 = 2 * math.pi * p.f1_hz, 2 * math.pi * p.f2_hz
    zeros = [np.zeros(2, dtype=complex)]
    poles = [_quadratic_roots(w1, 1 / math.sqrt(2)), _quadratic_roots(w2, 1 / math.sqrt(2))]
    gain = p.k * w2**2
    if math.isfinite(p.f4_hz):
        w4 = 2 * math.pi * p.f4_hz
        poles.append(_quadratic_roots(w4, p.q4))
        gain *= w4**2
        if math.isfinite(p.f3_hz):
            w3 = 2 * math.pi * p.f3_hz
            zeros.append(np.array([-w3], dtype=complex))
            gain /= w3
    if math.isfinite(p.f5_hz):
        zeros.append(_quadratic_roots(2 * math.pi * p.f5_hz, p.q5))
        poles.append(_quadratic_roots(2 * math.pi * p.f6_hz, p.q6))
    return WeightingZpk(np.concatenate(zeros), np.concatenate(poles), gain)


def zpk_response(f_hz: ArrayLike, zpk: WeightingZpk) -> NDArray[np.complex128]:
    """``gain prod(s - z) / prod(s - p)`` at ``s = j 2 pi f``, any shape of ``f_hz`` [Hz]."""
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)[..., None]
    return zpk.gain * np.prod(s - zpk.zeros_rad_s, axis=-1) / np.prod(s - zpk.poles_rad_s, axis=-1)


def weighting_partial_fractions(name: WeightingName) -> PartialFractions:
    """Partial fractions of an Annex A weighting from its closed-form zeros and poles.

    ``r_i = gain prod_j (p_i - z_j) / prod_{l != i} (p_i - p_l)`` (simple poles: the stages'
    corners all differ), for the poles with ``Im p >= 0``; well conditioned, as no polynomial
    is expanded or rooted.

    Parameters
    ----------
    name
        Weighting name.

    Returns
    -------
    PartialFractions
        Residues, poles, their weights (2 for a conjugate pair, 1 for a real pole) and ``D``.
    """
    zpk = weighting_zpk(name)
    z, p = zpk.zeros_rad_s, zpk.poles_rad_s
    upper = np.flatnonzero(p.imag >= 0.0)
    residues = np.array([zpk.gain * np.prod(p[i] - z) / np.prod(np.delete(p[i] - p, i)) for i in upper])
    weights = np.where(p[upper].imag > 0.0, 2.0, 1.0)
    direct = zpk.gain if z.size == p.size else 0.0
    return PartialFractions(residues, p[upper], weights, float(direct))


def settling_time_s(name: WeightingName, decay: float = SETTLING_DECAY) -> float:
    """[s] Time for the slowest pole's transient to decay to ``decay``: ``ln(1/decay) / sigma``.

    ``sigma = min_i(-Re p_i)`` is the slowest pole's decay rate; for every weighting but Wf it
    is the 0.4 Hz band limit's, ``2 pi 0.4 / sqrt2 = 1.78 /s``: 7.8 s at the default 1e-6
    (Wf: the 0.08 Hz band limit, 0.355 /s, 38.9 s).

    Parameters
    ----------
    name
        Weighting name.
    decay
        [-] Remaining share of the transient's envelope, in ``(0, 1)``.
    """
    if not 0.0 < decay < 1.0:
        raise ConfigError(f"expected 0 < decay < 1, got {decay!r}", key="decay")
    sigma = float(np.min(-weighting_zpk(name).poles_rad_s.real))
    return math.log(1.0 / decay) / sigma


def spline_gain(f_hz: ArrayLike, dt_s: float) -> NDArray[np.float64]:
    """[-] ``S = sinc^4(w T/2) 3 / (2 + cos w T)``: the cubic spline's gain at ``f`` (``T = dt``).

    The spectrum of the cardinal cubic spline interpolating samples every ``T`` (infinite
    record), over ``T``; ``1 - S = (w T)^4 / 720 + O((w T)^6)``.
    """
    x = np.asarray(f_hz, dtype=float) * dt_s
    return np.sinc(x) ** 4 * 3.0 / (2.0 + np.cos(2 * np.pi * x))


def sampled_response(f_hz: ArrayLike, dt_s: float, name: WeightingName, n_images: int = 64) -> NDArray[np.complex128]:
    """Exact response of :func:`weighted_signal` to a sampled sinusoid (infinite record).

    ``G(f) = sum_k W(f + k/T) S(f + k/T)``, ``|k| <= n_images``: the spline of a sampled
    sinusoid holds it with gain :func:`spline_gain` ``S`` plus images at ``f + k/T``, which the
    filter weights and the sampling folds back onto ``f``. The terms fall like ``k^-7`` (``S``
    like ``k^-4``, ``W`` like ``k^-3`` or faster), so 64 images leave under 1e-13.
    ``G / W - 1`` is the discretisation's whole error at ``f``.

    Parameters
    ----------
    f_hz
        [Hz] Frequencies, any shape, below the Nyquist frequency ``1/(2 dt)``.
    dt_s
        [s] Sampling interval.
    name
        Weighting name.
    n_images
        Images each side of the fundamental.

    Returns
    -------
    ndarray of complex, same shape as ``f_hz``
        [-] Gain and phase of the sampled output against the sampled input at ``f``.
    """
    f = np.asarray(f_hz, dtype=float)[..., None] + np.arange(-n_images, n_images + 1) / dt_s
    return np.sum(weighting_response(f, name) * spline_gain(f, dt_s), axis=-1)


def _step_integrals(pole_rad_s: complex, dt_s: float) -> NDArray[np.complex128]:
    """``[exp(p T), I_0, I_1, I_2, I_3]``, ``I_m = int_0^T exp(p (T - tau)) (tau/T)^m dtau``.

    From one matrix exponential: with ``A`` = ``p T`` in its corner feeding a chain of four
    integrators, ``expm(A)[0, 1 + m] = int_0^1 exp(p T (1 - u)) u^m / m! du`` (no cancellation
    for small ``p T``, unlike the closed forms by parts).
    """
    a = np.diag(np.ones(4, dtype=complex), 1)
    a[0, 0] = pole_rad_s * dt_s
    e = expm(a)[0]
    return np.concatenate([[e[0]], dt_s * e[1:] * np.array([1.0, 1.0, 2.0, 6.0])])


def _checked_record(signal: ArrayLike, dt_s: float, axis: int) -> NDArray[np.float64]:
    """The records as a C-ordered float array with time on the last axis; one line naming
    what is wrong."""
    if not (math.isfinite(dt_s) and dt_s > 0.0):
        raise ConfigError(f"expected a sampling interval dt_s > 0, got {dt_s!r}", key="dt_s")
    x = np.asarray(signal, dtype=float)
    if not -x.ndim <= axis < x.ndim:
        raise ConfigError(f"axis {axis} is out of range for a record of {x.ndim} dimensions", key="axis")
    x = np.ascontiguousarray(np.moveaxis(x, axis, -1))
    if x.shape[-1] < MIN_SAMPLES:
        raise ConfigError(f"expected at least {MIN_SAMPLES} samples along the time axis, got {x.shape[-1]}", key="signal")
    if not np.all(np.isfinite(x)):
        raise ConfigError("expected finite samples, got NaN or inf", key="signal")
    return x


def _spline_slopes(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Slopes per step (``T du/dt``) at the samples of the not-a-knot cubic spline through
    ``x`` (time on the last axis, unit spacing): one tridiagonal solve for every record.

    Inside, ``s_{i-1} + 4 s_i + s_{i+1} = 3 (x_{i+1} - x_{i-1})`` (continuous second
    derivative); at the ends the third derivative is continuous across the second and the
    last-but-one sample (not-a-knot): ``s_0 + 2 s_1 = (5 m_0 + m_1) / 2`` and
    ``2 s_{n-2} + s_{n-1} = (m_{n-3} + 5 m_{n-2}) / 2``, ``m_i = x_{i+1} - x_i``; the same
    spline as ``scipy.interpolate.CubicSpline(bc_type="not-a-knot")``.
    """
    n = x.shape[-1]
    m = np.diff(x, axis=-1)
    rhs = np.empty(x.shape)
    rhs[..., 0] = (5.0 * m[..., 0] + m[..., 1]) / 2.0
    np.add(m[..., :-1], m[..., 1:], out=rhs[..., 1:-1])
    rhs[..., 1:-1] *= 3.0
    rhs[..., -1] = (m[..., -2] + 5.0 * m[..., -1]) / 2.0
    bands = np.ones((3, n))  # upper diagonal, diagonal, lower diagonal
    bands[1, 1:-1] = 4.0
    bands[0, 0] = bands[2, -1] = 0.0
    bands[0, 1] = bands[2, -2] = 2.0
    columns = rhs.reshape(-1, n).T  # one column per record, Fortran-ordered: no copy
    return solve_banded((1, 1), bands, columns, overwrite_b=True, check_finite=False).T.reshape(x.shape)


def _pole_sections(
    residue: complex, pole_rad_s: complex, weight: float, dt_s: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], complex, complex]:
    """One pole's exact step on the spline as real IIR sections on the samples and slopes.

    On step n the spline is the cubic Hermite ``x_n h00 + x_{n+1} h01 + s_n h10 + s_{n+1} h11``
    of ``u = tau/T``, so with ``I_m`` of :func:`_step_integrals` the state ``z`` of
    ``r / (s - p)`` advances as ``z_{n+1} = a z_n + alpha x_n + beta x_{n+1} + gamma s_n +
    delta s_{n+1}``, ``a = exp(p T)``, ``alpha = I_0 - 3 I_2 + 2 I_3``, ``beta = 3 I_2 - 2 I_3``,
    ``gamma = I_1 - 2 I_2 + I_3``, ``delta = I_3 - I_2``. A complex pole and its conjugate
    together give ``2 Re(r z)``, a real second-order section
    ``(b_0 + b_1 q + b_2 q^2) / (1 - 2 Re(a) q + |a|^2 q^2)`` (``q`` the delay) with
    ``b = 2 Re(r [beta, alpha - beta conj(a), -alpha conj(a)])`` on the samples and the same
    with ``delta, gamma`` on the slopes.

    Returns
    -------
    tuple
        ``(den, num_samples, num_slopes, beta, delta)``: the sections' coefficients, and the
        drive's weights on ``x_0, s_0`` (the start, which :func:`weighted_signal` removes).
    """
    step = _step_integrals(pole_rad_s, dt_s)
    a, (i0, i1, i2, i3) = step[0], step[1:]
    alpha, beta, gamma, delta = i0 - 3 * i2 + 2 * i3, 3 * i2 - 2 * i3, i1 - 2 * i2 + i3, i3 - i2
    if weight == 2.0:
        den = np.array([1.0, -2.0 * a.real, abs(a) ** 2])
        on_samples = 2.0 * (residue * np.array([beta, alpha - beta * a.conjugate(), -alpha * a.conjugate()])).real
        on_slopes = 2.0 * (residue * np.array([delta, gamma - delta * a.conjugate(), -gamma * a.conjugate()])).real
    else:  # a real pole: a first-order section
        den = np.array([1.0, -a.real])
        on_samples, on_slopes = (residue * np.array([beta, alpha])).real, (residue * np.array([delta, gamma])).real
    return den, on_samples, on_slopes, complex(beta), complex(delta)


def weighted_signal(signal: ArrayLike, dt_s: float, name: WeightingName, axis: int = -1) -> NDArray[np.float64]:
    """The ISO 2631-1 weighting applied to uniformly sampled records, as the realisable filter.

    The causal filter :func:`weighting_zpk`, at rest at the first sample, integrated exactly
    on the record's not-a-knot cubic spline (module docstring; docs/model.md §22.1). Why the
    spline: its error ``1 - S`` (:func:`spline_gain`) is 4th order in ``w dt``, 0.49 % at 5
    samples per period (80 Hz at 2.5 ms) and 2e-6 at 12 Hz; the first-order hold
    (``scipy.signal.lsim``) errs by ``1 - sinc^2``, 12.5 % at 80 Hz, and the bilinear
    transform warps frequency by ``(w dt)^2 / 12``. The spline is not causal: a sample leaks
    into the output ``k`` steps before it in proportion to ``(2 - sqrt3)^k`` (0.27^k), below
    rounding 25 steps ahead; the filter itself is.

    Parameters
    ----------
    signal
        [u] Records, any shape, time along ``axis``, at least four samples each.
    dt_s
        [s] Sampling interval, ``> 0``.
    name
        Weighting name, one of :data:`~hisopt.standards.iso_2631_1_1997.WeightingName`.
    axis
        The time axis.

    Returns
    -------
    ndarray, shape of ``signal``
        [u] The weighted records at the same instants; 0 at the first sample.
    """
    x = _checked_record(signal, dt_s, axis)
    slopes = _spline_slopes(x)
    fractions = weighting_partial_fractions(name)
    out = fractions.direct * x
    k = np.arange(x.shape[-1])
    for residue, pole, weight in zip(fractions.residues, fractions.poles_rad_s, fractions.weights, strict=True):
        den, on_samples, on_slopes, beta, delta = _pole_sections(complex(residue), complex(pole), float(weight), dt_s)
        out += lfilter(on_samples, den, x)
        out += lfilter(on_slopes, den, slopes)
        # lfilter starts with the state z_0 = beta x_0 + delta s_0 (the first step's drive with
        # nothing before it); at rest z_0 = 0: remove its free response r z_0 a^k, kept where
        # it is above 1e-17 of its start
        start = residue * (beta * x[..., 0] + delta * slopes[..., 0])
        n_free = int(min(k.size, math.ceil(math.log(1e-17) / (pole.real * dt_s))))
        out[..., :n_free] -= weight * (start[..., None] * np.exp(pole * dt_s * k[:n_free])).real
    out[..., 0] = fractions.direct * x[..., 0]  # at rest: what the sums above leave is rounding
    return np.moveaxis(out, -1, axis)


def weighted_rms(
    signal: ArrayLike,
    dt_s: float,
    name: WeightingName,
    settle_s: float | None = None,
    axis: int = -1,
) -> NDArray[np.float64]:
    """RMS of the weighted records after a settling time, one value per record.

    Parameters
    ----------
    signal
        [u] Records, any shape, time along ``axis``.
    dt_s
        [s] Sampling interval, ``> 0``.
    name
        Weighting name.
    settle_s
        [s] Time dropped at the start, where the filter's start from rest still shows; default
        :func:`settling_time_s` (the slowest pole decayed to 1e-6: 7.8 s, Wf 38.9 s).
    axis
        The time axis.

    Returns
    -------
    ndarray, shape of ``signal`` without ``axis``
        [u] ``sqrt(mean(y_n^2))`` over the samples at ``t >= settle_s``.
    """
    settle = settling_time_s(name) if settle_s is None else settle_s
    if not (math.isfinite(settle) and settle >= 0.0):
        raise ConfigError(f"expected a settling time settle_s >= 0, got {settle_s!r}", key="settle_s")
    y = np.moveaxis(weighted_signal(signal, dt_s, name, axis), axis, 0)
    first = math.ceil(settle / dt_s - 1e-9)
    if first >= y.shape[0]:
        raise ConfigError(f"the record ({y.shape[0] * dt_s:.3g} s) is no longer than the settling time ({settle:.3g} s) of {name}", key="signal")
    return np.sqrt(np.mean(np.square(y[first:]), axis=0))


__all__ = [
    "MIN_SAMPLES",
    "SETTLING_DECAY",
    "PartialFractions",
    "WeightingZpk",
    "sampled_response",
    "settling_time_s",
    "spline_gain",
    "weighted_rms",
    "weighted_signal",
    "weighting_partial_fractions",
    "weighting_zpk",
    "zpk_response",
]
