"""The one validation layer (hisopt.specification.validation, hisopt.specification.designs): rules, statuses, entry forms."""

from __future__ import annotations

import logging
import math

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.hydraulics.roll_plane import DAMPER_KEYS, RollPlaneHIS
from hisopt.specification.designs import read_designs
from hisopt.specification.text_files import read_text
from hisopt.specification.validation import (
    STATUS_INVALID,
    STATUS_OK,
    STATUS_OUT_OF_BOUNDS,
    apply_assignments,
    check_designs,
    design_parameters,
    parameter_rule,
    parse_assignments,
)

BASE = [2e6, 10e-4, 0.5, 8e5]


def test_rules_are_the_pydantic_field_rules():
    # The independent reference: pydantic itself accepts or rejects each value.
    valves = {"orifice_diameter": 3e-3, "cracking_pressure": 1e6, "blowoff_resistance": 2e9}  # a damper valve value needs its valve
    for name in design_parameters():
        rule = parameter_rule(name)
        given = valves if name in DAMPER_KEYS or name in ("discharge_coefficient", "laminar_resistance") else {}
        for value in (-1.0, 0.0, 0.5, 1.0, 1.5, 2e6, math.nan, math.inf):
            try:
                RollPlaneHIS(**(given | {name: value}))
                accepted = True
            except ValueError:
                accepted = False
            assert bool(rule.holds(value)) == accepted, (name, value)
    assert parameter_rule("lam").text == "0 < lam < 1"
    assert parameter_rule("p0").text == "p0 >= 0"
    assert parameter_rule("dA").text == "dA > 0"


def test_a_design_variable_that_would_do_nothing_is_refused(problem):
    import tomllib

    from tests.conftest import DEFAULT_PROBLEM

    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["variables"]["chamber_volume"] = {"lower": 1e-4, "upper": 3e-4}
    with pytest.raises(hisopt.ConfigError, match=r"variables.chamber_volume: expected a non-zero \[his\] chamber_volume"):
        hisopt.problem.problem_from_dict(data, "my.toml")
    data["his"]["chamber_volume"] = 2e-4  # the chambers are in the model: the variable acts
    p = hisopt.problem.problem_from_dict(data, "my.toml")
    q = p.evaluator()(np.array([BASE + [1e-4], BASE + [3e-4]]))
    assert q["valid"].all() and q["sigma_aw"][0] != q["sigma_aw"][1]


def test_check_designs_flags_each_row_with_a_reason(problem):
    x = np.array([BASE, [-1, 1e-3, 0.5, 8e5], [2e6, 1e-3, 1.5, 8e5], [9e6, 1e-3, 0.5, 8e5], [np.nan, 1e-3, 0.5, 8e5], [2e6, -1e-3, 0.5, 8e5]])
    check = check_designs(problem, x)
    assert list(check.status) == [STATUS_OK, STATUS_INVALID, STATUS_INVALID, STATUS_OUT_OF_BOUNDS, STATUS_INVALID, STATUS_INVALID]
    assert check.reason[0] == ""
    assert "p0 = -1 breaks p0 >= 0" in check.reason[1]
    assert "lam = 1.5 breaks 0 < lam < 1" in check.reason[2]
    assert "above the upper bound 4e+06" in check.reason[3]
    assert "p0 = nan: expected a finite number" in check.reason[4]
    assert "dA = -0.001 breaks dA > 0" in check.reason[5]


def test_evaluate_never_evaluates_an_invalid_row_as_another(problem, caplog):
    # dA = -1e-3 used to give the result of +1e-3 (the model squares it).
    with caplog.at_level(logging.WARNING, logger="hisopt"):
        df = problem.evaluate([dict(zip(problem.variable_names, BASE, strict=True)), {"dA": -1e-3}, {"p0": 9e6}])
    assert df.loc[0, "status"] == "ok" and df.loc[0, "feasible"]
    assert df.loc[1, "status"] == "invalid" and np.isnan(df.loc[1, "sigma_aw"]) and not df.loc[1, "feasible"]
    assert df.loc[2, "status"] == "out_of_bounds" and np.isfinite(df.loc[2, "sigma_aw"]) and not df.loc[2, "feasible"]
    # the out-of-box row is evaluated exactly as the evaluator does
    assert df.loc[2, "sigma_aw"] == problem.evaluator()(np.array([[9e6, 1e-3, 0.5, 8e5]]))["sigma_aw"][0]
    assert [r.getMessage() for r in caplog.records] == [
        "2 of 3 designs flagged (1 invalid, 1 out_of_bounds); none of them is feasible, see the status and reason columns"
    ]


