"""What the catalogues cost (docs/model.md §17.5).

Checks: the relaxation makes exactly the choice variables continuous over the same box; the
recorded continuous hypervolume is that of an independent run of the relaxed problem with the
same settings and reference point, and that of the continuous front written to the run
directory; the run summary, ``run.json`` and the report show it; ``catalogue_cost = false``
switches it off; a run interrupted during the relaxation resumes to the same figures.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from hisopt.interrupt import TEST_HOOK_ENV
from hisopt.optim.catalogue_cost import continuous_relaxation, has_choices, wants_catalogue_cost
from hisopt.optim.decision import hypervolume
from hisopt.optim.engine import Engine
from hisopt.optim.rundir import read_front
from hisopt.optim.settings import resolve_settings
from hisopt.problem import problem_from_dict
from tests.cli_inprocess import run_cli
from tests.conftest import ROOT
from tests.test_catalogues import PARTS


@pytest.fixture(scope="module")
def parts():
    return problem_from_dict(tomllib.loads(PARTS))


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("cost")
    (folder / "parts.toml").write_text(PARTS)
    out = folder / "run"
    result = run_cli("optimize", str(folder / "parts.toml"), "--out", str(out), "--seed", "3")
    assert result.code == 0, result.stderr
    assert "catalogue cost (hypervolume)" in result.stdout
    return out


def test_the_relaxation_frees_the_choices_alone(parts):
    relaxed = continuous_relaxation(parts)
    assert has_choices(parts) and wants_catalogue_cost(parts)
    assert not has_choices(relaxed) and relaxed.choices == {}
    assert relaxed.variable_names == parts.variable_names
    np.testing.assert_array_equal(relaxed.lower, parts.lower)
    np.testing.assert_array_equal(relaxed.upper, parts.upper)
    assert relaxed.spec.model_dump(exclude={"variables"}) == parts.spec.model_dump(exclude={"variables"})
    # a listed design is the same design in both problems
    x = np.array([[2e6, 8e5, 0.063, 0.025, 1e-3]])
    a, b = parts.evaluator()(x), relaxed.evaluator()(x)
    assert a["sigma_aw"][0] == b["sigma_aw"][0] and a["roll_gradient"][0] == b["roll_gradient"][0]


def test_the_recorded_cost_is_an_independent_relaxed_run(run_dir, parts):
    record = json.loads((run_dir / "run.json").read_text())
    cost = record["result"]["catalogue_cost"]
    assert cost["hypervolume_catalogue"] == record["result"]["hypervolume"]
    assert cost["ratio"] == cost["hypervolume_catalogue"] / cost["hypervolume_continuous"]
    # the relaxed problem run again from scratch, with the run's settings and reference point
    reference = np.asarray(record["settings"]["hypervolume_reference_log10"])
    settings = resolve_settings(parts, seed=3)
    engine = Engine(continuous_relaxation(parts), settings, reference)
    while not engine.done:
        engine.step()
    assert engine.evaluations == cost["continuous_evaluations"] == settings.evaluations
    assert hypervolume(engine.archive.f, reference) == cost["hypervolume_continuous"]
    # the front written beside the run's is that run's front
    continuous = read_front(run_dir / "continuous_front.csv")
    assert len(continuous) == cost["continuous_front_size"] == len(engine.archive)
    objectives = continuous[list(parts.objective_names)].to_numpy()
    assert hypervolume(objectives, reference) == pytest.approx(cost["hypervolume_continuous"], rel=1e-12)
    # its variables are free: some of its designs take values off the lists
    listed = parts.choices[2]
    assert not np.isin(continuous["bore"].to_numpy(), listed).all()


def test_the_report_shows_the_cost(run_dir):
    result = run_cli("report", str(run_dir))
    assert result.code == 0, result.stderr
    page = (run_dir / "report.html").read_text()
    assert "What the catalogues cost" in page and "continuous relaxation&#x27;s" in page
    assert "Parts and settings of the knee design" in page and "front cylinder bore" in page


def test_switched_off_there_is_no_relaxation(tmp_path):
    (tmp_path / "parts.toml").write_text(PARTS.replace("[optimizer]", "[optimizer]\ncatalogue_cost = false"))
    result = run_cli("optimize", str(tmp_path / "parts.toml"), "--out", str(tmp_path / "run"), "--gens", "2")
    assert result.code == 0, result.stderr
    assert "catalogue cost" not in result.stdout
    assert "catalogue_cost" not in json.loads((tmp_path / "run" / "run.json").read_text())["result"]
    assert not (tmp_path / "run" / "continuous_front.csv").exists()


@pytest.mark.slow
def test_an_interrupt_during_the_relaxation_resumes_to_the_same_cost(tmp_path, run_dir):
    (tmp_path / "parts.toml").write_text(PARTS)
    out = tmp_path / "run"
    env = dict(os.environ) | {TEST_HOOK_ENV: "relaxation-2:INT"}
    proc = subprocess.run(
        [sys.executable, "-m", "hisopt", "optimize", str(tmp_path / "parts.toml"), "--out", str(out), "--seed", "3"],
        check=False,
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 130, proc.stderr
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted" and (out / "front.csv").is_file()  # the catalogue front is kept
    assert "catalogue_cost" not in info["result"]
    resumed = run_cli("resume", str(out))
    assert resumed.code == 0, resumed.stderr
    got = json.loads((out / "run.json").read_text())["result"]["catalogue_cost"]
    expected = json.loads((run_dir / "run.json").read_text())["result"]["catalogue_cost"]
    assert {k: v for k, v in got.items() if "wall_time" not in k} == {k: v for k, v in expected.items() if "wall_time" not in k}
