"""Figures of optimisation results (plotly), each in the ``hisopt`` template.

Quantities are plotted in engineering units (:func:`hisopt.units.display_for`: ``p0 [MPa]``,
``dA [cm^2]``); the units come from the frames' ``attrs["units"]`` unless given.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import columns as require_columns
from hisopt.arguments import not_empty
from hisopt.plotting.theme import COLORS, template
from hisopt.robust import scenario_column
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


@dataclass(frozen=True)
class _View:
    """One set of axes over the designs in a scatter matrix: a colour and legend entry each."""

    dims: Callable[[pd.DataFrame], list[dict]]  # the panels' axes of some designs
    hover: Callable[[pd.DataFrame], list[str]]  # their hover texts
    name: str
    refined_name: str
    colour: str
    refined_colour: str
    group: str | None = None  # legend group; None: traces ungrouped and highlights shown once each
    formats: tuple[str, ...] = ()  # d3 format of each axis's values on hover


def _format(shown: Display) -> str:
    """d3 format of a value on hover, 4 significant digits as the tables show them."""
    return ".3~e" if shown.scientific else ".4~g"


def _scatter_matrix(
    views: Sequence[_View],
    front: pd.DataFrame,
    refined: pd.DataFrame | None,
    highlights: Mapping[str, pd.Series] | None,
    n_axes: int,
    title: str,
    design_hover: bool = True,
) -> go.Figure:
    """Scatter matrix (lower half) of the front, the refined front and highlighted designs, in
    every view; ``design_hover=False``: a front's point shows its row and the panel's two
    values on hover, not its whole design (no text per point: a light page)."""
    import plotly.graph_objects as go

    def splom(view: _View, df: pd.DataFrame, **trace) -> go.Splom:
        return go.Splom(dimensions=view.dims(df), text=view.hover(df), hoverinfo="text", diagonal_visible=False, showupperhalf=False, **trace)

    def many(view: _View, df: pd.DataFrame, name: str, **trace) -> go.Splom:
        if design_hover:
            return splom(view, df, name=name, **trace)
        rows = f"{name}: row %{{pointNumber}}<br>%{{xaxis.title.text}} = %{{x}}<br>%{{yaxis.title.text}} = %{{y}}<extra></extra>"
        return go.Splom(dimensions=view.dims(df), hovertemplate=rows, diagonal_visible=False, showupperhalf=False, name=name, **trace)

    fig = go.Figure()
    for view in views:
        group = {} if view.group is None else {"legendgroup": view.group}
        fig.add_trace(many(view, front, view.name, marker={"size": 5, "color": view.colour, "opacity": 0.6}, **group))
        if refined is not None and len(refined):
            fig.add_trace(many(view, refined, view.refined_name, marker={"size": 6, "color": view.refined_colour, "symbol": "triangle-up"}, **group))
    for label, row in (highlights or {}).items():
        one = row.to_frame().T
        style = HIGHLIGHT_STYLE.get(label, HIGHLIGHT_STYLE["selected"])
        for k, view in enumerate(views):  # the same design in every view: one legend entry
            legend: dict[str, Any] = {} if view.group is None else {"legendgroup": label, "showlegend": k == 0}
            fig.add_trace(splom(view, one, name=label, marker={**style, "line": {"width": 1, "color": "black"}}, **legend))
    n = max(n_axes - 1, 1)
    fig.update_layout(template=template(), title=title, height=170 + 230 * n, dragmode="select", margin={"t": 60, "b": 110})
    # Side by side the columns' x ticks meet at the seams; three at most keeps them apart.
    fig.update_layout({f"xaxis{i if i > 1 else ''}": {"nticks": 3} for i in range(1, n_axes + 1)})
    for i, form in enumerate(views[0].formats, start=1):  # dimension i is drawn on x and y axes i
        fig.update_layout({f"{axis}{i if i > 1 else ''}": {"hoverformat": form} for axis in ("xaxis", "yaxis")})
    return fig


def front_scatter_matrix(
    front: pd.DataFrame,
    objectives: Sequence[str],
    variables: Sequence[str],
    highlights: Mapping[str, pd.Series] | None = None,
    refined: pd.DataFrame | None = None,
    units: Mapping[str, str] | None = None,
    design_hover: bool = True,
) -> go.Figure:
    """Scatter matrix of the objectives; hovering a point shows its whole design
    (``design_hover=False``: its front row and the two values, for a light page)."""
    not_empty(objectives, "objectives", "objective")
    require_columns(front, objectives, "objectives")
    require_columns(front, variables, "variables")
    view = _objective_view(displays(front, list(variables) + list(objectives), units), objectives, ("front", "refined front"), "#66a182")
    title = "Pareto front: objectives (hover for the design)" if design_hover else "Pareto front: objectives (hover for the front row)"
    return _scatter_matrix([view], front, refined, highlights, len(objectives), title, design_hover)


def _objective_view(shown: Mapping[str, Display], objectives: Sequence[str], names: tuple[str, str], second_colour: str) -> _View:
    """The objectives' axes of a front and a second set of designs drawn over it (``names``)."""
    return _View(
        dims=lambda df: [{"label": shown[o].label(o), "values": shown[o].values(df[o])} for o in objectives],
        hover=lambda df: _hover(df, shown),
        name=names[0],
        refined_name=names[1],
        colour=COLORS[0],
        refined_colour=second_colour,
        formats=tuple(_format(shown[o]) for o in objectives),
    )


