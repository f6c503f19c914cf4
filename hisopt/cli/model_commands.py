"""Commands on one problem's model: ``init``, ``modes``, ``layouts``, ``droptest``,
``evaluate``, ``response`` and ``envelope``; :func:`register` adds them to the app."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from hisopt.cli.options import ScenarioOpt, SetOpt, load
from hisopt.cli.usage import ProblemArg, SchedulerOpt, WorkersOpt, quantity

PROBLEM_TEMPLATE = "roll_plane_his.toml"  # in hisopt/data/; the same file as problems/roll_plane_his.toml


def modes(problem: ProblemArg, set_: SetOpt = None, scenario: ScenarioOpt = None) -> None:
    """Modes without and with HIS (paper Table 1).

    Natural frequency, damping ratio and motion of each mode of the baseline design, and how
    the HIS shifts each frequency. Modes are named by their shape (the same mode has the same
    name without and with HIS); the older wheel-mode names are listed below the table.
    """
    from hisopt.cli.console import print_modes

    print_modes(load(problem, set_, scenario))


def layouts(
    problem: Annotated[Path | None, typer.Argument(metavar="PROBLEM", help="problem file whose [his] values are used (default: the paper's problem)")] = None,
    set_: SetOpt = None,
) -> None:
    """Catalogue of HIS layouts and what each one stiffens.

    For every catalogue layout (and the problem's own custom layout), at the problem's
    baseline values: the static stiffness it adds per unit stroke pattern (bounce 1 1 1 1,
    roll 1 -1 1 -1, pitch 1 1 -1 -1, warp 1 -1 -1 1 for FL FR RL RR; per metre of the
    pattern's amplitude), its low-frequency damping and the largest static coupling between
    patterns (docs/model.md §12.4). Select a layout with [his] layout = "NAME".
    """
    import pandas as pd
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from hisopt.studies.screening import mode_stiffness
    from hisopt.units import display_frame

    p = load(problem, set_) if problem is not None else None
    frame = mode_stiffness(p)
    notes = frame["damper_valves"] if "damper_valves" in frame.columns else pd.Series("", index=frame.index)
    shown = display_frame(frame.drop(columns=["summary", "damper_valves"], errors="ignore"))
    source = p.name if p is not None else "the paper's problem"
    table = Table(title=Text(f"HIS layouts at the baseline of {source}: added stiffness and low-frequency damping per unit stroke pattern"))
    for col in shown.columns:
        table.add_column(Text(col.replace(" [", "\n[")), justify="left" if col.startswith("layout") else "right")
    for row in shown.itertuples(index=False):
        table.add_row(*[Text(v) for v in row])
    console = Console(width=170)
    console.print(table)
    for name, summary, note in zip(frame["layout"], frame["summary"], notes, strict=True):
        console.print(Text(f"{name}: {summary}" + (f"; {note}" if note else "")))
    console.print(Text('select one with [his] layout = "NAME"; descriptions and sources: docs/model.md §12.3'))


def droptest(
    problem: ProblemArg,
    out: Annotated[Path, typer.Option("--out", help="output folder for droptest.csv and droptest.html (a drop test's own folder)")],
    p0: Annotated[
        str,
        typer.Option(
            "--p0", metavar="PRESSURES", help='accumulator precharges (gauge), comma-separated; bare numbers in Pa, or with a unit, e.g. "1 MPa,2 MPa"'
        ),
    ] = "1e6,2e6,3e6",
    height: Annotated[
        float,
        typer.Option(
            "--height",
            parser=quantity("m"),
            metavar="HEIGHT",
            help="drop height (the wheels roll off blocks this high); a bare number in m, or with a unit, e.g. 5cm",
        ),
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
    case: Annotated[str | None, typer.Option("--case", help="drop test the --measured file records: front_axle, left_side or all_wheels")] = None,
    measured_p0: Annotated[
        float | None,
        typer.Option(
            "--measured-p0",
            parser=quantity("Pa"),
            metavar="PRESSURE",
            help='precharge (gauge) of the measured test, a bare number in Pa or with a unit, e.g. "2 MPa" (default: the problem\'s p0)',
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
    from hisopt.simulation.droptest import (
        DROP_CASES,
        check_drop_arguments,
        drop_table,
        measured_drop_test,
        read_measured,
        run_drop_tests,
        spectra_figure,
        unpaired_notes,
    )
    from hisopt.specification.validation import parameter_rule
    from hisopt.units import display_for, format_number

    p0_values = [to_si(v, "Pa", key="--p0") for v in p0.split(",") if v.strip()]
    check_drop_arguments(p0_values, height, mode, {"p0": "--p0", "height": "--height", "mode": "--mode"})
    if measured_p0 is not None and (measured is None or not parameter_rule("p0").holds(measured_p0)):
        raise ConfigError(f"expected a finite precharge >= 0 Pa with --measured, got {measured_p0!r}", key="--measured-p0")
    if (measured is None) != (case is None):
        raise ConfigError("--measured and --case go together: name the file and which drop test it records", key="--case")
    if case is not None and case not in DROP_CASES:
        raise ConfigError(f"expected one of {', '.join(DROP_CASES)}, got {case!r}", key="--case")

    if measured is not None:
        read_measured(measured)  # fail before the simulations if the file is unusable
    prob = load(problem, set_)
    from hisopt.folders import DROPTEST, claim

    claim(out, DROPTEST)  # before any work: a folder of another kind, or a user's, is refused
    tests = run_drop_tests(prob, p0_values, height, mode=mode)  # type: ignore[arg-type]
    if measured is not None:
        p0_meas = prob.spec.his.p0 if measured_p0 is None else measured_p0
        tests.append(measured_drop_test(prob, measured, case, p0_meas))  # type: ignore[arg-type]
    frame = drop_table(tests)
    try:
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


def evaluate(
    problem: ProblemArg,
    set_: SetOpt = None,
    designs: Annotated[
        Path | None,
        typer.Option(
            help="CSV with one column per design variable, e.g. examples/designs.csv; an optional units row "
            "below the header ([MPa], [cm^2], [-]) gives each column's unit, else SI"
        ),
    ] = None,
    out: Annotated[Path | None, typer.Option(help="results CSV (designs plus objective and constraint columns)")] = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    valves: Annotated[
        bool,
        typer.Option(
            "--valves",
            help="also each damper valve's RMS flow and equivalent resistance per design and load case, "
            "outside the linearisation's validated range marked (with --out: OUT_valves.csv beside OUT)",
        ),
    ] = False,
    build: Annotated[
        bool,
        typer.Option(
            "--build",
            help="also each buildability rule's usage per design and load case and the verdict (buildable, binding rule, margin), "
            "whether or not the problem constrains them (with --out: OUT_build.csv beside OUT)",
        ),
    ] = False,
) -> None:
    """Objectives and constraints of the baseline or a CSV file.

    Without --designs, of the problem's baseline design; with it, of every row. The
    table shows the first 20 designs; --out writes them all. A row that breaks a
    parameter's rule or is not finite is not evaluated, a row outside the [variables] box
    is; both are flagged in the status and reason columns, never feasible, and counted in
    one warning line. With physical damper valves, one more warning line counts the
    designs with a valve outside the linearisation's validated range (equivalent
    resistance over 1 GPa s/m^3); --valves lists every valve. --build adds every
    buildability rule's usage per load case and each design's verdict (docs/model.md §21.3).
    A file beside OUT (OUT_valves.csv, OUT_build.csv) is written over only if it is the
    same table from before. docs/model.md §8.1.
    """
    from rich.console import Console

    from hisopt.errors import ConfigError
    from hisopt.io import ensure_writable_file, write_csv
    from hisopt.specification.designs import read_designs
    from hisopt.specification.validation import flag_summary

    p = load(problem, set_)
    valves_out = None if out is None else out.with_name(f"{out.stem}_valves.csv")
    build_out = None if out is None else out.with_name(f"{out.stem}_build.csv")
    if valves:
        from hisopt.studies.damper_valves import check_damper_valves

        check_damper_valves(p, "--valves")
    if out is not None:
        from hisopt.io import ensure_own_table

        ensure_writable_file(out, "--out")  # fail before any work
        if valves and valves_out is not None:
            from hisopt.studies.damper_valves import VALVE_TABLE_COLUMNS

            ensure_own_table(valves_out, VALVE_TABLE_COLUMNS, "a damper valve table (evaluate --valves)")
        if build and build_out is not None:
            from hisopt.studies.build_views import usage_columns

            ensure_own_table(build_out, usage_columns(), "a buildability table (evaluate --build)")
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
    _valve_states(p, result, str(designs) if designs is not None else "baseline design", valves, valves_out if out is not None else None)
    if build:
        _build_rules(p, result, build_out)


def _valve_states(p: Any, result: Any, source: str, valves: bool, out: Path | None) -> None:
    """For a problem with damper valves: the line counting designs outside the validated range,
    and with ``valves`` each valve's RMS flow and equivalent resistance (printed, and written
    to ``out``)."""
    from hisopt.studies import damper_valves

    if not damper_valves.has_damper_valves(p):
        return
    cases = damper_valves.load_case_valves(p, result[list(p.variable_names)])
    summary = damper_valves.outside_summary(cases, source)
    if summary:
        typer.echo(f"warning: {summary}", err=True)
    if not valves:
        return
    from rich.console import Console

    from hisopt.cli.console import units_table
    from hisopt.units import display_frame

    table = damper_valves.valve_table(cases)
    if out is not None:
        from hisopt.io import write_csv

        write_csv(table, out)
        typer.echo(f"wrote {len(table)} valve rows to {out}")
    shown = table[table["design"] < 20].drop(columns="converged")
    shown.attrs = {"units": table.attrs["units"]}
    Console(width=200).print(units_table(display_frame(shown), f"{p.name}: damper valves (design: row from 0)", transposed_rows=0))
    typer.echo(damper_valves.range_note())


BUILD_SHOWN = 5
"""Designs whose every rule ``evaluate --build`` prints (the verdicts of the first 20)."""


def _build_rules(p: Any, result: Any, out: Path | None) -> None:
    """Every buildability rule's usage of the designs in every load case (printed for the first
    :data:`BUILD_SHOWN`, the verdicts of the first 20, and all written to ``out``)."""
    from rich.console import Console

    from hisopt.cli.console import units_table
    from hisopt.coupled.buildability import RULES
    from hisopt.io import write_csv
    from hisopt.studies.build_views import ALL_CASES, usage_table, verdict_sentence
    from hisopt.studies.buildability import VERDICT_COLUMNS, load_case_rules, rule_sheet
    from hisopt.units import display_frame

    cases = load_case_rules(p, result[list(p.variable_names)])
    table = usage_table(cases)
    if out is not None:
        write_csv(table, out)
        typer.echo(f"wrote {len(table)} rows ({len(result)} designs, each load case and {ALL_CASES!r}) to {out}")
    console = Console(width=200)
    names = [c.name for c in cases] + [ALL_CASES]
    for design in range(min(len(result), BUILD_SHOWN)):
        usages = table[table["design"] == design].set_index("load_case").loc[names, list(RULES)].T
        shown = display_frame(usages.rename_axis("rule").reset_index(), dict.fromkeys(["rule", *names], "-"))
        console.print(units_table(shown, f"design {design}: each rule's usage per load case (at most 1: it holds)", transposed_rows=0))
        typer.echo(verdict_sentence(rule_sheet(cases, design)))
    if len(result) > BUILD_SHOWN:
        verdict = table[table["load_case"] == ALL_CASES][["design", *VERDICT_COLUMNS]].head(20)
        verdict.attrs = {"units": table.attrs["units"]}
        console.print(units_table(display_frame(verdict), f"{p.name}: buildability verdict (design: row from 0)", transposed_rows=0))
        typer.echo(f"each rule of the first {BUILD_SHOWN} of {len(result)} designs shown; --out FILE writes every design's (FILE_build.csv)")


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


def response(
    problem: ProblemArg,
    out: Annotated[Path, typer.Option(help="output folder for response.csv and response.html (a response study's own folder)")],
    set_: SetOpt = None,
) -> None:
    """Response spectra with and without HIS (paper Figure 4).

    Writes OUT/response.csv and OUT/response.html (interactive, works offline).
    """
    from hisopt.folders import RESPONSE, claim
    from hisopt.io import write_csv
    from hisopt.plotting.theme import write_html
    from hisopt.studies.spectra import response_spectra

    p = load(problem, set_)
    claim(out, RESPONSE)  # before any work: a folder of another kind, or a user's, is refused
    spectra = response_spectra(p)
    write_csv(spectra.frame, out / "response.csv")
    write_html(spectra.plot(), out / "response.html")
    typer.echo(f"wrote {out / 'response.csv'} and {out / 'response.html'}")


def envelope(
    problem: ProblemArg,
    set_: SetOpt = None,
    knee: Annotated[Path | None, typer.Option(help="a run directory: take its knee design (front.csv) instead of the baseline")] = None,
    out: Annotated[Path | None, typer.Option(help="CSV of the table (SI units, with a units row)")] = None,
) -> None:
    """A design at every temperature and load of the problem.

    docs/model.md §16. Per temperature and payload: the body's static ride height, each circuit's static
    pressure, its accumulators' gas share and pressure over precharge, the roll gradient and
    sigma_aw on the problem's [road]. The baseline design (with --set), or a run's knee.
    """
    from rich.console import Console

    from hisopt.cli.console import units_table
    from hisopt.io import write_csv
    from hisopt.studies.envelope import envelope_table, knee_design, shown_envelope
    from hisopt.units import display_frame

    p = load(problem, set_)
    design = None if knee is None else knee_design(p, knee)
    table = envelope_table(p, design)
    if out is not None:
        write_csv(table, out)
        typer.echo(f"wrote {out}")
    model = table["model"].iloc[0]
    which = f"knee of {knee}" if knee is not None else "baseline design"
    title = f"{p.name}: {which}, {model} model, road {p.spec.road.road_class} at {p.spec.road.speed:g} m/s"
    Console(width=220).print(units_table(display_frame(shown_envelope(table)), title))
    if model == "ideal":
        typer.echo("ideal: the paper's idealisation (accumulators at their precharge, no oil in them); [his.charge] models a charged HIS")


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``, in the order ``hisopt --help`` lists them."""
    for command in (modes, layouts, droptest, evaluate, init, response, envelope):
        app.command()(command)
