"""Figures of a time-domain verification (``verify.html``, docs/model.md §22.5), from the
data handed to them: the worst second of a load case in the linear and the nonlinear model,
the simulated spectra over the frequency domain's, and each pressure's range against its
limits. Values in the units :data:`VERIFY_UNITS` names (:func:`verify_display`), the same in
``verify.html``'s tables, the design sheet and the terminal; PSDs in SI.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from hisopt.plotting.axes import log_axis
from hisopt.plotting.theme import COLORS, template
from hisopt.quantities import unit_factor
from hisopt.units import Display, display_for, psd_unit

if TYPE_CHECKING:
    import plotly.graph_objects as go

VERIFY_UNITS = {"Pa": "MPa", "m^3/s": "L/s", "m^3": "L", "m": "mm", "N": "kN", "-": "%", "rad": "deg", "rad/s": "deg/s"}
"""How a verification shows each SI unit, whatever the size (one unit per kind: a pressure in
MPa, a flow in L/s (as the design sheet's valves), a volume in L, a stroke in mm, a force in kN, a share in %, an angle in
degrees); any other unit as :func:`hisopt.units.display_for` shows it."""


def verify_display(unit: str, values: NDArray[np.float64] | float = 0.0) -> Display:
    """How a verification's quantity in SI ``unit`` is shown (:data:`VERIFY_UNITS`); ``values``
    pick the display of a unit not listed there."""
    shown = VERIFY_UNITS.get(unit)
    if shown is None:
        return display_for(unit, values)
    return Display(shown, 100.0 if shown == "%" else 1.0 / unit_factor(shown, unit))


Pair = tuple[NDArray[np.float64], NDArray[np.float64]]
"""A signal's ``(linear, nonlinear)`` records."""

PANELS = (
    ("acc_z", "CG vertical acceleration"),
    ("roll", "roll angle"),
    ("stroke_", "suspension strokes"),
    ("tire_load_", "dynamic tyre loads"),
    ("p_port_", "chamber pressures (gauge)"),
    ("p_acc_", "accumulator pressures (gauge)"),
    ("valve_flow_", "damper valve flows"),
)
"""The worst second's panels, top to bottom: the signals whose name is (or starts with) the
key, and the panel's title."""

LINEAR_DASH = "dot"
"""How a linear record is drawn (the nonlinear one is solid, the same colour)."""
LIMIT_COLOR = "#b3261e"
"""Colour of a limit line."""
SPECTRUM_DECADES = 8.0
"""[decades] The spectra's y range below their largest value (the frequency domain's notches,
exact zeros of a symmetric car at the wheelbase's frequencies, fall below it)."""
SPECTRUM_LABELS = {
    "acc_z": "CG vertical acceleration",
    "acc_roll": "roll acceleration",
    "acc_pitch": "pitch acceleration",
    "stroke_fl": "FL suspension stroke",
    "tire_load_fl": "FL dynamic tyre load",
}
"""What each simulated spectrum is, for panel titles."""


def channel_name(name: str, prefix: str) -> str:
    """A signal's name in its panel's legend: ``stroke_fl`` -> ``FL``, ``p_port_3`` ->
    ``chamber 3``, ``p_acc_0`` -> ``accumulator 0``, ``valve_flow_1`` -> ``valve 1``."""
    rest = name[len(prefix) :] if prefix.endswith("_") else name
    words = {"p_port_": "chamber ", "p_acc_": "accumulator ", "valve_flow_": "valve "}
    if prefix in words:
        return words[prefix] + rest
    return rest.upper() if prefix.endswith("_") else name


def panel_signals(signals: Mapping[str, Pair], prefix: str) -> list[tuple[str, Pair]]:
    """The signals of one panel (:data:`PANELS`), named for its legend; identical records
    (two chambers of one circuit) drawn once, named together (``chambers 0, 2``)."""
    chosen = [(n, s) for n, s in signals.items() if (n.startswith(prefix) if prefix.endswith("_") else n == prefix)]
    groups: list[tuple[list[str], Pair]] = []
    for name, pair in chosen:
        same = next((g for g in groups if all(np.array_equal(a, b, equal_nan=True) for a, b in zip(g[1], pair, strict=True))), None)
        if same is None:
            groups.append(([channel_name(name, prefix)], pair))
        else:
            same[0].append(channel_name(name, prefix))
    out = []
    for names, pair in groups:
        if len(names) == 1:
            out.append((names[0], pair))
        else:
            word, _, _ = names[0].partition(" ")
            out.append((f"{word}s " + ", ".join(n.partition(" ")[2] for n in names), pair))
    return out


def worst_second_figure(
    t_s: NDArray[np.float64],
    signals: Mapping[str, Pair],
    units: Mapping[str, str],
    limits: Mapping[str, Sequence[tuple[str, float]]] | None = None,
    title: str = "",
) -> go.Figure:
    """Stacked time histories of the worst second, linear (dotted) over nonlinear (solid).

    Parameters
    ----------
    t_s
        [s] sample times ``(n,)``
    signals
        name -> ``(linear, nonlinear)`` records [SI] ``(n,)`` each (NaN: a model not run)
    units
        each signal's SI unit
    limits
        per panel key of :data:`PANELS` (``"p_port_"``, ``"p_acc_"``) the lines to draw,
        ``(label, value [SI])``; a limit farther from the records than their own span is
        named in the panel instead of drawn (it would flatten them)
    title
        the figure's title
    """
    from plotly.subplots import make_subplots

    panels = [(prefix, what, panel_signals(signals, prefix)) for prefix, what in PANELS]
    panels = [p for p in panels if p[2]]
    fig = make_subplots(rows=len(panels), cols=1, shared_xaxes=True, vertical_spacing=0.035, subplot_titles=[p[1] for p in panels])
    for row, (prefix, _, chosen) in enumerate(panels, start=1):
        unit = units[next(n for n in signals if (n.startswith(prefix) if prefix.endswith("_") else n == prefix))]
        values = np.concatenate([np.concatenate(pair) for _, pair in chosen])
        shown = verify_display(unit, values)
        legend = "legend" if row == 1 else f"legend{row}"
        for k, (name, (linear, nonlinear)) in enumerate(chosen):
            color = COLORS[k % len(COLORS)]
            for label, y, dash in (("nonlinear", nonlinear, "solid"), ("linear", linear, LINEAR_DASH)):
                fig.add_scatter(
                    x=t_s,
                    y=shown.values(y),
                    name=name if len(chosen) > 1 else (label if name == prefix else f"{name} ({label})"),
                    legendgroup=f"{row}-{name}",
                    showlegend=label == "nonlinear" or len(chosen) == 1,
                    legend=legend,
                    line={"color": color, "dash": dash, "width": 1.5 if label == "nonlinear" else 1.3},
                    hovertemplate=f"{name} ({label}): %{{y:.4g}} {shown.unit}<extra></extra>",
                    row=row,
                    col=1,
                )
        off_scale = _limit_lines(fig, row, (limits or {}).get(prefix, ()), values, shown)
        if off_scale:
            title_note = fig.layout.annotations[row - 1]  # the subplot titles, in panel order
            title_note.text = f"{title_note.text} <span style='color:{LIMIT_COLOR}'>(limits off the scale: {off_scale})</span>"
        fig.update_yaxes(title_text=f"[{shown.unit}]", row=row, col=1)
    fig.update_xaxes(title_text="time [s]", row=len(panels), col=1)
    height = 230 * len(panels) + 110
    legends = {}
    for row in range(1, len(panels) + 1):
        domain = fig.layout[f"yaxis{'' if row == 1 else row}"].domain
        legends["legend" if row == 1 else f"legend{row}"] = {
            "x": 1.01,
            "xanchor": "left",
            "y": domain[1],
            "yanchor": "top",
            "yref": "paper",
            "orientation": "v",
            "font": {"size": 11},
        }
    fig.update_layout(template=template(), title=title, height=height, margin={"t": 90, "r": 150, "b": 60}, **legends)
    return fig


def _limit_lines(fig: go.Figure, row: int, lines: Sequence[tuple[str, float]], values: NDArray[np.float64], shown: Display) -> str:
    """Draw ``lines`` (label, SI value) on panel ``row``: those near the records as lines (the
    y range holds the records and the lines drawn); the others in words, returned for the
    panel's title (``""`` when none)."""
    finite = values[np.isfinite(values)]
    if not lines or not finite.size:
        return ""
    lo, hi = float(finite.min()), float(finite.max())
    span = max(hi - lo, 1e-9 * max(abs(hi), 1.0))
    drawn: list[tuple[str, float]] = []
    named: list[tuple[str, float]] = []
    seen: set[float] = set()
    for label, value in lines:
        if not math.isfinite(value) or value in seen:
            continue
        seen.add(value)
        (drawn if lo - span <= value <= hi + span else named).append((label, value))
    bottom, top = lo, hi
    for label, value in drawn:
        y = float(shown.values(value))
        fig.add_hline(y=y, line={"color": LIMIT_COLOR, "dash": "dash", "width": 1.2}, row=row, col=1)
        fig.add_annotation(
            text=f"{label} {shown(value)}",
            x=1.0,
            xref="x domain" if row == 1 else f"x{row} domain",
            xanchor="right",
            y=y,
            yref="y" if row == 1 else f"y{row}",
            yanchor="bottom",
            showarrow=False,
            font={"color": LIMIT_COLOR, "size": 11},
        )
        bottom, top = min(bottom, value), max(top, value)
    pad = 0.08 * (top - bottom if top > bottom else span)
    scaled = shown.values(np.array([bottom - pad, top + pad]))
    fig.update_yaxes(range=[float(scaled[0]), float(scaled[1])], row=row, col=1)
    return ", ".join(f"{label} {shown(value)}" for label, value in named)


def verify_spectra_figure(
    f_hz: NDArray[np.float64],
    spectra: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    units: Mapping[str, str],
    title: str = "",
) -> go.Figure:
    """Log-log PSDs of the simulated records, linear (dotted) and nonlinear (solid), over the
    frequency domain's (grey), one panel per output, two a row, over the frequency domain's
    band (where its PSD is positive).

    Parameters
    ----------
    f_hz
        [Hz] frequencies ``(F,)``
    spectra
        output -> ``(frequency domain, linear, nonlinear)`` one-sided PSDs
        [(output unit)^2/Hz] ``(F,)`` each
    units
        each output's SI unit
    title
        the figure's title
    """
    from plotly.subplots import make_subplots

    names = list(spectra)
    cols = 2
    rows = max((len(names) + 1) // cols, 1)
    titles = [f"{n}: {SPECTRUM_LABELS.get(n, n)}" for n in names]
    fig = make_subplots(rows=rows, cols=cols, subplot_titles=titles, vertical_spacing=0.32 / rows, horizontal_spacing=0.1)
    for k, name in enumerate(names):
        r, c = k // cols + 1, k % cols + 1
        fd, linear, nonlinear = (np.asarray(a, dtype=float) for a in spectra[name])
        band = (fd > 0) & (f_hz > 0)
        f = f_hz[band]
        for label, y, line in (
            ("frequency domain", fd, {"color": "#8a94a6", "width": 3.0}),
            ("linear, simulated", linear, {"color": COLORS[0], "width": 1.3, "dash": LINEAR_DASH}),
            ("nonlinear, simulated", nonlinear, {"color": COLORS[1], "width": 1.4}),
        ):
            fig.add_scatter(x=f, y=y[band], name=label, legendgroup=label, showlegend=k == 0, line=line, row=r, col=c)
        fig.update_xaxes(title_text="frequency [Hz]", row=r, col=c, **log_axis(f, pad=0.0, max_ticks=8))
        psd = np.concatenate([fd[band], linear[band], nonlinear[band]])
        psd = psd[np.isfinite(psd) & (psd > 0)]
        floor = max(float(psd.min()), float(psd.max()) * 10.0**-SPECTRUM_DECADES) if psd.size else 0.0
        fig.update_yaxes(title_text=f"PSD [{psd_unit(units.get(name, '-'))}]", row=r, col=c, **log_axis(np.clip(psd, floor, None)))
    fig.update_layout(template=template(), title=title, height=130 + 330 * rows, margin={"t": 90, "b": 70})
    return fig


def pressure_range_figure(ranges: Sequence[tuple[str, Mapping[str, tuple[float, float]], tuple[float, float]]], title: str = "") -> go.Figure:
    """Each pressure's range (lowest to highest) by the frequency domain (static value plus or
    minus three road sigmas), the linear and the nonlinear simulations, against its floor
    and ceiling.

    Parameters
    ----------
    ranges
        per pressure ``(name, {source: (low, high)} [Pa], (floor, ceiling) [Pa])``; a
        missing bound is NaN or infinite
    title
        the figure's title
    """
    import plotly.graph_objects as go

    shown = verify_display("Pa")
    fig = go.Figure(layout={"template": template()})
    colors = {"frequency domain": "#8a94a6", "linear": COLORS[0], "nonlinear": COLORS[1]}
    labels = []
    for name, spans, bounds in ranges:
        for source, (low, high) in spans.items():
            label = f"{name}: {source}"
            labels.append(label)
            fig.add_scatter(
                x=shown.values([low, high]),
                y=[label, label],
                mode="lines+markers",
                name=source,
                legendgroup=source,
                showlegend=len(labels) <= len(spans),
                line={"color": colors.get(source, COLORS[2]), "width": 6},
                marker={"size": 8},
                hovertemplate=f"{label}: %{{x:.4g}} {shown.unit}<extra></extra>",
            )
        for side, bound in zip(("floor", "ceiling"), bounds, strict=True):
            if math.isfinite(bound):
                ys = [f"{name}: {s}" for s in spans]
                fig.add_scatter(
                    x=shown.values([bound] * len(ys)),
                    y=ys,
                    mode="markers",
                    name="limit",
                    legendgroup="limit",
                    showlegend=False,
                    marker={"symbol": "line-ns", "size": 22, "line": {"width": 3, "color": LIMIT_COLOR}},
                    hovertemplate=f"{name}: {side} %{{x:.4g}} {shown.unit}<extra></extra>",
                )
    fig.add_scatter(x=[None], y=[None], mode="markers", name="limit", marker={"symbol": "line-ns", "size": 14, "line": {"width": 3, "color": LIMIT_COLOR}})
    fig.update_layout(
        title=title,
        height=110 + 26 * len(labels),
        xaxis_title=f"gauge pressure [{shown.unit}]",
        yaxis={"autorange": "reversed", "categoryorder": "array", "categoryarray": labels},
        margin={"t": 70, "b": 90, "l": 70},
    )
    return fig
