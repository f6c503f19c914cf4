"""Remake examples/left_side_drop_measured.csv, a SYNTHETIC drop-test record.

It is not a measurement. hisopt simulates the left-side drop test (paper Section VI) of
problems/roll_plane_his.toml at p0 = 2 MPa from 50 mm blocks, records the eight
accelerometers at 200 Hz (docs/droptest.md, "Measured records"), adds white noise of 2 % of
the peak body acceleration (seed 3) and gravity on the body sensors (DC-coupled
accelerometers read +9.81 m/s^2 at rest). The file stands in for a real record, so that the
README's ``hisopt droptest --measured`` command runs as written; tests/test_readme.py checks
that this script reproduces it. From the repository root::

    python examples/make_measured_example.py [OUT.csv]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import hisopt

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "examples" / "left_side_drop_measured.csv"
PROBLEM = ROOT / "problems" / "roll_plane_his.toml"
P0_PA = 2.0e6
NOISE = 0.02  # [-] of the peak body acceleration
SEED = 3
GRAVITY = 9.81  # [m/s^2]

HEADER = f"""\
# SYNTHETIC drop-test record, NOT a measurement: made by examples/make_measured_example.py
# (hisopt {hisopt.__version__}). Left-side drop of problems/roll_plane_his.toml, p0 = {P0_PA / 1e6:g} MPa
# (gauge), 0.05 m blocks, simulated, sampled at 200 Hz; plus white noise of {100 * NOISE:g} % of the
# peak body acceleration (seed {SEED}) and {GRAVITY} m/s^2 gravity on the body sensors.
# Units: time [s]; body_* and wheel_* vertical acceleration [m/s^2], z up (docs/droptest.md).
"""


def write_example(path: Path = OUT) -> Path:
    """Simulate, add noise and gravity, and write the record with its header comment."""
    problem = hisopt.load_problem(PROBLEM).with_values(p0=P0_PA)
    record = hisopt.response_sensors(hisopt.simulate_drop(problem.model(), "left_side"))
    sensors = [c for c in record.columns if c != "time"]  # body_fl ... wheel_rr
    body = [c for c in sensors if c.startswith("body_")]
    peak = np.abs(record[body].to_numpy()).max()
    rng = np.random.default_rng(SEED)
    record[sensors] += NOISE * peak * rng.standard_normal((len(record), len(sensors)))
    record[body] += GRAVITY
    path.write_text(HEADER + record.to_csv(index=False, float_format="%.6g", lineterminator="\n"), encoding="utf-8")
    return path


if __name__ == "__main__":
    print(f"wrote {write_example(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)}")
