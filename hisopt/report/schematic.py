"""A HIS layout as a plan-view schematic (plotly), drawn from the network data alone.

The car is seen from above, front at the top: a cylinder at each wheel (1 FL, 2 FR, 3 RL,
4 RR) with its top (``t``, annulus) and bottom (``b``, bore) chamber ports on the inner side.
Every circuit has its own colour: a thin line from each chamber to the node it feeds, the
series elements between nodes (valve: a bow-tie marker at its middle, orifice: a diamond,
pipe: a thick line), the shunt elements at their node (accumulator: a circle, oil volume: a
square). Hovering a marker shows the element and its parameters (with values when given).

Node positions are the weighted mean of their neighbours (chamber ports fixed, and a pull
toward a centre per circuit so that circuits sit side by side): one linear solve per layout,
so the same layout always gives the same drawing.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.hydraulics.layout import (
    ELEMENT_KINDS,
    FIELD_UNITS,
    PARAMETER_FIELDS,
    Accumulator,
    ChamberCompliance,
    Layout,
    Orifice,
    Pipe,
    Port,
    Valve,
)
from hisopt.plotting.theme import COLORS, template
from hisopt.units import format_quantity

if TYPE_CHECKING:
    import plotly.graph_objects as go

HALF_TRACK, HALF_BASE = 1.25, 1.35
"""[drawing units] Wheel positions: x = +-half track (left negative), y = +-half base (front up)."""

WHEEL_NAMES = ("1 FL", "2 FR", "3 RL", "4 RR")
CENTRE_PULL = 0.35
"""[-] Weight of the pull of every node toward its circuit's centre (a series element weighs 1)."""

MARKER_AT = 0.35
"""[-] Where along a series element (from its ``from`` node) its marker sits."""

CHAMBER_PULL = 2.5
"""[-] Weight of a chamber line: a node a chamber feeds stays near its cylinder."""


def wheel_position(wheel: int) -> tuple[float, float]:
    """[drawing units] Centre of a wheel's cylinder (0 FL, 1 FR, 2 RL, 3 RR)."""
    return (-HALF_TRACK if wheel % 2 == 0 else HALF_TRACK, HALF_BASE if wheel < 2 else -HALF_BASE)


def port_position(port: Port) -> tuple[float, float]:
    """[drawing units] A chamber's port: on the inner side of its cylinder, top above bottom."""
    x, y = wheel_position(port.wheel)
    return (x + (0.22 if x < 0 else -0.22), y + (0.12 if port.chamber == "top" else -0.12))


def node_positions(layout: Layout) -> dict[tuple[int, str], tuple[float, float]]:
    """[drawing units] Position of every node, keyed ``(circuit index, node name)`` (module docstring)."""
    out: dict[tuple[int, str], tuple[float, float]] = {}
    n_circuits = len(layout.circuits)
    for c, circuit in enumerate(layout.circuits):
        nodes = list(circuit.nodes)
        index = {n: i for i, n in enumerate(nodes)}
        centre = np.array([(c - (n_circuits - 1) / 2) * 0.5, 0.0])
        lap = np.zeros((len(nodes), len(nodes)))
        rhs = np.zeros((len(nodes), 2))
        for i in range(len(nodes)):
            lap[i, i] += CENTRE_PULL
            rhs[i] += CENTRE_PULL * centre
        for port in circuit.ports:
            i = index[port.node]
            lap[i, i] += CHAMBER_PULL
            rhs[i] += CHAMBER_PULL * np.array(port_position(port))
        for e in circuit.elements:
            if isinstance(e, (Valve, Pipe)):
                i, j = index[e.a], index[e.b]
                lap[i, i] += 1.0
                lap[j, j] += 1.0
                lap[i, j] -= 1.0
                lap[j, i] -= 1.0
        xy = np.linalg.solve(lap, rhs)
        for n, i in index.items():
            out[(c, n)] = (float(xy[i, 0]), float(xy[i, 1]))
    return out


def _hover(element: Any, values: Mapping[str, float] | None) -> str:
    lines = [ELEMENT_KINDS[type(element)]]
    for field in PARAMETER_FIELDS[type(element)]:
        ref = getattr(element, field)
        unit = FIELD_UNITS[(type(element), field)]
        if ref is None:  # an optional part left out: a damper valve's RMS flow is solved per load case, a blow-off may be absent
            shown = "solved per load case" if field == "flow_rms" else "none"
        elif isinstance(ref, str):
            shown = ref
            if values is not None and ref in values:
                shown += f" = {format_quantity(float(values[ref]), unit)}"
        else:
            shown = format_quantity(float(ref), unit)
        lines.append(f"{field}: {shown}")
    return "<br>".join(lines)


