"""The library is the command line's equal (issue 38): every public function refuses a bad
argument with a hisopt error (:class:`hisopt.errors.HisoptError`) whose message is one line
naming the argument, never an IndexError, KeyError, AttributeError, TypeError or ValueError
from deep inside, and never a silently wrong (NaN) result.

The table :data:`CASES` holds bad calls of every callable name of ``hisopt.__all__`` (a test
fails when a public name has none) and of the sub-packages' entry points that take a
person's input. The calls are cheap: a tiny run directory is built once per module.
"""

from __future__ import annotations

import json
import shutil
import socket
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import hisopt
import hisopt.plotting
import hisopt.report
import hisopt.road
from hisopt.errors import ConfigError, HisoptError
from tests.conftest import DEFAULT_PROBLEM, ROOT

UNCERTAIN_PROBLEM = ROOT / "problems" / "roll_plane_his_uncertain.toml"

NOT_CALLED = {
    "CATALOGUE_NAMES": "a tuple of names, not a function",
    "STROKE_PATTERNS": "a table of data, not a function",
    "ConfigError": "an exception class",
    "HisoptError": "an exception class",
    "ModelError": "an exception class",
    "ProblemFileNotFoundError": "an exception class",
    "RunError": "an exception class",
    "PlausibilityWarning": "a warning class",
    "OptimizationResult": "a result the library builds (hisopt.optimize), not made from a person's input",
    "SensitivityResult": "a result the library builds (hisopt.sensitivity), not made from a person's input",
    "ToleranceResult": "a result the library builds (hisopt.tolerance), not made from a person's input",
    "Problem": "built by load_problem / problem_from_dict from a validated specification (their rows check the input)",
    "DesignSpace": "built by load_problem / problem_from_dict from a validated specification (their rows check the input)",
    "catalogue": "takes no argument",
}
"""Public names without a row in :data:`CASES`, and why."""


@dataclass(frozen=True)
class Context:
    """What the calls are made with: problems, a model, a finished run directory, a scratch folder."""

    problem: hisopt.Problem
    uncertain: hisopt.Problem
    run: Path
    scratch: Path

    @property
    def design(self) -> np.ndarray:
        return self.problem.baseline[None, :]

    def folder(self, name: str, run_json: str | None = None, status: str | None = None) -> Path:
        """A copy of the finished run under ``name`` with ``run.json`` replaced by ``run_json``
        (or its status set to ``status``)."""
        path = self.scratch / name
        if not path.exists():
            shutil.copytree(self.run, path)
            if run_json is not None:
                (path / "run.json").write_text(run_json)
            if status is not None:
                record = json.loads((path / "run.json").read_text())
                process = {"pid": 1, "host": socket.gethostname(), "start": None}  # alive: init runs as long as the machine
                (path / "run.json").write_text(json.dumps(record | {"status": status, "process": process}))
        return path


@dataclass(frozen=True)
class Case:
    """One bad call: ``name`` the public name, ``call`` makes the call, ``names`` a word the
    one-line message must hold (the argument, option or file)."""

    name: str
    label: str
    call: Callable[[Context], Any]
    names: str
    error: type[HisoptError] = HisoptError


def _nan_design(c: Context) -> np.ndarray:
    x = c.design.copy()
    x[0, 0] = np.nan
    return x


