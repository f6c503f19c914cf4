"""How many designs of the paper's box a charged HIS refuses, against the paper's idealisation.

The idealisation (no oil in the accumulators) refuses none; a charged circuit refuses a design
whose accumulator would hold no oil at rest (docs/model.md §16.3): cold shrinks the oil, and
the struts of a rising car draw it out. Designs are drawn uniformly from the paper's box
(seed 7), each circuit's static state solved at -20 and 60 C, for a few gas fractions at
charge and oil volumes per circuit. Prints the counts and the median dA and p0 of the refused.

    python benchmarks/envelope_refusals.py [--designs 2000]
"""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

import numpy as np

from hisopt.problem import problem_from_dict

ROOT = Path(__file__).resolve().parents[1]


def refused(data: dict, x: np.ndarray) -> np.ndarray:
    """[-] Per design, whether its static state is refused (NaN static pressure)."""
    problem = problem_from_dict(data, warn_implausible=False)
    his = problem.model(x).his
    pressure = his.static_pressure if his.static_pressure is not None else np.zeros((len(x), 1))
    return np.isnan(pressure).any(axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=2000)
    args = parser.parse_args()
    text = (ROOT / "problems" / "roll_plane_his.toml").read_text()
    base = tomllib.loads(text)
    problem = problem_from_dict(base)
    x = problem.lower + np.random.default_rng(7).random((args.designs, len(problem.lower))) * (problem.upper - problem.lower)
    print(f"{args.designs} designs of the paper's box; refused (no oil left in an accumulator at rest)")
    for temperature in (253.15, 333.15):
        data = tomllib.loads(text) | {"temperature": temperature}
        print(f"ideal model at {temperature - 273.15:+.0f} degC: {int(refused(data, x).sum())}")
    for phi in (0.7, 0.8, 0.9, 0.95):
        for oil in (1e-3, 4e-3):
            for temperature in (253.15, 333.15):
                data = tomllib.loads(text) | {"temperature": temperature}
                data["his"]["charge"] = {"gas_fraction": phi, "oil_volume": oil}
                bad = refused(data, x)
                case = f"gas fraction {phi:g}, {oil * 1e3:g} L of oil per circuit, {temperature - 273.15:+.0f} degC"
                line = f"{case}: {int(bad.sum())} ({100 * bad.mean():.1f} %)"
                if bad.any():
                    d_a, p0 = (np.median(x[bad, 1]) * 1e4, np.median(x[:, 1]) * 1e4), (np.median(x[bad, 0]) / 1e6, np.median(x[:, 0]) / 1e6)
                    line += f"; refused median dA {d_a[0]:.2f} cm^2 (all {d_a[1]:.2f}), p0 {p0[0]:.2f} MPa (all {p0[1]:.2f})"
                print(line, flush=True)


if __name__ == "__main__":
    main()
