"""The buildability verdict where a run is read (docs/model.md §21.3): the optimise summary,
``buildability.csv``, the run report, the decision room and its "buildable only" filter, and
the refusal of a box with no buildable design.

Every number is checked against :func:`hisopt.studies.buildability.buildability` computed
here on the same designs. Error budget: the stored verdicts are the same computation on the
same designs, written with round-trip decimals, but in batches of another size (the run's
front against a test's selection), which can move a usage by rounding in the batched linear
algebra: 1e-9 relative, far below any rule's meaning and above 1e-15 times the condition
numbers of these small systems.
"""

from __future__ import annotations

import os
import re
import shutil
import tomllib

import numpy as np
import pandas as pd
import pytest

from hisopt.coupled.buildability import RULES
from hisopt.errors import ConfigError
from hisopt.io import read_csv
from hisopt.optim.decision import knee_index
from hisopt.optim.rundir import FRONT_CSV, read_front
from hisopt.problem import load_problem, problem_from_dict
from hisopt.studies.build_verdicts import BUILDABILITY_CSV, buildable_line, failing_rules, margin_text, verdict_cells, verdicts_of
from hisopt.studies.buildability import buildability
from hisopt.studies.buildable_box import BOX_SEED, box_sample, box_verdict, check_buildable_box, enforced_rules
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

VALVES = ROOT / "tests" / "data" / "valves_one_road.toml"  # the valves problem on its city road alone
RELAXED = """
[build]  # wide limits: a small run's front holds buildable designs and others
strut_load_share = 1.0
area_ratio_max = 10.0
annulus_wall = "1 mm"
wheel_damping = 0.01
"""
IMPOSSIBLE = """
[build]
strut_load_share = 0.001

[[constraints]]
name = "strut_load_usage"
limit = 1.0
"""
BATCH_BUDGET = 1e-9


def assert_same_verdicts(got: pd.DataFrame, expected: pd.DataFrame) -> None:
    """``got`` (a view's verdicts) equals ``expected`` (:func:`buildability`), rule by rule."""
    for name in [*RULES, "build_margin"]:
        np.testing.assert_allclose(got[name].to_numpy(dtype=float), expected[name].to_numpy(dtype=float), rtol=BATCH_BUDGET, equal_nan=True)
    assert got["buildable"].tolist() == expected["buildable"].tolist()
    assert got["binding_rule"].tolist() == expected["binding_rule"].tolist()


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A small run of the relaxed valves problem: ``(run directory, problem, summary text)``."""
    folder = tmp_path_factory.mktemp("views")
    path = folder / "relaxed.toml"
    path.write_text(VALVES.read_text() + RELAXED)
    out = folder / "run"
    result = run_cli("optimize", str(path), "--out", str(out), "--pop", "8", "--gens", "2", "--seed", "3")
    assert result.code == 0, result.stderr
    return out, load_problem(path, warn_implausible=False), result.stdout


@pytest.fixture(scope="module")
def expected(run):
    """The front's verdicts computed here."""
    out, problem, _ = run
    front = read_front(out / FRONT_CSV)
    return front, buildability(problem, front[list(problem.variable_names)])


def test_the_run_stores_each_front_designs_verdict(run, expected):
    out, problem, _ = run
    front, verdicts = expected
    stored = read_csv(out / BUILDABILITY_CSV, keep_default_na=False, na_values=[""])
    names = list(problem.variable_names)
    assert np.array_equal(stored[names].to_numpy(dtype=float), front[names].to_numpy(dtype=float))  # row by row the front's
    assert_same_verdicts(verdicts_of(problem, front[names].to_numpy(dtype=float), stored), verdicts)


def test_the_summary_counts_the_buildable_designs_and_gives_the_knees_verdict(run, expected):
    _, problem, text = run
    front, verdicts = expected
    n, ok = len(front), int(verdicts["buildable"].sum())
    assert 0 < ok < n, "the relaxed limits leave some front designs buildable and some not"
    assert f"{ok} of {n} front designs buildable" in text
    knee = verdicts.iloc[knee_index(front[list(problem.objective_names)].to_numpy(dtype=float))]
    picks = text[text.index("Knee and ASF pick") :]  # the knee's column, after the totals' "buildable" row

    def knee_cell(label: str) -> str:
        return next(line for line in picks.splitlines() if line.startswith(f"│ {label} ")).split("│")[2].strip()

    assert knee_cell("build_margin [%]") == f"{100 * knee['build_margin']:+.1f}"
    assert knee_cell("binding_rule") == knee["binding_rule"]
    assert knee_cell("buildable") == ("yes" if knee["buildable"] else "no")


