"""Command line: ``hisopt modes|evaluate|response|optimize|resume|...`` (typer).

User mistakes exit with code 2 and one line on stderr; internal errors exit 1; ``--debug``
shows tracebacks.
"""

from __future__ import annotations

import math
import os
import signal
import sys
from pathlib import Path
from typing import Annotated

import typer

from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, integer, quantity

# Plain help (no rich markup: "[his]" is text, not a style tag); -h is short for --help.
app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
    help="Design optimiser for hydraulically interconnected suspensions (HIS): layouts, load cases, Pareto fronts. "
    "Start with `hisopt init problem.toml`.",
)

# The scalar [his] keys --set accepts (RollPlaneHIS fields; tests/test_cli.py keeps them in step).
# Listed here rather than read from the model so that `hisopt --help` need not import it.
SET_KEYS = ("p0", "dA", "lam", "Rv", "dA_rear", "lam_rear", "Rv_rear", "V0", "gamma", "chamber_volume", "pipe_model", "layout")

SetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        metavar="KEY=VALUE",
        help="override a [his] value of the problem file, e.g. --set p0=3e6 or --set \"p0=2.5 MPa\" (repeatable; "
        f"bare numbers are SI, a value may carry its unit); KEY is one of {', '.join(SET_KEYS)}",
    ),
]

ScenarioOpt = Annotated[
    str | None,
    typer.Option("--scenario", metavar="NAME", help="a [[scenarios]] load case (its road and payload); default the problem's [road], no payload"),
]

_DEBUG = {"on": False}
PROBLEM_TEMPLATE = "roll_plane_his.toml"  # in hisopt/data/; the same file as problems/roll_plane_his.toml


def _show_version(value: bool) -> None:
    if value:
        from hisopt import __version__

        typer.echo(f"hisopt {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="show tracebacks of internal errors")] = False,
    version: Annotated[
        bool, typer.Option("--version", callback=_show_version, is_eager=True, help="print the version and exit")
    ] = False,
) -> None:
    _DEBUG["on"] = debug


def load(problem: Path, sets: list[str] | None, scenario: str | None = None):
    """Load a problem file, apply ``--set`` overrides (:func:`hisopt.specification.validation.apply_assignments`)
    and, with ``--scenario``, take that load case as a single-case problem."""
    from hisopt.errors import ConfigError
    from hisopt.problem import load_problem
    from hisopt.specification.validation import apply_assignments

    p = apply_assignments(load_problem(problem), sets)
    if scenario is None:
        return p
    if scenario not in p.scenario_names:
        known = f"one of {', '.join(p.scenario_names)}" if p.scenario_names else "a problem with [[scenarios]] (this one has none), or no --scenario"
        raise ConfigError(f"unknown scenario {scenario!r}; expected {known}", key="--scenario")
    return p.scenario_space(scenario)


@app.command()
def modes(problem: ProblemArg, set_: SetOpt = None, scenario: ScenarioOpt = None) -> None:
    """Modes without and with HIS (paper Table 1).

    Natural frequency, damping ratio and motion of each mode of the baseline design, and how
    the HIS shifts each frequency. Modes are named by their shape (the same mode has the same
    name without and with HIS); the older wheel-mode names are listed below the table.
    """
    from hisopt.cli.console import print_modes

    print_modes(load(problem, set_, scenario))


@app.command()
def layouts(
    problem: Annotated[
        Path | None, typer.Argument(metavar="PROBLEM", help="problem file whose [his] values are used (default: the paper's problem)")
    ] = None,
    set_: SetOpt = None,
) -> None:
    """Catalogue of HIS layouts and what each one stiffens.

    For every catalogue layout (and the problem's own custom layout), at the problem's
    baseline values: the static stiffness it adds per unit stroke pattern (bounce 1 1 1 1,
    roll 1 -1 1 -1, pitch 1 1 -1 -1, warp 1 -1 -1 1 for FL FR RL RR; per metre of the
    pattern's amplitude), its low-frequency damping and the largest static coupling between
    patterns (docs/model.md §12.4). Select a layout with [his] layout = "NAME".
    """
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from hisopt.studies.screening import mode_stiffness
    from hisopt.units import display_frame

    p = load(problem, set_) if problem is not None else None
    frame = mode_stiffness(p)
    shown = display_frame(frame.drop(columns="summary"))
    source = p.name if p is not None else "the paper's problem"
    table = Table(title=Text(f"HIS layouts at the baseline of {source}: added stiffness and low-frequency damping per unit stroke pattern"))
    for col in shown.columns:
        table.add_column(Text(col.replace(" [", "\n[")), justify="left" if col.startswith("layout") else "right")
    for row in shown.itertuples(index=False):
        table.add_row(*[Text(v) for v in row])
    console = Console(width=170)
    console.print(table)
    for name, summary in zip(frame["layout"], frame["summary"], strict=True):
        console.print(Text(f"{name}: {summary}"))
    console.print(Text('select one with [his] layout = "NAME"; descriptions and sources: docs/model.md §12.3'))


