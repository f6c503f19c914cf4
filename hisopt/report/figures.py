"""Figures of optimisation results (plotly), all in the registered ``hisopt`` template."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hisopt.report.theme import use_theme

if TYPE_CHECKING:
    import plotly.graph_objects as go

HIGHLIGHT_STYLE = {
    "knee": {"color": "#d1495b", "symbol": "diamond", "size": 12},
    "ASF pick": {"color": "#edae49", "symbol": "star", "size": 14},
    "selected": {"color": "#00798c", "symbol": "x", "size": 12},
}


def _hover(frame: pd.DataFrame, columns: Sequence[str]) -> list[str]:
    rows = frame[list(columns)].to_numpy()
    return ["<br>".join(f"{c} = {v:.5g}" for c, v in zip(columns, row)) for row in rows]


def front_scatter_matrix(
    front: pd.DataFrame,
    objectives: Sequence[str],
    variables: Sequence[str],
    highlights: Mapping[str, pd.Series] | None = None,
    refined: pd.DataFrame | None = None,
) -> "go.Figure":
    """Scatter matrix of the objectives; hovering a point shows its whole design."""
    import plotly.graph_objects as go

    use_theme()
    columns = list(variables) + list(objectives)
    dims = lambda df: [{"label": o, "values": df[o]} for o in objectives]  # noqa: E731
    fig = go.Figure()
    fig.add_trace(
        go.Splom(dimensions=dims(front), text=_hover(front, columns), hoverinfo="text", name="front",
                 marker={"size": 5, "color": "#1f4e79", "opacity": 0.6}, diagonal_visible=False, showupperhalf=False)
    )
    if refined is not None and len(refined):
        fig.add_trace(
            go.Splom(dimensions=dims(refined), text=_hover(refined, columns), hoverinfo="text", name="refined front",
                     marker={"size": 6, "color": "#66a182", "symbol": "triangle-up"}, diagonal_visible=False, showupperhalf=False)
        )
    for label, row in (highlights or {}).items():
        one = row.to_frame().T
        style = HIGHLIGHT_STYLE.get(label, HIGHLIGHT_STYLE["selected"])
        fig.add_trace(
            go.Splom(dimensions=dims(one), text=_hover(one, columns), hoverinfo="text", name=label,
                     marker={**style, "line": {"width": 1, "color": "black"}}, diagonal_visible=False, showupperhalf=False)
        )
    fig.update_layout(title="Pareto front: objectives (hover for the design)", height=720, dragmode="select")
    return fig


def parallel_coordinates(front: pd.DataFrame, variables: Sequence[str], objectives: Sequence[str], color_by: str) -> "go.Figure":
    """Parallel coordinates of variables and objectives, coloured by ``color_by``."""
    import plotly.graph_objects as go

    use_theme()
    dims = [{"label": c, "values": front[c]} for c in list(variables) + list(objectives)]
    fig = go.Figure(
        go.Parcoords(
            dimensions=dims,
            line={"color": front[color_by], "colorscale": "Viridis", "showscale": True, "colorbar": {"title": {"text": color_by}}},
        )
    )
    fig.update_layout(title=f"Designs and objectives of the front (colour: {color_by})", height=520)
    return fig


def convergence(generations: pd.DataFrame) -> "go.Figure":
    """Hypervolume, front size and feasible share per generation."""
    from plotly.subplots import make_subplots

    use_theme()
    fig = make_subplots(rows=1, cols=3, subplot_titles=("hypervolume (log10 objectives)", "front size", "feasible share"))
    x = generations["generation"]
    for col, (name, i) in enumerate((("hypervolume", 1), ("front_size", 2), ("feasible_share", 3))):
        if name in generations:
            fig.add_scatter(x=x, y=generations[name], mode="lines", name=name, row=1, col=i, showlegend=False)
        fig.update_xaxes(title_text="generation", row=1, col=col + 1)
    fig.update_layout(title="Convergence", height=360)
    return fig


def table_figure(frame: pd.DataFrame, title: str, height: int | None = None) -> "go.Figure":
    """A plotly table (numbers to 5 significant figures)."""
    import plotly.graph_objects as go

    use_theme()
    cells = [[f"{v:.5g}" if isinstance(v, (float, np.floating)) else str(v) for v in frame[c]] for c in frame.columns]
    fig = go.Figure(go.Table(header={"values": list(frame.columns), "align": "left"}, cells={"values": cells, "align": "left"}))
    fig.update_layout(title=title, height=height or 80 + 28 * (len(frame) + 2))
    return fig
