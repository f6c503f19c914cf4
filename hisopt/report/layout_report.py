"""``DIR/report.html`` of a layout study (:mod:`hisopt.studies.layout_study`): one offline page.

Schematics of the layouts side by side, their fronts overlaid in the shared normalised
objective space, the best comfort against the handling limit, the attainment surfaces across
seeds and the table of ``layouts.csv``; engineering units throughout (:mod:`hisopt.units`).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.plotting.axes import log_axis
from hisopt.plotting.theme import COLORS, template
from hisopt.report.tables import REPORT_CSS, html_table
from hisopt.studies.buildability import BUILDABLE, VERDICT_COLUMNS
from hisopt.units import display_for, display_frame, format_quantity

if TYPE_CHECKING:
    import plotly.graph_objects as go

    from hisopt.studies.layout_study import LayoutStudyResult

VERDICT_NOTE = (
    "buildable, binding_rule, build_margin: the buildability verdict (docs/model.md §21) of each layout's design at the limit, "
    "the one its sigma_aw_at_limit and best_<variable> columns give; every rule is judged in every load case, whether or not the "
    "problem constrains it (build_margin: 1 minus the binding rule's usage). The ranking does not use it."
)
"""What the verdict columns of a ranking judge (the layout and synthesis reports say it)."""
_GRID_CSS = ".schematics{display:grid;grid-template-columns:repeat(3,1fr);gap:8px}"


def _check_study(result: Any) -> None:
    """Refuse anything but a layout study's result (``result``)."""
    from hisopt.arguments import of_type
    from hisopt.studies.layout_study import LayoutStudyResult

    of_type(result, LayoutStudyResult, "result", "a LayoutStudyResult (hisopt.run_layout_study)")


def _colour(i: int) -> str:
    return COLORS[i % len(COLORS)]


def schematics(result: LayoutStudyResult) -> list[go.Figure]:
    """One plan-view schematic per layout, at its baseline values (hover)."""
    from hisopt.hydraulics.catalogue import his_parameter_values
    from hisopt.report.schematic import layout_schematic

    figs = []
    for case in result.cases:
        fig = layout_schematic(case.problem.layout(), his_parameter_values(case.problem.spec.his), title=case.name)
        fig.update_layout(height=380, margin={"l": 10, "r": 10, "t": 50, "b": 10}, showlegend=False, title_font_size=14)
        figs.append(fig)
    return figs


def fronts_figure(result: LayoutStudyResult) -> go.Figure:
    """Every seed's front per layout in the shared normalised space (scatter matrix)."""
    _check_study(result)
    import plotly.graph_objects as go

    names = list(result.normalisation.objectives)
    fig = go.Figure()
    for i, case in enumerate(result.cases):
        part = result.fronts[result.fronts["layout"] == case.name]
        dims = [{"label": f"{n} [-]", "values": part[f"{n}_norm"]} for n in names]
        fig.add_trace(
            go.Splom(
                dimensions=dims,
                name=case.name,
                marker={"size": 4, "color": _colour(i), "opacity": 0.6},
                diagonal_visible=False,
                showupperhalf=False,
                text=[f"{case.name}, seed {s}" for s in part["seed"]],
            )
        )
    fig.update_layout(
        template=template(), height=720, title="Fronts in the shared normalised space (0: ideal, 1: reference of the roll-plane grid; lower is better)"
    )
    return fig


