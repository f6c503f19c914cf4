"""Studies of the design space: ``sweep`` (one variable) and ``regions`` (the feasible region
of two); :func:`register` adds them to the app (``compare-layouts`` is in :mod:`hisopt.cli.compare`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hisopt.cli.options import ScenarioOpt, SetOpt, load
from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, integer


def sweep_cmd(
    problem: ProblemArg,
    vary: Annotated[str, typer.Option("--vary", metavar="NAME", help="design variable to sweep across its bounds, e.g. p0")],
    points: Annotated[int, typer.Option("--points", parser=integer, metavar="N", help="values between the bounds (both included)")] = 41,
    out: Annotated[Path, typer.Option("--out", help="output folder for sweep_NAME.csv and sweep_NAME.html (a sweep's own folder)")] = Path("sweeps"),
    set_: SetOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    scenario: ScenarioOpt = None,
) -> None:
    """Sweep one variable across its bounds (paper Figures 5-8).

    Frequencies and peak responses of the roll, pitch and bounce modes and of the FL tyre
    force; writes OUT/sweep_NAME.csv and OUT/sweep_NAME.html.
    """
    from hisopt.evaluation.parallel import open_backend
    from hisopt.folders import SWEEP, check_claim, claim
    from hisopt.io import write_csv
    from hisopt.plotting.theme import write_html
    from hisopt.studies.sweeps import sweep

    p = load(problem, set_, scenario)
    check_claim(out, SWEEP)  # before any work: a folder of another kind, or a user's, is refused
    with open_backend(workers, scheduler) as backend:
        result = sweep(p, vary, points, backend=backend)  # validates --vary and --points first
    claim(out, SWEEP)
    csv, html = out / f"sweep_{vary}.csv", out / f"sweep_{vary}.html"
    write_csv(result.to_frame(), csv)
    write_html(result.plot(), html)
    typer.echo(f"wrote {csv} and {html}")


def regions_cmd(
    problem: ProblemArg,
    pair: Annotated[str, typer.Option("--pair", metavar="A,B", help="two design variables, comma-separated, e.g. dA,lam")],
    points: Annotated[int, typer.Option("--points", parser=integer, metavar="N", help="grid values per variable")] = 41,
    out: Annotated[Path, typer.Option("--out", help="output folder for regions_A_B.csv and regions_A_B.html (a regions study's own folder)")] = Path("regions"),
    set_: SetOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Feasible region of two variables (paper Figures 9-10).

    The four indicators on a grid of the --pair variables, with the region that meets the
    constraints; writes OUT/regions_A_B.csv and OUT/regions_A_B.html.
    """
    from hisopt.errors import ConfigError
    from hisopt.folders import REGIONS, check_claim, claim
    from hisopt.io import write_csv
    from hisopt.plotting.theme import write_html
    from hisopt.studies.sweeps import regions

    names = tuple(n.strip() for n in pair.split(","))
    if len(names) != 2 or not all(names):
        raise ConfigError(f"expected two design variables separated by a comma, e.g. dA,lam; got {pair!r}", key="--pair")
    from hisopt.evaluation.parallel import open_backend

    p = load(problem, set_)
    check_claim(out, REGIONS)  # before any work: a folder of another kind, or a user's, is refused
    with open_backend(workers, scheduler) as backend:
        result = regions(p, (names[0], names[1]), points, backend=backend)
    claim(out, REGIONS)
    stem = f"regions_{names[0]}_{names[1]}"
    write_csv(result.to_frame(), out / f"{stem}.csv")
    write_html(result.plot(), out / f"{stem}.html")
    typer.echo(f"wrote {out / (stem + '.csv')} and {out / (stem + '.html')}")


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``, in the order ``hisopt --help`` lists them."""
    app.command("sweep")(sweep_cmd)
    app.command("regions")(regions_cmd)
