"""Figures of a one-variable sweep (paper Figs. 5-8) and of feasible regions over two variables
(paper Figs. 9-10), from the data handed to them."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hisopt.metrics import METRICS
from hisopt.plotting.axes import log_axis, log_ticks, tick_label
from hisopt.plotting.theme import COLORS, template
from hisopt.units import display_for, format_design, format_quantity

if TYPE_CHECKING:
    import plotly.graph_objects as go


def sweep_figure(
    problem_name: str,
    variable: str,
    unit: str,
    frame: pd.DataFrame,
    responses: Mapping[str, str],
    units: Mapping[str, str],
    baseline: Mapping[str, float],
    baseline_units: Mapping[str, str],
    labels: Mapping[str, str] | None = None,
    fig: go.Figure | None = None,
) -> go.Figure:
    """Frequency (left axis) and peak PSD (right axis, log) against the variable, a panel per key.

    Parameters
    ----------
    problem_name
        the problem's name (title)
    variable
        the swept variable, a column of ``frame``
    unit
        its unit (SI)
    frame : per key of ``responses``: ``<key>_peak_hz`` [Hz], ``<key>_peak_psd`` and, for a
        mode, ``<key>_frequency_hz`` [Hz]
    responses
        response of each key
    units
        PSD unit of each key
    baseline
        the fixed values of the other variables (subtitle)
    baseline_units
        their units
    labels
        what each key is, for panel titles (default: the key)
    fig
        figure with a ``secondary_y`` subplot grid to draw into; ``None`` makes one
    """
    from plotly.subplots import make_subplots

    labels = labels or {}
    keys = list(responses)
    titles = [f"{labels.get(k, k)}: {responses[k]}" for k in keys]
    rows = (len(keys) + 1) // 2
    fig = fig or make_subplots(
        rows=rows, cols=2, subplot_titles=titles, specs=[[{"secondary_y": True}] * 2] * rows, horizontal_spacing=0.16, vertical_spacing=0.3 / rows
    )
    shown = display_for(unit, frame[variable].to_numpy())
    x = shown.values(frame[variable])
    for n, key in enumerate(keys):
        r, c = n // 2 + 1, n % 2 + 1
        first = n == 0
        if f"{key}_frequency_hz" in frame:
            fig.add_scatter(
                x=x,
                y=frame[f"{key}_frequency_hz"],
                name="modal frequency",
                legendgroup="f",
                showlegend=first,
                line={"color": COLORS[0]},
                row=r,
                col=c,
                secondary_y=False,
            )
        fig.add_scatter(
            x=x,
            y=frame[f"{key}_peak_hz"],
            name="frequency of the PSD peak",
            legendgroup="fp",
            showlegend=first,
            line={"color": COLORS[0], "dash": "dot"},
            row=r,
            col=c,
            secondary_y=False,
        )
        fig.add_scatter(
            x=x,
            y=frame[f"{key}_peak_psd"],
            name="peak PSD (right axis)",
            legendgroup="a",
            showlegend=first,
            line={"color": COLORS[1]},
            row=r,
            col=c,
            secondary_y=True,
        )
        fig.update_xaxes(title_text=shown.label(variable), row=r, col=c)
        fig.update_yaxes(title_text="frequency [Hz]", row=r, col=c, secondary_y=False)
        fig.update_yaxes(
            title_text=f"peak PSD [{units[key]}]",
            row=r,
            col=c,
            secondary_y=True,
            showgrid=False,
            title_font={"color": COLORS[1]},
            tickfont={"color": COLORS[1]},
            **log_axis(frame[f"{key}_peak_psd"]),
        )
    fixed = format_design(baseline, baseline_units) or "no other variables"
    fig.update_layout(
        template=template(),
        title=f"{problem_name}: sweep of {variable}<br><sup>{fixed}</sup>",
        height=130 + 360 * rows,
        margin={"t": 90, "b": 70},
    )
    return fig


def regions_figure(
    problem_name: str,
    pair: tuple[str, str],
    units: tuple[str, str],
    grid_x: np.ndarray,
    grid_y: np.ndarray,
    values: Mapping[str, np.ndarray],
    valid: np.ndarray,
    feasible: np.ndarray,
    thresholds: Mapping[str, float],
    threshold_source: str,
    indicators: Sequence[str],
    baseline: Mapping[str, float],
    baseline_units: Mapping[str, str],
    fig: go.Figure | None = None,
) -> go.Figure:
    """Contours of log10 of each indicator (2 x 2 panels); thresholds dashed, the infeasible set shaded.

    Parameters
    ----------
    problem_name
        the problem's name (title)
    pair
        the two varied variables (x axis, y axis)
    units
        their units
    grid_x, grid_y
        [variable units] grid values, shapes ``(n_x,)``, ``(n_y,)``
    values : [physical units] each indicator and threshold quantity (names of
        :data:`hisopt.metrics.METRICS`), shape ``(n_y, n_x)``
    valid
        the model could be evaluated, shape ``(n_y, n_x)``
    feasible
        every threshold met, shape ``(n_y, n_x)``
    thresholds
        [physical units] upper limit per quantity (a dashed contour each)
    threshold_source : ``"constraints"`` (the problem's) or ``"baseline"`` (the baseline
        design's values), said in the subtitle
    indicators
        the quantities drawn, one panel each
    baseline
        the fixed values of the other variables (subtitle)
    baseline_units
        their units
    fig
        figure with a 2 x 2 subplot grid to draw into; ``None`` makes one
    """
    from plotly.subplots import make_subplots

    titles = [f"{n} (log colour scale)" for n in indicators]
    fig = fig or make_subplots(rows=2, cols=2, subplot_titles=titles, horizontal_spacing=0.2, vertical_spacing=0.16)
    shaded = feasible.astype(float)
    dashes = ["dash", "dot", "dashdot", "longdash", "longdashdot"]
    sx, sy = (display_for(u, g) for u, g in zip(units, (grid_x, grid_y), strict=True))
    gx, gy = sx.values(grid_x), sy.values(grid_y)
    for n, name in enumerate(indicators):
        r, c = n // 2 + 1, n % 2 + 1
        shown = np.where(valid, values[name], np.nan)
        finite = shown[np.isfinite(shown) & (shown > 0)]
        ticks = log_ticks(float(finite.min()), float(finite.max()), 5) if finite.size else []
        scientific = not all(1e-2 <= t < 1e4 for t in ticks)
        cell = fig.get_subplot(r, c)
        x_dom, y_dom = cell.xaxis.domain, cell.yaxis.domain
        fig.add_contour(
            x=gx,
            y=gy,
            z=np.log10(shown),
            colorscale="Viridis",
            ncontours=18,
            showlegend=False,
            name=name,
            colorbar={
                "len": y_dom[1] - y_dom[0],
                "thickness": 12,
                "x": x_dom[1] + 0.015,
                "xanchor": "left",
                "y": (y_dom[0] + y_dom[1]) / 2,
                "yanchor": "middle",
                "title": {"text": f"[{METRICS[name].unit}]", "side": "top"},
                "tickvals": np.log10(ticks) if ticks else None,
                "ticktext": [tick_label(t, scientific) for t in ticks] or None,
            },
            contours={"showlabels": False},
            hovertemplate=f"{name} = 10^%{{z:.3f}} {METRICS[name].unit}<extra></extra>",
            row=r,
            col=c,
        )
        fig.add_contour(  # shades where the feasibility indicator is below 1/2
            x=gx,
            y=gy,
            z=shaded,
            contours={"type": "constraint", "operation": ">=", "value": 0.5},
            fillcolor="rgba(60,60,60,0.35)",
            line={"width": 0},
            hoverinfo="skip",
            name="infeasible",
            legendgroup="infeasible",
            showlegend=n == 0,
            row=r,
            col=c,
        )
        for k, (q, limit) in enumerate(thresholds.items()):
            if np.all(np.isnan(np.where(valid, values[q], np.nan))):
                continue
            fig.add_contour(
                x=gx,
                y=gy,
                z=np.where(valid, values[q], np.nan),
                showscale=False,
                contours={"start": limit, "end": limit, "size": 1.0, "coloring": "lines"},
                line={"color": "black", "dash": dashes[k % len(dashes)], "width": 2},
                colorscale=[[0, "black"], [1, "black"]],
                name=f"{q} <= {format_quantity(limit, METRICS[q].unit)}",
                legendgroup=q,
                showlegend=n == 0,
                hoverinfo="skip",
                row=r,
                col=c,
            )
        fig.update_xaxes(title_text=sx.label(pair[0]), row=r, col=c)
        fig.update_yaxes(title_text=sy.label(pair[1]), row=r, col=c)
    fixed = format_design(baseline, baseline_units)
    source = "thresholds: the problem's constraints" if threshold_source == "constraints" else "no constraints: thresholds are the baseline design's values"
    subtitle = "; ".join(part for part in (fixed, source, "shaded: infeasible") if part)
    fig.update_layout(
        template=template(),
        title=f"{problem_name}: feasible region over {pair[0]}, {pair[1]}<br><sup>{subtitle}</sup>",
        height=900,
        margin={"t": 90, "b": 80, "r": 110},
    )
    return fig
