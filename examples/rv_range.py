"""How far the paper's valve coefficient Rv moves the paper's four indicators: across its box
(0 to 1.6e6 Pa s/m^3, paper Table 2) and across the range of real damper valves (1e8 to 1e10
Pa s/m^3, ../shared/HARDWARE.md), at the paper's baseline design (README, "Real damper valves").

    python examples/rv_range.py
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from hisopt import problem_from_dict

ROOT = Path(__file__).resolve().parents[1]


RANGES = {"paper box 0-1.6e6": np.linspace(0.0, 1.6e6, 33), "real valves 1e8-1e10": np.geomspace(1e8, 1e10, 41)}
"""[Pa s m^-3] The Rv values swept, by range."""


def spreads() -> dict[str, dict[str, float]]:
    """[-] Per range of :data:`RANGES`, each indicator's largest over smallest value minus 1."""
    data = tomllib.loads((ROOT / "problems" / "roll_plane_his.toml").read_text(encoding="utf-8"))
    data["variables"]["Rv"] = {"lower": 0.0, "upper": 1e10, "unit": "Pa s m^-3"}  # room for real valves
    problem = problem_from_dict(data, "roll_plane_his.toml with Rv up to 1e10")
    column = list(problem.variable_names).index("Rv")
    out = {}
    for label, values in RANGES.items():
        x = np.tile(problem.baseline, (len(values), 1))
        x[:, column] = values
        frame = problem.evaluate(x, log=False)
        out[label] = {n: float(frame[n].max() / frame[n].min() - 1) for n in problem.objective_names}
    return out


def main() -> None:
    for label, moves in spreads().items():
        print(f"Rv over {label} Pa s/m^3 (largest / smallest - 1): " + ", ".join(f"{n} {m:+.2%}" for n, m in moves.items()))


if __name__ == "__main__":
    main()
