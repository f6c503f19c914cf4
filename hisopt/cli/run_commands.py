"""Commands on optimisation runs: ``optimize``, ``resume``, ``status``, ``study`` (several
seeds), ``report`` and ``refine``; :func:`register` adds them to the app."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from hisopt.cli.options import DEBUG, load
from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, integer

if TYPE_CHECKING:
    from hisopt.optim.settings import RunSettings


def optimize_cmd(
    problem: ProblemArg,
    out: Annotated[Path | None, typer.Option("--out", help="run directory (default runs/NAME-TIMESTAMP)")] = None,
    seed: Annotated[int | None, typer.Option("--seed", parser=integer, metavar="N", help="random seed (default: problem file)")] = None,
    pop: Annotated[int | None, typer.Option("--pop", parser=integer, metavar="N", help="population size (default: problem file, 100)")] = None,
    gens: Annotated[int | None, typer.Option("--gens", parser=integer, metavar="N", help="generations (default: problem file, 200)")] = None,
    until: Annotated[
        str | None,
        typer.Option(
            "--until",
            metavar="RULE",
            help="generations (run them all) or converged (stop when the hypervolume "
            "stalls; tolerance and window from the problem file; --gens is the cap); default: problem file",
        ),
    ] = None,
    refine: Annotated[bool, typer.Option("--refine", help="refine the front afterwards (front_refined.csv; see `hisopt refine`)")] = False,
    max_points: Annotated[int, typer.Option("--max-points", parser=integer, metavar="N", help="with --refine: most front designs to refine")] = 40,
    epsilon: Annotated[
        list[str] | None,
        typer.Option(
            "--epsilon",
            metavar="NAME=TOL",
            help="tolerance of an objective for the thinned front (front_thinned.csv), relative (--epsilon sigma_aw=1%) or in "
            'its unit (--epsilon "sigma_aw=0.01 m/s^2"; bare numbers are SI); repeatable, overrides [optimizer] epsilon',
        ),
    ] = None,
) -> None:
    """Pareto-optimise PROBLEM in a resumable run directory.

    SMS-EMOA up to four objectives, NSGA-III above (the problem file's [optimizer]
    algorithm chooses otherwise). A checkpoint is written every 10 s, at the
    end and on Ctrl-C; `hisopt resume RUN_DIR` continues an interrupted run.
    """
    from datetime import datetime

    from hisopt.cli.console import run_with_console
    from hisopt.optim.run import optimize
    from hisopt.optim.rundir import prepare_run_directory
    from hisopt.optim.settings import resolve_settings
    from hisopt.problem import load_problem

    p = load_problem(problem)
    settings = resolve_settings(p, pop_size=pop, generations=gens, seed=seed, until=until)
    from hisopt.optim.thinning import resolve_epsilon

    tolerances = resolve_epsilon(p, epsilon, option="--epsilon")  # refused before any work
    if out is None:
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
        out = Path("runs") / f"{p.name}-{stamp}"
        suffix = 1
        while out.exists():
            suffix += 1
            out = Path("runs") / f"{p.name}-{stamp}-{suffix}"
    from hisopt.folders import RUN, check_claim
    from hisopt.optim.runstate import refuse_occupied

    check_claim(out, RUN)  # a folder of another kind, or a user's, is refused
    refuse_occupied(out)  # says what state a run already there is in
    from hisopt.optim.decision import reference_point

    reference_point(p)  # a box with no evaluable design says why before --out is made (cached: the run reuses it)
    from hisopt.studies.buildable_box import check_buildable_box

    check_buildable_box(p)  # so does one with no buildable design under the rules it constrains
    prepare_run_directory(out, fresh=True)  # fail before any work
    from hisopt.optim.catalogue_cost import wants_catalogue_cost

    relaxed = wants_catalogue_cost(p)
    typer.echo(
        f"{p.name}: {settings.algorithm.upper()}, population {settings.pop_size}, {settings.generations} generations, "
        f"seed {settings.seed}{_stop_words(settings)} -> {out}"
        + ("" if tolerances is None else f"; thinned front within {tolerances.describe()}")
        + ("; then the same with its choices continuous, for what the catalogues cost ([optimizer] catalogue_cost)" if relaxed else ""),
        err=True,
    )
    code = run_with_console(
        lambda update: optimize(p, out=out, seed=seed, pop_size=pop, generations=gens, until=until, progress=update, epsilon=epsilon),
        total=settings.generations * (2 if relaxed else 1),
        done=0,
        run_dir=out,
        debug=DEBUG["on"],
    )
    if code:
        raise SystemExit(code)  # click returns (drops) a typer.Exit code in non-standalone mode
    if refine:
        from hisopt.cli.console import refine_with_progress

        refine_with_progress(out, max_points, "slp", None, None)


def _stop_words(settings: RunSettings) -> str:
    if settings.until != "converged":
        return ""
    return f", until converged (gain < {settings.tolerance:g} over {settings.window} generations)"


def resume_cmd(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory of an interrupted `hisopt optimize`")],
) -> None:
    """Continue an interrupted run from its last checkpoint.

    The run may have been interrupted (Ctrl-C, SIGTERM), killed or stopped by an error. The
    final front is the one an uninterrupted run with the same seed gives.
    """
    from hisopt.cli.console import run_with_console
    from hisopt.optim.run import prepare_resume

    plan = prepare_resume(run_dir)  # every check before any output
    if plan.finished:
        typer.echo(f"{plan.state.line()}; nothing to resume", err=True)
        return
    state = plan.state
    typer.echo(f"resuming {run_dir} at generation {state.generation} of {state.generations}", err=True)
    from hisopt.optim.catalogue_cost import wants_catalogue_cost

    total = state.generations * (2 if wants_catalogue_cost(plan.engine.problem) else 1)
    code = run_with_console(plan.run, total=total, done=state.generation, run_dir=run_dir, debug=DEBUG["on"])
    if code:
        raise SystemExit(code)  # click returns (drops) a typer.Exit code in non-standalone mode


def status_cmd(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory of `hisopt optimize` (or a compare-layouts study)")],
) -> None:
    """Say in one line what state a run directory is in.

    The state is running, interrupted, killed, failed or finished, and the line says what
    to do next: resume the run, wait for it, or start over with another --out. On a
    `hisopt compare-layouts` study: its layouts, seeds, each run's state, its tables and
    report, and what to do next.
    """
    from hisopt.folders import LAYOUT_STUDY, folder_kind
    from hisopt.optim.runstate import read_state
    from hisopt.studies.layout_folder import study_status

    found = folder_kind(run_dir)  # a folder of another kind: read_state says what it is
    if found is not None and found.kind.name == LAYOUT_STUDY:
        typer.echo("\n".join(study_status(run_dir)))
        return
    typer.echo(read_state(run_dir).line())


def study(
    problem: ProblemArg,
    seeds: Annotated[str, typer.Option(metavar="SEEDS", help="seeds to run, e.g. 1-8 or 1,3,5")] = "1-4",
    out: Annotated[Path | None, typer.Option(help="study directory: seed-<n>/ run dirs, merged front.csv, runs.csv")] = None,
    pop: Annotated[int | None, typer.Option(parser=integer, metavar="N", help="population size (default: problem file)")] = None,
    gens: Annotated[int | None, typer.Option(parser=integer, metavar="N", help="generations (default: problem file)")] = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Optimise with several seeds, fronts merged.

    Each seed is an independent run in OUT/seed-<n>/, in parallel with --workers or
    --scheduler (Dask); OUT/front.csv merges their fronts and OUT/runs.csv compares them.
    """
    from rich.console import Console

    from hisopt.evaluation.parallel import open_backend
    from hisopt.optim.study import parse_seeds
    from hisopt.optim.study import study as run_study

    p = load(problem, None)
    seed_list = parse_seeds(seeds)
    if out is not None:
        from hisopt.folders import SEED_STUDY, check_claim

        check_claim(out, SEED_STUDY)  # before any work: a folder of another kind, or a user's, is refused
    finished: list[int] = []
    k = len(p.objective_names)

    def progress(run: dict) -> None:  # one stderr line per finished seed
        finished.append(run["seed"])
        typer.echo(
            f"seed {run['seed']} done ({len(finished)} of {len(seed_list)}): front of {run['front_size']} designs, "
            f"HV {run['hypervolume']:.6g} decades^{k}, {run['wall_time_s']:.1f} s",
            err=True,
        )

    with open_backend(workers, scheduler) as backend:
        where = f"on {backend.n_workers} Dask workers" if backend.is_distributed else "one after the other"
        typer.echo(f"running {len(seed_list)} seeds {where}", err=True)
        result = run_study(p, seed_list, out=out, pop_size=pop, generations=gens, backend=backend, progress=progress)
    from hisopt.cli.console import units_table
    from hisopt.units import display_frame, hypervolume_unit

    hv = f"{result.hypervolume:.6g} {hypervolume_unit(len(p.objective_names))}"
    title = f"{p.name}: {len(seed_list)} seeds, merged front of {len(result.front)} designs, hypervolume {hv}"
    Console(width=120).print(units_table(display_frame(result.runs), title))
    if out is not None:
        typer.echo(f"wrote {out / 'front.csv'} and {out / 'runs.csv'}")


