"""Issue 39, physical damper valves where users meet them (docs/model.md §3.3, §12.2, §12.4, §20):

- bad input, probe by probe: one line naming the key and the reason, exit 2 from the CLI,
  :class:`~hisopt.errors.ConfigError` from :func:`hisopt.load_problem`, nothing written;
- a custom layout's ``damper_valve`` elements, a design variable on one of their
  ``[his.parameters]``: the paper's layout written out that way gives the shipped valves
  problem's objectives (its Rv valves made damper valves by ``[his] orifice_diameter``), and it
  optimises;
- ``hisopt layouts`` on the valves problem: the damping of a layout is its damper valves'
  equivalent resistances at the baseline on the road, against the closed form
  ``A_b^2 sum_j R_j`` (each bottom-chamber valve carries ``A_b`` per unit stroke), with those
  resistances from :func:`hisopt.evaluation.valve_states.valve_states`;
- the synthesis screens the roll-plane candidate to the same damping and a tiny synthesis runs.
"""

from __future__ import annotations

import re
import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.errors import ConfigError
from hisopt.evaluation.valve_flows import FLOW_TOLERANCE
from hisopt.io import read_csv
from tests.cli_inprocess import assert_one_line, run_cli
from tests.conftest import ROOT

VALVES = ROOT / "tests" / "data" / "valves_one_road.toml"  # the valves problem on its city road alone
TEXT = VALVES.read_text(encoding="utf-8")
CUSTOM_TEXT = (ROOT / "problems" / "layout_custom_roll_plane.toml").read_text(encoding="utf-8")


def edited(text: str, *changes: tuple[str, str]) -> str:
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def without_valve_keys(text: str) -> str:
    """The valves problem with no damper valve value in ``[his]`` (its Rv valves stay linear)."""
    return re.sub(r"(?m)^(orifice_diameter|discharge_coefficient|cracking_pressure|blowoff_resistance) = .*\n", "", text, count=4)


def custom_valves_text(front: str = '"d_front"', crack: str = '"p_crack"') -> str:
    """The paper's layout written out with damper_valve elements: front orifice ``d_front``
    (a design variable), rear ``d_rear``, each with the valves problem's blow-off and discharge
    coefficient; the rest as the valves problem (roads, car, charge, p0 dA lam)."""
    head = TEXT.split("[his]")[0].replace('name = "roll_plane_his_valves"', 'name = "custom_damper_valves"')
    his = without_valve_keys(TEXT.split("[his]\n")[1].split("[his.charge]")[0])
    rest = "[his.charge]" + TEXT.split("[his.charge]")[1]
    rest = edited(rest, ('orifice_diameter = { lower = "1 mm"', 'd_front = { lower = "1 mm"'), ("cracking_pressure = { lower", "p_crack = { lower"))
    rear_law = f"discharge_coefficient = 0.7, cracking_pressure = {crack}, blowoff_resistance = 2e9"
    circuits = "\n".join(
        f"""[[his.circuits]]
name = "{c}"
nodes = ["{c}", "{c}.{f}", "{c}.{r}"]
chambers = {{ {chambers} }}
elements = [
    {{ type = "accumulator", node = "{c}" }},
    {{ type = "damper_valve", from = "{c}.{f}", to = "{c}", orifice_diameter = {front}, cracking_pressure = {crack}, blowoff_resistance = "2e9 Pa s/m^3" }},
    {{ type = "damper_valve", from = "{c}.{r}", to = "{c}", orifice_diameter = "d_rear", {rear_law} }},
]
"""
        for c, f, r, chambers in (
            ("A", "2b", "4b", '1t = "A", 2b = "A.2b", 3t = "A", 4b = "A.4b"'),
            ("B", "1b", "3b", '1b = "B.1b", 2t = "B", 3b = "B.3b", 4t = "B"'),
        )
    )
    parameters = '[his.parameters]\nd_front = "3 mm"\nd_rear = "3 mm"\n' + ('p_crack = "1.5 MPa"\n\n' if crack == '"p_crack"' else "\n")
    return f'{head}[his]\nlayout = "custom"\n{his}{parameters}{circuits}\n{rest}'


