"""Plotly figures in a light, offline page (``hisopt report``'s ``report.html``).

A page of plotly figures used to weigh plotly.js (4.8 MB) plus every figure's numbers as
full-precision JSON, the same column again in each figure that showed it. Here:

- plotly.js is embedded once, gzip-compressed and base64-encoded (about 2 MB); the browser
  unpacks it with ``DecompressionStream`` and then draws the figures. Still one file, still
  offline;
- a figure's numeric arrays travel as float32 (7 significant digits, more than a figure or a
  4-digit hover label shows) in plotly's typed-array form (``{"dtype": "f4", "bdata": ...}``),
  each distinct array once per page: a trace refers to it by its index in the page's store.
"""

from __future__ import annotations

import base64
import functools
import gzip
import json
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import plotly.graph_objects as go

SHARED_MIN_LENGTH = 16
"""[-] Numeric arrays of a trace at least this long go to the page's store as float32; shorter
ones (and the layout's: ticks, ranges) stay plain JSON numbers."""
FLOAT32_SMALLEST = 1e-30
"""[-] Magnitude below which a non-zero value would lose digits as float32 (its array stays float64)."""
FLOAT32_LARGEST = 1e30
"""[-] Magnitude above which a value would overflow float32 (its array stays float64)."""

PAGE_SCRIPT = r"""
(function () {
  var packed = document.getElementById('hisopt-plotly').textContent.trim();
  var store = JSON.parse(document.getElementById('hisopt-arrays').textContent);
  function resolve(obj) {
    if (Array.isArray(obj)) return obj.map(resolve);
    if (obj === null || typeof obj !== 'object') return obj;
    if (typeof obj.ref === 'number' && typeof obj.dtype === 'string') return {dtype: obj.dtype, bdata: store[obj.ref]};
    var out = {};
    for (var k in obj) out[k] = resolve(obj[k]);
    return out;
  }
  function fail(message) {
    window.hisoptFigures.forEach(function (f) {
      var div = document.getElementById(f[0]);
      if (div) div.innerHTML = '<p class="meta">' + message + '</p>';
    });
  }
  async function draw() {
    if (typeof DecompressionStream === 'undefined') {
      fail('This browser cannot unpack the figures (it lacks DecompressionStream: Chrome 80, Firefox 113, ' +
           'Safari 16.4 or later can). The tables below and decision.html do not need it.');
      return;
    }
    var bytes = Uint8Array.from(atob(packed), function (c) { return c.charCodeAt(0); });
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
    var code = await new Response(stream).text();
    var script = document.createElement('script');
    script.text = code;
    document.head.appendChild(script);
    var drawn = window.hisoptFigures.map(function (f) {
      return Plotly.newPlot(f[0], resolve(f[1]), resolve(f[2]), f[3]);
    });
    await Promise.all(drawn);
  }
  window.hisoptReady = draw();
})();
"""
"""Unpacks plotly.js, puts the stored arrays back into the figures and draws them;
``window.hisoptReady`` resolves when every figure is drawn."""


@functools.lru_cache(maxsize=1)
def packed_plotlyjs() -> str:
    """plotly.js, gzip-compressed (no timestamp: the same bytes every time) and base64-encoded."""
    import plotly.offline

    return base64.b64encode(gzip.compress(plotly.offline.get_plotlyjs().encode("utf-8"), compresslevel=6, mtime=0)).decode("ascii")


def _numeric(value: Any) -> np.ndarray | None:
    """``value`` as a 1-D float64 array when it is a numeric array (a list, an ndarray or
    plotly's typed-array form) long enough to store; else None."""
    if isinstance(value, dict):
        if set(value) - {"dtype", "bdata", "shape"} or "bdata" not in value or "shape" in value and "," in str(value["shape"]):
            return None
        array = np.frombuffer(base64.b64decode(value["bdata"]), dtype=np.dtype(value["dtype"]))
    elif isinstance(value, (list, tuple, np.ndarray)):
        if len(value) < SHARED_MIN_LENGTH:
            return None
        try:
            array = np.asarray(value)
        except ValueError:  # ragged
            return None
    else:
        return None
    if array.ndim != 1 or array.dtype.kind not in "iuf" or len(array) < SHARED_MIN_LENGTH:
        return None
    return array.astype(np.float64)


def _fits_float32(values: np.ndarray) -> bool:
    magnitude = np.abs(values[np.isfinite(values) & (values != 0)])
    return not magnitude.size or (magnitude.min() >= FLOAT32_SMALLEST and magnitude.max() <= FLOAT32_LARGEST)


class PageFigures:
    """The plotly figures of one page: each one's ``<div>`` and its drawing call, their
    arrays in one store (:meth:`store_html`) and plotly.js once (:meth:`scripts_html`).

    Attributes
    ----------
    arrays : list[str]
        the store: base64 of each distinct array, in the order first met
    """

    def __init__(self) -> None:
        self.arrays: list[str] = []
        self._index: dict[tuple[str, str], int] = {}

    def _store(self, values: np.ndarray) -> dict[str, Any]:
        dtype = "f4" if _fits_float32(values) else "f8"
        data = base64.b64encode(values.astype(np.float32 if dtype == "f4" else np.float64).tobytes()).decode("ascii")
        key = (dtype, data)
        if key not in self._index:
            self._index[key] = len(self.arrays)
            self.arrays.append(data)
        return {"dtype": dtype, "ref": self._index[key]}

    def _compact(self, obj: Any, attribute: bool = True) -> Any:
        """``obj`` with its attributes' numeric arrays stored (an array nested in an array,
        a heatmap's row, stays: plotly.js reads a typed array only as an attribute's value)."""
        array = _numeric(obj) if attribute else None
        if array is not None:
            return self._store(array)
        if isinstance(obj, dict):
            return {k: self._compact(v) for k, v in obj.items()}
        if isinstance(obj, (list, tuple)):
            return [self._compact(v, attribute=False) for v in obj]
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        return obj

    def div(self, fig: go.Figure, div_id: str, config: dict[str, Any] | None = None) -> str:
        """The ``<div>`` of ``fig`` and the script that queues its drawing; ``config`` plotly's
        options for it (``{"displayModeBar": False}`` for a schematic), beside ``responsive``."""
        from plotly.io.json import to_json_plotly

        spec = fig.to_plotly_json()
        data = to_json_plotly(self._compact(spec["data"]))
        layout = to_json_plotly(spec["layout"])
        height = f"{int(fig.layout.height)}px" if fig.layout.height else "100%"
        width = f"{int(fig.layout.width)}px" if fig.layout.width else "100%"
        options = json.dumps({"responsive": True} | dict(config or {}), separators=(",", ":"))
        call = f'window.hisoptFigures.push(["{div_id}", {data}, {layout}, {options}]);'.replace("</", "<\\/")
        return f'<div id="{div_id}" class="plotly-graph-div" style="height:{height}; width:{width};"></div>\n<script>{call}</script>'

    def head_html(self) -> str:
        """The script, for the page's head, that the figures' scripts fill."""
        return "<script>window.hisoptFigures = [];</script>"

    def scripts_html(self) -> str:
        """The store, plotly.js and the drawing script: the end of the page's body."""
        store = json.dumps(self.arrays, separators=(",", ":"))
        return (
            f'<script type="application/json" id="hisopt-arrays">{store}</script>\n'
            f'<script type="application/octet-stream" id="hisopt-plotly">{packed_plotlyjs()}</script>\n'
            f"<script>{PAGE_SCRIPT}</script>"
        )
