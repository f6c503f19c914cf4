"""Physical damper valves where a user reads a design (docs/model.md §3.3, §8.1, §17.4, §19):
the design sheet's valve sections, ``hisopt evaluate --valves`` and the decision room.

Checked against what they must be independently of how they are shown: each valve's
settings read back (as TOML quantities) to the design's values; each equivalent resistance is
the law's (:func:`hisopt.hydraulics.laws.damper_valve_equivalent_resistance`) at the RMS flow
shown beside it, to the fixed point's tolerance; each load case's roll and bounce damping is
that of the modes of that load case's own model (solved apart by ``Problem.model``); the
validated-range mark follows the threshold; and the paper problem's columns are unchanged.

Error budgets: the fixed point stops when ``|log F(s) - log s| <= 1e-4``
(:data:`hisopt.evaluation.valve_flows.FLOW_TOLERANCE`), and the equivalent resistance's
slope in ``log s`` is at most 1, so the resistance at the shown flow matches the shown
resistance to 1e-4 relative. Two solves of the same fixed point agree to the same budget, so
damping ratios (their slope in the resistance, log-log, below 1) to 1e-4. A shown setting has 4
significant figures: 5e-4 relative.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import hisopt
from hisopt.coupled.modal import modal_table
from hisopt.evaluation.valve_flows import FLOW_TOLERANCE
from hisopt.evaluation.valve_states import OUTSIDE_VALIDATED_RANGE, VALIDATED_RESISTANCE, valve_states
from hisopt.hydraulics import laws
from hisopt.io import read_csv
from hisopt.quantities import to_si
from hisopt.report.sheet import VALVE_SECTIONS, markdown, tables
from hisopt.studies import damper_valves
from hisopt.studies.decision_room import Source, decision_room_data, valve_columns
from hisopt.studies.design_sheet import design_sheet
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

VALVES = ROOT / "tests" / "data" / "valves_one_road.toml"  # the valves problem on its city road alone
SCENARIOS = """
[[scenarios]]
name = "smooth"
road = { class = "B", speed = 20.0 }
weight = 0.5

