"""Drawing (plotly): figures of the data handed to them, theme and axis labels. A leaf layer:
it imports nothing of hisopt above the small leaves, so any layer's ``.plot()`` may call it."""
