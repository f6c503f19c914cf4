"""What the user sees of a time-domain verification (docs/model.md §22.5): ``verify.html``,
the decision room's "verified" column and the design sheet's section, and the one reading of
a run's ``verify-N`` folders they share (malformed files refused in one line).

The page is made from a small real verification (the paper's problem on its road, two road
pairs of 4 s: a few seconds) and checked against the rows themselves: each number the page
shows is the row's SI value scaled here by the engineering unit's factor (1e-6 for MPa, 1e3
for mm, 1e3 for L, 100 for a share in %), to the 4 significant figures shown. The run is a
small optimisation of the same problem; its verification folders are written here in the
format ``hisopt verify`` writes.
"""

from __future__ import annotations

import html
import json
import math
import os
import shutil
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hisopt.errors import RunError
from hisopt.io import read_csv
from hisopt.problem import load_problem
from hisopt.simulation.verification import Verification, VerifySettings, load_cases, verify_case
from hisopt.studies.verified import VERIFY_FORMAT, read_verification_summary, verified_rows
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM

SCALES = {"Pa": (1e-6, "MPa"), "m": (1e3, "mm"), "m^3": (1e3, "L"), "m^3/s": (1e3, "L/s"), "N": (1e-3, "kN"), "-": (100.0, "%"), "m/s^2": (1.0, "m/s^2")}
"""[display unit per SI unit] The units a verification shows (a pressure in MPa, a stroke in mm,
a volume in L, a flow in L/s, a force in kN, a share in %; an acceleration as it is)."""
MANOEUVRES = pd.DataFrame(
    {
        "case": ["road", "road"],
        "manoeuvre": ["step steer", "bump"],
        "figure": ["peak_roll", "peak_chamber_pressure"],
        "unit": ["rad", "Pa"],
        "transient": [0.05, 3.1e6],
        "linear": [0.0501, 3.12e6],
        "nonlinear": [0.055, 3.4e6],
    }
)
"""Manoeuvre rows in the engine's columns (the manoeuvres are simulated elsewhere; the page only shows them)."""


@pytest.fixture(scope="module")
def problem():
    return load_problem(DEFAULT_PROBLEM)


@pytest.fixture(scope="module")
def verification(problem) -> Verification:
    """A real verification of the baseline, kept short (two road pairs of 4 s after 1 s)."""
    settings = VerifySettings(realisations=2, duration_s=4.0, settle_s=1.0)
    x = problem.baseline[None, :]
    cases = tuple(verify_case(case, x, name, i, settings) for i, (name, case) in enumerate(load_cases(problem)))
    values = dict(zip(problem.variable_names, map(float, x[0]), strict=True))
    return Verification(problem.name, "baseline", values, settings, cases, MANOEUVRES)


class _Balance(HTMLParser):
    """Checks that every element opened is closed, in order (void elements aside)."""

    VOID = {"meta", "br", "input", "img", "hr", "link", "col", "source", "wbr"}

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.errors: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1:] or 'nothing'}")
        else:
            self.stack.pop()


def _shown(value: float, unit: str) -> str:
    """The row's value as the page shows it, computed here from the unit table."""
    text = f"{value * SCALES[unit][0]:.4g}"
    if "e" in text:  # 8.5e-05 -> 8.5e-5
        mantissa, exponent = text.split("e")
        text = f"{mantissa}e{int(exponent)}"
    return text


# --- verify.html -----------------------------------------------------------------------------------
def test_the_page_shows_every_figure_in_engineering_units_with_its_verdict(verification, problem):
    from hisopt.report.verify_page import VERDICT_CLASSES, figures_table, verify_page

    page = verify_page(verification, problem.variable_units)
    frame = verification.frame()
    shown = figures_table(frame)
    assert len(shown) == len(frame)
    for (_, row), (_, cells) in zip(frame.iterrows(), shown.iterrows(), strict=True):
        assert cells["unit"] == SCALES[row["unit"]][1], row["figure"]
        for column, cell in (("linear", "linear ± SE"), ("nonlinear", "nonlinear ± SE")):
            assert cells[cell].split(" ± ")[0] == _shown(float(row[column]), row["unit"]), (row["figure"], cells[cell])
        if math.isfinite(row["gap"]):
            assert float(cells["gap ± SE [%]"].split(" ± ")[0]) == pytest.approx(100 * row["gap"], rel=5e-3)
        assert cells["verdict"].startswith(row["verdict"]) and (row["cause"] in cells["verdict"])
        colour = VERDICT_CLASSES[row["verdict"]]  # every verdict the engine gives has its colour
        assert f'<span class="verdict {colour}">{html.escape(cells["verdict"])}</span>' in page and cells["linear ± SE"] in page
    assert f"{verification.verdict}</span></h1>" in page  # the design's verdict, in the title
    assert "road: R = 2" in page and "T = 4 s" in page
    assert "p0 = 2 MPa" in page  # the design in engineering units
    assert "peak_chamber_pressure" in page and "3.4" in page  # the manoeuvres' table, in MPa
    assert page.count('id="hisopt-plotly"') == 1  # plotly.js once
    assert page.count("window.hisoptFigures.push") == 3 * len(verification.cases)  # worst second, pressure ranges, spectra
    parser = _Balance()
    parser.feed(page)
    assert not parser.errors and parser.stack == [], (parser.errors, parser.stack)


