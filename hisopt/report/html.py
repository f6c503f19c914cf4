"""``hisopt report RUN_DIR``: one self-contained, offline HTML file of a run.

Figures are plotly, embedded lightly (:mod:`hisopt.report.embed`: plotly.js once, compressed;
the front's numbers as float32, each array once); the other evaluations of the run are in
``decision.html``, not here. Tables are plain HTML tables, so that
they size to their content, wrap instead of clipping and copy into a spreadsheet. Every
number is shown in engineering units (:mod:`hisopt.units`).
"""

from __future__ import annotations

import html
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.errors import RunError
from hisopt.io import read_csv
from hisopt.plausibility import BOUND_TOLERANCE, bound_note, without_bound_column
from hisopt.report.embed import PageFigures
from hisopt.report.tables import REPORT_CSS, html_table
from hisopt.units import (
    column_units,
    display_for,
    display_frame,
    format_number,
    format_quantity,
    hypervolume_unit,
)

if TYPE_CHECKING:
    from hisopt.problem import Problem


def load_run_files(run_dir: str | Path) -> dict[str, Any]:
    """The run's record, front (and thinned and refined fronts, generations if present) and problem copy."""
    from hisopt.optim import rundir

    run_dir = Path(run_dir)
    record = rundir.run_record(run_dir)
    front_path = run_dir / rundir.FRONT_CSV
    if not front_path.is_file():
        raise RunError(f"{front_path}: missing; the run has not finished a generation yet")
    problem = rundir.load_run_problem(run_dir, record["problem"], check_original=False)
    out: dict[str, Any] = {"record": record, "problem": problem, "front": without_bound_column(read_csv(front_path))}
    files = (
        ("thinned", rundir.FRONT_THINNED_CSV),
        ("generations", rundir.GENERATIONS_CSV),
        ("continuous", rundir.CONTINUOUS_FRONT_CSV),
    )
    for key, name in files:
        path = run_dir / name
        out[key] = without_bound_column(read_csv(path)) if path.is_file() else None  # marks: recomputed where shown
    refined = [without_bound_column(read_csv(path)) for path in rundir.refined_fronts(run_dir)]  # SLP's and IPOPT's
    out["refined"] = pd.concat(refined, ignore_index=True) if refined else None
    return out


# --- tables ------------------------------------------------------------------------------------
def modes_table(modes_ref: pd.DataFrame, modes_his: pd.DataFrame) -> pd.DataFrame:
    """Paper Table 1 as display strings: frequencies [Hz] and damping ratios [-] without and with HIS."""
    merged = modes_ref[["mode", "motion", "frequency_hz", "damping_ratio"]].merge(
        modes_his[["mode", "frequency_hz", "damping_ratio"]], on="mode", suffixes=("_ref", "_his")
    )
    frame = pd.DataFrame(
        {
            "mode": merged["mode"],
            "motion": merged["motion"],
            "f without HIS": merged["frequency_hz_ref"],
            "zeta without HIS": merged["damping_ratio_ref"],
            "f with HIS": merged["frequency_hz_his"],
            "zeta with HIS": merged["damping_ratio_his"],
        }
    )
    frame.attrs["units"] = {"mode": "", "motion": "", "f without HIS": "Hz", "zeta without HIS": "-", "f with HIS": "Hz", "zeta with HIS": "-"}
    shown = display_frame(frame)
    change = 100.0 * (merged["frequency_hz_his"] / merged["frequency_hz_ref"] - 1.0)
    shown["change of f [%]"] = [f"{round(v, 1) + 0.0:+.1f}" for v in change]  # + 0.0: no "-0.0"
    return shown


