"""Command line: ``hisopt modes|evaluate|response|optimize|resume|...`` (typer).

User mistakes exit with code 2 and one line on stderr; internal errors exit 1; ``--debug``
shows tracebacks.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Design optimiser for roll-plane HIS vehicles.")

ProblemArg = Annotated[Path, typer.Argument(help="problem file (TOML), e.g. problems/roll_plane_his.toml")]
SetOpt = Annotated[
    Optional[list[str]], typer.Option("--set", help="override a [his] value, e.g. --set p0=3e6 (repeatable)")
]

_DEBUG = {"on": False}


@app.callback()
def _main(debug: Annotated[bool, typer.Option("--debug", help="show tracebacks")] = False) -> None:
    _DEBUG["on"] = debug


def parse_assignments(items: list[str] | None) -> dict[str, float | str]:
    """``["p0=3e6", "pipe_model=distributed"]`` -> ``{"p0": 3e6, "pipe_model": "distributed"}``."""
    from hisopt.errors import ConfigError

    out: dict[str, float | str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"expected KEY=VALUE, got {item!r}", key="--set")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            out[key.strip()] = value.strip()
    return out


def load(problem: Path, sets: list[str] | None):
    """Load a problem file and apply ``--set`` overrides."""
    from hisopt.problem import load_problem

    p = load_problem(problem)
    overrides = parse_assignments(sets)
    return p.with_values(**overrides) if overrides else p


@app.command()
def modes(problem: ProblemArg, set_: SetOpt = None) -> None:
    """Modal table without and with HIS (paper Table 1): frequency, damping, dominant motion."""
    from rich.console import Console
    from rich.table import Table

    from hisopt.modal import modal_analysis

    p = load(problem, set_)
    ref = modal_analysis(p, his=False)
    his = modal_analysis(p)
    design = ", ".join(f"{n}={v:.4g}" for n, v in zip(p.variable_names, p.baseline))
    table = Table(title=f"Modes of {p.name} without and with HIS ({design})")
    for col in ("mode", "motion", "f ref [Hz]", "zeta ref", "f HIS [Hz]", "zeta HIS", "change"):
        table.add_column(col, justify="left" if col in ("mode", "motion") else "right")
    merged = his.merge(ref, on="mode", how="left", suffixes=("", "_ref"))
    for row in merged.itertuples():
        change = f"{100 * (row.frequency_hz / row.frequency_hz_ref - 1):+.1f} %" if row.frequency_hz_ref == row.frequency_hz_ref else ""
        table.add_row(
            row.mode,
            row.motion,
            f"{row.frequency_hz_ref:.3f}",
            f"{row.damping_ratio_ref:.3f}",
            f"{row.frequency_hz:.3f}",
            f"{row.damping_ratio:.4f}",
            change,
        )
    Console(width=120).print(table)


def main() -> None:
    """Entry point: map user errors to exit code 2 and internal errors to 1."""
    from hisopt.errors import HisoptError

    try:
        app(standalone_mode=False)
    except HisoptError as exc:
        if _DEBUG["on"]:
            raise
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except (typer.Exit, SystemExit) as exc:
        code = getattr(exc, "exit_code", getattr(exc, "code", 0))
        sys.exit(code or 0)
    except Exception as exc:  # click usage errors come through here too
        import click

        if isinstance(exc, click.exceptions.ClickException):
            exc.show()
            sys.exit(2)
        if isinstance(exc, click.exceptions.Abort):
            typer.echo("aborted", err=True)
            sys.exit(130)
        if _DEBUG["on"]:
            raise
        typer.echo(f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)", err=True)
        sys.exit(1)