CASES: list[Case] = [
    # --- problems --------------------------------------------------------------------------------
    Case("load_problem", "missing file", lambda c: hisopt.load_problem(c.scratch / "none.toml"), "none.toml"),
    Case("load_problem", "not a path", lambda c: hisopt.load_problem(42), "path"),
    Case("problem_from_dict", "empty", lambda c: hisopt.problem_from_dict({}), "<problem>"),
    Case("problem_from_dict", "not a dict", lambda c: hisopt.problem_from_dict("vehicle"), "data"),
    Case("admissible", "wrong length", lambda c: hisopt.admissible(c.problem, np.ones((1, 2))), "x: "),
    Case("admissible", "text", lambda c: hisopt.admissible(c.problem, "abc"), "x: "),
    Case("admissible", "not a problem", lambda c: hisopt.admissible("problem.toml", c.design), "problem"),
    Case("uncertain_inputs", "not a problem", lambda c: hisopt.uncertain_inputs(None), "space"),
    Case("his_parameter_values", "not a his", lambda c: hisopt.his_parameter_values("his"), "his"),
    Case("his_parameter_values", "overrides not a dict", lambda c: hisopt.his_parameter_values(c.problem.spec.his, [1.0]), "overrides"),
    # --- the model -------------------------------------------------------------------------------
    Case("CoupledModel", "not a vehicle", lambda c: hisopt.CoupledModel("car"), "vehicle"),
    Case("Evaluator", "not a problem", lambda c: hisopt.Evaluator("problem.toml"), "problem"),
    Case("Evaluator", "chunk size 0", lambda c: hisopt.Evaluator(c.problem, chunk_size=0), "chunk_size"),
    Case("modal_analysis", "wrong length", lambda c: hisopt.modal_analysis(c.problem, [1.0, 2.0]), "shape"),
    Case("modal_analysis", "NaN design", lambda c: hisopt.modal_analysis(c.problem, _nan_design(c)), "p0"),
    Case("modal_analysis", "not a problem", lambda c: hisopt.modal_analysis("problem.toml"), "problem"),
    Case("track_modes", "anchor out of range", lambda c: hisopt.track_modes(c.problem, np.vstack([c.design] * 2), anchor=5), "anchor"),
    Case("track_modes", "no designs", lambda c: hisopt.track_modes(c.problem, np.empty((0, c.design.shape[1]))), "designs"),
    Case("track_modes", "min_mac above 1", lambda c: hisopt.track_modes(c.problem, np.vstack([c.design] * 2), min_mac=2.0), "min_mac"),
    Case("roll_gradient", "not a model", lambda c: hisopt.roll_gradient("model"), "model"),
    Case("mode_stiffness", "not a problem", lambda c: hisopt.mode_stiffness("problem.toml"), "problem"),
    Case("response_spectra", "unknown output", lambda c: hisopt.response_spectra(c.problem, outputs=("bogus",)), "bogus"),
    Case("response_spectra", "wrong length", lambda c: hisopt.response_spectra(c.problem, [1.0]), "shape"),
    # --- time domain -----------------------------------------------------------------------------
    Case("simulate", "empty time", lambda c: hisopt.simulate(c.problem.model(), [], np.zeros((0, 4))), "t_s"),
    Case("simulate", "road of the wrong shape", lambda c: hisopt.simulate(c.problem.model(), np.linspace(0, 1, 11), np.zeros((11, 3))), "road_m"),
    Case("simulate", "unknown mode", lambda c: hisopt.simulate(c.problem.model(), np.linspace(0, 1, 11), np.zeros((11, 4)), mode="bogus"), "mode"),
    Case("simulate", "unknown solver", lambda c: hisopt.simulate(c.problem.model(), np.linspace(0, 1, 11), np.zeros((11, 4)), method="bogus"), "method"),
    Case("simulate", "not a model", lambda c: hisopt.simulate("model", np.linspace(0, 1, 11), np.zeros((11, 4))), "model"),
    Case("simulate_drop", "unknown case", lambda c: hisopt.simulate_drop(c.problem.model(), "bogus"), "case"),
    Case("simulate_drop", "NaN height", lambda c: hisopt.simulate_drop(c.problem.model(), "front_axle", height_m=np.nan), "height"),
    Case("simulate_drop", "zero sample rate", lambda c: hisopt.simulate_drop(c.problem.model(), "front_axle", sample_rate_hz=0.0), "sample_rate_hz"),
    Case("simulate_drop", "text height", lambda c: hisopt.simulate_drop(c.problem.model(), "front_axle", height_m="5 cm"), "height"),
    Case("simulate_drop", "not a model", lambda c: hisopt.simulate_drop("model", "front_axle"), "model"),
    Case("response_sensors", "not a response", lambda c: hisopt.response_sensors("response"), "response"),
    Case("run_drop_tests", "no pressures", lambda c: hisopt.run_drop_tests(c.problem, []), "p0"),
    Case("run_drop_tests", "unknown case", lambda c: hisopt.run_drop_tests(c.problem, [2e6], cases=("bogus",)), "case"),
    Case("run_drop_tests", "negative height", lambda c: hisopt.run_drop_tests(c.problem, [2e6], height_m=-0.05), "height"),
    Case("run_drop_tests", "one number for the list", lambda c: hisopt.run_drop_tests(c.problem, 2e6), "p0"),
    Case("measured_drop_test", "missing file", lambda c: hisopt.measured_drop_test(c.problem, c.scratch / "none.csv", "front_axle", 2e6), "none.csv"),
    Case("measured_drop_test", "unknown case", lambda c: hisopt.measured_drop_test(c.problem, c.scratch / "none.csv", "bogus", 2e6), "case"),
    Case("drop_table", "no tests", lambda c: hisopt.drop_table([]), "tests"),
    Case("drop_table", "not tests", lambda c: hisopt.drop_table(["x"]), "tests"),
    Case("spectra_figure", "no tests", lambda c: hisopt.spectra_figure([]), "tests"),
    # --- units and files -------------------------------------------------------------------------
    Case("format_quantity", "unit not text", lambda c: hisopt.format_quantity(1.0, 3), "unit"),
    Case("format_quantity", "text value", lambda c: hisopt.format_quantity("abc", "m"), "value"),
    Case("format_quantity", "zero digits", lambda c: hisopt.format_quantity(1.0, "m", digits=0), "digits"),
    Case("display_frame", "not a frame", lambda c: hisopt.display_frame("frame"), "frame"),
    Case("display_frame", "units not a dict", lambda c: hisopt.display_frame(pd.DataFrame({"a": [1.0]}), ["m"]), "units"),
    Case("read_csv", "missing file", lambda c: hisopt.read_csv(c.scratch / "none.csv"), "none.csv"),
    # --- studies ---------------------------------------------------------------------------------
    Case("sweep", "unknown variable", lambda c: hisopt.sweep(c.problem, "bogus"), "bogus"),
    Case("sweep", "one point", lambda c: hisopt.sweep(c.problem, "p0", points=1), "points"),
    Case("regions", "unknown pair", lambda c: hisopt.regions(c.problem, ("bogus", "p0")), "bogus"),
    Case("regions", "one point", lambda c: hisopt.regions(c.problem, ("p0", "dA"), points=1), "points"),
    Case("tolerance", "no samples", lambda c: hisopt.tolerance(c.uncertain, c.uncertain.baseline, n_samples=0), "n_samples", ConfigError),
    Case("tolerance", "one sample", lambda c: hisopt.tolerance(c.uncertain, c.uncertain.baseline, n_samples=1), "n_samples", ConfigError),
    Case("tolerance", "no uncertain inputs", lambda c: hisopt.tolerance(c.problem, c.design, n_samples=10), "uncertain"),
    Case("tolerance", "wrong length", lambda c: hisopt.tolerance(c.uncertain, [1.0, 2.0], n_samples=10), "shape"),
    Case("tolerance", "NaN design", lambda c: hisopt.tolerance(c.uncertain, np.full(len(c.uncertain.variable_names), np.nan), n_samples=10), "design"),
    Case("tolerance", "text seed", lambda c: hisopt.tolerance(c.uncertain, c.uncertain.baseline, n_samples=10, seed="x"), "seed"),
    Case("tolerance", "not a problem", lambda c: hisopt.tolerance("problem.toml", [1.0], n_samples=10), "space"),
    Case("sensitivity", "not a power of two", lambda c: hisopt.sensitivity(c.uncertain, c.uncertain.baseline, n_base=1000), "n_base", ConfigError),
    Case("sensitivity", "wrong length", lambda c: hisopt.sensitivity(c.uncertain, [1.0], n_base=8), "shape"),
    Case("sensitivity", "nothing varies around a design", lambda c: hisopt.sensitivity(c.problem, c.design, n_base=8), "[[uncertain]]", ConfigError),
    Case("sensitivity", "not a problem", lambda c: hisopt.sensitivity("problem.toml", None, n_base=8), "space", ConfigError),
    # --- optimisation ----------------------------------------------------------------------------
    Case("optimize", "population 0", lambda c: hisopt.optimize(c.problem, pop_size=0, generations=1), "pop"),
    Case("optimize", "negative generations", lambda c: hisopt.optimize(c.problem, pop_size=8, generations=-1), "gen"),
    Case("optimize", "unknown algorithm", lambda c: hisopt.optimize(c.problem, pop_size=8, generations=1, algorithm="bogus"), "algorithm"),
    Case("optimize", "bad until", lambda c: hisopt.optimize(c.problem, pop_size=8, generations=1, until="bogus"), "until"),
    Case("optimize", "missing problem file", lambda c: hisopt.optimize(c.scratch / "none.toml"), "none.toml"),
    Case("optimize", "into a finished run", lambda c: hisopt.optimize(c.problem, out=c.run, pop_size=8, generations=1), "out"),
    Case("resume", "missing folder", lambda c: hisopt.resume(c.scratch / "none"), "none"),
    Case("resume", "empty run.json", lambda c: hisopt.resume(c.folder("empty-record", run_json="{}")), "run.json"),
    Case("refine_run", "missing folder", lambda c: hisopt.refine_run(c.scratch / "none"), "none"),
    Case("refine_run", "no points", lambda c: hisopt.refine_run(c.run, max_points=0), "max_points"),
    Case("refine_run", "unknown method", lambda c: hisopt.refine_run(c.run, method="bogus"), "method"),
    Case("refine_front", "front without the variables", lambda c: hisopt.refine_front(c.problem, pd.DataFrame({"a": [1.0]})), "front"),
    Case("refine_front", "no points", lambda c: hisopt.refine_front(c.problem, hisopt.read_csv(c.run / "front.csv"), max_points=0), "max_points"),
    Case("refine_front", "unknown method", lambda c: hisopt.refine_front(c.problem, hisopt.read_csv(c.run / "front.csv"), method="bogus"), "method"),
    Case("refine_front", "text max_points", lambda c: hisopt.refine_front(c.problem, hisopt.read_csv(c.run / "front.csv"), max_points="x"), "max_points"),
    Case("refine_front", "front not a table", lambda c: hisopt.refine_front(c.problem, "front.csv"), "front"),
    Case("open_backend", "no workers", lambda c: hisopt.open_backend(workers=0).__enter__(), "workers"),
    Case("open_backend", "text workers", lambda c: hisopt.open_backend(workers="two").__enter__(), "workers"),
    # --- layouts ---------------------------------------------------------------------------------
    Case("compare_layouts", "unknown layout", lambda c: hisopt.compare_layouts(c.problem, "bogus", seeds=[1], pop_size=8, generations=1), "bogus"),
    Case("compare_layouts", "bad seeds", lambda c: hisopt.compare_layouts(c.problem, "axle_roll", seeds="x", pop_size=8, generations=1), "seeds"),
    Case(
        "compare_layouts",
        "text handling limit",
        lambda c: hisopt.compare_layouts(c.problem, "axle_roll", seeds=[1], handling_limit="1.8 deg/g", pop_size=8, generations=1),
        "handling",
        ConfigError,
    ),
    Case(
        "compare_layouts",
        "NaN handling limit",
        lambda c: hisopt.compare_layouts(c.problem, "axle_roll", seeds=[1], handling="rollover", handling_limit=np.nan),
        "handling",
    ),
    Case("run_layout_study", "population 0", lambda c: hisopt.run_layout_study(c.problem, "axle_roll", seeds=[1], pop_size=0, generations=1), "pop"),
    Case("run_layout_study", "not a problem", lambda c: hisopt.run_layout_study("problem.toml", "axle_roll", seeds=[1]), "problem"),
    Case("run_synthesis", "no elements", lambda c: hisopt.run_synthesis(c.problem, 0), "max_elements"),
    Case("run_synthesis", "unknown chambers", lambda c: hisopt.run_synthesis(c.problem, 6, chambers="bogus"), "chambers"),
    Case("run_synthesis", "not a problem", lambda c: hisopt.run_synthesis("problem.toml", 6), "problem"),
    Case("run_synthesis", "negative optimise", lambda c: hisopt.run_synthesis(c.problem, 6, optimise=-1), "optimise"),
    # --- sub-packages ----------------------------------------------------------------------------
    Case("report.decision_room", "missing folder", lambda c: hisopt.report.decision_room(c.scratch / "none"), "none"),
    Case("report.decision_room", "empty run.json", lambda c: hisopt.report.decision_room(c.folder("empty", run_json="")), "run.json"),
    Case("report.decision_room", "run.json of {}", lambda c: hisopt.report.decision_room(c.folder("braces", run_json="{}")), "run.json"),
    Case("report.decision_room", "corrupt run.json", lambda c: hisopt.report.decision_room(c.folder("corrupt", run_json="{not json")), "run.json"),
    Case("report.decision_room", "running run", lambda c: hisopt.report.decision_room(c.folder("running", status="running")), "running"),
    Case("report.decision_room", "interrupted run", lambda c: hisopt.report.decision_room(c.folder("interrupted", status="interrupted")), "interrupted"),
    Case("report.decision_room", "a folder of another kind", lambda c: hisopt.report.decision_room(c.scratch), "run"),
    Case("report.decision_room", "an in-memory result", lambda c: hisopt.report.decision_room(_in_memory_result(c)), "out="),
    Case("report.decision_room", "a number", lambda c: hisopt.report.decision_room(3), "source"),
    Case("report.decision_room", "max_rows 0", lambda c: hisopt.report.decision_room(c.run, max_rows=0), "max_rows"),
    Case("report.build_report", "unknown design", lambda c: hisopt.report.build_report(c.folder("report"), design="bogus"), "design"),
    Case("report.build_report", "empty run.json", lambda c: hisopt.report.build_report(c.folder("empty-report", run_json="{}")), "run.json"),
    Case("report.build_report", "unknown colour column", lambda c: hisopt.report.build_report(c.folder("report"), color_by="bogus"), "color_by"),
    Case("report.layout_schematic", "not a layout", lambda c: hisopt.report.layout_schematic("axle_roll"), "layout"),
    Case("report.write_layout_report", "not a study", lambda c: hisopt.report.write_layout_report("runs/layouts"), "result"),
    Case("report.fronts_figure", "not a study", lambda c: hisopt.report.fronts_figure(None), "result"),
    Case("report.curve_figure", "not a study", lambda c: hisopt.report.curve_figure(None), "result"),
    Case("report.attainment_figure", "not a study", lambda c: hisopt.report.attainment_figure(None), "result"),
    Case(
        "road.random_profile",
        "unknown road class",
        lambda c: hisopt.road.random_profile(np.linspace(0, 1, 101), "Z", 10.0, 2.7, np.random.default_rng(0), 0.5, 20.0),
        "class",
    ),
    Case(
        "road.random_profile",
        "band upside down",
        lambda c: hisopt.road.random_profile(np.linspace(0, 1, 101), "C", 10.0, 2.7, np.random.default_rng(0), 20.0, 0.5),
        "f_min_hz",
    ),
    Case("road.bump_profile", "zero speed", lambda c: hisopt.road.bump_profile(np.linspace(0, 1, 101), 0.05, 1.0, 0.0, 2.7), "speed_mps"),
    Case("road.step_profile", "unknown wheel", lambda c: hisopt.road.step_profile(np.linspace(0, 1, 101), 0.05, 0.1, wheels=("xx",)), "wheel"),
    Case("road.wheel_input_csd", "unknown coherence", lambda c: hisopt.road.wheel_input_csd(np.ones(3), 1e-6, 10.0, 2.7, 1.5, coherence="bogus"), "coherence"),
    Case(
        "plotting.tolerance_figure",
        "unknown quantity",
        lambda c: hisopt.plotting.tolerance_figure(pd.DataFrame({"a": [1.0]}), ["bogus"], {}, {}, {}, "t"),
        "quantities",
    ),
    Case("plotting.parallel_coordinates", "unknown colour column", lambda c: hisopt.plotting.parallel_coordinates(_front(c), ["p0"], [], "bogus"), "color_by"),
    Case("plotting.front_scatter_matrix", "unknown objective", lambda c: hisopt.plotting.front_scatter_matrix(_front(c), ["bogus"], ["p0"]), "objectives"),
]