def curve_figure(result: LayoutStudyResult) -> go.Figure:
    """Best comfort against the handling limit per layout (staircases), the limit marked."""
    _check_study(result)
    import plotly.graph_objects as go

    h, unit = result.handling, result.table.attrs["units"]["handling_limit"]
    shown_h = display_for(unit, result.curve[h].to_numpy())
    fig = go.Figure()
    for i, case in enumerate(result.cases):
        part = result.curve[result.curve["layout"] == case.name].sort_values(h)
        if not len(part):
            continue
        x = shown_h.values(part[h].to_numpy())
        fig.add_trace(go.Scatter(x=x, y=part["sigma_aw"], mode="lines", line={"shape": "hv", "color": _colour(i)}, name=case.name))
        refined = part[part["source"] == "refined"]
        fig.add_trace(
            go.Scatter(
                x=shown_h.values(refined[h].to_numpy()),
                y=refined["sigma_aw"],
                mode="markers",
                showlegend=False,
                marker={"symbol": "diamond", "size": 8, "color": _colour(i)},
                name=f"{case.name} (refined)",
            )
        )
        row = result.table[result.table["layout"] == case.name].iloc[0]
        if np.isfinite(row["sigma_aw_at_limit"]):
            fig.add_trace(
                go.Scatter(
                    x=shown_h.values(np.array([row["handling_at_best"]])),
                    y=[row["sigma_aw_at_limit"]],
                    mode="markers",
                    marker={"symbol": "star", "size": 13, "color": _colour(i), "line": {"width": 1, "color": "black"}},
                    showlegend=False,
                    name=f"{case.name} at the limit",
                )
            )
    fig.add_vline(
        x=float(shown_h.values(np.array([result.handling_limit]))[0]),
        line={"dash": "dash", "color": "#556"},
        annotation_text=f"limit {format_quantity(result.handling_limit, unit)}",
    )
    fig.update_layout(
        template=template(),
        height=520,
        title=f"Best ride comfort against the {h} limit (stars: the equal-handling comparison; diamonds: refined by the NLP)",
        xaxis=log_axis(shown_h.values(result.curve[h].to_numpy())) | {"title": shown_h.label(f"{h} limit")},
        yaxis=log_axis(result.curve["sigma_aw"].to_numpy()) | {"title": "best sigma_aw [m/s^2]"},
    )
    return fig


def attainment_figure(result: LayoutStudyResult) -> go.Figure:
    """EAF surfaces (best, median, worst seed) and the Vorob'ev expectation per layout."""
    _check_study(result)
    import plotly.graph_objects as go

    h, unit = result.handling, result.table.attrs["units"]["handling_limit"]
    shown_h = display_for(unit, result.attainment[h].to_numpy())
    fig = go.Figure()
    styles = {"eaf": "solid", "vorobev": "dot"}
    for i, case in enumerate(result.cases):
        part = result.attainment[result.attainment["layout"] == case.name]
        groups = part.groupby(["kind", "percentile_pct"], sort=True)
        for (kind, pct), g in groups:
            g = g.sort_values(h)
            label = f"{case.name}: {'Vorob' + chr(39) + 'ev expectation' if kind == 'vorobev' else f'{pct:.0f} % attained'}"
            width = 2.5 if kind == "eaf" and pct == 50 else 1.2
            median = kind == "eaf" and pct == 50
            fig.add_trace(
                go.Scatter(
                    x=shown_h.values(g[h].to_numpy()),
                    y=g["sigma_aw"],
                    mode="lines",
                    legendgroup=case.name,
                    name=case.name if median else label,
                    showlegend=bool(median),
                    hovertext=label,
                    hoverinfo="text+x+y",
                    line={"shape": "hv", "color": _colour(i), "dash": styles[str(kind)], "width": width},
                )
            )
    fig.update_layout(
        template=template(),
        height=560,
        title="Attainment across seeds in the comfort-handling plane (thin: best and worst seed; thick: median; dotted: Vorob'ev expectation)",
        xaxis=log_axis(shown_h.values(result.attainment[h].to_numpy())) | {"title": shown_h.label(h)},
        yaxis=log_axis(result.attainment["sigma_aw"].to_numpy()) | {"title": "sigma_aw [m/s^2]"},
    )
    return fig


def table_html(result: LayoutStudyResult) -> str:
    """``layouts.csv`` in engineering units, split into the comparison, the buildability of each
    layout's design at the limit (a table of an older hisopt has none) and the layouts' data."""
    t = result.table
    first = [
        "layout",
        "hv_mean",
        "hv_std",
        "hv_min",
        "hv_max",
        "hv_merged",
        "vorobev_threshold_pct",
        "vorobev_deviation",
        "sigma_aw_at_limit",
        "handling_at_best",
        "refined",
        "gain_vs_roll_plane_pct",
        "handling_least",
        "at_limit",
    ]
    second = ["layout", "variables"] + [c for c in t.columns if c.startswith(("k_", "c_", "best_")) or c in ("stiffness_coupling", "damper_valves")]
    first = [c for c in first if c in t]  # a table of an older hisopt lacks handling_least and at_limit
    limit = format_quantity(result.handling_limit, t.attrs["units"]["handling_limit"])
    shown = [display_frame(t[cols]).replace("nan", "–") for cols in (first, second)]  # a layout that never meets the limit
    labels = ("layout [-]", "refined [-]", "variables [-]", "at_limit [-]", "damper_valves [-]", "buildable [-]", "binding_rule [-]")
    return (
        '<div style="overflow-x:auto">'
        + html_table(shown[0], f"Equal handling ({result.handling} <= {limit}) and spread across seeds", text_columns=labels)
        + verdict_html(t, labels)
        + html_table(shown[1], "Stiffness per unit stroke pattern (hisopt layouts) and the best design at the limit", text_columns=labels)
        + "</div>"
    )


