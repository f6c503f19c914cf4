"""Issue 22 item 3: every number a person types is read in the unit written (a bare number is SI).

The parser (hisopt.quantities) is checked against closed-form factors (1 MPa = 1e6 Pa,
1 deg = pi/180 rad, hisopt's 1 g = G_MPS2); the edges (problem files, --set, command-line
options, designs files, DataFrames) through the real CLI against the same run in SI; and
every unit that `evaluate`, `layouts` and `compare-layouts` print is pasted back.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hisopt
from hisopt.constants import G_MPS2
from hisopt.errors import ConfigError
from hisopt.hydraulics.layout import FIELD_UNITS
from hisopt.io import read_csv
from hisopt.quantities import KINDS, field_unit, to_si, unit_factor
from hisopt.specification.config import ProblemSpec
from hisopt.units import _STEPS, variable_units
from tests.cli_inprocess import Outcome, run_cli
from tests.conftest import DEFAULT_PROBLEM

TEXT = DEFAULT_PROBLEM.read_text(encoding="utf-8")
DEG = math.pi / 180.0

# A unit conversion is one or two float products of decimal factors (prefixes, pi/180, g):
# a few ulp, so 1e-14 relative. A run fed the converted values sees inputs within that of the
# SI run's; the evaluation is deterministic to 1e-12 relative (the determinism contract), which
# bounds the difference of their results.
CONVERSION_RTOL = 1e-14
SAME_RUN_RTOL = 1e-12
# A printed number has 4 significant figures (hisopt.units.DIGITS): it is within half a unit of
# the 4th digit of the true value, at most 5e-4 of it (leading digit 1); 1e-9 for the SI side.
PRINTED_RTOL = 5e-4 + 1e-9


def one_line(out: Outcome, *parts: str) -> str:
    assert out.code == 2, out
    assert len(out.error_lines) == 1 and "Traceback" not in out.stderr, out.stderr
    line = out.error_lines[0]
    assert line.startswith("error: "), line
    for part in parts:
        assert part in line, line
    return line


def write(tmp_path: Path, text: str, name: str = "p.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def replaced(text: str, *pairs: tuple[str, str]) -> str:
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def assert_same(a: pd.DataFrame, b: pd.DataFrame, rtol: float = SAME_RUN_RTOL) -> None:
    assert list(a.columns) == list(b.columns)
    for col in a.columns:
        if pd.api.types.is_numeric_dtype(a[col]) and not pd.api.types.is_bool_dtype(a[col]):
            np.testing.assert_allclose(a[col].to_numpy(float), b[col].to_numpy(float), rtol=rtol, atol=0, err_msg=col)
        else:
            assert a[col].tolist() == b[col].tolist(), col


# --- the parser against closed forms ----------------------------------------------------------
@pytest.mark.parametrize("si_unit", sorted(_STEPS))
def test_every_display_unit_reads_back_by_its_display_scale(si_unit):
    """Each engineering unit hisopt shows (hisopt.units._STEPS: value shown = scale x SI) is
    read back with the inverse of its hand-written scale."""
    for _, shown, scale in _STEPS[si_unit]:
        assert unit_factor(shown, si_unit) == pytest.approx(1.0 / scale, rel=CONVERSION_RTOL), shown


def test_psd_dimensionless_and_percent_units_read_back():
    for unit in ("rad^2/Hz", "m^2/Hz", "N^2/Hz", "(m/s^2)^2/Hz", "-", "%", "Hz", "m/s^2", "s"):
        assert unit_factor(unit, unit) == 1.0
    assert to_si("50 %", "-") == pytest.approx(0.5, rel=CONVERSION_RTOL)
    assert to_si("2 (m/s^2)^2/Hz", "(m/s^2)^2/Hz") == 2.0
    with pytest.raises(ConfigError, match="is a PSD of an acceleration; expected a PSD of a length"):
        to_si("1 (m/s^2)^2/Hz", "m^2/Hz")


@pytest.mark.parametrize("si_unit", sorted(KINDS))
def test_the_examples_messages_give_are_true(si_unit):
    """The example of each kind (``"2.5 MPa" or 2.5e6 [Pa]``) names one value twice."""
    _, shown, bare = KINDS[si_unit]
    assert to_si(shown, si_unit) == pytest.approx(float(bare), rel=PRINTED_RTOL), shown


def test_g_is_gravity_in_a_roll_gradient_and_an_acceleration_and_gram_in_a_mass():
    # hisopt's "1 g" is the model's own G_MPS2 (a roll gradient per g, step_g in g).
    assert to_si("1.8 deg/g", "rad/g") == pytest.approx(1.8 * DEG, rel=CONVERSION_RTOL)
    assert to_si("0.4 g", "g") == pytest.approx(0.4, rel=CONVERSION_RTOL)
    assert to_si("3.924 m/s^2", "g") == pytest.approx(3.924 / G_MPS2, rel=CONVERSION_RTOL)
    assert to_si("1 deg/(m/s^2)", "rad/g") == pytest.approx(DEG * G_MPS2, rel=CONVERSION_RTOL)
    assert to_si("1 deg/g", "rad/(m/s^2)") == pytest.approx(DEG / G_MPS2, rel=CONVERSION_RTOL)
    assert to_si("0.05 g", "m/s^2") == pytest.approx(0.05 * G_MPS2, rel=CONVERSION_RTOL)
    assert to_si("500 g", "kg") == pytest.approx(0.5, rel=CONVERSION_RTOL)  # a payload of 500 gram
    assert to_si("2 kg", "kg") == 2.0  # the g of kg is the gram's
    with pytest.raises(ConfigError, match=r'"1.8 deg/kg" is of dimension .*; expected a roll gradient'):
        to_si("1.8 deg/kg", "rad/g")
    with pytest.raises(ConfigError, match=r'"5 g" is a mass; expected a pressure'):
        to_si("5 g", "Pa")


def test_micro_litre_and_spacing():
    for text in ("250 µm", "250 μm", "250 um", "250µm", " 250  um "):  # micro sign, Greek mu, u
        assert to_si(text, "m") == pytest.approx(2.5e-4, rel=CONVERSION_RTOL), text
    for text in ("2 L", "2 l", "2000 cm^3", "2 dm^3"):
        assert to_si(text, "m^3") == pytest.approx(2e-3, rel=CONVERSION_RTOL), text
    assert to_si("72 km/h", "m/s") == pytest.approx(20.0, rel=CONVERSION_RTOL)
    assert to_si("0.8 MPa s/m^3", "Pa s m^-3") == pytest.approx(8e5, rel=CONVERSION_RTOL)
    assert to_si("0.8 MPa*s/m³", "Pa s m^-3") == pytest.approx(8e5, rel=CONVERSION_RTOL)


def test_angles_are_not_ratios_and_bare_numbers_stay_si():
    assert to_si("1.5 deg", "rad") == pytest.approx(1.5 * DEG, rel=CONVERSION_RTOL)
    assert to_si("1.5", "rad") == 1.5 and to_si(1.5, "rad") == 1.5 and to_si("2.5e6", "Pa") == 2.5e6
    with pytest.raises(ConfigError, match=r'"0.5 deg" is an angle; expected a dimensionless number'):
        to_si("0.5 deg", "-")
    with pytest.raises(ConfigError, match=r'"0.5 -" is a dimensionless number; expected an angle'):
        to_si("0.5 -", "rad")


def test_a_unit_pint_would_compute_forever_is_refused_at_once():
    import time

    start = time.perf_counter()
    for text in ("1 10^10^10", "1 m^10^10", "1 km^99^99", "1 2^1000", "1 m^1000"):
        with pytest.raises(ConfigError, match="cannot read the unit"):
            to_si(text, "m")
    assert time.perf_counter() - start < 5.0  # pint's import included; 10^10^10 alone never returns
    assert to_si("3 1/s", "Hz") == 3.0 and to_si("1 (m/s^2)^2/Hz", "(m/s^2)^2/Hz") == 1.0


UNIT_ATOMS = [
    "m",
    "km",
    "Gm",
    "^",
    "99",
    "-3",
    "2",
    "/",
    "*",
    "(",
    ")",
    " ",
    "g",
    "deg",
    "Pa",
    "s",
    "1",
    "%",
    "-",
    "µ",
    "L",
    "kg",
    "**",
    "e",
    "°",
    "²",
    "degC",
    "min",
    "'",
    "[",
    ",",
    "_",
    "0",
    ".",
]


@settings(max_examples=300, derandomize=True, database=None, deadline=None)
@given(st.lists(st.sampled_from(UNIT_ATOMS), min_size=1, max_size=8).map("".join) | st.text(max_size=8), st.sampled_from(sorted(KINDS)))
def test_any_text_is_a_number_in_si_or_one_config_error(unit_text, si_unit):
    """Whatever follows a number, the reading is a finite SI number or a ConfigError naming
    the expected kind; never another exception (pint raises many), never a hang."""
    try:
        value = to_si(f"1 {unit_text}", si_unit, key="k")
    except ConfigError as exc:
        assert str(exc).startswith("k: ") and "\n" not in str(exc) and "expected" in str(exc), exc
    else:
        assert math.isfinite(value) and value > 0


def test_messages_name_the_place_the_kind_and_an_example():
    with pytest.raises(ConfigError) as info:
        to_si("2 m", "Pa", file="problems/x.toml", key="his.p0")
    assert str(info.value) == 'problems/x.toml: his.p0: "2 m" is a length; expected a pressure (e.g. "2.5 MPa" or 2.5e6 [Pa])'
    with pytest.raises(ConfigError, match=r'^--p0: "2.5 MPx": unknown unit \'MPx\'; expected a pressure'):
        to_si("2.5 MPx", "Pa", key="--p0")
    with pytest.raises(ConfigError, match=r"^--p0: expected a number \(SI\) or a number with a unit, e.g. .*; got 'abc'$"):
        to_si("abc", "Pa", key="--p0")


# --- every numeric input field declares its SI unit ------------------------------------------
_DYNAMIC = {("Variable", "lower"), ("Variable", "upper"), ("Constraint", "limit")}  # the unit of what they bound


def _float_fields(model: Any, seen: set[Any]) -> list[tuple[Any, str]]:
    out = []
    if model in seen:
        return out
    seen.add(model)
    for name, info in model.model_fields.items():
        ann = info.annotation
        args = [a for a in getattr(ann, "__args__", ()) if a is not type(None)]
        if ann is float or args == [float]:
            out.append((model, name))
        for inner in [ann, *args, *(a for x in args for a in getattr(x, "__args__", ()))]:
            if hasattr(inner, "model_fields"):
                out += _float_fields(inner, seen)
    return out


def test_every_float_field_of_a_problem_file_declares_a_known_si_unit():
    fields = _float_fields(ProblemSpec, set())
    names = {(m.__name__, n) for m, n in fields}
    assert {
        ("VehicleParams", "m_s"),
        ("RollPlaneHIS", "p0"),
        ("PipeLayout", "diameter"),
        ("Fluid", "mu"),
        ("Road", "speed"),
        ("Band", "f_max_hz"),
        ("Handling", "step_g"),
        ("Payload", "I_x"),
        ("Scenario", "weight"),
    } <= names
    missing = [f"{m.__name__}.{n}" for m, n in fields if field_unit(m, n) is None and (m.__name__, n) not in _DYNAMIC]
    assert not missing, missing
    for model, name in fields:
        unit = field_unit(model, name)
        if unit is not None:
            assert unit in KINDS or unit in ("kg", "Pa s"), (model.__name__, name, unit)  # messages name the kind
            assert unit_factor(f" {unit} ", unit) == 1.0
    for unit in FIELD_UNITS.values():  # layout element fields
        assert unit in KINDS, unit
    assert field_unit(ProblemSpec, "name") is None and field_unit(ProblemSpec, "nope") is None


def test_variable_units_come_from_the_declared_units_not_descriptions(problem):
    from hisopt.hydraulics.roll_plane import RollPlaneHIS

    assert not RollPlaneHIS.model_fields["p0"].description.startswith("[")
    assert variable_units(problem) == {"p0": "Pa", "dA": "m^2", "lam": "-", "Rv": "Pa s m^-3"}


# --- problem files ----------------------------------------------------------------------------
SI_EXTRA = """
[payload]
mass = 80.0
x = -0.5
z = 0.3