def designs_table(designs: Mapping[str, pd.Series], units: Mapping[str, str], bounds: Mapping[str, tuple[float, float]] | None = None) -> pd.DataFrame:
    """One row per quantity (``name [unit]``), one column per design, engineering units; a
    variable of ``bounds`` (``{name: (lower, upper)}``) at a bound is marked ``(at lower
    bound)`` (:func:`hisopt.plausibility.bound_note`)."""
    names = list(next(iter(designs.values())).index)
    bounds = bounds or {}
    rows = []
    for name in names:
        values = [float(d[name]) for d in designs.values()]
        shown = display_for(units.get(name, ""), values, trim=False)
        notes = [bound_note(v, *bounds[name]) if name in bounds else "" for v in values]
        rows.append([shown.label(name), *[shown.number(v) + note for v, note in zip(values, notes, strict=True)]])
    return pd.DataFrame(rows, columns=["quantity [unit]", *designs])


def scenario_table(problem: Problem, designs: Mapping[str, pd.Series], variables: list[str]) -> pd.DataFrame:
    """The scenario columns (``"sigma_aw@city"``, ...) of each design, re-evaluated, as
    :func:`designs_table` shows them."""
    x = np.array([[float(d[v]) for v in variables] for d in designs.values()])
    df = problem.evaluate(x, log=False)
    columns = list(problem.scenario_columns)
    rows = {label: df.loc[i, columns] for i, label in enumerate(designs)}
    return designs_table(rows, df.attrs["units"])


def settings_table(record: dict[str, Any], n_objectives: int) -> pd.DataFrame:
    """Settings, timings, result and versions of a run, each value with its unit."""
    from hisopt.metrics import METRICS

    settings = record.get("settings", {})
    rows: list[tuple[str, str, str]] = []
    for key, value in settings.items():
        if key == "constraints":
            text = (
                "; ".join(
                    f"{c['name']} <= {format_quantity(float(c['limit']), METRICS[c['name']].unit)}"
                    + (f" ({', '.join(c['scenarios'])})" if c.get("scenarios") else "")
                    + (f" with probability >= {1 - float(c['probability']):g}" if c.get("probability") else "")
                    if c.get("name") in METRICS
                    else json.dumps(c)
                    for c in value
                )
                or "none"
            )
        elif key == "uncertain":  # statistics over common random samples (docs/model.md §18.4)
            text = f"{value['statistic']} over {value['samples']} common random samples (seed {value['seed']}) of {', '.join(value['inputs'])}"
        elif key == "epsilon":  # the thinned front's tolerances, as given
            text = ", ".join(f"{name} {entry['text']}" for name, entry in value.items())
        elif key == "hypervolume_reference_log10":
            text = ", ".join(format_number(float(v)) for v in value) + " decades (log10 of each objective in SI units)"
        elif isinstance(value, list):
            text = ", ".join(map(str, value))
        else:
            text = format_number(value)
        rows.append(("setting", key, text))
    for key, value in record.get("timings", {}).items():
        rows.append(("timing", key, format_quantity(float(value), "s")))
    result_units = {"hypervolume": hypervolume_unit(n_objectives)}
    for key in ("generations", "evaluations", "front_size", "thinned_front_size", "hypervolume"):
        if key in record.get("result", {}):
            value = record["result"][key]
            rows.append(("result", key, format_quantity(value, result_units[key]) if key in result_units else format_number(value)))
    rows.append(("problem", "sha256", record["problem"]["sha256"][:16]))
    for key, value in record.get("versions", {}).items():
        rows.append(("version", key, str(value)))
    return pd.DataFrame(rows, columns=["group", "item", "value"])


# --- the report --------------------------------------------------------------------------------
def envelope_sections(problem: Any, x: np.ndarray, label: str) -> list[tuple[str, Any]]:
    """The design at every temperature and load (docs/model.md §16.7): a figure against
    temperature and the table."""
    from hisopt.plotting.envelope import envelope_figure
    from hisopt.studies.envelope import envelope_table, shown_envelope

    table = envelope_table(problem, x[None, :])
    model = table["model"].iloc[0]
    road = problem.spec.road
    charge = "charged above the precharge, [his.charge]" if model == "charged" else "the paper's idealisation: accumulators at their precharge"
    about = f"{model} model ({charge}); ride and handling on the [road], class {road.road_class} at {format_quantity(road.speed, 'm/s')}"
    return [
        (f"Operating envelope of the {label} design", envelope_figure(table, table.attrs["units"], f"{problem.name}: {about}")),
        (
            f"Operating envelope of the {label} design: the table",
            html_table(display_frame(shown_envelope(table)), f"Every temperature and load of the problem; {about}"),
        ),
    ]