def catalogue_scatter_matrix(
    front: pd.DataFrame,
    continuous: pd.DataFrame,
    objectives: Sequence[str],
    variables: Sequence[str],
    units: Mapping[str, str] | None = None,
    design_hover: bool = True,
) -> go.Figure:
    """Scatter matrix of a catalogue run's front over its continuous relaxation's
    (docs/model.md §17.5): where the standard parts give up performance (``design_hover``:
    as :func:`front_scatter_matrix`)."""
    units = dict(front.attrs.get("units", {}) if units is None else units)
    shown = displays(pd.concat([front, continuous], ignore_index=True), list(variables) + list(objectives), units)
    view = _objective_view(shown, objectives, ("catalogue front", "continuous relaxation's front"), "#d1495b")
    title = "Catalogue front and its continuous relaxation's " + ("(hover for the design)" if design_hover else "(hover for the row)")
    return _scatter_matrix([view], front, continuous, None, len(objectives), title, design_hover)


def scenario_scatter_matrix(
    front: pd.DataFrame,
    quantities: Sequence[str],
    scenarios: Sequence[str],
    variables: Sequence[str],
    highlights: Mapping[str, pd.Series] | None = None,
    refined: pd.DataFrame | None = None,
    units: Mapping[str, str] | None = None,
    design_hover: bool = True,
) -> go.Figure:
    """The front of a ``per_scenario`` problem (objectives ``"<quantity>@<scenario>"``): one
    scatter matrix of the quantities, a colour per load case, each design once per scenario.

    The matrix of every column would be ``(Q S)^2 / 2`` panels (120 for four quantities in four
    scenarios); this one is ``Q^2 / 2`` and shows how each load case trades the quantities
    off. Each quantity's axis has one unit across its scenarios; hovering a point shows its
    design and that scenario's values (``design_hover=False``: its front row and the two
    values, for a light page).
    """
    units = dict(front.attrs.get("units", {}) if units is None else units)
    columns = {q: [scenario_column(q, s) for s in scenarios] for q in quantities}
    tables = [front] + ([refined] if refined is not None and len(refined) else []) + [r.to_frame().T for r in (highlights or {}).values()]
    shown = {q: display_for(units.get(cols[0], ""), np.concatenate([t[cols].to_numpy(dtype=float).ravel() for t in tables])) for q, cols in columns.items()}
    design = displays(front, variables, units)

    def view(k: int, s: str) -> _View:
        def dims(df: pd.DataFrame) -> list[dict]:
            return [{"label": shown[q].label(q), "values": shown[q].values(df[scenario_column(q, s)])} for q in quantities]

        def hover(df: pd.DataFrame) -> list[str]:
            both = {v: design[v] for v in variables} | {scenario_column(q, s): shown[q] for q in quantities}
            return [f"load case {s}<br>{text}" for text in _hover(df, both)]

        colour = COLORS[k % len(COLORS)]
        formats = tuple(_format(shown[q]) for q in quantities)
        return _View(dims, hover, name=s, refined_name=f"{s}: refined", colour=colour, refined_colour=colour, group=s, formats=formats)

    views = [view(k, s) for k, s in enumerate(scenarios)]
    title = "Pareto front in each load case (colour; hover for the " + ("design)" if design_hover else "front row)")
    return _scatter_matrix(views, front, refined, highlights, len(quantities), title, design_hover)


