"""Units of every column hisopt returns or writes, and their engineering display."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.cli.console import summary_tables
from hisopt.coupled.modal import modal_analysis
from hisopt.errors import ConfigError
from hisopt.io import read_csv, write_csv
from hisopt.metrics import METRICS
from hisopt.optim.run import optimize
from hisopt.problem import problem_from_dict
from hisopt.quantities import to_si, unit_factor
from hisopt.units import (
    column_units,
    display_for,
    display_frame,
    format_number,
    format_quantity,
    psd_unit,
    variable_units,
)
from tests.conftest import ROOT

# --- display -----------------------------------------------------------------------------------
ENGINEERING = [
    # (SI value, SI unit, shown): hand-converted, 1 MPa = 1e6 Pa, 1 cm^2 = 1e-4 m^2, 1 L = 1e-3 m^3
    (0.1e6, "Pa", "0.1 MPa"),
    (2.5e6, "Pa", "2.5 MPa"),
    (5.0e4, "Pa", "50 kPa"),
    (0.0, "Pa", "0 Pa"),
    (12.8e-4, "m^2", "12.8 cm^2"),
    (1.0e-4, "m^2", "1 cm^2"),
    (5.0e-5, "m^2", "50 mm^2"),
    (8.0e5, "Pa s m^-3", "0.8 MPa s/m^3"),
    (1.6e6, "Pa s m^-3", "1.6 MPa s/m^3"),
    (1.0e-3, "m^3", "1 L"),
    (2.0e-5, "m^3", "20 cm^3"),
    (7.166e-3, "m", "7.166 mm"),
    (0.3, "m", "300 mm"),
    (1265.0, "N", "1265 N"),
    (12650.0, "N", "12.65 kN"),
    (math.radians(2.5), "rad/g", "2.5 deg/g"),
    (math.radians(0.25), "rad", "0.25 deg"),
    (8.4676e-05, "rad^2/Hz", "8.468e-5 rad^2/Hz"),
    (4.7222e04, "N^2/Hz", "4.722e4 N^2/Hz"),
    (1.0e-6, "(m/s^2)^2/Hz", "1e-6 (m/s^2)^2/Hz"),
    (0.55344, "m/s^2", "0.5534 m/s^2"),
    (2.7441, "Hz", "2.744 Hz"),
    (0.5, "-", "0.5"),
]


@pytest.mark.parametrize("value, unit, shown", ENGINEERING)
def test_engineering_format_of_known_values(value, unit, shown):
    assert format_quantity(value, unit) == shown


def test_a_column_shares_one_unit_chosen_from_its_largest_value():
    shown = display_for("Pa", [0.0, 1.0e5, 4.0e6], trim=False)
    assert shown.unit == "MPa" and [shown.number(v) for v in (0.0, 1.0e5, 4.0e6)] == ["0", "0.1000", "4.000"]
    assert display_for("m^2", [1e-4, 25e-4]).label("dA") == "dA [cm^2]"
    assert display_for("rad^2/Hz", [1e-4]).label("max_roll_psd") == "max_roll_psd [rad^2/Hz]"


def test_numbers_for_people():
    assert format_number(True) == "yes" and format_number(np.False_) == "no"
    assert format_number(np.int64(12)) == "12" and format_number("roll") == "roll"
    assert format_number(1.4, trim=False) == "1.400" and format_number(1.4) == "1.4"
    assert format_number(float("nan")) == "nan" and format_number(1.0e7) == "1e7"


def test_psd_units_square_the_signal_unit():
    assert psd_unit("m") == "m^2/Hz" and psd_unit("N") == "N^2/Hz" and psd_unit("rad") == "rad^2/Hz"
    assert psd_unit("m/s^2") == "(m/s^2)^2/Hz" and psd_unit("rad/s^2") == "(rad/s^2)^2/Hz"
    for m in METRICS.values():  # the registry's PSD units follow the same rule
        if m.kind == "max":
            assert m.unit == psd_unit(METRICS[m.name.replace("max_", "rms_").replace("_psd", "")].unit)


def test_display_frame_headers_carry_units_and_values_are_scaled():
    frame = pd.DataFrame({"p0": [2.0e6, 1.0e5], "max_roll_psd": [8.4675e-5, 1.0e-4], "feasible": [True, False]})
    frame.attrs["units"] = {"p0": "Pa", "max_roll_psd": "rad^2/Hz", "feasible": "-"}
    shown = display_frame(frame)
    assert list(shown.columns) == ["p0 [MPa]", "max_roll_psd [rad^2/Hz]", "feasible [-]"]
    assert shown.iloc[1].tolist() == ["0.1000", "1.000e-4", "no"]
    assert frame["p0"].tolist() == [2.0e6, 1.0e5]  # the numbers themselves do not change


# --- units of columns --------------------------------------------------------------------------
def _complete(frame: pd.DataFrame) -> dict[str, str]:
    units = frame.attrs["units"]
    assert list(units) == [str(c) for c in frame.columns]
    assert all(units.values()), {c: u for c, u in units.items() if not u}
    return units


def test_variable_units_come_from_the_declared_field_units(problem):
    assert variable_units(problem) == {"p0": "Pa", "dA": "m^2", "lam": "-", "Rv": "Pa s m^-3"}
    data = problem.spec.model_dump(by_alias=True)
    for var in data["variables"].values():
        var["unit"] = ""
    bare = problem_from_dict(data)
    assert variable_units(bare) == variable_units(problem)  # from RollPlaneHIS's json_schema_extra={"unit": ...}


def test_variable_units_are_the_design_space_s(problem):
    """The units of design variables come from DesignSpace.variable_units (the [his] fields'
    declared units, a layout parameter's element field, else the file's label); hisopt.units
    only reads a problem's ``variable_units`` and ``objective_names``, whatever the object."""
    from types import SimpleNamespace

    assert problem.variable_units == {"p0": "Pa", "dA": "m^2", "lam": "-", "Rv": "Pa s m^-3"}  # RollPlaneHIS fields
    assert variable_units(problem) == problem.variable_units
    duck = SimpleNamespace(variable_units={"x": "N/m"}, objective_names=("sigma_aw", "roll_gradient"))
    units = column_units(["x", "sigma_aw", "hypervolume", "feasible"], duck)
    assert units == {"x": "N/m", "sigma_aw": "m/s^2", "hypervolume": "decades^2", "feasible": "-"}


