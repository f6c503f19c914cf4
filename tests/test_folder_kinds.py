"""Every output folder knows its kind (issue 38, docs/model.md §8.5, :mod:`hisopt.folders`).

Each kind of folder is written once per module, with tiny budgets, by its command into an
empty folder that already exists (so an empty existing folder is shown accepted). Each case
works on a copy. For every pair of commands (A wrote the folder, B is pointed at it), B
refuses in one line with exit 2, naming the option, the folder and what it is, and the
folder's files hash the same before and after (every path and its bytes, folders included:
a refused command makes no subfolder either); A again on its own folder resumes, writes it
again or says it is finished. A folder holding a user's file is refused by every writer.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

import hisopt
from hisopt import folders
from hisopt.errors import RunError
from hisopt.optim import rundir
from tests.cli_inprocess import Outcome, run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

UNCERTAIN = ROOT / "problems" / "roll_plane_his_uncertain.toml"
TINY = ("--pop", "8", "--gens", "2")

# kind -> the command that writes that kind of folder at OUT (RUN: the module's run, for `sheet`)
WRITERS: dict[str, Callable[[Path, Path], tuple[object, ...]]] = {
    folders.RUN: lambda out, run: ("optimize", DEFAULT_PROBLEM, "--out", out, *TINY),
    folders.SEED_STUDY: lambda out, run: ("study", DEFAULT_PROBLEM, "--seeds", "1", "--out", out, *TINY),
    folders.LAYOUT_STUDY: lambda out, run: ("compare-layouts", DEFAULT_PROBLEM, "--layouts", "roll_plane", "--seeds", "1", "--out", out, *TINY),
    folders.SYNTHESIS: lambda out, run: ("synthesize", DEFAULT_PROBLEM, "--max-elements", "2", "--optimise", "0", "--out", out),
    folders.SWEEP: lambda out, run: ("sweep", DEFAULT_PROBLEM, "--vary", "p0", "--points", "3", "--out", out),
    folders.REGIONS: lambda out, run: ("regions", DEFAULT_PROBLEM, "--pair", "p0,dA", "--points", "3", "--out", out),
    folders.SHEET: lambda out, run: ("sheet", run, "--out", out),
    folders.TOLERANCE: lambda out, run: ("tolerance", UNCERTAIN, "--samples", "16", "--out", out),
    folders.SENSITIVITY: lambda out, run: ("sensitivity", UNCERTAIN, "--samples", "4", "--out", out),
    folders.RESPONSE: lambda out, run: ("response", DEFAULT_PROBLEM, "--out", out),
    folders.DROPTEST: lambda out, run: ("droptest", DEFAULT_PROBLEM, "--p0", "2e6", "--out", out),
    folders.VERIFY: lambda out, run: ("verify", DEFAULT_PROBLEM, "--out", out, "--realisations", "2", "--no-manoeuvres"),
}
# commands that read a folder (and write into a run or a layout study, their own)
READERS: dict[str, Callable[[Path], tuple[object, ...]]] = {
    "report": lambda folder: ("report", folder),
    "refine": lambda folder: ("refine", folder, "--max-points", "1"),
    "status": lambda folder: ("status", folder),
    "resume": lambda folder: ("resume", folder),
}
READS = {"report": (folders.RUN, folders.LAYOUT_STUDY), "refine": (folders.RUN,), "status": (folders.RUN, folders.LAYOUT_STUDY), "resume": (folders.RUN,)}


def digest(folder: Path) -> str:
    """SHA-256 over every path under ``folder`` (folders too) and every file's bytes."""
    h = hashlib.sha256()
    for path in sorted(folder.rglob("*")):
        h.update(str(path.relative_to(folder)).encode() + (b"/" if path.is_dir() else b"\0"))
        if path.is_file():
            h.update(path.read_bytes())
    return h.hexdigest()


