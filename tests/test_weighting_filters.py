"""ISO 2631-1 weightings in the time domain (hisopt.standards.weighting_filters).

References: the standard's tabulated weighting factors (``tests/data/iso2631_weights.csv``,
provenance in ``tests/data/README.md``), the analytic Annex A filter
(``iso_2631_1_1997.weighting_response``, itself checked against the table by
``tests/test_iso_2631.py``) and Parseval's theorem.

Error budgets (docs/model.md §22.1):

- the discretisation's whole error at ``f`` is ``G(f)/W(f) - 1`` with ``G`` =
  ``sampled_response`` (closed form: the cubic spline's gain ``sinc^4 3/(2 + cos)`` and its
  images); at 2.5 ms it is 0.49 % at 80 Hz and 2e-6 at 12 Hz;
- the start from rest: after ``settling_time_s(name, 1e-9)`` the slowest pole's transient has
  decayed to 1e-9 of its start, which is of the order of the output's own amplitude; the
  checks against ``G`` allow 1e-8;
- the not-a-knot spline's end: its error is larger than the interior's over the last ~10
  samples, so the windows that are checked against ``G`` stop 0.1 s (40 samples) before
  the record's end.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from hisopt.errors import ConfigError
from hisopt.standards import iso_2631_1_1997 as iso
from hisopt.standards import weighting_filters as wf

DATA = Path(__file__).parent / "data"
NAMES = ("Wk", "Wd", "We", "Wc", "Wj", "Wf")
DT_S = 2.5e-3  # 1/(5 f_max), f_max = 80 Hz: what the verification samples at
TABLE_TOLERANCE = 5e-3  # the 0.5 % of tests/test_iso_2631.py (analytic filter against the table)
TRANSIENT = 1e-9  # settling decay of the tight checks
TRANSIENT_BUDGET = 1e-8
TAIL_S = 0.1  # left out at the record's end (the not-a-knot end's error)


def _table(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Nominal centres 0.5-80 Hz and the tabulated factors of one weighting."""
    with open(DATA / "iso2631_weights.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    rows = [r for r in rows if r[name] and 0.5 <= float(r["f_hz"]) <= 80.0]
    return np.array([float(r["f_hz"]) for r in rows]), np.array([float(r[name]) for r in rows])


def _steady_amplitude(f_hz: np.ndarray, dt_s: float, name: str) -> np.ndarray:
    """Complex steady-state gain of ``weighted_signal`` on unit cosines, one record per
    frequency in one call: least-squares projection on cos and sin over at least two periods
    of the lowest frequency (whole periods of it) after settling."""
    settle = wf.settling_time_s(name, TRANSIENT)
    window = 2.0 / f_hz.min()
    t = np.arange(int(np.ceil((settle + window + TAIL_S) / dt_s))) * dt_s
    y = wf.weighted_signal(np.cos(2 * np.pi * f_hz[:, None] * t), dt_s, name)
    keep = (t >= settle) & (t < settle + window)
    phase = 2 * np.pi * f_hz[:, None] * t[keep]
    basis = np.stack([np.cos(phase), np.sin(phase)], axis=-1)  # (n_f, n_t, 2)
    gram = np.einsum("fti,ftj->fij", basis, basis)
    coef = np.linalg.solve(gram, np.einsum("fti,ft->fi", basis, y[:, keep])[..., None])[..., 0]
    return coef[:, 0] - 1j * coef[:, 1]


@pytest.mark.parametrize("name", NAMES)
def test_zpk_and_partial_fractions_equal_the_analytic_weighting(name: str) -> None:
    f = np.geomspace(1e-2, 1e3, 1201)
    expected = iso.weighting_response(f, name)
    zpk = wf.weighting_zpk(name)
    np.testing.assert_allclose(wf.zpk_response(f, zpk), expected, rtol=1e-13)
    assert np.all(zpk.poles_rad_s.real < 0.0)
    fractions = wf.weighting_partial_fractions(name)
    s = 2j * np.pi * f[:, None]
    pairs = fractions.weights == 2.0  # a complex pole stands for its conjugate too
    terms = fractions.residues / (s - fractions.poles_rad_s)
    terms = terms + np.where(pairs, fractions.residues.conj() / (s - fractions.poles_rad_s.conj()), 0.0)
    summed = np.sum(terms, axis=-1) + fractions.direct
    # rounding of a sum of terms of the size of the peak gain: absolute against that peak
    np.testing.assert_allclose(summed, expected, rtol=0.0, atol=1e-13 * np.abs(expected).max())


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("dt_s", [DT_S, 1e-3])
def test_sinusoids_reproduce_the_tabulated_weights(name: str, dt_s: float) -> None:
    f, table = _table(name)
    gain = _steady_amplitude(f, dt_s, name)
    # the filter is the discretisation it claims to be: the closed form G, to the transient's budget
    sampled = wf.sampled_response(f, dt_s, name)
    np.testing.assert_allclose(gain, sampled, rtol=TRANSIENT_BUDGET)
    # the standard's table: its 0.5 % plus the discretisation's error at each frequency
    discretisation = np.abs(np.abs(sampled) / np.abs(iso.weighting_response(f, name)) - 1.0)
    assert np.all(np.abs(np.abs(gain) - table) <= (TABLE_TOLERANCE + discretisation) * table)
    if dt_s == DT_S and name != "Wf":  # the budget's size at 5 samples per period of 80 Hz
        assert 4e-3 < discretisation[-1] < 6e-3 and discretisation[f == 12.5][0] < 3e-6  # Wj 5.3e-3, 2.2e-6


def test_spline_gain_is_the_stated_series() -> None:
    w_dt = np.array([0.01, 0.05, 0.1])
    gain = wf.spline_gain(w_dt / (2 * np.pi), 1.0)
    np.testing.assert_allclose(1.0 - gain, w_dt**4 / 720, rtol=3e-3)  # next term (w dt)^6 / 1500: 0.2 % at 0.1


def _body_spectrum(f_hz: np.ndarray) -> np.ndarray:
    """[(m/s^2)^2/Hz] up to a factor: road velocity (ISO 8608 w = 2) through a body mode
    at 1.2 Hz and a wheel mode at 11 Hz."""
    s = 2j * np.pi * f_hz
    w1, w2 = 2 * np.pi * 1.2, 2 * np.pi * 11.0
    body = (1 + 0.6 * s / w1) / (1 + 0.6 * s / w1 + (s / w1) ** 2)
    wheel = (1 + 0.4 * s / w2) / (1 + 0.4 * s / w2 + (s / w2) ** 2)
    return np.abs(body * wheel) ** 2 * (2 * np.pi * f_hz) ** 2


@pytest.mark.parametrize("name", ["Wk", "Wd", "We"])
def test_parseval_rms_matches_the_frequency_domain(name: str) -> None:
    # harmonics on the 1/T grid, 0.5-80 Hz, random phases and amplitudes around a body spectrum
    rng = np.random.default_rng(41)
    period_s = 20.0
    n_period = round(period_s / DT_S)
    k = np.arange(round(0.5 * period_s), round(80.0 * period_s) + 1)
    f = k / period_s
    amplitude = np.sqrt(2 * _body_spectrum(f) / period_s * rng.exponential(size=f.size))
    spectrum = np.zeros(n_period // 2 + 1, dtype=complex)
    spectrum[k] = amplitude * np.exp(2j * np.pi * rng.random(f.size)) * n_period / 2
    one_period = np.fft.irfft(spectrum, n_period)
    n_settle = int(np.ceil(wf.settling_time_s(name, TRANSIENT) / DT_S))
    record = np.tile(one_period, n_settle // n_period + 2)[: n_settle + n_period]

    frequency_domain = np.sqrt(np.sum(iso.weighting_gain_squared(f, name) * amplitude**2 / 2))
    sampled = np.sqrt(np.sum(np.abs(wf.sampled_response(f, DT_S, name)) ** 2 * amplitude**2 / 2))
    budget = abs(sampled / frequency_domain - 1.0)  # the discretisation's, for this spectrum
    assert budget < 1e-5  # Wk 1.7e-6: the body spectrum has little weighted power near 80 Hz

    rms = wf.weighted_rms(record, DT_S, name, settle_s=n_settle * DT_S)  # exactly one period
    assert abs(rms / frequency_domain - 1.0) <= 1e-3
    assert abs(rms / frequency_domain - 1.0) <= budget + 1e-6  # + the spline's end, 4e-8 here
    # one period away from the record's end: Parseval on the sampled response exactly
    longer = np.tile(one_period, n_settle // n_period + 3)[: n_settle + n_period + round(TAIL_S / DT_S)]
    y = wf.weighted_signal(longer, DT_S, name)[n_settle : n_settle + n_period]
    assert abs(np.sqrt(np.mean(y**2)) / sampled - 1.0) <= TRANSIENT_BUDGET


def test_at_rest_linear_and_causal_up_to_the_splines_leak() -> None:
    rng = np.random.default_rng(7)
    n = 4000
    assert not np.any(wf.weighted_signal(np.zeros(n), DT_S, "Wk"))
    u1, u2 = rng.standard_normal((2, n))
    y1, y2 = wf.weighted_signal(u1, DT_S, "Wk"), wf.weighted_signal(u2, DT_S, "Wk")
    assert y1[0] == 0.0
    scale = np.abs(y1).max()
    np.testing.assert_allclose(wf.weighted_signal(2.0 * u1 - 3.0 * u2, DT_S, "Wk"), 2.0 * y1 - 3.0 * y2, rtol=0, atol=1e-12 * scale)
    # change the record from sample m on: the output moves before m only by the spline's
    # leak, (2 - sqrt3)^k at k samples ahead, below rounding 25 samples ahead
    m = 2500
    u3 = u1.copy()
    u3[m:] = rng.standard_normal(n - m)
    change = np.abs(wf.weighted_signal(u3, DT_S, "Wk") - y1)
    assert np.all(change[: m - 25] <= 1e-13 * scale)
    k = np.arange(1, 12)
    leak = change[m - k] / change[m:].max()
    assert np.all(leak <= (2 - np.sqrt(3)) ** k)  # times 2.7e-4 here: one step's share of the integral
    assert change[m - 1] > 1e-4 * change[m:].max()  # the leak is real (5e-4 here): the spline is not causal


def test_a_batch_equals_record_by_record() -> None:
    rng = np.random.default_rng(3)
    batch = rng.standard_normal((2, 3, 800))
    out = wf.weighted_signal(batch, DT_S, "Wd")
    for i in range(2):
        for j in range(3):
            np.testing.assert_allclose(out[i, j], wf.weighted_signal(batch[i, j], DT_S, "Wd"), rtol=0, atol=1e-14)
    # time along another axis
    np.testing.assert_allclose(wf.weighted_signal(np.moveaxis(batch, -1, 0), DT_S, "Wd", axis=0), np.moveaxis(out, -1, 0), rtol=0, atol=1e-14)
    rms = wf.weighted_rms(batch, DT_S, "Wd", settle_s=0.5)
    assert rms.shape == (2, 3)
    np.testing.assert_allclose(rms[1, 2], np.sqrt(np.mean(out[1, 2, 200:] ** 2)), rtol=1e-14)


def test_settling_time_is_the_slowest_poles() -> None:
    sigma = 2 * np.pi * 0.4 / np.sqrt(2)  # the 0.4 Hz Butterworth band limit
    assert wf.settling_time_s("Wk") == pytest.approx(np.log(1e6) / sigma, rel=1e-12)
    assert wf.settling_time_s("Wf") == pytest.approx(np.log(1e6) / (2 * np.pi * 0.08 / np.sqrt(2)), rel=1e-12)


@pytest.mark.parametrize(
    ("call", "key"),
    [
        (lambda: wf.weighted_signal(np.zeros(100), 0.0, "Wk"), "dt_s"),
        (lambda: wf.weighted_signal(np.zeros(3), DT_S, "Wk"), "signal"),
        (lambda: wf.weighted_signal(np.full(100, np.nan), DT_S, "Wk"), "signal"),
        (lambda: wf.weighted_signal(np.zeros(100), DT_S, "Wz"), "name"),
        (lambda: wf.weighted_signal(np.zeros(100), DT_S, "Wk", axis=1), "axis"),
        (lambda: wf.weighted_rms(np.zeros(100), DT_S, "Wk"), "signal"),
        (lambda: wf.weighted_rms(np.zeros(100), DT_S, "Wk", settle_s=-1.0), "settle_s"),
        (lambda: wf.settling_time_s("Wk", decay=1.0), "decay"),
    ],
)
def test_bad_input_names_the_argument(call, key: str) -> None:
    with pytest.raises(ConfigError) as caught:
        call()
    assert caught.value.key == key


@pytest.mark.parametrize("n", [4, 5, 200])
def test_the_spline_is_scipys_not_a_knot(n: int) -> None:
    records = np.random.default_rng(n).standard_normal((3, n))
    expected = CubicSpline(np.arange(n), records, axis=-1, bc_type="not-a-knot")(np.arange(n), 1)
    np.testing.assert_allclose(wf._spline_slopes(records), expected, rtol=0, atol=1e-13)