def test_the_report_reads_the_stored_verdicts_and_computes_those_of_an_older_run(run, expected, tmp_path):
    from hisopt.report.html import report_page

    out, problem, _ = run
    front, verdicts = expected
    names = list(problem.variable_names)
    older = tmp_path / "older"
    shutil.copytree(out, older)
    (older / BUILDABILITY_CSV).unlink()
    page = report_page(older)
    assert buildable_line(verdicts) in page
    assert not (older / BUILDABILITY_CSV).exists()  # a reader writes nothing into a finished run
    tampered = tmp_path / "tampered"
    shutil.copytree(out, tampered)
    stored = read_csv(tampered / BUILDABILITY_CSV, keep_default_na=False, na_values=[""])
    stored["binding_rule"], stored["buildable"] = "hose_reynolds_usage", False
    stored.to_csv(tampered / BUILDABILITY_CSV, index=False)
    page = report_page(tampered)
    assert f"none of {len(front)} front designs buildable" in page and "hose_reynolds_usage" in page
    assert np.array_equal(stored[names].to_numpy(dtype=float), front[names].to_numpy(dtype=float))


def test_the_decision_room_gives_every_design_its_verdict(run):
    from hisopt.report.decision_page import room_payload
    from hisopt.studies.decision_room import decision_room_data, run_sources

    out, problem, _ = run
    sources = run_sources(out)
    room = decision_room_data(sources)
    expected = buildability(problem, sources[0].x)
    assert_same_verdicts(room.table.assign(**{r: expected[r] for r in RULES}), expected)  # the room keeps the verdict, not the usages
    assert room.groups["build_margin"] == "build"
    payload = room_payload(room)
    import base64

    assert np.frombuffer(base64.b64decode(payload["buildable"]), dtype=np.uint8).tolist() == expected["buildable"].astype(int).tolist()
    rules = [payload["rules"][k] for k in np.frombuffer(base64.b64decode(payload["binding_rule"]), dtype=np.uint8)]
    assert rules == expected["binding_rule"].tolist()


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


def test_the_buildable_only_filter_hides_the_others_in_every_view(run, tmp_path):
    """In headless Chromium: ticking "buildable only" keeps the front's buildable designs in
    the count, the linked views' selection and the table."""
    if CHROMIUM is None or CHROMEDRIVER is None:
        if os.environ.get("CI"):
            pytest.fail("chromium or chromedriver is not installed (.ci/run installs Debian's chromium and chromium-driver)")
        pytest.skip("chromium or chromedriver not installed")
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    from hisopt.report.decision_page import decision_room_page
    from hisopt.studies.decision_room import decision_room_data, run_sources

    out, problem, _ = run
    room = decision_room_data(run_sources(out))
    page = tmp_path / "decision.html"
    page.write_text(decision_room_page(room, "room"), encoding="utf-8")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--window-size=1400,1200"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        driver.get(page.as_uri())
        driver.find_element("id", "f-buildable").click()
        keep = np.flatnonzero(room.table["front"].to_numpy(dtype=bool) & room.table["buildable"].to_numpy(dtype=bool))
        assert 0 < len(keep) < room.table["front"].sum()
        assert driver.find_element("id", "count").text == str(len(keep))
        assert driver.execute_script("return window.hisoptRoom.selectedRows()") == keep.tolist()
        cells = [td.text for td in driver.find_elements("css selector", "#designs tbody tr td:nth-child(3)")]
        assert cells and set(cells) == {"yes"}
    finally:
        driver.quit()