def test_a_bad_row_does_not_abort_the_batch(problem):
    df = problem.evaluate(pd.DataFrame({"p0": [-1.0, 2e6], "dA": 1e-3, "lam": 0.5, "Rv": 8e5}))
    assert list(df["status"]) == ["invalid", "ok"] and np.isfinite(df.loc[1, "sigma_aw"])


def test_model_refuses_a_rule_breaking_design_naming_the_row(problem):
    with pytest.raises(hisopt.ConfigError, match=r"design row 2: lam = 1.5 breaks 0 < lam < 1"):
        problem.model(np.array([BASE, [2e6, 1e-3, 1.5, 8e5]]))
    with pytest.raises(hisopt.ConfigError, match="p0 = -1 breaks p0 >= 0"):
        hisopt.modal_analysis(problem, {"p0": -1.0})


@pytest.mark.parametrize(
    "designs,match",
    [
        ([{"p0": 1.0}, {"p0": "abc"}], r"row 2: p0: expected a number, got 'abc'"),
        ([{"p0": 1.0}, [1, 2, 3, 4]], r"row 2: expected a dict like the other rows"),
        ([{"nope": 1.0}], r"row 1: unknown design variable 'nope'"),
        ([[1.0, 2.0, 3.0, 4.0], [1.0, "x", 3.0, 4.0]], r"row 2, column 'dA': expected a number, got 'x'"),
        ([[1.0, 2.0, 3.0, 4.0], [1.0, 2.0]], r"rows differ in length"),
        (np.ones((2, 3)), r"shape \(n, 4\)"),
        (np.array([True, False, True, True]), r"got the boolean True"),
        (pd.DataFrame({"p0": [1.0], "dA": [1e-3], "lam": [True], "Rv": [0.0]}), r"column 'lam' holds booleans"),
        (pd.DataFrame({"p0": [1.0], "dA": [1e-3], "lam": ["x"], "Rv": [0.0]}), r"row 1, column 'lam': expected a number"),
        (
            pd.DataFrame({"p0": [1.0], "P0": [1.0], "dA": [1e-3], "lam": [0.4], "Rv": [0.0]}),
            r"columns 'p0', 'P0' all name the design variable 'p0'; expected one column",
        ),
        ({"p0": [1.0, 2.0], "dA": [1e-3, 2e-3, 3e-3]}, r"values of different lengths"),
    ],
)
def test_library_entry_errors_name_the_row_and_column(problem, designs, match):
    with pytest.raises(hisopt.ConfigError, match=match):
        problem.evaluate(designs)


def test_every_entry_form_gives_the_same_matrix(problem):
    names = problem.variable_names
    rows = [dict(zip(names, BASE, strict=True)), dict(zip(names, [0.0, 1e-4, 0.1, 0.0], strict=True))]
    expected = np.array([BASE, [0.0, 1e-4, 0.1, 0.0]])
    frame = pd.DataFrame(rows)
    renamed = frame.rename(columns={"p0": "P0", "lam": " LAM "})
    for form in (expected, expected.tolist(), rows, frame, renamed, {n: expected[:, j] for j, n in enumerate(names)}):
        assert np.array_equal(problem.design_matrix(form), expected)


def test_set_values_are_toml_values_and_blamed_on_the_option(problem):
    assert parse_assignments(["p0=3e6", "pipe_model=distributed", "Rv = 1_000"]) == {"p0": 3e6, "pipe_model": "distributed", "Rv": 1000}
    assert apply_assignments(problem, ["p0=3e6"]).baseline[0] == 3e6
    for items, match in (
        (["p0=abc"], r"^--set p0=abc: expected a valid number, got 'abc'$"),
        (["p0=true"], r"^--set p0=true: expected a number, got the boolean true"),
        (["p0=inf"], r"^--set p0=inf: expected a finite number"),
        (["p0=-1"], r"^--set p0=-1: expected greater than or equal to 0"),
        (["p0=1", "p0=2"], r"^--set: 'p0' is set twice"),
        (["p0="], r"^--set: expected a value after '='"),
        (["nonsense"], r"^--set: expected KEY=VALUE"),
    ):
        with pytest.raises(hisopt.ConfigError, match=match):
            apply_assignments(problem, items)


