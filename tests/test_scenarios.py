"""Load cases: scenario columns, aggregation, per-scenario constraints (docs/model.md §14)."""

from __future__ import annotations

import copy
import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.errors import ConfigError
from hisopt.problem import problem_from_dict
from hisopt.robust import aggregate, cvar, expected, scenario_column, worst
from tests.conftest import ROOT

BASE = tomllib.loads((ROOT / "problems" / "roll_plane_his.toml").read_text())
ROADS = {
    "city": {"class": "C", "speed": 10.0},
    "rural": {"class": "B", "speed": 20.0},
    "motorway": {"class": "A", "speed": 33.0, "coherence": "isotropic"},
}


def scenario_problem(roads: dict[str, dict], **extra) -> hisopt.Problem:
    data = copy.deepcopy(BASE)
    data["scenarios"] = [{"name": name, "road": road} for name, road in roads.items()]
    data.update(extra)
    return problem_from_dict(data)


def single_problem(road: dict) -> hisopt.Problem:
    data = copy.deepcopy(BASE)
    data["road"] = road
    return problem_from_dict(data)


@pytest.fixture(scope="module")
def designs():
    p = hisopt.load_problem(ROOT / "problems" / "roll_plane_his.toml")
    rng = np.random.default_rng(7)
    return p.lower + rng.random((12, len(p.lower))) * (p.upper - p.lower)


def test_one_scenario_equals_the_plain_problem_exactly(designs):
    plain = hisopt.load_problem(ROOT / "problems" / "roll_plane_his.toml")
    one = scenario_problem({"only": dict(BASE["road"])})
    a, b = plain.evaluate(designs), one.evaluate(designs)
    for name in plain.objective_names:
        np.testing.assert_array_equal(a[name].to_numpy(), b[name].to_numpy())
        np.testing.assert_array_equal(a[name].to_numpy(), b[f"{name}@only"].to_numpy())
    assert list(b.columns[: len(a.columns) - 3]) == list(a.columns[:-3])  # plain columns first, same order


def test_each_scenario_equals_its_single_case_problem(designs):
    p = scenario_problem(ROADS)
    df = p.evaluate(designs)
    for name, road in ROADS.items():
        single = single_problem(road).evaluate(designs)
        for q in p.spec.objectives:
            # one model, poles and nodes, the roads side by side: the determinism contract (docs/model.md §9)
            np.testing.assert_allclose(df[scenario_column(q, name)], single[q], rtol=1e-12, atol=0)


@pytest.mark.parametrize("how", ["worst", "expected", "cvar"])
def test_aggregate_columns_follow_their_definition(designs, how):
    weights = {"city": 1.0, "rural": 2.0, "motorway": 1.0}
    p = scenario_problem(ROADS, robust={"aggregate": how} | ({"alpha": 0.6} if how == "cvar" else {}))  # alpha: cvar only
    data = copy.deepcopy(p.spec.model_dump(by_alias=True))
    for sc in data["scenarios"]:
        sc["weight"] = weights[sc["name"]]
    p = problem_from_dict(data)
    df = p.evaluate(designs)
    w = np.array([weights[s] for s in p.scenario_names]) / 4.0
    for q in p.spec.objectives:
        v = df[[scenario_column(q, s) for s in p.scenario_names]].to_numpy()
        if how == "worst":
            want = v.max(axis=1)
        elif how == "expected":
            want = v @ w
        else:  # Rockafellar-Uryasev: min over t of t + E[(v - t)+] / (1 - alpha); a scenario's value attains it
            want = np.min([v[:, [k]] + ((v - v[:, [k]]).clip(0) @ w)[:, None] / 0.4 for k in range(3)], axis=0)[:, 0]
        np.testing.assert_allclose(df[q], want, rtol=1e-12)


def test_cvar_by_hand():
    # losses 1, 2, 4 with probabilities 0.5, 0.25, 0.25; the worst 40 % is all of 4 (0.25)
    # and 0.15 of 2: (0.25 * 4 + 0.15 * 2) / 0.4 = 3.25
    v = np.array([[1.0, 2.0, 4.0], [4.0, 1.0, 2.0]])
    w = [0.5, 0.25, 0.25]
    np.testing.assert_allclose(cvar(v, w, 0.6), [3.25, 4.0])  # row 2: the worst scenario holds 0.5 > 0.4
    np.testing.assert_allclose(cvar(v, w, 0.0), expected(v, w))  # alpha = 0: the expected value
    np.testing.assert_allclose(cvar(v, w, 0.99), worst(v))  # the tail lies in the worst scenario
    assert np.isnan(aggregate(np.array([[1.0, np.nan]]), "cvar", [1, 1], 0.5))[0]


