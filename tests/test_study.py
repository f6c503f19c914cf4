"""Multi-seed studies: the O(n log n) non-dominated filter and the merge of the seeds' fronts."""

from __future__ import annotations

import subprocess
import sys
import tracemalloc

import numpy as np
import pandas as pd

from hisopt.io import read_csv
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.study import SUMMARY_COLUMNS, study
from tests.conftest import DEFAULT_PROBLEM


def quadratic_mask(f: np.ndarray) -> np.ndarray:
    """The former (n, n)-matrix implementation: no row dominates it; of equal rows the first."""
    n = len(f)
    weak = np.ones((n, n), dtype=bool)
    for j in range(f.shape[1]):
        weak &= f[:, None, j] <= f[None, :, j]
    strict = weak & ~weak.T
    earlier_equal = np.tril(weak & weak.T, k=-1)
    return ~(strict.any(axis=0) | earlier_equal.any(axis=1))


def random_sets(rng: np.random.Generator):
    """Objective sets with ties, duplicates and NaN rows, small and past moocore's naive size."""
    for n in (1, 2, 7, 40, 300, 2500):
        for k in (1, 2, 3, 4, 5):
            yield rng.integers(0, 5, size=(n, k)).astype(float)  # coarse grid: many ties
            g = rng.random((n, k))
            g = np.round(g / g.sum(axis=1, keepdims=True), 2)  # near a simplex: large front, duplicates
            yield g
            h = np.vstack([g, g[rng.integers(0, n, n // 3 + 1)]])[rng.permutation(n + n // 3 + 1)]
            h[rng.integers(0, len(h), 2)] = np.nan
            yield h


def test_non_dominated_mask_equals_the_quadratic_definition(rng):
    count = 0
    for f in random_sets(rng):
        assert np.array_equal(non_dominated_mask(f), quadratic_mask(f)), f.shape
        count += 1
    assert count == 90
    assert non_dominated_mask(np.empty((0, 4))).shape == (0,)


def test_non_dominated_mask_memory_is_linear():
    # 20 000 rows: one (n, n) boolean matrix alone would be 400 MB
    rng = np.random.default_rng(5)
    f = rng.random((20_000, 4))
    f /= f.sum(axis=1, keepdims=True)
    tracemalloc.start()
    try:
        mask = non_dominated_mask(f)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert mask.all()
    assert peak < 20 * f.nbytes


def test_study_front_is_the_non_dominated_set_of_the_union(problem, tmp_path):
    reports: list[dict] = []
    result = study(problem, [3, 1, 2], out=tmp_path, pop_size=12, generations=3, progress=reports.append)
    objectives = list(problem.objective_names)
    fronts = [read_csv(tmp_path / f"seed-{s}" / "front.csv").assign(seed=s) for s in (3, 1, 2)]
    union = pd.concat(fronts, ignore_index=True)
    expected = union[quadratic_mask(union[objectives].to_numpy())]
    expected = expected.sort_values(objectives + ["seed"], kind="stable").reset_index(drop=True)
    got = result.front
    np.testing.assert_array_equal(got[objectives].to_numpy(), expected[objectives].to_numpy())
    np.testing.assert_array_equal(got["seed"].to_numpy(), expected["seed"].to_numpy())
    assert len(got) < len(union)  # the merge did remove dominated designs
    # one progress report per seed, with the summary's columns; the summary stays in seed order
    assert sorted(r["seed"] for r in reports) == [1, 2, 3]
    assert all(tuple(r) == SUMMARY_COLUMNS for r in reports)
    assert list(result.runs["seed"]) == [3, 1, 2]
    assert list(result.runs["front_size"]) == [len(f) for f in fronts]


def test_cli_study_reports_each_seed(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "study", str(DEFAULT_PROBLEM), "--seeds", "1-2", "--pop", "12", "--gens", "2"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("seed ")]
    assert [line.split()[1] for line in lines] == ["1", "2"]
    assert "(2 of 2): front of" in lines[1] and "decades^4" in lines[1] and lines[1].endswith(" s")
    assert "merged front of" in proc.stdout
