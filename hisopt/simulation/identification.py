"""Modal identification from measured or simulated transients (paper Section VI).

The signal-processing kit of the drop tests (:mod:`hisopt.simulation.droptest`), usable on any record:

1. accelerations low-passed at 20 Hz (4th-order Butterworth, forward and backward: no phase
   shift);
2. the four body corners projected on body coordinates with the pseudo-inverse of ``T_z`` and
   weighted by ``sqrt(m_s), sqrt(I_x), sqrt(I_y)`` (squared amplitudes are kinetic energies);
3. the free decay fitted by the Eigensystem Realization Algorithm (ERA, Juang and Pappa
   1985) at several model orders; the dominant body mode of each fit, medians over the orders;
4. the dominant mode's motion shape: its complex amplitude in every channel (body and
   wheels) by least squares on the fit's poles (:func:`mode_amplitudes`).

References
----------
J.-N. Juang and R. S. Pappa, "An eigensystem realization algorithm for modal parameter
identification and model reduction", J. Guidance, Control, and Dynamics 8(5), 620-627, 1985.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import butter, filtfilt

from hisopt.errors import ConfigError, ModelError
from hisopt.vehicle import VehicleParams, body_to_corners

BodyMode = Literal["bounce", "roll", "pitch"]

BODY_COORDINATES = ("z_s", "phi", "theta")

LOWPASS_HZ = 20.0
"""[Hz] Cut-off of the paper's low-pass filter (Section VI)."""

ERA_ORDERS = tuple(range(12, 31, 2))
"""Model orders of the ERA stabilisation: from 12 states (the three body modes and the
strongest wheel-hop modes; exact on noise-free records) to 30 (room for noise modes)."""

BODY_BAND_HZ = (0.3, 6.0)
"""[Hz] Band of body modes: below the wheel hop (~11 Hz) and above drift."""

_ERA_RATE_HZ = 50.0
"""[Hz] Records are decimated to at least this rate before ERA (2.5 x the 20 Hz cut-off),
so the Hankel matrix spans the slow body decay with few rows."""


def lowpass(signals: ArrayLike, sample_rate_hz: float, cutoff_hz: float = LOWPASS_HZ, order: int = 4) -> NDArray[np.float64]:
    """Zero-phase Butterworth low-pass (``scipy.signal.butter`` + ``filtfilt``) along axis 0.

    Parameters
    ----------
    signals
        [any] Samples, shape ``(n_t, ...)``.
    sample_rate_hz
        [Hz] Sampling rate, ``> 2 cutoff_hz``.
    cutoff_hz
        [Hz] Cut-off (-3 dB of each pass), paper: 20 Hz.
    order
        [-] Filter order of each pass.

    Returns
    -------
    ndarray
        Filtered samples, shape of ``signals``.
    """
    if not sample_rate_hz > 2.0 * cutoff_hz:
        raise ConfigError(f"expected a sampling rate above {2 * cutoff_hz:g} Hz for the {cutoff_hz:g} Hz low-pass, got {sample_rate_hz:g} Hz")
    b, a = butter(order, cutoff_hz, fs=sample_rate_hz)
    return filtfilt(b, a, np.asarray(signals, dtype=float), axis=0)


def body_motion(corner_acc: ArrayLike, vehicle: VehicleParams) -> NDArray[np.float64]:
    """Body accelerations ``[z_s'', phi'', theta'']`` from the four corner accelerometers.

    Least squares through the pseudo-inverse of ``T_z`` (exact for a rigid body).

    Parameters
    ----------
    corner_acc
        [m/s^2] Body accelerations above FL, FR, RL, RR, shape ``(n_t, 4)``.
    vehicle
        Geometry (half tracks, axle distances).

    Returns
    -------
    ndarray, shape ``(n_t, 3)``
        [m/s^2, rad/s^2, rad/s^2] Heave, roll and pitch accelerations.
    """
    return np.asarray(corner_acc, dtype=float) @ np.linalg.pinv(body_to_corners(vehicle)).T


def modal_weights(vehicle: VehicleParams) -> NDArray[np.float64]:
    """[kg^0.5, (kg m^2)^0.5] ``sqrt(m_s, I_x, I_y)``: body coordinates to kinetic scale, ``(3,)``."""
    return np.sqrt([vehicle.m_s, vehicle.I_x, vehicle.I_y])


@dataclass(frozen=True)
class ModalFit:
    """Modes of a free decay: poles ``s`` [rad/s] ``(n,)``, output shapes ``(m, n)`` and
    initial modal amplitudes ``(n,)``; channel ``c`` of the record is
    ``sum_k shapes[c, k] amplitudes[k] exp(s_k t)``."""

    poles: NDArray[np.complex128]
    shapes: NDArray[np.complex128]
    amplitudes: NDArray[np.complex128]

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        """[Hz] Damped frequencies ``Im(s) / 2 pi``."""
        return self.poles.imag / (2 * np.pi)

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """[-] ``-Re(s) / |s|``."""
        return -self.poles.real / np.abs(self.poles)

    def contribution(self, channel: int) -> NDArray[np.float64]:
        """[channel unit] Initial amplitude of each mode in ``channel``, ``(n,)``."""
        return np.abs(self.shapes[channel] * self.amplitudes)


