"""Figures of the uncertainty studies (docs/model.md §18): Sobol indices as bars, a design's
Monte Carlo spread as histograms, from the tables :mod:`hisopt.studies.uncertainty` makes."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hisopt.arguments import columns as require_columns
from hisopt.arguments import not_empty
from hisopt.plotting.theme import COLORS, template
from hisopt.units import display_for

if TYPE_CHECKING:
    import plotly.graph_objects as go


def sensitivity_figure(indices: pd.DataFrame, title: str) -> go.Figure:
    """One panel per quantity: each input's total (ST) and first-order (S1) Sobol index as
    horizontal bars with their bootstrap half-widths, inputs ordered by ST.

    Parameters
    ----------
    indices
        [-] rows ``quantity``, ``input``, ``S1``, ``S1_conf``, ``ST``, ``ST_conf``
    title
        the figure's title
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    quantities = list(dict.fromkeys(indices["quantity"]))
    cols = min(2, len(quantities))
    rows = math.ceil(len(quantities) / cols)
    n_inputs = indices["input"].nunique()
    fig = make_subplots(rows=rows, cols=cols, subplot_titles=quantities, horizontal_spacing=0.22, vertical_spacing=0.5 / max(rows, 1))
    for k, q in enumerate(quantities):
        part = indices[indices["quantity"] == q].sort_values("ST")
        row, col = k // cols + 1, k % cols + 1
        for name, err, color in (("S1", "S1_conf", COLORS[1]), ("ST", "ST_conf", COLORS[0])):
            fig.add_trace(
                go.Bar(
                    y=part["input"],
                    x=part[name],
                    error_x={"type": "data", "array": part[err], "visible": True},
                    orientation="h",
                    name="first order S1" if name == "S1" else "total ST",
                    marker_color=color,
                    legendgroup=name,
                    showlegend=k == 0,
                ),
                row=row,
                col=col,
            )
        fig.update_xaxes(title_text="Sobol index [-]", range=[-0.05, 1.05], row=row, col=col)
    fig.update_layout(template=template(), title=title, barmode="group", height=max(360, rows * (90 + 42 * n_inputs)), legend={"orientation": "h", "y": -0.08})
    return fig


def tolerance_figure(
    values: pd.DataFrame, quantities: Sequence[str], units: Mapping[str, str], limits: Mapping[str, float], nominal: Mapping[str, float], title: str
) -> go.Figure:
    """A histogram per quantity over the Monte Carlo samples, in engineering units, with the
    nominal design's value (dashed) and any constraint's limit (red).

    Parameters
    ----------
    values
        [SI] one row per sample, a column per quantity (NaN: failed)
    quantities
        the columns to draw
    units
        SI unit of each
    limits
        [SI] constraint limits by quantity
    nominal
        [SI] each quantity with every input at its nominal value
    title
        the figure's title
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    not_empty(quantities, "quantities", "quantity")
    require_columns(values, quantities, "quantities")
    cols = min(3, len(quantities))
    rows = math.ceil(len(quantities) / cols)
    fig = make_subplots(rows=rows, cols=cols, subplot_titles=list(quantities), horizontal_spacing=0.08, vertical_spacing=0.6 / max(rows, 1))
    for k, q in enumerate(quantities):
        v = values[q].to_numpy()
        v = v[np.isfinite(v)]
        show = display_for(units.get(q, ""), v)
        row, col = k // cols + 1, k % cols + 1
        fig.add_trace(go.Histogram(x=show.values(v), nbinsx=60, marker_color=COLORS[0], showlegend=False, name=q), row=row, col=col)
        if np.isfinite(nominal.get(q, np.nan)):
            fig.add_vline(x=float(show.values(nominal[q])), line_color=COLORS[2], line_dash="dash", line_width=2, row=row, col=col)
        if q in limits:
            fig.add_vline(x=float(show.values(limits[q])), line_color=COLORS[1], line_width=2, row=row, col=col)
        fig.update_xaxes(title_text=show.label(q), row=row, col=col)
        fig.update_yaxes(title_text="samples" if col == 1 else None, row=row, col=col)
    fig.update_layout(template=template(), title=title, height=max(360, rows * 320), bargap=0.02)
    return fig