def report(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory of `hisopt optimize` (or a compare-layouts study)")],
    color_by: Annotated[str | None, typer.Option("--color-by", help="objective colouring the parallel coordinates")] = None,
    design: Annotated[
        str, typer.Option(help="design for spectra and modes: knee, asf or a row index of front.csv (front_thinned.csv with --epsilon)")
    ] = "knee",
) -> None:
    """Offline report and decision room of a run.

    RUN_DIR/report.html: front, parallel coordinates, convergence, spectra and modes of one design
    (plotly.js embedded, so the file opens offline). RUN_DIR/decision.html, the decision room:
    brush, filter and navigate the designs (reference point, E-NAUTILUS) and export the
    chosen ones as CSV or problem files (docs/model.md §19). On a finished
    `hisopt compare-layouts` study, its study report from its files.
    """
    from hisopt.cli.compare import study_report
    from hisopt.folders import LAYOUT_STUDY, folder_kind
    from hisopt.report.html import build_report

    found = folder_kind(run_dir)  # a folder of another kind: build_report refuses it, saying what it is
    study = found is not None and found.kind.name == LAYOUT_STUDY
    path = study_report(run_dir, color_by, design) if study else build_report(run_dir, color_by=color_by, design=design)
    typer.echo(f"wrote {path}")
    decision = path.parent / "decision.html"
    if decision.is_file():
        typer.echo(f"wrote {decision}")


