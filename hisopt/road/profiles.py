"""Road displacement time histories at the four wheels, for time-domain simulation.

Every function returns an array of shape ``(n_t, 4)`` [m], columns FL, FR, RL, RR
(:data:`hisopt.constants.WHEEL_NAMES`). Rear wheels follow the front wheels of the same track
delayed by ``tau = wheelbase / speed`` (docs/model.md §4.3).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hisopt.constants import WHEEL_NAMES
from hisopt.errors import ConfigError
from hisopt.road.spectra import Coherence, check_coherence, isotropic_coherence
from hisopt.standards.iso_8608_2016 import WAVINESS, RoadClass, class_gd_n0, temporal_psd

Wheel = Literal["fl", "fr", "rl", "rr"]
"""Wheel names (upper case accepted too)."""


def _time_grid(t_s: ArrayLike) -> tuple[NDArray[np.float64], float]:
    """Validated 1-D increasing time vector and its step [s]."""
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0.0):
        raise ConfigError(f"expected t_s 1-D, increasing, >= 2 samples; got shape {t.shape}")
    return t, float(t[1] - t[0])


def _wheel_mask(wheels: tuple[str, ...]) -> NDArray[np.float64]:
    """``(4,)`` indicator of the selected wheels."""
    names = tuple(w.lower() for w in wheels)
    unknown = sorted(set(names) - set(WHEEL_NAMES))
    if unknown:
        raise ConfigError(f"unknown wheel(s) {unknown}; expected names from {WHEEL_NAMES}")
    return np.array([name in names for name in WHEEL_NAMES], dtype=float)


def random_profile(
    t_s: ArrayLike,
    road: RoadClass | float,
    speed_mps: float,
    wheelbase_m: float,
    rng: np.random.Generator,
    f_min_hz: float,
    f_max_hz: float,
    coherence: Coherence = "independent",
    track_m: float | None = None,
    waviness: float = WAVINESS,
) -> NDArray[np.float64]:
    """Random ISO 8608 road inputs at the four wheels, by harmonic superposition (FFT).

    Each track is ``x(t) = sum_k A_k cos(2 pi f_k t + phi_k)`` on the grid ``f_k = k / T`` in
    ``[f_min_hz, f_max_hz]``, ``A_k = sqrt(2 G(f_k) df)`` with ``G`` the ISO 8608 temporal PSD
    and uniform random phases, so the one-sided PSD is ``G`` in the band and zero outside, and
    the variance is ``sum_k G(f_k) df``, close to
    :func:`~hisopt.standards.iso_8608_2016.temporal_variance`. The period ``T`` exceeds the
    record plus ``tau``, so the rear wheels see exactly the front track delayed by ``tau``
    (Fourier shift: band-limited interpolation of the same realisation). With
    ``coherence="isotropic"`` the right track is ``g L + sqrt(1 - g^2) R'`` per harmonic, ``g``
    from :func:`~hisopt.road.spectra.isotropic_coherence` and ``R'`` independent.

    Parameters
    ----------
    t_s
        [s] Uniformly spaced times, shape ``(n_t,)``.
    road
        ISO 8608 class letter, or ``G_d(n0)`` [m^3].
    speed_mps
        [m/s] Vehicle speed.
    wheelbase_m
        [m] Wheelbase ``l_f + l_r``.
    rng
        Random generator; the same seed gives the same profile.
    f_min_hz, f_max_hz
        [Hz] Band of the synthesised PSD, ``0 < f_min_hz < f_max_hz < 1 / (2 dt)``.
    coherence
        ``"independent"`` (default) or ``"isotropic"`` left-right tracks.
    track_m
        [m] Track width, required for ``coherence="isotropic"``.
    waviness
        [-] ISO 8608 waviness w.

    Returns
    -------
    ndarray, shape ``(n_t, 4)``
        [m] Displacements at FL, FR, RL, RR.
    """
    from scipy.fft import irfft, next_fast_len  # on use: importing it costs 0.1 s

    t, dt = _time_grid(t_s)
    if np.max(np.abs(np.diff(t) - dt)) > 1e-6 * dt:
        raise ConfigError("expected uniformly spaced t_s for random_profile; resample first")
    check_coherence(coherence)
    if coherence == "isotropic" and (track_m is None or not track_m > 0.0):
        raise ConfigError(f"coherence='isotropic' needs track_m > 0, got {track_m!r}")
    gd_n0 = class_gd_n0(road) if isinstance(road, str) else float(road)
    if not (gd_n0 > 0.0 and speed_mps > 0.0 and wheelbase_m >= 0.0):
        raise ConfigError(f"expected G_d(n0) > 0, speed_mps > 0, wheelbase_m >= 0; got {gd_n0!r}, {speed_mps!r}, {wheelbase_m!r}")
    if not 0.0 < f_min_hz < f_max_hz < 0.5 / dt:
        raise ConfigError(f"expected 0 < f_min_hz < f_max_hz < Nyquist {0.5 / dt:g} Hz, got f_min_hz={f_min_hz!r}, f_max_hz={f_max_hz!r}")
    tau = wheelbase_m / speed_mps
    n_per = next_fast_len(t.size + math.ceil(tau / dt), real=True)
    k = np.arange(n_per // 2 + 1)
    f = k / (n_per * dt)
    sel = (f >= f_min_hz) & (f <= f_max_hz) & (k > 0) & (2 * k < n_per)
    if not np.any(sel):
        raise ConfigError(f"record of {n_per * dt:g} s resolves no frequency in [{f_min_hz}, {f_max_hz}] Hz; lengthen t_s or widen the band")
    amplitude = np.sqrt(2.0 * temporal_psd(f[sel], gd_n0, speed_mps, waviness) / (n_per * dt))
    phase_left, phase_other = np.exp(2j * np.pi * rng.random((2, int(sel.sum()))))
    if coherence == "isotropic":
        assert track_m is not None  # checked above
        g = isotropic_coherence(f[sel] / speed_mps, track_m, waviness)
        phase_right = g * phase_left + np.sqrt(1.0 - g**2) * phase_other
    else:
        phase_right = phase_other
    spectra = np.zeros((4, k.size), dtype=complex)
    delay = np.exp(-2j * np.pi * f[sel] * tau)
    spectra[:, sel] = 0.5 * n_per * amplitude * np.stack([phase_left, phase_right, phase_left * delay, phase_right * delay])
    return irfft(spectra, n=n_per, axis=-1)[:, : t.size].T


def step_profile(
    t_s: ArrayLike,
    height_m: float,
    t0_s: float,
    wheels: tuple[Wheel, ...] = ("fl", "fr", "rl", "rr"),
    rise_time_s: float = 0.0,
) -> NDArray[np.float64]:
    """Step of ``height_m`` at time ``t0_s`` under the selected wheels, simultaneously.

    With ``rise_time_s > 0`` the step rises as a half cosine, ``h (1 - cos(pi (t - t0) / t_r))/2``
    for ``t0 <= t <= t0 + t_r``, so the input velocity stays finite (needed with tyre damping).

    Parameters
    ----------
    t_s
        [s] Increasing times, shape ``(n_t,)``.
    height_m
        [m] Step height (negative for a step down).
    t0_s
        [s] Start of the step.
    wheels
        Wheels that see the step (default all four: heave step); e.g. ``("fl",)``.
    rise_time_s
        [s] Rise time ``t_r >= 0``; 0 gives an ideal step (``h`` for ``t >= t0``).

    Returns
    -------
    ndarray, shape ``(n_t, 4)``
        [m] Displacements at FL, FR, RL, RR.
    """
    t, _ = _time_grid(t_s)
    if not rise_time_s >= 0.0:
        raise ConfigError(f"expected rise_time_s >= 0, got {rise_time_s!r}")
    if rise_time_s > 0.0:
        shape = 0.5 * (1.0 - np.cos(np.pi * np.clip((t - t0_s) / rise_time_s, 0.0, 1.0)))
    else:
        shape = (t >= t0_s).astype(float)
    return height_m * shape[:, None] * _wheel_mask(wheels)


def _over_the_bump(t_s: ArrayLike, length_m: float, speed_mps: float, wheelbase_m: float, t0_s: float) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """[m] Each wheel's distance past the bump's start, ``(n_t, 4)`` (the front wheels reach it
    at ``t0_s``, the rear ``wheelbase / speed`` later), and where it is on the bump."""
    t, _ = _time_grid(t_s)
    if not (length_m > 0.0 and speed_mps > 0.0 and wheelbase_m >= 0.0):
        raise ConfigError(f"expected length_m > 0, speed_mps > 0, wheelbase_m >= 0; got {length_m!r}, {speed_mps!r}, {wheelbase_m!r}")
    s = speed_mps * (t[:, None] - t0_s) - np.array([0.0, 0.0, wheelbase_m, wheelbase_m])
    return s, (s >= 0.0) & (s <= length_m)


def bump_profile(
    t_s: ArrayLike,
    height_m: float,
    length_m: float,
    speed_mps: float,
    wheelbase_m: float,
    wheels: tuple[Wheel, ...] = ("fl", "fr", "rl", "rr"),
    t0_s: float = 0.0,
) -> NDArray[np.float64]:
    """Smooth 1-cos bump ``h (1 - cos(2 pi s / L)) / 2``, ``0 <= s <= L``, driven over at speed v.

    The front wheels reach the bump start at ``t0_s`` (``s = v (t - t0)``), the rear wheels
    ``tau = wheelbase / v`` later.

    Parameters
    ----------
    t_s
        [s] Increasing times, shape ``(n_t,)``.
    height_m
        [m] Bump height (negative for a pothole).
    length_m
        [m] Bump length L ``> 0``.
    speed_mps
        [m/s] Vehicle speed ``> 0``.
    wheelbase_m
        [m] Wheelbase ``l_f + l_r``.
    wheels
        Wheels that cross the bump (default all four); e.g. ``("fl", "rl")`` for the left track.
    t0_s
        [s] Time the front wheels reach the bump.

    Returns
    -------
    ndarray, shape ``(n_t, 4)``
        [m] Displacements at FL, FR, RL, RR.
    """
    s, inside = _over_the_bump(t_s, length_m, speed_mps, wheelbase_m, t0_s)
    shape = np.where(inside, 0.5 * (1.0 - np.cos(2.0 * np.pi * s / length_m)), 0.0)
    return height_m * shape * _wheel_mask(wheels)


def half_sine_profile(
    t_s: ArrayLike,
    height_m: float,
    length_m: float,
    speed_mps: float,
    wheelbase_m: float,
    wheels: tuple[Wheel, ...] = ("fl", "fr", "rl", "rr"),
    t0_s: float = 0.0,
) -> NDArray[np.float64]:
    """Half-sine bump ``h sin(pi s / L)``, ``0 <= s <= L``, driven over at speed v.

    The same placement as :func:`bump_profile` (front wheels at the start at ``t0_s``, rear
    wheels ``tau = wheelbase / v`` later); unlike its 1-cos the half sine rises with a slope
    ``pi h / L`` at both ends (the road's velocity steps there).

    Parameters
    ----------
    t_s
        [s] Increasing times, shape ``(n_t,)``.
    height_m
        [m] Bump height (negative for a dip).
    length_m
        [m] Bump length L ``> 0``.
    speed_mps
        [m/s] Vehicle speed ``> 0``.
    wheelbase_m
        [m] Wheelbase ``l_f + l_r``.
    wheels
        Wheels that cross the bump (default all four); e.g. ``("fl", "rl")`` for the left track.
    t0_s
        [s] Time the front wheels reach the bump.

    Returns
    -------
    ndarray, shape ``(n_t, 4)``
        [m] Displacements at FL, FR, RL, RR.
    """
    s, inside = _over_the_bump(t_s, length_m, speed_mps, wheelbase_m, t0_s)
    shape = np.where(inside, np.sin(np.pi * np.clip(s, 0.0, length_m) / length_m), 0.0)
    return height_m * shape * _wheel_mask(wheels)


__all__ = ["Wheel", "bump_profile", "half_sine_profile", "random_profile", "step_profile"]