def parallel_coordinates(
    front: pd.DataFrame,
    variables: Sequence[str],
    objectives: Sequence[str],
    color_by: str,
    units: Mapping[str, str] | None = None,
) -> go.Figure:
    """Parallel coordinates of variables and objectives, coloured by ``color_by``."""
    import plotly.graph_objects as go

    require_columns(front, variables, "variables")
    require_columns(front, objectives, "objectives")
    require_columns(front, [color_by], "color_by")
    names = list(variables) + list(objectives)
    shown = displays(front, list(dict.fromkeys(names + [color_by])), units)

    def dimension(c: str) -> dict:
        out = {"label": shown[c].label(c), "values": shown[c].values(front[c])}
        out["tickformat"] = ".2~e" if shown[c].scientific else ".4~g"  # ticks and range labels
        return out

    colour = shown[color_by]
    colorbar = {"title": {"text": colour.label(color_by).replace(" [", "<br>["), "side": "top"}, "thickness": 14}
    colorbar["tickformat"] = ".2~e" if colour.scientific else ".4~g"
    fig = go.Figure(
        go.Parcoords(
            dimensions=[dimension(c) for c in names],
            line={"color": colour.values(front[color_by]), "colorscale": "Viridis", "showscale": True, "colorbar": colorbar},
            labelfont={"size": 12},
            labelangle=-20,
            rangefont={"size": 10},
            tickfont={"size": 11},
        )
    )
    colour_name = colour.label(color_by)
    top = 140
    if len(names) > 10:  # e.g. per-scenario objectives: slanted labels would cross the next axes' ranges
        top = 80 + 7 * max(len(d["label"]) for d in fig.data[0].dimensions)  # ~7 px per character at 12 px
        fig.update_traces(labelangle=-90)
        # ticks of neighbouring axes meet below ~75 px apart: a fixed width (the report's figures scroll sideways)
        fig.update_layout(width=75 * len(names) + 190, autosize=False)
    fig.update_layout(
        template=template(),
        title=f"Designs and objectives of the front (colour: {colour_name})",
        height=420 + top,
        margin={"t": top, "l": 70, "r": 120, "b": 40},
    )
    return fig


def convergence(generations: pd.DataFrame, n_objectives: int | None = None) -> go.Figure:
    """Hypervolume, front size and feasible share per generation.

    ``n_objectives`` sets the hypervolume's unit (``decades^n``); default from the frame's
    ``attrs["units"]``.
    """
    from plotly.subplots import make_subplots

    hv_unit = generations.attrs.get("units", {}).get("hypervolume") or (hypervolume_unit(n_objectives) if n_objectives else "decades^n")
    fig = make_subplots(rows=1, cols=3, horizontal_spacing=0.09)
    x = generations["generation"]
    panels = (
        ("hypervolume", f"hypervolume [{hv_unit}]", 1.0),
        ("front_size", "front size [-]", 1.0),
        ("feasible_share", "feasible designs [%]", 100.0),
    )
    for i, (name, title, scale) in enumerate(panels, start=1):
        if name in generations:
            fig.add_scatter(
                x=x,
                y=generations[name] * scale,
                mode="lines+markers",
                name=title,
                row=1,
                col=i,
                showlegend=False,
                line={"color": COLORS[i - 1]},
                marker={"size": 5},
            )
        fig.update_xaxes(title_text="generation [-]", row=1, col=i)
        fig.update_yaxes(title_text=title, row=1, col=i, rangemode="tozero" if name != "hypervolume" else "normal")
    fig.update_yaxes(range=[0, 105], row=1, col=3)
    fig.update_layout(template=template(), title="Convergence (hypervolume in log10 objective space)", height=340, margin={"t": 60})
    return fig