def test_a_limit_near_the_records_is_drawn_and_a_far_one_named():
    from hisopt.plotting.verify import worst_second_figure

    t = np.linspace(0.0, 1.0, 50)
    p = 2e6 + 1e5 * np.sin(2 * np.pi * t)  # 1.9 to 2.1 MPa
    signals = {"p_acc_0": (p, p * 1.01), "p_acc_1": (p, p * 1.01)}  # two equal records: drawn once
    fig = worst_second_figure(t, signals, {"p_acc_0": "Pa", "p_acc_1": "Pa"}, {"p_acc_": [("floor", 1.85e6), ("ceiling", 16e6)]})
    lines = [s.y0 for s in fig.layout.shapes]
    assert lines == [pytest.approx(1.85)]  # in MPa, the panel's unit
    assert "ceiling 16 MPa" in fig.layout.annotations[0].text  # off the scale: said in the panel's title
    assert [tr.name for tr in fig.data if tr.showlegend] == ["accumulators 0, 1 (nonlinear)", "accumulators 0, 1 (linear)"]


# --- a run with verified designs -------------------------------------------------------------------
def _write_verification(folder: Path, verification: Verification, row: int | None, values: dict[str, float]) -> None:
    """``verify.csv``, ``verify.json`` and ``verify.html`` as ``hisopt verify`` writes them, of ``verification`` told it is of ``values``."""
    from hisopt.report.verify_page import verify_page
    from hisopt.studies.verify_designs import write_verification

    folder.mkdir(parents=True, exist_ok=True)
    verification = replace(verification, values=values, design=f"front.csv row {row}")
    write_verification(verification, folder, row, verify_page(verification))


@pytest.fixture(scope="module")
def run(tmp_path_factory, verification, problem):
    """A small run: front row 2 verified; ``verify-5`` holds a verification of another design
    (row 5 of an earlier front); ``verify-extra`` one of a design that is no front row."""
    out = tmp_path_factory.mktemp("verified") / "run"
    result = run_cli("optimize", str(DEFAULT_PROBLEM), "--out", str(out), "--pop", "8", "--gens", "2", "--seed", "3")
    assert result.code == 0, result.stderr
    front = read_csv(out / "front.csv")
    assert len(front) > 5
    names = list(problem.variable_names)
    _write_verification(out / "verify-2", verification, 2, {n: float(front[n].iloc[2]) for n in names})
    _write_verification(out / "verify-5", verification, 5, {n: float(front[n].iloc[4]) for n in names})
    _write_verification(out / "verify-extra", verification, None, verification.values)
    return out


def test_the_decision_room_shows_the_verdict_of_each_verified_front_design(run, verification):
    import base64

    from hisopt.report.decision_page import room_payload, run_decision_room
    from hisopt.studies.decision_room import decision_room_data, run_sources

    assert set(verified_rows(run)) == {2, 5}
    room = decision_room_data(run_sources(run))
    table = room.table
    expected = np.where((table["kind"] == "front") & (table["row"] == 2), verification.verdict, "")
    assert table["verified"].tolist() == expected.tolist()  # row 5's summary is of another design: blank
    payload = room_payload(room)
    codes = np.frombuffer(base64.b64decode(payload["verified"]), dtype=np.uint8)
    assert [payload["verdicts"][k] for k in codes] == expected.tolist()
    page = run_decision_room(run).read_text(encoding="utf-8")
    assert '"verify_pages":{"2":"verify-2/verify.html"}' in page
    assert "1 front designs verified in the time domain" in page