[[constraints]]
name = "roll_step_peak"
limit = 0.05
"""

UNITS_EXTRA = """
[payload]
mass = "80 kg"
x = "-500 mm"
z = "30 cm"

[[constraints]]
name = "roll_step_peak"
limit = "2.864788975654116 deg"
"""

UNIT_EDITS = (
    ("m_s = 1210.0", 'm_s = "1.21 t"'),
    ("I_x = 390.0", 'I_x = "390 kg m^2"'),
    ("k_sf = 18000.0", 'k_sf = "18 kN/m"'),
    ("c_sf = 1500.0", 'c_sf = "1.5 kN s/m"'),
    ("t_f = 0.74", 't_f = "740 mm"'),
    ("p0 = 2.0e6", 'p0 = "2 MPa"'),
    ("dA = 10e-4", 'dA = "10 cm^2"'),
    ("Rv = 8e5", 'Rv = "0.8 MPa s/m^3"'),
    ("V0 = 1.0e-3", 'V0 = "1 L"'),
    ("upper = 4.0e6", 'upper = "4 MPa"'),
    ("lower = 1.0e-4, upper = 25.0e-4", 'lower = "1 cm^2", upper = "25 cm^2"'),
    ("upper = 16.0e5", 'upper = "1.6 MPa s/m^3"'),
    ("speed = 10.0", 'speed = "36 km/h"'),
    ("f_max_hz = 80.0", 'f_max_hz = "80 Hz"'),
    ("k_x = 1.0", 'k_x = "100 %"'),
)


def test_a_problem_file_with_units_evaluates_as_the_si_one(tmp_path):
    step = "gravity_moment = false"  # [handling] of the paper's problem, with a step in SI and in a unit
    si = write(tmp_path, replaced(TEXT, (step, f"{step}\nstep_g = 0.4")) + SI_EXTRA, "si.toml")
    units = write(tmp_path, replaced(TEXT, *UNIT_EDITS, (step, f'{step}\nstep_g = "3.924 m/s^2"')) + UNITS_EXTRA, "units.toml")
    a, b = hisopt.load_problem(si), hisopt.load_problem(units)
    assert b.spec.road.speed == pytest.approx(10.0, rel=CONVERSION_RTOL) and b.spec.his.V0 == pytest.approx(1e-3, rel=CONVERSION_RTOL)
    assert b.spec.constraints[0].limit == pytest.approx(0.05, rel=CONVERSION_RTOL)  # 2.8648 deg is 0.05 rad
    for name in ("si", "units"):
        out = run_cli("evaluate", tmp_path / f"{name}.toml", "--out", tmp_path / f"{name}.csv")
        assert out.code == 0, out
    assert_same(read_csv(tmp_path / "si.csv"), read_csv(tmp_path / "units.csv"))
    assert a.lower.tolist() == pytest.approx(b.lower.tolist(), rel=CONVERSION_RTOL)


def test_layout_parameters_and_custom_elements_take_units():
    from hisopt.problem import problem_from_dict

    data = hisopt.load_problem(Path(DEFAULT_PROBLEM).parent / "layout_roll_plane_accumulator_valves.toml").spec.model_dump(by_alias=True)
    data["his"]["parameters"]["Rv_acc"] = "100 MPa s/m^3"
    data["variables"]["Rv_acc"] = {"lower": "1 MPa s/m^3", "upper": "1 GPa s/m^3"}
    p = problem_from_dict(data)
    assert p.spec.his.parameters["Rv_acc"] == pytest.approx(1e8, rel=CONVERSION_RTOL)
    assert p.spec.variables["Rv_acc"].upper == pytest.approx(1e9, rel=CONVERSION_RTOL)
    data["his"]["parameters"]["Rv_acc"] = "100 L"
    with pytest.raises(ConfigError, match=r'^<problem>: his.parameters.Rv_acc: "100 L" is a volume; expected a valve coefficient'):
        problem_from_dict(data)
    custom = hisopt.load_problem(Path(DEFAULT_PROBLEM).parent / "layout_custom_roll_plane.toml").spec.model_dump(by_alias=True)
    element = custom["his"]["circuits"][0]["elements"][0]
    assert element["type"] == "accumulator"
    element["volume"] = "1.5 L"
    assert problem_from_dict(custom).layout().circuits[0].elements[0].volume == pytest.approx(1.5e-3, rel=CONVERSION_RTOL)
    element["volume"] = "1.5 m"
    with pytest.raises(ConfigError, match=r'his.circuits.0.elements.0.volume: "1.5 m" is a length; expected a volume'):
        problem_from_dict(custom)


def test_scenario_roads_payloads_and_weights_take_units(tmp_path):
    robust = Path(DEFAULT_PROBLEM).parent / "roll_plane_his_robust.toml"
    text = robust.read_text(encoding="utf-8")
    edited = replaced(text, ('road = { class = "B", speed = 20.0 }', 'road = { class = "B", speed = "72 km/h" }'))
    spec = hisopt.load_problem(write(tmp_path, edited, "robust.toml")).spec
    assert [sc.road.speed for sc in spec.scenarios if sc.road is not None] == [
        sc.road.speed for sc in hisopt.load_problem(robust).spec.scenarios if sc.road is not None
    ]  # 72 km/h is exactly 20 m/s
    bad = replaced(text, ('road = { class = "B", speed = 20.0 }', 'road = { class = "B", speed = "20 m" }'))
    path = write(tmp_path, bad, "bad.toml")
    one_line(run_cli("evaluate", path), f'{path}: scenarios.1.road.speed: "20 m" is a length; expected a speed')


def test_set_with_a_unit_equals_set_in_si(tmp_path):
    for name, value in (("si", "p0=2.5e6"), ("units", "p0=2.5 MPa"), ("quoted", 'p0="2.5 MPa"')):
        out = run_cli("evaluate", DEFAULT_PROBLEM, "--set", value, "--out", tmp_path / f"{name}.csv")
        assert out.code == 0, out
    si = read_csv(tmp_path / "si.csv")
    assert si.loc[0, "p0"] == 2.5e6
    assert_same(si, read_csv(tmp_path / "units.csv"), rtol=0)  # 2.5 x 1e6 is exact
    assert_same(si, read_csv(tmp_path / "quoted.csv"), rtol=0)


@pytest.mark.parametrize(
    ("args", "parts"),
    [
        (("evaluate", "{P}", "--set", "p0=2 m"), ('--set p0=2 m: "2 m" is a length; expected a pressure (e.g. "2.5 MPa" or 2.5e6 [Pa])',)),
        (("evaluate", "{P}", "--set", "p0=abc"), ("--set p0=abc: expected a valid number, got 'abc'",)),
        (("droptest", "{P}", "--out", "{T}", "--p0", "1 MPa,2 m"), ('--p0: "2 m" is a length; expected a pressure',)),
        (("droptest", "{P}", "--out", "{T}", "--measured-p0", "2 bar/s"), ('--measured-p0: "2 bar/s" is of dimension',)),
        (
            ("compare-layouts", "{P}", "--out", "{T}", "--handling-limit", "1.8 deg"),
            ('--handling-limit: "1.8 deg" is an angle; expected a roll gradient (angle per g) (e.g. "1.8 deg/g"',),
        ),
        (("compare-layouts", "{P}", "--out", "{T}", "--handling-limit", "steep"), ("--handling-limit: expected a number (SI) or a number with a unit",)),
    ],
)
def test_options_refuse_a_unit_of_the_wrong_kind_in_one_line(tmp_path, args, parts):
    out = run_cli(*[a.format(P=DEFAULT_PROBLEM, T=tmp_path / "out") for a in args])
    one_line(out, *parts)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("old", "new", "key", "expect"),
    [
        ("p0 = 2.0e6", 'p0 = "2 m"', "his.p0", '"2 m" is a length; expected a pressure (e.g. "2.5 MPa" or 2.5e6 [Pa])'),
        ("speed = 10.0", 'speed = "10 Hz"', "road.speed", '"10 Hz" is a frequency; expected a speed (e.g. "72 km/h" or 20 [m/s])'),
        ("m_s = 1210.0", 'm_s = "1210 N"', "vehicle.m_s", '"1210 N" is a force; expected a mass'),
        ("p0 = 2.0e6", 'p0 = "2 MPascals"', "his.p0", "\"2 MPascals\": unknown unit 'MPascals'; expected a pressure"),
        ("p0 = 2.0e6", 'p0 = "lots"', "his.p0", "expected a valid number, got 'lots'"),  # today's message
        ('unit = "Pa"', 'unit = "MPa"', "variables.p0.unit", "'MPa' is not the SI unit 'Pa'"),
        ("lam = 0.5", 'lam = "0.5 deg"', "his.lam", '"0.5 deg" is an angle; expected a dimensionless number'),
    ],
)
def test_problem_files_refuse_a_unit_of_the_wrong_kind_in_one_line(tmp_path, old, new, key, expect):
    path = write(tmp_path, replaced(TEXT, (old, new)))
    one_line(run_cli("evaluate", path), f"{path}: {key}: {expect}")


def test_a_roll_limit_in_deg_is_read_as_deg(tmp_path):
    """The issue's case: limit = 1.5 on roll_step_peak was 86 deg; "1.5 deg" is 1.5 deg."""
    path = write(tmp_path, TEXT + '\n[[constraints]]\nname = "roll_step_peak"\nlimit = "1.5 deg"\n')
    assert hisopt.load_problem(path).spec.constraints[0].limit == pytest.approx(1.5 * DEG, rel=CONVERSION_RTOL)
    bad = write(tmp_path, TEXT + '\n[[constraints]]\nname = "roll_step_peak"\nlimit = "1.5 m"\n', "bad.toml")
    one_line(run_cli("evaluate", bad), f'{bad}: constraints.0.limit: "1.5 m" is a length; expected an angle (e.g. "1.5 deg"')


