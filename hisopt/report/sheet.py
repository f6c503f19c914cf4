"""A design sheet (:mod:`hisopt.studies.design_sheet`) as Markdown, HTML and a problem file
(``hisopt sheet RUN_DIR``; docs/model.md §17.4). Every number in engineering units."""

from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

from hisopt.evaluation.valve_states import OUTSIDE_VALIDATED_RANGE
from hisopt.plausibility import bound_labels
from hisopt.report.tables import REPORT_CSS, html_table
from hisopt.studies.build_views import rule_cells, verdict_sentence
from hisopt.studies.damper_valves import OUTSIDE, range_note
from hisopt.studies.design_sheet import DesignSheet, write_problem
from hisopt.studies.envelope import CELSIUS_OFFSET, shown_envelope
from hisopt.units import column_units, display_frame, format_quantity

SHEET_FILES = ("sheet.md", "sheet.html", "sheet.toml")
"""What :func:`write_sheet` writes into its folder."""


def parts_shown(parts: pd.DataFrame) -> pd.DataFrame:
    """The bill of parts (:func:`hisopt.studies.design_sheet.parts_table`) for reading:
    ``item``, ``value`` with its unit, ``note``."""
    return pd.DataFrame(
        {
            "item": parts["item"],
            "value": [_shown(v, u) for v, u in zip(parts["value"], parts["unit"], strict=True)],
            "note": parts["note"],
        }
    )


def _shown(value: float, unit: str) -> str:
    """A part's value in engineering units; a temperature in degC (a point on its scale, which reads back)."""
    return f"{value - CELSIUS_OFFSET:.4g} degC" if unit == "K" else format_quantity(value, unit)


def quantities_shown(sheet: DesignSheet) -> pd.DataFrame:
    """The design's quantities (each load case's too), one per row, for reading."""
    q = sheet.quantities.drop(columns=[c for c in ("feasible", "status", "reason") if c in sheet.quantities])
    q = q.drop(columns=list(sheet.problem.variable_names))
    units = column_units(q.columns, sheet.problem)
    rows = [(name, format_quantity(float(q[name].iloc[0]), units.get(name, ""))) for name in q.columns]
    return pd.DataFrame(rows, columns=["quantity", "value"])


def valves_shown(valves: pd.DataFrame) -> pd.DataFrame:
    """The damper valves' settings (:attr:`DesignSheet.valves`) for reading and pasting back:
    each value with its unit (``3 mm``, ``1.5 MPa``; ``-`` where the valve has no such part)."""
    units = valves.attrs.get("units", {})
    return pd.DataFrame(
        {c: [v if units.get(c) == "-" and isinstance(v, str) else _setting(v, units.get(c, "")) for v in valves[c]] for c in valves.columns},
        index=valves.index,
    )


def _setting(value: object, unit: str) -> str:
    if isinstance(value, str):
        return value
    number = float(value)  # type: ignore[arg-type]  # a setting is a number or a label
    return "-" if number != number else format_quantity(number, unit)


def tables(sheet: DesignSheet) -> list[tuple[str, pd.DataFrame]]:
    """``(title, table of strings)`` of every section, in order (the damper valves' only for a
    problem with physical damper valves)."""
    out = [
        ("Parts and settings", parts_shown(sheet.parts)),
        ("Quantities", quantities_shown(sheet)),
        ("Operating envelope", display_frame(shown_envelope(sheet.envelope))),
        ("Modes with HIS", display_frame(sheet.modes)),
    ]
    if len(sheet.build):
        out.append((BUILD_SECTION, rule_cells(sheet.build)))
    if len(sheet.valve_cases):
        out += [
            (VALVE_SECTIONS[0], valves_shown(sheet.valves)),
            (VALVE_SECTIONS[1], display_frame(sheet.valve_cases)),
            (VALVE_SECTIONS[2], display_frame(sheet.valve_modes)),
        ]
    return out