# --- words ---------------------------------------------------------------------------------------
def test_the_verdict_in_words():
    rows = pd.DataFrame({name: [0.5, 0.9, 1.2] for name in RULES})
    rows["strut_load_usage"] = [2.0, 3.0, 0.1]
    rows["area_ratio_usage"] = [1.5, 0.2, np.nan]
    rows["buildable"], rows["binding_rule"], rows["build_margin"] = False, ["strut_load_usage", "strut_load_usage", ""], [-1.0, -2.0, np.nan]
    assert failing_rules(rows) == [("strut_load_usage", 2), ("pressure_floor_usage", 1), ("pressure_ceiling_usage", 1)]
    assert buildable_line(rows).startswith("none of 3 front designs buildable; failing most often: strut_load_usage (2), ")
    rows.loc[2, "buildable"] = True
    assert buildable_line(rows) == "1 of 3 front designs buildable"
    assert (margin_text(-0.0312), margin_text(0.125), margin_text(-0.0), margin_text(np.nan)) == ("-3.1", "+12.5", "+0.0", "-")
    assert verdict_cells(rows.iloc[2])["buildable"] == "yes" and verdict_cells(rows.iloc[1])["build_margin [%]"] == "-200.0"


def test_an_infinite_usage_shows_as_broken_with_a_margin_of_minus_infinity():
    """The paper problem's zero precharge: an accumulator rated at zero (an infinite ceiling usage)."""
    problem = load_problem(DEFAULT_PROBLEM, warn_implausible=False)
    x = np.array([[0.0, 10e-4, 0.5, 8e5], [2e6, 10e-4, 0.5, 8e5]])
    raw = buildability(problem, x)
    assert np.isinf(raw.loc[0, "pressure_ceiling_usage"])
    shown = verdicts_of(problem, x)
    assert_same_verdicts(shown, raw)
    assert verdict_cells(shown.iloc[0]) == {"buildable": "no", "binding_rule": "pressure_ceiling_usage", "build_margin [%]": "-inf"}


# --- a box with no buildable design --------------------------------------------------------------
def test_a_box_with_no_buildable_design_is_refused_before_the_run(tmp_path):
    path = tmp_path / "impossible.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + IMPOSSIBLE)
    out = tmp_path / "run"
    result = run_cli("optimize", str(path), "--out", str(out), "--pop", "8", "--gens", "2")
    assert result.code == 2 and len(result.error_lines) == 1, result.stderr
    line = result.error_lines[0]
    assert str(path) in line and "no design is buildable" in line and f"Sobol' sample of the [variables] box (seed {BOX_SEED})" in line
    assert "strut_load_usage (100 % of them)" in line
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["impossible.toml"]
    with pytest.raises(ConfigError, match="no design is buildable"):
        check_buildable_box(load_problem(path, warn_implausible=False))


def test_the_box_verdict_counts_the_sample_as_buildability_judges_it():
    data = tomllib.loads(VALVES.read_text() + RELAXED)
    data["constraints"] = [{"name": "strut_load_usage", "limit": 0.5}, {"name": "area_ratio_usage", "limit": 0.3}]
    problem = problem_from_dict(data, warn_implausible=False)
    assert set(enforced_rules(problem)) == {"strut_load_usage", "area_ratio_usage"}
    verdict = box_verdict(problem, 64)
    assert verdict is not None
    judged = buildability(problem, box_sample(problem, 64))
    strut, ratio = judged["strut_load_usage"].to_numpy(dtype=float), judged["area_ratio_usage"].to_numpy(dtype=float)
    assert verdict.buildable == int(np.sum((strut <= 0.5) & (ratio <= 0.3)))
    assert dict(verdict.failing) == pytest.approx({"strut_load_usage": np.mean(strut > 0.5), "area_ratio_usage": np.mean(ratio > 0.3)})
    assert min(dict(verdict.failing).values()) > 0 and [share for _, share in verdict.failing] == sorted(dict(verdict.failing).values(), reverse=True)
    assert 0 < verdict.buildable < 64
    check_buildable_box(problem, 64)  # some design is buildable: no refusal
    every = problem_from_dict(data | {"constraints": [{"name": "build_usage", "limit": 1.0}]}, warn_implausible=False)
    assert set(enforced_rules(every)) == set(RULES)
    assert box_verdict(load_problem(DEFAULT_PROBLEM, warn_implausible=False)) is None  # nothing enforced, nothing judged


def test_summary_lines_name_no_rule_twice():
    """The rules failing most often are each counted once per design (a design failing two
    rules counts under both), never as 'not evaluated' as well."""
    problem = load_problem(DEFAULT_PROBLEM, warn_implausible=False)
    x = np.array([[0.0, 10e-4, 0.5, 8e5]])
    words = buildable_line(verdicts_of(problem, x), "designs")
    names = re.findall(r"(\w+_usage|not evaluated) \(", words)
    assert len(names) == len(set(names)) and "not evaluated" not in names
