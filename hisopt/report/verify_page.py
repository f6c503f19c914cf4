"""``verify.html``: one design verified in the time domain, as one offline page (docs/model.md
§22.5).

The page says the verdict and what it rests on (the realisations and record of each load
case, the notes on the model's validity), tables every figure of every load case in
engineering units (frequency domain, linear and nonlinear simulations with their standard
errors, the gap, the limit, the verdict coloured) and the manoeuvres, and draws per load case
the worst second of both models with the pressure limits, each pressure's range against its
limits, and the simulated spectra over the frequency domain's. plotly.js is embedded once
(:mod:`hisopt.report.embed`).
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.report.embed import PageFigures
from hisopt.report.tables import REPORT_CSS
from hisopt.simulation.verification_rows import MATERIAL_GAP
from hisopt.units import Display, format_design, format_number

if TYPE_CHECKING:
    from hisopt.simulation.verification import CaseVerification, Verification

VERDICT_CLASSES = {
    "agrees": "ok",
    "within limits": "ok",
    "small gap": "small",
    "gap": "gap",
    "beyond limit": "bad",
    "outside validity": "bad",
    "info": "info",
}
"""The colour class of each verdict's cell."""

VERDICT_CSS = """
.verdict{display:inline-block;padding:1px 8px;border-radius:10px;font-weight:600}
.verdict.ok{background:#e3f1e6;color:#1e6b34} .verdict.small{background:#eef3d9;color:#56641a} .verdict.gap{background:#fdf0d5;color:#8a5a00}
.verdict.bad{background:#fbe3e1;color:#a3261e} .verdict.info{background:#eef1f5;color:#556}
h1 .verdict{font-size:20px;vertical-align:middle}
table.data.figures th,table.data.figures td{padding:4px 8px}
table.data td.what{white-space:normal;min-width:170px;max-width:250px;color:#556;font-size:13px}
ul.notes{color:#1d2330;line-height:1.5}
"""

VERDICT_SENTENCES = {
    "agrees": "every figure the nonlinear model gives agrees with the linear model's within three standard errors, and every extreme is within its limit",
    "gap": "some figures of the nonlinear model differ from the linear model's by more than three standard errors (the table names the "
    "nonlinearity that causes each gap); every extreme is within its limit and the model within its validity",
    "beyond limit": "a pressure or gas volume of the nonlinear run goes beyond its limit (the rows marked beyond limit)",
    "outside validity": "the nonlinear run leaves the model's validity (the notes say where and how): its figures there are not to be trusted",
}
"""What a design's verdict means, in words."""

FIGURE_WORDS = {
    "sigma_aw": "weighted RMS acceleration (ISO 2631-1)",
    "rms_stroke": "RMS suspension stroke, {} (the largest)",
    "rms_tire_load": "RMS dynamic tyre load, {} (the largest)",
    "rms_valve_flow": "RMS flow, damper valve {} (the largest)",
    "peak_stroke": "peak suspension stroke, any wheel",
    "tyre_off_share": "time a tyre is off the ground (the worst tyre)",
    "peak_valve_flow": "peak damper valve flow",
    "blowoff_share": "time a damper valve is on its blow-off (the worst)",
    "chamber_pressure_min": "lowest chamber pressure (gauge)",
    "chamber_pressure_max": "highest chamber pressure (gauge)",
    "peak_strut_force": "peak strut force",
    "accumulator_pressure_min": "lowest pressure, accumulator {} (gauge)",
    "accumulator_pressure_max": "highest pressure, accumulator {} (gauge)",
    "gas_volume_min": "smallest gas volume of an accumulator",
    "gas_volume_max": "largest gas volume of an accumulator",
}
"""What each figure of ``verify.csv`` is (``{}``: its wheel, valve or accumulator)."""

MISSING = "–"
"""A cell without a value (a model not run, a figure without a limit)."""