VALVE_SECTIONS = ("Damper valves", "Damper valves per load case", "Roll and bounce damping per load case")
"""The titles of the damper valves' sections (:func:`tables`)."""
BUILD_SECTION = "Buildability"
"""The title of the section of every buildability rule (:func:`tables`)."""


def notes(sheet: DesignSheet) -> dict[str, str]:
    """A line under a section, by its title: what its columns mean where a number alone does not say."""
    out = {}
    if len(sheet.build):
        out[BUILD_SECTION] = (
            f"{verdict_sentence(sheet.build)} Every rule is computed, whether or not the problem constrains it; each in the load case "
            "where it binds (its largest usage), its value and limit there (pressure: absolute or gauge, as the rule judges it), "
            "margin = 1 - usage in % of the limit; – where the layout has no such part (nothing to check). docs/model.md §21."
        )
    if len(sheet.valve_cases):
        out[VALVE_SECTIONS[0]] = (
            "Each physical damper valve's settings, as [his] takes them (key: the parameter a value comes from where its name differs; "
            "laminar_resistance: the laminar part in series)."
        )
        outside = int((sheet.valve_cases["validated_range"] == OUTSIDE).sum())
        count = f"{outside} of {len(sheet.valve_cases)} valve and load-case pairs are {OUTSIDE}. " if outside else ""
        out[VALVE_SECTIONS[1]] = (
            "flow_rms: the RMS flow the road drives through the valve; resistance: its equivalent linear resistance there "
            f"(the fixed point). {count}{range_note()}"
        )
        out[VALVE_SECTIONS[2]] = "The body's roll and bounce (heave) modes with each load case's equivalent valve resistances."
    return out


VERIFY_SECTION = "Verified in the time domain"
"""The title of the section of the design's time-domain verification (:func:`verification`)."""


def verification(sheet: DesignSheet) -> tuple[str, pd.DataFrame | None]:
    """The section of the design's verification in the time domain (``hisopt verify``):
    ``(line, table)``: the verdict in words, the realisations and record of each load case,
    the notes, and every figure in engineering units; without one, the line that says how
    to make it and no table (``("", None)`` for a sheet not of a run)."""
    from hisopt.report.verify_page import VERDICT_SENTENCES, figures_table
    from hisopt.simulation.verification_rows import MATERIAL_GAP

    found = sheet.verified
    if found is None:
        return sheet.verify_hint, None
    s = found.summary
    cases = ", ".join(f"{case}: R = {r}" for case, r in s["realisations"].items())
    notes = " ".join(s["notes"]) if s["notes"] else "The nonlinear model stayed within its validity on every road."
    line = (
        f"Verdict: {s['verdict']}: {VERDICT_SENTENCES.get(s['verdict'], s['verdict'])}. Each load case on R seeded road realisations "
        f"(each with its mirror) of {format_quantity(float(s['duration_s']), 's')} after {format_quantity(float(s['settle_s']), 's')} "
        f"of settling, seed {s['seed']}: {cases}. {notes} Linear: the state space the frequency domain integrates, on the same roads; "
        "nonlinear: gas law, valve laws, tyre lift-off; gap: nonlinear over linear minus 1, agrees within three standard errors "
        f"(a small gap: beyond them but below {format_quantity(100 * MATERIAL_GAP, '%')}). "
        f"The figures and time histories: {found.folder / 'verify.html'} (SI: verify.csv)."
    )
    return line, figures_table(found.rows).drop(columns=["what"])


