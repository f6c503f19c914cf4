"""``DIR/report.html`` of a topology synthesis (:mod:`hisopt.studies.synthesis`): one offline page.

The candidates per element count and what the screen kept, successive halving's rungs and
how well the screen's order predicted the measured one (Spearman), the ranking of the optimised
layouts at equal handling (with the buildability verdict of each one's design at the limit), the schematics of the best ten and their trade-off curves (best
comfort against the handling limit); engineering units throughout. The layout study of the
survivors keeps its own fuller report in ``DIR/study/report.html``.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hisopt.report.layout_report import verdict_html
from hisopt.report.tables import REPORT_CSS, html_table
from hisopt.units import display_frame, format_quantity

if TYPE_CHECKING:
    import plotly.graph_objects as go

    from hisopt.studies.synthesis import SynthesisResult

BEST_SHOWN = 10
_GRID_CSS = ".schematics{display:grid;grid-template-columns:repeat(3,1fr);gap:8px}"


def best_schematics(result: SynthesisResult, count: int = BEST_SHOWN) -> list[go.Figure]:
    """Plan-view schematics of the ``count`` best-ranked layouts, at their best design's
    values where they have one (else the baseline's)."""
    from hisopt.hydraulics.catalogue import his_parameter_values
    from hisopt.report.schematic import layout_schematic

    if result.study is None:
        return []
    cases = {c.name: c for c in result.study.cases}
    figs = []
    with_circuits = [row for row in result.layouts.itertuples(index=False) if row.layout in cases]  # not the car without circuits
    for row in with_circuits[:count]:
        case = cases[row.layout]
        gain = row.gain_vs_roll_plane_pct
        title = f"{row.layout} ({row.elements} elements{', ' + row.catalogue if row.catalogue and row.catalogue != row.layout else ''}): " + (
            f"gain {gain:+.1f} %" if gain == gain else "no design at the limit"
        )
        fig = layout_schematic(case.problem.layout(), his_parameter_values(case.problem.spec.his), title=title)
        fig.update_layout(height=380, margin={"l": 10, "r": 10, "t": 50, "b": 10}, showlegend=False, title_font_size=13)
        figs.append(fig)
    return figs


def _ranking_html(result: SynthesisResult) -> str:
    columns = [
        "layout",
        "elements",
        "catalogue",
        "description",
        "sigma_aw_at_limit",
        "handling_at_best",
        "gain_vs_roll_plane_pct",
        "hv_mean",
        "hv_std",
        "k_bounce",
        "k_roll",
        "k_pitch",
        "k_warp",
    ]
    shown = display_frame(result.layouts[[c for c in columns if c in result.layouts]]).replace("nan", "–")
    return html_table(
        shown,
        "Optimised layouts, best gain in comfort over roll_plane at equal handling first",
        text_columns=("layout [-]", "catalogue [-]", "description [-]"),
    )


def halving_html(halving: dict[str, Any]) -> str:
    """The successive-halving paragraph: the rungs, the Spearman correlations of the screen's
    order and the measured one, and the top ten the old rule would have missed."""
    rungs = "; ".join(
        f"rung {g['rung']}: {g['candidates']:,} candidates x {g['generations']} generation{'s' if g['generations'] != 1 else ''} x "
        f"{len(g['seeds'])} seed{'s' if len(g['seeds']) != 1 else ''}"
        for g in halving["plan"]
    )

    def rho(found: dict[str, Any]) -> str:
        return f"{found['rho']:+.2f}" if found["rho"] is not None else "undefined"

    missed = halving["top_ten_missed_by_old_rule"]
    return (
        "<h2>Successive halving</h2>"
        f'<p class="meta">{html.escape(rungs)} (docs/model.md §20.4; each candidate\'s rung and measure per rung in candidates.csv). '
        f"Spearman rank correlation of the screen's order (roll selectivity) and the measured order: {rho(halving['spearman_final'])} over the "
        f"{halving['spearman_final']['candidates']} candidates of the last rung, {rho(halving['spearman_first'])} over the "
        f"{halving['spearman_first']['candidates']} of the first (+1: the screen predicts the order). Of the final top ten, the old rule "
        f"(the screen's first ten) would have missed {len(missed)}{': ' + html.escape(', '.join(missed)) if missed else ''}.</p>"
    )


def write_synthesis_report(result: SynthesisResult, path: str | Path | None = None) -> Path:
    """Write the report (default ``DIR/report.html``) and the study's own; return its path."""
    from hisopt.errors import ConfigError
    from hisopt.io import atomic_write_text
    from hisopt.report.embed import PageFigures
    from hisopt.report.layout_report import curve_figure, write_layout_report

    if path is None:
        if result.out is None:
            raise ConfigError("the synthesis has no directory; give the report a path")
        path = result.out / "report.html"
    page_figures = PageFigures()
    counts = display_frame(result.counts)
    parts = ["<h2>Candidates</h2>", html_table(counts, "Candidates per element count and those the screen kept")]
    if result.study is not None:
        if result.study.out is not None:
            write_layout_report(result.study)
        cells = "".join(f"<div>{page_figures.div(f, f'schematic{i}', config={'displayModeBar': False})}</div>" for i, f in enumerate(best_schematics(result)))
        limit = format_quantity(result.study.handling_limit, result.study.table.attrs["units"]["handling_limit"])
        parts += [
            *([halving_html(result.halving)] if result.halving is not None else []),
            "<h2>Ranking</h2>",
            f'<p class="meta">Equal handling: {html.escape(result.study.handling)} &le; {html.escape(limit)}; gain_vs_roll_plane_pct &gt; 0 is better comfort '
            "than the paper's roll-plane layout there. Each layout's problem file is in layouts/; the study of the survivors, with its fronts, "
            'attainment and decision room, is <a href="study/report.html">study/report.html</a>.</p>',
            '<div style="overflow-x:auto">' + _ranking_html(result) + "</div>",
            verdict_html(result.layouts, ("layout [-]", "buildable [-]", "binding_rule [-]")),
            f"<h2>The best {min(BEST_SHOWN, len(result.layouts))}</h2>",
            f'<div class="schematics">{cells}</div>',
            "<h2>Trade-off: best comfort against the handling limit</h2>",
            '<div class="figure">' + page_figures.div(curve_figure(result.study), "curve") + "</div>",
        ]
    else:
        parts.append('<p class="meta">No candidate was optimised (none screened in, or --optimise 0).</p>')
    total = int(result.counts["candidates"].sum())
    kept = int(result.counts["screened_in"].sum())
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>hisopt synthesis</title>
<style>{REPORT_CSS}{_GRID_CSS}</style>
{page_figures.head_html()}</head>
<body><h1>hisopt topology synthesis</h1>
<p class="meta">{total:,} candidate layouts enumerated, {kept:,} kept by the screen; every candidate with its stiffness table is in
candidates.csv (docs/model.md §20). Values in engineering units (SI in the CSV files).</p>
{"".join(parts)}
{page_figures.scripts_html()}
</body></html>"""
    atomic_write_text(path, page)
    return Path(path)