def figure_words(figure: str) -> str:
    """What a figure is, in words: ``rms_stroke_fl`` -> ``RMS suspension stroke, FL (the largest)``."""
    if figure in FIGURE_WORDS:
        return FIGURE_WORDS[figure]
    stem, _, which = figure.rpartition("_")
    if stem in FIGURE_WORDS:
        return FIGURE_WORDS[stem].format(which.upper() if which.isalpha() else which)
    return figure


def row_display(unit: str, values: list[float]) -> Display:
    """How a row's numbers are shown: in its kind's unit (:data:`hisopt.plotting.verify.VERIFY_UNITS`,
    a share in %), else the engineering unit of its largest value."""
    from hisopt.plotting.verify import verify_display

    return verify_display(unit, np.asarray([v for v in values if math.isfinite(v)] or [0.0]))


def _value(shown: Display, value: float, error: float = math.nan) -> str:
    if not math.isfinite(value):
        return MISSING
    text = shown.number(value)
    return f"{text} ± {format_number(abs(error) * shown.scale, 2)}" if math.isfinite(error) else text


def _limit(figure: str, shown: Display, limit: float) -> str:
    if not math.isfinite(limit):
        return MISSING
    side = "≥" if figure.endswith("_min") or figure.rsplit("_", 1)[0].endswith("_min") else "≤"
    return f"{side} {shown.number(limit)}"


def _gap(gap: float, error: float) -> str:
    if not math.isfinite(gap):
        return MISSING
    text = format_number(100.0 * gap, 3)
    text = text if text.startswith("-") or text == "0" else f"+{text}"
    return f"{text} ± {format_number(100.0 * abs(error), 2)}" if math.isfinite(error) else text


