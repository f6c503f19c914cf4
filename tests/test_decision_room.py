"""The decision room (docs/model.md §19): what it holds, its navigation rules, and the page
itself driven in headless Chromium (Debian's chromium and chromium-driver, through selenium).

The page's brush, reference point and E-NAUTILUS step are checked against this package's
Python (:func:`hisopt.optim.decision.asf_index`, :mod:`hisopt.optim.navigation`), its exports
against ``hisopt evaluate``. The page's own clock times a brush; the figure is reported in the
test session's summary, never asserted.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

import hisopt
import hisopt.io
from hisopt.constants import G_MPS2
from hisopt.evaluation.psd import roll_gradient
from hisopt.evaluation.transient import step_responses, transient_quantities
from hisopt.optim.decision import asf_index, normalised_log
from hisopt.optim.navigation import enautilus_options, enautilus_walk, reachable_ranges, representatives
from hisopt.problem import problem_from_dict
from hisopt.simulation.timedomain import simulate
from hisopt.studies.decision_room import decision_room_data, part_columns, problem_template, run_sources
from hisopt.studies.design_sheet import parts_table
from tests.conftest import DEFAULT_PROBLEM, ROOT

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
TIMINGS: dict[str, float] = {}
"""Brush update times the page measured [ms], by archive (tests/conftest.py prints them)."""


# --- navigation rules ----------------------------------------------------------------------------
def _front(n: int, k: int, seed: int) -> np.ndarray:
    """A non-dominated set: points on the simplex-like surface sum(z^2) = 1, scaled."""
    rng = np.random.default_rng(seed)
    z = np.abs(rng.normal(size=(n, k)))
    return z / np.linalg.norm(z, axis=1, keepdims=True)


def test_representatives_are_deterministic_spread_and_all_when_few():
    z = _front(200, 3, 1)
    first = representatives(z, 5)
    assert np.array_equal(first, representatives(z.copy(), 5)) and len(set(first.tolist())) == 5
    assert first[0] == int(np.argmin(z.sum(axis=1)))
    # each next one is the farthest from those before it
    for m in range(1, 5):
        d = np.min(np.linalg.norm(z[:, None, :] - z[first[:m]][None], axis=2), axis=1)
        assert d[first[m]] == pytest.approx(d.max(), rel=1e-12)
    assert np.array_equal(representatives(z[:3], 5), np.arange(3))


def test_an_enautilus_walk_narrows_to_a_front_design():
    z = _front(300, 4, 2)
    z = normalised_log(10**z)[0]
    steps, k = 4, 3
    walk = enautilus_walk(z, [0, 1, 2], steps, k)
    assert len(walk) == steps
    previous = np.arange(len(z))
    for step, options in enumerate(walk):
        for o in options:
            assert set(o.reachable.tolist()) <= set(previous.tolist())  # reachable sets only shrink
            assert o.representative in o.reachable
            assert np.all(o.best <= o.point) and np.all(o.best == z[o.reachable].min(axis=0))
        if step < 3:
            previous = options[[0, 1, 2][step]].reachable
    # the last step's points are designs of the front
    for o in walk[-1]:
        assert np.array_equal(o.point, z[o.representative]) and o.representative in o.reachable
    with pytest.raises(ValueError, match="at least one step"):
        enautilus_options(z, np.ones(4), np.arange(len(z)), 0, 3)


def test_reachable_ranges_are_those_of_the_designs_at_least_as_good():
    z = _front(100, 2, 3)
    point = np.array([0.6, 0.9])
    lo, hi = reachable_ranges(z, point)
    inside = z[np.all(z <= point, axis=1)]
    assert np.array_equal(lo, inside.min(axis=0)) and np.array_equal(hi, inside.max(axis=0))
    assert reachable_ranges(z, np.array([0.0, 0.0])) is None


# --- what the room holds -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def problem() -> hisopt.Problem:
    return hisopt.load_problem(DEFAULT_PROBLEM)


def test_step_responses_follow_the_time_domain_simulator(problem):
    x = np.array([[2.0e6, 10e-4, 0.5, 8e5], [0.0, 1e-4, 0.1, 0.0]])
    t = np.linspace(0.0, 3.0, 31)
    model = problem.model(x)
    assert not problem.spec.handling.gravity_moment  # the simulator's body force is the lateral force's moment alone
    phi = step_responses(model, model.car, t, 0.4, False)
    peaks = transient_quantities(model, model.car, ["roll_step_peak"], 0.4, False)["roll_step_peak"]
    steady = roll_gradient(model.stiffness(), model.vehicle, False) * 0.4
    for i, design in enumerate(x):
        one = problem.model(design[None])
        force = np.zeros(7)
        force[1] = one.vehicle.m_s * 0.4 * G_MPS2 * one.vehicle.h_0s
        r = simulate(one, t, np.zeros((len(t), 4)), body_force=force, rtol=1e-10)
        # the integrator's global error: a local tolerance of 1e-10 over some 1e4 steps, with
        # margin 1e-6 of the peak; a wrong sign or factor shows at 1e-1
        assert np.max(np.abs(phi[i] - r.displacement[:, 1])) <= 1e-6 * peaks[i]
        assert np.max(np.abs(phi[i])) <= peaks[i] * (1 + 1e-9)  # samples never beat the refined peak
    assert np.all(np.sign(phi[:, -1]) == np.sign(steady))


def test_part_columns_match_the_design_sheet():
    for name in ("roll_plane_his.toml", "roll_plane_his_parts.toml"):
        p = hisopt.load_problem(ROOT / "problems" / name)
        x = np.vstack([p.baseline, p.lower + 0.5 * (p.upper - p.lower)])
        parts = part_columns(p, x)
        for i in range(len(x)):
            design = p.replace_values(dict(zip(p.variable_names, map(float, x[i]), strict=True)))
            sheet = parts_table(design).set_index("item")["value"]
            assert parts["front bore"][i] == pytest.approx(sheet["front cylinder bore"], rel=1e-15)
            assert parts["front rod"][i] == pytest.approx(sheet["front piston rod"], rel=1e-15)


@pytest.mark.parametrize("name", ["roll_plane_his.toml", "roll_plane_his_parts.toml", "layout_roll_plane_accumulator_valves.toml"])
def test_the_problem_template_with_a_design_reads_back_as_that_design(name):
    p = hisopt.load_problem(ROOT / "problems" / name)
    design = p.lower + 0.37 * (p.upper - p.lower)
    text = problem_template(p)
    for v, value in zip(p.variable_names, design, strict=True):
        assert text.count("{{" + v + "}}") == 1
        text = text.replace("{{" + v + "}}", repr(float(value)))
    read = problem_from_dict(tomllib.loads(text))
    assert np.array_equal(read.baseline, design)
    assert read.spec.model_dump(exclude={"his"}) == p.spec.model_dump(exclude={"his"})


# --- the page ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("room") / "run"
    args = ["optimize", str(DEFAULT_PROBLEM), "--out", str(out), "--pop", "24", "--gens", "12", "--seed", "5"]
    proc = subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    proc = subprocess.run([sys.executable, "-m", "hisopt", "report", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {out / 'decision.html'}" in proc.stdout
    return out


@pytest.fixture(scope="module")
def room(run_dir):
    return decision_room_data(run_sources(run_dir))


def test_run_sources_keep_the_front_whole_and_the_latest_other_designs(run_dir):
    import pandas as pd

    names = ["p0", "dA", "lam", "Rv"]
    front = hisopt.io.read_csv(run_dir / "front.csv")[names].to_numpy(dtype=float)
    every = run_sources(run_dir)[0]
    assert np.array_equal(every.x[: len(front)], front) and set(every.kind[: len(front)]) == {"front"}
    assert len({tuple(v) for v in every.x}) == len(every.x)  # each design once
    evaluated = pd.read_parquet(run_dir / "evaluations.parquet")
    valid = evaluated[evaluated["valid"]]
    others = {tuple(v) for v in valid[names].to_numpy(dtype=float)} - {tuple(v) for v in front}
    assert len(every.x) == len(front) + len(others)  # below the cap: all of them
    capped = run_sources(run_dir, max_rows=len(front) + 10)[0]
    latest = capped.row[capped.kind == "evaluated"]
    assert len(capped.x) == len(front) + 10 and np.all(np.diff(latest) > 0)
    assert latest.min() >= np.sort(every.row[every.kind == "evaluated"])[-10]  # the ten latest
    assert len(run_sources(run_dir, max_rows=5)[0].x) == len(front)  # the front always whole


def _driver_or_skip(download: Path):
    if CHROMIUM is None or CHROMEDRIVER is None:
        if os.environ.get("CI"):
            pytest.fail("chromium or chromedriver is not installed (.ci/run installs Debian's chromium and chromium-driver)")
        pytest.skip("chromium or chromedriver not installed")
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--window-size=1400,1200"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"performance": "ALL", "browser": "ALL"})
    options.add_experimental_option("prefs", {"download.default_directory": str(download), "download.prompt_for_download": False})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.execute_cdp_cmd("Page.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(download)})
    return driver


@pytest.fixture(scope="module")
def page(run_dir, tmp_path_factory):
    download = tmp_path_factory.mktemp("downloads")
    driver = _driver_or_skip(download)
    driver.get((run_dir / "decision.html").as_uri())
    driver.download = download  # type: ignore[attr-defined]
    yield driver
    driver.quit()


def _brush(driver, axis: str, low: float, high: float) -> None:
    """Drag along ``axis`` from ``low`` to ``high`` of its height (0 the bottom), as a person does."""
    from selenium.webdriver.common.action_chains import ActionChains

    canvas = driver.find_element("id", "pc-ax")
    a = next(a for a in driver.execute_script("return window.hisoptRoom.axes()") if a["name"] == axis)
    width, height = canvas.size["width"], canvas.size["height"]
    y = lambda t: a["bottom"] - t * (a["bottom"] - a["top"])  # noqa: E731
    chain = ActionChains(driver)
    chain.move_to_element_with_offset(canvas, int(a["x"] - width / 2), int(y(low) - height / 2)).click_and_hold()
    chain.move_by_offset(0, int(y(high) - y(low))).release().perform()


def _front_rows(room, brushes: dict) -> np.ndarray:
    keep = room.table["front"].to_numpy(dtype=bool).copy()
    for name, (lo, hi) in brushes.items():
        v = room.table[name].to_numpy(dtype=float)
        keep &= (v >= lo) & (v <= hi)
    return np.flatnonzero(keep)


def test_the_page_loads_offline_without_errors(page, run_dir, room):
    severe = [e for e in page.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe
    assert page.find_element("id", "total").text == str(len(room.table))
    assert page.find_element("id", "count").text == str(int(room.table["front"].sum()))  # on the front only, at first
    size = (run_dir / "decision.html").stat().st_size
    assert size < 8e6


def test_a_brush_filters_the_count_to_the_rows_in_its_range(page, room):
    _brush(page, "sigma_aw", 0.25, 0.7)
    brushes = page.execute_script("return window.hisoptRoom.brushes()")
    assert list(brushes) == ["sigma_aw"]
    rows = _front_rows(room, brushes)
    assert 0 < len(rows) < room.table["front"].sum()
    assert page.find_element("id", "count").text == str(len(rows))
    assert page.execute_script("return window.hisoptRoom.selectedRows()") == rows.tolist()
    TIMINGS[f"brush, {len(room.table)} designs"] = page.execute_script("return window.hisoptRoom.timing().last")


def test_a_reference_point_picks_the_python_asf_design(page, room):
    from selenium.webdriver.common.keys import Keys

    brushes = page.execute_script("return window.hisoptRoom.brushes()")
    rows = _front_rows(room, brushes)
    f = room.table.loc[rows, room.objectives].to_numpy(dtype=float)
    columns = {c["name"]: c for c in json.loads(page.execute_script("return document.getElementById('room-data').textContent"))["columns"]}
    # aspire to the middle of each objective's range among those designs, typed in the shown unit
    typed = [float(f"{np.sqrt(f[:, j].min() * f[:, j].max()) * columns[o]['display']['scale']:.4g}") for j, o in enumerate(room.objectives)]
    for j, value in enumerate(typed):
        box = page.find_element("css selector", f'#ref-table input.ref[data-j="{j}"]')
        box.clear()
        box.send_keys(repr(value), Keys.TAB)
    reference = np.array([v / columns[o]["display"]["scale"] for v, o in zip(typed, room.objectives, strict=True)])
    # one ulp of log10 could only swap two designs whose ASF values agree to 1e-16
    assert page.execute_script("return window.hisoptRoom.asf()") == int(rows[asf_index(f, reference)])
    assert page.execute_script("return window.hisoptRoom.shown()") == int(rows[asf_index(f, reference)])


def test_enautilus_steps_show_the_python_steps(page, room):
    brushes = page.execute_script("return window.hisoptRoom.brushes()")
    rows = _front_rows(room, brushes)
    z = normalised_log(room.table.loc[rows, room.objectives].to_numpy(dtype=float))[0]
    for name, value in (("en-k", "3"), ("en-steps", "3")):
        box = page.find_element("id", name)
        box.clear()
        box.send_keys(value)
    page.find_element("id", "en-start").click()
    walk = enautilus_walk(z, [1, 0], 3, 3)
    shown = lambda: [int(tr.get_attribute("data-representative")) for tr in page.find_elements("css selector", "#en-table tbody tr")]  # noqa: E731
    assert shown() == [int(rows[o.representative]) for o in walk[0]]
    page.find_element("css selector", '#en-table button[data-option="1"]').click()
    assert shown() == [int(rows[o.representative]) for o in walk[1]]
    page.find_element("css selector", '#en-table button[data-option="0"]').click()
    assert shown() == [int(rows[o.representative]) for o in walk[2]]
    page.find_element("id", "en-back").click()
    assert shown() == [int(rows[o.representative]) for o in walk[1]]


def _downloaded(folder: Path, name: str) -> Path:
    path = folder / name
    for _ in range(100):
        if path.is_file() and not list(folder.glob("*.crdownload")):
            return path
        time.sleep(0.1)
    raise AssertionError(f"{name} was not downloaded; {sorted(p.name for p in folder.iterdir())}")


def test_exports_reproduce_the_designs_objectives(page, run_dir, room, tmp_path):
    boxes = page.find_elements("css selector", "#designs tbody input[type=checkbox]")[:3]
    for box in boxes:
        box.click()
    chosen = sorted(int(b.get_attribute("data-row")) for b in boxes)
    page.find_element("id", "export-csv").click()
    exported = _downloaded(page.download, "designs.csv")
    out = tmp_path / "again.csv"
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "evaluate", str(run_dir / "problem.toml"), "--designs", str(exported), "--out", str(out)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    with open(exported, newline="") as fh:
        written = list(csv.DictReader(fh))[1:]  # below the units row
    assert [int(r["row"]) for r in written] == room.table.loc[chosen, "row"].tolist()
    again = hisopt.io.read_csv(out)
    stored = room.table.loc[chosen, room.objectives].to_numpy(dtype=float)
    assert np.allclose(again[room.objectives].to_numpy(dtype=float), stored, rtol=1e-9, atol=0)
    # the shown design as a problem file
    page.find_elements("css selector", "#designs tbody tr")[1].click()
    shown = page.execute_script("return window.hisoptRoom.shown()")
    page.find_element("id", "export-toml").click()
    toml = _downloaded(page.download, f"design-{int(room.table.loc[shown, 'row'])}.toml")
    out = tmp_path / "one.csv"
    proc = subprocess.run([sys.executable, "-m", "hisopt", "evaluate", str(toml), "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    one = hisopt.io.read_csv(out)
    assert np.allclose(one[room.objectives].to_numpy(dtype=float)[0], room.table.loc[shown, room.objectives].to_numpy(dtype=float), rtol=1e-9, atol=0)


def test_the_page_made_no_network_request(page):
    urls = []
    for entry in page.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message["method"] == "Network.requestWillBeSent":
            urls.append(message["params"]["request"]["url"])
    assert urls and all(u.split(":", 1)[0] in ("file", "data", "blob") for u in urls), urls
