"""ISO 8608 road spectra, four-wheel input CSD and road time histories.

Class values: packaged ``hisopt/data/iso8608_classes.csv`` (provenance in its header and in
``tests/data/README.md``); docs/model.md §4.1 lists the same geometric means.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.interpolate import CubicSpline
from scipy.signal import csd, welch

from hisopt.constants import WHEEL_NAMES
from hisopt.road.profiles import bump_profile, random_profile, step_profile
from hisopt.road.spectra import isotropic_coherence, track_inputs, wheel_input_csd
from hisopt.standards import iso_8608_2016 as iso
from hisopt.standards.iso_2631_1_1997 import third_octave_bands

GD_C = 256e-6
SPEED = 10.0


# --- ISO 8608 single-track PSD ------------------------------------------------------------------


def test_class_geometric_means_and_limits() -> None:
    means = [iso.class_gd_n0(c) for c in "ABCDEFGH"]
    np.testing.assert_allclose(means, 16e-6 * 4.0 ** np.arange(8), rtol=1e-12)
    for c, (lower, mean, upper) in iso.road_classes().items():
        assert lower == (0.0 if c == "A" else pytest.approx(mean / 2))
        assert upper == (np.inf if c == "H" else pytest.approx(mean * 2))
    with pytest.raises(ValueError, match="expected one of.*'A'.*'H'"):
        iso.class_gd_n0("Z")  # type: ignore[arg-type]


def test_temporal_psd_closed_form() -> None:
    f = np.geomspace(0.1, 100.0, 50)
    expected = GD_C * iso.N0_CYCLES_PER_M**2 * SPEED / f**2
    np.testing.assert_allclose(iso.temporal_psd(f, GD_C, SPEED), expected, rtol=1e-13)
    np.testing.assert_allclose(iso.temporal_psd(f, GD_C, SPEED, 2.5), iso.spatial_psd(f / SPEED, GD_C, 2.5) / SPEED, 1e-13)
    with pytest.raises(ValueError, match="speed_mps > 0"):
        iso.temporal_psd(f, GD_C, 0.0)


@pytest.mark.parametrize("waviness", [1.0, 1.5, 2.0, 2.5, 3.0])
def test_temporal_variance_is_integral_of_psd(waviness: float) -> None:
    f1, f2 = 0.5, 80.0
    numeric, _ = quad(lambda f: iso.temporal_psd(f, GD_C, SPEED, waviness), f1, f2, limit=200)
    analytic = iso.temporal_variance(f1, f2, GD_C, SPEED, waviness)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-9)
    with pytest.raises(ValueError, match="f2_hz > f1_hz"):
        iso.temporal_variance(f2, f1, GD_C, SPEED, waviness)


# --- four-wheel spectra ------------------------------------------------------------------------


@pytest.mark.parametrize("coherence", ["independent", "isotropic"])
def test_wheel_csd_is_hermitian_psd_with_delay(coherence: str) -> None:
    f = np.geomspace(0.2, 50.0, 300)
    gd = np.array([64e-6, 256e-6, 1024e-6])  # three designs: batch shape (3,)
    wheelbase = np.array([2.5, 2.7, 3.1])
    s = wheel_input_csd(f, gd, SPEED, wheelbase, 1.5, coherence)  # type: ignore[arg-type]
    assert s.shape == (3, 300, 4, 4)
    np.testing.assert_array_equal(s, np.conj(np.swapaxes(s, -1, -2)))
    g = iso.temporal_psd(f, gd[:, None], SPEED)
    eigenvalues = np.linalg.eigvalsh(s)
    assert np.all(eigenvalues >= -1e-12 * g[..., None])
    diagonal = np.diagonal(s, axis1=-2, axis2=-1)
    np.testing.assert_allclose(diagonal, np.repeat(g[..., None], 4, -1), rtol=1e-14)
    tau = wheelbase[:, None] / SPEED
    for rear, front in [(2, 0), (3, 1)]:  # RL-FL, RR-FR: G exp(-j w tau)
        np.testing.assert_allclose(s[..., rear, front], g * np.exp(-2j * np.pi * f * tau), 1e-12)
        np.testing.assert_allclose(
            np.angle(s[..., rear, front] / s[..., front, front]),
            np.angle(np.exp(-2j * np.pi * f * tau)),
            atol=1e-9,
        )


def test_track_inputs_reproduce_csd_and_output_psd() -> None:
    f = np.geomspace(0.2, 50.0, 64)
    e = track_inputs(f, SPEED, 2.7)
    assert e.shape == (64, 4, 2)
    g = iso.temporal_psd(f, GD_C, SPEED)
    s = wheel_input_csd(f, GD_C, SPEED, 2.7, 1.5)
    np.testing.assert_allclose(s, g[:, None, None] * e @ np.conj(np.swapaxes(e, -1, -2)))
    # S_y = H S H^H (paper Eq. 24) equals G sum_tracks |H E|^2 for a random 3-output H
    rng = np.random.default_rng(0)
    h = rng.normal(size=(64, 3, 4)) + 1j * rng.normal(size=(64, 3, 4))
    s_y = np.einsum("fij,fjk,fik->fi", h, s, np.conj(h)).real
    np.testing.assert_allclose(s_y, g[:, None] * np.sum(np.abs(h @ e) ** 2, -1), rtol=1e-12)


@pytest.mark.parametrize("waviness", [2.0, 2.5, 3.0])
def test_isotropic_coherence_from_two_dimensional_spectrum(waviness: float) -> None:
    # Cross-spectrum of tracks b apart over single-track PSD, for the isotropic 2-D spectrum
    # ~ |kappa|^-(w+1): int cos(2 pi m b) (n^2+m^2)^-(w+1)/2 dm / int (n^2+m^2)^-(w+1)/2 dm.
    b = 1.5
    for n in (0.02, 0.1, 0.3, 1.0):
        kernel = lambda m, n=n: (n * n + m * m) ** (-(waviness + 1) / 2)  # noqa: E731
        cross, _ = quad(kernel, 0.0, np.inf, weight="cos", wvar=2 * np.pi * b)
        auto, _ = quad(kernel, 0.0, np.inf)
        np.testing.assert_allclose(isotropic_coherence(n, b, waviness), cross / auto, rtol=1e-7)
    g = isotropic_coherence(np.linspace(0.0, 5.0, 200), b, waviness)
    assert g[0] == 1.0 and np.all(np.diff(g) <= 0.0) and np.all(g >= 0.0)


# --- time histories ----------------------------------------------------------------------------

DT = 0.01
T = np.arange(60_000) * DT  # 600 s at 100 Hz
F_MIN, F_MAX = 0.5, 20.0


def _band_powers(x: np.ndarray, bands_lo: float, bands_hi: float) -> tuple[np.ndarray, ...]:
    """Welch power of each column in one-third-octave bands, and the ISO 8608 value."""
    f, p = welch(x.T, fs=1 / DT, nperseg=4096)
    bands = third_octave_bands(bands_lo, bands_hi)
    band_of_bin = np.floor(10 * np.log10(np.maximum(f, 1e-12)) + 0.5)
    one_hot = band_of_bin[:, None] == bands.band_n
    measured = p @ one_hot * f[1]
    expected = iso.temporal_variance(bands.lower_hz, bands.upper_hz, GD_C, SPEED)
    return measured, np.broadcast_to(expected, measured.shape)


def test_random_profile_matches_iso_psd_and_variance() -> None:
    z = random_profile(T, "C", SPEED, 2.5, np.random.default_rng(1), F_MIN, F_MAX)
    assert z.shape == (T.size, 4)
    # Welch (28 averaged segments) integrated over the 1-16 Hz one-third-octave bands
    # (9-150 bins each): sampling scatter about +-10 % with random phases.
    measured, expected = _band_powers(z, 1.0, 16.0)
    np.testing.assert_allclose(measured, expected, rtol=0.2)
    np.testing.assert_allclose(measured.sum(-1), expected.sum(-1), rtol=0.05)
    variance = iso.temporal_variance(F_MIN, F_MAX, GD_C, SPEED)
    np.testing.assert_allclose(z.var(axis=0), variance, rtol=0.1)
    # same seed, same road; another seed, another road
    np.testing.assert_array_equal(z, random_profile(T, "C", SPEED, 2.5, np.random.default_rng(1), F_MIN, F_MAX))
    other = random_profile(T, GD_C, SPEED, 2.5, np.random.default_rng(2), F_MIN, F_MAX)
    assert abs(np.corrcoef(z[:, 0], other[:, 0])[0, 1]) < 0.1
    # independent tracks: left and right uncorrelated
    assert abs(np.corrcoef(z[:, 0], z[:, 1])[0, 1]) < 0.1


def test_rear_track_is_delayed_front_track() -> None:
    # tau = 2.5 m / 10 m/s = 25 samples exactly
    z = random_profile(T, "C", SPEED, 2.5, np.random.default_rng(3), F_MIN, F_MAX)
    scale = z[:, 0].std()
    np.testing.assert_allclose(z[25:, 2:], z[:-25, :2], rtol=0, atol=1e-12 * scale)
    # fractional delay, tau = 0.273 s: the same realisation, compared by spline interpolation
    # (band to 5 Hz, 20 samples a period: spline error observed 3e-5 of the rms)
    z = random_profile(T, "C", SPEED, 2.73, np.random.default_rng(3), F_MIN, 5.0)
    scale = z[:, 0].std()
    later = T >= 0.273
    delayed_front = CubicSpline(T, z[:, :2])(T[later] - 0.273)
    np.testing.assert_allclose(z[later, 2:], delayed_front, rtol=0, atol=2e-4 * scale)


def test_random_profile_isotropic_coherence() -> None:
    z = random_profile(T, "C", SPEED, 2.5, np.random.default_rng(4), F_MIN, F_MAX, "isotropic", track_m=1.5)
    measured, expected = _band_powers(z, 1.0, 16.0)
    np.testing.assert_allclose(measured, expected, rtol=0.2)
    f, c = csd(z[:, 0], z[:, 1], fs=1 / DT, nperseg=4096)
    _, p = welch(z[:, :2].T, fs=1 / DT, nperseg=4096)
    bands = third_octave_bands(1.0, 16.0)
    one_hot = np.floor(10 * np.log10(np.maximum(f, 1e-12)) + 0.5)[:, None] == bands.band_n
    g_measured = (c.real @ one_hot) / np.sqrt((p[0] @ one_hot) * (p[1] @ one_hot))
    weight = iso.temporal_psd(f[1:], GD_C, SPEED)[:, None] * one_hot[1:]
    g_model = (isotropic_coherence(f[1:] / SPEED, 1.5) @ weight) / weight.sum(0)
    np.testing.assert_allclose(g_measured, g_model, atol=0.15)  # observed max 0.09 over 8 seeds
    with pytest.raises(ValueError, match="track_m"):
        random_profile(T, "C", SPEED, 2.5, np.random.default_rng(4), F_MIN, F_MAX, "isotropic")


def test_random_profile_rejects_bad_input() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="Nyquist"):
        random_profile(T, "C", SPEED, 2.5, rng, F_MIN, 60.0)
    with pytest.raises(ValueError, match="uniformly spaced"):
        random_profile(np.r_[T[:10], T[10:20] + 0.001], "C", SPEED, 2.5, rng, F_MIN, F_MAX)
    with pytest.raises(ValueError, match="road class"):
        random_profile(T, "Q", SPEED, 2.5, rng, F_MIN, F_MAX)  # type: ignore[arg-type]


def test_step_profile() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    z = step_profile(t, 0.05, 0.2, wheels=("fl",))
    assert z.shape == (1001, 4)
    np.testing.assert_array_equal(z[:, 1:], 0.0)
    np.testing.assert_array_equal(z[:, 0], np.where(t >= 0.2, 0.05, 0.0))
    smooth = step_profile(t, 0.05, 0.2, rise_time_s=0.1)
    np.testing.assert_allclose(smooth[t <= 0.2], 0.0, atol=1e-15)
    np.testing.assert_allclose(smooth[t >= 0.3], 0.05)
    np.testing.assert_allclose(smooth[250], 0.025)  # half height mid-rise
    assert np.all(np.diff(smooth[:, 3]) >= 0.0)
    with pytest.raises(ValueError, match="unknown wheel"):
        step_profile(t, 0.05, 0.2, wheels=("front",))  # type: ignore[arg-type]


def test_bump_profile() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    z = bump_profile(t, 0.08, 0.5, SPEED, 2.7, wheels=("FL", "RL"), t0_s=0.1)
    assert z.shape == (1001, 4)
    np.testing.assert_array_equal(z[:, [1, 3]], 0.0)
    front, rear = z[:, 0], z[:, 2]
    assert front.max() == pytest.approx(0.08) and t[np.argmax(front)] == pytest.approx(0.125)
    np.testing.assert_allclose(rear[270:], front[:-270], atol=1e-15)  # tau = 0.27 s
    np.testing.assert_allclose(front[(t < 0.1) | (t > 0.15)], 0.0, atol=1e-15)
    assert np.sum(front) * 1e-3 == pytest.approx(0.08 * 0.05 / 2, rel=1e-3)  # area h L/(2v)
    assert WHEEL_NAMES == ("fl", "fr", "rl", "rr")
