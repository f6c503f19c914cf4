"""The HIS in hardware terms: cylinders by bore and rod (docs/model.md §3.1).

Independent references: the chamber areas of a bore and a rod by hand (circle areas); the
paper's default cylinder written as its bore and rod gives the paper's numbers; every engine
reads the sizes through the same dA and lam (CasADi against numpy).
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from hisopt.hydraulics import laws
from hisopt.problem import problem_from_dict
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, random_designs
from tests.error_budget import EPS, SAFETY, assert_within, pole_budget

PAPER_ROD = math.sqrt(4 * 10e-4 / math.pi)  # [m] dA = 10 cm^2 is the rod's area
PAPER_BORE = PAPER_ROD / math.sqrt(1 - 0.5)  # [m] lam = 0.5 = 1 - (rod / bore)^2


def sized(his: dict | None = None, variables: dict | None = None) -> dict:
    """The default problem with its cylinders given by bore and rod instead of dA and lam."""
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    for key in ("dA", "lam"):
        data["his"].pop(key)
        data["variables"].pop(key)
    data["his"] |= {"bore": PAPER_BORE, "rod": PAPER_ROD} | (his or {})
    if variables is not None:
        data["variables"] |= variables
    return data


def test_bore_and_rod_give_the_chamber_areas_by_hand():
    bore, rod = 0.050, 0.028
    dA, lam = laws.bore_and_rod_parameters(bore, rod)
    top, bottom = laws.cylinder_areas(dA, lam)
    assert bottom == pytest.approx(math.pi * 0.025**2, rel=1e-15)
    assert top == pytest.approx(math.pi * (0.025**2 - 0.014**2), rel=1e-15)
    assert dA == pytest.approx(math.pi * 0.014**2, rel=1e-15)
    assert laws.bore_and_rod(dA, lam) == pytest.approx((bore, rod), rel=1e-15)  # and back


def test_the_paper_cylinder_as_bore_and_rod_gives_the_paper_numbers(problem, rng):
    paper = problem
    parts = problem_from_dict(sized())
    assert parts.variable_names == ("p0", "Rv")
    x = random_designs(parts, 6, rng)
    on_paper = np.column_stack([x[:, 0], np.full(len(x), 10e-4), np.full(len(x), 0.5), x[:, 1]])
    a, b = parts.evaluator()(x), paper.evaluator()(on_paper)
    # The same dA and lam up to the rounding of a square root and its square (a few eps), so
    # two eigendecompositions of matrices equal to rounding: each path's pole budget
    # (tests/error_budget.py), and the inputs' few eps through the quantities' sensitivity
    # to them (of order one: SAFETY * 16 eps). The 1e-12 is the budget's ceiling.
    budget = pole_budget([parts.model(x).state_space().a], 0.5, 80.0) + pole_budget([paper.model(on_paper).state_space().a], 0.5, 80.0)
    budget = np.minimum(budget + SAFETY * 16 * EPS, 1e-12)
    for name in paper.spec.objectives:
        assert_within(a[name], b[name], budget, name)


def test_bore_and_rod_as_variables_and_the_rows_that_break_them(rng):
    data = sized(variables={"bore": {"lower": "40 mm", "upper": "63 mm"}, "rod": {"lower": "20 mm", "upper": "45 mm"}})
    p = problem_from_dict(data)
    assert p.variable_names == ("p0", "Rv", "bore", "rod")
    assert p.lower[2:] == pytest.approx([0.040, 0.020]) and p.upper[2:] == pytest.approx([0.063, 0.045])
    x = np.array([[2e6, 8e5, 0.050, 0.028], [2e6, 8e5, 0.040, 0.045], [2e6, 8e5, 0.045, 0.045]])
    df = p.evaluate(x)
    assert df.loc[0, "status"] == "ok"
    assert list(df.loc[1:, "status"]) == ["invalid", "invalid"]
    assert "rod = 0.045 is not thinner than bore = 0.04" in df.loc[1, "reason"]
    # the model's dA and lam are the hand values of the sizes
    params = p.model(x[:1]).his.params
    assert params["dA"][0] == pytest.approx(math.pi * 0.014**2, rel=1e-15)
    assert params["lam"][0] == pytest.approx(1 - (0.028 / 0.050) ** 2, rel=1e-15)
    assert params["dA_rear"][0] == params["dA"][0]  # the rear follows the front


def test_casadi_reads_the_sizes_as_numpy_does():
    ca = pytest.importorskip("casadi")
    from hisopt.evaluation.evaluate import roll_gradient
    from hisopt.optim.gradient.casadi_model import CasadiModel

    p = problem_from_dict(sized(variables={"rod": {"lower": "20 mm", "upper": "45 mm"}}))
    x = np.array([2e6, 8e5, 0.030])
    sym = ca.MX.sym("x", 3)
    symbolic = float(ca.Function("rg", [sym], [CasadiModel(p, compile=False).roll_gradient(sym)])(x))
    # one static 7 x 7 solve each, by CasADi and by LAPACK: rounding of a well-conditioned solve
    assert symbolic == pytest.approx(roll_gradient(p.model(x[None]), p.spec.handling.gravity_moment)[0], rel=1e-12)


@pytest.mark.parametrize(
    "change, key",
    [
        ({"his": {"rod": 0.06}}, "his.rod"),  # not thinner than the 50 mm bore
        ({"his": {"dA": 1e-3}}, "his.dA"),  # sized twice
        ({"his": {"rod": None}}, "his.rod"),  # a bore alone
        ({"his": {"bore_rear": 0.05}, "drop": True}, "his.bore_rear"),  # a rear size without the front's
        ({"variables": {"lam": {"lower": 0.1, "upper": 0.8}}}, "variables.lam"),
        ({"his": {"rod": "28 kg"}}, "his.rod"),  # a unit that does not fit
    ],
)
def test_bad_sizes_are_one_line_naming_the_key(tmp_path, change, key):
    data = sized({"bore": 0.050, "rod": 0.028})
    data["his"] |= {k: v for k, v in change.get("his", {}).items() if v is not None}
    for k, v in change.get("his", {}).items():
        if v is None:
            data["his"].pop(k)
    if change.get("drop"):
        data["his"].pop("bore")
        data["his"].pop("rod")
        data["his"] |= {"dA": 10e-4, "lam": 0.5}
    data["variables"] |= change.get("variables", {})
    path = tmp_path / "bad.toml"
    path.write_text(_toml(data))
    result = run_cli("evaluate", str(path))
    assert result.code == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert f"{key}:" in result.stderr, result.stderr


def _toml(data: dict) -> str:
    import tomli_w

    return tomli_w.dumps(data)
