"""The command line's signal handlers (standard library only: installed before anything heavy
is imported, so a Ctrl-C or SIGTERM while the libraries load is one line, not a traceback)."""

from __future__ import annotations

import os
import signal

INTERRUPTED: list[bool] = []
"""Set by Ctrl-C outside a run: whether a command reported it (runs and savers do)."""


def _quit_now(signum: int, frame: object) -> None:
    """Ctrl-C or SIGTERM while importing, or SIGTERM in a command with nothing to save: one
    line and the shell's exit code, not a traceback (runs install their own handlers, which
    save a checkpoint first; files are written atomically, so none is left half written)."""
    os.write(2, f"interrupted by {signal.Signals(signum).name}\n".encode())
    os._exit(128 + signum)


def _keyboard_interrupt(signum: int, frame: object) -> None:
    INTERRUPTED.append(False)
    raise KeyboardInterrupt


def quit_on_signals() -> None:
    """While the command line loads: Ctrl-C and SIGTERM end it with one line (nothing to save yet)."""
    signal.signal(signal.SIGINT, _quit_now)
    signal.signal(signal.SIGTERM, _quit_now)


def install_signal_handlers() -> None:
    """The handlers of a running command, installed by :func:`hisopt.cli.main` (never on
    import: a library that imports :mod:`hisopt.cli` keeps its own). Ctrl-C is a
    KeyboardInterrupt (commands that save work catch it and say so; typer turns the others
    into a silent exit 130, named by the entry point); SIGTERM is a quiet exit until a run
    installs its own handler (:mod:`hisopt.interrupt`)."""
    signal.signal(signal.SIGINT, _keyboard_interrupt)
    signal.signal(signal.SIGTERM, _quit_now)
