"""One plotly template for every hisopt figure, passed to each figure (``template=``).

:func:`template` returns it; plotly's global default is never changed, so a user's own
figures keep their look.
"""

from __future__ import annotations

from typing import Any

TEMPLATE_NAME = "hisopt"

COLORS = ("#1f4e79", "#d1495b", "#edae49", "#00798c", "#66a182", "#8d6a9f", "#2e4057")
"""Line colours in order (the template's colourway)."""

WITH_HIS, WITHOUT_HIS = "#1f4e79", "#8a94a6"
"""Colours of a design with HIS and of the car without HIS, the same in every figure."""

FONT = "Inter, Helvetica, Arial, sans-serif"


def template() -> Any:
    """The ``hisopt`` template on top of ``plotly_white`` (registered once, by name)."""
    import plotly.graph_objects as go
    import plotly.io as pio

    if TEMPLATE_NAME not in pio.templates:
        axis = {
            "gridcolor": "#e3e6ea",
            "zeroline": False,
            "automargin": True,  # tick labels and titles push the margin instead of overlapping
            "exponentformat": "power",  # 10^-5, never SI letters (µ, M) beside a unit
            "title": {"standoff": 8},
            "ticks": "outside",
            "ticklen": 4,
            "tickcolor": "#b8bec8",
            "linecolor": "#b8bec8",
            "showline": True,
        }
        base = pio.templates["plotly_white"]
        pio.templates[TEMPLATE_NAME] = go.layout.Template(base).update(
            layout={
                "font": {"family": FONT, "size": 13, "color": "#1d2330"},
                "title": {
                    "font": {"size": 17},
                    "x": 0.01,
                    "xanchor": "left",
                    "xref": "container",
                    "y": 1.0,
                    "yanchor": "top",
                    "yref": "container",
                    "pad": {"t": 14},
                },
                "colorway": list(COLORS),
                "paper_bgcolor": "white",
                "plot_bgcolor": "#fbfbfd",
                "xaxis": axis,
                "yaxis": axis,
                "legend": {"orientation": "h", "x": 0.0, "xanchor": "left", "y": 0.0, "yanchor": "bottom", "yref": "container"},
                "margin": {"l": 70, "r": 30, "t": 90, "b": 60},
            }
        )
    return pio.templates[TEMPLATE_NAME]


def write_html(fig, path) -> None:
    """Write a self-contained HTML file (plotly.js embedded: works offline), atomically."""
    from hisopt.io import atomic_write

    atomic_write(path, lambda tmp: fig.write_html(tmp, include_plotlyjs=True, full_html=True))