@app.command()
def droptest(
    problem: ProblemArg,
    out: Annotated[Path, typer.Option("--out", help="output directory for droptest.csv and droptest.html")],
    p0: Annotated[
        str,
        typer.Option("--p0", metavar="PRESSURES",
                     help="accumulator precharges (gauge), comma-separated; bare numbers in Pa, or with a unit, e.g. \"1 MPa,2 MPa\""),
    ] = "1e6,2e6,3e6",
    height: Annotated[
        float,
        typer.Option("--height", parser=quantity("m"), metavar="HEIGHT",
                     help="drop height (the wheels roll off blocks this high); a bare number in m, or with a unit, e.g. 5cm"),
    ] = 0.05,
    measured: Annotated[
        Path | None,
        typer.Option(
            "--measured",
            help="measured drop record, CSV with columns time (s) and body_fl, body_fr, body_rl, body_rr "
            "(vertical acceleration in m/s^2, z up; optional wheel_fl, wheel_fr, wheel_rl, wheel_rr), "
            "uniformly sampled above 40 Hz; see docs/droptest.md",
        ),
    ] = None,
    case: Annotated[
        str | None, typer.Option("--case", help="drop test the --measured file records: front_axle, left_side or all_wheels")
    ] = None,
    measured_p0: Annotated[
        float | None,
        typer.Option(
            "--measured-p0", parser=quantity("Pa"), metavar="PRESSURE",
            help="precharge (gauge) of the measured test, a bare number in Pa or with a unit, e.g. \"2 MPa\" (default: the problem's p0)",
        ),
    ] = None,
    mode: Annotated[str, typer.Option("--mode", help="simulation model: linear or nonlinear (gas law, tyre lift-off)")] = "linear",
    set_: SetOpt = None,
) -> None:
    """Drop tests, simulated and measured (paper Table 3).

    Repeats the paper's drop tests (Section VI, Table 3, Fig. 13) on the model. Writes
    OUT/droptest.csv (case, p0, mode, mac, frequency_time_hz, frequency_model_hz,
    error_pct, damping; damped frequencies in Hz) and OUT/droptest.html (response spectra).
    Each signal is paired with the model mode it is by frequency and shape (MAC); one that
    matches no single mode is "mixed" and has no error. A measured record replaces the
    simulated row of the same case and p0.
    """
    from rich.console import Console
    from rich.table import Table

    from hisopt.errors import ConfigError
    from hisopt.io import write_csv
    from hisopt.quantities import to_si
    from hisopt.simulation.droptest import DROP_CASES, drop_table, measured_drop_test, read_measured, run_drop_tests, spectra_figure, unpaired_notes
    from hisopt.units import display_for, format_number

    p0_values = [to_si(v, "Pa", key="--p0") for v in p0.split(",") if v.strip()]
    from hisopt.specification.validation import parameter_rule, plausible

    if not p0_values or not parameter_rule("p0").holds(p0_values).all():
        raise ConfigError(f"expected one or more finite precharges >= 0 Pa, got {p0!r}", key="--p0")
    if not (height > 0 and plausible(height)):
        raise ConfigError(f"expected a finite drop height > 0 m, got {height!r}", key="--height")
    if measured_p0 is not None and (measured is None or not parameter_rule("p0").holds(measured_p0)):
        raise ConfigError(f"expected a finite precharge >= 0 Pa with --measured, got {measured_p0!r}", key="--measured-p0")
    if mode not in ("linear", "nonlinear"):
        raise ConfigError(f"expected linear or nonlinear, got {mode!r}", key="--mode")
    if (measured is None) != (case is None):
        raise ConfigError("--measured and --case go together: name the file and which drop test it records", key="--case")
    if case is not None and case not in DROP_CASES:
        raise ConfigError(f"expected one of {', '.join(DROP_CASES)}, got {case!r}", key="--case")

    if measured is not None:
        read_measured(measured)  # fail before the simulations if the file is unusable
    prob = load(problem, set_)
    tests = run_drop_tests(prob, p0_values, height, mode=mode)  # type: ignore[arg-type]
    if measured is not None:
        p0_meas = prob.spec.his.p0 if measured_p0 is None else measured_p0
        tests.append(measured_drop_test(prob, measured, case, p0_meas))  # type: ignore[arg-type]
    frame = drop_table(tests)
    try:
        out.mkdir(parents=True, exist_ok=True)
        write_csv(frame, out / "droptest.csv")
        spectra_figure(tests).write_html(out / "droptest.html", include_plotlyjs=True)
    except OSError as exc:
        raise ConfigError(f"cannot write the results ({exc.strerror}); expected a writable directory", key="--out") from exc

    sources = {(t.case, t.p0_pa): t.source for t in tests}
    from rich.text import Text

    table = Table(title=f"Drop tests of {prob.name}, {height * 1000:g} mm (paper Table 3; damped frequencies)")
    pressure = display_for("Pa", frame["p0"].to_numpy())
    for col in ("case", pressure.label("p0"), "mode", "MAC [-]", "source", "f time [Hz]", "f model [Hz]", "error [%]", "damping [-]"):
        table.add_column(Text(col), justify="left" if col in ("case", "mode", "source") else "right")
    for row in frame.itertuples():
        paired = math.isfinite(row.frequency_model_hz)
        table.add_row(
            row.case,
            pressure.number(row.p0),
            row.mode,
            f"{row.mac:.3f}" if math.isfinite(row.mac) else "-",
            sources[(row.case, row.p0)],
            format_number(row.frequency_time_hz, trim=False),
            format_number(row.frequency_model_hz, trim=False) if paired else "-",
            f"{row.error_pct:+.2f}" if paired else "-",
            format_number(row.damping, trim=False),
        )
    Console(width=130).print(table)
    for line in unpaired_notes(tests):
        typer.echo(line)
    typer.echo(f"wrote {out / 'droptest.csv'} and {out / 'droptest.html'}")


