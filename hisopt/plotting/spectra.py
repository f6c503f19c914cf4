"""Figure of response spectra with and without HIS (paper Fig. 4), from the data handed to it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import pandas as pd

from hisopt.plotting.axes import log_axis
from hisopt.plotting.theme import WITH_HIS, WITHOUT_HIS, template
from hisopt.units import format_design, psd_unit

if TYPE_CHECKING:
    import plotly.graph_objects as go


def response_spectra_figure(
    frame: pd.DataFrame,
    outputs: Sequence[str],
    units: Mapping[str, str],
    design: Mapping[str, float],
    design_units: Mapping[str, str],
    labels: Mapping[str, str] | None = None,
    fig: go.Figure | None = None,
) -> go.Figure:
    """Log-log PSDs with and without HIS, one panel per output, two panels a row.

    Parameters
    ----------
    frame : ``f_hz`` [Hz] and, per output, ``<output>_his`` and ``<output>_ref``
        [(output unit)^2/Hz]
    outputs
        the outputs, in panel order
    units
        each output's own unit
    design
        the design's values (subtitle)
    design_units
        their units
    labels
        what each output is, for panel titles (default: the name alone)
    fig
        figure with a subplot grid to draw into; ``None`` makes one
    """
    from plotly.subplots import make_subplots

    labels = labels or {}
    cols = 2
    rows = (len(outputs) + 1) // cols
    titles = [f"{o}: {labels.get(o, o)}" for o in outputs]
    fig = fig or make_subplots(rows=rows, cols=cols, subplot_titles=titles, vertical_spacing=0.3 / rows, horizontal_spacing=0.1)
    f = frame["f_hz"]
    x_axis = log_axis(f, pad=0.0, max_ticks=8)
    for k, name in enumerate(outputs):
        r, c = k // cols + 1, k % cols + 1
        for suffix, label, dash, color in (("his", "with HIS", "solid", WITH_HIS), ("ref", "without HIS", "dash", WITHOUT_HIS)):
            fig.add_scatter(
                x=f,
                y=frame[f"{name}_{suffix}"],
                name=label,
                legendgroup=label,
                showlegend=k == 0,
                line={"dash": dash, "color": color, "width": 1.6},
                row=r,
                col=c,
            )
        psd = frame[[f"{name}_his", f"{name}_ref"]].to_numpy()
        fig.update_xaxes(title_text="frequency [Hz]", row=r, col=c, **x_axis)
        fig.update_yaxes(title_text=f"PSD [{psd_unit(units[name])}]", row=r, col=c, **log_axis(psd))
    shown = format_design(design, design_units)
    fig.update_layout(
        template=template(),
        title=f"Response spectra with and without HIS<br><sup>{shown}</sup>",
        height=130 + 360 * rows,
        margin={"t": 90, "b": 70},
    )
    return fig
