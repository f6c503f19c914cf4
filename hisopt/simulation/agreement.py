"""The linearised frequency domain against the nonlinear time domain on random roads (docs/model.md §3.10).

The evaluator takes each physical damper valve at its equivalent linear resistance under a
Gaussian flow of the RMS the road drives through it (statistical linearisation, §3.3). The
time domain integrates the valve law itself. :func:`road_agreement` simulates one design of a
problem on seeded random ISO 8608 realisations of the problem's road (its class, speed,
coherence, the wheelbase delay) and compares, band for band, four figures with the
evaluator's:

- ``valve_flow``: RMS flow through the damper valves (their mean square averaged over the valves);
- ``stroke_fl``, ``tire_load_fl``: RMS FL stroke and dynamic tyre load;
- ``sigma_aw``: ISO 2631-1 total weighted RMS acceleration (``k^2``-weighted sum over the axes).

Each simulated signal is band-limited as the evaluator integrates: its periodogram summed over
the problem's ``[band]``, times ``|W(f)|^2`` for the comfort axes
(:func:`hisopt.standards.iso_2631_1_1997.weighting_gain_squared`), after a settling time.
Each realisation is run as given and with its right track negated (an equally likely road):
the pair cancels the random left-right cross terms of the superposed harmonics. The same roads
also drive the linear model (``mode="linear"``): its gap to the frequency domain is the
pipeline's own error (record length, band edges), and the nonlinear over the linear mean square
on the same roads is the control-variate estimate of the linearisation's gap.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hisopt.coupled.model import CoupledModel
from hisopt.coupled.response import Output, standard_outputs
from hisopt.errors import ConfigError
from hisopt.evaluation.evaluate import Evaluator
from hisopt.evaluation.valve_states import valve_states
from hisopt.metrics import COMFORT_OUTPUTS
from hisopt.problem import Problem
from hisopt.road.interpolation import RoadInput
from hisopt.road.profiles import random_profile
from hisopt.simulation.timedomain import SolverMethod, TimeResponse, simulate
from hisopt.standards.iso_2631_1_1997 import weighting_gain_squared

FIGURES = ("valve_flow", "stroke_fl", "tire_load_fl", "sigma_aw")
"""The compared figures, in table order."""

FREQUENCY_DOMAIN_METRICS = {"stroke_fl": "rms_stroke", "tire_load_fl": "rms_tire_load", "sigma_aw": "sigma_aw"}
"""The evaluator's metric for each figure besides the valve flow."""


def band_mean_square(signal: NDArray[np.float64], dt_s: float, f_min_hz: float, f_max_hz: float, weighting: str | None = None) -> float:
    """Mean square of ``signal`` ``(n,)`` sampled every ``dt_s`` [s] within ``[f_min_hz, f_max_hz]``:
    its one-sided periodogram (mean removed, rectangular window) summed over the bins in the
    band, each times ``|W(f)|^2`` of the ISO 2631-1 ``weighting`` if given. Over all bins it is
    the variance (Parseval).

    The rectangular window suits a road of superposed harmonics of fixed amplitudes: over a
    long record their powers add up almost exactly. A Hann window (less leakage from the jump
    between the record's ends) weighs the record's middle and lets the beats between
    neighbouring harmonics through: on the valves problem it spread the realisations' RMS
    stroke by 5 to 10 % instead of 1 to 2 %, and taking out the end-to-end ramp (the jump)
    moved the rectangular result by less than the spread.
    """
    n = signal.size
    spectrum = np.fft.rfft(signal - signal.mean())
    f = np.fft.rfftfreq(n, dt_s)
    power = 2.0 * np.abs(spectrum) ** 2 / n**2
    power[0] *= 0.5
    if n % 2 == 0:
        power[-1] *= 0.5
    keep = (f >= f_min_hz) & (f <= f_max_hz)
    gain = weighting_gain_squared(f[keep], weighting) if weighting else 1.0  # type: ignore[arg-type]
    return float(np.sum(gain * power[keep]))


