"""The envelope table and ``hisopt envelope`` (docs/model.md §16.7).

Independent references: the reference state by definition (the charge pressure
``p0_abs / phi``, the gas share ``phi``, no ride-height change), each row's ride and handling
against a single-case problem written for that temperature and payload, the monotonic
physics of temperature and load, and the table read back from its CSV.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.constants import P_ATM_PA
from hisopt.io import read_csv
from hisopt.problem import problem_from_dict
from hisopt.studies.envelope import envelope_table
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

ENVELOPE = ROOT / "problems" / "roll_plane_his_envelope.toml"


@pytest.fixture(scope="module")
def envelope_problem() -> hisopt.Problem:
    with pytest.warns(hisopt.PlausibilityWarning, match="extrapolated"):
        return hisopt.load_problem(ENVELOPE)


@pytest.fixture(scope="module")
def table(envelope_problem):
    return envelope_table(envelope_problem)


def test_rows_are_every_temperature_with_every_load_coldest_first(table):
    assert list(table["temperature"]) == [253.15, 253.15, 293.15, 293.15, 333.15, 333.15]
    assert list(table["payload"]) == [0.0, 350.0] * 3
    assert set(table["model"]) == {"charged"}
    assert table.attrs["units"]["p_static_A"] == "Pa" and table.attrs["units"]["ride_height"] == "m"


def test_the_reference_row_is_the_charge_itself(table, envelope_problem):
    ref = table[(table["temperature"] == 293.15) & (table["payload"] == 0.0)].iloc[0]
    p0_abs = envelope_problem.spec.his.p0 + P_ATM_PA
    for circuit in ("A", "B"):
        assert ref[f"p_static_{circuit}"] == pytest.approx(p0_abs / 0.7, rel=1e-14)
        assert ref[f"gas_fraction_{circuit}"] == pytest.approx(0.7, rel=1e-14)
    assert abs(ref["ride_height"]) < 1e-15


def test_temperature_and_load_move_the_static_state_as_physics_says(table):
    unladen, laden = table[table["payload"] == 0.0], table[table["payload"] > 0.0]
    for rows in (unladen, laden):
        assert np.all(np.diff(rows["p_static_A"]) > 0)  # warmer: higher pressure
        assert np.all(np.diff(rows["ride_height"]) > 0)  # and the body rises on the struts
    assert np.all(laden["p_static_A"].to_numpy() > unladen["p_static_A"].to_numpy())
    assert np.all(laden["ride_height"].to_numpy() < unladen["ride_height"].to_numpy())
    assert np.all((table["gas_fraction_A"] > 0.5) & (table["gas_fraction_A"] < 1.0))


def test_each_row_rides_as_a_problem_written_for_it(table):
    """Row (60 C, 350 kg) against the same problem file rewritten as a single case."""
    data = tomllib.loads(ENVELOPE.read_text())
    payload = next(sc["payload"] for sc in data["scenarios"] if "payload" in sc)
    for key in ("scenarios", "robust", "constraints"):
        data.pop(key)
    data |= {"temperature": 333.15, "payload": payload, "objectives": ["sigma_aw", "roll_gradient"]}
    single = problem_from_dict(data)
    values = single.evaluator()(single.baseline[None, :])
    row = table.iloc[5]
    assert row["sigma_aw"] == pytest.approx(values["sigma_aw"][0], rel=1e-12)
    assert row["roll_gradient"] == pytest.approx(values["roll_gradient"][0], rel=1e-12)


def test_the_cli_prints_degc_and_writes_si_that_reads_back(tmp_path, table):
    out = tmp_path / "envelope.csv"
    result = run_cli("envelope", str(ENVELOPE), "--out", str(out))
    assert result.code == 0
    assert "[degC]" in result.stdout and "-20" in result.stdout and "charged model" in result.stdout
    back = read_csv(out)
    np.testing.assert_allclose(back["p_static_A"], table["p_static_A"], rtol=1e-12)
    assert back.attrs["units"]["temperature"] == "K"


def test_the_cli_names_the_ideal_model_and_takes_a_runs_knee(tmp_path):
    run = tmp_path / "run"
    assert run_cli("optimize", str(DEFAULT_PROBLEM), "--out", str(run), "--pop", "8", "--gens", "2").code == 0
    result = run_cli("envelope", str(DEFAULT_PROBLEM), "--knee", str(run))
    assert result.code == 0 and "ideal model" in result.stdout and "knee of" in result.stdout
    assert "paper's idealisation" in result.stdout
    missing = run_cli("envelope", str(DEFAULT_PROBLEM), "--knee", str(tmp_path))
    assert missing.code == 2 and len(missing.error_lines) == 1 and "front.csv: missing" in missing.stderr


def test_the_report_shows_the_knee_against_temperature_only_where_temperature_matters(tmp_path):
    from hisopt.report.html import build_report

    run = tmp_path / "run"
    assert run_cli("optimize", str(ENVELOPE), "--out", str(run), "--pop", "8", "--gens", "2").code == 0
    page = build_report(run).read_text()
    assert "Operating envelope of the knee design" in page and "charged model" in page
    assert "[degC]" in page  # the table's temperatures
    plain = tmp_path / "plain"
    assert run_cli("optimize", str(DEFAULT_PROBLEM), "--out", str(plain), "--pop", "8", "--gens", "2").code == 0
    assert "Operating envelope" not in build_report(plain).read_text()
