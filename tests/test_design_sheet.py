"""A front design as a sheet to build from (docs/model.md §17.4).

Checks: the sheet's problem file re-evaluates to the sheet's quantities (to 1e-12; it is the
same design, read back from TOML's shortest round-trip floats), its parts are the design's,
and a design not in the run is refused naming the rows it has.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import hisopt
from hisopt.io import read_csv
from hisopt.plausibility import bound_labels
from tests.cli_inprocess import run_cli
from tests.test_catalogues import PARTS


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("sheet")
    (folder / "parts.toml").write_text(PARTS)
    out = folder / "run"
    assert run_cli("optimize", str(folder / "parts.toml"), "--out", str(out), "--seed", "2").code == 0
    return out


def test_the_sheet_reproduces_its_design(run_dir, tmp_path):
    result = run_cli("sheet", str(run_dir), "--design", "1", "--out", str(tmp_path))
    assert result.code == 0, result.stderr
    for name in ("sheet.md", "sheet.html", "sheet.toml"):
        assert (tmp_path / name).is_file()
    front = read_csv(run_dir / "front.csv")
    problem = hisopt.load_problem(tmp_path / "sheet.toml")
    design = front.iloc[1]
    # its [his] values are the design's, so its baseline is the design
    np.testing.assert_array_equal(problem.baseline, design[list(problem.variable_names)].to_numpy(dtype=float))
    again = problem.evaluate(problem.baseline[None, :])
    for name in problem.objective_names:
        assert again[name].iloc[0] == pytest.approx(float(design[name]), rel=1e-12, abs=0)


def test_the_sheet_lists_the_designs_parts(run_dir, tmp_path):
    assert run_cli("sheet", str(run_dir), "--out", str(tmp_path)).code == 0  # the knee
    data = tomllib.loads((tmp_path / "sheet.toml").read_text())
    text = (tmp_path / "sheet.md").read_text()
    bore, rod, volume = data["his"]["bore"], data["his"]["rod"], data["his"]["V0"]
    assert f"| front cylinder bore | {bore * 1000:g} mm |" in text
    assert f"| front piston rod | {rod * 1000:g} mm |" in text
    assert f"| accumulator A: nominal volume | {volume * 1000:g} L |" in text
    for section in ("## Parts and settings", "## Quantities", "## Operating envelope", "## Modes with HIS", "## Buildability"):
        assert section in text
    assert "charge: temperature | 20 degC" in text
    problem = hisopt.load_problem(tmp_path / "sheet.toml")
    on = bound_labels(problem.baseline, problem.lower, problem.upper, problem.variable_names)[0]
    assert (f"At a bound of [variables] (the box, not the physics, chose it): {on}." in text) if on else ("At a bound" not in text)


def test_a_design_not_in_the_run_says_which_are(run_dir):
    n = len(read_csv(run_dir / "front.csv"))
    result = run_cli("sheet", str(run_dir), "--design", str(n))
    assert result.code == 2 and len(result.stderr.strip().splitlines()) == 1
    assert f"has designs 0 to {n - 1}" in result.stderr
