"""The ``hisopt`` command line (typer): :func:`main` is the console script's entry point."""

from hisopt.cli.app import app, main

__all__ = ["app", "main"]
