"""Statistical linearisation of a quadratic damper against simulation: one oscillator.

The oscillator of tests/test_statistical_linearisation.py (400 kg on a 1 Hz spring, a 30 mm
piston through a 5 mm orifice; docs/model.md §22.3), under white base acceleration whose PSD
puts the valve's statistical linearisation at each damping ratio ``zeta_eq`` of ``--zetas``.
Per ``zeta_eq``, in one run on the same seeded signals:

- **baseline**: the same oscillator with a linear damper of ``c = c_eq``: its simulated RMS
  velocity over the spectral sum of its signal (the pipeline's own error);
- **quadratic damper**: the simulated RMS velocity (64 or ``--realisations`` realisations,
  standard error), statistical linearisation's figure and stochastic averaging's (both as white
  noise less the band's tail), their ratios, the shape factor ``E|v|^3 / sigma_v^3`` (Gaussian
  1.596, averaging 1.494) and the dissipated power over the band's input power;
- the RMS again at half the step (``--step-check``) for the step-size error.

    python benchmarks/bench_linearisation_sdof.py [--zetas 0.02 0.05 0.1 0.2 0.3] [--realisations 128]
"""

from __future__ import annotations

import argparse
import math
import time

from hisopt.hydraulics.laws import orifice_coefficient
from hisopt.simulation.linearisation_check import (
    SL_TO_AVERAGING_QUADRATIC,
    ValveOscillator,
    averaged_velocity_rms,
    band_tail_velocity_ms,
    discrete_linear_velocity_ms,
    linearised_velocity_rms,
    mean_and_standard_error,
    psd_at_linearised_damping_ratio,
    rms_and_standard_error,
    simulate_oscillator,
    white_noise_input_power,
)

OSCILLATOR = ValveOscillator(mass=400.0, stiffness=400.0 * (2.0 * math.pi) ** 2, area=0.25 * math.pi * 0.030**2, kq=orifice_coefficient(0.005, 0.7, 870.0))
GAUSSIAN_SHAPE = 2.0 * math.sqrt(2.0 / math.pi)


def run_settings(zeta: float, realisations: int) -> dict[str, float | int]:
    """A band of 8 Hz at 0.01 s steps up to ``zeta`` 0.05, 16 Hz at 0.005 s above (the band's
    tail under 2.5 % of the mean square); records of ``40 / zeta_eq`` s for the light ones."""
    f_max, step = (8.0, 0.01) if zeta <= 0.05 else (16.0, 0.005)
    period = max(200.0, 8.0 / zeta)
    return {"f_max_hz": f_max, "period_s": period, "settle_s": 2.0 / zeta, "step_s": step, "realisations": realisations, "seed": 41}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--zetas", type=float, nargs="+", default=[0.02, 0.05, 0.1, 0.2, 0.3])
    parser.add_argument("--realisations", type=int, default=128)
    parser.add_argument("--step-check", type=float, default=0.05, help="zeta_eq at which to rerun at half the step")
    args = parser.parse_args()
    osc = OSCILLATOR
    print(f"oscillator: m {osc.mass:.0f} kg, f_n {osc.natural_frequency / (2 * math.pi):.2f} Hz, c_q {osc.quadratic_damping:.1f} N s^2/m^2")
    print(f"averaging over linearisation (closed form): {SL_TO_AVERAGING_QUADRATIC:.4f}")
    header = (
        f"{'zeta_eq':>7} {'G (m/s^2)^2/Hz':>15} {'lin/sum':>9} {'sim m/s':>8} {'SE %':>6} {'SL m/s':>8} {'avg m/s':>8}"
        f" {'sim/SL':>7} {'sim/avg':>7} {'shape':>6} {'P/P_in':>7} {'CPU s':>6}"
    )
    print(header)
    for zeta in args.zetas:
        psd = psd_at_linearised_damping_ratio(osc, zeta)
        settings = run_settings(zeta, args.realisations)
        tail = band_tail_velocity_ms(psd, float(settings["f_max_hz"]))
        c_eq = 2.0 * zeta * osc.mass * osc.natural_frequency
        linear = ValveOscillator(osc.mass, osc.stiffness, osc.area, kq=0.0, r=c_eq / osc.area**2)
        linear_rms, _ = rms_and_standard_error(simulate_oscillator(linear, psd, **settings).velocity_ms)  # type: ignore[arg-type]
        spectral = math.sqrt(discrete_linear_velocity_ms(linear, c_eq, psd, float(settings["f_max_hz"]), float(settings["period_s"])))
        start = time.process_time()
        runs = simulate_oscillator(osc, psd, **settings)  # type: ignore[arg-type]
        cpu = time.process_time() - start
        rms, se = rms_and_standard_error(runs.velocity_ms)
        sl = math.sqrt(linearised_velocity_rms(osc, psd) ** 2 - tail)
        avg = math.sqrt(averaged_velocity_rms(osc, psd) ** 2 - tail)
        shape = float(runs.abs_velocity_cubed.mean() / runs.velocity_ms.mean() ** 1.5)
        power, _ = mean_and_standard_error(runs.power)
        p_in = white_noise_input_power(osc.mass, psd) - c_eq * tail
        print(
            f"{zeta:7.3f} {psd:15.4g} {linear_rms / spectral:9.6f} {rms:8.5f} {100 * se / rms:6.3f} {sl:8.5f} {avg:8.5f}"
            f" {rms / sl:7.4f} {rms / avg:7.4f} {shape:6.4f} {power / p_in:7.4f} {cpu:6.2f}"
        )
        if math.isclose(zeta, args.step_check):
            half = rms_and_standard_error(simulate_oscillator(osc, psd, **(settings | {"step_s": float(settings["step_s"]) / 2})).velocity_ms)[0]  # type: ignore[arg-type]
            print(f"        half step: RMS {half:.6f} m/s, {half / rms - 1:+.2e} relative")
    print(f"shape factors: Gaussian {GAUSSIAN_SHAPE:.4f}, averaging {GAUSSIAN_SHAPE / SL_TO_AVERAGING_QUADRATIC**3:.4f}")


if __name__ == "__main__":
    main()
