"""``hisopt verify``: a design in the time domain beside the frequency domain (docs/model.md §22);
:func:`register` adds it to the app."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from hisopt.cli.usage import SchedulerOpt, WorkersOpt, integer, quantity

if TYPE_CHECKING:
    from hisopt.simulation.verification import Verification


def verify_cmd(
    target: Annotated[
        Path,
        typer.Argument(
            metavar="RUN_DIR|PROBLEM", help="run directory written by `hisopt optimize`, or a problem file (its baseline; a design sheet's sheet.toml)"
        ),
    ],
    design: Annotated[str | None, typer.Option("--design", metavar="N[,M...]", help="front.csv rows of RUN_DIR, from 0 (default: the knee)")] = None,
    out: Annotated[Path | None, typer.Option("--out", help="folder of the verification (default RUN_DIR/verify-N; for several designs, OUT/verify-N)")] = None,
    realisations: Annotated[
        int | None,
        typer.Option(
            "--realisations",
            parser=integer,
            metavar="R",
            help="road realisations per load case, each with its mirror (default: enough for a 2 % standard error of sigma_aw)",
        ),
    ] = None,
    duration: Annotated[
        float,
        typer.Option(
            "--duration", parser=quantity("s"), metavar="T", help="record per simulation after settling; a bare number in s, or with a unit, e.g. 30s"
        ),
    ] = 20.0,
    seed: Annotated[int, typer.Option("--seed", parser=integer, metavar="S", help="seed of the road realisations")] = 41,
    manoeuvres: Annotated[
        bool, typer.Option("--manoeuvres/--no-manoeuvres", help="also the step steer, sine with dwell and half-sine bump of each load case")
    ] = True,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Verify designs in the time domain, nonlinear.

    For each load case: R seeded ISO 8608 road realisations (each with its mirror) of T seconds
    through the linear model and the nonlinear one (gas law, valve laws, tyre lift-off):
    sigma_aw with the ISO 2631-1 filters in the time domain, strokes, tyre loads, valve flows,
    chamber and accumulator pressures against their limits, gas volumes, each with its
    standard error and a verdict; a gap is named by rerunning without each nonlinearity.
    Writes verify.csv, verify.json and verify.html. docs/model.md §22.
    """
    from hisopt.evaluation.parallel import open_backend
    from hisopt.folders import VERIFY, check_claim, claim
    from hisopt.simulation.verification_rows import VerifySettings, check_settings
    from hisopt.studies.verify_designs import parse_rows, targets, verify_designs, write_verification

    settings = VerifySettings(realisations=realisations, duration_s=duration, seed=seed)
    problem, chosen = targets(target, parse_rows(design), out)
    check_settings(settings, problem.spec.band.f_min_hz, {"realisations": "--realisations", "duration": "--duration"})
    for t in chosen:
        check_claim(t.folder, VERIFY)  # before any work: a folder of another kind, or a user's, is refused
    with open_backend(workers, scheduler) as backend:
        results = verify_designs(problem, chosen, settings, backend, manoeuvres)
    from hisopt.report.verify_page import verify_page
    from hisopt.units import variable_units

    for t, verification in zip(chosen, results, strict=True):
        check_error(verification, settings)
        claim(t.folder, VERIFY)
        show(verification)
        for path in write_verification(verification, t.folder, t.row, verify_page(verification, variable_units(problem))):
            typer.echo(f"wrote {path}")


def check_error(verification: Verification, settings: Any) -> None:
    """Refuse (one line, exit 2) a verification whose ``sigma_aw`` standard error exceeds
    ``settings.worst_se`` in any load case: R or T too small for a verdict."""
    from hisopt.errors import ConfigError

    for case in verification.cases:
        row = next(r for r in case.rows if r["figure"] == "sigma_aw")
        error = row["nonlinear_se"] if math.isfinite(row["nonlinear_se"]) else row["linear_se"]
        value = row["nonlinear"] if math.isfinite(row["nonlinear"]) else row["linear"]
        if error > settings.worst_se * value:
            raise ConfigError(
                f"load case {case.traces.case!r}: sigma_aw's standard error is {100 * error / value:.1f} % "
                f"with R = {case.realisations} and T = {settings.duration_s:g} s; "
                f"expected at most {100 * settings.worst_se:g} %: give more --realisations or a longer --duration",
                key="--realisations",
            )


def show(verification: Verification) -> None:
    """The verification as a terminal table, engineering units on every number."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from hisopt.plotting.verify import verify_display

    console = Console(width=170)
    chosen = ", ".join(f"{c.traces.case} R = {c.realisations}" for c in verification.cases)
    s = verification.settings
    console.print(Text(f"{verification.problem}, {verification.design}: {chosen} road pairs of {s.duration_s:g} s (+{s.settle_s:g} s settling), seed {s.seed}"))
    table = Table(title=f"Time domain against frequency domain: {verification.verdict}")
    for col in ("case", "figure", "unit", "frequency domain", "linear ± SE", "nonlinear ± SE", "gap ± SE [%]", "limit", "verdict"):
        table.add_column(Text(col), justify="left" if col in ("case", "figure", "unit", "verdict") else "right")

    def num(value: float, unit: str) -> str:
        if not math.isfinite(value):
            return "-" if math.isnan(value) else str(value)
        return verify_display(unit, value).number(value)

    def with_error(value: float, error: float, unit: str) -> str:
        text = num(value, unit)
        return text if not math.isfinite(error) or not math.isfinite(value) else f"{text} ± {num(error, unit)}"

    for row in verification.frame().to_dict("records"):
        unit = row["unit"]
        gap = "-" if not math.isfinite(row["gap"]) else with_error(row["gap"], row["gap_se"], "-")
        verdict = row["verdict"] + (f" ({row['cause']})" if row["cause"] else "")
        table.add_row(
            row["case"],
            row["figure"],
            verify_display(unit, row["linear"]).unit,
            num(row["frequency_domain"], unit),
            with_error(row["linear"], row["linear_se"], unit),
            with_error(row["nonlinear"], row["nonlinear_se"], unit),
            gap,
            num(row["limit"], unit),
            verdict,
        )
    console.print(table)
    if not verification.manoeuvres.empty:
        man = Table(title="Manoeuvres: linear against nonlinear")
        for col in ("case", "manoeuvre", "figure", "unit", "transient", "linear", "nonlinear"):
            man.add_column(Text(col), justify="left" if col in ("case", "manoeuvre", "figure", "unit") else "right")
        for row in verification.manoeuvres.to_dict("records"):
            unit = row["unit"]
            shown = verify_display(unit, row["linear"]).unit
            man.add_row(row["case"], row["manoeuvre"], row["figure"], shown, num(row["transient"], unit), num(row["linear"], unit), num(row["nonlinear"], unit))
        console.print(man)
    for note in verification.notes:
        console.print(Text(note))


def register(app: typer.Typer) -> None:
    """Add ``verify`` to ``app``."""
    app.command("verify")(verify_cmd)
