"""Every interruption is resumable: SIGINT, SIGTERM and SIGKILL at three points of a real run,
and crashes, each followed by ``hisopt resume``.

The points are hit deterministically with the run engine's test hook
(``HISOPT_TEST_SIGNAL_AT``, see :mod:`hisopt.interrupt`): ``generation-1`` (before the first
checkpoint), ``generation-4`` (mid-run) and ``final-write`` (``front.csv`` written, the other
files and the status not yet). The interrupted runs are real processes; the resumes run the
CLI entry point in this process. Every resumed run must end with the byte-identical
``front.csv`` and the same evaluations as the uninterrupted run.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from hisopt.interrupt import TEST_HOOK_ENV
from hisopt.optim import rundir
from hisopt.optim.run import CHECKPOINT_INTERVAL_ENV
from hisopt.optim.runstate import read_state
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

POP, GENERATIONS = 12, 8
ARGS = ("--pop", str(POP), "--gens", str(GENERATIONS), "--seed", "5")
pytestmark = pytest.mark.slow  # real processes, about 30 s together


def _default_sigint() -> None:
    # A shell without job control starts background jobs with SIGINT ignored (inherited).
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def optimize(run_dir: Path, hook: str | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ) | {CHECKPOINT_INTERVAL_ENV: "0"}  # a checkpoint per generation: kills land at known points
    env.pop(TEST_HOOK_ENV, None)
    if hook:
        env[TEST_HOOK_ENV] = hook
    return subprocess.run(
        [sys.executable, "-m", "hisopt", "optimize", str(DEFAULT_PROBLEM), "--out", str(run_dir), *ARGS],
        check=False,
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=_default_sigint,
    )


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    run_dir = tmp_path_factory.mktemp("reference") / "run"
    proc = optimize(run_dir)
    assert proc.returncode == 0, proc.stderr
    return run_dir


def assert_same_run(run_dir: Path, reference: Path) -> None:
    assert (run_dir / rundir.FRONT_CSV).read_bytes() == (reference / rundir.FRONT_CSV).read_bytes()
    a, b = pd.read_parquet(run_dir / rundir.EVALUATIONS), pd.read_parquet(reference / rundir.EVALUATIONS)
    assert a.equals(b) and len(a) == POP * GENERATIONS
    assert read_state(run_dir).status == "finished"


EXPECTED_CODE = {"INT": 130, "TERM": 143, "KILL": -signal.SIGKILL}


@pytest.mark.parametrize("point", ["generation-1", "generation-4", "final-write"])
@pytest.mark.parametrize("sig", ["INT", "TERM", "KILL"])
def test_interrupt_then_resume_gives_the_identical_front(tmp_path, reference, sig, point):
    run_dir = tmp_path / "run"
    proc = optimize(run_dir, f"{point}:{sig}")
    assert proc.returncode == EXPECTED_CODE[sig], proc.stderr
    assert "Traceback" not in proc.stderr
    state = read_state(run_dir)
    saved = {"generation-1": 0, "generation-4": 3, "final-write": GENERATIONS}[point]
    assert state.generation == saved
    last = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ""
    if sig == "KILL":
        assert state.status == "killed" and "hisopt resume" in state.line()
    elif point == "final-write":  # the signal waited for the final write: the run is complete
        assert state.status == "finished"
        assert last == f"SIG{sig} arrived during the final write, which completed: the run is finished ({run_dir / 'front.csv'})"
    else:
        assert state.status == "interrupted"
        assert last == (f"interrupted by SIG{sig} after {saved} of {GENERATIONS} generations; checkpoint saved. Resume with: hisopt resume {run_dir}")
        refused = run_cli("optimize", DEFAULT_PROBLEM, "--out", run_dir, *ARGS)  # a new run may not overwrite it
        assert refused.code == 2 and len(refused.error_lines) == 1
        assert f"continue it with `hisopt resume {run_dir}`" in refused.stderr and "to start over" in refused.stderr
    resumed = run_cli("resume", run_dir)
    assert resumed.code == 0, resumed.stderr
    if state.status == "finished":
        expected = f"{run_dir}: finished, {GENERATIONS} of {GENERATIONS} generations; results in {run_dir / 'front.csv'}; nothing to resume"
        assert resumed.error_lines == [expected]
    assert_same_run(run_dir, reference)


def test_a_crash_is_recorded_and_a_repeated_crash_is_named(tmp_path, reference):
    run_dir = tmp_path / "run"
    proc = optimize(run_dir, "generation-3:FAIL")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith(f"internal error: {run_dir}: failed at generation 3 of {GENERATIONS} (RuntimeError: simulated crash")
    assert f"retry from generation 2 with `hisopt resume {run_dir}`" in last
    info = json.loads((run_dir / "run.json").read_text())
    assert info["status"] == "failed" and info["failure"]["generation"] == 3 and info["failure"]["time"]
    # the same crash again on resume: said so, in one line
    os.environ[TEST_HOOK_ENV] = "generation-3:FAIL"
    try:
        from hisopt import interrupt

        interrupt._state["fired"] = set()
        again = run_cli("resume", run_dir)
    finally:
        del os.environ[TEST_HOOK_ENV]
    assert again.code == 1
    assert again.error_lines[-1].startswith(f"internal error: {run_dir}: failed at generation 3 of {GENERATIONS} again")
    assert "resuming will not get past it" in again.error_lines[-1]
    assert "again" in run_cli("status", run_dir).stdout
    # once the cause is gone, resume reaches the uninterrupted front
    resumed = run_cli("resume", run_dir)
    assert resumed.code == 0, resumed.stderr
    assert_same_run(run_dir, reference)
    assert "failure" not in json.loads((run_dir / "run.json").read_text())


def test_resume_refuses_a_run_that_is_still_running(tmp_path, reference):
    run_dir = tmp_path / "run"
    proc = optimize(run_dir, "generation-2:KILL")
    assert proc.returncode == -signal.SIGKILL
    info = json.loads((run_dir / "run.json").read_text())
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        from hisopt.optim.runstate import _start_time, process_identity

        info["process"] = process_identity() | {"pid": sleeper.pid, "start": _start_time(sleeper.pid)}
        (run_dir / "run.json").write_text(json.dumps(info))
        out = run_cli("resume", run_dir)
        assert out.code == 2 and len(out.error_lines) == 1
        assert f"running in process {sleeper.pid}" in out.stderr and f"kill -TERM {sleeper.pid}" in out.stderr
    finally:
        sleeper.kill()  # ours, by its id
        sleeper.wait()
    assert read_state(run_dir).status == "killed"
    assert run_cli("resume", run_dir).code == 0
    assert_same_run(run_dir, reference)


def test_interrupted_before_the_first_generation_says_to_start_again(tmp_path):
    from hisopt.interrupt import Interrupted
    from hisopt.optim.runstate import interrupted_line

    (tmp_path / "problem.toml").write_text("")  # the run directory as optimize leaves it that early
    line = interrupted_line(tmp_path, Interrupted(signal.SIGINT))
    assert "nothing to resume" in line and f"hisopt optimize PROBLEM --out {tmp_path}" in line and "hisopt resume" not in line


def _wait_for_handlers(pid: int, timeout_s: float = 60.0) -> None:
    """Until process ``pid`` catches SIGTERM (Linux ``/proc``): the command line's handlers
    are in (Python itself catches SIGINT from its start, never SIGTERM), so what follows
    does not depend on how fast a loaded machine starts Python."""
    import time

    status = Path(f"/proc/{pid}/status")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        caught = next((line.split()[1] for line in status.read_text().splitlines() if line.startswith("SigCgt:")), "0")
        if int(caught, 16) >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.005)
    raise AssertionError(f"process {pid} did not install its signal handlers within {timeout_s} s")


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads the signal mask from Linux's /proc")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("delay_s", [0.0, 0.3, 1.2])
def test_a_signal_outside_a_run_is_one_line_not_a_traceback(tmp_path, sig, delay_s):
    """Ctrl-C or SIGTERM while a command without a run directory imports the numerical stack
    or works (here a large feasible region): one line naming the signal, exit 128 + signal.
    A plain KeyboardInterrupt failed this at some instants: swallowed by importlib (exit 0) or
    turned by CPython into death by SIGINT (exit -2), so the signal lands at several, counted
    from the moment the handlers are in."""
    cmd = [sys.executable, "-m", "hisopt", "regions", str(DEFAULT_PROBLEM), "--pair", "p0,dA", "--points", "300", "--out", str(tmp_path)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    import time

    _wait_for_handlers(proc.pid)
    time.sleep(delay_s)  # the numerical stack imports for about 0.3-1 s; the 90,000 designs take several
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    lines = [line for line in err.splitlines() if line.strip()]
    assert proc.returncode == 128 + sig, err
    assert len(lines) == 1 and signal.Signals(sig).name in lines[0] and "Traceback" not in err


def test_a_signal_raised_inside_a_compiled_kernels_dispatch_is_still_the_interruption():
    """A signal whose handler raises while a numba dispatcher returns comes out as a
    SystemError carrying the interruption (seen under load in CI): the run engine treats it
    as the interruption; a SystemError of its own stays a failure."""
    from hisopt import interrupt

    try:
        try:
            raise interrupt.Interrupted(signal.SIGTERM)
        except KeyboardInterrupt as inner:
            raise SystemError("CPUDispatcher(<function lay_nodes>) returned a result with an exception set") from inner
    except SystemError as outer:
        found = interrupt.as_interrupt(outer)
    assert isinstance(found, interrupt.Interrupted) and found.exit_code == 143
    assert interrupt.as_interrupt(SystemError("a failure of its own")) is None
