"""Issue 13, item by item, through the real CLI entry point: bad input never passes silently
and never crashes (exit 2 with one line naming the file or option, the key or row, and what
was expected; or exit 0 with every questionable row flagged)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hisopt.io import read_csv
from tests.cli_inprocess import assert_one_line, run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

TEXT = DEFAULT_PROBLEM.read_text(encoding="utf-8")


def edited(tmp_path: Path, old: str, new: str, name: str = "edited.toml") -> Path:
    assert old in TEXT
    path = tmp_path / name
    path.write_text(TEXT.replace(old, new, 1), encoding="utf-8")
    return path


# --- accepted silently, wrong answer ---------------------------------------------------------
@pytest.mark.parametrize(
    "old,new,key,expect",
    [
        ("m_s = 1210.0", "m_s = true", "vehicle.m_s", "got the boolean true"),
        ("m_s = 1210.0", "m_s = 1e309", "vehicle.m_s", "expected a finite number, got inf"),
        ("k_tf = 200000.0", "k_tf = inf", "vehicle.k_tf", "expected a finite number, got inf"),
        ("I_x = 390.0", "I_x = nan", "vehicle.I_x", "expected a finite number, got nan"),
        ("m_s = 1210.0", "m_s = 1.21e303", "vehicle.m_s", "magnitude between 1e-15 and 1e+15"),
        ("pop_size = 100", "pop_size = true", "optimizer.pop_size", "expected an integer, got the boolean true"),
    ],
)
def test_booleans_and_non_finite_numbers_are_refused(tmp_path, old, new, key, expect):
    path = edited(tmp_path, old, new)
    assert_one_line(run_cli("evaluate", path), str(path), key, expect)


def test_duplicate_objectives_are_refused_in_evaluate_and_optimize(tmp_path):
    path = edited(tmp_path, '"sigma_aw", "max_roll_psd"', '"sigma_aw", "sigma_aw"')
    for args in (("evaluate", path), ("optimize", path, "--out", tmp_path / "run", "--pop", "8", "--gens", "2")):
        assert_one_line(run_cli(*args), str(path), "objectives", "'sigma_aw' is listed twice")
    assert not (tmp_path / "run").exists()


# --- design files validated like problem files ------------------------------------------------
def test_design_rows_are_flagged_and_never_feasible(tmp_path):
    designs = tmp_path / "designs.csv"
    designs.write_text(
        "p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n-1,1e-3,0.5,8e5\n2e6,1e-3,1.5,8e5\n2e6,-1e-3,0.5,8e5\nnan,1e-3,0.5,8e5\ninf,1e-3,0.5,8e5\n9e6,1e-3,0.5,8e5\n"
    )
    results = tmp_path / "out.csv"
    out = run_cli("evaluate", DEFAULT_PROBLEM, "--designs", designs, "--out", results)
    assert out.code == 0, out.stderr
    assert out.error_lines == [
        f"warning: {designs}: 6 of 7 designs flagged (5 invalid, 1 out_of_bounds); none of them is feasible, see the status and reason columns"
    ]
    df = read_csv(results)
    assert list(df["status"]) == ["ok", "invalid", "invalid", "invalid", "invalid", "invalid", "out_of_bounds"]
    assert list(df["feasible"]) == [True] + [False] * 6
    assert df.loc[1:5, "sigma_aw"].isna().all() and np.isfinite(df.loc[[0, 6], "sigma_aw"]).all()
    assert "p0 = -1 breaks p0 >= 0" in df.loc[1, "reason"] and "lam = 1.5 breaks 0 < lam < 1" in df.loc[2, "reason"]
    assert "dA = -0.001 breaks dA > 0" in df.loc[3, "reason"] and "expected a finite number" in df.loc[5, "reason"]
    assert "above the upper bound 4e+06" in df.loc[6, "reason"]
    # the results file reads back as a design file (units row, extra columns) with the same rows
    again = tmp_path / "again.csv"
    assert run_cli("evaluate", DEFAULT_PROBLEM, "--designs", results, "--out", again).code == 0
    assert again.read_bytes() == results.read_bytes()


def test_design_file_header_case_and_semicolons_are_accepted(tmp_path):
    designs = tmp_path / "d.csv"
    designs.write_text("P0;DA;LAM;RV\n2e6;1e-3;0.5;8e5\n")
    out = run_cli("evaluate", DEFAULT_PROBLEM, "--designs", designs)
    assert out.code == 0 and out.stderr == "" and "0.5534" in out.stdout  # docs/model.md §7.1: 0.5534


# --- internal errors for user mistakes ---------------------------------------------------------
def test_empty_problem_file_and_empty_variables(tmp_path):
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    for args in (("evaluate", empty), ("optimize", empty, "--out", tmp_path / "run"), ("modes", empty)):
        assert_one_line(run_cli(*args), str(empty), "variables: expected at least one design variable")
    no_vars = tmp_path / "novars.toml"
    no_vars.write_text(TEXT[: TEXT.index("[variables]")] + "[variables]\n" + TEXT[TEXT.index("[road]") :])
    assert_one_line(run_cli("evaluate", no_vars), str(no_vars), "variables: expected at least one design variable")


def test_infinite_vehicle_value_with_modes(tmp_path):
    path = edited(tmp_path, "m_s = 1210.0", "m_s = inf")
    assert_one_line(run_cli("modes", path), str(path), "vehicle.m_s", "finite")


@pytest.mark.parametrize("target", ["afile/x.csv", "/proc/hisopt-test/x.csv", "adir"])
def test_evaluate_out_that_cannot_be_written(tmp_path, target):
    (tmp_path / "afile").write_text("")
    (tmp_path / "adir").mkdir()
    out_path = tmp_path / target if not target.startswith("/") else Path(target)
    line = assert_one_line(run_cli("evaluate", DEFAULT_PROBLEM, "--out", out_path), "--out")
    assert ".tmp" not in line and str(out_path) in line


# --- unbounded work -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "args,expect",
    [
        (("sweep", DEFAULT_PROBLEM, "--vary", "p0", "--points", "100000000"), "expected at most 1000 sweep points"),
        (("regions", DEFAULT_PROBLEM, "--pair", "dA,lam", "--points", "5000"), "expected at most 300 grid values"),
    ],
)
def test_huge_requests_are_refused_up_front(tmp_path, args, expect):
    started = time.perf_counter()
    line = assert_one_line(run_cli(*args, "--out", tmp_path), "--points", expect)
    assert "take about" in line  # the reason
    assert time.perf_counter() - started < 30  # refused before any work (generous: no timing threshold intended)


# --- unclear messages ---------------------------------------------------------------------------
def test_bom_is_accepted(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + TEXT.encode("utf-8"))
    out = run_cli("evaluate", path)
    assert out.code == 0 and "0.5534" in out.stdout


@pytest.mark.parametrize(
    "content,expect",
    [
        (("# caf\u00e9\n" + TEXT).encode("latin-1", errors="replace"), "not UTF-8 text (byte 0xe9 at line 1, column 6)"),
        (b"\x7fELF\x02\x01\x01\x00\x00\x00", "binary data (NUL bytes)"),
        (None, "is a directory; expected a TOML problem file"),
    ],
)
def test_encodings_and_directories_get_one_clear_line(tmp_path, content, expect):
    path = tmp_path / "problem.toml"
    if content is None:
        path.mkdir()
    else:
        path.write_bytes(content)
    assert_one_line(run_cli("evaluate", path), str(path), expect)


def test_set_blames_the_option_not_the_file():
    line = assert_one_line(run_cli("evaluate", DEFAULT_PROBLEM, "--set", "p0=abc"), "--set p0=abc", "expected a valid number")
    assert str(DEFAULT_PROBLEM) not in line


def test_refusing_to_resume_a_changed_problem_prints_one_line(tmp_path):
    problem = tmp_path / "mine.toml"
    problem.write_text(TEXT)
    run = tmp_path / "run"
    assert run_cli("optimize", problem, "--out", run, "--pop", "8", "--gens", "2").code == 0
    problem.write_text(TEXT + "\n# edited\n")
    line = assert_one_line(run_cli("resume", run), "changed since the run started")
    assert "start a new run" in line


def test_real_process_one_line_and_exit_2(tmp_path):
    """A handful through a real process: nothing but one line on stderr, exit code 2."""
    path = edited(tmp_path, "m_s = 1210.0", "m_s = true")
    proc = subprocess.run([sys.executable, "-m", "hisopt", "evaluate", str(path)], check=False, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith(f"error: {path}: vehicle.m_s")


def test_refinement_start_points_are_checked_like_every_design(tmp_path):
    run = tmp_path / "run"
    assert run_cli("optimize", DEFAULT_PROBLEM, "--out", run, "--pop", "8", "--gens", "2").code == 0
    front = read_csv(run / "front.csv")
    front.loc[len(front) - 1, "lam"] = 1.5
    from hisopt.io import write_csv

    write_csv(front, run / "front.csv")
    assert_one_line(run_cli("refine", run, "--max-points", "2"), f"{run / 'front.csv'}: row {len(front)}: lam = 1.5 breaks 0 < lam < 1")


@pytest.mark.parametrize(
    "args,option",
    [
        (("droptest", DEFAULT_PROBLEM, "--p0", "inf"), "--p0"),
        (("droptest", DEFAULT_PROBLEM, "--p0", "1e6", "--height", "inf"), "--height"),
        (("droptest", DEFAULT_PROBLEM, "--p0", "1e6", "--measured-p0", "-5"), "--measured-p0"),
        (("evaluate", DEFAULT_PROBLEM, "--designs", "DESIGNS", "--workers", "0"), "--workers"),
        (("evaluate", DEFAULT_PROBLEM, "--designs", "DESIGNS", "--scheduler", "nonsense"), "--scheduler"),
    ],
)
def test_bad_options_name_the_option(tmp_path, args, option):
    designs = tmp_path / "d.csv"
    designs.write_text("p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n")
    args = tuple(designs if a == "DESIGNS" else a for a in args)
    if args[0] == "droptest":
        args += ("--out", tmp_path / "dt")
    assert_one_line(run_cli(*args), f"error: {option}:")