def _front(c: Context) -> pd.DataFrame:
    return hisopt.read_csv(c.run / "front.csv")


def _in_memory_result(c: Context) -> hisopt.OptimizationResult:
    from dataclasses import replace

    return replace(_run_result(c), run_dir=None)


_RESULTS: dict[Path, hisopt.OptimizationResult] = {}


def _run_result(c: Context) -> hisopt.OptimizationResult:
    return _RESULTS[c.run]


@pytest.fixture(scope="module")
def context(tmp_path_factory) -> Context:
    root = tmp_path_factory.mktemp("library-bad-input")
    problem = hisopt.load_problem(DEFAULT_PROBLEM)
    run = root / "run"
    _RESULTS[run] = hisopt.optimize(problem, out=run, pop_size=8, generations=2, seed=1)
    scratch = root / "scratch"
    scratch.mkdir()
    return Context(problem, hisopt.load_problem(UNCERTAIN_PROBLEM), run, scratch)


@pytest.mark.parametrize("case", CASES, ids=[f"{c.name}: {c.label}" for c in CASES])
def test_a_bad_argument_gives_one_hisopt_line_naming_it(case: Case, context: Context):
    with pytest.raises(Exception) as caught:
        case.call(context)
    error = caught.value
    assert isinstance(error, case.error), f"{type(error).__name__}: {error}"
    message = str(error)
    assert message.strip() and "\n" not in message.strip(), message
    # the library's parameter (max_points) or the command's option (--max-points) that both check
    assert case.names.lower().replace("-", "_") in message.lower().replace("-", "_"), message


