"""Layout study (`hisopt compare-layouts`, hisopt.studies.layout_study) on a tiny budget.

- end to end through the CLI in a real process, SIGKILLed mid-study and re-run: the same
  files as an uninterrupted study; a changed problem is refused with one line;
- serial and on a 2-worker Dask LocalCluster: the same numbers (within 1e-12 relative);
- the equal-handling design of each layout meets the limit (checked with an independent
  roll-gradient computation) and no feasible design its runs evaluated that meets the limit
  has better comfort;
- the shared normalisation: the same front has the same hypervolume whichever other layouts
  a study holds.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hisopt.io import read_csv
from hisopt.optim import rundir
from hisopt.studies.layout_study import run_layout_study
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT
from tests.sigkill import kill_at_generation

POP, GENS, SEEDS = 12, 6, "1-2"
STUDY_FILES = ("layouts.csv", "runs.csv", "fronts.csv", "handling_curve.csv", "attainment.csv")


@pytest.fixture(scope="module")
def serial(problem, tmp_path_factory):
    out = tmp_path_factory.mktemp("layout-study") / "serial"
    return run_layout_study(problem, "axle_roll", SEEDS, out=out, pop_size=POP, generations=GENS)


def _numeric_equal(a: pd.DataFrame, b: pd.DataFrame, rtol: float = 1e-12) -> None:
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    for col in a.columns:
        if pd.api.types.is_numeric_dtype(a[col]) and not pd.api.types.is_bool_dtype(a[col]):
            np.testing.assert_allclose(b[col].to_numpy(float), a[col].to_numpy(float), rtol=rtol, atol=0, err_msg=col)
        else:
            assert a[col].tolist() == b[col].tolist(), col


def test_study_outputs_and_units(serial):
    table = serial.table
    assert table["layout"].tolist() == ["roll_plane", "axle_roll"]  # the reference first
    units = table.attrs["units"]
    assert units["gain_vs_roll_plane_pct"] == "%" and units["sigma_aw_at_limit"] == "m/s^2"
    assert units["handling_limit"] == "rad/g" and units["k_roll"] == "N/m" and units["best_p0"] == "Pa"
    assert table.loc[0, "gain_vs_roll_plane_pct"] == 0.0
    assert np.all(table["hv_min"] <= table["hv_mean"]) and np.all(table["hv_mean"] <= table["hv_max"])
    assert np.all(table["hv_merged"] >= table["hv_max"] - 1e-12)  # the merged front dominates each seed's
    # the stiffness columns are those of `hisopt layouts` (mode_stiffness) for the catalogue
    from hisopt.studies.screening import mode_stiffness

    ref = mode_stiffness(serial.cases[0].problem).set_index("layout")
    for name in table["layout"]:
        row = table.set_index("layout").loc[name]
        for col in ("k_bounce", "k_roll", "k_pitch", "k_warp", "c_roll", "stiffness_coupling"):
            assert row[col] == pytest.approx(ref.loc[name, col], rel=1e-12, abs=1e-9)
    for name in STUDY_FILES:
        back = read_csv(serial.out / name)
        assert back.attrs["units"], name
    assert (serial.out / "axle_roll" / "seed-2" / rundir.FRONT_CSV).is_file()
    # the trade-off staircase: comfort falls as the handling limit rises
    for name, part in serial.curve.groupby("layout"):
        h = part[serial.handling].to_numpy()
        s = part["sigma_aw"].to_numpy()
        assert np.all(np.diff(h) >= 0) and np.all(np.diff(s) < 0), name


def test_equal_handling_is_feasible_and_beats_every_sampled_design(serial):
    from hisopt.evaluation.evaluate import roll_gradient

    limit = serial.handling_limit
    assert serial.handling == "roll_gradient"
    # the default limit: the roll-plane baseline's own roll gradient, computed independently
    base = serial.cases[0].problem
    assert limit == pytest.approx(float(roll_gradient(base.model(base.baseline[None, :]), base.spec.handling.gravity_moment)[0]), rel=1e-12)
    assert serial.table["refined"].any()  # the NLP found better designs than the sampled ones
    for case in serial.cases:
        row = serial.table.set_index("layout").loc[case.name]
        names = list(case.problem.variable_names)
        x = np.array([[row[f"best_{n}"] for n in names]])
        rg = float(roll_gradient(case.problem.model(x), case.problem.spec.handling.gravity_moment)[0])
        assert rg <= limit * (1 + 1e-6)
        assert rg == pytest.approx(row["handling_at_best"], rel=1e-9)
        again = case.problem.evaluate(x)
        assert bool(again["feasible"].iloc[0])
        assert again["sigma_aw"].iloc[0] == pytest.approx(row["sigma_aw_at_limit"], rel=1e-12)
        sampled = []
        for seed in (1, 2):
            hist = pd.read_parquet(serial.out / case.name / f"seed-{seed}" / rundir.EVALUATIONS)
            hist = hist[hist["feasible"]]
            meets = roll_gradient(case.problem.model(hist[names].to_numpy()), case.problem.spec.handling.gravity_moment) <= limit
            sampled.append(hist.loc[meets, "sigma_aw"].to_numpy())
        best_sampled = np.concatenate(sampled).min()
        assert row["sigma_aw_at_limit"] <= best_sampled
    rp, ar = serial.table["sigma_aw_at_limit"]
    assert serial.table.loc[1, "gain_vs_roll_plane_pct"] == pytest.approx(100 * (1 - ar / rp), rel=1e-12)


def test_each_layouts_design_at_the_limit_has_its_buildability_verdict(serial, tmp_path):
    """Every rule (the study's problem constrains none) on the best_<variable> design, against
    buildability computed here; in layouts.csv, the layout report and the synthesis's ranking."""
    import dataclasses
    import html

    from hisopt.report.layout_report import VERDICT_NOTE, write_layout_report
    from hisopt.report.synthesis_report import write_synthesis_report
    from hisopt.studies.buildability import VERDICT_COLUMNS, buildability
    from hisopt.studies.synthesis import SynthesisResult, _layouts_table

    table = serial.table
    at = list(table.columns).index("at_limit")
    assert list(table.columns[at + 1 : at + 4]) == list(VERDICT_COLUMNS)
    assert all(table.attrs["units"][c] == "-" for c in VERDICT_COLUMNS)
    for case in serial.cases:
        row = table.set_index("layout").loc[case.name]
        x = np.array([[row[f"best_{n}"] for n in case.problem.variable_names]])
        verdict = buildability(case.problem, x).iloc[0]
        assert (bool(row["buildable"]), row["binding_rule"]) == (bool(verdict["buildable"]), verdict["binding_rule"])
        assert row["build_margin"] == pytest.approx(verdict["build_margin"], rel=1e-12)
    back = read_csv(serial.out / "layouts.csv")
    assert back["binding_rule"].tolist() == table["binding_rule"].tolist() and back.attrs["units"]["build_margin"] == "-"
    page = write_layout_report(serial, tmp_path / "report.html").read_text(encoding="utf-8")
    assert html.escape(VERDICT_NOTE) in page and all(f">{rule}<" in page for rule in table["binding_rule"])

    # the synthesis ranks the same table: the verdict travels with each layout, the order by gain alone
    study = dataclasses.replace(serial, out=None)
    candidates = pd.DataFrame(columns=["candidate", "elements", "catalogue", "description"])
    layouts = _layouts_table(candidates, study, {}, None)
    assert layouts["gain_vs_roll_plane_pct"].is_monotonic_decreasing
    merged = layouts.set_index("layout")[list(VERDICT_COLUMNS)].loc[table["layout"]]
    assert merged["binding_rule"].tolist() == table["binding_rule"].tolist()
    np.testing.assert_array_equal(merged["build_margin"].to_numpy(), table["build_margin"].to_numpy())
    counts = pd.DataFrame({"elements": [1], "candidates": [1], "screened_in": [1]})
    result = SynthesisResult(candidates, layouts, study, counts, None)
    page = write_synthesis_report(result, tmp_path / "synthesis.html").read_text(encoding="utf-8")
    assert html.escape(VERDICT_NOTE) in page and "binding_rule" in page


def test_normalisation_does_not_depend_on_the_other_layouts(problem, serial):
    from hisopt.studies.layout_metrics import normalised_hypervolume

    other = run_layout_study(problem, ["pitch_plane", "axle_roll"], SEEDS, pop_size=POP, generations=GENS)
    assert other.table["layout"].tolist() == ["roll_plane", "pitch_plane", "axle_roll"]
    for field in ("ideal_log", "reference_log", "plane_ideal_log", "plane_reference_log"):
        assert np.array_equal(getattr(other.normalisation, field), getattr(serial.normalisation, field))
    a = serial.runs.set_index(["layout", "seed"])["hypervolume"]
    b = other.runs.set_index(["layout", "seed"])["hypervolume"]
    for key in a.index:
        assert b[key] == a[key]
    # the same front, hypervolume computed alone: the same number
    front = serial.fronts[(serial.fronts["layout"] == "axle_roll") & (serial.fronts["seed"] == 1)]
    alone = normalised_hypervolume(front[list(problem.objective_names)].to_numpy(), other.normalisation)
    assert alone == a[("axle_roll", 1)] > 0
    # a dominated copy of a front has a smaller hypervolume: the measure is not constant
    worse = front[list(problem.objective_names)].to_numpy() * 1.05
    assert normalised_hypervolume(worse, other.normalisation) < alone


def test_serial_and_dask_give_the_same_study(problem, serial):
    from hisopt.evaluation.parallel import open_backend

    with open_backend(workers=2) as backend:
        dist = run_layout_study(problem, "axle_roll", SEEDS, pop_size=POP, generations=GENS, backend=backend)
    for name in ("table", "runs", "fronts", "curve", "attainment"):
        _numeric_equal(getattr(serial, name).reset_index(drop=True), getattr(dist, name).reset_index(drop=True))


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--layouts", "roll_plane,nope"), "unknown layout 'nope'"),
        (("--layouts", "missing.toml"), "not found"),
        (("--seeds", "3-1"), "increasing seed range"),
        (("--seeds", "a-b"), "expected seeds like"),
        (("--handling", "bogus"), "unknown quantity 'bogus'"),
        (("--handling", "sigma_aw"), "must differ from the comfort one"),
        (("--handling-limit", "-1 deg/g"), "expected a finite limit > 0"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, args, needle):
    outcome = run_cli("compare-layouts", str(DEFAULT_PROBLEM), "--out", str(tmp_path / "s"), "--pop", "8", "--gens", "1", *args)
    assert outcome.code == 2 and len(outcome.error_lines) == 1, outcome.stderr
    assert needle in outcome.stderr and "Traceback" not in outcome.stderr
    assert not (tmp_path / "s" / "roll_plane").exists()  # nothing ran


# --- real processes ----------------------------------------------------------------------------
CLI_ARGS = ("--layouts", "axle_roll", "--seeds", "1-2", "--pop", "12", "--gens", "20")


def _cli(problem: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "hisopt", "compare-layouts", str(problem), "--out", str(out), *CLI_ARGS]


@pytest.mark.slow
def test_cli_study_resumes_after_sigkill_to_identical_files(tmp_path):
    problem = tmp_path / "problem.toml"
    shutil.copy(DEFAULT_PROBLEM, problem)
    reference = subprocess.run(_cli(problem, tmp_path / "reference"), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert reference.returncode == 0, reference.stderr
    assert "wrote" in reference.stdout and (tmp_path / "reference" / "report.html").is_file()

    out = tmp_path / "killed"
    target = out / "axle_roll" / "seed-1"
    kill_at_generation(_cli(problem, out), target, 3, timeout=300)
    assert rundir.read_run_json(target)["status"] == "running"  # cut short mid-run
    assert not (out / "layouts.csv").exists()
    again = subprocess.run(_cli(problem, out), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    for name in STUDY_FILES:
        assert (out / name).read_bytes() == (tmp_path / "reference" / name).read_bytes(), name
    for layout in ("roll_plane", "axle_roll"):
        for seed in (1, 2):
            run = Path(layout) / f"seed-{seed}" / rundir.FRONT_CSV
            assert (out / run).read_bytes() == (tmp_path / "reference" / run).read_bytes()

    # the problem changed: refused with one line, exit 2
    problem.write_text(problem.read_text().replace("speed = 10.0", "speed = 12.0"))
    changed = subprocess.run(_cli(problem, out), cwd=ROOT, capture_output=True, text=True, timeout=300)
    lines = [line for line in changed.stderr.splitlines() if line.strip()]
    assert changed.returncode == 2 and len(lines) == 1 and "another problem" in lines[0], changed.stderr


def test_layout_cases_take_variables_from_the_catalogue_and_custom_files(problem, rng):
    from hisopt.studies.layout_cases import layout_cases

    cases = {c.name: c for c in layout_cases(problem, "roll_plane_twin_accumulator,problems/layout_custom_roll_plane.toml")}
    assert list(cases) == ["roll_plane", "roll_plane_twin_accumulator", "layout_custom_roll_plane"]
    twin = cases["roll_plane_twin_accumulator"].problem
    assert twin.variable_names == ("p0", "dA", "lam", "Rv", "Rv_link")  # the catalogue's bounds of its extra parameter
    assert (twin.spec.variables["Rv_link"].lower, twin.spec.variables["Rv_link"].upper) == (1e6, 5e9)
    assert twin.spec.objectives == problem.spec.objectives and twin.spec.road == problem.spec.road
    # the custom file writes the paper's circuits out: the same quantities as the catalogue's roll_plane
    custom, paper = cases["layout_custom_roll_plane"].problem, cases["roll_plane"].problem
    assert custom.spec.his.layout == "custom" and custom.variable_names == paper.variable_names
    x = paper.lower + (paper.upper - paper.lower) * rng.random((20, 4))
    a, b = paper.evaluate(x), custom.evaluate(x)
    for name in problem.objective_names:
        np.testing.assert_allclose(b[name], a[name], rtol=1e-12, err_msg=name)  # the same network: the determinism contract


# --- a problem with load cases ------------------------------------------------------------------
def _scenario_problem(folder: Path) -> Path:
    """The shipped robust problem cut down: two roads sharing one model (the evaluator shares
    their samples) and two objectives, so that the equal-handling NLP (objective sigma_aw
    alone) evaluates load cases without any PSD maximum. The handling quantity is the static
    roll gradient (the step steer's would make each NLP ten times slower), constrained so
    that the runs' logs hold it."""
    text = (ROOT / "problems" / "roll_plane_his_robust.toml").read_text()
    text = text[: text.index("[[scenarios]]")].replace(
        'objectives = ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd"]', 'objectives = ["sigma_aw", "max_roll_psd"]'
    )
    text += """
[[scenarios]]
name = "city"
road = { class = "C", speed = 10.0 }

[[scenarios]]
name = "motorway"
road = { class = "A", speed = 33.0 }

[[constraints]]
name = "rms_tire_load"
limit = 1265.0

[[constraints]]
name = "roll_gradient"
limit = 0.08
"""
    path = folder / "two_roads.toml"
    path.write_text(text)
    return path


def _least_feasible(run_dir: Path, quantity: str) -> float:
    """[SI] The least ``quantity`` of a run's feasible designs, from its evaluation log."""
    log = pd.read_parquet(run_dir / "evaluations.parquet")
    return float(log.loc[log["feasible"], quantity].min())


def test_cli_study_of_a_scenario_problem_including_a_limit_no_design_meets(tmp_path):
    """Regression (issue 22): the study of a problem with load cases crashed after its runs
    (the NLP's problem has no PSD maximum); and a layout with no design at the limit must say
    so in layouts.csv, on the terminal and in the report."""
    problem = _scenario_problem(tmp_path)
    out = tmp_path / "study"
    args = ("compare-layouts", problem, "--layouts", "axle_roll", "--seeds", "1", "--pop", "10", "--gens", "3", "--out", out, "--handling", "roll_gradient")
    first = run_cli(*args)
    assert first.code == 0, first.stderr
    table = read_csv(out / "layouts.csv").set_index("layout")
    assert (out / "report.html").is_file() and table.loc["roll_plane", "handling"] == "roll_gradient"
    least = {name: _least_feasible(out / name / "seed-1", "roll_gradient") for name in ("roll_plane", "axle_roll")}
    for name, row in table.iterrows():
        assert row["handling_least"] == least[name]  # the same numbers, read back from the runs' own logs
        met = least[name] <= row["handling_limit"]
        assert row["at_limit"] == ("met" if met else row["at_limit"]) and (row["at_limit"] == "met") == met
        assert np.isfinite(row["sigma_aw_at_limit"]) == met
        if met:
            assert row["handling_at_best"] <= row["handling_limit"]

    # a limit below every feasible design of both layouts: the study says so, it does not crash
    limit = 0.5 * min(least.values())
    second = run_cli(*args, "--handling-limit", f"{limit!r} rad/g")
    assert second.code == 0, second.stderr
    table = read_csv(out / "layouts.csv").set_index("layout")
    assert table["handling_limit"].tolist() == [limit, limit]
    assert table["sigma_aw_at_limit"].isna().all() and table["gain_vs_roll_plane_pct"].isna().all()
    for name in ("roll_plane", "axle_roll"):
        status = table.loc[name, "at_limit"]
        assert status.startswith("none of ") and "feasible designs meets roll_gradient <= " in status, status
        assert f"{name}: {status}, so it has no sigma_aw_at_limit" in second.stdout
    assert "without the reference, no layout has a gain_vs_roll_plane_pct" in second.stdout
    page = (out / "report.html").read_text()
    assert page.count("No design at the limit.") == 2
    assert page.count('id="hisopt-plotly"') == 1 and page.count("window.hisoptFigures.push") >= 5  # light: plotly.js once, compressed

    # between the two layouts' least values: one layout compared, the other said to have no design
    low, high = sorted(least.values())
    if low < high:
        third = run_cli(*args, "--handling-limit", f"{0.5 * (low + high)!r} rad/g")
        assert third.code == 0, third.stderr
        table = read_csv(out / "layouts.csv").set_index("layout")
        assert sorted(table["at_limit"] == "met") == [False, True]
        assert (read_csv(out / "layouts.csv").set_index("layout")["sigma_aw_at_limit"].notna() == (table["at_limit"] == "met")).all()
        assert third.stdout.count("so it has no sigma_aw_at_limit") == 1


# --- hisopt status and hisopt report on a study directory -----------------------------------------
def _backticked(line: str) -> list[str]:
    return line.split("`")[1].split()


def test_status_and_report_recognise_a_study_directory(serial, tmp_path):
    """Issue 22: both said "start a run with hisopt optimize". Now status summarises the
    study (layouts, seeds, each run, its files, what to do next, from the runs' own state)
    and report writes the study report from its files, byte for byte the one the study's own
    result gives; an unfinished study says how to finish it, and that command finishes it."""
    from hisopt.report.layout_report import write_layout_report

    out = tmp_path / "study"
    shutil.copytree(serial.out, out)
    status = run_cli("status", out)
    assert status.code == 0, status.stderr
    lines = status.stdout.splitlines()
    assert lines[0] == f"{out}: layout study of roll_plane_his: layouts roll_plane, axle_roll; seeds 1-2; runs of population {POP} for {GENS} generations"
    assert lines[1:5] == [f"  {n} seed {s}: finished, {GENS} of {GENS} generations" for n in ("roll_plane", "axle_roll") for s in (1, 2)]
    assert lines[5] == "  layouts.csv written, no report.html yet" and lines[6] == f"next: `hisopt report {out}` writes {out / 'report.html'}"

    report = run_cli("report", out)
    assert report.code == 0 and report.stdout.splitlines() == [f"wrote {out / 'report.html'}", f"wrote {out / 'decision.html'}"], report.stderr
    direct = write_layout_report(serial, tmp_path / "direct.html")
    assert (out / "report.html").read_bytes() == direct.read_bytes()
    assert run_cli("status", out).stdout.splitlines()[-1].startswith(f"finished: open {out / 'report.html'}")
    wrong = run_cli("report", out, "--color-by", "sigma_aw")
    assert wrong.code == 2 and len(wrong.error_lines) == 1 and "takes no --color-by" in wrong.stderr

    # unfinished: a run missing, the table gone
    shutil.rmtree(out / "axle_roll" / "seed-2")
    (out / "layouts.csv").unlink()
    lines = run_cli("status", out).stdout.splitlines()
    assert "  axle_roll seed 2: not started" in lines and "  report.html written, layouts.csv missing" in lines
    assert lines[-1].startswith("next: finish the study (finished runs are reused) with `hisopt compare-layouts ")
    command = _backticked(lines[-1])
    assert command[3:] == ["--layouts", "roll_plane,axle_roll", "--seeds", "1-2", "--pop", str(POP), "--gens", str(GENS), "--out", str(out)]
    refused = run_cli("report", out)
    assert refused.code == 2 and len(refused.error_lines) == 1 and "has no layouts.csv yet (it has not finished)" in refused.stderr
    assert _backticked(refused.error_lines[0]) == command
    finished = run_cli(*command[1:])
    assert finished.code == 0, finished.stderr
    assert run_cli("status", out).stdout.splitlines()[-1].startswith("finished: open")
    _numeric_equal(read_csv(serial.out / "layouts.csv"), read_csv(out / "layouts.csv"))  # the same study


def test_the_decision_room_holds_every_layouts_fronts(serial, tmp_path):
    """Issue 27: the layout study's decision room navigates its layouts' fronts: each seed's
    front of each layout, every quantity the layout's own problem gives (NaN for a variable
    another layout has), exports in the layout's problem file."""
    import base64
    import json
    import re
    import tomllib

    from hisopt.problem import problem_from_dict
    from hisopt.report.decision_page import study_decision_room
    from hisopt.studies.decision_room import decision_room_data, layout_sources

    sources = layout_sources(serial)
    assert [(s.name, Path(s.location).name) for s in sources] == [(n, f"seed-{k}") for n in ("roll_plane", "axle_roll") for k in (1, 2)]
    for s in sources:
        front = read_csv(Path(s.location) / rundir.FRONT_CSV)
        assert np.array_equal(s.x, front[list(s.problem.variable_names)].to_numpy(dtype=float))
    room = decision_room_data(sources)
    assert len(room.table) == sum(len(s.x) for s in sources)
    for name in ("roll_plane", "axle_roll"):
        assert (room.table["source"] == name).sum() == sum(len(s.x) for s in sources if s.name == name)
    assert room.table["p0"].notna().all() and {c for c, g in room.groups.items() if g == "variable"} >= set(sources[-1].problem.variable_names)
    page = study_decision_room(serial)
    assert page == serial.out / "decision.html"
    data = json.loads(re.search(r'<script type="application/json" id="room-data">(.*?)</script>', page.read_text(), re.S).group(1))
    assert [s["label"] for s in data["sources"]] == [f"{n} (seed-{k})" for n in ("roll_plane", "axle_roll") for k in (1, 2)]
    # each row names its own seed's source (a layout's seeds share a name)
    index = np.frombuffer(base64.b64decode(data["source"]), dtype=np.uint8)
    assert index.tolist() == [k for k, s in enumerate(sources) for _ in range(len(s.x))]
    # each layout's template, with its baseline put in, is that layout's problem
    for s, entry in zip(sources, data["sources"], strict=True):
        text = entry["template"]
        for v, value in zip(s.problem.variable_names, s.problem.baseline, strict=True):
            text = text.replace("{{" + v + "}}", repr(float(value)))
        assert problem_from_dict(tomllib.loads(text)).spec == s.problem.spec


def test_quantities_of_a_problem_with_constraint_only_quantities():
    """The study reads every objective, constraint and the handling quantity of a problem; a
    constraint-only quantity (static_gas_fraction: lower is not better) among them is read as
    a constraint, and each value equals the problem's own evaluation."""
    import hisopt
    from hisopt.studies.layout_metrics import COMFORT, evaluate_quantities

    parts = hisopt.load_problem(ROOT / "problems" / "roll_plane_his_parts.toml")
    names = (*parts.objective_names, *parts.constraint_names, COMFORT, "roll_gradient")
    assert "roll_gradient" not in parts.objective_names + parts.constraint_names  # read through another problem
    got = evaluate_quantities(parts, parts.baseline[None, :], names)
    own = parts.evaluator()(parts.baseline[None, :])
    for name in (*parts.objective_names, *parts.constraint_names):
        assert got[name][0] == pytest.approx(own[name][0], rel=1e-12), name
    assert np.isfinite(got["roll_gradient"][0]) and got["valid"][0]


# --- successive halving's early rungs: nothing refined, one hypervolume reference -----------------
def test_unrefined_study_takes_each_layouts_best_sampled_design_at_the_limit(problem, serial, tmp_path):
    """``refine_method="none"`` (successive halving's early rungs): the same runs as a refined
    study, each layout's comfort at the limit the best of its sampled feasible designs that
    meet the limit (read back from the runs' evaluations), nothing marked refined, the curve
    the sampled staircase only; a refined value is never worse than the sampled one."""
    from hisopt.studies.layout_metrics import COMFORT, evaluate_quantities

    plain = run_layout_study(problem, "axle_roll", SEEDS, out=tmp_path / "plain", pop_size=POP, generations=GENS, refine_method="none")
    for name in STUDY_FILES[1:3]:  # runs.csv, fronts.csv: the runs are the refined study's
        assert (tmp_path / "plain" / name).read_bytes() == (serial.out / name).read_bytes(), name
    table = plain.table.set_index("layout")
    assert not table["refined"].any() and set(plain.curve["source"]) == {"sampled"}
    limit, handling = plain.handling_limit, plain.handling
    for case in plain.cases:
        layout, names = case.name, list(case.problem.variable_names)
        pool = pd.concat([pd.read_parquet(tmp_path / "plain" / layout / f"seed-{seed}" / rundir.EVALUATIONS) for seed in (1, 2)])
        x = pool.loc[pool["feasible"].astype(bool), names].to_numpy(float)
        q = evaluate_quantities(case.problem, x, (COMFORT, handling))
        best = q[COMFORT][q[handling] <= limit].min()
        assert table.loc[layout, "sigma_aw_at_limit"] == best, layout
        assert serial.table.set_index("layout").loc[layout, "sigma_aw_at_limit"] <= best
    assert table.loc["roll_plane", "gain_vs_roll_plane_pct"] == 0.0


def test_a_studys_runs_share_roll_planes_reference_and_it_changes_no_design(problem, serial, tmp_path):
    """Every run of a study records progress against roll_plane's hypervolume reference (no
    grid of its own per candidate), and a run's designs do not depend on the reference: the
    study's axle_roll run equals, design for design, a standalone run with its own reference."""
    import json

    from hisopt.errors import ConfigError
    from hisopt.optim.decision import reference_point
    from hisopt.optim.run import optimize

    expected = reference_point(serial.cases[0].problem).tolist()
    for layout in ("roll_plane", "axle_roll"):
        info = json.loads((serial.out / layout / "seed-1" / rundir.RUN_JSON).read_text())
        assert info["settings"]["hypervolume_reference_log10"] == expected, layout
    axle = serial.cases[1].problem
    assert reference_point(axle).tolist() != expected  # its own would differ: the test can fail
    alone = optimize(axle, seed=1, pop_size=POP, generations=GENS)
    names = list(axle.variable_names)
    in_study = read_csv(serial.out / "axle_roll" / "seed-1" / rundir.FRONT_CSV)[names].to_numpy(float)
    mine = alone.front[names].to_numpy(float)
    np.testing.assert_array_equal(mine[np.lexsort(mine.T)], in_study[np.lexsort(in_study.T)])  # the same designs, row by row
    with pytest.raises(ConfigError, match="hypervolume reference of"):
        optimize(axle, seed=1, pop_size=POP, generations=1, reference_log=[0.0])
