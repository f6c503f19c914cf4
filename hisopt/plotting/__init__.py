"""Drawing (plotly): figures of the data handed to them, theme and axis labels. A leaf layer:
it imports nothing of hisopt above the small leaves, so any layer's ``.plot()`` may call it.

Domain result objects gather their data and hand it to a module here, imported inside the
method, so that plotly loads only when something is drawn: :mod:`.spectra` (response
spectra), :mod:`.sweeps` (sweeps and feasible regions), :mod:`.timeseries` (time responses),
:mod:`.droptest` (drop-test spectra), :mod:`.figures` (optimisation results).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from plotly.graph_objects import Figure as Figure  # the type of every figure here, for annotations elsewhere
