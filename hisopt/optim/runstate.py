"""What state a run directory is in, in one line that says what to do next.

``run.json`` is written when the first generation begins (a run killed before that leaves a
directory without it, which ``hisopt optimize --out`` may reuse) and records a ``status``:

- ``running``: a process is working on it (``process``: pid, host and start time);
- ``interrupted``: Ctrl-C (SIGINT) or SIGTERM stopped it after saving the checkpoint;
- ``failed``: an error stopped it (``failure``: time, generation, error; ``repeated`` when a
  resume failed again at the same generation with the same error);
- ``finished``: every generation is done and all files are written.

A process killed with SIGKILL (or a power cut) cannot update ``run.json``: its status stays
``running`` while the recorded process is gone (``starting``, which older runs may record,
is treated alike). :func:`read_state` reports such
a run as ``killed``. Every state but ``finished`` and a live ``running`` can be continued with
``hisopt resume``; starting over means another ``--out`` (or deleting the directory).
"""

from __future__ import annotations

import os
import socket
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from hisopt.errors import RunError
from hisopt.optim import rundir
from hisopt.optim.rundir import read_run_json

STARTING, RUNNING, INTERRUPTED, FAILED, FINISHED = "starting", "running", "interrupted", "failed", "finished"
KILLED = "killed"
"""Derived state: recorded as starting or running, but the recorded process is gone."""


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _start_time(pid: int) -> str | None:
    """The kernel's start time of process ``pid`` (Linux), to tell a reused pid apart."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rsplit(")", 1)[-1].split()[19]


def process_identity() -> dict[str, Any]:
    """This process as ``run.json`` records it: pid, host and start time."""
    return {"pid": os.getpid(), "host": socket.gethostname(), "start": _start_time(os.getpid())}


def process_alive(identity: dict[str, Any] | None) -> bool | None:
    """[-] Whether the recorded process still runs: True, False, or None (another host)."""
    if not identity or "pid" not in identity:
        return False
    if identity.get("host") != socket.gethostname():
        return None
    pid = int(identity["pid"])
    if pid == os.getpid():
        return False  # this process is not running the run any more, whatever run.json says
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # exists, another user's
    recorded, now = identity.get("start"), _start_time(pid)
    return recorded is None or now is None or recorded == now


@dataclass(frozen=True)
class RunState:
    """The state of a run directory (see the module docstring).

    Attributes
    ----------
    run_dir : Path
        [-] the directory
    status : str
        [-] recorded status, or ``killed``
    generation : int
        [-] generations saved in the checkpoint
    generations : int
        [-] generations of the whole run
    info : dict[str, Any]
        [-] the parsed ``run.json``
    alive : bool | None
        [-] whether the recorded process runs (None: recorded on another host)
    """

    run_dir: Path
    status: str
    generation: int
    generations: int
    info: dict[str, Any]
    alive: bool | None

    @property
    def resumable(self) -> bool:
        """[-] ``hisopt resume`` may continue it now."""
        return self.status not in (FINISHED,) and not (self.status in (STARTING, RUNNING) and self.alive)

    @property
    def failure(self) -> dict[str, Any]:
        """The recorded failure (empty unless ``failed``)."""
        return dict(self.info.get("failure") or {}) if self.status == FAILED else {}

    def line(self) -> str:
        """One line: the state, and what to do."""
        d, g, n = self.run_dir, self.generation, self.generations
        resume = f"continue it with `hisopt resume {d}`"
        proc = self.info.get("process") or {}
        if self.status == FINISHED:
            return f"{d}: finished, {g} of {n} generations; results in {d / rundir.FRONT_CSV}"
        if self.status in (STARTING, RUNNING) and self.alive:
            return f"{d}: {self.status} in process {proc.get('pid')}, {g} of {n} generations saved"
        if self.status in (STARTING, RUNNING) and self.alive is None:
            return (
                f"{d}: recorded as {self.status} on host {proc.get('host')} (process {proc.get('pid')}), {g} of {n} "
                f"generations saved; if it no longer runs there, {resume}"
            )
        if self.status == KILLED:
            return f"{d}: stopped without saving its status (killed, or the machine stopped) after {g} of {n} generations; {resume}"
        if self.status == INTERRUPTED:
            sessions = self.info.get("sessions") or [{}]
            by = sessions[-1].get("signal", "an interrupt")
            return f"{d}: interrupted by {by} after {g} of {n} generations; {resume}"
        if self.status == FAILED:
            f = self.failure
            at = f"at generation {f.get('generation', g + 1)} of {n}"
            if f.get("repeated"):
                return (
                    f"{d}: failed {at} again, with the same error as the session before ({f.get('error')}): resuming will "
                    f"not get past it; report it with {d / rundir.RUN_JSON}, or start over with another --out"
                )
            return f"{d}: failed {at} ({f.get('error', 'unknown error')}); retry from generation {g} with `hisopt resume {d}`, or start over with another --out"
        return f"{d}: status {self.status!r}, {g} of {n} generations saved"


def read_state(run_dir: str | Path) -> RunState:
    """The state of ``run_dir`` (see the module docstring).

    Raises
    ------
    RunError
        Not a run directory, or ``run.json`` or the checkpoint is unreadable.
    """
    run_dir = Path(run_dir)
    info = read_run_json(run_dir)
    status = str(info.get("status", STARTING))
    alive = process_alive(info.get("process"))
    if status in (STARTING, RUNNING) and alive is False:
        status = KILLED
    total = int((info.get("settings") or {}).get("generations", 0))
    return RunState(run_dir, status, rundir.checkpoint_generation(run_dir), total, info, alive)


def finished_run(run_dir: str | Path, what: str) -> RunState:
    """The state of ``run_dir`` when it is a finished run, else a :class:`RunError` of one
    line: the folder's state and what to do (``what`` names the caller, e.g.
    ``decision_room``, which needs every file of a finished run)."""
    rundir.run_record(Path(run_dir))
    state = read_state(run_dir)
    if state.status != FINISHED:
        raise RunError(f"{state.line()}; {what} takes a finished run")
    return state


def record_failure(info: dict[str, Any], session: dict[str, Any], exc: BaseException, generation: int) -> None:
    """Mark ``info`` failed at ``generation`` with ``exc``; ``repeated`` if the last failure
    was the same error at the same generation."""
    error = f"{type(exc).__name__}: {exc}"
    previous = info.get("failure") or {}
    repeated = previous.get("error") == error and previous.get("generation") == generation
    info["status"] = FAILED
    info["failure"] = {"time": _now(), "generation": generation, "error": error, "repeated": repeated}
    session |= {"ended": _now(), "status": FAILED, "error": error}


def state_line(run_dir: Path) -> str:
    """:meth:`RunState.line` of ``run_dir``, or why its state is unknown."""
    try:
        return read_state(run_dir).line()
    except (RunError, OSError, ValueError, KeyError) as exc:
        return f"{run_dir}: state unknown ({exc})"


def interrupted_line(run_dir: Path, exc: BaseException) -> str:
    """The CLI's line after Ctrl-C or SIGTERM: what was saved and how to resume."""
    from hisopt.interrupt import signal_name

    name = signal_name(exc)
    if not (Path(run_dir) / rundir.RUN_JSON).is_file():  # before the first generation began
        return f"interrupted by {name} before the first generation; nothing to resume. Start again with the same `hisopt optimize PROBLEM --out {run_dir}`"
    try:
        state = read_state(run_dir)
    except (RunError, OSError, ValueError, KeyError):
        return f"interrupted by {name}. Resume with: hisopt resume {run_dir}"
    if state.status == FINISHED:
        return f"{name} arrived during the final write, which completed: the run is finished ({run_dir / rundir.FRONT_CSV})"
    if state.status == INTERRUPTED:
        return f"interrupted by {name} after {state.generation} of {state.generations} generations; checkpoint saved. Resume with: hisopt resume {run_dir}"
    return f"interrupted by {name}; {state.line()}"


def refuse_occupied(run_dir: str | Path) -> None:
    """Raise :class:`RunError` if ``run_dir`` holds a run, saying what state it is in and how
    to continue it or start over (called before a new run claims ``--out``)."""
    run_dir = Path(run_dir)
    if not (run_dir / rundir.RUN_JSON).exists():
        return
    try:
        line = read_state(run_dir).line().removeprefix(f"{run_dir}: ")
    except RunError as exc:
        line = str(exc).removeprefix(f"{run_dir}: ")
    raise RunError(f"--out {run_dir} already holds a run: {line}; to start over choose another --out or delete {run_dir}")