def parts_section(problem: Problem, x: np.ndarray, label: str) -> str:
    """The bill of parts and settings of design ``x`` (as ``hisopt sheet`` writes it)."""
    import warnings

    from hisopt.errors import PlausibilityWarning
    from hisopt.report.sheet import parts_shown
    from hisopt.studies.design_sheet import parts_table

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PlausibilityWarning)  # the run's problem warned when the run started
        design = problem.replace_values(dict(zip(problem.variable_names, (float(v) for v in x), strict=True)))
    caption = f"What to build for the {label} design: its cylinders, accumulators, charge, valves and pipes (hisopt sheet writes the whole sheet)"
    return html_table(parts_shown(parts_table(design)), caption, text_columns=("item", "note"))


def catalogue_section(run: Mapping[str, Any], objectives: list[str], variables: list[str], units: Mapping[str, str], page: PageFigures) -> str | None:
    """A catalogue run's hypervolume against its continuous relaxation's, over both fronts
    (docs/model.md §17.5), its figure on ``page``; None for a run without the relaxation."""
    from hisopt.optim.results import CatalogueCost
    from hisopt.plotting.figures import catalogue_scatter_matrix

    record = run["record"].get("result", {}).get("catalogue_cost")
    if record is None or run["continuous"] is None:
        return None
    cost = CatalogueCost.from_record(record)
    line = cost.line(hypervolume_unit(len(objectives)))
    figure = catalogue_scatter_matrix(run["front"], run["continuous"], objectives, variables, units, design_hover=False)
    note = (
        f"<p>Hypervolume of the catalogue front (log10 objectives): {html.escape(line)}. The relaxation lets every choice "
        "variable take any value between its first and last listed one, with the run's settings and reference point; "
        "below 100 % is the performance the standard parts give up.</p>"
    )
    return note + '<div class="figure">' + page.div(figure, "catalogue") + "</div>"


def build_report(run_dir: str | Path, color_by: str | None = None, design: str = "knee") -> Path:
    """Write ``RUN_DIR/report.html`` (:func:`report_page`) and ``RUN_DIR/decision.html``
    (:func:`hisopt.report.decision_page.run_decision_room`); the report's path.

    Parameters
    ----------
    color_by : str | None, optional
        objective colouring the parallel coordinates (default: the first objective)
    design : str, optional
        design whose spectra and modes are shown: ``knee``, ``asf`` or a row index of the
        front shown (``front_thinned.csv`` when the run has one, else ``front.csv``)
    """
    from hisopt.io import atomic_write_text
    from hisopt.report.decision_page import run_decision_room

    page = report_page(run_dir, color_by, design)
    out = Path(run_dir) / "report.html"
    atomic_write_text(out, page)
    run_decision_room(run_dir)
    return out


