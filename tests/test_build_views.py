"""The buildability verdict in the views (docs/model.md §21.3, §17.4, §8.1): the design sheet's
section and ``hisopt evaluate --build``.

Every number is checked against :func:`hisopt.studies.buildability.load_case_rules`,
``rule_sheet`` and ``buildability`` computed here on the same designs; a shown value is read
back with :func:`hisopt.quantities.to_si` from its cell (4 significant figures: within 5e-4
relative), so the cells can be pasted back. The layout study's and synthesis's columns are
checked in tests/test_layout_study.py on its study.
"""

from __future__ import annotations

import re
import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.coupled.buildability import RULES
from hisopt.io import read_csv
from hisopt.problem import problem_from_dict
from hisopt.quantities import to_si
from hisopt.report.sheet import BUILD_SECTION, markdown, tables
from hisopt.studies.build_views import ALL_CASES, RULE_DISPLAY, pressure_basis, usage_columns, verdict_sentence
from hisopt.studies.buildability import buildability, load_case_rules, rule_sheet
from hisopt.studies.design_sheet import design_sheet
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

ENVELOPE = ROOT / "problems" / "roll_plane_his_envelope.toml"
PARTS = ROOT / "problems" / "roll_plane_his_parts.toml"
pytestmark = pytest.mark.filterwarnings("ignore::hisopt.errors.PlausibilityWarning")  # the envelope's -20 degC oil
SHOWN = 5e-4
"""[-] Relative rounding of a cell of 4 significant figures (half a unit in the 4th)."""


def _cells(text: str, section: str) -> list[list[str]]:
    """The rows of the pipe table under ``## section`` of a sheet's Markdown."""
    part = text.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in part.splitlines() if line.startswith("| ")]
    return [[c.strip() for c in row.strip("|").split(" | ")] for row in rows[1:]]


@pytest.mark.parametrize("path", [ENVELOPE, PARTS], ids=["envelope", "parts"])
def test_the_sheets_section_is_every_rule_of_the_design(path):
    """Six load cases (the envelope's), and hoses (the parts problem's): each rule's load case,
    value, limit and margin as rule_sheet gives them, in MPa, mm, kN, m/s, Hz or bare."""
    problem = hisopt.load_problem(path, warn_implausible=False)
    x = problem.baseline
    sheet = design_sheet(problem, x, 0, "test")
    expected = rule_sheet(load_case_rules(problem, x[None, :]))
    assert list(sheet.build["rule"]) == list(RULES)
    np.testing.assert_array_equal(sheet.build["usage"].to_numpy(), expected["usage"].to_numpy())
    text = markdown(sheet)
    rows = _cells(text, BUILD_SECTION)
    assert [r[0] for r in rows] == list(RULES)
    for row, rule in zip(rows, expected.itertuples(index=False), strict=True):
        _, check, case, basis, value, limit, margin, holds = row
        assert check == RULES[rule.rule].label and basis == (pressure_basis(rule.rule) or "–")
        assert holds == ("yes" if rule.holds else "no")
        assert float(margin.removesuffix(" %")) == pytest.approx(100 * rule.margin, rel=SHOWN, abs=1e-9)
        if not np.isfinite(rule.limit):  # nothing to check: the layout has no such part
            assert (case, value, limit, rule.usage) == ("–", "–", "–", 0.0)
            continue
        assert case == rule.load_case
        unit = RULE_DISPLAY[rule.unit].unit
        for cell, number in ((value, rule.value), (limit, rule.limit)):
            assert cell.endswith(f" {unit}") if unit != "-" else re.fullmatch(r"-?[0-9.e+-]+", cell), cell
            assert to_si(cell, rule.unit) == pytest.approx(number, rel=SHOWN)
    verdict = buildability(problem, x[None, :]).iloc[0]
    first = text.split("\n\n")[1]  # the heading's line says the verdict too
    assert verdict_sentence(expected) in first
    assert first.count("Not buildable") == (not verdict["buildable"])
    assert f"the binding rule is {verdict['binding_rule']} " in first
    worst = float(re.search(r"margin (-?[0-9.]+) %\.", first).group(1))
    assert worst == pytest.approx(100 * verdict["build_margin"], rel=SHOWN)
    assert BUILD_SECTION in dict(tables(sheet))


