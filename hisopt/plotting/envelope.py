"""The operating envelope of one design against temperature (docs/model.md §16.7), from the
table handed to it (:func:`hisopt.studies.envelope.envelope_table`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import pandas as pd

from hisopt.plotting.theme import COLORS, template
from hisopt.units import display_for

if TYPE_CHECKING:
    import plotly.graph_objects as go

CELSIUS_OFFSET = 273.15
"""[K] 0 degC: temperatures are drawn in degC."""


def envelope_figure(table: pd.DataFrame, units: Mapping[str, str], title: str) -> go.Figure:
    """Four panels against temperature, a line per payload: each circuit's static pressure,
    its accumulators' gas share (1: no oil left), the body's ride height, and ``sigma_aw``
    and the roll gradient (secondary axis).

    Parameters
    ----------
    table
        [SI] one row per temperature and payload: ``temperature`` [K], ``payload`` [kg],
        ``ride_height``, ``p_static_<c>``, ``gas_fraction_<c>``, ``sigma_aw``, ``roll_gradient``
    units
        SI unit of each column
    title
        the figure's title
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    circuits = [c.removeprefix("p_static_") for c in table.columns if c.startswith("p_static_")]
    panels = ["static pressure", "gas share of the accumulator (1: no oil)", "ride height from the design position", "ride comfort and handling"]
    fig = make_subplots(rows=2, cols=2, subplot_titles=panels, specs=[[{}, {}], [{}, {"secondary_y": True}]], horizontal_spacing=0.14, vertical_spacing=0.2)
    shows = {c: display_for(units.get(c, ""), table[c].to_numpy()) for c in table.columns if c not in ("model",)}
    dashes = ("solid", "dash", "dot", "dashdot")
    for n, (payload, rows) in enumerate(table.groupby("payload", sort=True)):
        t = rows["temperature"].to_numpy() - CELSIUS_OFFSET
        load = "unladen" if payload == 0 else f"{payload:g} kg payload"
        dash = dashes[n % len(dashes)]

        def line(
            column: str,
            name: str,
            color: str,
            row: int,
            col: int,
            secondary: bool = False,
            rows: pd.DataFrame = rows,
            t=t,
            dash: str = dash,
            first: bool = True,
        ) -> None:
            shown = shows[column]
            fig.add_trace(
                go.Scatter(
                    x=t, y=shown.values(rows[column]), mode="lines+markers", name=name, legendgroup=name, showlegend=first, line={"color": color, "dash": dash}
                ),
                row=row,
                col=col,
                secondary_y=secondary,
            )

        for i, c in enumerate(circuits):
            color = COLORS[i % len(COLORS)]
            line(f"p_static_{c}", f"circuit {c}, {load}", color, 1, 1)
            line(f"gas_fraction_{c}", f"circuit {c}, {load}", color, 1, 2, first=False)
        line("ride_height", f"ride height, {load}", COLORS[4], 2, 1)
        line("sigma_aw", f"sigma_aw, {load}", COLORS[5], 2, 2)
        line("roll_gradient", f"roll gradient, {load}", COLORS[6], 2, 2, secondary=True)
    names = {"p_static": "static pressure", "gas_fraction": "gas share", "ride_height": "ride height"}
    label = lambda c, name: shows[c].label(name)  # noqa: E731
    first = circuits[0] if circuits else ""
    fig.update_yaxes(title_text=label(f"p_static_{first}", names["p_static"]) if circuits else "", row=1, col=1)
    fig.update_yaxes(title_text=label(f"gas_fraction_{first}", names["gas_fraction"]) if circuits else "", row=1, col=2)
    fig.update_yaxes(title_text=label("ride_height", names["ride_height"]), row=2, col=1)
    fig.update_yaxes(title_text=label("sigma_aw", "sigma_aw"), row=2, col=2, secondary_y=False)
    fig.update_yaxes(title_text=label("roll_gradient", "roll gradient"), row=2, col=2, secondary_y=True)
    fig.update_xaxes(title_text="temperature [degC]")
    fig.update_layout(template=template(), title=title, height=720)
    return fig
