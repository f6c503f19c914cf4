"""The command line's signal handlers (standard library only: installed before anything heavy
is imported, so a Ctrl-C or SIGTERM while the libraries load is one line, not a traceback)."""

from __future__ import annotations

import os
import signal


def _quit_now(signum: int, frame: object) -> None:
    """Ctrl-C or SIGTERM while importing, or SIGTERM in a command with nothing to save: one
    line and the shell's exit code, not a traceback (runs install their own handlers, which
    save a checkpoint first; files are written atomically, so none is left half written)."""
    os.write(2, f"interrupted by {signal.Signals(signum).name}\n".encode())
    os._exit(128 + signum)


def quit_on_signals() -> None:
    """While the command line loads: Ctrl-C and SIGTERM end it with one line (nothing to save yet)."""
    signal.signal(signal.SIGINT, _quit_now)
    signal.signal(signal.SIGTERM, _quit_now)


def install_signal_handlers() -> None:
    """The handlers of a running command, installed by :func:`hisopt.cli.main` (never on
    import: a library that imports :mod:`hisopt.cli` keeps its own). Ctrl-C and SIGTERM end a
    command with nothing to save at once, with one line; the commands that save work (runs,
    layout studies) install their own handlers while they work (:mod:`hisopt.interrupt`).

    Not a plain ``KeyboardInterrupt``: one raised while C code runs Python source (importlib's
    callbacks, ``PyRun_String``) is swallowed (the command goes on and exits 0) or sets
    CPython's "unhandled Ctrl-C" flag, after which ``python -m`` kills itself with SIGINT
    whatever exit code the command chose (seen as exit -2 in about 1 in 10 interrupts)."""
    quit_on_signals()