def test_a_design_that_holds_every_rule_says_so():
    """A rule sheet whose every usage is at most 1 is buildable, its binding rule the largest."""
    problem = hisopt.load_problem(ENVELOPE, warn_implausible=False)
    sheet = rule_sheet(load_case_rules(problem, problem.baseline[None, :]))
    sheet["usage"] = np.linspace(0.1, 0.9, len(sheet))
    sheet["margin"], sheet["holds"] = 1 - sheet["usage"], True
    assert verdict_sentence(sheet).startswith(f"Buildable: every rule holds in every load case; the binding rule is {sheet['rule'].iloc[-1]} ")


def _designs_file(problem, tmp_path, rows):
    path = tmp_path / "designs.csv"
    lines = [",".join(problem.variable_names)] + [",".join(repr(float(v)) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_evaluate_build_writes_every_rules_usage_per_load_case(tmp_path):
    problem = hisopt.load_problem(ENVELOPE, warn_implausible=False)
    x = problem.design_matrix([{}, {"p0": 1e6}])
    out = tmp_path / "results.csv"
    result = run_cli("evaluate", str(ENVELOPE), "--designs", str(_designs_file(problem, tmp_path, x)), "--build", "--out", str(out))
    assert result.code == 0, result.stderr
    written = read_csv(tmp_path / "results_build.csv")
    assert list(written.columns) == list(usage_columns())
    assert set(written.attrs["units"].values()) == {"-"}
    cases = load_case_rules(problem, x)
    names = [c.name for c in cases]
    assert list(written["load_case"]) == (names + [ALL_CASES]) * 2
    for design in range(2):
        mine = written[written["design"] == design].set_index("load_case")
        for case in cases:
            for name in RULES:
                assert mine.loc[case.name, name] == pytest.approx(case.rules[name].usage[design], rel=1e-12, abs=1e-15)
        verdict = buildability(problem, x).iloc[design]
        for name in [*RULES, "build_margin"]:
            assert mine.loc[ALL_CASES, name] == pytest.approx(verdict[name], rel=1e-12, abs=1e-15)
        assert mine.loc[ALL_CASES, "binding_rule"] == verdict["binding_rule"]
        assert bool(mine.loc[ALL_CASES, "buildable"]) == bool(verdict["buildable"])
        assert verdict_sentence(rule_sheet(cases, design)) in result.stdout
    for case in names:
        assert case in result.stdout
    again = run_cli("evaluate", str(ENVELOPE), "--designs", str(tmp_path / "designs.csv"), "--build", "--out", str(out))
    assert again.code == 0, again.stderr  # its own table from before is written again


@pytest.mark.parametrize("flag, beside", [("--build", "paper_build.csv"), ("--valves", "paper_valves.csv")])
def test_a_file_beside_out_that_hisopt_did_not_write_is_refused_before_any_work(tmp_path, flag, beside):
    problem = DEFAULT_PROBLEM if flag == "--build" else ROOT / "tests" / "data" / "valves_one_road.toml"
    mine = tmp_path / beside
    mine.write_text("my,own,notes\n1,2,3\n", encoding="utf-8")
    result = run_cli("evaluate", str(problem), flag, "--out", str(tmp_path / "paper.csv"))
    assert result.code == 2 and len(result.error_lines) == 1, result.stderr
    assert str(mine) in result.stderr and "--out" in result.stderr
    assert mine.read_text(encoding="utf-8") == "my,own,notes\n1,2,3\n" and not (tmp_path / "paper.csv").exists()


def test_a_constrained_rule_is_an_ordinary_column_with_units_row_dash(tmp_path):
    """The metrics' columns equal the verdict's usages (one load case: the paper's road)."""
    data = tomllib.loads(DEFAULT_PROBLEM.read_text(encoding="utf-8"))
    data["constraints"] = [{"name": "strut_load_usage", "limit": 1.0}, {"name": "build_usage", "limit": 1.0}]
    path = tmp_path / "constrained.toml"
    import tomli_w

    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    problem = problem_from_dict(data, warn_implausible=False)
    out = tmp_path / "results.csv"
    assert run_cli("evaluate", str(path), "--out", str(out)).code == 0
    written = read_csv(out)
    assert written.attrs["units"]["strut_load_usage"] == "-" and written.attrs["units"]["build_usage"] == "-"
    verdict = buildability(problem, problem.baseline[None, :]).iloc[0]
    assert written.loc[0, "strut_load_usage"] == pytest.approx(verdict["strut_load_usage"], rel=1e-12)
    # the binding rule here reads the road's swing: the problem's evaluator and the verdict's own
    # (no objectives) integrate the band RMS on their own grids, 7e-7 apart measured (2026-12-05)
    assert written.loc[0, "build_usage"] == pytest.approx(1.0 - verdict["build_margin"], rel=1e-5)
