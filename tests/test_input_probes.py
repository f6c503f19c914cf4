"""Issue 38 item 3, probe by probe: inputs that passed silently, or were refused with wrong
advice, when tried as a new user would. Each is refused at load (one line naming the file
or option, the key and what was expected; exit 2; nothing written) or warned about."""

from __future__ import annotations

import hashlib
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

import hisopt
from hisopt.errors import ConfigError, PlausibilityWarning, RunError
from hisopt.optim.decision import grid_designs, grid_sample_rows
from hisopt.quantities import to_si
from tests.cli_inprocess import assert_one_line, run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

DEFAULT_TEXT = DEFAULT_PROBLEM.read_text(encoding="utf-8")
PARTS_TEXT = (ROOT / "problems" / "roll_plane_his_parts.toml").read_text(encoding="utf-8")
UNCERTAIN_TEXT = (ROOT / "problems" / "roll_plane_his_uncertain.toml").read_text(encoding="utf-8")
PARTS_ROD = 'rod = { catalogue = "iso3320_rods", lower = "12 mm", upper = "56 mm"'
PARTS_BORE = 'bore = { catalogue = "iso3320_bores", lower = "32 mm", upper = "100 mm"'


def edited(text: str, *changes: tuple[str, str]) -> str:
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def written(tmp_path: Path, text: str, name: str = "probe.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def at_top(text: str, line: str) -> str:
    """``text`` with a top-level ``line`` (before its first table)."""
    return edited(text, ("objectives =", f"{line}\nobjectives ="))


def refusal(text: str) -> str:
    """The one-line message loading ``text`` as a problem raises."""
    with pytest.raises(ConfigError) as err:
        hisopt.problem_from_dict(tomllib.loads(text), "probe.toml")
    message = str(err.value)
    assert "\n" not in message, message
    return message


def folder_digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


# --- 1. a log-uniform input whose lower end is not above 0 -------------------------------------
@pytest.mark.parametrize(
    ("entry", "got"),
    [
        ('input = "vehicle.k_sr"\ndistribution = "loguniform"\nlower = 0.0\nupper = 20000.0', "got 0.0"),
        ('input = "road.speed"\ndistribution = "loguniform"\nlower = "-1 m/s"\nupper = "20 m/s"', "got '-1 m/s'"),
    ],
)
def test_a_loguniform_input_from_zero_or_below_is_refused_at_load(tmp_path, entry, got):
    # log(0) is -inf: every sample was 0 (a spring of 0 N/m), silently; log(-1) is no number
    text = UNCERTAIN_TEXT + f"\n[[uncertain]]\n{entry}\n"
    index = len(re.findall(r"^\[\[uncertain\]\]", UNCERTAIN_TEXT, flags=re.M))
    message = refusal(text)
    assert message.startswith(f"probe.toml: uncertain.{index}.lower: a log-uniform distribution") and "lower above 0" in message and got in message
    path = written(tmp_path, text)
    assert_one_line(run_cli("tolerance", path, "--samples", "16", "--out", tmp_path / "t"), str(path), f"uncertain.{index}.lower", "above 0")
    assert not (tmp_path / "t").exists()


def test_a_loguniform_input_above_zero_still_loads():
    text = UNCERTAIN_TEXT + '\n[[uncertain]]\ninput = "vehicle.k_sr"\ndistribution = "loguniform"\nlower = "15 kN/m"\nupper = "20 kN/m"\n'
    problem = hisopt.problem_from_dict(tomllib.loads(text), "probe.toml")
    assert problem.spec.uncertain[-1].distribution == "loguniform"


# --- 2. the charge temperature is checked like every other temperature --------------------------
@pytest.mark.parametrize("value", ['"500 degC"', '"-100 degF"', "20"])
def test_the_charge_temperature_is_range_checked_like_the_load_cases(value):
    charge = edited(PARTS_TEXT, ('temperature = "20 degC"', f"temperature = {value}"))
    operating = at_top(PARTS_TEXT, f"temperature = {value}")  # the same value as the problem's temperature
    message, reference = refusal(charge), refusal(operating)
    head = "probe.toml: his.charge.temperature: "
    assert message.startswith(head) and reference.startswith("probe.toml: temperature: ")
    assert message.removeprefix(head) == reference.removeprefix("probe.toml: temperature: ")  # one check, one wording
    assert "outside the range the oil is used in" in message


def test_a_charge_temperature_in_the_oils_range_loads():
    problem = hisopt.problem_from_dict(tomllib.loads(edited(PARTS_TEXT, ('temperature = "20 degC"', 'temperature = "40 degC"'))), "probe.toml")
    assert problem.spec.his.charge is not None and problem.spec.his.charge.temperature == pytest.approx(313.15, abs=1e-12)


# --- 3. the absolute-zero message names the value as written --------------------------------------
BELOW_ZERO = [
    ('"-300 degC"', "-300 degC is below absolute zero (-273.15 degC)"),
    ('"-500 degF"', "-500 degF is below absolute zero (-459.67 degF)"),
    ('"-5 K"', "-5 K is below absolute zero (0 K)"),
    ('"-273.15 degC"', "-273.15 degC is absolute zero (-273.15 degC)"),
]


@pytest.mark.parametrize(("value", "expect"), BELOW_ZERO)
@pytest.mark.parametrize("where", ["temperature", "his.charge.temperature", "scenarios.0.temperature", "his.oil.lowest"])
def test_a_temperature_below_absolute_zero_is_named_as_written(value, expect, where):
    if where == "temperature":
        text = at_top(DEFAULT_TEXT, f"temperature = {value}")
    elif where == "his.charge.temperature":
        text = edited(PARTS_TEXT, ('temperature = "20 degC"', f"temperature = {value}"))
    elif where == "scenarios.0.temperature":
        text = DEFAULT_TEXT + f'\n[[scenarios]]\nname = "cold"\ntemperature = {value}\n[scenarios.road]\nclass = "C"\nspeed = 10.0\n'
    else:
        text = DEFAULT_TEXT + f"\n[his.oil]\nlowest = {value}\n"
    message = refusal(text)
    assert message.startswith(f"probe.toml: {where}: {expect}"), message
    assert "kelvin" not in message  # never the hint that a bare number is kelvin, for a value with its unit


def test_a_cold_temperature_written_in_celsius_gets_no_kelvin_hint():
    # 73.15 K is under the 150 K below which a bare number gets the hint; written in degC it must not
    message = refusal(at_top(DEFAULT_TEXT, 'temperature = "-200 degC"'))
    assert message == "probe.toml: temperature: -200 degC is outside the range the oil is used in (-30 to 120 degC: his.oil.lowest, his.oil.highest)"
    message = refusal(at_top(DEFAULT_TEXT, 'temperature = "-100 degF"'))
    assert message.startswith("probe.toml: temperature: -100 degF is outside the range") and "kelvin" not in message


@pytest.mark.parametrize(("value", "expect"), [("-5", "-5 K is below absolute zero (0 K)"), ("20", "-253.1 degC is outside the range the oil is used in")])
def test_a_bare_number_is_kelvin_and_says_so(value, expect):
    message = refusal(at_top(DEFAULT_TEXT, f"temperature = {value}"))
    assert message.startswith(f"probe.toml: temperature: {expect}") and f'(a bare number is kelvin; for Celsius write "{value} degC")' in message


def test_an_uncertain_temperature_below_absolute_zero_is_named_as_written():
    text = DEFAULT_TEXT + '\n[[uncertain]]\ninput = "temperature"\nlower = "-300 degC"\nupper = "20 degC"\n'
    assert refusal(text) == "probe.toml: uncertain.0.lower: -300 degC is below absolute zero (-273.15 degC)"


def test_absolute_zero_is_refused_by_the_unit_reader_itself():
    # the same words wherever a temperature is typed: to_si is where every value with a unit comes in
    for text, expect in (("-300 degC", "-300 degC is below absolute zero (-273.15 degC)"), ("-1 mK", "-1 mK is below absolute zero (0 K)")):
        with pytest.raises(ConfigError, match=re.escape(f"x: {expect}")):
            to_si(text, "K", key="x")
    assert to_si("-273 degC", "K") == pytest.approx(0.15, abs=1e-12)  # just above: read, the range check is the oil's


def test_cli_refuses_a_temperature_below_absolute_zero_in_one_line(tmp_path):
    path = written(tmp_path, at_top(DEFAULT_TEXT, 'temperature = "-300 degC"'))
    before = folder_digest(tmp_path)
    assert_one_line(run_cli("evaluate", path), str(path), "temperature: -300 degC is below absolute zero (-273.15 degC)")
    assert folder_digest(tmp_path) == before


# --- 4. bores and rods that cannot make a cylinder ----------------------------------------------------
@pytest.mark.parametrize(
    ("changes", "rod", "bore"),
    [
        (
            ((PARTS_ROD, 'rod = { catalogue = "iso3320_rods", lower = "100 mm", upper = "140 mm"'),),
            "variables.rod (100 to 140 mm)",
            "variables.bore (32 to 100 mm)",
        ),
        (
            ((PARTS_ROD, 'rod = { choices = ["100 mm", "110 mm"]'), (PARTS_BORE, 'bore = { choices = ["63 mm", "100 mm"]')),
            "variables.rod (100 to 110 mm)",
            "variables.bore (63 to 100 mm)",
        ),
        (
            ((PARTS_BORE + ', description = "cylinder bore" }\n', ""), (PARTS_ROD, 'rod = { lower = "50 mm", upper = "60 mm"')),
            "variables.rod (50 to 60 mm)",
            "his.bore (50 mm)",
        ),
        (
            ((PARTS_ROD + ', description = "piston rod" }\n', ""), (PARTS_BORE, 'bore = { lower = "20 mm", upper = "36 mm"')),
            "his.rod (36 mm)",
            "variables.bore (20 to 36 mm)",
        ),
    ],
)
def test_a_box_without_a_buildable_cylinder_is_refused_naming_both_boxes(tmp_path, changes, rod, bore):
    # today: loaded, and every design of the box invalid (rod not thinner than its bore)
    text = edited(PARTS_TEXT, *changes)
    message = refusal(text)
    key = rod.split(" ")[0] if rod.startswith("variables.") else bore.split(" ")[0]
    assert message.startswith(f"probe.toml: {key}: no rod of {rod} is thinner than any bore of {bore}"), message
    path = written(tmp_path, text)
    before = folder_digest(tmp_path)
    assert_one_line(run_cli("optimize", path, "--out", tmp_path / "run", "--pop", "8", "--gens", "2"), str(path), rod, bore)
    assert folder_digest(tmp_path) == before and not (tmp_path / "run").exists()


def test_the_rear_axle_box_is_checked_on_its_own(tmp_path):
    text = edited(
        PARTS_TEXT, ('rod = "36 mm"', 'rod = "36 mm"\nbore_rear = "40 mm"'), (PARTS_ROD, 'rod = { catalogue = "iso3320_rods", lower = "40 mm", upper = "56 mm"')
    )
    message = refusal(text)
    assert "no rod of variables.rod (40 to 56 mm) is thinner than any bore of his.bore_rear (40 mm)" in message, message


def test_a_rod_box_reaching_the_largest_bore_warns_naming_both():
    text = edited(PARTS_TEXT, (PARTS_ROD, 'rod = { catalogue = "iso3320_rods", lower = "12 mm", upper = "110 mm"'))
    with pytest.warns(PlausibilityWarning) as caught:
        hisopt.problem_from_dict(tomllib.loads(text), "probe.toml")
    (warning,) = [str(w.message) for w in caught]
    assert warning.startswith("probe.toml: variables.rod: the rods of variables.rod (12 to 110 mm) reach the largest bore of variables.bore (32 to 100 mm)")
    assert "\n" not in warning


def test_a_rod_box_below_the_largest_bore_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped parts problem: rods 12 to 56 mm, bores 32 to 100 mm
        hisopt.problem_from_dict(tomllib.loads(PARTS_TEXT), "probe.toml")


# --- 5. optimize on a box with no evaluable design says why --------------------------------------
def _dry_text() -> str:
    """The parts problem charged to 99.9 % gas at 20 C and run at 0 C: the oil contracts more
    than the accumulators hold, at every precharge up to 2 MPa, so every design runs dry."""
    text = edited(
        PARTS_TEXT,
        ("gas_fraction = 0.7", "gas_fraction = 0.999"),
        ('p0 = { lower = "0.5 MPa", upper = "4 MPa"', 'p0 = { lower = "0.5 MPa", upper = "2 MPa"'),
        ("[his.charge]", '[his.oil]\ntemperature_1 = "0 degC"\nviscosity_1 = "338 cSt"\ntemperature_2 = "100 degC"\nviscosity_2 = "5.4 cSt"\n\n[his.charge]'),
    )
    text = re.sub(r"^(bore|rod|V0|pipe_diameter) = \{ catalogue.*\n", "", text, flags=re.M)
    return at_top(text, 'temperature = "0 degC"')


@pytest.mark.parametrize("command", [("optimize",), ("study", "--seeds", "1-2")])
def test_optimize_on_a_box_with_no_evaluable_design_says_why_and_writes_nothing(tmp_path, command):
    path = written(tmp_path, _dry_text())
    before = folder_digest(tmp_path)
    out = run_cli(*command, path, "--out", tmp_path / "run", "--pop", "8", "--gens", "2")
    assert out.code == 2 and "Traceback" not in out.stderr, out
    (line,) = [line for line in out.error_lines if line.startswith("error: ")]  # after the study's "running 2 seeds" line
    assert line.startswith("error: no design of a 961-design grid over the box of roll_plane_his_parts can be evaluated: "), line
    assert line.endswith("the model is unstable or singular here, or an accumulator holds no oil at rest (NaN results) (961 designs)"), line
    assert folder_digest(tmp_path) == before and not (tmp_path / "run").exists()


def test_the_reasons_of_an_unevaluable_grid_are_its_commonest():
    # rods 12 to 110 mm over bores 32 to 100 mm: the grid's designs whose rod is not thinner than
    # their bore are invalid; given only those, the error counts each reason check_designs gives
    problem = hisopt.problem_from_dict(
        tomllib.loads(edited(PARTS_TEXT, (PARTS_ROD, 'rod = { lower = "12 mm", upper = "110 mm"'))), "probe.toml", warn_implausible=False
    )
    x = grid_designs(problem.lower, problem.upper)
    names = list(problem.variable_names)
    bad = x[x[:, names.index("rod")] >= x[:, names.index("bore")]]
    assert len(bad) > 3
    with pytest.raises(RunError) as err:
        grid_sample_rows(problem, {"valid": np.zeros(len(bad), dtype=bool)} | {c: np.full(len(bad), np.nan) for c in problem.constraint_names}, bad)
    message = str(err.value)
    reasons = re.findall(r"rod = ([\d.e+-]+) is not thinner than bore = ([\d.e+-]+) \((\d+) designs?\)", message)
    assert len(reasons) == 3 and "more reason" in message, message
    assert all(float(rod) >= float(bore) for rod, bore, _ in reasons)
    counts = [int(c) for _, _, c in reasons]
    assert counts == sorted(counts, reverse=True)


# --- 6. compare-layouts --handling-limit: a bare number where hisopt prints another unit ------------
def test_a_bare_handling_limit_is_refused_with_the_unit_to_write(tmp_path):
    # the study prints "roll_gradient <= 1.779 deg/g"; pasted back bare it was read as 1.779 rad/g (101.9 deg/g)
    out = run_cli("compare-layouts", DEFAULT_PROBLEM, "--out", tmp_path / "study", "--seeds", "1", "--pop", "4", "--gens", "1", "--handling-limit", "1.8")
    assert_one_line(out, "--handling-limit: '1.8' has no unit", "prints roll_gradient in deg/g", "read in rad/g (SI)", '"1.8 deg/g" or "1.8 rad/g"')
    assert not (tmp_path / "study").exists()


def test_a_bare_handling_limit_is_si_where_hisopt_prints_si(tmp_path):
    # rms_tire_load prints in N below 10 kN: a bare 500 is 500 N, so the limit passes and the next check speaks
    args = ("compare-layouts", DEFAULT_PROBLEM, "--out", tmp_path / "study", "--seeds", "3-1", "--handling", "rms_tire_load")
    assert_one_line(run_cli(*args, "--handling-limit", "500"), "--seeds", "increasing seed range")
    assert_one_line(run_cli(*args, "--handling-limit", "2e4"), "--handling-limit: '2e4' has no unit", '"2e4 kN" or "2e4 N"')
    assert not (tmp_path / "study").exists()
