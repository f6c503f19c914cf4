"""The API reference (docs/api, Sphinx + numpydoc) builds with warnings as errors and covers
every public name: each name of ``hisopt.__all__`` and of the documented sub-packages'
``__all__`` has its entry (an HTML anchor ``hisopt[.sub].name``) in the built pages.

The build runs on a copy of docs/api, so autosummary's generated pages stay out of the
checkout; nothing is fetched from the network (no intersphinx).
"""

from __future__ import annotations

import importlib
import re
import shutil
import subprocess
import sys
from pathlib import Path

import hisopt
from tests.conftest import ROOT

API = ROOT / "docs" / "api"


def _build(source: Path, out: Path) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(source), str(out)]
    return subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=900)


def test_api_reference_builds_without_warnings_and_covers_every_public_name(tmp_path):
    source = tmp_path / "api"
    shutil.copytree(API, source, ignore=shutil.ignore_patterns("generated", "_build"))
    done = _build(source, tmp_path / "html")
    assert done.returncode == 0, done.stderr
    anchors = set()
    for page in (tmp_path / "html").rglob("*.html"):
        anchors |= set(re.findall(r'id="(hisopt\.[\w.]+)"', page.read_text(encoding="utf-8")))
    expected = {f"hisopt.{name}" for name in hisopt.__all__}
    for package in hisopt._DOCUMENTED_SUBPACKAGES:
        expected |= {f"{package}.{name}" for name in importlib.import_module(package).__all__}
    assert not expected - anchors, f"public names missing from docs/api/index.rst: {sorted(expected - anchors)}"


def test_a_warning_fails_the_build(tmp_path):
    """The same configuration with one reference to a name that does not exist must fail."""
    source = tmp_path / "api"
    source.mkdir()
    shutil.copy(API / "conf.py", source)
    (source / "index.rst").write_text("Broken\n======\n\n.. autofunction:: hisopt.no_such_function\n", encoding="utf-8")
    done = _build(source, tmp_path / "html")
    assert done.returncode != 0
    assert "no_such_function" in done.stderr
