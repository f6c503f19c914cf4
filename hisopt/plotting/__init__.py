"""Drawing (plotly): figures of the data handed to them, theme and axis labels. A leaf layer:
it imports nothing of hisopt above the small leaves, so any layer's ``.plot()`` may call it.

Domain result objects gather their data and hand it to a module here, imported inside the
method, so that plotly loads only when something is drawn: :mod:`.spectra` (response
spectra), :mod:`.sweeps` (sweeps and feasible regions), :mod:`.timeseries` (time responses),
:mod:`.droptest` (drop-test spectra), :mod:`.figures` (optimisation results), :mod:`.uncertainty`
(Sobol indices and Monte Carlo spreads).

Public API (documented sub-package): the names of ``__all__``, imported when first used.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from plotly.graph_objects import Figure as Figure  # the type of every figure here, for annotations elsewhere

    from hisopt.plotting.figures import convergence, front_scatter_matrix, parallel_coordinates
    from hisopt.plotting.theme import COLORS, template, write_html
    from hisopt.plotting.uncertainty import sensitivity_figure, tolerance_figure

_LAZY = {
    "COLORS": "hisopt.plotting.theme",
    "template": "hisopt.plotting.theme",
    "write_html": "hisopt.plotting.theme",
    "convergence": "hisopt.plotting.figures",
    "front_scatter_matrix": "hisopt.plotting.figures",
    "parallel_coordinates": "hisopt.plotting.figures",
    "sensitivity_figure": "hisopt.plotting.uncertainty",
    "tolerance_figure": "hisopt.plotting.uncertainty",
}

__all__ = [
    "COLORS",
    "convergence",
    "front_scatter_matrix",
    "parallel_coordinates",
    "sensitivity_figure",
    "template",
    "tolerance_figure",
    "write_html",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'hisopt.plotting' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