def figures_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Every figure (``verify.csv``'s rows, SI) for reading: one unit per row in engineering
    units, each estimate with its standard error, the gap in %, the limit with its side and
    the verdict (with its cause)."""
    rows = []
    for r in frame.itertuples(index=False):
        shown = row_display(r.unit, [float(r.frequency_domain), float(r.linear), float(r.nonlinear), float(r.limit)])
        cause = r.cause if isinstance(r.cause, str) and r.cause else ""
        rows.append(
            {
                "load case": r.case,
                "figure": r.figure,
                "what": figure_words(r.figure),
                "unit": shown.unit,
                "frequency domain": _value(shown, float(r.frequency_domain)),
                "linear ± SE": _value(shown, float(r.linear), float(r.linear_se)),
                "nonlinear ± SE": _value(shown, float(r.nonlinear), float(r.nonlinear_se)),
                "gap ± SE [%]": _gap(float(r.gap), float(r.gap_se)),
                "limit": _limit(r.figure, shown, float(r.limit)),
                "verdict": f"{r.verdict} ({cause})" if cause else r.verdict,
            }
        )
    return pd.DataFrame(rows)


def manoeuvres_table(frame: pd.DataFrame) -> pd.DataFrame:
    """The manoeuvres' figures (SI, a unit per row) for reading: each row in its engineering
    unit, and the nonlinear run against the linear one in %."""
    rows = []
    numeric = [c for c in ("transient", "linear", "nonlinear") if c in frame.columns]
    others = [c for c in frame.columns if c not in (*numeric, "case", "manoeuvre", "figure", "unit")]
    extras = [c for c in others if frame[c].map(lambda v: not pd.isna(v) and str(v) != "").any()]  # a column of blanks says nothing
    for _, r in frame.iterrows():
        values = [float(r[c]) for c in numeric]
        shown = row_display(str(r.get("unit", "")), values)
        row: dict[str, Any] = {"load case": r.get("case", ""), "manoeuvre": r.get("manoeuvre", ""), "figure": r.get("figure", ""), "unit": shown.unit}
        row |= {c: _value(shown, float(r[c])) for c in numeric}
        if "linear" in numeric and "nonlinear" in numeric and float(r["linear"]) != 0.0:
            row["nonlinear vs linear [%]"] = _gap(float(r["nonlinear"]) / float(r["linear"]) - 1.0, math.nan)
        for extra in extras:
            row[extra] = "" if pd.isna(r[extra]) else str(r[extra])
        rows.append(row)
    return pd.DataFrame(rows)


TEXT_COLUMNS = ("load case", "figure", "what", "unit", "verdict", "manoeuvre", "cause")
"""The columns of words (set left)."""


def verdict_table(shown: pd.DataFrame, caption: str = "") -> str:
    """An HTML table of strings (as :func:`hisopt.report.tables.html_table` makes them) whose
    ``verdict`` cells are coloured by :data:`VERDICT_CLASSES`."""

    def header(col: str) -> str:
        name, sep, unit = col.partition(" [")
        cls = ' class="text"' if col in TEXT_COLUMNS else ""
        return f"<th{cls}>{html.escape(name)}" + (f'<span class="unit">[{html.escape(unit)}</span>' if sep else "") + "</th>"

    def cell(col: str, value: Any) -> str:
        text = html.escape(str(value))
        if col == "verdict":
            kind = VERDICT_CLASSES.get(str(value).split(" (")[0], "info")
            text = f'<span class="verdict {kind}">{text}</span>'
        classes = " ".join(c for c, on in (("text", col in TEXT_COLUMNS), ("what", col == "what")) if on)
        return f'<td class="{classes}">{text}</td>' if classes else f"<td>{text}</td>"

    head = "".join(header(str(c)) for c in shown.columns)
    body = "".join("<tr>" + "".join(cell(str(c), v) for c, v in zip(shown.columns, row, strict=True)) + "</tr>" for row in shown.itertuples(index=False))
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<table class="data figures">{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


# --- what the figures are drawn from ----------------------------------------------------------------
def pressure_limits(rows: list[dict[str, Any]]) -> dict[str, list[tuple[str, float]]]:
    """The lines of the worst second's pressure panels from a load case's rows: the chambers'
    floor and ceiling, each accumulator's (one label when they share a value)."""
    by_figure = {r["figure"]: float(r["limit"]) for r in rows}
    out: dict[str, list[tuple[str, float]]] = {"p_port_": [], "p_acc_": []}
    for side, figure in (("floor", "chamber_pressure_min"), ("ceiling", "chamber_pressure_max")):
        if figure in by_figure:
            out["p_port_"].append((side, by_figure[figure]))
    for side, stem in (("floor", "accumulator_pressure_min_"), ("ceiling", "accumulator_pressure_max_")):
        limits = {f.removeprefix(stem): v for f, v in by_figure.items() if f.startswith(stem)}
        if len(set(limits.values())) == 1:
            out["p_acc_"].append((side, next(iter(limits.values()))))
        else:
            out["p_acc_"] += [(f"{side}, accumulator {j}", v) for j, v in limits.items()]
    return out


def pressure_ranges(rows: list[dict[str, Any]]) -> list[tuple[str, dict[str, tuple[float, float]], tuple[float, float]]]:
    """Each pressure's range by source and its (floor, ceiling) from a load case's rows
    (:func:`hisopt.plotting.verify.pressure_range_figure`)."""
    by_figure = {r["figure"]: r for r in rows}
    pairs = [("chambers", "chamber_pressure_min", "chamber_pressure_max")]
    pairs += [(f"accumulator {f.rsplit('_', 1)[1]}", f, f.replace("_min_", "_max_")) for f in by_figure if f.startswith("accumulator_pressure_min_")]
    out = []
    for name, low, high in pairs:
        if low not in by_figure or high not in by_figure:
            continue
        a, b = by_figure[low], by_figure[high]
        spans = {
            label: (float(a[key]), float(b[key]))
            for label, key in (("frequency domain", "frequency_domain"), ("linear", "linear"), ("nonlinear", "nonlinear"))
            if math.isfinite(float(a[key])) and math.isfinite(float(b[key]))
        }
        out.append((name, spans, (float(a["limit"]), float(b["limit"]))))
    return out


def case_section(case: CaseVerification, page: PageFigures, index: int) -> str:
    """One load case: its realisations and notes, the worst second, the pressure ranges and the spectra."""
    from hisopt.plotting.verify import pressure_range_figure, verify_spectra_figure, worst_second_figure

    traces = case.traces
    name = html.escape(traces.case)
    parts = [f'<h2 id="case-{name}">Load case {name}</h2>']
    counts = pd.Series([r["verdict"] for r in case.rows]).value_counts()
    said = ", ".join(f"{int(n)} {v}" for v, n in counts.items())
    parts.append(f'<p class="meta">{case.realisations} road realisations, each with its mirror; figures: {html.escape(said)}.</p>')
    if case.notes:
        parts.append('<ul class="notes">' + "".join(f"<li>{html.escape(n)}</li>" for n in case.notes) + "</ul>")
    worst = worst_second_figure(
        traces.t_s,
        traces.signals,
        traces.units,
        pressure_limits(case.rows),
        f"{traces.case}: the worst second of the first road (largest mean square of the CG's vertical acceleration)<br>"
        "<sup>nonlinear solid, linear dotted (the same road); pressure limits dashed red</sup>",
    )
    parts.append('<div class="figure">' + page.div(worst, f"worst{index}") + "</div>")
    ranges = pressure_ranges(case.rows)
    if ranges:
        figure = pressure_range_figure(
            ranges, f"{traces.case}: each pressure's range over every record against its limits<br><sup>frequency domain: static ± 3 road sigmas</sup>"
        )
        parts.append('<div class="figure">' + page.div(figure, f"ranges{index}") + "</div>")
    units = dict(traces.units) | {n: u for n, u in SPECTRUM_UNITS.items() if n not in traces.units}
    spectra = verify_spectra_figure(
        traces.f_hz,
        traces.spectra,
        units,
        f"{traces.case}: spectra of the simulated records over the frequency domain's<br><sup>Welch averages over every record after settling</sup>",
    )
    parts.append('<div class="figure">' + page.div(spectra, f"spectra{index}") + "</div>")
    return "\n".join(parts)


SPECTRUM_UNITS = {"acc_z": "m/s^2", "acc_roll": "rad/s^2", "acc_pitch": "rad/s^2", "stroke_fl": "m", "tire_load_fl": "N"}
"""[SI] The units of the spectra's outputs not among the traces' signals."""


# --- the page --------------------------------------------------------------------------------------
def header_html(v: Verification, variable_units: Mapping[str, str] | None) -> str:
    """The verdict in words, the design, the sampling of each load case and the notes."""
    verdict = v.verdict
    frame = v.frame()
    counts = frame["verdict"].value_counts()
    said = ", ".join(f"{int(n)} {k}" for k, n in counts.items())
    if variable_units is not None:
        design = format_design(v.values, variable_units)
    else:
        design = ", ".join(f"{k} = {format_number(x)}" for k, x in v.values.items()) + " (SI)"
    s = v.settings
    chosen = (
        f"{s.realisations} per load case (as asked)"
        if s.realisations is not None
        else f"chosen per load case for a standard error of sigma_aw at most {format_number(100 * s.target_se)} % "
        f"({s.first_realisations} to {s.max_realisations})"
    )
    per_case = ", ".join(f"{c.traces.case}: R = {c.realisations}" for c in v.cases)
    lines = [
        f'<h1>Time-domain verification: {html.escape(v.problem)}, {html.escape(v.design)} <span class="verdict {VERDICT_CLASSES.get(verdict, "info")}">'
        f"{html.escape(verdict)}</span></h1>",
        f'<p class="meta"><b>Verdict: {html.escape(verdict)}</b>: {html.escape(VERDICT_SENTENCES.get(verdict, verdict))}. '
        f"{len(frame)} figures over {len(v.cases)} load cases: {html.escape(said)}.</p>",
        f'<p class="meta">Design: {html.escape(design)}.</p>',
        f'<p class="meta">Each load case drives the car over R seeded ISO 8608 road realisations (each with its mirror, the right track '
        f"negated), T = {format_number(s.duration_s)} s recorded after {format_number(s.settle_s)} s of settling, seed {s.seed}; "
        f"R {html.escape(chosen)}: {html.escape(per_case)}. The same roads drive the linear model (the state space the frequency "
        "domain integrates) and the nonlinear one (gas law, valve laws, tyre lift-off).</p>",
    ]
    if v.notes:
        notes = "".join(f"<li>{html.escape(n)}</li>" for n in v.notes)
        lines.append(f'<p class="meta"><b>Notes on the model\'s validity</b>:</p><ul class="notes">{notes}</ul>')
    else:
        lines.append('<p class="meta">The nonlinear model stayed within its validity on every road.</p>')
    links = " · ".join(f'<a href="#case-{html.escape(c.traces.case)}">{html.escape(c.traces.case)}</a>' for c in v.cases)
    lines.append(f'<p class="meta">Load cases: {links}.</p>')
    return "\n".join(lines)


TABLE_NOTE = (
    "frequency domain: the evaluator's value (RMS figures: exact expectations; peaks: Davenport's expected largest value over T; "
    "tyre-off share: the Gaussian share beyond the static load; pressures: static ± 3 road sigmas). linear, nonlinear: the "
    "simulations' means over the realisations ± their standard errors (extremes: the lowest or highest over every record). "
    "gap: nonlinear over linear on the same roads, minus 1 (RMS figures: the square root of the mean squares' ratio) ± its "
    "standard error; agrees: within three standard errors, else a gap with the nonlinearity that causes it (the one whose "
    f"removal takes away at least half of it): a small gap below {format_number(100 * MATERIAL_GAP)} %, too small to change a "
    "design decision. limit: the buildability rules' pressure limits and the model's validity; "
    "values in each row's unit, SI in verify.csv."
)
"""What the figures table's columns mean."""


def verify_page(v: Verification, variable_units: Mapping[str, str] | None = None) -> str:
    """The text of ``verify.html`` for verification ``v``: a complete offline page.

    Parameters
    ----------
    v : Verification
        the verification (:func:`hisopt.simulation.verification.verify_design`)
    variable_units : Mapping[str, str] | None, optional
        the design variables' SI units (:attr:`hisopt.problem.Problem.variable_units`), to
        show the design in engineering units; without, its values are shown in SI
    """
    page = PageFigures()
    frame = v.frame()
    body = [header_html(v, variable_units)]
    body.append("<h2>Figures per load case</h2>")
    for case in v.cases:
        rows = frame[frame["case"] == case.traces.case]
        caption = f"{case.traces.case}: {case.realisations} road realisations"
        body.append('<div class="figure">' + verdict_table(figures_table(rows).drop(columns=["load case"]), caption) + "</div>")
    body.append(f'<p class="note">{html.escape(TABLE_NOTE)}</p>')
    body.append("<h2>Manoeuvres</h2>")
    if len(v.manoeuvres):
        body.append('<div class="figure">' + verdict_table(manoeuvres_table(v.manoeuvres)) + "</div>")
        body.append(
            '<p class="note">transient: the frequency-domain model\'s closed-form transient quantities; linear, nonlinear: the '
            "simulated manoeuvre in each model.</p>"
        )
    else:
        body.append('<p class="meta">No manoeuvre was simulated.</p>')
    body += [case_section(case, page, i) for i, case in enumerate(v.cases)]
    title = f"hisopt verify: {v.problem}, {v.design}"
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{REPORT_CSS}{VERDICT_CSS}</style>
{page.head_html()}</head>
<body>
{chr(10).join(body)}
{page.scripts_html()}
</body></html>
"""
