"""``hisopt synthesize``: registered on :mod:`hisopt.cli.application`'s app by :func:`register`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, integer


def synthesize_cmd(
    problem: ProblemArg,
    max_elements: Annotated[int, typer.Option("--max-elements", parser=integer, metavar="K", help="accumulators plus valves per layout, at most")],
    out: Annotated[Path, typer.Option("--out", help="directory: candidates.csv, layouts/, study/, layouts.csv, report.html")],
    chambers: Annotated[str, typer.Option(metavar="SET", help="chambers to interconnect: all, front (single-axle layouts) or rear")] = "all",
    asymmetric: Annotated[bool, typer.Option("--asymmetric", help="also layouts that are not their own left-right mirror image")] = False,
    seeds: Annotated[str, typer.Option(metavar="SEEDS", help="seeds per optimised layout, e.g. 1-3")] = "1-3",
    pop: Annotated[int | None, typer.Option(parser=integer, metavar="N", help="population size (default: problem file)")] = None,
    gens: Annotated[int | None, typer.Option(parser=integer, metavar="N", help="generations (default: problem file)")] = None,
    optimise: Annotated[
        int | None,
        typer.Option(
            "--optimise",
            parser=integer,
            metavar="N",
            help="the old top-N mode instead of successive halving: the screen's first N candidates, each at the full budget (0: screen only)",
        ),
    ] = None,
    rungs: Annotated[
        int | None,
        typer.Option(
            "--rungs",
            parser=integer,
            metavar="R",
            help="successive halving's rungs (default: until the last rung holds the best ten; fewer if a rung would reach --gens; not with --optimise)",
        ),
    ] = None,
    first_gens: Annotated[
        int | None,
        typer.Option(
            "--first-gens",
            parser=integer,
            metavar="G",
            help="generations of the first rung (default 1: the population sampled over the box), tripled each rung; the last runs --gens",
        ),
    ] = None,
    finalists: Annotated[
        int | None,
        typer.Option(
            "--finalists",
            parser=integer,
            metavar="N",
            help="the least the last rung keeps, at the full budget with every seed (default 10; not with --optimise)",
        ),
    ] = None,
    max_candidates: Annotated[int, typer.Option("--max-candidates", parser=integer, metavar="N", help="refuse a search with more candidates")] = 100_000,
    handling: Annotated[str | None, typer.Option(metavar="QUANTITY", help="quantity held equal (default as compare-layouts)")] = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Search every HIS interconnection of up to K elements.

    Enumerates the layouts (accumulators on nodes, directly or behind a valve; damper valves
    on chamber lines and between nodes), screens them by the problem's [synthesis] screen on
    their mode-stiffness tables, optimises the survivors as compare-layouts does and ranks
    them by comfort gain over roll_plane at equal handling (docs/model.md §20). By default
    successive halving: every screened-in candidate runs a small budget (--first-gens, one
    seed), each rung keeps the best third (by sampled designs, unrefined) and triples the
    budget, the last rung runs the best ten or more (--finalists) at the full budget (--gens)
    with every seed; --optimise N instead optimises the screen's first N at the full budget.
    The same command resumes an interrupted synthesis.
    """
    code = synthesize_command(
        problem, max_elements, out, chambers, asymmetric, seeds, pop, gens, optimise, rungs, first_gens, finalists, max_candidates, handling, workers, scheduler
    )
    if code:
        raise SystemExit(code)


