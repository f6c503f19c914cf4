"""Gradient refinement of Pareto fronts (hisopt.optim.gradient.refine).

Every kept refined design is re-evaluated with the standard evaluator and must weakly
dominate its start; the refined front must be non-dominated and never lose hypervolume. The
acceptance run of the issue (40 generations, population 40, 40 refined designs, >= 1 %
hypervolume gain) is ``test_refinement_gains_hypervolume_on_a_40_by_40_run`` (slow); its
timing is printed here and checked by ``benchmarks/bench_refine.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.io import read_csv
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.gradient.asf_slp import SlpSettings, lp_steps, refine_designs
from hisopt.optim.gradient.casadi_model import CasadiModel
from hisopt.optim.gradient.refine import (
    Part,
    RefineSettings,
    asf_weights,
    refine_front,
    refine_point,
    refine_run,
    select_points,
)
from hisopt.optim.run import optimize
from hisopt.optim.rundir import FRONT_REFINED_CSV, REFINE_JSON, read_front
from tests.conftest import ROOT

HANDLING = ROOT / "problems" / "roll_plane_his_handling.toml"


@pytest.fixture(scope="module", autouse=True)
def compile_cache(tmp_path_factory):
    # compiled CasADi functions go to a test directory, not the user's cache
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HISOPT_CACHE_DIR", str(tmp_path_factory.mktemp("casadi_cache")))
        yield


@pytest.fixture(scope="module")
def small_run(problem):
    return optimize(problem, seed=3, pop_size=20, generations=8, algorithm="nsga2")


def objectives(problem: hisopt.Problem, frame: pd.DataFrame) -> np.ndarray:
    return frame[list(problem.objective_names)].to_numpy(dtype=float)


def check_refined(problem: hisopt.Problem, front: pd.DataFrame, result, rtol: float = 1e-12) -> None:
    """Shared invariants of a refinement result (``rtol``: how far a row's values may move when
    it is evaluated in another batch: the evaluator's rounding, 1e-12)."""
    names = list(problem.objective_names)
    refined = result.front
    assert list(refined.columns) == [*front.columns, "source_index"]
    assert refined["source_index"].between(0, len(front) - 1).all()
    # re-evaluated with the standard evaluator, every row has the values it shows
    q = problem.evaluator()(refined[list(problem.variable_names)])
    for name in problem.objective_names + problem.constraint_names:
        np.testing.assert_allclose(refined[name], q[name], rtol=rtol)
    # every refined row weakly dominates its start, and no row is dominated
    start = objectives(problem, front)[refined["source_index"]]
    f = refined[names].to_numpy()
    assert np.all(f <= start + rtol * np.abs(start))
    assert non_dominated_mask(f).all()
    assert result.hypervolume_after >= result.hypervolume_before
    for row in result.points.itertuples():
        mine = np.array([getattr(row, n) for n in names])
        start_row = objectives(problem, front)[row.source_index]
        assert np.all(mine <= start_row + rtol * np.abs(start_row))
        if row.accepted:
            assert np.any(mine < start_row)
        else:  # not taken: the start's own values, evaluated again
            assert np.all(mine >= start_row - rtol * np.abs(start_row))


def test_select_points_takes_extremes_then_spreads(rng):
    f = 10.0 ** rng.normal(size=(300, 4))
    chosen = select_points(f, 25)
    assert len(chosen) == 25 and np.all(np.diff(chosen) > 0)
    assert set(np.argmin(f, axis=0)) <= set(chosen)
    np.testing.assert_array_equal(chosen, select_points(f, 25))
    np.testing.assert_array_equal(select_points(f[:7], 25), np.arange(7))
    # farthest-point sampling leaves no design far from the chosen ones
    z = np.log10(f)
    z = (z - z.min(0)) / (z.max(0) - z.min(0))
    gap = np.min(np.linalg.norm(z[:, None] - z[None, chosen], axis=2), axis=1).max()
    random_gap = np.min(np.linalg.norm(z[:, None] - z[None, rng.choice(300, 25, replace=False)], axis=2), axis=1).max()
    assert gap < random_gap
    with pytest.raises(hisopt.ConfigError, match="--max-points"):
        select_points(f, 0)


def test_asf_weights_are_reciprocal_log_ranges():
    f = np.array([[1.0, 1e-3, 5.0], [100.0, 1e-2, 5.0]])
    np.testing.assert_allclose(asf_weights(f), [0.5, 1.0, 1.0])


def test_refine_point_improves_an_interior_design(problem):
    # the baseline design is far from the front: refinement must dominate it
    model = CasadiModel(problem)
    x0 = problem.baseline
    q0 = problem.evaluator()(x0[None])
    f0 = np.array([q0[n][0] for n in problem.objective_names])
    result = refine_point(problem, [Part(None, problem, model)], 0, x0, f0, np.ones(4) * 3.0, RefineSettings())
    assert result.accepted and result.merit < -1e-3
    q = problem.evaluator()(result.x[None])
    f = np.array([q[n][0] for n in problem.objective_names])
    assert np.all(f <= f0) and np.any(f < f0)
    assert np.all((result.x >= problem.lower) & (result.x <= problem.upper))


def test_peak_search_of_all_peaks_at_once_equals_one_search_per_peak(problem, rng):
    # node_plan searches every PSD peak in one batch: each bracket must give what its own
    # refine_maximum on that output's PSD gives (the FRF is frequency by frequency), exactly
    from hisopt.evaluation.channels import DirectOutputs
    from hisopt.evaluation.peaks import refine_maximum
    from hisopt.optim.gradient.asf_nlp import peak_locations

    ev = problem.evaluator()
    x = problem.lower + (problem.upper - problem.lower) * rng.uniform(0.1, 0.9, problem.lower.size)
    frf = DirectOutputs(problem.model(x[None]), ev.outputs)
    n_out = len(ev.outputs)
    outputs = np.arange(6) % n_out
    lo = rng.uniform(0.5, 15.0, 6)
    hi = lo * rng.uniform(1.05, 1.5, 6)
    found = peak_locations(frf, ev, outputs, lo, hi)
    for j, a, b, got in zip(outputs, lo, hi, found, strict=True):

        def values_at(pts, j=j):
            return ev.spectra(pts, frf(2 * np.pi * pts, int(j)))[..., 0]

        f = np.linspace(a, b, 9)[None, :]
        assert got == refine_maximum(values_at, f, values_at(f), 12)[0][0]
        assert a <= got <= b
        # the search keeps the best sample: no bracket sample is higher than the peak found
        assert values_at(np.array([[got]]))[0, 0] >= values_at(f).max()
    assert peak_locations(frf, ev, np.zeros(0, dtype=int), np.zeros(0), np.zeros(0)).size == 0


@pytest.mark.parametrize("method", ["slp", "ipopt"])
def test_refine_front_keeps_only_dominating_designs(problem, small_run, method):
    front = small_run.front
    result = refine_front(problem, front, max_points=6, method=method)
    assert len(result.points) == min(6, len(front))
    check_refined(problem, front, result)
    assert result.points["accepted"].any()


def test_refinement_on_a_dask_cluster_equals_serial(problem, small_run):
    from hisopt.evaluation.parallel import open_backend

    serial = refine_front(problem, small_run.front, max_points=3)
    with open_backend(workers=2) as backend:
        distributed = refine_front(problem, small_run.front, max_points=3, backend=backend)
    pd.testing.assert_frame_equal(serial.front, distributed.front)


def test_refinement_respects_the_problem_constraints():
    problem = hisopt.load_problem(HANDLING)
    run = optimize(problem, seed=2, pop_size=20, generations=6, algorithm="nsga2")
    result = refine_front(problem, run.front, max_points=5)
    check_refined(problem, run.front, result)
    for c in problem.spec.constraints:
        assert (result.front[c.name] <= c.limit).all(), c.name


def test_refine_run_and_cli_write_the_refined_front(problem, tmp_path):
    run_dir = tmp_path / "run"
    optimize(problem, out=run_dir, seed=5, pop_size=16, generations=5, algorithm="nsga2")
    front = read_front(run_dir / "front.csv")
    result = refine_run(run_dir, max_points=3)
    written = read_csv(run_dir / FRONT_REFINED_CSV)
    assert list(written.columns) == [*front.columns, "source_index", "on_bound"]  # read_front drops front.csv's marks
    np.testing.assert_allclose(written[list(problem.objective_names)], result.front[list(problem.objective_names)], rtol=1e-15)
    summary = json.loads((run_dir / REFINE_JSON).read_text())
    assert summary["points"] == 3 and summary["hypervolume_after"] >= summary["hypervolume_before"]
    (run_dir / FRONT_REFINED_CSV).unlink()
    out = subprocess.run(
        [sys.executable, "-m", "hisopt", "refine", str(run_dir), "--max-points", "2", "--workers", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    assert "hypervolume" in out.stdout and (run_dir / FRONT_REFINED_CSV).is_file()
    bad = subprocess.run([sys.executable, "-m", "hisopt", "refine", str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "not a run directory" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.slow
@pytest.mark.parametrize("name", ["roll_plane_his_chamber", "roll_plane_his_pipes"])
def test_refine_runs_on_chamber_and_distributed_pipe_problems(tmp_path, name):
    """The CasADi model is built from the same core as the evaluator: every problem refines."""
    import subprocess
    import sys

    from hisopt.io import read_csv

    run_dir = tmp_path / name
    env = dict(os.environ)
    for args in (
        ("optimize", str(ROOT / "problems" / f"{name}.toml"), "--out", str(run_dir), "--pop", "16", "--gens", "4", "--seed", "2"),
        # six points: the first four are the front's extremes (each the least of one objective),
        # which a dominating design rarely beats; the other two are interior designs
        ("refine", str(run_dir), "--max-points", "6"),
    ):
        done = subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)
        assert done.returncode == 0, done.stderr
    problem = hisopt.load_problem(ROOT / "problems" / f"{name}.toml")
    front = read_csv(run_dir / "front.csv")
    summary = json.loads((run_dir / "refine.json").read_text())
    assert summary["hypervolume_after"] > summary["hypervolume_before"]
    refined = read_csv(run_dir / "front_refined.csv")
    start = objectives(problem, front)[refined["source_index"]]
    assert np.all(objectives(problem, refined) <= start * (1 + 1e-12))  # no point worse than its start
    assert summary["accepted"] >= 1


@pytest.mark.slow
def test_refinement_gains_hypervolume_on_a_40_by_40_run(problem):
    run = optimize(problem, seed=1, pop_size=40, generations=40, algorithm="nsga2")
    started = time.perf_counter()
    result = refine_front(problem, run.front, max_points=40, reference_log=run.reference_point)
    seconds = time.perf_counter() - started
    print(
        f"\nrefined {int(result.points['accepted'].sum())}/{len(result.points)} designs of a {len(run.front)}-design front: "
        f"hypervolume {result.hypervolume_before:.6g} -> {result.hypervolume_after:.6g} "
        f"({100 * result.hypervolume_gain:+.2f} %), {seconds / len(result.points):.2f} s per design"
    )
    assert len(result.points) == 40
    assert result.hypervolume_before == pytest.approx(run.hypervolume, rel=1e-12)
    assert result.hypervolume_gain >= 0.01
    check_refined(problem, run.front, result)


def test_optimize_with_refine_flag_writes_refined_front(tmp_path):
    import subprocess
    import sys

    from tests.conftest import DEFAULT_PROBLEM

    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "optimize", str(DEFAULT_PROBLEM), "--out", str(out), "--pop", "12", "--gens", "3", "--refine", "--max-points", "2"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    refined = read_csv(out / "front_refined.csv")
    front = read_csv(out / "front.csv")
    assert list(refined.columns) == [c for c in front.columns if c != "on_bound"] + ["source_index", "on_bound"]
    assert refined["source_index"].between(0, len(front) - 1).all()


# --- the batched SLP (hisopt.optim.gradient.asf_slp) -----------------------------------------
# HiGHS meets its primal and dual feasibility tolerances (1e-7) on data of order 1: optimal
# objective values of the same programme, however batched, agree within about 1e-6.
LP_TOLERANCE = 1e-6
LP_FEASIBILITY = 1e-7  # HiGHS's primal feasibility tolerance: how far a bound or row may be exceeded


def test_batched_linear_programme_equals_one_per_design(rng):
    n, k, m, c = 6, 4, 4, 2
    gap = -rng.random((n, k)) * 0.1
    jac = rng.normal(size=(n, k, m))
    con = -rng.random((n, c))
    con_jac = rng.normal(size=(n, c, m))
    u = rng.random((n, m))
    low, high = np.maximum(-0.3, -u), np.minimum(0.3, 1.0 - u)
    rho = np.where(np.arange(n) % 2 == 0, 0.05, 0.0)
    s_cap = np.where(np.arange(n) % 3 == 0, gap.max(axis=1), np.inf)
    d, predicted = lp_steps(gap, jac, con, con_jac, low, high, rho, s_cap)
    for i in range(n):
        one = slice(i, i + 1)
        d_i, p_i = lp_steps(gap[one], jac[one], con[one], con_jac[one], low[one], high[one], rho[one], s_cap[one])
        assert predicted[i] == pytest.approx(p_i[0], abs=LP_TOLERANCE)
    # the steps keep to their bounds and constraints, and the prediction is their merit
    assert np.all(d >= low - LP_FEASIBILITY) and np.all(d <= high + LP_FEASIBILITY)
    assert np.all(con + np.einsum("ncm,nm->nc", con_jac, d) <= LP_FEASIBILITY)
    linear = gap + np.einsum("nkm,nm->nk", jac, d)
    np.testing.assert_allclose(predicted, linear.max(axis=1) + rho * linear.sum(axis=1), atol=LP_TOLERANCE)


def test_linear_programme_of_one_objective_is_the_box_corner():
    # one gap a with gradient g over the box |d_j| <= r: the step is -r sign(g), the merit
    # (1 + rho)(a - r sum |g|)
    g = np.array([[[0.5, -2.0, 1.0]]])
    a, r, rho = -0.1, 0.2, 0.05
    d, predicted = lp_steps(
        np.array([[a]]), g, np.zeros((1, 0)), np.zeros((1, 0, 3)), np.full((1, 3), -r), np.full((1, 3), r), np.array([rho]), np.array([np.inf])
    )
    np.testing.assert_allclose(d[0], -r * np.sign(g[0, 0]), atol=LP_FEASIBILITY)
    assert predicted[0] == pytest.approx((1 + rho) * (a - r * np.abs(g).sum()), abs=LP_TOLERANCE)


def test_slp_moves_a_design_far_from_the_front_to_one_dominating_it(problem):
    x0 = problem.baseline[None]
    q0 = problem.evaluator()(x0)
    f0 = np.column_stack([q0[n] for n in problem.objective_names])
    result = refine_designs(problem, x0, f0, np.array([0]), np.full(4, 3.0))
    assert result.merit[0] < -1e-3 and result.steps[0] > 0
    q = problem.evaluator()(result.x)
    f = np.column_stack([q[n] for n in problem.objective_names])
    assert np.all(f <= f0) and np.any(f < f0)
    np.testing.assert_array_equal(f, np.column_stack([result.quantities[n] for n in problem.objective_names]))
    assert np.all((result.x >= problem.lower) & (result.x <= problem.upper))


def test_a_design_s_starts_do_not_depend_on_the_others(problem, small_run):
    # each design draws its own starts from its front row: refined alone or with others, the same
    from hisopt.optim.gradient.asf_slp import start_points

    u = np.random.default_rng(1).random((3, 4))
    together = start_points(u, np.array([4, 9, 2]), SlpSettings())
    alone = start_points(u[1:2], np.array([9]), SlpSettings())
    np.testing.assert_array_equal(together[1], alone[0])
    np.testing.assert_array_equal(together[:, 0], u)
    np.testing.assert_array_equal(together[:, 1], u)
    assert np.all((together >= 0.0) & (together <= 1.0))


def test_refinement_method_and_settings_are_checked(problem, small_run, tmp_path):
    with pytest.raises(hisopt.ConfigError, match="--method"):
        refine_front(problem, small_run.front, max_points=2, method="newton")
    with pytest.raises(hisopt.ConfigError, match="SlpSettings"):
        refine_front(problem, small_run.front, max_points=2, method="slp", settings=RefineSettings())
    run_dir = tmp_path / "run"
    optimize(problem, out=run_dir, seed=5, pop_size=16, generations=3, algorithm="nsga2")
    out = subprocess.run([sys.executable, "-m", "hisopt", "refine", str(run_dir), "--method", "newton"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and "--method" in out.stderr, out.stderr
    assert "Traceback" not in out.stderr


def test_slp_settings_are_checked():
    with pytest.raises(hisopt.ConfigError, match="starts >= 2"):
        SlpSettings(starts=1)
    with pytest.raises(hisopt.ConfigError, match="chunk >= 1"):
        SlpSettings(chunk=0)