def refine_cmd(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory written by `hisopt optimize`")],
    max_points: Annotated[
        int,
        typer.Option("--max-points", parser=integer, metavar="N", help="most front designs to refine, spread evenly over the front"),
    ] = 40,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            metavar="NAME",
            help="slp (every design at once, on the evaluator: about 0.05 s per design) or ipopt (CasADi/IPOPT, one design at a time: about a second each)",
        ),
    ] = "slp",
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Refine RUN_DIR's front by gradients.

    Writes RUN_DIR/front_refined.csv (--method ipopt: RUN_DIR/front_refined_ipopt.csv, beside
    the SLP's; the same method again writes its file anew). Each of up to --max-points designs spread over
    front.csv is moved towards the Pareto front by an NLP (its achievement scalarising
    function) and kept only if, evaluated again, it weakly dominates its start. The NLPs
    are solved by batched SLP on the evaluator (default) or by CasADi/IPOPT (--method
    ipopt), in this process or on Dask with --workers or --scheduler. See docs/refine.md.
    """
    from hisopt.cli.console import refine_with_progress
    from hisopt.optim.gradient.refine import check_max_points

    check_max_points(max_points)

    refine_with_progress(run_dir, max_points, method, workers, scheduler)


def sheet(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory written by `hisopt optimize`")],
    design: Annotated[int | None, typer.Option("--design", parser=integer, metavar="N", help="front.csv row, from 0 (default: the knee)")] = None,
    out: Annotated[Path | None, typer.Option(help="folder of the sheet (default RUN_DIR/sheet-N)")] = None,
) -> None:
    """A front design as a sheet to build from.

    Writes sheet.md, sheet.html and sheet.toml: its parts and settings (bores, rods,
    accumulators, charge, valves, pipes), its quantities in every load case, its operating
    envelope and its modes; its buildability (every rule, constrained or not: where it
    binds, its value, limit and margin, and the verdict); with physical damper valves, their
    settings and per load case their RMS flows, equivalent resistances (outside the validated
    range marked) and the roll and bounce damping; its verification in the time domain when
    `hisopt verify RUN_DIR --design N` has written one. `hisopt evaluate sheet.toml`
    reproduces it. docs/model.md §17.4.
    """
    from hisopt.folders import SHEET, check_claim
    from hisopt.optim.decision import front_design
    from hisopt.optim.rundir import FRONT_CSV, run_problem
    from hisopt.report.sheet import write_sheet
    from hisopt.studies.design_sheet import design_sheet

    problem, _ = run_problem(run_dir)
    source = Path(run_dir) / FRONT_CSV
    row, x = front_design(problem, source, design)
    folder = out or Path(run_dir) / f"sheet-{row}"
    check_claim(folder, SHEET)  # before any work: a folder of another kind, or a user's, is refused
    paths = write_sheet(design_sheet(problem, x, row, str(source), run_dir=run_dir), folder)
    for path in paths:
        typer.echo(f"wrote {path}")


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``, in the order ``hisopt --help`` lists them."""
    app.command("optimize")(optimize_cmd)
    app.command("resume")(resume_cmd)
    app.command("status")(status_cmd)
    app.command()(study)
    app.command()(report)
    app.command("refine")(refine_cmd)
    app.command()(sheet)