def test_every_public_callable_has_a_bad_argument_row():
    covered = {c.name for c in CASES}
    missing = [n for n in hisopt.__all__ if n not in covered and n not in NOT_CALLED]
    assert not missing, f"public names without a bad-argument row in CASES (or a reason in NOT_CALLED): {missing}"
    stale = [n for n in NOT_CALLED if n not in hisopt.__all__ or n in covered]
    assert not stale, stale
    for name in NOT_CALLED:
        value = getattr(hisopt, name)
        assert not callable(value) or isinstance(value, type) or name == "catalogue", name


def test_the_command_and_the_library_refuse_one_sample_with_one_check(context: Context, tmp_path):
    """`hisopt tolerance --samples 1` and `hisopt.tolerance(..., n_samples=1)` say the same
    thing (one check, two names for the argument), and the command writes nothing."""
    from tests.cli_inprocess import run_cli

    out = tmp_path / "tolerance"
    outcome = run_cli("tolerance", str(UNCERTAIN_PROBLEM), "--samples", "1", "--out", str(out))
    with pytest.raises(ConfigError) as caught:
        hisopt.tolerance(context.uncertain, context.uncertain.baseline, n_samples=1)
    assert caught.value.key == "n_samples"
    assert outcome.code == 2 and outcome.error_lines == [f"error: --samples: {caught.value.detail}"]
    assert not out.exists()


def test_decision_room_takes_the_result_of_a_run_with_a_directory(context: Context):
    """An OptimizationResult with a run directory is read from that directory: its front whole."""
    room = hisopt.report.decision_room(_run_result(context), max_rows=1)
    assert (room.table["kind"] == "front").sum() == len(_front(context)) == len(room.table)