def test_constraints_hold_in_their_scenarios_only(designs):
    base = scenario_problem(ROADS)
    df = base.evaluate(designs)
    limit = float(np.median(df["max_roll_psd@city"]))
    constraints = [{"name": "rms_roll", "limit": 0.3}, {"name": "max_roll_psd", "limit": limit, "scenarios": ["motorway"]}]
    only_motorway = scenario_problem(ROADS, constraints=constraints, objectives=["sigma_aw", "max_stroke_psd"])
    out = only_motorway.evaluate(designs)
    assert "max_roll_psd@city" not in out and "max_roll_psd@motorway" in out
    np.testing.assert_array_equal(out["max_roll_psd"], out["max_roll_psd@motorway"])
    assert np.array_equal(out["feasible"], (out["max_roll_psd@motorway"] <= limit) & (out["rms_roll"] <= 0.3))
    everywhere = scenario_problem(ROADS, constraints=[{"name": "max_roll_psd", "limit": limit}], objectives=["sigma_aw"])
    out = everywhere.evaluate(designs)
    cols = [f"max_roll_psd@{s}" for s in ROADS]
    np.testing.assert_array_equal(out["max_roll_psd"], out[cols].max(axis=1))
    assert 0 < out["feasible"].sum() < len(designs)


def test_per_scenario_objectives_are_pairs(designs):
    p = scenario_problem({k: ROADS[k] for k in ("city", "motorway")}, robust={"aggregate": "per_scenario"}, objectives=["sigma_aw", "max_roll_psd"])
    assert p.objective_names == ("sigma_aw@city", "sigma_aw@motorway", "max_roll_psd@city", "max_roll_psd@motorway")
    df = p.evaluate(designs)
    np.testing.assert_array_equal(df["sigma_aw"], df[["sigma_aw@city", "sigma_aw@motorway"]].max(axis=1))
    assert df.attrs["units"]["sigma_aw@city"] == "m/s^2"


def test_scenarios_share_a_model_when_only_the_road_differs():
    p = scenario_problem(ROADS)
    ev = p.evaluator()
    assert ev.groups == [[0, 1, 2]]


NO_SCENARIOS = "combines the results of [[scenarios]] (or, with statistic, of [[uncertain]] samples) and this problem has none"


@pytest.mark.parametrize(
    "change, words",
    [
        ({"scenarios": [{"name": "a"}, {"name": "a"}]}, "'a' is named twice"),
        ({"scenarios": [{"name": "a@b"}]}, "expected letters, digits"),
        ({"robust": {"aggregate": "cvar"}}, NO_SCENARIOS),
        ({"robust": {}}, NO_SCENARIOS),  # a [robust] table at all
        ({"scenarios": [{"name": "a"}], "robust": {"alpha": 0.6}}, "robust.alpha: alpha is the CVaR level"),
        ({"scenarios": [{"name": "a"}], "constraints": [{"name": "rms_roll", "limit": 1.0, "scenarios": ["b"]}]}, "names scenario 'b'"),
        ({"scenarios": [{"name": "a", "weight": 0}]}, "greater than 0"),
        ({"scenarios": [{"name": "a"}], "robust": {"aggregate": "expected"}, "constraints": [{"name": "sigma_aw", "limit": 1.0}]}, "also an objective"),
    ],
)
def test_bad_scenario_tables_get_one_clear_line(change, words):
    data = copy.deepcopy(BASE)
    data.update(change)
    with pytest.raises(ConfigError) as err:
        problem_from_dict(data, "p.toml")
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("how", ["worst", "expected", "cvar", "per_scenario"])
def test_refinement_over_load_cases_improves_the_baseline(how):
    """The CasADi NLP aggregates the load cases as the evaluator does: from the baseline (far
    from the front) it finds a design the evaluator confirms dominates it."""
    from hisopt.optim.gradient.casadi_model import CasadiModel
    from hisopt.optim.gradient.refine import Part, RefineSettings, refine_point

    roads = {k: ROADS[k] for k in ("city", "motorway")}
    data = copy.deepcopy(BASE)
    data["scenarios"] = [{"name": n, "road": r, "weight": w} for (n, r), w in zip(roads.items(), (1.0, 3.0), strict=True)]
    data["scenarios"].append({"name": "laden", "road": roads["city"], "payload": {"mass": 250.0, "x": -0.4}})
    data.update(robust={"aggregate": how} | ({"alpha": 0.5} if how == "cvar" else {}), objectives=["sigma_aw", "max_tire_load_psd"])
    data["constraints"] = [{"name": "roll_gradient", "limit": 0.06, "scenarios": ["laden"]}]
    p = problem_from_dict(data)
    parts = [Part(n, p.scenario_space(n), CasadiModel(p.scenario_space(n), compile=False)) for n in p.scenario_names]
    x0 = p.baseline
    q0 = p.evaluator()(x0[None])
    f0 = np.array([q0[n][0] for n in p.objective_names])
    result = refine_point(p, parts, 0, x0, f0, np.full(len(f0), 3.0), RefineSettings(rounds=3))
    q = p.evaluator()(result.x[None])
    f = np.array([q[n][0] for n in p.objective_names])
    assert result.accepted and np.all(f <= f0) and np.any(f < f0 * (1 - 1e-3))
    assert q["roll_gradient@laden"][0] <= 0.06


