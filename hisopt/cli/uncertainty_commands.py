"""Uncertainty studies: ``sensitivity`` (Sobol indices) and ``tolerance`` (Monte Carlo of one
design); :func:`register` adds them to the app (docs/model.md §18)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hisopt.cli.options import SetOpt, load
from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, integer, quantity

DesignOpt = Annotated[
    str | None,
    typer.Option(
        "--design",
        metavar="baseline|RUN_DIR",
        help="the design: 'baseline' (the [his] values, with --set) or a run directory (its knee design)",
    ),
]
SeedOpt = Annotated[int, typer.Option("--seed", parser=integer, metavar="N", help="seed of the sample set (same seed, same numbers)")]


def _design(p, design: str):  # noqa: ANN001, ANN202 - a Problem and its design row
    """The design row ``--design`` names, and how to say it (with its values, in engineering units)."""
    from hisopt.studies.envelope import knee_design
    from hisopt.units import format_design

    if design == "baseline":
        x, what = p.baseline[None, :], "the baseline design"
    elif Path(design).is_dir():
        x, what = knee_design(p, Path(design)), f"the knee of {design}"
    else:
        from hisopt.errors import ConfigError

        raise ConfigError(f"expected 'baseline' or a run directory; {design!r} is neither", key="--design")
    return x, f"{what} ({format_design(dict(zip(p.variable_names, x[0], strict=True)), p.variable_units)})"


def _print(shown, title: str) -> None:  # noqa: ANN001 - a DataFrame of strings
    """A table of strings, text columns left and numbers right."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    table = Table(title=Text(title))
    for col in shown.columns:
        table.add_column(Text(col), justify="left" if col in ("quantity", "input", "distribution", "constraint") else "right", no_wrap=True)
    for row in shown.itertuples(index=False):
        table.add_row(*(Text(str(v)) for v in row))
    Console(width=200).print(table)


