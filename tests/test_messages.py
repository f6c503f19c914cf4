"""Issue 22, the smaller messages, through the real CLI entry point (as tests/test_bad_input.py):
files in UTF-16/UTF-32, articles built from element names, a value named twice, "expected
one of none", a file where a run directory is expected, a layout study given to run commands."""

from __future__ import annotations

import json

import pytest

from hisopt.errors import with_article
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT
from tests.test_bad_input import TEXT, assert_one_line, edited

ROBUST = ROOT / "problems" / "roll_plane_his_robust.toml"
CUSTOM = ROOT / "problems" / "layout_custom_roll_plane.toml"
B_ACC = '{ type = "accumulator", node = "B", volume = "V0", precharge = "p0", gamma = "gamma" }'


# --- files saved as "Unicode" ---------------------------------------------------------------------
@pytest.mark.parametrize(
    "codec, name",
    [
        ("utf-16", "UTF-16 (little-endian)"),
        ("utf-16-be", "UTF-16 (big-endian)"),
        ("utf-16-le", "UTF-16 (little-endian)"),
        ("utf-32", "UTF-32 (little-endian)"),
        ("utf-32-be", "UTF-32 (big-endian)"),
    ],
)
def test_utf16_and_utf32_files_are_named_not_called_binary(tmp_path, codec, name):
    """Python's "utf-16" and "utf-32" write a byte-order mark, the -le/-be codecs none: both are
    recognised (the problem file carries non-ASCII text, so the BOM-less check must allow it)."""
    problem = tmp_path / "problem.toml"
    problem.write_bytes(("# 20 °C, §3.6\n" + TEXT).encode(codec))
    line = assert_one_line(run_cli("evaluate", problem), str(problem), f"{name} text; save it as UTF-8, expected a TOML problem file")
    assert "binary" not in line
    designs = tmp_path / "designs.csv"
    designs.write_bytes("p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n".encode(codec))
    assert_one_line(run_cli("evaluate", DEFAULT_PROBLEM, "--designs", designs), str(designs), f"{name} text; save it as UTF-8")


def test_binary_files_are_still_binary(tmp_path):
    path = tmp_path / "problem.toml"
    path.write_bytes(bytes(range(256)) * 8)
    assert_one_line(run_cli("evaluate", path), str(path), "binary data (NUL bytes)")


# --- "a accumulator" ------------------------------------------------------------------------------
def test_articles_follow_the_element_name(tmp_path):
    path = tmp_path / "custom.toml"
    text = CUSTOM.read_text(encoding="utf-8")
    assert B_ACC in text
    path.write_text(text.replace(B_ACC, B_ACC.replace(" }", ', resistance = "Rv" }')), encoding="utf-8")
    assert_one_line(run_cli("evaluate", path), "an accumulator takes node, volume, precharge, gamma; got 'resistance'")
    path.write_text(text.replace(B_ACC, B_ACC.replace('volume = "V0"', "volume = 0.0")), encoding="utf-8")
    assert_one_line(run_cli("evaluate", path), "for an accumulator, got 0.0")
    orifice = B_ACC + ',\n    { type = "orifice", from = "B", to = "B.x", kq = 1e9 }'
    nodes = 'nodes = ["B.1b", "B", "B.3b"]'
    assert nodes in text
    path.write_text(text.replace(B_ACC, orifice).replace(nodes, 'nodes = ["B.1b", "B", "B.3b", "B.x"]'), encoding="utf-8")
    assert_one_line(run_cli("evaluate", path), "expected both ends of an orifice connected")


@pytest.mark.parametrize(
    "word, text",
    [
        ("accumulator", "an accumulator"),
        ("orifice", "an orifice"),
        ("valve", "a valve"),
        ("pipe", "a pipe"),
        ("compliance", "a compliance"),
        ("8-design", "an 8-design"),
        (11, "an 11"),
        (18, "an 18"),
        (81, "an 81"),
        (625, "a 625"),
        (800, "an 800"),
        (1000, "a 1000"),
        (8000, "an 8000"),
        (11000, "an 11000"),
        (110000, "a 110000"),
    ],
)
def test_with_article_by_sound(word, text):
    assert with_article(word) == text


# --- a value named twice --------------------------------------------------------------------------
def test_scenario_name_error_names_the_value_once(tmp_path):
    path = tmp_path / "robust.toml"
    path.write_text(ROBUST.read_text(encoding="utf-8").replace('name = "city"', 'name = "city@night"', 1), encoding="utf-8")
    line = assert_one_line(run_cli("evaluate", path), "scenarios.0.name: expected letters, digits, '_' or '-'")
    assert line.count("got 'city@night'") == 1 and line.endswith("got 'city@night'")


# --- "expected one of none" -----------------------------------------------------------------------
def test_no_scenarios_is_not_a_list_of_none(tmp_path):
    line = assert_one_line(
        run_cli("modes", DEFAULT_PROBLEM, "--scenario", "city"),
        "--scenario",
        "unknown scenario 'city'",
        "expected a problem with [[scenarios]] (this one has none), or no --scenario",
    )
    assert "one of none" not in line
    path = edited(tmp_path, "[optimizer]", '[[constraints]]\nname = "rms_roll"\nlimit = 1.0\nscenarios = ["city"]\n\n[optimizer]')
    line = assert_one_line(run_cli("evaluate", path), "constraints: rms_roll names scenario 'city'; expected [[scenarios]] tables for it")
    assert "one of none" not in line


# --- a file or a layout study where a run directory is expected ----------------------------------
@pytest.mark.parametrize("command", ["status", "report", "resume", "refine"])
def test_a_file_is_called_a_file(command):
    assert_one_line(run_cli(command, DEFAULT_PROBLEM), f"{DEFAULT_PROBLEM}: a file, not a run directory; expected the --out directory")


def test_a_layout_study_is_named_to_run_commands_and_summarised_by_status(tmp_path):
    """A study whose runs never began (study.json only): status says what it holds and what to
    do; report refuses with that command; resume and refine name it instead of asking for a run."""
    out = tmp_path / "study"
    out.mkdir()
    record = {
        "format": "hisopt-layout-study/1",
        "problem": {"name": "paper", "sha256": "ab" * 32, "path": str(DEFAULT_PROBLEM)},
        "budget": {"pop_size": 8, "generations": 2},
        "normalisation": {},
        "layouts": {"roll_plane": "catalogue", "axle_roll": "catalogue"},
    }
    (out / "study.json").write_text(json.dumps(record), encoding="utf-8")
    status = run_cli("status", out)
    assert status.code == 0, status.stderr
    lines = status.stdout.splitlines()
    assert lines[0] == f"{out}: layout study of paper: layouts roll_plane, axle_roll; seeds none yet; runs of population 8 for 2 generations"
    assert lines[1] == "  no layouts.csv or report.html yet"
    assert lines[2].startswith(
        f"next: finish the study (finished runs are reused) with `hisopt compare-layouts {DEFAULT_PROBLEM} "
        f"--layouts roll_plane,axle_roll --seeds SEEDS --pop 8 --gens 2 --out {out}` (SEEDS: the seeds you gave"
    )
    assert f"{DEFAULT_PROBLEM} has changed since the study began" in lines[2]  # the recorded digest is not the file's
    assert_one_line(run_cli("report", out), "the layout study has no layouts.csv yet (it has not finished); finish it with `hisopt compare-layouts")
    for command in ("resume", "refine"):
        assert_one_line(run_cli(command, out), f"{out}: a layout study (`hisopt compare-layouts`), not a run; `hisopt status {out}` summarises it")