@app.command()
def evaluate(
    problem: ProblemArg,
    set_: SetOpt = None,
    designs: Annotated[
        Path | None,
        typer.Option(help="CSV with one column per design variable, e.g. examples/designs.csv; an optional units row "
                     "below the header ([MPa], [cm^2], [-]) gives each column's unit, else SI"),
    ] = None,
    out: Annotated[Path | None, typer.Option(help="results CSV (designs plus objective and constraint columns)")] = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Objectives and constraints of the baseline or a CSV file.

    Without --designs, of the problem's baseline design; with it, of every row. The
    table shows the first 20 designs; --out writes them all. A row that breaks a
    parameter's rule or is not finite is not evaluated, a row outside the [variables] box
    is; both are flagged in the status and reason columns, never feasible, and counted in
    one warning line.
    """
    from rich.console import Console

    from hisopt.errors import ConfigError
    from hisopt.io import ensure_writable_file, write_csv
    from hisopt.specification.designs import read_designs
    from hisopt.specification.validation import flag_summary

    p = load(problem, set_)
    if out is not None:
        ensure_writable_file(out, "--out")  # fail before any work
    if designs is not None:
        from hisopt.units import variable_units

        frame = read_designs(designs, p.variable_names, variable_units(p))
        from hisopt.evaluation.parallel import open_backend

        with open_backend(workers, scheduler) as backend:
            result = p.evaluate(frame, backend=backend, source=str(designs), log=False)
    else:
        result = p.evaluate(p.baseline, log=False)
    summary = flag_summary(result["status"], str(designs) if designs is not None else "baseline design")
    if summary:
        typer.echo(f"warning: {summary}", err=True)
    if out is not None:
        try:
            write_csv(result, out)
        except OSError as exc:
            raise ConfigError(f"cannot write {out} ({exc.strerror or exc})", key="--out") from None
        typer.echo(f"wrote {len(result)} designs to {out}")
    if designs is None or out is None:
        from hisopt.cli.console import units_table
        from hisopt.units import display_frame

        Console(width=200).print(units_table(display_frame(result.head(20)), f"{p.name}: {len(result)} design(s)"))
        if len(result) > 20:
            typer.echo(f"showing the first 20 of {len(result)} designs; write them all with --out FILE")


@app.command()
def init(
    file: Annotated[Path, typer.Argument(metavar="FILE", help="problem file to write, e.g. problem.toml")],
    force: Annotated[bool, typer.Option("--force", help="overwrite FILE if it exists")] = False,
) -> None:
    """Write the paper's problem to FILE as a starting point.

    The default vehicle, HIS, design box, road and the paper's four objectives, commented
    and in SI units (the same file as problems/roll_plane_his.toml). Edit it, then run
    `hisopt evaluate FILE` or `hisopt optimize FILE`.
    """
    from importlib import resources

    from hisopt.errors import ConfigError

    if file.exists() and not force:
        raise ConfigError("already exists; expected a new file name, or --force to overwrite it", file=str(file))
    text = (resources.files("hisopt") / "data" / PROBLEM_TEMPLATE).read_text(encoding="utf-8")
    try:
        file.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot write the file ({exc.strerror}); expected a writable path", file=str(file)) from None
    typer.echo(f"wrote {file}; next: hisopt evaluate {file}")


@app.command()
def response(
    problem: ProblemArg,
    out: Annotated[Path, typer.Option(help="output directory for response.csv and response.html")],
    set_: SetOpt = None,
) -> None:
    """Response spectra with and without HIS (paper Figure 4).

    Writes OUT/response.csv and OUT/response.html (interactive, works offline).
    """
    from hisopt.io import ensure_writable_dir, write_csv
    from hisopt.plotting.theme import write_html
    from hisopt.studies.spectra import response_spectra

    p = load(problem, set_)
    ensure_writable_dir(out)
    spectra = response_spectra(p)
    write_csv(spectra.frame, out / "response.csv")
    write_html(spectra.plot(), out / "response.html")
    typer.echo(f"wrote {out / 'response.csv'} and {out / 'response.html'}")


@app.command("optimize")
def optimize_cmd(
    problem: ProblemArg,
    out: Annotated[Path | None, typer.Option("--out", help="run directory (default runs/NAME-TIMESTAMP)")] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", parser=integer, metavar="N", help="random seed (default: problem file)")
    ] = None,
    pop: Annotated[
        int | None, typer.Option("--pop", parser=integer, metavar="N", help="population size (default: problem file, 100)")
    ] = None,
    gens: Annotated[
        int | None, typer.Option("--gens", parser=integer, metavar="N", help="generations (default: problem file, 200)")
    ] = None,
    refine: Annotated[bool, typer.Option("--refine", help="refine the front with CasADi/IPOPT afterwards (front_refined.csv)")] = False,
    max_points: Annotated[
        int, typer.Option("--max-points", parser=integer, metavar="N", help="with --refine: most front designs to refine")
    ] = 40,
) -> None:
    """Pareto-optimise PROBLEM in a resumable run directory.

    NSGA-II, or NSGA-III from four objectives. A checkpoint is written after every
    generation; `hisopt resume RUN_DIR` continues an interrupted run.
    """
    from datetime import datetime

    from hisopt.cli.console import run_with_console
    from hisopt.optim.run import optimize
    from hisopt.optim.rundir import prepare_run_directory
    from hisopt.optim.settings import resolve_settings
    from hisopt.problem import load_problem

    p = load_problem(problem)
    settings = resolve_settings(p, pop_size=pop, generations=gens, seed=seed)
    if out is None:
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
        out = Path("runs") / f"{p.name}-{stamp}"
        suffix = 1
        while out.exists():
            suffix += 1
            out = Path("runs") / f"{p.name}-{stamp}-{suffix}"
    from hisopt.optim.runstate import refuse_occupied

    refuse_occupied(out)  # says what state a run already there is in
    prepare_run_directory(out, fresh=True)  # fail before any work
    typer.echo(
        f"{p.name}: {settings.algorithm.upper()}, population {settings.pop_size}, {settings.generations} generations, "
        f"seed {settings.seed} -> {out}",
        err=True,
    )
    code = run_with_console(
        lambda update: optimize(p, out=out, seed=seed, pop_size=pop, generations=gens, progress=update),
        total=settings.generations,
        done=0,
        run_dir=out,
        debug=_DEBUG["on"],
    )
    if code:
        raise SystemExit(code)  # click returns (drops) a typer.Exit code in non-standalone mode
    if refine:
        from hisopt.cli.console import refine_with_progress

        refine_with_progress(out, max_points, None, None)


@app.command("resume")
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
    code = run_with_console(plan.run, total=state.generations, done=state.generation, run_dir=run_dir, debug=_DEBUG["on"])
    if code:
        raise SystemExit(code)  # click returns (drops) a typer.Exit code in non-standalone mode


@app.command("status")
def status_cmd(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory of `hisopt optimize` (or a compare-layouts study)")],
) -> None:
    """Say in one line what state a run directory is in.

    The state is running, interrupted, killed, failed or finished, and the line says what
    to do next: resume the run, wait for it, or start over with another --out. On a
    `hisopt compare-layouts` study: its layouts, seeds, each run's state, its tables and
    report, and what to do next.
    """
    from hisopt.optim.runstate import read_state
    from hisopt.studies.layout_folder import is_layout_study, study_status

    if is_layout_study(run_dir):
        typer.echo("\n".join(study_status(run_dir)))
        return
    typer.echo(read_state(run_dir).line())


@app.command()
def study(
    problem: ProblemArg,
    seeds: Annotated[str, typer.Option(metavar="SEEDS", help="seeds to run, e.g. 1-8 or 1,3,5")] = "1-4",
    out: Annotated[Path | None, typer.Option(help="study directory: seed-<n>/ run dirs, merged front.csv, runs.csv")] = None,
    pop: Annotated[
        int | None, typer.Option(parser=integer, metavar="N", help="population size (default: problem file)")
    ] = None,
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


@app.command()
def report(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory of `hisopt optimize` (or a compare-layouts study)")],
    color_by: Annotated[str | None, typer.Option("--color-by", help="objective colouring the parallel coordinates")] = None,
    design: Annotated[str, typer.Option(help="design for spectra and modes: knee, asf or a front.csv row index")] = "knee",
) -> None:
    """Write RUN_DIR/report.html, the run's offline report.

    Front, parallel coordinates, convergence, spectra and modes of one design; plotly.js
    is embedded, so the file opens offline. On a finished `hisopt compare-layouts` study,
    its study report from its files.
    """
    from hisopt.cli.compare import study_report
    from hisopt.report.html import build_report
    from hisopt.studies.layout_folder import is_layout_study

    path = study_report(run_dir, color_by, design) if is_layout_study(run_dir) else build_report(run_dir, color_by=color_by, design=design)
    typer.echo(f"wrote {path}")


@app.command("refine")
def refine_cmd(
    run_dir: Annotated[Path, typer.Argument(metavar="RUN_DIR", help="run directory written by `hisopt optimize`")],
    max_points: Annotated[
        int,
        typer.Option("--max-points", parser=integer, metavar="N", help="most front designs to refine, spread evenly over the front"),
    ] = 40,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Refine RUN_DIR's front by gradients (CasADi/IPOPT).

    Writes RUN_DIR/front_refined.csv. Each of up to --max-points designs spread over
    front.csv is moved towards the Pareto front by an NLP (its achievement scalarising
    function) and kept only if, evaluated again, it weakly dominates its start. NLPs run
    in this process, or on Dask with --workers or --scheduler. See docs/refine.md.
    """
    from hisopt.errors import ConfigError

    if max_points < 1:
        raise ConfigError(f"expected at least 1, got {max_points}", key="--max-points")
    from hisopt.cli.console import refine_with_progress

    refine_with_progress(run_dir, max_points, workers, scheduler)


@app.command("sweep")
def sweep_cmd(
    problem: ProblemArg,
    vary: Annotated[str, typer.Option("--vary", metavar="NAME", help="design variable to sweep across its bounds, e.g. p0")],
    points: Annotated[
        int, typer.Option("--points", parser=integer, metavar="N", help="values between the bounds (both included)")
    ] = 41,
    out: Annotated[Path, typer.Option("--out", help="output directory for sweep_NAME.csv and sweep_NAME.html")] = Path("."),
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
    from hisopt.io import ensure_writable_dir, write_csv
    from hisopt.plotting.theme import write_html
    from hisopt.studies.sweeps import sweep

    p = load(problem, set_, scenario)
    with open_backend(workers, scheduler) as backend:
        result = sweep(p, vary, points, backend=backend)  # validates --vary and --points first
    ensure_writable_dir(out)
    csv, html = out / f"sweep_{vary}.csv", out / f"sweep_{vary}.html"
    write_csv(result.to_frame(), csv)
    write_html(result.plot(), html)
    typer.echo(f"wrote {csv} and {html}")


@app.command("regions")
def regions_cmd(
    problem: ProblemArg,
    pair: Annotated[str, typer.Option("--pair", metavar="A,B", help="two design variables, comma-separated, e.g. dA,lam")],
    points: Annotated[int, typer.Option("--points", parser=integer, metavar="N", help="grid values per variable")] = 41,
    out: Annotated[Path, typer.Option("--out", help="output directory for regions_A_B.csv and regions_A_B.html")] = Path("."),
    set_: SetOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
) -> None:
    """Feasible region of two variables (paper Figures 9-10).

    The four indicators on a grid of the --pair variables, with the region that meets the
    constraints; writes OUT/regions_A_B.csv and OUT/regions_A_B.html.
    """
    from hisopt.errors import ConfigError
    from hisopt.io import ensure_writable_dir, write_csv
    from hisopt.plotting.theme import write_html
    from hisopt.studies.sweeps import regions

    names = tuple(n.strip() for n in pair.split(","))
    if len(names) != 2 or not all(names):
        raise ConfigError(f"expected two design variables separated by a comma, e.g. dA,lam; got {pair!r}", key="--pair")
    from hisopt.evaluation.parallel import open_backend

    p = load(problem, set_)
    with open_backend(workers, scheduler) as backend:
        result = regions(p, (names[0], names[1]), points, backend=backend)
    ensure_writable_dir(out)
    stem = f"regions_{names[0]}_{names[1]}"
    write_csv(result.to_frame(), out / f"{stem}.csv")
    write_html(result.plot(), out / f"{stem}.html")
    typer.echo(f"wrote {out / (stem + '.csv')} and {out / (stem + '.html')}")


from hisopt.cli.compare import register  # noqa: E402  (the command joins the app defined above)

register(app)


_INTERRUPTED: list[bool] = []
"""Set by Ctrl-C outside a run: whether a command reported it (runs and savers do)."""


def _quit_now(signum: int, frame: object) -> None:
    """SIGTERM in a command with nothing to save: one line and the shell's exit code, not a
    traceback (runs install their own handlers, which save a checkpoint first; files are
    written atomically, so none is left half written)."""
    os.write(2, f"interrupted by {signal.Signals(signum).name}\n".encode())
    os._exit(128 + signum)


def _keyboard_interrupt(signum: int, frame: object) -> None:
    _INTERRUPTED.append(False)
    raise KeyboardInterrupt


def install_signal_handlers() -> None:
    """The command line's handlers, installed by :func:`main` (never on import: a library that
    imports :mod:`hisopt.cli` keeps its own). Ctrl-C is a KeyboardInterrupt (commands that
    save work catch it and say so; typer turns the others into a silent exit 130, named by
    :func:`main`); SIGTERM is a quiet exit until a run installs its own handler
    (:mod:`hisopt.interrupt`)."""
    signal.signal(signal.SIGINT, _keyboard_interrupt)
    signal.signal(signal.SIGTERM, _quit_now)


def main() -> None:
    """Entry point: install the signal handlers, map user errors to exit code 2 and internal
    errors to 1; print each implausible value's warning as one line and go on."""
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
        if _DEBUG["on"]:
            raise
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except (typer.Exit, SystemExit) as exc:
        code = getattr(exc, "exit_code", getattr(exc, "code", 0))
        sys.exit(code or 0)
    except typer.Abort:
        typer.echo("aborted", err=True)
        sys.exit(130)
    except KeyboardInterrupt:  # a command with nothing to save (runs report their own)
        code = 130
    except Exception as exc:  # command-line usage errors come through here too
        line = usage_error_line(exc, args)  # by what they carry: their classes move between typer versions
        if line is not None:
            typer.echo(f"error: {line}", err=True)
            sys.exit(2)
        if _DEBUG["on"]:
            raise
        typer.echo(f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)", err=True)
        sys.exit(1)
    if code == 130 and _INTERRUPTED and not _INTERRUPTED[0]:  # no command reported it
        typer.echo("interrupted by SIGINT", err=True)
    if isinstance(code, int) and code:
        sys.exit(code)
