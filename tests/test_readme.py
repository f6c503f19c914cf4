"""Every command in README.md runs as written.

The commands come from README's ```bash blocks, in README order (later commands use the run
directories of earlier ones). Each runs through the installed ``hisopt`` in a fresh process,
from a scratch directory that links the repository's ``problems/`` and ``examples/``, so
README's relative paths work and nothing is written into the checkout. Only the budgets are
cut (population, generations, grid points, refined designs, seeds, precharges; see BUDGETS),
so that the whole README runs in about a minute; everything else is verbatim.

A README line that is not a ``hisopt`` command must be listed in NOT_RUN with the reason it
is not run here, and a ``hisopt`` command that cannot run here in SKIP: a new README command
is thus either run or explained.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hisopt.coupled.modal import modal_analysis
from hisopt.io import read_csv
from hisopt.simulation.droptest import measured_drop_test
from tests.conftest import ROOT

README = ROOT / "README.md"
LINKED = ("problems", "examples")  # README's inputs, relative to the repository root

# Command-line lines of README that are not hisopt commands, by how they start.
NOT_RUN = {
    "python3 -m venv": "creates the environment these tests already run in",
    ". .venv/bin/activate": "activates that environment",
    "pip install": "installs hisopt (the tests run the installed copy)",
    "python -m hisopt.optim.warmup": "compiles the kernels ahead (tests/test_kernels_warmup.py runs it in a fresh cache)",
    "python -m pytest": "runs this test suite",
    "python benchmarks/": "a benchmark (minutes); benchmarks/ compares against its own baselines",
    "python examples/rv_range.py": "an example script; tests/test_damper_valve.py checks the figures README quotes from it",
    "dask scheduler": "starts a Dask scheduler on host A of a multi-machine cluster",
    "dask worker": "starts Dask workers on other hosts",
}
# hisopt commands that cannot run on one machine without a network.
SKIP = {
    "--scheduler tcp://hostA:8786": "needs the multi-machine Dask cluster of the two lines before it",
}
# Option values that keep each command to seconds: {command: {option: value}}.
BUDGETS = {
    "optimize": {"--pop": "8", "--gens": "2"},
    "study": {"--pop": "8", "--gens": "2", "--seeds": "1-2"},
    "compare-layouts": {"--pop": "8", "--gens": "2", "--seeds": "1"},
    "synthesize": {"--pop": "8", "--gens": "2", "--seeds": "1", "--max-elements": "4", "--optimise": "1"},
    "refine": {"--max-points": "2"},
    "sweep": {"--points": "3"},
    "regions": {"--points": "3"},
    "droptest": {"--p0": "2e6"},  # one precharge: three drop simulations, not nine
    "sensitivity": {"--samples": "64"},
    "tolerance": {"--samples": "2000"},
    "verify": {"--realisations": "2"},
}
REFINE_BUDGET = {"--max-points": "2"}  # optimize --refine


def readme_command_lines(text: str) -> list[str]:
    """Command lines of the ```bash blocks, comments dropped, ``a && b`` split into two."""
    lines = []
    for block in re.findall(r"^```(?:bash|sh|console)\n(.*?)^```", text, flags=re.S | re.M):
        for line in block.splitlines():
            words = shlex.split(line.removeprefix("$ "), comments=True)
            lines += [part.strip() for part in shlex.join(words).split(" '&&' ")] if words else []
    return [line for line in lines if line]


def with_budget(words: list[str]) -> list[str]:
    """``hisopt CMD ...`` with the BUDGETS options set (replaced or added)."""
    budget = dict(BUDGETS.get(words[1], {}))
    if words[1] == "optimize" and "--refine" in words:
        budget |= REFINE_BUDGET
    out = list(words)
    for option, value in budget.items():
        if option in out:
            out[out.index(option) + 1] = value
        else:
            out += [option, value]
    return out


def plan(text: str) -> tuple[list[list[str]], list[tuple[str, str]]]:
    """The hisopt commands to run (budgets applied) and the lines not run, with reasons."""
    runs: list[list[str]] = []
    not_run: list[tuple[str, str]] = []
    seen: set[str] = set()
    for line in readme_command_lines(text):
        if not line.startswith("hisopt "):
            reason = next((r for start, r in NOT_RUN.items() if line.startswith(start)), None)
            assert reason is not None, f"README line {line!r} is neither a hisopt command nor listed in NOT_RUN"
            not_run.append((line, reason))
        elif any(key in line for key in SKIP):
            not_run.append((line, next(r for key, r in SKIP.items() if key in line)))
        elif line in seen:  # the set-up line's optimize, repeated in Quick start
            not_run.append((line, "same as an earlier README command"))
        else:
            seen.add(line)
            runs.append(with_budget(shlex.split(line)))
    return runs, not_run


def hisopt_executable() -> list[str]:
    script = Path(sys.executable).with_name("hisopt")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "hisopt"]


def test_plan_covers_the_readme():
    runs, not_run = plan(README.read_text(encoding="utf-8"))
    commands = {words[1] for words in runs}
    assert {"optimize", "resume", "report", "modes", "evaluate", "response", "sweep", "regions", "refine",
            "droptest", "study", "init", "sensitivity", "tolerance"} <= commands  # fmt: skip
    assert any("--measured" in words for words in runs) and any("--designs" in words for words in runs)
    assert all(reason for _, reason in not_run)
    assert with_budget(["hisopt", "sweep", "p.toml", "--points", "41"])[-2:] == ["--points", "3"]
    assert with_budget(["hisopt", "optimize", "p.toml", "--refine"]) == [
        "hisopt", "optimize", "p.toml", "--refine", "--pop", "8", "--gens", "2", "--max-points", "2"]  # fmt: skip


@pytest.mark.slow  # every command of the README, about 3 min
def test_every_readme_command_runs_as_written(tmp_path):
    for name in LINKED:
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    runs, _ = plan(README.read_text(encoding="utf-8"))
    for words in runs:
        done = subprocess.run([*hisopt_executable(), *words[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, f"`{shlex.join(words)}` exited {done.returncode}:\n{done.stderr[-3000:]}"
    assert (tmp_path / "runs" / "paper" / "report.html").is_file()
    assert len(read_csv(tmp_path / "results.csv")) == len(read_csv(ROOT / "examples" / "designs.csv"))
    table = read_csv(tmp_path / "dt" / "droptest.csv")
    assert (table["case"] == "left_side").sum() == 1


# --- the example files ---------------------------------------------------------------------


def test_example_designs_lie_in_the_box_and_start_with_the_reference_designs(problem):
    designs = read_csv(ROOT / "examples" / "designs.csv")
    assert list(designs.columns) == list(problem.variable_names)
    assert designs.attrs["units"] == {"p0": "Pa", "dA": "m^2", "lam": "-", "Rv": "Pa s m^-3"}
    x = designs.to_numpy(dtype=float)
    assert np.all(x >= problem.lower) and np.all(x <= problem.upper)
    np.testing.assert_array_equal(x[:2], [[2.0e6, 10e-4, 0.5, 8e5], [0.0, 1e-4, 0.1, 0.0]])  # docs/model.md §7.1


def test_measured_example_is_labelled_synthetic_and_reproducible(tmp_path):
    """The script in its docstring remakes the file; the header says what it is."""
    example = ROOT / "examples" / "left_side_drop_measured.csv"
    header = [line for line in example.read_text(encoding="utf-8").splitlines() if line.startswith("#")]
    assert "SYNTHETIC" in header[0] and "NOT a measurement" in header[0]
    remade = tmp_path / "remade.csv"
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "make_measured_example.py"), str(remade)],
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    old, new = (read_csv(path, comment="#") for path in (example, remade))
    assert list(old.columns) == list(new.columns)
    peak = np.abs(old.drop(columns="time").to_numpy()).max()
    np.testing.assert_allclose(new.to_numpy(), old.to_numpy(), rtol=0, atol=1e-5 * peak)


def test_measured_example_gives_the_model_roll_frequency(problem):
    """2 % noise: the identified roll frequency is the model's damped one within 0.5 %
    (docs/droptest.md), and not exactly it (it is the noisy record's)."""
    test = measured_drop_test(problem, ROOT / "examples" / "left_side_drop_measured.csv", "left_side", 2e6)
    modes = modal_analysis(problem.with_values(p0=2e6))
    roll = modes.loc[modes["mode"] == "roll", "damped_frequency_hz"].item()
    assert test.identified.frequency_hz == pytest.approx(roll, rel=5e-3)
    assert test.identified.frequency_hz != pytest.approx(roll, rel=1e-6)


def test_readme_lists_the_example_files():
    text = README.read_text(encoding="utf-8")
    shipped = sorted(p.name for p in (ROOT / "examples").iterdir() if p.suffix == ".csv")
    assert shipped == ["designs.csv", "left_side_drop_measured.csv"]
    assert all(f"`{name}`" in text and f"examples/{name}" in text for name in shipped)
