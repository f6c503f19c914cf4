"""The hisopt helpers ``benchmarks/legacy_evaluate.py`` runs, frozen as they were at commit abd5bcd.

``legacy_evaluate.py`` used to import these from hisopt, so the "before" it measures moved
with every change to them. Here they are copied, numpy path only, from

- ``hisopt/linalg.py`` (batched products, complex pairs, the one-BLAS-thread rule),
- ``hisopt/metrics.py`` (the quantity registry, frequency-domain quantities only),
- ``hisopt/coupled/response.py`` and ``hisopt/vehicle/full_car.py`` (the outputs and the
  stroke map they use),
- ``hisopt/evaluation/psd.py`` (comfort gain, the metric dispatch, roll gradient),
- ``hisopt/standards/iso_2631_1_1997.py`` (weightings and one-third-octave bands),
- ``hisopt/standards/iso_8608_2016.py`` (class roughness and the temporal road PSD; the class
  table's geometric means copied from ``hisopt/data/iso8608_classes.csv``),
- ``hisopt/road/spectra.py`` (isotropic left-right coherence).

The arithmetic is unchanged; only what the benchmark never reaches is left out: the CasADi
branches, the transient quantities, and hisopt's error classes (a bad name raises
``ValueError``; hisopt's ``ConfigError`` is one). Not part of the package.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.polynomial import polynomial as P

G_MPS2 = 9.81  # hisopt/constants.py

# --- hisopt/linalg.py ------------------------------------------------------------------------

_CONTROLLER: dict[str, Any] = {}


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the enclosed numpy linear algebra on one BLAS thread."""
    if "controller" not in _CONTROLLER:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER["controller"] = ThreadpoolController()
    with _CONTROLLER["controller"].limit(limits=1, user_api="blas"):
        yield


def bmm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix product ``a @ b`` over the last two axes, broadcasting leading axes."""
    return np.matmul(a, b)


def split(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real and imaginary parts as contiguous real arrays."""
    z = np.asarray(z)
    return np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag)


def cmul(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Complex product of (real, imag) pairs in real arithmetic."""
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def cbmm(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Complex batched matrix product of (real, imag) pairs in real arithmetic."""
    return bmm(a[0], b[0]) - bmm(a[1], b[1]), bmm(a[0], b[1]) + bmm(a[1], b[0])


# --- hisopt/metrics.py -----------------------------------------------------------------------


@dataclass(frozen=True)
class Metric:
    """A scalar performance quantity of a design (smaller is better)."""

    name: str
    kind: str  # "comfort", "max", "rms" or "static"
    output: str | None


METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        Metric("sigma_aw", "comfort", None),
        Metric("max_roll_psd", "max", "roll"),
        Metric("max_stroke_psd", "max", "stroke_fl"),
        Metric("max_tire_load_psd", "max", "tire_load_fl"),
        Metric("rms_roll", "rms", "roll"),
        Metric("rms_stroke", "rms", "stroke_fl"),
        Metric("rms_tire_load", "rms", "tire_load_fl"),
        Metric("roll_gradient", "static", None),
    )
}

COMFORT_OUTPUTS = {"x": "acc_x", "y": "acc_y", "z": "acc_z"}

# --- hisopt/vehicle/full_car.py and hisopt/coupled/response.py -------------------------------


def stroke_matrix(vehicle: Any) -> np.ndarray:
    """Stroke map ``G = [T_z, -I4]``: suspension extension of each corner, shape (4, 7)."""
    v = vehicle
    body_to_corners = np.array(
        [
            [1.0, v.t_f - v.y_cg, -v.l_f],
            [1.0, -v.t_f - v.y_cg, -v.l_f],
            [1.0, v.t_r - v.y_cg, v.l_r],
            [1.0, -v.t_r - v.y_cg, v.l_r],
        ]
    )
    return np.hstack([body_to_corners, -np.eye(4)])