def layout_schematic(layout: Layout, values: Mapping[str, Any] | None = None, title: str | None = None) -> go.Figure:
    """The plan-view schematic of a layout (module docstring).

    Parameters
    ----------
    layout : Layout
        the circuits (e.g. :meth:`hisopt.specification.design_space.DesignSpace.layout`)
    values : Mapping[str, Any] | None, optional
        [SI] parameter values shown on hover (e.g. the baseline's), None: names only
    title : str | None, optional
        figure title (default names the layout)
    """
    import plotly.graph_objects as go

    from hisopt.arguments import of_type

    of_type(layout, Layout, "layout", "a Layout (a problem's layout())")

    fig = go.Figure()
    for wheel, name in enumerate(WHEEL_NAMES):
        x, y = wheel_position(wheel)
        fig.add_shape(
            type="rect", x0=x - 0.12, x1=x + 0.12, y0=y - 0.3, y1=y + 0.3, line={"color": "#8a94a6", "width": 1.5}, fillcolor="#eef1f5", layer="below"
        )
        fig.add_annotation(x=x, y=y + 0.42, text=f"<b>{name}</b>", showarrow=False, font={"size": 12})
        for chamber in ("top", "bottom"):
            _, py = port_position(Port("", wheel, chamber))
            fig.add_annotation(x=x, y=py, text=chamber[0], showarrow=False, font={"size": 11, "color": "#556"})
    pos = node_positions(layout)
    used_ports: set[tuple[int, str]] = set()
    markers: dict[str, dict[str, list[Any]]] = {}

    def marker(kind: str, x: float, y: float, text: str, colour: str) -> None:
        m = markers.setdefault(kind, {"x": [], "y": [], "text": [], "color": []})
        m["x"].append(x)
        m["y"].append(y)
        m["text"].append(text)
        m["color"].append(colour)

    for c, circuit in enumerate(layout.circuits):
        colour = COLORS[c % len(COLORS)]
        xs: list[float | None] = []
        ys: list[float | None] = []
        for port in circuit.ports:
            px, py = port_position(port)
            nx, ny = pos[(c, port.node)]
            xs += [px, nx, None]
            ys += [py, ny, None]
            used_ports.add((port.wheel, port.chamber))
            marker("chamber", px, py, f"chamber {port.label} (circuit {circuit.name}) feeds node {port.node}", colour)
        pipes_x: list[float | None] = []
        pipes_y: list[float | None] = []
        shunts_at: dict[str, int] = {}
        for e in circuit.elements:
            if isinstance(e, (Accumulator, ChamberCompliance)):
                k = shunts_at.get(e.node, 0)
                shunts_at[e.node] = k + 1
                nx, ny = pos[(c, e.node)]
                sx, sy = nx + 0.16 * (k % 2 * 2 - 1) * (k // 2 + 1), ny + 0.16  # stacked beside the node
                xs += [nx, sx, None]
                ys += [ny, sy, None]
                kind = "accumulator" if isinstance(e, Accumulator) else "oil volume"
                marker(kind, sx, sy, f"{_hover(e, values)}<br>at {e.node}", colour)
            else:
                (ax, ay), (bx, by) = pos[(c, e.a)], pos[(c, e.b)]
                if isinstance(e, Pipe):
                    pipes_x += [ax, bx, None]
                    pipes_y += [ay, by, None]
                else:
                    xs += [ax, bx, None]
                    ys += [ay, by, None]
                kind = "orifice" if isinstance(e, Orifice) else "valve" if isinstance(e, Valve) else "pipe"
                at = MARKER_AT  # off the middle: mirrored circuits do not stack their markers
                marker(kind, ax + at * (bx - ax), ay + at * (by - ay), f"{_hover(e, values)}<br>{e.a} -> {e.b}", colour)
        fig.add_scatter(x=xs, y=ys, mode="lines", line={"color": colour, "width": 2}, name=f"circuit {circuit.name}", hoverinfo="skip")
        if pipes_x:
            fig.add_scatter(x=pipes_x, y=pipes_y, mode="lines", line={"color": colour, "width": 6}, opacity=0.6, showlegend=False, hoverinfo="skip")
        nodes = [(n, pos[(c, n)]) for n in circuit.nodes]
        fig.add_scatter(
            x=[p[0] for _, p in nodes],
            y=[p[1] for _, p in nodes],
            mode="markers",
            showlegend=False,
            marker={"size": 6, "color": colour},
            text=[f"node {n} (circuit {circuit.name})" for n, _ in nodes],
            hoverinfo="text",
        )
    vented = [(w, ch) for w in range(4) for ch in ("top", "bottom") if (w, ch) not in used_ports]
    if vented:
        pts = [port_position(Port("", w, ch)) for w, ch in vented]  # type: ignore[arg-type]
        fig.add_scatter(
            x=[p[0] for p in pts],
            y=[p[1] for p in pts],
            mode="markers",
            name="chamber in no circuit",
            marker={"symbol": "circle-open", "size": 9, "color": "#8a94a6"},
            text=[f"chamber {w + 1}{ch[0]}: in no circuit (vented)" for w, ch in vented],
            hoverinfo="text",
        )
    symbols = {
        "chamber": ("circle", 8),
        "valve": ("bowtie", 14),
        "orifice": ("diamond", 12),
        "pipe": ("line-ns-open", 12),
        "accumulator": ("circle", 15),
        "oil volume": ("square", 11),
    }
    for kind, m in markers.items():
        symbol, size = symbols[kind]
        fig.add_scatter(
            x=m["x"],
            y=m["y"],
            mode="markers",
            name=kind,
            text=m["text"],
            hoverinfo="text",
            marker={"symbol": symbol, "size": size, "color": m["color"], "line": {"width": 1, "color": "#1d2330"}},
        )
    fig.add_annotation(x=0, y=HALF_BASE + 0.62, text="front", showarrow=False, font={"size": 12, "color": "#556"})
    fig.update_xaxes(visible=False, range=[-2.0, 2.0], scaleanchor="y", scaleratio=1)
    fig.update_yaxes(visible=False, range=[-2.0, 2.15])
    name = title or f"HIS layout {layout.name}: chambers, circuits, accumulators, valves (plan view, front up)"
    fig.update_layout(template=template(), title=name, height=620, plot_bgcolor="white", margin={"t": 70, "b": 90})
    return fig
