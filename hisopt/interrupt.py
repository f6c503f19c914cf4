"""Ctrl-C and SIGTERM as one resumable interruption; signals deferred during final writes.

Batch schedulers, ``timeout`` and ``kill`` send SIGTERM; a terminal sends SIGINT. During a
run both raise :class:`Interrupted` (a ``KeyboardInterrupt``) in the main thread, so the run
engine saves its checkpoint, records the status and the CLI exits with ``128 + signal``
(130 for SIGINT, 143 for SIGTERM). Inside :func:`deferred` a signal waits until the block
ends, so that a short final write is never cut in two.

Test hook (inert unless set): ``HISOPT_TEST_SIGNAL_AT=POINT:ACTION`` makes the run engine act
at a named point, so interrupt tests hit the same point every time. POINT is
``generation-N`` (while generation N is computed, after checkpoint N-1) or ``final-write``
(after ``front.csv`` of the final outputs is written, before the other files and the status);
ACTION is ``INT``, ``TERM`` or ``KILL`` (the signal sent to this process) or ``FAIL`` (an
exception, as a crash). Each point acts once per process.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
from types import FrameType

TEST_HOOK_ENV = "HISOPT_TEST_SIGNAL_AT"
HANDLED = (signal.SIGINT, signal.SIGTERM)

_state: dict[str, object] = {"defer": 0, "pending": None, "fired": set()}


class Interrupted(KeyboardInterrupt):
    """A run was interrupted by a signal (SIGINT or SIGTERM).

    Attributes
    ----------
    signum : int
        [-] the signal number
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def name(self) -> str:
        """``"SIGINT"`` or ``"SIGTERM"``."""
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """[-] The shell's code for death by this signal: ``128 + signum``."""
        return 128 + self.signum


def exit_code(exc: BaseException) -> int:
    """[-] Exit code for an interruption: ``128 + signum``; 130 for a plain KeyboardInterrupt."""
    return exc.exit_code if isinstance(exc, Interrupted) else 128 + signal.SIGINT


def as_interrupt(exc: BaseException) -> KeyboardInterrupt | None:
    """The interruption ``exc`` is or carries, else None. A signal whose handler raises while a
    compiled (numba) function's dispatcher returns comes out as ``SystemError: ... returned a
    result with an exception set``, the interruption chained as its cause."""
    seen: BaseException | None = exc
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            return seen
        seen = seen.__cause__ or seen.__context__
    return None


def signal_name(exc: BaseException) -> str:
    """``"SIGTERM"``, ``"SIGINT"`` (also for a plain KeyboardInterrupt)."""
    return exc.name if isinstance(exc, Interrupted) else "SIGINT"


def _handler(signum: int, frame: FrameType | None) -> None:
    if int(_state["defer"]) > 0:  # type: ignore[call-overload]
        _state["pending"] = signum
        return
    raise Interrupted(signum)


@contextlib.contextmanager
def signals_as_interrupts() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Interrupted` (main thread only;
    a signal the process ignores stays ignored). The previous handlers come back after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}
    for sig in HANDLED:
        current = signal.getsignal(sig)
        if current is signal.SIG_IGN:
            continue
        previous[sig] = current
        signal.signal(sig, _handler)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT/SIGTERM until the block ends, then raise :class:`Interrupted` for the last
    one that arrived (only where :func:`signals_as_interrupts` is active)."""
    _state["defer"] = int(_state["defer"]) + 1  # type: ignore[call-overload]
    pending = None
    try:
        yield
    finally:
        _state["defer"] = int(_state["defer"]) - 1  # type: ignore[call-overload]
        if _state["defer"] == 0:  # cleared even when the block raised, so it never fires later
            pending, _state["pending"] = _state["pending"], None
    if pending is not None:
        raise Interrupted(int(pending))  # type: ignore[call-overload]


def hook_point(point: str) -> None:
    """Act at ``point`` if ``HISOPT_TEST_SIGNAL_AT`` names it (module docstring); else nothing."""
    spec = os.environ.get(TEST_HOOK_ENV)
    if not spec:
        return
    where, _, action = spec.rpartition(":")
    fired: set[str] = _state["fired"]  # type: ignore[assignment]
    if where != point or point in fired:
        return
    fired.add(point)
    if action == "FAIL":
        raise RuntimeError(f"simulated crash at {point} ({TEST_HOOK_ENV})")
    os.kill(os.getpid(), getattr(signal, f"SIG{action}"))