@dataclass(frozen=True)
class Output:
    """A linear response: ``c`` (P, 7) weights ``s^p X``, ``d`` (P, 4) weights ``s^p z_g``."""

    name: str
    unit: str
    c: np.ndarray
    d: np.ndarray
    weighting: str | None = None  # ISO 2631-1 weighting applied in comfort sums

    def frf(self, h_x: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Output FRF per wheel input, shape ``(..., F, 4)``, from ``h_x`` (..., F, 7, 4) at ``s`` (..., F)."""
        out = np.zeros(np.broadcast_shapes(h_x.shape[:-2], s.shape) + (4,), dtype=np.result_type(h_x, s))
        for p in range(self.c.shape[0]):
            term = bmm(self.c[p][None, :], h_x)[..., 0, :] + self.d[p]
            out = out + s[..., None] ** p * term
        return out


def _unit(i: int, n: int) -> np.ndarray:
    e = np.zeros(n)
    e[i] = 1.0
    return e


def standard_outputs(vehicle: Any) -> dict[str, Output]:
    """Every output of docs/model.md §5.1, keyed by name."""
    v = vehicle
    zero7, zero4 = np.zeros(7), np.zeros(4)

    def poly(*cs: np.ndarray) -> np.ndarray:
        return np.array(cs)

    acc = lambda c: poly(zero7, zero7, c)  # noqa: E731  s^2 x
    acc_d = poly(zero4, zero4, zero4)
    g = stroke_matrix(v)
    return {
        "acc_z": Output("acc_z", "m/s^2", acc(_unit(0, 7)), acc_d, "Wk"),
        "acc_x": Output("acc_x", "m/s^2", acc(v.h_0s * _unit(2, 7)), acc_d, "Wd"),
        "acc_y": Output("acc_y", "m/s^2", acc(-v.h_0s * _unit(1, 7)), acc_d, "Wd"),
        "acc_roll": Output("acc_roll", "rad/s^2", acc(_unit(1, 7)), acc_d, "We"),
        "acc_pitch": Output("acc_pitch", "rad/s^2", acc(_unit(2, 7)), acc_d, "We"),
        "roll": Output("roll", "rad", poly(_unit(1, 7)), poly(zero4)),
        "pitch": Output("pitch", "rad", poly(_unit(2, 7)), poly(zero4)),
        "stroke_fl": Output("stroke_fl", "m", poly(g[0]), poly(zero4)),
        "tire_load_fl": Output(
            "tire_load_fl",
            "N",
            poly(v.k_tf * _unit(3, 7), v.c_tf * _unit(3, 7)),
            poly(-v.k_tf * _unit(0, 4), -v.c_tf * _unit(0, 4)),
        ),
    }


# --- hisopt/standards/iso_2631_1_1997.py -----------------------------------------------------


@dataclass(frozen=True)
class WeightingParameters:
    """Parameters of one Annex A weighting (ISO 2631-1:1997 Table A.1)."""

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

_NOMINAL_MANTISSA = (1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0)
_BAND_TOLERANCE = 0.05


def _params(name: str) -> WeightingParameters:
    try:
        return WEIGHTINGS[name]
    except KeyError:
        raise ValueError(f"unknown ISO 2631-1 weighting {name!r}; expected one of {sorted(WEIGHTINGS)}") from None


def _inv(f_hz: float) -> float:
    """Reciprocal of a corner frequency, 0 for an omitted (infinite) corner."""
    return 0.0 if math.isinf(f_hz) else 1.0 / f_hz


def _quadratic_gain2(inv_f_hz: float, q: float) -> np.ndarray:
    """Coefficients in ``x = f^2`` of ``|1 + s/(Q w) + (s/w)^2|^2`` (ascending powers)."""
    if inv_f_hz == 0.0:
        return np.array([1.0])
    r2 = inv_f_hz**2
    return np.array([1.0, r2 / q**2 - 2 * r2, r2**2])


def _gain2_polynomials(p: WeightingParameters) -> tuple[np.ndarray, np.ndarray]:
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


def weighting_gain_squared(f_hz: Any, name: str) -> np.ndarray:
    """Squared weighting factor ``|W(f)|^2`` as a precomputed rational function of ``f^2``."""
    _params(name)
    num, den = _GAIN2_POLYNOMIALS[name]
    x = np.square(np.asarray(f_hz, dtype=float))
    return _horner(x, num) / _horner(x, den)


def _horner(x: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    """``sum_k c_k x^k`` by Horner's rule, in place on one array."""
    out = np.full(x.shape, coefficients[-1])
    for c in coefficients[-2::-1]:
        out *= x
        out += c
    return out


class ThirdOctaveBands(NamedTuple):
    """One-third-octave bands (base-10 system, IEC 61260), each field of shape ``(n_bands,)``."""

    band_n: np.ndarray
    nominal_hz: np.ndarray
    exact_hz: np.ndarray
    lower_hz: np.ndarray
    upper_hz: np.ndarray


def third_octave_bands(f_lo_hz: float = 0.5, f_hi_hz: float = 80.0) -> ThirdOctaveBands:
    """One-third-octave bands whose centre lies in ``[f_lo_hz, f_hi_hz]``."""
    if not (0.0 < f_lo_hz <= f_hi_hz and math.isfinite(f_hi_hz)):
        raise ValueError(f"expected 0 < f_lo_hz <= f_hi_hz < inf, got f_lo_hz={f_lo_hz}, f_hi_hz={f_hi_hz}")
    n_lo = math.ceil(10.0 * math.log10(f_lo_hz) - _BAND_TOLERANCE)
    n_hi = math.floor(10.0 * math.log10(f_hi_hz) + _BAND_TOLERANCE)
    n = np.arange(n_lo, n_hi + 1)
    nominal = np.array([float(f"{_NOMINAL_MANTISSA[k % 10]}e{k // 10}") for k in n.tolist()])
    exact = 10.0 ** (n / 10.0)
    return ThirdOctaveBands(n, nominal, exact, exact * 10.0**-0.05, exact * 10.0**0.05)


def _band_index(f_hz: np.ndarray, bands: ThirdOctaveBands) -> np.ndarray:
    """Index into ``bands`` of the band holding each frequency, -1 outside all bands."""
    positive = f_hz > 0.0
    n = np.floor(10.0 * np.log10(np.where(positive, f_hz, 1.0)) + 0.5).astype(np.int64)
    idx = n - int(bands.band_n[0])
    return np.where(positive & (idx >= 0) & (idx < bands.band_n.size), idx, -1)


def band_gain_squared(f_hz: Any, name: str, f_lo_hz: float = 0.5, f_hi_hz: float = 80.0) -> np.ndarray:
    """Piecewise-constant ``w_i^2`` of the band method at each frequency (0 outside the bands)."""
    bands = third_octave_bands(f_lo_hz, f_hi_hz)
    w2 = weighting_gain_squared(bands.nominal_hz, name)
    idx = _band_index(np.asarray(f_hz, dtype=float), bands)
    return np.where(idx >= 0, w2[np.maximum(idx, 0)], 0.0)


# --- hisopt/standards/iso_8608_2016.py -------------------------------------------------------

N0_CYCLES_PER_M = 0.1
WAVINESS = 2.0
# Geometric means of G_d(n0) [1e-6 m^3], hisopt/data/iso8608_classes.csv (ISO 8608:2016 Table C.2).
_GD_N0_MEAN = {"A": "16", "B": "64", "C": "256", "D": "1024", "E": "4096", "F": "16384", "G": "65536", "H": "262144"}


def class_gd_n0(road_class: str) -> float:
    """[m^3] Geometric-mean ``G_d(n0)`` of a road class (read as hisopt reads its table)."""
    if road_class not in _GD_N0_MEAN:
        raise ValueError(f"unknown ISO 8608 road class {road_class!r}; expected one of {sorted(_GD_N0_MEAN)}")
    return float(_GD_N0_MEAN[road_class]) * 1e-6


def _check_positive(**values: Any) -> None:
    for key, value in values.items():
        array = np.asarray(value, dtype=float)
        if not np.all(array > 0.0):
            raise ValueError(f"expected {key} > 0 everywhere, got minimum {np.min(array)!r}")


def spatial_psd(n_cyc_per_m: Any, gd_n0: Any, waviness: Any = WAVINESS) -> np.ndarray:
    """[m^3] Single-track displacement PSD ``G_d(n) = G_d(n0) (n/n0)^-w`` (ISO 8608:2016)."""
    _check_positive(n_cyc_per_m=n_cyc_per_m, gd_n0=gd_n0)
    n = np.asarray(n_cyc_per_m, dtype=float)
    return np.asarray(gd_n0, dtype=float) * (n / N0_CYCLES_PER_M) ** -np.asarray(waviness, float)


def temporal_psd(f_hz: Any, gd_n0: Any, speed_mps: Any, waviness: Any = WAVINESS) -> np.ndarray:
    """[m^2/Hz] One-sided temporal displacement PSD seen by a wheel at constant speed."""
    _check_positive(f_hz=f_hz, speed_mps=speed_mps)
    v = np.asarray(speed_mps, dtype=float)
    return spatial_psd(np.asarray(f_hz, dtype=float) / v, gd_n0, waviness) / v


# --- hisopt/road/spectra.py ------------------------------------------------------------------


def isotropic_coherence(n_cyc_per_m: Any, track_m: Any, waviness: float = WAVINESS) -> np.ndarray:
    """[-] Left-right coherence ``g(n) = 2 (z/2)^nu K_nu(z) / Gamma(nu)`` of an isotropic road."""
    from scipy.special import gamma, kv

    if not waviness > 0.0:
        raise ValueError(f"expected waviness > 0, got {waviness!r}")
    nu = waviness / 2.0
    z = 2.0 * np.pi * np.asarray(n_cyc_per_m, dtype=float) * np.asarray(track_m, dtype=float)
    z_safe = np.where(z > 0.0, z, 1.0)
    g = 2.0 * (z_safe / 2.0) ** nu * kv(nu, z_safe) / gamma(nu)
    return np.where(z > 0.0, g, 1.0)


# --- hisopt/evaluation/psd.py ----------------------------------------------------------------


def comfort_gain_squared(f_hz: np.ndarray, weighting: str, comfort: Any, f_lo_hz: float, f_hi_hz: float) -> np.ndarray:
    """``|W(f)|^2`` of an ISO 2631-1 weighting as the problem's comfort method applies it."""
    if comfort.method == "band":
        return band_gain_squared(f_hz, weighting, f_lo_hz, f_hi_hz)
    return weighting_gain_squared(f_hz, weighting)


def reduce_metrics(
    metrics: Sequence[Metric],
    comfort: Any,
    weighting_of: Callable[[str], str],
    integral: Callable[[str, str | None], Any],
    maximum: Callable[[str], Any],
    static: Callable[[str], Any],
) -> dict[str, Any]:
    """Every metric from its spectra: the one dispatch of docs/model.md §6."""
    out: dict[str, Any] = {}
    for m in metrics:
        if m.kind == "comfort":
            total: Any = 0.0
            for axis, name in COMFORT_OUTPUTS.items():
                total = total + getattr(comfort, f"k_{axis}") ** 2 * integral(name, weighting_of(name))
            out[m.name] = np.sqrt(total)
        elif m.kind == "rms":
            out[m.name] = np.sqrt(integral(m.output, None))  # type: ignore[arg-type]
        elif m.kind == "max":
            out[m.name] = maximum(m.output)  # type: ignore[arg-type]
        else:
            out[m.name] = static(m.name)
    return out


def roll_gradient(stiffness: Any, vehicle: Any) -> np.ndarray:
    """[rad/g] Static roll angle under the moment ``m_s g h_0s`` on the roll DOF."""
    load = np.zeros(7)
    load[1] = vehicle.m_s * G_MPS2 * vehicle.h_0s
    k = np.asarray(stiffness)
    x = np.linalg.solve(k, np.broadcast_to(load[:, None], k.shape[:-1] + (1,)))
    return np.atleast_1d(x[..., 1, 0])