def synthesize_command(
    problem_path: Path,
    max_elements: int,
    out: Path,
    chambers: str,
    asymmetric: bool,
    seeds: str,
    pop: int | None,
    gens: int | None,
    optimise: int | None,
    rungs: int | None,
    first_gens: int | None,
    finalists: int | None,
    max_candidates: int,
    handling: str | None,
    workers: int | None,
    scheduler: str | None,
) -> int:
    """Run the synthesis, write its files and report, print the ranking; the exit code."""
    from rich.console import Console

    import hisopt.interrupt as interrupt
    from hisopt.evaluation.parallel import open_backend
    from hisopt.problem import load_problem
    from hisopt.report.synthesis_report import write_synthesis_report
    from hisopt.studies.layout_study import study_budget
    from hisopt.studies.synthesis import check_mode, check_search_arguments, run_synthesis

    problem = load_problem(problem_path)
    check_search_arguments(max_elements, chambers, max_candidates)  # the library's own checks, before the backend starts
    check_mode(optimise, rungs, first_gens, study_budget(problem, pop, gens)["generations"], finalists)
    try:
        with interrupt.signals_as_interrupts(), open_backend(workers, scheduler) as backend:
            result = run_synthesis(
                problem,
                max_elements,
                chambers=chambers,
                symmetric=not asymmetric,
                seeds=seeds,
                out=out,
                pop_size=pop,
                generations=gens,
                optimise=optimise,
                rungs=rungs,
                first_generations=first_gens,
                finalists=finalists,
                max_candidates=max_candidates,
                handling=handling,
                backend=backend,
                progress=lambda line: typer.echo(f"{problem.name}: {line}", err=True),
            )
    except KeyboardInterrupt as exc:
        print(
            f"interrupted by {interrupt.signal_name(exc)}; finished runs are kept and the others saved their checkpoints. "
            f"Resume with the same command (--out {out})",
            file=sys.stderr,
        )
        return interrupt.exit_code(exc)
    report = write_synthesis_report(result)
    console = Console(width=200)
    console.print(_counts(result))
    if len(result.layouts):
        console.print(_ranking(result))
    if result.halving is not None:
        typer.echo(halving_lines(result.halving))
    files = f" and each optimised layout's problem file in {out / 'layouts'}" if result.study is not None else " (no candidate optimised)"
    typer.echo(f"wrote {out / 'candidates.csv'}, {out / 'layouts.csv'}, {report}{files}")
    return 0


def halving_lines(halving: dict[str, Any]) -> str:
    """The terminal's account of successive halving: the rungs, the Spearman correlations of
    the screen's order and the measured one, the top ten the old rule would have missed."""
    rungs = ", ".join(
        f"rung {g['rung']}: {g['candidates']:,} x {g['generations']} generation{'s' if g['generations'] != 1 else ''} x "
        f"{len(g['seeds'])} seed{'s' if len(g['seeds']) > 1 else ''}"
        for g in halving["plan"]
    )

    def rho(found: dict[str, Any]) -> str:
        value = found["rho"]
        return f"{value:+.2f} over {found['candidates']} candidates" if value is not None else f"undefined over {found['candidates']} candidates"

    missed = halving["top_ten_missed_by_old_rule"]
    return "\n".join(
        [
            f"successive halving: {rungs}",
            f"Spearman rank correlation of the screen's order (roll selectivity) and the measured one: {rho(halving['spearman_final'])} of the last rung, "
            f"{rho(halving['spearman_first'])} of the first (+1: the screen predicts the order)",
            f"of the final top ten, the old rule (--optimise 10) would have missed {len(missed)}" + (f": {', '.join(missed)}" if missed else ""),
        ]
    )


def _counts(result: Any) -> Any:
    from rich.table import Table

    table = Table(title="Candidates per element count (accumulators plus valves)")
    for col in ("elements", "candidates", "screened in"):
        table.add_column(col, justify="right")
    for row in result.counts.itertuples(index=False):
        table.add_row(str(row.elements), f"{row.candidates:,}", f"{row.screened_in:,}")
    return table


def _ranking(result: Any) -> Any:
    from rich.console import Group
    from rich.table import Table
    from rich.text import Text

    from hisopt.cli.compare import verdict_table
    from hisopt.units import display_frame

    columns = [
        "layout",
        "elements",
        "catalogue",
        "sigma_aw_at_limit",
        "gain_vs_roll_plane_pct",
        "gain_vs_conventional_pct",
        "hv_mean",
        "hv_std",
        "k_bounce",
        "k_roll",
        "k_warp",
        "file",
    ]
    shown = display_frame(result.layouts[[c for c in columns if c in result.layouts]]).replace("nan", "–")
    study = result.study
    title = f"Optimised layouts at equal handling ({study.handling} at most the roll-plane baseline's), best comfort gain over roll_plane first"
    table = Table(title=Text(title))
    for col in shown.columns:
        table.add_column(
            Text(col.replace(" [", "\n[")),
            justify="left" if col.startswith(("layout", "catalogue", "file")) else "right",
        )
    for row in shown.itertuples(index=False):
        table.add_row(*[Text(str(v)) for v in row])
    return Group(table, verdict_table(result.layouts, "layout", "Buildability of each layout's design at the limit (every rule, docs/model.md §21)"))


def register(app: typer.Typer) -> None:
    """Add ``synthesize`` to ``app``."""
    app.command("synthesize")(synthesize_cmd)