def test_the_rooms_table_shows_the_verified_column_in_the_browser(run, verification):
    """In headless Chromium: the designs table's "verified" cell holds front row 2's verdict, every other one is blank."""
    chromium, driver_path = shutil.which("chromium") or shutil.which("chromium-browser"), shutil.which("chromedriver")
    if chromium is None or driver_path is None:
        if os.environ.get("CI"):
            pytest.fail("chromium or chromedriver is not installed (.ci/run installs Debian's chromium and chromium-driver)")
        pytest.skip("chromium or chromedriver not installed")
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    from hisopt.report.decision_page import run_decision_room

    path = run_decision_room(run)
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--window-size=1400,1200"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    try:
        driver.get(path.as_uri())
        header = [th.text.split("\n")[0] for th in driver.find_elements("css selector", "#designs thead th")]
        assert header[:4] == ["export", "design", "buildable", "verified"]
        rows = {
            tr.find_elements("css selector", "td")[1].text: tr.find_elements("css selector", "td")[3].text
            for tr in driver.find_elements("css selector", "#designs tbody tr")
        }
        assert rows.pop("front row 2") == verification.verdict
        assert rows and set(rows.values()) == {""}
    finally:
        driver.quit()


def test_the_sheet_shows_the_verification_or_how_to_make_it(run, verification, tmp_path):
    result = run_cli("sheet", str(run), "--design", "2", "--out", str(tmp_path / "two"))
    assert result.code == 0, result.stderr
    text = (tmp_path / "two" / "sheet.md").read_text(encoding="utf-8")
    section = text[text.index("## Verified in the time domain") :]
    assert f"Verdict: {verification.verdict}:" in section and "road: R = 2" in section
    row = verification.frame().set_index("figure").loc["chamber_pressure_max"]
    assert f"| road | chamber_pressure_max | MPa | {_shown(row['frequency_domain'], 'Pa')} |" in section
    assert f"Verified in the time domain: {verification.verdict}." in text  # in the sheet's opening line too
    html_text = (tmp_path / "two" / "sheet.html").read_text(encoding="utf-8")
    assert "<h2>Verified in the time domain</h2>" in html_text
    for design in (3, 5):  # not verified; verified, but another design (an earlier front's row 5)
        assert run_cli("sheet", str(run), "--design", str(design), "--out", str(tmp_path / str(design))).code == 0
        text = (tmp_path / str(design) / "sheet.md").read_text(encoding="utf-8")
        assert f"run hisopt verify {run} --design {design}" in text and "| chamber_pressure_max |" not in text


# --- malformed files -------------------------------------------------------------------------------
BAD_SUMMARIES = {
    "not JSON": "{not json",
    "another format": json.dumps({"format": "hisopt-verify/0"}),
    "a list": "[1, 2]",
    "no verdict": json.dumps({"format": VERIFY_FORMAT, "problem": "p", "design": "d", "row": 1}),
}


@pytest.mark.parametrize("text", BAD_SUMMARIES.values(), ids=list(BAD_SUMMARIES))
def test_a_malformed_summary_is_refused_in_one_line(tmp_path, text):
    (tmp_path / "verify.json").write_text(text, encoding="utf-8")
    with pytest.raises(RunError) as caught:
        read_verification_summary(tmp_path)
    message = str(caught.value)
    assert "\n" not in message and str(tmp_path / "verify.json") in message


def test_a_summary_with_a_wrong_value_names_its_key(run, tmp_path):
    good = json.loads((run / "verify-2" / "verify.json").read_text())
    for key, value in (("row", -1), ("verdict", "fine"), ("realisations", {"road": 2.5}), ("duration_s", "20 s")):
        (tmp_path / "verify.json").write_text(json.dumps(good | {key: value}), encoding="utf-8")
        with pytest.raises(RunError, match=key if key != "verdict" else "verdict 'fine'"):
            read_verification_summary(tmp_path)


def test_the_sheet_and_the_room_refuse_a_malformed_summary_in_one_line(run, tmp_path):
    from hisopt.studies.decision_room import decision_room_data, run_sources

    broken = tmp_path / "run"
    shutil.copytree(run, broken)
    (broken / "verify-2" / "verify.json").write_text('{"format": "hisopt-verify/1", "row": 2', encoding="utf-8")
    result = run_cli("sheet", str(broken), "--design", "2", "--out", str(tmp_path / "sheet"))
    assert result.code == 2 and len(result.error_lines) == 1, result.stderr
    assert "verify-2/verify.json" in result.stderr
    assert not (tmp_path / "sheet").exists()  # refused before anything was written
    with pytest.raises(RunError, match="verify.json"):
        decision_room_data(run_sources(broken))