def refused(out: Outcome, *parts: object) -> str:
    assert out.code == 2, out
    assert len(out.error_lines) == 1 and out.error_lines[0].startswith("error: "), out.stderr
    for part in parts:
        assert str(part) in out.error_lines[0], out.error_lines[0]
    return out.error_lines[0]


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One folder of every kind, each written by its command into an empty existing folder."""
    root = tmp_path_factory.mktemp("kinds")
    made: dict[str, Path] = {}
    for kind, writer in WRITERS.items():  # RUN first: the sheet's run
        out = root / kind
        out.mkdir()
        outcome = run_cli(*writer(out, root / folders.RUN))
        assert outcome.code == 0, (kind, outcome.stderr)
        made[kind] = out
    return made


@pytest.fixture
def copy(built: dict[str, Path], tmp_path: Path) -> Callable[[str], Path]:
    def make(kind: str) -> Path:
        return Path(shutil.copytree(built[kind], tmp_path / f"copy-{kind}"))

    return make


def test_every_kind_is_told_by_its_record(built):
    for kind, folder in built.items():
        found = folders.folder_kind(folder)
        assert found is not None and found.kind.name == kind, (kind, found)
        assert found.evidence == folders.KINDS[kind].record
        assert (folder / folders.MARKER).is_file() == folders.KINDS[kind].marked
    assert json.loads((built[folders.SWEEP] / folders.MARKER).read_text())["kind"] == folders.SWEEP


@pytest.mark.parametrize("writer", list(WRITERS))
def test_a_writer_refuses_every_other_kind_and_changes_nothing(built, copy, writer):
    for kind in WRITERS:
        if kind == writer:
            continue
        folder = copy(kind)
        before = digest(folder)
        line = refused(run_cli(*WRITERS[writer](folder, built[folders.RUN])), "--out", folder, folders.KINDS[kind].what, folders.KINDS[writer].what)
        assert "name a new one" in line
        assert digest(folder) == before, (writer, kind)
        shutil.rmtree(folder)


@pytest.mark.parametrize("reader", list(READERS))
def test_a_reader_given_another_kind_says_what_it_is_and_changes_nothing(copy, reader):
    for kind in WRITERS:
        if kind in READS[reader] or (kind == folders.SYNTHESIS and reader != "resume"):
            continue  # a synthesis keeps its own words for report, status and refine (tests/test_synthesis.py)
        folder = copy(kind)
        before = digest(folder)
        refused(run_cli(*READERS[reader](folder)), folder, folders.KINDS[kind].what)
        assert digest(folder) == before, (reader, kind)
        shutil.rmtree(folder)


@pytest.mark.parametrize("kind", list(WRITERS))
def test_the_same_command_again_resumes_or_says_it_is_finished(built, copy, kind):
    folder = copy(kind)
    again = run_cli(*WRITERS[kind](folder, built[folders.RUN]))
    if kind == folders.RUN:  # a finished run is never started over
        before = digest(folder)
        refused(again, "--out", folder, "finished")
        assert digest(folder) == before
        return
    assert again.code == 0, again.stderr
    found = folders.folder_kind(folder)
    assert found is not None and found.kind.name == kind
    if kind == folders.SEED_STUDY:  # the finished run is reused, not run again
        assert digest(folder / "seed-1") == digest(built[kind] / "seed-1")


@pytest.mark.parametrize("kind", list(WRITERS))
def test_a_folder_with_a_users_file_is_refused(built, tmp_path, kind):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("my notes\n")
    before = digest(folder)
    refused(run_cli(*WRITERS[kind](folder, built[folders.RUN])), "--out", folder, "notes.txt", "did not write")
    assert digest(folder) == before


@pytest.mark.parametrize("kind", [folders.SEED_STUDY, folders.SWEEP, folders.TOLERANCE, folders.SHEET])
def test_a_folder_written_before_markers_is_told_by_its_files(built, copy, kind):
    folder = copy(kind)
    (folder / folders.MARKER).unlink()
    found = folders.folder_kind(folder)
    assert found is not None and found.kind.name == kind and found.evidence != folders.MARKER
    before = digest(folder)
    refused(run_cli(*WRITERS[folders.RESPONSE](folder, built[folders.RUN])), "--out", folder, folders.KINDS[kind].what)
    assert digest(folder) == before
    assert run_cli(*WRITERS[kind](folder, built[folders.RUN])).code == 0  # its own command takes it, and marks it
    assert json.loads((folder / folders.MARKER).read_text())["kind"] == kind


def test_one_file_of_a_kinds_name_does_not_make_a_users_folder_that_kind(built, tmp_path):
    """A folder written before markers is told by all the files its command writes: a user's
    response.csv alone is the user's, and `hisopt response` does not write over it."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "response.csv").write_text("my,numbers\n1,2\n")
    assert folders.folder_kind(mine) is None
    refused(run_cli(*WRITERS[folders.RESPONSE](mine, built[folders.RUN])), "--out", mine, "did not write (response.csv)")
    assert (mine / "response.csv").read_text() == "my,numbers\n1,2\n"


def test_a_run_stopped_before_its_first_generation_is_still_a_run(copy, tmp_path):
    """Its run.json comes with the first generation; its marker before: the same command
    starts it again. A folder holding only a user's problem file is not a run."""
    run = copy(folders.RUN)
    for path in run.iterdir():
        if path.name not in (folders.MARKER, rundir.PROBLEM_TOML):
            shutil.rmtree(path) if path.is_dir() else path.unlink()
    assert run_cli(*WRITERS[folders.RUN](run, run)).code == 0 and (run / rundir.RUN_JSON).is_file()
    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(DEFAULT_PROBLEM, mine / rundir.PROBLEM_TOML)
    before = digest(mine)
    refused(run_cli(*WRITERS[folders.RUN](mine, run)), "--out", mine, "did not write (problem.toml)")
    assert digest(mine) == before