# --- bad input -----------------------------------------------------------------------------------
BAD = {
    "orifice zero": (TEXT, [('orifice_diameter = "3 mm"', 'orifice_diameter = "0 mm"')], "his.orifice_diameter", "bleed orifice"),
    "orifice negative": (TEXT, [('orifice_diameter = "3 mm"', 'orifice_diameter = "-1 mm"')], "his.orifice_diameter", "got -1 mm"),
    "Cd zero": (TEXT, [("discharge_coefficient = 0.7", "discharge_coefficient = 0")], "his.discharge_coefficient", "vena contracta"),
    "Cd above 1": (TEXT, [("discharge_coefficient = 0.7", "discharge_coefficient = 1.2")], "his.discharge_coefficient", "less than or equal to 1"),
    "cracking negative": (TEXT, [('cracking_pressure = "1.5 MPa"', 'cracking_pressure = "-1 MPa"')], "his.cracking_pressure", "got -1 MPa"),
    "cracking above rating": (
        TEXT,
        [('cracking_pressure = "1.5 MPa"', 'cracking_pressure = "40 MPa"')],
        "his.cracking_pressure",
        "rated working pressure 16 MPa (the baseline precharge 2 MPa gauge times pressure_rating 8)",
    ),
    "cracking bound above rating": (
        TEXT,
        [('upper = "4 MPa", description = "damper valve blow-off', 'upper = "40 MPa", description = "damper valve blow-off')],
        "variables.cracking_pressure",
        "rated working pressure 32 MPa",
    ),
    "cracking without its law": (TEXT, [('blowoff_resistance = "2e9 Pa s/m^3"', "")], "his.cracking_pressure", "needs blowoff_resistance"),
    "law without cracking": (
        TEXT,
        [('cracking_pressure = "1.5 MPa"', ""), ("cracking_pressure = { lower", "# ")],
        "his.blowoff_resistance",
        "needs cracking_pressure",
    ),
    "Rv beside damper valves": (TEXT, [("[variables]\n", "[variables]\nRv = { lower = 0, upper = 1.6e6 }\n")], "variables.Rv", "physical damper valves"),
    "valve variable without valves": (without_valve_keys(TEXT), [], "variables.orifice_diameter", "has no damper valves"),
    "blow-off variable without blow-off": (
        TEXT,
        [('cracking_pressure = "1.5 MPa"', ""), ('blowoff_resistance = "2e9 Pa s/m^3"', "")],
        "variables.cracking_pressure",
        "have no blow-off",
    ),
    "element cracking above rating": (custom_valves_text(crack='"30 MPa"'), [("p_crack = { lower", "# ")], "cracking_pressure", "rated working pressure"),
    "parameter cracking above rating": (
        custom_valves_text(),
        [('p_crack = "1.5 MPa"', 'p_crack = "30 MPa"')],
        "his.parameters.p_crack",
        "rated working pressure",
    ),
    "element blow-off by half": (custom_valves_text(), [(", blowoff_resistance = 2e9 }", " }")], "his.circuits", "needs blowoff_resistance"),
    "element orifice zero": (custom_valves_text(), [('d_rear = "3 mm"', "d_rear = 0")], "his.parameters.d_rear", "bleed orifice"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_damper_valve_input_is_one_line_exit_2(case, tmp_path):
    text, changes, key, reason = BAD[case]
    path = tmp_path / "probe.toml"
    path.write_text(edited(text, *changes), encoding="utf-8")
    line = assert_one_line(run_cli("evaluate", path), key, reason)
    with pytest.raises(ConfigError) as err:
        hisopt.load_problem(path)
    assert str(err.value) in line and "\n" not in str(err.value)


def test_a_refused_optimise_writes_nothing(tmp_path):
    path = tmp_path / "probe.toml"
    path.write_text(edited(TEXT, ("[variables]\n", "[variables]\nRv = { lower = 0, upper = 1.6e6 }\n")), encoding="utf-8")
    assert_one_line(run_cli("optimize", path, "--out", tmp_path / "run", "--pop", "8", "--gens", "1"), "variables.Rv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["probe.toml"]


# --- custom layouts ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def valves() -> hisopt.Problem:
    return hisopt.load_problem(VALVES)


def test_custom_damper_valves_give_the_catalogue_valves_objectives(valves, tmp_path):
    custom = hisopt.problem_from_dict(tomllib.loads(custom_valves_text()), "custom.toml")
    assert custom.variable_names == ("p0", "dA", "lam", "d_front", "p_crack")
    assert [type(e).__name__ for c in custom.layout().circuits for e in c.elements].count("DamperValve") == 4
    rng = np.random.default_rng(39)
    x = valves.lower + rng.random((3, 5)) * (valves.upper - valves.lower)
    x[:, 3] = valves.baseline[3]  # the rear orifice is d_rear (fixed) here, orifice_diameter_rear = orifice_diameter there
    got = custom.evaluate(x, log=False)
    want = valves.evaluate(x, log=False)
    for name in valves.objective_names:  # the same network, element for element: round-off only
        # two problems solve the same fixed point from their own starts: each within the flows'
        # tolerance of it, a quantity moving at most as much (its slope in log flow is below 1)
        np.testing.assert_allclose(got[name].to_numpy(), want[name].to_numpy(), rtol=2 * FLOW_TOLERANCE)
    moved = custom.evaluate(np.vstack([custom.baseline, custom.baseline * [1, 1, 1, 1.5, 1]]), log=False)
    assert moved["sigma_aw"].iloc[0] != moved["sigma_aw"].iloc[1]  # d_front acts


def test_custom_damper_valves_optimise(tmp_path):
    path = tmp_path / "custom.toml"
    path.write_text(custom_valves_text(), encoding="utf-8")
    out = run_cli("optimize", path, "--out", tmp_path / "run", "--pop", "8", "--gens", "2")
    assert out.code == 0, out.stderr
    front = read_csv(tmp_path / "run" / "front.csv")
    assert len(front) and front["d_front"].between(1e-3, 6e-3).all()


def test_schematic_draws_damper_valves(valves):
    from hisopt.hydraulics.catalogue import his_parameter_values
    from hisopt.report.schematic import layout_schematic

    fig = layout_schematic(valves.layout(), his_parameter_values(valves.spec.his))
    (trace,) = [t for t in fig.data if t.name == "damper valve"]
    assert len(trace.x) == 4 and trace.marker.symbol == "bowtie"
    assert "orifice_diameter: orifice_diameter = 3 mm" in trace.text[0] and "flow_rms: solved on the road" in trace.text[0]


# --- screening, the layout study and the synthesis ------------------------------------------------
def bore_area(problem: hisopt.Problem) -> float:
    """[m^2] ``A_b = dA / (1 - lam)`` at the baseline (A_t = lam A_b)."""
    his = problem.spec.his
    return his.dA / (1.0 - his.lam)


@pytest.fixture(scope="module")
def resistances(valves) -> np.ndarray:
    from hisopt.evaluation.valve_states import valve_states

    states = valve_states(valves, valves.baseline)
    assert states.converged.all() and states.resistance.shape == (1, 4)
    return states.resistance[0]


def test_layouts_screen_damper_valves_at_their_equivalent_resistance(valves, resistances):
    frame = hisopt.mode_stiffness(valves).set_index("layout")
    row = frame.loc["roll_plane"]
    want = bore_area(valves) ** 2 * resistances.sum()
    assert row["c_roll"] == pytest.approx(want, rel=1e-9) and row["c_bounce"] == pytest.approx(want, rel=1e-9)
    assert 1e9 < resistances.min() and resistances.max() < 1e10  # damper valves, not the paper's Rv
    linear = hisopt.mode_stiffness(hisopt.problem_from_dict(tomllib.loads(edited(without_valve_keys(TEXT), *_valve_variables_out())), "linear.toml"))
    np.testing.assert_allclose(frame["k_roll"].to_numpy(), linear["k_roll"].to_numpy(), rtol=1e-12)  # the valves change no static stiffness
    assert frame["damper_valves"].str.contains("orifice 3 mm, cracking 1.5 MPa").all()
    out = run_cli("layouts", VALVES)
    assert out.code == 0 and "4 damper valves (orifice 3 mm, cracking 1.5 MPa)" in " ".join(out.stdout.split())


def _valve_variables_out() -> list[tuple[str, str]]:
    return [("orifice_diameter = { lower", "# "), ("cracking_pressure = { lower", "# ")]


def test_synthesis_screens_damper_valves_at_the_baseline_resistance(valves, resistances):
    from hisopt.hydraulics import topology
    from hisopt.studies import synthesis

    enumeration = topology.enumerate_layouts(6, "all", symmetric=True)
    frame = synthesis.screening_frame(valves, enumeration)
    (roll_plane,) = [i for i, name in synthesis.catalogue_names(enumeration).items() if name == "roll_plane"]
    # two front and two rear valves, each held at its axle's mean equivalent resistance
    rear_valve = np.array([e.orifice_diameter == "orifice_diameter_rear" for _, e, _ in valves.network().damper_valves()])
    front, rear = resistances[~rear_valve].mean(), resistances[rear_valve].mean()
    assert rear_valve.sum() == 2 and front != rear
    assert frame.loc[roll_plane, "c_roll"] == pytest.approx(bore_area(valves) ** 2 * 2 * (front + rear), rel=1e-9)
    assert frame.loc[roll_plane, "description"].count(":damper(3 mm, 1.5 MPa)") == 4


def test_a_tiny_synthesis_optimises_a_layout_with_damper_valves(tmp_path):
    from hisopt.studies import synthesis

    text = TEXT + '\n[synthesis]\nscreen = { c_roll = { min = "1 kN s/m" }, k_roll = { min = "100 kN/m" } }\n'  # valves that damp roll
    problem = hisopt.problem_from_dict(tomllib.loads(text), "synthesis.toml")
    result = synthesis.run_synthesis(problem, 4, seeds=[1], pop_size=8, generations=1, optimise=1, out=tmp_path / "syn")
    assert result.study is not None
    row = result.layouts.iloc[0]
    assert row["layout"] != "roll_plane" and row["description"].count(":damper(3 mm, 1.5 MPa)") == 2
    assert row["damper_valves"].startswith("2 damper valves (orifice 3 mm, cracking 1.5 MPa), equivalent resistance")
    assert not row["refined"]  # the NLP holds one resistance per valve: solved flows keep the sampled design
    candidate = hisopt.load_problem(tmp_path / "syn" / row["file"])
    assert len(candidate.network().solved_valves()) == 2
    assert {"orifice_diameter", "cracking_pressure"} <= set(candidate.variable_names) and "Rv" not in candidate.variable_names