# --- designs files and frames ----------------------------------------------------------------
DESIGNS_SI = "p0,dA,lam,Rv\n[Pa],[m^2],[-],[Pa s m^-3]\n2.5e6,12.5e-4,0.5,8e5\n1.234e6,3.3e-4,0.25,1.5e6\n0,25e-4,0.8,0\n"
DESIGNS_ENG = "p0,dA,lam,Rv\n[MPa],[cm^2],[%],[MPa s/m^3]\n2.5,12.5,50,0.8\n1.234,3.3,25,1.5\n0,25,80,0\n"


def test_a_designs_file_in_engineering_units_evaluates_as_the_si_file(tmp_path, problem):
    (tmp_path / "si.csv").write_text(DESIGNS_SI)
    (tmp_path / "eng.csv").write_text(DESIGNS_ENG)
    for name in ("si", "eng"):
        out = run_cli("evaluate", DEFAULT_PROBLEM, "--designs", tmp_path / f"{name}.csv", "--out", tmp_path / f"{name}-out.csv")
        assert out.code == 0, out
    si, eng = read_csv(tmp_path / "si-out.csv"), read_csv(tmp_path / "eng-out.csv")
    assert_same(si, eng)  # objectives, status and the design columns themselves
    assert eng.attrs["units"]["p0"] == "Pa" and eng.attrs["units"]["dA"] == "m^2"  # written in SI, headed in SI
    # The printed table shows the converted values in engineering units again.
    shown = run_cli("evaluate", DEFAULT_PROBLEM, "--designs", tmp_path / "eng.csv")
    assert shown.code == 0 and "p0 [MPa]" in shown.stdout and "2.500" in shown.stdout and "1.234" in shown.stdout
    # The library path: a frame whose attrs name its units (io.read_csv of the same file).
    assert_same(problem.evaluate(read_csv(tmp_path / "eng.csv")), problem.evaluate(read_csv(tmp_path / "si.csv")))


