"""One registered plotly template for every hisopt figure."""

from __future__ import annotations

TEMPLATE_NAME = "hisopt"


def use_theme() -> str:
    """Register the ``hisopt`` template (once) and make it the default; returns its name."""
    import plotly.graph_objects as go
    import plotly.io as pio

    if TEMPLATE_NAME not in pio.templates:
        pio.templates[TEMPLATE_NAME] = go.layout.Template(
            layout={
                "font": {"family": "Inter, Helvetica, Arial, sans-serif", "size": 13},
                "colorway": ["#1f4e79", "#d1495b", "#edae49", "#00798c", "#66a182", "#8d6a9f", "#2e4057"],
                "paper_bgcolor": "white",
                "plot_bgcolor": "#fbfbfd",
                "xaxis": {"gridcolor": "#e3e6ea", "zeroline": False},
                "yaxis": {"gridcolor": "#e3e6ea", "zeroline": False},
                "legend": {"orientation": "h", "y": -0.15},
                "margin": {"l": 60, "r": 20, "t": 60, "b": 60},
            }
        )
    pio.templates.default = "plotly_white+" + TEMPLATE_NAME
    return TEMPLATE_NAME


def write_html(fig, path) -> None:
    """Write a self-contained HTML file (plotly.js embedded: works offline), atomically."""
    from hisopt.io import atomic_write

    atomic_write(path, lambda tmp: fig.write_html(tmp, include_plotlyjs=True, full_html=True))
