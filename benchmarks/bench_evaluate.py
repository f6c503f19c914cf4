"""Throughput of the fast evaluator against a straightforward one, side by side.

Baseline: the straightforward evaluator, written here in plain numpy: the lumped model's
``K`` and ``C`` (HIS included, ``D(s) = K_his + s C_his``), ``s^2 M + s C + K`` on a plain
1000-point log grid (0.5-80 Hz), one batched ``numpy.linalg.solve`` for all designs and
frequencies, the same outputs, road spectra and ISO weightings, trapezoid integrals and
sample maxima. Fast: ``problem.evaluate`` (pole-residue evaluation on
a pole-aware Gauss-Legendre grid with refined maxima). Also prints each method's largest
relative error against a converged reference on a few designs, so speed is never bought with
accuracy.

    python benchmarks/bench_evaluate.py [--designs 2000] [--problem problems/roll_plane_his.toml]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import hisopt
from hisopt.evaluate import Evaluator, grid_quantities
from hisopt.metrics import COMFORT_OUTPUTS
from hisopt.quadrature import base_edges
from hisopt.standards.iso_2631_1_1997 import weighting_gain_squared
from hisopt.vehicle import damping_matrix, mass_matrix, road_stiffness_input, stroke_matrix

ROOT = Path(__file__).resolve().parents[1]


def converged_grid(problem: hisopt.Problem, x: np.ndarray) -> np.ndarray:
    """[Hz] a very fine grid: dense log spacing plus tan-clustered points around every mode."""
    band = problem.spec.band
    lam = np.linalg.eigvals(problem.model(x[None]).state_space().a[0])
    parts = [np.geomspace(band.f_min_hz, band.f_max_hz, 100_001)]
    theta = np.linspace(-np.pi / 2, np.pi / 2, 8001)[1:-1]
    for pole in lam[lam.imag > 1e-6]:
        f_d, b = pole.imag / (2 * np.pi), max(-pole.real / (2 * np.pi), 1e-9)
        parts.append(f_d + b * np.tan(theta))
    f = np.concatenate(parts)
    return np.unique(f[(f >= band.f_min_hz) & (f <= band.f_max_hz)])


def output_frf(output, h_x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``sum_p s^p (c_p H_X + d_p)`` with plain numpy products."""
    terms = [p for p in range(output.c.shape[0]) if np.any(output.c[p]) or np.any(output.d[p])]
    return sum(s[:, None] ** p * (output.c[p] @ h_x + output.d[p]) for p in terms)


def baseline(problem: hisopt.Problem, evaluator: Evaluator, x: np.ndarray, f_hz: np.ndarray, chunk: int = 16) -> dict[str, np.ndarray]:
    """Straightforward evaluation: dense solve on a fixed grid (lumped, no-pipe model)."""
    v = problem.spec.vehicle
    m, g, b0 = mass_matrix(v), stroke_matrix(v), road_stiffness_input(v)
    s = 2j * np.pi * f_hz
    names = list(evaluator.outputs)
    out: dict[str, list[np.ndarray]] = {name: [] for name in evaluator.names}
    for i in range(0, len(x), chunk):
        model = problem.model(x[i : i + chunk])
        k = model.stiffness()  # K + G^T K_his G
        w0 = 2 * np.pi  # C_his from D(j w0) = K_his + j w0 C_his
        c = damping_matrix(v) + g.T @ (model.his.stroke_impedance(np.array([1j * w0]))[:, 0].imag / w0) @ g
        kdyn = s[None, :, None, None] ** 2 * m + s[None, :, None, None] * c[:, None] + k[:, None]
        h_x = np.linalg.solve(kdyn, np.broadcast_to(b0, kdyn.shape[:-1] + (4,)))
        h_out = np.stack([output_frf(evaluator.all_outputs[n], h_x, s) for n in names], axis=-1)
        psd = evaluator.spectra(np.broadcast_to(f_hz, (len(k), f_hz.size)), h_out)
        spectra = {n: psd[..., j] for j, n in enumerate(names)}
        for metric in evaluator.metrics:
            if metric.kind == "comfort":
                ms = sum(np.trapezoid(weighting_gain_squared(f_hz, evaluator.outputs[o].weighting) * spectra[o], f_hz, axis=1)
                         for o in COMFORT_OUTPUTS.values())
                out[metric.name].append(np.sqrt(ms))
            else:
                out[metric.name].append(spectra[metric.output].max(axis=1))
    return {k: np.concatenate(v) for k, v in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--problem", default=str(ROOT / "problems" / "roll_plane_his.toml"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    problem = hisopt.load_problem(args.problem)
    rng = np.random.default_rng(0)
    x = problem.lower + (problem.upper - problem.lower) * rng.random((args.designs, len(problem.lower)))
    band = problem.spec.band
    grid = np.geomspace(band.f_min_hz, band.f_max_hz, 1000)
    evaluator = Evaluator(problem)
    evaluator(x[:8])  # warm-up

    def best_of(fn) -> float:
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times)

    n_base = min(args.designs, 400)  # the baseline is slow; time it on a subset
    t_fast = best_of(lambda: evaluator(x))
    t_base = best_of(lambda: baseline(problem, evaluator, x[:n_base], grid))
    fast_rate, base_rate = args.designs / t_fast, n_base / t_base
    print(f"problem: {problem.name}, objectives: {', '.join(evaluator.names)}")
    print(f"fast evaluator     : {fast_rate:10.0f} designs/s  ({args.designs} designs, best of {args.repeats})")
    print(f"baseline (1000-pt) : {base_rate:10.0f} designs/s  ({n_base} designs, best of {args.repeats})")
    print(f"speed-up           : {fast_rate / base_rate:10.1f} x")

    # Accuracy against a converged reference, including the box corners.
    corners = np.array(np.meshgrid(*[[0, 1]] * x.shape[1], indexing="ij")).reshape(x.shape[1], -1).T
    check = np.vstack([x[:4], problem.lower + (problem.upper - problem.lower) * corners[[0, 5, 10, 15]]])
    ref = {k: np.concatenate([grid_quantities(problem, c[None], converged_grid(problem, c))[k] for c in check]) for k in evaluator.names}
    fast = evaluator(check)
    base = baseline(problem, evaluator, check, grid)
    for name in evaluator.names:
        e_fast = np.max(np.abs(fast[name] / ref[name] - 1))
        e_base = np.max(np.abs(base[name] / ref[name] - 1))
        print(f"max rel. error {name:18s}: fast {e_fast:8.1e}   baseline {e_base:8.1e}")
    print(f"nodes per design (fast): {base_edges(band.f_min_hz, band.f_max_hz).size} base edges + pole panels")


if __name__ == "__main__":
    main()
