"""Command line: ``hisopt modes|evaluate|response|optimize|resume|...`` (typer).

The app, its global options and :func:`run` (what :func:`hisopt.cli.main`, the entry point, runs). The commands live by concept in
:mod:`~hisopt.cli.model_commands`, :mod:`~hisopt.cli.run_commands`,
:mod:`~hisopt.cli.study_commands` and :mod:`~hisopt.cli.compare`.
User mistakes exit with code 2 and one line on stderr; internal errors exit 1; ``--debug``
shows tracebacks.
"""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from hisopt.cli import compare, model_commands, run_commands, study_commands, synthesis_commands, uncertainty_commands, verify_commands
from hisopt.cli.options import DEBUG
from hisopt.cli.signals import install_signal_handlers

# Plain help (no rich markup: "[his]" is text, not a style tag); -h is short for --help.
app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
    help="Design optimiser for hydraulically interconnected suspensions (HIS): layouts, load cases, Pareto fronts. Start with `hisopt init problem.toml`.",
)


def _show_version(value: bool) -> None:
    if value:
        from hisopt.version import __version__

        typer.echo(f"hisopt {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="show tracebacks of internal errors")] = False,
    version: Annotated[bool, typer.Option("--version", callback=_show_version, is_eager=True, help="print the version and exit")] = False,
) -> None:
    DEBUG["on"] = debug


# In the order `hisopt --help` lists them.
for _commands in (model_commands, run_commands, study_commands, compare, synthesis_commands, uncertainty_commands, verify_commands):
    _commands.register(app)


def run() -> None:
    """Run the command line (:func:`hisopt.cli.main`): install the signal handlers, map user
    errors to exit code 2 and internal errors to 1; print each implausible value's warning as
    one line and go on."""
    install_signal_handlers()  # first: the commands import the numerical stack when they run
    from hisopt.cli.usage import one_line_warnings

    with one_line_warnings():
        _main_command()


def _main_command() -> None:
    from hisopt.cli.usage import usage_error_line
    from hisopt.errors import HisoptError

    args = sys.argv[1:]
    if all(arg == "--debug" for arg in args):  # bare `hisopt`: the help, exit 0
        args = [*args, "--help"]
    try:
        code = app(args=args, prog_name="hisopt", standalone_mode=False)  # click returns a typer.Exit code here
    except HisoptError as exc:
        if DEBUG["on"]:
            raise
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except (typer.Exit, SystemExit) as exc:
        code = getattr(exc, "exit_code", getattr(exc, "code", 0))
        sys.exit(code or 0)
    except typer.Abort:
        typer.echo("aborted", err=True)
        sys.exit(130)
    except Exception as exc:  # command-line usage errors come through here too
        line = usage_error_line(exc, args)  # by what they carry: their classes move between typer versions
        if line is not None:
            typer.echo(f"error: {line}", err=True)
            sys.exit(2)
        if DEBUG["on"]:
            raise
        typer.echo(f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)", err=True)
        sys.exit(1)
    if isinstance(code, int) and code:
        sys.exit(code)