def heading(sheet: DesignSheet) -> tuple[str, str]:
    """``(title, line)``: the design and where it comes from, and whether it is feasible."""
    status = sheet.quantities["status"].iloc[0]
    feasible = "feasible" if bool(sheet.quantities["feasible"].iloc[0]) else f"not feasible ({status}: {sheet.quantities['reason'].iloc[0]})"
    p = sheet.problem
    on = bound_labels(p.baseline, p.lower, p.upper, p.variable_names)[0]
    bounds = f" At a bound of [variables] (the box, not the physics, chose it): {on}." if on else ""
    cases = sheet.valve_cases
    outside = sorted(set(cases.loc[cases["validated_range"] == OUTSIDE, "load_case"])) if len(cases) else []
    valves = f" Its damper valves are {OUTSIDE_VALIDATED_RANGE} in: {', '.join(outside)}." if outside else ""
    build = f" {verdict_sentence(sheet.build)}" if len(sheet.build) else ""
    verified = f" Verified in the time domain: {sheet.verified.summary['verdict']}." if sheet.verified is not None else ""
    return f"Design sheet: {p.name}, design {sheet.design}", f"Front row {sheet.design} of {sheet.source}; {feasible}.{bounds}{valves}{build}{verified}"


def markdown(sheet: DesignSheet) -> str:
    """The sheet as Markdown (pipe tables)."""
    title, line = heading(sheet)
    parts = [f"# {title}", "", line, "", "The problem file `sheet.toml` reproduces it: `hisopt evaluate sheet.toml`.", ""]
    said = notes(sheet)
    for name, table in tables(sheet):
        parts += [f"## {name}", "", _pipe_table(table), ""] + ([said[name], ""] if name in said else [])
    line, found = verification(sheet)
    if line:
        parts += [f"## {VERIFY_SECTION}", "", line, ""] + ([_pipe_table(found), ""] if found is not None else [])
    return "\n".join(parts)


def _pipe_table(table: pd.DataFrame) -> str:
    def cell(value: object) -> str:
        return str(value).replace("|", "\\|")

    lines = ["| " + " | ".join(cell(c) for c in table.columns) + " |", "|" + "---|" * len(table.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in table.itertuples(index=False)]
    return "\n".join(lines)


def html_page(sheet: DesignSheet) -> str:
    """The sheet as one self-contained HTML page."""
    title, line = heading(sheet)
    body = [f"<h1>{html.escape(title)}</h1>", f'<p class="meta">{html.escape(line)} The problem file <code>sheet.toml</code> reproduces it.</p>']
    said = notes(sheet)
    for name, table in tables(sheet):
        text = tuple(c for c in table.columns if str(c).split(" [")[0] in TEXT_COLUMNS)
        body += [f"<h2>{html.escape(name)}</h2>", f'<div class="figure">{html_table(table, text_columns=text)}</div>']
        body += [f'<p class="meta">{html.escape(said[name])}</p>'] if name in said else []
    line, found = verification(sheet)
    if line:
        body += [f"<h2>{html.escape(VERIFY_SECTION)}</h2>", f'<p class="meta">{html.escape(line)}</p>']
        body += [f'<div class="figure">{html_table(found, text_columns=VERIFY_TEXT)}</div>'] if found is not None else []
    head = f'<meta charset="utf-8"><title>{html.escape(title)}</title><style>{REPORT_CSS}</style>'
    return f"<!DOCTYPE html><html><head>{head}</head><body>{''.join(body)}</body></html>\n"


VERIFY_TEXT = ("load case", "figure", "unit", "verdict")
"""The columns of words of the verification's table."""
TEXT_COLUMNS = ("item", "note", "quantity", "mode", "motion", "valve", "key", "load_case", "validated_range", "rule", "check", "pressure", "holds")
"""The columns of words, not numbers (set left in the HTML tables)."""


def write_sheet(sheet: DesignSheet, folder: Path) -> list[Path]:
    """Write :data:`SHEET_FILES` into ``folder`` (made if need be); their paths.

    Raises
    ------
    RunError
        ``folder`` is a folder of another kind, or holds files hisopt did not write
        (:func:`hisopt.folders.claim`).
    """
    from hisopt.folders import SHEET, claim

    claim(folder, SHEET)
    paths = [folder / name for name in SHEET_FILES]
    paths[0].write_text(markdown(sheet) + "\n", encoding="utf-8")
    paths[1].write_text(html_page(sheet), encoding="utf-8")
    write_problem(sheet, paths[2])
    return paths
