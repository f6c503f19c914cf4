"""`hisopt report`: a self-contained HTML report that renders in headless Chromium."""

import html as html_lib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hisopt.problem import load_problem
from tests.conftest import DEFAULT_PROBLEM

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "small"
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "optimize", str(DEFAULT_PROBLEM), "--out", str(out), "--pop", "16", "--gens", "4", "--seed", "3"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    return out


def _report(run_dir, *args):
    proc = subprocess.run([sys.executable, "-m", "hisopt", "report", str(run_dir), *args], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return (run_dir / "report.html").read_text()


def test_report_is_self_contained(run_dir):
    html = _report(run_dir, "--color-by", "max_roll_psd")
    assert 'src="http' not in html  # no CDN or remote script: works offline
    assert html.count('id="hisopt-plotly"') == 1 and len(html) > 1_500_000  # plotly.js embedded once (gzip, base64)
    assert html.count("window.hisoptFigures.push(") >= 4
    for title in ("Pareto front", "Designs and objectives", "Convergence", "Response spectra", "Modes of the knee design", "Run settings"):
        assert title in html
    # Tables are HTML tables with units in their headers; names keep their underscores.
    assert html.count('<table class="data">') == 4 and '<td class="text">front_axle_hop</td>' in html
    assert "Parts and settings of the knee design" in html and '<td class="text">front cylinder bore</td>' in html
    for header in ('f with HIS<span class="unit">[Hz]</span>', 'zeta with HIS<span class="unit">[-]</span>'):
        assert header in html
    for row in ("sigma_aw [m/s^2]", "max_roll_psd [rad^2/Hz]", "max_tire_load_psd [N^2/Hz]", "lam [-]", "decades^4", " s</td>"):
        assert row in html
    for row in (r"p0 \[(k|M)Pa\]", r"dA \[(cm|mm)\^2\]", r"Rv \[(k|M)?Pa s/m\^3\]"):  # prefixes follow the values
        assert re.search(row, html), row


def test_report_holds_the_front_and_links_the_decision_room_for_the_rest(run_dir, default_report):
    """Issue 38: the run's other evaluations are in decision.html, not embedded again in
    report.html. Every number the figures draw, against the run's evaluations: each front
    design's sigma_aw is drawn, no sigma_aw of a design off the front is (the values as
    float32: the figures' precision; a design off the front that shares its value with a
    front design, to that precision, is not counted)."""
    import pandas as pd

    from hisopt.io import read_csv

    page = default_report
    assert '<a href="decision.html">' in page and (run_dir / "decision.html").is_file()
    front = read_csv(run_dir / "front.csv")
    evaluated = pd.read_parquet(run_dir / "evaluations.parquet")
    f32 = lambda v: set(np.asarray(v, dtype=np.float32).tolist())  # noqa: E731
    on_front = f32(front["sigma_aw"])
    off_front = f32(evaluated["sigma_aw"]) - on_front
    assert len(on_front) > 3 and len(off_front) > 3  # designs on and off the front: the check can fail

    drawn: set[float] = set()

    def collect(obj):
        if isinstance(obj, np.ndarray):
            drawn.update(f32(obj))
        elif isinstance(obj, dict):
            for v in obj.values():
                collect(v)
        elif isinstance(obj, list):
            numbers = [v for v in obj if isinstance(v, float)]
            drawn.update(f32(numbers))
            for v in obj:
                collect(v)

    ids = re.findall(r'window\.hisoptFigures\.push\(\["(\w+)"', page)
    assert {"fig0", "fig1"} <= set(ids)  # the scatter matrix and the parallel coordinates
    for div_id in ids:
        collect(_figure_data(page, div_id))
    assert on_front <= drawn
    assert not off_front & drawn


def test_report_bad_options_are_user_errors(run_dir):
    proc = subprocess.run([sys.executable, "-m", "hisopt", "report", str(run_dir), "--color-by", "nope"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 2 and "nope" in proc.stderr and "Traceback" not in proc.stderr


# --- layout, checked as a person would see it ---------------------------------------------------
LAYOUT_CHECK_JS = r"""
(function () {
  // Corners of a text's own box on the screen: rotated text stays a rotated rectangle.
  function corners(t) {
    const b = t.getBBox(), m = t.getScreenCTM(), svg = t.ownerSVGElement;
    return [[b.x, b.y], [b.x + b.width, b.y], [b.x + b.width, b.y + b.height], [b.x, b.y + b.height]].map(function (c) {
      const p = svg.createSVGPoint(); p.x = c[0]; p.y = c[1];
      const q = p.matrixTransform(m); return [q.x, q.y];
    });
  }
  // Separating-axis test of two convex quadrilaterals: do they overlap by more than tol px?
  function overlap(a, b, tol) {
    const polys = [a, b];
    for (let k = 0; k < 2; k++) {
      const p = polys[k];
      for (let i = 0; i < 4; i++) {
        const e = [p[(i + 1) % 4][0] - p[i][0], p[(i + 1) % 4][1] - p[i][1]];
        const len = Math.hypot(e[0], e[1]);
        if (len < 1e-9) continue;
        const n = [-e[1] / len, e[0] / len];
        const pa = a.map(function (c) { return c[0] * n[0] + c[1] * n[1]; });
        const pb = b.map(function (c) { return c[0] * n[0] + c[1] * n[1]; });
        const depth = Math.min(Math.max.apply(null, pa), Math.max.apply(null, pb)) - Math.max(Math.min.apply(null, pa), Math.min.apply(null, pb));
        if (depth <= tol) return false;
      }
    }
    return true;
  }
  function visible(el) {
    for (let e = el; e && e.nodeType === 1; e = e.parentNode) {
      const cs = getComputedStyle(e);
      if (cs.display === 'none' || cs.visibility === 'hidden' || parseFloat(cs.opacity) === 0) return false;
    }
    return true;
  }
  function run() {
    const out = {figures: 0, texts: 0, overlaps: [], clipped: [], axis_titles: [], cells: 0};
    document.querySelectorAll('.js-plotly-plot').forEach(function (plot) {
      out.figures += 1;
      const items = [];
      plot.querySelectorAll('svg text').forEach(function (t) {
        const s = (t.textContent || '').trim();
        if (!s || t.closest('.hoverlayer') || !visible(t)) return;
        const r = t.getBoundingClientRect();
        if (r.width < 1 || r.height < 1) return;
        items.push({s: s, c: corners(t)});
      });
      out.texts += items.length;
      for (let i = 0; i < items.length; i++) {
        for (let j = i + 1; j < items.length; j++) {
          if (overlap(items[i].c, items[j].c, 1.0)) out.overlaps.push([plot.id, items[i].s, items[j].s]);
        }
      }
      // Axis titles: cartesian (g-xtitle, g-y2title, ...), parcoords, colour bars; not the
      // figure's title or subplot titles (annotations).
      plot.querySelectorAll('[class*="title"] text, text[class*="title"]').forEach(function (t) {
        const g = t.closest('[class]');
        const cls = (t.getAttribute('class') || '') + ' ' + (g ? g.getAttribute('class') : '');
        const s = (t.textContent || '').trim();
        if (!/gtitle|annotation|legendtitle/.test(cls) && s && visible(t)) out.axis_titles.push(s);
      });
    });
    document.querySelectorAll('table td, table th').forEach(function (cell) {
      out.cells += 1;
      if (!cell.textContent.trim()) return;  // an empty cell has nothing to clip (its text box sits at the origin)
      const range = document.createRange();
      range.selectNodeContents(cell);
      const t = range.getBoundingClientRect(), c = cell.getBoundingClientRect();
      const outside = t.left < c.left - 0.5 || t.right > c.right + 0.5 || t.top < c.top - 0.5 || t.bottom > c.bottom + 0.5;
      if (cell.scrollWidth > cell.clientWidth + 1 || outside) out.clipped.push(cell.textContent);
    });
    const pre = document.createElement('pre');
    pre.id = 'layout-check';
    pre.textContent = JSON.stringify(out);
    document.body.appendChild(pre);
  }
  // report.html draws its figures once plotly.js is unpacked (window.hisoptReady)
  window.addEventListener('load', function () { Promise.resolve(window.hisoptReady).then(function () { setTimeout(run, 1000); }); });
})();
"""


def _chromium_or_skip() -> str:
    if CHROMIUM is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed (.ci/run installs Debian's chromium package)")
        pytest.skip("chromium not installed")
    return CHROMIUM


def render(page: str, folder: Path, width: int = 1400) -> tuple[dict, str, str]:
    """Render the HTML ``page`` in headless Chromium and measure its text: overlaps of SVG text
    (plotly titles, axis titles, tick labels, legends, colour bars), clipped table cells and
    axis titles. Returns ``(measurements, dom, stderr)``."""
    folder.mkdir(parents=True, exist_ok=True)
    probe = folder / f"probe-{width}.html"
    probe.write_text(page.replace("</body>", f"<script>{LAYOUT_CHECK_JS}</script></body>"), encoding="utf-8")
    proc = subprocess.run(
        [
            _chromium_or_skip(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-quic",
            "--no-first-run", "--disable-component-update", "--disable-sync", f"--user-data-dir={folder / 'profile'}",
            "--enable-logging=stderr", "--v=0", f"--window-size={width},1000", "--virtual-time-budget=20000", "--dump-dom",
            probe.as_uri(),
        ],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = re.search(r'<pre id="layout-check">(.*?)</pre>', proc.stdout, re.S)
    assert found, "the layout check did not run"
    return json.loads(html_lib.unescape(found.group(1))), proc.stdout, proc.stderr


UNIT_IN_BRACKETS = re.compile(r"\[[^\]]+\]")


def assert_clean_layout(result: dict, figures: int) -> None:
    assert result["figures"] == figures and result["texts"] > 20 * figures  # everything was drawn and measured
    assert result["overlaps"] == [], result["overlaps"][:10]
    assert result["clipped"] == [], result["clipped"][:10]
    assert result["axis_titles"], "no axis titles found"
    assert [t for t in result["axis_titles"] if not UNIT_IN_BRACKETS.search(t)] == []


@pytest.fixture(scope="module")
def default_report(run_dir) -> str:
    return _report(run_dir)


@pytest.fixture(scope="module")
def rendered_report(default_report, tmp_path_factory):
    return render(default_report, tmp_path_factory.mktemp("chromium"))


def test_report_renders_in_headless_chromium(default_report, rendered_report):
    _, dom, stderr = rendered_report
    console = [line for line in stderr.splitlines() if ":CONSOLE" in line]
    errors = [line for line in console if re.search(r"Uncaught|Error:|TypeError|ReferenceError", line)]
    assert not errors, errors
    # Every figure was drawn: plotly replaced each placeholder div by a rendered plot.
    n_figures = default_report.count("window.hisoptFigures.push(")
    assert dom.count('class="plot-container plotly"') == n_figures
    assert dom.count('class="main-svg"') >= n_figures


def test_report_layout_has_no_overlapping_text_and_units_on_every_axis(rendered_report):
    result = rendered_report[0]
    assert_clean_layout(result, figures=5)  # with the layout schematic
    assert result["cells"] > 60  # the three tables were measured too
    titles = set(result["axis_titles"])
    for title in ("frequency [Hz]", "PSD [(m/s^2)^2/Hz]", "generation [-]", "hypervolume [decades^4]", "sigma_aw [m/s^2]"):
        assert title in titles


def test_report_layout_holds_in_a_narrow_window(default_report, tmp_path):
    assert_clean_layout(render(default_report, tmp_path, width=900)[0], figures=5)


@pytest.fixture(scope="module")
def small_figures(problem):
    from hisopt.studies.spectra import response_spectra
    from hisopt.studies.sweeps import regions, sweep

    handling = load_problem(DEFAULT_PROBLEM.with_name("roll_plane_his_handling.toml"))
    return {
        "sweep": sweep(problem, "p0", 5).plot(),
        "regions": regions(handling, ("dA", "lam"), 5).plot(),
        "response": response_spectra(problem).plot(),
    }


def test_sweep_region_and_response_figures_have_no_overlapping_text(small_figures, tmp_path):
    import plotly.offline

    body = "".join(f"<h2>{name}</h2>" + fig.to_html(full_html=False, include_plotlyjs=False) for name, fig in small_figures.items())
    page = f"<!doctype html><html><head><meta charset='utf-8'><script>{plotly.offline.get_plotlyjs()}</script></head><body>{body}</body></html>"
    result = render(page, tmp_path)[0]
    assert_clean_layout(result, figures=3)
    for title in ("p0 [MPa]", "peak PSD [(rad/s^2)^2/Hz]", "dA [cm^2]", "lam [-]", "[N^2/Hz]", "PSD [N^2/Hz]"):
        assert title in result["axis_titles"]


def _tick_value(label: str) -> float:
    """``0.04``, ``10<sup>-5</sup>``, ``2.5×10<sup>4</sup>`` -> float."""
    match = re.fullmatch(r"(?:([\d.]+)×)?10<sup>(-?\d+)</sup>", label)
    if match:
        return float(match.group(1) or 1.0) * 10.0 ** int(match.group(2))
    return float(label)


@pytest.mark.parametrize("name", ["sweep", "response"])
def test_log_axes_tick_decades_or_round_values_labelled_in_full(small_figures, name):
    """No more ``1, 4, 1.089826, 3`` on a log axis: explicit ticks whose labels are their values."""
    figures = small_figures
    layout = figures[name].layout
    log_axes = [layout[k] for k in layout if k.startswith(("xaxis", "yaxis")) and layout[k].type == "log"]
    assert len(log_axes) >= 4
    for axis in log_axes:
        values, labels = list(axis.tickvals), list(axis.ticktext)
        assert len(values) >= 2 and values == sorted(values)
        for value, label in zip(values, labels, strict=True):
            assert _tick_value(label) == pytest.approx(value, rel=1e-9)
            mantissa = f"{value:.6e}".split("e")[0].rstrip("0")
            assert len(re.sub(r"[^0-9]", "", mantissa)) <= 3  # round values: 2, 0.0375, 5e-5
        low, high = 10 ** np.array(axis.range)  # every tick is inside the shown range
        assert low <= values[0] and values[-1] <= high


# --- a run whose objectives are per scenario ------------------------------------------------------
def _figure_data(page: str, div_id: str) -> list[dict]:
    """The traces plotly draws in ``div_id`` (typed arrays decoded, arrays of the page's store
    put back as the page's script does)."""
    import base64

    start = page.index(f'window.hisoptFigures.push(["{div_id}",')
    data, _ = json.JSONDecoder().raw_decode(page, page.index("[", page.index(",", start)))
    store_at = page.index('id="hisopt-arrays">') + len('id="hisopt-arrays">')
    store, _ = json.JSONDecoder().raw_decode(page, store_at)

    def decode(obj):
        if isinstance(obj, dict) and set(obj) == {"dtype", "ref"}:
            return np.frombuffer(base64.b64decode(store[obj["ref"]]), dtype=np.dtype(obj["dtype"])).astype(float)
        if isinstance(obj, dict) and set(obj) == {"dtype", "bdata"}:
            return np.frombuffer(base64.b64decode(obj["bdata"]), dtype=np.dtype(obj["dtype"])).astype(float)
        if isinstance(obj, dict):
            return {k: decode(v) for k, v in obj.items()}
        if isinstance(obj, list):
            return [decode(v) for v in obj]
        return obj

    return decode(data)


def test_report_of_a_per_scenario_run(tmp_path):
    """Regression (issue 22): `hisopt report` on a ``[robust] aggregate = "per_scenario"`` run
    crashed (KeyError 'sigma_aw@city'). Through the CLI: optimise small, then report. The
    front is drawn per load case (quantity axes, a trace per scenario holding exactly the
    front's "<quantity>@<scenario>" values), the spectra are those of the problem's [road]
    (the problem without its scenarios gives the same numbers), and nothing overlaps."""
    from hisopt.io import read_csv
    from hisopt.studies.spectra import response_spectra
    from tests.cli_inprocess import run_cli

    text = (DEFAULT_PROBLEM.parent / "roll_plane_his_robust.toml").read_text()
    text = text.replace('aggregate = "expected"', 'aggregate = "per_scenario"').replace(
        'objectives = ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd"]', 'objectives = ["sigma_aw", "max_roll_psd", "max_tire_load_psd"]'
    )
    text = text.replace('[[scenarios]]\nname = "rural"\nroad = { class = "B", speed = 20.0 }\nweight = 0.3\n', "")
    path = tmp_path / "per_scenario.toml"
    path.write_text(text)
    problem = load_problem(path)
    assert problem.scenario_names == ("city", "motorway", "laden") and len(problem.objective_names) == 9
    run = tmp_path / "run"
    out = run_cli("optimize", path, "--pop", "16", "--gens", "2", "--seed", "2", "--out", run)
    assert out.code == 0, out.stderr
    out = run_cli("report", run)
    assert out.code == 0, out.stderr
    page = (run / "report.html").read_text()
    front = read_csv(run / "front.csv")

    traces = _figure_data(page, "fig0")
    by_name = {t["name"]: t for t in traces}
    for s in problem.scenario_names:
        dims = by_name[s]["dimensions"]
        assert [d["label"] for d in dims] == ["sigma_aw [m/s^2]", "max_roll_psd [rad^2/Hz]", "max_tire_load_psd [N^2/Hz]"]
        for d, q in zip(dims, ("sigma_aw", "max_roll_psd", "max_tire_load_psd"), strict=True):
            # m/s^2 and PSDs shown in SI, as float32 (half a unit in the 24th bit: 6e-8 relative)
            np.testing.assert_allclose(d["values"], front[f"{q}@{s}"].to_numpy(), rtol=6e-8, atol=0)
    assert {t["name"] for t in traces} == {*problem.scenario_names, "knee", "ASF pick"}
    assert "Response spectra of the knee design against the car without HIS ([road]: class C at 10 m/s)" in page
    assert "every objective minimised in each scenario (per_scenario)" in page

    design = front.loc[0, list(problem.variable_names)].to_numpy(dtype=float)
    plain = tmp_path / "plain.toml"  # the same file without [robust], [[scenarios]] and [[constraints]]
    plain.write_text(text[: text.index("\n[robust]")])
    a, b = response_spectra(problem, design).frame, response_spectra(load_problem(plain), design).frame
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())
    # `hisopt sweep` read the per-scenario objective names the same way (KeyError too): now the [road]'s sweep
    for source, folder in ((path, "sweep"), (plain, "sweep-plain")):
        out = run_cli("sweep", source, "--vary", "p0", "--points", "3", "--out", tmp_path / folder)
        assert out.code == 0, out.stderr
    pd_equal = read_csv(tmp_path / "sweep" / "sweep_p0.csv").equals(read_csv(tmp_path / "sweep-plain" / "sweep_p0.csv"))
    assert pd_equal

    result = render(page, tmp_path / "chromium", width=900)[0]
    assert_clean_layout(result, figures=5)


def test_page_figures_store_each_array_once_as_float32():
    """A figure's long numeric arrays go to the page's store once each, as float32 (6e-8
    relative: half a unit in the 24th bit); short ones, the layout's and values float32 cannot
    hold stay exact; the page draws what plotly drew (the store put back)."""
    import plotly.graph_objects as go

    from hisopt.report.embed import SHARED_MIN_LENGTH, PageFigures

    f = np.geomspace(0.5, 80.0, 300)
    fig = go.Figure([go.Scatter(x=f, y=1.0 / f, name="a"), go.Scatter(x=f, y=2.0 / f, name="b"), go.Scatter(x=[1.0, 2.0], y=[3.0, 4.0])])
    fig.add_scatter(x=f[: SHARED_MIN_LENGTH - 1], y=f[: SHARED_MIN_LENGTH - 1] * 1e-40)  # short: inline; too small for float32
    fig.add_scatter(x=f, y=f * 1e-40)
    fig.update_layout(xaxis={"tickvals": list(f[::10])})
    page = PageFigures()
    div = page.div(fig, "fig0")
    html = f"<head>{page.head_html()}</head><body>{div}{page.scripts_html()}</body>"
    traces = _figure_data(html, "fig0")
    assert len(page.arrays) == 4  # f once (three traces), 1/f, 2/f and f * 1e-40 (as float64)
    for trace, ratio in zip(traces[:2], (1.0, 2.0), strict=True):
        np.testing.assert_allclose(trace["x"], f, rtol=6e-8, atol=0)
        np.testing.assert_allclose(trace["y"], ratio / f, rtol=6e-8, atol=0)
    assert traces[2]["x"] == [1.0, 2.0]
    np.testing.assert_array_equal(traces[3]["y"], f[: SHARED_MIN_LENGTH - 1] * 1e-40)  # plotly's own float64 array
    np.testing.assert_array_equal(traces[4]["y"], f * 1e-40)  # float64 kept
    layout = json.loads(re.search(r'window\.hisoptFigures\.push\(\["fig0", \[.*?\], (\{.*\}), \{"responsive"', html).group(1))
    assert layout["xaxis"]["tickvals"] == list(f[::10])