def sensitivity_cmd(
    problem: ProblemArg,
    design: DesignOpt = None,
    samples: Annotated[
        int | None,
        typer.Option(
            "--samples",
            parser=integer,
            metavar="N",
            help="a fixed count of base samples N (a power of 2; N (D + 2) evaluations) instead of doubling until the intervals converge",
        ),
    ] = None,
    target: Annotated[
        float | None,
        typer.Option(
            "--target", parser=quantity("-"), metavar="HALF_WIDTH", help="double until every S1 and ST 95 % half-width is at most this [default: 0.05]"
        ),
    ] = None,
    max_evaluations: Annotated[
        int | None, typer.Option("--max-evaluations", parser=integer, metavar="N", help="do not double past this many model evaluations [default: 500000]")
    ] = None,
    max_time: Annotated[
        float | None,
        typer.Option(
            "--max-time",
            parser=quantity("s"),
            metavar="TIME",
            help="do not start a doubling that would end past this time, e.g. '10 min' (where it stops then depends on the machine)",
        ),
    ] = None,
    seed: SeedOpt = 0,
    log: Annotated[
        bool | None,
        typer.Option(
            "--log/--no-log",
            help="indices of log10 of every quantity (its relative changes), or of none [default: log10 of each quantity spanning more than a decade]",
        ),
    ] = None,
    out: Annotated[Path, typer.Option("--out", help="output folder for sensitivity.csv and sensitivity.html (a sensitivity study's own folder)")] = Path(
        "sensitivity"
    ),
    set_: SetOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Sobol indices: which inputs drive each quantity.

    First- and total-order Sobol indices with bootstrap 95 % intervals (SALib) of every
    objective and constraint: with --design, with respect to the [[uncertain]] inputs around
    that design; without, over the whole box, with respect to the design variables and the
    uncertain inputs. The base samples double (every evaluation reused) until every interval's
    half-width is at most --target, or a cap stops them (the output names the intervals still
    wider); --samples fixes the count. A quantity spanning more than a decade is taken as
    log10 (said in the output). Writes OUT/sensitivity.csv and OUT/sensitivity.html.
    """
    from hisopt.errors import ConfigError
    from hisopt.evaluation.parallel import open_backend
    from hisopt.folders import SENSITIVITY, claim
    from hisopt.report.uncertainty import sensitivity_notes, total_indices_shown, write_sensitivity
    from hisopt.studies.sobol import MAX_EVALUATIONS, TARGET_HALF_WIDTH, check_convergence_settings, check_n_base
    from hisopt.studies.uncertainty import check_sensitivity, sensitivity

    if samples is not None:
        check_n_base(samples, key="--samples")
        given = [name for name, value in (("--target", target), ("--max-evaluations", max_evaluations), ("--max-time", max_time)) if value is not None]
        if given:
            raise ConfigError(
                f"fixes the count; {' and '.join(given)} {'stops' if len(given) == 1 else 'stop'} the doubling: give one or the other", key="--samples"
            )
    half_width = TARGET_HALF_WIDTH if target is None else target
    cap = MAX_EVALUATIONS if max_evaluations is None else max_evaluations
    check_convergence_settings(half_width, cap, max_time, keys=("--target", "--max-evaluations", "--max-time"))
    p = load(problem, set_)
    check_sensitivity(p, design, str(problem))
    x, where = (None, "over the whole box of the design variables") if design is None else _design(p, design)
    claim(out, SENSITIVITY)  # before any work: a folder of another kind, or a user's, is refused
    with open_backend(workers, scheduler) as backend:
        result = sensitivity(p, x, samples, seed, backend=backend, log=log, target=half_width, max_evaluations=cap, max_seconds=max_time)
    of = "log10 of each quantity, " if log else ""
    place = f"{of}around {where}" if x is not None else f"{of}{where}"
    files = write_sensitivity(result, out, f"{p.name}: which inputs matter", place)
    _print(total_indices_shown(result.indices), f"{p.name}: total Sobol indices ST, {place} (± 95 % half-widths; S1 in the files)")
    for line in sensitivity_notes(result):
        typer.echo(line)
    if result.dropped:
        typer.echo(f"{result.dropped} sample blocks dropped where the model failed")
    typer.echo(f"wrote {' and '.join(map(str, files))}")


def tolerance_cmd(
    problem: ProblemArg,
    design: DesignOpt = "baseline",
    samples: Annotated[int, typer.Option("--samples", parser=integer, metavar="N", help="Monte Carlo samples")] = 100_000,
    seed: SeedOpt = 0,
    out: Annotated[
        Path, typer.Option("--out", help="output folder for tolerance.csv, violations.csv, samples.parquet and tolerance.html (a tolerance study's own folder)")
    ] = Path("tolerance"),
    set_: SetOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Monte Carlo of one design under its tolerances.

    Each objective's and constraint's mean, standard deviation and percentiles over the
    samples, and each constraint's probability of violation with its 95 % interval (a sample
    the model cannot evaluate counts as a violation). Writes OUT/tolerance.csv,
    OUT/violations.csv, OUT/samples.parquet and OUT/tolerance.html.
    """
    from hisopt.arguments import integer
    from hisopt.evaluation.parallel import open_backend
    from hisopt.folders import TOLERANCE, claim
    from hisopt.report.uncertainty import tolerance_shown, violations_shown, write_tolerance
    from hisopt.studies.uncertainty import check_tolerance, tolerance, uncertain_inputs

    integer(samples, "--samples", minimum=2, what="samples")  # before the problem loads
    p = load(problem, set_)
    check_tolerance(p, samples, "--samples", str(problem))
    x, where = _design(p, design or "baseline")
    claim(out, TOLERANCE)  # before any work: a folder of another kind, or a user's, is refused
    with open_backend(workers, scheduler) as backend:
        result = tolerance(p, x, n_samples=samples, seed=seed, backend=backend)
    limits = {c.name: c.limit for c in p.spec.constraints}
    inputs = uncertain_inputs(p)
    files = write_tolerance(result, out, f"{p.name}: tolerance study", where, limits, inputs)
    _print(tolerance_shown(result.summary), f"{p.name}: {where} over {samples} samples (seed {seed}), mean ± 95 % half-width")
    if len(result.violations):
        _print(violations_shown(result.violations), "probability of violating each constraint")
    typer.echo(f"wrote {', '.join(map(str, files))}")


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``, in the order ``hisopt --help`` lists them."""
    app.command("sensitivity")(sensitivity_cmd)
    app.command("tolerance")(tolerance_cmd)