def report_page(run_dir: str | Path, color_by: str | None = None, design: str = "knee") -> str:
    """The text of ``RUN_DIR/report.html``: the run's summary, the front's figures and
    tables; every design the run evaluated is in ``decision.html``, which it links, not here.

    A run with epsilon tolerances is shown by its thinned front: the figures, the knee and
    the ASF pick are of ``front_thinned.csv``; the page says how many designs both fronts hold.

    Parameters
    ----------
    color_by : str | None, optional
        objective colouring the parallel coordinates (default: the first objective)
    design : str, optional
        design whose spectra and modes are shown: ``knee``, ``asf`` or a row index of the
        front shown (``front_thinned.csv`` when the run has one, else ``front.csv``)
    """
    from hisopt.coupled.modal import modal_analysis
    from hisopt.hydraulics.catalogue import his_parameter_values
    from hisopt.optim.decision import asf_index, knee_index
    from hisopt.plotting import figures
    from hisopt.report import schematic
    from hisopt.report.decision_page import DECISION_FILE
    from hisopt.studies import build_verdicts
    from hisopt.studies.spectra import response_spectra

    run_dir = Path(run_dir)
    run = load_run_files(run_dir)
    problem, full = run["problem"], run["front"]
    front = full if run["thinned"] is None else run["thinned"]  # what the engineer is shown and picks from
    objectives, variables = list(problem.objective_names), list(problem.variable_names)
    color_by = color_by or objectives[0]
    if color_by not in front.columns:
        from hisopt.errors import ConfigError

        raise ConfigError(f"unknown column {color_by!r}; expected one of {', '.join(objectives)}", key="--color-by")
    if not len(front):
        raise RunError(f"{run_dir}: the front is empty (no feasible design yet)")
    units = column_units(front.columns, problem) | dict(front.attrs.get("units", {}))
    shown_file = "front.csv" if run["thinned"] is None else "front_thinned.csv"
    f = front[objectives].to_numpy()
    knee = front.iloc[knee_index(f)]
    asf = front.iloc[asf_index(f)]
    if design == "knee":
        chosen, chosen_label = knee, "knee"
    elif design == "asf":
        chosen, chosen_label = asf, "ASF pick"
    else:
        try:
            chosen, chosen_label = front.iloc[int(design)], f"front row {int(design)}"
        except (ValueError, IndexError):
            from hisopt.errors import ConfigError

            raise ConfigError(f"expected knee, asf or a row index below {len(front)} (rows of {shown_file}), got {design!r}", key="--design") from None
    x = chosen[variables].to_numpy(dtype=float)
    if run["thinned"] is None:
        front_note = f"front of {len(full)} designs"
    else:
        tolerances = ", ".join(f"{n} {e['text']}" for n, e in run["record"].get("settings", {}).get("epsilon", {}).items())
        front_note = (
            f"front of {len(full)} designs, thinned to {len(front)} designs that differ by more than {tolerances} ({shown_file}: the figures and the picks)"
        )

    modes = modes_table(modal_analysis(problem, x, his=False), modal_analysis(problem, x))
    highlighted = {"knee": knee, "ASF pick": asf}
    designs_caption = "Knee and ASF pick (closest to the ideal point)"
    if chosen_label not in highlighted:
        highlighted[chosen_label] = chosen
        designs_caption += f", and {chosen_label}: the design of the spectra and modes"
    picks = designs_table(highlighted, units, dict(zip(variables, zip(problem.lower, problem.upper, strict=True), strict=True)))
    if any(" bound)" in cell for col in picks.columns[1:] for cell in picks[col]):
        designs_caption += (
            f"; at lower (upper) bound: within {100 * BOUND_TOLERANCE:g} % of the [variables] box width of "
            "that bound, where the box rather than the physics chose the value"
        )
    verdicts = build_verdicts.run_verdicts(run_dir, problem, full[variables].to_numpy(dtype=float))  # stored when the run finished
    stored = build_verdicts.with_variables(problem, full, verdicts)
    verdict_rows = build_verdicts.verdict_rows(problem, highlighted, stored)
    picks = pd.concat([picks, pd.DataFrame([[label, *cells] for label, cells in verdict_rows], columns=picks.columns)], ignore_index=True)
    designs_caption += f"; {build_verdicts.VERDICT_NOTE}"
    front_note += f"; {build_verdicts.buildable_line(verdicts)}"
    if run["thinned"] is not None:
        front_note += f" ({build_verdicts.buildable_line(build_verdicts.verdicts_of(problem, front[variables].to_numpy(dtype=float), stored), 'thinned')})"
    spec = problem.spec
    if spec.scenarios and spec.robust.aggregate == "per_scenario" and len(spec.objectives) > 1:
        pareto = figures.scenario_scatter_matrix(
            front, spec.objectives, problem.scenario_names, variables, {"knee": knee, "ASF pick": asf}, run["refined"], units, design_hover=False
        )
    else:
        pareto = figures.front_scatter_matrix(front, objectives, variables, {"knee": knee, "ASF pick": asf}, run["refined"], units, design_hover=False)
    # a problem with load cases: the spectra of its [road] without payload, as `hisopt response` gives them
    road = f" ([road]: class {spec.road.road_class} at {format_quantity(spec.road.speed, 'm/s')})" if spec.scenarios else ""
    sections: list[tuple[str, Any]] = [
        ("Pareto front", pareto),
        ("Designs and objectives", figures.parallel_coordinates(front, variables, objectives, color_by, units)),
        (f"Response spectra of the {chosen_label} design against the car without HIS{road}", response_spectra(problem, x).plot()),
        (
            f"HIS layout (values of the {chosen_label} design on hover)",
            schematic.layout_schematic(problem.layout(), his_parameter_values(problem.spec.his, dict(zip(variables, map(float, x), strict=True)))),
        ),
        (
            f"Modes of the {chosen_label} design",
            html_table(modes, "Modes without and with HIS (paper Table 1): undamped natural frequency f, damping ratio zeta", text_columns=("mode", "motion")),
        ),
        ("Highlighted designs", html_table(picks, designs_caption, text_columns=("quantity [unit]",))),
        (f"Parts and settings of the {chosen_label} design", parts_section(problem, x, chosen_label)),
    ]
    page_figures = PageFigures()
    cost = catalogue_section(run, objectives, variables, units, page_figures)
    if cost is not None:
        sections.append(("What the catalogues cost", cost))
    if problem.spec.scenarios:
        sections.append(
            (
                "Load cases",
                html_table(
                    scenario_table(problem, highlighted, variables),
                    'Each quantity in each scenario ("quantity@scenario") for the highlighted designs; '
                    + (
                        "every objective minimised in each scenario (per_scenario)"
                        if spec.robust.aggregate == "per_scenario"
                        else f"objectives aggregated as {spec.robust.aggregate}"
                    ),
                    text_columns=("quantity [unit]",),
                ),
            )
        )
    if spec.his.charge is not None or spec.temperatures():
        sections += envelope_sections(problem, x, chosen_label)
    if run["generations"] is not None:
        sections.insert(2, ("Convergence", figures.convergence(run["generations"], len(objectives))))
    sections.append(
        (
            "Run settings and timings",
            html_table(
                settings_table(run["record"], len(objectives)), "Settings, timings, versions", text_columns=("group", "item", "value"), wrap_columns=("value",)
            ),
        )
    )

    parts = []
    for i, (title, content) in enumerate(sections):
        parts.append(f"<h2>{html.escape(title)}</h2>")
        if isinstance(content, str):
            parts.append(content)
        else:
            parts.append('<div class="figure">' + page_figures.div(content, f"fig{i}") + "</div>")
    refined_note = "" if run["refined"] is None else f", refined front of {len(run['refined'])} designs"
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>hisopt report: {html.escape(problem.name)}</title>
<style>{REPORT_CSS}</style>
{page_figures.head_html()}</head>
<body><h1>hisopt report: {html.escape(problem.name)}</h1>
<p class="meta">{html.escape(str(run_dir))}: {html.escape(front_note)}{refined_note};
objectives {html.escape(", ".join(objectives))}; knee and ASF pick highlighted. Values in engineering units
(SI in the CSV files).</p>
<p class="meta">To narrow the front down to one design and hand it over: <a href="{DECISION_FILE}">the decision room</a>
(every design of the run, the front and the other evaluations: linked views, each design's values and spectra,
reference-point and E-NAUTILUS navigation, export). This page shows the front; hover a point for its row.</p>
{"".join(parts)}
{page_figures.scripts_html()}
</body></html>"""
