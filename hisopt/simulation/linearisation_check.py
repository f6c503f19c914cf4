"""Statistical linearisation against simulation: one oscillator with a damper valve (docs/model.md §22.3).

The frequency domain takes every damper valve at the equivalent linear resistance of a
Gaussian flow (:func:`hisopt.hydraulics.laws.damper_valve_equivalent_resistance`, §3.3). Here
that figure is checked where the answer is known: a single-degree-of-freedom oscillator

    m x'' + F_d(x') + k x = -m a(t),       F_d(v) = A dp(A v)

whose damper is a piston of area ``A`` pushing its flow ``q = A v`` through a valve of law
``dp`` (:func:`hisopt.hydraulics.laws.damper_valve_pressure_drop`: ``r q + K q |q|`` without a
blow-off, so ``F_d = c v + c_q v |v|`` with ``c = A^2 r`` and ``c_q = A^3 K``), driven by a base
acceleration ``a`` of one-sided PSD ``G`` [(m/s^2)^2/Hz], white over a band wide compared with
the resonance. Three figures for the velocity's RMS ``sigma_v`` (the stroke's is ``sigma_v / w_n``
in all three closed forms):

- **linear** (``K = 0``), exact for white noise: ``sigma_v^2 = m G / (4 c)``
  (:func:`linear_velocity_ms`; with ``D = G / 2`` the two-sided intensity of the per-unit-mass
  forcing, ``E[w(t) w(t + tau)] = D delta(tau)``, this is the textbook ``D / (2 c / m)``);
- **statistical linearisation** (:func:`linearised_velocity_rms`): the linear figure at the
  damper's equivalent damping ``c_eq = A^2 R_eq(A sigma_v)`` from hisopt's own law function,
  solved for its fixed point ``sigma_v^2 c_eq(sigma_v) = m G / 4``; for the pure quadratic
  (``c_eq = 2 sqrt(2 / pi) c_q sigma_v``) in closed form, ``sigma_v^3 = sqrt(2 pi) m G / (16 c_q)``;
- **energy-based stochastic averaging** (:func:`averaged_velocity_rms`): the energy per unit
  mass ``H = v^2 / 2 + w_n^2 x^2 / 2`` of a lightly damped oscillator is, averaged over a cycle,
  a one-dimensional diffusion whose stationary density is ``p(H) ~ exp(-alpha H - lam H^{3/2})``
  with ``alpha = 4 c / (m G)``, ``lam = 2^{13/2} c_q / (9 pi m G)`` (the cycle averages
  ``<v^2> = H`` and ``<|v|^3> = (4 / (3 pi)) (2 H)^{3/2}``); ``sigma_v^2 = E[H]``, which for the
  pure quadratic is ``Gamma(4/3) / Gamma(2/3) lam^{-2/3}``. Averaging is exact for the linear
  damper and asymptotically exact as the damping goes to zero (Khasminskii's limit theorem;
  Roberts and Spanos, "Stochastic averaging: an approximate method of solving random vibration
  problems", Int. J. Non-Linear Mech. 21 (1986) 111-134; the density is the one of the
  energy-dependent "equivalent nonlinear system", Caughey, Probabilistic Eng. Mech. 1 (1986) 2-4).

For the pure quadratic the ratio of the two approximations is a number,

    sigma_v,avg / sigma_v,SL = ((9 sqrt(pi) / 8) (Gamma(4/3) / Gamma(2/3))^{3/2})^{1/3} = 1.0221

(:data:`SL_TO_AVERAGING_QUADRATIC`): statistical linearisation underestimates the RMS of a
lightly damped quadratic damper by 2.2 % (4.5 % in mean square) whatever ``m, k, c_q, G``. The
reason is exact: white noise feeds the power ``m G / 4`` whatever the damper
(:func:`white_noise_input_power`; Ito's rule on ``v^2``), so ``E[v F_d(v)] = m G / 4``, i.e.
``c_q E|v|^3 = m G / 4``; linearisation takes ``E|v|^3 = 2 sqrt(2 / pi) sigma_v^3`` (Gaussian,
1.596 sigma_v^3), while the lightly damped response's velocity is flatter-topped
(1.494 sigma_v^3 under the averaged density). The simulation checks that power balance exactly.

:func:`simulate_oscillator` integrates the oscillator on seeded realisations of the base
acceleration, stacked as columns, with a fixed-step classical Runge-Kutta (RK4). The signal is
a harmonic superposition on the ``1/T`` grid with the PSD's amplitudes and uniform random
phases, the same construction as :func:`hisopt.road.random_profile` (so the check exercises the
kind of input the verification runs): it is periodic with period ``T``, so after a settling
time the mean square over exactly one period of the linear response is the spectral sum
``sum_k G df |H_v(f_k)|^2`` to the integrator's error, with no sampling error at all
(:func:`discrete_linear_velocity_ms`), and the realisations' spread in the nonlinear case is the
response's own. The signal is sampled by an inverse FFT at half steps, the times RK4 evaluates.
``gaussian=True`` draws Rayleigh amplitudes instead (complex Gaussian coefficients: an exactly
Gaussian input, at about four times the standard error), to tell the input's finite number of
lines from averaging's error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import integrate, optimize, special

from hisopt.errors import ConfigError
from hisopt.hydraulics.laws import damper_valve_equivalent_resistance, damper_valve_pressure_drop

SL_TO_AVERAGING_QUADRATIC = ((9.0 * math.sqrt(math.pi) / 8.0) * (special.gamma(4.0 / 3.0) / special.gamma(2.0 / 3.0)) ** 1.5) ** (1.0 / 3.0)
"""[-] Stochastic averaging's RMS velocity over statistical linearisation's for a pure quadratic
damper under white noise (1.0221): a constant, see the module docstring."""


@dataclass(frozen=True)
class ValveOscillator:
    """A mass on a spring whose damper is a piston pushing oil through a damper valve.

    Parameters
    ----------
    mass : float
        [kg] the mass ``m``
    stiffness : float
        [N/m] the spring ``k``
    area : float
        [m^2] the piston's area ``A``: the valve's flow is ``A v``, its drop pushes ``A dp``
    kq : float
        [Pa s^2 m^-6] the valve's quadratic coefficient ``K`` (0: a linear damper)
    r : float
        [Pa s m^-3] the valve's laminar part
    """

    mass: float
    stiffness: float
    area: float
    kq: float
    r: float = 0.0

    @property
    def natural_frequency(self) -> float:
        """[rad/s] ``w_n = sqrt(k / m)``."""
        return math.sqrt(self.stiffness / self.mass)

    @property
    def quadratic_damping(self) -> float:
        """[N s^2/m^2] ``c_q = A^3 K``: the damper's force ``c_q v |v|`` of its bleed."""
        return self.area**3 * self.kq

    @property
    def linear_damping(self) -> float:
        """[N s/m] ``c = A^2 r``: the damper's force ``c v`` of its laminar part."""
        return self.area**2 * self.r

    def damper_force(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        """[N] ``A dp(A v)``: the valve law of the evaluator at the velocity ``v`` [m/s]."""
        return self.area * damper_valve_pressure_drop(self.area * v, self.kq, r=self.r)

    def equivalent_damping(self, sigma_v: float) -> float:
        """[N s/m] ``A^2 R_eq(A sigma_v)``: the evaluator's statistical linearisation of the
        valve at a Gaussian velocity of RMS ``sigma_v`` [m/s]."""
        return float(self.area**2 * damper_valve_equivalent_resistance(self.area * sigma_v, self.kq, r=self.r))


def white_noise_input_power(mass: float, psd: float) -> float:
    """[W] Mean power ``m G / 4`` white base acceleration of one-sided PSD ``psd`` = ``G``
    [(m/s^2)^2/Hz] feeds a mass ``m`` [kg] on any damper and spring: in the stationary state
    it is ``E[v F_d(v)]``, the damper's mean dissipation (Ito's rule on ``v^2``), exactly."""
    return mass * psd / 4.0


def linear_velocity_ms(mass: float, damping: float, psd: float) -> float:
    """[m^2/s^2] ``sigma_v^2 = m G / (4 c)`` of ``m x'' + c x' + k x = -m a`` under white
    ``a`` of one-sided PSD ``psd`` = ``G`` [(m/s^2)^2/Hz]; ``damping`` = ``c`` [N s/m]. The
    stroke's is ``sigma_v^2 / w_n^2``."""
    return mass * psd / (4.0 * damping)


def band_tail_velocity_ms(psd: float, f_max_hz: float) -> float:
    """[m^2/s^2] The velocity's mean square a white base acceleration of one-sided PSD ``psd``
    [(m/s^2)^2/Hz] puts above ``f_max_hz`` [Hz], where any oscillator is mass-like
    (``|H_v| = 1 / w``): ``G / (4 pi^2 f_max)``, to a relative ``O((f_n / f_max)^2)``. A signal
    band-limited at ``f_max`` lacks it; the resonance, which the damper sets, keeps its share
    (the input power the band lacks is what that tail would have dissipated)."""
    return psd / (4.0 * math.pi**2 * f_max_hz)


def velocity_gain_squared(osc: ValveOscillator, damping: float, f_hz: NDArray[np.float64]) -> NDArray[np.float64]:
    """[s^2] ``|H_v(f)|^2`` from base acceleration to velocity of the oscillator at the linear
    damping ``damping`` [N s/m]: ``w^2 / ((w_n^2 - w^2)^2 + (c w / m)^2)``."""
    w = 2.0 * np.pi * np.asarray(f_hz, dtype=float)
    wn2 = osc.stiffness / osc.mass
    return w**2 / ((wn2 - w**2) ** 2 + (damping * w / osc.mass) ** 2)


def discrete_linear_velocity_ms(osc: ValveOscillator, damping: float, psd: float, f_max_hz: float, period_s: float) -> float:
    """[m^2/s^2] The linear response's mean square over one period of the signal
    :func:`simulate_oscillator` builds: ``sum_k G df |H_v(f_k)|^2`` over its harmonics
    ``f_k = k / T <= f_max``."""
    f = harmonic_frequencies(f_max_hz, period_s)
    return float(np.sum(psd / period_s * velocity_gain_squared(osc, damping, f)))


def linearised_velocity_rms(osc: ValveOscillator, psd: float) -> float:
    """[m/s] Statistical linearisation's RMS velocity under white base acceleration of
    one-sided PSD ``psd`` [(m/s^2)^2/Hz]: the root of ``sigma^2 c_eq(sigma) = m G / 4`` with
    ``c_eq`` from the evaluator's law (:meth:`ValveOscillator.equivalent_damping`), increasing
    in ``sigma``, bracketed between the pure quadratic's and the pure linear's figures."""
    target = white_noise_input_power(osc.mass, psd)
    bounds = []
    if osc.linear_damping > 0.0:
        bounds.append(math.sqrt(target / osc.linear_damping))
    if osc.quadratic_damping > 0.0:
        bounds.append((target / (2.0 * math.sqrt(2.0 / math.pi) * osc.quadratic_damping)) ** (1.0 / 3.0))
    if not bounds:
        raise ConfigError("the oscillator has no damping (kq and r both 0): no stationary response", key="kq")
    hi = min(bounds)  # each part alone dissipates the input power at a larger sigma than both
    return float(optimize.brentq(lambda s: s * s * osc.equivalent_damping(s) - target, 0.0, hi * (1.0 + 1e-12), xtol=1e-15 * hi, rtol=1e-14))


def psd_at_linearised_damping_ratio(osc: ValveOscillator, zeta: float) -> float:
    """[(m/s^2)^2/Hz] The white base acceleration's one-sided PSD at which statistical
    linearisation puts the pure quadratic damper of ``osc`` at the damping ratio ``zeta``:
    ``c_eq = 2 zeta m w_n`` at ``sigma_v = c_eq / (2 sqrt(2 / pi) c_q)``, ``G = 4 c_eq sigma_v^2 / m``."""
    c_eq = 2.0 * zeta * osc.mass * osc.natural_frequency
    sigma_v = c_eq / (2.0 * math.sqrt(2.0 / math.pi) * osc.quadratic_damping)
    return 4.0 * c_eq * sigma_v**2 / osc.mass


def averaged_velocity_rms(osc: ValveOscillator, psd: float) -> float:
    """[m/s] Energy-based stochastic averaging's RMS velocity (see the module docstring):
    ``sqrt(E[H])`` under ``p(H) ~ exp(-alpha H - lam H^{3/2})``; the pure quadratic in closed
    form, ``Gamma(4/3) / Gamma(2/3) lam^{-2/3}``, a damper with a laminar part by quadrature."""
    mg = osc.mass * psd
    alpha = 4.0 * osc.linear_damping / mg
    lam = 2.0**6.5 * osc.quadratic_damping / (9.0 * math.pi * mg)
    if alpha == 0.0:
        return math.sqrt(special.gamma(4.0 / 3.0) / special.gamma(2.0 / 3.0) * lam ** (-2.0 / 3.0))
    scale = 1.0 / alpha if lam == 0.0 else min(1.0 / alpha, lam ** (-2.0 / 3.0))  # H's natural unit
    weight = lambda u: math.exp(-alpha * scale * u - lam * (scale * u) ** 1.5)  # noqa: E731
    mean = integrate.quad(lambda u: u * weight(u), 0.0, np.inf)[0] / integrate.quad(weight, 0.0, np.inf)[0]
    return math.sqrt(scale * mean)


def harmonic_frequencies(f_max_hz: float, period_s: float) -> NDArray[np.float64]:
    """[Hz] The harmonics ``k / T``, ``k = 1 .. floor(f_max T)``, of a signal of period ``T``."""
    return np.arange(1, int(math.floor(f_max_hz * period_s + 1e-9)) + 1) / period_s


def base_acceleration(
    psd: float, f_max_hz: float, period_s: float, n_samples: int, realisations: int, seed: int, gaussian: bool = False
) -> NDArray[np.float64]:
    """[m/s^2] ``(n_samples, realisations)`` samples over one period ``T`` (at ``j T / n``) of
    ``a(t) = sum_k sqrt(2 G df) cos(2 pi f_k t + phi_k)``: one-sided PSD ``G`` on the
    harmonics up to ``f_max``, uniform random phases (seeded), by an inverse real FFT."""
    f = harmonic_frequencies(f_max_hz, period_s)
    if 2 * f.size >= n_samples:
        raise ConfigError(f"{n_samples} samples per period cannot carry {f.size} harmonics up to {f_max_hz} Hz", key="f_max_hz")
    rng = np.random.default_rng(seed)
    if gaussian:  # Rayleigh amplitudes: complex Gaussian coefficients of the same mean square
        phases = (rng.standard_normal((f.size, realisations)) + 1j * rng.standard_normal((f.size, realisations))) / math.sqrt(2.0)
    else:
        phases = np.exp(2j * np.pi * rng.random((f.size, realisations)))
    spectrum = np.zeros((n_samples // 2 + 1, realisations), dtype=complex)
    spectrum[1 : f.size + 1] = 0.5 * n_samples * math.sqrt(2.0 * psd / period_s) * phases
    return np.fft.irfft(spectrum, n=n_samples, axis=0)


@dataclass(frozen=True)
class OscillatorRuns:
    """Per-realisation statistics of :func:`simulate_oscillator`, each over one period after
    the settling time.

    Parameters
    ----------
    velocity_ms : NDArray[np.float64]
        [m^2/s^2] mean square velocity, one per realisation
    stroke_ms : NDArray[np.float64]
        [m^2] mean square displacement
    power : NDArray[np.float64]
        [W] mean power the damper dissipates, ``<v F_d(v)>``
    abs_velocity_cubed : NDArray[np.float64]
        [m^3/s^3] mean ``|v|^3``
    """

    velocity_ms: NDArray[np.float64]
    stroke_ms: NDArray[np.float64]
    power: NDArray[np.float64]
    abs_velocity_cubed: NDArray[np.float64]


def mean_and_standard_error(values: NDArray[np.float64]) -> tuple[float, float]:
    """The mean of independent per-realisation ``values`` and its standard error
    ``s / sqrt(R)`` (sample standard deviation, ``R - 1`` degrees of freedom)."""
    v = np.asarray(values, dtype=float)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))


def rms_and_standard_error(mean_squares: NDArray[np.float64]) -> tuple[float, float]:
    """The RMS ``sqrt(mean)`` of per-realisation mean squares and its standard error by the
    delta method, ``SE(mean) / (2 sqrt(mean))``."""
    m, se = mean_and_standard_error(mean_squares)
    return math.sqrt(m), se / (2.0 * math.sqrt(m))


def simulate_oscillator(
    osc: ValveOscillator,
    psd: float,
    *,
    f_max_hz: float,
    period_s: float,
    settle_s: float,
    step_s: float,
    realisations: int,
    seed: int,
    gaussian: bool = False,
) -> OscillatorRuns:
    """Integrate ``m x'' + A dp(A x') + k x = -m a(t)`` from rest on ``realisations`` seeded
    signals of :func:`base_acceleration` (the columns of one stacked state), classical RK4 at
    the fixed ``step_s``; the statistics are rectangle sums at the steps over the one period
    after ``settle_s`` (spectrally exact for a periodic integrand).

    Step-size budget (``h = step_s``): RK4 damps a free oscillation by ``(w h)^6 / 144`` per
    step, which over the physical ``zeta w h`` per step is a relative error in the damping of
    ``(w_n h)^5 / (144 zeta)``, below 1e-6 at ``w_n h <= 0.1``, ``zeta >= 0.01``; the signal
    enters through Simpson's rule over each step (RK4's stages at ``t, t + h/2, t + h``), whose
    relative error on its highest harmonic is ``(w_max h)^4 / 2880``, 2e-5 at ``w_max h = 0.5``,
    on harmonics carrying under 2 % of the mean square. The settling leaves the transient at
    ``exp(-zeta w_n settle)`` of its start.

    Parameters
    ----------
    osc : ValveOscillator
        the oscillator
    psd : float
        [(m/s^2)^2/Hz] one-sided PSD ``G`` of the base acceleration
    f_max_hz : float
        [Hz] the signal's band edge
    period_s : float
        [s] the signal's period ``T`` and the record the statistics average over
    settle_s : float
        [s] settling time dropped before the record (the signal wraps periodically)
    step_s : float
        [s] the RK4 step; ``period_s / step_s`` must be a whole number
    realisations : int
        number of independent signals (columns)
    seed : int
        seed of their phases
    """
    steps_per_period = int(round(period_s / step_s))
    if abs(steps_per_period * step_s - period_s) > 1e-9 * period_s:
        raise ConfigError(f"period {period_s} s is not a whole number of {step_s} s steps", key="step_s")
    accel = base_acceleration(psd, f_max_hz, period_s, 2 * steps_per_period, realisations, seed, gaussian)
    n_half = accel.shape[0]
    settle_steps = int(math.ceil(settle_s / step_s))
    h, wn2 = step_s, osc.stiffness / osc.mass
    inv_m = 1.0 / osc.mass

    def acceleration(x: NDArray[np.float64], v: NDArray[np.float64], j: int) -> NDArray[np.float64]:
        return -accel[j % n_half] - wn2 * x - inv_m * osc.damper_force(v)

    x = np.zeros(realisations)
    v = np.zeros(realisations)
    sums = np.zeros((4, realisations))
    for n in range(settle_steps + steps_per_period):
        if n >= settle_steps:
            force = osc.damper_force(v)
            av = np.abs(v)
            sums += (v * v, x * x, v * force, av * av * av)
        j = 2 * n
        k1x, k1v = v, acceleration(x, v, j)
        k2x, k2v = v + 0.5 * h * k1v, acceleration(x + 0.5 * h * k1x, v + 0.5 * h * k1v, j + 1)
        k3x, k3v = v + 0.5 * h * k2v, acceleration(x + 0.5 * h * k2x, v + 0.5 * h * k2v, j + 1)
        k4x, k4v = v + h * k3v, acceleration(x + h * k3x, v + h * k3v, j + 2)
        x = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
        v = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
    sums /= steps_per_period
    return OscillatorRuns(velocity_ms=sums[0], stroke_ms=sums[1], power=sums[2], abs_velocity_cubed=sums[3])
