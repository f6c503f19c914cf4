"""`hisopt report`: a self-contained HTML report that renders in headless Chromium."""

import os
import re
import shutil
import subprocess
import sys

import pytest

from tests.conftest import DEFAULT_PROBLEM

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "small"
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "optimize", str(DEFAULT_PROBLEM), "--out", str(out), "--pop", "16", "--gens", "4", "--seed", "3"],
        capture_output=True, text=True, timeout=600,
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
    assert len(html) > 2_000_000  # plotly.js embedded once
    assert html.count("Plotly.newPlot") >= 6
    for title in ("Pareto front", "Designs and objectives", "Convergence", "Response spectra", "Modes of the knee design", "Run settings"):
        assert title in html


def test_report_bad_options_are_user_errors(run_dir):
    proc = subprocess.run([sys.executable, "-m", "hisopt", "report", str(run_dir), "--color-by", "nope"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 2 and "nope" in proc.stderr and "Traceback" not in proc.stderr


def test_report_renders_in_headless_chromium(run_dir, tmp_path):
    if CHROMIUM is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed (.ci/run installs Debian's chromium package)")
        pytest.skip("chromium not installed")
    html = _report(run_dir)
    n_figures = html.count("Plotly.newPlot")
    proc = subprocess.run(
        [
            CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-quic",
            "--no-first-run", "--disable-component-update", "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
            "--enable-logging=stderr", "--v=0", "--virtual-time-budget=20000", "--dump-dom", (run_dir / "report.html").as_uri(),
        ],
        capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    errors = [line for line in console if re.search(r"Uncaught|Error:|TypeError|ReferenceError", line)]
    assert not errors, errors
    dom = proc.stdout
    # Every figure was drawn: plotly replaced each placeholder div by a rendered plot.
    assert dom.count('class="plot-container plotly"') == n_figures
    assert dom.count('class="main-svg"') >= n_figures