[[scenarios]]
name = "rough"
road = { class = "D", speed = 10.0 }
weight = 0.5
"""
MODERATE = {"p0": 3.0e6, "dA": 1.07e-4, "lam": 0.22, "orifice_diameter": 3.6e-3, "cracking_pressure": 2.0e6}
"""A design of the valves problem whose valves sit inside the validated range (about 0.33 GPa s/m^3)."""
STIFF = {"orifice_diameter": 2e-3, "cracking_pressure": 4e6}
"""The baseline with a 2 mm bleed whose blow-off hardly opens: about 9.5-9.9 GPa s/m^3, outside."""
FIXED_POINT_BUDGET = FLOW_TOLERANCE
SHOWN_BUDGET = 5e-4


@pytest.fixture(scope="module")
def problem():
    return hisopt.load_problem(VALVES)


@pytest.fixture(scope="module")
def scenario_problem(tmp_path_factory):
    path = tmp_path_factory.mktemp("valves") / "valves_scenarios.toml"
    path.write_text(VALVES.read_text(encoding="utf-8") + SCENARIOS, encoding="utf-8")
    return hisopt.load_problem(path)


def _design(problem, values: dict[str, float]) -> np.ndarray:
    return problem.design_matrix(values)[0]


# --- the library ---------------------------------------------------------------------------------
def test_each_resistance_is_the_laws_at_the_flow_shown_beside_it(scenario_problem):
    x = scenario_problem.design_matrix([MODERATE, {}])  # {}: the baseline
    cases = damper_valves.load_case_valves(scenario_problem, x)
    assert [c.name for c in cases] == ["smooth", "rough"]
    table = damper_valves.valve_table(cases)
    assert len(table) == 2 * 2 * 4 and table.attrs["units"]["flow_rms"] == "m^3/s"
    for case in cases:
        for design in range(len(x)):
            his = case.model(design).his
            for j, (k, _, _) in enumerate(his.network.damper_valves()):
                r, kq, p_c, r_b = (float(np.ravel(v)[0]) for v in his.values.damper[k])
                expected = laws.damper_valve_equivalent_resistance(case.states.flow_rms[design, j], kq, p_c, r_b, r)
                assert case.states.resistance[design, j] == pytest.approx(float(expected), rel=FIXED_POINT_BUDGET)
    rough, smooth = (table[table["load_case"] == name]["flow_rms"].to_numpy() for name in ("rough", "smooth"))
    assert np.all(rough > 2 * smooth)  # class D at 10 m/s drives the valves harder than class B at 20 m/s


def test_the_validated_range_follows_the_threshold(problem):
    x = problem.design_matrix([MODERATE, STIFF])
    cases = damper_valves.load_case_valves(problem, x)
    resistance = cases[0].states.resistance
    assert np.all(resistance[0] < VALIDATED_RESISTANCE) and np.all(resistance[1] > VALIDATED_RESISTANCE)
    table = damper_valves.valve_table(cases)
    assert list(table["validated_range"]) == [damper_valves.INSIDE] * 4 + [damper_valves.OUTSIDE] * 4
    assert list(damper_valves.designs_outside(cases)) == [False, True]
    assert "1 of 2 designs" in (damper_valves.outside_summary(cases, "here") or "")


def test_a_row_breaking_a_rule_blanks_only_itself(problem):
    x = problem.design_matrix([STIFF, {"p0": -1.0}, MODERATE])  # p0 >= 0 broken: not evaluated, as by evaluate
    cases = damper_valves.load_case_valves(problem, x)
    alone = [valve_states(problem, x[[i]]).resistance[0] for i in (0, 2)]
    np.testing.assert_allclose(cases[0].states.resistance[[0, 2]], alone, rtol=FIXED_POINT_BUDGET)
    ranges = damper_valves.valve_table(cases).groupby("design")["validated_range"].agg(set)
    assert list(ranges) == [{damper_valves.OUTSIDE}, {damper_valves.NOT_EVALUATED}, {damper_valves.INSIDE}]
    assert damper_valves.outside_summary(cases, "here") == f"here: 1 of 3 designs have a damper valve {OUTSIDE_VALIDATED_RANGE}; see --valves"


def test_a_load_cases_damping_is_that_of_its_own_model(scenario_problem):
    x = _design(scenario_problem, MODERATE)[None, :]
    cases = damper_valves.load_case_valves(scenario_problem, x)
    damping = damper_valves.mode_damping(cases)
    for case, row in zip(cases, damping.itertuples(), strict=True):
        modes = modal_table(scenario_problem.scenario_space(case.name).model(x)).set_index("mode")  # solves its own fixed point
        assert row.roll_damping_ratio == pytest.approx(modes.loc["roll", "damping_ratio"], rel=FIXED_POINT_BUDGET)
        assert row.bounce_damping_ratio == pytest.approx(modes.loc["bounce", "damping_ratio"], rel=FIXED_POINT_BUDGET)
        assert row.roll_frequency_hz == pytest.approx(modes.loc["roll", "frequency_hz"], rel=FIXED_POINT_BUDGET)
    assert damping["roll_damping_ratio"].iloc[0] != pytest.approx(damping["roll_damping_ratio"].iloc[1], rel=1e-3)  # the road sets it


# --- the design sheet ----------------------------------------------------------------------------
def test_the_sheet_shows_each_valves_settings_as_they_read_back(scenario_problem):
    x = _design(scenario_problem, MODERATE)
    sheet = design_sheet(scenario_problem, x, 3, "front.csv")
    shown = dict(tables(sheet))
    settings = shown[VALVE_SECTIONS[0]]
    assert len(settings) == 4
    for name, unit in (("orifice_diameter", "m"), ("cracking_pressure", "Pa")):
        for text in settings[name]:
            assert to_si(text, unit) == pytest.approx(MODERATE[name], rel=SHOWN_BUDGET)
    assert {to_si(t, "-") for t in settings["discharge_coefficient"]} == {0.7}
    assert {to_si(t, "Pa s m^-3") for t in settings["blowoff_resistance"]} == {2e9}
    per_case = shown[VALVE_SECTIONS[1]]
    assert list(per_case.columns) == ["load_case [-]", "valve [-]", "flow_rms [L/s]", "resistance [GPa s/m^3]", "validated_range [-]"]
    states = valve_states(scenario_problem.scenario_space("rough"), x[None, :])
    rough = per_case[per_case["load_case [-]"] == "rough"]
    np.testing.assert_allclose(rough["flow_rms [L/s]"].astype(float), states.flow_rms[0] * 1e3, rtol=SHOWN_BUDGET)
    np.testing.assert_allclose(rough["resistance [GPa s/m^3]"].astype(float), states.resistance[0] * 1e-9, rtol=SHOWN_BUDGET)
    assert list(shown[VALVE_SECTIONS[2]]["load_case [-]"]) == ["smooth", "rough"]
    text = markdown(sheet)
    assert "## Damper valves per load case" in text and "## Roll and bounce damping per load case" in text
    assert "valve a - b: coefficient" not in text  # a physical valve is its settings, not one number


def test_the_sheet_marks_a_valve_outside_the_validated_range(problem):
    outside = markdown(design_sheet(problem, _design(problem, STIFF), 0, "front.csv"))
    inside = markdown(design_sheet(problem, _design(problem, MODERATE), 0, "front.csv"))
    assert f"Its damper valves are {OUTSIDE_VALIDATED_RANGE} in: road." in outside
    assert "| outside |" in outside and "4 of 4 valve and load-case pairs are outside" in outside
    assert OUTSIDE_VALIDATED_RANGE not in inside.split("\n\n")[1] and "| inside |" in inside


def test_a_sheet_without_damper_valves_has_no_valve_section():
    paper = hisopt.load_problem(DEFAULT_PROBLEM)
    sheet = design_sheet(paper, paper.baseline, 0, "front.csv")
    assert [name for name, _ in tables(sheet)] == ["Parts and settings", "Quantities", "Operating envelope", "Modes with HIS", "Buildability"]
    assert any(  # the paper's Rv keeps its coefficient row
        item.startswith("valve ") and item.endswith(": coefficient") for item in sheet.parts["item"]
    )


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("valves_run") / "run"
    assert run_cli("optimize", str(VALVES), "--out", str(out), "--pop", "8", "--gens", "2", "--seed", "1").code == 0
    return out


def test_hisopt_sheet_writes_the_valves_and_its_problem_file_keeps_them(run_dir, tmp_path):
    result = run_cli("sheet", str(run_dir), "--design", "0", "--out", str(tmp_path))
    assert result.code == 0, result.stderr
    text = (tmp_path / "sheet.md").read_text(encoding="utf-8")
    assert "## Damper valves" in text and "| road |" in text
    design = read_csv(run_dir / "front.csv").iloc[0]
    data = tomllib.loads((tmp_path / "sheet.toml").read_text(encoding="utf-8"))
    for name in ("orifice_diameter", "cracking_pressure"):
        assert data["his"][name] == float(design[name])  # the file reproduces the design's valves exactly


# --- hisopt evaluate ------------------------------------------------------------------------------
def test_evaluate_valves_prints_and_writes_each_valve(tmp_path):
    out = tmp_path / "results.csv"
    problem = hisopt.load_problem(VALVES)
    x = _design(problem, STIFF)
    designs = tmp_path / "stiff.csv"
    designs.write_text(",".join(problem.variable_names) + "\n" + ",".join(repr(float(v)) for v in x) + "\n", encoding="utf-8")
    result = run_cli("evaluate", str(VALVES), "--designs", str(designs), "--valves", "--out", str(out))
    assert result.code == 0, result.stderr
    assert f"1 of 1 designs have a damper valve {OUTSIDE_VALIDATED_RANGE}" in result.stderr
    written = read_csv(tmp_path / "results_valves.csv")
    assert list(written.columns) == ["design", "load_case", "valve", "flow_rms", "resistance", "validated_range", "converged"]
    states = valve_states(problem, x[None, :])
    np.testing.assert_allclose(written["resistance"].to_numpy(dtype=float), states.resistance[0], rtol=1e-12)
    assert set(written["validated_range"]) == {"outside"}
    assert "flow_rms" in result.stdout and "L/s" in result.stdout and "GPa s/m^3" in result.stdout


def test_evaluate_keeps_its_columns_with_and_without_valves(tmp_path):
    paper = hisopt.load_problem(DEFAULT_PROBLEM)
    columns = list(paper.evaluate(paper.baseline, log=False).columns)
    assert columns == ["p0", "dA", "lam", "Rv", "sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd", "feasible", "status", "reason"]
    valves = hisopt.load_problem(VALVES)
    expected = [*valves.variable_names, *valves.objective_names, "feasible", "status", "reason"]
    assert list(valves.evaluate(valves.baseline, log=False).columns) == expected  # the valves are --valves' table, not columns
    result = run_cli("evaluate", str(DEFAULT_PROBLEM), "--out", str(tmp_path / "paper.csv"))
    assert result.code == 0 and list(read_csv(tmp_path / "paper.csv").columns) == columns
    assert "damper valve" not in result.stderr


def test_evaluate_valves_on_a_problem_without_valves_is_refused_before_any_work(tmp_path):
    out = tmp_path / "paper.csv"
    result = run_cli("evaluate", str(DEFAULT_PROBLEM), "--valves", "--out", str(out))
    assert result.code == 2 and len(result.error_lines) == 1
    assert "--valves" in result.stderr and "has no damper valves" in result.stderr
    assert not out.exists() and not (tmp_path / "paper_valves.csv").exists()


# --- the decision room ----------------------------------------------------------------------------
def test_the_room_holds_each_valves_resistance_per_load_case(scenario_problem):
    x = scenario_problem.design_matrix([MODERATE, {}])
    columns = valve_columns(scenario_problem, x)
    assert len(columns) == 2 * 4 and all(name.endswith(("@smooth", "@rough")) for name in columns)
    states = valve_states(scenario_problem.scenario_space("smooth"), x)
    for j, label in enumerate(states.labels):
        np.testing.assert_array_equal(columns[f"{label} resistance@smooth"], states.resistance[:, j])
    assert valve_columns(hisopt.load_problem(DEFAULT_PROBLEM), x[:, :4]) == {}


def test_the_page_marks_a_design_outside_the_validated_range(problem, tmp_path):
    from hisopt.report.decision_page import room_payload, write_decision_room
    from tests.test_decision_room import _driver_or_skip

    x = problem.design_matrix([MODERATE, STIFF, {"orifice_diameter": 1e-3, "cracking_pressure": 4e6}])
    room = decision_room_data([Source("valves", problem, x, np.array(["front"] * len(x)), np.arange(len(x)))])
    payload = room_payload(room)
    assert payload["validated_resistance"] == VALIDATED_RESISTANCE
    valve = [c for c in payload["columns"] if c["group"] == "valve"]
    assert len(valve) == 4 and {c["unit"] for c in valve} == {"Pa s m^-3"}
    resistance = room.table[[c["name"] for c in valve]].to_numpy()
    outside = np.any(resistance > VALIDATED_RESISTANCE, axis=1)
    assert list(outside) == [False, True, True]
    path = write_decision_room(room, tmp_path / "decision.html", "valves")
    driver = _driver_or_skip(tmp_path)
    try:
        driver.get(path.as_uri())
        assert not [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        shown = [int(r.get_attribute("data-row")) for r in driver.find_elements("css selector", "#designs tr[data-row]")]
        assert set(shown) == set(np.flatnonzero(room.table["front"]))
        assert len({bool(outside[i]) for i in shown}) == 2  # one of each on the front
        for i in shown:
            cell = driver.find_element("css selector", f'#designs tr[data-row="{i}"] td.text')
            driver.execute_script("arguments[0].click()", cell)  # the click itself: a pointer on its way would hover other rows
            title, detail = driver.find_element("id", "d-title").text, driver.find_element("id", "d-table").text
            assert (OUTSIDE_VALIDATED_RANGE in title) == bool(outside[i])
            assert detail.count("(outside the validated range)") == int(np.sum(resistance[i] > VALIDATED_RESISTANCE))
    finally:
        driver.quit()