def test_a_designs_units_row_of_the_wrong_kind_is_refused(tmp_path, problem):
    path = tmp_path / "d.csv"
    path.write_text("p0,dA,lam,Rv\n[m],[cm^2],[-],[MPa s/m^3]\n2.5,12.5,0.5,0.8\n")
    one_line(
        run_cli("evaluate", DEFAULT_PROBLEM, "--designs", path),
        f"{path}: line 2, column 'p0': [m] is a length; expected a pressure (e.g. \"2.5 MPa\" or 2.5e6 [Pa])",
    )
    with pytest.raises(ConfigError, match=r"column 'p0' \(attrs\['units'\]\): \[m\] is a length"):
        problem.evaluate(read_csv(path))
    path.write_text("p0,dA,lam,Rv\n2.5 MPa,12.5e-4,0.5,8e5\n")
    one_line(run_cli("evaluate", DEFAULT_PROBLEM, "--designs", path), "expected a number, got '2.5 MPa'; give a column's unit once")


# --- printed units pasted back -----------------------------------------------------------------
_ROW = re.compile(r"^│ (\S+) \[([^\]]*)\]\s*│\s*(\S*)\s*│$")


def _table_cells(stdout: str) -> tuple[list[str], list[str], list[list[str]]]:
    """Names, units and rows of a rich table with ``name`` over ``[unit]`` headers."""
    lines = stdout.splitlines()
    heads = [[c.strip() for c in line.strip().strip("┃").split("┃")] for line in lines if line.startswith("┃")]
    rows = [[c.strip() for c in line.strip().strip("│").split("│")] for line in lines if line.startswith("│")]
    names, units = heads[0], [u.strip("[]") for u in heads[1]]
    return names, units, rows


