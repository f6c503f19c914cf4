"""``hisopt compare-layouts``: registered on :mod:`hisopt.cli.application`'s app by :func:`register`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, integer


def register(app: typer.Typer) -> None:
    """Add the ``compare-layouts`` command to ``app`` (:mod:`hisopt.cli.application`'s)."""

    @app.command("compare-layouts")
    def compare_layouts_cmd(
        problem: ProblemArg,
        out: Annotated[Path, typer.Option("--out", help="study directory: <layout>/seed-<n>/ runs, layouts.csv, report.html")],
        layouts: Annotated[
            str | None,
            typer.Option(
                metavar="A,B,...",
                help=(
                    "catalogue layouts, custom layouts' problem files and conventional (the car with anti-roll bars sized at the limit) "
                    "(default: the whole catalogue; roll_plane is always included)"
                ),
            ),
        ] = None,
        seeds: Annotated[str, typer.Option(metavar="SEEDS", help="seeds per layout, e.g. 1-3 or 1,3,5")] = "1-3",
        pop: Annotated[int | None, typer.Option(parser=integer, metavar="N", help="population size (default: problem file)")] = None,
        gens: Annotated[int | None, typer.Option(parser=integer, metavar="N", help="generations (default: problem file)")] = None,
        handling: Annotated[str | None, typer.Option(metavar="QUANTITY", help="quantity held equal (default roll_gradient)")] = None,
        handling_limit: Annotated[
            str | None,
            typer.Option(
                "--handling-limit",
                metavar="VALUE",
                help='its limit with its unit, e.g. "1.8 deg/g" (a bare number only where hisopt prints the quantity in SI; '
                "default: the roll-plane baseline design's value)",
            ),
        ] = None,
        workers: WorkersOpt = None,
        scheduler: SchedulerOpt = None,
    ) -> None:
        """Compare HIS layouts: ride comfort at equal handling.

        Every layout and seed is a resumable run in OUT/<layout>/seed-<n>/ (the same command
        resumes an interrupted study); writes OUT/layouts.csv and OUT/report.html
        (docs/model.md §15).
        """
        code = compare_layouts_command(problem, layouts, seeds, out, pop, gens, handling, handling_limit, workers, scheduler)
        if code:
            raise SystemExit(code)  # click returns (drops) a typer.Exit code in non-standalone mode


def compare_layouts_command(
    problem_path: Path,
    layouts: str | None,
    seeds: str,
    out: Path,
    pop: int | None,
    gens: int | None,
    handling: str | None,
    handling_limit: str | float | None,
    workers: int | None,
    scheduler: str | None,
) -> int:
    """Run the study, write its files and the report, print the table; the exit code.

    Ctrl-C or SIGTERM: the running runs save their checkpoints; the same command resumes.
    """
    from rich.console import Console

    import hisopt.interrupt as interrupt
    from hisopt.evaluation.parallel import open_backend
    from hisopt.problem import load_problem
    from hisopt.report.layout_report import write_layout_report
    from hisopt.studies.layout_study import check_arguments, read_study_record, run_layout_study, study_budget

    problem = load_problem(problem_path)
    limit = _handling_limit(problem, handling, handling_limit)
    check_arguments(problem, layouts, seeds, handling, limit)  # one line and exit 2 before any work
    from hisopt.folders import LAYOUT_STUDY, check_claim

    check_claim(out, LAYOUT_STUDY)  # a folder of another kind, or a user's, is refused
    read_study_record(out, problem, study_budget(problem, pop, gens))

    def progress(run: dict[str, Any]) -> None:
        typer.echo(f"{run['layout']} seed {run['seed']} done: {run['evaluations']} designs, {run['feasible_designs']} feasible", err=True)

    try:
        with interrupt.signals_as_interrupts(), open_backend(workers, scheduler) as backend:
            where = f"on {backend.n_workers} Dask workers" if backend.is_distributed else "one after the other"
            typer.echo(f"{problem.name}: layout study in {out}, runs {where}", err=True)
            result = run_layout_study(
                problem, layouts, seeds, out=out, pop_size=pop, generations=gens, handling=handling, handling_limit=limit, backend=backend, progress=progress
            )
    except KeyboardInterrupt as exc:
        print(
            f"interrupted by {interrupt.signal_name(exc)}; finished runs are kept and the others saved their "
            f"checkpoints. Resume with the same command (--out {out})",
            file=sys.stderr,
        )
        return interrupt.exit_code(exc)
    report = write_layout_report(result)
    Console(width=200).print(_table(result))
    for note in result.limit_notes():
        typer.echo(note)
    typer.echo(f"wrote {out / 'layouts.csv'}, {report} and {report.parent / 'decision.html'}")
    return 0


def _handling_limit(problem: Any, handling: str | None, text: str | float | None) -> float | None:
    """``--handling-limit`` in the SI unit of the handling quantity (``"1.8 deg/g"`` -> rad/g).

    A bare number is refused where hisopt prints the quantity in another unit than its SI
    one (a roll gradient in deg/g, not rad/g): the limit a study prints, pasted back without
    its unit, would be read 57 times too large. Where the two agree, a bare number is SI.
    """
    if text is None:
        return None
    from hisopt.errors import ConfigError
    from hisopt.quantities import split_quantity, to_si
    from hisopt.studies.layout_metrics import check_handling, default_handling_quantity
    from hisopt.units import column_unit, display_for

    name = check_handling(problem, handling or default_handling_quantity(problem))  # an unknown name first
    unit = column_unit(name) or "-"
    parts = split_quantity(str(text))
    if parts is not None and not parts[1]:
        shown = display_for(unit, float(parts[0])).unit
        if shown != unit:
            raise ConfigError(
                f"{str(text).strip()!r} has no unit, and hisopt prints {name} in {shown} while a bare number would be read in {unit} (SI); "
                f'expected the number with its unit: "{parts[0]} {shown}" or "{parts[0]} {unit}"',
                key="--handling-limit",
            )
    return to_si(text, unit, key="--handling-limit")


def study_report(out: Path, color_by: str | None, design: str) -> Path:
    """``hisopt report`` on a layout study's directory: its report written again from its files."""
    from hisopt.errors import ConfigError
    from hisopt.report.layout_report import write_layout_report
    from hisopt.studies.layout_folder import read_layout_study

    for given, name in ((color_by, "--color-by"), (None if design == "knee" else design, "--design")):
        if given is not None:
            raise ConfigError(f"a layout study's report takes no {name}; expected the study directory alone", key=name)
    return write_layout_report(read_layout_study(out))


def _table(result: Any) -> Any:
    """The headline columns of ``layouts.csv`` as a rich table (engineering units)."""
    from rich.console import Group
    from rich.table import Table
    from rich.text import Text

    from hisopt.units import display_frame, format_quantity

    columns = [
        "layout",
        "hv_mean",
        "hv_std",
        "hv_min",
        "hv_max",
        "vorobev_deviation",
        "sigma_aw_at_limit",
        "handling_at_best",
        "gain_vs_roll_plane_pct",
        "gain_vs_conventional_pct",
        "k_roll",
        "k_warp",
    ]
    shown = display_frame(result.table[[c for c in columns if c in result.table]]).replace("nan", "–")  # e.g. a layout without a design at the limit
    limit = format_quantity(result.handling_limit, result.table.attrs["units"]["handling_limit"])  # with its unit: pasted back as is
    table = Table(title=Text(f"Layouts at equal handling: {result.handling} <= {limit} (normalised hypervolume across seeds; gain in comfort over roll_plane)"))
    for col in shown.columns:
        table.add_column(Text(col.replace(" [", "\n[")), justify="left" if col.startswith("layout") else "right")
    for row in shown.itertuples(index=False):
        table.add_row(*[Text(v) for v in row])
    return Group(table, verdict_table(result.table, "layout", "Buildability of each layout's design at the limit (every rule, docs/model.md §21)"))


def verdict_table(frame: Any, key: str, title: str) -> Any:
    """``key`` and the buildability verdict's columns of ``frame`` as a rich table of their own
    (engineering units), beside a wide ranking."""
    from rich.table import Table
    from rich.text import Text

    from hisopt.studies.buildability import VERDICT_COLUMNS
    from hisopt.units import display_frame

    shown = display_frame(frame[[c for c in (key, *VERDICT_COLUMNS) if c in frame]]).replace("nan", "–")
    table = Table(title=Text(title))
    for col in shown.columns:
        table.add_column(Text(col.replace(" [", "\n[")), justify="left" if col.startswith((key, "binding_rule")) else "right", no_wrap=True)
    for row in shown.itertuples(index=False):
        table.add_row(*[Text(str(v)) for v in row])
    return table
