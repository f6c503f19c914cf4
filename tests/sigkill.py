"""Killing a hisopt process at a checkpoint, for the tests that resume it (one helper for the
run, layout-study and synthesis tests)."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from hisopt.optim import rundir
from tests.conftest import ROOT


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


def kill_process_at_generation(proc: subprocess.Popen, run_dir: Path, generation: int, timeout: float = 120.0) -> int:
    """SIGKILL the running ``proc`` once the run in ``run_dir`` has checkpointed ``generation``;
    asserts it died of the kill and returns the generation it had checkpointed."""
    try:
        killed_at = wait_for_generation(proc, run_dir, generation, timeout)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        if proc.poll() is None:
            proc.kill()  # ours, by its id: after the SIGKILL above or a failed wait
        proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    return killed_at


def kill_at_generation(command: list[str], run_dir: Path, generation: int, timeout: float) -> None:
    """Run ``command`` (from the repository's root) and SIGKILL it once the run in ``run_dir``
    has checkpointed ``generation``; asserts it died of the kill."""
    proc = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    kill_process_at_generation(proc, run_dir, generation, timeout)
