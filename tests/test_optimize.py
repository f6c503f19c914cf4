"""NSGA runs: pymoo adapter, archive, determinism, exact fronts, checkpoints, resume, CLI."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.errors import ConfigError, RunError
from hisopt.io import read_csv
from hisopt.optim import rundir
from hisopt.optim.archive import Archive, non_dominated_mask, pareto_update, weakly_dominates
from hisopt.optim.convergence import hypervolume_estimate
from hisopt.optim.decision import asf_index, grid_designs, hypervolume, knee_index, log_objectives, reference_from_sample
from hisopt.optim.pymoo_problem import HisoptPymooProblem, constraint_matrix, objective_matrix
from hisopt.optim.run import optimize, resume
from hisopt.optim.settings import das_dennis_partitions, resolve_settings
from hisopt.problem import problem_from_dict
from tests.conftest import DEFAULT_PROBLEM, ROOT

HANDLING_PROBLEM = ROOT / "problems" / "roll_plane_his_handling.toml"
SMALL = {"pop_size": 16, "generations": 6, "seed": 7}


@pytest.fixture(scope="module")
def handling() -> hisopt.Problem:
    return hisopt.load_problem(HANDLING_PROBLEM)


def two_objective_problem() -> hisopt.Problem:
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["objectives"] = ["sigma_aw", "max_roll_psd"]
    data["constraints"] = [{"name": "rms_tire_load", "limit": 1265.0}]
    return problem_from_dict(data)


def read_front(path: Path) -> pd.DataFrame:
    """A front.csv without its on_bound marks (derived from the values; tests/test_plausibility.py checks them)."""
    front = read_csv(path)
    assert front.attrs["units"].pop("on_bound") == "-"
    return front.drop(columns="on_bound")


def brute_force_front(f: np.ndarray) -> np.ndarray:
    """Indices of the archive rule by definition: not weakly dominated by any earlier row
    and not dominated by any row."""
    keep = []
    for j in range(len(f)):
        earlier_weak = any(np.all(f[i] <= f[j]) for i in range(j))
        dominated = any(np.all(f[i] <= f[j]) and np.any(f[i] < f[j]) for i in range(len(f)))
        if not earlier_weak and not dominated:
            keep.append(j)
    return np.array(keep, dtype=int)


# --- pymoo adapter ---------------------------------------------------------------------
def test_adapter_follows_pymoo_contract(handling):
    pp = HisoptPymooProblem(handling)
    assert (pp.n_var, pp.n_obj, pp.n_ieq_constr) == (4, 4, 4)
    x = grid_designs(handling.lower, handling.upper, 16)
    out = pp.evaluate(x, return_as_dictionary=True)
    df = handling.evaluate(x)
    assert np.array_equal(out["F"], df[list(handling.objective_names)].to_numpy())
    for j, c in enumerate(handling.spec.constraints):
        assert np.array_equal(out["G"][:, j], df[c.name].to_numpy() / c.limit - 1.0)
    assert np.all(out["G"][:, -1] == 0.0)
    assert np.array_equal(np.all(out["G"] <= 0, axis=1), df["feasible"].to_numpy())
    assert 0 < df["feasible"].mean() < 1


def test_invalid_designs_are_infeasible_and_never_dominate():
    q = {"a": np.array([1.0, np.nan, 3.0]), "b": np.array([0.5, 0.1, 2.0]), "valid": np.array([True, False, True])}
    f = objective_matrix(q, ("a",))
    g = constraint_matrix(q, ("b",), (1.0,))
    assert np.array_equal(f[:, 0], [1.0, np.inf, 3.0])
    assert np.array_equal(g, [[-0.5, 0.0], [1.0, 1.0], [1.0, 0.0]])


def test_adapter_runs_with_pymoo_minimize(problem):
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.optimize import minimize

    res = minimize(HisoptPymooProblem(problem), NSGA2(pop_size=8), ("n_gen", 2), seed=1)
    assert res.F.shape[1] == 4 and np.all(np.isfinite(res.F))


def test_run_survives_invalid_designs(problem, monkeypatch):
    evaluator = problem.evaluator()
    original = type(evaluator).__call__

    def flaky(self, designs):
        out = original(self, designs)
        bad = np.asarray(designs)[:, 2] > 0.6  # pretend large area ratios are unstable
        out = {k: v.copy() for k, v in out.items()}
        for k in out:
            if k != "valid":
                out[k][bad] = np.nan
        out["valid"] = out["valid"] & ~bad
        return out

    monkeypatch.setattr(type(evaluator), "__call__", flaky)
    for algorithm in ("nsga2", "nsga3"):
        res = optimize(problem, pop_size=12, generations=4, seed=2, algorithm=algorithm)
        assert not res.history["valid"].all()
        assert len(res.front) and np.all(res.front["lam"] <= 0.6)


# --- archive ---------------------------------------------------------------------------
def test_archive_equals_non_dominated_set_of_everything_offered(rng):
    f_all = np.round(rng.random((300, 3)), 1)  # coarse values: many ties and duplicates
    feasible = rng.random(300) < 0.8
    archive = Archive.empty(2, 3, 3)
    for start in range(0, 300, 25):
        sl = slice(start, start + 25)
        ids = np.arange(start, start + 25)
        archive = archive.update(rng.random((25, 2)), f_all[sl], f_all[sl], ids, feasible[sl])
    offered = np.flatnonzero(feasible)
    expected = offered[brute_force_front(f_all[offered])]
    assert np.array_equal(archive.ids, expected)
    assert np.all(np.diff(archive.ids) > 0)


def test_non_dominated_mask_and_update_agree_with_definitions(rng):
    f = rng.integers(0, 4, size=(60, 2)).astype(float)
    assert np.array_equal(np.flatnonzero(non_dominated_mask(f)), brute_force_front(f))
    keep, accept = pareto_update(f[:30][non_dominated_mask(f[:30])], f[30:])
    assert keep.dtype == bool and accept.dtype == bool
    w = weakly_dominates(f[:5], f[5:9])
    assert w[0, 0] == np.all(f[0] <= f[5])


# --- decision support ------------------------------------------------------------------
def test_hypervolume_is_the_log_space_box_volume():
    f = np.array([[1e-2, 1e3], [1e-3, 1e4]])
    ref = np.array([0.0, 5.0])  # log10 space
    # boxes [-2, 0] x [3, 5] and [-3, 0] x [4, 5]: union area 2*2 + 1*1
    assert hypervolume(f, ref) == pytest.approx(5.0, rel=1e-12)
    assert hypervolume(np.array([[10.0, 1e6]]), ref) == 0.0


def test_knee_and_asf_pick_on_a_known_front():
    t = np.linspace(0.0, 1.0, 101)
    z = np.column_stack([t, (1 - np.sqrt(t)) ** 2])  # convex front, knee at t = 0.25
    f = 10.0**z
    assert z[knee_index(f), 0] == pytest.approx(0.25, abs=0.011)
    target = f[70]
    assert asf_index(f, reference=target) == 70
    heavy_first = asf_index(f, weights=np.array([10.0, 1.0]))
    assert z[heavy_first, 0] < z[asf_index(f), 0]
    with pytest.raises(ConfigError, match="positive ASF weights"):
        asf_index(f, weights=np.array([1.0, -1.0]))


def test_reference_point_is_nadir_plus_margin():
    f = np.array([[1.0, 100.0], [10.0, 10.0], [100.0, 1.0], [1000.0, 1000.0]])
    assert np.allclose(reference_from_sample(f), [2.2, 2.2])


# --- settings --------------------------------------------------------------------------
def test_settings_defaults_and_overrides(problem):
    s = resolve_settings(problem)
    assert (s.algorithm, s.pop_size, s.generations, s.seed) == ("smsemoa", 100, 200, 1)
    assert resolve_settings(two_objective_problem()).algorithm == "smsemoa"
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["objectives"] = [*data["objectives"], "rms_roll"]
    assert resolve_settings(problem_from_dict(data)).algorithm == "nsga3"  # five objectives
    s = resolve_settings(problem, pop_size=20, generations=3, seed=5, algorithm="nsga2")
    assert (s.algorithm, s.pop_size, s.generations, s.seed) == ("nsga2", 20, 3, 5)
    assert das_dennis_partitions(4, 100) == 6  # 84 reference directions
    with pytest.raises(ConfigError, match="population size >= 4"):
        resolve_settings(problem, pop_size=2)
    with pytest.raises(ConfigError, match="generations >= 1"):
        resolve_settings(problem, generations=0)


# --- runs ------------------------------------------------------------------------------
def test_same_seed_same_front_different_seed_different_front(problem):
    global_rng = np.random.get_state()[1].copy()
    a = optimize(problem, **SMALL)
    assert np.array_equal(np.random.get_state()[1], global_rng)  # pymoo draws from its own generator
    b = optimize(problem, **SMALL)
    c = optimize(problem, **(SMALL | {"seed": 8}))
    assert a.front.equals(b.front) and a.history.equals(b.history)
    assert not a.front.equals(c.front)
    assert len(a.history) == SMALL["pop_size"] * SMALL["generations"]
    assert list(a.history["generation"].unique()) == list(range(1, SMALL["generations"] + 1))


def test_front_is_the_archive_of_all_feasible_evaluations(handling):
    res = optimize(handling, **SMALL)
    names = list(handling.objective_names)
    feasible = res.history[res.history["feasible"]]
    assert 0 < len(feasible) < len(res.history)
    f_front, f_feas = res.front[names].to_numpy(), feasible[names].to_numpy()
    # every feasible design is weakly dominated by a front design; the front is non-dominated
    assert weakly_dominates(f_front, f_feas).any(axis=0).all()
    assert non_dominated_mask(f_front).all()
    merged = res.front.merge(res.history, on=list(res.front.columns), how="left")
    assert merged["feasible"].all()
    # more of the front than the last population holds
    last = res.history[res.history["generation"] == SMALL["generations"]]
    assert len(res.front) > len(last[last["feasible"]]) / 2
    assert res.hypervolume == pytest.approx(hypervolume(f_front, res.reference_point), rel=1e-12)
    # the progress column is the estimator of hisopt.optim.convergence, kept incrementally: it
    # equals the estimate of the final front from scratch (same directions, same maxima; the
    # mean of rho^k summed in another order: 1e-12 relative)
    progress = res.generations["hypervolume"].iloc[-1]
    assert progress == pytest.approx(hypervolume_estimate(log_objectives(f_front), res.reference_point), rel=1e-12)


def test_run_directory_contents_and_exact_front(tmp_path, handling):
    run_dir = tmp_path / "run"
    res = optimize(handling, out=run_dir, **SMALL)
    front = read_front(run_dir / "front.csv")
    expected_columns = ["p0", "dA", "lam", "Rv", *handling.objective_names, "roll_gradient", "rms_tire_load", "rms_stroke"]
    assert list(front.columns) == expected_columns
    assert front.equals(res.front)
    again = handling.evaluate(front[list(handling.variable_names)])
    np.testing.assert_allclose(again[expected_columns].to_numpy(), front.to_numpy(), rtol=1e-12, atol=0)
    info = json.loads((run_dir / "run.json").read_text())
    assert info["status"] == "finished"
    assert info["problem"]["sha256"] == handling.sha256 == rundir.sha256_bytes(HANDLING_PROBLEM.read_bytes())
    assert info["problem"]["text"] == HANDLING_PROBLEM.read_text()
    assert (run_dir / "problem.toml").read_bytes() == HANDLING_PROBLEM.read_bytes()
    assert {"hisopt", "numpy", "pymoo", "python"} <= set(info["versions"])
    assert info["settings"]["seed"] == SMALL["seed"] and info["settings"]["algorithm"] == "smsemoa"
    assert info["result"]["front_size"] == len(front) and info["sessions"][0]["end_generation"] == SMALL["generations"]
    assert 0 < info["timings"]["evaluation_s"] < info["timings"]["wall_time_s"]
    assert rundir.checkpoint_generation(run_dir) == SMALL["generations"]
    history = pd.read_parquet(run_dir / "evaluations.parquet")
    assert history.equals(res.history)
    assert not list(run_dir.glob(".*"))  # no temporary files left


def test_problem_from_dict_is_copied_as_json_and_resumable(tmp_path):
    run_dir = tmp_path / "run"
    p = two_objective_problem()

    def stop(stats):
        if stats.generation == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        optimize(p, out=run_dir, progress=stop, **SMALL)
    assert (run_dir / "problem.json").is_file() and not (run_dir / "problem.toml").exists()
    resumed = resume(run_dir)
    assert resumed.front.equals(optimize(p, **SMALL).front)


@pytest.mark.parametrize("path", [DEFAULT_PROBLEM, HANDLING_PROBLEM], ids=["default", "default-constrained"])
def test_interrupt_and_resume_gives_identical_run(tmp_path, path):
    p = hisopt.load_problem(path)
    full = optimize(p, out=tmp_path / "full", **SMALL)

    def stop(stats):
        if stats.generation == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        optimize(p, out=tmp_path / "cut", progress=stop, **SMALL)
    info = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert info["status"] == "interrupted" and rundir.checkpoint_generation(tmp_path / "cut") == 3
    resumed = resume(tmp_path / "cut")
    assert (tmp_path / "cut" / "front.csv").read_bytes() == (tmp_path / "full" / "front.csv").read_bytes()
    assert resumed.history.equals(full.history)
    cols = ["generation", "evaluations", "feasible_share", "front_size", "hypervolume"]
    assert resumed.generations[cols].equals(full.generations[cols])
    assert [s["status"] for s in json.loads((tmp_path / "cut" / "run.json").read_text())["sessions"]] == [
        "interrupted",
        "finished",
    ]


def test_interrupt_inside_an_evaluation_resumes_from_the_last_generation(tmp_path, monkeypatch):
    p = two_objective_problem()  # NSGA-II: rank and crowding must survive the checkpoint
    full = optimize(p, **SMALL)
    evaluator = p.evaluator()
    original = type(evaluator).__call__
    calls = {"n": 0}

    def interrupting(self, designs):
        if len(designs) == SMALL["pop_size"]:  # a generation (not the reference grid)
            calls["n"] += 1
            if calls["n"] == 5:  # Ctrl-C while generation 5 is evaluated
                raise KeyboardInterrupt
        return original(self, designs)

    monkeypatch.setattr(type(evaluator), "__call__", interrupting)
    with pytest.raises(KeyboardInterrupt):
        optimize(p, out=tmp_path / "cut", **SMALL)
    monkeypatch.setattr(type(evaluator), "__call__", original)
    assert rundir.checkpoint_generation(tmp_path / "cut") == 4
    resumed = resume(tmp_path / "cut")
    assert resumed.front.equals(full.front) and resumed.history.equals(full.history)


def test_resume_of_a_finished_run_changes_nothing(tmp_path, problem):
    first = optimize(problem, out=tmp_path / "run", **SMALL)
    before = (tmp_path / "run" / "front.csv").read_bytes()
    again = resume(tmp_path / "run")
    assert again.front.equals(first.front)
    assert (tmp_path / "run" / "front.csv").read_bytes() == before


def test_resume_refuses_a_changed_problem_file_and_accepts_a_deleted_one(tmp_path):
    original = tmp_path / "mine.toml"
    original.write_bytes(DEFAULT_PROBLEM.read_bytes())
    p = hisopt.load_problem(original)

    def stop(stats):
        if stats.generation == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        optimize(p, out=tmp_path / "run", progress=stop, **SMALL)
    original.write_text(original.read_text().replace("speed = 10.0", "speed = 20.0"))
    with pytest.raises(RunError, match="mine.toml changed since the run started"):
        resume(tmp_path / "run")
    original.unlink()
    copy = tmp_path / "run" / "problem.toml"
    copy.write_text(copy.read_text() + "\n")
    with pytest.raises(RunError, match="problem.toml was edited"):
        resume(tmp_path / "run")
    copy.write_bytes(DEFAULT_PROBLEM.read_bytes())
    assert resume(tmp_path / "run").front.equals(optimize(p, **SMALL).front)


def test_unwritable_or_occupied_run_directory_fails_before_work(tmp_path, problem, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setattr(type(problem), "evaluator", lambda self: pytest.fail("evaluated before checking --out"))
    with pytest.raises(RunError, match="file is a file, not a folder"):  # hisopt.folders.check_claim
        optimize(problem, out=blocker / "run", **SMALL)
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "run.json").write_text("{}")
    with pytest.raises(RunError, match="already holds a run"):
        optimize(problem, out=tmp_path / "old", **SMALL)
    with pytest.raises(RunError, match="not a run directory"):
        resume(tmp_path / "nothing")
    assert not (tmp_path / "nothing").exists()


def test_checkpoint_round_trip_is_exact(tmp_path):
    meta = {"generation": 3, "rng": {"state": 2**127 + 5}}
    arrays = {"a": np.array([0.1, 1 / 3, np.nan]), "b": np.arange(4)}
    rundir.save_checkpoint(tmp_path / "c.npz", meta, arrays)
    meta2, arrays2 = rundir.load_checkpoint(tmp_path / "c.npz")
    assert meta2["rng"]["state"] == 2**127 + 5 and meta2["generation"] == 3
    assert np.array_equal(arrays2["a"], arrays["a"], equal_nan=True) and np.array_equal(arrays2["b"], arrays["b"])


def test_result_decision_support(problem):
    res = optimize(problem, **SMALL)
    knee, pick = res.knee, res.asf_pick()
    assert list(knee.index) == list(res.front.columns)
    names = list(problem.objective_names)
    ideal_roll = res.front["max_roll_psd"].min()
    roll_pick = res.asf_pick(reference={"max_roll_psd": ideal_roll}, weights={"max_roll_psd": 100.0})
    assert roll_pick["max_roll_psd"] <= pick["max_roll_psd"]
    best = res.front.iloc[5]
    assert res.asf_pick(reference=best[names].to_numpy()).equals(best)
    with pytest.raises(ConfigError, match="unknown objective"):
        res.asf_pick(reference={"speed": 1.0})


# --- command line ----------------------------------------------------------------------
def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=300, cwd=ROOT)


def test_cli_optimize_writes_run_and_prints_summary(tmp_path):
    out = cli("optimize", str(HANDLING_PROBLEM), "--out", str(tmp_path / "run"), "--pop", "12", "--gens", "3", "--seed", "4")
    assert out.returncode == 0, out.stderr
    for word in ("front size", "evaluations", "hypervolume", "knee", "ASF pick", "max_tire_load_psd"):
        assert word in out.stdout
    for shown in ("p0 [MPa]", "dA [cm^2]", "sigma_aw [m/s^2]", "max_roll_psd [rad^2/Hz]", "roll_gradient [deg/g]", "decades^4"):
        assert shown in out.stdout  # the picks and the hypervolume with their units
    assert "gen    3/3" in out.stderr and "feasible" in out.stderr
    lib = optimize(hisopt.load_problem(HANDLING_PROBLEM), pop_size=12, generations=3, seed=4)
    front = read_front(tmp_path / "run" / "front.csv")
    assert front.equals(lib.front)
    assert front.attrs["units"] == lib.front.attrs["units"] and front.attrs["units"]["rms_stroke"] == "m"
    generations = read_csv(tmp_path / "run" / "generations.csv")
    assert generations.attrs["units"]["hypervolume"] == "decades^4" and generations.attrs["units"]["elapsed_s"] == "s"


def test_cli_user_errors_are_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    out = cli("optimize", str(DEFAULT_PROBLEM), "--out", str(blocker / "run"))
    assert out.returncode == 2 and "file is a file, not a folder" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr
    out = cli("optimize", str(DEFAULT_PROBLEM), "--pop", "2")
    assert out.returncode == 2 and "population size >= 4" in out.stderr
    out = cli("resume", str(tmp_path / "nowhere"))
    assert out.returncode == 2 and "not a run directory" in out.stderr


def test_result_plot_methods_return_figures(problem):
    import hisopt

    run = hisopt.optimize(problem, pop_size=12, generations=3, seed=2)
    for fig in (run.plot_front(), run.plot_parallel("max_roll_psd"), run.plot_convergence()):
        assert len(fig.data) >= 1
    assert hisopt.resume is hisopt.optim.run.resume