def era(y: ArrayLike, dt_s: float, orders: Sequence[int], n_rows: int | None = None) -> list[ModalFit]:
    """Eigensystem Realization Algorithm on a multichannel free decay, at several orders.

    Block Hankel matrices ``H0 = [y_{i+j}]``, ``H1 = [y_{i+j+1}]``; with the SVD
    ``H0 = U S V^T`` truncated to ``n`` states the realisation is
    ``A = S^-1/2 U^T H1 V S^-1/2``, ``C = U_1 S^1/2``, ``x0 = S^1/2 V^T e_1`` and the poles are
    ``ln(eig A) / dt``. One SVD serves every order.

    Parameters
    ----------
    y
        Free-decay samples, shape ``(n_t, m)`` (or ``(n_t,)``), uniformly spaced.
    dt_s
        [s] Sample spacing.
    orders
        [-] Numbers of states to keep (twice the number of oscillating modes).
    n_rows
        [-] Block rows of the Hankel matrix (default ``n_t / 3``).

    Returns
    -------
    list of ModalFit
        One per order, in the order given.

    References
    ----------
    Juang and Pappa (1985), Eq. (9)-(17).
    """
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    n_t, m = y.shape
    r = n_rows or n_t // 3
    c = n_t - r - 1
    if c < 1 or min(r * m, c) < max(orders) or min(orders) < 1:
        raise ConfigError(f"a free decay of {n_t} samples is too short for ERA orders up to {max(orders)}")
    h0 = np.concatenate([y[i : i + c].T for i in range(r)], axis=0)
    h1 = np.concatenate([y[i + 1 : i + 1 + c].T for i in range(r)], axis=0)
    u_all, sv_all, vt_all = np.linalg.svd(h0, full_matrices=False)
    rank = int(np.sum(sv_all > 1e-14 * sv_all[0]))  # fewer modes than an order asks for
    fits = []
    for order in orders:
        n = min(order, rank)
        u, root, vt = u_all[:, :n], np.sqrt(sv_all[:n]), vt_all[:n]
        a = (u.T @ h1 @ vt.T) / root[:, None] / root[None, :]
        lam, psi = np.linalg.eig(a)
        with np.errstate(divide="ignore"):
            poles = np.log(lam.astype(complex)) / dt_s
        fits.append(ModalFit(poles, (u[:m] * root) @ psi, np.linalg.solve(psi, root * vt[:, 0])))
    return fits


@dataclass(frozen=True)
class IdentifiedMode:
    """The dominant mode of a free decay (median over ERA orders).

    ``frequency_hz`` [Hz] damped; ``damping_ratio`` [-]; ``spread_hz`` [Hz] range of the
    frequency over the orders; ``t_start_s`` [s] start of the analysed decay; ``orders``
    [-] ERA orders that found a mode in the band; ``shape`` [m/s^2, rad/s^2] the mode's
    complex acceleration amplitudes at ``t_start_s`` over ``DOF_NAMES`` (body ``z_s, phi,
    theta``, then wheels FL, FR, RL, RR; NaN for wheels without a sensor), from the ERA order
    whose frequency is nearest the median: relative amplitudes and phases, the motion shape
    a drop test is paired with a model mode by (:mod:`hisopt.simulation.droptest`).
    """

    frequency_hz: float
    damping_ratio: float
    spread_hz: float
    t_start_s: float
    orders: int
    shape: NDArray[np.complex128] = field(repr=False)


def mode_amplitudes(y: ArrayLike, dt_s: float, poles: ArrayLike) -> NDArray[np.complex128]:
    """Complex amplitudes of given modes in each channel of a free decay, by least squares.

    The second stage of the two-stage identification methods: with the poles ``s_k`` known
    (from :func:`era`), channel ``c`` is ``sum_k a[k, c] exp(s_k t)`` and the ``a`` are
    linear. Poles that would grow by more than ``e^20`` over the record are numerical
    (a free decay has none) and are left out (their amplitudes are 0).

    Parameters
    ----------
    y
        Free-decay samples, ``(n_t, m)``, uniformly spaced from ``t = 0``.
    dt_s
        [s] Sample spacing.
    poles
        [rad/s] ``(n,)``, conjugate pairs both present (real records).

    Returns
    -------
    ndarray, ``(n, m)`` complex
        [unit of y] Amplitude of mode ``k`` in channel ``c`` at ``t = 0``.
    """
    y = np.asarray(y, dtype=float)
    s = np.asarray(poles, dtype=complex)
    tau = np.arange(y.shape[0]) * dt_s
    keep = np.isfinite(s) & (s.real * tau[-1] < 20.0)
    basis = np.exp(tau[:, None] * s[keep])
    norm = np.linalg.norm(basis, axis=0)  # unit columns: fast and slow decays alike conditioned
    coef = np.linalg.lstsq(basis / norm, y.astype(complex), rcond=None)[0] / norm[:, None]
    out = np.zeros((s.size, y.shape[1]), dtype=complex)
    out[keep] = coef
    return out


