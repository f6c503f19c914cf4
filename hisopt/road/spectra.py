"""Four-wheel road input spectra: wheelbase delay and left-right coherence (docs/model.md §4.3).

Wheels are ordered FL, FR, RL, RR (:data:`hisopt.constants.WHEEL_NAMES`), tracks left, right.
The rear wheels see the front input delayed by ``tau = wheelbase / v``; with
``E(f) = [[1,0],[0,1],[e^-jwt,0],[0,e^-jwt]]`` and the 2x2 track spectrum ``C = G [[1,g],[g,1]]``
the wheel cross-spectral matrix is ``S_zg = E C E^H`` and an output ``y = H_y z_g`` has PSD
``S_y = H_y S_zg H_y^H`` (paper Eq. 24).

Shapes: ``f_hz`` is ``(..., n_freq)``; per-design parameters (``gd_n0``, ``speed_mps``,
``wheelbase_m``, ``track_m``) are scalars or arrays of the batch shape ``(...)``, broadcast
against the leading axes of ``f_hz``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hisopt.errors import ConfigError
from hisopt.standards.iso_8608_2016 import WAVINESS, temporal_psd

Coherence = Literal["independent", "isotropic"]
"""Left-right track model: independent tracks, or the isotropic-surface coherence."""

COHERENCE_MODELS: tuple[str, ...] = ("independent", "isotropic")


def _per_design(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A per-design parameter, positive, with a trailing axis for frequency."""
    array = np.asarray(value, dtype=float)
    if not np.all(array > 0.0):
        raise ConfigError(f"expected {name} > 0 everywhere, got minimum {np.min(array)!r}")
    return array[..., None]


def check_coherence(coherence: str) -> None:
    """Raise a :class:`~hisopt.errors.ConfigError` unless ``coherence`` is one of :data:`COHERENCE_MODELS`."""
    if coherence not in COHERENCE_MODELS:
        raise ConfigError(f"unknown coherence {coherence!r}; expected one of {COHERENCE_MODELS}")


def delay_factor(f_hz: ArrayLike, speed_mps: ArrayLike, wheelbase_m: ArrayLike) -> NDArray:
    """Rear-wheel delay factor ``exp(-j 2 pi f tau)``, ``tau = wheelbase / speed``.

    Parameters
    ----------
    f_hz
        [Hz] Frequencies, shape ``(..., n_freq)``.
    speed_mps
        [m/s] Speed, scalar or batch shape ``(...)``.
    wheelbase_m
        [m] Wheelbase ``l_f + l_r``, scalar or batch shape ``(...)``.

    Returns
    -------
    ndarray of complex, shape ``(..., n_freq)``
        [-] Delay factor.
    """
    tau = _per_design(wheelbase_m, "wheelbase_m") / _per_design(speed_mps, "speed_mps")
    return np.exp(-2j * np.pi * np.asarray(f_hz, dtype=float) * tau)


def track_inputs(f_hz: ArrayLike, speed_mps: ArrayLike, wheelbase_m: ArrayLike) -> NDArray:
    """Track-to-wheel matrix ``E(f)`` mapping (left, right) track inputs to the four wheels.

    For independent tracks of equal PSD ``G`` an output ``y = H_y z_g`` has
    ``S_y = G sum_tracks |H_y E|^2``, with no 4x4 matrix formed.

    Parameters
    ----------
    f_hz
        [Hz] Frequencies, shape ``(..., n_freq)``.
    speed_mps
        [m/s] Speed, scalar or batch shape ``(...)``.
    wheelbase_m
        [m] Wheelbase ``l_f + l_r``, scalar or batch shape ``(...)``.

    Returns
    -------
    ndarray of complex, shape ``(..., n_freq, 4, 2)``
        [-] ``[[1,0],[0,1],[d,0],[0,d]]`` with ``d = exp(-j 2 pi f tau)``.
    """
    d = delay_factor(f_hz, speed_mps, wheelbase_m)
    e = np.zeros(d.shape + (4, 2), dtype=complex)
    e[..., 0, 0] = e[..., 1, 1] = 1.0
    e[..., 2, 0] = e[..., 3, 1] = d
    return e


