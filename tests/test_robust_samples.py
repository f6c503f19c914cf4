"""Robust objectives and chance constraints over common random samples (docs/model.md §18.4):
the statistics against numpy's, the chance constraint's order statistic against a count of
exceedances, zero-width inputs against the nominal problem (evaluation and a whole run)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.errors import ConfigError
from hisopt.evaluation.robust_evaluator import RobustEvaluator, chance_value, sample_statistic
from hisopt.evaluation.uncertain import UncertainEvaluator
from hisopt.problem import problem_from_dict
from hisopt.specification.uncertain import Uncertain
from tests.cli_inprocess import run_cli
from tests.conftest import ROOT

UNCERTAIN_PROBLEM = ROOT / "problems" / "roll_plane_his_uncertain.toml"


def robust_data(**robust) -> dict:
    data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    data["robust"] = {"statistic": "mean_plus_k_sigma", "k": 2.0, "samples": 32} | robust
    return data


def test_sample_statistics_equal_numpy_s():
    rng = np.random.default_rng(2)
    v = rng.normal(3.0, 0.2, (5, 40))
    np.testing.assert_allclose(sample_statistic(v, "mean"), v.mean(axis=1), rtol=1e-14)
    np.testing.assert_allclose(sample_statistic(v, "mean_plus_k_sigma", 1.5), v.mean(axis=1) + 1.5 * v.std(axis=1, ddof=1), rtol=1e-14)
    v[2, 7] = np.nan
    assert np.isnan(sample_statistic(v, "mean")[2]) and np.isfinite(sample_statistic(v, "mean")[[0, 1, 3, 4]]).all()
    same = np.full((1, 64), 0.1)  # shifted sums: equal samples give their value exactly
    assert sample_statistic(same, "mean_plus_k_sigma", 2.0)[0] == 0.1


@pytest.mark.parametrize("probability", [0.01, 0.05, 0.1, 0.5])
def test_chance_value_is_at_most_a_limit_exactly_when_few_enough_samples_exceed_it(probability):
    rng = np.random.default_rng(3)
    v = rng.random((200, 60))
    v[5, :3] = np.nan  # failed samples exceed every limit
    value = chance_value(v, probability)
    allowed = int(np.floor(probability * 60 + 1e-9))
    for limit in (0.3, 0.7, 0.95):
        with np.errstate(invalid="ignore"):
            exceed = np.sum(~(v <= limit), axis=1)
        assert np.array_equal(value <= limit, exceed <= allowed)


def test_a_robust_problem_rates_each_design_by_its_samples():
    data = robust_data()
    data["constraints"][0]["probability"] = 0.05
    p = problem_from_dict(data)
    ev = p.evaluator()
    assert isinstance(ev, RobustEvaluator)
    x = np.tile(p.baseline, (3, 1))
    x[:, 0] = [1e6, 2e6, 3e6]
    got = ev(x)
    per = UncertainEvaluator(p)(x, ev.variates)
    for name in ("sigma_aw", "max_roll_psd"):
        np.testing.assert_allclose(got[name], per[name].mean(axis=1) + 2 * per[name].std(axis=1, ddof=1), rtol=1e-12)
    # at most floor(0.05 * 32) = 1 of the 32 samples above the column's value
    assert np.all(np.sum(per["roll_gradient"] > got["roll_gradient"][:, None], axis=1) <= 1)
    frame = p.evaluate(x)  # the public route: the same columns
    np.testing.assert_array_equal(frame["sigma_aw"].to_numpy(), got["sigma_aw"])


def zero_width(p) -> list[Uncertain]:
    return [Uncertain(u.name, u.unit, "uniform", None, 0.0, True) for u in UncertainEvaluator(p).inputs]


def test_inputs_of_zero_width_give_the_nominal_values_to_the_last_bit():
    p = problem_from_dict(robust_data())
    nominal_data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    del nominal_data["uncertain"]
    nominal = problem_from_dict(nominal_data)
    rng = np.random.default_rng(1)
    x = p.lower + rng.random((40, 4)) * (p.upper - p.lower)
    got = RobustEvaluator(p, zero_width(p))(x)
    want = nominal.evaluator()(x)
    for name in want:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)


def test_a_robust_run_with_zero_width_equals_the_nominal_run():
    p = problem_from_dict(robust_data())
    p._cache["evaluator"] = RobustEvaluator(p, zero_width(p))  # the API's route to inputs a file refuses
    nominal_data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    del nominal_data["uncertain"]
    nominal = problem_from_dict(nominal_data)
    robust = hisopt.optimize(p, pop_size=16, generations=4, seed=3)
    plain = hisopt.optimize(nominal, pop_size=16, generations=4, seed=3)
    np.testing.assert_array_equal(robust.front[list(p.variable_names)].to_numpy(), plain.front[list(p.variable_names)].to_numpy())
    np.testing.assert_array_equal(robust.front["sigma_aw"].to_numpy(), plain.front["sigma_aw"].to_numpy())


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda d: d.pop("uncertain"), "robust"),
        (lambda d: d["constraints"][0].update(probability=1.5), "constraints.0.probability"),
        (lambda d: d["constraints"][0].update(probability=0.0), "constraints.0.probability"),
        (lambda d: d["robust"].update(statistic="mean"), "robust.k"),
        (lambda d: d["robust"].update(aggregate="worst"), "[[scenarios]]"),
        (lambda d: d["robust"].update(samples=1), "robust.samples"),
    ],
)
def test_bad_robust_settings_are_one_line(tmp_path, change, words):
    data = robust_data()
    change(data)
    import tomli_w

    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(ConfigError) as err:
        hisopt.load_problem(path)
    assert words in str(err.value) and "\n" not in str(err.value), str(err.value)
    out = run_cli("evaluate", str(path))
    assert out.code == 2 and len(out.error_lines) == 1


def test_a_chance_constraint_without_uncertain_inputs_is_refused():
    data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    del data["uncertain"]
    data["constraints"][0]["probability"] = 0.05
    with pytest.raises(ConfigError, match="roll_gradient has a probability"):
        problem_from_dict(data)


@pytest.mark.parametrize("robust", [{"statistic": "mean_plus_k_sigma", "k": 1.5, "samples": 32}, {"samples": 128, "seed": 3}])
def test_a_robust_problem_reads_back_from_its_dump(robust):
    data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    data["robust"] = robust
    data["constraints"][0]["probability"] = 0.05
    p = problem_from_dict(data)
    again = p.with_values(V0=1.1e-3)  # dumps the specification and reads it back
    assert again.spec.robust == p.spec.robust and again.spec.constraints == p.spec.constraints
    assert again.spec.uncertain == p.spec.uncertain


def test_the_casadi_sample_parts_equal_the_evaluator_sample_by_sample():
    """The IPOPT refinement's parts (a problem, a moved design and a road factor per sample) on
    the evaluator's nodes give each sample's value as the evaluator's samples do, within the
    two paths' rounding budget (tests/error_budget.py, as tests/test_casadi_model.py)."""
    import casadi as ca

    from hisopt.evaluation.symmetry import split, state_mirror
    from hisopt.optim.gradient.asf_nlp import RefineSettings, node_plan
    from hisopt.optim.gradient.refine import model_parts
    from hisopt.optim.gradient.sample_parts import road_shift
    from tests.error_budget import assert_discriminating, pole_budget, solve_budget

    data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    data["robust"] = {"statistic": "mean", "samples": 4}
    data["uncertain"].append({"input": "road.gd_n0", "lower": 1e-4, "upper": 5e-4})
    p = problem_from_dict(data)
    x = p.baseline.copy()
    x[0] = 1.5e6
    per = UncertainEvaluator(p)(x[None, :], p.evaluator().variates)
    budgets = []
    for s, part in enumerate(model_parts(p)):
        moved = part.design(x)
        plan = node_plan(part.problem, part.model, moved, RefineSettings())
        got = {k: float(v) * 10 ** road_shift(k, part.road) for k, v in part.model.integrals(ca.DM(moved), plan.fs).items()}
        model = part.problem.model(moved[None])
        ss = model.state_space()
        halves = [h.a for h in split(ss, state_mirror(model, ss)).values()]
        budget = (
            solve_budget(model, plan.fs.f_hz, backward=("componentwise", "normwise"))[0] + pole_budget(halves, p.spec.band.f_min_hz, p.spec.band.f_max_hz)[0]
        )
        budgets.append(budget)
        for name in ("sigma_aw", "roll_gradient"):
            assert got[name] == pytest.approx(per[name][0, s], rel=budget), (name, s)
    assert_discriminating(np.array(budgets))


def test_ipopt_refines_a_robust_front_on_its_sample_average():
    """IPOPT on the sample average with a chance constraint (as CVaR) moves designs; one is
    kept only if the robust evaluator finds it no worse in any objective and feasible (its
    chance constraint met on the samples)."""
    from hisopt.optim.gradient.refine import refine_front

    data = tomllib.loads(UNCERTAIN_PROBLEM.read_text())
    data["robust"] = {"statistic": "mean", "samples": 4}
    data["constraints"][0] |= {"probability": 0.25, "limit": "2 deg/g"}
    p = problem_from_dict(data)
    front = hisopt.optimize(p, pop_size=16, generations=6, seed=2).front
    points = refine_front(p, front, max_points=2, method="ipopt").points
    assert points["accepted"].any(), points
    for _, row in points[points["accepted"]].iterrows():
        start = front.iloc[int(row["source_index"])]
        assert all(row[name] <= start[name] for name in p.objective_names)
        assert row["roll_gradient"] <= p.spec.constraints[0].limit
