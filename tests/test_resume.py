"""Interrupted runs in real processes: SIGKILL and Ctrl-C (SIGINT), then `hisopt resume`.

The resumed run must end with the byte-identical front.csv (and the same evaluations) as an
uninterrupted run with the same seed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from hisopt.optim import rundir
from tests.conftest import DEFAULT_PROBLEM, ROOT

HANDLING_PROBLEM = ROOT / "problems" / "roll_plane_his_handling.toml"
ARGS = ("--pop", "24", "--gens", "30", "--seed", "11")
POP, GENERATIONS = 24, 30
pytestmark = pytest.mark.slow  # real processes, about 30 s together


def _default_sigint() -> None:
    # A shell without job control starts background jobs (and so this test run) with SIGINT
    # ignored, which children inherit; a terminal's Ctrl-C reaches a foreground process.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "hisopt", *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
    )


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hisopt", *args], cwd=ROOT, capture_output=True, text=True, timeout=300)


def wait_for_generation(proc: subprocess.Popen, run_dir: Path, generation: int, timeout: float = 120.0) -> int:
    """Poll the checkpoint until it reports ``generation`` (or more); the process must still run."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"run ended before generation {generation}: {proc.stderr.read() if proc.stderr else ''}"
        done = rundir.checkpoint_generation(run_dir) if (run_dir / rundir.CHECKPOINT).exists() else 0
        if done >= generation:
            return done
        time.sleep(0.005)
    pytest.fail(f"no checkpoint for generation {generation} within {timeout} s")


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
    proc = start("optimize", str(path), "--out", str(run_dir), *ARGS)
    try:
        killed_at = wait_for_generation(proc, run_dir, 8)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        if proc.poll() is None:
            proc.kill()  # ours, by its id: after the SIGKILL above or a failed wait
        proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
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