def output_signal(output: Output, response: TimeResponse) -> NDArray[np.float64]:
    """One of :func:`hisopt.coupled.response.standard_outputs` read from a simulated record by
    the evaluator's own definition, ``sum_p s^p (c_p X + d_p z_g)``, ``(n_t,)``."""
    assert not output.d[2:].any()  # no output reads the road's acceleration
    motion = (response.displacement, response.velocity, response.acceleration)
    road = (response.road_m, RoadInput(response.t_s, response.road_m, "cubic").sampled_rate())
    total = np.zeros(response.t_s.size)
    for p in range(output.c.shape[0]):
        total = total + motion[p] @ output.c[p][:7] + (road[p] @ output.d[p] if p < 2 else 0.0)
    return total


def response_mean_squares(problem: Problem, response: TimeResponse, settle_s: float) -> NDArray[np.float64]:
    """Band mean squares of :data:`FIGURES` (``sigma_aw`` as its square) of a simulated
    ``response`` after ``settle_s`` [s], each output built from the motion by the evaluator's own
    definition (:func:`hisopt.coupled.response.standard_outputs`: ``sum_p s^p (c_p X + d_p z_g)``)."""
    keep = response.t_s >= response.t_s[0] + settle_s
    dt = float(response.t_s[1] - response.t_s[0])
    band = problem.spec.band
    outputs = standard_outputs(problem.vehicle)

    def signal(name: str) -> NDArray[np.float64]:
        return output_signal(outputs[name], response)[keep]

    def mean_square(x: NDArray[np.float64], weighting: str | None = None) -> float:
        return band_mean_square(x, dt, band.f_min_hz, band.f_max_hz, weighting)

    flows = response.valve_flow_m3s[keep]
    comfort = problem.spec.comfort
    aw = sum(getattr(comfort, f"k_{axis}") ** 2 * mean_square(signal(name), outputs[name].weighting) for axis, name in COMFORT_OUTPUTS.items())
    return np.array(
        [
            np.mean([mean_square(flows[:, j]) for j in range(flows.shape[1])]) if flows.shape[1] else np.nan,
            mean_square(signal("stroke_fl")),
            mean_square(signal("tire_load_fl")),
            aw,
        ]
    )


AGREEMENT_DESIGNS = {
    "D1": {"p0": 1.0e6, "dA": 4e-4, "lam": 0.1, "orifice_diameter": 6e-3, "cracking_pressure": 1.5e6},
    "D2": {"p0": 2.0e6, "dA": 1e-3, "lam": 0.5, "orifice_diameter": 6e-3, "cracking_pressure": 1.5e6},
    "D3": {"p0": 2.0e6, "dA": 1e-3, "lam": 0.5, "orifice_diameter": 4.5e-3, "cracking_pressure": 1.5e6},
    "D4": {"p0": 2.0e6, "dA": 1e-3, "lam": 0.5, "orifice_diameter": 3e-3, "cracking_pressure": 0.8e6},
    "D5": {"p0": 3.0e6, "dA": 1e-3, "lam": 0.5, "orifice_diameter": 2.5e-3, "cracking_pressure": 1.5e6},
    "D6": {"p0": 2.0e6, "dA": 1e-3, "lam": 0.5, "orifice_diameter": 2.5e-3, "cracking_pressure": 4e6},
}
"""The designs of the valves problem the agreement is measured on (SI; docs/model.md §3.10,
``benchmarks/bench_valve_agreement.py``, ``tests/test_valve_agreement.py``). On its city road
(``tests/data/valves_one_road.toml``) their front equivalent resistances are about 1.4e8,
4.4e8, 1.1e9, 2.9e9 and 5.1e9 Pa s/m^3; D6 (5.5e9) has D5's orifice, p0 2 MPa and the
blow-off at the box's top, which it hardly reaches (its crossover flow is 3.5 RMS flows): a
bleed orifice alone."""