def verdict_html(table: Any, text_columns: tuple[str, ...]) -> str:
    """The buildability verdict of each ranked layout's design at the limit (``table``: the
    layout study's or the synthesis's ranking) with :data:`VERDICT_NOTE`; ``""`` for a table
    written before hisopt judged it."""
    if BUILDABLE not in table:
        return ""
    columns = [c for c in ("layout", "sigma_aw_at_limit", "gain_vs_roll_plane_pct", *VERDICT_COLUMNS) if c in table]
    shown = display_frame(table[columns]).replace({"nan": "–", "": "–"})  # no design at the limit: empty here, NaN read back
    caption = "Buildability of each layout's design at the limit (every rule, constrained or not)"
    return html_table(shown, caption, text_columns=text_columns) + f'<p class="meta">{html.escape(VERDICT_NOTE)}</p>'


def write_layout_report(result: LayoutStudyResult, path: str | Path | None = None) -> Path:
    """Write the report (default ``DIR/report.html``) and return its path."""
    _check_study(result)
    from hisopt.errors import ConfigError
    from hisopt.io import atomic_write_text
    from hisopt.report.decision_page import DECISION_FILE, study_decision_room
    from hisopt.report.embed import PageFigures

    if path is None:
        if result.out is None:
            raise ConfigError("the study has no directory; give the report a path")
        path = result.out / "report.html"
    figs = schematics(result)
    page_figures = PageFigures()
    cells = "".join(f"<div>{page_figures.div(f, f'schematic{i}', config={'displayModeBar': False})}</div>" for i, f in enumerate(figs))
    sections: list[tuple[str, Any]] = [
        ("Layouts", f'<div class="schematics">{cells}</div>'),
        ("Comparison", table_html(result)),
        ("Best comfort at equal handling", curve_figure(result)),
        ("Spread across seeds: attainment", attainment_figure(result)),
        ("Fronts", fronts_figure(result)),
    ]
    parts = []
    for i, (title, content) in enumerate(sections):
        parts.append(f"<h2>{html.escape(title)}</h2>")
        parts.append(content if isinstance(content, str) else '<div class="figure">' + page_figures.div(content, f"fig{i}") + "</div>")
    runs = result.runs
    seeds = sorted(set(runs["seed"]))
    budget = runs["evaluations"].iloc[0] if len(runs) else 0
    name = result.cases[0].problem.name.removesuffix(f"-{result.cases[0].name}")
    notes = "".join(f'<p class="meta"><b>No design at the limit.</b> {html.escape(n)}.</p>' for n in result.limit_notes())
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>hisopt layout study: {html.escape(name)}</title>
<style>{REPORT_CSS}{_GRID_CSS}</style>
{page_figures.head_html()}</head>
<body><h1>hisopt layout study: {html.escape(name)}</h1>
<p class="meta">{len(result.cases)} layouts, seeds {html.escape(", ".join(map(str, seeds)))}, {budget} evaluations per run;
objectives {html.escape(", ".join(result.normalisation.objectives))}. Equal handling: {html.escape(result.handling)}
&le; {html.escape(format_quantity(result.handling_limit, result.table.attrs["units"]["handling_limit"]))}.
gain_vs_roll_plane_pct &gt; 0: better comfort than the paper's roll-plane layout at that limit. Hypervolumes in
the shared normalisation (docs/model.md §15). Values in engineering units (SI in the CSV files).</p>
<p class="meta">To compare the layouts' designs one by one, navigate their fronts and hand one over:
<a href="{DECISION_FILE}">the decision room</a>.</p>
{notes}{"".join(parts)}
{page_figures.scripts_html()}
</body></html>"""
    atomic_write_text(path, page)
    if Path(path) == (None if result.out is None else result.out / "report.html"):
        study_decision_room(result)
    return Path(path)