def _paste_back(printed: str, unit: str, si_value: float, si_unit: str, seen: set[str]) -> None:
    """``printed`` (4 significant figures) with its unit, read in ``si_unit``, is ``si_value``."""
    try:
        float(printed)
    except ValueError:
        return  # a label or a flag (yes, ok, a layout name)
    if math.isnan(float(printed)):
        assert math.isnan(si_value)
        return
    seen.add(unit)
    back = to_si(f"{printed} {unit}", si_unit)
    assert back == pytest.approx(si_value, rel=PRINTED_RTOL, abs=0), (printed, unit, si_value, si_unit)


def _roll_problem(tmp_path: Path) -> Path:
    """The default problem evaluating a quantity of every unit hisopt shows, V0 a variable."""
    objectives = (
        '["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd", "rms_roll", "rms_stroke", "rms_tire_load", '
        '"roll_gradient", "roll_step_peak", "roll_rate_peak", "roll_gain_peak"]'
    )
    text = replaced(
        TEXT,
        ('objectives = ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd"]', f"objectives = {objectives}"),
        ("Rv = { lower", "V0 = { lower = 0.5e-3, upper = 2e-3 }\nRv = { lower"),
    )
    return write(tmp_path, text + '\n[[constraints]]\nname = "roll_gain_peak_hz"\nlimit = 100.0\n', "roll.toml")


