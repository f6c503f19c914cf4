"""Figures of time responses (signals against time), from the data handed to them."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hisopt.plotting.theme import template

if TYPE_CHECKING:
    import plotly.graph_objects as go


def signals_figure(frame: pd.DataFrame, columns: Sequence[str], units: Mapping[str, str], label: str, fig: go.Figure | None = None) -> go.Figure:
    """Stacked time histories of ``columns`` of ``frame`` against its ``time`` [s], one panel each.

    Parameters
    ----------
    frame
        ``time`` [s] and the signals
    columns
        the signals drawn, one panel each, in order
    units
        unit of each column (axis titles)
    label
        the traces' legend suffix (e.g. the simulation mode)
    fig : figure whose subplot grid has ``len(columns)`` rows to add the traces to; ``None``
        makes a new one
    """
    from plotly.subplots import make_subplots

    if fig is None:
        fig = make_subplots(rows=len(columns), cols=1, shared_xaxes=True, subplot_titles=list(columns))
        fig.update_layout(template=template())
    for row, col in enumerate(columns, start=1):
        fig.add_scatter(x=frame["time"], y=frame[col], name=f"{col} ({label})", row=row, col=1)
        fig.update_yaxes(title_text=f"{col} [{units[col]}]", row=row, col=1)
    fig.update_xaxes(title_text="time [s]", row=len(columns), col=1)
    return fig


def pressures_figure(t_s: np.ndarray, pressure_pa: np.ndarray, names: Sequence[str], label: str, fig: go.Figure | None = None) -> go.Figure:
    """Gauge accumulator pressures [MPa] against time, a trace per accumulator.

    Parameters
    ----------
    t_s
        [s] sample times, shape ``(n_t,)``
    pressure_pa
        [Pa] gauge pressure of each accumulator, shape ``(n_t, len(names))``
    names
        the accumulators' names
    label
        the traces' legend suffix (e.g. the simulation mode)
    fig
        figure to add the traces to; ``None`` makes a new one
    """
    import plotly.graph_objects as go

    fig = go.Figure(layout={"template": template()}) if fig is None else fig
    for i, name in enumerate(names):
        pressure_mpa = pressure_pa[:, i] / 1e6
        fig.add_scatter(x=t_s, y=pressure_mpa, name=f"accumulator {name} ({label})")
    fig.update_layout(xaxis_title="time [s]", yaxis_title="gauge pressure [MPa]")
    return fig