def test_read_text_accepts_a_bom_and_names_other_encodings(tmp_path):
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbfname = 'x'\n")
    assert read_text(tmp_path / "bom.toml", "a TOML problem file") == "name = 'x'\n"
    (tmp_path / "latin.toml").write_bytes(b"a = 1\nname = 'caf\xe9'\n")
    with pytest.raises(hisopt.ConfigError, match=r"latin.toml: not UTF-8 text \(byte 0xe9 at line 2, column 12\)"):
        read_text(tmp_path / "latin.toml", "a TOML problem file")
    (tmp_path / "bin.toml").write_bytes(b"\x7fELF\x00\x01")
    with pytest.raises(hisopt.ConfigError, match="binary data"):
        read_text(tmp_path / "bin.toml", "a TOML problem file")
    with pytest.raises(hisopt.ConfigError, match="is a directory; expected a TOML problem file"):
        read_text(tmp_path, "a TOML problem file")
    with pytest.raises(hisopt.ConfigError, match=r"cannot read \("):
        read_text("/proc/self/mem", "a TOML problem file")


def test_design_files_with_units_row_delimiters_header_case_and_blank_lines(tmp_path, problem):
    names = problem.variable_names
    cases = {
        "plain.csv": "p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n",
        "units.csv": "p0,dA,lam,Rv,sigma_aw\n[Pa],[m^2],[-],[Pa s m^-3],[m/s^2]\n2e6,1e-3,0.5,8e5,0.55\n",
        "semicolon.csv": "p0;dA;lam;Rv\n2e6;1e-3;0.5;8e5\n",
        "tab.csv": "p0\tdA\tlam\tRv\n2e6\t1e-3\t0.5\t8e5\n",
        "case.csv": "P0 , DA,Lam,rv\n\n2e6,1e-3,0.5,8e5\n\n",
        "bom.csv": "\ufeffp0,dA,lam,Rv\r\n2e6,1e-3,0.5,8e5\r\n",
    }
    for name, text in cases.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
        frame = read_designs(tmp_path / name, names)
        assert frame.to_numpy().tolist() == [BASE], name
    (tmp_path / "nan.csv").write_text("p0,dA,lam,Rv\n,1e-3,0.5,8e5\nnan,1e-3,0.5,inf\n")
    assert np.isnan(read_designs(tmp_path / "nan.csv", names)["p0"]).all()


@pytest.mark.parametrize(
    "text,match",
    [
        ("", r"empty file"),
        ("p0,dA,lam,Rv\n", r"no designs below the header \(line 1\)"),
        ("p0,dA,lam\n1,2,3\n", r"missing column 'Rv'"),
        ("p0|dA|lam|Rv\n1|2|3|4\n", r"the header is the single column 'p0\|dA\|lam\|Rv'"),
        ("p0,dA,lam,Rv\n1,2,3\n", r"line 2: 3 fields, expected 4"),
        ("p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n2e6,abc,0.5,8e5\n", r"line 3, column 'dA': expected a number, got 'abc'"),
        ("p0;dA;lam;Rv\n2e6;0,001;0.5;8e5\n", r"line 2, column 'dA': expected a number, got '0,001'; use a point"),
        ("p0,P0,dA,lam,Rv\n1,1,1,1,1\n", r"columns 'p0', 'P0' all name the design variable 'p0'; expected one column"),
    ],
)
def test_unreadable_design_files_name_file_line_and_column(tmp_path, problem, text, match):
    path = tmp_path / "designs.csv"
    path.write_text(text)
    with pytest.raises(hisopt.ConfigError, match=match) as info:
        read_designs(path, problem.variable_names)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_deferred_signals_wait_for_the_block_and_never_leak():
    import os
    import signal

    from hisopt import interrupt

    before = signal.getsignal(signal.SIGTERM)  # SIG_DFL, or the CLI's if a test imported hisopt.cli
    with interrupt.signals_as_interrupts():
        with pytest.raises(interrupt.Interrupted) as info:
            with interrupt.deferred():
                os.kill(os.getpid(), signal.SIGTERM)
                done = True  # the block runs to its end first
        assert done and info.value.exit_code == 143 and info.value.name == "SIGTERM"
        with pytest.raises(ValueError):  # a block that fails: the held signal is dropped with it
            with interrupt.deferred():
                os.kill(os.getpid(), signal.SIGINT)
                raise ValueError("write failed")
        with interrupt.deferred():
            pass  # nothing left over from the failed block
    assert signal.getsignal(signal.SIGTERM) is before
