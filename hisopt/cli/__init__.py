"""The ``hisopt`` command line (typer): :func:`main` is the console script's entry point and
``app`` the typer application (:mod:`hisopt.cli.application`)."""

from __future__ import annotations

from typing import Any

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of ``hisopt``: the signal handlers first, then the command line (importing
    it loads typer, and the commands load the numerical stack)."""
    from hisopt.cli.signals import quit_on_signals

    quit_on_signals()  # a Ctrl-C or SIGTERM while the libraries load: one line, exit 128 + n
    from hisopt.cli.application import run

    run()


def __getattr__(name: str) -> Any:
    if name == "app":  # the typer application, loaded when first asked for
        from hisopt.cli.application import app

        return app
    raise AttributeError(f"module 'hisopt.cli' has no attribute {name!r}")