def test_units_module_imports_only_leaves():
    """hisopt/units.py is a leaf: every import in it (also inside functions) is of a leaf module."""
    import ast

    leaves = {"hisopt.metrics", "hisopt.robust", "hisopt.constants", "hisopt.errors", "hisopt.quantities", "hisopt.arguments"}
    tree = ast.parse((ROOT / "hisopt" / "units.py").read_text(encoding="utf-8"))
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert {m for m in imported if m.split(".")[0] == "hisopt"} <= leaves


def test_evaluate_frame_has_the_unit_of_every_column(problem):
    units = _complete(problem.evaluate(problem.baseline))
    assert units["p0"] == "Pa" and units["dA"] == "m^2" and units["sigma_aw"] == "m/s^2" and units["feasible"] == "-"
    for name in problem.objective_names:
        assert units[name] == METRICS[name].unit


def test_modal_frame_has_the_unit_of_every_column(problem):
    units = _complete(modal_analysis(problem))
    assert units["frequency_hz"] == units["damped_frequency_hz"] == "Hz"
    assert units["damping_ratio"] == units["mode"] == units["shape_phi"] == "-"


def test_run_frames_have_the_unit_of_every_column_and_the_summary_shows_them(tmp_path):
    from rich.console import Console

    handling = hisopt.load_problem(ROOT / "problems" / "roll_plane_his_handling.toml")
    run = optimize(handling, out=tmp_path / "run", pop_size=8, generations=2, seed=2)
    front, history, generations = (_complete(f) for f in (run.front, run.history, run.generations))
    assert front["roll_gradient"] == "rad/g" and front["rms_tire_load"] == "N"
    assert history["evaluation"] == history["generation"] == history["valid"] == "-"
    assert generations["hypervolume"] == "decades^4" and generations["elapsed_s"] == "s"
    for name in ("front.csv", "generations.csv"):  # the CSVs carry the same units (front.csv: and its on_bound marks)
        assert read_csv(tmp_path / "run" / name).attrs["units"] == (front | {"on_bound": "-"} if name == "front.csv" else generations)
    console = Console(width=120, record=True)
    for table in summary_tables(run):
        console.print(table)
    text = console.export_text()
    for shown in ("p0 [MPa]", "dA [cm^2]", "Rv [MPa s/m^3]", "rms_stroke [mm]", "roll_gradient [deg/g]", "decades^4"):
        assert shown in text


def test_write_csv_takes_the_units_from_attrs_and_read_csv_gives_them_back(tmp_path, problem):
    frame = problem.evaluate(np.vstack([problem.baseline, problem.lower]))
    write_csv(frame, tmp_path / "x.csv")
    lines = (tmp_path / "x.csv").read_text().splitlines()
    assert lines[1] == "[Pa],[m^2],[-],[Pa s m^-3],[m/s^2],[rad^2/Hz],[m^2/Hz],[N^2/Hz],[-],[-],[-]"  # ..., feasible, status, reason
    back = read_csv(tmp_path / "x.csv")
    assert back.attrs["units"] == frame.attrs["units"]
    assert back.drop(columns="reason").equals(frame.drop(columns="reason"))
    assert (frame["reason"] == "").all() and back["reason"].isna().all()  # an ok row's empty reason reads back as NaN


def test_column_units_by_name():
    units = column_units(["f_hz", "elapsed_s", "error_pct", "bounce_damping_ratio", "seed", "mystery"])
    assert units == {"f_hz": "Hz", "elapsed_s": "s", "error_pct": "%", "bounce_damping_ratio": "-", "seed": "-", "mystery": ""}


@pytest.mark.parametrize(
    ("text", "kelvin"),
    [("20 degC", 293.15), ("-20 °C", 253.15), ("60 celsius", 333.15), ("68 degF", 293.15), ("-40 degF", 233.15), ("300 K", 300.0), ("300", 300.0)],
)
def test_a_temperature_on_a_scale_is_read_as_a_point_not_a_multiple(text, kelvin):
    # 20 degC is 293.15 K, not 20 x 274.15 K (a multiplicative factor would give 5483 K)
    assert to_si(text, "K") == kelvin


def test_a_temperature_scale_is_refused_where_another_kind_or_a_factor_is_expected():
    with pytest.raises(ConfigError, match="is a temperature; expected a pressure"):
        to_si("20 degC", "Pa", key="his.p0")
    with pytest.raises(ConfigError, match="offset is not a factor"):
        unit_factor("degC", "K")
