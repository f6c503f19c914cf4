"""Run the real CLI entry point (``hisopt.cli.main``) in this process and capture its output.

In-process runs are fast enough for hundreds of property-based examples; pytest's
warnings-as-errors then also turns any stray RuntimeWarning into a failure (exit 1).
"""

from __future__ import annotations

import contextlib
import io
import signal
import sys
from dataclasses import dataclass
from unittest import mock


@dataclass
class Outcome:
    code: int
    stdout: str
    stderr: str

    @property
    def error_lines(self) -> list[str]:
        return [line for line in self.stderr.splitlines() if line.strip()]


def run_cli(*args: str) -> Outcome:
    """``hisopt ARGS`` through :func:`hisopt.cli.main`: exit code, stdout and stderr.

    The signal handlers the CLI installs (on import and in ``main``) are put back afterwards, so
    that a later test in this process sees Python's own.
    """
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    out, err = io.StringIO(), io.StringIO()
    code = 0
    try:
        from hisopt.cli import main

        with mock.patch.object(sys, "argv", ["hisopt", *map(str, args)]), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                main()
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        for number, handler in handlers.items():
            signal.signal(number, handler)
    return Outcome(code, out.getvalue(), err.getvalue())


def assert_one_line(out: Outcome, *parts: str) -> str:
    """The one error line of a refused command (exit 2, no traceback), holding every one of ``parts``."""
    assert out.code == 2, out
    assert len(out.error_lines) == 1, out.stderr
    line = out.error_lines[0]
    assert line.startswith("error: ") and "Traceback" not in out.stderr
    for part in parts:
        assert part in line, line
    return line
