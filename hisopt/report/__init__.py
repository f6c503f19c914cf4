"""Figures and reports (plotly); imported lazily so the CLI starts fast."""