def identify_mode(
    t_s: ArrayLike,
    body_acc: ArrayLike,
    vehicle: VehicleParams,
    mode: BodyMode,
    window_s: float = 4.0,
    orders: Sequence[int] = ERA_ORDERS,
    band_hz: tuple[float, float] = BODY_BAND_HZ,
    wheel_acc: ArrayLike | None = None,
) -> IdentifiedMode:
    """Frequency, damping and motion shape of the dominant body mode of a drop-test record.

    The dominant mode is, at each ERA order, the mode in ``band_hz`` that contributes most to
    the body coordinate of ``mode`` (the one the test is meant to excite); which model mode
    it *is* is decided later from its shape (:func:`hisopt.simulation.droptest.pair_mode`).

    Parameters
    ----------
    t_s
        [s] Uniform sample times, shape ``(n_t,)``.
    body_acc
        [m/s^2, rad/s^2] Filtered body accelerations ``[z_s'', phi'', theta'']``, ``(n_t, 3)``
        (see :func:`body_motion`).
    vehicle
        Masses and inertias for the kinetic weighting.
    mode
        Body mode the test excites: ``"bounce"``, ``"roll"`` or ``"pitch"``.
    window_s
        [s] Length of the analysed free decay after the largest response.
    orders
        ERA model orders to fit (the median over them is reported).
    band_hz
        [Hz] Frequencies a body mode may have.
    wheel_acc
        [m/s^2] Filtered wheel accelerations FL, FR, RL, RR, ``(n_t, 4)``, or ``None``: they
        only add the wheels to the identified shape.

    Returns
    -------
    IdentifiedMode
    """
    t = np.asarray(t_s, dtype=float)
    coord = BODY_COORDINATES.index({"bounce": "z_s", "roll": "phi", "pitch": "theta"}[mode])
    body = np.asarray(body_acc, dtype=float)
    y = body * modal_weights(vehicle)
    dt = float(t[1] - t[0])
    step = max(1, int(np.floor(1.0 / (dt * _ERA_RATE_HZ))))
    start = int(np.argmax(np.abs(y[:, coord])))
    window = slice(start, start + int(round(window_s / dt)) + 1, step)
    found: list[tuple[float, float, ModalFit, int]] = []
    for fit in era(y[window], dt * step, orders):
        f, zeta = fit.frequency_hz, fit.damping_ratio
        ok = np.isfinite(f) & (f >= band_hz[0]) & (f <= band_hz[1]) & (zeta > 0.0) & (zeta < 1.0)
        if ok.any():
            k = int(np.flatnonzero(ok)[np.argmax(fit.contribution(coord)[ok])])
            found.append((float(f[k]), float(zeta[k]), fit, k))
    if not found:
        raise ModelError(f"no {mode} mode found in {band_hz[0]:g}-{band_hz[1]:g} Hz; is the record a free decay?")
    freqs, zetas = np.array([(f, z) for f, z, _, _ in found]).T
    median = float(np.median(freqs))
    # The shape of one order's pole: a median of shapes would mix poles of different orders.
    _, _, fit, k = found[int(np.argmin(np.abs(freqs - median)))]
    wheels = np.full((t.size, 4), np.nan) if wheel_acc is None else np.asarray(wheel_acc, dtype=float)
    channels = np.concatenate([body, wheels], axis=1)[window]
    measured = np.all(np.isfinite(channels), axis=0)
    shape = np.full(channels.shape[1], np.nan, dtype=complex)
    shape[measured] = mode_amplitudes(channels[:, measured], dt * step, fit.poles)[k]
    return IdentifiedMode(
        frequency_hz=median,
        damping_ratio=float(np.median(zetas)),
        spread_hz=float(freqs.max() - freqs.min()),
        t_start_s=float(t[start]),
        orders=len(found),
        shape=shape,
    )


def amplitude_spectrum(t_s: ArrayLike, signal: ArrayLike, n_fft: int = 8192) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Amplitude spectrum ``|Y(f)| dt`` of a transient (zero-padded FFT), paper Fig. 13.

    Parameters
    ----------
    t_s
        [s] Uniform sample times, shape ``(n_t,)``.
    signal
        [unit] Samples, shape ``(n_t,)``.
    n_fft
        [-] FFT length (at least ``n_t``).

    Returns
    -------
    f_hz, magnitude
        [Hz] and [unit s], shape ``(n_fft // 2 + 1,)`` each.
    """
    t = np.asarray(t_s, dtype=float)
    dt = float(t[1] - t[0])
    n = max(n_fft, t.size)
    f_hz = np.asarray(np.fft.rfftfreq(n, dt), dtype=np.float64)
    return f_hz, np.abs(np.fft.rfft(np.asarray(signal, dtype=float), n)) * dt