def test_shipped_robust_problem_runs_through_optimize_refine_and_report(tmp_path):
    from tests.cli_inprocess import run_cli

    path = ROOT / "problems" / "roll_plane_his_robust.toml"
    p = hisopt.load_problem(path)
    assert {"city", "rural", "motorway", "laden"} <= set(p.scenario_names)
    roads = {sc.name: (sc.road.road_class, sc.road.speed) for sc in p.spec.scenarios}
    assert roads["city"] == ("C", 10.0) and roads["rural"] == ("B", 20.0) and roads["motorway"] == ("A", 33.0)
    assert p.constraint_scenarios("roll_step_peak") == ("laden",)
    run = tmp_path / "run"
    out = run_cli("optimize", path, "--pop", "12", "--gens", "2", "--out", run)
    assert out.code == 0, out.stderr
    out = run_cli("refine", run, "--max-points", "1")
    assert out.code == 0, out.stderr
    out = run_cli("report", run)
    assert out.code == 0, out.stderr
    page = (run / "report.html").read_text()
    assert "Load cases" in page and "roll_step_peak@laden" in page and "(laden)" in page


def test_robust_problem_columns_equal_each_load_case_alone(designs):
    """Payload and road scenarios with a step steer constrained in one of them: every column
    equals the single-case problem of its scenario, and the models that serve no scenario
    asking for the step steer skip it (they are valid nonetheless)."""
    p = hisopt.load_problem(ROOT / "problems" / "roll_plane_his_robust.toml")
    ev = p.evaluator()
    skipped = {p.scenario_names[g[0]]: ev.evaluators[g[0]].unread for g in ev.groups}
    assert skipped == {"city": frozenset({"roll_step_peak"}), "laden": frozenset()}
    q = ev(designs)
    assert q["valid"].all()
    data = p.spec.model_dump(by_alias=True)
    for sc in data["scenarios"]:
        alone = {k: v for k, v in data.items() if k != "robust"} | {"scenarios": [], "road": sc["road"], "payload": sc["payload"]}
        alone["constraints"] = [c | {"scenarios": None} for c in data["constraints"]]
        single = problem_from_dict(alone).evaluator()(designs)
        for col in [c for c in q if c.endswith("@" + sc["name"])]:
            np.testing.assert_allclose(q[col], single[col.split("@")[0]], rtol=1e-12, atol=0)  # the determinism contract


def test_cli_evaluates_load_cases_sharing_a_model_without_any_psd_maximum(tmp_path, designs):
    """Regression (issue 22): roads sharing one model and no PSD maximum among the quantities
    (as the layout study's NLP poses it: sigma_aw alone) crashed in ``hisopt evaluate``
    gathering the shared samples of maxima there are none of. Every scenario column equals
    its road's single-case problem, which samples on its own: the same nodes and kernels, so
    equal to rounding (bit-equal on this machine); 1e-9 leaves a BLAS kernel that batches the
    FRF products differently its reordered sums (~1e-13 relative over ~1e3 nodes)."""
    from tests.cli_inprocess import run_cli

    text = (ROOT / "problems" / "roll_plane_his.toml").read_text()
    text = text.replace('objectives = ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd"]', 'objectives = ["sigma_aw", "rms_roll"]')
    text += "".join(
        f'\n[[scenarios]]\nname = "{name}"\nroad = {{ class = "{r["class"]}", speed = {r["speed"]} }}\n' for name, r in ROADS.items() if name != "motorway"
    )  # independent tracks both: one model, two roads
    path = tmp_path / "two_roads.toml"
    path.write_text(text)
    rows = tmp_path / "designs.csv"
    rows.write_text("p0,dA,lam,Rv\n" + "".join(",".join(repr(float(v)) for v in x) + "\n" for x in designs))
    out = run_cli("evaluate", path, "--designs", rows, "--out", tmp_path / "out.csv")
    assert out.code == 0, out.stderr
    from hisopt.io import read_csv

    got = read_csv(tmp_path / "out.csv")
    assert hisopt.load_problem(path).evaluator().groups == [[0, 1]]  # the shared path
    for name in ("city", "rural"):
        data = copy.deepcopy(BASE) | {"objectives": ["sigma_aw", "rms_roll"], "road": ROADS[name]}
        alone = problem_from_dict(data).evaluate(designs)
        for q in ("sigma_aw", "rms_roll"):
            np.testing.assert_allclose(got[f"{q}@{name}"], alone[q], rtol=1e-9, atol=0)
