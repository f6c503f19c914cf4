"""Figures of optimisation results (plotly), each in the ``hisopt`` template.

Quantities are plotted in engineering units (:func:`hisopt.units.display_for`: ``p0 [MPa]``,
``dA [cm^2]``); the units come from the frames' ``attrs["units"]`` unless given.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import pandas as pd

from hisopt.report.theme import COLORS, template
from hisopt.units import Display, display_for, hypervolume_unit

if TYPE_CHECKING:
    import plotly.graph_objects as go

HIGHLIGHT_STYLE = {
    "knee": {"color": "#d1495b", "symbol": "diamond", "size": 12},
    "ASF pick": {"color": "#edae49", "symbol": "star", "size": 14},
    "selected": {"color": "#00798c", "symbol": "x", "size": 12},
}


def displays(frame: pd.DataFrame, columns: Sequence[str], units: Mapping[str, str] | None = None) -> dict[str, Display]:
    """The engineering display of each column (one unit per column, from its values)."""
    units = dict(frame.attrs.get("units", {}) if units is None else units)
    return {c: display_for(units.get(c, ""), frame[c].to_numpy(dtype=float)) for c in columns}


def _hover(frame: pd.DataFrame, shown: Mapping[str, Display]) -> list[str]:
    rows = frame[list(shown)].to_numpy(dtype=float)
    return ["<br>".join(f"{c} = {d(v)}" for (c, d), v in zip(shown.items(), row, strict=True)) for row in rows]


def front_scatter_matrix(
    front: pd.DataFrame,
    objectives: Sequence[str],
    variables: Sequence[str],
    highlights: Mapping[str, pd.Series] | None = None,
    refined: pd.DataFrame | None = None,
    units: Mapping[str, str] | None = None,
) -> go.Figure:
    """Scatter matrix of the objectives; hovering a point shows its whole design."""
    import plotly.graph_objects as go

    shown = displays(front, list(variables) + list(objectives), units)
    dims = lambda df: [{"label": shown[o].label(o), "values": shown[o].values(df[o])} for o in objectives]  # noqa: E731
    fig = go.Figure()
    fig.add_trace(
        go.Splom(dimensions=dims(front), text=_hover(front, shown), hoverinfo="text", name="front",
                 marker={"size": 5, "color": COLORS[0], "opacity": 0.6}, diagonal_visible=False, showupperhalf=False)
    )
    if refined is not None and len(refined):
        fig.add_trace(
            go.Splom(dimensions=dims(refined), text=_hover(refined, shown), hoverinfo="text", name="refined front",
                     marker={"size": 6, "color": "#66a182", "symbol": "triangle-up"}, diagonal_visible=False, showupperhalf=False)
        )
    for label, row in (highlights or {}).items():
        one = row.to_frame().T
        style = HIGHLIGHT_STYLE.get(label, HIGHLIGHT_STYLE["selected"])
        fig.add_trace(
            go.Splom(dimensions=dims(one), text=_hover(one, shown), hoverinfo="text", name=label,
                     marker={**style, "line": {"width": 1, "color": "black"}}, diagonal_visible=False, showupperhalf=False)
        )
    n = max(len(objectives) - 1, 1)
    fig.update_layout(
        template=template(), title="Pareto front: objectives (hover for the design)", height=170 + 230 * n,
        dragmode="select", margin={"t": 60, "b": 110},
    )
    # Side by side the columns' x ticks meet at the seams; three at most keeps them apart.
    fig.update_layout({f"xaxis{i if i > 1 else ''}": {"nticks": 3} for i in range(1, len(objectives) + 1)})
    return fig


def parallel_coordinates(
    front: pd.DataFrame,
    variables: Sequence[str],
    objectives: Sequence[str],
    color_by: str,
    units: Mapping[str, str] | None = None,
) -> go.Figure:
    """Parallel coordinates of variables and objectives, coloured by ``color_by``."""
    import plotly.graph_objects as go

    columns = list(variables) + list(objectives)
    shown = displays(front, list(dict.fromkeys(columns + [color_by])), units)

    def dimension(c: str) -> dict:
        out = {"label": shown[c].label(c), "values": shown[c].values(front[c])}
        out["tickformat"] = ".2~e" if shown[c].scientific else ".4~g"  # ticks and range labels
        return out

    colour = shown[color_by]
    colorbar = {"title": {"text": colour.label(color_by).replace(" [", "<br>["), "side": "top"}, "thickness": 14}
    colorbar["tickformat"] = ".2~e" if colour.scientific else ".4~g"
    fig = go.Figure(
        go.Parcoords(
            dimensions=[dimension(c) for c in columns],
            line={"color": colour.values(front[color_by]), "colorscale": "Viridis", "showscale": True, "colorbar": colorbar},
            labelfont={"size": 12},
            labelangle=-20,
            rangefont={"size": 10},
            tickfont={"size": 11},
        )
    )
    colour_name = colour.label(color_by)
    fig.update_layout(
        template=template(), title=f"Designs and objectives of the front (colour: {colour_name})", height=560,
        margin={"t": 140, "l": 70, "r": 120, "b": 40},
    )
    return fig


def convergence(generations: pd.DataFrame, n_objectives: int | None = None) -> go.Figure:
    """Hypervolume, front size and feasible share per generation.

    ``n_objectives`` sets the hypervolume's unit (``decades^n``); default from the frame's
    ``attrs["units"]``.
    """
    from plotly.subplots import make_subplots

    hv_unit = generations.attrs.get("units", {}).get("hypervolume") or (
        hypervolume_unit(n_objectives) if n_objectives else "decades^n"
    )
    fig = make_subplots(rows=1, cols=3, horizontal_spacing=0.09)
    x = generations["generation"]
    panels = (
        ("hypervolume", f"hypervolume [{hv_unit}]", 1.0),
        ("front_size", "front size [-]", 1.0),
        ("feasible_share", "feasible designs [%]", 100.0),
    )
    for i, (name, title, scale) in enumerate(panels, start=1):
        if name in generations:
            fig.add_scatter(x=x, y=generations[name] * scale, mode="lines+markers", name=title, row=1, col=i,
                            showlegend=False, line={"color": COLORS[i - 1]}, marker={"size": 5})
        fig.update_xaxes(title_text="generation [-]", row=1, col=i)
        fig.update_yaxes(title_text=title, row=1, col=i, rangemode="tozero" if name != "hypervolume" else "normal")
    fig.update_yaxes(range=[0, 105], row=1, col=3)
    fig.update_layout(template=template(), title="Convergence (hypervolume in log10 objective space)", height=340, margin={"t": 60})
    return fig