def isotropic_coherence(n_cyc_per_m: ArrayLike, track_m: ArrayLike, waviness: float = WAVINESS) -> NDArray[np.float64]:
    """Left-right coherence of an isotropic road surface with ``G_d(n) ~ n^-w``.

    Ratio of the cross-spectrum of two parallel tracks a distance ``b`` apart to the
    single-track PSD (real, in ``(0, 1]``; the squared coherence is its square):

    ``g(n) = 2 (z/2)^nu K_nu(z) / Gamma(nu)``, ``z = 2 pi n b``, ``nu = w/2``,

    with ``K_nu`` the modified Bessel function of the second kind; for ``w = 2`` this is
    ``g = z K_1(z)``. It follows from an isotropic 2-D spectrum ``~ |kappa|^-(w+1)``
    integrated across the track direction.

    Parameters
    ----------
    n_cyc_per_m
        [cycle/m] Spatial frequencies ``>= 0``, any shape.
    track_m
        [m] Track width b; broadcast elementwise with ``n_cyc_per_m``.
    waviness
        [-] Waviness exponent w ``> 0``.

    Returns
    -------
    ndarray
        [-] ``g(n)``, 1 at ``n = 0`` and decreasing towards 0.

    References
    ----------
    K.M.A. Kamash and J.D. Robson, "The application of isotropy in road surface modelling",
    J. Sound Vib. 57(1), 89-100, 1978.
    K. Bogsjo, "Coherence of road roughness in left and right wheel-path", Vehicle System
    Dynamics 46(S1), 599-609, 2008 (compares this isotropic model with measured coherence).
    """
    from scipy.special import gamma, kv  # on use: importing it costs 0.08 s

    if not waviness > 0.0:
        raise ConfigError(f"expected waviness > 0, got {waviness!r}")
    nu = waviness / 2.0
    z = 2.0 * np.pi * np.asarray(n_cyc_per_m, dtype=float) * np.asarray(track_m, dtype=float)
    z_safe = np.where(z > 0.0, z, 1.0)
    g = 2.0 * (z_safe / 2.0) ** nu * kv(nu, z_safe) / gamma(nu)
    return np.where(z > 0.0, g, 1.0)


def wheel_input_csd(
    f_hz: ArrayLike,
    gd_n0: ArrayLike,
    speed_mps: ArrayLike,
    wheelbase_m: ArrayLike,
    track_m: ArrayLike,
    coherence: Coherence = "independent",
    waviness: float = WAVINESS,
) -> NDArray[np.complex128]:
    """Cross-spectral matrix of the four wheel displacement inputs, ``S_zg = E C E^H``.

    Parameters
    ----------
    f_hz
        [Hz] Frequencies ``> 0``, shape ``(..., n_freq)``.
    gd_n0
        [m^3] ISO 8608 ``G_d(n0)``, scalar or batch shape ``(...)``.
    speed_mps
        [m/s] Speed, scalar or batch shape ``(...)``.
    wheelbase_m
        [m] Wheelbase ``l_f + l_r``, scalar or batch shape ``(...)``.
    track_m
        [m] Track width (used by ``coherence="isotropic"``), scalar or batch shape ``(...)``.
    coherence
        ``"independent"`` (default, docs/model.md §4.3) or ``"isotropic"`` (:func:`isotropic_coherence`).
    waviness
        [-] ISO 8608 waviness w.

    Returns
    -------
    ndarray of complex, shape ``(..., n_freq, 4, 4)``
        [m^2/Hz] One-sided CSD, wheels FL, FR, RL, RR; Hermitian positive semi-definite.
        ``S[..., 2, 0] = G exp(-j 2 pi f tau)``: the rear input lags the front by ``tau``.

    References
    ----------
    Paper Eq. (24); ISO 8608:2016; docs/model.md §4.4.
    """
    check_coherence(coherence)
    f = np.asarray(f_hz, dtype=float)
    v = _per_design(speed_mps, "speed_mps")
    g_auto = temporal_psd(f, _per_design(gd_n0, "gd_n0"), v, waviness)
    if coherence == "isotropic":
        g_cross = g_auto * isotropic_coherence(f / v, _per_design(track_m, "track_m"), waviness)
    else:
        g_cross = np.zeros_like(g_auto)
    c = np.stack([np.stack([g_auto, g_cross], -1), np.stack([g_cross, g_auto], -1)], -2)
    d = delay_factor(f, speed_mps, wheelbase_m)[..., None, None]
    c, d = np.broadcast_arrays(c, d)
    front = np.concatenate([c + 0j, c * np.conj(d)], -1)
    rear = np.concatenate([c * d, c + 0j], -1)
    return np.concatenate([front, rear], -2)


__all__ = [
    "COHERENCE_MODELS",
    "Coherence",
    "check_coherence",
    "delay_factor",
    "isotropic_coherence",
    "track_inputs",
    "wheel_input_csd",
]