def test_a_file_or_a_path_through_a_file_is_refused(built, tmp_path):
    (tmp_path / "f").write_text("x")
    refused(run_cli(*WRITERS[folders.SWEEP](tmp_path / "f", built[folders.RUN])), "--out", "is a file")
    refused(run_cli(*WRITERS[folders.RESPONSE](tmp_path / "f" / "g", built[folders.RUN])), "--out", "is a file, not a folder")
    assert (tmp_path / "f").read_text() == "x"


def test_the_library_refuses_what_the_command_refuses(built, copy, problem):
    """hisopt.optimize, compare_layouts, run_synthesis, the seed study and the writers of
    sheets and uncertainty studies call the same claim."""
    from hisopt.optim.study import study
    from hisopt.report.sheet import write_sheet

    run, sweep = copy(folders.RUN), copy(folders.SWEEP)
    before = {run: digest(run), sweep: digest(sweep)}
    calls = [
        (lambda: hisopt.optimize(problem, out=sweep, pop_size=8, generations=2), "a sweep"),
        (lambda: hisopt.compare_layouts(problem, "roll_plane", [1], out=run, pop_size=8, generations=2), "an optimisation run"),
        (lambda: hisopt.run_synthesis(problem, 2, optimise=0, out=run), "an optimisation run"),
        (lambda: study(problem, [1], out=run, pop_size=8, generations=2), "an optimisation run"),
        (lambda: write_sheet(None, run), "an optimisation run"),  # type: ignore[arg-type]  # refused before the sheet is read
    ]
    for call, what in calls:
        with pytest.raises(RunError, match=what) as caught:
            call()
        assert "\n" not in str(caught.value) and "--out" in str(caught.value)
    assert {folder: digest(folder) for folder in before} == before


def test_status_no_longer_calls_a_run_with_a_study_record_a_layout_study(copy):
    """The issue's probe: a layout study's record inside a run (an older hisopt wrote it there)."""
    run = copy(folders.RUN)
    shutil.copy(copy(folders.LAYOUT_STUDY) / rundir.LAYOUT_STUDY_JSON, run / rundir.LAYOUT_STUDY_JSON)
    out = run_cli("status", run)
    assert out.code == 0 and "finished" in out.stdout and "layout study" not in out.stdout, out


def test_sweep_and_regions_default_to_their_own_folders(tmp_path, monkeypatch):
    """Their --out once defaulted to the current folder: a project folder, which is not theirs."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(DEFAULT_PROBLEM, tmp_path / "problem.toml")
    assert run_cli("sweep", "problem.toml", "--vary", "p0", "--points", "3").code == 0
    assert run_cli("regions", "problem.toml", "--pair", "p0,dA", "--points", "3").code == 0
    assert (tmp_path / "sweeps" / "sweep_p0.csv").is_file() and (tmp_path / "regions" / "regions_p0_dA.csv").is_file()
    refused(run_cli("sweep", "problem.toml", "--vary", "p0", "--points", "3", "--out", "."), "--out . holds files hisopt did not write (problem.toml")


def test_a_second_refinement_method_writes_its_own_files(copy):
    """IPOPT beside the SLP: front_refined_ipopt.csv and refine_ipopt.json, front_refined.csv
    untouched; the report and the decision room read both."""
    from hisopt.optim.gradient.asf_nlp import RefineSettings
    from hisopt.report.html import load_run_files
    from hisopt.studies.decision_room import run_sources

    assert rundir.refined_files("slp") == (rundir.FRONT_REFINED_CSV, rundir.REFINE_JSON)
    assert rundir.refined_files("ipopt") == ("front_refined_ipopt.csv", "refine_ipopt.json")
    run = copy(folders.RUN)
    hisopt.refine_run(run, 2)
    slp = {name: (run / name).read_bytes() for name in rundir.refined_files("slp")}
    hisopt.refine_run(run, 1, method="ipopt", settings=RefineSettings(rounds=1, max_iter=5))
    assert {name: (run / name).read_bytes() for name in rundir.refined_files("slp")} == slp
    ipopt = [run / name for name in rundir.refined_files("ipopt")]
    assert all(path.is_file() for path in ipopt)
    assert json.loads(ipopt[1].read_text())["method"] == "ipopt" and json.loads((run / rundir.REFINE_JSON).read_text())["method"] == "slp"
    rows = sum(len(hisopt.read_csv(path)) for path in rundir.refined_fronts(run))
    assert len(load_run_files(run)["refined"]) == rows
    assert int((run_sources(run)[0].kind == "refined").sum()) == rows
    hisopt.refine_run(run, 1)  # the same method again: its own files anew, the other's kept
    assert json.loads((run / rundir.REFINE_JSON).read_text())["max_points"] == 1 and json.loads(ipopt[1].read_text())["method"] == "ipopt"
