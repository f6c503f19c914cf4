"""The command line's run display: a live progress bar, the exit codes of interrupted and
failed runs, and the summary tables (with units) printed at the end."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hisopt.errors import HisoptError

if TYPE_CHECKING:  # the run machinery is imported where a run needs it: `evaluate` prints tables too
    from hisopt.optim.results import GenerationStats, OptimizationResult, ProgressFn


def console_progress(total: int, start: int = 0) -> tuple[Any, ProgressFn]:
    """A rich progress display (on stderr) and its callback: ``(progress, callback)``.

    Use the display as a context manager around the run.
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    progress = Progress(
        TextColumn("[bold]optimising"),
        BarColumn(),
        TextColumn("gen {task.completed:>4.0f}/{task.total:.0f}"),
        TextColumn("evals {task.fields[evals]:>6}"),
        TextColumn("feasible {task.fields[feasible]:>5}"),
        TextColumn("front {task.fields[front]:>5}"),
        TextColumn("HV {task.fields[hv]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True, width=None if sys.stderr.isatty() else 160),  # logs get whole lines
        transient=False,
    )
    task = progress.add_task("optimise", total=total, completed=start, evals="-", feasible="-", front="-", hv="-")

    def update(stats: GenerationStats) -> None:
        progress.update(
            task,
            completed=stats.generation,
            evals=stats.evaluations,
            feasible=f"{100 * stats.feasible_share:.0f}%",
            front=stats.front_size,
            hv=f"{stats.hypervolume:.5g}",
        )

    return progress, update


def run_with_console(start: Callable[[ProgressFn], OptimizationResult], *, total: int, done: int, run_dir: Path, debug: bool = False) -> int:
    """Run ``start(progress_callback)`` under a live progress bar, then print the summary.

    Parameters
    ----------
    start : Callable[[ProgressFn], OptimizationResult]
        [-] starts or resumes the run with the given progress callback
    total : int
        [-] generations of the run
    done : int
        [-] generations already completed
    run_dir : Path
        [-] the run directory (for the resume hint)
    debug : bool, optional
        [-] re-raise an internal error (for its traceback) instead of reporting it

    Returns
    -------
    int
        Exit code: 0; ``128 + signal`` after Ctrl-C (130) or SIGTERM (143), the checkpoint
        saved and the resume command printed on stderr; 1 after an internal error, with one
        line on stderr saying what ``run.json`` now records and what to do.
    """
    from rich.console import Console

    import hisopt.interrupt as interrupt
    from hisopt.optim import runstate

    display, update = console_progress(total, done)
    try:
        with display:
            result = start(update)
    except KeyboardInterrupt as exc:
        print(runstate.interrupted_line(run_dir, exc), file=sys.stderr)
        return interrupt.exit_code(exc)
    except HisoptError:
        raise
    except Exception as exc:
        if debug:
            raise
        line = runstate.state_line(run_dir)
        if type(exc).__name__ not in line:  # the state line names a recorded failure itself
            line = f"{type(exc).__name__}: {exc}; {line}"
        print(f"internal error: {line} (--debug shows a traceback)", file=sys.stderr)
        return 1
    try:
        verdicts = finished_verdicts(result)
    except KeyboardInterrupt as exc:
        print(f"interrupted while judging the front's buildability; the run is finished in {run_dir} (hisopt report judges it)", file=sys.stderr)
        return interrupt.exit_code(exc)
    except Exception as exc:
        if debug:
            raise
        print(f"internal error judging the front's buildability: {type(exc).__name__}: {exc}; the run is finished in {run_dir}", file=sys.stderr)
        verdicts = False
    console = Console(width=120)
    for table in summary_tables(result, verdicts):
        console.print(table)
    return 0


def finished_verdicts(result: OptimizationResult) -> Any:
    """The buildability verdicts of a finished run's front, computed once and stored beside it
    (``buildability.csv``, :func:`hisopt.studies.build_verdicts.write_run_verdicts`) for the
    report and the decision room to read; a DataFrame, one row per front design (None
    without a front)."""
    from hisopt.studies.build_verdicts import BUILDABILITY_CSV, run_verdicts, write_run_verdicts

    front, problem = result.front, result.problem
    if not len(front):
        return None
    if result.run_dir is None:
        return run_verdicts(None, problem, front[list(problem.variable_names)].to_numpy(dtype=float))
    print(f"judging the buildability of {len(front)} front designs -> {result.run_dir / BUILDABILITY_CSV}", file=sys.stderr)
    return write_run_verdicts(result.run_dir, problem, front)


def summary_tables(result: OptimizationResult, verdicts: Any = None) -> list[Any]:
    """Rich tables summarising a run: totals, then the knee design and the ASF pick (with
    units and their buildability verdicts); ``verdicts`` those of the front's designs, in its
    order (:func:`finished_verdicts`; None: read from the run directory or computed; False:
    none shown)."""
    from rich.table import Table
    from rich.text import Text

    from hisopt.plausibility import BOUND_TOLERANCE, bound_note
    from hisopt.studies.build_verdicts import VERDICT_NOTE
    from hisopt.units import display_for, hypervolume_unit

    totals = Table(title=f"{result.problem.name}: {result.settings.algorithm.upper()} run summary", show_header=False)
    totals.add_column("item")
    totals.add_column("value", justify="right")
    rows = [
        ("front size", f"{len(result.front)} designs"),
        *(
            []
            if result.thinned is None or result.epsilon is None
            else [("thinned front", f"{len(result.thinned)} designs (within {result.epsilon.describe()}; front_thinned.csv)")]
        ),
        ("evaluations", f"{len(result.history)}"),
        ("generations", f"{len(result.generations)} of {result.settings.generations}"),
        ("population / seed", f"{result.settings.pop_size} / {result.settings.seed}"),
        ("wall time", f"{result.wall_time_s:.1f} s"),
        ("hypervolume (log10 objectives)", f"{result.hypervolume:.6g} {hypervolume_unit(len(result.problem.objective_names))}"),
        *(
            []
            if result.catalogue_cost is None
            else [
                (
                    "catalogue cost (hypervolume)",
                    result.catalogue_cost.line(hypervolume_unit(len(result.problem.objective_names))) + "; continuous_front.csv",
                )
            ]
        ),
        ("stop rule", stop_words(result)),
        ("run directory", str(result.run_dir) if result.run_dir else "-"),
    ]
    at_bound = bound_summary(result.front, result.problem)
    if at_bound:
        rows.insert(1, ("front at a bound", at_bound.split(" sit ")[0] + " (on_bound column of front.csv)"))
    valves = front_valves(result)
    if valves is not None:
        rows.insert(2, ("damper valves", valves[0]))
    build = None if verdicts is False else front_buildability(result, verdicts)
    if build is not None:
        rows.insert(1, ("buildable", build[0]))
    for item, value in rows:
        totals.add_row(item, Text(value))
    tables: list[Any] = [totals]
    history = result.hypervolume_history()
    if history:
        unit = hypervolume_unit(len(result.problem.objective_names))
        hv = Table(title=Text(f"Hypervolume history (progress estimate, {unit}): still rising at the end means more generations help"))
        hv.add_column("evaluations", justify="right")
        hv.add_column(Text(f"hypervolume [{unit}]"), justify="right")
        hv.add_column("gain since previous row", justify="right")
        previous: float | None = None
        for evaluations, volume in history:
            gain = "" if previous is None or previous <= 0 else f"{100 * (volume / previous - 1):+.3f} %"
            hv.add_row(str(evaluations), f"{volume:.6g}", gain)
            previous = volume
        tables.append(hv)
    if len(result.front):
        of = "" if result.thinned is None else " of the thinned front"
        picks = Table(title=f"Knee and ASF pick{of} (closest to the ideal)")
        picks.add_column(Text("quantity [unit]"))  # Text: brackets are not rich markup
        picks.add_column("knee", justify="right")
        picks.add_column("ASF pick", justify="right")
        knee, asf = result.knee, result.asf_pick()
        units = result.front.attrs.get("units", {})
        problem = result.problem
        bounds = dict(zip(problem.variable_names, zip(problem.lower, problem.upper, strict=True), strict=True))
        marked = False
        for name in result.front.columns:
            # a variable is shown in its box's unit, so a pick at 0 Pa still reads in MPa
            shown = display_for(units.get(name, ""), [knee[name], asf[name], *bounds.get(name, ())], trim=False)
            notes = [bound_note(float(d[name]), *bounds[name]) if name in bounds else "" for d in (knee, asf)]
            marked = marked or any(notes)
            picks.add_row(Text(shown.label(name)), *[Text(shown.number(d[name]) + n) for d, n in zip((knee, asf), notes, strict=True)])
        for label, marks in [] if valves is None else valves[1]:
            picks.add_row(Text(label), *(Text(m) for m in marks))
        for label, marks in [] if build is None else build[1]:
            picks.add_row(Text(label), *(Text(m) for m in marks))
        caption = []
        if marked:
            caption.append(
                f"at lower (upper) bound: within {100 * BOUND_TOLERANCE:g} % of the [variables] box width of "
                "that bound; the box, not the physics, chose that value"
            )
        if build is not None:
            caption.append(VERDICT_NOTE)
        if valves is not None:
            caption.append("outside: a damper valve outside the linearisation's validated range in some load case (hisopt sheet, evaluate --valves)")
        if caption:
            picks.caption = Text("\n".join(caption))
        tables.append(picks)
    return tables


def front_buildability(result: OptimizationResult, verdicts: Any = None) -> tuple[str, list[tuple[str, tuple[str, ...]]]] | None:
    """A summary row counting the front's buildable designs (naming the rules failing most
    often when none is), and the knee's and the ASF pick's ``buildable``, ``binding_rule``
    and ``build_margin`` rows (:mod:`hisopt.studies.build_verdicts`); None without a front."""
    from hisopt.studies.build_verdicts import BUILDABILITY_CSV, buildable_line, run_verdicts, verdict_rows, with_variables

    problem, front = result.problem, result.front
    if not len(front):
        return None
    if verdicts is None:
        verdicts = run_verdicts(result.run_dir, problem, front[list(problem.variable_names)].to_numpy(dtype=float))
    rows = verdict_rows(problem, {"knee": result.knee, "ASF pick": result.asf_pick()}, with_variables(problem, front, verdicts))
    where = f" ({BUILDABILITY_CSV})" if result.run_dir is not None and (result.run_dir / BUILDABILITY_CSV).is_file() else ""
    return buildable_line(verdicts) + where, rows


def front_valves(result: OptimizationResult) -> tuple[str, list[tuple[str, tuple[str, ...]]]] | None:
    """For a problem with damper valves: a summary row counting the front's designs with a valve
    outside the linearisation's validated range in some load case, and rows of the knee's and
    the ASF pick's largest equivalent resistance over the valves and load cases, marked
    ``outside`` there (docs/model.md §3.3); None without damper valves or a front."""
    import numpy as np

    from hisopt.evaluation.valve_states import VALIDATED_RESISTANCE
    from hisopt.studies.damper_valves import designs_outside, has_damper_valves, load_case_valves
    from hisopt.units import display_for

    problem = result.problem
    if not has_damper_valves(problem) or not len(result.front):
        return None
    names = list(problem.variable_names)
    picks = [result.knee, result.asf_pick()]
    x = np.vstack([result.front[names].to_numpy(dtype=float), *(np.array([[float(d[n]) for n in names]]) for d in picks)])
    cases = load_case_valves(problem, x)
    outside = designs_outside(cases)
    n = len(result.front)
    largest = np.nanmax(np.stack([case.states.resistance for case in cases]), axis=(0, 2))[n:]
    shown = display_for("Pa s m^-3", list(largest), trim=False)
    marks = tuple(shown.number(r) + (" (outside)" if out else "") for r, out in zip(largest, outside[n:], strict=True))
    summary = f"{int(outside[:n].sum())} of {n} front designs outside the validated range (over {VALIDATED_RESISTANCE / 1e9:g} GPa s/m^3 in a load case)"
    return summary, [(shown.label("largest valve resistance"), marks)]


def stop_words(result: OptimizationResult) -> str:
    """[-] The run's stop rule in words: its generations, or the convergence criterion and
    whether and where it fired."""
    s = result.settings
    if s.until != "converged":
        return f"all {s.generations} generations"
    rule = f"converged: hypervolume gain < {s.tolerance:g} (relative) over {s.window} generations"
    if result.converged_at is not None:
        return f"{rule}; fired at generation {result.converged_at}"
    return f"{rule}; did not fire within {s.generations} generations"


def print_modes(p: Any) -> None:
    """The ``hisopt modes`` table of problem ``p``'s baseline design, without and with HIS."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from hisopt.coupled.modal import MODE_ALIASES, modal_analysis
    from hisopt.units import format_design, format_number, variable_units

    ref = modal_analysis(p, his=False)
    his = modal_analysis(p)
    design = format_design(dict(zip(p.variable_names, p.baseline, strict=True)), variable_units(p))
    table = Table(title=f"Modes of {p.name} without and with HIS ({design})")
    for col in ("mode", "motion", "f ref [Hz]", "zeta ref [-]", "f HIS [Hz]", "zeta HIS [-]", "change [%]"):
        table.add_column(Text(col), justify="left" if col in ("mode", "motion") else "right")
    merged = his.merge(ref, on="mode", how="left", suffixes=("", "_ref"))
    for row in merged.itertuples():
        rise = round(100 * (row.frequency_hz / row.frequency_hz_ref - 1), 1) + 0.0  # + 0.0: no "-0.0"
        change = f"{rise:+.1f}" if row.frequency_hz_ref == row.frequency_hz_ref else ""
        table.add_row(
            row.mode,
            row.motion,
            format_number(row.frequency_hz_ref, trim=False),
            format_number(row.damping_ratio_ref, trim=False),
            format_number(row.frequency_hz, trim=False),
            format_number(row.damping_ratio, trim=False),
            change,
        )
    console = Console(width=132)
    console.print(table)
    old = "wheel_hop_" + "/".join(k.removeprefix("wheel_hop_") for k in MODE_ALIASES)
    console.print(f"older names: {old} = {', '.join(MODE_ALIASES.values())}")


def units_table(shown: Any, title: str, transposed_rows: int = 4) -> Any:
    """A rich table of :func:`hisopt.units.display_frame` strings (headers ``name [unit]``).

    Up to ``transposed_rows`` rows print transposed, one line per quantity, so that nothing is cut.
    """
    from rich.table import Table
    from rich.text import Text

    table = Table(title=Text(title))
    if len(shown) <= transposed_rows:
        table.add_column(Text("quantity [unit]"))
        for i in range(len(shown)):
            table.add_column("value" if len(shown) == 1 else f"design {i + 1}", justify="right")
        for col in shown.columns:
            table.add_row(Text(col), *[Text(v) for v in shown[col]])
        return table
    for col in shown.columns:
        table.add_column(Text(col.replace(" [", "\n[")), justify="right", overflow="fold")  # unit under the name
    for row in shown.itertuples(index=False):
        table.add_row(*[Text(v) for v in row])
    return table


def refine_with_progress(run_dir: Path, max_points: int, method: str, workers: int | None, scheduler: str | None) -> None:
    """Refine a run's front with a progress bar; in this process unless Dask is asked for."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from hisopt.evaluation.parallel import open_backend
    from hisopt.optim.gradient.refine import method_settings, refine_run, start_designs
    from hisopt.optim.rundir import FRONT_CSV, read_front, refined_files, run_problem

    method_settings(method, None)  # every check before the progress bar
    problem = run_problem(run_dir)[0]
    front = read_front(run_dir / FRONT_CSV)
    start_designs(problem, front, str(run_dir / FRONT_CSV))
    if method == "ipopt":
        from hisopt.optim.gradient.casadi_model import check_valve_flows_given

        check_valve_flows_given(problem)
    bar = Progress(
        TextColumn("[bold]refining"), BarColumn(), TextColumn("{task.completed}/{task.total} designs"), TimeElapsedColumn(), console=Console(stderr=True)
    )
    task = bar.add_task("refine", total=min(max_points, len(front)))
    with open_backend(workers, scheduler) as backend, bar:
        result = refine_run(run_dir, max_points, method=method, backend=backend, progress=lambda _: bar.update(task, advance=1))
    accepted = int(result.points["accepted"].sum()) if len(result.points) else 0
    print(
        f"refined {accepted} of {len(result.points)} designs; hypervolume {result.hypervolume_before:.6g} -> "
        f"{result.hypervolume_after:.6g} decades^{len(result.reference_point)} ({100 * result.hypervolume_gain:+.2f} %), "
        f"{result.seconds_per_point:.3g} s per design ({method})"
    )
    line = bound_summary(result.front, problem)
    if line:
        print(f"{line}; see the on_bound column of {refined_files(method)[0]}")
    print(f"wrote {run_dir / refined_files(method)[0]}")


def bound_summary(front: Any, problem: Any) -> str | None:
    """``"3 of 12 designs sit at a bound (p0 (lower): 3)"``, or None when none does
    (:func:`hisopt.plausibility.bound_labels`)."""
    from collections import Counter

    from hisopt.plausibility import BOUND_TOLERANCE, bound_labels

    names = tuple(problem.variable_names)
    labels = bound_labels(front[list(names)].to_numpy(dtype=float), problem.lower, problem.upper, names) if len(front) else []
    counts = Counter(part for label in labels for part in label.split("; ") if part)
    if not counts:
        return None
    each = ", ".join(f"{part}: {counts[part]}" for part in (f"{n} ({side})" for n in names for side in ("lower", "upper")) if part in counts)
    return f"{sum(map(bool, labels))} of {len(labels)} designs sit at a bound of the [variables] box, within {100 * BOUND_TOLERANCE:g} % of its width ({each})"