def test_every_printed_unit_pastes_back_to_the_same_value(tmp_path):
    seen: set[str] = set()
    # evaluate: the baseline's table against its SI results file
    path = _roll_problem(tmp_path)
    out = run_cli("evaluate", path)
    assert run_cli("evaluate", path, "--out", tmp_path / "base.csv").code == 0 and out.code == 0, out
    si = read_csv(tmp_path / "base.csv")
    printed = {m.group(1): (m.group(2), m.group(3)) for m in map(_ROW.match, out.stdout.splitlines()) if m}
    assert set(printed) == set(si.columns), printed
    for name, (unit, text) in printed.items():
        _paste_back(text, unit, si.loc[0, name], si.attrs["units"][name], seen)
    # The printed design pasted back with --set is the same run (2.000 MPa, 10.00 cm^2 ... are exact here).
    sets = [f"{name}={printed[name][1]} {printed[name][0]}" for name in ("p0", "dA", "lam", "Rv", "V0")]
    pasted = run_cli("evaluate", path, *[a for s in sets for a in ("--set", s)], "--out", tmp_path / "pasted.csv")
    assert pasted.code == 0, pasted
    assert_same(read_csv(tmp_path / "pasted.csv"), si)

    # layouts: the screening table against its SI frame
    from hisopt.studies.screening import mode_stiffness

    out = run_cli("layouts")
    assert out.code == 0, out
    frame = mode_stiffness(None)
    names, units, rows = _table_cells(out.stdout)
    for row in rows:
        layout = frame[frame["layout"] == row[0]].iloc[0]
        for name, unit, text in zip(names[1:], units[1:], row[1:], strict=True):
            _paste_back(text, unit, float(layout[name]), frame.attrs["units"][name], seen)

    # compare-layouts: the printed roll gradient pasted as --handling-limit is read in deg/g,
    # and the study's own table and title paste back to its layouts.csv.
    limit = f"{printed['roll_gradient'][1]} {printed['roll_gradient'][0]}"
    assert printed["roll_gradient"][0] == "deg/g"
    study = tmp_path / "study"
    out = run_cli(
        "compare-layouts", DEFAULT_PROBLEM, "--layouts", "roll_plane", "--seeds", "1", "--pop", "4", "--gens", "1", "--handling-limit", limit, "--out", study
    )
    assert out.code == 0, out
    table = read_csv(study / "layouts.csv")
    assert table.attrs["units"]["handling_limit"] == "rad/g"
    assert table.loc[0, "handling_limit"] == pytest.approx(float(printed["roll_gradient"][1]) * DEG, rel=CONVERSION_RTOL)
    assert table.loc[0, "handling_limit"] == pytest.approx(si.loc[0, "roll_gradient"], rel=PRINTED_RTOL)  # not 57x it
    title = re.search(r"roll_gradient <= (\S+) (\S+) \(", out.stdout)
    assert title is not None and f"{title.group(1)} {title.group(2)}" == limit, out.stdout  # the title prints its unit
    names, units, rows = _table_cells(out.stdout)
    for name, unit, text in zip(names[1:], units[1:], rows[0][1:], strict=True):
        _paste_back(text, unit, float(table.loc[0, name]), table.attrs["units"][name], seen)

    # Not vacuous: the engineering units (not SI) were among those pasted back.
    assert {"MPa", "cm^2", "MPa s/m^3", "L", "deg", "deg/g", "deg/s", "deg/(m/s^2)", "mm", "kN/m", "N s/m", "rad^2/Hz", "-"} <= seen, seen


def test_a_unit_label_with_a_line_break_is_named_on_one_line():
    """Hypothesis found it (tests/test_reliability.py): the label was echoed as written, so a
    line break in it split the message; it is now escaped, the message one line."""
    import tomllib

    from hisopt.errors import ConfigError
    from hisopt.problem import problem_from_dict

    data = tomllib.loads(DEFAULT_PROBLEM.read_text(encoding="utf-8"))
    data["variables"]["lam"]["unit"] = "\nÀ"
    with pytest.raises(ConfigError) as err:
        problem_from_dict(data, "edited.toml")
    assert "\n" not in str(err.value) and str(err.value).startswith('edited.toml: variables.lam.unit: "\\nÀ": unknown unit')
