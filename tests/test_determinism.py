"""The determinism contract (docs/model.md) on any BLAS and any thread count.

- same problem, seed and installation: identical front and archive files (timing aside),
  whether BLAS runs on one thread or two;
- a stored design re-evaluated alone or in any batch: within 1e-12 relative of its stored
  objectives (not bit for bit);
- Dask against serial: within 1e-12 relative (tests/test_parallel.py).
Resume after SIGKILL or Ctrl-C is tests/test_resume.py. Each run here is a real process with
``OPENBLAS_NUM_THREADS`` set before numpy loads.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from hisopt.io import read_csv
from tests.conftest import ROOT

HANDLING_PROBLEM = ROOT / "problems" / "roll_plane_his_handling.toml"
ARGS = ("--pop", "16", "--gens", "6", "--seed", "5")
TIMING_COLUMNS = ("elapsed_s",)
pytestmark = pytest.mark.slow  # real processes, about 20 s together

REEVALUATE = """
import sys
import numpy as np
import hisopt
from hisopt.io import read_csv
problem = hisopt.load_problem(sys.argv[1])
front = read_csv(sys.argv[2])
names = list(dict.fromkeys(problem.objective_names + problem.constraint_names))
x = front[list(problem.variable_names)].to_numpy()
stored = front[names].to_numpy()
rng = np.random.default_rng(0)
batches = [np.arange(len(x)), rng.permutation(len(x)), np.r_[rng.permutation(len(x)), 0, 1]]
batches += [np.array([i]) for i in range(min(len(x), 5))]
worst = max(float(np.max(np.abs(problem.evaluate(x[i])[names].to_numpy() / stored[i] - 1.0))) for i in batches)
print(worst)
"""


def _env(threads: int) -> dict[str, str]:
    env = dict(os.environ)
    env.update({"OPENBLAS_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads)})
    return env


def _optimize(out: Path, threads: int) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "optimize", str(HANDLING_PROBLEM), "--out", str(out), *ARGS],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env=_env(threads),
    )
    assert proc.returncode == 0, proc.stderr


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("determinism")
    out = {}
    for key, threads in (("1a", 1), ("1b", 1), ("2a", 2), ("2b", 2)):
        _optimize(base / key, threads)
        out[key] = base / key
    return out


def _same_files(a: Path, b: Path) -> None:
    assert (a / "front.csv").read_bytes() == (b / "front.csv").read_bytes()
    assert pd.read_parquet(a / "evaluations.parquet").equals(pd.read_parquet(b / "evaluations.parquet"))
    ga, gb = read_csv(a / "generations.csv"), read_csv(b / "generations.csv")
    keep = [c for c in ga.columns if c not in TIMING_COLUMNS]
    assert ga[keep].equals(gb[keep])
    assert (a / "checkpoint.npz").is_file() and (b / "checkpoint.npz").is_file()


@pytest.mark.parametrize("pair", [("1a", "1b"), ("2a", "2b"), ("1a", "2a")], ids=["1-thread", "2-threads", "1-vs-2"])
def test_same_seed_gives_identical_files(runs, pair):
    _same_files(runs[pair[0]], runs[pair[1]])


@pytest.mark.parametrize("threads", [1, 2])
def test_stored_front_reevaluates_within_1e12_alone_and_in_any_batch(runs, threads):
    proc = subprocess.run(
        [sys.executable, "-c", REEVALUATE, str(HANDLING_PROBLEM), str(runs[f"{threads}a"] / "front.csv")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env=_env(threads),
    )
    assert proc.returncode == 0, proc.stderr
    assert float(proc.stdout.strip()) <= 1e-12
    assert len(read_csv(runs[f"{threads}a"] / "front.csv")) > 1