@dataclass(frozen=True)
class Agreement:
    """One design's frequency- and time-domain figures (:data:`FIGURES`) on its problem's road.

    Attributes
    ----------
    valves : tuple[str, ...]
        [-] each damper valve's label
    resistance : np.ndarray
        [Pa s m^-3] each valve's equivalent resistance on the road, ``(n_valves,)``
    frequency_domain : np.ndarray
        the evaluator's figures (RMS; ``sigma_aw`` in m/s^2), ``(4,)``
    nonlinear, linear : np.ndarray
        band mean squares of the nonlinear and the linear simulation per realisation (each the
        mean of the road and its mirror), ``(n_realisations, 4)``
    simulated_s : float
        [s] simulated time per realisation and mirror, the settling time included
    effective_resistance : np.ndarray
        [Pa s m^-3] each valve's ``E[q dp] / E[q^2]`` over the nonlinear runs' kept records: the
        linear resistance that dissipates what the valve dissipated on the simulated flows (the
        equivalent resistance is this for a Gaussian flow), ``(n_valves,)``
    """

    valves: tuple[str, ...]
    resistance: NDArray[np.float64]
    frequency_domain: NDArray[np.float64]
    nonlinear: NDArray[np.float64]
    linear: NDArray[np.float64]
    simulated_s: float
    effective_resistance: NDArray[np.float64]

    def gap(self, mode: str = "nonlinear") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """[-] The time domain's RMS over the frequency domain's, minus 1, per figure, and its
        standard error: the spread of the realisations' mean squares over ``sqrt(n)``, halved
        for the square root (delta method). ``mode``: ``"nonlinear"`` or ``"linear"``."""
        ms = self.nonlinear if mode == "nonlinear" else self.linear
        mean = ms.mean(axis=0)
        rms = np.sqrt(mean)
        return rms / self.frequency_domain - 1.0, _spread(ms) / (2.0 * mean) * rms / self.frequency_domain

    def corrected_gap(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """[-] The control-variate estimate of :meth:`gap`: ``sqrt(MS_nonlinear / MS_linear) - 1``
        on the same roads (ratio of the mean mean squares; the linear simulation's expectation is
        the frequency domain's), and its standard error (the spread of
        ``MS_nonlinear - R MS_linear`` over ``sqrt(n)``, delta method)."""
        ratio = self.nonlinear.mean(axis=0) / self.linear.mean(axis=0)
        error = _spread(self.nonlinear - ratio * self.linear) / self.linear.mean(axis=0)
        return np.sqrt(ratio) - 1.0, error / (2.0 * np.sqrt(ratio))


def _spread(samples: NDArray[np.float64]) -> NDArray[np.float64]:
    """Standard error of the mean of ``samples`` ``(n, k)`` over their first axis (NaN for n = 1)."""
    n = samples.shape[0]
    if n < 2:
        return np.full(samples.shape[1], np.nan)
    return samples.std(axis=0, ddof=1) / np.sqrt(n)


def frequency_domain_figures(problem: Problem, design: Any) -> tuple[NDArray[np.float64], Any]:
    """The evaluator's :data:`FIGURES` for one design (RMS over the band, the valves' RMS flows
    pooled as their mean square) and its :class:`~hisopt.evaluation.valve_states.ValveStates`."""
    x = problem.design_matrix(design)
    if len(x) != 1:
        raise ConfigError(f"expected one design, got {len(x)}")
    if problem.spec.comfort.method != "filter":
        raise ConfigError("[comfort] method: the time-domain comparison weights the spectrum by the filter weightings; expected method = 'filter'")
    values = Evaluator(problem, names=tuple(FREQUENCY_DOMAIN_METRICS.values()))(x)
    states = valve_states(problem, x)
    flow = float(np.sqrt(np.mean(states.flow_rms[0] ** 2))) if states.labels else np.nan
    return np.array([flow, *(float(values[FREQUENCY_DOMAIN_METRICS[f]][0]) for f in FIGURES[1:])]), states


def road_realisation(problem: Problem, t_s: ArrayLike, seed: int, index: int) -> NDArray[np.float64]:
    """[m] Realisation ``index`` of ``problem``'s road at the four wheels on the uniform grid
    ``t_s`` (:func:`hisopt.road.random_profile` over the problem's band, its coherence and the
    wheelbase delay), from the generator seeded ``(seed, index)``: deterministic."""
    spec, v = problem.spec, problem.vehicle
    rng = np.random.default_rng([seed, index])
    road, band = spec.road, spec.band
    return random_profile(t_s, road.road_class, road.speed, v.wheelbase, rng, band.f_min_hz, band.f_max_hz, road.coherence, v.t_f + v.t_r)


def road_agreement(
    problem: Problem,
    design: Any,
    realisations: int = 4,
    duration_s: float = 30.0,
    settle_s: float = 5.0,
    seed: int = 39,
    method: SolverMethod = "RK45",
    rtol: float = 1e-4,
) -> Agreement:
    """Simulate one ``design`` of ``problem`` on ``realisations`` random roads (each with its
    mirror) and collect :data:`FIGURES` in both domains (the module docstring).

    Parameters
    ----------
    problem
        A problem with physical damper valves (or without: the valve flow is then NaN).
    design
        One design (any form :meth:`~hisopt.specification.design_space.DesignSpace.design_matrix` takes).
    realisations
        [-] Number of seeded road realisations.
    duration_s, settle_s
        [s] Record kept per simulation, and the settling time simulated before it.
    seed
        [-] Seed of the realisations (realisation ``i`` uses ``(seed, i)``).
    method, rtol
        Integrator and relative tolerance of :func:`~hisopt.simulation.timedomain.simulate`
        (``"LSODA"`` for designs whose valves lock the struts: stiff).

    Returns
    -------
    Agreement
    """
    frequency_domain, states = frequency_domain_figures(problem, design)
    model: CoupledModel = problem.model(problem.design_matrix(design))
    f_max = problem.spec.band.f_max_hz
    dt = 1.0 / (5.0 * f_max)  # five samples per period of the band's top: the cubic road holds its shape
    t = np.arange(int(round((settle_s + duration_s) / dt))) * dt
    nonlinear, linear = np.zeros((realisations, len(FIGURES))), np.zeros((realisations, len(FIGURES)))
    power, flow_square = np.zeros(len(states.labels)), np.zeros(len(states.labels))  # sums of q dp and q^2
    for i in range(realisations):
        road = road_realisation(problem, t, seed, i)
        for mirror in (1.0, -1.0):
            z = road * np.array([1.0, mirror, 1.0, mirror])
            for mode, out in (("nonlinear", nonlinear), ("linear", linear)):
                response = simulate(model, t, z, mode, interpolation="cubic", method=method, rtol=rtol)  # type: ignore[arg-type]
                out[i] += 0.5 * response_mean_squares(problem, response, settle_s)
                if mode == "nonlinear":
                    q = response.valve_flow_m3s[t >= settle_s]
                    power += np.sum(q * response.valve_drop_pa[t >= settle_s], axis=0)
                    flow_square += np.sum(q * q, axis=0)
    with np.errstate(invalid="ignore"):
        effective = power / flow_square
    return Agreement(states.labels, states.resistance[0], frequency_domain, nonlinear, linear, float(t[-1] + dt), effective)


__all__ = [
    "AGREEMENT_DESIGNS",
    "FIGURES",
    "Agreement",
    "band_mean_square",
    "frequency_domain_figures",
    "output_signal",
    "response_mean_squares",
    "road_agreement",
    "road_realisation",
]
