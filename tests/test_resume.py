"""Interrupted runs in real processes: SIGKILL and Ctrl-C (SIGINT), then `hisopt resume`.

The resumed run must end with the byte-identical front.csv (and the same evaluations) as an
uninterrupted run with the same seed. These runs last a second or two, so they checkpoint
after every generation (``HISOPT_CHECKPOINT_INTERVAL_S=0``) unless a test says otherwise.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hisopt.interrupt import TEST_HOOK_ENV
from hisopt.optim import rundir
from hisopt.optim.run import CHECKPOINT_INTERVAL_ENV
from tests.conftest import DEFAULT_PROBLEM, ROOT
from tests.sigkill import kill_process_at_generation, wait_for_generation

HANDLING_PROBLEM = ROOT / "problems" / "roll_plane_his_handling.toml"
ARGS = ("--pop", "24", "--gens", "30", "--seed", "11")
POP, GENERATIONS = 24, 30
pytestmark = pytest.mark.slow  # real processes, about 30 s together


def _default_sigint() -> None:
    # A shell without job control starts background jobs (and so this test run) with SIGINT
    # ignored, which children inherit; a terminal's Ctrl-C reaches a foreground process.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def env(**extra: str) -> dict[str, str]:
    return os.environ | {CHECKPOINT_INTERVAL_ENV: "0"} | extra


def start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "hisopt", *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
        env=env(),
    )


def run(*args: str, **extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hisopt", *args], cwd=ROOT, capture_output=True, text=True, timeout=300, env=env(**extra))


@pytest.fixture(scope="module")
def reference_runs(tmp_path_factory) -> dict[str, Path]:
    """Uninterrupted runs through the same command line, one per problem."""
    base = tmp_path_factory.mktemp("reference")
    out = {}
    for name, path in (("default", DEFAULT_PROBLEM), ("handling", HANDLING_PROBLEM)):
        result = run("optimize", str(path), "--out", str(base / name), *ARGS)
        assert result.returncode == 0, result.stderr
        out[name] = base / name
    return out


def assert_same_run(resumed: Path, reference: Path) -> None:
    assert (resumed / "front.csv").read_bytes() == (reference / "front.csv").read_bytes()
    a = pd.read_parquet(resumed / "evaluations.parquet")
    b = pd.read_parquet(reference / "evaluations.parquet")
    assert a.equals(b) and len(a) == POP * GENERATIONS


@pytest.mark.parametrize("name", ["default", "handling"])
def test_sigkill_then_resume_gives_identical_front(tmp_path, reference_runs, name):
    path = DEFAULT_PROBLEM if name == "default" else HANDLING_PROBLEM
    run_dir = tmp_path / "run"
    killed_at = kill_process_at_generation(start("optimize", str(path), "--out", str(run_dir), *ARGS), run_dir, 8)
    assert killed_at < GENERATIONS and not (run_dir / "front.csv").exists()
    resumed = run("resume", str(run_dir))
    assert resumed.returncode == 0, resumed.stderr
    assert "front size" in resumed.stdout
    assert_same_run(run_dir, reference_runs[name])


def test_ctrl_c_saves_checkpoint_prints_resume_command_and_resumes(tmp_path, reference_runs):
    run_dir = tmp_path / "run"
    proc = start("optimize", str(DEFAULT_PROBLEM), "--out", str(run_dir), *ARGS)
    try:
        wait_for_generation(proc, run_dir, 5)
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, stderr
    assert f"hisopt resume {run_dir}" in stderr and "Traceback" not in stderr
    saved = rundir.checkpoint_generation(run_dir)
    assert 5 <= saved < GENERATIONS
    assert (run_dir / "front.csv").exists()  # partial results are written too
    resumed = run("resume", str(run_dir))
    assert resumed.returncode == 0, resumed.stderr
    assert f"at generation {saved} of {GENERATIONS}" in resumed.stderr
    assert_same_run(run_dir, reference_runs["default"])


def test_sigkill_between_interval_checkpoints_resumes_identically(tmp_path, reference_runs):
    """A kill long after the last interval checkpoint: the generations since are lost and
    computed again, identically (the history chunks written before stay; none after)."""
    run_dir = tmp_path / "run"
    first = run("optimize", str(DEFAULT_PROBLEM), "--out", str(run_dir), *ARGS, **{TEST_HOOK_ENV: "generation-12:KILL"})
    assert first.returncode == -signal.SIGKILL
    assert rundir.checkpoint_generation(run_dir) == 11  # interval 0: checkpoints up to the one before the kill
    # a session whose interval never elapses: killed at generation 25, its checkpoint is still 11's
    second = run("resume", str(run_dir), **{TEST_HOOK_ENV: "generation-25:KILL", CHECKPOINT_INTERVAL_ENV: "1e9"})
    assert second.returncode == -signal.SIGKILL
    assert rundir.checkpoint_generation(run_dir) == 11 and not (run_dir / "front.csv").exists()
    meta, arrays = rundir.load_checkpoint(run_dir / rundir.CHECKPOINT)
    assert len(meta["history_chunks"]) == 11 and len(arrays["hist_x"]) == 11 * POP
    third = run("resume", str(run_dir), **{CHECKPOINT_INTERVAL_ENV: "1e9"})  # only the final checkpoint
    assert third.returncode == 0, third.stderr
    assert_same_run(run_dir, reference_runs["default"])
    meta, arrays = rundir.load_checkpoint(run_dir / rundir.CHECKPOINT)
    assert meta["generation"] == GENERATIONS and len(meta["history_chunks"]) == 12 and len(arrays["hist_x"]) == POP * GENERATIONS


def test_convergence_stop_is_deterministic_and_resumes_to_the_same_generation(tmp_path):
    """``until = "converged"`` stops at the same generation in two runs with one seed, and a run
    killed before that generation and resumed stops there too, with the same front."""
    problem = tmp_path / "converging.toml"  # the default problem; its [optimizer] table is last
    problem.write_text(DEFAULT_PROBLEM.read_text() + 'until = "converged"\ntolerance = 0.01\nwindow = 10\n')
    args = ("--pop", "24", "--gens", "200", "--seed", "11")
    ends = []
    for name in ("a", "b"):
        out = run("optimize", str(problem), "--out", str(tmp_path / name), *args)
        assert out.returncode == 0, out.stderr
        ends.append(json.loads((tmp_path / name / "run.json").read_text())["result"]["stop"])
    assert ends[0] == ends[1] and ends[0]["converged"] and ends[0]["converged_at_generation"] < 200
    stop = ends[0]["converged_at_generation"]
    assert "fired" in out.stdout and "Hypervolume history" in out.stdout
    generations = pd.read_csv(tmp_path / "a" / "generations.csv", skiprows=[1])
    assert len(generations) == stop
    hv = generations["hypervolume"].to_numpy()  # the rule, recomputed from the recorded history
    window, tolerance = ends[0]["window_generations"], ends[0]["tolerance"]
    gains = hv[window:] - hv[:-window]
    assert gains[-1] <= tolerance * hv[-1] and np.all(gains[:-1] > tolerance * hv[window:-1])
    killed = run("optimize", str(problem), "--out", str(tmp_path / "k"), *args, **{TEST_HOOK_ENV: f"generation-{stop - 3}:KILL"})
    assert killed.returncode == -signal.SIGKILL
    resumed = run("resume", str(tmp_path / "k"))
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((tmp_path / "k" / "run.json").read_text())["result"]["stop"] == ends[0]
    assert (tmp_path / "k" / "front.csv").read_bytes() == (tmp_path / "a" / "front.csv").read_bytes()
